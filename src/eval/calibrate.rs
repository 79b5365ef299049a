//! `beeswarm calibrate`: fit the bee model's parameters to a recording with the genetic
//! algorithm of paper 000 Sec. VI.
//!
//! Genes are Γ = {κ1, κ2, κ3, L, ε, h} plus the preferred speed, each in [0, 1] and mapped
//! to a documented physical range (`PARAMS`; log-scaled where the range spans decades).
//! An individual is scored by cloning the base shot, giving every swarm its parameters,
//! running the whole shot in memory (once per simulation seed, flights pooled), and
//! comparing the flights with the recording: fitness = mean q over the single-insect
//! metrics (`report::Reference::fitness`). Every individual runs with the same seeds
//! (common random numbers), so two parameter sets are compared on the same noise field
//! and spawn, and differences in fitness come from the parameters rather than from luck.

use super::ga::{self, GaConfig, GaResult, Generation};
use super::histogram::TAIL;
use super::report::{Reference, Settings, measure};
use super::resample::resample;
use super::tracks::{self, Dataset, Track, TrackFormat};
use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use crate::model::{ModelKind, ParamValues};
use crate::plot::{Figure, bold, house_axes, palette, px, text};
use crate::progress::Mode;
use crate::shot::Shot;
use crate::sim::Simulation;
use plotters::prelude::*;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One calibrated parameter: its `BeeParams` field and search range.
#[derive(Clone, Copy, Debug)]
pub struct ParamRange {
    pub key: &'static str,
    pub lo: f64,
    pub hi: f64,
    /// Search uniformly in log space (for ranges over orders of magnitude).
    pub log: bool,
}

impl ParamRange {
    pub fn value(&self, gene: f64) -> f64 {
        let g = gene.clamp(0.0, 1.0);
        if self.log {
            (self.lo.ln() + (self.hi.ln() - self.lo.ln()) * g).exp()
        } else {
            self.lo + (self.hi - self.lo) * g
        }
    }
}

/// The search space: Γ of paper 000, the preferred speed and the obstacle distance d0.
/// Ranges bracket paper 000's Table I (κ1 1–1.5, κ2 2.3–5, κ3 0.9–1.7, L 2.2–2.7 and h 3
/// scene units = 0.11–0.135 m and 0.15 m, ε 1.7–2) by a wide margin either way, and the
/// speed spans hovering to fast cruising of small insects.
pub const PARAMS: [ParamRange; 21] = [
    ParamRange {
        key: "kappa1",
        lo: 0.1,
        hi: 3.0,
        log: false,
    },
    ParamRange {
        key: "kappa2",
        lo: 0.0,
        hi: 6.0,
        log: false,
    },
    ParamRange {
        key: "kappa3",
        lo: 0.1,
        hi: 3.0,
        log: false,
    },
    ParamRange {
        key: "noise_cell",
        lo: 0.01,
        hi: 0.5,
        log: true,
    },
    ParamRange {
        key: "noise_gain",
        lo: 0.05,
        hi: 10.0,
        log: true,
    },
    ParamRange {
        key: "neighbour_radius",
        lo: 0.02,
        hi: 0.3,
        log: true,
    },
    ParamRange {
        key: "speed",
        lo: 0.01,
        hi: 1.5,
        log: true,
    },
    // d0 of Eq. 5–6 is not in the paper's Γ, but in a cage the walls shape much of the
    // flight: at the default 0.12 m a strongly damped insect whose thrust points into a
    // wall gets pinned there (15 % of the samples of a first calibration sat still within
    // 2 mm of a wall), which no recorded flight does.
    ParamRange {
        key: "avoid_distance",
        lo: 0.02,
        hi: 0.5,
        log: true,
    },
    // Not in the default search (see DEFAULT_SEARCH), from here on: the body's heading lag
    // (Sec. V-A) and the preferred speed's wandering, both our additions to the paper.
    ParamRange {
        key: "heading_lag",
        lo: 0.02,
        hi: 2.0,
        log: true,
    },
    ParamRange {
        key: "speed_wander",
        lo: 0.0,
        hi: 1.2,
        log: false,
    },
    ParamRange {
        key: "speed_wander_time",
        lo: 0.1,
        hi: 10.0,
        log: true,
    },
    // Optic-flow speed control (docs/model.md): the speed at a surface as a fraction of
    // `speed`, and the distance over which it recovers.
    ParamRange {
        key: "surface_speed",
        lo: 0.1,
        hi: 1.0,
        log: false,
    },
    ParamRange {
        key: "surface_speed_distance",
        lo: 0.01,
        hi: 1.0,
        log: true,
    },
    // How strongly the shot's targets pull (a landing surface, a nest): the scale of the
    // shot's own `strength`, from a tenth to three times it.
    ParamRange {
        key: "attraction",
        lo: 0.1,
        hi: 3.0,
        log: true,
    },
    // The zonal model (paper 002): the seven parameters the paper estimates from its
    // recordings (γ, scale, gain, χ_rep, r_rep, χ_att, r_att), around its Table 1 values
    // in SI (docs/model.md, "Paper 002: units") by a wide margin either way.
    ParamRange {
        key: "gamma",
        lo: 1.0,
        hi: 1000.0,
        log: true,
    },
    ParamRange {
        key: "scale",
        lo: 0.005,
        hi: 1.0,
        log: true,
    },
    ParamRange {
        key: "gain",
        lo: 1e-4,
        hi: 1.0,
        log: true,
    },
    ParamRange {
        key: "chi_rep",
        lo: 0.01,
        hi: 10.0,
        log: true,
    },
    ParamRange {
        key: "r_rep",
        lo: 0.002,
        hi: 0.2,
        log: true,
    },
    ParamRange {
        key: "chi_att",
        lo: 0.01,
        hi: 10.0,
        log: true,
    },
    ParamRange {
        key: "r_att_star",
        lo: 0.01,
        hi: 1.0,
        log: true,
    },
];

