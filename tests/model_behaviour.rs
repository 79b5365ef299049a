//! The behaviours paper 000 describes, checked on the whole simulation.

mod common;

use beeswarm::geometry::signed_distance;
use beeswarm::sim::Simulation;
use common::*;
use glam::Vec3;

/// A single bee flying along +X at 2 m/s from x = −0.25 through `obstacles` (TOML),
/// without noise. It starts close to the obstacles so its maneuvering sway (Eq. 4) cannot
/// carry it out of their way before it sees them.
fn lone_bee(obstacles: &str, frames: u32) -> Simulation {
    let src = format!(
        "[scene]\nfps = 100\nframes = [1, {frames}]\nsubsteps = 2\n[[swarm]]\ncount = 1\nvariation = {{ size = 0, speed = 0, phase = 0 }}\nbounds = {{ center = [0, 1, 0], size = [40, 40, 40] }}\nparams = {{ kappa2 = 0, speed = 2.0 }}\nspawn = {{ shape = \"sphere\", center = [-0.25, 1, 0], radius = 0.001 }}\n{obstacles}"
    );
    let mut sim = Simulation::new(&shot(&src));
    sim.set_bee(0, Vec3::new(-0.25, 1.0, 0.0), Vec3::new(2.0, 0.0, 0.0));
    sim
}

/// Roll (degrees) and z position per frame of the lone bee.
fn roll_and_z(obstacles: &str, frames: u32) -> Vec<(f32, f32, f32)> {
    let mut out = Vec::new();
    let sim = lone_bee(obstacles, frames);
    let roll = sim.meta().swarms[0]
        .channel("roll")
        .expect("a roll channel");
    run_with(sim, |sim| {
        let s = &sim.record()[0];
        out.push((s.position[0].x, s.channels[roll][0], s.position[0].z));
    });
    out
}

/// A sphere of radius 0.15 m ahead of the bee, its centre 5 cm off the flight line on the
/// side `side` (−1 left, +1 right): the bee flies at it and must go round.
fn sphere_beside(side: f32) -> String {
    format!(
        "[[obstacle]]\ntype = \"sphere\"\ncenter = [0.1, 1, {}]\nradius = 0.15\n",
        side * 0.05
    )
}

#[test]
fn roll_to_avoid_banks_away_from_an_obstacle_on_either_side() {
    // The same bee with and without the shaft: the difference is the avoidance.
    let free = roll_and_z("", 60);
    for (side_z, expected_sign) in [(-1.0f32, 1.0f32), (1.0, -1.0)] {
        // A sphere just off the flight line, on the left (−Z) or the right (+Z).
        let obstacle = sphere_beside(side_z);
        let with = roll_and_z(&obstacle, 60);
        let extra_roll = with
            .iter()
            .zip(&free)
            .map(|(w, f)| (w.1 - f.1) * expected_sign)
            .fold(f32::MIN, f32::max);
        let wrong_roll = with
            .iter()
            .zip(&free)
            .map(|(w, f)| (w.1 - f.1) * -expected_sign)
            .fold(f32::MIN, f32::max);
        let (w_end, f_end) = (with.last().unwrap(), free.last().unwrap());
        println!(
            "obstacle on side {side_z}: extra roll away {extra_roll:.1}°, towards {wrong_roll:.1}°, lateral shift {:.3} m",
            w_end.2 - f_end.2
        );
        assert!(
            extra_roll > 8.0,
            "the bee banks away from the obstacle: {extra_roll}°"
        );
        assert!(wrong_roll < 1.0, "never towards it: {wrong_roll}°");
        // Banking away moves the bee away: positive roll pushes right (+Z).
        assert!(
            (w_end.2 - f_end.2) * expected_sign > 0.01,
            "pushed away from the obstacle"
        );
    }
}

