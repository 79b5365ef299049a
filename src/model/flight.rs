//! Force-based flight shared by the models that integrate accelerations (the bee model and
//! the Brownian and boids baselines): targets' pull and soft bounds, contact springs,
//! semi-implicit Euler with paper 000's obstacle velocity tuning (Eq. 5) and a keep-out
//! guard, and the body's heading following the direction of travel.

use super::context::Context;
use super::targets::{self, TargetKind};
use super::{Start, SwarmSetup, collision, vision};
use crate::geometry::Shape;
use crate::math::{self, Rng, finite_or_zero};
use glam::Vec3;

/// Largest yaw rate, rad/s, of an agent that has (nearly) stopped in front of an obstacle
/// it sees and turns on the spot to face away from it.
pub const HOVER_TURN_RATE: f32 = std::f32::consts::PI;
/// Horizontal speed, m/s, below which an agent avoiding an obstacle turns on the spot: the
/// roll of Eq. 6 steers only a moving bee, and a bee whose thrust points into a corner stops.
const HOVER_TURN_SPEED: f32 = 0.05;

/// An angle difference wrapped into [−π, π), radians.
fn wrap_angle(a: f32) -> f32 {
    math::wrap_tau(a + std::f32::consts::PI) - std::f32::consts::PI
}

/// Per-step blend factor 1 − exp(−dt/τ) of a first-order lag with time constant τ.
pub fn lag_blend(dt: f32, tau: f32) -> f32 {
    1.0 - (-dt / tau).exp()
}

/// The state every force-based flyer has.
#[derive(Clone, Copy, Debug)]
pub struct Cruiser {
    pub pos: Vec3,
    pub vel: Vec3,
    /// Heading about +Y, radians.
    pub yaw: f32,
    /// Body scale (per-agent variation).
    pub size: f32,
    /// Preferred speed (per-agent variation), m/s.
    pub speed: f32,
}

impl Cruiser {
    /// A new flyer at `start`, cruising at the model's preferred `speed` (m/s) times the
    /// agent's variation.
    pub fn new(start: &Start, speed: f32) -> Self {
        let speed = speed * start.speed_factor;
        Cruiser {
            pos: start.pos,
            vel: start.dir * speed,
            yaw: math::yaw_of(start.dir),
            size: start.size,
            speed,
        }
    }

    /// Moves the agent; the heading follows the new direction of travel at once.
    pub fn place(&mut self, position: Vec3, velocity: Vec3) {
        self.pos = position;
        self.vel = velocity;
        let horizontal = Vec3::new(velocity.x, 0.0, velocity.z);
        if horizontal.length() > 0.02 {
            self.yaw = math::yaw_of(horizontal);
        }
    }
}

/// How a model steers away from obstacles this step (the bee model's vision).
#[derive(Clone, Copy, Debug, Default)]
pub struct Avoidance {
    /// An obstacle is seen within d0.
    pub avoiding: bool,
    /// The horizontal way out, away from every obstacle within d0.
    pub away: Vec3,
}

/// Per-swarm constants of force-based flight.
#[derive(Clone, Debug)]
pub struct Flight {
    /// d0 of Eq. 5: distance at which velocity towards an obstacle is tuned down, m.
    pub d0: f32,
    /// Per-substep blend of the heading towards the direction of travel.
    pub yaw_blend: f32,
    /// Contact spring stiffness, 1/s².
    pub spring: f32,
    /// Scale of the targets' pull.
    pub attraction: f32,
    /// Pull back into the bounds, 1/s².
    pub containment: f32,
    /// Body radius of an agent of size 1, m.
    pub radius: f32,
    pub bounds: Option<(Vec3, Vec3)>,
    pub targets: Vec<usize>,
}

