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
    /// Bees per cubic metre in the spawn box, which soft bounds enclose.
    #[arg(long, default_value_t = 500.0)]
    pub density: f64,
    /// The bounds' pull back into the box, m/s² per metre outside (default: the preset's,
    /// 4 for the bee). Pressure pushes a crowd out of gently held bounds within a second;
    /// 1000 holds it (the JSON's `inside_at_end` tells how much stayed in).
    #[arg(long)]
    pub containment: Option<f64>,
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
    /// Bees per cubic metre in the spawn box, which soft bounds enclose.
    pub density: f64,
    /// The bounds' `containment` (None: the preset's).
    pub containment: Option<f64>,
    pub nest: bool,
}

/// The bench's spawn box (and bounds) for `bees` at `density` per m³: the height of its
/// centre above the origin (its bottom half a metre up) and its edge, metres.
pub fn bench_box(bees: usize, density: f64) -> (f64, f64) {
    let side = (bees as f64 / density).cbrt().max(0.01);
    (side / 2.0 + 0.5, side)
}

/// A swarm at a given density in soft bounds on its spawn box, so that the work per bee
/// stays the same as the count grows (a crowd needs a strong `containment` to stay).
pub fn bench_shot(b: &BenchShot) -> std::result::Result<Shot, crate::error::ShotError> {
    let BenchShot {
        bees,
        frames,
        substeps,
        model,
        nest,
        ..
    } = *b;
    let (height, side) = bench_box(bees, b.density);
    let preset = b
        .preset
        .map(|p| format!("preset = \"{p}\"\n"))
        .unwrap_or_default();
    let params = b
        .containment
        .map(|c| format!("params = {{ containment = {c:?} }}\n"))
        .unwrap_or_default();
    // Soft bounds on the spawn box keep the swarm where it was spawned, loosely (a sparse
    // swarm breathes in and out of the box; `containment` sets how firmly), so that the
    // density does not fall as the count grows; a nest pulls every bee into one ever
    // denser cloud instead.
    let target = if nest {
        format!("\n[[target]]\ntype = \"nest\"\nposition = [0, {height}, 0]\n")
    } else {
        String::new()
    };
    let src = format!(
        "[scene]\nname = \"bench\"\nfps = 24\nframes = [1, {}]\nsubsteps = {substeps}\nseed = 1\n\n[[swarm]]\ncount = {bees}\nmodel = \"{model}\"\n{preset}spawn = {{ shape = \"box\", center = [0, {c}, 0], size = [{side}, {side}, {side}] }}\nbounds = {{ center = [0, {c}, 0], size = [{side}, {side}, {side}] }}\n{params}{target}",
        frames + 1,
        c = height
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
    if let Some(c) = a.containment.filter(|c| !c.is_finite()) {
        return Err(Error::input(format!(
            "--containment: expected an acceleration from 0 to 1000, found {c}"
        )));
    }
    let shot = bench_shot(&BenchShot {
        bees: a.bees,
        frames: a.frames,
        substeps: a.substeps,
        model: &a.model,
        preset: a.preset.as_deref(),
        density: a.density,
        containment: a.containment,
        nest: a.nest,
    })
    .map_err(|e| {
        // The shot is generated from the options: name the option, not the hidden text.
        let option = match e.key.as_str() {
            "scene.substeps" => "--substeps",
            "scene.frames" => "--frames",
            k if k.ends_with(".preset") => "--preset",
            k if k.ends_with(".model") => "--model",
            k if k.ends_with(".containment") || k.ends_with(".params") => "--containment",
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
    let (seconds, rss, inside) = with_threads(threads, || {
        let mut sim = Simulation::new(&shot);
        let t = Instant::now();
        for _ in 0..a.frames {
            sim.advance();
        }
        let seconds = t.elapsed().as_secs_f64();
        (
            seconds,
            peak_rss_mb(),
            share_inside(&sim, a.bees, a.density),
        )
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
            "containment": a.containment,
            "inside_at_end": inside,
            "scene": if a.nest { "nest: every bee drawn to one nest" } else { "a swarm in soft bounds on its spawn box" },
            "bee_steps": steps,
            "ns_per_bee_step": (seconds * 1e9 / steps * 10.0).round() / 10.0,
            "seconds": (seconds * 1000.0).round() / 1000.0,
            "bee_steps_per_s": (steps / seconds).round(),
            "bee_frames_per_s": ((a.bees * a.frames) as f64 / seconds).round(),
            "peak_rss_mb": rss,
            // Which wide paths ran (`crate::simd`; capped by BEESWARM_SIMD): without the
            // sixteen-lane ones a sparse bee-step took 18 % longer here (docs/model.md),
            // so figures from different levels do not compare.
            "simd": crate::simd::level().name(),
        })
    ));
    Ok(())
}

/// The share of the bees inside the spawn box after the last frame, to 3 decimals: how much
/// of the density the bounds held.
fn share_inside(sim: &Simulation, bees: usize, density: f64) -> f64 {
    let (height, side) = bench_box(bees, density);
    let center = glam::Vec3::new(0.0, height as f32, 0.0);
    let half = (side / 2.0) as f32;
    let inside = sim
        .record()
        .iter()
        .flat_map(|s| &s.position)
        .filter(|p| (**p - center).abs().max_element() <= half)
        .count();
    (inside as f64 / bees.max(1) as f64 * 1000.0).round() / 1000.0
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Why `--containment` exists: released at 100,000 per m³, SPH pressure empties the
    /// gently held box within half a second; the strongest containment keeps a crowd in.
    #[test]
    fn a_crowd_leaves_gently_held_bounds_and_strong_ones_hold_it() {
        let inside = |containment: Option<f64>| {
            let shot = bench_shot(&BenchShot {
                bees: 2_000,
                frames: 12,
                substeps: 4,
                model: "bee",
                preset: None,
                density: 100_000.0,
                containment,
                nest: false,
            })
            .unwrap();
            let mut sim = Simulation::new(&shot);
            for _ in 0..12 {
                sim.advance();
            }
            share_inside(&sim, 2_000, 100_000.0)
        };
        let (gentle, held) = (inside(None), inside(Some(1000.0)));
        assert!(gentle < 0.05, "{gentle}");
        assert!(held > 0.3, "{held}");
    }
}
