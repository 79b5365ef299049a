//! Paper 001's local noise field, Eqs. 1–3: V_l = ∇ × N with
//! N = a P + (1 − a)(n · P) n, P = gain · (P1, P2, P3)(x / scale), a = ramp(d / d0).
//!
//! P is three seeded improved-Perlin potentials (`crate::field::noise`), x in metres, so
//! `scale` is the size of the noise lattice in metres and P has units of m²/s (its curl is
//! a velocity). The curl is evaluated in closed form at the agent's position rather than by
//! differences on a grid. With n = ∇d, ∇ × (φ n) = ∇φ × n, so
//!
//! V_l = a ∇×P + (a′/d0) n × P + (1 − a) (Σ_k n_k ∇P_k + (∇n) P) × n
//!
//! Every term but the first is perpendicular to n and a(0) = 0, so V_l · n = a ∇×P · n
//! vanishes on the wall and grows as a near it; the field is divergence-free wherever d is
//! smooth (docs/model.md, "Paper 001").

use super::boundary::Near;
use crate::field::noise::{LatticePoint, Perlin, gradients3};
use glam::Vec3;

/// Eq. 3, the quintic ramp: a(r) = 15/8 r − 10/8 r³ + 3/8 r⁵ on [0, 1], 1 beyond; a
/// negative r (a point inside an obstacle) reads as 0.
#[inline]
pub fn ramp(r: f32) -> f32 {
    let r = r.clamp(0.0, 1.0);
    let r2 = r * r;
    r * (15.0 / 8.0 - r2 * (10.0 / 8.0 - r2 * (3.0 / 8.0)))
}

/// da/dr of Eq. 3: 15/8 (1 − r²)², zero beyond r = 1.
#[inline]
pub fn ramp_slope(r: f32) -> f32 {
    if r >= 1.0 {
        return 0.0;
    }
    let s = 1.0 - r.max(0.0) * r.max(0.0);
    15.0 / 8.0 * s * s
}

/// The divergence-free noise velocity field of one swarm.
#[derive(Clone, Debug)]
pub struct LocalField {
    noise: [Perlin; 3],
    /// 1 / scale, per metre.
    inv_scale: f32,
    /// gain, m²/s.
    gain: f32,
    /// d0 of Eq. 2, m.
    d0: f32,
    /// Bounds of the step of the normal's central difference near curved shapes, m.
    eps_min: f32,
    eps_max: f32,
}

impl LocalField {
    /// `scale` (m) and `gain` (m²/s) of Table 1; `d0` (m), the ramp's width.
    pub fn new(seed: u64, scale: f32, gain: f32, d0: f32) -> Self {
        LocalField {
            noise: [
                Perlin::new(seed),
                Perlin::new(seed ^ 0x1111),
                Perlin::new(seed ^ 0x2222),
            ],
            inv_scale: 1.0 / scale,
            gain,
            d0,
            eps_min: 0.1 * d0.min(scale),
            eps_max: 0.25 * d0.min(scale),
        }
    }

    /// d0, m.
    pub fn d0(&self) -> f32 {
        self.d0
    }

    /// V_l at `p` (m/s), with the nearest boundary within d0 if there is one.
    #[inline]
    pub fn velocity(&self, p: Vec3, near: Option<&Near>) -> Vec3 {
        let lp = LatticePoint::new(p * self.inv_scale);
        let k = self.gain * self.inv_scale;
        let Some(near) = near.filter(|n| n.d < self.d0) else {
            // Far from every boundary a = 1 and N = P: the plain curl.
            let [g1, g2, g3] = gradients3(&self.noise, &lp);
            return Vec3::new(g3.y - g2.z, g1.z - g3.x, g2.x - g1.y) * k;
        };
        let (v1, g1) = self.noise[0].sample_at(&lp);
        let (v2, g2) = self.noise[1].sample_at(&lp);
        let (v3, g3) = self.noise[2].sample_at(&lp);
        let pot = Vec3::new(v1, v2, v3) * self.gain;
        let (g1, g2, g3) = (g1 * k, g2 * k, g3 * k);
        let curl = Vec3::new(g3.y - g2.z, g1.z - g3.x, g2.x - g1.y);
        let n = near.n;
        let r = near.d / self.d0;
        let a = ramp(r);
        let da = ramp_slope(r) / self.d0;
        // ∇(n · P) = Σ_k n_k ∇P_k + (∇n) P.
        // The normal's derivative over a quarter of the distance (a level set of d curves
        // with radius at least d outside a convex shape), at least 0.1 min(d0, scale):
        // close to a sharp edge the exact curvature, 1/d, would make the flow around it
        // as fast as one likes (docs/model.md).
        let eps = (0.25 * near.d).clamp(self.eps_min, self.eps_max);
        let grad_np =
            g1 * n.x + g2 * n.y + g3 * n.z + near.boundary.normal_derivative(p, n, pot, eps);
        curl * a + n.cross(pot) * da + grad_np.cross(n) * (1.0 - a)
    }
}

