//! `beeswarm wedge`: variant shots checked up front, an OpenJD job, the local runner and
//! the contact sheet.

mod common;

use std::path::Path;
use std::process::{Command, Output};

const SHOT: &str = r#"# A small shot to wedge.
[scene]
name = "small"
frames = [1, 12]
seed = 1

[[swarm]]
name = "bees"
count = 20
preset = "grassland"
spawn = { shape = "box", center = [0.0, 1.1, 0.0], size = [2.0, 1.0, 2.0] }

[output]
formats = ["csv"]
"#;

fn beeswarm(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

#[test]
fn writes_checked_variants_and_a_job() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("small.toml"), SHOT).unwrap();
    let out = beeswarm(
        p,
        &[
            "wedge",
            "small.toml",
            "--vary",
            "seed=1..2",
            "--vary",
            "swarm.bees.params.speed=0.8,1.2",
            "--out",
            "w",
        ],
    );
    common::assert_succeeded(&out);
    let v3 = std::fs::read_to_string(p.join("w/variants/small_3.toml")).unwrap();
    // Variant 3 = seed 2, speed 0.8 (the first key varies slowest); comments survive.
    assert!(v3.starts_with("# A small shot to wedge.\n"), "{v3}");
    assert!(v3.contains("seed = 2\n"), "{v3}");
    assert!(v3.contains("params = { speed = 0.8 }"), "{v3}");
    assert!(v3.contains("name = \"small_3\""), "{v3}");
    assert!(v3.contains("dir = \"../caches/small_3\""), "{v3}");
    assert!(!p.join("w/variants/small_5.toml").exists());
    let job = std::fs::read_to_string(p.join("w/job.yaml")).unwrap();
    assert!(job.contains("specificationVersion: jobtemplate-2023-09"));
    assert!(job.contains("range: \"1-4\""), "{job}");
    assert!(job.contains("dependsOn: Bake"), "{job}");
    assert!(job.contains("default: \".\""), "{job}");
    let bundle = std::fs::read_to_string(p.join("w/template.yaml")).unwrap();
    assert_eq!(bundle, job, "the folder is a Deadline Cloud job bundle too");
    let manifest = std::fs::read_to_string(p.join("w/wedge.json")).unwrap();
    assert!(
        manifest.contains("\"label\": \"seed=2 speed=0.8\""),
        "{manifest}"
    );
}

