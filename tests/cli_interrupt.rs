//! Ctrl-C (SIGINT) stops a bake in every phase, within a frame too, and leaves the
//! previous cache as it was with nothing of the interrupted bake behind.
#![cfg(unix)]

mod common;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

#[test]
fn sigint_within_a_long_frame_stops_the_bake_before_that_frame_ends() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    // 100,000 bees in a 1 m box: each frame costs seconds (crowded on purpose).
    std::fs::write(
        p.join("shot.toml"),
        "[scene]\nframes = [1, 5]\n[[swarm]]\ncount = 100000\nspawn = { size = [1, 1, 1] }\n",
    )
    .unwrap();
    std::fs::create_dir(p.join("out")).unwrap();
    std::fs::write(p.join("out/shot.tracks.csv"), "the previous cache\n").unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .args(["bake", "shot.toml", "--format", "csv", "--progress", "json"])
        .current_dir(p)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    assert!(first.contains("\"frame\":1"), "{first}");
    // Frame 1 is the initial state; frame 2 is being simulated now.
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let rest: Vec<String> = lines.map(|l| l.unwrap()).collect();
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert!(
        rest.iter().all(|l| !l.contains("\"frame\":2")),
        "the frame under way was not finished first: {rest:?}"
    );
    assert_eq!(
        std::fs::read_to_string(p.join("out/shot.tracks.csv")).unwrap(),
        "the previous cache\n"
    );
    let left: Vec<_> = std::fs::read_dir(p.join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, ["shot.tracks.csv"], "nothing else left behind");
}

#[test]
fn a_cancelled_simulation_stops_without_advancing() {
    use std::sync::atomic::{AtomicBool, Ordering};
    static CANCEL: AtomicBool = AtomicBool::new(false);
    let shot = beeswarm::shot::parse(
        "[scene]\nframes = [1, 10]\n[[swarm]]\ncount = 50\n",
        std::path::Path::new("t.toml"),
        std::path::Path::new("."),
    )
    .unwrap();
    let mut sim = beeswarm::sim::Simulation::new(&shot);
    sim.set_cancel(&CANCEL);
    assert!(sim.advance_or_cancel(), "runs while the flag is clear");
    assert_eq!(sim.frame(), 2);
    CANCEL.store(true, Ordering::Relaxed);
    assert!(!sim.advance_or_cancel(), "stops once it is set");
    assert_eq!(sim.frame(), 2, "and does not count the abandoned frame");
}

#[test]
fn the_next_bake_removes_what_a_killed_bake_left() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("shot.toml"),
        "[scene]\nframes = [1, 400]\n[[swarm]]\ncount = 3000\n",
    )
    .unwrap();
    let temporaries = || -> Vec<String> {
        std::fs::read_dir(p.join("out"))
            .map(|d| {
                d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                    .filter(|n| n.starts_with(".beeswarm-") && n.ends_with(".tmp"))
                    .collect()
            })
            .unwrap_or_default()
    };
    let mut child = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .args([
            "bake",
            "shot.toml",
            "--format",
            "glb,usda,csv",
            "--progress",
            "json",
        ])
        .current_dir(p)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    for _ in 0..5 {
        lines.next().unwrap().unwrap();
    }
    // kill -9: no handler runs, nothing is cleaned up.
    child.kill().unwrap();
    child.wait().unwrap();
    let left = temporaries();
    assert!(!left.is_empty(), "a killed bake leaves its temporary files");
    // Every name is ours and none embeds the shot's name.
    assert!(left.iter().all(|n| !n.contains("shot")), "{left:?}");
    std::fs::write(
        p.join("small.toml"),
        "[scene]\nframes = [1, 3]\n[[swarm]]\ncount = 3\n",
    )
    .unwrap();
    let status = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .args([
            "bake",
            "small.toml",
            "--format",
            "csv",
            "--progress",
            "none",
        ])
        .current_dir(p)
        .status()
        .unwrap();
    assert!(status.success());
    assert_eq!(
        temporaries(),
        Vec::<String>::new(),
        "the next bake removed them"
    );
}

#[test]
fn many_swarms_bake_under_a_small_open_file_limit() {
    // 150 swarms: about 1,200 USDA scratch files, beyond a 256-file limit if all stayed open.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let mut shot = String::from("[scene]\nframes = [1, 4]\n");
    for i in 0..150 {
        shot += &format!("[[swarm]]\nname = \"s{i}\"\ncount = 1\n");
    }
    std::fs::write(p.join("many.toml"), shot).unwrap();
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -n 256 && exec '{}' bake many.toml --format usda,glb,csv --progress none",
            env!("CARGO_BIN_EXE_beeswarm")
        ))
        .current_dir(p)
        .output()
        .unwrap();
    common::assert_succeeded(&out);
    let usda = std::fs::read_to_string(p.join("out/many.usda")).unwrap();
    assert_eq!(usda.matches("point3f[] positions.timeSamples").count(), 150);
    // Nine sampled attributes a swarm: positions, orientations, velocities, angular
    // velocities, extent, and the primvars pitch, roll, sway and state.
    assert_eq!(
        usda.matches("            4: [").count(),
        150 * 9,
        "every swarm and attribute at frame 4"
    );
}
