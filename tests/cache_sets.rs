//! Cache sets (issue 16): a bake's files form one set recorded in `<name>.beeswarm.json`;
//! a re-bake replaces the set as a whole and removes the previous set's files it no longer
//! writes, and only those; a missing, corrupt or unfinished manifest is handled.

mod common;
use beeswarm::cache_set::{self, Manifest};
use common::files_under;
use std::path::{Path, PathBuf};
use std::process::Command;

const SHOT: &str = "[scene]\nname = \"hive\"\nframes = [1, 9]\n[[swarm]]\ncount = 40\n";

fn bake(dir: &Path, args: &[&str]) -> (i32, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_beeswarm"));
    cmd.current_dir(dir)
        .args(["bake", "shot.toml", "--progress", "none"])
        .args(args);
    if !args.contains(&"--out") {
        cmd.args(["--out", "out"]);
    }
    let out = cmd.output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `check` of a csv bake into `out`, which must pass; its report.
fn check_csv(dir: &Path) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .current_dir(dir)
        .args(["check", "shot.toml", "--out", "out", "--format", "csv"])
        .output()
        .unwrap();
    common::assert_succeeded(&out);
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn baked(dir: &Path, args: &[&str]) -> String {
    let (code, stderr) = bake(dir, args);
    assert_eq!(code, 0, "{stderr}");
    stderr
}

/// The folder's set, checked: complete, every listed file as described (size, SHA-256).
fn set(out: &Path) -> Manifest {
    cache_set::verify(out, "hive").unwrap_or_else(|e| panic!("set of {}: {e}", out.display()))
}

fn listed(m: &Manifest) -> Vec<String> {
    let mut v: Vec<String> = m.files.iter().map(|f| f.path.clone()).collect();
    v.push("hive.beeswarm.json".to_owned());
    v.sort();
    v
}

fn setup() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), SHOT).unwrap();
    let out = dir.path().join("out");
    (dir, out)
}

#[test]
fn the_manifest_lists_exactly_the_files_of_the_bake() {
    let (dir, out) = setup();
    baked(dir.path(), &["--format", "glb,usda,csv", "--seed", "3"]);
    let m = set(&out);
    assert!(m.complete && m.replacing.is_empty());
    assert_eq!((m.seed, m.frame_start, m.frame_end), (3, 1, 9));
    assert_eq!(m.tool_version, env!("CARGO_PKG_VERSION"));
    assert_eq!(files_under(&out), listed(&m));
    assert_eq!(
        listed(&m),
        [
            "hive.beeswarm.json",
            "hive.glb",
            "hive.tracks.csv",
            "hive.usda"
        ]
    );
    // The hash is the standard SHA-256 of the file (what `sha256sum` prints).
    let csv = m
        .files
        .iter()
        .find(|f| f.path == "hive.tracks.csv")
        .unwrap();
    assert_eq!(csv.sha256.len(), 64);
    assert_eq!(
        csv.bytes,
        std::fs::metadata(out.join("hive.tracks.csv"))
            .unwrap()
            .len()
    );
    // The shot's hash follows what is simulated (the seed), not where the caches go.
    baked(
        dir.path(),
        &["--format", "csv", "--seed", "3", "--out", "elsewhere"],
    );
    let there = cache_set::verify(&dir.path().join("elsewhere"), "hive").unwrap();
    assert_eq!(there.shot_sha256, m.shot_sha256);
    baked(dir.path(), &["--format", "glb,usda,csv", "--seed", "4"]);
    assert_ne!(set(&out).shot_sha256, m.shot_sha256);
}

#[test]
fn a_rebake_with_fewer_formats_removes_the_old_files_and_nothing_else() {
    let (dir, out) = setup();
    std::fs::write(
        dir.path().join("shot.toml"),
        format!("{SHOT}[output]\nusda_clip_frames = 4\n"),
    )
    .unwrap();
    baked(dir.path(), &["--format", "glb,usda,csv", "--seed", "1"]);
    let first = set(&out);
    assert!(
        listed(&first).contains(&"hive.clips/hive.0001.usda".to_owned()),
        "value clips belong to the set: {:?}",
        listed(&first)
    );
    assert_eq!(files_under(&out), listed(&first));
    // Files that are not the set's, even named after the shot, are never removed.
    std::fs::write(out.join("hive.notes.txt"), "mine").unwrap();
    std::fs::write(out.join("other.glb"), "another shot's").unwrap();

    baked(dir.path(), &["--format", "csv", "--seed", "2"]);
    let second = set(&out);
    assert_eq!(second.seed, 2);
    assert_eq!(listed(&second), ["hive.beeswarm.json", "hive.tracks.csv"]);
    assert_eq!(
        files_under(&out),
        [
            "hive.beeswarm.json",
            "hive.notes.txt",
            "hive.tracks.csv",
            "other.glb"
        ],
        "the seed-1 glb, usda and clips went; the user's files stayed"
    );
    assert!(
        !out.join("hive.clips").exists(),
        "the emptied clips folder went"
    );
}

#[test]
fn a_missing_manifest_leaves_unknown_files_alone() {
    let (dir, out) = setup();
    baked(dir.path(), &["--format", "glb,csv"]);
    std::fs::remove_file(out.join("hive.beeswarm.json")).unwrap();
    baked(dir.path(), &["--format", "csv", "--seed", "5"]);
    let m = set(&out);
    assert_eq!(listed(&m), ["hive.beeswarm.json", "hive.tracks.csv"]);
    // No manifest named the glb, so it is not known to be ours: it stays, and it is not
    // in the set (a reader goes by the manifest).
    assert!(out.join("hive.glb").exists());
}

