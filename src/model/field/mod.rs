//! Paper 001 (Wang et al. 2014, *Inherent Noise-Aware Insect Swarm Simulation*): agents
//! advected by V = V_l + V_g (Eq. 9), a divergence-free curl-noise field that flows along
//! every boundary (Eqs. 1–3, `noise_field`) plus the direction of a minimum-cost path field
//! solved by fast marching from the goals (Eqs. 4–8, `path_field`), with minimum distance
//! enforcement after each move (Sec. 6, `mde`).
//!
//! Position-based: the agent moves by V Δt; its velocity is what it moved. The goals are
//! the swarm's targets (their positions; bodies of nests and flowers are boundaries too);
//! the domain is the swarm's bounds box, which the noise field treats as a boundary seen
//! from inside. The path field is solved at the first substep and again whenever a goal
//! has moved `resolve_distance` (`Model::prepare`). docs/model.md, "Paper 001", has every reading.

pub mod attitude;
pub mod boundary;
pub mod mde;
pub mod noise_field;
pub mod params;
pub mod path_field;

use super::attitudes::{self, Attitudes};
use super::context::Context;
use super::flight;
use super::targets::TargetKind;
use super::{Agent, Model, ModelInfo, Pose, Start, SwarmSetup};
use crate::math::{self, Rng};
use crate::species::{Channel, HONEYBEE};
use attitude::Attitude;
use boundary::{Boundary, nearest_and_clearance};
use glam::Vec3;
use noise_field::{LocalField, ramp};
pub use params::FieldParams;
use path_field::{CostMap, Lattice, PathField};

/// The most cells a path field may have (about 130 MB); a finer `cell` is coarsened to fit.
pub const MAX_CELLS: usize = 4_000_000;

/// One insect: position-based, so its state is where it is and how it moved.
#[derive(Clone, Copy, Debug)]
pub struct Insect {
    pub pos: Vec3,
    /// What it moved over the last substep, divided by Δt, m/s.
    pub vel: Vec3,
    pub attitude: Attitude,
    /// Attitude one substep earlier (for the angular velocity).
    pub prev: Attitude,
    pub size: f32,
    /// Factor on s0 (per-agent variation).
    pub speed_factor: f32,
    /// Own extra speed towards the nearest target, m/s.
    pub taxis: f32,
    /// C at the agent (Eq. 4's units), −1 where no path leads.
    pub cost: f32,
    /// Minimum distance enforcement moved it in the last substep.
    pub mde: bool,
}

impl Agent for Insect {
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
        self.attitude = Attitude::along(velocity, self.attitude.smooth);
        self.prev = self.attitude;
    }
}

pub struct FieldModel {
    local: LocalField,
    /// The obstacles and the domain box.
    walls: Vec<Boundary>,
    /// Goal bodies at the current substep.
    balls: Vec<Boundary>,
    map: CostMap,
    path: Option<PathField>,
    /// Goal positions the path field was solved for.
    solved_for: Vec<Vec3>,
    /// How many times the path field has been solved.
    solves: u32,
    targets: Vec<usize>,
    domain: (Vec3, Vec3),
    s0: f32,
    d_min: f32,
    goal_radius: f32,
    resolve_distance: f32,
    taxis_speed: f32,
    heading_blend: f32,
    bank_max: f32,
    radius: f32,
}

impl Model for FieldModel {
    type Agent = Insect;
    // The cost field (Eq. 4) and the boundary walls are built from the obstacles once.
    const STATIC_OBSTACLES: bool = true;
    const INFO: ModelInfo = ModelInfo {
        name: "field",
        summary: "Paper 001 (Wang et al. 2014): a divergence-free curl-noise field with a \
                  boundary ramp plus a fast-marching path field to the goals, with minimum \
                  distance enforcement",
        params: FieldParams::SPECS,
        presets: params::PRESETS,
        channels: &[
            Channel {
                name: "speed",
                unit: "m/s",
                doc: "Speed over the last substep.",
            },
            Channel {
                name: "cost",
                unit: "m",
                doc: "Path cost C to the nearest goal (paper 001 Eq. 4: A times metres of free flight, more near obstacles); -1 where no path leads.",
            },
            Channel {
                name: "mde",
                unit: "1",
                doc: "1 if minimum distance enforcement moved the agent in the last substep, else 0.",
            },
        ],
        species: &HONEYBEE,
    };

    fn new(s: &SwarmSetup) -> Self {
        let p = FieldParams::from_values(s.params);
        let domain = s
            .bounds
            .unwrap_or((Vec3::new(0.0, 5.0, 0.0), Vec3::splat(5.0)));
        let lattice = Lattice::over(domain.0, domain.1, p.cell as f32, MAX_CELLS);
        let mut walls: Vec<Boundary> = s
            .obstacles
            .iter()
            .map(|o| Boundary::Shape(o.clone()))
            .collect();
        walls.push(Boundary::Domain {
            center: domain.0,
            half: domain.1,
        });
        FieldModel {
            local: LocalField::new(
                math::mix64(s.seed ^ ((s.index as u64 + 1) * 0xF1E1D)),
                p.scale as f32,
                p.gain as f32,
                p.d0 as f32,
            ),
            walls,
            balls: Vec::new(),
            map: CostMap::new(
                lattice,
                s.obstacles,
                p.cost_length as f32,
                p.cost_repulsion as f32,
            ),
            path: None,
            solved_for: Vec::new(),
            solves: 0,
            targets: s.targets.clone(),
            domain,
            s0: p.s0 as f32,
            d_min: p.d_min as f32,
            goal_radius: p.goal_radius as f32,
            resolve_distance: p.resolve_distance as f32,
            taxis_speed: p.taxis_speed as f32,
            heading_blend: flight::lag_blend(s.dt as f32, p.heading_lag as f32),
            bank_max: (p.bank_max_deg as f32).to_radians(),
            radius: s.body.radius,
        }
    }

