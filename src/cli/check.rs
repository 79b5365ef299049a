//! `beeswarm check`: validate a shot and say what a bake would produce.

use crate::error::Result;
use crate::shot::{Region, Shape, Shot, Swarm, defaults};
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
    // Whatever would stop a bake before it starts stops the check too.
    super::bake::check_out_dir(&shot.output.dir, false)?;
    crate::progress::stdout(&summary(&shot));
    Ok(())
}

/// A length in metres, to the millimetre.
fn mm(v: f32) -> String {
    num((v as f64 * 1000.0).round() / 1000.0)
}

/// The swarm's starting density, and a warning when agents start with more neighbours than
/// a step handles at its usual cost.
fn crowding(w: &Swarm) -> String {
    let (shape, volume) = match w.spawn {
        Region::Box { half, .. } => (
            format!(
                "box {} × {} × {} m",
                mm(2.0 * half.x),
                mm(2.0 * half.y),
                mm(2.0 * half.z)
            ),
            8.0 * (half.x * half.y * half.z) as f64,
        ),
        Region::Sphere { radius, .. } => (
            format!("sphere of radius {} m", mm(radius)),
            4.0 / 3.0 * std::f64::consts::PI * (radius as f64).powi(3),
        ),
    };
    let density = w.count as f64 / volume;
    let mut line = format!(
        "      spawn: {shape}, {} agents per m³",
        num(density.round())
    );
    if let Some(h) = w.params.get("neighbour_radius") {
        let neighbours = density * 4.0 / 3.0 * std::f64::consts::PI * h.powi(3);
        line += &format!(
            " (about {} neighbours within {} m)",
            num(neighbours.round()),
            num(h)
        );
        if neighbours > defaults::CROWDED_NEIGHBOURS {
            line += &format!(
                "\n      warning: more than {} neighbours per agent makes every step far slower; \
                 give the swarm a larger spawn region (at most {} agents per m³ here)",
                defaults::CROWDED_NEIGHBOURS,
                num((defaults::CROWDED_NEIGHBOURS
                    / (4.0 / 3.0 * std::f64::consts::PI * h.powi(3)))
                .floor())
            );
        }
    }
    line
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
        let _ = writeln!(s, "{}", crowding(w));
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
