//! Paper 000's bio-inspired bee model (Chen et al., "A Bio-inspired Model for Bee
//! Simulations"), one file per force: body oscillation (Eq. 2–4), SPH repulsion
//! (Eq. 10–11) with its kernels, and the parameters with Table I. Vision (Eq. 5–7) and
//! contact springs are shared with other models (`model::vision`, `model::collision`).
//!
//! Eq. 1: a = κ1 F_o + γ (κ2 F_curl + F_target) + κ3 F_repul − drag, with the terms the
//! paper leaves implicit described in docs/model.md.

pub mod hive;
pub mod kernels;
pub mod manoeuvre;
pub mod oscillation;
mod pairs;
pub mod params;
pub mod repulsion;

pub use params::BeeParams;

use super::attitudes::{self, Attitudes};
use super::context::{Context, Neighbour, TargetNow};
use super::curl_now::CurlNow;
use super::flight::{Avoidance, Cruiser, Flight, lag_blend};
use super::{Agent, Model, ModelInfo, Pose, Start, SwarmSetup, vision};
use crate::field::CurlNoise;
use crate::math::{self, Rng, normalize_or};
use crate::species::{BEE_CHANNELS, HONEYBEE};
use glam::{Quat, Vec3};
use kernels::Kernels;
use oscillation::Phasor;

/// Time constants of the body's attitude, seconds: how fast the roll reaches its target,
/// and the smoothing of the mean path for sway. (How fast the heading follows the velocity
/// is the `heading_lag` parameter.)
const ROLL_LAG_S: f32 = 0.04;
const SWAY_PATH_S: f32 = 0.3;

/// Values of the `state` channel.
pub const FLYING: f32 = 0.0;
pub const HOVERING: f32 = 1.0;
pub const LANDED: f32 = 2.0;
/// Inside a hive (hidden in the caches; see `hive`).
pub const INSIDE: f32 = 3.0;
/// Speed, m/s, below which a flying bee is recorded as hovering.
const HOVER_SPEED: f32 = 0.1;
/// A bee touches down on a target with `land = true` once its body is this close to the
/// target's surface, m.
const TOUCH_DOWN_M: f32 = 0.02;
/// After taking off a bee flies at least this long, s, before it can land again.
const TAKE_OFF_S: f32 = 1.0;
/// A bee that may land and has slowed below this speed, m/s, within the reach of a
/// `land = true` target's particles comes in to land: that target no longer pushes it
/// back, and its pull brings the bee down onto the surface.
const LANDING_SPEED: f32 = 0.5;

/// One bee's state.
#[derive(Clone, Copy, Debug)]
pub struct Bee {
    pub c: Cruiser,
    /// Ornstein–Uhlenbeck state (stationary N(0, 1)) of the preferred speed's wandering.
    wander: f32,
    /// Exponentially smoothed path; sway is the lateral offset from it.
    mean_pos: Vec3,
    /// Elevation of the direction of travel, degrees (up positive), followed with the
    /// heading's lag: the body's pitch is this plus Eq. 3's oscillation about its mean.
    climb_deg: f32,
    /// 1 while banking away from an obstacle seen and not yet passed, else 0 (an f32 so
    /// that the state stays plain 4-byte words for checkpoints).
    banking: f32,
    /// Body roll as drawn, degrees: `roll_deg` except while banking away from an obstacle.
    drawn_roll_deg: f32,
    /// Body pitch as drawn, degrees (nose up positive).
    pitch_deg: f32,
    roll_deg: f32,
    /// Attitude (yaw rad, pitch deg, roll deg) one substep earlier: the recorded angular
    /// velocity is the rotation between the two attitudes over that substep.
    prev_attitude: (f32, f32, f32),
    /// `FLYING`, `HOVERING`, `LANDED` or `INSIDE` (recorded as the `state` channel).
    state: f32,
    /// Landed: seconds left before taking off (or going in). Inside: seconds left before
    /// coming out. Flying: seconds before it may land again.
    timer: f32,
    /// Landed on a hive entrance: 1 if this stay ends by going in, 0 if by taking off.
    going_in: f32,
    /// Landed or inside: the body's offset from the centre of the target it sits on, and that
    /// target's index (as f32, so that the state stays plain 4-byte words).
    perch: Vec3,
    perch_target: f32,
    /// This bee's phase offsets of Eq. 3 and Eq. 4, as phasors (`oscillation::offsets`).
    phase_pitch: Phasor,
    phase_roll: Phasor,
}

