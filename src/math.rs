//! Small math helpers: deterministic random numbers and guarded vector operations.
//!
//! Randomness is a pure function of (seed, stream, index) so results never depend on the
//! order in which threads run.

use glam::{Quat, Vec3};

/// SplitMix64 finaliser: a fast, well-mixed 64-bit hash.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A small deterministic generator (SplitMix64), seeded from a hash of its inputs.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64, stream: u64, index: u64) -> Self {
        Rng(mix64(
            seed ^ mix64(stream.wrapping_mul(0xA24B_AED4_963E_E407) ^ mix64(index)),
        ))
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        mix64(self.0)
    }
    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    /// Standard normal (Box–Muller).
    pub fn gaussian(&mut self) -> f32 {
        let u1 = ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
        let u2 = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
    }
    /// Uniform direction on the unit sphere.
    pub fn unit_vector(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let a = self.range(0.0, std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * a.cos(), z, r * a.sin())
    }
}

/// `v` normalised, or `fallback` when `v` is too short to have a direction.
#[inline]
pub fn normalize_or(v: Vec3, fallback: Vec3) -> Vec3 {
    let l2 = v.length_squared();
    if l2 > 1e-18 { v / l2.sqrt() } else { fallback }
}

/// Replaces a non-finite vector with zero (a last line of defence; tested never to trigger).
#[inline]
pub fn finite_or_zero(v: Vec3) -> Vec3 {
    if v.is_finite() { v } else { Vec3::ZERO }
}

/// Rotation about +Y that turns +X onto the horizontal direction (dx, dz).
#[inline]
pub fn yaw_of(dir: Vec3) -> f32 {
    atan2(-dir.z, dir.x)
}

/// [`atan2`]'s polynomial in a² (a = the smaller of |x|, |y| over the larger), lowest
/// degree first (also `model::attitudes::atan2_4`'s).
pub(crate) const ATAN2_POLY: [f32; 7] = [
    0.999_996_1,
    -0.333_173_7,
    0.198_078_16,
    -0.132_333_4,
    0.079_623_63,
    -0.033_604_18,
    0.006_811_778_5,
];

/// atan2(y, x) in radians, in [−π, π], within 5e-7 rad of the exact value (two f32 steps at π; tested): an
/// odd polynomial of degree 13 on [0, 1] (a minimax fit) after reducing to the octant.
/// About a fifth of the C library's instructions in the steps that call it twice per
/// substep, and the same bits on every platform and C library. atan2(±0, x) is ±0 for
/// x ≥ 0 and ±π for x < 0, as in C; atan2(0, 0) is 0.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    const C: [f32; 7] = ATAN2_POLY;
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let a = if hi > 0.0 { lo / hi } else { 0.0 };
    let s = a * a;
    let p = C[0] + s * (C[1] + s * (C[2] + s * (C[3] + s * (C[4] + s * (C[5] + s * C[6])))));
    let mut r = a * p;
    if ay > ax {
        r = std::f32::consts::FRAC_PI_2 - r;
    }
    if x.is_sign_negative() && !(x == 0.0 && y == 0.0) {
        r = std::f32::consts::PI - r;
    }
    if y.is_sign_negative() { -r } else { r }
}

/// Body orientation from heading yaw, pitch and roll (radians):
/// `Ry(yaw) * Rz(pitch) * Rx(roll)` — X forward, Y up, Z right. (The recorded poses work
/// it out four at a time: `model::attitudes`.)
#[inline]
pub fn body_orientation(yaw: f32, pitch: f32, roll: f32) -> Quat {
    Quat::from_rotation_y(yaw) * Quat::from_rotation_z(pitch) * Quat::from_rotation_x(roll)
}

/// `floor` as an integer without a library call (x86-64 without SSE4.1 has no floor
/// instruction); saturates far out of range.
#[inline(always)]
fn floor_i32(v: f32) -> i32 {
    let t = v as i32;
    if (t as f32) > v { t - 1 } else { t }
}

/// `a` wrapped into [0, 2π), radians, for angles within a few turns (headings): a floor
/// instead of the C library's fmod.
#[inline]
pub fn wrap_tau(a: f32) -> f32 {
    use std::f32::consts::TAU;
    // Headings stray at most a turn either way between substeps: their turn count by
    // comparisons, which a heading update waits on less than on a float-to-integer round
    // trip (a few per cent of a bee-step's time).
    let turns = if (-TAU..2.0 * TAU).contains(&a) {
        (a >= TAU) as i32 as f32 - (a < 0.0) as i32 as f32
    } else {
        floor_i32(a * (1.0 / TAU)) as f32
    };
    let w = a - TAU * turns;
    // Rounding can land a hair outside the range.
    if w >= TAU {
        w - TAU
    } else if w < 0.0 {
        w + TAU
    } else {
        w
    }
}

