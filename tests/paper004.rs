//! Paper 004 (Chen et al. 2022, butterfly flight) claims, each measured on its example shot
//! (`examples/butterfly_*.toml`) baked in memory. The numbers are printed
//! (`cargo test --release --test paper004 -- --nocapture`) and recorded in docs/model.md.

use beeswarm::geometry::signed_distance;
use beeswarm::model::butterfly::BUTTERFLY_CHANNELS;
use beeswarm::model::butterfly::maneuvering::{Angle, frequency, sigmoid};
use beeswarm::shot::Shot;
use beeswarm::sim::Simulation;
use glam::Vec3;
use std::path::Path;

mod common;

/// Per frame, per swarm: positions and the channels by name.
struct Baked {
    shot: Shot,
    /// `[frame][swarm][agent]`
    pos: Vec<Vec<Vec<Vec3>>>,
    /// `[frame][swarm][channel][agent]`
    channels: Vec<Vec<Vec<Vec<f32>>>>,
    names: Vec<&'static str>,
}

impl Baked {
    fn column(&self, name: &str) -> usize {
        self.names.iter().position(|n| *n == name).unwrap()
    }

    /// Every value of channel `name` of swarm `s` from frame `from` on, agent after agent
    /// within a frame.
    fn values(&self, s: usize, name: &str, from: usize) -> Vec<f32> {
        let c = self.column(name);
        self.channels[from..]
            .iter()
            .flat_map(|f| f[s][c].iter().copied())
            .collect()
    }
}

fn bake_shot(shot: Shot) -> Baked {
    let mut sim = Simulation::new(&shot);
    let names = BUTTERFLY_CHANNELS.iter().map(|c| c.name).collect();
    let mut b = Baked {
        shot: shot.clone(),
        pos: Vec::new(),
        channels: Vec::new(),
        names,
    };
    loop {
        let r = sim.record();
        b.pos.push(r.iter().map(|s| s.position.clone()).collect());
        b.channels
            .push(r.iter().map(|s| s.channels.clone()).collect());
        if sim.done() {
            break;
        }
        sim.advance();
    }
    b
}

fn example_text(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name);
    std::fs::read_to_string(path).unwrap()
}

fn bake(name: &str) -> Baked {
    bake_shot(common::shot(&example_text(name)))
}

fn mean(v: &[f32]) -> f32 {
    v.iter().sum::<f32>() / v.len() as f32
}