#[test]
fn the_bee_levels_out_after_passing_an_obstacle() {
    let free = roll_and_z("", 100);
    let with = roll_and_z(&sphere_beside(-1.0), 100);
    let during = with
        .iter()
        .zip(&free)
        .map(|(w, f)| (w.1 - f.1).abs())
        .fold(0.0f32, f32::max);
    // Once past (x > 0.5 m) the roll is back on the maneuvering function Eq. 4.
    let after = with
        .iter()
        .zip(&free)
        .filter(|(w, _)| w.0 > 0.5)
        .map(|(w, f)| (w.1 - f.1).abs())
        .fold(0.0f32, f32::max);
    println!(
        "roll departs from Eq. 4 by up to {during:.1}° near the obstacle and by {after:.3}° after it"
    );
    assert!(
        during > 8.0 && after < 0.5,
        "during {during}, after {after}"
    );
}

#[test]
fn bees_flying_at_a_wall_for_ten_seconds_never_enter_it() {
    let src = r#"
[scene]
fps = 24
frames = [1, 241]
substeps = 4
seed = 4
[[swarm]]
count = 150
preset = "grassland"
spawn = { shape = "box", center = [-0.8, 1, 0], size = [0.6, 0.6, 0.6] }
[[obstacle]]
type = "box"
center = [0.3, 1, 0]
size = [0.2, 3, 3]
[[target]]
type = "attractor"
position = [1.5, 1, 0]
strength = 6
"#;
    let sh = shot(src);
    let wall = sh.obstacles[0].shape.clone();
    let r = sh.swarms[0].bee.radius * (1.0 + sh.swarms[0].variation.size);
    let mut closest = f32::INFINITY;
    let mut near = 0;
    let frames = run_with(Simulation::new(&sh), assert_all_finite);
    for f in &frames {
        for p in f {
            let d = signed_distance(&wall, *p);
            closest = closest.min(d);
            if d < 0.05 {
                near += 1;
            }
        }
    }
    println!(
        "closest approach to the wall: {:.4} m ({} bee-frames within 5 cm)",
        closest, near
    );
    assert!(
        near > 100,
        "the attractor must press bees against the wall for the test to mean anything"
    );
    assert!(closest >= 0.0, "a bee entered the wall: {closest}");
    assert!(
        closest > -1e-6
            && frames
                .iter()
                .flatten()
                .all(|p| signed_distance(&wall, *p) >= 0.0)
    );
    let _ = r;
}

#[test]
fn a_swarm_passing_a_row_of_shafts_has_zero_penetrations() {
    let src = common::shafts_src();
    let sh = shot(&src);
    let r = sh.swarms[0].bee.radius;
    let mut penetrations = 0;
    let mut rolled = 0;
    let sim = Simulation::new(&sh);
    let roll = sim.meta().swarms[0]
        .channel("roll")
        .expect("a roll channel");
    let frames = run_with(sim, |sim| {
        assert_all_finite(sim);
        rolled += sim.record()[0].channels[roll]
            .iter()
            .filter(|r| r.abs() > 25.0)
            .count();
    });
    for f in &frames {
        for p in f {
            if sh
                .obstacles
                .iter()
                .any(|o| signed_distance(&o.shape, *p) < r * 0.9 - 1e-5)
            {
                penetrations += 1;
            }
        }
    }
    let crossed = frames.last().unwrap().iter().filter(|p| p.x > 0.1).count();
    println!(
        "{crossed} of 120 bees crossed the row of shafts; {rolled} bee-frames rolled past 25°"
    );
    assert_eq!(penetrations, 0);
    assert!(crossed > 60, "most bees get through the row: {crossed}");
    assert!(rolled > 0, "bees roll to avoid the shafts");
}

