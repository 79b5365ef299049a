//! Output into a pipe whose reader has gone (`beeswarm … | head`) is dropped, never a
//! panic: the command finishes its work and exits as it would have.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

/// Runs beeswarm with stdout piped, reads `keep` lines (0: none), closes the pipe, and
/// returns (exit code, stderr).
fn with_closed_stdout(dir: &std::path::Path, args: &[&str], keep: usize) -> (i32, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let mut lines = BufReader::new(stdout).lines();
    for _ in 0..keep {
        lines.next().expect("a line").unwrap();
    }
    drop(lines);
    let out = child.wait_with_output().unwrap();
    (
        out.status.code().expect("exited, not killed by a signal"),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bake_progress_into_a_closed_pipe_finishes_the_bake() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("shot.toml"),
        "[scene]\nframes = [1, 60]\n[[swarm]]\ncount = 200\n",
    )
    .unwrap();
    // One progress line read, then the reader leaves; 59 more lines and "done" follow.
    let (code, stderr) = with_closed_stdout(
        dir.path(),
        &["bake", "shot.toml", "--format", "csv", "--progress", "json"],
        1,
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        dir.path().join("out/shot.tracks.csv").is_file(),
        "the cache was still written"
    );
}

#[test]
fn bench_models_and_check_into_a_closed_pipe_do_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), "[[swarm]]\ncount = 3\n").unwrap();
    for args in [
        &["bench", "--bees", "200", "--frames", "4"][..],
        &["models"][..],
        &["models", "--json"][..],
        &["check", "shot.toml"][..],
    ] {
        let (code, stderr) = with_closed_stdout(dir.path(), args, 0);
        assert_eq!(code, 0, "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}
