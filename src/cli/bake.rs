//! `beeswarm bake`: shot → caches.

use super::progress::{Mode, Reporter};
use crate::bake::{BakeOptions, INTERRUPTED, bake};
use crate::error::Result;
use crate::export::Format;
use clap::Args;
use std::path::PathBuf;
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
    #[arg(long, value_parser = super::parse_formats)]
    pub format: Option<Vec<Format>>,
    /// Override the shot's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Override the frame range, START:END inclusive.
    #[arg(long, value_parser = super::parse_frames)]
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
}

pub fn run(a: BakeArgs) -> Result<()> {
    let mut shot = match &a.shot {
        Some(p) => crate::shot::load(p)?,
        None => crate::shot::embedded_default(),
    };
    if let Some(seed) = a.seed {
        shot.seed = seed;
    }
    if let Some((s, e)) = a.frames {
        shot.frame_start = s;
        shot.frame_end = e;
    }
    let out_dir = a.out.clone().unwrap_or_else(|| shot.output.dir.clone());
    let formats = a
        .format
        .clone()
        .unwrap_or_else(|| shot.output.formats.clone());
    let opts = BakeOptions {
        out_dir: &out_dir,
        formats: &formats,
        preview: a.preview || shot.output.preview,
        threads: a.threads,
    };

    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::Relaxed));
    let mut reporter = Reporter::new(a.progress, shot.frame_count(), a.quiet);
    let started = std::time::Instant::now();
    let result = bake(&shot, &opts, &mut |p| reporter.update(p));
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