/// Angular velocity (rad/s, world frame) taking `from` to `to` in `dt` seconds, one pair
/// at a time: the reference `model::attitudes` (which the caches use) is tested against.
#[cfg(test)]
pub fn angular_velocity(from: Quat, to: Quat, dt: f32) -> Vec3 {
    let mut d = to * from.inverse();
    if d.w < 0.0 {
        d = -d; // shortest arc
    }
    let (axis, angle) = d.normalize().to_axis_angle();
    if angle.is_finite() && axis.is_finite() && dt > 0.0 {
        axis * (angle / dt)
    } else {
        Vec3::ZERO
    }
}

/// Smooth 0→1 step (C1) of x between edges a < b.
#[inline]
pub fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// `n` points uniform in the cube [−half, half]³, drawn x, y, z in turn (test clouds).
#[cfg(test)]
pub fn random_cloud(rng: &mut Rng, n: usize, half: f32) -> Vec<Vec3> {
    (0..n)
        .map(|_| {
            Vec3::new(
                rng.range(-half, half),
                rng.range(-half, half),
                rng.range(-half, half),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn wrap_tau_stays_in_range() {
        use std::f32::consts::TAU;
        for i in -10_000..10_000 {
            let a = i as f32 * 0.00371;
            let w = super::wrap_tau(a);
            assert!((0.0..TAU).contains(&w), "{a} -> {w}");
            assert!(
                (w - a.rem_euclid(TAU)).abs() < 1e-5 || (w - a.rem_euclid(TAU)).abs() > TAU - 1e-5,
                "{a}"
            );
        }
        assert!(super::wrap_tau(-1e-6) > TAU - 1e-5);
        assert_eq!(super::wrap_tau(TAU), 0.0);
    }
    #[test]
    fn atan2_is_within_5e_7_rad_of_the_exact_value_and_keeps_the_quadrants() {
        let mut worst = 0.0f64;
        let n = 2000;
        for i in 0..n {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            for r in [1e-6f64, 0.3, 1.0, 7.0, 1e6] {
                let (y, x) = ((r * t.sin()) as f32, (r * t.cos()) as f32);
                let exact = (y as f64).atan2(x as f64);
                worst = worst.max((super::atan2(y, x) as f64 - exact).abs());
            }
        }
        assert!(worst < 5e-7, "worst error {worst} rad");
        for (y, x) in [
            (0.0f32, 1.0f32),
            (1.0, 0.0),
            (0.0, -1.0),
            (-1.0, 0.0),
            (-0.0, -1.0),
        ] {
            assert!((super::atan2(y, x) - y.atan2(x)).abs() < 1e-6, "({y}, {x})");
        }
        assert_eq!(super::atan2(0.0, 0.0), 0.0);
    }

    use super::*;

    #[test]
    fn rng_is_a_pure_function_of_its_inputs() {
        let a: Vec<u64> = (0..4).map(|_| Rng::new(7, 1, 2).next_u64()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        assert_ne!(Rng::new(7, 1, 2).next_u64(), Rng::new(7, 1, 3).next_u64());
        let mut r = Rng::new(1, 2, 3);
        let n = 20000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let g = r.gaussian() as f64;
            s += g;
            s2 += g * g;
        }
        assert!((s / n as f64).abs() < 0.03 && ((s2 / n as f64) - 1.0).abs() < 0.05);
    }

    #[test]
    fn body_axes_follow_the_stated_convention() {
        // Positive pitch lifts the nose; positive roll drops the right wing (+Z).
        let q = body_orientation(0.0, 0.3, 0.0);
        assert!((q * Vec3::X).y > 0.0);
        let q = body_orientation(0.0, 0.0, 0.3);
        assert!((q * Vec3::Z).y < 0.0);
        // Heading yaw turns +X onto the direction of travel.
        let dir = Vec3::new(-1.0, 0.0, 1.0).normalize();
        let q = body_orientation(yaw_of(dir), 0.0, 0.0);
        assert!((q * Vec3::X - dir).length() < 1e-5);
    }

    #[test]
    fn angular_velocity_recovers_a_known_spin() {
        let a = Quat::from_rotation_y(0.1);
        let b = Quat::from_rotation_y(0.3);
        let w = angular_velocity(a, b, 0.1);
        assert!((w - Vec3::Y * 2.0).length() < 1e-4);
        assert_eq!(angular_velocity(a, a, 0.1), Vec3::ZERO);
    }
}
