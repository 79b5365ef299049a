//! Calibration: a short genetic-algorithm run on a small shot must improve the fitness,
//! be reproducible for a seed, and write a preset that shots can load.

use beeswarm::eval::calibrate::{self, PARAMS};
use beeswarm::eval::ga::{self, GaConfig};
use beeswarm::eval::report::{Reference, Settings, measure};
use beeswarm::eval::{CalibrateArgs, run_calibrate};
use beeswarm::shot::{self, Shot};
use std::path::Path;

const SHOT: &str = r#"
[scene]
name = "small_cage"
fps = 25
frames = [1, 151]
substeps = 2
seed = 5

[[swarm]]
name = "flies"
count = 3
spawn = { shape = "box", center = [0.5, 0.5, 0.5], size = [0.4, 0.4, 0.4] }
bounds = { center = [0.5, 0.5, 0.5], size = [1.0, 1.0, 1.0] }

[output]
formats = ["csv"]
"#;

fn small_shot() -> Shot {
    shot::parse(SHOT, Path::new("small.toml"), Path::new(".")).unwrap()
}

fn settings() -> Settings {
    Settings {
        dt: 0.04,
        bins: 20,
        density_radius: 0.15,
        min_speed: 1e-3,
        tail: 0.005,
    }
}

/// A reference made by the model itself with known parameters, so there is a point in the
/// search space that fits it well.
fn synthetic_reference(shot: &Shot, genes: &[f64]) -> Reference {
    let ds = calibrate::simulate(&calibrate::shot_with(shot, &PARAMS, genes));
    Reference::new(measure(&ds, &settings(), false), settings().bins)
}

#[test]
fn a_short_calibration_improves_fitness() {
    let shot = small_shot();
    let target = [0.4, 0.3, 0.5, 0.6, 0.5, 0.5, 0.35, 0.5];
    let reference = synthetic_reference(&shot, &target);
    let cfg = GaConfig {
        population: 6,
        generations: 6,
        seed: 9,
        ..GaConfig::default()
    };
    let s = settings();
    let r = ga::run(
        PARAMS.len(),
        &cfg,
        |g| calibrate::fitness(&shot, &PARAMS, &reference, &s, 1, g),
        |_| {},
    );
    let first = r.history.first().unwrap().best;
    let last = r.history.last().unwrap().best;
    assert!(
        last > first,
        "best fitness did not improve: first {first}, last {last}"
    );
    assert!(
        r.history.windows(2).all(|w| w[1].best >= w[0].best),
        "elitism keeps the best"
    );
    assert!(
        r.history
            .iter()
            .all(|g| g.best.is_finite() && g.mean.is_finite())
    );
    // The parameters that made the reference fit it better than the search's start.
    let exact = calibrate::fitness(&shot, &PARAMS, &reference, &s, 1, &target);
    assert!(exact > 0.99, "{exact}");
    assert!(exact >= first);
}