#[cfg(test)]
mod tests {
    use super::super::boundary::{Boundary, nearest};
    use super::*;
    use crate::geometry::Shape;
    use glam::Quat;

    #[test]
    fn the_ramp_runs_from_zero_at_the_wall_to_one_at_d0() {
        assert_eq!(ramp(0.0), 0.0);
        assert!((ramp(1.0) - 1.0).abs() < 1e-6);
        assert_eq!(ramp(-0.5), 0.0);
        assert_eq!(ramp(3.0), 1.0);
        assert!((ramp_slope(1.0)).abs() < 1e-6 && (ramp_slope(0.0) - 15.0 / 8.0).abs() < 1e-6);
        // Monotone, and the slope is the derivative.
        for k in 1..100 {
            let r = k as f32 / 100.0;
            assert!(ramp(r) > ramp(r - 0.01));
            let fd = (ramp(r + 1e-3) - ramp(r - 1e-3)) / 2e-3;
            assert!(
                (fd - ramp_slope(r)).abs() < 1e-2,
                "at {r}: {fd} vs {}",
                ramp_slope(r)
            );
        }
    }

    /// The domain, a rotated box, a sphere, a capsule and the ground.
    fn scene() -> Vec<Boundary> {
        let mut b = smooth_scene();
        b.push(Boundary::Shape(Shape::Box {
            center: Vec3::new(-1.0, 1.0, 0.0),
            half: Vec3::new(0.5, 1.0, 0.7),
            rotation: Quat::from_rotation_y(0.4),
        }));
        b
    }

    /// Boundaries whose distance fields are smooth off their medial surfaces (no edges).
    fn smooth_scene() -> Vec<Boundary> {
        vec![
            Boundary::Domain {
                center: Vec3::new(0.0, 2.0, 0.0),
                half: Vec3::new(3.0, 2.0, 3.0),
            },
            Boundary::Shape(Shape::Capsule {
                a: Vec3::new(1.0, 1.0, -2.0),
                b: Vec3::new(-1.0, 2.5, -1.5),
                radius: 0.12,
            }),
            Boundary::Shape(Shape::Sphere {
                center: Vec3::new(1.5, 2.0, 1.0),
                radius: 0.6,
            }),
            Boundary::Shape(Shape::Plane {
                point: Vec3::new(0.0, 0.3, 0.0),
                normal: Vec3::Y,
            }),
        ]
    }

    fn field() -> LocalField {
        LocalField::new(17, 0.4, 0.25, 0.3)
    }

    fn v_at(f: &LocalField, b: &[Boundary], p: Vec3) -> Vec3 {
        let near = nearest([b, &[]], p, f.d0());
        f.velocity(p, near.as_ref())
    }

    /// Points in free space, many of them within d0 of a boundary.
    fn samples(b: &[Boundary], f: &LocalField) -> Vec<Vec3> {
        let mut rng = crate::math::Rng::new(1, 2, 3);
        let mut out = Vec::new();
        while out.len() < 3000 {
            let p = Vec3::new(
                rng.range(-2.9, 2.9),
                rng.range(0.05, 3.95),
                rng.range(-2.9, 2.9),
            );
            if let Some(n) = nearest([b, &[]], p, 10.0)
                && n.d > 0.02
            {
                // Keep off the medial surfaces where the nearest boundary switches (d is
                // not smooth there).
                let second = b
                    .iter()
                    .filter(|x| !std::ptr::eq(*x, n.boundary))
                    .map(|x| x.query(p).0)
                    .fold(f32::INFINITY, f32::min);
                // The domain's own medial planes, where its nearest face changes.
                let own = match *n.boundary {
                    Boundary::Domain { center, half } => {
                        let mut room = (half - (p - center).abs()).to_array();
                        room.sort_by(f32::total_cmp);
                        room[1]
                    }
                    _ => f32::INFINITY,
                };
                if second.min(own) - n.d > 0.02 && (n.d < f.d0() || out.len() % 4 == 0) {
                    out.push(p);
                }
            }
        }
        out
    }

