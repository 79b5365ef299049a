//! Paper 002's claims (Ren et al. 2016), each measured on its example shot
//! (`examples/paper002_*.toml`) baked in memory with `model = "zonal"`: the tests assert
//! the claims on numbers measured from the tracks and print them (docs/validation.md
//! records them; `cargo test --release --test paper002 -- --nocapture` shows them).

mod common;

use beeswarm::eval::collective::{self, Frames};
use common::bake_example as bake;
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::Path;

fn centroid(p: &[Vec3]) -> Vec3 {
    p.iter().copied().sum::<Vec3>() / p.len() as f32
}

/// Density of the swarm's core in one frame, agents per m³: the 90 % of agents nearest the
/// centroid over the volume of the sphere that holds them.
fn core_density(p: &[Vec3]) -> f64 {
    let c = centroid(p);
    let mut d: Vec<f32> = p.iter().map(|q| q.distance(c)).collect();
    d.sort_by(f32::total_cmp);
    let k = (p.len() * 9) / 10;
    let r = d[k - 1] as f64;
    k as f64 / (4.0 / 3.0 * std::f64::consts::PI * r * r * r)
}

/// Frames from `from_s` seconds on.
fn after(f: &Frames, from_s: f64) -> (Vec<Vec<Vec3>>, Vec<Vec<Vec3>>) {
    let k = (from_s * f.fps()).round() as usize;
    (f.positions()[k..].to_vec(), f.velocities()[k..].to_vec())
}

#[test]
fn fig3_aggregation_holds_its_centre_and_3000_midges_are_denser_than_500() {
    let swarms = bake("paper002_aggregation.toml");
    let mut density = BTreeMap::new();
    for name in ["midges_500", "midges_3000"] {
        let (pos, _) = after(&swarms[name], 2.0);
        let c0 = centroid(&pos[0]);
        let drift = pos
            .iter()
            .map(|p| centroid(p).distance(c0))
            .fold(0.0, f32::max);
        let rho = pos.iter().map(|p| core_density(p)).sum::<f64>() / pos.len() as f64;
        let mean_speed = pos.len();
        println!(
            "{name}: centroid drift over 2–6 s {drift:.4} m, core density {rho:.0} /m³ ({mean_speed} frames)"
        );
        density.insert(name, rho);
        // The swarm centre hardly changes: less than the attraction radius (0.32 m).
        assert!(drift < 0.32 * 0.5, "{name} drifted {drift} m");
    }
    let ratio = density["midges_3000"] / density["midges_500"];
    println!("density ratio 3000/500: {ratio:.2} (paper: 6.0)");
    assert!(ratio > 2.0, "ratio {ratio}");
}

#[test]
fn fig8_flies_that_see_the_predator_fly_away_from_it() {
    let swarms = bake("paper002_escape.toml");
    let f = &swarms["flies"];
    let shot = beeswarm::shot::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/paper002_escape.toml"),
    )
    .unwrap();
    let predator = &shot.targets[0];
    let r_res = 8.0 * 0.05;
    let (mut seen, mut away, mut cos_sum) = (0usize, 0usize, 0.0f64);
    for (k, (pos, vel)) in f.positions().iter().zip(f.velocities()).enumerate() {
        let e = predator.position_at(shot.frame_start as f64 + k as f64);
        for (p, v) in pos.iter().zip(vel) {
            let d = *p - e;
            if d.length() > r_res || v.length() < 1e-6 {
                continue;
            }
            let cos = v.normalize().dot(d.normalize()) as f64;
            seen += 1;
            cos_sum += cos;
            if cos > 0.0 {
                away += 1;
            }
        }
    }
    let frac = away as f64 / seen as f64;
    println!(
        "escape: {seen} (frame, fly) samples within r_res of the predator; {:.1} % fly away from it, mean cos {:.2}",
        100.0 * frac,
        cos_sum / seen as f64
    );
    assert!(seen > 200, "the predator met too few flies: {seen}");
    assert!(frac > 0.8, "only {frac} fly away");
}

#[test]
fn fig6_phase_transition_disordered_when_sparse_ordered_when_dense() {
    let swarms = bake("paper002_phase.toml");
    let mut pol = BTreeMap::new();
    for name in ["sparse", "dense"] {
        let (p, v) = after(&swarms[name], 5.0);
        let a = collective::alignment(&Frames::new(24.0, p, v).unwrap());
        let phi = a.polarisation.unwrap();
        println!("phase {name}: polarisation {phi:.3}");
        pol.insert(name, phi);
    }
    assert!(pol["sparse"] < 0.3, "sparse {}", pol["sparse"]);
    assert!(pol["dense"] > 0.7, "dense {}", pol["dense"]);
}

/// The smallest distance between two agents of one frame, and the number of pairs closer
/// than `contact` (all pairs: the swarms here are small enough).
fn min_pair_distance(p: &[Vec3], contact: f32) -> (f32, usize) {
    let (mut best, mut touching) = (f32::INFINITY, 0);
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d2 = p[i].distance_squared(p[j]);
            best = best.min(d2);
            touching += usize::from(d2 < contact * contact);
        }
    }
    (best.sqrt(), touching)
}

