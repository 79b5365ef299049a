//! `beeswarm check`: validate a shot and say what a bake would produce.

use super::resources::{Needs, bytes, density};
use crate::error::Result;
use crate::geometry::mesh::MeshMode;
use crate::shot::{Region, Shape, Shot, Swarm};
use clap::Args;
use std::path::Path;

#[derive(Args, Debug)]
#[command(
    about = "Validate a shot and report what a bake would do (a dry run: takes every bake option)",
    after_help = "Examples:\n  beeswarm check examples/nest.toml\n  beeswarm check shot.toml --frames 1:48 --format usda,csv --out caches"
)]
pub struct CheckArgs {
    /// The same options as `bake` (without a shot file, the built-in demo shot).
    #[command(flatten)]
    pub bake: super::bake::BakeArgs,
}

pub fn run(a: CheckArgs) -> Result<()> {
    let shot = match &a.bake.shot {
        Some(path) => crate::shot::load(path)?,
        None => crate::shot::embedded_default(),
    };
    // Whatever would stop a bake before it starts stops the check too.
    let plan = a.bake.plan(shot)?;
    super::resources::reserve_memory(&plan, a.bake.shot.as_deref())?;
    let mut text = summary(&plan.shot);
    text += &dry_run(&plan);
    crate::progress::stdout(&text);
    Ok(())
}

/// What a bake of the plan would write and replace, and the time, memory and disk it
/// would take (estimates; the time from a short run of a smaller copy of the shot).
fn dry_run(plan: &super::bake::Plan) -> String {
    use std::fmt::Write;
    let shot = &plan.shot;
    let needs = Needs::of(plan);
    let mut s = String::new();
    let _ = writeln!(s, "  a bake would write into {}:", plan.out_dir.display());
    for (name, size) in &needs.files {
        let file = name.split(' ').next().unwrap_or(name);
        let replaces = if plan.out_dir.join(file).exists() {
            " (replaces the existing file)"
        } else {
            ""
        };
        let _ = writeln!(s, "    {name}: about {}{replaces}", bytes(*size));
    }
    let _ = writeln!(
        s,
        "    {}: the set's manifest (files, sizes, SHA-256, shot hash, seed, frames)",
        crate::cache_set::manifest_path(Path::new(""), &shot.name).display()
    );
    let previous = crate::cache_set::read(&plan.out_dir, &shot.name);
    if let Some(problem) = previous.problem(&plan.out_dir, &shot.name) {
        let _ = writeln!(s, "  note: {problem}");
    }
    for old in previous.files() {
        if !writes(&old, &shot.name, &needs.files, needs.usda_clips) {
            let _ = writeln!(s, "    {old}: removed (a file of the previous set)");
        }
    }
    let disk = needs.disk();
    let seconds = predicted_seconds(shot);
    let _ = writeln!(
        s,
        "  predicted: about {} of simulation (measured on a smaller copy of this shot), \
         {} of memory, {} of disk ({} while baking)",
        duration(seconds),
        bytes(needs.memory),
        bytes(disk),
        bytes(disk + needs.scratch)
    );
    s
}

/// Whether a bake writing `files` (names, with a description after a space) and, with
/// clips, `clips` clip layers writes the previous set's file `old`.
fn writes(old: &str, shot: &str, files: &[(String, f64)], clips: Option<usize>) -> bool {
    if files
        .iter()
        .any(|(name, _)| name.split(' ').next() == Some(old))
    {
        return true;
    }
    let Some(count) = clips else {
        return false;
    };
    let Some(layer) = old
        .strip_prefix(&format!("{shot}.clips/{shot}."))
        .and_then(|r| r.strip_suffix(".usda"))
    else {
        return false;
    };
    layer == "manifest"
        || layer
            .parse::<usize>()
            .is_ok_and(|i| (1..=count).contains(&i))
}

