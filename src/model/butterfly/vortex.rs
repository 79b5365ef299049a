//! The vortex force of paper 004 (Sec. 5.2, Eq. 7): the curl of three Perlin noise
//! potentials, each sampled at the thorax position divided by its own `gain` (22 m across,
//! 5.5 m up: flat vortices), scaled by η, acting on the thorax only.
//!
//! ψ_k(p) = η s_k(p / gain_k), so ∂ψ_k/∂p = (η / gain_k) ∇s_k — the curl is taken from the
//! analytic noise gradients, hence exactly divergence-free. The paper adds F_vor to the
//! wing forces and divides by m (Eq. 10); with m in kilograms η = 3.66 would give
//! thousands of m/s², so F_vor / m is read as η·curl in m/s² (docs/model.md, "Paper 004").

use crate::field::noise::Perlin;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct Vortex {
    potentials: [Perlin; 3],
    /// 1 / gain per component, 1/m.
    inv_gain: Vec3,
    /// η / gain per component, m/s².
    scale: Vec3,
}

impl Vortex {
    /// `gain` = (gain_x, gain_y, gain_z) in metres, `eta` = η.
    pub fn new(seed: u64, gain: Vec3, eta: f32) -> Self {
        Vortex {
            // "Different noise seeds" for s1, s2, s3.
            potentials: [
                Perlin::new(seed),
                Perlin::new(seed ^ 0xB0_0001),
                Perlin::new(seed ^ 0xB0_0002),
            ],
            inv_gain: gain.recip(),
            scale: gain.recip() * eta,
        }
    }

    /// F_vor / m at `p` (metres), m/s².
    pub fn accel(&self, p: Vec3) -> Vec3 {
        let g = |k: usize| {
            let (_, grad) = self.potentials[k].sample(p * self.inv_gain[k]);
            grad * self.scale[k]
        };
        let (g1, g2, g3) = (g(0), g(1), g(2));
        Vec3::new(g3.y - g2.z, g1.z - g3.x, g2.x - g1.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vortex_field_is_divergence_free_and_scales_with_eta() {
        let v = Vortex::new(7, Vec3::new(22.0, 5.5, 22.0), 3.66);
        let e = 1e-2f32;
        let mut worst = 0.0f32;
        let mut typical = 0.0f32;
        for i in 0..100 {
            let p = Vec3::new(
                i as f32 * 0.37 - 10.0,
                (i as f32 * 0.13).sin() * 3.0,
                i as f32 * -0.29,
            );
            let div = (v.accel(p + Vec3::X * e).x - v.accel(p - Vec3::X * e).x
                + v.accel(p + Vec3::Y * e).y
                - v.accel(p - Vec3::Y * e).y
                + v.accel(p + Vec3::Z * e).z
                - v.accel(p - Vec3::Z * e).z)
                / (2.0 * e);
            worst = worst.max(div.abs());
            typical += v.accel(p).length() / 100.0;
        }
        assert!(typical > 0.05, "{typical}");
        assert!(worst < 1e-3, "{worst}");
        let w = Vortex::new(7, Vec3::new(22.0, 5.5, 22.0), 7.32);
        let p = Vec3::new(1.0, 2.0, 3.0);
        assert!((w.accel(p) - 2.0 * v.accel(p)).length() < 1e-5);
    }
}
