//! Evaluation against known answers: synthetic tracks with analytic metrics, the real
//! mosquito recording (skipped, saying so, where it is absent), and the plot output.

use beeswarm::eval::histogram::Summary;
use beeswarm::eval::metrics::{Metric, MetricOptions, compute, poly6};
use beeswarm::eval::report::{Measured, Reference, Settings, compare, measure};
use beeswarm::eval::resample::resample;
use beeswarm::eval::tracks::{self, Dataset, Track, TrackFormat};
use beeswarm::plot::{Figure, Legend, Mark, palette, px, text};
use glam::DVec3;
use plotters::prelude::*;
use std::path::PathBuf;

const DT: f64 = 0.02;

fn dataset(tracks: Vec<Track>) -> Dataset {
    Dataset {
        name: "synthetic".into(),
        format: TrackFormat::Memory,
        tracks,
    }
}

/// A constant-speed circle of radius `r` in the X–Z plane, sampled every DT.
fn circle(id: &str, r: f64, v: f64, n: usize) -> Track {
    let w = v / r;
    let mut t = Track {
        id: id.into(),
        ..Default::default()
    };
    for i in 0..n {
        let time = i as f64 * DT;
        let a = w * time;
        t.time.push(time);
        t.position.push(DVec3::new(r * a.cos(), 1.0, r * a.sin()));
        t.velocity.push(DVec3::new(-v * a.sin(), 0.0, v * a.cos()));
    }
    t
}

fn line(id: &str, start: DVec3, vel: DVec3, n: usize) -> Track {
    let mut t = Track {
        id: id.into(),
        ..Default::default()
    };
    for i in 0..n {
        let time = i as f64 * DT;
        t.time.push(time);
        t.position.push(start + vel * time);
        t.velocity.push(vel);
    }
    t
}

/// Report settings at DT with `bins` shared bins and the CLI's other defaults.
fn settings(bins: usize) -> Settings {
    Settings {
        dt: DT,
        bins,
        density_radius: 0.15,
        min_speed: 1e-3,
        tail: 0.005,
    }
}

fn metrics_of(ds: &Dataset) -> beeswarm::eval::metrics::Samples {
    let opts = MetricOptions {
        dt: DT,
        ..MetricOptions::default()
    };
    compute(&resample(ds, DT), &opts)
}

fn all_close(v: &[f64], want: f64, tol: f64) -> bool {
    !v.is_empty() && v.iter().all(|x| (x - want).abs() <= tol)
}

#[test]
fn constant_speed_circle_has_known_metrics() {
    let (r, v) = (0.5, 1.5);
    let s = metrics_of(&dataset(vec![circle("c", r, v, 400)]));
    let theta = v / r * DT; // turn per step
    assert!(all_close(s.get(Metric::Speed), v, 1e-12));
    assert!(all_close(s.get(Metric::AngularVelocity), v / r, 1e-9));
    assert!(all_close(s.get(Metric::AngularAcceleration), 0.0, 1e-6));
    // Finite differences of the exact velocities: |Δv| = 2 v sin(θ/2), and the second
    // difference is v · 2(1 − cos θ): close to the continuous v²/R and v³/R².
    assert!(all_close(
        s.get(Metric::Acceleration),
        2.0 * v * (theta / 2.0).sin() / DT,
        1e-9
    ));
    assert!(all_close(
        s.get(Metric::Acceleration),
        v * v / r,
        1e-2 * v * v / r
    ));
    let jerk = v * 2.0 * (1.0 - theta.cos()) / (DT * DT);
    assert!(all_close(s.get(Metric::Jerk), jerk, 1e-6));
    assert!(all_close(
        s.get(Metric::Jerk),
        v.powi(3) / (r * r),
        1e-2 * v.powi(3) / (r * r)
    ));
    // One insect: nothing to be a neighbour of.
    assert!(s.get(Metric::NeighbourDistance).is_empty());
    assert_eq!(s.get(Metric::Speed).len(), 400);
    assert_eq!(s.get(Metric::Jerk).len(), 398);
}

#[test]
fn straight_line_has_no_turning_and_no_jerk() {
    let s = metrics_of(&dataset(vec![line(
        "l",
        DVec3::ZERO,
        DVec3::new(0.3, 0.1, -0.2),
        100,
    )]));
    assert!(all_close(s.get(Metric::AngularVelocity), 0.0, 1e-12));
    assert!(all_close(s.get(Metric::AngularAcceleration), 0.0, 1e-9));
    assert!(all_close(s.get(Metric::Acceleration), 0.0, 1e-12));
    assert!(all_close(s.get(Metric::Jerk), 0.0, 1e-12));
}