impl Agent for Bee {
    fn position(&self) -> Vec3 {
        self.c.pos
    }
    fn velocity(&self) -> Vec3 {
        self.c.vel
    }
    fn size(&self) -> f32 {
        self.c.size
    }
    fn place(&mut self, position: Vec3, velocity: Vec3) {
        self.c.place(position, velocity);
        self.mean_pos = position;
        if velocity.length() > 0.02 {
            self.climb_deg = elevation_deg(velocity);
        }
        self.prev_attitude = (self.c.yaw, self.pitch_deg, self.drawn_roll_deg);
    }
    fn hidden(&self) -> bool {
        self.state == INSIDE
    }
}

/// Per-swarm constants, precomputed in f32.
pub struct BeeModel {
    flight: Flight,
    k1: f32,
    k2: f32,
    k3: f32,
    h: f32,
    kernels: Kernels,
    rest_density: f32,
    fov: f32,
    roll_max: f32,
    roll_blend: f32,
    sway_blend: f32,
    /// Preferred-speed wandering: σ (log units), and the per-substep decay and kick of
    /// its Ornstein–Uhlenbeck state.
    wander_sigma: f32,
    wander_decay: f32,
    wander_kick: f32,
    surface_speed: f32,
    surface_speed_distance: f32,
    arrival_speed: f32,
    time_unit: f64,
    /// Speed of Eq. 2's lift when it is the weight-bearing wing speed; None: the air speed.
    wing_speed: Option<f32>,
    /// Weight of the stroke-plane manoeuvres (`manoeuvre`, src/model/bee/manoeuvre.rs).
    manoeuvre: f32,
    stiffness: f32,
    mass: f32,
    wing_area: f32,
    mean_cl: f32,
    phase_spread: f32,
    speed: f32,
    curl: CurlNoise,
    /// Eq. 8–9's force at every bee of the swarm this substep (set by `prepare`).
    curl_now: CurlNow,
    /// Eq. 3's and Eq. 4's phasors at the time of the substep being stepped, and that
    /// time, s (set by `prepare`, once per substep for the whole swarm).
    clock: (Phasor, Phasor),
    clock_t: f64,
}