#[test]
fn bees_keep_apart_in_a_dense_swarm() {
    let src = r#"
[scene]
fps = 24
frames = [1, 97]
seed = 5
[[swarm]]
count = 400
preset = "nest"
spawn = { shape = "sphere", center = [0, 1, 0], radius = 0.25 }
bounds = { center = [0, 1, 0], size = [0.6, 0.6, 0.6] }
params = { containment = 20 }
"#;
    let sh = shot(src);
    let frames = run(&sh);
    let contact = 2.0 * sh.swarms[0].bee.radius;
    let mut min_d = f32::INFINITY;
    let mut touching = 0usize;
    let mut pairs = 0usize;
    for f in &frames[24..] {
        for i in 0..f.len() {
            for j in i + 1..f.len() {
                let d = f[i].distance(f[j]);
                min_d = min_d.min(d);
                pairs += 1;
                if d < contact {
                    touching += 1;
                }
            }
        }
    }
    // 400 bees in a 0.6 m box: about 1850 bees per cubic metre.
    println!(
        "dense swarm: minimum centre distance {:.4} m (body contact at {contact} m), {touching} of {pairs} pair-frames touching",
        min_d
    );
    assert!(min_d > contact * 0.5, "bodies overlap deeply: {min_d}");
    assert!(
        (touching as f64) < pairs as f64 * 1e-4,
        "touching {touching} of {pairs}"
    );
}

/// Local minima of a distance series that are at least `depth` below the maxima around them.
fn approach_cycles(d: &[f32], depth: f32) -> usize {
    common::turnarounds(d, depth).len()
}

#[test]
fn a_nest_produces_repeated_approach_and_retreat() {
    let src = r#"
[scene]
fps = 25
frames = [1, 501]
seed = 6
[[swarm]]
count = 30
preset = "nest"
spawn = { shape = "box", center = [0, 1, 0.7], size = [0.8, 0.4, 0.4] }
[[target]]
type = "nest"
position = [0, 1, 0]
"#;
    let frames = run(&shot(src));
    let nest = Vec3::new(0.0, 1.0, 0.0);
    let mut cycles: Vec<usize> = (0..30)
        .map(|b| {
            approach_cycles(
                &frames
                    .iter()
                    .map(|f| f[b].distance(nest))
                    .collect::<Vec<_>>(),
                0.1,
            )
        })
        .collect();
    let closest = frames
        .iter()
        .flatten()
        .map(|p| p.distance(nest))
        .fold(f32::INFINITY, f32::min);
    cycles.sort();
    println!(
        "approach–retreat cycles per bee in 20 s: {cycles:?}; closest approach {closest:.3} m"
    );
    assert!(cycles[15] >= 4, "median {} cycles", cycles[15]);
    assert!(
        closest > 0.08,
        "the nest pushes bees back before they reach its body: {closest}"
    );
}

#[test]
fn vertical_oscillation_peaks_at_the_maneuvering_frequency() {
    let fps = 100.0;
    let src = "[scene]\nfps = 100\nframes = [1, 2000]\n[[swarm]]\ncount = 1\nvariation = { size = 0, speed = 0, phase = 0 }\nbounds = { center = [0, 1, 0], size = [200, 200, 200] }\nparams = { kappa2 = 0, speed = 3.0 }\n";
    // Vertical velocity after the start-up transient (the initial climb decays in ~1 s).
    let mut vy = Vec::new();
    run_with(Simulation::new(&shot(src)), |sim| {
        if sim.frame() > 300 {
            vy.push(sim.record()[0].velocity[0].y as f64)
        }
    });
    let y = vy;
    // Remove the linear trend, then find the strongest frequency between 0.3 and 10 Hz.
    let n = y.len() as f64;
    let (mx, my) = ((n - 1.0) / 2.0, y.iter().sum::<f64>() / n);
    let slope = y
        .iter()
        .enumerate()
        .map(|(i, v)| (i as f64 - mx) * (v - my))
        .sum::<f64>()
        / y.iter()
            .enumerate()
            .map(|(i, _)| (i as f64 - mx).powi(2))
            .sum::<f64>();
    let detrended: Vec<f64> = y
        .iter()
        .enumerate()
        .map(|(i, v)| v - my - slope * (i as f64 - mx))
        .collect();
    let power = |f: f64| {
        let (mut re, mut im) = (0.0, 0.0);
        for (i, v) in detrended.iter().enumerate() {
            let a = std::f64::consts::TAU * f * i as f64 / fps;
            re += v * a.cos();
            im += v * a.sin();
        }
        re * re + im * im
    };
    let freqs: Vec<f64> = (30..1000).map(|k| k as f64 * 0.01).collect();
    let peak = freqs.iter().copied().fold((0.0, 0.0), |(bf, bp), f| {
        let p = power(f);
        if p > bp { (f, p) } else { (bf, bp) }
    });
    let unit = beeswarm::model::BeeParams::nest().oscillation_time_unit;
    let expected = 1.0 / (beeswarm::model::bee::oscillation::PITCH_PERIOD * unit);
    println!(
        "vertical spectrum peak {:.3} Hz, Eq. 3 frequency {:.3} Hz",
        peak.0, expected
    );
    assert!(
        (peak.0 - expected).abs() < 0.05,
        "peak {} Hz, expected {expected} Hz",
        peak.0
    );
}

