//! The command line's answers to bad input, run on the real binary: every message names
//! the file, line, column and key and says what was expected; exit code 2 for a bad shot
//! or argument, 1 for a failure while baking; never a panic; never an output file.

mod common;
use common::files_under;
use std::path::Path;
use std::process::Command;
use tempfile::TempDir;

/// What one run of the binary did.
struct Run {
    code: i32,
    stdout: String,
    stderr: String,
}

/// Runs `beeswarm args…` in `dir`.
fn beeswarm(dir: &Path, args: &[&str]) -> Run {
    beeswarm_with(dir, args, None)
}

/// [`beeswarm`] with `BEESWARM_SIMD` set to `simd` (unset for `None`).
fn beeswarm_with(dir: &Path, args: &[&str], simd: Option<&str>) -> Run {
    let mut command = Command::new(env!("CARGO_BIN_EXE_beeswarm"));
    match simd {
        Some(v) => command.env(beeswarm::simd::ENV, v),
        None => command.env_remove(beeswarm::simd::ENV),
    };
    let out = command
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the beeswarm binary runs");
    let run = Run {
        code: out.status.code().expect("exited, not killed by a signal"),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    };
    for marker in ["panicked", "RUST_BACKTRACE", "stack backtrace"] {
        assert!(
            !run.stderr.contains(marker) && !run.stdout.contains(marker),
            "beeswarm {args:?} must not panic:\n{}",
            run.stderr
        );
    }
    run
}

/// Asserts that the folder holds exactly `expected` files (the inputs, or the inputs and
/// a bake's set): nothing else was written.
fn assert_only(dir: &Path, expected: &[&str]) {
    let mut want: Vec<String> = expected.iter().map(|f| f.to_string()).collect();
    want.sort();
    assert_eq!(files_under(dir), want, "no output file may appear");
}

/// Asserts that `text` contains every one of `parts`.
#[track_caller]
fn assert_says(text: &str, parts: &[&str]) {
    for p in parts {
        assert!(
            text.contains(p),
            "expected the message to contain {p:?}:\n{text}"
        );
    }
}

/// Writes `src` as `shot.toml` in a fresh folder, bakes it as CSV into `out/` and checks
/// it with `beeswarm check`. Both must refuse it with exit code 2, the same message, and
/// no file written. Returns the bake's stderr.
fn refuse(src: impl AsRef<[u8]>) -> String {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), src).unwrap();
    let bake = beeswarm(
        dir.path(),
        &["bake", "shot.toml", "--out", "out", "--format", "csv"],
    );
    assert_eq!(bake.code, 2, "bad shot → exit 2:\n{}", bake.stderr);
    assert!(
        bake.stderr.starts_with("error: shot.toml"),
        "{}",
        bake.stderr
    );
    let check = beeswarm(dir.path(), &["check", "shot.toml"]);
    assert_eq!(check.code, 2, "{}", check.stderr);
    assert_eq!(check.stderr, bake.stderr, "check and bake report alike");
    assert_eq!(check.stdout, "", "check prints no summary for a bad shot");
    assert_only(dir.path(), &["shot.toml"]);
    assert!(!dir.path().join("out").exists(), "not even the folder");
    bake.stderr
}

/// The line of an error message that shows the source, and the caret line below it.
fn caret_column(stderr: &str) -> usize {
    let caret = stderr
        .lines()
        .find(|l| l.trim_end().ends_with('^') && l.contains('|'))
        .unwrap_or_else(|| panic!("no caret line:\n{stderr}"));
    caret.find('^').unwrap()
}

#[test]
fn a_valid_shot_bakes_with_exit_0_and_writes_the_tracks() {
    // The control for everything below: the same harness accepts a good shot.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("shot.toml"),
        "[scene]\nframes = [1, 3]\n[[swarm]]\ncount = 4\n",
    )
    .unwrap();
    let run = beeswarm(
        dir.path(),
        &["bake", "shot.toml", "--out", "out", "--format", "csv"],
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert_only(
        dir.path(),
        &["shot.toml", "out/shot.tracks.csv", "out/shot.beeswarm.json"],
    );
    let csv = std::fs::read_to_string(dir.path().join("out/shot.tracks.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 4 * 3);
}

#[test]
fn missing_shot_file() {
    let dir = tempfile::tempdir().unwrap();
    let run = beeswarm(
        dir.path(),
        &["bake", "nope.toml", "--out", "out", "--format", "csv"],
    );
    assert_eq!(run.code, 2);
    assert_says(
        &run.stderr,
        &["error: nope.toml: no such shot file", "hint:"],
    );
    assert_only(dir.path(), &[]);
    assert_eq!(beeswarm(dir.path(), &["check", "nope.toml"]).code, 2);
}

#[test]
fn a_folder_given_as_the_shot() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("shots")).unwrap();
    let run = beeswarm(dir.path(), &["check", "shots"]);
    assert_eq!(run.code, 2);
    assert_says(&run.stderr, &["shots: this is a folder, not a shot file"]);
    let run = beeswarm(
        dir.path(),
        &["bake", "shots", "--out", "out", "--format", "csv"],
    );
    assert_eq!(run.code, 2);
    assert_says(&run.stderr, &["shots: this is a folder, not a shot file"]);
    assert_only(dir.path(), &[]);
    assert!(!dir.path().join("out").exists());
}

#[test]
fn binary_garbage_is_located_at_its_first_bad_byte() {
    let mut bytes = b"[[swarm]]\ncount = 3\nname = \"ab".to_vec();
    bytes.extend_from_slice(&[0xff, 0xfe, 0x00, 0x9c, b'\n']);
    let err = refuse(bytes);
    assert_says(
        &err,
        &[
            "shot.toml:3:11:",
            "not a text file: byte 0xff is not UTF-8",
            "expected TOML text in UTF-8",
            "hint:",
        ],
    );
}

#[test]
fn control_characters_are_not_toml_and_are_not_echoed() {
    let err = refuse(b"\x00\x01\x1b[2J garbage\n");
    assert_says(&err, &["shot.toml:1:1:", "not valid TOML"]);
    assert!(
        !err.contains('\x1b') && !err.contains('\0'),
        "raw control characters would garble the terminal: {err:?}"
    );
}

#[test]
fn unterminated_table_header() {
    let err = refuse("[[swarm\ncount = 3\n");
    assert_says(
        &err,
        &[
            "shot.toml:1:8:",
            "not valid TOML: invalid table header",
            "expected `.`, `]]`",
            " 1 | [[swarm",
        ],
    );
    // One line of message, then the source line, then the caret under column 8.
    assert_eq!(err.lines().count(), 3, "{err}");
    assert_eq!(caret_column(&err), " 1 | [[swarm".len());
}

