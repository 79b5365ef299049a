//! Friction, paper 002's F_fric = −γ |v| v: quadratic air drag on a unit mass, so that a
//! constant force F alone brings an insect to the terminal speed √(|F| / γ).

use glam::Vec3;

/// F_fric, m/s², for velocity `v` (m/s) and coefficient `gamma` (1/m).
#[inline]
pub fn friction(v: Vec3, gamma: f32) -> Vec3 {
    -v * (gamma * v.length())
}

/// The speed at which friction balances a constant force of magnitude `force`, m/s.
pub fn terminal_speed(force: f32, gamma: f32) -> f32 {
    (force / gamma).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_force_against_friction_reaches_the_terminal_speed() {
        let (f, gamma, dt) = (0.7f32, 223.2f32, 1e-3f32);
        let mut v = Vec3::ZERO;
        for _ in 0..20_000 {
            v += (Vec3::X * f + friction(v, gamma)) * dt;
        }
        let want = terminal_speed(f, gamma);
        assert!(
            (v.length() - want).abs() < 0.01 * want,
            "{} vs {want}",
            v.length()
        );
    }
}
