//! Baseline: Reynolds' boids (separation, alignment, cohesion), as paper 000 compares in
//! Fig. 9 and paper 002 in its evaluation.

use glam::Vec3;

/// Rule weights (1/s² for separation and cohesion, 1/s for alignment and speed).
pub const SEPARATION: f32 = 0.02;
pub const ALIGNMENT: f32 = 2.0;
pub const COHESION: f32 = 1.5;
pub const SPEED_GAIN: f32 = 2.0;

/// What a boid sees of its neighbours within the perception radius.
#[derive(Clone, Copy, Debug, Default)]
pub struct Neighbourhood {
    pub count: u32,
    /// Σ (pᵢ − pⱼ) / |pᵢ − pⱼ|² over neighbours closer than the separation radius.
    pub separation: Vec3,
    pub velocity_sum: Vec3,
    pub position_sum: Vec3,
}

/// Acceleration of one boid from the three rules and a pull towards its preferred speed.
pub fn accel(p: Vec3, u: Vec3, n: &Neighbourhood, speed: f32) -> Vec3 {
    let mut a = n.separation * SEPARATION;
    if n.count > 0 {
        let inv = 1.0 / n.count as f32;
        a += (n.velocity_sum * inv - u) * ALIGNMENT;
        a += (n.position_sum * inv - p) * COHESION;
    }
    let s = u.length();
    let dir = if s > 1e-6 { u / s } else { Vec3::X };
    a + dir * ((speed - s) * SPEED_GAIN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_point_the_right_way() {
        let lone = accel(Vec3::ZERO, Vec3::X * 0.5, &Neighbourhood::default(), 1.0);
        assert!(lone.x > 0.0, "a slow boid speeds up");
        let n = Neighbourhood {
            count: 1,
            separation: Vec3::ZERO,
            velocity_sum: Vec3::Z,
            position_sum: Vec3::Y,
        };
        let a = accel(Vec3::ZERO, Vec3::X, &n, 1.0);
        assert!(a.z > 0.0 && a.y > 0.0, "aligns and coheres: {a}");
    }
}
