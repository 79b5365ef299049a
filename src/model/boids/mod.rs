//! Baseline: Reynolds' boids (separation, alignment, cohesion), as paper 000 compares in
//! Fig. 9 and paper 002 in its evaluation.

use super::context::Context;
use super::flight::{Flight, Flyer};
use super::params::DEFAULTS_ONLY;
use super::{Model, ModelInfo, Pose, Start, SwarmSetup};
use crate::math::Rng;
use crate::species::HONEYBEE;
use glam::Vec3;

crate::declare_params! {
    /// Parameters of the boids baseline.
    pub struct BoidsParams {
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
        /// Perception radius beyond body contact; separation acts within half of it.
        neighbour_radius: "m", 0.15, [1e-3, 10.0], "a neighbourhood radius from 0.001 to 10 m";
    }
}

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

/// Reynolds' boids as a model, with the shared targets, bounds, contacts and obstacle
/// handling of `flight`.
pub struct BoidsModel {
    flight: Flight,
    speed: f32,
    h: f32,
}

impl Model for BoidsModel {
    type Agent = Flyer;
    const INFO: ModelInfo = ModelInfo {
        name: "boids",
        summary: "Baseline: Reynolds' separation, alignment and cohesion, as paper 000 Fig. 9 \
                  compares against",
        params: BoidsParams::SPECS,
        presets: DEFAULTS_ONLY,
        channels: &[],
        species: &HONEYBEE,
    };

    fn new(s: &SwarmSetup) -> Self {
        let p = BoidsParams::from_values(s.params);
        BoidsModel {
            flight: Flight::new(s),
            speed: p.speed as f32,
            h: p.neighbour_radius as f32,
        }
    }

    fn reach(&self) -> f32 {
        self.h
    }

    fn spawn(&self, start: &Start, _rng: &mut Rng) -> Flyer {
        Flyer::new(start, self.speed)
    }

    fn step(&self, cx: &Context, i: usize, b: &Flyer) -> Flyer {
        let ri = self.flight.body_radius(b.c.size);
        let mut a_col = Vec3::ZERO;
        let mut hood = Neighbourhood::default();
        cx.for_each_neighbour(i, self.h + ri + cx.max_body_radius, |j, pj, d2| {
            let o = &cx.agents[j];
            let r = b.c.pos - pj;
            let dist = d2.sqrt();
            hood.count += 1;
            hood.velocity_sum += o.vel;
            hood.position_sum += o.pos;
            if dist < self.h * 0.5 {
                hood.separation += if dist > 1e-6 {
                    r / (dist * dist)
                } else {
                    cx.separation_fallback(i, j) * 1e3
                };
            }
            a_col += self.flight.contact(
                || cx.separation_fallback(i, j),
                ri + o.radius,
                r,
                dist,
                b.c.vel - o.vel,
            );
        });
        let a = accel(b.c.pos, b.c.vel, &hood, b.c.speed) + self.flight.pull(cx, b.c.pos);
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
