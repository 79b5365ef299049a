//! Paper 004 (Chen et al. 2022, *A Practical Model for Realistic Butterfly Flight
//! Simulation*): `model = "butterfly"`. Each substep:
//!
//! 1. the five maneuvering angles of Eq. 1 at the current flapping phase, with frequency
//!    and amplitude fixed for the cycle (`maneuvering.rs`);
//! 2. Σ F_j, blade-element lift and drag on the four wings in the air relative to each
//!    element, wind and the wing's own turn included (Eq. 4–6, `aerodynamics.rs`);
//! 3. F_vor, the curl-noise vortex force on the thorax (Eq. 7, `vortex.rs`);
//! 4. a_pre, attraction to the closest target within L through the ramp (Eq. 8–9,
//!    `attraction.rs`);
//! 5. u += (a_loc + a_pre) Δt with a_loc = ΣF_j / m + F_vor / m + g (Eq. 10–11), and the
//!    body moves, never into an obstacle;
//! 6. when the flap completes a cycle, Eq. 2–3 give the next cycle's frequency and
//!    amplitude from the speed at its start, smoothed by Eq. 12.
//!
//! Wind is the shot's `[wind]` plus the model's gust; rain gives random downward kicks
//! (Fig. 10–11). SI units: metres, seconds, kilograms, newtons; world Y up; body frame
//! X forward, Y up, Z right. docs/model.md, "Paper 004", lists every reading.

pub mod aerodynamics;
pub mod attraction;
pub mod maneuvering;
pub mod params;
pub mod vortex;

use super::attitudes::{self, Attitudes};
use super::context::Context;
use super::flight::{self, Avoidance, lag_blend};
use super::{Agent, Model, ModelInfo, Pose, Start, SwarmSetup};
use crate::math::{self, Rng, finite_or_zero};
use crate::species::{BUTTERFLY, Channel};
use aerodynamics::{Flow, WingState, Wings};
use glam::{Quat, Vec3};
use maneuvering::{Angle, Window};
pub use params::ButterflyParams;
use std::f32::consts::TAU;
use vortex::Vortex;

/// Random stream of the raindrops.
const STREAM_RAIN: u64 = 0xB07_0001;
/// Standard gravity, m/s².
pub const GRAVITY: f32 = 9.81;
/// Largest speed as a multiple of |u_max| (not in the paper: a guard against a runaway
/// explicit step; flight stays far below it).
const SPEED_GUARD: f32 = 5.0;

/// What the butterfly model records per butterfly each frame.
pub const BUTTERFLY_CHANNELS: [Channel; 9] = [
    Channel {
        name: "thorax_pitch",
        unit: "deg",
        doc: "θ_β of paper 004 Eq. 1: thorax pitch, degrees, nose up positive (also in the body's orientation).",
    },
    Channel {
        name: "flap",
        unit: "deg",
        doc: "θ_γ: wing flapping angle of all four wings, degrees, tips up positive.",
    },
    Channel {
        name: "feather",
        unit: "deg",
        doc: "θ_ζ: forewing feathering angle, degrees, leading edge up positive.",
    },
    Channel {
        name: "sweep",
        unit: "deg",
        doc: "θ_ψ: forewing sweeping angle, degrees, tips forward positive.",
    },
    Channel {
        name: "abdomen",
        unit: "deg",
        doc: "θ_φ: abdomen rotation, degrees, in the body's plane of symmetry, tip up positive.",
    },
    Channel {
        name: "flap_hz",
        unit: "Hz",
        doc: "Flapping frequency of the current cycle (Eq. 2 smoothed by Eq. 12), hertz.",
    },
    Channel {
        name: "flap_phase",
        unit: "1",
        doc: "Position in the current flapping cycle, 0 (wings highest) to 1.",
    },
    Channel {
        name: "speed",
        unit: "m/s",
        doc: "Speed of flight, metres per second.",
    },
    Channel {
        name: "cycle_speed",
        unit: "m/s",
        doc: "|u(t0)|: the speed at the start of the current flapping cycle, which Eq. 2-3 read, metres per second.",
    },
];

/// One butterfly. Only 4-byte fields: its bytes are its checkpoint (`sim::agent_bytes`).
#[derive(Clone, Copy, Debug)]
pub struct Butterfly {
    pub pos: Vec3,
    pub vel: Vec3,
    /// Heading about +Y, radians.
    pub yaw: f32,
    /// Heading and thorax pitch (degrees) one substep earlier, for the angular velocity.
    pub prev_yaw: f32,
    pub prev_pitch: f32,
    /// Body scale (variation): span × size, area × size², mass × size³.
    pub size: f32,
    /// Flapping phase 2π f (t − t0), radians in [0, 2π): the wings, abdomen, feathering
    /// and sweeping share it.
    pub phase: f32,
    /// The thorax's own phase (its frequency range is 3 Hz, not 11).
    pub pitch_phase: f32,
    /// The smoothed sigmoid of the current cycle: every f* and φ_a* is R* times it.
    pub s: f32,
    /// Eq. 12's window.
    pub window: Window,
    /// |u(t0)|, m/s: the speed the current cycle's values came from.
    pub cycle_speed: f32,
}

