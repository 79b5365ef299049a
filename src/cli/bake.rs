//! `beeswarm bake`: shot → caches.

use crate::bake::{BakeOptions, INTERRUPTED, bake_resumable};
use crate::checkpoint::CheckpointOptions;
use crate::error::{Error, Result};
use crate::export::Format;
use crate::progress::{Mode, Reporter};
use clap::Args;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

#[derive(Args, Debug)]
#[command(
    about = "Bake a shot into animation caches",
    after_help = "Examples:\n  beeswarm bake                                 the built-in demo shot, into ./out/\n  beeswarm bake examples/nest.toml --out caches --format glb,usda,csv\n  beeswarm bake shot.toml --frames 1:48 --seed 7 --preview\n  beeswarm bake shot.toml --progress json       one JSON line per frame (for tools)"
)]
pub struct BakeArgs {
    /// The shot file (TOML). Without it, the built-in demo shot is baked into ./out/.
    pub shot: Option<PathBuf>,
    /// Output folder (default: the shot's [output] dir, relative to the shot file).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Comma-separated formats: glb, gltf, usda, csv (default: the shot's, else glb,usda).
    #[arg(long, value_delimiter = ',', value_parser = super::parse_format)]
    pub format: Vec<Format>,
    /// Override the shot's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Override the frame range, START:END inclusive.
    #[arg(long, value_parser = super::parse_frames, allow_hyphen_values = true)]
    pub frames: Option<(i32, i32)>,
    /// Worker threads (default: all cores). Results are identical for any count.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Progress output.
    #[arg(long, value_enum, default_value_t = Mode::Auto)]
    pub progress: Mode,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
    /// Also write <shot name>.preview.png, a plot of the trajectories.
    #[arg(long)]
    pub preview: bool,
    /// Write the simulation state every N frames (to <out>/<name>.checkpoint/), so a
    /// bake killed part-way can continue with --resume (0: no checkpoints).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub checkpoint_every: u32,
    /// Continue from the checkpoint in the output folder, if one fits this shot; the
    /// caches are byte-identical to an uninterrupted bake's. Without one, bake afresh.
    #[arg(long)]
    pub resume: bool,
    /// Bake a shot over the limits (memory above what is available, disk above what is
    /// free, more than 10⁹ neighbour pairs at spawn), which is refused otherwise.
    #[arg(long)]
    pub allow_large: bool,
}

/// A shot with the command line's overrides applied, and where and what it bakes: what
/// `bake` runs and `check` reports.
pub struct Plan {
    pub shot: crate::shot::Shot,
    pub out_dir: PathBuf,
    pub formats: Vec<Format>,
    pub preview: bool,
}

impl BakeArgs {
    /// The plan these options make of `shot`, refused (exit 2) where a bake could not
    /// start (too many threads, an output folder that cannot be made) or, without
    /// `--allow-large`, is over a limit (`resources::over_limit`).
    pub fn plan(&self, mut shot: crate::shot::Shot) -> Result<Plan> {
        if let Some(seed) = self.seed {
            shot.seed = seed;
        }
        if let Some((s, e)) = self.frames {
            shot.frame_start = s;
            shot.frame_end = e;
        }
        crate::bake::check_threads(self.threads)?;
        let out_dir = self.out.clone().unwrap_or_else(|| shot.output.dir.clone());
        check_out_dir(&out_dir, self.out.is_some())?;
        let formats = if self.format.is_empty() {
            shot.output.formats.clone()
        } else {
            // `--format csv,CSV` names one writer, not two writing the same file.
            let mut unique: Vec<Format> = Vec::new();
            for f in &self.format {
                if !unique.contains(f) {
                    unique.push(*f);
                }
            }
            unique
        };
        let preview = self.preview || shot.output.preview;
        let plan = Plan {
            shot,
            out_dir,
            formats,
            preview,
        };
        super::resources::refuse_over_limits(&plan, self.shot.as_deref(), self.allow_large)?;
        Ok(plan)
    }
}

