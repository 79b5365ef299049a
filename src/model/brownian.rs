//! Baseline: Brownian motion, a white-noise force with friction (an Ornstein–Uhlenbeck
//! velocity process), as the biology literature and paper 000 Sec. VIII compare against.

use glam::Vec3;

/// Friction rate of the Brownian baseline, 1/s (velocity memory of 0.5 s).
pub const FRICTION: f32 = 2.0;

/// Acceleration for one step: −f (u − wind) + σ ξ / √dt, with σ = v √(2f/3) so that the
/// stationary root-mean-square speed equals the preferred speed `v`. `xi` is a standard
/// normal 3-vector.
#[inline]
pub fn accel(u: Vec3, wind: Vec3, speed: f32, xi: Vec3, dt: f32) -> Vec3 {
    let sigma = speed * (2.0 * FRICTION / 3.0).sqrt();
    -(u - wind) * FRICTION + xi * (sigma / dt.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    #[test]
    fn stationary_rms_speed_is_the_preferred_speed() {
        let mut rng = Rng::new(1, 2, 3);
        let dt = 0.01;
        let mut u = Vec3::ZERO;
        let mut sum = 0.0f64;
        let n = 200_000;
        for i in 0..n {
            let xi = Vec3::new(rng.gaussian(), rng.gaussian(), rng.gaussian());
            u += accel(u, Vec3::ZERO, 1.5, xi, dt) * dt;
            if i > 1000 {
                sum += u.length_squared() as f64;
            }
        }
        let rms = (sum / (n - 1001) as f64).sqrt();
        assert!((rms - 1.5).abs() < 0.1, "{rms}");
    }
}