    fn reach(&self) -> f32 {
        self.d_min
    }

    fn prepare(&mut self, cx: &Context, _agents: std::ops::Range<usize>) {
        self.balls.clear();
        let mut goals = Vec::with_capacity(self.targets.len());
        for &ti in &self.targets {
            let t = &cx.targets[ti];
            goals.push(t.center);
            if t.kind.has_body() && t.kind != TargetKind::Surface {
                self.balls.push(Boundary::Ball {
                    center: t.center,
                    radius: t.radius,
                });
            }
        }
        if goals.is_empty() {
            self.path = None;
            return;
        }
        let moved = self.path.is_none()
            || goals.len() != self.solved_for.len()
            || goals
                .iter()
                .zip(&self.solved_for)
                .any(|(a, b)| a.distance(*b) >= self.resolve_distance);
        if moved {
            self.path = Some(PathField::solve(&self.map, &goals, self.goal_radius));
            self.solved_for = goals;
            self.solves += 1;
        }
    }

    fn spawn(&self, start: &Start, rng: &mut Rng) -> Insect {
        let vel = start.dir * self.s0 * start.speed_factor;
        let attitude = Attitude::along(vel, vel);
        Insect {
            pos: start.pos,
            vel,
            attitude,
            prev: attitude,
            size: start.size,
            speed_factor: start.speed_factor,
            taxis: rng.f32() * self.taxis_speed,
            cost: 0.0,
            mde: false,
        }
    }

    fn step(&self, cx: &Context, i: usize, a: &Insect) -> Insect {
        let dt = cx.dt;
        let p = a.pos;
        let ri = self.radius * a.size;
        let d0 = self.local.d0();
        let (near, clearance) = nearest_and_clearance([&self.walls, &self.balls], p, d0);
        // Eq. 1–3.
        let v_l = self.local.velocity(p, near.as_ref());
        // Eq. 8, and the phototaxis pull.
        let (dir, cost) = match &self.path {
            Some(f) => f.sample(p),
            None => (Vec3::ZERO, -1.0),
        };
        let mut v_g = dir * (self.s0 * a.speed_factor);
        if a.taxis > 0.0 {
            let closest = self
                .targets
                .iter()
                .map(|&t| cx.targets[t].center)
                .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)));
            if let Some(c) = closest {
                v_g += math::normalize_or(c - p, Vec3::ZERO) * a.taxis;
            }
        }
        // The path field is not divergence-free and may point into a wall (at corners,
        // and the taxis pull does): its part into the nearest wall is ramped as Eq. 2
        // ramps the noise's.
        if let Some(n) = &near {
            let vn = v_g.dot(n.n);
            if vn < 0.0 {
                v_g -= n.n * (vn * (1.0 - ramp(n.d / d0)));
            }
        }
        // Eq. 9.
        let v = math::finite_or_zero(v_l + v_g);
        let (mut q, mde) = mde::enforce(cx, i, p + v * dt, dt, self.d_min, ri);
        q = self.inside_domain(q, ri);
        for b in &self.balls {
            if let Boundary::Ball { center, radius } = *b {
                let r = q - center;
                if r.length() < radius + ri {
                    q = center + math::normalize_or(r, Vec3::Y) * (radius + ri);
                }
            }
        }
        // The distance to an obstacle changes at most as fast as the agent moves: a move
        // shorter than the clearance (less the body radius) cannot reach one, and the
        // guard's sweep would find nothing.
        let q = if (q - p).length() + ri < clearance {
            q
        } else {
            flight::keep_out(cx, p, q, v, ri).0
        };
        let vel = math::finite_or_zero((q - p) / dt);
        Insect {
            pos: q,
            vel,
            attitude: a
                .attitude
                .follow(vel, self.heading_blend, self.bank_max, dt),
            prev: a.attitude,
            cost,
            mde,
            ..*a
        }
    }

    fn poses(&self, insects: [&Insect; 4], spin_dt: Option<f32>) -> [Pose; 4] {
        let of = |a: &Attitude| (a.yaw, a.pitch, a.roll);
        let now = Attitudes::of(insects, |i| of(&i.attitude));
        attitudes::poses(&now, || Attitudes::of(insects, |i| of(&i.prev)), spin_dt)
    }

    fn record(&self, a: &Insect, _: &Pose, out: &mut [f32]) {
        out[0] = a.vel.length();
        out[1] = a.cost;
        out[2] = if a.mde { 1.0 } else { 0.0 };
    }
}

impl FieldModel {
    /// `q` moved inside the domain box by at least `ri` from its faces.
    fn inside_domain(&self, q: Vec3, ri: f32) -> Vec3 {
        let (c, h) = self.domain;
        let m = (h - Vec3::splat(ri)).max(Vec3::ZERO);
        c + (q - c).clamp(-m, m)
    }

    /// The path field of the current goals, once solved.
    pub fn path(&self) -> Option<&PathField> {
        self.path.as_ref()
    }

    /// How many times the path field has been solved (once, plus once per goal move).
    pub fn solves(&self) -> u32 {
        self.solves
    }
}
