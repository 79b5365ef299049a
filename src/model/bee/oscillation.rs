//! Body oscillation force F_o (paper 000 Sec. IV-A, Eq. 2–4).
//!
//! F_o = (thrust, lift, sway) = (m g θ_pitch, ½ ρ A |u|² l(θ_pitch), m g θ_roll) in the
//! heading frame (X along the horizontal direction of travel, Y up, Z right). Angles enter
//! Eq. 2 in radians (the small-angle decomposition of a tilted wing force); the lift
//! coefficient l(α) of Fig. 4 takes degrees. See docs/model.md for the choices.

use glam::Vec3;

pub const AIR_DENSITY: f32 = 1.225;
pub const GRAVITY: f32 = 9.81;

/// Lift coefficient of Fig. 4, α in degrees.
#[inline]
pub fn lift_coefficient(alpha_deg: f32) -> f32 {
    -0.00095953 * alpha_deg * alpha_deg + 0.090635 * alpha_deg - 0.34182
}

/// sin(π (t + shift) / half_period), with the phase reduced in f64 so that long shots
/// keep full precision, then evaluated in f32.
#[inline]
fn periodic(t: f64, shift: f64, half_period: f64) -> f32 {
    let phase = ((t + shift) / (2.0 * half_period)).rem_euclid(1.0);
    (phase as f32 * std::f32::consts::TAU).sin()
}

/// Eq. 3: pitch angle (degrees) at maneuvering time t (in the equation's time units).
#[inline]
pub fn pitch_deg(t: f64) -> f32 {
    16.429 + 3.5 * periodic(t, PITCH_SHIFT, PITCH_HALF_PERIOD)
}

/// Eq. 4: roll angle (degrees) at maneuvering time t.
#[inline]
pub fn roll_deg(t: f64) -> f32 {
    -0.765 + 18.914 * periodic(t, ROLL_SHIFT, ROLL_HALF_PERIOD)
}

const PITCH_SHIFT: f64 = 2.986;
const PITCH_HALF_PERIOD: f64 = 35.972;
const ROLL_SHIFT: f64 = 38.298;
const ROLL_HALF_PERIOD: f64 = 91.775;

/// The unit vector (cos θ, sin θ) of an oscillation's phase angle θ: Eq. 3–4 at the sum of
/// the shot's time and a bee's own phase offset come from the time's phasor, worked out
/// once per substep for the whole swarm, and the bee's, worked out once when it is born,
/// by the angle-sum rule: no sine per bee and substep. Two f32, so a bee's state stays
/// plain 4-byte words.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phasor {
    pub cos: f32,
    pub sin: f32,
}

impl Phasor {
    /// The phasor of θ = π (t + shift) / half_period, reduced to one turn in f64 (so long
    /// shots keep full precision) and evaluated in f64.
    fn at(t: f64, shift: f64, half_period: f64) -> Self {
        let turns = ((t + shift) / (2.0 * half_period)).rem_euclid(1.0);
        let (sin, cos) = (turns * std::f64::consts::TAU).sin_cos();
        Phasor {
            cos: cos as f32,
            sin: sin as f32,
        }
    }

    /// sin(θ_self + θ_other), by the angle-sum rule (products summed in f64: within
    /// 2 × 10⁻⁷ of the exact sine of the summed angles; tested).
    #[inline]
    pub fn sin_of_sum(self, other: Phasor) -> f32 {
        (self.sin as f64 * other.cos as f64 + self.cos as f64 * other.sin as f64) as f32
    }
}

/// The phasors of Eq. 3 and Eq. 4 at maneuvering time t, shifts included: add a bee's
/// [`offsets`] to them with [`Phasor::sin_of_sum`].
pub fn clock(t: f64) -> (Phasor, Phasor) {
    (
        Phasor::at(t, PITCH_SHIFT, PITCH_HALF_PERIOD),
        Phasor::at(t, ROLL_SHIFT, ROLL_HALF_PERIOD),
    )
}

