//! FASTSWARM (paper 003, Xiang et al. 2020): data-driven velocity selection. Every step
//! each agent picks, from a database of recorded (velocity, acceleration) samples, the one
//! that minimises an energy of interaction, self-propulsion, noise and user control
//! (Eq. 1–14), and flies it; shape constraints steer agents through key points (Eq. 15).
//!
//! One file per concept: [`database`] (D and its speed groups), [`energies`] (Eq. 2–14),
//! [`selection`] (the minimiser of Eq. 1), [`shape`] (Eq. 15), [`params`] (Table 1).
//! docs/model.md, "Paper 003", lists every choice where the paper is silent.
//!
//! Conventions: metres, seconds, world Y-up right-handed.

pub mod database;
pub mod energies;
pub mod neighbours;
pub mod params;
pub mod selection;
pub mod shape;

use super::context::{Context, MAX_NEIGHBOURS};
use super::curl_now::CurlNow;
use super::flight::{self, Avoidance, Cruiser, Flyer, lag_blend};
use super::{Agent, Model, ModelInfo, Pose, Start, SwarmSetup};
use crate::field::CurlNoise;
use crate::math::{self, Rng};
use crate::species::{Channel, HONEYBEE};
use database::Database;
use energies::{Attraction, Energy, MAX_GATHER, MAX_STIMULI, Zone};
use glam::Vec3;
use neighbours::Nearest;
use params::FastswarmParams;
use shape::Tour;

/// Random stream of the free rotation (selection.rs).
const TURN_STREAM: u64 = 0xFA57_5A4D;
/// Time constant of the body's heading following the direction of travel, s.
const HEADING_LAG: f32 = 0.04;

/// What FASTSWARM records per agent per frame.
pub const CHANNELS: [Channel; 2] = [
    Channel {
        name: "speed",
        unit: "m/s",
        doc: "Speed of the chosen database velocity, m/s.",
    },
    Channel {
        name: "startled",
        unit: "1",
        doc: "1 while a danger is within d_danger (paper 003 Eq. 12), else 0.",
    },
];

/// A FASTSWARM agent: a flyer, its key-point tour and whether it is startled.
#[derive(Clone, Copy, Debug)]
pub struct Insect {
    pub fly: Flyer,
    pub tour: Tour,
    pub startled: bool,
}

impl Agent for Insect {
    fn position(&self) -> Vec3 {
        self.fly.c.pos
    }
    fn velocity(&self) -> Vec3 {
        self.fly.c.vel
    }
    fn size(&self) -> f32 {
        self.fly.c.size
    }
    fn place(&mut self, position: Vec3, velocity: Vec3) {
        self.fly.place(position, velocity);
    }
}

pub struct FastswarmModel {
    db: std::sync::Arc<Database>,
    p: FastswarmParams,
    rho: f32,
    noise: CurlNoise,
    /// The curl-noise field (Eq. 13's n̂) at every agent of the swarm this step (set by
    /// `prepare`).
    noise_now: CurlNow,
    /// The swarm centre of Eq. 7: the centre of the swarm's bounds (fixed; the paper's
    /// aggregation keeps "an unchanged swarm center").
    center: Option<Vec3>,
    targets: Vec<usize>,
    radius: f32,
    yaw_blend: f32,
    /// Every agent by grid cell, for Eq. 6's attraction zone and Eq. 4's repulsion zone
    /// (rebuilt each step).
    cells: neighbours::CellIndex,
    /// Every agent's position at the step by id (what `cells` is built from; kept to reuse).
    positions: Vec<Vec3>,
    /// Every agent's velocity by id, m/s (Eq. 4's p′_j = p_j + v_jΔt). A copy: reading the
    /// world's records through `indices_by_id` instead ran 2.6 % slower on one thread.
    velocities: Vec<Vec3>,
}

impl FastswarmModel {
    /// The database the swarm draws from.
    pub fn database(&self) -> &Database {
        &self.db
    }

    fn shape_mode(&self) -> bool {
        self.p.w_user > 0.0 && !self.targets.is_empty()
    }
}