pub fn run(a: BakeArgs) -> Result<()> {
    let shot = match &a.shot {
        Some(p) => crate::shot::load(p)?,
        None => crate::shot::embedded_default(),
    };
    let plan = a.plan(shot)?;
    super::resources::reserve_memory(&plan, a.shot.as_deref())?;
    let Plan {
        shot,
        out_dir,
        formats,
        preview,
    } = plan;
    let opts = BakeOptions {
        out_dir: &out_dir,
        formats: &formats,
        preview,
        threads: a.threads,
    };

    if !a.quiet
        && let Some(problem) =
            crate::cache_set::read(&out_dir, &shot.name).problem(&out_dir, &shot.name)
    {
        eprintln!("note: {problem}");
    }
    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::Relaxed));
    let mut reporter = Reporter::new(a.progress, shot.frame_count(), a.quiet);
    let started = std::time::Instant::now();
    let checkpoints = (a.checkpoint_every > 0 || a.resume).then_some(CheckpointOptions {
        every: a.checkpoint_every,
        resume: a.resume,
        quiet: a.quiet,
    });
    let result = bake_resumable(&shot, &opts, checkpoints.as_ref(), &mut |p| {
        reporter.update(p)
    });
    match result {
        Ok(outputs) => {
            reporter.finish(&outputs);
            if !a.quiet && reporter.mode() != Mode::Json {
                eprintln!(
                    "baked {} bees × {} frames of \"{}\" in {:.2} s",
                    shot.bee_count(),
                    shot.frame_count(),
                    shot.name,
                    started.elapsed().as_secs_f64()
                );
                for p in &outputs {
                    let size = std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
                    eprintln!("  wrote {} ({:.1} MB)", p.display(), size as f64 / 1e6);
                }
            }
            Ok(())
        }
        Err(e) => {
            reporter.abandon();
            Err(e)
        }
    }
}

/// Refuses an output folder that is, or lies under, a regular file, naming the file (the
/// system's "File exists" / "Not a directory" do not say which one is in the way).
pub(crate) fn check_out_dir(dir: &Path, from_option: bool) -> Result<()> {
    let source = if from_option {
        "--out"
    } else {
        "the shot's [output] dir"
    };
    let blocker = dir
        .ancestors()
        .filter(|p| !p.as_os_str().is_empty())
        .find(|p| p.exists())
        .filter(|p| !p.is_dir());
    match blocker {
        Some(file) if file == dir => Err(Error::input(format!(
            "the output folder {} ({source}) is a file, not a folder",
            dir.display()
        ))),
        Some(file) => Err(Error::input(format!(
            "cannot create the output folder {} ({source}): {} is a file, not a folder",
            dir.display(),
            file.display()
        ))),
        None => writable_ancestor(dir, source),
    }
}

/// The nearest existing folder above `dir` must let us create folders and files in it
/// (a bake creates the rest of the path). Tested by creating and removing an empty probe
/// folder there, which `check` may do without leaving a trace.
fn writable_ancestor(dir: &Path, source: &str) -> Result<()> {
    let Some(existing) = dir
        .ancestors()
        .filter(|p| !p.as_os_str().is_empty())
        .find(|p| p.is_dir())
    else {
        return Ok(()); // relative to the working folder, which exists
    };
    if existing == dir {
        return crate::atomic::probe_writable(dir).map_err(|e| {
            Error::input(format!(
                "the output folder {} ({source}) is not writable: {e}",
                dir.display()
            ))
        });
    }
    let probe = existing.join(format!(".beeswarm-{}-probe.tmp", std::process::id()));
    match std::fs::create_dir(&probe) {
        Ok(()) => {
            let _ = std::fs::remove_dir(&probe);
            Ok(())
        }
        Err(e) => Err(Error::input(format!(
            "cannot create the output folder {} ({source}) in {}: {e}",
            dir.display(),
            existing.display()
        ))),
    }
}