#[test]
fn degenerate_cases_never_produce_nan() {
    // Coincident bees (a spawn sphere far below float resolution), zero velocity, a bee
    // exactly on an obstacle surface, a bee spawned inside an obstacle, a bee on a box's
    // centre, all at once.
    let src = r#"
[scene]
fps = 24
frames = [1, 49]
[[swarm]]
count = 40
spawn = { shape = "sphere", center = [0, 1, 0], radius = 1e-9 }
[[obstacle]]
type = "sphere"
center = [0.5, 1, 0]
radius = 0.2
[[obstacle]]
type = "box"
center = [-0.5, 1, 0]
size = [0.2, 0.2, 0.2]
[[obstacle]]
type = "cylinder"
center = [0, 1, 0.5]
radius = 0.1
height = 0.5
[[target]]
type = "nest"
position = [0, 1, 0]
"#;
    let sh = shot(src);
    let mut sim = Simulation::new(&sh);
    sim.set_bee(0, Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO);
    sim.set_bee(1, Vec3::new(0.3, 1.0, 0.0), Vec3::new(1.0, 0.0, 0.0)); // on the sphere's surface
    sim.set_bee(2, Vec3::new(-0.5, 1.0, 0.0), Vec3::ZERO); // at the box's centre
    sim.set_bee(3, Vec3::new(0.0, 1.0, 0.5), Vec3::ZERO); // on the cylinder's axis
    sim.set_bee(4, Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO); // coincident with bee 0 and the nest centre
    let frames = run_with(sim, assert_all_finite);
    let r = sh.swarms[0].bee.radius * 0.9;
    for p in frames.last().unwrap() {
        for o in &sh.obstacles {
            assert!(
                signed_distance(&o.shape, *p) >= r - 1e-5,
                "bee left inside {o:?} at {p}"
            );
        }
    }
}

/// Speed samples (m/s, every frame of every bee) and the mean angle (degrees) between the
/// body's horizontal heading and the horizontal velocity, for a few bees flying freely
/// with curl noise and the given parameter overrides.
fn free_flight(params: &str) -> (Vec<f32>, f32) {
    let src = format!(
        "[scene]\nfps = 50\nframes = [1, 1000]\nseed = 5\n[[swarm]]\ncount = 8\nvariation = {{ speed = 0 }}\nbounds = {{ center = [0, 1, 0], size = [6, 6, 6] }}\nparams = {{ speed = 0.5, {params} }}\nspawn = {{ shape = \"box\", center = [0, 1, 0], size = [2, 2, 2] }}\n"
    );
    let (mut speeds, mut angle, mut n) = (Vec::new(), 0.0f32, 0);
    run_with(Simulation::new(&shot(&src)), |sim| {
        let s = &sim.record()[0];
        for (v, q) in s.velocity.iter().zip(&s.orientation) {
            speeds.push(v.length());
            let f = *q * Vec3::X;
            let (f, v) = (Vec3::new(f.x, 0.0, f.z), Vec3::new(v.x, 0.0, v.z));
            if v.length() > 0.05 && f.length() > 1e-3 {
                angle += f.angle_between(v).to_degrees();
                n += 1;
            }
        }
    });
    (speeds, angle / n.max(1) as f32)
}

