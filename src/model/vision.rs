//! Visually based obstacle sensing and roll-to-avoid (paper 000 Sec. IV-B, Eq. 5–7).

use glam::Vec3;

/// Bridson's ramp, ramp(x) = 15/8 x − 10/8 x³ + 3/8 x⁵ on [−1, 1], ±1 outside.
#[inline]
pub fn ramp(x: f32) -> f32 {
    if x >= 1.0 {
        1.0
    } else if x <= -1.0 {
        -1.0
    } else {
        let x2 = x * x;
        x * (15.0 / 8.0 - x2 * (10.0 / 8.0 - x2 * 3.0 / 8.0))
    }
}

/// Whether a surface point at offset `r_e` from the bee lies within the field of view
/// around the body axis `o` (half-angle in degrees; the paper uses ±45°).
#[inline]
pub fn in_view(o: Vec3, r_e: Vec3, half_angle_deg: f32) -> bool {
    let denom = o.length() * r_e.length();
    if denom <= 1e-12 {
        // On the surface itself: the obstacle fills the view.
        return true;
    }
    o.dot(r_e) / denom >= half_angle_deg.to_radians().cos()
}

/// Optic-flow speed control (our addition, docs/model.md): insects hold the image motion
/// of nearby surfaces roughly constant, so they fly slower the closer a surface is
/// (Srinivasan et al. 1996 for honeybees; landing bees slow in proportion to height).
/// The factor on the preferred speed at distance `d` from the nearest surface is
/// r + (1 − r)(1 − e^(−d/λ)): `ratio` r at the surface, recovering to 1 over `length` λ.
#[inline]
pub fn surface_speed_factor(d: f32, ratio: f32, length: f32) -> f32 {
    if ratio >= 1.0 {
        return 1.0;
    }
    let x = d.max(0.0) / length.max(1e-6);
    // e^(−x) rounds to exactly 0 in f32 beyond x ≈ 104.7 (half the smallest subnormal), so
    // skipping the library call there — no surface or target in sight, x = ∞ — gives the
    // same bits.
    let e = if x > FAR_E_FOLDINGS { 0.0 } else { (-x).exp() };
    ratio + (1.0 - ratio) * (1.0 - e)
}

/// Distances, in e-folding lengths, beyond which e^(−x) is 0 in f32.
const FAR_E_FOLDINGS: f32 = 110.0;

/// Substep, s, at which Eq. 5 is applied once as the paper writes it: the calibrated
/// `mosquito_cage` shot's (50 fps × 4 substeps), so that its preset keeps its score.
pub const EQ5_STEP_S: f32 = 0.005;

/// Eq. 5, read so that the normal component vanishes at the surface while the tangential
/// (slipping) component is kept: u* = u − (1 − γ) n (n·u), γ = |ramp(d/d0)|, applied only
/// while the bee moves towards the surface (docs/model.md explains the reading).
///
/// The paper applies it once per time step, which brakes harder the more steps there are.
/// Here it is a rate: the normal velocity decays as e^(−λt) with λ = ln(1/γ) / [`EQ5_STEP_S`]
/// (one application of the paper's factor γ every 5 ms), integrated exactly over the substep
/// of `dt` seconds together with the normal part of the velocity change `dv` the forces
/// made in it: uₙ' = (uₙ − dvₙ) k + dvₙ (1 − k) / ln(1/k), k = γ^(dt/5 ms). So 2 or 16
/// substeps brake alike, and a bee pressed at a surface creeps at the same speed.
#[inline]
pub fn tune_velocity(u: Vec3, dv: Vec3, n: Vec3, d: f32, d0: f32, dt: f32) -> Vec3 {
    let un = n.dot(u);
    if un >= 0.0 || d >= d0 {
        return u;
    }
    let gamma = ramp((d / d0).max(0.0)).abs();
    let dvn = n.dot(dv);
    let tuned = if gamma > 0.0 {
        let log_k = gamma.ln() * (dt / EQ5_STEP_S);
        let k = log_k.exp();
        // (1 − k) / ln(1/k), → 1 as k → 1.
        let gain = if log_k < -1e-4 {
            (1.0 - k) / -log_k
        } else {
            1.0 + 0.5 * log_k
        };
        (un - dvn) * k + dvn * gain
    } else {
        0.0
    };
    u - n * (un - tuned)
}

/// Eq. 7: y = ŷ · (o × r_e). Positive when the obstacle is on the bee's left.
#[inline]
pub fn side(o: Vec3, r_e: Vec3) -> f32 {
    o.cross(r_e).y
}

/// Eq. 6 as the text describes it: the roll grows as the bee approaches (largest at the
/// surface, d = 0) and fades towards the threshold d0: θ = sign(y) θmax exp(−½ (d/σ)²)
/// with σ = 0.6 d0 (a quarter of θmax at d0, 70 % at d0/2). This roll drives the sway
/// force; the body is drawn banking further ([`drawn_bank_deg`]).
/// Positive roll drops the right wing, so the sway force (Eq. 2) pushes the bee right, away
/// from an obstacle on its left.
#[inline]
pub fn avoid_roll_deg(y: f32, d: f32, d0: f32, roll_max_deg: f32) -> f32 {
    let sign = if y >= 0.0 { 1.0 } else { -1.0 };
    let x = d.max(0.0) / (0.6 * d0);
    sign * roll_max_deg * (-0.5 * x * x).exp()
}

