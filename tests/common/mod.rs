//! Helpers shared by the integration tests.
#![allow(dead_code)]

use beeswarm::eval::collective::Frames;
use beeswarm::shot::{self, Shot};
use beeswarm::sim::Simulation;
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::Path;

pub fn shot(src: &str) -> Shot {
    shot::parse(src, Path::new("test.toml"), Path::new("."))
        .unwrap_or_else(|e| panic!("test shot is invalid: {e}"))
}

/// Runs a shot to its end and returns every bee's positions per frame: `[frame][bee]`.
pub fn run(shot: &Shot) -> Vec<Vec<Vec3>> {
    run_with(Simulation::new(shot), |_| {})
}

/// Runs a prepared simulation, calling `inspect` at every frame, and returns positions.
pub fn run_with(mut sim: Simulation, mut inspect: impl FnMut(&Simulation)) -> Vec<Vec<Vec3>> {
    let mut frames = Vec::new();
    loop {
        inspect(&sim);
        frames.push(
            sim.record()
                .iter()
                .flat_map(|s| s.position.iter().copied())
                .collect(),
        );
        if sim.done() {
            break;
        }
        sim.advance();
    }
    frames
}

/// Asserts that nothing recorded is NaN or infinite.
pub fn assert_all_finite(sim: &Simulation) {
    for s in sim.record() {
        for i in 0..s.len() {
            assert!(
                s.position[i].is_finite() && s.velocity[i].is_finite(),
                "bee {} at frame {}",
                s.ids[i],
                sim.frame()
            );
            assert!(
                s.orientation[i].is_finite() && s.orientation[i].is_normalized(),
                "bee {} orientation",
                s.ids[i]
            );
            assert!(
                s.channels.iter().all(|c| c[i].is_finite()),
                "bee {} channels",
                s.ids[i]
            );
            assert!(s.angular_velocity_deg[i].is_finite() && s.scale[i].is_finite());
        }
    }
}

/// Runs `beeswarm bake` with `args`, failing the test with its error output unless it
/// succeeds.
pub fn bake_ok<S: AsRef<std::ffi::OsStr>>(args: impl IntoIterator<Item = S>) {
    bake_ok_with(args, &[]);
}

/// [`bake_ok`] with the environment variables `env` set.
pub fn bake_ok_with<S: AsRef<std::ffi::OsStr>>(
    args: impl IntoIterator<Item = S>,
    env: &[(&str, &str)],
) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .envs(env.iter().copied())
        .arg("bake")
        .args(args)
        .output()
        .unwrap();
    assert_succeeded(&out);
}

/// Fails the test with the command's error output unless it exited with success.
pub fn assert_succeeded(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Every file under `dir` (recursively), relative to it and `/`-separated, sorted.
pub fn files_under(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap();
                out.push(rel.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    out.sort();
    out
}

/// Bakes an example in memory: every swarm's positions and velocities per frame, by name.
pub fn bake_example(example: &str) -> BTreeMap<String, Frames> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(example);
    let shot = beeswarm::shot::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let mut sim = Simulation::new(&shot);
    let n = shot.swarms.len();
    let mut pos: Vec<Vec<Vec<Vec3>>> = vec![Vec::new(); n];
    let mut vel: Vec<Vec<Vec<Vec3>>> = vec![Vec::new(); n];
    loop {
        for (k, s) in sim.record().iter().enumerate() {
            pos[k].push(s.position.clone());
            vel[k].push(s.velocity.clone());
        }
        if sim.done() {
            break;
        }
        sim.advance();
    }
    shot.swarms
        .iter()
        .zip(pos.into_iter().zip(vel))
        .map(|(s, (p, v))| (s.name.clone(), Frames::new(shot.fps, p, v).unwrap()))
        .collect()
}

/// A closed star-shaped mesh as OBJ text: a UV sphere of `rings` × `segments` cells whose
/// radius is `radius(θ, φ)` (polar angle from +Y, azimuth), so never self-intersecting.
pub fn star_shaped_obj(rings: u32, segments: u32, radius: impl Fn(f32, f32) -> f32) -> String {
    let mut s = format!("v 0 {} 0\n", radius(0.0, 0.0));
    for i in 1..rings {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let ph = std::f32::consts::TAU * j as f32 / segments as f32;
            let r = radius(th, ph);
            s += &format!(
                "v {} {} {}\n",
                r * th.sin() * ph.cos(),
                r * th.cos(),
                r * th.sin() * ph.sin()
            );
        }
    }
    s += &format!("v 0 {} 0\n", -radius(std::f32::consts::PI, 0.0));
    let bottom = 2 + (rings - 1) * segments;
    let at = |i: u32, j: u32| 2 + (i - 1) * segments + j % segments;
    for j in 0..segments {
        s += &format!("f 1 {} {}\n", at(1, j + 1), at(1, j));
        s += &format!("f {bottom} {} {}\n", at(rings - 1, j), at(rings - 1, j + 1));
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            s += &format!(
                "f {} {} {} {}\n",
                at(i, j),
                at(i, j + 1),
                at(i + 1, j + 1),
                at(i + 1, j)
            );
        }
    }
    s
}

