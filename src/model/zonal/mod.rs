//! Paper 002 (Ren et al. 2016, *Simulating Flying Insects Using Dynamics and Data-Driven
//! Noise Modeling*): `model = "zonal"`. Each substep is the paper's Algorithm 1:
//!
//! 1. neighbours within r_att (the world's grid lists the nearest 16, docs/model.md);
//! 2. F_int, the zonal repulsion, alignment and attraction of Eq. 5 (`zones.rs`);
//! 3. F_pro = F_fric + F_res: friction −γ|v|v (`friction.rs`) and the escape or pursuit
//!    response to a predator, food or light target (`response.rs`);
//! 4. F_ξ = C(r), curl noise (Eq. 4; `noise.rs`), counted once;
//! 5. the preferred velocity v_pref = v + (F_int + F_pro + F_ξ) Δt;
//! 6. the actual velocity from 3D ORCA against neighbours and obstacles with the agents'
//!    real body radii (`orca.rs`), and r += v Δt.
//!
//! Unit mass: forces are accelerations, m/s². World frame, metres, seconds, Y up.

pub mod friction;
pub mod noise;
pub mod orca;
pub mod params;
pub mod response;
pub mod zones;

use super::context::Context;
use super::flight::{self, Avoidance, Cruiser, Flyer, lag_blend};
use super::targets::{self, TargetKind};
use super::{Agent, Model, ModelInfo, Pose, Start, SwarmSetup};
use crate::math::{self, Rng, finite_or_zero};
use crate::species::{Channel, HONEYBEE};
use glam::Vec3;
use noise::{Noise, NoiseKind};
use orca::{Mover, Planes, Times};
pub use params::ZonalParams;
use response::Stimulus;
use zones::{Weights, ZoneSums, Zones};

/// Random stream of the noise force (white and Gaussian draws).
const STREAM_NOISE: u64 = 0x2A0_0001;
/// Random stream of the escape angle θ.
const STREAM_ESCAPE: u64 = 0x2A0_0002;

/// What the zonal model records per insect each frame.
pub const ZONAL_CHANNELS: [Channel; 2] = [
    Channel {
        name: "speed",
        unit: "m/s",
        doc: "Speed of flight, metres per second.",
    },
    Channel {
        name: "escaping",
        unit: "1",
        doc: "1 while the insect flees a predator it sees, else 0.",
    },
];

/// One insect.
#[derive(Clone, Copy, Debug)]
pub struct Insect {
    pub f: Flyer,
    /// θ of the current escape (radians), drawn when a predator comes into view.
    pub escape_theta: f32,
    pub escaping: bool,
}

impl Agent for Insect {
    fn position(&self) -> Vec3 {
        self.f.c.pos
    }
    fn velocity(&self) -> Vec3 {
        self.f.c.vel
    }
    fn size(&self) -> f32 {
        self.f.c.size
    }
    fn place(&mut self, position: Vec3, velocity: Vec3) {
        self.f.place(position, velocity);
    }
}

/// Per-swarm constants.
pub struct ZonalModel {
    zones: Zones,
    weights: Weights,
    gamma: f32,
    noise: Noise,
    chi_res: f32,
    r_res: f32,
    orca: bool,
    time_horizon: f32,
    max_speed: f32,
    containment: f32,
    yaw_blend: f32,
    /// Body radius of an insect of size 1, m.
    radius: f32,
    bounds: Option<(Vec3, Vec3)>,
    /// The swarm's targets: predator, food and light ones are stimuli (F_res); the others
    /// pull as they pull every model.
    targets: Vec<usize>,
}

/// The stimulus kind of a target, if it is one.
fn stimulus(kind: TargetKind) -> Option<Stimulus> {
    match kind {
        TargetKind::Predator => Some(Stimulus::Predator),
        TargetKind::Food | TargetKind::Light => Some(Stimulus::Food),
        _ => None,
    }
}

impl Model for ZonalModel {
    type Agent = Insect;
    const KEEPS_CANDIDATES: bool = true;
    const INFO: ModelInfo = ModelInfo {
        name: "zonal",
        summary: "Paper 002 (Ren et al. 2016): zonal repulsion, alignment and attraction, \
                  friction, escape and pursuit, curl noise, then 3D ORCA",
        params: ZonalParams::SPECS,
        presets: params::PRESETS,
        channels: &ZONAL_CHANNELS,
        species: &HONEYBEE,
    };

    fn new(s: &SwarmSetup) -> Self {
        let p = ZonalParams::from_values(s.params);
        ZonalModel {
            zones: Zones::from_increments(p.r_rep as f32, p.r_ali_star as f32, p.r_att_star as f32),
            weights: Weights {
                rep: p.chi_rep as f32,
                ali: p.chi_ali as f32,
                att: p.chi_att as f32,
            },
            gamma: p.gamma as f32,
            noise: Noise::new(
                NoiseKind::from_param(p.noise),
                math::mix64(s.seed ^ ((s.index as u64 + 1) * 0x2A02)),
                p.scale,
                p.gain,
            ),
            chi_res: p.chi_res as f32,
            r_res: p.r_res as f32,
            orca: p.orca >= 0.5,
            time_horizon: p.time_horizon as f32,
            max_speed: p.max_speed as f32,
            containment: p.containment as f32,
            yaw_blend: lag_blend(s.dt as f32, p.heading_lag as f32),
            radius: s.body.radius,
            bounds: s.bounds,
            targets: s.targets.clone(),
        }
    }

    fn reach(&self) -> f32 {
        self.zones.r_att
    }

