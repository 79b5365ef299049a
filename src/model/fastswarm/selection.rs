//! The minimiser of Eq. 1: the candidate (v, a) from the database, rotated about the
//! vertical, with the least energy.
//!
//! The recording holds a few hundred headings per speed group, so the candidates are
//! rotated about world +Y (the vertical; speed and climb rate are unchanged) in two ways,
//! and both are weighed:
//! - **continuing**: each sample turned so that the velocity it was recorded coming from,
//!   v − aΔt, has the agent's current heading: the recorded manoeuvre, flown from here;
//! - **free**: every sample turned by one random angle, drawn per agent per step, so that
//!   any heading can be reached.
//!
//! Conventions: world Y-up, m/s, m/s².

use super::database::{Prepared, Sample};
use super::energies::Energy;
use glam::{Quat, Vec3};

/// Rotation about +Y by the angle whose cosine and sine are `c`, `s`.
#[inline]
fn turn(v: Vec3, c: f32, s: f32) -> Vec3 {
    Vec3::new(c * v.x + s * v.z, v.y, -s * v.x + c * v.z)
}

/// (cos, sin) of the rotation about +Y taking the horizontal direction of `from` to that
/// of `to`; identity where either has none. (`select` does the same with unit directions
/// prepared in advance.)
#[cfg(test)]
fn turn_between(from: Vec3, to: Vec3) -> (f32, f32) {
    let (fx, fz, tx, tz) = (from.x, from.z, to.x, to.z);
    let (lf, lt) = ((fx * fx + fz * fz).sqrt(), (tx * tx + tz * tz).sqrt());
    if lf < 1e-6 || lt < 1e-6 {
        return (1.0, 0.0);
    }
    // Rotation by θ about +Y maps (x, z) to (x cos θ + z sin θ, −x sin θ + z cos θ).
    let c = (fx * tx + fz * tz) / (lf * lt);
    let s = (fz * tx - fx * tz) / (lf * lt);
    (c, s)
}

/// The chosen velocity and acceleration (rotated) and the sample's index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice {
    pub v: Vec3,
    pub a: Vec3,
    pub index: usize,
    pub energy: f32,
}

/// Eq. 1: the least-energy candidate among `samples` (the first on ties, so the choice is
/// the same on any machine), each weighed continuing the current heading and turned by
/// `free_angle` radians; candidates `allowed` refuses (an obstacle) are skipped. `None`
/// when every candidate is refused.
pub fn select(
    e: &Energy,
    samples: &[Prepared],
    free_angle: f32,
    allowed: impl Fn(Vec3) -> bool,
) -> Option<Choice> {
    let (fs, fc) = free_angle.sin_cos();
    let (hx, hz) = {
        let h = (e.v.x * e.v.x + e.v.z * e.v.z).sqrt();
        if h > 1e-6 {
            (e.v.x / h, e.v.z / h)
        } else {
            (0.0, 0.0)
        }
    };
    let mut best: Option<Choice> = None;
    for (index, d) in samples.iter().enumerate() {
        // The rotation taking the sample's previous heading to the agent's (turn_between
        // with both directions already unit); none where either has no heading.
        let (bx, bz) = d.back;
        let (cc, cs) = if (bx == 0.0 && bz == 0.0) || (hx == 0.0 && hz == 0.0) {
            (1.0, 0.0)
        } else {
            (bx * hx + bz * hz, bz * hx - bx * hz)
        };
        for (c, s) in [(cc, cs), (fc, fs)] {
            let v = turn(d.v, c, s);
            let bound = best.map_or(f32::INFINITY, |b| b.energy);
            let Some(energy) = e.of_unit_below(
                v,
                turn(d.v_unit, c, s),
                turn(d.a_unit, c, s),
                d.a_len,
                bound,
            ) else {
                continue;
            };
            let a = turn(d.a, c, s);
            if energy.is_finite() && allowed(e.p + v * e.dt) {
                best = Some(Choice {
                    v,
                    a,
                    index,
                    energy,
                });
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
        let (c, s) = turn_between(Vec3::new(1.0, 5.0, 0.0), Vec3::new(0.0, -1.0, 2.0));
        let r = turn(Vec3::X, c, s);
        assert!((r - Vec3::Z).length() < 1e-6, "{r}");
    }

    #[test]
    fn the_minimum_is_picked_and_refused_candidates_skipped() {
        let samples: Vec<Prepared> = [0.1f32, 0.2, 0.3]
            .iter()
            .map(|&s| {
                let d = Sample {
                    v: Vec3::new(0.0, s, 0.0),
                    a: Vec3::ZERO,
                };
                Prepared::new(d, 0.02)
            })
            .collect();
        // Prefers going up fast? A direction term cannot tell speeds apart; attraction can.
        let mut e = Energy::new(2.5, 0.02, Vec3::ZERO, Vec3::Y * 0.2);
        e.attraction(1.0, 0.08, &[Vec3::Y * 0.2]);
        let c = select(&e, &samples, 0.0, |_| true).unwrap();
        assert_eq!(c.index, 2);
        let c = select(&e, &samples, 0.0, |p| p.y < 0.003).unwrap();
        assert_eq!(c.index, 0);
        assert!(select(&e, &samples, 0.0, |_| false).is_none());
    }
}
