//! The curl-noise model paper 000 compares itself against (its reference [17], Bridson et
//! al.; paper 001's Eq. 1 in its plainest form): agents advected by a divergence-free
//! velocity field, V = speed · curl(Per)(p/L) / rms. Position-based — no inertia, no
//! neighbours, blind to body size — so agents pass through each other (paper 000 Fig. 7)
//! and fly smooth, chaotic paths (Fig. 5).
//!
//! The field is paper 000's curl noise (`field::CurlNoise`, Eq. 8–9) scaled so that
//! `speed` is its root-mean-square speed. Wind carries the agents; targets and the
//! swarm's bounds add the velocity their pull would give over `response_time`; obstacles
//! are never entered (the shared keep-out guard).

use super::context::Context;
use super::curl_now::CurlNow;
use super::flight::{self, Avoidance, Cruiser, Flyer, lag_blend};
use super::params::DEFAULTS_ONLY;
use super::{Model, ModelInfo, Pose, Start, SwarmSetup};
use crate::field::CurlNoise;
use crate::math::{self, Rng};
use crate::species::HONEYBEE;
use glam::Vec3;

crate::declare_params! {
    /// Parameters of the curl-noise model.
    pub struct CurlParams {
        /// Root-mean-square speed of the field.
        speed: "m/s", 1.0, [0.01, 50.0], "a speed from 0.01 to 50 m/s";
        /// L: edge length of the noise lattice (the size of the field's eddies).
        noise_cell: "m", 0.11, [1e-3, 100.0], "a noise cell size from 0.001 to 100 m";
        /// Time constant with which the body's heading follows the direction of travel.
        heading_lag: "s", 0.06, [1e-3, 100.0], "a time constant from 0.001 to 100 s";
        /// Scale of target attraction (multiplies each target's strength).
        attraction: "1", 1.0, [0.0, 100.0], "a factor from 0 to 100";
        /// Pull back inside the swarm bounds, per metre outside.
        containment: "1/s²", 4.0, [0.0, 1000.0], "an acceleration from 0 to 1000";
        /// Time over which the targets' and bounds' pull (an acceleration) becomes velocity.
        response_time: "s", 0.25, [1e-3, 100.0], "a time from 0.001 to 100 s";
    }
}

pub struct CurlModel {
    field: CurlNoise,
    /// The field at every agent of the swarm this substep (set by `prepare`).
    field_now: CurlNow,
    /// speed / rms of the raw field.
    gain: f32,
    yaw_blend: f32,
    attraction: f32,
    containment: f32,
    response: f32,
    radius: f32,
    bounds: Option<(Vec3, Vec3)>,
    targets: Vec<usize>,
}

/// Root-mean-square magnitude of `field` over a lattice of 16³ points spread over eight
/// cells each way (deterministic; within a few per cent of the field's true RMS).
fn rms(field: &CurlNoise, cell: f32) -> f32 {
    let n = 16;
    let mut sum = 0.0f64;
    for a in 0..n {
        for b in 0..n {
            for c in 0..n {
                // An irrational step, so samples do not line up with the lattice.
                let p = Vec3::new(a as f32, b as f32, c as f32) * (cell * 0.5 * 1.0737);
                sum += field.force(p).length_squared() as f64;
            }
        }
    }
    ((sum / (n * n * n) as f64).sqrt() as f32).max(1e-12)
}

impl Model for CurlModel {
    type Agent = Flyer;
    const INFO: ModelInfo = ModelInfo {
        name: "curl",
        summary: "Curl noise (paper 000's reference [17], paper 001 Eq. 1 at its plainest): \
                  agents advected by a divergence-free noise velocity field",
        params: CurlParams::SPECS,
        presets: DEFAULTS_ONLY,
        channels: &[],
        species: &HONEYBEE,
    };