#[test]
fn calibrate_command_writes_a_loadable_preset_and_a_figure() {
    let dir = tempfile::tempdir().unwrap();
    let shot_path = dir.path().join("small.toml");
    std::fs::write(&shot_path, SHOT).unwrap();
    // The reference as a tracks CSV, as `bake` writes it.
    let ds = calibrate::simulate(&small_shot());
    let mut csv = String::from(beeswarm::export::csv::HEADER);
    csv.push('\n');
    for t in &ds.tracks {
        for i in 0..t.len() {
            let (p, v) = (t.position[i], t.velocity[i]);
            csv += &format!(
                "{},{i},{},{},{},{},{},{},{},0,0,0,1,0,0,0\n",
                t.id, t.time[i], p.x, p.y, p.z, v.x, v.y, v.z
            );
        }
    }
    let real = dir.path().join("real.csv");
    std::fs::write(&real, csv).unwrap();
    let out = dir.path().join("fitted.toml");
    let args = CalibrateArgs {
        reference: real,
        shot: shot_path.clone(),
        out: out.clone(),
        generations: 2,
        population: 4,
        seed: 3,
        threads: 1,
        progress: beeswarm::progress::Mode::None,
        figure: None,
        bins: 20,
        name: None,
        only: vec![],
        seeds: 1,
    };
    run_calibrate(&args).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("[preset]") && text.contains("provenance") && text.contains("# calibrated")
    );
    // The default search: Γ, the speed and d0; the heading lag and speed wander only on
    // request.
    assert_eq!(text.matches("# calibrated").count(), 8, "{text}");
    assert!(text.contains("\nheading_lag = 0.06\n"), "{text}");
    assert!(dir.path().join("fitted.fitness.png").exists());
    // The history beside the figure draws the same figure again, without calibrating.
    let history = dir.path().join("fitted.fitness.csv");
    let again = dir.path().join("again.png");
    beeswarm::eval::calibrate::run_fitness_figure(&calibrate::FitnessFigureArgs {
        history: history.clone(),
        figure: Some(again.clone()),
        name: None,
    })
    .unwrap();
    assert_eq!(
        std::fs::read(&again).unwrap(),
        std::fs::read(dir.path().join("fitted.fitness.png")).unwrap()
    );
    let first = text.clone();

    // Same seed, same preset (apart from the timing in the provenance).
    run_calibrate(&args).unwrap();
    let strip = |s: &str| {
        s.lines()
            .filter(|l| !l.contains(" evaluations in "))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(
        strip(&first),
        strip(&std::fs::read_to_string(&out).unwrap())
    );

    // A shot can load it.
    let user = SHOT.replace("count = 3", "count = 3\npreset = \"fitted.toml\"");
    let user_path = dir.path().join("user.toml");
    std::fs::write(&user_path, user).unwrap();
    let loaded = shot::load(&user_path).unwrap();
    let p = &loaded.swarms[0].params;
    assert!(
        text.contains(&format!(
            "speed = {}",
            toml::Value::Float(p.get("speed").unwrap())
        )),
        "{text}"
    );

    // --only calibrates a subset and leaves the rest alone.
    let only = CalibrateArgs {
        only: vec!["speed".into()],
        out: dir.path().join("speed.toml"),
        ..args
    };
    run_calibrate(&only).unwrap();
    let text = std::fs::read_to_string(dir.path().join("speed.toml")).unwrap();
    assert_eq!(text.matches("# calibrated").count(), 1);
    let extra = CalibrateArgs {
        only: vec![
            "speed_wander".into(),
            "heading_lag".into(),
            "attraction".into(),
            "surface_speed".into(),
        ],
        out: dir.path().join("extra.toml"),
        ..only.clone()
    };
    run_calibrate(&extra).unwrap();
    let text = std::fs::read_to_string(dir.path().join("extra.toml")).unwrap();
    assert_eq!(text.matches("# calibrated").count(), 4);
    for key in [
        "speed_wander = ",
        "heading_lag = ",
        "attraction = ",
        "surface_speed = ",
    ] {
        assert!(text.contains(key), "{key} missing from {text}");
    }
    // A preset with the new parameters loads.
    let user = SHOT.replace("count = 3", "count = 3\npreset = \"extra.toml\"");
    std::fs::write(&user_path, user).unwrap();
    shot::load(&user_path).unwrap();
    let bad = CalibrateArgs {
        only: vec!["wings".into()],
        ..only
    };
    assert!(run_calibrate(&bad).is_err());
}

#[test]
fn fitness_history_reads_back_exactly_and_bad_lines_are_located() {
    use beeswarm::eval::ga::{GaResult, Generation};
    let r = GaResult {
        best_genes: vec![],
        best_fitness: 0.8830123456789,
        history: (0..5)
            .map(|i| Generation {
                index: i,
                best: 0.5 + 0.1 * i as f64 / 3.0,
                mean: 0.1 * (i as f64).sqrt(),
                best_genes: vec![],
            })
            .collect(),
        evaluations: 0,
    };
    let text = calibrate::history_csv(&r);
    let back = calibrate::parse_history(&text, Path::new("h.csv")).unwrap();
    assert_eq!(back.history.len(), 5);
    for (a, b) in r.history.iter().zip(&back.history) {
        assert_eq!(
            (a.index, a.best.to_bits(), a.mean.to_bits()),
            (b.index, b.best.to_bits(), b.mean.to_bits())
        );
    }
    let f = |t: &str| {
        calibrate::parse_history(t, Path::new("h.csv"))
            .unwrap_err()
            .to_string()
    };
    assert!(f("gen,best\n").starts_with("h.csv:1: expected the header"));
    let e = f("generation,best,mean\n1,0.5,0.4\n2,0.6\n");
    assert!(e.starts_with("h.csv:3: expected 3 values"), "{e}");
    let e = f("generation,best,mean\n1,0.5,0.4\n3,0.6,0.5\n");
    assert!(
        e.starts_with("h.csv:3: generation: expected 2, found 3"),
        "{e}"
    );
    let e = f("generation,best,mean\n1,NaN,0.4\n");
    assert!(
        e.starts_with("h.csv:2: best: expected a finite fitness"),
        "{e}"
    );
    assert!(f("generation,best,mean\n").contains("at least one generation"));
}

#[test]
fn fitness_figure_command_refuses_a_bad_history_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad_fitness.csv");
    std::fs::write(&bad, "generation,best,mean\n1,0.5,oops\n").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .arg("fitness-figure")
        .arg(&bad)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!(
            "{}:2: mean: expected a finite fitness, found `oops`",
            bad.display()
        )),
        "{err}"
    );
    assert!(!dir.path().join("bad_fitness.png").exists());
}
