//! Hive traffic (issue 17): bees land on a hive entrance, go in, stay inside hidden, come
//! out and fly off, measured on `examples/hive_traffic.toml`; and every cache hides
//! exactly the bees inside. Figures print with
//! `cargo test --release --test hive_traffic -- --nocapture --test-threads 1`.

mod common;

use beeswarm::geometry;
use beeswarm::model::bee::{INSIDE, LANDED};
use beeswarm::sim::Simulation;
use common::run_with;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/hive_traffic.toml")
}

/// Entries (landed → inside) and exits (inside → landed) in a bee's states, frame by
/// frame, and the lengths of its completed stays inside, in frames.
fn traffic(states: &[f32]) -> (usize, usize, Vec<usize>) {
    let (mut entries, mut exits, mut stays) = (0, 0, Vec::new());
    let mut since = None;
    for (f, w) in states.windows(2).enumerate() {
        if w[0] != INSIDE && w[1] == INSIDE {
            entries += 1;
            since = Some(f + 1);
        }
        if w[0] == INSIDE && w[1] != INSIDE {
            exits += 1;
            if let Some(s) = since.take() {
                stays.push(f + 1 - s);
            }
        }
    }
    (entries, exits, stays)
}

#[test]
fn bees_go_in_and_come_out_through_the_entrance() {
    let sh = beeswarm::shot::load(&example()).unwrap();
    let entrance = &sh.targets[0];
    let (centre, radius) = (entrance.keys[0].1, entrance.radius);
    let (inside_lo, inside_hi) = entrance.inside.expect("a hive");
    let r_max = sh.swarms[0].bee.radius * (1.0 + sh.swarms[0].variation.size);
    let sim = Simulation::new(&sh);
    let state = sim.meta().swarms[0].channel("state").unwrap();
    let mut states: Vec<Vec<f32>> = Vec::new();
    let (mut in_geometry, mut off_entrance, mut moving_inside) = (0, 0, 0);
    let mut flying_frames = 0;
    run_with(sim, |sim| {
        let s = &sim.record()[0];
        for i in 0..s.len() {
            let st = s.channels[state][i];
            let p = s.position[i];
            let clearance = sh
                .obstacles
                .iter()
                .map(|o| geometry::signed_distance(&o.shape, p))
                .fold(f32::INFINITY, f32::min);
            if st < LANDED {
                flying_frames += 1;
                // A flying bee's centre is never inside the hive (or the ground).
                in_geometry += (clearance < 0.0) as usize;
            }
            if st == INSIDE {
                // Kept at its place on the entrance, clear of the hive's geometry.
                let d = p.distance(centre);
                let on = d >= radius - 1e-4 && d <= radius + r_max + 0.01 && clearance > 0.0;
                off_entrance += (!on) as usize;
                moving_inside += (s.velocity[i] != glam::Vec3::ZERO) as usize;
            }
        }
        states.push(s.channels[state].clone());
    });
    let n = states[0].len();
    let minutes = (states.len() - 1) as f64 / sh.fps / 60.0;
    let (mut entries, mut exits, mut stays) = (0, 0, Vec::new());
    let mut landings = 0;
    for b in 0..n {
        let column: Vec<f32> = states.iter().map(|f| f[b]).collect();
        let (e, x, s) = traffic(&column);
        entries += e;
        exits += x;
        stays.extend(s);
        landings += column
            .windows(2)
            .filter(|w| w[0] < LANDED && w[1] == LANDED)
            .count();
    }
    let total = (n * states.len()) as f64;
    let inside = states.iter().flatten().filter(|&&s| s == INSIDE).count();
    let started_inside = states[0].iter().filter(|&&s| s == INSIDE).count();
    let (entry_rate, exit_rate) = (
        entries as f64 / n as f64 / minutes,
        exits as f64 / n as f64 / minutes,
    );
    println!(
        "hive_traffic.toml: {n} bees, {started_inside} inside at frame 1; {entries} entries \
         ({entry_rate:.2} per bee per minute), {exits} exits ({exit_rate:.2}), {landings} \
         landings at the entrance; {:.1} % of bee-frames inside; stays inside {:.2}-{:.2} s; \
         {flying_frames} flying bee-frames, {in_geometry} inside the hive's geometry",
        inside as f64 / total * 100.0,
        stays.iter().min().copied().unwrap_or(0) as f64 / sh.fps,
        stays.iter().max().copied().unwrap_or(0) as f64 / sh.fps,
    );
    assert_eq!(
        started_inside,
        (sh.swarms[0].start_inside as f64 * n as f64).round() as usize
    );
    // Two-way traffic: bees come out (those that started inside, and later ones) and go in.
    assert!(
        entries >= 10 && exits >= started_inside,
        "{entries} entries, {exits} exits"
    );
    assert!(
        entry_rate > 0.2 && exit_rate > 0.2,
        "{entry_rate} {exit_rate}"
    );
    // Every entry follows a landing on the entrance.
    assert!(
        landings >= entries,
        "{landings} landings, {entries} entries"
    );
    assert_eq!(in_geometry, 0, "flying bees inside the hive");
    assert_eq!(off_entrance, 0, "bees inside kept at the entrance");
    assert_eq!(moving_inside, 0, "bees inside are still");
    let frame = 1.0 / sh.fps;
    assert!(!stays.is_empty());
    assert!(
        stays.iter().all(|&s| {
            let s = s as f64 / sh.fps;
            s >= inside_lo as f64 - frame && s <= inside_hi as f64 + frame
        }),
        "stays inside {stays:?} frames"
    );
}

