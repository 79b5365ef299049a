//! `beeswarm check` is the dry run of `bake`: the same options, the files it would write
//! and replace, and what it would cost, with nothing written.

use std::process::Command;

fn run(dir: &std::path::Path, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    (
        out.status.code().unwrap(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn check_takes_the_bake_options_and_lists_what_would_be_written_and_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("hive.toml"),
        "[scene]\nframes = [1, 240]\n[[swarm]]\ncount = 1000\n",
    )
    .unwrap();
    std::fs::create_dir(p.join("caches")).unwrap();
    std::fs::write(p.join("caches/hive.tracks.csv"), "old").unwrap();
    let (code, out, err) = run(
        p,
        &[
            "check",
            "hive.toml",
            "--frames",
            "1:48",
            "--format",
            "usda,csv",
            "--out",
            "caches",
            "--preview",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("frames 1–48 (48 frames"), "{out}");
    assert!(out.contains("a bake would write into caches:"), "{out}");
    assert!(out.contains("hive.usda: about 9 MB\n"), "{out}");
    assert!(
        out.contains("hive.tracks.csv: about 8 MB (replaces the existing file)"),
        "{out}"
    );
    assert!(out.contains("hive.preview.png"), "{out}");
    assert!(
        !out.contains("hive.glb"),
        "--format replaced the shot's formats: {out}"
    );
    assert!(
        out.contains("predicted: about") && out.contains("of memory") && out.contains("of disk"),
        "{out}"
    );
    // A dry run: nothing written, nothing replaced.
    assert_eq!(
        std::fs::read_to_string(p.join("caches/hive.tracks.csv")).unwrap(),
        "old"
    );
    assert_eq!(std::fs::read_dir(p.join("caches")).unwrap().count(), 1);
    // Large caches are announced as value clips.
    std::fs::write(
        p.join("big.toml"),
        "[scene]\nframes = [1, 240]\n[[swarm]]\ncount = 100000\n",
    )
    .unwrap();
    let (code, out, err) = run(p, &["check", "big.toml", "--format", "usda"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("big.usda + big.clips/ (18 clip layers of 14 frames): about 4.3 GB"),
        "{out}"
    );
    // What would stop the bake stops the check.
    let (code, _, err) = run(p, &["check", "hive.toml", "--threads", "100000"]);
    assert_eq!(code, 2);
    assert!(err.contains("--threads"), "{err}");
}