impl Flight {
    /// From the setup and the model's parameters `avoid_distance`, `heading_lag`,
    /// `collision_stiffness`, `attraction` and `containment`, which every model that flies
    /// with `Flight` declares (with the same meaning; `tests/docs.rs` lists them).
    pub fn new(setup: &SwarmSetup) -> Self {
        let p = |name: &str| {
            setup
                .params
                .get(name)
                .unwrap_or_else(|| panic!("{} declares no `{name}`", setup.params.model().name()))
        };
        Flight {
            d0: p("avoid_distance") as f32,
            yaw_blend: lag_blend(setup.dt as f32, p("heading_lag") as f32),
            spring: p("collision_stiffness") as f32,
            attraction: p("attraction") as f32,
            containment: p("containment") as f32,
            radius: setup.body.radius,
            bounds: setup.bounds,
            targets: setup.targets.clone(),
        }
    }

    /// A flyer's next state: [`Flight::advance`] without steering, the previous heading kept
    /// for the angular velocity.
    #[inline(always)]
    pub fn fly(&self, cx: &Context, b: &Flyer, a: Vec3, a_col: Vec3) -> Flyer {
        Flyer {
            c: self.advance(cx, &b.c, a, a_col, Avoidance::default()),
            prev_yaw: b.c.yaw,
        }
    }

    /// The contact springs on agent i at `c` from every neighbour touching it.
    #[inline(always)]
    pub fn contacts(&self, cx: &Context, i: usize, c: &Cruiser) -> Vec3 {
        let ri = self.body_radius(c.size);
        let mut a_col = Vec3::ZERO;
        cx.for_each_neighbour(i, ri + cx.max_body_radius, |j, pj, d2| {
            let o = &cx.agents[j];
            a_col += self.contact(
                || cx.separation_fallback(i, j),
                ri + o.radius,
                c.pos - pj,
                d2.sqrt(),
                c.vel - o.vel,
            );
        });
        a_col
    }

    /// Body radius of an agent of scale `size`, m.
    #[inline]
    pub fn body_radius(&self, size: f32) -> f32 {
        self.radius * size
    }

    /// Contact spring (paper 000 Sec. VII) between bodies `contact` metres apart at rest,
    /// at offset `r` = agent − neighbour and distance `dist`, with relative velocity
    /// `rel_vel`; `fallback` separates coincident bodies ([`separation_fallback`]).
    #[inline(always)]
    pub fn contact(
        &self,
        fallback: impl FnOnce() -> Vec3,
        contact: f32,
        r: Vec3,
        dist: f32,
        rel_vel: Vec3,
    ) -> Vec3 {
        collision::spring_accel(r, dist, contact, rel_vel, self.spring, fallback)
    }

    /// The targets' pull on an agent at `pos`, plus the pull back into the bounds.
    #[inline]
    pub fn pull(&self, cx: &Context, pos: Vec3) -> Vec3 {
        pull(
            cx,
            &self.targets,
            self.attraction,
            self.bounds,
            self.containment,
            pos,
        )
    }

    /// One substep: semi-implicit Euler with acceleration `a + a_col`, then obstacle
    /// velocity tuning (Eq. 5), a speed limit and a hard guard, then the heading.
    #[inline(always)]
    pub fn advance(
        &self,
        cx: &Context,
        b: &Cruiser,
        a: Vec3,
        a_col: Vec3,
        steer: Avoidance,
    ) -> Cruiser {
        let dt = cx.dt;
        let ri = self.body_radius(b.size);
        let a = finite_or_zero(a + a_col);
        let dv = a * dt;
        let mut vel = b.vel + dv;
        for q in cx.obstacle_queries(b.pos) {
            vel = vision::tune_velocity(vel, dv, q.normal, q.distance - ri, self.d0, dt);
        }
        let max_speed = 4.0 * b.speed + 2.0;
        if vel.length() > max_speed {
            vel = vel.normalize() * max_speed;
        }
        let (pos, vel) = keep_out(cx, b.pos, b.pos + vel * dt, vel, ri);
        Cruiser {
            pos,
            vel,
            yaw: self.heading(b.yaw, vel, steer, dt),
            ..*b
        }
    }

    /// The heading after a substep at velocity `vel` (see [`follow_heading`]).
    #[inline]
    pub fn heading(&self, yaw: f32, vel: Vec3, steer: Avoidance, dt: f32) -> f32 {
        follow_heading(yaw, vel, steer, self.yaw_blend, dt)
    }
}