fn mean_and_cv(x: &[f32]) -> (f32, f32) {
    let m = x.iter().sum::<f32>() / x.len() as f32;
    let var = x.iter().map(|v| (v - m) * (v - m)).sum::<f32>() / x.len() as f32;
    (m, var.sqrt() / m)
}

#[test]
fn speed_wander_widens_the_speed_distribution_around_the_same_mean() {
    let (steady, _) = free_flight("speed_wander = 0.0");
    let (wander, _) = free_flight("speed_wander = 0.6, speed_wander_time = 0.5");
    let (m0, cv0) = mean_and_cv(&steady);
    let (m1, cv1) = mean_and_cv(&wander);
    println!("steady: mean {m0:.3} m/s, cv {cv0:.3}; wandering: mean {m1:.3} m/s, cv {cv1:.3}");
    assert!(
        cv1 > 1.5 * cv0,
        "wandering should widen the speed spread: cv {cv1} vs {cv0}"
    );
    // The log-normal factor keeps the mean preferred speed.
    assert!(
        (m1 / m0 - 1.0).abs() < 0.25,
        "mean speed moved too far: {m1} vs {m0}"
    );
}

#[test]
fn a_longer_heading_lag_lets_body_and_velocity_differ_more() {
    let (_, quick) = free_flight("kappa2 = 3.0, heading_lag = 0.03");
    let (_, slow) = free_flight("kappa2 = 3.0, heading_lag = 0.5");
    println!("mean heading-velocity angle: lag 0.03 s {quick:.2}°, lag 0.5 s {slow:.2}°");
    assert!(
        slow > 2.0 * quick,
        "a slow heading should trail the velocity more: {slow}° vs {quick}°"
    );
}

/// The fraction of frames (all bees) spent within 10 cm above the ground at y = 0, for a
/// few bees flying in a 2 m room, with `extra` (TOML) added to the shot.
fn share_near_the_ground(extra: &str) -> f32 {
    let src = format!(
        "[scene]\nfps = 50\nframes = [1, 1000]\nseed = 7\n[[swarm]]\ncount = 8\nbounds = {{ center = [0, 1, 0], size = [2, 2, 2] }}\nparams = {{ speed = 0.3, avoid_distance = 0.05 }}\nspawn = {{ shape = \"box\", center = [0, 1.2, 0], size = [1, 1, 1] }}\n[[obstacle]]\ntype = \"plane\"\nname = \"ground\"\n{extra}"
    );
    let (mut near, mut n) = (0usize, 0usize);
    run_with(Simulation::new(&shot(&src)), |sim| {
        for p in &sim.record()[0].position {
            assert!(p.y >= 0.0, "a bee went through the ground: {p}");
            near += (p.y < 0.1) as usize;
            n += 1;
        }
    });
    near as f32 / n as f32
}

#[test]
fn a_landing_surface_draws_bees_down_to_it_without_letting_them_through() {
    let free = share_near_the_ground("");
    let landing = share_near_the_ground(
        "[[target]]\ntype = \"surface\"\nposition = [0, 0, 0]\nnormal = [0, 1, 0]\nstrength = 1.0\n",
    );
    println!("share of frames within 10 cm of the ground: free {free:.3}, landing {landing:.3}");
    assert!(
        landing > 0.3 && free < 0.1,
        "the surface should hold bees near it: {landing} vs {free} without it"
    );
}

/// Median speeds (m/s) of bees over a landing surface at y = 0: within 3 cm of it and more
/// than 25 cm above it, with `params` (TOML) added to the swarm's parameters.
fn speeds_low_and_high(params: &str) -> (f32, f32) {
    let src = format!(
        "[scene]\nfps = 50\nframes = [1, 1500]\nseed = 3\n[[swarm]]\ncount = 8\nvariation = {{ speed = 0 }}\nbounds = {{ center = [0, 1, 0], size = [2, 2, 2] }}\nparams = {{ speed = 0.3, avoid_distance = 0.05, {params} }}\nspawn = {{ shape = \"box\", center = [0, 0.6, 0], size = [1, 1, 1] }}\n[[obstacle]]\ntype = \"plane\"\nname = \"ground\"\n[[target]]\ntype = \"surface\"\nposition = [0, 0, 0]\nnormal = [0, 1, 0]\nstrength = 0.5\n"
    );
    let (mut low, mut high) = (Vec::new(), Vec::new());
    run_with(Simulation::new(&shot(&src)), |sim| {
        let s = &sim.record()[0];
        for (p, v) in s.position.iter().zip(&s.velocity) {
            if p.y < 0.03 {
                low.push(v.length());
            } else if p.y > 0.25 {
                high.push(v.length());
            }
        }
    });
    let median = |v: &mut Vec<f32>| {
        assert!(v.len() > 200, "too few samples: {}", v.len());
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    };
    (median(&mut low), median(&mut high))
}

