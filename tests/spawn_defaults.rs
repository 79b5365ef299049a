//! Defaults that scale: a swarm that names no spawn size starts at a bounded density, and
//! `check` reports every swarm's density and warns when agents start crowded.

use beeswarm::shot::Region;
use std::process::Command;

mod common;

fn spawn_of(src: &str) -> (glam::Vec3, glam::Vec3) {
    match common::shot(src).swarms[0].spawn {
        Region::Box { center, half } => (center, half),
        other => panic!("expected a box, got {other:?}"),
    }
}

#[test]
fn a_swarm_without_a_spawn_size_starts_at_most_500_per_cubic_metre() {
    // Up to 500 agents: the 1 m cube 1 m above the ground, as always.
    let (c, h) = spawn_of("[[swarm]]\ncount = 500\n");
    assert_eq!(
        (c, h),
        (glam::Vec3::new(0.0, 1.0, 0.0), glam::Vec3::splat(0.5))
    );
    // 100,000: a cube of 200 m³, standing on the ground.
    let (c, h) = spawn_of("[[swarm]]\ncount = 100000\n");
    let volume = 8.0 * h.x * h.y * h.z;
    assert!((volume - 200.0).abs() < 0.5, "{volume} m³");
    assert!((c.y - h.y).abs() < 1e-5, "bottom at y = {}", c.y - h.y);
    // A centre without a size keeps the scaled size; an explicit size is kept as given.
    let (c, h) = spawn_of("[[swarm]]\ncount = 4000\nspawn = { center = [3, 4, 5] }\n");
    assert_eq!(c, glam::Vec3::new(3.0, 4.0, 5.0));
    assert!((h.x - 1.0).abs() < 1e-5, "2 m cube for 4,000: {h}");
    let (_, h) = spawn_of("[[swarm]]\ncount = 4000\nspawn = { size = [1, 1, 1] }\n");
    assert_eq!(h, glam::Vec3::splat(0.5));
}

#[test]
fn check_reports_density_and_warns_when_agents_start_crowded() {
    let dir = tempfile::tempdir().unwrap();
    let check = |src: &str| {
        std::fs::write(dir.path().join("shot.toml"), src).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_beeswarm"))
            .args(["check", "shot.toml"])
            .current_dir(dir.path())
            .output()
            .unwrap();
        common::assert_succeeded(&out);
        String::from_utf8(out.stdout).unwrap()
    };
    let roomy = check("[[swarm]]\ncount = 100000\n");
    assert!(
        roomy.contains("500 agents per m³ (about 7 neighbours within 0.15 m)"),
        "{roomy}"
    );
    assert!(!roomy.contains("warning"), "{roomy}");
    let crowded = check("[[swarm]]\ncount = 100000\nspawn = { size = [1, 1, 1] }\n");
    assert!(
        crowded.contains("100000 agents per m³ (about 1414 neighbours"),
        "{crowded}"
    );
    assert!(
        crowded
            .contains("warning: more than 16 neighbours per agent: each feels only its nearest 16"),
        "{crowded}"
    );
    assert!(
        crowded.contains("at most 1131 agents per m³ here"),
        "{crowded}"
    );
}