#[test]
fn rvo_keeps_every_pair_apart_by_the_sum_of_their_radii_and_out_of_obstacles() {
    let swarms = bake("paper002_rvo.toml");
    let contact = 2.0 * 0.0015;
    let mut closest = BTreeMap::new();
    for (name, centre) in [
        ("orca", Vec3::new(-3.0, 2.0, 0.0)),
        ("no_orca", Vec3::new(3.0, 2.0, 0.0)),
    ] {
        let f = &swarms[name];
        let mut d_min = f32::INFINITY;
        let mut touching = 0usize;
        let mut inside = 0usize;
        // From the first step on: the spawn draws positions uniformly, bodies overlapping
        // where they fall (ORCA separates them within a step).
        for (k, p) in f.positions().iter().enumerate().skip(1) {
            let (d, n) = min_pair_distance(p, contact);
            if n > 0 && name == "orca" {
                println!("frame {k}: {n} touching, closest {d}");
            }
            d_min = d_min.min(d);
            touching += n;
            // A body inside the sphere: its centre closer than 5 cm + its radius.
            inside += p
                .iter()
                .filter(|q| q.distance(centre) < 0.05 + 0.0015 * 0.999)
                .count();
        }
        println!(
            "{name}: smallest pair distance {:.5} m (sum of radii {contact} m), touching pair-frames {touching}, inside the sphere {inside}",
            d_min
        );
        assert_eq!(inside, 0, "{name}: a fly inside the obstacle");
        closest.insert(name, d_min);
    }
    // Without ORCA flies do touch, so the comparison is not vacuous.
    assert!(closest["no_orca"] < contact, "{closest:?}");
    assert!(closest["orca"] >= contact * 0.999, "{closest:?}");
}

/// Mean over the frames from `a` to `b` seconds of each frame's mean distance to `at`.
fn mean_distance(f: &Frames, at: impl Fn(usize) -> Vec3, a: f64, b: f64) -> f64 {
    let (ka, kb) = (
        (a * f.fps()) as usize,
        ((b * f.fps()) as usize).min(f.len() - 1),
    );
    let mut sum = 0.0;
    for k in ka..=kb {
        let e = at(k);
        let p = &f.positions()[k];
        sum += p.iter().map(|q| q.distance(e) as f64).sum::<f64>() / p.len() as f64;
    }
    sum / (kb - ka + 1) as f64
}

/// The fraction of agents within `radius` of `at` in frame `k`.
fn near(f: &Frames, k: usize, at: Vec3, radius: f32) -> f64 {
    let p = &f.positions()[k];
    p.iter().filter(|q| q.distance(at) < radius).count() as f64 / p.len() as f64
}

#[test]
fn fig7_moths_gather_at_the_lamp_without_entering_it() {
    let swarms = bake("paper002_phototaxis.toml");
    let f = &swarms["moths"];
    let lamp = Vec3::new(0.0, 2.5, 0.0);
    let early = mean_distance(f, |_| lamp, 0.0, 1.0);
    let late = mean_distance(f, |_| lamp, 8.0, 10.0);
    let within = near(f, f.len() - 1, lamp, 0.25);
    let mut inside = 0;
    for p in f.positions() {
        for q in p {
            let pole = Vec3::new(0.0, q.y.clamp(0.0, 2.4), 0.0);
            inside += usize::from(q.distance(lamp) < 0.06 + 0.004 * 0.9 * 0.999);
            inside += usize::from(q.y < 2.4 && q.distance(pole) < 0.03 + 0.004 * 0.9 * 0.999);
        }
    }
    println!(
        "phototaxis: mean distance to the lamp {early:.3} m in the first second, {late:.3} m in the last 2 s; {:.0} % within r_res at the end; {inside} inside the lamp or pole",
        within * 100.0
    );
    assert!(late < 0.8 * early, "{early} → {late}");
    assert_eq!(inside, 0);
}

