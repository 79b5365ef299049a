//! Four bodies' attitudes at a time, for the recording pass: orientation `Ry(yaw) ·
//! Rz(pitch) · Rx(roll)` (as [`crate::math::body_orientation`]: X forward, Y up, Z right;
//! glam quaternions, x y z w) and the angular velocity between two attitudes (as
//! [`crate::math::angular_velocity`]), each lane of a `Vec4` one body.
//!
//! Why: a bee's pose took six `sincosf` and an `atan2f` from the C library, about 8 % of a
//! sparse bench's time at four substeps a frame (docs/model.md, "Poses four at a time"),
//! and lanes, not a cheaper polynomial alone, are what cut that. Here the sines
//! and cosines are a polynomial four lanes wide, and `atan2` is [`crate::math::atan2`]'s
//! polynomial lane by lane. Only IEEE additions, multiplications, divisions and square
//! roots, each rounded once (no fused multiply-add), so every CPU and every SIMD level
//! gives the same bits, and the caches stay identical on any machine.

use super::Pose;
use crate::math;
use glam::{BVec4A, Quat, Vec3, Vec4};

/// Four quaternions, one per lane (x, y, z, w as glam's `Quat`).
#[derive(Clone, Copy, Debug)]
pub struct Quat4 {
    pub x: Vec4,
    pub y: Vec4,
    pub z: Vec4,
    pub w: Vec4,
}

impl Quat4 {
    /// Lane `k` as a glam quaternion.
    #[inline]
    pub fn lane(&self, k: usize) -> Quat {
        Quat::from_xyzw(self.x[k], self.y[k], self.z[k], self.w[k])
    }
}

/// Four attitudes, radians.
#[derive(Clone, Copy, Debug)]
pub struct Attitudes {
    pub yaw: Vec4,
    pub pitch: Vec4,
    pub roll: Vec4,
}

impl Attitudes {
    /// The attitudes `(yaw, pitch, roll)`, radians, that `f` gives four agents.
    #[inline]
    pub fn of<A>(agents: [&A; 4], f: impl Fn(&A) -> (f32, f32, f32)) -> Attitudes {
        let a = agents.map(f);
        Attitudes {
            yaw: Vec4::from_array(a.map(|a| a.0)),
            pitch: Vec4::from_array(a.map(|a| a.1)),
            roll: Vec4::from_array(a.map(|a| a.2)),
        }
    }
}

/// Four agents' poses (`Model::poses`) from their attitudes now and, only where the
/// angular velocity over the last substep (`spin_dt` seconds) is asked for, one substep
/// earlier (`before`); otherwise the angular velocity is zero.
#[inline]
pub fn poses(
    now: &Attitudes,
    before: impl FnOnce() -> Attitudes,
    spin_dt: Option<f32>,
) -> [Pose; 4] {
    let (body, heading) = orientations(now);
    assemble(&body, &heading, || orientations(&before()).0, spin_dt)
}

/// [`poses`] of level bodies, along their headings (yaw now, and one substep earlier:
/// `before`), without working out a pitch and a roll of zero.
#[inline]
pub fn level_poses(yaw: Vec4, before: impl FnOnce() -> Vec4, spin_dt: Option<f32>) -> [Pose; 4] {
    let heading = about_y(yaw);
    assemble(&heading, &heading, || about_y(before()), spin_dt)
}

/// The poses of bodies `body` with headings `heading`, turned from `from()` over the last
/// substep where `spin_dt` asks for it.
#[inline]
fn assemble(
    body: &Quat4,
    heading: &Quat4,
    from: impl FnOnce() -> Quat4,
    spin_dt: Option<f32>,
) -> [Pose; 4] {
    let spin = spin_dt.map_or([Vec3::ZERO; 4], |dt| {
        angular_velocities(&from(), body, dt).map(|w| w * (180.0 / std::f32::consts::PI))
    });
    std::array::from_fn(|k| Pose {
        orientation: body.lane(k),
        heading: heading.lane(k),
        angular_velocity_deg: spin[k],
    })
}