impl Model for BeeModel {
    type Agent = Bee;
    const INFO: ModelInfo = ModelInfo {
        name: "bee",
        summary: "Paper 000, Chen et al.: body oscillation, visual obstacle avoidance with \
                  roll, curl-noise flight and SPH repulsion (Eq. 1)",
        params: BeeParams::SPECS,
        presets: params::PRESETS,
        channels: &BEE_CHANNELS,
        species: &HONEYBEE,
    };
    const GATHERS: bool = true;
    const HIDDEN_STATE: Option<(&'static str, f32)> = Some(("state", INSIDE));

    fn new(s: &SwarmSetup) -> Self {
        let p = BeeParams::from_values(s.params);
        let dt = s.dt;
        let kernels = Kernels::new(p.neighbour_radius as f32);
        BeeModel {
            flight: Flight::new(s),
            k1: p.kappa1 as f32,
            k2: p.kappa2 as f32,
            k3: p.kappa3 as f32,
            h: p.neighbour_radius as f32,
            rest_density: s.body.mass * kernels.poly6(0.0),
            kernels,
            fov: p.fov_deg as f32,
            roll_max: p.roll_max_deg as f32,
            roll_blend: lag_blend(dt as f32, ROLL_LAG_S),
            sway_blend: lag_blend(dt as f32, SWAY_PATH_S),
            wander_sigma: p.speed_wander as f32,
            wander_decay: (-dt / p.speed_wander_time).exp() as f32,
            wander_kick: (1.0 - (-2.0 * dt / p.speed_wander_time).exp()).sqrt() as f32,
            surface_speed: p.surface_speed as f32,
            surface_speed_distance: p.surface_speed_distance as f32,
            arrival_speed: p.arrival_speed as f32,
            time_unit: p.oscillation_time_unit,
            manoeuvre: p.manoeuvre as f32,
            wing_speed: (p.wing_lift > 0.5).then(|| {
                oscillation::weight_bearing_wing_speed(
                    s.body.mass,
                    s.body.wing_area,
                    oscillation::mean_lift_coefficient(),
                )
            }),
            stiffness: p.pressure_stiffness as f32,
            mass: s.body.mass,
            wing_area: s.body.wing_area,
            mean_cl: oscillation::mean_lift_coefficient(),
            phase_spread: s.variation.phase,
            speed: p.speed as f32,
            curl: CurlNoise::new(
                math::mix64(s.seed ^ ((s.index as u64 + 1) * 0x51ED)),
                p.noise_cell,
                p.noise_gain,
            ),
            curl_now: CurlNow::default(),
            clock: oscillation::clock(0.0),
            clock_t: 0.0,
        }
    }

    fn prepare(&mut self, cx: &Context, agents: std::ops::Range<usize>) {
        self.clock = oscillation::clock(cx.t / self.time_unit);
        self.clock_t = cx.t;
        self.curl_now.fill(&self.curl, cx, agents);
    }

    fn reach(&self) -> f32 {
        self.h
    }

    fn target_particle_spacing(&self) -> Option<f32> {
        Some(self.h * 0.4)
    }

    fn spawn(&self, start: &Start, rng: &mut Rng) -> Bee {
        let c = Cruiser::new(start, self.speed);
        let phase_pitch = self.phase_spread * rng.f32() * oscillation::PITCH_PERIOD as f32;
        let phase_roll = self.phase_spread * rng.f32() * oscillation::ROLL_PERIOD as f32;
        let climb_deg = elevation_deg(c.vel);
        let pitch_deg =
            climb_deg + oscillation::pitch_deg(phase_pitch as f64) - oscillation::MEAN_PITCH_DEG;
        let roll_deg = oscillation::roll_deg(phase_roll as f64);
        let (phase_pitch, phase_roll) = oscillation::offsets(phase_pitch as f64, phase_roll as f64);
        let bee = Bee {
            c,
            wander: rng.gaussian(),
            mean_pos: c.pos,
            climb_deg,
            banking: 0.0,
            drawn_roll_deg: roll_deg,
            state: FLYING,
            timer: 0.0,
            perch: Vec3::ZERO,
            perch_target: 0.0,
            pitch_deg,
            roll_deg,
            prev_attitude: (c.yaw, pitch_deg, roll_deg),
            phase_pitch,
            phase_roll,
            going_in: 0.0,
        };
        match start.inside {
            Some(h) => hive::starting_inside(bee, h),
            None => bee,
        }
    }

    #[inline]
    fn gather_term(&self, ri: f32, o: &Neighbour, d2: f32) -> f32 {
        repulsion::density_term(&self.kernels, o.mass, d2.sqrt(), ri + o.radius)
    }

    fn gather_list(
        &self,
        me: &Neighbour,
        agents: &[Neighbour],
        list: &[u32],
        own: f32,
    ) -> Option<f32> {
        pairs::density_sum(&self.kernels, agents, list, me, own)
    }

    fn gather_finish(&self, targets: &[TargetNow], pos: Vec3, ri: f32, sum: f32) -> (f32, f32) {
        let mut rho = sum;
        for &ti in &self.flight.targets {
            let t = &targets[ti];
            if pos.distance(t.center) > t.radius + self.h + ri {
                continue;
            }
            for off in &t.particles {
                rho += repulsion::density_term(
                    &self.kernels,
                    self.mass,
                    pos.distance(t.center + *off),
                    ri,
                );
            }
        }
        (
            rho,
            repulsion::pressure(self.stiffness, rho, self.rest_density),
        )
    }

    fn step(&self, cx: &Context, i: usize, b: &Bee) -> Bee {
        if b.state >= LANDED {
            return if b.state == LANDED {
                self.perched(cx, i, b)
            } else {
                self.inside(cx, i, b)
            };
        }
        let c = &b.c;
        let ri = self.flight.body_radius(c.size);
        let (density, pressure) = (cx.agents[i].density, cx.agents[i].pressure);
        let mut out = *b;

        // Neighbours: pressure repulsion (Eq. 11) and contact springs (Sec. VII), a whole
        // list at once where the CPU allows (`pairs`), else one neighbour at a time.
        let bee = pairs::Bee {
            kernels: &self.kernels,
            pos: c.pos,
            vel: c.vel,
            radius: ri,
            density,
            pressure,
            reach: self.h + ri + cx.max_body_radius,
            spring: self.flight.spring,
        };
        let (mut a_rep, a_col) = match pairs::sums(cx.agents, cx.lists[i].indices(), &bee) {
            Some(sums) => sums,
            None => pairs_one_by_one(cx, i, &bee),
        };

        // Targets: attraction, and the push of their virtual particles.
        let a_attr = self.flight.pull(cx, c.pos);
        for &ti in &self.flight.targets {
            let t = &cx.targets[ti];
            if c.pos.distance(t.center) > t.radius + self.h + ri {
                continue;
            }
            if t.land && b.timer <= 0.0 && c.vel.length() < LANDING_SPEED {
                continue; // coming in to land
            }
            for off in &t.particles {
                let r = c.pos - (t.center + *off);
                // A static particle mirrors the bee's pressure at rest density.
                a_rep += repulsion::pressure_term(
                    &self.kernels,
                    r,
                    r.length(),
                    ri,
                    self.mass,
                    pressure,
                    pressure,
                    density,
                    self.rest_density,
                    || normalize_or(*off, Vec3::Y),
                );
            }
        }

        // Body oscillation (Eq. 3–4) and vision (Sec. IV-B).
        let air = c.vel - cx.wind;
        let heading = Quat::from_rotation_y(c.yaw);
        // (A step outside the world's loop, without `prepare`, works its clock out here.)
        let (pitch_now, roll_now) = if cx.t == self.clock_t {
            self.clock
        } else {
            oscillation::clock(cx.t / self.time_unit)
        };
        // Eq. 3's pitch drives the thrust (Eq. 2); the body drawn points along the flight
        // direction, rocking by Eq. 3's oscillation about it (docs/model.md).
        let wing_pitch = oscillation::pitch_deg_of(pitch_now, b.phase_pitch);
        let mut roll_target = oscillation::roll_deg_of(roll_now, b.phase_roll);
        // The vision axis o is F_o's thrust axis (the heading pitched by Eq. 3), as the
        // calibrated preset was fitted with, not the drawn body's (docs/model.md). Only
        // an obstacle needs it: worked out at the first one (a sine and cosine saved in
        // open air).
        let mut vision_axis = None::<Vec3>;
        let thrust_axis = || heading * (Quat::from_rotation_z(wing_pitch.to_radians()) * Vec3::X);
        let d0 = self.flight.d0;
        let mut gamma = 1.0f32;
        let mut nearest = f32::INFINITY;
        let mut nearest_any = f32::INFINITY;
        let (mut nearest_bank, mut bank, mut held) = (f32::INFINITY, None::<f32>, None::<f32>);
        // While avoiding an obstacle it sees: the horizontal way out, away from every
        // obstacle within d0 (seen or not, so that a corner's way out is its diagonal).
        let mut steer = Avoidance::default();
        for q in cx.obstacle_queries(c.pos) {
            let d = q.distance - ri;
            nearest_any = nearest_any.min(d);
            let r_e = q.point - c.pos;
            let forward = *vision_axis.get_or_insert_with(thrust_axis);
            if d < d0 {
                let n = normalize_or(Vec3::new(-r_e.x, 0.0, -r_e.z), Vec3::ZERO);
                steer.away += n * (1.0 - d.max(0.0) / d0);
            }
            // The nearest obstacle seen within d0 takes over the roll and the flight.
            if d < d0 && d < nearest && vision::in_view(forward, r_e, self.fov) {
                nearest = d;
                roll_target =
                    vision::avoid_roll_deg(vision::side(forward, r_e), d, d0, self.roll_max);
                bank = Some(vision::drawn_bank_deg(
                    vision::side(forward, r_e),
                    d,
                    d0,
                    self.roll_max,
                ));
                gamma = vision::ramp((d / d0).max(0.0)).abs();
                steer.avoiding = true;
            }
            // One that has left the view to the side but is not yet abeam (a shaft being
            // passed) keeps the bank until it is: the bee levels out once the obstacle is
            // avoided, not as soon as its nose turns away from it (docs/model.md).
            // Only an obstacle off to the side (a floor or a wall dead ahead has no side).
            let beside = vision::side(forward, r_e).abs() > 0.5 * r_e.length();
            if !steer.avoiding && d < d0 && d < nearest_bank && beside && forward.dot(r_e) > 0.0 {
                nearest_bank = d;
                held = Some(vision::drawn_bank_deg(
                    vision::side(forward, r_e),
                    d,
                    d0,
                    self.roll_max,
                ));
            }
        }
        // The drawn bank: 1 from the moment an obstacle is seen until it is abeam or
        // beyond d0. It is drawn only; the sway force keeps Eq. 6's roll (docs/model.md).
        let mut drawn_target = roll_target;
        out.banking = if let Some(r) = bank {
            drawn_target = r;
            1.0
        } else if let (Some(r), true) = (held, b.banking > 0.5) {
            drawn_target = r;
            1.0
        } else {
            0.0
        };
        out.drawn_roll_deg = b.drawn_roll_deg + (drawn_target - b.drawn_roll_deg) * self.roll_blend;
        out.roll_deg = b.roll_deg + (roll_target - b.roll_deg) * self.roll_blend;
        let mut f_o = oscillation::accel(
            wing_pitch,
            out.roll_deg,
            self.wing_speed.unwrap_or_else(|| air.length()),
            self.mass,
            self.wing_area,
            self.mean_cl,
        );
        // Linear drag sized so that mean thrust balances at the preferred speed, which
        // slows near surfaces (optic flow) and wanders slowly (log-normal, mean preserved)
        // when speed_wander > 0.
        let mut pref = c.speed
            * vision::surface_speed_factor(
                nearest_any,
                self.surface_speed,
                self.surface_speed_distance,
            );
        // Arriving at a nest or flower the bee slows to a hover (docs/model.md), so that it
        // does not overshoot and orbit it: the approach and retreat are then the push of
        // the target's particles against the pull (Sec. V-B).
        let mut nearest_target = f32::INFINITY;
        for &ti in &self.flight.targets {
            let t = &cx.targets[ti];
            if t.kind.has_body() {
                nearest_target = nearest_target.min(c.pos.distance(t.center) - t.radius);
            }
        }
        if self.arrival_speed < 1.0 {
            pref *= vision::surface_speed_factor(nearest_target, self.arrival_speed, self.h);
        }
        if self.wander_sigma > 0.0 {
            let mut rng = cx.rng(0x5BEED, i);
            out.wander = b.wander * self.wander_decay + self.wander_kick * rng.gaussian();
            let sg = self.wander_sigma;
            pref *= (sg * out.wander - 0.5 * sg * sg).exp();
        }
        let thrust = self.k1 * oscillation::mean_thrust_accel();
        let drag = thrust / pref.max(1e-3);
        // Where Eq. 1's other forces send the bee. While avoiding, noise and pull are faded
        // out by the ramp γ.
        let curl = self.curl_now.at(&self.curl, cx, i, c.pos);
        let steer_noise_pull = gamma * (self.k2 * curl + a_attr);
        let want = steer_noise_pull + self.k3 * a_rep;
        // Hovering, sharp turns, backward flight: the stroke plane tilts the thrust (issue 17).
        let near = (1.0 - nearest_target / self.h).clamp(0.0, 1.0);
        // Within d0 of a surface, seen or not, it also wants out, away from it (out of a
        // corner along its diagonal, even facing straight into it, where both walls lie
        // outside the ±45° view).
        let situation = manoeuvre::Situation {
            forward: heading * Vec3::X,
            vel: c.vel,
            cruise: c.speed,
            want: want + steer.away * thrust,
            thrust,
            near,
            pull: a_attr,
        };
        let cmd = manoeuvre::command(&situation, self.manoeuvre);
        f_o.x *= cmd.thrust;
        // Eq. 1, plus the terms the paper leaves implicit (docs/model.md).
        let a = self.k1 * (heading * f_o) + steer_noise_pull + self.k3 * a_rep - air * drag;

        out.c = self.flight.advance(cx, c, a, a_col, steer);
        if let Some(yaw) = manoeuvre::heading(&cmd, c.yaw, out.c.vel, cx.dt) {
            out.c.yaw = yaw;
        }
        if out.c.vel.length() > 0.02 {
            // A hovering bee stays level rather than nodding with the bob of Eq. 2: the
            // pitch follows the climb fully from half the cruising speed.
            let level = (out.c.vel.length() / (0.5 * c.speed)).min(1.0);
            out.climb_deg = b.climb_deg
                + (level * elevation_deg(out.c.vel) - b.climb_deg) * self.flight.yaw_blend;
        }
        out.pitch_deg = out.climb_deg + wing_pitch - oscillation::MEAN_PITCH_DEG;
        self.touch_down(cx, i, &mut out, ri);
        out.mean_pos = b.mean_pos + (out.c.pos - b.mean_pos) * self.sway_blend;
        out.prev_attitude = (c.yaw, b.pitch_deg, b.drawn_roll_deg);
        out
    }

    fn poses(&self, bees: [&Bee; 4], spin_dt: Option<f32>) -> [Pose; 4] {
        // The drawn body: Eq. 3's pitch about the climb, the drawn roll.
        let now = Attitudes::of(bees, |b| {
            let rad = f32::to_radians;
            (b.c.yaw, rad(b.pitch_deg), rad(b.drawn_roll_deg))
        });
        let before = || {
            Attitudes::of(bees, |b| {
                let (yaw, pitch, roll) = b.prev_attitude;
                (yaw, pitch.to_radians(), roll.to_radians())
            })
        };
        attitudes::poses(&now, before, spin_dt)
    }

    fn record(&self, b: &Bee, pose: &Pose, channels: &mut [f32]) {
        channels[0] = b.pitch_deg;
        channels[1] = b.drawn_roll_deg;
        channels[2] = (b.c.pos - b.mean_pos).dot(pose.heading * Vec3::Z);
        channels[3] = b.state;
    }
}

impl BeeModel {
    /// After a flying substep: lands the bee on a target with `land = true` whose surface
    /// its body touches (once it may land again), and records hovering.
    fn touch_down(&self, cx: &Context, i: usize, out: &mut Bee, ri: f32) {
        out.timer = (out.timer - cx.dt).max(0.0);
        out.state = if out.c.vel.length() < HOVER_SPEED {
            HOVERING
        } else {
            FLYING
        };
        if out.timer > 0.0 {
            return;
        }
        for &ti in &self.flight.targets {
            let t = &cx.targets[ti];
            let r = out.c.pos - t.center;
            if !t.land || r.length() - t.radius - ri > TOUCH_DOWN_M {
                continue;
            }
            // On the surface, never inside: the body rests on the target's sphere.
            out.perch = normalize_or(r, Vec3::Y) * (t.radius + ri);
            out.perch_target = ti as f32;
            out.c.pos = t.center + out.perch;
            out.c.vel = Vec3::ZERO;
            out.state = LANDED;
            let u = cx.rng(0x1A4D, i).f32();
            out.timer = t.stay.0 + (t.stay.1 - t.stay.0) * u;
            out.going_in = t.inside.is_some() as u8 as f32;
            out.mean_pos = out.c.pos;
            return;
        }
    }