    fn spawn(&self, start: &Start, _rng: &mut Rng) -> Insect {
        // Start at the speed attraction alone would hold against friction.
        let v0 = if self.gamma > 0.0 {
            friction::terminal_speed(self.weights.att, self.gamma)
        } else {
            0.0
        };
        let v0 = (v0 * start.speed_factor).min(self.max_speed);
        Insect {
            f: Flyer::new(start, v0),
            escape_theta: 0.0,
            escaping: false,
        }
    }

    fn step(&self, cx: &Context, i: usize, a: &Insect) -> Insect {
        let c = &a.f.c;
        let (p, v, dt) = (c.pos, c.vel, cx.dt);
        let ri = self.radius * c.size;

        // Obstacles first: the planes that must hold whatever the neighbours ask.
        let mut planes = Planes::default();
        let times = Times {
            horizon: self.time_horizon,
            dt,
        };
        if self.orca {
            let look = ri + self.max_speed * self.time_horizon;
            for (k, q) in cx.obstacle_queries(p).enumerate() {
                if q.distance < look {
                    // A moving mesh's surface coming at the insect moves the plane with it.
                    let surface_speed = cx.obstacle_point_velocity(k, q.point).dot(q.normal);
                    planes.push(orca::obstacle_plane(
                        q.normal,
                        q.distance,
                        ri,
                        surface_speed,
                        times,
                    ));
                }
            }
        }

        // Eq. 5 over the listed neighbours, and their ORCA planes.
        let mut sums = ZoneSums::default();
        cx.for_each_neighbour(
            i,
            self.zones.r_att + ri + cx.max_body_radius,
            |j, pj, d2| {
                let o = &cx.agents[j];
                let dist = d2.sqrt();
                sums.add(&self.zones, pj - p, dist, o.vel - v);
                if self.orca {
                    planes.push(orca::agent_plane(
                        Mover { pos: p, vel: v },
                        Mover {
                            pos: pj,
                            vel: o.vel,
                        },
                        ri + o.radius,
                        times,
                        0.5,
                        cx.separation_fallback(i, j),
                    ));
                }
            },
        );
        let f_int = sums.force(&self.weights);

        // F_res: one stimulus at a time — the nearest predator in sight, else the nearest
        // food or light in sight.
        let mut seen: Option<(f32, Vec3, Stimulus, f32)> = None;
        let mut pull = Vec3::ZERO;
        for &t in &self.targets {
            let tn = &cx.targets[t];
            let Some(kind) = stimulus(tn.kind) else {
                pull += match tn.kind {
                    TargetKind::Surface => {
                        targets::surface_attraction(p, tn.center, tn.normal, tn.strength, tn.reach)
                    }
                    _ => targets::attraction(p, tn.center, tn.strength, tn.reach),
                };
                continue;
            };
            let range = self.r_res.min(tn.reach);
            let d = p.distance(tn.center);
            if d > range {
                continue;
            }
            let better = match seen {
                None => true,
                Some((d0, _, k0, _)) => {
                    (kind == Stimulus::Predator && k0 != Stimulus::Predator)
                        || (kind == k0 && d < d0)
                }
            };
            if better {
                seen = Some((d, tn.center, kind, self.chi_res * tn.strength));
            }
        }
        let fleeing = matches!(seen, Some((_, _, Stimulus::Predator, _)));
        let escape_theta = if fleeing && !a.escaping {
            response::escape_angle(cx.rng(STREAM_ESCAPE, i).f32())
        } else {
            a.escape_theta
        };
        let f_res = seen.map_or(Vec3::ZERO, |(_, e, kind, chi)| {
            response::response(p, e, kind, chi, f32::INFINITY, escape_theta)
        });

        let f_xi = self.noise.force(p, &mut cx.rng(STREAM_NOISE, i));
        if let Some((centre, half)) = self.bounds {
            pull += targets::containment(p, centre, half, self.containment);
        }

        // Preferred velocity. Friction acts on the velocity through the air and is
        // integrated semi-implicitly, v' = (v + F Δt) / (1 + γ|v_air|Δt), which equals the
        // explicit step to first order but stays stable for any γ|v|Δt.
        let v_air = v - cx.wind;
        let others = finite_or_zero(f_int + f_res + f_xi + pull);
        let v_pref = cx.wind + (v_air + others * dt) / (1.0 + self.gamma * v_air.length() * dt);

        let vel = if self.orca {
            orca::solve(planes.as_slice(), self.max_speed, v_pref).0
        } else if v_pref.length() > self.max_speed {
            v_pref.normalize() * self.max_speed
        } else {
            v_pref
        };
        let vel = finite_or_zero(vel);
        let (pos, vel) = flight::keep_out(cx, p, p + vel * dt, vel, ri);
        let yaw = flight::follow_heading(c.yaw, vel, Avoidance::default(), self.yaw_blend, dt);
        Insect {
            f: Flyer {
                c: Cruiser {
                    pos,
                    vel,
                    yaw,
                    ..*c
                },
                prev_yaw: c.yaw,
            },
            escape_theta,
            escaping: fleeing,
        }
    }

    fn poses(&self, a: [&Insect; 4], spin_dt: Option<f32>) -> [Pose; 4] {
        Flyer::poses(a.map(|a| &a.f), spin_dt)
    }

    fn record(&self, a: &Insect, _: &Pose, channels: &mut [f32]) {
        channels[0] = a.f.c.vel.length();
        channels[1] = if a.escaping { 1.0 } else { 0.0 };
    }
}