/// The body orientations `Ry(yaw) · Rz(pitch) · Rx(roll)` of `a`, and the heading alone,
/// `Ry(yaw)` (its rotation about world +Y).
// Always inlined: called out of line, its first 16-byte load of `a.yaw` spanned the four
// 4-byte stores that had just built it, which the CPU cannot forward (44 % of its samples).
#[inline(always)]
pub fn orientations(a: &Attitudes) -> (Quat4, Quat4) {
    let half = Vec4::splat(0.5);
    let heading = about_y(a.yaw);
    let (sy, cy) = (heading.y, heading.w);
    let (sp, cp) = sin_cos4(a.pitch * half);
    let (sr, cr) = sin_cos4(a.roll * half);
    // The product of the three axis rotations written out: Ry · Rz is
    // (sy sp, sy cp, cy sp, cy cp), and that times Rx = (sr, 0, 0, cr) gives:
    let (x1, y1, z1, w1) = (sy * sp, sy * cp, cy * sp, cy * cp);
    let body = Quat4 {
        x: w1 * sr + x1 * cr,
        y: y1 * cr + z1 * sr,
        z: z1 * cr - y1 * sr,
        w: w1 * cr - x1 * sr,
    };
    (body, heading)
}

/// The rotations `Ry(yaw)` (about world +Y).
#[inline]
fn about_y(yaw: Vec4) -> Quat4 {
    let (s, c) = sin_cos4(yaw * Vec4::splat(0.5));
    Quat4 {
        x: Vec4::ZERO,
        y: s,
        z: Vec4::ZERO,
        w: c,
    }
}

/// The angular velocities (radians per second, world frame) turning `from` into `to`
/// in `dt` seconds, as [`crate::math::angular_velocity`]: the shortest arc of
/// `to · from⁻¹`, zero where it is no turn (or not finite). `from` and `to` are unit
/// quaternions.
#[inline]
pub fn angular_velocities(from: &Quat4, to: &Quat4, dt: f32) -> [Vec3; 4] {
    // d = to · conj(from): w = w₁w₂ + v₁·v₂, v = w₂v₁ − w₁v₂ − v₁ × v₂.
    let (a, b) = (to, from);
    let w = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
    let x = b.w * a.x - a.w * b.x - (a.y * b.z - a.z * b.y);
    let y = b.w * a.y - a.w * b.y - (a.z * b.x - a.x * b.z);
    let z = b.w * a.z - a.w * b.z - (a.x * b.y - a.y * b.x);
    // The shortest arc, then normalised against rounding.
    let flip = w.cmplt(Vec4::ZERO);
    let sign = Vec4::select(flip, Vec4::splat(-1.0), Vec4::ONE);
    let (w, x, y, z) = (w * sign, x * sign, y * sign, z * sign);
    let inv = Vec4::ONE / sqrt4(w * w + x * x + y * y + z * z);
    let (w, x, y, z) = (w * inv, x * inv, y * inv, z * inv);
    let length = sqrt4(x * x + y * y + z * z);
    let angle = Vec4::splat(2.0) * atan2_4(length, w);
    let rate = angle / (Vec4::splat(dt) * length);
    let mut out = [Vec3::ZERO; 4];
    for (k, o) in out.iter_mut().enumerate() {
        let v = Vec3::new(x[k], y[k], z[k]) * rate[k];
        // As glam's axis–angle: no turn below 1e-8 (the axis is then undefined).
        if length[k] >= 1.0e-8 && v.is_finite() && dt > 0.0 {
            *o = v;
        }
    }
    out
}

/// The square roots of four values (each exactly rounded, as `f32::sqrt`).
#[inline]
fn sqrt4(v: Vec4) -> Vec4 {
    Vec4::from_array(v.to_array().map(f32::sqrt))
}