impl Model for FastswarmModel {
    type Agent = Insect;
    const INFO: ModelInfo = ModelInfo {
        name: "fastswarm",
        summary: "FASTSWARM (paper 003, Xiang et al. 2020): each step every agent flies the \
                  recorded velocity that minimises an energy of neighbours, heading, \
                  acceleration, stimuli, curl noise and key points",
        params: FastswarmParams::SPECS,
        presets: params::PRESETS,
        channels: &CHANNELS,
        species: &HONEYBEE,
    };

    fn new(s: &SwarmSetup) -> Self {
        let p = FastswarmParams::from_values(s.params);
        FastswarmModel {
            db: s
                .database
                .clone()
                .unwrap_or_else(|| Database::default_mosquito().clone()),
            rho: p.rho as f32,
            noise: CurlNoise::new(
                math::mix64(s.seed ^ ((s.index as u64 + 1) * 0xFA57)),
                p.noise_cell,
                1.0,
            ),
            noise_now: CurlNow::default(),
            center: s.bounds.map(|(c, _)| c),
            targets: s.targets.clone(),
            radius: s.body.radius,
            yaw_blend: lag_blend(s.dt as f32, HEADING_LAG),
            cells: neighbours::CellIndex::default(),
            positions: Vec::new(),
            velocities: Vec::new(),
            p,
        }
    }

    /// How far it looks for repulsion (Eq. 4); both its zones are searched in its own
    /// grid (see `prepare`).
    fn reach(&self) -> f32 {
        self.p.d_rep as f32
    }

    /// Both neighbour zones come from the model's own grid (`prepare`), not the world's
    /// lists: Eq. 6's must hold every agent in the zone, and Eq. 4's are found by the same
    /// scan, so the world builds no grid for a swarm of fastswarm alone.
    fn lists_neighbours(&self) -> bool {
        false
    }

    /// Indexes every agent for the attraction zone (Eq. 6 averages over all of them) and
    /// the repulsion zone, by id: the order of Eq. 6's sum, who counts in a crowd past its
    /// limit, and which k are the nearest at equal distances must not depend on where the
    /// world stores the agents.
    fn prepare(&mut self, cx: &Context, agents: std::ops::Range<usize>) {
        self.noise_now.fill(&self.noise, cx, agents);
        // Cells as wide as the wider zone: the 27 around an agent hold both.
        let cell = (self.p.d_att2.max(self.p.d_rep) as f32).max(1e-4);
        let by_id = cx.indices_by_id();
        self.positions.clear();
        self.positions
            .extend(by_id.iter().map(|&k| cx.agents[k as usize].pos));
        self.velocities.clear();
        self.velocities
            .extend(by_id.iter().map(|&k| cx.agents[k as usize].vel));
        self.cells.build(&self.positions, cell);
    }

    /// Starts with a database velocity (the paper: "a random velocity selected from the
    /// reference dataset") turned to the start direction, and a random key-point tour.
    fn spawn(&self, start: &Start, rng: &mut Rng) -> Insect {
        let k = (rng.next_u64() % self.db.samples.len() as u64) as usize;
        let d = self.db.samples[k].v;
        let angle = math::yaw_of(start.dir) - math::yaw_of(d);
        let mut fly = Flyer::new(start, 0.0);
        fly.c.vel = selection::turn_quat(angle) * d;
        Insect {
            fly,
            tour: Tour::draw(self.targets.len(), rng),
            startled: false,
        }
    }