    /// A landed bee: it sits still on its target (moving with it), level, until its stay
    /// is over, then takes off away from the target's surface at half its cruising speed
    /// (or, on a hive entrance it has just landed on, goes in: `hive`).
    fn perched(&self, cx: &Context, i: usize, b: &Bee) -> Bee {
        let t = &cx.targets[b.perch_target as usize];
        let mut out = *b;
        out.prev_attitude = (b.c.yaw, b.pitch_deg, b.drawn_roll_deg);
        out.c.pos = t.center + b.perch;
        out.mean_pos = out.c.pos;
        out.pitch_deg = b.pitch_deg * (1.0 - self.roll_blend);
        out.roll_deg = b.roll_deg * (1.0 - self.roll_blend);
        out.drawn_roll_deg = b.drawn_roll_deg * (1.0 - self.roll_blend);
        out.climb_deg = out.pitch_deg;
        out.timer = b.timer - cx.dt;
        if out.timer > 0.0 {
            out.c.vel = Vec3::ZERO;
            return out;
        }
        if b.going_in > 0.5 {
            return self.go_inside(cx, i, out);
        }
        let away = normalize_or(b.perch, Vec3::Y);
        out.c.vel = away * (0.5 * b.c.speed);
        let horizontal = Vec3::new(away.x, 0.0, away.z);
        if horizontal.length() > 0.1 {
            out.c.yaw = math::yaw_of(horizontal);
        }
        out.state = FLYING;
        out.timer = if t.inside.is_some() {
            hive::LEAVE_S
        } else {
            TAKE_OFF_S
        };
        out
    }
}

/// The sums of Eq. 11's pressure terms and Sec. VII's contact springs over bee `i`'s
/// neighbours within reach, one neighbour at a time (`pairs::sums` does a whole list at
/// once).
fn pairs_one_by_one(cx: &Context, i: usize, bee: &pairs::Bee) -> (Vec3, Vec3) {
    let (mut a_rep, mut a_col) = (Vec3::ZERO, Vec3::ZERO);
    cx.for_each_neighbour(i, bee.reach, |j, pj, d2| {
        let (push, spring) =
            pairs::one(bee, &cx.agents[j], pj, d2, || cx.separation_fallback(i, j));
        a_rep += push;
        a_col += spring;
    });
    (a_rep, a_col)
}

/// Elevation of `v` above the horizontal, degrees.
fn elevation_deg(v: Vec3) -> f32 {
    math::atan2(v.y, Vec3::new(v.x, 0.0, v.z).length()).to_degrees()
}