/// sin x and cos x of four angles (radians), within 10⁻⁷ of the exact values for
/// |x| up to a thousand turns (tested; headings and half-angles are within a turn). The
/// angle less the nearest multiple k of π/2 in three parts (Cody–Waite: k times the
/// first two parts is exact), then Cephes' polynomials for sin and cos on [−π/4, π/4],
/// swapped and negated by k's quadrant. Not for non-finite angles (NaN out).
#[inline]
pub fn sin_cos4(x: Vec4) -> (Vec4, Vec4) {
    // π/2 = P1 + P2 + P3, P1 and P2 with few enough bits that k · P1 and k · P2 are exact
    // for |k| < 2¹³.
    const P1: f32 = 1.570_312_5;
    const P2: f32 = 4.837_513e-4;
    const P3: f32 = 7.549_79e-8;
    // Rounds to the nearest integer (ties to even) for |t| < 2²²: the IEEE addition does it.
    const ROUND: f32 = 12_582_912.0;
    let t = x * Vec4::splat(std::f32::consts::FRAC_2_PI);
    let k = (t + Vec4::splat(ROUND)) - Vec4::splat(ROUND);
    let r = ((x - k * Vec4::splat(P1)) - k * Vec4::splat(P2)) - k * Vec4::splat(P3);
    let z = r * r;
    let s = ((Vec4::splat(-1.951_529_6e-4) * z + Vec4::splat(8.332_161e-3)) * z
        - Vec4::splat(0.166_666_55))
        * z
        * r
        + r;
    let c = ((Vec4::splat(2.443_315_7e-5) * z - Vec4::splat(1.388_731_6e-3)) * z
        + Vec4::splat(4.166_664_6e-2))
        * z
        * z
        - Vec4::splat(0.5) * z
        + Vec4::ONE;
    // The quadrant k mod 4 (k is an integer-valued float of at most 2²²).
    let q = k.to_array().map(|k| (k as i32) & 3);
    let mask = |f: fn(i32) -> bool| BVec4A::new(f(q[0]), f(q[1]), f(q[2]), f(q[3]));
    let swap = mask(|q| q & 1 == 1);
    let (s1, c1) = (Vec4::select(swap, c, s), Vec4::select(swap, s, c));
    let sin = Vec4::select(mask(|q| q & 2 == 2), -s1, s1);
    let cos = Vec4::select(mask(|q| (q + 1) & 2 == 2), -c1, c1);
    (sin, cos)
}