/// How many of `PARAMS`, from the start, a calibration searches by default: Γ, the speed
/// and d0. The heading lag, the preferred speed's wandering, the surface speed and the
/// targets' pull are searched only when `--only` names them (docs/validation.md records
/// what each did to the fit of the mosquito recording).
pub const DEFAULT_SEARCH: usize = 8;

/// The calibrated subset of `PARAMS` (the default search unless `--only` names some).
pub fn select(only: &[String]) -> Result<Vec<ParamRange>> {
    if only.is_empty() {
        return Ok(PARAMS[..DEFAULT_SEARCH].to_vec());
    }
    let mut out = Vec::new();
    for k in only {
        let r = PARAMS.iter().find(|r| r.key == k.trim()).ok_or_else(|| {
            Error::input(format!(
                "--only: unknown parameter \"{k}\"; expected some of {}",
                PARAMS.iter().map(|r| r.key).collect::<Vec<_>>().join(", ")
            ))
        })?;
        if !out.iter().any(|o: &ParamRange| o.key == r.key) {
            out.push(*r);
        }
    }
    Ok(out)
}

/// Applies genes (one per entry of `space`) to parameters. A key the model does not have
/// is left alone (`check_space` refuses such a search up front).
pub fn apply(space: &[ParamRange], genes: &[f64], p: &mut ParamValues) {
    for (r, &g) in space.iter().zip(genes) {
        p.set(r.key, r.value(g));
    }
}