    fn new(s: &SwarmSetup) -> Self {
        let p = CurlParams::from_values(s.params);
        let field = CurlNoise::new(
            math::mix64(s.seed ^ ((s.index as u64 + 1) * 0xC0C1)),
            p.noise_cell,
            1.0,
        );
        let gain = p.speed as f32 / rms(&field, p.noise_cell as f32);
        CurlModel {
            field,
            field_now: CurlNow::default(),
            gain,
            yaw_blend: lag_blend(s.dt as f32, p.heading_lag as f32),
            attraction: p.attraction as f32,
            containment: p.containment as f32,
            response: p.response_time as f32,
            radius: s.body.radius,
            bounds: s.bounds,
            targets: s.targets.clone(),
        }
    }

    /// Blind to neighbours; the world still lists contacts, which this model ignores.
    fn reach(&self) -> f32 {
        0.0
    }

    fn spawn(&self, start: &Start, _rng: &mut Rng) -> Flyer {
        let mut f = Flyer::new(start, 1.0);
        f.c.vel = self.velocity(f.c.pos);
        f
    }

    fn prepare(&mut self, cx: &Context, agents: std::ops::Range<usize>) {
        self.field_now.fill(&self.field, cx, agents);
    }

    fn step(&self, cx: &Context, i: usize, b: &Flyer) -> Flyer {
        let pull = flight::pull(
            cx,
            &self.targets,
            self.attraction,
            self.bounds,
            self.containment,
            b.c.pos,
        );
        let field = self.field_now.at(&self.field, cx, i, b.c.pos) * self.gain;
        let vel = field + cx.wind + pull * self.response;
        let ri = self.radius * b.c.size;
        let (pos, vel) = flight::keep_out(cx, b.c.pos, b.c.pos + vel * cx.dt, vel, ri);
        let yaw = flight::follow_heading(b.c.yaw, vel, Avoidance::default(), self.yaw_blend, cx.dt);
        Flyer {
            c: Cruiser {
                pos,
                vel,
                yaw,
                ..b.c
            },
            prev_yaw: b.c.yaw,
        }
    }

    fn poses(&self, b: [&Flyer; 4], spin_dt: Option<f32>) -> [Pose; 4] {
        Flyer::poses(b, spin_dt)
    }

    fn record(&self, _: &Flyer, _: &Pose, _: &mut [f32]) {}
}

impl CurlModel {
    /// The field's velocity at `p`, m/s.
    pub fn velocity(&self, p: Vec3) -> Vec3 {
        self.field.force(p) * self.gain
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Body, ModelKind, ParamValues, Variation};

    fn model(speed: f64) -> CurlModel {
        let mut params = ParamValues::defaults(ModelKind::Curl);
        assert!(params.set("speed", speed));
        CurlModel::new(&SwarmSetup {
            database: None,
            index: 0,
            seed: 7,
            dt: 1.0 / 96.0,
            params: &params,
            body: Body {
                length: 0.012,
                radius: 0.002,
                mass: 1e-4,
                wing_area: 4e-5,
                wing_beat_hz: 230.0,
            },
            variation: Variation {
                size: 0.0,
                speed: 0.0,
                phase: 1.0,
            },
            bounds: None,
            targets: Vec::new(),
            obstacles: &[],
        })
    }

    #[test]
    fn the_velocity_field_is_divergence_free() {
        let m = model(1.0);
        let e = 1e-3f32;
        let mut worst = 0.0f32;
        for k in 0..200 {
            let p = Vec3::new(
                k as f32 * 0.037,
                (k % 7) as f32 * 0.05,
                (k % 11) as f32 * 0.03,
            );
            let mut div = 0.0;
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                let d = (m.velocity(p + axis * e) - m.velocity(p - axis * e)) / (2.0 * e);
                div += d.dot(axis);
            }
            // Relative to the size of the field's gradients (speed / L).
            worst = worst.max(div.abs() * 0.11);
        }
        assert!(worst < 0.02, "largest |div V| · L / speed = {worst}");
    }

    #[test]
    fn speed_is_the_fields_rms_speed() {
        let m = model(2.5);
        let mut sum = 0.0f64;
        let n = 20_000;
        let mut rng = Rng::new(3, 4, 5);
        for _ in 0..n {
            let p = Vec3::new(
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
            );
            sum += m.velocity(p).length_squared() as f64;
        }
        let rms = (sum / n as f64).sqrt();
        assert!((rms - 2.5).abs() < 0.25, "rms speed {rms} for speed = 2.5");
    }
}