/// [`crate::math::atan2`] of four pairs, lane by lane the same operations, so the same
/// bits.
#[inline]
pub fn atan2_4(y: Vec4, x: Vec4) -> Vec4 {
    const C: [f32; 7] = math::ATAN2_POLY;
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let a = Vec4::select(hi.cmpgt(Vec4::ZERO), lo / hi, Vec4::ZERO);
    let s = a * a;
    let c = |i: usize| Vec4::splat(C[i]);
    let p = c(0) + s * (c(1) + s * (c(2) + s * (c(3) + s * (c(4) + s * (c(5) + s * c(6))))));
    let mut r = a * p;
    r = Vec4::select(
        ay.cmpgt(ax),
        Vec4::splat(std::f32::consts::FRAC_PI_2) - r,
        r,
    );
    let negative = |v: Vec4| {
        let m = v.is_negative_bitmask();
        BVec4A::new(m & 1 != 0, m & 2 != 0, m & 4 != 0, m & 8 != 0)
    };
    let both_zero = x.cmpeq(Vec4::ZERO) & y.cmpeq(Vec4::ZERO);
    r = Vec4::select(
        negative(x) & !both_zero,
        Vec4::splat(std::f32::consts::PI) - r,
        r,
    );
    Vec4::select(negative(y), -r, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    #[test]
    fn sin_cos4_is_within_1e_7_of_the_exact_values() {
        let mut worst = 0.0f64;
        let mut check = |x: Vec4| {
            let (s, c) = sin_cos4(x);
            for k in 0..4 {
                let e = x[k] as f64;
                worst = worst
                    .max((s[k] as f64 - e.sin()).abs())
                    .max((c[k] as f64 - e.cos()).abs());
            }
        };
        // Every quadrant boundary and its neighbours, then random angles out to 1,000 turns.
        for k in -16..=16 {
            let b = k as f32 * std::f32::consts::FRAC_PI_2;
            check(Vec4::new(
                b,
                f32::from_bits(b.to_bits() + 1),
                b - 1e-4,
                b + 1e-4,
            ));
        }
        let mut rng = Rng::new(1, 2, 3);
        for _ in 0..50_000 {
            let turns = rng.range(-1.0, 1.0);
            let v = Vec4::new(
                rng.range(-3.2, 3.2),
                rng.range(-0.8, 0.8),
                turns * 6283.0,
                rng.range(-40.0, 40.0),
            );
            check(v);
        }
        assert!(worst < 1e-7, "worst error {worst}");
        let (s, c) = sin_cos4(Vec4::new(0.0, -0.0, 1e-30, -1e-30));
        assert_eq!(s, Vec4::new(0.0, 0.0, 1e-30, -1e-30));
        assert_eq!(c, Vec4::ONE);
    }

    #[test]
    fn atan2_4_is_atan2_bit_for_bit() {
        let mut rng = Rng::new(4, 5, 6);
        let specials = [0.0f32, -0.0, 1.0, -1.0, 1e-30, -1e-30, 3.0e7, -2.5];
        let mut pairs: Vec<(f32, f32)> = specials
            .iter()
            .flat_map(|&y| specials.iter().map(move |&x| (y, x)))
            .collect();
        pairs.extend((0..20_000).map(|_| (rng.range(-5.0, 5.0), rng.range(-5.0, 5.0))));
        for group in pairs.chunks(4) {
            let mut y = [0.0; 4];
            let mut x = [1.0; 4];
            for (k, &(a, b)) in group.iter().enumerate() {
                (y[k], x[k]) = (a, b);
            }
            let got = atan2_4(Vec4::from_array(y), Vec4::from_array(x));
            for k in 0..4 {
                assert_eq!(
                    got[k].to_bits(),
                    math::atan2(y[k], x[k]).to_bits(),
                    "atan2({}, {})",
                    y[k],
                    x[k]
                );
            }
        }
    }

    #[test]
    fn orientations_are_the_three_axis_rotations_in_order() {
        let mut rng = Rng::new(7, 8, 9);
        for _ in 0..2_000 {
            let a = Attitudes {
                yaw: Vec4::new(
                    rng.range(0.0, 6.3),
                    rng.range(0.0, 6.3),
                    rng.range(-6.3, 0.0),
                    rng.range(0.0, 6.3),
                ),
                pitch: Vec4::new(
                    rng.range(-1.6, 1.6),
                    0.0,
                    rng.range(-1.6, 1.6),
                    rng.range(-1.6, 1.6),
                ),
                roll: Vec4::new(
                    rng.range(-1.6, 1.6),
                    rng.range(-1.6, 1.6),
                    0.0,
                    rng.range(-3.2, 3.2),
                ),
            };
            let (body, heading) = orientations(&a);
            for k in 0..4 {
                let exact = math::body_orientation(a.yaw[k], a.pitch[k], a.roll[k]);
                assert!(body.lane(k).abs_diff_eq(exact, 1e-6), "{k}");
                assert!((body.lane(k).length() - 1.0).abs() < 1e-6);
                let yaw = Quat::from_rotation_y(a.yaw[k]);
                assert!(heading.lane(k).abs_diff_eq(yaw, 1e-6));
            }
        }
    }

    #[test]
    fn a_pose_depends_on_its_own_lane_alone() {
        // The recording groups agents in fours (a swarm's last agent repeated): whatever
        // shares its four, an agent's pose must be the same bits.
        let mut rng = Rng::new(16, 17, 18);
        let mut angles = || std::array::from_fn::<f32, 12, _>(|_| rng.range(-3.0, 3.0));
        for _ in 0..500 {
            let (now, before) = (angles(), angles());
            let lanes = |a: [f32; 12], order: [usize; 4]| Attitudes {
                yaw: Vec4::from_array(order.map(|k| a[k])),
                pitch: Vec4::from_array(order.map(|k| a[4 + k])),
                roll: Vec4::from_array(order.map(|k| a[8 + k])),
            };
            let bits = |p: &Pose| {
                let (o, h, w) = (p.orientation, p.heading, p.angular_velocity_deg);
                [o.x, o.y, o.z, o.w, h.x, h.y, h.z, h.w, w.x, w.y, w.z].map(f32::to_bits)
            };
            let dt = Some(1.0 / 96.0);
            let together = poses(
                &lanes(now, [0, 1, 2, 3]),
                || lanes(before, [0, 1, 2, 3]),
                dt,
            );
            for (k, pose) in together.iter().enumerate() {
                let alone = poses(&lanes(now, [k; 4]), || lanes(before, [k; 4]), dt);
                let moved = poses(
                    &lanes(now, [3, k, 0, 1]),
                    || lanes(before, [3, k, 0, 1]),
                    dt,
                );
                assert_eq!(bits(pose), bits(&alone[0]));
                assert_eq!(bits(pose), bits(&moved[1]));
            }
        }
    }

    #[test]
    fn level_poses_are_poses_without_pitch_or_roll() {
        let mut rng = Rng::new(13, 14, 15);
        let mut yaw = || Vec4::from_array(std::array::from_fn(|_| rng.range(-7.0, 7.0)));
        for _ in 0..500 {
            let (now, before) = (yaw(), yaw());
            let level = |yaw| Attitudes {
                yaw,
                pitch: Vec4::ZERO,
                roll: Vec4::ZERO,
            };
            for spin_dt in [None, Some(0.01)] {
                let a = level_poses(now, || before, spin_dt);
                let b = poses(&level(now), || level(before), spin_dt);
                for (a, b) in a.iter().zip(&b) {
                    // (Equal as values: a zero's sign may differ.)
                    assert!(a.orientation == b.orientation && a.heading == b.heading);
                    let w = a.angular_velocity_deg - b.angular_velocity_deg;
                    assert!(w.length() <= 1e-4 * b.angular_velocity_deg.length().max(1.0));
                }
            }
        }
    }

    #[test]
    fn angular_velocities_match_the_one_at_a_time_turn() {
        let mut rng = Rng::new(10, 11, 12);
        let mut attitude = |scale: f32| Attitudes {
            yaw: Vec4::new(0.3, 6.2, 3.1, 1.0) + Vec4::splat(rng.range(-scale, scale)),
            pitch: Vec4::new(0.1, -0.4, 0.0, 1.2) + Vec4::splat(rng.range(-scale, scale)),
            roll: Vec4::new(-0.2, 0.5, 0.0, 0.0) + Vec4::splat(rng.range(-scale, scale)),
        };
        for scale in [0.0, 1e-4, 0.01, 0.3, 3.0] {
            for _ in 0..200 {
                let (from, to) = (
                    orientations(&attitude(scale)).0,
                    orientations(&attitude(scale)).0,
                );
                let got = angular_velocities(&from, &to, 0.01);
                for (k, g) in got.iter().enumerate() {
                    let exact = math::angular_velocity(from.lane(k), to.lane(k), 0.01);
                    assert!(
                        (*g - exact).length() <= 1e-3 * exact.length().max(1.0),
                        "{g} against {exact}"
                    );
                }
            }
        }
        // The same attitude: no turn.
        let a = orientations(&attitude(0.0)).0;
        assert_eq!(angular_velocities(&a, &a, 0.01), [Vec3::ZERO; 4]);
        // No time: no rate.
        let b = orientations(&attitude(0.5)).0;
        assert_eq!(angular_velocities(&a, &b, 0.0), [Vec3::ZERO; 4]);
    }
}
