//! The response force of paper 002 (Self-propulsion force, F_res): escape from a predator,
//! pursuit of food, a female or a light.
//!
//! F_res = χ_res H(r_res − r_ie) (s_e r̂_ie R(n, θ) − (1 − s_e) r̂_ie), s_e = 1 for a
//! predator and 0 for food. For pursuit to fly *towards* the stimulus, r̂_ie must point
//! from the stimulus to the insect, r̂_ie = (r_i − r_e)/|r_i − r_e| (the paper's Fig. 20;
//! the r̂_ji convention of Eq. 5 would point the other way). Escape flies along r̂_ie
//! rotated about n = (0, 1, 0) — the world's up — by θ ~ U[−π/2, 0]: within 90° of straight
//! away, on one side, as Fig. 20 draws it (90°–180° from the predator's bearing). The paper
//! does not say when θ is drawn; we draw it once per encounter (when the predator comes into
//! view), so an insect flees along a steady direction instead of jittering.

use glam::{Quat, Vec3};

/// What a stimulus asks of the insects that see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stimulus {
    /// s_e = 1: flee.
    Predator,
    /// s_e = 0: pursue (food, a female, a light).
    Food,
}

/// θ of the escape rotation from a uniform number `u` in [0, 1): θ ∈ [−π/2, 0).
#[inline]
pub fn escape_angle(u: f32) -> f32 {
    -std::f32::consts::FRAC_PI_2 * u
}

/// F_res (m/s²) on an insect at `p` from a stimulus at `e` of kind `kind`, with weight
/// `chi` (m/s²) and visual range `range` (m); `theta` is the insect's escape angle.
/// Zero beyond the range, and at the stimulus itself (no direction).
#[inline]
pub fn response(p: Vec3, e: Vec3, kind: Stimulus, chi: f32, range: f32, theta: f32) -> Vec3 {
    let d = p - e;
    let dist = d.length();
    if dist > range || dist < 1e-9 {
        return Vec3::ZERO;
    }
    let r_hat = d / dist;
    match kind {
        Stimulus::Predator => Quat::from_rotation_y(theta) * r_hat * chi,
        Stimulus::Food => -r_hat * chi,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pursuit_flies_at_the_stimulus_and_escape_within_90_degrees_of_away() {
        let (p, e) = (Vec3::new(1.0, 0.5, 0.0), Vec3::ZERO);
        let f = response(p, e, Stimulus::Food, 2.0, 5.0, 0.0);
        assert!((f + p.normalize() * 2.0).length() < 1e-6, "{f}");
        for k in 0..=10 {
            let theta = escape_angle(k as f32 / 10.0 * 0.9999);
            let f = response(p, e, Stimulus::Predator, 2.0, 5.0, theta);
            assert!((f.length() - 2.0).abs() < 1e-5);
            let cos = f.normalize().dot(p.normalize());
            assert!(cos >= -1e-6, "θ = {theta}: cos to away = {cos}");
        }
        // Out of sight: nothing.
        assert_eq!(
            response(p * 10.0, e, Stimulus::Predator, 2.0, 5.0, 0.0),
            Vec3::ZERO
        );
    }
}