#[test]
fn a_bee_slows_near_a_surface_with_surface_speed() {
    let (low0, high0) = speeds_low_and_high("surface_speed = 1.0");
    let (low1, high1) = speeds_low_and_high("surface_speed = 0.3, surface_speed_distance = 0.1");
    println!(
        "median speed near / far from the surface: off {low0:.3} / {high0:.3}, on {low1:.3} / {high1:.3} m/s"
    );
    assert!(
        low1 / high1 < 0.6 && low1 / high1 < 0.75 * (low0 / high0),
        "optic-flow control should slow bees near the surface: {low1}/{high1} vs {low0}/{high0}"
    );
}

#[test]
fn a_bee_stopped_in_a_corner_turns_and_flies_out() {
    // Two walls meeting along the Y axis; the bee sits 2 cm from both, facing the corner,
    // almost still, without noise to shake it loose.
    let src = "[scene]\nfps = 50\nframes = [1, 250]\n[[swarm]]\ncount = 1\nvariation = { size = 0, speed = 0, phase = 0 }\nbounds = { center = [1, 1, 1], size = [4, 4, 4] }\nparams = { kappa2 = 0, speed = 0.3, avoid_distance = 0.1 }\nspawn = { shape = \"sphere\", center = [0.02, 1, 0.02], radius = 0.001 }\n[[obstacle]]\ntype = \"plane\"\npoint = [0, 0, 0]\nnormal = [1, 0, 0]\n[[obstacle]]\ntype = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n";
    let mut sim = Simulation::new(&shot(src));
    sim.set_bee(0, Vec3::new(0.02, 1.0, 0.02), Vec3::new(-0.02, 0.0, -0.021));
    let frames = run_with(sim, |_| {});
    let end = frames.last().unwrap()[0];
    let clearance = end.x.min(end.z);
    let from_corner = (end.x * end.x + end.z * end.z).sqrt();
    println!(
        "after 5 s the bee is at {end}, {from_corner:.3} m from the corner, {clearance:.3} m \
         from the nearer wall"
    );
    // Out of the corner and off both walls (it may then fly on along one of them: since
    // issue 17 a slowed bee backs out of the corner while it turns, and without noise
    // nothing turns it further once it is clear of d0).
    assert!(
        from_corner > 0.3 && clearance > 0.05,
        "the bee should have turned and left the corner: {end}"
    );
}

#[test]
fn a_crowd_with_bounded_neighbours_still_spreads_out() {
    // 2,000 bees released in a 10 cm cube (2 million per m³): each feels only its 16
    // nearest (docs/model.md, "Bounded neighbours"), and their pressure must still push
    // the crowd apart — further than contact springs alone push it (1.68 m against 1.03 m
    // when measured) — with
    // every position finite.
    let spread_after_1s = |params: &str| {
        let src = format!(
            "[scene]\nframes = [1, 25]\n[[swarm]]\ncount = 2000\nparams = {{ {params} }}\nspawn = {{ shape = \"box\", center = [0, 1, 0], size = [0.1, 0.1, 0.1] }}\n"
        );
        let mut sim = Simulation::new(&shot(&src));
        while !sim.done() {
            sim.advance();
        }
        let p = &sim.record()[0].position;
        assert!(p.iter().all(|p| p.is_finite()));
        let c = p.iter().copied().sum::<Vec3>() / p.len() as f32;
        p.iter().map(|q| q.distance(c)).sum::<f32>() / p.len() as f32
    };
    let pushed = spread_after_1s("");
    let drifting = spread_after_1s("kappa3 = 0");
    assert!(
        pushed > 1.3 * drifting,
        "mean distance from the centre after 1 s: {pushed} m with repulsion, {drifting} m without"
    );
}

