//! `beeswarm eval`: compare simulated tracks with a recording.

use super::figure;
use super::histogram::TAIL;
use super::report::{Measured, Reference, Report, Settings, compare, measure};
use super::tracks;
use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Compare simulated tracks with recorded insect flights.
///
/// Reads tracks CSV files written by `beeswarm bake` (format `csv`) and a recording
/// (beeswarm tracks CSV or `object;time;XSplined;...` splined tracks, detected from the
/// header), resamples everything to one time step, computes speed, acceleration, angular
/// velocity and acceleration, jerk and the neighbour metrics, and reports per metric the
/// L1 distance between the distributions on shared bins, paper 000's fitness q and paper
/// 002's entropy-weighted score. See docs/validation.md.
#[derive(clap::Args, Clone, Debug)]
pub struct EvalArgs {
    /// Simulated tracks to evaluate (`NAME=PATH` sets the name shown in reports;
    /// `NAME=A.csv,B.csv` pools several runs, e.g. seeds, into one candidate).
    pub tracks: String,
    /// The recording to compare with.
    #[arg(long, value_name = "REAL")]
    pub reference: PathBuf,
    /// Compare with part I of N of the recording only: its ids (recorded segments)
    /// numbered 0, 1, … in order of first appearance, those equal to I mod N kept — the
    /// flights held out from a model built on another part (`beeswarm fastswarm-db
    /// --part`).
    #[arg(long, value_name = "I/N")]
    pub reference_part: Option<tracks::Part>,
    /// More simulated tracks compared in the same report and figure (repeatable,
    /// `NAME=PATH` and `NAME=A.csv,B.csv` allowed), e.g. baseline models.
    #[arg(long = "candidate", value_name = "TRACKS")]
    pub candidates: Vec<String>,
    /// Write the report as JSON here.
    #[arg(long, value_name = "REPORT.json")]
    pub out: Option<PathBuf>,
    /// Write a PNG with the distributions overlaid here.
    #[arg(long, value_name = "FIG.png")]
    pub figure: Option<PathBuf>,
    /// Write the table of distances and scores as Markdown here (for docs).
    #[arg(long, value_name = "TABLE.md")]
    pub markdown: Option<PathBuf>,
    /// Common time step in seconds [default: the coarsest native step of the inputs,
    /// so no data set is upsampled].
    #[arg(long, value_name = "S")]
    pub dt: Option<f64>,
    /// Number of shared bins per metric.
    #[arg(long, value_name = "K", default_value_t = 40)]
    pub bins: usize,
    /// Neighbourhood radius h of the density metric (Eq. 10), metres.
    #[arg(long, value_name = "M", default_value_t = 0.15)]
    pub density_radius: f64,
    /// Speed below which a direction, hence angular velocity, is undefined, m/s.
    #[arg(long, value_name = "M/S", default_value_t = 1e-3)]
    pub min_speed: f64,
}

/// Splits `NAME=PATH[,PATH...]`: the runs pooled into one candidate. Without a name, the
/// candidate is named after its first file.
pub fn named_paths(s: &str) -> (String, Vec<PathBuf>) {
    let (name, list) = match s.split_once('=') {
        Some((name, list)) if !name.is_empty() && !name.contains(['/', '\\']) => {
            (Some(name.to_owned()), list)
        }
        _ => (None, s),
    };
    let paths: Vec<PathBuf> = list.split(',').map(PathBuf::from).collect();
    let name = name.unwrap_or_else(|| file_stem_name(&paths[0], list));
    (name, paths)
}

/// A tracks file's name without `.tracks.csv` (or `fallback` if it has none).
fn file_stem_name(p: &Path, fallback: &str) -> String {
    p.file_name()
        .map(|n| {
            n.to_string_lossy()
                .trim_end_matches(".csv")
                .trim_end_matches(".tracks")
                .to_owned()
        })
        .unwrap_or_else(|| fallback.to_owned())
}

/// Chooses the common step: the coarsest native step (rounded to microseconds, so 50 Hz
/// data stored with rounding noise still gives exactly 0.02).
pub fn default_dt(steps: &[f64]) -> Option<f64> {
    let dt = steps
        .iter()
        .copied()
        .filter(|s| *s > 0.0)
        .fold(0.0, f64::max);
    (dt > 0.0).then(|| (dt * 1e6).round() / 1e6)
}

