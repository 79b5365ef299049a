//! Shots over the limits a user can raise (issue 16): `check` and `bake` refuse them with
//! a located error (exit 2) giving the figures and the flag, `--allow-large`.

use std::path::Path;
use std::process::Command;

fn run(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_cache_larger_than_the_free_disk_is_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    // 10⁶ bees × 10⁵ frames of CSV: about 16 TB, more than any test machine has free.
    std::fs::write(
        dir.path().join("shot.toml"),
        "[scene]\nframes = [1, 100000]\n[[swarm]]\ncount = 1000000\n",
    )
    .unwrap();
    let (code, _, stderr) = run(dir.path(), &["check", "shot.toml", "--format", "csv"]);
    assert_eq!(code, 2, "{stderr}");
    for part in [
        "shot.toml:4:9: key `swarm[0].count`",
        "a bake of 1000000 bees × 100000 frames needs about 16.3 TB of disk while it runs",
        "free",
        "pass --allow-large",
    ] {
        assert!(stderr.contains(part), "{part:?} in {stderr}");
    }
    let (code, stdout, stderr) = run(
        dir.path(),
        &["check", "shot.toml", "--format", "csv", "--allow-large"],
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("16.3 TB of disk"), "{stdout}");
}

/// Memory the system will not give is an error naming the count (exit 2), not an abort:
/// check and bake run with their address space capped at 1.5 GB (`setrlimit`, as `ulimit -v`
/// does), below the 2.6 GB a million bees with glTF and USDA need.
#[cfg(target_os = "linux")]
#[test]
fn memory_the_system_refuses_is_an_error_not_an_abort() {
    use std::os::unix::process::CommandExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("shot.toml"),
        "[scene]\nframes = [1, 2]\n[[swarm]]\ncount = 1000000\n",
    )
    .unwrap();
    // check refuses it first, as bake does.
    for command in ["check", "bake"] {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_beeswarm"));
        cmd.current_dir(dir.path()).args([
            command,
            "shot.toml",
            "--format",
            "glb,usda",
            "--progress",
            "none",
        ]);
        // SAFETY: only setrlimit, which is async-signal-safe, runs between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                let limit = libc::rlimit {
                    rlim_cur: 1_500_000_000,
                    rlim_max: 1_500_000_000,
                };
                if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let out = cmd.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{command}: {stderr}");
        for part in [
            "shot.toml:4:9: key `swarm[0].count`",
            "a bake of 1000000 bees needs about 2.6 GB of memory, and the system refused to allocate it",
        ] {
            assert!(stderr.contains(part), "{command}: {part:?} in {stderr}");
        }
        assert!(!dir.path().join("out").exists(), "nothing written");
    }
}
