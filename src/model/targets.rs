//! Attraction to targets (a nest, a flower, an attractor) and soft containment.
//!
//! The paper attracts bees to a target and lets the repulsion of the target's virtual
//! particles push them back (Sec. V-B); it does not give the attraction's form. We use a
//! constant-magnitude pull towards the target centre that fades out at the target's reach.

use crate::math::{normalize_or, smoothstep};
use glam::Vec3;

/// Attraction acceleration towards `target` (m/s²).
#[inline]
pub fn attraction(p: Vec3, target: Vec3, strength: f32, reach: f32) -> Vec3 {
    let r = target - p;
    let d = r.length();
    let fade = if reach.is_finite() {
        1.0 - smoothstep(0.8 * reach, reach, d)
    } else {
        1.0
    };
    // Near the centre the pull fades too, so a bee on the target does not jitter.
    let near = smoothstep(0.0, 0.02, d);
    normalize_or(r, Vec3::ZERO) * (strength * fade * near)
}

/// Pull back into an axis-aligned box (centre, half extents): proportional to the distance
/// outside it.
#[inline]
pub fn containment(p: Vec3, center: Vec3, half: Vec3, gain: f32) -> Vec3 {
    let local = p - center;
    let outside = local - local.clamp(-half, half);
    -outside * gain
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attraction_points_at_the_target_and_respects_reach() {
        let a = attraction(Vec3::ZERO, Vec3::X, 2.0, f32::INFINITY);
        assert!((a - Vec3::X * 2.0).length() < 1e-6);
        assert_eq!(attraction(Vec3::ZERO, Vec3::X * 5.0, 2.0, 1.0), Vec3::ZERO);
        assert_eq!(attraction(Vec3::X, Vec3::X, 2.0, 1.0), Vec3::ZERO);
    }

    #[test]
    fn containment_only_acts_outside() {
        assert_eq!(
            containment(Vec3::ZERO, Vec3::ZERO, Vec3::ONE, 3.0),
            Vec3::ZERO
        );
        assert_eq!(
            containment(Vec3::X * 2.0, Vec3::ZERO, Vec3::ONE, 3.0),
            -Vec3::X * 3.0
        );
    }
}
