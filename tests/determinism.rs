//! The same shot and seed give byte-identical caches (and preview PNG) whatever the number
//! of threads, and a different seed gives a different swarm. The shot holds a crowd (400
//! bees in a 5 cm cube) so that the bounded-neighbour search's ring walk is covered too, a
//! swarm of paper 001's field model (its path field, noise and minimum distance
//! enforcement) and a dense zonal swarm (paper 002: ORCA, escape angles drawn per agent)
//! meeting a predator, and paper 004's butterflies chasing each other in the rain. A mesh
//! obstacle among the bees covers the mesh queries' per-thread memo and search bounds,
//! which must not change an answer. The nest is a hive that a fifth of the bees start
//! inside (hive traffic: bees out of the neighbour grid, coming out and going in). The
//! same shots give the same bytes with the wide (SIMD) paths capped at every level the CPU
//! has (`beeswarm::simd`), so on every x86-64 machine.

mod common;

use std::path::Path;

const SHOT: &str = r#"
[scene]
name = "det"
fps = 24
frames = [1, 25]
seed = 11
[[swarm]]
name = "bees"
count = 300
preset = "nest"
spawn = { shape = "box", center = [0, 1, 0.5], size = [1, 0.5, 0.5] }
start_inside = 0.2
[[swarm]]
name = "boids"
count = 60
model = "boids"
[[swarm]]
name = "brownian"
count = 60
model = "brownian"
[[swarm]]
name = "fast"
count = 60
model = "fastswarm"
spawn = { shape = "box", center = [0.3, 1, 0.3], size = [0.4, 0.4, 0.4] }
[[swarm]]
name = "crowd"
count = 400
spawn = { shape = "box", center = [0.6, 1.5, 0], size = [0.05, 0.05, 0.05] }
[[swarm]]
name = "field"
count = 200
model = "field"
spawn = { shape = "box", center = [-0.5, 1, 0], size = [0.4, 0.4, 0.4] }
params = { d_min = 0.05, goal_radius = 0.2 }
[[swarm]]
name = "zonal"
count = 300
model = "zonal"
preset = "escape"
spawn = { shape = "box", center = [-0.6, 1.5, 0], size = [0.2, 0.2, 0.2] }
[[swarm]]
name = "butterflies"
count = 40
model = "butterfly"
spawn = { shape = "box", center = [0, 1.5, -0.5], size = [0.6, 0.3, 0.6] }
params = { chase = 1, rain_rate = 10 }
[[target]]
type = "predator"
keys = [{ frame = 1, position = [-1.2, 1.5, 0] }, { frame = 25, position = [0, 1.5, 0] }]
swarms = ["zonal"]
[[obstacle]]
type = "cylinder"
center = [0.3, 1, 0.3]
radius = 0.05
height = 2
[[target]]
type = "nest"
position = [0, 1, 0]
swarms = ["bees", "boids", "field", "butterflies"]
land = true
stay = [0.05, 0.2]
inside = [0.1, 0.5]
[[obstacle]]
type = "mesh"
file = "ball.obj"
position = [0.2, 1, 0.5]
"#;

/// A UV sphere of radius 0.15 m, 1,920 triangles, as OBJ text.
fn ball_obj() -> String {
    common::star_shaped_obj(20, 48, |_, _| 0.15)
}

/// Bees and a zonal swarm around a flattened ball that sweeps through them, turning: the
/// moving mesh's pose, set each substep, must not change an answer either.
const MOVING_SHOT: &str = r#"
[scene]
name = "det"
fps = 24
frames = [1, 25]
seed = 5
[[swarm]]
name = "bees"
count = 300
params = { speed = 3 }
spawn = { center = [0, 1, 0], size = [1, 0.6, 1] }
[[swarm]]
name = "zonal"
model = "zonal"
count = 300
spawn = { center = [0, 1, 0], size = [1, 0.6, 1] }
[[target]]
position = [0, 1, 0]
[[obstacle]]
type = "mesh"
file = "ball.obj"
scale = [3, 1, 2]
keys = [
  { frame = 1, position = [-0.9, 1, 0], rotation = [0, 0, 0] },
  { frame = 13, position = [0, 1.1, 0.1], rotation = [30, 180, 0] },
  { frame = 25, position = [0.9, 1, 0], rotation = [0, 360, 45] },
]
"#;

fn bake(dir: &Path, threads: usize, seed: Option<u64>) -> Vec<(String, Vec<u8>)> {
    bake_shot(dir, SHOT, threads, seed)
}

fn bake_shot(dir: &Path, src: &str, threads: usize, seed: Option<u64>) -> Vec<(String, Vec<u8>)> {
    bake_at(dir, src, threads, seed, "native")
}

/// Bakes `src` with the wide paths capped at `simd` (`BEESWARM_SIMD`).
fn bake_at(
    dir: &Path,
    src: &str,
    threads: usize,
    seed: Option<u64>,
    simd: &str,
) -> Vec<(String, Vec<u8>)> {
    let shot = dir.join("det.toml");
    std::fs::write(&shot, src).unwrap();
    std::fs::write(dir.join("ball.obj"), ball_obj()).unwrap();
    let out = dir.join(format!("t{threads}-{}-{simd}", seed.unwrap_or(0)));
    let threads = threads.to_string();
    let mut args = vec![
        shot.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--format",
        "csv",
        // The preview PNG too: drawn on the writer thread, it must not vary either.
        "--preview",
        "--progress",
        "none",
        "--threads",
        &threads,
    ];
    let seed = seed.map(|s| s.to_string());
    if let Some(s) = &seed {
        args.extend(["--seed", s]);
    }
    common::bake_ok_with(args, &[(beeswarm::simd::ENV, simd)]);
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    files.sort();
    files
}

