//! Every shot in `examples/` is valid and bakes: each is found by listing the folder (a
//! new example is covered without touching this file), checked with `beeswarm check`,
//! and baked over its first few frames to tracks CSV, whose rows are all read back.

use beeswarm::export::csv::HEADER;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Bee-frames baked per example: keeps the whole test to a few seconds in a debug build.
const BEE_FRAMES: usize = 20_000;

fn examples() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut shots: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    shots.sort();
    shots
}

fn beeswarm(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .args(args)
        .output()
        .expect("the beeswarm binary runs");
    (
        out.status.code().expect("exited, not killed by a signal"),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_paper_scenarios_have_examples() {
    let names: Vec<String> = examples()
        .iter()
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    for required in ["grassland", "nest", "shafts", "landing", "minimal"] {
        assert!(
            names.iter().any(|n| n == required),
            "examples/{required}.toml is missing: {names:?}"
        );
    }
}

#[test]
fn every_example_starts_with_a_comment_saying_what_it_shows() {
    for path in examples() {
        let src = std::fs::read_to_string(&path).unwrap();
        let header: Vec<&str> = src.lines().take_while(|l| l.starts_with('#')).collect();
        assert!(
            header.len() >= 2,
            "{} must open with a comment saying what it shows and how to bake it",
            path.display()
        );
    }
}

#[test]
fn the_table_i_examples_use_table_i() {
    // Table I: 1000 bees over grassland, 350 around a nest, with those presets.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    for (file, count, preset) in [
        ("grassland.toml", 1000, "grassland"),
        ("nest.toml", 350, "nest"),
    ] {
        let shot = beeswarm::shot::load(&dir.join(file)).unwrap();
        assert_eq!(shot.bee_count(), count, "{file}");
        assert!(shot.swarms.iter().all(|s| s.preset == preset), "{file}");
    }
}

#[test]
fn every_example_bakes_to_complete_finite_tracks() {
    let out = tempfile::tempdir().unwrap();
    let shots = examples();
    assert!(!shots.is_empty());
    for path in &shots {
        let file = path.display().to_string();
        let shot = beeswarm::shot::load(path).unwrap_or_else(|e| panic!("{e}"));

        let (code, stdout, stderr) = beeswarm(&["check", &file]);
        assert_eq!(code, 0, "beeswarm check {file}:\n{stderr}");
        assert!(
            stdout.starts_with(&format!("shot \"{}\": ok", shot.name)),
            "{stdout}"
        );

        // The first few frames of the shot's own range (targets are keyed to frames).
        let bees = shot.bee_count();
        let frames = (BEE_FRAMES / bees).clamp(3, 24).min(shot.frame_count());
        let (first, last) = (shot.frame_start, shot.frame_start + frames as i32 - 1);
        let dir = out.path().join(path.file_stem().unwrap());
        let (code, _, stderr) = beeswarm(&[
            "bake",
            &file,
            "--out",
            dir.to_str().unwrap(),
            "--format",
            "csv",
            "--frames",
            &format!("{first}:{last}"),
            "--progress",
            "none",
        ]);
        assert_eq!(code, 0, "beeswarm bake {file}:\n{stderr}");

        let csv_path = dir.join(format!("{}.tracks.csv", shot.name));
        let mut written: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        written.sort();
        let manifest = dir.join(format!("{}.beeswarm.json", shot.name));
        assert_eq!(
            written,
            vec![manifest, csv_path.clone()],
            "{file}: only the tracks and the set's manifest"
        );
        let csv = std::fs::read_to_string(&csv_path).unwrap();
        let mut lines = csv.lines();
        // The pose columns, then one per channel of the shot's models (the bee model's
        // pitch, roll, sway; the field model's speed, cost, mde).
        let header = lines.next().unwrap_or_default();
        let pose: Vec<&str> = HEADER.split(',').take(13).collect();
        let columns: Vec<&str> = header.split(',').collect();
        assert_eq!(columns[..13], pose[..], "{file}");
        let expected: Vec<&str> = shot
            .swarms
            .iter()
            .flat_map(|s| s.model.info().channels.iter().map(|c| c.name))
            .collect();
        assert!(
            expected.iter().all(|c| columns[13..].contains(c)),
            "{file}: {header}"
        );
        let mut rows = 0;
        let mut seen = vec![0usize; bees];
        for line in lines {
            // A channel column is empty for agents whose model does not record it (the
            // pose columns, the first 13, never are).
            let v: Vec<f64> = line
                .split(',')
                .enumerate()
                .map(|(k, x)| match x {
                    "" if k >= 13 => 0.0,
                    _ => x
                        .parse()
                        .unwrap_or_else(|_| panic!("{file}: not a number {x:?} in {line}")),
                })
                .collect();
            assert_eq!(v.len(), columns.len(), "{file}: {line}");
            assert!(v.iter().all(|x| x.is_finite()), "{file}: {line}");
            let (id, frame, time) = (v[0] as usize, v[1] as i32, v[2]);
            assert!(id < bees, "{file}: id {id}");
            seen[id] += 1;
            assert!((first..=last).contains(&frame), "{file}: frame {frame}");
            let expected_time = (frame - first) as f64 / shot.fps;
            assert!((time - expected_time).abs() < 1e-6, "{file}: {line}");
            // A unit quaternion, positions within the shot's ±1e6 m.
            let q = (v[9] * v[9] + v[10] * v[10] + v[11] * v[11] + v[12] * v[12]).sqrt();
            assert!((q - 1.0).abs() < 1e-3, "{file}: {line}");
            assert!(v[3..6].iter().all(|x| x.abs() < 1e6), "{file}: {line}");
            rows += 1;
        }
        assert_eq!(rows, bees * frames, "{file}: one row per bee per frame");
        assert!(
            seen.iter().all(|&n| n == frames),
            "{file}: every bee in every frame"
        );
        println!("{file}: {bees} bees × {frames} frames baked");
    }
}

/// The ```toml blocks of a Markdown file.
fn toml_blocks(markdown: &str) -> Vec<String> {
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in markdown.lines() {
        match (&mut current, line.trim_end()) {
            (None, "```toml") => current = Some(String::new()),
            (Some(b), "```") => {
                blocks.push(std::mem::take(b));
                current = None;
            }
            (Some(b), l) => {
                b.push_str(l);
                b.push('\n');
            }
            _ => {}
        }
    }
    blocks
}

#[test]
fn every_shot_in_the_docs_is_valid() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    for doc in ["docs/shot-format.md", "README.md"] {
        let Ok(text) = std::fs::read_to_string(root.join(doc)) else {
            continue;
        };
        let blocks = toml_blocks(&text);
        // A preset file in the docs is written beside the shots, as the docs name it.
        for b in blocks.iter().filter(|b| b.contains("[preset]")) {
            std::fs::write(dir.path().join("meadow.toml"), b).unwrap();
        }
        let mut shots = 0;
        for b in blocks.iter().filter(|b| b.contains("[[swarm]]")) {
            let path = dir.path().join("doc_shot.toml");
            std::fs::write(&path, b).unwrap();
            beeswarm::shot::load(&path)
                .unwrap_or_else(|e| panic!("a shot in {doc} is invalid:\n{e}\n\n{b}"));
            shots += 1;
        }
        if doc == "docs/shot-format.md" {
            assert!(shots >= 2, "{doc}: the minimal and the complete example");
            // The preset file shown there works as a preset.
            std::fs::write(
                dir.path().join("uses_preset.toml"),
                "[[swarm]]\ncount = 3\npreset = \"meadow.toml\"\n",
            )
            .unwrap();
            let shot = beeswarm::shot::load(&dir.path().join("uses_preset.toml"))
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(shot.swarms[0].preset, "meadow.toml");
        }
    }
}
