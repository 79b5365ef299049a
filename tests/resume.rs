//! Resumable bakes: a bake killed between checkpoints and resumed writes caches
//! byte-identical to an uninterrupted bake's.
#![cfg(unix)]

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};

/// Seven models (a bee swarm with its channels, a boids flock, Brownian flyers whose
/// random kicks depend on the step count, paper 001's field insects, paper 002's zonal
/// insects escaping a predator, paper 003's fastswarm insects, paper 004's butterflies in
/// the rain, mid-window of Eq. 12), obstacles and targets, among them a hive that 30 bees
/// start inside and leave around the checkpoint (the state of the hive traffic is in it).
const SHOT: &str = r#"
[scene]
name = "resume"
frames = [1, 30]
seed = 5
[[swarm]]
name = "bees"
count = 150
preset = "grassland"
spawn = { shape = "box", center = [0.0, 1.1, 0.0], size = [2.0, 1.0, 2.0] }
start_inside = 0.2
[[swarm]]
name = "flock"
model = "boids"
count = 60
spawn = { shape = "sphere", center = [0.0, 2.0, 0.0], radius = 0.8 }
[[swarm]]
name = "drift"
model = "brownian"
count = 30
spawn = { shape = "box", center = [1.0, 1.0, 0.0], size = [1.0, 1.0, 1.0] }
[[swarm]]
name = "midges"
model = "field"
count = 30
spawn = { shape = "box", center = [-1.0, 1.0, 0.0], size = [1.0, 1.0, 1.0] }
[[swarm]]
name = "gnats"
model = "zonal"
preset = "escape"
count = 40
spawn = { shape = "box", center = [0.0, 1.5, -1.0], size = [0.3, 0.3, 0.3] }
[[swarm]]
name = "mosquitoes"
model = "fastswarm"
count = 30
spawn = { shape = "box", center = [1.0, 1.5, -1.0], size = [0.5, 0.5, 0.5] }
[[swarm]]
name = "monarchs"
model = "butterfly"
count = 10
params = { rain_rate = 5 }
spawn = { shape = "box", center = [0.0, 1.5, 1.0], size = [0.5, 0.5, 0.5] }
[[target]]
type = "predator"
name = "bat"
keys = [{ frame = 1, position = [-0.6, 1.5, -1.0] }, { frame = 30, position = [0.6, 1.5, -1.0] }]
swarms = ["gnats"]
[[obstacle]]
type = "plane"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
[[target]]
type = "flower"
name = "clover"
position = [0.5, 0.4, 0.5]
[[target]]
type = "nest"
name = "hive"
position = [-0.5, 0.6, 0.5]
land = true
stay = [0.05, 0.2]
inside = [0.2, 0.6]
swarms = ["bees"]
[output]
formats = ["glb", "usda", "csv"]
preview = true
"#;

fn bake(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .arg("bake")
        .arg("shot.toml")
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// Starts a checkpointed bake that stops after `frame`, and kills it there (SIGKILL: no
/// clean-up at all, as a farm pre-empting a task).
fn bake_and_kill_after(dir: &Path, out: &str, frame: i32, extra: &[&str]) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .args(["bake", "shot.toml", "--out", out, "--checkpoint-every", "4"])
        .args(extra)
        .env("BEESWARM_PAUSE_AT", format!("journaled {frame}"))
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = BufReader::new(child.stderr.take().unwrap());
    let mut seen = Vec::new();
    for line in stderr.lines() {
        let line = line.unwrap();
        let paused = line.contains(&format!("paused at journaled {frame}"));
        seen.push(line);
        if paused {
            break;
        }
    }
    assert!(
        seen.last().is_some_and(|l| l.contains("paused")),
        "{seen:?}"
    );
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert!(!status.success(), "the bake was killed, not finished");
}

fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_killed_bake_resumes_into_byte_identical_caches() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("shot.toml"), SHOT).unwrap();
    let out = bake(p, &["--out", "whole", "--quiet"]);
    common::assert_succeeded(&out);
    let expected = files(&p.join("whole"));
    assert_eq!(
        expected,
        [
            "resume.beeswarm.json",
            "resume.glb",
            "resume.preview.png",
            "resume.tracks.csv",
            "resume.usda"
        ]
    );

    // Killed after frame 11: the last checkpoint is frame 8, frames 9–11 are made again.
    bake_and_kill_after(p, "parts", 11, &[]);
    assert!(p.join("parts/resume.checkpoint/state.bin").exists());
    assert!(
        !p.join("parts/resume.glb").exists(),
        "no cache before the end"
    );
    let out = bake(
        p,
        &[
            "--out",
            "parts",
            "--checkpoint-every",
            "4",
            "--resume",
            "--threads",
            "1",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("resuming from the checkpoint at frame 8"),
        "{err}"
    );
    for name in &expected {
        let a = std::fs::read(p.join("whole").join(name)).unwrap();
        let b = std::fs::read(p.join("parts").join(name)).unwrap();
        assert!(a == b, "{name} differs after resuming");
    }
    // The checkpoint and the killed bake's temporary files are gone.
    assert_eq!(files(&p.join("parts")), expected);
}

#[test]
fn a_checkpoint_of_another_seed_is_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("shot.toml"), SHOT).unwrap();
    let out = bake(
        p,
        &[
            "--out", "whole", "--seed", "9", "--format", "csv", "--quiet",
        ],
    );
    common::assert_succeeded(&out);
    bake_and_kill_after(p, "parts", 6, &["--format", "csv"]);
    let out = bake(
        p,
        &[
            "--out",
            "parts",
            "--seed",
            "9",
            "--format",
            "csv",
            "--checkpoint-every",
            "4",
            "--resume",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("ignoring the checkpoint"), "{err}");
    assert!(err.contains("another shot, seed"), "{err}");
    let a = std::fs::read(p.join("whole/resume.tracks.csv")).unwrap();
    let b = std::fs::read(p.join("parts/resume.tracks.csv")).unwrap();
    assert!(a == b);
}
