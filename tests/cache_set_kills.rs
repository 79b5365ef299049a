//! `kill -9` at ten moments of a glb + usda (value clips) + csv bake (issue 16): in the
//! simulation, while sealing, while hashing and in the middle of the renames. After each
//! kill the folder's manifest either is the previous complete set, whole, or says that a
//! replacement was under way, and every file there is one it lists; the next bake into the
//! folder leaves no temporary file and exactly the files of its own set.
//!
//! The moments are reached with the `BEESWARM_PAUSE_AT` hook (docs/caches.md): the bake
//! prints `paused at <point>` and waits there to be killed.

mod common;
use beeswarm::cache_set::{self, Manifest, Previous};
use common::files_under;
use std::io::BufRead;
use std::path::Path;
use std::process::{Command, Stdio};

/// 4,000 bees over 24 frames (a 44 MB set), USDA split into three clip layers: a set of
/// seven files. `BEESWARM_KILL_BEES=N` bakes N bees instead (a larger run by hand).
fn shot() -> String {
    let bees = std::env::var("BEESWARM_KILL_BEES").unwrap_or_else(|_| "4000".to_owned());
    format!(
        "[scene]\nname = \"hive\"\nframes = [1, 24]\n[[swarm]]\ncount = {bees}\n\
         [output]\nusda_clip_frames = 8\n"
    )
}

/// The points, in the order a bake passes them. Writers seal in format order (glb, usda,
/// csv); the set's files are renamed glb, the three clips, the clip manifest, the main
/// layer, csv.
const MOMENTS: [&str; 10] = [
    "frame 2",
    "frame 12",
    "frame 24",
    "sealed 1",
    "sealed 3",
    "hashed",
    "replacing",
    "renamed 1",
    "renamed 4",
    "removed",
];

fn is_temporary(name: &str) -> bool {
    name.starts_with(".beeswarm-") && name.ends_with(".tmp")
}

fn temporaries(dir: &Path) -> Vec<String> {
    files_under(dir)
        .into_iter()
        .filter(|f| is_temporary(f.rsplit('/').next().unwrap()))
        .collect()
}

fn command(dir: &Path, seed: u64, formats: &str) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_beeswarm"));
    cmd.current_dir(dir).args([
        "bake",
        "shot.toml",
        "--out",
        "out",
        "--progress",
        "none",
        "--format",
        formats,
        "--seed",
        &seed.to_string(),
    ]);
    cmd
}

/// A whole bake; its set must be exactly what the folder holds.
fn bake_and_check(dir: &Path, seed: u64, formats: &str) -> Manifest {
    let out = command(dir, seed, formats).output().unwrap();
    common::assert_succeeded(&out);
    let folder = dir.join("out");
    assert_eq!(
        temporaries(&folder),
        Vec::<String>::new(),
        "no scratch file"
    );
    let m = cache_set::verify(&folder, "hive").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.seed, seed);
    let mut listed: Vec<String> = m.files.iter().map(|f| f.path.clone()).collect();
    listed.push("hive.beeswarm.json".to_owned());
    listed.sort();
    assert_eq!(files_under(&folder), listed, "only the set's files");
    m
}

/// Starts a bake that stops at `point` and kills it there with SIGKILL.
fn kill_at(dir: &Path, seed: u64, point: &str) {
    let mut child = command(dir, seed, "glb,usda,csv")
        .env("BEESWARM_PAUSE_AT", point)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let mut said = Vec::new();
    let mut paused = false;
    for line in std::io::BufReader::new(stderr).lines() {
        let line = line.unwrap();
        paused = line.contains(&format!("paused at {point} "));
        said.push(line);
        if paused {
            break;
        }
    }
    assert!(paused, "the bake never reached {point}: {said:?}");
    child.kill().unwrap(); // SIGKILL: nothing of the bake's own clean-up runs
    child.wait().unwrap();
}

#[test]
fn kill_9_at_ten_moments_never_leaves_a_mixed_set_or_scratch_files() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), shot()).unwrap();
    let folder = dir.path().join("out");
    let mut previous = bake_and_check(dir.path(), 1, "glb,usda,csv");
    let mut scratch_left = 0;
    // The next bakes change the formats, so some kills interrupt a set that also
    // removes the previous set's files, and some next bakes remove the killed set's.
    let next_formats = ["usda,csv", "glb,usda,csv", "csv", "glb,csv"];
    for (i, point) in MOMENTS.iter().enumerate() {
        let before = std::fs::read(folder.join("hive.beeswarm.json")).unwrap();
        kill_at(dir.path(), 100 + i as u64, point);
        scratch_left += temporaries(&folder).len();
        let unfinished = MOMENTS.iter().position(|p| *p == "replacing").unwrap();
        let m = match cache_set::read(&folder, "hive") {
            Previous::Set(m) => m,
            other => panic!("{point}: {other:?}"),
        };
        if i < unfinished {
            // The previous set is untouched and whole.
            assert_eq!(
                std::fs::read(folder.join("hive.beeswarm.json")).unwrap(),
                before,
                "{point}"
            );
            assert_eq!(cache_set::verify(&folder, "hive").unwrap(), previous);
        } else {
            assert!(!m.complete, "{point}: the manifest says the set is mixed");
        }
        // Whatever the moment, every file of ours there is one the manifest accounts for.
        for f in files_under(&folder) {
            let name = f.rsplit('/').next().unwrap();
            // The bake lock's file stays after `kill -9` (its lock does not); the next
            // bake takes it over and removes it.
            let accounted = is_temporary(name)
                || f == "hive.beeswarm.json"
                || f == ".hive.beeswarm.lock"
                || m.files.iter().any(|e| e.path == f)
                || m.replacing.contains(&f);
            assert!(accounted, "{point}: {f} is in no set: {m:?}");
        }
        previous = bake_and_check(
            dir.path(),
            200 + i as u64,
            next_formats[i % next_formats.len()],
        );
    }
    assert!(!cache_set::lock_path(&folder, "hive").exists());
    assert!(
        scratch_left > 0,
        "the kills left scratch files, which the next bakes removed"
    );
}
