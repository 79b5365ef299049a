//! The boundaries of paper 001's noise field (Sec. 4): the shot's obstacles, the domain box
//! seen from inside ("extended boundaries … to avoid them flying too far away") and goal
//! bodies that move (the chasing scene's ball). Each gives the distance d from a point to
//! its surface, the unit normal n = ∇d pointing into free space, and the derivative of n
//! along a vector (the distance field's Hessian times it), which Eq. 1's curl needs.
//!
//! Metres; world Y-up.

use crate::geometry::{self, Shape};
use glam::Vec3;

/// One boundary of the noise field.
#[derive(Clone, Debug, PartialEq)]
pub enum Boundary {
    /// An obstacle of the shot (free space outside it).
    Shape(Shape),
    /// The simulation domain: an axis-aligned box (centre, half extents), free inside.
    Domain { center: Vec3, half: Vec3 },
    /// A goal's body: a sphere that may move between substeps.
    Ball { center: Vec3, radius: f32 },
}

/// Where a point stands relative to its nearest boundary.
#[derive(Clone, Copy, Debug)]
pub struct Near<'a> {
    /// Distance to the surface, m; negative inside the boundary.
    pub d: f32,
    /// Unit normal pointing into free space: ∇d.
    pub n: Vec3,
    pub boundary: &'a Boundary,
}

impl Boundary {
    /// Signed distance (positive in free space) and normal n = ∇d at `p`.
    #[inline]
    pub fn query(&self, p: Vec3) -> (f32, Vec3) {
        match *self {
            Boundary::Shape(ref s) => {
                let q = geometry::query(s, p);
                (q.distance, q.normal)
            }
            Boundary::Domain { center, half } => {
                // Distance to the nearest face from inside; the normal points inwards.
                let l = p - center;
                let room = half - l.abs();
                let axis = if room.x <= room.y && room.x <= room.z {
                    0
                } else if room.y <= room.z {
                    1
                } else {
                    2
                };
                let mut n = Vec3::ZERO;
                n[axis] = if l[axis] >= 0.0 { -1.0 } else { 1.0 };
                (room[axis], n)
            }
            Boundary::Ball { center, radius } => {
                let r = p - center;
                let len = r.length();
                let n = if len > 1e-9 { r / len } else { Vec3::Y };
                (len - radius, n)
            }
        }
    }

    /// (∇n) v: how the normal turns along `v` (the distance field's Hessian times v).
    /// Exact for planes, the domain's faces and balls; for other shapes a central
    /// difference of the normal over ±`eps` along v, which bounds the curvature near
    /// sharp edges, where the exact value grows without limit (1/ρ at distance ρ).
    #[inline]
    pub fn normal_derivative(&self, p: Vec3, n: Vec3, v: Vec3, eps: f32) -> Vec3 {
        match *self {
            Boundary::Domain { .. } => Vec3::ZERO,
            Boundary::Shape(Shape::Plane { .. }) => Vec3::ZERO,
            Boundary::Ball { center, .. } => {
                let rho = (p - center).length().max(eps);
                (v - n * n.dot(v)) / rho
            }
            Boundary::Shape(ref s) => {
                let len = v.length();
                if len < 1e-12 {
                    return Vec3::ZERO;
                }
                let u = v / len * eps;
                let a = geometry::query(s, p + u).normal;
                let b = geometry::query(s, p - u).normal;
                (a - b) * (len / (2.0 * eps))
            }
        }
    }
}

/// The boundary nearest `p` among `lists`, if any lies within `reach`.
#[inline]
pub fn nearest<'a>(lists: [&'a [Boundary]; 2], p: Vec3, reach: f32) -> Option<Near<'a>> {
    nearest_and_clearance(lists, p, reach).0
}

/// [`nearest`], and the distance from `p` to the nearest obstacle (`Boundary::Shape`),
/// whatever its distance (infinite without obstacles).
#[inline]
pub fn nearest_and_clearance<'a>(
    lists: [&'a [Boundary]; 2],
    p: Vec3,
    reach: f32,
) -> (Option<Near<'a>>, f32) {
    let mut best: Option<Near<'a>> = None;
    let mut clearance = f32::INFINITY;
    for b in lists.into_iter().flatten() {
        let (d, n) = b.query(p);
        if matches!(b, Boundary::Shape(_)) {
            clearance = clearance.min(d);
        }
        if d < reach && best.as_ref().is_none_or(|x| d < x.d) {
            best = Some(Near { d, n, boundary: b });
        }
    }
    (best, clearance)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_domain_normal_points_inwards_from_the_nearest_face() {
        let b = Boundary::Domain {
            center: Vec3::ZERO,
            half: Vec3::new(1.0, 2.0, 3.0),
        };
        let (d, n) = b.query(Vec3::new(0.9, 0.0, 0.0));
        assert!((d - 0.1).abs() < 1e-6 && n == -Vec3::X);
        let (d, n) = b.query(Vec3::new(0.0, -1.95, 0.0));
        assert!((d - 0.05).abs() < 1e-6 && n == Vec3::Y);
    }

    #[test]
    fn the_normal_derivative_of_a_sphere_matches_the_exact_hessian() {
        let s = Boundary::Shape(Shape::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        });
        let ball = Boundary::Ball {
            center: Vec3::ZERO,
            radius: 1.0,
        };
        let p = Vec3::new(1.2, 0.3, -0.1);
        let (_, n) = s.query(p);
        let v = Vec3::new(0.2, -0.5, 0.7);
        let fd = s.normal_derivative(p, n, v, 1e-3);
        let exact = ball.normal_derivative(p, n, v, 1e-3);
        assert!(
            (fd - exact).length() < 1e-3 * exact.length().max(1.0),
            "{fd} {exact}"
        );
    }
}