/// Approach–retreat cycles of a distance series: local minima at least `depth` below the
/// maxima on both sides; returns the distances at those minima.
pub fn turnarounds(d: &[f32], depth: f32) -> Vec<f32> {
    let mut out = Vec::new();
    let mut hi = d[0];
    let mut lo = f32::INFINITY;
    let mut descending = true;
    for &x in d {
        if descending {
            lo = lo.min(x);
            if hi - lo >= depth && x - lo >= depth {
                out.push(lo);
                descending = false;
                hi = x;
            }
        } else {
            hi = hi.max(x);
            if hi - x >= depth {
                descending = true;
                lo = x;
            }
        }
    }
    out
}

/// 120 bees flying through a row of seven vertical shafts towards an attractor (the roll
/// and penetration tests' scene), as shot text.
pub fn shafts_src() -> String {
    let mut src = String::from(
        "[scene]\nfps = 24\nframes = [1, 145]\nsubsteps = 4\nseed = 2\n[[swarm]]\ncount = 120\npreset = \"optimized\"\nspawn = { shape = \"box\", center = [-1, 1, 0], size = [0.4, 0.4, 1.2] }\nparams = { speed = 1.5 }\n[[target]]\ntype = \"attractor\"\nposition = [1.5, 1, 0]\nstrength = 4\n",
    );
    for k in 0..7 {
        let z = -0.6 + 0.2 * k as f32;
        src += &format!(
            "[[obstacle]]\ntype = \"shaft\"\na = [0, 0, {z}]\nb = [0, 2, {z}]\nradius = 0.025\n"
        );
    }
    src
}

/// A lone bee's departures from its path, sampled at `fps` (positions per frame, after the
/// first two seconds): the vertical (bob) and lateral (sway) offsets from the path averaged
/// over one second around each frame, per frame, in metres.
pub fn bob_and_sway_series(p: &[Vec3], fps: f64) -> (Vec<f64>, Vec<f64>) {
    let w = (fps / 2.0).round() as usize;
    let (mut bob, mut sway) = (Vec::new(), Vec::new());
    for i in (2.0 * fps).round() as usize..p.len() - w {
        let mean = p[i - w..=i + w].iter().copied().sum::<Vec3>() / (2 * w + 1) as f32;
        let dir = (p[i + w] - p[i - w]).normalize_or_zero();
        let d = p[i] - mean;
        let side = dir.cross(Vec3::Y).normalize_or_zero();
        bob.push(d.y as f64);
        sway.push(d.dot(side) as f64);
    }
    (bob, sway)
}

/// Root mean square of a series.
pub fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}