#[test]
fn a_corrupt_manifest_is_reported_and_replaced() {
    let (dir, out) = setup();
    baked(dir.path(), &["--format", "glb,csv"]);
    std::fs::write(out.join("hive.beeswarm.json"), "{ not json").unwrap();
    // check reports it, the bake says so and writes a good one.
    let text = check_csv(dir.path());
    assert!(text.contains("is not a beeswarm manifest"), "{text}");
    let stderr = baked(dir.path(), &["--format", "csv"]);
    assert!(stderr.contains("is not a beeswarm manifest"), "{stderr}");
    assert_eq!(
        listed(&set(&out)),
        ["hive.beeswarm.json", "hive.tracks.csv"]
    );
    assert!(out.join("hive.glb").exists(), "unknown, so kept");
}

#[test]
fn a_manifest_naming_files_outside_its_set_removes_none_of_them() {
    let (dir, out) = setup();
    baked(dir.path(), &["--format", "csv"]);
    let mut m = set(&out);
    std::fs::write(dir.path().join("precious.txt"), "keep").unwrap();
    std::fs::write(out.join("other.usda"), "keep").unwrap();
    m.replacing = vec!["../precious.txt".to_owned()];
    m.files.push(cache_set::FileEntry {
        path: "other.usda".to_owned(),
        bytes: 4,
        sha256: "0".repeat(64),
    });
    std::fs::write(
        out.join("hive.beeswarm.json"),
        serde_json::to_string(&m).unwrap(),
    )
    .unwrap();
    let stderr = baked(dir.path(), &["--format", "csv"]);
    assert!(stderr.contains("not a file of this set"), "{stderr}");
    assert!(dir.path().join("precious.txt").exists());
    assert!(out.join("other.usda").exists());
}

#[test]
fn an_unfinished_replacement_is_reported_and_completed_by_the_next_bake() {
    let (dir, out) = setup();
    baked(dir.path(), &["--format", "glb,usda,csv"]);
    // What a bake killed between its renames leaves: a manifest saying so, listing the
    // new files and the old ones still to go.
    let mut m = set(&out);
    m.complete = false;
    m.files.retain(|f| f.path == "hive.tracks.csv");
    m.replacing = vec!["hive.glb".to_owned(), "hive.usda".to_owned()];
    std::fs::write(
        out.join("hive.beeswarm.json"),
        serde_json::to_string(&m).unwrap(),
    )
    .unwrap();
    assert!(cache_set::verify(&out, "hive").is_err(), "not a whole set");
    let text = check_csv(dir.path());
    assert!(text.contains("stopped while replacing"), "{text}");
    assert!(
        text.contains("hive.glb: removed") && text.contains("hive.usda: removed"),
        "check lists what the bake would remove: {text}"
    );
    let stderr = baked(dir.path(), &["--format", "csv"]);
    assert!(stderr.contains("stopped while replacing"), "{stderr}");
    assert_eq!(files_under(&out), listed(&set(&out)));
    assert_eq!(files_under(&out), ["hive.beeswarm.json", "hive.tracks.csv"]);
}

#[test]
fn a_second_bake_of_the_same_shot_into_the_same_folder_is_refused_while_the_first_runs() {
    let (dir, out) = setup();
    std::fs::create_dir_all(&out).unwrap();
    baked(dir.path(), &["--format", "csv"]);
    let before = set(&out);
    // Held as a running bake holds it (the lock is per process, not per thread, so the
    // binary, another process, sees it).
    let held = cache_set::lock(&out, "hive").unwrap();
    let (code, stderr) = bake(dir.path(), &["--format", "csv", "--seed", "9"]);
    assert_eq!(code, 1, "{stderr}");
    let pid = std::process::id().to_string();
    assert!(
        stderr.contains("another bake") && stderr.contains(&pid) && stderr.contains("--out"),
        "{stderr}"
    );
    assert_eq!(set(&out), before, "the refused bake touched the set");
    // Another shot into the same folder is not held up.
    std::fs::write(
        dir.path().join("other.toml"),
        SHOT.replace("\"hive\"", "\"other\""),
    )
    .unwrap();
    let other = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .current_dir(dir.path())
        .args(["bake", "other.toml", "--out", "out", "--format", "csv"])
        .args(["--progress", "none"])
        .output()
        .unwrap();
    common::assert_succeeded(&other);
    drop(held);
    assert!(!cache_set::lock_path(&out, "hive").exists());
    baked(dir.path(), &["--format", "csv", "--seed", "9"]);
    assert_ne!(set(&out), before);
    assert!(
        !cache_set::lock_path(&out, "hive").exists(),
        "a finished bake leaves its lock file behind"
    );
}

#[test]
fn a_lock_file_left_by_a_killed_bake_does_not_block_the_next() {
    let (dir, out) = setup();
    std::fs::create_dir_all(&out).unwrap();
    // What `kill -9` leaves: the file, with a process id, but no lock (the system drops
    // it with the process).
    std::fs::write(cache_set::lock_path(&out, "hive"), "4194303\n").unwrap();
    baked(dir.path(), &["--format", "csv"]);
    set(&out);
    assert!(!cache_set::lock_path(&out, "hive").exists());
}
