//! `beeswarm check`: validate a shot and say what a bake would produce.

use crate::error::Result;
use crate::shot::{Shape, Shot};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
#[command(
    about = "Validate a shot and report what it would produce",
    after_help = "Example:\n  beeswarm check examples/nest.toml"
)]
pub struct CheckArgs {
    /// The shot file (TOML).
    pub shot: PathBuf,
}

pub fn run(a: CheckArgs) -> Result<()> {
    let shot = crate::shot::load(&a.shot)?;
    crate::progress::stdout(&summary(&shot));
    Ok(())
}

/// A human-readable summary of a valid shot.
pub fn summary(shot: &Shot) -> String {
    let mut s = String::new();
    use std::fmt::Write;
    let _ = writeln!(s, "shot \"{}\": ok", shot.name);
    let _ = writeln!(
        s,
        "  frames {}–{} ({} frames at {} fps, {:.2} s), {} substeps, seed {}",
        shot.frame_start,
        shot.frame_end,
        shot.frame_count(),
        shot.fps,
        (shot.frame_count() - 1) as f64 / shot.fps,
        shot.substeps,
        shot.seed
    );
    let _ = writeln!(
        s,
        "  {} swarm(s), {} bees in all:",
        shot.swarms.len(),
        shot.bee_count()
    );
    for w in &shot.swarms {
        let _ = writeln!(
            s,
            "    {}: {} bees, model {}, preset {}",
            w.name,
            w.count,
            w.model.name(),
            w.preset,
        );
        // Every parameter with its unit, so a TD sees what the preset and overrides gave.
        let params: Vec<String> = w
            .params
            .iter()
            .map(|(p, v)| match p.unit {
                "1" => format!("{} {}", p.name, num(v)),
                u => format!("{} {} {u}", p.name, num(v)),
            })
            .collect();
        let _ = writeln!(s, "      params: {}", params.join(", "));
    }
    let _ = writeln!(s, "  {} obstacle(s)", shot.obstacles.len());
    for o in &shot.obstacles {
        let kind = match o.shape {
            Shape::Sphere { .. } => "sphere",
            Shape::Box { .. } => "box",
            Shape::Capsule { .. } => "capsule",
            Shape::Cylinder { .. } => "cylinder",
            Shape::Plane { .. } => "plane",
        };
        let _ = writeln!(s, "    {}: {kind}", o.name);
    }
    let _ = writeln!(s, "  {} target(s)", shot.targets.len());
    for t in &shot.targets {
        let _ = writeln!(
            s,
            "    {}: {:?}, {} key(s), strength {} m/s²",
            t.name,
            t.kind,
            t.keys.len(),
            t.strength
        );
    }
    if shot.wind != glam::Vec3::ZERO {
        let _ = writeln!(s, "  wind {} m/s", shot.wind);
    }
    let _ = writeln!(s, "  outputs in {}:", shot.output.dir.display());
    for f in &shot.output.formats {
        let _ = writeln!(s, "    {}", f.file_name(&shot.name));
    }
    if shot.output.preview {
        let _ = writeln!(s, "    {}.preview.png", shot.name);
    }
    s
}

/// A parameter for people: six significant digits, so 2.2 × 0.05 prints as 0.11 rather
/// than 0.11000000000000001.
fn num(x: f64) -> String {
    let rounded: f64 = format!("{x:.5e}").parse().unwrap_or(x);
    rounded.to_string()
}
