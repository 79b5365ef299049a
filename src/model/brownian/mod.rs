//! Baseline: Brownian motion, a white-noise force with friction (an Ornstein–Uhlenbeck
//! velocity process), as the biology literature and paper 000 Sec. VIII compare against.

use super::context::Context;
use super::flight::{Flight, Flyer};
use super::params::DEFAULTS_ONLY;
use super::{Model, ModelInfo, Pose, Start, SwarmSetup};
use crate::math::Rng;
use crate::species::HONEYBEE;
use glam::Vec3;

crate::declare_params! {
    /// Parameters of the Brownian baseline.
    pub struct BrownianParams {
        /// Preferred speed, m/s.
        speed: "m/s", 1.0, [0.01, 50.0], "a speed from 0.01 to 50 m/s";
        /// Distance from an obstacle at which velocity towards it is tuned down (paper 000 Eq. 5).
        avoid_distance: "m", 0.12, [1e-3, 10.0], "a distance from 0.001 to 10 m";
        /// Time constant with which the body's heading follows the direction of travel.
        heading_lag: "s", 0.06, [1e-3, 100.0], "a time constant from 0.001 to 100 s";
        /// Spring stiffness of agent–agent contact (paper 000 Sec. VII).
        collision_stiffness: "1/s²", 4000.0, [0.0, 1e7], "a stiffness from 0 to 1e7";
        /// Scale of target attraction (multiplies each target's strength).
        attraction: "1", 1.0, [0.0, 100.0], "a factor from 0 to 100";
        /// Acceleration pulling agents back inside the swarm bounds, per metre outside.
        containment: "1/s²", 4.0, [0.0, 1000.0], "an acceleration from 0 to 1000";
    }
}

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

/// The Brownian baseline as a model: level flight driven by white noise, with the shared
/// targets, bounds, contacts and obstacle handling of `flight`.
pub struct BrownianModel {
    flight: Flight,
    speed: f32,
}

impl Model for BrownianModel {
    type Agent = Flyer;
    const INFO: ModelInfo = ModelInfo {
        name: "brownian",
        summary: "Baseline: a white-noise force with friction (an Ornstein-Uhlenbeck velocity), \
                  as paper 000 Sec. VIII compares against",
        params: BrownianParams::SPECS,
        presets: DEFAULTS_ONLY,
        channels: &[],
        species: &HONEYBEE,
    };

    fn new(s: &SwarmSetup) -> Self {
        let p = BrownianParams::from_values(s.params);
        BrownianModel {
            flight: Flight::new(s),
            speed: p.speed as f32,
        }
    }

    /// Blind to neighbours but for body contact.
    fn reach(&self) -> f32 {
        0.0
    }

    fn spawn(&self, start: &Start, _rng: &mut Rng) -> Flyer {
        Flyer::new(start, self.speed)
    }

    fn step(&self, cx: &Context, i: usize, b: &Flyer) -> Flyer {
        let a_col = self.flight.contacts(cx, i, &b.c);
        let mut rng = cx.rng(0xB12, i);
        let xi = Vec3::new(rng.gaussian(), rng.gaussian(), rng.gaussian());
        let a = accel(b.c.vel, cx.wind, b.c.speed, xi, cx.dt) + self.flight.pull(cx, b.c.pos);
        self.flight.fly(cx, b, a, a_col)
    }

    fn poses(&self, b: [&Flyer; 4], spin_dt: Option<f32>) -> [Pose; 4] {
        Flyer::poses(b, spin_dt)
    }

    fn record(&self, _: &Flyer, _: &Pose, _: &mut [f32]) {}
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