#[test]
fn caches_are_byte_identical_with_1_and_4_threads() {
    let dir = tempfile::tempdir().unwrap();
    identical(bake(dir.path(), 1, None), bake(dir.path(), 4, None));
}

#[test]
fn caches_around_a_moving_mesh_are_byte_identical_with_1_and_4_threads() {
    let dir = tempfile::tempdir().unwrap();
    identical(
        bake_shot(dir.path(), MOVING_SHOT, 1, None),
        bake_shot(dir.path(), MOVING_SHOT, 4, None),
    );
}

/// The wide paths (`beeswarm::simd`: the grid's scan and ranking, the bee's pair and
/// density sums, the curl noise, fastswarm's batches) do the portable code's operations in
/// its order, so a cache is the same bytes on a CPU without them: baked on every level
/// this CPU has, against the portable code.
#[test]
fn caches_are_byte_identical_on_every_simd_level() {
    let dir = tempfile::tempdir().unwrap();
    let levels: &[(&str, beeswarm::simd::Level)] = &[
        ("avx2", beeswarm::simd::Level::Avx2),
        ("native", beeswarm::simd::Level::Avx512),
    ];
    let cpu = beeswarm::simd::detected();
    if cpu == beeswarm::simd::Level::Portable {
        eprintln!("this CPU has neither AVX2 nor AVX-512: no wide path to compare");
        return;
    }
    for src in [SHOT, MOVING_SHOT] {
        let portable = bake_at(dir.path(), src, 2, None, "portable");
        for &(cap, level) in levels {
            if level > cpu {
                eprintln!(
                    "this CPU lacks {}: that level is not compared",
                    level.name()
                );
                continue;
            }
            identical(portable.clone(), bake_at(dir.path(), src, 2, None, cap));
        }
    }
}

fn identical(first: Vec<(String, Vec<u8>)>, second: Vec<(String, Vec<u8>)>) {
    assert!(!first.is_empty());
    assert_eq!(
        first.iter().map(|f| &f.0).collect::<Vec<_>>(),
        second.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for ((name, a), (_, b)) in first.iter().zip(&second) {
        // The set's manifest is small; it must be identical too (hashes, no time stamp).
        assert!(
            a.len() > 1000 || name.ends_with(".beeswarm.json"),
            "{name} is too small to mean anything"
        );
        assert!(a == b, "{name} differs between the two bakes");
    }
}

#[test]
fn another_seed_gives_another_swarm() {
    let dir = tempfile::tempdir().unwrap();
    let a = bake(dir.path(), 2, Some(1));
    let b = bake(dir.path(), 2, Some(2));
    for ((name, a), (_, b)) in a.iter().zip(&b) {
        assert_ne!(a, b, "{name}");
    }
}

#[test]
fn a_cache_is_the_same_whichever_other_caches_the_bake_writes() {
    // A bake without USDA records no angular velocities (`Simulation::record_spin`): its
    // glb and CSV are those of a bake that also writes USDA, and USDA's own
    // angularVelocities are the turning bees' (not zeros) whatever else is written.
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("spin.toml");
    std::fs::write(
        &shot,
        "[scene]\nname = \"spin\"\nfps = 24\nframes = [1, 6]\nseed = 3\n\
         [[swarm]]\ncount = 40\n",
    )
    .unwrap();
    let bake = |formats: &str| {
        let out = dir.path().join(formats.replace(',', "-"));
        let (shot, to) = (shot.to_str().unwrap(), out.to_str().unwrap());
        common::bake_ok([shot, "--out", to, "--format", formats, "--progress", "none"]);
        out
    };
    let (all, glb, usda) = (bake("glb,csv,usda"), bake("glb,csv"), bake("usda"));
    for name in ["spin.glb", "spin.tracks.csv"] {
        let a = std::fs::read(all.join(name)).unwrap();
        assert!(a == std::fs::read(glb.join(name)).unwrap(), "{name}");
    }
    let text = std::fs::read_to_string(all.join("spin.usda")).unwrap();
    assert_eq!(
        text,
        std::fs::read_to_string(usda.join("spin.usda")).unwrap()
    );
    // From frame 2 on (a bee's first frame has no substep before it), the bees turn.
    let samples = text
        .split("angularVelocities.timeSamples = {")
        .nth(1)
        .unwrap();
    let samples = &samples[..samples.find('}').unwrap()];
    let turning = samples
        .split('(')
        .skip(1)
        .map(|v| {
            v[..v.find(')').unwrap()]
                .split(", ")
                .map(|x| x.parse::<f32>().unwrap())
        })
        .filter(|w| w.clone().any(|x| x.abs() > 1.0))
        .count();
    assert!(
        turning > 40,
        "angularVelocities hold the bees' turns: {turning}"
    );
}