#[test]
fn unknown_key_names_the_path_lists_the_known_keys_and_suggests_one() {
    let err = refuse("[[swarm]]\ncuont = 3\n");
    assert_says(
        &err,
        &[
            "shot.toml:2:1:",
            "key `swarm[0].cuont`",
            "unknown field `cuont`",
            "expected one of `name`, `count`",
            "hint: did you mean `count`?",
            " 2 | cuont = 3",
        ],
    );
}

#[test]
fn unknown_keys_in_inline_tables_and_top_level_tables() {
    let err = refuse("[[swarm]]\ncount = 3\nspawn = { centre = [0, 1, 0] }\n");
    assert_says(
        &err,
        &[
            "shot.toml:3:11:",
            "key `swarm[0].spawn.centre`",
            "did you mean `center`?",
        ],
    );
    let err = refuse("[sceen]\nfps = 30\n[[swarm]]\ncount = 3\n");
    assert_says(
        &err,
        &["shot.toml:1:2:", "key `sceen`", "did you mean `scene`?"],
    );
    let err = refuse("[[swarm]]\ncount = 3\n[output]\nformat = [\"csv\"]\n");
    assert_says(
        &err,
        &[
            "shot.toml:4:1:",
            "key `output.format`",
            "did you mean `formats`?",
        ],
    );
    // Nothing close: no wild guess.
    let err = refuse("[[swarm]]\ncount = 3\nzzzzzzzz = 1\n");
    assert_says(&err, &["key `swarm[0].zzzzzzzz`", "check the spelling"]);
    assert!(!err.contains("did you mean"), "{err}");
}

#[test]
fn wrong_type() {
    let err = refuse("[[swarm]]\ncount = \"many\"\n");
    assert_says(
        &err,
        &[
            "shot.toml:2:9:",
            "key `swarm[0].count`",
            "invalid type: string \"many\", expected a whole number",
        ],
    );
    assert_eq!(caret_column(&err), " 2 | count = ".len());
    let err = refuse("[[swarm]]\ncount = 3\nspawn = { center = [0, 1] }\n");
    assert_says(
        &err,
        &[
            "shot.toml:3:20:",
            "key `swarm[0].spawn.center`",
            "expected a list of three numbers [x, y, z]",
        ],
    );
}

#[test]
fn negative_and_zero_counts() {
    for (count, col) in [("-5", 9), ("0", 9)] {
        let err = refuse(format!("[scene]\nfps = 24\n[[swarm]]\ncount = {count}\n"));
        assert_says(
            &err,
            &[
                &format!("shot.toml:4:{col}:"),
                "key `swarm[0].count`",
                &format!("expected at least 1 bee, found {count}"),
                "hint: remove the swarm",
            ],
        );
    }
    // The second swarm is named by its index.
    let err = refuse("[[swarm]]\ncount = 3\n[[swarm]]\nname = \"b\"\ncount = -1\n");
    assert_says(&err, &["shot.toml:5:9:", "key `swarm[1].count`"]);
}

#[test]
fn missing_count_and_missing_swarm() {
    let err = refuse("[[swarm]]\nname = \"a\"\n");
    assert_says(
        &err,
        &[
            "shot.toml:1:1:",
            "key `swarm[0].count`",
            "missing key `count`: expected the number of bees",
        ],
    );
    let err = refuse("[scene]\nfps = 24\n");
    assert_says(
        &err,
        &[
            "key `swarm`",
            "the shot has no swarm",
            "hint: add one",
            "count = 200",
        ],
    );
}

#[test]
fn reversed_frame_range() {
    let err = refuse("[scene]\nframes = [120, 1]\n[[swarm]]\ncount = 3\n");
    assert_says(
        &err,
        &[
            "shot.toml:2:10:",
            "key `scene.frames`",
            "the frame range is reversed: [120, 1]",
            "hint: write frames = [1, 120]",
        ],
    );
}

#[test]
fn zero_fps() {
    let err = refuse("[scene]\nfps = 0\n[[swarm]]\ncount = 3\n");
    assert_says(
        &err,
        &[
            "shot.toml:2:7:",
            "key `scene.fps`",
            "expected frames per second between 1 and 1000, found 0",
        ],
    );
}

#[test]
fn nan_and_infinite_numbers() {
    let err = refuse("[scene]\nfps = nan\n[[swarm]]\ncount = 3\n");
    assert_says(
        &err,
        &[
            "shot.toml:2:7:",
            "key `scene.fps`",
            "expected a finite number, found nan",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\nspawn = { shape = \"sphere\", radius = inf }\n");
    assert_says(
        &err,
        &[
            "shot.toml:3:38:",
            "key `swarm[0].spawn.radius`",
            "expected a finite number, found inf",
        ],
    );
    let err = refuse(
        "[[swarm]]\ncount = 3\n[[obstacle]]\ntype = \"sphere\"\ncenter = [0, -inf, 0]\nradius = 1\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:5:14:",
            "key `obstacle[0].center[1]`",
            "found -inf",
        ],
    );
    // A whole number cannot be nan either, and says what it expected.
    let err = refuse("[[swarm]]\ncount = nan\n");
    assert_says(
        &err,
        &[
            "shot.toml:2:9:",
            "key `swarm[0].count`",
            "expected a whole number",
        ],
    );
}

#[test]
fn spawn_region_inside_an_obstacle() {
    let err = refuse(
        "[[swarm]]\ncount = 3\nspawn = { center = [0, 1, 0], size = [0.2, 0.2, 0.2] }\n\n[[obstacle]]\ntype = \"sphere\"\ncenter = [0, 1, 0]\nradius = 1\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:3:9:",
            "key `swarm[0].spawn`",
            "the spawn region lies entirely inside obstacles",
            "hint: move the spawn centre",
        ],
    );
}

#[test]
fn a_key_of_the_other_spawn_shape() {
    // `radius` without `shape = "sphere"` would otherwise be ignored for the default box.
    let err = refuse("[[swarm]]\ncount = 3\nspawn = { center = [0, 1, 0], radius = 0.5 }\n");
    assert_says(
        &err,
        &[
            "shot.toml:3:40:",
            "key `swarm[0].spawn.radius`",
            "a box spawn region has no `radius`",
            "hint: a box takes center and size; for a sphere write shape = \"sphere\"",
        ],
    );
    let err = refuse(
        "[[swarm]]\ncount = 3\n[swarm.spawn]\nshape = \"sphere\"\nradius = 0.5\nsize = [1, 1, 1]\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:6:8:",
            "key `swarm[0].spawn.size`",
            "a sphere spawn region has no `size`",
        ],
    );
}