impl Agent for Butterfly {
    fn position(&self) -> Vec3 {
        self.pos
    }
    fn velocity(&self) -> Vec3 {
        self.vel
    }
    fn size(&self) -> f32 {
        self.size
    }
    fn place(&mut self, position: Vec3, velocity: Vec3) {
        self.pos = position;
        self.vel = velocity;
        let horizontal = Vec3::new(velocity.x, 0.0, velocity.z);
        if horizontal.length() > 0.02 {
            self.yaw = math::yaw_of(horizontal);
        }
        self.prev_yaw = self.yaw;
    }
}

/// Per-swarm constants.
pub struct ButterflyModel {
    p: ButterflyParams,
    wings: Wings,
    vortex: Vortex,
    yaw_blend: f32,
    gust: Vec3,
    /// Body radius of a butterfly of size 1 (its thorax), m.
    radius: f32,
    targets: Vec<usize>,
}

impl ButterflyModel {
    /// The flapping frequency at smoothed sigmoid `s`, Hz: Eq. 2, no lower than
    /// `min_flap_hz` (a cycle must end for Eq. 2 to be evaluated again).
    pub fn flap_hz(&self, s: f32) -> f32 {
        maneuvering::frequency(Angle::Flap, s).max(self.p.min_flap_hz as f32)
    }

    /// The wind at time `t`: the shot's plus the gust while it blows.
    fn wind(&self, cx: &Context) -> Vec3 {
        if cx.t >= self.p.gust_start && cx.t < self.p.gust_end {
            cx.wind + self.gust
        } else {
            cx.wind
        }
    }

    /// Body → world: heading, then the thorax pitch θ_β.
    fn orientation(yaw: f32, pitch_deg: f32) -> Quat {
        math::body_orientation(yaw, pitch_deg.to_radians(), 0.0)
    }

    /// The five angles of a butterfly now, degrees (order of [`Angle::ALL`]).
    pub fn angles(b: &Butterfly) -> [f32; 5] {
        Angle::ALL.map(|a| {
            let phase = if a == Angle::Pitch {
                b.pitch_phase
            } else {
                b.phase
            };
            maneuvering::angle(a, b.s, phase)
        })
    }
}

impl Model for ButterflyModel {
    type Agent = Butterfly;
    const INFO: ModelInfo = ModelInfo {
        name: "butterfly",
        summary: "Paper 004 (Chen et al. 2022): flapping, feathering, sweeping and abdomen from \
                  the speed, blade-element lift and drag on four wings, curl-noise vortex force, \
                  attraction to targets",
        params: ButterflyParams::SPECS,
        presets: params::PRESETS,
        channels: &BUTTERFLY_CHANNELS,
        species: &BUTTERFLY,
    };

    fn new(s: &SwarmSetup) -> Self {
        let p = ButterflyParams::from_values(s.params);
        let gain = Vec3::new(p.gain_xz as f32, p.gain_y as f32, p.gain_xz as f32);
        ButterflyModel {
            wings: Wings::new(),
            vortex: Vortex::new(
                math::mix64(s.seed ^ ((s.index as u64 + 1) * 0xB077)),
                gain,
                p.eta as f32,
            ),
            yaw_blend: lag_blend(s.dt as f32, p.heading_lag as f32),
            gust: Vec3::new(p.gust_x as f32, p.gust_y as f32, p.gust_z as f32),
            radius: s.body.radius,
            targets: s.targets.clone(),
            p,
        }
    }

    fn lists_neighbours(&self) -> bool {
        self.p.chase >= 0.5
    }

    fn reach(&self) -> f32 {
        if self.p.chase >= 0.5 {
            self.p.sense_length as f32
        } else {
            0.0
        }
    }

    fn spawn(&self, start: &Start, rng: &mut Rng) -> Butterfly {
        // Cruising at half |u_max| (times the agent's variation), mid-window.
        let speed = 0.5 * self.p.max_speed as f32 * start.speed_factor;
        let s = maneuvering::sigmoid(speed, self.p.max_speed as f32);
        let yaw = math::yaw_of(start.dir);
        Butterfly {
            pos: start.pos,
            vel: start.dir * speed,
            yaw,
            prev_yaw: yaw,
            prev_pitch: 0.0,
            size: start.size,
            phase: rng.f32() * TAU,
            pitch_phase: rng.f32() * TAU,
            s,
            window: Window::new(),
            cycle_speed: speed,
        }
    }