/// A numeric option within its range, or an input error naming it. Every size the
/// evaluation allocates follows from these (samples per track = duration / dt, one
/// histogram of `bins` per metric), so none may be unbounded.
pub(crate) fn check_range(option: &str, v: f64, lo: f64, hi: f64, what: &str) -> Result<f64> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(Error::input(format!(
            "{option}: expected {what}, found {v}"
        )))
    }
}

/// The histogram bins: 1 to 10,000.
pub(crate) fn check_bins(bins: usize) -> Result<usize> {
    check_range(
        "--bins",
        bins as f64,
        1.0,
        10_000.0,
        "a whole number of bins from 1 to 10000",
    )?;
    Ok(bins)
}

pub fn run_eval(args: &EvalArgs) -> Result<()> {
    check_bins(args.bins)?;
    if let Some(dt) = args.dt {
        check_range(
            "--dt",
            dt,
            1e-4,
            10.0,
            "a resampling step from 0.0001 to 10 seconds",
        )?;
    }
    check_range(
        "--density-radius",
        args.density_radius,
        1e-4,
        100.0,
        "a radius from 0.0001 to 100 m",
    )?;
    check_range(
        "--min-speed",
        args.min_speed,
        0.0,
        100.0,
        "a speed from 0 to 100 m/s",
    )?;
    for (path, option) in [
        (&args.out, "--out"),
        (&args.figure, "--figure"),
        (&args.markdown, "--markdown"),
    ] {
        if let Some(p) = path {
            crate::atomic::check_writable(p, option)?;
        }
    }
    for s in std::iter::once(&args.tracks).chain(&args.candidates) {
        if named_paths(s).1.iter().any(|p| p.as_os_str().is_empty()) {
            return Err(Error::input(format!(
                "\"{s}\": expected tracks files separated by commas, found an empty one"
            )));
        }
    }
    let mut reference = tracks::read(&args.reference)?;
    if let Some(p) = args.reference_part {
        reference = reference.part(p);
    }
    // Per candidate, its runs: measured one by one (neighbours only within a run), pooled.
    let mut sims: Vec<(String, Vec<tracks::Dataset>)> = Vec::new();
    for s in std::iter::once(&args.tracks).chain(&args.candidates) {
        let (name, paths) = named_paths(s);
        let mut runs = Vec::new();
        for path in &paths {
            let mut ds = tracks::read(path)?;
            ds.name = name.clone();
            runs.push(ds);
        }
        sims.push((name, runs));
    }
    let runs = || sims.iter().flat_map(|(_, r)| r);
    let steps: Vec<f64> = std::iter::once(&reference)
        .chain(runs())
        .map(|d| d.median_step())
        .collect();
    let dt = match args.dt.or_else(|| default_dt(&steps)) {
        Some(dt) => dt,
        None => {
            return Err(Error::input(
                "no track has two samples: cannot choose a time step",
            ));
        }
    };
    for d in std::iter::once(&reference).chain(runs()) {
        let s = d.median_step();
        if s > dt * 1.01 {
            eprintln!(
                "warning: {} is sampled every {s} s, coarser than --dt {dt} s: its values are interpolated",
                d.name
            );
        }
    }
    let settings = Settings {
        dt,
        bins: args.bins,
        density_radius: args.density_radius,
        min_speed: args.min_speed,
        tail: TAIL,
    };
    let measured: Vec<Measured> = sims
        .iter()
        .map(|(name, runs)| {
            let parts = runs.iter().map(|d| measure(d, &settings, true)).collect();
            Measured::pool(name, parts)
        })
        .collect();
    let reference = Reference::new(measure(&reference, &settings, true), settings.bins);
    reference.check_usable(&args.reference.display().to_string())?;
    let report = compare(settings, &reference, &measured);

    print_table(&report);
    if let Some(path) = &args.out {
        write_json(&report, path)?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(path) = &args.figure {
        figure::draw(&report)?.save_png(path)?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(path) = &args.markdown {
        let mut f = AtomicFile::create(path)?;
        f.write_all(markdown_table(&report).as_bytes())
            .map_err(|e| Error::io(path, e))?;
        f.commit()?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// Writes the report atomically as pretty JSON.
pub fn write_json(report: &Report, path: &Path) -> Result<PathBuf> {
    let text = serde_json::to_string_pretty(report)
        .map_err(|e| Error::bake(format!("cannot serialise the report: {e}")))?;
    let mut f = AtomicFile::create(path)?;
    f.write_all(text.as_bytes())
        .map_err(|e| Error::io(path, e))?;
    f.write_all(b"\n").map_err(|e| Error::io(path, e))?;
    f.commit()
}

/// A plain-text table of ΔE per metric and candidate, then the scores.
pub fn print_table(r: &Report) {
    let mut out = String::new();
    out += &format!(
        "reference {}: {} tracks, {:.1} s tracked; dt = {} s, {} bins\n",
        r.reference.name,
        r.reference.tracks,
        r.reference.tracked_seconds,
        r.settings.dt,
        r.settings.bins
    );
    out += &format!("{:<22} {:>12}", "ΔE (Eq. 20, 0..2)", "ref median");
    for c in &r.candidates {
        out += &format!(" {:>14}", truncate(&c.name, 14));
    }
    out.push('\n');
    for m in &r.metrics {
        out += &format!("{:<22} ", m.metric.key());
        if !m.applicable {
            out += &format!("{}\n", m.note.as_deref().unwrap_or("not applicable"));
            continue;
        }
        out += &format!("{:>12.4}", m.reference.median);
        for c in &m.candidates {
            match c.l1 {
                Some(d) => out += &format!(" {d:>14.4}"),
                None => out += &format!(" {:>14}", "n/a"),
            }
        }
        out.push('\n');
    }
    for (label, f) in [
        (
            "fitness q (single)",
            (|s: &super::report::CandidateScore| s.fitness) as fn(&_) -> f64,
        ),
        ("q (all applicable)", |s| s.q_all),
        ("entropy score E", |s| s.entropy_score),
    ] {
        out += &format!("{label:<22} {:>12}", "");
        for s in &r.scores {
            out += &format!(" {:>14.4}", f(s));
        }
        out.push('\n');
    }
    crate::progress::stdout(&out);
}

/// ΔE per metric (lowest in bold) and the scores, as a Markdown table.
pub fn markdown_table(r: &Report) -> String {
    let mut s = String::new();
    s += &format!(
        "Reference: `{}` ({} tracks, {:.0} s tracked). Common step {} s, {} shared bins.\n\n",
        r.reference.name,
        r.reference.tracks,
        r.reference.tracked_seconds,
        r.settings.dt,
        r.settings.bins
    );
    s += "| metric | real median |";
    for c in &r.candidates {
        s += &format!(" ΔE {} |", c.name);
    }
    s += "\n|---|---:|";
    s += &"---:|".repeat(r.candidates.len());
    s.push('\n');
    for m in &r.metrics {
        if !m.applicable {
            s += &format!(
                "| {} | – | {} |\n",
                m.metric.key(),
                m.note.as_deref().unwrap_or("not applicable")
            );
            continue;
        }
        let best = m
            .candidates
            .iter()
            .filter_map(|c| c.l1)
            .fold(f64::INFINITY, f64::min);
        s += &format!(
            "| {} | {:.4} {} |",
            m.metric.key(),
            m.reference.median,
            m.unit
        );
        for c in &m.candidates {
            s += &match c.l1 {
                Some(d) if d == best => format!(" **{d:.4}** |"),
                Some(d) => format!(" {d:.4} |"),
                None => " n/a |".to_owned(),
            };
        }
        s.push('\n');
    }
    for (label, f) in [
        (
            "fitness q (single-insect mean)",
            (|x: &super::report::CandidateScore| x.fitness) as fn(&_) -> f64,
        ),
        ("q over all applicable metrics", |x| x.q_all),
        ("entropy-weighted score E (paper 002)", |x| x.entropy_score),
        ("entropy-weighted q", |x| x.entropy_weighted_q),
    ] {
        s += &format!("| {label} | |");
        for x in &r.scores {
            s += &format!(" {:.4} |", f(x));
        }
        s.push('\n');
    }
    s
}

fn truncate(s: &str, n: usize) -> String {
    s.chars().take(n).collect()
}
