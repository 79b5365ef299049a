//! The world: every bee's state, the fields and targets, and the fixed-step integrator.
//!
//! Each substep reads the previous state and writes a new one bee by bee (in parallel);
//! neighbour sums run in grid order, so results are identical for any number of threads.

use super::frame::{CacheMeta, SwarmFrame, SwarmMeta};
use super::grid::Grid;
use super::obstacle;
use crate::field::CurlNoise;
use crate::math::{self, Rng, normalize_or};
use crate::model::kernels::Kernels;
use crate::model::{boids, brownian, collision, oscillation, repulsion, targets, vision};
use crate::shot::{ModelKind, Region, Shot, TargetKind};
use glam::{Quat, Vec3};
use rayon::prelude::*;

/// Time constants of the body's attitude, seconds: how fast the roll reaches its target,
/// and the smoothing of the mean path for sway. (How fast the heading follows the velocity
/// is the `heading_lag` parameter.)
const ROLL_LAG_S: f32 = 0.04;
const SWAY_PATH_S: f32 = 0.3;

/// Per-step blend factors 1 − exp(−dt/τ) of the first-order lags above.
struct Lags {
    roll: f32,
    sway: f32,
}

impl Lags {
    fn new(dt: f32) -> Self {
        Lags {
            roll: lag_blend(dt, ROLL_LAG_S),
            sway: lag_blend(dt, SWAY_PATH_S),
        }
    }
}

/// Largest yaw rate, rad/s, of a bee that has (nearly) stopped in front of an obstacle it
/// sees and turns on the spot to face away from it.
const HOVER_TURN_RATE: f32 = std::f32::consts::PI;
/// Horizontal speed, m/s, below which a bee avoiding an obstacle turns on the spot: the roll
/// of Eq. 6 steers only a moving bee, and a bee whose thrust points into a corner stops.
const HOVER_TURN_SPEED: f32 = 0.05;