    fn step(&self, cx: &Context, i: usize, b: &Butterfly) -> Butterfly {
        let p = &self.p;
        let dt = cx.dt;
        let size = b.size;
        let mass = p.mass as f32 * size * size * size;
        let hz = self.flap_hz(b.s);
        let pitch_deg = maneuvering::angle(Angle::Pitch, b.s, b.pitch_phase);

        // Eq. 4–6 on the four wings.
        let flow = Flow {
            orientation: Self::orientation(b.yaw, pitch_deg),
            velocity: b.vel,
            wind: self.wind(cx),
            span: p.span as f32 * size,
            area: p.wing_area as f32 * size * size,
            density: p.air_density as f32,
        };
        let aero = self.wings.force(&WingState::at(b.s, b.phase, hz), &flow);

        // Eq. 10: a_loc = (ΣF_j + F_vor + m g) / m, F_vor / m read as η·curl in m/s².
        let a_loc = aero / mass + self.vortex.accel(b.pos) - Vec3::Y * GRAVITY;

        // Eq. 8–9 towards the closest attraction point: the targets, and in a chase the
        // nearest other butterfly.
        let sense = p.sense_length as f32;
        let mut chased = None;
        if p.chase >= 0.5 {
            let mut best = f32::INFINITY;
            cx.for_each_neighbour(i, sense, |_, pj, d2| {
                if d2 < best {
                    best = d2;
                    chased = Some(pj);
                }
            });
        }
        let points = self
            .targets
            .iter()
            .map(|&t| cx.targets[t].center)
            .chain(chased);
        let a_pre =
            attraction::preferred_accel(b.pos, points, sense, p.attraction_force as f32, mass);

        // Eq. 11, and the rain's kicks (Fig. 11: drops hitting the butterfly).
        let mut vel = b.vel + finite_or_zero(a_loc + a_pre) * dt;
        if p.rain_rate > 0.0 {
            let mut rng = cx.rng(STREAM_RAIN, i);
            if rng.f32() < p.rain_rate as f32 * dt {
                let kick = p.rain_kick as f32 * rng.range(0.5, 1.5);
                let side = rng.unit_vector() * (0.3 * kick);
                vel += Vec3::new(side.x, -kick, side.z);
            }
        }
        let guard = SPEED_GUARD * p.max_speed as f32;
        if vel.length() > guard {
            vel = vel.normalize() * guard;
        }
        let vel = finite_or_zero(vel);
        let (pos, vel) = flight::keep_out(cx, b.pos, b.pos + vel * dt, vel, self.radius * size);
        let yaw = flight::follow_heading(b.yaw, vel, Avoidance::default(), self.yaw_blend, dt);

        // The oscillators advance; a completed flap starts a new cycle whose f and φ_a
        // come from the speed now (Eq. 2–3), smoothed (Eq. 12).
        let mut phase = b.phase + TAU * hz * dt;
        let mut s = b.s;
        let mut window = b.window;
        let mut cycle_speed = b.cycle_speed;
        if phase >= TAU {
            phase = (phase - TAU).rem_euclid(TAU);
            cycle_speed = vel.length();
            let raw = maneuvering::sigmoid(cycle_speed, p.max_speed as f32);
            s = window.next(raw, p.window as usize);
        }
        let pitch_hz = maneuvering::frequency(Angle::Pitch, b.s);
        let pitch_phase = (b.pitch_phase + TAU * pitch_hz * dt).rem_euclid(TAU);
        Butterfly {
            pos,
            vel,
            yaw,
            prev_yaw: b.yaw,
            prev_pitch: pitch_deg,
            size,
            phase,
            pitch_phase,
            s,
            window,
            cycle_speed,
        }
    }

    fn poses(&self, flyers: [&Butterfly; 4], spin_dt: Option<f32>) -> [Pose; 4] {
        // Body → world: heading, then the thorax pitch θ_β.
        let now = Attitudes::of(flyers, |b| {
            let pitch = maneuvering::angle(Angle::Pitch, b.s, b.pitch_phase);
            (b.yaw, pitch.to_radians(), 0.0)
        });
        let before = || Attitudes::of(flyers, |b| (b.prev_yaw, b.prev_pitch.to_radians(), 0.0));
        attitudes::poses(&now, before, spin_dt)
    }

    fn record(&self, b: &Butterfly, _: &Pose, channels: &mut [f32]) {
        let a = Self::angles(b);
        channels[..5].copy_from_slice(&a);
        channels[5] = self.flap_hz(b.s);
        channels[6] = b.phase / TAU;
        channels[7] = b.vel.length();
        channels[8] = b.cycle_speed;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_drawn_butterfly_is_driven_by_recorded_channels() {
        BUTTERFLY.check(&BUTTERFLY_CHANNELS).unwrap();
    }
}