/// The heading (radians about +Y) after a substep at velocity `vel`: it follows the
/// direction of travel with per-substep blend `blend`; stopped facing an obstacle (in a
/// corner, say), it turns on the spot towards open air, or the heading, and with it the
/// thrust, would stay pointed at the wall.
// Always inlined: with the bee's pair sums moved out of its step the compiler stopped
// inlining it there, a call per substep (2–3 % of a sparse bee-step).
#[inline(always)]
pub fn follow_heading(yaw: f32, vel: Vec3, steer: Avoidance, blend: f32, dt: f32) -> f32 {
    let horizontal = Vec3::new(vel.x, 0.0, vel.z);
    let stopped = steer.avoiding && horizontal.length() < HOVER_TURN_SPEED;
    if stopped && steer.away.length_squared() > 1e-8 {
        turn_towards(yaw, steer.away, HOVER_TURN_RATE, dt)
    } else if horizontal.length() > 0.02 {
        let dy = wrap_angle(math::yaw_of(horizontal) - yaw);
        math::wrap_tau(yaw + dy * blend)
    } else {
        yaw
    }
}

/// The heading (radians about +Y) turned towards the horizontal direction `dir` by at most
/// `rate` rad/s over `dt`: a turn on the spot.
#[inline]
pub fn turn_towards(yaw: f32, dir: Vec3, rate: f32, dt: f32) -> f32 {
    let dy = wrap_angle(math::yaw_of(dir) - yaw);
    math::wrap_tau(yaw + dy.clamp(-rate * dt, rate * dt))
}

/// The pull of targets `targets` (scaled by `attraction`) on an agent at `pos`, plus the
/// pull back into `bounds` (centre, half extents) with gain `containment`, m/s².
#[inline(always)]
pub fn pull(
    cx: &Context,
    targets: &[usize],
    attraction: f32,
    bounds: Option<(Vec3, Vec3)>,
    containment: f32,
    pos: Vec3,
) -> Vec3 {
    let mut a = Vec3::ZERO;
    for &ti in targets {
        let t = &cx.targets[ti];
        let strength = t.strength * attraction;
        a += match t.kind {
            TargetKind::Surface => {
                targets::surface_attraction(pos, t.center, t.normal, strength, t.reach)
            }
            TargetKind::Predator => -targets::attraction(pos, t.center, strength, t.reach),
            _ => targets::attraction(pos, t.center, strength, t.reach),
        };
    }
    if let Some((c, h)) = bounds {
        a += targets::containment(pos, c, h, containment);
    }
    a
}

/// Never lets a body of radius `ri` into an obstacle. A move from `from` to `pos` that
/// would pass through an obstacle (fast, or the obstacle thin) stops where it meets it
/// ([`sweep`]); an end closer than `ri` to a surface is put back on it. Either way the
/// velocity into the surface is removed. A non-finite result keeps the agent where it
/// was, at rest.
#[inline(always)]
pub fn keep_out(cx: &Context, from: Vec3, pos: Vec3, vel: Vec3, ri: f32) -> (Vec3, Vec3) {
    let (mut pos, mut vel) = (pos, vel);
    if !cx.obstacles.is_empty() {
        (pos, vel) = sweep(cx.obstacles, from, pos, vel, ri);
        // Pushing a body out of one obstacle can push it into another where they
        // overlap: repeat, with a tolerance after the first pass so that a body already
        // put on a surface is not nudged by rounding.
        for round in 0..4 {
            let inside = if round == 0 { ri } else { ri * 0.999 };
            let mut moved = false;
            for q in cx.obstacle_queries(pos) {
                if q.distance < inside {
                    // Numerically the ramp can leave a sliver of approach; never let a
                    // body in.
                    pos = q.point + q.normal * ri;
                    let vn = vel.dot(q.normal);
                    if vn < 0.0 {
                        vel -= q.normal * vn;
                    }
                    moved = true;
                }
            }
            if !moved {
                break;
            }
            if round == 3 {
                // Still pushed to and fro between overlapping obstacles: a crevice the
                // body does not fit. It stays where it was, outside all of them.
                return (from, Vec3::ZERO);
            }
        }
    }
    if !pos.is_finite() || !vel.is_finite() {
        return (from, Vec3::ZERO);
    }
    (pos, vel)
}