#[test]
fn hovering_insect_has_no_angular_velocity_instead_of_nan() {
    let s = metrics_of(&dataset(vec![line("h", DVec3::ONE, DVec3::ZERO, 50)]));
    assert!(s.get(Metric::AngularVelocity).is_empty());
    assert!(s.values.iter().flatten().all(|v| v.is_finite()));
}

#[test]
fn two_parallel_insects_have_known_neighbour_metrics() {
    let gap = 0.1;
    let a = line("a", DVec3::ZERO, DVec3::new(0.5, 0.0, 0.0), 60);
    let b = line(
        "b",
        DVec3::new(0.0, gap, 0.0),
        DVec3::new(0.5, 0.0, 0.2),
        60,
    );
    let s = metrics_of(&dataset(vec![a, b]));
    // The gap grows by 0.2 m/s in z, so the distance is sqrt(gap² + (0.2 t)²).
    let d = s.get(Metric::NeighbourDistance);
    assert_eq!(d.len(), 120);
    assert!((d[0] - gap).abs() < 1e-12);
    assert!((s.get(Metric::VelocityDifference)[0] - 0.2 / gap).abs() < 1e-9);
    assert!((s.get(Metric::Density)[0] - poly6(gap, 0.15)).abs() < 1e-9);
    assert_eq!(s.shared_instants, 60);
}

#[test]
fn identical_data_scores_perfectly_and_a_scaled_copy_does_not() {
    let settings = settings(30);
    let tracks: Vec<Track> = (0..5)
        .map(|i| {
            circle(
                &i.to_string(),
                0.2 + 0.1 * i as f64,
                0.5 + 0.2 * i as f64,
                300,
            )
        })
        .collect();
    let real = dataset(tracks.clone());
    let fast = dataset(
        tracks
            .iter()
            .map(|t| circle(&t.id, 0.2, 3.0 * t.velocity[0].length(), 300))
            .collect(),
    );
    let reference = Reference::new(measure(&real, &settings, true), settings.bins);
    let same = measure(&real, &settings, true);
    let other = measure(&fast, &settings, true);
    let rep = compare(settings, &reference, &[same, other]);
    assert!((rep.scores[0].fitness - 1.0).abs() < 1e-12);
    assert!(rep.scores[1].fitness < 0.7, "{}", rep.scores[1].fitness);
    assert!(rep.scores[0].entropy_score > rep.scores[1].entropy_score);
    // Single insects at a time? No: these five fly at once, so neighbour metrics exist.
    assert!(rep.metrics.iter().all(|m| m.applicable));
    let json = serde_json::to_string(&rep).unwrap();
    assert!(!json.contains("NaN") && !json.contains("inf"));
}

#[test]
fn single_insect_data_reports_neighbour_metrics_as_not_applicable() {
    let settings = settings(20);
    let real = dataset(vec![circle("a", 0.3, 1.0, 200)]);
    let reference = Reference::new(measure(&real, &settings, true), settings.bins);
    let rep = compare(settings, &reference, &[measure(&real, &settings, true)]);
    let nd = &rep.metrics[Metric::NeighbourDistance.index()];
    assert!(!nd.applicable);
    assert!(
        nd.note
            .as_deref()
            .unwrap()
            .contains("never has two insects")
    );
    assert_eq!(nd.candidates[0].l1, None);
    let json = serde_json::to_string(&rep).unwrap();
    assert!(json.contains("\"l1\":null") && !json.contains("NaN"));
    assert_eq!(Summary::of(&[]).n, 0);
}