#[test]
fn fig5_males_that_see_the_female_chase_her_and_most_find_her() {
    let shot = beeswarm::shot::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/paper002_mating.toml"),
    )
    .unwrap();
    let female = &shot.targets[0];
    let at = |k: usize| female.position_at(shot.frame_start as f64 + k as f64);
    // The control swarm is the males' twin 2 m along x; the female is not its stimulus.
    let shift = Vec3::new(2.0, 0.0, 0.0);
    let swarms = bake("paper002_mating.toml");
    let (f, control) = (&swarms["males"], &swarms["control"]);
    let r_res = 2.0 * 0.05;
    let (mut seen, mut towards) = (0usize, 0usize);
    let mut chasers = vec![false; f.agents()];
    for (k, (pos, vel)) in f.positions().iter().zip(f.velocities()).enumerate() {
        let e = at(k);
        for (m, (p, v)) in pos.iter().zip(vel).enumerate() {
            let d = e - *p;
            if d.length() > r_res || v.length() < 1e-6 {
                continue;
            }
            seen += 1;
            chasers[m] = true;
            towards += usize::from(v.dot(d) > 0.0);
        }
    }
    let frac = towards as f64 / seen as f64;
    let n_chasers = chasers.iter().filter(|&&c| c).count();
    // How the males gather (docs/model.md, "Paper 002: the mating scene"), every 6 s.
    for k in (0..f.len()).step_by(144) {
        let speed = f.velocities()[k].iter().map(|v| v.length()).sum::<f32>() / f.agents() as f32;
        println!(
            "t {:4.1} s: {:3.0} % of the males within r_res of her (control {:3.0} %); males' mean speed {speed:.3} m/s",
            k as f64 / f.fps(),
            100.0 * near(f, k, at(k), r_res),
            100.0 * near(control, k, at(k) + shift, r_res),
        );
    }
    // "Found her": within r_res of her, averaged over the last 2 s.
    let end = f.len() - 1;
    let last = end - 2 * f.fps() as usize..=end;
    let mean = |s: &Frames, off: Vec3| {
        last.clone()
            .map(|k| near(s, k, at(k) + off, r_res))
            .sum::<f64>()
            / last.clone().count() as f64
    };
    let (males_end, control_end) = (mean(f, Vec3::ZERO), mean(control, shift));
    println!(
        "mating: {n_chasers} of {} males saw the female; {:.1} % of {seen} (frame, male) samples in sight fly towards her; over the last 2 s {:.0} % within r_res of her (control {:.0} %)",
        f.agents(),
        100.0 * frac,
        100.0 * males_end,
        100.0 * control_end
    );
    assert!(n_chasers >= 5, "{n_chasers} males saw her");
    assert!(frac > 0.8, "{frac}");
    // (d) "most of the males found the female", and not because the swarm is small: the
    // twin swarm that does not see her has far fewer within r_res of the same path.
    assert!(males_end > 0.5, "{males_end}");
    assert!(
        males_end > control_end + 0.3,
        "{males_end} vs control {control_end}"
    );
}

#[test]
fn fig4_locusts_migrate_towards_the_crop_as_a_group_around_the_houses() {
    let shot = beeswarm::shot::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/paper002_locust.toml"),
    )
    .unwrap();
    let crop = shot.targets[0].position_at(shot.frame_start as f64);
    let swarms = bake("paper002_locust.toml");
    let f = &swarms["locusts"];
    let end = f.len() - 1;
    let (c0, c1) = (centroid(&f.positions()[0]), centroid(&f.positions()[end]));
    let towards = (crop - c0).normalize();
    let progress = (c1 - c0).dot(towards);
    // Polarisation while the swarm travels (0.5–3 s), before it reaches the crop and mills.
    let (a, b) = ((0.5 * f.fps()) as usize, (3.0 * f.fps()) as usize);
    let phi = collective::alignment(
        &Frames::new(
            f.fps(),
            f.positions()[a..b].to_vec(),
            f.velocities()[a..b].to_vec(),
        )
        .unwrap(),
    )
    .polarisation
    .unwrap();
    let speed =
        |k: usize| f.velocities()[k].iter().map(|v| v.length()).sum::<f32>() / f.agents() as f32;
    println!(
        "locust mean speed at 1, 3, 6, 10 s: {:.2} {:.2} {:.2} {:.2} m/s",
        speed(24),
        speed(72),
        speed(144),
        speed(end)
    );
    // Share of locusts whose own displacement over the shot points at the crop.
    let moved = f.positions()[0]
        .iter()
        .zip(&f.positions()[end])
        .filter(|(a, b)| (**b - **a).dot(crop - **a) > 0.0)
        .count() as f64
        / f.agents() as f64;
    // No body inside a house: the distance from every centre to each box exceeds the radius.
    let (mut inside, mut closest) = (0usize, f32::INFINITY);
    for pos in f.positions() {
        for q in pos {
            for o in &shot.obstacles {
                let d = beeswarm::geometry::signed_distance(&o.shape, *q);
                closest = closest.min(d);
                if d < 0.006 * 0.999 {
                    inside += 1;
                }
            }
        }
    }
    println!(
        "locust: centroid {c0:.2} → {c1:.2}, {progress:.2} m towards the crop in {:.0} s; polarisation over 0.5–3 s {phi:.3}; {:.0} % moved towards it; {inside} inside an obstacle, closest centre {closest:.4} m from one (radius 0.006)",
        end as f64 / f.fps(),
        100.0 * moved
    );
    // Measured: 6.1 m, 74 %, 0.46 (docs/model.md); the 0.05 m reading of the same column
    // gave 0.01 m and 0.02 (the swarm never left). Half the measured figures:
    assert!(progress > 3.0, "{progress} m");
    assert!(moved > 0.6, "{moved}");
    assert!(phi > 0.3, "{phi}");
    assert_eq!(inside, 0);
    assert!(closest >= 0.006 * 0.999, "{closest}");
}
