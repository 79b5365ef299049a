//! Curl-noise force, Eq. 8–9 of paper 000.
//!
//! ψ(r) = ε (Per₁(r/L), Per₂(r/L), Per₃(r/L)) / L in the paper's scene units, and
//! F_curl = ∇ × ψ. With ξ = r/L, ∂ψ/∂r = (ε / L²) ∂Per/∂ξ, so the curl is
//! (ε / L²) (∇_ξ × Per) — computed from the analytic noise gradients, hence exactly
//! divergence-free. L is given in metres and converted to scene units
//! ([`SCENE_UNIT_M`]); the result is an acceleration in m/s²
//! (one scene force unit per unit mass = 1 m/s², see docs/model.md).

use super::noise::{LatticePoint, Perlin, gradients3};
use super::wide::WideTables;
use glam::Vec3;

/// Metres per scene length unit of paper 000, whose Table I (h, L) and Eq. 8's gain are
/// stated in unstated scene units: a few bee lengths (docs/model.md).
pub const SCENE_UNIT_M: f64 = 0.05;

#[derive(Clone, Debug)]
pub struct CurlNoise {
    potentials: [Perlin; 3],
    /// 1 / L, per metre.
    inv_cell: f32,
    /// ε / L² with L in scene units.
    gain: f32,
    /// The potentials' permutation tables as [`CurlNoise::forces`] gathers them.
    wide: Box<WideTables>,
}

impl CurlNoise {
    /// `cell` is L in metres; `epsilon` is ε.
    pub fn new(seed: u64, cell: f64, epsilon: f64) -> Self {
        let l_scene = cell / SCENE_UNIT_M;
        let potentials = [
            Perlin::new(seed),
            Perlin::new(seed ^ 0x1111),
            Perlin::new(seed ^ 0x2222),
        ];
        CurlNoise {
            wide: Box::new(WideTables::new(&potentials)),
            potentials,
            inv_cell: (1.0 / cell) as f32,
            gain: (epsilon / (l_scene * l_scene)) as f32,
        }
    }

    /// 1 / L, per metre.
    pub(super) fn inv_cell(&self) -> f32 {
        self.inv_cell
    }

    /// ε / L² with L in scene units.
    pub(super) fn gain(&self) -> f32 {
        self.gain
    }

    /// The potentials' permutation tables as [`CurlNoise::forces`] gathers them.
    pub(super) fn hash_tables(&self) -> &WideTables {
        &self.wide
    }

    /// F_curl at `p` (metres), as an acceleration in m/s².
    // Inlined into the models' steps, as the compiler chose by itself before other code
    // moved it into another unit.
    #[inline]
    pub fn force(&self, p: Vec3) -> Vec3 {
        let xi = p * self.inv_cell;
        // The three potentials differ by their permutation tables alone, so they share
        // the lattice point.
        let [g1, g2, g3] = gradients3(&self.potentials, &LatticePoint::new(xi));
        // Eq. 9: (∂ψz/∂y − ∂ψy/∂z, ∂ψx/∂z − ∂ψz/∂x, ∂ψy/∂x − ∂ψx/∂y).
        Vec3::new(g3.y - g2.z, g1.z - g3.x, g2.x - g1.y) * self.gain
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curl_field_is_divergence_free() {
        let c = CurlNoise::new(5, 0.11, 2.0);
        let e = 1e-4f32;
        let mut worst = 0.0f32;
        let mut typical = 0.0f32;
        for i in 0..300 {
            let p = Vec3::new(
                i as f32 * 0.0173 - 1.0,
                (i as f32 * 0.031).sin(),
                i as f32 * -0.0119,
            );
            let div = (c.force(p + Vec3::X * e).x - c.force(p - Vec3::X * e).x
                + c.force(p + Vec3::Y * e).y
                - c.force(p - Vec3::Y * e).y
                + c.force(p + Vec3::Z * e).z
                - c.force(p - Vec3::Z * e).z)
                / (2.0 * e);
            // Compare with the size of single derivatives to make the test scale-free.
            let dxx = ((c.force(p + Vec3::X * e).y - c.force(p - Vec3::X * e).y) / (2.0 * e)).abs();
            worst = worst.max(div.abs());
            typical += dxx / 300.0;
        }
        assert!(typical > 1.0, "the field should vary: {typical}");
        assert!(
            worst < typical * 0.01,
            "divergence {worst} vs derivative scale {typical}"
        );
    }

    #[test]
    fn gain_scales_with_epsilon_over_cell_squared() {
        let p = Vec3::new(0.3, 0.7, -0.2);
        let a = CurlNoise::new(1, 0.1, 1.0).force(p);
        let b = CurlNoise::new(1, 0.1, 2.0).force(p);
        assert!((b - a * 2.0).length() < 1e-4);
    }
}
