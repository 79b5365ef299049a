//! SPH smoothing kernels of Müller et al. 2003 (used by Eq. 10–11), 3D, radius h.

use glam::Vec3;
use std::f32::consts::PI;

/// Both kernels for one radius h, with their normalisation constants computed once.
#[derive(Clone, Copy, Debug)]
pub struct Kernels {
    pub h: f32,
    h2: f32,
    poly6_coef: f32,
    spiky_coef: f32,
}

impl Kernels {
    pub fn new(h: f32) -> Self {
        Kernels {
            h,
            h2: h * h,
            poly6_coef: 315.0 / (64.0 * PI * h.powi(9)),
            spiky_coef: 45.0 / (PI * h.powi(6)),
        }
    }
    /// Poly6 W(s) for kernel distance s ≥ 0.
    #[inline]
    pub fn poly6(&self, s: f32) -> f32 {
        if s >= self.h {
            return 0.0;
        }
        let x = self.h2 - s * s;
        self.poly6_coef * x * x * x
    }
    /// 315 / (64 π h⁹), Poly6's factor (`pairs` works the kernel out itself).
    #[inline]
    pub fn poly6_coef(&self) -> f32 {
        self.poly6_coef
    }
    /// 45 / (π h⁶), the spiky gradient's factor (`pairs` works the gradient out itself).
    #[inline]
    pub fn spiky_coef(&self) -> f32 {
        self.spiky_coef
    }
    /// −dW_spiky/ds for kernel distance s ≥ 0.
    #[inline]
    pub fn spiky_grad_mag(&self, s: f32) -> f32 {
        if s >= self.h {
            return 0.0;
        }
        let x = self.h - s;
        self.spiky_coef * x * x
    }
}

/// Poly6 kernel W(s, h) = 315 / (64 π h⁹) (h² − s²)³ for 0 ≤ s ≤ h, else 0.
#[inline]
pub fn poly6(s: f32, h: f32) -> f32 {
    if !(0.0..h).contains(&s) && s != 0.0 {
        return 0.0;
    }
    let s = s.max(0.0);
    let x = h * h - s * s;
    315.0 / (64.0 * PI * h.powi(9)) * x * x * x
}

/// Magnitude of the spiky kernel gradient, −dW/ds = 45 / (π h⁶) (h − s)², for 0 ≤ s ≤ h.
/// The gradient itself points from the neighbour towards the particle times −this.
#[inline]
pub fn spiky_grad_mag(s: f32, h: f32) -> f32 {
    if s >= h {
        return 0.0;
    }
    let x = h - s.max(0.0);
    45.0 / (PI * h.powi(6)) * x * x
}

/// ∇W_spiky at offset `r` (particle minus neighbour) for kernel distance `s`.
#[inline]
pub fn spiky_grad(r: Vec3, dist: f32, s: f32, h: f32, fallback: Vec3) -> Vec3 {
    let dir = if dist > 1e-9 { r / dist } else { fallback };
    -dir * spiky_grad_mag(s, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ f(|x|) d³x over the ball of radius h, by the radial integral 4π ∫ s² f(s) ds.
    fn radial_integral(f: impl Fn(f32) -> f32, h: f32) -> f64 {
        let n = 20000;
        let ds = h as f64 / n as f64;
        (0..n)
            .map(|i| {
                let s = (i as f64 + 0.5) * ds;
                4.0 * std::f64::consts::PI * s * s * f(s as f32) as f64 * ds
            })
            .sum()
    }

    #[test]
    fn poly6_is_normalised() {
        for h in [0.05, 0.15, 1.0, 3.0] {
            let i = radial_integral(|s| poly6(s, h), h);
            assert!((i - 1.0).abs() < 1e-3, "h={h}: {i}");
        }
    }

    #[test]
    fn spiky_is_normalised() {
        // The spiky kernel W = 15/(π h⁶)(h − s)³ integrates to 1; check via its gradient:
        // W(s) = ∫_s^h |∇W| ds'.
        for h in [0.05f32, 0.15, 1.0] {
            let w = |s: f32| {
                let n = 2000;
                let ds = (h - s) / n as f32;
                (0..n)
                    .map(|i| spiky_grad_mag(s + (i as f32 + 0.5) * ds, h) * ds)
                    .sum::<f32>()
            };
            let i = radial_integral(w, h);
            assert!((i - 1.0).abs() < 2e-3, "h={h}: {i}");
        }
    }

    #[test]
    fn precomputed_kernels_equal_the_formulas() {
        let k = Kernels::new(0.15);
        for i in 0..20 {
            let s = i as f32 * 0.01;
            assert!((k.poly6(s) - poly6(s, 0.15)).abs() <= 1e-6 * poly6(0.0, 0.15));
            assert!(
                (k.spiky_grad_mag(s) - spiky_grad_mag(s, 0.15)).abs()
                    <= 1e-6 * spiky_grad_mag(0.0, 0.15)
            );
        }
    }

    #[test]
    fn kernels_vanish_outside_the_support() {
        assert_eq!(poly6(0.2, 0.15), 0.0);
        assert_eq!(spiky_grad_mag(0.15, 0.15), 0.0);
        assert!(poly6(0.0, 0.15) > 0.0);
        assert!(spiky_grad(Vec3::ZERO, 0.0, 0.0, 0.1, Vec3::Y).is_finite());
    }
}
