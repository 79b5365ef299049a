//! The minimiser of Eq. 1: the candidate from the database, rotated about the vertical,
//! with the least energy.
//!
//! The recording holds a few hundred headings per speed group, so the candidates are
//! rotated about world +Y (the vertical; speed and climb rate are unchanged), each sample
//! one way, by its speed rank (database::Family):
//! - **continuing** (even rank): turned so that the velocity it was recorded coming from,
//!   v − aΔt, has the agent's current heading: the recorded manoeuvre, flown from here;
//! - **free** (odd rank): turned by one random angle, drawn per agent per step, so that
//!   any heading can be reached.
//!
//! Every sample of the search range is thus one candidate: at most k = 300 (Sec. 5.2.1).
//! Each family is evaluated in batches of [`LANES`] in its own frame (Energy::frame).
//!
//! Conventions: world Y-up, m/s, m/s².

use super::database::{Database, Family, LANES, Sample, turn};
use super::energies::Energy;
use glam::{Quat, Vec3};

/// The chosen velocity (rotated) and the sample's index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice {
    pub v: Vec3,
    pub index: usize,
    pub energy: f32,
}

/// Eq. 1: the least-energy candidate among the samples `range` of `db`, continuing the
/// current heading or turned by `free_angle` radians by family; candidates `allowed`
/// refuses (an obstacle) are skipped. Ties go to the first in a fixed order (continuing,
/// then free, each by speed rank), so the choice is the same on any machine. `None` when
/// every candidate is refused.
pub fn select(
    e: &Energy,
    db: &Database,
    range: std::ops::Range<usize>,
    free_angle: f32,
    allowed: impl Fn(Vec3) -> bool,
) -> Option<Choice> {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx512() {
        // SAFETY: the CPU has AVX-512 F and VL and AVX2 (`simd::avx512`).
        return unsafe { select_avx512(e, db, range, free_angle, allowed) };
    }
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: the CPU has AVX2 (`simd::avx2`).
        return unsafe { select_avx2(e, db, range, free_angle, allowed) };
    }
    select_in_batches(e, db, range, free_angle, allowed)
}

/// [`select_in_batches`] compiled for AVX2 (eight lanes in one instruction instead of
/// four). The same IEEE operations in the same order (no fused multiply-add: AVX2 does
/// not enable it, and Rust never contracts), so the same bits as without.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn select_avx2(
    e: &Energy,
    db: &Database,
    range: std::ops::Range<usize>,
    free_angle: f32,
    allowed: impl Fn(Vec3) -> bool,
) -> Option<Choice> {
    select_in_batches(e, db, range, free_angle, allowed)
}

/// [`select_in_batches`] compiled for AVX-512 (a batch of sixteen lanes in one
/// instruction, 32 vector registers): the same operations, so the same bits, as
/// [`select_avx2`] (AVX-512 brings no fused multiply-add either unless asked for).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl")]
fn select_avx512(
    e: &Energy,
    db: &Database,
    range: std::ops::Range<usize>,
    free_angle: f32,
    allowed: impl Fn(Vec3) -> bool,
) -> Option<Choice> {
    select_in_batches(e, db, range, free_angle, allowed)
}

#[inline(always)]
fn select_in_batches(
    e: &Energy,
    db: &Database,
    range: std::ops::Range<usize>,
    free_angle: f32,
    allowed: impl Fn(Vec3) -> bool,
) -> Option<Choice> {
    let (fs, fc) = free_angle.sin_cos();
    // The rotation taking +x (every continuing sample's previous heading) to the agent's
    // heading; an agent with none continues as if heading +x.
    let (hx, hz) = {
        let h = (e.v.x * e.v.x + e.v.z * e.v.z).sqrt();
        if h > 1e-6 {
            (e.v.x / h, e.v.z / h)
        } else {
            (1.0, 0.0)
        }
    };
    let mut best: Option<Choice> = None;
    for (family, c, s) in [(Family::Continuing, hx, -hz), (Family::Free, fc, fs)] {
        let d = db.family(family);
        let frame = e.frame(c, s);
        let (lo, hi) = (
            family.count_below(range.start),
            family.count_below(range.end),
        );
        for start in (lo..hi).step_by(LANES) {
            let count = (hi - start).min(LANES);
            let bound = best.map_or(f32::INFINITY, |b| b.energy);
            let energies = frame.energies(d, start, count, bound);
            // Most batches hold no better candidate: one vector comparison says so (the
            // least lane, folded lane by lane, was sixteen dependent scalar minima, 3 % of
            // the step). NaN lanes are never below: skipped, as the loop below skips them.
            let mut below = false;
            for &x in &energies {
                below |= x < bound;
            }
            if !below {
                continue;
            }
            for (l, &energy) in energies.iter().enumerate().take(count) {
                let better = energy < best.map_or(f32::INFINITY, |b| b.energy);
                if !better || !energy.is_finite() {
                    continue;
                }
                let v = turn(d.v(start + l), c, s);
                if allowed(e.p + v * e.dt) {
                    best = Some(Choice {
                        v,
                        index: family.index(start + l),
                        energy,
                    });
                }
            }
        }
    }
    best
}