#[test]
fn pooled_runs_keep_neighbours_within_a_run_and_add_their_samples() {
    let settings = settings(20);
    // Two runs of one insect each, flying through the same place at the same times: pooled,
    // they are still lone insects (no neighbour samples), with twice the samples of one.
    let a = measure(&dataset(vec![circle("0", 0.3, 1.0, 200)]), &settings, true);
    let b = measure(&dataset(vec![circle("0", 0.3, 0.5, 200)]), &settings, true);
    let pooled = Measured::pool("both", vec![a.clone(), b.clone()]);
    assert_eq!(pooled.info.name, "both");
    assert_eq!(pooled.info.tracks, 2);
    assert_eq!(pooled.samples.shared_instants, 0);
    assert!(pooled.samples.get(Metric::NeighbourDistance).is_empty());
    let speeds = pooled.samples.get(Metric::Speed);
    assert_eq!(speeds.len(), a.samples.get(Metric::Speed).len() * 2);
    assert!(all_close(&speeds[..speeds.len() / 2], 1.0, 1e-9));
    assert!(all_close(&speeds[speeds.len() / 2..], 0.5, 1e-9));
    // Pooling a run with itself changes no distribution.
    let reference = Reference::new(a.clone(), settings.bins);
    let twice = Measured::pool("twice", vec![b.clone(), b.clone()]);
    let rep = compare(settings, &reference, &[b, twice]);
    assert_eq!(rep.scores[0].fitness, rep.scores[1].fitness);
}

/// The recording at `<repo>/../shared/data/`, or in `$BEESWARM_DATA_DIR` (for work trees
/// that do not sit beside shared/).
fn mosquito_file() -> Option<PathBuf> {
    let beside =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/mosquito_flights.csv");
    let from_env = std::env::var_os("BEESWARM_DATA_DIR")
        .map(|d| PathBuf::from(d).join("mosquito_flights.csv"));
    match [Some(beside.clone()), from_env]
        .into_iter()
        .flatten()
        .find(|p| p.exists())
    {
        Some(p) => Some(p),
        None => {
            println!(
                "skipped: the mosquito recording is not at {}",
                beside.display()
            );
            None
        }
    }
}

#[test]
fn mosquito_recording_is_split_at_nan_gaps() {
    let Some(path) = mosquito_file() else { return };
    let text = std::fs::read_to_string(&path).unwrap();
    let rows = text
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .count();
    let nan_rows = text.lines().filter(|l| l.contains("NaN")).count();
    let objects: std::collections::BTreeSet<&str> = text
        .lines()
        .skip(1)
        .filter_map(|l| l.split(';').next())
        .collect();
    assert!(nan_rows > 0, "the test needs gaps to check splitting");
    let ds = tracks::read(&path).unwrap();
    assert_eq!(ds.format, TrackFormat::Splined);
    assert_eq!(ds.sample_count(), rows - nan_rows);
    // Some objects have gaps, so there are more tracks than objects.
    assert!(
        ds.tracks.len() > objects.len(),
        "{} tracks",
        ds.tracks.len()
    );
    assert!((ds.median_step() - 0.02).abs() < 1e-9);
    for t in &ds.tracks {
        // No track bridges a gap: consecutive samples are one step apart.
        for w in t.time.windows(2) {
            assert!(
                w[1] - w[0] < 0.0301,
                "track {} jumps {} → {}",
                t.id,
                w[0],
                w[1]
            );
        }
    }
}

#[test]
fn mosquito_recording_compared_with_itself_is_perfect_and_finite() {
    let Some(path) = mosquito_file() else { return };
    let ds = tracks::read(&path).unwrap();
    let settings = settings(40); // DT is the recording's 0.02 s
    let m = measure(&ds, &settings, true);
    // One to four mosquitoes in view: neighbours exist at some instants.
    assert!(m.info.shared_instants > 100);
    let reference = Reference::new(m.clone(), settings.bins);
    let rep = compare(settings, &reference, &[m]);
    assert!((rep.scores[0].fitness - 1.0).abs() < 1e-12);
    let speed = &rep.metrics[Metric::Speed.index()].reference;
    assert!(
        speed.median > 0.05 && speed.median < 2.0,
        "median speed {}",
        speed.median
    );
    let json = serde_json::to_string(&rep).unwrap();
    assert!(!json.contains("NaN"));
}