/// A bee's phase offsets (in the equations' time units) as phasors, without the shifts.
pub fn offsets(pitch_phase: f64, roll_phase: f64) -> (Phasor, Phasor) {
    (
        Phasor::at(pitch_phase, 0.0, PITCH_HALF_PERIOD),
        Phasor::at(roll_phase, 0.0, ROLL_HALF_PERIOD),
    )
}

/// Eq. 3 from the time's and the bee's phasors ([`clock`], [`offsets`]).
#[inline]
pub fn pitch_deg_of(clock: Phasor, offset: Phasor) -> f32 {
    16.429 + 3.5 * clock.sin_of_sum(offset)
}

/// Eq. 4 from the time's and the bee's phasors.
#[inline]
pub fn roll_deg_of(clock: Phasor, offset: Phasor) -> f32 {
    -0.765 + 18.914 * clock.sin_of_sum(offset)
}

/// Mean of Eq. 3's pitch, degrees: the body's attitude about which it rocks.
pub const MEAN_PITCH_DEG: f32 = 16.429;

/// Period of Eq. 3 in its own time units (2 × 35.972).
pub const PITCH_PERIOD: f64 = 2.0 * PITCH_HALF_PERIOD;
/// Period of Eq. 4 in its own time units (2 × 91.775).
pub const ROLL_PERIOD: f64 = 2.0 * ROLL_HALF_PERIOD;

/// Mean of l(θ_pitch(t)) over one pitch cycle: l is quadratic, so the mean is
/// l(mean angle) + c₂ · amplitude² / 2.
pub fn mean_lift_coefficient() -> f32 {
    lift_coefficient(16.429) + (-0.00095953) * 3.5 * 3.5 / 2.0
}

/// Mean thrust per unit mass over a pitch cycle, m/s² (g × mean pitch in radians).
pub fn mean_thrust_accel() -> f32 {
    GRAVITY * 16.429f32.to_radians()
}

/// The wing speed U, m/s, at which Eq. 2's mean lift ½ ρ A U² l̄ carries the weight m g:
/// 6.7 m/s for the default honeybee, close to the mean speed of its flapping wing
/// (docs/model.md). With it the oscillating lift is g (l(θ) − l̄) / l̄, whatever the body.
pub fn weight_bearing_wing_speed(mass: f32, wing_area: f32, mean_cl: f32) -> f32 {
    (2.0 * mass * GRAVITY / (AIR_DENSITY * wing_area * mean_cl)).sqrt()
}

