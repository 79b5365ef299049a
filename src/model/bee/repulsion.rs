//! Repulsion between bees, and between bees and targets, from SPH pressure
//! (paper 000 Sec. V-B, Eq. 10–11).
//!
//! Bees are capsules of radius r: the kernel distance is s = max(|rᵢ − rⱼ| − 2r, 0).
//! Density (Eq. 10): ρᵢ = Σⱼ mⱼ W_poly6(s, h). Pressure: pᵢ = k (ρᵢ − ρ₀) with ρ₀ the
//! density of a lone bee, clamped at 0 so neighbours only ever push (no tensile pull).
//! Force (Eq. 11, Müller's symmetric form, see docs/model.md):
//! aᵢ = −Σⱼ mⱼ (pᵢ + pⱼ) / (2 ρᵢ ρⱼ) ∇W_spiky(s, h).

use super::kernels::Kernels;
use glam::Vec3;

/// Kernel distance between two capsule bodies (or a body and a point).
#[inline]
pub fn kernel_distance(dist: f32, contact: f32) -> f32 {
    (dist - contact).max(0.0)
}

/// One neighbour's contribution to the density (Eq. 10).
#[inline]
pub fn density_term(k: &Kernels, mass_j: f32, dist: f32, contact: f32) -> f32 {
    mass_j * k.poly6(kernel_distance(dist, contact))
}

/// Pressure from density (equation of state), clamped to push only.
#[inline]
pub fn pressure(stiffness: f32, density: f32, rest_density: f32) -> f32 {
    stiffness * (density - rest_density).max(0.0)
}

/// One neighbour's contribution to the repulsion acceleration (Eq. 11).
/// `r` is (bee − neighbour); `fallback` gives the direction that separates coincident
/// bodies deterministically (only called when they coincide).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn pressure_term(
    k: &Kernels,
    r: Vec3,
    dist: f32,
    contact: f32,
    mass_j: f32,
    p_i: f32,
    p_j: f32,
    rho_i: f32,
    rho_j: f32,
    fallback: impl FnOnce() -> Vec3,
) -> Vec3 {
    let s = kernel_distance(dist, contact);
    if s >= k.h || rho_i <= 0.0 || rho_j <= 0.0 || p_i + p_j <= 0.0 {
        return Vec3::ZERO;
    }
    let dir = if dist > 1e-9 { r / dist } else { fallback() };
    // −∇W_spiky points away from the neighbour: the push is along `dir`.
    dir * (k.spiky_grad_mag(s) * mass_j * (p_i + p_j) / (2.0 * rho_i * rho_j))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pressure_pushes_bees_apart() {
        let k = Kernels::new(0.15);
        let m = 1e-4;
        let rho0 = density_term(&k, m, 0.0, 0.004);
        let d = 0.05;
        let rho = rho0 + density_term(&k, m, d, 0.004);
        let p = pressure(1.0, rho, rho0);
        assert!(p > 0.0);
        let a = pressure_term(&k, Vec3::X * d, d, 0.004, m, p, p, rho, rho, || Vec3::Y);
        assert!(a.x > 0.0 && a.y == 0.0, "{a}");
        // Coincident bees still get a finite push.
        let a0 = pressure_term(&k, Vec3::ZERO, 0.0, 0.004, m, p, p, rho, rho, || Vec3::Y);
        assert!(a0.is_finite() && a0.y > 0.0);
    }
}