/// The bank the body is drawn with while avoiding: Eq. 6 with σ = d0 (61 % of θmax, 27°,
/// when first seen at d0; 88 % at d0/2), above the ±19° of Eq. 4's rocking from the moment
/// it starts, so that the avoidance reads on screen (docs/model.md).
#[inline]
pub fn drawn_bank_deg(y: f32, d: f32, d0: f32, roll_max_deg: f32) -> f32 {
    let sign = if y >= 0.0 { 1.0 } else { -1.0 };
    let x = d.max(0.0) / d0;
    sign * roll_max_deg * (-0.5 * x * x).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_matches_bridson() {
        assert_eq!(ramp(0.0), 0.0);
        assert!((ramp(1.0) - 1.0).abs() < 1e-6);
        assert!((ramp(0.5) - (15.0 / 16.0 - 10.0 / 64.0 + 3.0 / 256.0)).abs() < 1e-6);
        // Monotone on [0, 1].
        assert!((0..100).all(|i| ramp(i as f32 / 100.0) < ramp((i + 1) as f32 / 100.0)));
    }

    #[test]
    fn tuned_velocity_has_no_normal_component_at_the_surface_and_keeps_slip() {
        let n = Vec3::X;
        let u = Vec3::new(-2.0, 0.0, 1.0);
        let dt = EQ5_STEP_S;
        let z = Vec3::ZERO;
        let at = tune_velocity(u, z, n, 0.0, 0.1, dt);
        assert!(at.x.abs() < 1e-6 && (at.z - 1.0).abs() < 1e-6);
        assert_eq!(tune_velocity(u, z, n, 0.2, 0.1, dt), u);
        // Moving away is never altered.
        assert_eq!(tune_velocity(-u, z, n, 0.01, 0.1, dt), -u);
        // With no force, one reference step is the paper's single application, and two
        // half steps brake exactly as much as one whole.
        let one = tune_velocity(u, z, n, 0.05, 0.1, dt);
        assert!((one.x - u.x * ramp(0.5)).abs() < 1e-6);
        let half = tune_velocity(
            tune_velocity(u, z, n, 0.05, 0.1, dt / 2.0),
            z,
            n,
            0.05,
            0.1,
            dt / 2.0,
        );
        assert!((half - one).length() < 1e-6, "{half} {one}");
        // Pressed on by a steady force, the normal speed settles where the decay balances
        // it, dvₙ/dt / λ, whatever the step.
        let settle = |dt: f32| {
            let (mut v, dv) = (Vec3::ZERO, -n * (3.0 * dt));
            for _ in 0..(1.0 / dt) as usize {
                v = tune_velocity(v + dv, dv, n, 0.05, 0.1, dt);
            }
            v.x
        };
        let lambda = -ramp(0.5).ln() / EQ5_STEP_S;
        for dt in [0.0025, 0.005, 0.01, 0.02] {
            assert!(
                (settle(dt) + 3.0 / lambda).abs() < 1e-4,
                "dt {dt}: {}",
                settle(dt)
            );
        }
    }

    #[test]
    fn far_from_every_surface_the_speed_factor_skips_nothing_but_the_call() {
        // e^(−x) is already 0 where the shortcut starts, and at infinity.
        assert_eq!((-FAR_E_FOLDINGS).exp(), 0.0);
        assert_eq!((-f32::INFINITY).exp(), 0.0);
        for ratio in [0.0f32, 0.3, 0.55, 0.999] {
            for d in [0.2f32, 10.0, 11.0, 16.4, 1e3, f32::INFINITY] {
                let formula = ratio + (1.0 - ratio) * (1.0 - (-d.max(0.0) / 0.1f32).exp());
                assert_eq!(
                    surface_speed_factor(d, ratio, 0.1).to_bits(),
                    formula.to_bits(),
                    "{d} {ratio}"
                );
            }
        }
    }

    #[test]
    fn surface_speed_factor_rises_from_the_ratio_to_one() {
        assert!((surface_speed_factor(0.0, 0.4, 0.1) - 0.4).abs() < 1e-6);
        // One e-folding length out, 1 − e^(−1) of the way back.
        let one = surface_speed_factor(0.1, 0.4, 0.1);
        assert!((one - (0.4 + 0.6 * (1.0 - (-1.0f32).exp()))).abs() < 1e-6);
        assert!(surface_speed_factor(2.0, 0.4, 0.1) > 0.9999);
        assert!(surface_speed_factor(0.05, 0.4, 0.1) < one);
        // Ratio 1 switches it off, even inside a surface or with a zero length.
        assert_eq!(surface_speed_factor(-1.0, 1.0, 0.0), 1.0);
        assert!(surface_speed_factor(0.01, 0.5, 0.0).is_finite());
    }

    #[test]
    fn roll_direction_is_away_from_the_obstacle() {
        let o = Vec3::X; // flying along +X; +Z is right, −Z is left
        let left = Vec3::new(0.5, 0.0, -0.5);
        let right = Vec3::new(0.5, 0.0, 0.5);
        assert!(side(o, left) > 0.0 && side(o, right) < 0.0);
        // Obstacle on the left: positive roll (right wing down), sway pushes right (+Z).
        assert!(avoid_roll_deg(side(o, left), 0.05, 0.1, 45.0) > 0.0);
        assert!(avoid_roll_deg(side(o, right), 0.05, 0.1, 45.0) < 0.0);
        // The roll grows as the bee approaches.
        assert!(avoid_roll_deg(1.0, 0.01, 0.1, 45.0) > avoid_roll_deg(1.0, 0.08, 0.1, 45.0));
        assert!((avoid_roll_deg(1.0, 0.0, 0.1, 45.0) - 45.0).abs() < 1e-4);
    }

    #[test]
    fn field_of_view_is_plus_minus_45_degrees() {
        assert!(in_view(Vec3::X, Vec3::new(1.0, 0.0, 0.9), 45.0));
        assert!(!in_view(Vec3::X, Vec3::new(1.0, 0.0, 1.1), 45.0));
        assert!(!in_view(Vec3::X, -Vec3::X, 45.0));
    }
}