/// F_o / m in the heading frame (m/s²). `lift_speed` is the speed u of Eq. 2's lift: the
/// body's air speed as the paper writes it, or the weight-bearing wing speed
/// ([`weight_bearing_wing_speed`]). The lift is taken relative to its cycle mean: the mean
/// wing lift carries the bee's weight, which the paper does not model, so only the
/// oscillating part moves the body (docs/model.md).
#[inline]
pub fn accel(
    pitch_deg: f32,
    roll_deg: f32,
    lift_speed: f32,
    mass: f32,
    wing_area: f32,
    mean_cl: f32,
) -> Vec3 {
    let thrust = GRAVITY * pitch_deg.to_radians();
    let lift = 0.5
        * AIR_DENSITY
        * wing_area
        * lift_speed
        * lift_speed
        * (lift_coefficient(pitch_deg) - mean_cl)
        / mass;
    let sway = GRAVITY * roll_deg.to_radians();
    Vec3::new(thrust, lift, sway)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fig4_polynomial_and_eq3_eq4_ranges() {
        assert!((lift_coefficient(16.429) - 0.8884).abs() < 1e-3);
        let (mut pmin, mut pmax, mut rmin, mut rmax) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        for i in 0..2000 {
            let t = i as f64 * 0.1;
            pmin = pmin.min(pitch_deg(t));
            pmax = pmax.max(pitch_deg(t));
            rmin = rmin.min(roll_deg(t));
            rmax = rmax.max(roll_deg(t));
        }
        // The paper: pitch and roll stay small (≤ 20°).
        assert!((pmin - 12.929).abs() < 0.01 && (pmax - 19.929).abs() < 0.01);
        assert!((rmin + 19.679).abs() < 0.01 && (rmax - 18.149).abs() < 0.01);
    }

    #[test]
    fn maneuvering_functions_equal_eq3_and_eq4_even_after_long_times() {
        for t in [0.0, 1.0, 17.3, 1e4, 3.6e6] {
            let p = 16.429 + 3.5 * (std::f64::consts::PI * (t + 2.986) / 35.972).sin();
            let r = -0.765 + 18.914 * (std::f64::consts::PI * (t + 38.298) / 91.775).sin();
            assert!((pitch_deg(t) as f64 - p).abs() < 1e-3, "t={t}");
            assert!((roll_deg(t) as f64 - r).abs() < 5e-3, "t={t}");
        }
    }

    #[test]
    fn phasor_sums_equal_eq3_and_eq4_at_the_summed_time_even_after_long_times() {
        // The exact equations in f64 at time t plus a bee's phase offsets (as the f32
        // the bee stores), against the angle-sum evaluation the step uses.
        let mut rng = crate::math::Rng::new(3, 14, 0);
        let (mut worst_p, mut worst_r) = (0.0f64, 0.0f64);
        for k in 0..20_000 {
            let t = match k % 4 {
                0 => rng.range(0.0, 200.0) as f64,
                1 => rng.range(0.0, 1e4) as f64,
                2 => 3.6e6 + rng.range(0.0, 1e3) as f64,
                _ => k as f64 * 0.25,
            };
            let pp = rng.range(0.0, PITCH_PERIOD as f32);
            let rp = rng.range(0.0, ROLL_PERIOD as f32);
            let (cp, cr) = clock(t);
            let (op, or) = offsets(pp as f64, rp as f64);
            let p = 16.429 + 3.5 * (std::f64::consts::PI * (t + pp as f64 + 2.986) / 35.972).sin();
            let r =
                -0.765 + 18.914 * (std::f64::consts::PI * (t + rp as f64 + 38.298) / 91.775).sin();
            worst_p = worst_p.max((pitch_deg_of(cp, op) as f64 - p).abs());
            worst_r = worst_r.max((roll_deg_of(cr, or) as f64 - r).abs());
        }
        // Degrees: the f32 rounding of the angle itself (16° → 1e-6, 19° → 2e-6) plus
        // the amplitude (3.5°, 18.9°) times 2e-7 for the sine. (The f32 sine of the
        // summed phase it replaced, `pitch_deg(t + offset)`, was off by up to 3.7e-6° and
        // 1.1e-5° on the same draws.)
        assert!(worst_p < 2.5e-6, "pitch off by {worst_p}°");
        assert!(worst_r < 5e-6, "roll off by {worst_r}°");
    }

    #[test]
    fn phasors_are_unit_vectors() {
        for t in [0.0, 0.3, 17.0, 35.972, 1e5, 3.6e6] {
            let (p, r) = clock(t);
            for q in [p, r] {
                assert!(((q.cos * q.cos + q.sin * q.sin) as f64 - 1.0).abs() < 3e-7);
            }
        }
    }

    #[test]
    fn at_the_weight_bearing_wing_speed_the_lift_swings_by_a_quarter_of_g() {
        // The default honeybee: 100 mg, 40 mm² of wing.
        let cl = mean_lift_coefficient();
        let u = weight_bearing_wing_speed(1e-4, 40e-6, cl);
        assert!((u - 6.7).abs() < 0.05, "{u}");
        let lift = |p: f32| accel(p, 0.0, u, 1e-4, 40e-6, cl).y;
        // l(θ) at the ends of Eq. 3's swing against its mean, times g.
        let (lo, hi) = (lift(12.929), lift(19.929));
        assert!(
            (lo + 2.37).abs() < 0.02 && (hi - 2.23).abs() < 0.02,
            "{lo} {hi}"
        );
    }

    #[test]
    fn oscillating_lift_averages_to_zero_over_a_cycle() {
        let cl = mean_lift_coefficient();
        let n = 10000;
        let mean: f64 = (0..n)
            .map(|i| (lift_coefficient(pitch_deg(i as f64 * PITCH_PERIOD / n as f64)) - cl) as f64)
            .sum::<f64>()
            / n as f64;
        assert!(mean.abs() < 1e-5, "{mean}");
    }
}