/// Bakes the example's first `frames` frames in every format into a temporary folder.
fn bake_all(dir: &Path, frames: i32) -> PathBuf {
    let out = dir.join("out");
    let frames = format!("1:{frames}");
    let example = example();
    common::bake_ok([
        example.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--format",
        "glb,usda,csv",
        "--frames",
        &frames,
        "--progress",
        "none",
    ]);
    out
}

/// (id, frame) → state, from the tracks CSV.
fn csv_states(path: &Path) -> BTreeMap<(u64, i32), f32> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|&c| c == "state").unwrap();
    lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            (
                (v[0].parse().unwrap(), v[1].parse().unwrap()),
                v[col].parse().unwrap(),
            )
        })
        .collect()
}

/// frame → ids of the USDA's `invisibleIds` time samples.
fn usda_invisible(path: &Path) -> BTreeMap<i32, Vec<u64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let start = text
        .find("int64[] invisibleIds.timeSamples = {")
        .expect("invisibleIds time samples");
    let mut out = BTreeMap::new();
    for line in text[start..].lines().skip(1) {
        let line = line.trim();
        if line == "}" {
            break;
        }
        let (frame, list) = line.split_once(": ").unwrap();
        let list = list.trim_end_matches(',');
        let list = &list[1..list.len() - 1];
        let ids = list
            .split(", ")
            .filter(|s| !s.is_empty())
            .map(|s| s.parse().unwrap())
            .collect();
        out.insert(frame.parse().unwrap(), ids);
    }
    out
}

/// node name → (interpolation, scale per key) of each node's scale track in the glb.
fn glb_scale_tracks(path: &Path) -> BTreeMap<String, (String, Vec<f32>)> {
    let bytes = std::fs::read(path).unwrap();
    let g = gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = g.blob.as_deref().unwrap();
    let mut out = BTreeMap::new();
    for anim in g.animations() {
        for ch in anim.channels() {
            if ch.target().property() != gltf::animation::Property::Scale {
                continue;
            }
            let reader = ch.reader(|_| Some(blob));
            let Some(gltf::animation::util::ReadOutputs::Scales(s)) = reader.read_outputs() else {
                panic!("scale outputs")
            };
            let name = ch.target().node().name().unwrap().to_owned();
            let interp = format!("{:?}", ch.sampler().interpolation());
            out.insert(name, (interp, s.map(|v| v[0]).collect()));
        }
    }
    out
}

#[test]
fn every_cache_hides_exactly_the_bees_inside() {
    let dir = tempfile::tempdir().unwrap();
    let frames = 120;
    let out = bake_all(dir.path(), frames);
    let states = csv_states(&out.join("hive_traffic.tracks.csv"));
    let invisible = usda_invisible(&out.join("hive_traffic.usda"));
    let scales = glb_scale_tracks(&out.join("hive_traffic.glb"));
    assert_eq!(invisible.len(), frames as usize, "a sample every frame");
    let mut hidden_frames = 0;
    let mut hiding_bees = 0;
    let ids: Vec<u64> = states
        .keys()
        .map(|k| k.0)
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    for &id in &ids {
        let name = format!("bee_{id:06}");
        let track = scales.get(&name);
        let hides = (1..=frames).any(|f| states[&(id, f)] == INSIDE);
        hiding_bees += hides as usize;
        // Only bees that hide at some frame get a scale track, and it is STEP.
        assert_eq!(track.is_some(), hides, "{name}");
        if let Some((interp, _)) = track {
            assert_eq!(interp, "Step", "{name}");
        }
        for f in 1..=frames {
            let inside = states[&(id, f)] == INSIDE;
            hidden_frames += inside as usize;
            assert_eq!(
                invisible[&f].contains(&id),
                inside,
                "USD invisibleIds, bee {id} at frame {f}"
            );
            if let Some((_, s)) = track {
                let expected = if inside { 0.0 } else { 1.0 };
                assert_eq!(
                    s[(f - 1) as usize],
                    expected,
                    "glTF scale, {name} at frame {f}"
                );
            }
        }
    }
    // The hidden set changes over time: bees come out and go in within these frames.
    let changes = invisible
        .values()
        .collect::<Vec<_>>()
        .windows(2)
        .filter(|w| w[0] != w[1])
        .count();
    println!(
        "{frames} frames: {hiding_bees} bees hidden at some frame, {hidden_frames} hidden \
         bee-frames, the invisible set changes at {changes} frames"
    );
    assert!(hidden_frames > 0 && changes >= 5, "{changes}");
}
