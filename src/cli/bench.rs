//! `beeswarm bench`: simulation throughput for the default preset, as one JSON line.

use crate::bake::with_threads;
use crate::error::{Error, Result};
use crate::shot::{self, Shot};
use crate::sim::Simulation;
use clap::Args;
use std::path::Path;
use std::time::Instant;

#[derive(Args, Debug)]
#[command(
    about = "Measure simulation speed (prints one JSON line)",
    after_help = "Examples:\n  beeswarm bench --bees 10000 --frames 48 --threads 2\n  beeswarm bench --model boids --density 20000\n\nInstructions per bee-step (stable where wall time is not): run under callgrind and\ndivide the total by bee_steps from the JSON line:\n  valgrind --tool=callgrind beeswarm bench --bees 10000 --frames 6 --threads 1"
)]
pub struct BenchArgs {
    /// Number of bees.
    #[arg(long, default_value_t = 10_000)]
    pub bees: usize,
    /// Number of frames to simulate (after the first).
    #[arg(long, default_value_t = 48)]
    pub frames: usize,
    /// Integration substeps per frame.
    #[arg(long, default_value_t = 4)]
    pub substeps: u32,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Model to measure (`beeswarm models` lists them).
    #[arg(long, default_value = "bee")]
    pub model: String,
    /// Preset of that model (default: the model's first).
    #[arg(long)]
    pub preset: Option<String>,
    /// Bees per cubic metre, held by soft bounds on the spawn box.
    #[arg(long, default_value_t = 500.0)]
    pub density: f64,
    /// Add a nest that draws every bee into one cloud (density then grows with the count).
    #[arg(long)]
    pub nest: bool,
}

/// What a benchmark shot holds.
pub struct BenchShot<'a> {
    pub bees: usize,
    pub frames: usize,
    pub substeps: u32,
    pub model: &'a str,
    pub preset: Option<&'a str>,
    /// Bees per cubic metre in the spawn box, which soft bounds hold.
    pub density: f64,
    pub nest: bool,
}

/// A swarm at a constant density (soft bounds on the spawn box), so that the work per bee
/// stays the same as the count grows.
pub fn bench_shot(b: &BenchShot) -> std::result::Result<Shot, crate::error::ShotError> {
    let BenchShot {
        bees,
        frames,
        substeps,
        model,
        nest,
        ..
    } = *b;
    let side = (bees as f64 / b.density).cbrt().max(0.01);
    let preset = b
        .preset
        .map(|p| format!("preset = \"{p}\"\n"))
        .unwrap_or_default();
    // Soft bounds on the spawn box keep the density constant as the count grows; a nest
    // pulls every bee into one ever denser cloud instead.
    let target = if nest {
        format!(
            "\n[[target]]\ntype = \"nest\"\nposition = [0, {}, 0]\n",
            side / 2.0 + 0.5
        )
    } else {
        String::new()
    };
    let src = format!(
        "[scene]\nname = \"bench\"\nfps = 24\nframes = [1, {}]\nsubsteps = {substeps}\nseed = 1\n\n[[swarm]]\ncount = {bees}\nmodel = \"{model}\"\n{preset}spawn = {{ shape = \"box\", center = [0, {c}, 0], size = [{side}, {side}, {side}] }}\nbounds = {{ center = [0, {c}, 0], size = [{side}, {side}, {side}] }}\n{target}",
        frames + 1,
        c = side / 2.0 + 0.5
    );
    shot::parse(&src, Path::new("<bench>"), Path::new("."))
}

pub fn run(a: BenchArgs) -> Result<()> {
    if a.bees == 0 || a.frames == 0 {
        return Err(Error::input("--bees and --frames must be at least 1"));
    }
    if !(a.density.is_finite() && (1e-3..=1e7).contains(&a.density)) {
        return Err(Error::input(format!(
            "--density: expected bees per cubic metre from 0.001 to 1e7, found {}",
            a.density
        )));
    }
    let shot = bench_shot(&BenchShot {
        bees: a.bees,
        frames: a.frames,
        substeps: a.substeps,
        model: &a.model,
        preset: a.preset.as_deref(),
        density: a.density,
        nest: a.nest,
    })
    .map_err(|e| {
        // The shot is generated from the options: name the option, not the hidden text.
        let option = match e.key.as_str() {
            "scene.substeps" => "--substeps",
            "scene.frames" => "--frames",
            k if k.ends_with(".preset") => "--preset",
            k if k.ends_with(".model") => "--model",
            _ => "--bees",
        };
        let hint = e.hint.map(|h| format!("\n  hint: {h}")).unwrap_or_default();
        Error::input(format!("{option}: {}{hint}", e.message))
    })?;
    let threads = if a.threads == 0 {
        rayon::current_num_threads()
    } else {
        a.threads
    };
    let (seconds, rss) = with_threads(threads, || {
        let mut sim = Simulation::new(&shot);
        let t = Instant::now();
        for _ in 0..a.frames {
            sim.advance();
        }
        (t.elapsed().as_secs_f64(), peak_rss_mb())
    })?;
    let steps = (a.bees * a.frames) as f64 * a.substeps as f64;
    crate::progress::stdout(&format!(
        "{}\n",
        serde_json::json!({
            "bees": a.bees,
            "frames": a.frames,
            "substeps": a.substeps,
            "threads": threads,
            "model": shot.swarms[0].model.name(),
            "preset": shot.swarms[0].preset,
            "density_per_m3": a.density,
            "scene": if a.nest { "nest: every bee drawn to one nest" } else { "constant density in soft bounds" },
            "bee_steps": steps,
            "ns_per_bee_step": (seconds * 1e9 / steps * 10.0).round() / 10.0,
            "seconds": (seconds * 1000.0).round() / 1000.0,
            "bee_steps_per_s": (steps / seconds).round(),
            "bee_frames_per_s": ((a.bees * a.frames) as f64 / seconds).round(),
            "peak_rss_mb": rss,
        })
    ));
    Ok(())
}

/// Peak resident memory of this process in MB (Linux), or null elsewhere.
pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb: f64 = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some((kb / 1024.0).round())
}
