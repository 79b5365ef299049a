//! Target attraction of paper 004 (Sec. 6.1, Eq. 8–9): a_pre = R(d) (F / m) (q − p)/|q − p|
//! towards the closest attraction point q within the sensory length L, with the ramp
//! R(d) = 15/8 d − 10/8 d³ + 3/8 d⁵ of d = |p − q| / L.
//!
//! Readings (docs/model.md, "Paper 004"): Eq. 8 prints p − q, which points away from the
//! target; the butterfly flies towards it, so q − p. Eq. 8 has d = min(1, |p − q|/L) but
//! the text says a butterfly farther than L is not attracted: R = 0 beyond L. Eq. 8 is a
//! force over the mass with the force left implicit (R(d) ≤ 1); `attraction_force` F is
//! that force at d = 1 (1 mN: the paper's 1 with m in grams, Table 2's unit).

use crate::model::vision::ramp;
use glam::Vec3;

/// a_pre of Eq. 8, m/s², for a butterfly at `p` of mass `mass` (kg) drawn by `force` (N)
/// to the closest of `points` within `sense` (L, m).
pub fn preferred_accel(
    p: Vec3,
    points: impl Iterator<Item = Vec3>,
    sense: f32,
    force: f32,
    mass: f32,
) -> Vec3 {
    let mut best: Option<(f32, Vec3)> = None;
    for q in points {
        let d = p.distance(q);
        if d <= sense && best.is_none_or(|(d0, _)| d < d0) {
            best = Some((d, q));
        }
    }
    match best {
        Some((dist, q)) if dist > 0.0 => (q - p) / dist * (ramp(dist / sense) * force / mass),
        _ => Vec3::ZERO,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pulls_towards_the_closest_point_and_cools_down_near_it() {
        let p = Vec3::ZERO;
        let pts = [
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 9.0, 0.0),
        ];
        let a = preferred_accel(p, pts.into_iter(), 4.5, 1e-3, 0.5e-3);
        assert!(a.z < 0.0 && a.x.abs() < 1e-6, "{a}");
        // |a| = R(1/4.5) · 2 m/s².
        assert!((a.length() - ramp(1.0 / 4.5) * 2.0).abs() < 1e-5);
        // Nothing within L: no pull.
        assert_eq!(
            preferred_accel(p, [Vec3::Y * 5.0].into_iter(), 4.5, 1e-3, 0.5e-3),
            Vec3::ZERO
        );
        // Closer: weaker (the ramp cools the approach down).
        let near = preferred_accel(p, [Vec3::X * 0.1].into_iter(), 4.5, 1e-3, 0.5e-3);
        let far = preferred_accel(p, [Vec3::X * 3.0].into_iter(), 4.5, 1e-3, 0.5e-3);
        assert!(near.length() < far.length());
    }
}