/// Whether `v` is database sample `d`'s velocity turned about the vertical: the same
/// climb rate and horizontal speed (what a test of "every velocity is a database
/// velocity" checks), within `tol` m/s.
pub fn is_turned(v: Vec3, d: &Sample, tol: f32) -> bool {
    let h = |u: Vec3| (u.x * u.x + u.z * u.z).sqrt();
    (v.y - d.v.y).abs() <= tol && (h(v) - h(d.v)).abs() <= tol
}

/// The rotation of [`turn`] as a quaternion (for tests and tools).
pub fn turn_quat(angle: f32) -> Quat {
    Quat::from_rotation_y(angle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turns_are_rotations_about_the_vertical() {
        let v = Vec3::new(0.3, -0.1, 0.2);
        let a = 0.7f32;
        let (s, c) = a.sin_cos();
        assert!((turn(v, c, s) - turn_quat(a) * v).length() < 1e-6);
    }

    #[test]
    fn continuing_candidates_fly_on_from_the_agents_heading() {
        // Every continuing sample, turned to the agent's heading (as `select` turns it),
        // is a database velocity turned about the vertical, and the velocity it was
        // recorded coming from, v − aΔt, then lies along the agent's heading.
        let db = Database::default_mosquito();
        let dt = db.dt as f32;
        let heading = Vec3::new(-0.3, 0.1, 0.4);
        let h = heading.with_y(0.0).normalize();
        let d = db.family(Family::Continuing);
        let mut checked = 0;
        for j in 0..Family::Continuing.count_below(db.samples.len()) {
            let sample = db.samples[Family::Continuing.index(j)];
            let turned = turn(d.v(j), h.x, -h.z);
            assert!(is_turned(turned, &sample, 1e-5), "{j}");
            let a = Vec3::new(d.ax[j], d.ay[j], d.az[j]) * d.alen[j];
            let back = turn(d.v(j) - a * dt, h.x, -h.z).with_y(0.0);
            if back.length() > 1e-3 {
                assert!(back.normalize().dot(h) > 1.0 - 1e-4, "{j}: {back}");
                checked += 1;
            }
        }
        assert!(checked > 120, "{checked}");
    }

    #[test]
    fn every_instruction_set_chooses_the_same_bits() {
        // The AVX2 and AVX-512 builds of the batches against the portable one, over agents in every
        // heading and speed group: the same choice and the same energy bits.
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let db = Database::default_mosquito();
            let mut rng = crate::math::Rng::new(5, 0, 0);
            for _ in 0..200 {
                let mut r = || rng.range(-1.0, 1.0);
                let v = Vec3::new(r(), r() * 0.3, r()) * 0.4;
                let p = Vec3::new(r(), r(), r());
                let mut e = Energy::new(2.5, 0.02, p, v);
                e.direction(1.0, v);
                e.direction(0.2, Vec3::new(r(), r(), r()));
                e.repulsion(1.0, 0.03, &[p + Vec3::new(r(), r(), r()) * 0.02]);
                e.attraction(1.0, 0.08, &[p + Vec3::new(r(), r(), r()) * 0.3]);
                e.acceleration(1.0, db.mean_accel);
                let (angle, range) = (r() * 3.0, db.candidates(v.length()));
                let portable = select_in_batches(&e, db, range.clone(), angle, |_| true);
                // SAFETY: AVX2 checked above.
                let avx2 = unsafe { select_avx2(&e, db, range.clone(), angle, |_| true) };
                let bits = |c: Option<Choice>| c.map(|c| (c.index, c.energy.to_bits()));
                assert_eq!(bits(portable), bits(avx2));
                if std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                {
                    // SAFETY: AVX-512 F and VL checked just above.
                    let avx512 = unsafe { select_avx512(&e, db, range, angle, |_| true) };
                    assert_eq!(bits(portable), bits(avx512));
                }
            }
        }
    }

    #[test]
    fn pruning_changes_no_choice() {
        // Batches dropped early (no lane's lower bound below the best so far) against every
        // candidate weighed in full: the same first least energy, bit for bit, for agents
        // with and without repulsion neighbours (which decide where the bound is taken).
        let db = Database::default_mosquito();
        let mut rng = crate::math::Rng::new(9, 0, 0);
        for case in 0..300 {
            let mut r = || rng.range(-1.0, 1.0);
            let v = Vec3::new(r(), r() * 0.3, r()) * 0.4;
            let p = Vec3::new(r(), r(), r());
            // From nearly flat energies (many near-ties) to the paper's ρ = 2.5.
            let rho = 1.4 + r() * 1.2;
            let mut e = Energy::new(rho, 0.02, p, v);
            e.direction(1.0, v);
            e.direction(0.3, Vec3::new(r(), r(), r()));
            let rep: Vec<Vec3> = (0..case % 4)
                .map(|_| p + Vec3::new(r(), r(), r()) * 0.03)
                .collect();
            e.repulsion(1.0, 0.03, &rep);
            e.attraction(1.0, 0.08, &[p + Vec3::new(r(), r(), r()) * 0.3]);
            e.acceleration(1.0, db.mean_accel);
            let (angle, range) = (r() * 3.0, db.candidates(v.length()));
            let got = select(&e, db, range.clone(), angle, |_| true).unwrap();
            let (hx, hz) = (v.x / v.with_y(0.0).length(), v.z / v.with_y(0.0).length());
            let (fs, fc) = angle.sin_cos();
            let mut want: Option<(f32, usize)> = None;
            for (family, c, s) in [(Family::Continuing, hx, -hz), (Family::Free, fc, fs)] {
                let frame = e.frame(c, s);
                let d = db.family(family);
                let (lo, hi) = (
                    family.count_below(range.start),
                    family.count_below(range.end),
                );
                for start in (lo..hi).step_by(LANES) {
                    let count = (hi - start).min(LANES);
                    let all = frame.energies(d, start, count, f32::INFINITY);
                    for (l, &x) in all.iter().enumerate().take(count) {
                        if want.is_none_or(|w| x < w.0) {
                            want = Some((x, family.index(start + l)));
                        }
                    }
                }
            }
            let want = want.unwrap();
            assert_eq!(
                (got.energy.to_bits(), got.index),
                (want.0.to_bits(), want.1)
            );
        }
    }

    #[test]
    fn the_minimum_is_picked_and_refused_candidates_skipped() {
        // Vertical samples have no heading, so both rotations leave them as they are.
        let samples: Vec<Sample> = (0..300)
            .map(|k| Sample {
                v: Vec3::new(0.0, 0.1 + 0.001 * k as f32, 0.0),
                a: Vec3::ZERO,
            })
            .collect();
        let db = Database::new(0.02, samples);
        // Prefers going up fast? A direction term cannot tell speeds apart; attraction can.
        let mut e = Energy::new(2.5, 0.02, Vec3::ZERO, Vec3::Y * 0.2);
        e.attraction(1.0, 0.08, &[Vec3::Y * 0.2]);
        let c = select(&e, &db, 0..300, 0.0, |_| true).unwrap();
        assert_eq!(c.index, 299);
        let c = select(&e, &db, 0..300, 0.0, |p| p.y < 0.00299).unwrap();
        assert_eq!(c.index, 49);
        assert!(select(&e, &db, 0..300, 0.0, |_| false).is_none());
    }
}
