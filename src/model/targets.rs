//! Attraction to targets (a nest, a flower, an attractor) and soft containment.
//!
//! The paper attracts bees to a target and lets the repulsion of the target's virtual
//! particles push them back (Sec. V-B); it does not give the attraction's form. We use a
//! constant-magnitude pull towards the target centre that fades out at the target's reach.

use crate::math::{normalize_or, smoothstep};
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetKind {
    /// A hive entrance: attracts, and is sampled with virtual particles that push back.
    Nest,
    /// A flower: like a nest, smaller and weaker by default.
    Flower,
    /// A pure attractor, with no body.
    Attractor,
    /// A landing surface: pulls towards a plane rather than a point, with no body.
    Surface,
    /// A predator-like object (paper 002): the zonal model's insects flee it; the other
    /// models are pushed away from it as strongly as an attractor would pull.
    Predator,
    /// Food or a female to chase (paper 002's pursuit stimulus); pulls like an attractor in
    /// the other models.
    Food,
    /// A light (paper 002's phototaxis): a pursuit stimulus like food.
    Light,
}

impl TargetKind {
    /// Whether the target has a body that agents feel (sampled with virtual particles).
    pub fn has_body(self) -> bool {
        matches!(self, TargetKind::Nest | TargetKind::Flower)
    }
}

/// Attraction acceleration towards `target` (m/s²).
#[inline]
pub fn attraction(p: Vec3, target: Vec3, strength: f32, reach: f32) -> Vec3 {
    let r = target - p;
    let d = r.length();
    normalize_or(r, Vec3::ZERO) * pull(d, strength, reach)
}

/// Attraction towards a landing surface, the plane through `point` with unit `normal`
/// (m/s²): the same pull as [`attraction`], along the normal, by the distance to the plane.
/// A bee behind the plane is pulled back to it too.
#[inline]
pub fn surface_attraction(p: Vec3, point: Vec3, normal: Vec3, strength: f32, reach: f32) -> Vec3 {
    let s = normal.dot(p - point);
    -normal * (s.signum() * pull(s.abs(), strength, reach))
}

/// The pull's magnitude at distance `d`: `strength`, fading out between 0.8 × `reach` and
/// `reach`, and within 2 cm of the target so that a bee on it does not jitter.
#[inline]
fn pull(d: f32, strength: f32, reach: f32) -> f32 {
    let fade = if reach.is_finite() {
        1.0 - smoothstep(0.8 * reach, reach, d)
    } else {
        1.0
    };
    strength * fade * smoothstep(0.0, 0.02, d)
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
    fn surface_attraction_pulls_along_the_normal_from_either_side() {
        let (o, n) = (Vec3::ZERO, Vec3::Y);
        // Above the plane, off to the side: straight down, whatever the offset.
        let a = surface_attraction(Vec3::new(3.0, 0.5, -2.0), o, n, 1.5, f32::INFINITY);
        assert!((a - Vec3::new(0.0, -1.5, 0.0)).length() < 1e-6);
        let below = surface_attraction(Vec3::new(0.0, -0.5, 0.0), o, n, 1.5, f32::INFINITY);
        assert!((below - Vec3::new(0.0, 1.5, 0.0)).length() < 1e-6);
        // Zero on the plane and beyond the reach.
        assert_eq!(surface_attraction(Vec3::X, o, n, 1.5, 1.0), Vec3::ZERO);
        assert_eq!(
            surface_attraction(Vec3::Y * 2.0, o, n, 1.5, 1.0),
            Vec3::ZERO
        );
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