#[test]
fn a_bad_variant_fails_the_whole_wedge_with_a_located_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("small.toml"), SHOT).unwrap();
    let out = beeswarm(
        p,
        &[
            "wedge",
            "small.toml",
            "--vary",
            "seed=9..10",
            "--vary",
            "swarm.bees.count=5,-1",
            "--out",
            "w",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("small.toml:9:9: key `swarm[0].count`"),
        "{err}"
    );
    assert!(
        err.contains("(in wedge variant 2: seed=9 count=-1)"),
        "{err}"
    );
    assert!(!p.join("w").exists(), "nothing is written");

    let out = beeswarm(
        p,
        &[
            "wedge",
            "small.toml",
            "--vary",
            "swarm.bes.count=3",
            "--out",
            "w",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("no swarm named \"bes\"; the shot has \"bees\""),
        "{err}"
    );

    // A key the shot does not have is added by the wedge: its line is the variant's.
    let out = beeswarm(
        p,
        &[
            "wedge",
            "small.toml",
            "--vary",
            "swarm.bees.variation.size=0.1,7",
            "--out",
            "w",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("small.toml as wedge variant 2 writes it:") && err.contains("variation"),
        "{err}"
    );

    let out = beeswarm(
        p,
        &["wedge", "small.toml", "--vary", "seed=3..1", "--out", "w"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("reversed"));
}

#[test]
fn run_bakes_every_variant_like_a_plain_bake_and_gathers_a_contact_sheet() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("small.toml"), SHOT).unwrap();
    let out = beeswarm(
        p,
        &[
            "wedge",
            "small.toml",
            "--variant",
            "seed=4",
            "--variant",
            "seed=5;swarm.bees.params.speed=1.1",
            "--variant",
            "seed=6",
            "--out",
            "w",
            "--run",
        ],
    );
    common::assert_succeeded(&out);
    for k in 1..=3 {
        let csv = p.join(format!("w/caches/small_{k}/small_{k}.tracks.csv"));
        assert!(csv.exists(), "{}", csv.display());
    }
    // A variant's cache is exactly what baking that seed directly gives.
    let out = beeswarm(
        p,
        &[
            "bake",
            "small.toml",
            "--seed",
            "6",
            "--out",
            "direct",
            "--quiet",
        ],
    );
    common::assert_succeeded(&out);
    let direct = std::fs::read_to_string(p.join("direct/small.tracks.csv")).unwrap();
    let wedged = std::fs::read_to_string(p.join("w/caches/small_3/small_3.tracks.csv")).unwrap();
    assert_eq!(direct, wedged.replace("small_3", "small"));
    // The contact sheet holds the three previews side by side.
    let sheet = std::fs::File::open(p.join("w/small.contact.png")).unwrap();
    let info = png::Decoder::new(std::io::BufReader::new(sheet))
        .read_info()
        .unwrap();
    let (w, h) = (info.info().width, info.info().height);
    assert!(w > 3 * 400 && h > 200, "{w}x{h}");
    // Gathering again gives the same bytes.
    let before = std::fs::read(p.join("w/small.contact.png")).unwrap();
    let out = beeswarm(p, &["gather", "w"]);
    common::assert_succeeded(&out);
    assert_eq!(
        before,
        std::fs::read(p.join("w/small.contact.png")).unwrap()
    );
}

#[test]
fn with_a_reference_the_gather_step_ranks_the_variants() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    // The shot writes glb only: a ranked wedge adds CSV to its variants.
    std::fs::write(p.join("small.toml"), SHOT.replace("[\"csv\"]", "[\"glb\"]")).unwrap();
    // The "recording": the same shot baked with a seed of its own.
    let out = beeswarm(
        p,
        &[
            "bake",
            "small.toml",
            "--seed",
            "100",
            "--format",
            "csv",
            "--out",
            "rec",
            "--quiet",
        ],
    );
    common::assert_succeeded(&out);
    let out = beeswarm(
        p,
        &[
            "wedge",
            "small.toml",
            "--vary",
            "swarm.bees.params.speed=0.3,1.0,3.0",
            "--reference",
            "rec/small.tracks.csv",
            "--out",
            "w",
            "--run",
            "--quiet",
        ],
    );
    common::assert_succeeded(&out);
    let v1 = std::fs::read_to_string(p.join("w/variants/small_1.toml")).unwrap();
    assert!(v1.contains("formats = [\"glb\", \"csv\"]"), "{v1}");
    assert!(p.join("w/reference.csv").exists());
    assert!(p.join("w/small.eval.json").exists());
    let md = std::fs::read_to_string(p.join("w/small.eval.md")).unwrap();
    let rows: Vec<Vec<&str>> = md
        .lines()
        .filter(|l| l.starts_with("| 1 |") || l.starts_with("| 2 |") || l.starts_with("| 3 |"))
        .take(3)
        .map(|l| l.split('|').map(str::trim).collect())
        .collect();
    assert_eq!(rows.len(), 3, "{md}");
    let fitness: Vec<f64> = rows.iter().map(|r| r[4].parse().unwrap()).collect();
    assert!(fitness[0] >= fitness[1] && fitness[1] >= fitness[2], "{md}");
    // The variant flying at the recording's own speed (1.0, the preset's) ranks first.
    assert_eq!(rows[0][3], "speed=1.0", "{md}");
    assert!(md.contains("## Per metric (eval)"), "{md}");
}

#[test]
fn a_wedge_rewritten_with_fewer_variants_removes_the_others_and_their_caches() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("small.toml"), SHOT).unwrap();
    let wedge = |seeds: &str| {
        let out = beeswarm(p, &["wedge", "small.toml", "--vary", seeds, "--out", "w"]);
        common::assert_succeeded(&out);
    };
    wedge("seed=1..4");
    // Variant 4 baked (a stand-in cache), and a file of the user's beside the caches.
    std::fs::create_dir_all(p.join("w/caches/small_4")).unwrap();
    std::fs::write(p.join("w/caches/small_4/small_4.tracks.csv"), "x").unwrap();
    std::fs::write(p.join("w/caches/notes.txt"), "mine").unwrap();
    wedge("seed=1..2");
    let variants: Vec<String> = std::fs::read_dir(p.join("w/variants"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let mut variants = variants;
    variants.sort();
    assert_eq!(variants, ["small_1.toml", "small_2.toml"]);
    assert!(!p.join("w/caches/small_4").exists());
    assert!(
        p.join("w/caches/notes.txt").exists(),
        "not the wedge's: kept"
    );
}