/// Continuous collision: where the straight move from `from` to `to` of a body of radius
/// `ri` first meets an obstacle it would otherwise pass through, with the velocity into
/// that surface removed; `(to, vel)` when it meets none.
///
/// Passing through is a move that ends outside the obstacle after crossing it, or ends
/// inside it beyond its middle (projecting such an end onto the nearest surface would put
/// the body out on the far side). Every other move is left to the end-position guard of
/// [`keep_out`], so flight that merely grazes a surface is unchanged. The search sphere-
/// traces the segment with the signed distance (steps of at least 1/32 of the move, so a
/// slab thicker than that is always sampled inside), then bisects to the entry.
pub fn sweep(obstacles: &[Shape], from: Vec3, to: Vec3, mut vel: Vec3, ri: f32) -> (Vec3, Vec3) {
    if obstacles.is_empty() {
        return (to, vel);
    }
    let step = to - from;
    let len = step.length();
    if !(len > 0.0 && len.is_finite()) {
        return (to, vel);
    }
    let dir = step / len;
    let mut first: Option<(f32, Vec3)> = None;
    for shape in obstacles {
        let d0 = crate::geometry::query(shape, from).distance - ri;
        // Out of reach, or already touching at the start (the end guard handles that).
        if d0 >= len || d0 < 0.0 {
            continue;
        }
        let end = crate::geometry::query(shape, to);
        if end.distance < ri && end.normal.dot(dir) <= 0.0 {
            continue;
        }
        let inside = |t: f32| crate::geometry::query(shape, from + dir * t).distance - ri;
        let min_step = len / 32.0;
        let (mut t_prev, mut t) = (0.0f32, d0);
        loop {
            let d = inside(t);
            if d < 0.0 {
                // Bisect between the last sample outside and this one inside.
                let (mut a, mut b) = (t_prev, t);
                for _ in 0..12 {
                    let m = 0.5 * (a + b);
                    if inside(m) < 0.0 {
                        b = m;
                    } else {
                        a = m;
                    }
                }
                if first.is_none_or(|(t0, _)| a < t0) {
                    let n = crate::geometry::query(shape, from + dir * a).normal;
                    first = Some((a, n));
                }
                break;
            }
            if t >= len || d >= len - t {
                break;
            }
            t_prev = t;
            t = (t + d.max(min_step)).min(len);
        }
    }
    match first {
        Some((t, n)) => {
            let vn = vel.dot(n);
            if vn < 0.0 {
                vel -= n * vn;
            }
            (from + dir * t, vel)
        }
        None => (to, vel),
    }
}

/// A deterministic direction separating coincident agents with ids i and j (opposite for j
/// and i): see [`crate::model::Context::separation_fallback`].
pub fn separation_fallback(i: usize, j: usize) -> Vec3 {
    let (a, b, sign) = if i < j { (i, j, 1.0) } else { (j, i, -1.0) };
    Rng::new(a as u64, b as u64, 0x5EA).unit_vector() * sign
}

/// The agent state of a model that is a flyer and nothing more (the baselines): level
/// flight, the body along its heading.
#[derive(Clone, Copy, Debug)]
pub struct Flyer {
    pub c: Cruiser,
    /// Heading one substep earlier, radians (for the recorded angular velocity).
    pub prev_yaw: f32,
}

impl Flyer {
    pub fn new(start: &Start, speed: f32) -> Self {
        let c = Cruiser::new(start, speed);
        Flyer { c, prev_yaw: c.yaw }
    }

    /// Four flyers' poses (`Model::poses`): level flight, the body along the heading,
    /// turning from the heading one substep earlier.
    pub fn poses(flyers: [&Flyer; 4], spin_dt: Option<f32>) -> [super::Pose; 4] {
        let yaw = |f: fn(&Flyer) -> f32| glam::Vec4::from_array(flyers.map(f));
        super::attitudes::level_poses(yaw(|f| f.c.yaw), || yaw(|f| f.prev_yaw), spin_dt)
    }
}

impl super::Agent for Flyer {
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
        self.prev_yaw = self.c.yaw;
    }
}