#[test]
fn values_out_of_range_say_the_range() {
    let err = refuse("[[swarm]]\ncount = 3\nparams = { kappa1 = 200 }\n");
    assert_says(
        &err,
        &[
            "shot.toml:3:21:",
            "key `swarm[0].params.kappa1`",
            "expected a weight from 0 to 100, found 200",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\npreset = \"meadow\"\n");
    assert_says(
        &err,
        &[
            "shot.toml:3:10:",
            "key `swarm[0].preset`",
            "the bee model has no preset \"meadow\": expected one of \"nest\", \"grassland\", \"optimized\" or a preset file",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\n[output]\nformats = [\"csv\", \"fbx\"]\n");
    assert_says(
        &err,
        &[
            "shot.toml:4:19:",
            "key `output.formats[1]`",
            "expected one of \"glb\", \"gltf\", \"usda\", \"csv\", found \"fbx\"",
        ],
    );
}

#[test]
fn keys_of_another_obstacle_type_and_unknown_swarm_names() {
    let err = refuse(
        "[[swarm]]\ncount = 3\n[[obstacle]]\ntype = \"sphere\"\ncenter = [0, 1, 0]\nradius = 0.1\nheight = 2\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:7:10:",
            "key `obstacle[0].height`",
            "a sphere has no `height`",
            "hint: a sphere takes center, radius",
        ],
    );
    let err = refuse(
        "[[swarm]]\nname = \"bees\"\ncount = 3\n[[target]]\nposition = [0, 1, 0]\nswarms = [\"bes\"]\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:6:11:",
            "key `target[0].swarms[0]`",
            "no swarm named \"bes\"; the shot has \"bees\"",
        ],
    );
}

#[test]
fn a_normal_belongs_to_a_surface_target_and_is_not_zero() {
    let err =
        refuse("[[swarm]]\ncount = 3\n[[target]]\nposition = [0, 1, 0]\nnormal = [0, 1, 0]\n");
    assert_says(
        &err,
        &[
            "shot.toml:5:10:",
            "key `target[0].normal`",
            "an attractor target has no `normal`",
            "hint: type = \"surface\"",
        ],
    );
    let err = refuse(
        "[[swarm]]\ncount = 3\n[[target]]\ntype = \"surface\"\nposition = [0, 0, 0]\nnormal = [0, 0, 0]\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:6:10:",
            "key `target[0].normal`",
            "expected a non-zero normal",
        ],
    );
}

#[test]
fn landing_keys_belong_to_nests_and_flowers() {
    let err = refuse("[[swarm]]\ncount = 3\n[[target]]\nposition = [0, 1, 0]\nland = true\n");
    assert_says(
        &err,
        &[
            "shot.toml:5:8:",
            "key `target[0].land`",
            "bees cannot land on an attractor",
            "hint: `land = true` is for a nest or a flower",
        ],
    );
    let err = refuse(
        "[[swarm]]\ncount = 3\n[[target]]\ntype = \"flower\"\nposition = [0, 1, 0]\nstay = [2, 6]\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:6:8:",
            "key `target[0].stay`",
            "this target has no `land = true`",
        ],
    );
    let err = refuse(
        "[[swarm]]\ncount = 3\n[[target]]\ntype = \"flower\"\nposition = [0, 1, 0]\nland = true\nstay = [6, 2]\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:7:8:",
            "key `target[0].stay`",
            "expected [min, max] seconds with 0 <= min <= max <= 3600, found [6.0, 2.0]",
        ],
    );
}

#[test]
fn hive_keys_belong_to_nests_with_landing_and_bee_swarms() {
    let err = refuse(
        "[[swarm]]\ncount = 3\n[[target]]\ntype = \"flower\"\nposition = [0, 1, 0]\nland = true\ninside = [5, 10]\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:7:10:",
            "key `target[0].inside`",
            "bees cannot go inside a flower",
            "hint: `inside` is for a nest (a hive entrance) with `land = true`",
        ],
    );
    let err = refuse(
        "[[swarm]]\ncount = 3\n[[target]]\ntype = \"nest\"\nposition = [0, 1, 0]\ninside = [5, 10]\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:6:10:",
            "key `target[0].inside`",
            "this nest has no `land = true`",
            "hint: add `land = true`",
        ],
    );
    let err = refuse(
        "[[swarm]]\ncount = 3\n[[target]]\ntype = \"nest\"\nposition = [0, 1, 0]\nland = true\ninside = [10, -1]\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:7:10:",
            "key `target[0].inside`",
            "expected [min, max] seconds with 0 <= min <= max <= 3600, found [10.0, -1.0]",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\nstart_inside = 1.5\n");
    assert_says(
        &err,
        &[
            "shot.toml:3:16:",
            "key `swarm[0].start_inside`",
            "expected a fraction of the swarm from 0 to 1, found 1.5",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\nstart_inside = 0.5\n");
    assert_says(
        &err,
        &[
            "shot.toml:3:16:",
            "key `swarm[0].start_inside`",
            "no nest with `inside` attracts this swarm",
        ],
    );
    let err = refuse(
        "[[swarm]]\ncount = 3\nmodel = \"boids\"\nstart_inside = 0.5\n[[target]]\ntype = \"nest\"\nposition = [0, 1, 0]\nland = true\ninside = [5, 10]\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:4:16:",
            "key `swarm[0].start_inside`",
            "only bees go inside a hive, and this swarm flies with the `boids` model",
        ],
    );
}

#[test]
fn preset_files_missing_or_bad() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("shot.toml"),
        "[[swarm]]\ncount = 3\npreset = \"meadow.toml\"\n",
    )
    .unwrap();
    let run = beeswarm(p, &["check", "shot.toml"]);
    assert_eq!(run.code, 2);
    assert_says(
        &run.stderr,
        &[
            "shot.toml:3:10:",
            "key `swarm[0].preset`",
            "cannot read the preset file meadow.toml",
            "hint: built-in presets",
        ],
    );
    std::fs::write(
        p.join("meadow.toml"),
        "[preset]\nname = \"meadow\"\nbase = \"grassland\"\n\n[params]\nkapa1 = 2\n",
    )
    .unwrap();
    let run = beeswarm(p, &["check", "shot.toml"]);
    assert_eq!(run.code, 2);
    assert_says(
        &run.stderr,
        &[
            "shot.toml:3:10:",
            "the preset file \"meadow.toml\" has an error",
            "meadow.toml:6:1: key `params.kapa1`",
            "did you mean `kappa1`?",
        ],
    );
    assert_only(p, &["shot.toml", "meadow.toml"]);
}