    fn step(&self, cx: &Context, i: usize, b: &Insect) -> Insect {
        let (pos, vel) = (b.fly.c.pos, b.fly.c.vel);
        let dt = cx.dt;
        let p = &self.p;
        let n_targets = self.targets.len();
        let target_at = |k: usize| cx.targets[self.targets[k]].center;

        // Eq. 15: move on to the next key point on arrival.
        let tour = if self.shape_mode() {
            b.tour.advance(
                pos,
                target_at(b.tour.goal as usize % n_targets),
                p.arrival_radius as f32,
                n_targets,
            )
        } else {
            b.tour
        };

        // Eq. 12: startled by every danger within d_danger.
        let danger = p.danger_distance as f32;
        let stimuli = p.w_env > 0.0 && !self.shape_mode();
        let mut e = Energy::new(self.rho, dt, pos, vel);
        let mut startled = false;
        if stimuli && danger > 0.0 {
            for k in 0..n_targets.min(MAX_STIMULI) {
                let at = target_at(k);
                if at.distance(pos) < danger {
                    startled = true;
                    e.startle(p.w_env as f32, at, danger);
                }
            }
        } else if stimuli {
            for k in 0..n_targets.min(MAX_STIMULI) {
                e.direction(p.w_env as f32, target_at(k) - pos);
            }
        }

        // Eq. 4 and 6: neighbours in the repulsion and attraction zones.
        let (d_rep, d_att1, d_att2) = (p.d_rep as f32, p.d_att1 as f32, p.d_att2 as f32);
        // Table 1, escaping "in danger": no attraction to neighbours or the centre.
        let calm = if startled { 0.0 } else { 1.0 };
        let w_oa = p.w_oa as f32 * calm;
        // Eq. 6: every agent between d_att1 and d_att2 (Sec. 5.2.1's grid); in a crowd of
        // more, the first MAX_GATHER found (the sum is an average). Eq. 4's neighbours come
        // from the same scan.
        let mut att = Attraction::new(self.rho, d_att1, pos);
        let mut near = Nearest::default();
        if w_oa > 0.0 {
            let zone = Zone {
                r0: d_rep,
                r1: d_att1,
                r2: d_att2,
                limit: MAX_GATHER,
            };
            att.gather(&self.cells, cx.id(i), zone, &mut near);
        } else {
            self.cells.nearest_within(pos, d_rep, cx.id(i), &mut near);
        }
        let mut rep = [Vec3::ZERO; MAX_NEIGHBOURS];
        for (r, (&j, &pj)) in rep
            .iter_mut()
            .zip(near.index.iter().zip(&near.pos))
            .take(near.n)
        {
            *r = pj + self.velocities[j as usize] * dt;
        }
        e.repulsion(p.w_rep as f32, d_rep, &rep[..near.n]);
        e.attraction_sums(w_oa, &att);
        if let Some(c) = self.center {
            e.direction(p.w_cos as f32 * calm, c - pos);
        }
        e.direction(p.w_dir as f32, vel);
        e.direction(p.w_n as f32, self.noise_now.at(&self.noise, cx, i, pos));
        if self.shape_mode() {
            e.direction(
                p.w_user as f32,
                shape::control_direction(pos, target_at(tour.goal as usize % n_targets)),
            );
        }
        e.acceleration(p.w_acc as f32, self.db.mean_accel);

        let free = cx.rng(TURN_STREAM, i).range(0.0, std::f32::consts::TAU);
        let ri = self.radius * b.fly.c.size;
        let clear = |q: Vec3| cx.obstacle_queries(q).all(|o| o.distance >= ri);
        let chosen = selection::select(&e, &self.db, self.db.candidates(vel.length()), free, clear);
        // With every candidate refused (boxed in by obstacles) the agent keeps its
        // velocity and the shared guard stops it at the surface.
        let v = chosen.map_or(vel, |c| c.v);
        let (pos1, v1) = flight::keep_out(cx, pos, pos + v * dt, v, ri);
        let yaw = flight::follow_heading(b.fly.c.yaw, v1, Avoidance::default(), self.yaw_blend, dt);
        Insect {
            fly: Flyer {
                c: Cruiser {
                    pos: pos1,
                    vel: v1,
                    yaw,
                    ..b.fly.c
                },
                prev_yaw: b.fly.c.yaw,
            },
            tour,
            startled,
        }
    }

    fn poses(&self, b: [&Insect; 4], spin_dt: Option<f32>) -> [Pose; 4] {
        Flyer::poses(b.map(|b| &b.fly), spin_dt)
    }

    fn record(&self, b: &Insect, _: &Pose, channels: &mut [f32]) {
        channels[0] = b.fly.c.vel.length();
        channels[1] = if b.startled { 1.0 } else { 0.0 };
    }
}