/// An angle difference wrapped into [−π, π), radians.
fn wrap_angle(a: f32) -> f32 {
    (a + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI
}

/// Per-step blend factor 1 − exp(−dt/τ) of a first-order lag with time constant τ.
fn lag_blend(dt: f32, tau: f32) -> f32 {
    1.0 - (-dt / tau).exp()
}

/// Neighbours cached per bee by the density pass for the force pass: one grid walk per
/// substep instead of two. A bee with more neighbours than fit falls back to the grid.
const CACHED_NEIGHBOURS: usize = 40;

#[derive(Clone, Copy)]
struct Neighbours {
    len: u8,
    overflow: bool,
    idx: [u32; CACHED_NEIGHBOURS],
}

impl Default for Neighbours {
    fn default() -> Self {
        Neighbours {
            len: 0,
            overflow: false,
            idx: [0; CACHED_NEIGHBOURS],
        }
    }
}

impl Neighbours {
    fn push(&mut self, j: usize) {
        if (self.len as usize) < CACHED_NEIGHBOURS {
            self.idx[self.len as usize] = j as u32;
            self.len += 1;
        } else {
            self.overflow = true;
        }
    }
}

/// What other bees' neighbour loops read of a bee, packed in 40 bytes so that those
/// loops touch less memory than the whole state would take.
#[derive(Clone, Copy, Debug, Default)]
struct Hot {
    pos: Vec3,
    /// Capsule radius, m (the swarm's radius times the bee's size).
    radius: f32,
    vel: Vec3,
    mass: f32,
    density: f32,
    pressure: f32,
}

/// One bee's state.
#[derive(Clone, Copy, Debug)]
struct Bee {
    pos: Vec3,
    vel: Vec3,
    /// Ornstein–Uhlenbeck state (stationary N(0, 1)) of the preferred speed's wandering.
    wander: f32,
    /// Exponentially smoothed path; sway is the lateral offset from it.
    mean_pos: Vec3,
    /// Heading about +Y, radians.
    yaw: f32,
    pitch_deg: f32,
    roll_deg: f32,
    /// Attitude (yaw rad, pitch deg, roll deg) one substep earlier: the recorded angular
    /// velocity is the rotation between the two attitudes over that substep. Quaternions
    /// are only built when a frame is recorded.
    prev_attitude: (f32, f32, f32),
    swarm: u32,
    /// Body scale and preferred speed (per-bee variation), oscillation phases in the
    /// maneuvering functions' own time units.
    size: f32,
    speed: f32,
    phase_pitch: f32,
    phase_roll: f32,
}

impl Bee {
    fn orientation(&self) -> Quat {
        math::body_orientation(
            self.yaw,
            self.pitch_deg.to_radians(),
            self.roll_deg.to_radians(),
        )
    }
    fn prev_orientation(&self) -> Quat {
        let (y, p, r) = self.prev_attitude;
        math::body_orientation(y, p.to_radians(), r.to_radians())
    }
}

/// Per-swarm constants, precomputed in f32.
struct SwarmRt {
    model: ModelKind,
    k1: f32,
    k2: f32,
    k3: f32,
    h: f32,
    kernels: Kernels,
    rest_density: f32,
    d0: f32,
    fov: f32,
    roll_max: f32,
    /// Per-substep blend of the heading towards the direction of travel.
    yaw_blend: f32,
    /// Preferred-speed wandering: σ (log units), and the per-substep decay and kick of
    /// its Ornstein–Uhlenbeck state.
    wander_sigma: f32,
    wander_decay: f32,
    wander_kick: f32,
    /// Optic-flow speed control: preferred-speed fraction at a surface and its recovery
    /// length (vision::surface_speed_factor).
    surface_speed: f32,
    surface_speed_distance: f32,
    time_unit: f64,
    stiffness: f32,
    spring: f32,
    attraction: f32,
    containment: f32,
    mass: f32,
    radius: f32,
    wing_area: f32,
    mean_cl: f32,
    curl: CurlNoise,
    bounds: Option<(Vec3, Vec3)>,
    /// Targets attracting this swarm.
    targets: Vec<usize>,
}

/// A target's static virtual particles (offsets from its centre) and current centre.
struct TargetRt {
    offsets: Vec<Vec3>,
    center: Vec3,
    bounding: f32,
}

/// A running simulation of a shot.
pub struct Simulation {
    shot: Shot,
    swarms: Vec<SwarmRt>,
    targets: Vec<TargetRt>,
    bees: Vec<Bee>,
    next: Vec<Bee>,
    neighbours: Vec<Neighbours>,
    densities: Vec<(f32, f32)>,
    hot: Vec<Hot>,
    positions: Vec<Vec3>,
    grid: Grid,
    grid_cell: f32,
    /// Largest capsule radius of any bee, m: bounds every interaction distance.
    max_body_radius: f32,
    frame: i32,
    step_index: u64,
    record: Vec<SwarmFrame>,
}

impl Simulation {
    pub fn new(shot: &Shot) -> Self {
        let shot = shot.clone();
        let swarms: Vec<SwarmRt> = shot
            .swarms
            .iter()
            .enumerate()
            .map(|(si, s)| {
                let p = &s.params;
                SwarmRt {
                    model: s.model,
                    k1: p.kappa1 as f32,
                    k2: p.kappa2 as f32,
                    k3: p.kappa3 as f32,
                    h: p.neighbour_radius as f32,
                    kernels: Kernels::new(p.neighbour_radius as f32),
                    rest_density: s.bee.mass * Kernels::new(p.neighbour_radius as f32).poly6(0.0),
                    d0: p.avoid_distance as f32,
                    fov: p.fov_deg as f32,
                    roll_max: p.roll_max_deg as f32,
                    yaw_blend: lag_blend(shot.dt() as f32, p.heading_lag as f32),
                    wander_sigma: p.speed_wander as f32,
                    wander_decay: (-shot.dt() / p.speed_wander_time).exp() as f32,
                    wander_kick: (1.0 - (-2.0 * shot.dt() / p.speed_wander_time).exp()).sqrt()
                        as f32,
                    surface_speed: p.surface_speed as f32,
                    surface_speed_distance: p.surface_speed_distance as f32,
                    time_unit: p.oscillation_time_unit,
                    stiffness: p.pressure_stiffness as f32,
                    spring: p.collision_stiffness as f32,
                    attraction: p.attraction as f32,
                    containment: p.containment as f32,
                    mass: s.bee.mass,
                    radius: s.bee.radius,
                    wing_area: s.bee.wing_area,
                    mean_cl: oscillation::mean_lift_coefficient(),
                    curl: CurlNoise::new(
                        math::mix64(shot.seed ^ ((si as u64 + 1) * 0x51ED)),
                        p.noise_cell,
                        p.noise_gain,
                    ),
                    bounds: s.bounds,
                    targets: shot
                        .targets
                        .iter()
                        .enumerate()
                        .filter(|(_, t)| t.swarms.contains(&si))
                        .map(|(ti, _)| ti)
                        .collect(),
                }
            })
            .collect();
        let spacing = swarms.iter().map(|s| s.h).fold(f32::INFINITY, f32::min) * 0.4;
        let targets = shot
            .targets
            .iter()
            .map(|t| {
                let offsets = match t.kind {
                    TargetKind::Attractor | TargetKind::Surface => Vec::new(),
                    _ => {
                        repulsion::sphere_samples(Vec3::ZERO, t.radius, spacing.max(t.radius * 0.3))
                    }
                };
                TargetRt {
                    offsets,
                    center: t.position_at(shot.frame_start as f64),
                    bounding: t.radius,
                }
            })
            .collect();
        let max_body_radius = shot
            .swarms
            .iter()
            .map(|s| s.bee.radius * (1.0 + s.variation.size))
            .fold(0.0, f32::max);
        let grid_cell = swarms
            .iter()
            .map(|s| s.h + 2.0 * max_body_radius)
            .fold(0.0, f32::max);

        let mut bees = Vec::with_capacity(shot.bee_count());
        for (si, s) in shot.swarms.iter().enumerate() {
            for k in 0..s.count {
                let mut rng = Rng::new(shot.seed, si as u64, k as u64);
                let mut pos = match s.spawn {
                    Region::Box { center, half } => {
                        center
                            + Vec3::new(
                                rng.range(-1.0, 1.0),
                                rng.range(-1.0, 1.0),
                                rng.range(-1.0, 1.0),
                            ) * half
                    }
                    Region::Sphere { center, radius } => loop {
                        let v = Vec3::new(
                            rng.range(-1.0, 1.0),
                            rng.range(-1.0, 1.0),
                            rng.range(-1.0, 1.0),
                        );
                        if v.length_squared() <= 1.0 {
                            break center + v * radius;
                        }
                    },
                };
                let var = s.variation;
                let size = 1.0 + var.size * rng.range(-1.0, 1.0);
                let speed = s.params.speed as f32 * (1.0 + var.speed * rng.range(-1.0, 1.0));
                // A bee spawned inside an obstacle starts just outside its surface.
                let r = s.bee.radius * size;
                for o in &shot.obstacles {
                    let q = obstacle::query(&o.shape, pos);
                    if q.distance < r {
                        pos = q.point + q.normal * (r + 1e-3);
                    }
                }
                let dir = normalize_or(
                    Vec3::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-0.2, 0.2),
                        rng.range(-1.0, 1.0),
                    ),
                    Vec3::X,
                );
                let vel = dir * speed;
                let yaw = math::yaw_of(dir);
                let phase_pitch = var.phase * rng.f32() * oscillation::PITCH_PERIOD as f32;
                let phase_roll = var.phase * rng.f32() * oscillation::ROLL_PERIOD as f32;
                let model = s.model;
                let (pitch_deg, roll_deg) = match model {
                    ModelKind::Bee => (
                        oscillation::pitch_deg(phase_pitch as f64),
                        oscillation::roll_deg(phase_roll as f64),
                    ),
                    _ => (0.0, 0.0),
                };
                bees.push(Bee {
                    pos,
                    vel,
                    wander: rng.gaussian(),
                    mean_pos: pos,
                    yaw,
                    pitch_deg,
                    roll_deg,
                    prev_attitude: (yaw, pitch_deg, roll_deg),
                    swarm: si as u32,
                    size,
                    speed,
                    phase_pitch,
                    phase_roll,
                });
            }
        }
        let mut sim = Simulation {
            frame: shot.frame_start,
            shot,
            swarms,
            targets,
            next: bees.clone(),
            neighbours: Vec::new(),
            densities: Vec::new(),
            hot: Vec::new(),
            bees,
            positions: Vec::new(),
            grid: Grid::default(),
            grid_cell,
            max_body_radius,
            step_index: 0,
            record: Vec::new(),
        };
        sim.update_record();
        sim
    }

    /// Places bee `index` (shot order) at `position` with `velocity` and re-records the
    /// current frame: for tests and tools that need exact starting conditions.
    pub fn set_bee(&mut self, index: usize, position: Vec3, velocity: Vec3) {
        let b = &mut self.bees[index];
        b.pos = position;
        b.vel = velocity;
        b.mean_pos = position;
        // The heading follows the new direction of travel at once.
        let horizontal = Vec3::new(velocity.x, 0.0, velocity.z);
        if horizontal.length() > 0.02 {
            b.yaw = math::yaw_of(horizontal);
        }
        b.prev_attitude = (b.yaw, b.pitch_deg, b.roll_deg);
        self.update_record();
    }

    pub fn shot(&self) -> &Shot {
        &self.shot
    }

    /// The current frame number.
    pub fn frame(&self) -> i32 {
        self.frame
    }

    /// True once the last frame of the range has been reached.
    pub fn done(&self) -> bool {
        self.frame >= self.shot.frame_end
    }

    /// Seconds since the first frame.
    pub fn time(&self) -> f64 {
        (self.frame - self.shot.frame_start) as f64 / self.shot.fps
    }

    /// The state at the current frame, one entry per swarm.
    pub fn record(&self) -> &[SwarmFrame] {
        &self.record
    }

    pub fn meta(&self) -> CacheMeta {
        CacheMeta {
            shot_name: self.shot.name.clone(),
            fps: self.shot.fps,
            frame_start: self.shot.frame_start,
            frame_end: self.shot.frame_end,
            seed: self.shot.seed,
            tool_version: env!("CARGO_PKG_VERSION").to_owned(),
            swarms: self
                .shot
                .swarms
                .iter()
                .map(|s| SwarmMeta {
                    name: s.name.clone(),
                    count: s.count,
                    species: &crate::species::HONEYBEE,
                    channels: crate::species::BEE_CHANNELS.to_vec(),
                    body_length_m: s.bee.length,
                    wing_beat_hz: s.bee.wing_beat_hz,
                })
                .collect(),
        }
    }

    /// Advances one frame (`substeps` integration steps) and records it.
    pub fn advance(&mut self) {
        let dt = self.shot.dt() as f32;
        for k in 0..self.shot.substeps {
            let t = self.time() + (k as f64) * self.shot.dt();
            self.step(t, dt);
        }
        self.frame += 1;
        self.update_record();
    }

    fn update_targets(&mut self, t: f64) {
        let frame = self.shot.frame_start as f64 + t * self.shot.fps;
        for (rt, target) in self.targets.iter_mut().zip(&self.shot.targets) {
            rt.center = target.position_at(frame);
        }
    }

    /// One integration step of `dt` seconds starting at time `t`.
    fn step(&mut self, t: f64, dt: f32) {
        if self.bees.is_empty() {
            return;
        }
        self.update_targets(t);
        self.positions.clear();
        self.positions.extend(self.bees.iter().map(|b| b.pos));
        self.grid.build(&self.positions, self.grid_cell);
        let swarms = &self.swarms;
        self.hot.clear();
        self.hot.extend(self.bees.iter().map(|b| {
            let s = &swarms[b.swarm as usize];
            Hot {
                pos: b.pos,
                radius: s.radius * b.size,
                vel: b.vel,
                mass: s.mass,
                density: 0.0,
                pressure: 0.0,
            }
        }));

        // Pass 1: neighbours, and density and pressure (Eq. 10) for bees of the bee model,
        // written in place (no per-step allocation).
        let n = self.bees.len();
        let mut neighbours = std::mem::take(&mut self.neighbours);
        neighbours.resize(n, Neighbours::default());
        let mut densities = std::mem::take(&mut self.densities);
        densities.resize(n, (0.0, 0.0));
        neighbours
            .par_iter_mut()
            .zip(densities.par_iter_mut())
            .enumerate()
            .with_min_len(256)
            .for_each(|(i, (list, d))| *d = self.density(i, list));
        for (h, &(d, p)) in self.hot.iter_mut().zip(&densities) {
            h.density = d;
            h.pressure = p;
        }
        self.neighbours = neighbours;
        self.densities = densities;
        // Pass 2: forces and integration into the second state buffer.
        let step_index = self.step_index;
        let lags = Lags::new(dt);
        let mut next = std::mem::take(&mut self.next);
        next.resize(n, self.bees[0]);
        next.par_iter_mut()
            .enumerate()
            .with_min_len(128)
            .for_each(|(i, out)| *out = self.integrate(i, t, dt, &lags, step_index));
        self.next = next;
        std::mem::swap(&mut self.bees, &mut self.next);
        self.step_index += 1;
    }

    /// Every other bee within interaction reach of bee i, in grid order: the cached list,
    /// or a grid walk when the list overflowed.
    #[inline]
    fn for_each_neighbour(&self, i: usize, reach: f32, mut f: impl FnMut(usize, Vec3, f32)) {
        let p = self.bees[i].pos;
        let n = &self.neighbours[i];
        if n.overflow {
            self.grid.for_each_within(p, reach, |j, pj, d2| {
                if j != i {
                    f(j, pj, d2)
                }
            });
        } else {
            for &j in &n.idx[..n.len as usize] {
                let pj = self.hot[j as usize].pos;
                f(j as usize, pj, p.distance_squared(pj));
            }
        }
    }

    /// Density and pressure of bee i; fills `list` with its neighbours.
    fn density(&self, i: usize, list: &mut Neighbours) -> (f32, f32) {
        let b = &self.bees[i];
        let s = &self.swarms[b.swarm as usize];
        let ri = s.radius * b.size;
        let reach = s.h + ri + self.max_body_radius;
        let bee_model = s.model == ModelKind::Bee;
        let mut rho = 0.0;
        list.len = 0;
        list.overflow = false;
        self.grid.for_each_within(b.pos, reach, |j, _, d2| {
            if j != i {
                list.push(j);
            }
            if bee_model {
                let o = &self.hot[j];
                rho += repulsion::density_term(&s.kernels, o.mass, d2.sqrt(), ri + o.radius);
            }
        });
        if !bee_model {
            return (0.0, 0.0);
        }
        for &ti in &s.targets {
            let tr = &self.targets[ti];
            if b.pos.distance(tr.center) > tr.bounding + s.h + ri {
                continue;
            }
            for off in &tr.offsets {
                rho += repulsion::density_term(
                    &s.kernels,
                    s.mass,
                    b.pos.distance(tr.center + *off),
                    ri,
                );
            }
        }
        (rho, repulsion::pressure(s.stiffness, rho, s.rest_density))
    }

    /// A deterministic direction separating coincident bees i and j (opposite for j and i).
    fn separation_fallback(i: usize, j: usize) -> Vec3 {
        let (a, b, sign) = if i < j { (i, j, 1.0) } else { (j, i, -1.0) };
        Rng::new(a as u64, b as u64, 0x5EA).unit_vector() * sign
    }

    fn integrate(&self, i: usize, t: f64, dt: f32, lags: &Lags, step_index: u64) -> Bee {
        let b = self.bees[i];
        let s = &self.swarms[b.swarm as usize];
        let shot = &self.shot;
        let wind = shot.wind;
        let ri = s.radius * b.size;
        let (density, pressure) = (self.hot[i].density, self.hot[i].pressure);
        let mut out = b;

        // Neighbours: pressure repulsion (Eq. 11), contact springs (Sec. VII), boids rules.
        let mut a_rep = Vec3::ZERO;
        let mut a_col = Vec3::ZERO;
        let mut hood = boids::Neighbourhood::default();
        let reach = s.h + ri + self.max_body_radius;
        self.for_each_neighbour(i, reach, |j, pj, d2| {
            let o = &self.hot[j];
            let r = b.pos - pj;
            let dist = d2.sqrt();
            let contact = ri + o.radius;
            let fallback = || Self::separation_fallback(i, j);
            match s.model {
                ModelKind::Bee => {
                    let rho_j = if o.density > 0.0 { o.density } else { density };
                    a_rep += repulsion::pressure_term(
                        &s.kernels, r, dist, contact, o.mass, pressure, o.pressure, density, rho_j,
                        fallback,
                    );
                }
                ModelKind::Boids => {
                    hood.count += 1;
                    hood.velocity_sum += o.vel;
                    hood.position_sum += o.pos;
                    if dist < s.h * 0.5 {
                        hood.separation += if dist > 1e-6 {
                            r / (dist * dist)
                        } else {
                            fallback() * 1e3
                        };
                    }
                }
                ModelKind::Brownian => {}
            }
            a_col += collision::spring_accel(r, dist, contact, b.vel - o.vel, s.spring, fallback);
        });

        // Targets: attraction, and the push of their virtual particles.
        let mut a_attr = Vec3::ZERO;
        for &ti in &s.targets {
            let target = &shot.targets[ti];
            let tr = &self.targets[ti];
            let strength = target.strength * s.attraction;
            a_attr += match target.kind {
                TargetKind::Surface => targets::surface_attraction(
                    b.pos,
                    tr.center,
                    target.normal,
                    strength,
                    target.reach,
                ),
                _ => targets::attraction(b.pos, tr.center, strength, target.reach),
            };
            if s.model == ModelKind::Bee && b.pos.distance(tr.center) <= tr.bounding + s.h + ri {
                for off in &tr.offsets {
                    let r = b.pos - (tr.center + *off);
                    let dist = r.length();
                    // A static particle mirrors the bee's pressure at rest density.
                    a_rep += repulsion::pressure_term(
                        &s.kernels,
                        r,
                        dist,
                        ri,
                        s.mass,
                        pressure,
                        pressure,
                        density,
                        s.rest_density,
                        || normalize_or(*off, Vec3::Y),
                    );
                }
            }
        }
        if let Some((c, h)) = s.bounds {
            a_attr += targets::containment(b.pos, c, h, s.containment);
        }

        // Model-specific acceleration.
        let air = b.vel - wind;
        let heading = Quat::from_rotation_y(b.yaw);
        let mut gamma = 1.0f32;
        // While avoiding an obstacle it sees: the horizontal way out, away from every
        // obstacle within d0 (seen or not, so that a corner's way out is its diagonal).
        let mut avoiding = false;
        let mut away = Vec3::ZERO;
        let a = match s.model {
            ModelKind::Bee => {
                let tt = t / s.time_unit;
                out.pitch_deg = oscillation::pitch_deg(tt + b.phase_pitch as f64);
                let mut roll_target = oscillation::roll_deg(tt + b.phase_roll as f64);
                // Vision (Sec. IV-B): the nearest obstacle seen within d0 takes over the roll.
                let forward =
                    heading * (Quat::from_rotation_z(out.pitch_deg.to_radians()) * Vec3::X);
                let mut nearest = f32::INFINITY;
                let mut nearest_any = f32::INFINITY;
                for o in &shot.obstacles {
                    let q = obstacle::query(&o.shape, b.pos);
                    let d = q.distance - ri;
                    nearest_any = nearest_any.min(d);
                    let r_e = q.point - b.pos;
                    if d < s.d0 {
                        let n = normalize_or(Vec3::new(-r_e.x, 0.0, -r_e.z), Vec3::ZERO);
                        away += n * (1.0 - d.max(0.0) / s.d0);
                    }
                    if d < s.d0 && d < nearest && vision::in_view(forward, r_e, s.fov) {
                        nearest = d;
                        roll_target =
                            vision::avoid_roll_deg(vision::side(forward, r_e), d, s.d0, s.roll_max);
                        gamma = vision::ramp((d / s.d0).max(0.0)).abs();
                        avoiding = true;
                    }
                }
                out.roll_deg = b.roll_deg + (roll_target - b.roll_deg) * lags.roll;
                let f_o = oscillation::accel(
                    out.pitch_deg,
                    out.roll_deg,
                    air.length(),
                    s.mass,
                    s.wing_area,
                    s.mean_cl,
                );
                let a_o = heading * f_o;
                // Linear drag sized so that mean thrust balances at the preferred speed,
                // which wanders slowly (log-normal, mean preserved) when speed_wander > 0.
                let mut pref = b.speed
                    * vision::surface_speed_factor(
                        nearest_any,
                        s.surface_speed,
                        s.surface_speed_distance,
                    );
                if s.wander_sigma > 0.0 {
                    let mut rng = Rng::new(shot.seed ^ 0x5BEED, i as u64, step_index);
                    out.wander = b.wander * s.wander_decay + s.wander_kick * rng.gaussian();
                    let sg = s.wander_sigma;
                    pref *= (sg * out.wander - 0.5 * sg * sg).exp();
                }
                let drag = s.k1 * oscillation::mean_thrust_accel() / pref.max(1e-3);
                // Eq. 1, plus the terms the paper leaves implicit (docs/model.md). While
                // avoiding, the other rules are faded out by the ramp γ.
                s.k1 * a_o + gamma * (s.k2 * s.curl.force(b.pos) + a_attr) + s.k3 * a_rep
                    - air * drag
            }
            ModelKind::Brownian => {
                let mut rng = Rng::new(shot.seed ^ 0xB12, i as u64, step_index);
                let xi = Vec3::new(rng.gaussian(), rng.gaussian(), rng.gaussian());
                brownian::accel(b.vel, wind, b.speed, xi, dt) + a_attr
            }
            ModelKind::Boids => boids::accel(b.pos, b.vel, &hood, b.speed) + a_attr,
        };
        let a = math::finite_or_zero(a + a_col);

        // Semi-implicit Euler, then obstacle velocity tuning (Eq. 5) and a hard guard.
        let mut vel = b.vel + a * dt;
        for o in &shot.obstacles {
            let q = obstacle::query(&o.shape, b.pos);
            vel = vision::tune_velocity(vel, q.normal, q.distance - ri, s.d0);
        }
        let max_speed = 4.0 * b.speed + 2.0;
        if vel.length() > max_speed {
            vel = vel.normalize() * max_speed;
        }
        let mut pos = b.pos + vel * dt;
        for o in &shot.obstacles {
            let q = obstacle::query(&o.shape, pos);
            if q.distance < ri {
                // Numerically the ramp can leave a sliver of approach; never let a body in.
                pos = q.point + q.normal * ri;
                let vn = vel.dot(q.normal);
                if vn < 0.0 {
                    vel -= q.normal * vn;
                }
            }
        }
        if !pos.is_finite() || !vel.is_finite() {
            pos = b.pos;
            vel = Vec3::ZERO;
        }
        out.pos = pos;
        out.vel = vel;

        let horizontal = Vec3::new(vel.x, 0.0, vel.z);
        let stopped = avoiding && horizontal.length() < HOVER_TURN_SPEED;
        if stopped && away.length_squared() > 1e-8 {
            // Stopped facing an obstacle (in a corner, say): turn on the spot towards open
            // air, or the heading, and with it the thrust, would stay pointed at the wall.
            let dy = wrap_angle(math::yaw_of(away) - b.yaw);
            let turn = dy.clamp(-HOVER_TURN_RATE * dt, HOVER_TURN_RATE * dt);
            out.yaw = (b.yaw + turn).rem_euclid(std::f32::consts::TAU);
        } else if horizontal.length() > 0.02 {
            let target = math::yaw_of(horizontal);
            let dy = wrap_angle(target - b.yaw);
            out.yaw = (b.yaw + dy * s.yaw_blend).rem_euclid(std::f32::consts::TAU);
        }
        out.mean_pos = b.mean_pos + (pos - b.mean_pos) * lags.sway;
        out.prev_attitude = (b.yaw, b.pitch_deg, b.roll_deg);
        out
    }

    fn update_record(&mut self) {
        let dt = self.shot.dt() as f32;
        let mut id = 0u64;
        let mut rec = std::mem::take(&mut self.record);
        rec.resize_with(self.shot.swarms.len(), SwarmFrame::default);
        let mut start = 0;
        for (si, s) in self.shot.swarms.iter().enumerate() {
            let bees = &self.bees[start..start + s.count];
            let f = &mut rec[si];
            f.ids.clear();
            f.ids.extend((0..s.count as u64).map(|k| id + k));
            f.position.clear();
            f.position.extend(bees.iter().map(|b| b.pos));
            f.velocity.clear();
            f.velocity.extend(bees.iter().map(|b| b.vel));
            f.orientation.clear();
            f.orientation.extend(bees.iter().map(|b| b.orientation()));
            f.heading.clear();
            f.heading
                .extend(bees.iter().map(|b| Quat::from_rotation_y(b.yaw)));
            // Channels: BEE_CHANNELS, pitch, roll, sway.
            f.channels.resize_with(3, Vec::new);
            let [pitch, roll, sway] = &mut f.channels[..] else {
                unreachable!("three channels")
            };
            pitch.clear();
            pitch.extend(bees.iter().map(|b| b.pitch_deg));
            roll.clear();
            roll.extend(bees.iter().map(|b| b.roll_deg));
            sway.clear();
            sway.extend(
                bees.iter()
                    .zip(&f.heading)
                    .map(|(b, h)| (b.pos - b.mean_pos).dot(*h * Vec3::Z)),
            );
            f.angular_velocity_deg.clear();
            f.angular_velocity_deg
                .extend(bees.iter().zip(&f.orientation).map(|(b, q)| {
                    math::angular_velocity(b.prev_orientation(), *q, dt)
                        * (180.0 / std::f32::consts::PI)
                }));
            f.scale.clear();
            f.scale.extend(bees.iter().map(|b| b.size));
            id += s.count as u64;
            start += s.count;
        }
        self.record = rec;
    }
}