#[test]
fn output_folder_under_a_regular_file() {
    // Tests run as root, so a read-only folder would not stop the write: use a path whose
    // parent is a file.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("shot.toml"), "[[swarm]]\ncount = 3\n").unwrap();
    std::fs::write(p.join("notes.txt"), "a file, not a folder").unwrap();
    let run = beeswarm(
        p,
        &[
            "bake",
            "shot.toml",
            "--out",
            "notes.txt/caches",
            "--format",
            "csv",
        ],
    );
    assert_eq!(
        run.code, 2,
        "an unusable --out is bad input:\n{}",
        run.stderr
    );
    assert_says(
        &run.stderr,
        &[
            "error: cannot create the output folder notes.txt/caches (--out): notes.txt is a file, not a folder",
        ],
    );
    // The file itself as the folder.
    let run = beeswarm(
        p,
        &["bake", "shot.toml", "--out", "notes.txt", "--format", "csv"],
    );
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert_says(
        &run.stderr,
        &["error: the output folder notes.txt (--out) is a file, not a folder"],
    );
    // The same folder given by the shot's [output] dir.
    std::fs::write(
        p.join("shot.toml"),
        "[[swarm]]\ncount = 3\n[output]\ndir = \"notes.txt/caches\"\nformats = [\"csv\"]\n",
    )
    .unwrap();
    let run = beeswarm(p, &["bake", "shot.toml"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert_says(
        &run.stderr,
        &["notes.txt/caches (the shot's [output] dir): notes.txt is a file, not a folder"],
    );
    assert_only(p, &["shot.toml", "notes.txt"]);
    assert_eq!(
        std::fs::read_to_string(p.join("notes.txt")).unwrap(),
        "a file, not a folder"
    );
}

#[test]
fn a_failure_while_baking_exits_1_and_leaves_no_file() {
    // A folder sits where the tracks file must go: the bake runs, then cannot write.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("shot.toml"),
        "[scene]\nframes = [1, 4]\n[[swarm]]\ncount = 3\n",
    )
    .unwrap();
    std::fs::create_dir_all(p.join("out/shot.tracks.csv")).unwrap();
    let run = beeswarm(p, &["bake", "shot.toml", "--out", "out", "--format", "csv"]);
    assert_eq!(
        run.code, 1,
        "a failure while baking → exit 1:\n{}",
        run.stderr
    );
    assert_says(
        &run.stderr,
        &[
            "error: cannot write out/shot.tracks.csv",
            "a folder stands there",
        ],
    );
    assert!(p.join("out/shot.tracks.csv").is_dir());
    // No temporary file left behind either.
    assert_only(p, &["shot.toml"]);
}

#[test]
fn a_failure_in_one_format_leaves_every_previous_cache_untouched() {
    // The previous CSV cache exists; a folder blocks the glb. Nothing may be replaced,
    // not even the CSV that could have been written.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("shot.toml"),
        "[scene]\nframes = [1, 4]\n[[swarm]]\ncount = 3\n",
    )
    .unwrap();
    std::fs::create_dir_all(p.join("out/shot.glb")).unwrap();
    std::fs::write(p.join("out/shot.tracks.csv"), "previous cache").unwrap();
    let run = beeswarm(
        p,
        &["bake", "shot.toml", "--out", "out", "--format", "csv,glb"],
    );
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert_says(&run.stderr, &["cannot write out/shot.glb"]);
    assert_eq!(
        std::fs::read_to_string(p.join("out/shot.tracks.csv")).unwrap(),
        "previous cache"
    );
    assert_only(p, &["shot.toml", "out/shot.tracks.csv"]);
}

/// Bakes a good shot with `args` appended; returns the run and the folder.
fn bake_with(args: &[&str]) -> (Run, TempDir) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("shot.toml"),
        "[scene]\nframes = [1, 3]\n[[swarm]]\ncount = 3\n",
    )
    .unwrap();
    let mut all = vec!["bake", "shot.toml", "--out", "out"];
    all.extend_from_slice(args);
    (beeswarm(dir.path(), &all), dir)
}

#[test]
fn bad_frames_arguments() {
    for (arg, says) in [
        ("10:1", "the frame range 10:1 is reversed; write 1:10"),
        ("abc", "expected START:END, e.g. 1:120, found \"abc\""),
        ("1:", "expected a whole end frame, found \"\""),
        ("x:5", "expected a whole start frame, found \"x\""),
        ("1.5:3", "expected a whole start frame"),
        (
            "-2000000000:2000000000",
            "expected at most 100000 frames within ±1000000",
        ),
    ] {
        let (run, dir) = bake_with(&["--format", "csv", "--frames", arg]);
        assert_eq!(run.code, 2, "--frames {arg}:\n{}", run.stderr);
        assert_says(
            &run.stderr,
            &[
                &format!("invalid value '{arg}' for '--frames <FRAMES>'"),
                says,
            ],
        );
        assert_only(dir.path(), &["shot.toml"]);
    }
}

#[test]
fn bad_format_arguments() {
    for (arg, bad) in [("fbx", "fbx"), ("csv,abc", "abc"), ("", ""), ("csv,", "")] {
        let (run, dir) = bake_with(&["--frames", "1:2", "--format", arg]);
        assert_eq!(run.code, 2, "--format {arg:?}:\n{}", run.stderr);
        assert_says(
            &run.stderr,
            &[
                "'--format <FORMAT>'",
                &format!("unknown format \"{bad}\": expected glb, gltf, usda or csv"),
            ],
        );
        assert_only(dir.path(), &["shot.toml"]);
    }
}

#[test]
fn unknown_arguments_and_commands() {
    let (run, dir) = bake_with(&["--fromat", "csv"]);
    assert_eq!(run.code, 2);
    assert_says(&run.stderr, &["unexpected argument '--fromat'", "--format"]);
    assert_only(dir.path(), &["shot.toml"]);
    let run = beeswarm(dir.path(), &["bkae"]);
    assert_eq!(run.code, 2);
    assert_says(&run.stderr, &["unrecognized subcommand 'bkae'", "bake"]);
    let run = beeswarm(dir.path(), &["bench", "--bees", "0"]);
    assert_eq!(run.code, 2);
    assert_says(&run.stderr, &["--bees and --frames must be at least 1"]);
}