fn correlation(a: &[f32], b: &[f32]) -> f32 {
    let (ma, mb) = (mean(a), mean(b));
    let (mut sab, mut saa, mut sbb) = (0.0f64, 0.0f64, 0.0f64);
    for (x, y) in a.iter().zip(b) {
        let (dx, dy) = ((x - ma) as f64, (y - mb) as f64);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    (sab / (saa * sbb).sqrt()) as f32
}

fn median(mut v: Vec<f32>) -> f32 {
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

/// Eq. 2: with the window of Eq. 12 off, the frequency of each cycle is R_f σ(|u(t0)|)
/// (floored at `min_flap_hz`); with it on, frequency still rises with speed.
#[test]
fn flap_frequency_rises_with_speed_as_eq2_gives() {
    let src = example_text("butterfly_travelling.toml");
    let raw = src.replace(
        "params = { sense_length = 10 }",
        "params = { sense_length = 10, window = 0 }",
    );
    assert_ne!(raw, src);
    let b = bake_shot(common::shot(&raw));
    let p = &b.shot.swarms[0].params;
    let (umax, floor) = (
        p.get("max_speed").unwrap() as f32,
        p.get("min_flap_hz").unwrap() as f32,
    );
    // Every frame: the cycle's frequency from the speed at its start.
    let (hz, speed) = (b.values(0, "flap_hz", 0), b.values(0, "cycle_speed", 0));
    let mut worst = 0.0f32;
    let mut above_floor = 0;
    for k in 0..hz.len() {
        let expect = frequency(Angle::Flap, sigmoid(speed[k], umax)).max(floor);
        worst = worst.max((hz[k] - expect).abs());
        above_floor += usize::from(expect > floor);
    }
    println!(
        "Eq. 2 without smoothing: {} samples ({above_floor} above the floor), largest |f − R_f σ(|u(t0)|)| = {worst:.2e} Hz",
        hz.len()
    );
    assert!(above_floor > hz.len() / 2, "{above_floor}");
    assert!(worst < 1e-4, "{worst}");

    // Smoothed (Eq. 12, k = 10): mean frequency per speed band still rises.
    let b = bake("butterfly_travelling.toml");
    let (hz, speed) = (b.values(0, "flap_hz", 30), b.values(0, "speed", 30));
    let bands = [0.0, 0.6, 0.8, 1.0, 1.2, 10.0];
    let means: Vec<f32> = bands
        .windows(2)
        .map(|w| {
            let v: Vec<f32> = (0..hz.len())
                .filter(|&k| speed[k] >= w[0] && speed[k] < w[1])
                .map(|k| hz[k])
                .collect();
            mean(&v)
        })
        .collect();
    let r = correlation(&speed, &hz);
    println!(
        "smoothed: mean flap Hz per speed band {bands:?}: {means:.2?}; corr(speed, f) = {r:.2}"
    );
    assert!(means.windows(2).all(|m| m[1] > m[0]), "{means:?}");
    assert!(r > 0.5, "{r}");
}

/// Sec. 4.1: the abdomen moves with the opposite phase to the wings' flapping.
#[test]
fn wing_flap_and_abdomen_are_anti_correlated() {
    let b = bake("butterfly_path.toml");
    let (flap, abdomen) = (b.values(0, "flap", 0), b.values(0, "abdomen", 0));
    let r = correlation(&flap, &abdomen);
    println!("corr(θ_γ, θ_φ) = {r:.4} over {} frames", flap.len());
    assert!(r < -0.99, "{r}");
}

/// Fig. 16 top: a heavier butterfly flies lower and flaps faster.
#[test]
fn heavier_butterflies_fly_lower_and_flap_faster() {
    let src = example_text("butterfly_path.toml");
    let mut heights = Vec::new();
    let mut freqs = Vec::new();
    for factor in [0.5, 1.0, 2.0] {
        let text = src.replace("count = 1\n", "count = 8\n").replace(
            "preset = \"monarch\"\n",
            &format!(
                "preset = \"monarch\"\nparams = {{ mass = {} }}\n",
                0.428e-3 * factor
            ),
        );
        let b = bake_shot(common::shot(&text));
        // After the first 2 s.
        let y: Vec<f32> = b.pos[60..]
            .iter()
            .flat_map(|f| f[0].iter().map(|p| p.y))
            .collect();
        heights.push(mean(&y));
        freqs.push(mean(&b.values(0, "flap_hz", 60)));
    }
    println!("mass ×0.5, ×1, ×2: mean height {heights:.3?} m, mean flap {freqs:.2?} Hz");
    assert!(
        heights[0] > heights[1] && heights[1] > heights[2],
        "{heights:?}"
    );
    assert!(freqs[2] > freqs[1] && freqs[1] > freqs[0], "{freqs:?}");
}

/// Fig. 10: when the wind disappears, the butterfly recovers its normal flight. Measured
/// on the group: the median speed and the median distance from the flower return to
/// their values before the gust.
#[test]
fn speed_recovers_within_seconds_after_the_gust() {
    // One seed's ten butterflies make a noisy measure (a change in the last bits of the
    // angle of attack moved it from 1.0 s to 4.0 s): the claim is asserted on the median
    // of eight seeds.
    let text = example_text("butterfly_wind.toml");
    assert!(text.contains("\nseed = 5"));
    let mut times = Vec::new();
    for seed in 5..13 {
        let b = bake_shot(common::shot(
            &text.replace("\nseed = 5", &format!("\nseed = {seed}")),
        ));
        let (speed0, dist0, dist_gust, recovered) = recovery(&b);
        println!(
            "seed {seed}: before the gust median speed {speed0:.2} m/s, {dist0:.2} m from the \
             flower; at the gust's end {dist_gust:.2} m; back within 25 % / 20 % after \
             {recovered:?} s"
        );
        assert!(
            dist_gust > 1.5 * dist0,
            "the gust must push them off: {dist_gust} vs {dist0}"
        );
        times.push(recovered.expect("never recovered"));
    }
    let m = median(times.clone());
    println!("median recovery {m:.2} s over {times:?}");
    assert!(m < 3.0, "{m}");
}

/// Group medians before and after the gust (`butterfly_wind.toml`'s `gust_*` params):
/// speed and distance to the flower two seconds before it starts, the distance in its
/// last second, and how long after it ends until a one-second window's median speed is
/// back within 25 % and the median distance within 20 %.
fn recovery(b: &Baked) -> (f32, f32, f32, Option<f32>) {
    let fps = b.shot.fps as f32;
    let p = &b.shot.swarms[0].params;
    let (start, end) = (
        p.get("gust_start").unwrap() as f32,
        p.get("gust_end").unwrap() as f32,
    );
    let flower = b.shot.targets[0].keys[0].1;
    let frame = |t: f32| (t * fps).round() as usize;
    let c = b.column("speed");
    // Medians over the group in a one-second window from time t.
    let window = |t: f32| {
        let (mut s, mut d) = (Vec::new(), Vec::new());
        for f in frame(t)..frame(t + 1.0) {
            s.extend(b.channels[f][0][c].iter().copied());
            d.extend(b.pos[f][0].iter().map(|q| q.distance(flower)));
        }
        (median(s), median(d))
    };
    let (speed0, dist0) = window(start - 2.0);
    let (_, dist_gust) = window(end - 1.0);
    let mut t = end;
    while t + 1.0 < b.pos.len() as f32 / fps {
        let (s, d) = window(t);
        if (s - speed0).abs() <= 0.25 * speed0 && d <= 1.2 * dist0 {
            return (speed0, dist0, dist_gust, Some(t - end));
        }
        t += 1.0 / fps;
    }
    (speed0, dist0, dist_gust, None)
}

/// No butterfly is ever inside an obstacle or under the ground, in any example.
#[test]
fn no_butterfly_enters_an_obstacle_or_the_ground() {
    for name in [
        "butterfly_path.toml",
        "butterfly_wind.toml",
        "butterfly_rain.toml",
        "butterfly_chasing.toml",
        "butterfly_aggregation.toml",
        "butterfly_travelling.toml",
    ] {
        let b = bake(name);
        let mut worst = f32::INFINITY;
        for frame in &b.pos {
            for (s, swarm) in frame.iter().enumerate() {
                let r = b.shot.swarms[s].bee.radius;
                for p in swarm {
                    for o in &b.shot.obstacles {
                        worst = worst.min(signed_distance(&o.shape, *p) - r);
                    }
                }
            }
        }
        println!("{name}: smallest gap to an obstacle {:.2} mm", worst * 1e3);
        assert!(worst > -1e-4, "{name}: {worst}");
    }
}

/// Fig. 12: the follower keeps close to the leader it chases.
#[test]
fn the_follower_chases_the_leader() {
    let b = bake("butterfly_chasing.toml");
    let d: Vec<f32> = b.pos[90..]
        .iter()
        .map(|f| f[0][0].distance(f[1][0]))
        .collect();
    let (m, max) = (median(d.clone()), d.iter().copied().fold(0.0, f32::max));
    println!("chasing: median gap {m:.2} m, largest {max:.2} m after 3 s");
    assert!(m < 1.5 && max < 4.5, "{m} {max}");
}

/// The path example with `params` for its swarm (and `count` butterflies): the bake and
/// the mean distance to the guide after the first 2 s (60 frames).
fn path_run(count: usize, params: &str) -> (Baked, f32) {
    let src = example_text("butterfly_path.toml");
    let text = src
        .replace("count = 1\n", &format!("count = {count}\n"))
        .replace(
            "preset = \"monarch\"\n",
            &format!("preset = \"monarch\"\nparams = {{ {params} }}\n"),
        );
    assert_ne!(text, src);
    let b = bake_shot(common::shot(&text));
    let guide = &b.shot.targets[0];
    let mut err = Vec::new();
    for (k, f) in b.pos.iter().enumerate().skip(60) {
        let g = guide.position_at((b.shot.frame_start as usize + k) as f64);
        err.extend(f[0].iter().map(|p| p.distance(g)));
    }
    let e = mean(&err);
    (b, e)
}

/// Sec. 5.2 / Fig. 8: the vortex force makes the path noisy, so without it (η = 0) the
/// butterfly keeps closer to the guide it follows.
#[test]
fn path_error_is_lower_without_the_vortex_force() {
    let (_, with) = path_run(8, "eta = 3.66");
    let (_, without) = path_run(8, "eta = 0");
    println!("mean distance to the guide after 2 s: η = 3.66 {with:.3} m, η = 0 {without:.3} m");
    assert!(without < with, "{without} vs {with}");
}