/// Seconds to simulate `shot`, from two frames of a copy with at most 2,000 agents at the
/// same spawn density (spawn regions and bounds shrunk in proportion).
fn predicted_seconds(shot: &Shot) -> f64 {
    let total = shot.bee_count().max(1) as f64;
    let f = (2000.0 / total).min(1.0);
    let mut small = shot.clone();
    small.frame_end = small.frame_start + 2;
    let shrink = (f as f32).cbrt();
    for w in &mut small.swarms {
        w.count = ((w.count as f64 * f).ceil() as usize).max(1);
        w.spawn = match w.spawn {
            Region::Box { center, half } => Region::Box {
                center,
                half: half * shrink,
            },
            Region::Sphere { center, radius } => Region::Sphere {
                center,
                radius: radius * shrink,
            },
        };
        if let Some((c, h)) = w.bounds {
            w.bounds = Some((c, h * shrink));
        }
    }
    let mut sim = crate::sim::Simulation::new(&small);
    let start = std::time::Instant::now();
    sim.advance();
    sim.advance();
    let per_agent_step =
        start.elapsed().as_secs_f64() / (small.bee_count() as f64 * 2.0 * small.substeps as f64);
    per_agent_step * total * (shot.frame_count() as f64 - 1.0) * shot.substeps as f64
}

fn duration(s: f64) -> String {
    match s {
        s if s >= 3600.0 => format!("{:.1} h", s / 3600.0),
        s if s >= 60.0 => format!("{:.1} min", s / 60.0),
        s if s >= 1.0 => format!("{s:.0} s"),
        s => format!("{s:.1} s"),
    }
}

/// A length in metres, to the millimetre.
fn mm(v: f32) -> String {
    num((v as f64 * 1000.0).round() / 1000.0)
}

/// The swarm's starting density, and a warning when agents start with more neighbours than
/// a step handles at its usual cost.
fn crowding(w: &Swarm) -> String {
    // Beyond the most neighbours an agent interacts with, each feels only its nearest.
    const CROWDED: f64 = crate::model::context::MAX_NEIGHBOURS as f64;
    let shape = match w.spawn {
        Region::Box { half, .. } => format!(
            "box {} × {} × {} m",
            mm(2.0 * half.x),
            mm(2.0 * half.y),
            mm(2.0 * half.z)
        ),
        Region::Sphere { radius, .. } => format!("sphere of radius {} m", mm(radius)),
    };
    let (density, near) = density(w);
    let mut line = format!(
        "      spawn: {shape}, {} agents per m³",
        num(density.round())
    );
    if let Some((h, neighbours)) = near {
        line += &format!(
            " (about {} neighbours within {} m)",
            num(neighbours.round()),
            num(h)
        );
        if neighbours > CROWDED {
            line += &format!(
                "\n      warning: more than {} neighbours per agent: each feels only its nearest {} \
                 and a step costs more (about 1.5 times as much at 100,000 per m³); give \
                 the swarm a larger spawn region \
                 (at most {} agents per m³ here)",
                CROWDED,
                CROWDED,
                num((CROWDED / (4.0 / 3.0 * std::f64::consts::PI * h.powi(3))).floor())
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
        let kind = match &o.shape {
            Shape::Sphere { .. } => "sphere".to_owned(),
            Shape::Box { .. } => "box".to_owned(),
            Shape::Capsule { .. } => "capsule".to_owned(),
            Shape::Cylinder { .. } => "cylinder".to_owned(),
            Shape::Plane { .. } => "plane".to_owned(),
            Shape::Mesh { mesh, .. } => {
                let (lo, hi) = mesh.bounds();
                let how = match mesh.mode() {
                    MeshMode::Solid => format!("solid, {} closed piece(s)", mesh.piece_count()),
                    MeshMode::Shell { thickness } => {
                        format!("shell {} m thick", num(thickness as f64))
                    }
                };
                format!(
                    "mesh, {} triangles, {how}, from [{}, {}, {}] to [{}, {}, {}] m",
                    mesh.triangle_count(),
                    num(lo.x as f64),
                    num(lo.y as f64),
                    num(lo.z as f64),
                    num(hi.x as f64),
                    num(hi.y as f64),
                    num(hi.z as f64)
                )
            }
        };
        let motion = match o.keys.len() {
            0 => String::new(),
            n => format!(" (in its rest frame), moving on {n} key(s)"),
        };
        let _ = writeln!(s, "    {}: {kind}{motion}", o.name);
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
    s
}

/// A parameter for people: six significant digits, so 2.2 × 0.05 prints as 0.11 rather
/// than 0.11000000000000001.
fn num(x: f64) -> String {
    let rounded: f64 = format!("{x:.5e}").parse().unwrap_or(x);
    rounded.to_string()
}