    /// Largest |∇·V_l| and the mean largest single derivative |∂V_i/∂x_j| over `pts`, 1/s.
    fn divergence(f: &LocalField, b: &[Boundary], pts: &[Vec3]) -> (f32, f32) {
        let e = 1e-3f32;
        let (mut worst, mut scale_sum) = (0.0f32, 0.0f32);
        for &p in pts {
            let mut div = 0.0;
            let mut grad = 0.0f32;
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                let d = (v_at(f, b, p + axis * e) - v_at(f, b, p - axis * e)) / (2.0 * e);
                div += d.dot(axis);
                grad = grad.max(d.abs().max_element());
            }
            worst = worst.max(div.abs());
            scale_sum += grad;
        }
        (worst, scale_sum / pts.len() as f32)
    }

    #[test]
    fn near_sharp_edges_the_divergence_stays_small() {
        // The box's edges: the normal's derivative is measured over a finite step there.
        let b = scene();
        let f = field();
        let pts: Vec<Vec3> = samples(&b, &f)
            .into_iter()
            .filter(|p| {
                nearest([&b, &[]], *p, f.d0())
                    .is_some_and(|n| matches!(n.boundary, Boundary::Shape(Shape::Box { .. })))
            })
            .collect();
        let (worst, typical) = divergence(&f, &b, &pts);
        println!(
            "noise field within d0 of a box ({} points): largest |div V_l| {worst:.3} 1/s, typical |∂V/∂x| {typical:.3} 1/s",
            pts.len()
        );
        assert!(pts.len() > 100);
        assert!(worst < 0.5 * typical, "{worst} vs {typical}");
    }

    #[test]
    fn the_noise_field_is_divergence_free_near_and_far_from_boundaries() {
        let b = smooth_scene();
        let f = field();
        let pts = samples(&b, &f);
        let near_count = pts
            .iter()
            .filter(|p| nearest([&b, &[]], **p, f.d0()).is_some())
            .count();
        let (worst, typical) = divergence(&f, &b, &pts);
        println!(
            "noise field: largest |div V_l| {worst:.4} 1/s over {} points ({near_count} within d0); typical |∂V/∂x| {typical:.3} 1/s",
            pts.len()
        );
        assert!(near_count > 1000, "{near_count}");
        assert!(typical > 0.3, "the field must vary: {typical}");
        assert!(
            worst < 0.05 * typical,
            "divergence {worst} vs derivatives {typical}"
        );
    }

    #[test]
    fn the_noise_field_has_no_normal_component_at_walls() {
        let b = scene();
        let f = field();
        let mut rng = crate::math::Rng::new(9, 8, 7);
        // The field's RMS speed away from walls, for scale.
        let mut rms = 0.0f32;
        for k in 0..1000 {
            let p = Vec3::new(
                k as f32 * 0.013 - 6.0,
                50.0 + k as f32 * 0.007,
                k as f32 * 0.011,
            );
            rms += f.velocity(p, None).length_squared() / 1000.0;
        }
        let rms = rms.sqrt();
        let (mut worst_at, mut worst_near, mut mean_speed, mut k) = (0.0f32, 0.0f32, 0.0f32, 0);
        // Points a small distance from each wall, along its normal.
        while k < 2000 {
            let p0 = Vec3::new(
                rng.range(-2.9, 2.9),
                rng.range(0.3, 3.9),
                rng.range(-2.9, 2.9),
            );
            let Some(n) = nearest([&b, &[]], p0, 10.0) else {
                continue;
            };
            if n.d <= 0.0 {
                continue;
            }
            // On the wall, and 1 % of d0 out along its normal.
            let wall = p0 - n.n * n.d;
            let p = wall + n.n * (0.01 * f.d0());
            let (Some(at), Some(on)) =
                (nearest([&b, &[]], p, 10.0), nearest([&b, &[]], wall, 10.0))
            else {
                continue;
            };
            if (at.d - 0.01 * f.d0()).abs() > 1e-3 || !std::ptr::eq(at.boundary, on.boundary) {
                continue; // another boundary is nearer there
            }
            let v = f.velocity(p, Some(&at));
            worst_near = worst_near.max(v.dot(at.n).abs());
            worst_at = worst_at.max(f.velocity(wall, Some(&on)).dot(on.n).abs());
            mean_speed += v.length();
            k += 1;
        }
        mean_speed /= k as f32;
        println!(
            "noise field: RMS speed {rms:.3} m/s; largest |V_l·n| on walls {worst_at:.2e} m/s, at 0.01 d0 {worst_near:.4} m/s; mean |V_l| there {mean_speed:.3} m/s"
        );
        assert!(
            mean_speed > 0.2 * rms,
            "the field flows along the wall: {mean_speed}"
        );
        assert!(worst_at < 1e-4 * rms, "{worst_at}");
        assert!(worst_near < 0.05 * rms, "{worst_near}");
    }

    #[test]
    fn far_from_boundaries_the_field_is_the_plain_curl_and_continuous_at_d0() {
        let b = scene();
        let f = field();
        // Crossing d = d0 above the plane (y = 0.3) far from the rest: no jump.
        let p = Vec3::new(0.5, 0.3 + f.d0(), -2.0);
        let below = v_at(&f, &b, p - Vec3::Y * 1e-4);
        let above = v_at(&f, &b, p + Vec3::Y * 1e-4);
        assert!(
            (below - above).length() < 0.02 * above.length().max(0.1),
            "{below} {above}"
        );
    }
}
