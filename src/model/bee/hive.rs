//! Hive traffic: bees going in through a hive entrance, staying inside, and coming out.
//!
//! A hive entrance is a nest target with `land = true` and `inside = [min, max]` seconds
//! (docs/shot-format.md). Paper 000 shows bees at a hive and their landing at its entrance
//! (Sec. VII, Fig. 8 and 12) but models no life inside; this is our design, for animation:
//!
//! 1. A bee lands on the entrance as on a flower (touch-down on the target's sphere) and
//!    stays its `stay` there: the walk onto the landing board.
//! 2. It goes in: `state` INSIDE for a time drawn uniformly from `inside`. It keeps its
//!    place on the entrance (never inside the hive's geometry, so that motion blur and
//!    bounds stay sane), still and level; it is out of the world — no other bee meets it
//!    (`Agent::hidden`) — and hidden in every cache.
//! 3. It comes out where it went in, stays its `stay` again on the entrance, and takes off
//!    away from it like any landed bee; it may land again only after `LEAVE_S`.
//!
//! Bees can also start inside (the swarm's `start_inside`), with a time left drawn from
//! 0 to the longest stay inside, so that traffic runs both ways from the first frame.
//!
//! Units: metres, seconds; world Y-up.

use super::{Bee, BeeModel, INSIDE, LANDED};
use crate::model::{Context, StartInside};
use glam::Vec3;

/// A bee that has come out of the hive and taken off flies at least this long, s, before
/// it may land again: a forager leaves on its trip instead of turning straight back.
pub const LEAVE_S: f32 = 3.0;

/// Random stream salts (per bee and substep), apart from the landing's.
const INSIDE_STREAM: u64 = 0x1B51DE;
const OUT_STREAM: u64 = 0x0C7E;

/// A bee of `spawn` that starts inside the hive of `h`.
pub fn starting_inside(mut b: Bee, h: StartInside) -> Bee {
    b.state = INSIDE;
    b.timer = h.time_left;
    b.perch = h.offset;
    b.perch_target = h.target as f32;
    b.c.vel = Vec3::ZERO;
    b.mean_pos = b.c.pos;
    b.climb_deg = 0.0;
    b.pitch_deg = 0.0;
    b.roll_deg = 0.0;
    b.drawn_roll_deg = 0.0;
    b.prev_attitude = (b.c.yaw, 0.0, 0.0);
    b
}

impl BeeModel {
    /// A landed bee whose stay on a hive entrance is over: it goes in, for a time drawn
    /// uniformly from the hive's `inside` range.
    pub(super) fn go_inside(&self, cx: &Context, i: usize, mut out: Bee) -> Bee {
        let t = &cx.targets[out.perch_target as usize];
        let (lo, hi) = t.inside.unwrap_or((0.0, 0.0));
        out.state = INSIDE;
        out.going_in = 0.0;
        out.timer = lo + (hi - lo) * cx.rng(INSIDE_STREAM, i).f32();
        out.c.vel = Vec3::ZERO;
        out
    }

    /// A bee inside the hive: it waits at its place on the entrance (moving with a keyed
    /// target), still, until its time is up, then comes out onto the entrance for a stay
    /// drawn from the target's `stay`, after which it takes off (`perched`).
    pub(super) fn inside(&self, cx: &Context, i: usize, b: &Bee) -> Bee {
        let t = &cx.targets[b.perch_target as usize];
        let mut out = *b;
        out.c.pos = t.center + b.perch;
        out.c.vel = Vec3::ZERO;
        out.mean_pos = out.c.pos;
        out.prev_attitude = (b.c.yaw, b.pitch_deg, b.drawn_roll_deg);
        out.timer = b.timer - cx.dt;
        if out.timer > 0.0 {
            return out;
        }
        out.state = LANDED;
        out.going_in = 0.0;
        let u = cx.rng(OUT_STREAM, i).f32();
        out.timer = t.stay.0 + (t.stay.1 - t.stay.0) * u;
        // Facing out of the entrance, as a bee that has walked out of it.
        let away = Vec3::new(b.perch.x, 0.0, b.perch.z);
        if away.length() > 1e-4 {
            out.c.yaw = crate::math::yaw_of(away);
            out.prev_attitude.0 = out.c.yaw;
        }
        out
    }
}