/// A small chart: grey reference bars, a step outline, a circle, the figure legend.
fn sample_figure() -> Figure {
    Figure::draw(320, 220, |root| {
        let mut ch = ChartBuilder::on(root)
            .margin(px(10.0))
            .x_label_area_size(px(30.0))
            .y_label_area_size(px(40.0))
            .build_cartesian_2d(0.0..2.0, 0.0..1.0)?;
        ch.configure_mesh()
            .label_style(text(12.0, palette::TEXT))
            .y_desc("probability")
            .axis_desc_style(text(12.0, palette::TEXT))
            .draw()?;
        let edges = [0.0, 0.5, 1.0, 1.5, 2.0];
        ch.draw_series([0.2, 0.8, 0.5, 0.1].iter().enumerate().map(|(i, &h)| {
            Rectangle::new(
                [(edges[i], 0.0), (edges[i + 1], h)],
                palette::LIGHT_GREY.filled(),
            )
        }))?;
        ch.draw_series([PathElement::new(
            vec![
                (0.0, 0.3),
                (0.5, 0.3),
                (0.5, 0.6),
                (1.0, 0.6),
                (1.0, 0.4),
                (2.0, 0.2),
            ],
            palette::series(0).stroke_width(px(2.0) as u32),
        )])?;
        ch.draw_series([Circle::new(
            (1.2, 0.7),
            px(20.0),
            palette::series(1).stroke_width(px(1.0) as u32),
        )])?;
        let mut l = Legend::default();
        l.add(
            "real",
            Mark::Area {
                fill: palette::LIGHT_GREY.to_rgba(),
                edge: palette::GREY,
            },
        );
        l.add("sim ω", Mark::Line(palette::series(0).to_rgba()));
        l.draw(root, 180.0, 20.0, 130.0)
    })
    .unwrap()
}

#[test]
fn plot_writes_a_valid_deterministic_png() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.png");
    let b = dir.path().join("b.png");
    // Drawn on another thread too: the font registry is global, the output must not care.
    let other = std::thread::spawn(sample_figure).join().unwrap();
    sample_figure().save_png(&a).unwrap();
    other.save_png(&b).unwrap();
    let (ba, bb) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert_eq!(ba, bb, "same drawing, same bytes");
    assert_eq!(&ba[..8], b"\x89PNG\r\n\x1a\n");
    // Only the image header and data: no time stamp or text chunk that could vary.
    let chunks: Vec<&[u8]> = {
        let mut at = 8;
        let mut v = Vec::new();
        while at + 8 <= ba.len() {
            let len = u32::from_be_bytes(ba[at..at + 4].try_into().unwrap()) as usize;
            v.push(&ba[at + 4..at + 8]);
            at += 12 + len;
        }
        v
    };
    assert!(
        chunks
            .iter()
            .all(|c| [&b"IHDR"[..], b"IDAT", b"IEND"].contains(c)),
        "{:?}",
        chunks
            .iter()
            .map(|c| String::from_utf8_lossy(c))
            .collect::<Vec<_>>()
    );
    let dec = png::Decoder::new(std::io::Cursor::new(ba));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (320, 220));
    assert_eq!(&buf[..info.buffer_size()], sample_figure().pixels());
    // The text is drawn: the legend's label area is not blank.
    let fig = sample_figure();
    let inked = (220..300)
        .flat_map(|x| (25..60).map(move |y| (x, y)))
        .filter(|&(x, y)| fig.get(x, y).unwrap()[0] < 150)
        .count();
    assert!(inked > 30, "legend text pixels: {inked}");
    // Only the PNGs are left: the temporary files were renamed.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
}

#[test]
fn a_shot_mixing_models_bakes_empty_channel_cells_that_eval_reads() {
    // Bees record pitch, roll, sway and state; curl agents record none.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("mix.toml"),
        "[scene]\nframes = [1, 12]\n[[swarm]]\nname = \"bees\"\ncount = 4\n[[swarm]]\nname = \"drift\"\nmodel = \"curl\"\ncount = 3\n",
    )
    .unwrap();
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_beeswarm"))
        .args(["bake", "mix.toml", "--format", "csv", "--out", "out"])
        .current_dir(dir.path())
        .status()
        .unwrap();
    assert!(status.success());
    let path = dir.path().join("out/mix.tracks.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), beeswarm::export::csv::HEADER);
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 7 * 12);
    // Ids 0–3 are bees (every cell filled), 4–6 curl agents (the four channels empty).
    for row in &rows {
        let cells: Vec<&str> = row.split(',').collect();
        let id: u64 = cells[0].parse().unwrap();
        let empty = cells[13..].iter().filter(|c| c.is_empty()).count();
        assert_eq!(empty, if id < 4 { 0 } else { 4 }, "{row}");
    }
    let ds = beeswarm::eval::tracks::read(&path).unwrap();
    assert_eq!(ds.tracks.len(), 7);
    assert!(ds.tracks.iter().all(|t| t.position.len() == 12));
}