/// Bees of `model` drawn to an attractor at (0, 1, 0) that a 0.6 m closed box (a mesh)
/// covers at the first frame: with `keys`, the box moves off along +X over the first
/// second. Returns the body-frames within 0.3 m of the attractor over the last two
/// seconds (a ball the box holds whole at rest), and asserts at every frame that no body is
/// inside the box where it stands.
fn bees_at_a_place_a_mesh_leaves(model: &str, keys: bool) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let (v, t) = beeswarm_box();
    std::fs::write(dir.path().join("box.obj"), obj_text(&v, &t)).unwrap();
    let placement = if keys {
        "keys = [{ frame = 1, position = [0, 1, 0] }, { frame = 26, position = [3, 1, 0], rotation = [0, 90, 0] }]"
    } else {
        "position = [0, 1, 0]"
    };
    let src = format!(
        "[scene]\nframes = [1, 150]\n[[swarm]]\ncount = 40\nmodel = \"{model}\"\n\
         spawn = {{ center = [-0.6, 1, 0], size = [0.4, 0.6, 0.6] }}\n\
         [[obstacle]]\ntype = \"mesh\"\nfile = \"box.obj\"\n{placement}\n\
         [[target]]\nposition = [0, 1, 0]\nstrength = 3\n"
    );
    let shot = beeswarm::shot::parse(&src, &dir.path().join("s.toml"), dir.path()).unwrap();
    let o = shot.obstacles[0].clone();
    let radius = shot.swarms[0].bee.radius;
    let mut sim = Simulation::new(&shot);
    let mut near = 0;
    loop {
        // The box's centre at this frame; the box is axis-aligned in its rest frame.
        let pose = o.pose_at(sim.frame() as f64);
        for (p, s) in sim.record()[0].position.iter().zip(&sim.record()[0].scale) {
            let local = pose.map_or(*p - Vec3::Y, |r| r.to_rest(*p));
            let d = local.abs() - Vec3::splat(0.3);
            let outside = d.max(Vec3::ZERO).length() + d.max_element().min(0.0);
            assert!(
                outside - radius * s > -1e-4,
                "{model}, frame {}: a body inside the box",
                sim.frame()
            );
            if sim.frame() > 100 && (*p - Vec3::Y).length() < 0.3 {
                near += 1;
            }
        }
        if sim.done() {
            return near;
        }
        sim.advance();
    }
}

/// A 0.6 m cube centred at the origin, outward-wound.
fn beeswarm_box() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let v: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -0.3 } else { 0.3 },
                if i & 2 == 0 { -0.3 } else { 0.3 },
                if i & 4 == 0 { -0.3 } else { 0.3 },
            )
        })
        .collect();
    let t = vec![
        [0, 2, 3],
        [0, 3, 1],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    (v, t)
}

fn obj_text(v: &[Vec3], t: &[[u32; 3]]) -> String {
    let mut s = String::new();
    for p in v {
        s += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for f in t {
        s += &format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    s
}

/// The bee model and the zonal model (velocity obstacles) see where a moving mesh is
/// now: once the box has moved off the attractor, bees reach the attractor; with the
/// box left there, none can.
#[test]
fn bee_and_zonal_swarms_follow_a_moving_mesh() {
    for model in ["bee", "zonal"] {
        let static_box = bees_at_a_place_a_mesh_leaves(model, false);
        let moved = bees_at_a_place_a_mesh_leaves(model, true);
        println!(
            "{model}: {static_box} body-frames near the attractor under a static box, {moved} once it moved away"
        );
        assert_eq!(static_box, 0, "{model}: inside the static box");
        assert!(moved > 200, "{model}: {moved}");
    }
}