/// `bench` prints one JSON line: its figures, and which wide paths ran (figures from
/// different levels do not compare), which `BEESWARM_SIMD` caps; a cap that names no
/// level is an error before anything runs.
#[test]
fn bench_prints_its_figures_and_which_wide_paths_ran() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["bench", "--bees", "50", "--frames", "1", "--threads", "1"];
    let json = |run: &Run| -> serde_json::Value {
        assert_eq!(run.code, 0, "{}", run.stderr);
        serde_json::from_str(run.stdout.trim()).unwrap()
    };
    let v = json(&beeswarm_with(dir.path(), &args, None));
    assert_eq!(v["bees"], 50);
    assert_eq!(v["bee_steps"], 200.0);
    assert!(v["ns_per_bee_step"].as_f64().is_some_and(|ns| ns > 0.0));
    assert_eq!(v["simd"], beeswarm::simd::detected().name());
    let v = json(&beeswarm_with(dir.path(), &args, Some("portable")));
    assert_eq!(v["simd"], "portable");
    let v = json(&beeswarm_with(dir.path(), &args, Some("native")));
    assert_eq!(v["simd"], beeswarm::simd::detected().name());
    let run = beeswarm_with(dir.path(), &args, Some("avx512f"));
    assert_eq!(run.code, 2);
    assert_says(
        &run.stderr,
        &[
            "BEESWARM_SIMD is \"avx512f\"",
            "expected portable, avx2 or native",
        ],
    );
    assert!(run.stdout.is_empty(), "{}", run.stdout);
}

#[test]
fn good_arguments_are_accepted() {
    // Repeated and mixed-case formats, negative frames: exit 0 and exactly the CSV.
    let (run, dir) = bake_with(&["--format", "CSV,csv", "--frames", "-2:1"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert_only(
        dir.path(),
        &["shot.toml", "out/shot.tracks.csv", "out/shot.beeswarm.json"],
    );
    let csv = std::fs::read_to_string(dir.path().join("out/shot.tracks.csv")).unwrap();
    let frames: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(frames.len(), 3 * 4);
    assert_eq!((frames[0], frames[frames.len() - 1]), ("-2", "1"));
}

#[test]
fn bad_bench_options_name_the_option() {
    let dir = tempfile::tempdir().unwrap();
    for (args, says) in [
        (
            &["--substeps", "0"][..],
            "error: --substeps: expected a whole number of substeps from 1 to 64, found 0",
        ),
        (
            &["--preset", "meadow"][..],
            "error: --preset: the bee model has no preset \"meadow\": expected one of \"nest\", \"grassland\", \"optimized\"",
        ),
        (
            &["--frames", "200000"][..],
            "error: --frames: expected at most 100000 frames",
        ),
        (
            &["--model", "wasp"][..],
            "error: --model: expected one of \"bee\", \"curl\", \"brownian\", \"boids\", \"field\", \"fastswarm\", \"zonal\", \"butterfly\", found \"wasp\"",
        ),
        (
            &["--model", "boids", "--preset", "nest"][..],
            "error: --preset: the boids model has no preset \"nest\"",
        ),
        (
            &["--density", "0"][..],
            "error: --density: expected bees per cubic metre from 0.001 to 1e7, found 0",
        ),
        (
            &["--containment", "2000"][..],
            "error: --containment: expected an acceleration from 0 to 1000, found 2000",
        ),
        (
            &["--containment", "NaN"][..],
            "error: --containment: expected an acceleration from 0 to 1000, found NaN",
        ),
    ] {
        let mut all = vec!["bench", "--bees", "10"];
        all.extend_from_slice(args);
        if !args.contains(&"--frames") {
            all.extend_from_slice(&["--frames", "2"]);
        }
        let run = beeswarm(dir.path(), &all);
        assert_eq!(run.code, 2, "{args:?}: {}", run.stderr);
        assert_says(&run.stderr, &[says]);
        assert!(!run.stderr.contains("<bench>"), "{}", run.stderr);
        assert_eq!(run.stdout, "", "no measurement printed");
    }
    assert_only(dir.path(), &[]);
}

#[test]
fn a_file_name_that_cannot_name_the_outputs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("my shot.toml"), "[[swarm]]\ncount = 3\n").unwrap();
    let run = beeswarm(
        dir.path(),
        &["bake", "my shot.toml", "--out", "out", "--format", "csv"],
    );
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert_says(
        &run.stderr,
        &[
            "error: my shot.toml: key `scene.name`",
            "the shot is named after its file, \"my shot\"",
            "hint: name it in the shot: [scene] name = \"my_shot\"",
        ],
    );
    assert_only(dir.path(), &["my shot.toml"]);
}

#[test]
fn wing_flap_above_half_the_frame_rate() {
    let err = refuse("[scene]\nfps = 30\n[[swarm]]\ncount = 3\n[output]\nwing_flap_hz = 20\n");
    assert_says(
        &err,
        &[
            "shot.toml:6:16:",
            "key `output.wing_flap_hz`",
            "up to half the frame rate (15 Hz at 30 fps), found 20",
        ],
    );
}

#[test]
fn wing_display_and_gltf_layout_must_be_known_names() {
    let err = refuse("[scene]\nfps = 30\n[[swarm]]\ncount = 3\n[output]\nwings = \"fast\"\n");
    assert_says(
        &err,
        &[
            "key `output.wings`",
            "expected one of \"still\", \"blur\", \"flap\", found \"fast\"",
        ],
    );
    let err = refuse("[scene]\nfps = 30\n[[swarm]]\ncount = 3\n[output]\ngltf_layout = \"flat\"\n");
    assert_says(
        &err,
        &[
            "key `output.gltf_layout`",
            "expected one of \"parts\", \"agent\", found \"flat\"",
        ],
    );
}

#[test]
fn a_flap_rate_with_wings_that_do_not_flap_is_refused() {
    let err = refuse(
        "[scene]\nfps = 30\n[[swarm]]\ncount = 3\n[output]\nwings = \"still\"\nwing_flap_hz = 5\n",
    );
    assert_says(
        &err,
        &[
            "shot.toml:7:16:",
            "key `output.wing_flap_hz`",
            "only applies to wings = \"flap\"",
        ],
    );
}

#[test]
fn eval_names_an_empty_path_in_a_pooled_list() {
    let dir = TempDir::new().unwrap();
    let run = beeswarm(
        dir.path(),
        &["eval", "model=a.csv,", "--reference", "real.csv"],
    );
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("model=a.csv,") && run.stderr.contains("found an empty one"),
        "{}",
        run.stderr
    );
}