/// Every searched parameter must be one of the calibrated swarm's model.
fn check_space(space: &[ParamRange], shot: &Shot) -> Result<()> {
    for s in &shot.swarms {
        if let Some(r) = space.iter().find(|r| s.params.get(r.key).is_none()) {
            return Err(Error::input(format!(
                "swarm \"{}\" flies the {} model, which has no parameter \"{}\"; pick the \
                 searched parameters with --only (its parameters: {})",
                s.name,
                s.model.name(),
                r.key,
                s.params
                    .iter()
                    .map(|(p, _)| p.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
    }
    Ok(())
}

/// Runs a shot in memory and returns every bee's track (time = seconds since the first
/// frame, as in the tracks CSV).
pub fn simulate(shot: &Shot) -> Dataset {
    let mut sim = Simulation::new(shot);
    let n = shot.bee_count();
    let frames = shot.frame_count();
    let mut tracks: Vec<Track> = (0..n)
        .map(|_| Track {
            time: Vec::with_capacity(frames),
            position: Vec::with_capacity(frames),
            velocity: Vec::with_capacity(frames),
            ..Default::default()
        })
        .collect();
    for k in 0..frames {
        if k > 0 {
            sim.advance();
        }
        let t = k as f64 / shot.fps;
        let mut b = 0;
        for s in sim.record() {
            for i in 0..s.len() {
                let tr = &mut tracks[b];
                if tr.id.is_empty() {
                    tr.id = s.ids[i].to_string();
                }
                tr.time.push(t);
                tr.position.push(s.position[i].as_dvec3());
                tr.velocity.push(s.velocity[i].as_dvec3());
                b += 1;
            }
        }
    }
    Dataset {
        name: shot.name.clone(),
        format: TrackFormat::Memory,
        tracks,
    }
}

/// The shot with parameters from `genes` on every swarm. (The baselines read only
/// `speed`; calibrating them with `--only speed` gives them the same chance to fit.)
pub fn shot_with(base: &Shot, space: &[ParamRange], genes: &[f64]) -> Shot {
    let mut shot = base.clone();
    for s in &mut shot.swarms {
        apply(space, genes, &mut s.params);
    }
    shot
}

/// Fitness of one parameter set against the reference: the flights of `seeds` runs of
/// the shot (seeds `shot.seed`, `shot.seed + 1`, ...) pooled into one sample.
pub fn fitness(
    base: &Shot,
    space: &[ParamRange],
    reference: &Reference,
    settings: &Settings,
    seeds: u64,
    genes: &[f64],
) -> f64 {
    let shot = shot_with(base, space, genes);
    let mut ds = simulate(&shot);
    for k in 1..seeds {
        let mut other = shot.clone();
        other.seed = shot.seed.wrapping_add(k);
        ds.tracks.extend(simulate(&other).tracks);
    }
    // Only single-insect metrics enter the fitness: skip the O(n²) neighbour pass.
    let uni = resample(&ds, settings.dt);
    let samples = super::metrics::compute(&uni, &settings.metric_options(false));
    reference.fitness(&samples)
}

/// Fit the bee model's parameters to a recording with a genetic algorithm.
///
/// Searches κ1, κ2, κ3, the noise cell L, the noise gain ε, the neighbourhood radius h,
/// the preferred speed and the obstacle distance d0 (ranges in docs/validation.md) to
/// maximise the fitness q: the mean over speed, acceleration, angular velocity, angular
/// acceleration and jerk of 1 − ΔE/2, ΔE the L1 distance between simulated and real
/// distributions. Writes the
/// best parameters as a preset file shots can load (`preset = "PRESET.toml"`) and a
/// PNG of fitness over generations.
#[derive(clap::Args, Clone, Debug)]
pub struct CalibrateArgs {
    /// The recording to fit (splined tracks or a beeswarm tracks CSV).
    #[arg(long, value_name = "REAL")]
    pub reference: PathBuf,
    /// The shot to simulate; every swarm gets the parameters.
    #[arg(long, value_name = "BASE.toml")]
    pub shot: PathBuf,
    /// Where to write the preset.
    #[arg(long, value_name = "PRESET.toml")]
    pub out: PathBuf,
    /// Generations to run.
    #[arg(long, value_name = "N", default_value_t = 200)]
    pub generations: usize,
    /// Individuals per generation.
    #[arg(long, value_name = "N", default_value_t = 10)]
    pub population: usize,
    /// Seed of the genetic algorithm (the simulations use the shot's seed).
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub seed: u64,
    /// Worker threads for evaluating individuals (0 = one per core).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub threads: usize,
    /// Progress: a line per generation on stderr (auto, bar), JSON lines on stdout, or none.
    #[arg(long, value_enum, default_value_t = Mode::Auto)]
    pub progress: Mode,
    /// Fitness figure [default: the preset path with .fitness.png].
    #[arg(long, value_name = "FIG.png")]
    pub figure: Option<PathBuf>,
    /// Bins per metric.
    #[arg(long, value_name = "K", default_value_t = 40)]
    pub bins: usize,
    /// Preset name [default: the file stem of --out].
    #[arg(long)]
    pub name: Option<String>,
    /// Runs of the shot per individual, with seeds shot.seed, shot.seed + 1, ...: their
    /// flights are pooled, so a parameter set is judged on more than one draw of spawn
    /// and noise and the fit does not chase the luck of a single seed.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seeds: u64,
    /// Calibrate only these parameters (comma-separated), keeping the shot's values for
    /// the rest; e.g. `--only speed` for the Brownian and boids baselines. Default: κ1, κ2,
    /// κ3, noise_cell, noise_gain, neighbour_radius, speed, avoid_distance; heading_lag,
    /// speed_wander, speed_wander_time, surface_speed, surface_speed_distance and
    /// attraction are searched only when named here.
    #[arg(long, value_delimiter = ',', value_name = "PARAM,...")]
    pub only: Vec<String>,
}

/// The exact command line, quoted where needed, for provenance.
fn command_line() -> String {
    std::env::args()
        .enumerate()
        // The program as a person types it, not the path it was started by here.
        .map(|(i, a)| if i == 0 { "beeswarm".to_owned() } else { a })
        .map(|a| {
            if !a.is_empty()
                && a.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+".contains(c))
            {
                a
            } else {
                format!("'{}'", a.replace('\'', "'\\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

pub fn run_calibrate(args: &CalibrateArgs) -> Result<()> {
    use super::cli::{check_bins, check_range};
    check_range(
        "--population",
        args.population as f64,
        2.0,
        10_000.0,
        "a population from 2 to 10000",
    )?;
    check_range(
        "--generations",
        args.generations as f64,
        1.0,
        100_000.0,
        "from 1 to 100000 generations",
    )?;
    check_bins(args.bins)?;
    check_range(
        "--seeds",
        args.seeds as f64,
        1.0,
        1000.0,
        "from 1 to 1000 simulation seeds",
    )?;
    crate::bake::check_threads(args.threads)?;
    // Every output is checked before the generations run, not after.
    crate::atomic::check_writable(&args.out, "--out")?;
    let figure = args
        .figure
        .clone()
        .unwrap_or_else(|| args.out.with_extension("fitness.png"));
    crate::atomic::check_writable(&figure, "--figure")?;
    crate::atomic::check_writable(&history_path(&figure), "--figure's history (.csv)")?;
    let shot = crate::shot::load(&args.shot)?;
    if shot.swarms.is_empty() {
        return Err(Error::input(format!(
            "{}: the shot has no swarm to calibrate",
            args.shot.display()
        )));
    }
    let space = select(&args.only)?;
    check_space(&space, &shot)?;
    let real = tracks::read(&args.reference)?;
    let dt = super::cli::default_dt(&[real.median_step(), 1.0 / shot.fps])
        .ok_or_else(|| Error::input("the reference has no track with two samples"))?;
    let settings = Settings {
        dt,
        bins: args.bins,
        density_radius: 0.15,
        min_speed: 1e-3,
        tail: TAIL,
    };
    let reference = Reference::new(measure(&real, &settings, false), settings.bins);
    reference.check_usable(&args.reference.display().to_string())?;
    let cfg = GaConfig {
        population: args.population,
        generations: args.generations,
        seed: args.seed,
        ..GaConfig::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(crate::bake::check_threads(args.threads)?)
        .build()
        .map_err(|e| Error::bake(format!("cannot start worker threads: {e}")))?;
    let mode = match args.progress {
        Mode::Auto if !std::io::stderr().is_terminal() => Mode::None,
        m => m,
    };
    eprintln!(
        "calibrating {} of {} ({} swarm(s), model {}) on {} ({} tracks): {} generations × {} individuals",
        space.iter().map(|r| r.key).collect::<Vec<_>>().join(", "),
        shot.name,
        shot.swarms.len(),
        shot.swarms[0].model.name(),
        real.name,
        real.tracks.len(),
        cfg.generations,
        cfg.population
    );
    let start = Instant::now();
    let result: GaResult = pool.install(|| {
        ga::run(
            space.len(),
            &cfg,
            |g| fitness(&shot, &space, &reference, &settings, args.seeds, g),
            |g| {
                let el = start.elapsed().as_secs_f64();
                match mode {
                    Mode::Json => {
                        crate::progress::stdout(&format!(
                            "{{\"event\":\"generation\",\"generation\":{},\"total\":{},\"best\":{:.6},\"mean\":{:.6},\"elapsed_s\":{el:.3}}}\n",
                            g.index + 1,
                            cfg.generations,
                            g.best,
                            g.mean
                        ));
                    }
                    Mode::None => {}
                    _ => eprintln!(
                        "generation {:>3}/{}: best q {:.4}, mean q {:.4} ({el:.1} s)",
                        g.index + 1,
                        cfg.generations,
                        g.best,
                        g.mean
                    ),
                }
            },
        )
    });
    let seconds = start.elapsed().as_secs_f64();

    let mut params = shot.swarms[0].params.clone();
    apply(&space, &result.best_genes, &mut params);
    let name = args.name.clone().unwrap_or_else(|| {
        args.out
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "calibrated".to_owned())
    });
    let base = base_preset(shot.swarms[0].model, &shot.swarms[0].preset, &args.shot);
    let provenance = format!(
        "{}\n{} generations x {} individuals (crossover {}, mutation {}, elitism {}), GA seed {}, \
         {} simulation seed(s) from {}, \
         {} evaluations in {:.0} s; best fitness q = {:.4} (mean over speed, acceleration, \
         angular velocity, angular acceleration and jerk of 1 - dE/2, {} shared bins, dt {} s) \
         against {} ({} tracks); beeswarm {}",
        command_line(),
        cfg.generations,
        cfg.population,
        cfg.crossover,
        cfg.mutation,
        cfg.elitism,
        cfg.seed,
        args.seeds,
        shot.seed,
        result.evaluations,
        seconds,
        result.best_fitness,
        settings.bins,
        settings.dt,
        real.name,
        real.tracks.len(),
        env!("CARGO_PKG_VERSION"),
    );
    let text = preset_toml(&name, &base, &shot, &space, &params, &provenance);
    let mut f = AtomicFile::create(&args.out)?;
    f.write_all(text.as_bytes())
        .map_err(|e| Error::io(&args.out, e))?;
    f.commit()?;
    let fig = args
        .figure
        .clone()
        .unwrap_or_else(|| args.out.with_extension("fitness.png"));
    fitness_figure(&result, &name)?.save_png(&fig)?;
    let history = history_path(&fig);
    let mut f = AtomicFile::create(&history)?;
    f.write_all(history_csv(&result).as_bytes())
        .map_err(|e| Error::io(&history, e))?;
    f.commit()?;
    eprintln!(
        "best fitness q = {:.4} after {} generations ({seconds:.1} s)\nwrote {}\nwrote {}",
        result.best_fitness,
        cfg.generations,
        args.out.display(),
        fig.display()
    );
    Ok(())
}

/// The built-in preset a calibrated preset is based on: the swarm's own, or the base of
/// the preset file it loaded.
fn base_preset(model: ModelKind, preset: &str, shot_path: &Path) -> String {
    if ParamValues::preset(model, preset).is_some() {
        return preset.to_owned();
    }
    let path = shot_path.parent().unwrap_or(Path::new(".")).join(preset);
    std::fs::read_to_string(path)
        .ok()
        .and_then(|s| toml::from_str::<crate::shot::schema::RawPresetFile>(&s).ok())
        .and_then(|p| p.preset.base)
        .filter(|b| ParamValues::preset(model, b).is_some())
        .unwrap_or_else(|| model.default_preset().to_owned())
}

/// The preset file: header with provenance, then every parameter (not only the calibrated
/// ones) so the file alone fixes the model whatever its base preset becomes.
pub fn preset_toml(
    name: &str,
    base: &str,
    shot: &Shot,
    space: &[ParamRange],
    p: &ParamValues,
    provenance: &str,
) -> String {
    let q = |s: &str| toml::Value::String(s.to_owned()).to_string();
    let model = shot.swarms[0].model.name();
    let mut s = String::new();
    s += "# Written by `beeswarm calibrate`; load it with `preset = \"<this file>\"` in a swarm.\n";
    s += "[preset]\n";
    s += &format!("name = {}\n", q(name));
    s += &format!("model = {}\n", q(model));
    s += &format!("base = {}\n", q(base));
    s += &format!(
        "description = {}\n",
        q(&format!(
            "{model} model calibrated with a genetic algorithm (paper 000 Sec. VI) on shot \"{}\"",
            shot.name
        ))
    );
    s += &format!("provenance = {}\n\n", q(provenance));
    s += "[params]\n";
    let calibrated = |k: &str| space.iter().any(|r| r.key == k);
    for (spec, v) in p.iter() {
        // Six significant digits: plenty for a fitted value, and readable.
        let v: f64 = format!("{v:.6e}").parse().unwrap_or(v);
        let note = if calibrated(spec.name) {
            "  # calibrated"
        } else {
            ""
        };
        s += &format!("{} = {}{note}\n", spec.name, toml::Value::Float(v));
    }
    s
}

/// Where `calibrate` keeps the fitness history of a figure: beside it, `.csv` for `.png`.
pub fn history_path(figure: &Path) -> PathBuf {
    figure.with_extension("csv")
}

/// The header of a fitness history CSV.
pub const HISTORY_HEADER: &str = "generation,best,mean";

/// Best and mean fitness per generation (1-based) as CSV, every value written in the
/// shortest form that reads back to the same `f64`, so a figure drawn again from it is
/// the figure `calibrate` drew.
pub fn history_csv(r: &GaResult) -> String {
    let mut s = format!("{HISTORY_HEADER}\n");
    for g in &r.history {
        s += &format!("{},{},{}\n", g.index + 1, g.best, g.mean);
    }
    s
}

/// Reads a fitness history written by [`history_csv`]; `file` names it in errors, which
/// give the line and what was expected.
pub fn parse_history(text: &str, file: &Path) -> Result<GaResult> {
    let bad =
        |line: usize, what: String| Error::input(format!("{}:{line}: {what}", file.display()));
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim() == HISTORY_HEADER => {}
        other => {
            return Err(bad(
                1,
                format!(
                    "expected the header `{HISTORY_HEADER}` of a fitness history, found `{}`",
                    other.map(|(_, l)| l).unwrap_or("")
                ),
            ));
        }
    }
    let mut history = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let n = i + 1;
        let cols: Vec<&str> = line.split(',').map(str::trim).collect();
        if cols.len() != 3 {
            return Err(bad(
                n,
                format!(
                    "expected 3 values `generation,best,mean`, found {}",
                    cols.len()
                ),
            ));
        }
        let generation: usize = cols[0].parse().map_err(|_| {
            bad(
                n,
                format!("generation: expected a whole number, found `{}`", cols[0]),
            )
        })?;
        if generation != history.len() + 1 {
            return Err(bad(
                n,
                format!(
                    "generation: expected {}, found {generation}",
                    history.len() + 1
                ),
            ));
        }
        let value = |k: usize, key: &str| -> Result<f64> {
            match cols[k].parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(bad(
                    n,
                    format!("{key}: expected a finite fitness, found `{}`", cols[k]),
                )),
            }
        };
        history.push(Generation {
            index: generation - 1,
            best: value(1, "best")?,
            mean: value(2, "mean")?,
            best_genes: Vec::new(),
        });
    }
    if history.is_empty() {
        return Err(bad(2, "expected at least one generation".to_owned()));
    }
    let best_fitness = history.iter().map(|g| g.best).fold(0.0f64, f64::max);
    Ok(GaResult {
        best_genes: Vec::new(),
        best_fitness,
        history,
        evaluations: 0,
    })
}

/// Draws a calibration's fitness figure again from the history `calibrate` wrote beside
/// it, without calibrating: e.g. after the charts changed.
#[derive(clap::Args, Clone, Debug)]
pub struct FitnessFigureArgs {
    /// The fitness history (`<figure>.csv`, written by `calibrate` beside its figure).
    #[arg(value_name = "HISTORY.csv")]
    pub history: PathBuf,
    /// The figure to write [default: the history's path with .png].
    #[arg(long, value_name = "FIG.png")]
    pub figure: Option<PathBuf>,
    /// The preset name in the caption [default: the history's file stem without
    /// `_fitness` or `.fitness`].
    #[arg(long)]
    pub name: Option<String>,
}

pub fn run_fitness_figure(args: &FitnessFigureArgs) -> Result<()> {
    let figure = args
        .figure
        .clone()
        .unwrap_or_else(|| args.history.with_extension("png"));
    crate::atomic::check_writable(&figure, "--figure")?;
    let bytes = crate::shot::read_bounded(&args.history)
        .map_err(|e| Error::input(format!("cannot read {}: {e}", args.history.display())))?;
    let text = String::from_utf8(bytes)
        .map_err(|_| Error::input(format!("{}: not UTF-8 text", args.history.display())))?;
    let result = parse_history(&text, &args.history)?;
    let name = args.name.clone().unwrap_or_else(|| {
        let stem = args
            .history
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        stem.trim_end_matches("_fitness")
            .trim_end_matches(".fitness")
            .to_owned()
    });
    fitness_figure(&result, &name)?.save_png(&figure)?;
    eprintln!("wrote {}", figure.display());
    Ok(())
}

/// Best and mean fitness per generation (like Fig. 10 of paper 000).
pub fn fitness_figure(r: &GaResult, name: &str) -> Result<Figure> {
    let n = r.history.len();
    let lo = r
        .history
        .iter()
        .map(|g| g.mean.min(g.best))
        .fold(1.0f64, f64::min);
    let hi = r.history.iter().map(|g| g.best).fold(0.0f64, f64::max);
    let pad = ((hi - lo) * 0.08).max(0.005);
    let (y0, y1) = ((lo - pad).max(0.0), (hi + pad).min(1.0));
    let series = |f: fn(&Generation) -> f64| -> Vec<(f64, f64)> {
        r.history
            .iter()
            .map(|g| ((g.index + 1) as f64, f(g)))
            .collect()
    };
    let caption = format!(
        "Calibration of {name}: fitness q over generations (best {:.4})",
        r.best_fitness
    );
    Figure::draw(760, 440, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(&caption, bold(17.0, palette::TEXT))
            .margin(px(16.0))
            .x_label_area_size(px(46.0))
            .y_label_area_size(px(64.0))
            .build_cartesian_2d(1.0..n.max(2) as f64, y0..y1)?;
        house_axes(&mut chart.configure_mesh(), 13.0)
            .x_desc("generation")
            .y_desc("fitness q")
            // Generations are whole numbers: no more labels than generations.
            .x_labels(n.clamp(2, 10))
            .draw()?;
        for (label, color, values) in [
            ("mean of generation", palette::series(1), series(|g| g.mean)),
            ("best of generation", palette::series(0), series(|g| g.best)),
        ] {
            let style = color.stroke_width(px(2.0) as u32);
            chart
                .draw_series([PathElement::new(values, style)])?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + px(22.0), y)], style));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .label_font(text(13.0, palette::TEXT))
            .legend_area_size(px(30.0))
            .background_style(palette::WHITE.mix(0.9))
            .border_style(palette::LIGHT_GREY.stroke_width(px(1.0) as u32))
            .margin(px(10.0))
            .draw()
    })
}
