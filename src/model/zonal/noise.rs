//! The inherent-noise force F_ξ of paper 002 (Eq. 4) and the three alternatives its noise
//! comparison plugs in instead (Fig. 10).
//!
//! The paper's Perlin field is P(r) = gain · (P₁, P₂, P₃)(r / scale) and its curl noise
//! C(r) = ∇ × P(r) = (gain / scale) ∇_ξ × (P₁, P₂, P₃)(ξ), ξ = r / scale: an acceleration
//! when gain is in m²/s² and scale in m. For the comparison to vary the noise and nothing
//! else, the other three are given the same magnitude gain / scale (m/s²): Perlin noise
//! (gain / scale)·(P₁, P₂, P₃)(ξ), white noise λ·U[−1, 1]³ and the paper's Box–Muller
//! Gaussian λ·√(−2 ln W₁)·sin(2π W₂) per component, with λ = gain / scale, drawn afresh
//! each step from the agent's deterministic stream.

use crate::field::noise::{LatticePoint, Perlin, gradients3};
use crate::math::Rng;
use glam::Vec3;

/// Which random force an agent feels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseKind {
    Curl,
    White,
    Gaussian,
    Perlin,
}

impl NoiseKind {
    /// From the `noise` parameter: 0 curl, 1 white, 2 Gaussian, 3 Perlin.
    pub fn from_param(x: f64) -> Self {
        match x.round() as i64 {
            1 => NoiseKind::White,
            2 => NoiseKind::Gaussian,
            3 => NoiseKind::Perlin,
            _ => NoiseKind::Curl,
        }
    }
}

/// A swarm's noise force.
#[derive(Clone, Debug)]
pub struct Noise {
    kind: NoiseKind,
    potentials: [Perlin; 3],
    inv_scale: f32,
    /// gain / scale, m/s².
    magnitude: f32,
}

impl Noise {
    pub fn new(kind: NoiseKind, seed: u64, scale: f64, gain: f64) -> Self {
        Noise {
            kind,
            potentials: [
                Perlin::new(seed),
                Perlin::new(seed ^ 0x1111),
                Perlin::new(seed ^ 0x2222),
            ],
            inv_scale: (1.0 / scale) as f32,
            magnitude: (gain / scale) as f32,
        }
    }

    /// F_ξ at `p` (m), m/s²; `rng` is the agent's stream for this step (white and Gaussian).
    pub fn force(&self, p: Vec3, rng: &mut Rng) -> Vec3 {
        match self.kind {
            NoiseKind::Curl => {
                let [g1, g2, g3] =
                    gradients3(&self.potentials, &LatticePoint::new(p * self.inv_scale));
                Vec3::new(g3.y - g2.z, g1.z - g3.x, g2.x - g1.y) * self.magnitude
            }
            NoiseKind::Perlin => {
                let xi = p * self.inv_scale;
                Vec3::new(
                    self.potentials[0].sample(xi).0,
                    self.potentials[1].sample(xi).0,
                    self.potentials[2].sample(xi).0,
                ) * self.magnitude
            }
            NoiseKind::White => {
                Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                ) * self.magnitude
            }
            NoiseKind::Gaussian => {
                let mut g = || {
                    // W₁ in (0, 1] so that the logarithm is finite.
                    let w1 = 1.0 - rng.f32();
                    let w2 = rng.f32();
                    (-2.0 * w1.ln()).sqrt() * (std::f32::consts::TAU * w2).sin()
                };
                Vec3::new(g(), g(), g()) * self.magnitude
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curl_noise_is_divergence_free_and_scales_with_gain_over_scale() {
        let n = Noise::new(NoiseKind::Curl, 3, 0.1, 0.02);
        let mut rng = Rng::new(1, 2, 3);
        let e = 1e-4f32;
        let mut worst = 0.0f32;
        let mut sum = 0.0f32;
        for k in 0..200 {
            let p = Vec3::new(
                k as f32 * 0.0137,
                (k % 7) as f32 * 0.021,
                (k % 5) as f32 * 0.033,
            );
            let mut div = 0.0;
            for a in [Vec3::X, Vec3::Y, Vec3::Z] {
                div += (n.force(p + a * e, &mut rng) - n.force(p - a * e, &mut rng)).dot(a)
                    / (2.0 * e);
            }
            worst = worst.max(div.abs());
            sum += n.force(p, &mut rng).length();
        }
        // |div| relative to the field's gradient scale (magnitude / scale = 2 /s² per m).
        assert!(worst * 0.1 / 0.2 < 0.02, "div {worst}");
        let mean = sum / 200.0;
        assert!(
            mean > 0.05 && mean < 1.0,
            "mean |C| {mean} for gain/scale = 0.2"
        );
    }

    #[test]
    fn white_and_gaussian_noise_have_zero_mean_and_the_given_size() {
        for kind in [NoiseKind::White, NoiseKind::Gaussian] {
            let n = Noise::new(kind, 3, 0.5, 1.0);
            let mut rng = Rng::new(9, 9, 9);
            let (mut sum, mut sq) = (Vec3::ZERO, 0.0f64);
            let count = 20_000;
            for _ in 0..count {
                let f = n.force(Vec3::ZERO, &mut rng);
                sum += f;
                sq += (f.x * f.x) as f64;
            }
            let mean = sum / count as f32;
            let sd = (sq / count as f64).sqrt();
            // λ = 2: white U[−2, 2] has sd 2/√3; the Box–Muller sine form has sd 2.
            let want = if kind == NoiseKind::White {
                2.0 / 3f64.sqrt()
            } else {
                2.0
            };
            assert!(mean.length() < 0.06, "{kind:?} mean {mean}");
            assert!(
                (sd - want).abs() < 0.05 * want,
                "{kind:?} sd {sd} vs {want}"
            );
        }
    }
}