#[test]
fn parameters_and_presets_are_checked_against_the_swarms_model() {
    // A bee parameter on a boids swarm: located at the key, naming the boids' parameters.
    let err =
        refuse("[[swarm]]\ncount = 3\nmodel = \"boids\"\nparams = { speed = 1, kappa1 = 2 }\n");
    assert_says(
        &err,
        &[
            "shot.toml:4:23:",
            "key `swarm[0].params.kappa1`",
            "the boids model has no parameter `kappa1`",
            "its parameters: speed, avoid_distance",
            "neighbour_radius",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\nmodel = \"curl\"\nparams = { sped = 2 }\n");
    assert_says(
        &err,
        &[
            "the curl model has no parameter `sped`",
            "did you mean `speed`?",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\nmodel = \"curl\"\npreset = \"nest\"\n");
    assert_says(
        &err,
        &[
            "key `swarm[0].preset`",
            "the curl model has no preset \"nest\"",
            "\"default\"",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\nmodel = \"wasp\"\n");
    assert_says(
        &err,
        &[
            "key `swarm[0].model`",
            "expected one of \"bee\", \"curl\", \"brownian\", \"boids\", \"field\"",
        ],
    );
    // A preset file written for another model.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("shot.toml"),
        "[[swarm]]\ncount = 3\nmodel = \"boids\"\npreset = \"fit.toml\"\n",
    )
    .unwrap();
    std::fs::write(
        p.join("fit.toml"),
        "[preset]\nname = \"fit\"\nmodel = \"bee\"\n[params]\nspeed = 2\n",
    )
    .unwrap();
    let run = beeswarm(p, &["check", "shot.toml"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert_says(
        &run.stderr,
        &[
            "the preset file \"fit.toml\" has an error",
            "this preset is for the bee model, the swarm flies the boids model",
        ],
    );
    // The same file for the right model loads, and sets the value.
    std::fs::write(
        p.join("fit.toml"),
        "[preset]\nname = \"fit\"\nmodel = \"boids\"\n[params]\nspeed = 2\n",
    )
    .unwrap();
    let run = beeswarm(p, &["check", "shot.toml"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(
        run.stdout.contains("model boids, preset fit.toml") && run.stdout.contains("speed 2 m/s"),
        "{}",
        run.stdout
    );
}

#[test]
fn fixed_length_lists_have_exactly_their_length() {
    let err = refuse("[scene]\nframes = [1, 24, 99]\n[[swarm]]\ncount = 3\n");
    assert_says(
        &err,
        &[
            "shot.toml:2:10:",
            "key `scene.frames`",
            "expected a list of two frame numbers [start, end], found 3 elements",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\nspawn = { center = [0, 1, 0, 99] }\n");
    assert_says(
        &err,
        &[
            "shot.toml:3:20:",
            "key `swarm[0].spawn.center`",
            "expected a list of three numbers [x, y, z], found 4 elements",
        ],
    );
    let err = refuse("[[swarm]]\ncount = 3\n[wind]\nvelocity = [1, 0, 0, 0, 0]\n");
    assert_says(&err, &["key `wind.velocity`", "found 5 elements"]);
}

#[test]
fn numeric_options_are_bounded_and_unusable_references_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("shot.toml"), "[[swarm]]\ncount = 3\n").unwrap();
    // Three insects of three samples each: nothing to measure.
    let mut short = String::from("id,frame,time,x,y,z,vx,vy,vz,qx,qy,qz,qw\n");
    for i in 1..=3 {
        for f in 1..=3 {
            short += &format!("{i},{f},0.0{f},0,1,0,0,0,0,0,0,0,1\n");
        }
    }
    std::fs::write(p.join("short.csv"), short).unwrap();
    for (args, says) in [
        (
            &["bake", "shot.toml", "--threads", "100000"][..],
            "--threads: expected 0 (all cores) up to",
        ),
        (
            &["bench", "--threads", "100000"][..],
            "--threads: expected 0 (all cores) up to",
        ),
        (
            &[
                "eval",
                "short.csv",
                "--reference",
                "short.csv",
                "--dt",
                "1e-12",
            ][..],
            "--dt: expected a resampling step from 0.0001 to 10 seconds",
        ),
        (
            &[
                "eval",
                "short.csv",
                "--reference",
                "short.csv",
                "--dt",
                "1e30",
            ][..],
            "--dt: expected a resampling step from 0.0001 to 10 seconds",
        ),
        (
            &[
                "eval",
                "short.csv",
                "--reference",
                "short.csv",
                "--bins",
                "1000000000",
            ][..],
            "--bins: expected a whole number of bins from 1 to 10000",
        ),
        (
            &[
                "eval",
                "short.csv",
                "--reference",
                "short.csv",
                "--min-speed",
                "nan",
            ][..],
            "--min-speed: expected a speed from 0 to 100 m/s, found NaN",
        ),
        (
            &["eval", "short.csv", "--reference", "short.csv"][..],
            "short.csv: no usable track in the reference",
        ),
        (
            &[
                "calibrate",
                "--reference",
                "short.csv",
                "--shot",
                "shot.toml",
                "--out",
                "fit.toml",
                "--generations",
                "1",
                "--population",
                "2",
            ][..],
            "short.csv: no usable track in the reference",
        ),
    ] {
        let run = beeswarm(p, args);
        assert_eq!(run.code, 2, "{args:?}: {}", run.stderr);
        assert_says(&run.stderr, &[says]);
    }
    assert_only(p, &["shot.toml", "short.csv"]);
}

#[test]
fn check_refuses_what_bake_would_fail_on() {
    // A number TOML cannot hold names its key.
    let err = refuse("[[swarm]]\ncount = 9223372036854775808\n");
    assert_says(
        &err,
        &[
            "shot.toml:2:9:",
            "key `count`",
            "expected a whole number from",
        ],
    );
    // Names longer than a file name can hold.
    let long = "a".repeat(101);
    let err = refuse(format!(
        "[scene]\nname = \"{long}\"\n[[swarm]]\ncount = 3\n"
    ));
    assert_says(
        &err,
        &["key `scene.name`", "at most 100 characters, found 101"],
    );
    let err = refuse(format!("[[swarm]]\ncount = 3\nname = \"{long}\"\n"));
    assert_says(
        &err,
        &["key `swarm[0].name`", "at most 100 characters, found 101"],
    );
    // The wind is a velocity: its limit is inclusive and in m/s.
    let err = refuse("[[swarm]]\ncount = 3\n[wind]\nvelocity = [1000001, 0, 0]\n");
    assert_says(&err, &["key `wind.velocity`", "within ±1000000 m/s"]);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("shot.toml"),
        "[[swarm]]\ncount = 3\n[wind]\nvelocity = [1000000, 0, -1000000]\n",
    )
    .unwrap();
    assert_eq!(
        beeswarm(dir.path(), &["check", "shot.toml"]).code,
        0,
        "the documented limit itself is valid"
    );
}

#[test]
fn check_refuses_an_output_folder_bake_could_not_use() {
    let err = refuse("[[swarm]]\ncount = 3\n[output]\ndir = \"a\\u0000b\"\n");
    assert_says(&err, &["key `output.dir`", "holding a NUL character"]);
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("afile"), "").unwrap();
    for (out, says) in [
        ("afile", "is a file, not a folder"),
        ("afile/deeper", "is a file, not a folder"),
        (
            "/proc/beeswarm-test",
            "cannot create the output folder /proc/beeswarm-test",
        ),
    ] {
        if out.starts_with("/proc") && !Path::new("/proc").is_dir() {
            continue;
        }
        std::fs::write(
            p.join("shot.toml"),
            format!("[[swarm]]\ncount = 3\n[output]\ndir = \"{out}\"\n"),
        )
        .unwrap();
        for cmd in ["check", "bake"] {
            let run = beeswarm(p, &[cmd, "shot.toml"]);
            assert_eq!(run.code, 2, "{cmd} {out}: {}", run.stderr);
            assert_says(&run.stderr, &[says]);
        }
    }
    assert_only(p, &["afile", "shot.toml"]);
}

#[test]
fn outputs_are_checked_before_the_work_and_endless_inputs_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("shot.toml"),
        "[scene]\nframes = [1, 30]\n[[swarm]]\ncount = 3\n",
    )
    .unwrap();
    // A reference long enough to calibrate against: the model's own tracks.
    let run = beeswarm(p, &["bake", "shot.toml", "--format", "csv", "--out", "ref"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let csv = "ref/shot.tracks.csv";
    for (args, says) in [
        (
            &[
                "calibrate",
                "--reference",
                csv,
                "--shot",
                "shot.toml",
                "--out",
                "missing/fit.toml",
                "--generations",
                "1",
                "--population",
                "2",
            ][..],
            "--out missing/fit.toml: the folder missing does not exist",
        ),
        (
            &[
                "calibrate",
                "--reference",
                csv,
                "--shot",
                "shot.toml",
                "--out",
                "fit.toml",
                "--figure",
                "nope/fig.png",
                "--generations",
                "1",
                "--population",
                "2",
            ][..],
            "--figure nope/fig.png: the folder nope does not exist",
        ),
        (
            &["eval", csv, "--reference", csv, "--out", "nope/report.json"][..],
            "--out nope/report.json: the folder nope does not exist",
        ),
        (
            &["eval", csv, "--reference", csv, "--figure", "ref"][..],
            "--figure ref: a folder stands there",
        ),
    ] {
        let run = beeswarm(p, args);
        assert_eq!(run.code, 2, "{args:?}: {}", run.stderr);
        assert_says(&run.stderr, &[says]);
    }
    assert!(!p.join("fit.toml").exists());
    // A preset path to an endless file is refused after a bounded read.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("/dev/zero", p.join("endless.toml")).unwrap();
        std::fs::write(
            p.join("shot.toml"),
            "[[swarm]]\ncount = 3\npreset = \"endless.toml\"\n",
        )
        .unwrap();
        let run = beeswarm(p, &["check", "shot.toml"]);
        assert_eq!(run.code, 2, "{}", run.stderr);
        assert_says(&run.stderr, &["key `swarm[0].preset`", "larger than 16 MB"]);
    }
}

#[test]
fn mesh_files_missing_malformed_empty_or_open() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let shot = |extra: &str| {
        std::fs::write(
            p.join("shot.toml"),
            format!(
                "[[swarm]]\ncount = 3\n[[obstacle]]\ntype = \"mesh\"\nfile = \"m.obj\"\n{extra}"
            ),
        )
        .unwrap();
        let run = beeswarm(p, &["bake", "shot.toml", "--out", "out", "--format", "csv"]);
        assert_eq!(run.code, 2, "{}", run.stderr);
        assert!(!p.join("out").exists(), "nothing written");
        run.stderr
    };
    assert_says(
        &shot(""),
        &[
            "shot.toml:5:8:",
            "key `obstacle[0].file`",
            "m.obj: cannot read it",
        ],
    );
    // A face naming a vertex that is not there: located in the mesh file, and back.
    std::fs::write(p.join("m.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    assert_says(
        &shot(""),
        &[
            "m.obj:4:1: key `obstacle[0].file`: vertex index 9 does not exist",
            " 4 | f 1 2 9",
            "hint: the mesh of obstacle[0], `file` at shot.toml:5",
        ],
    );
    std::fs::write(p.join("m.obj"), "v 0 0 0\nv 1 0 inf\n").unwrap();
    assert_says(
        &shot(""),
        &["m.obj:2:1:", "expected a finite number, found \"inf\""],
    );
    std::fs::write(p.join("m.obj"), "# no faces\nv 0 0 0\n").unwrap();
    assert_says(&shot(""), &["m.obj: the file has no triangles"]);
    // One open triangle: not a solid, but a shell is fine.
    std::fs::write(p.join("m.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert_says(
        &shot(""),
        &["the mesh is not closed", "3 open edges", "mode = \"shell\""],
    );
    assert_says(
        &shot("thickness = 0.1\n"),
        &[
            "key `obstacle[0].thickness`",
            "a solid mesh has no `thickness`",
        ],
    );
    assert_says(
        &shot("mode = \"shell\"\nradius = 1\n"),
        &["a mesh has no `radius`"],
    );
    let run = beeswarm(p, &["check", "shot.toml"]);
    assert_eq!(run.code, 2);
    std::fs::write(
        p.join("shot.toml"),
        "[[swarm]]\ncount = 3\n[[obstacle]]\ntype = \"mesh\"\nfile = \"m.obj\"\nmode = \"shell\"\n",
    )
    .unwrap();
    let run = beeswarm(p, &["check", "shot.toml"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    // PLY: located at its line, and back to the shot.
    std::fs::write(
        p.join("m.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n",
    )
    .unwrap();
    let mesh_shot = |file: &str, extra: &str| {
        std::fs::write(
            p.join("shot.toml"),
            format!(
                "[[swarm]]\ncount = 3\n[[obstacle]]\ntype = \"mesh\"\nfile = \"{file}\"\n{extra}"
            ),
        )
        .unwrap();
        let run = beeswarm(p, &["check", "shot.toml"]);
        assert_eq!(run.code, 2, "{}", run.stderr);
        run.stderr
    };
    assert_says(
        &mesh_shot("m.ply", ""),
        &[
            "m.ply:13:1: key `obstacle[0].file`: face 1: vertex index 5 does not exist",
            "hint: the mesh of obstacle[0], `file` at shot.toml:5",
        ],
    );
    // glTF: a node that is not there is an error at the `node` key.
    std::fs::write(
        p.join("m.gltf"),
        r#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"name": "fence"}]}"#,
    )
    .unwrap();
    assert_says(
        &mesh_shot("m.gltf", "node = \"tree\"\n"),
        &[
            "key `obstacle[0].node`",
            "no node named \"tree\" in the scene; its nodes: fence",
        ],
    );
    assert_says(
        &mesh_shot("m.gltf", ""),
        &["m.gltf: the file has no triangles"],
    );
    std::fs::write(p.join("m.gltf"), "{\n\"asset\": 3\n}").unwrap();
    assert_says(
        &mesh_shot("m.gltf", ""),
        &["m.gltf:2:1:", "invalid glTF JSON"],
    );
    // Another format: refused by name.
    std::fs::write(p.join("m.3ds"), "x").unwrap();
    assert_says(
        &mesh_shot("m.3ds", ""),
        &["m.3ds: expected a .obj, .stl, .ply, .gltf or .glb mesh file"],
    );
}

#[test]
fn a_velocity_database_is_read_and_its_errors_located() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let run_with = |model: &str, db: &str| {
        std::fs::write(
            p.join("shot.toml"),
            format!("[[swarm]]\ncount = 3\nmodel = \"{model}\"\ndatabase = \"{db}\"\n"),
        )
        .unwrap();
        beeswarm(p, &["check", "shot.toml"])
    };
    let run = run_with("fastswarm", "none.db");
    assert_eq!(run.code, 2);
    assert_says(
        &run.stderr,
        &[
            "shot.toml:4:12:",
            "key `swarm[0].database`",
            "none.db: cannot read it",
        ],
    );
    std::fs::write(
        p.join("bad.db"),
        "# provenance\ndt = 0.02\n0.1,0.2,0.3,1,2\n",
    )
    .unwrap();
    let run = run_with("fastswarm", "bad.db");
    assert_eq!(run.code, 2);
    assert_says(
        &run.stderr,
        &[
            "bad.db:3:1: key `swarm[0].database`: expected six finite numbers",
            "hint: the velocity database of swarm[0], `database` at shot.toml:4",
        ],
    );
    std::fs::write(p.join("few.db"), "dt = 0.02\n0.1,0.2,0.3,1,2,3\n").unwrap();
    let run = run_with("fastswarm", "few.db");
    assert_says(
        &run.stderr,
        &["few.db: 1 samples; a database needs at least 50 (ten in each of 5 speed groups)"],
    );
    let run = run_with("bee", "few.db");
    assert_eq!(run.code, 2);
    assert_says(&run.stderr, &["a bee swarm has no velocity database"]);
    // The shipped database, copied beside the shot, is accepted.
    std::fs::write(
        p.join("good.db"),
        std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/src/model/fastswarm/mosquito_db.csv"
        ))
        .unwrap(),
    )
    .unwrap();
    let run = run_with("fastswarm", "good.db");
    assert_eq!(run.code, 0, "{}", run.stderr);
}

#[test]
fn moving_meshes_refused_where_they_cannot_move() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("m.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    let run_with = |swarm: &str, obstacle: &str| {
        std::fs::write(
            p.join("shot.toml"),
            format!("[[swarm]]\ncount = 3\n{swarm}[[obstacle]]\n{obstacle}"),
        )
        .unwrap();
        beeswarm(p, &["bake", "shot.toml", "--out", "out", "--format", "csv"])
    };
    let refused = |swarm: &str, obstacle: &str| {
        let run = run_with(swarm, obstacle);
        assert_eq!(run.code, 2, "{}", run.stderr);
        assert!(!p.join("out").exists(), "nothing written");
        run.stderr
    };
    let keys = "keys = [{ frame = 1, position = [3, 1, 0] }, { frame = 20, position = [-3, 1, 0], rotation = [0, 90, 0] }]\n";
    let moving = format!("type = \"mesh\"\nfile = \"m.obj\"\n{keys}");
    // The field model's path cost is built once from the obstacles: located at `keys`.
    assert_says(
        &refused("model = \"field\"\n", &moving),
        &[
            "shot.toml:7:8: key `obstacle[0].keys`",
            "swarm[0] (\"swarm\") flies the `field` model",
            "cannot move",
            "remove `keys`",
        ],
    );
    assert_says(
        &refused("", &format!("{moving}position = [0, 1, 0]\n")),
        &["key `obstacle[0].position`", "either `position` or `keys`"],
    );
    assert_says(
        &refused(
            "",
            &format!("type = \"sphere\"\ncenter = [0, 1, 0]\nradius = 0.2\n{keys}"),
        ),
        &[
            "key `obstacle[0].keys`",
            "a sphere has no `keys`",
            "only mesh obstacles move",
        ],
    );
    assert_says(
        &refused(
            "",
            "type = \"mesh\"\nfile = \"m.obj\"\nkeys = [{ frame = 5, position = [0, 2, 0] }, { frame = 2, position = [0, 2, 0] }]\n",
        ),
        &[
            "key `obstacle[0].keys[1].frame`",
            "increasing order, found 2 after 5",
        ],
    );
    // A target's keys move a point: no rotation.
    std::fs::write(
        p.join("shot.toml"),
        "[[swarm]]\ncount = 3\n[[target]]\nkeys = [{ frame = 1, position = [0, 1, 0], rotation = [0, 90, 0] }]\n",
    )
    .unwrap();
    let run = beeswarm(p, &["check", "shot.toml"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert_says(
        &run.stderr,
        &[
            "key `target[0].keys[0].rotation`",
            "a target's key has no `rotation`",
        ],
    );
    // Every other model bakes it.
    let run = run_with("model = \"zonal\"\n", &moving);
    assert_eq!(run.code, 0, "{}", run.stderr);
}
