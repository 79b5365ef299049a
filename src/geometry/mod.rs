//! Obstacle geometry, below both `shot` (validation) and `sim` (flight): the shapes, and
//! their signed distance, closest surface point and outward normal.
//! Distances in metres; negative inside. Degenerate inputs (a point exactly on an axis or
//! at a centre) get a well-defined normal instead of NaN.

pub mod grid;
pub mod mesh;

use glam::{Quat, Vec3};
pub use grid::{Found, Grid};

/// Obstacle geometry. Rotations are body → world. Cloning is cheap: a mesh is shared, not
/// copied.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Sphere {
        center: Vec3,
        radius: f32,
    },
    /// Oriented box: centre, half extents, rotation.
    Box {
        center: Vec3,
        half: Vec3,
        rotation: Quat,
    },
    /// A shaft: segment a–b with round ends.
    Capsule {
        a: Vec3,
        b: Vec3,
        radius: f32,
    },
    /// Flat-capped cylinder along its local +Y, `half_height` each way from the centre.
    Cylinder {
        center: Vec3,
        radius: f32,
        half_height: f32,
        rotation: Quat,
    },
    /// Infinite plane through `point`; bees stay on the `normal` side.
    Plane {
        point: Vec3,
        normal: Vec3,
    },
    /// A triangle mesh (see [`mesh`]). Shared by every thread and every copy of the shot
    /// through the `Arc`, freed with the last of them. `pose: None`: the mesh is built in
    /// world space and never moves. `Some`: it is built in its rest frame and `pose`
    /// places it in the world now (a keyframed obstacle; the world sets it each substep).
    Mesh {
        mesh: std::sync::Arc<mesh::Mesh>,
        pose: Option<Rigid>,
    },
}

/// A rigid placement, rest frame → world: rotate about the rest frame's origin, then
/// translate. Metres; `rotation` a unit quaternion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    pub rotation: Quat,
    pub translation: Vec3,
}

impl Rigid {
    /// A world point in the rest frame.
    #[inline]
    pub fn to_rest(&self, p: Vec3) -> Vec3 {
        // The conjugate is the inverse of a unit quaternion.
        self.rotation.conjugate() * (p - self.translation)
    }
    /// A rest-frame point in the world.
    #[inline]
    pub fn to_world(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.translation
    }
}

/// Euler angles in degrees as a rotation: first about X, then Y, then Z, about world axes
/// (R = Rz · Ry · Rx, Blender's 'XYZ'): the convention of every `rotation` in a shot.
pub fn euler_deg(v: Vec3) -> Quat {
    let r = v * (std::f32::consts::PI / 180.0);
    Quat::from_rotation_z(r.z) * Quat::from_rotation_y(r.y) * Quat::from_rotation_x(r.x)
}

/// Where a point stands relative to an obstacle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceQuery {
    /// Signed distance to the surface, m (negative inside).
    pub distance: f32,
    /// Closest point on the surface.
    pub point: Vec3,
    /// Unit outward normal at that point.
    pub normal: Vec3,
}

/// A unit vector along `v`, or `fallback` when `v` is (nearly) zero.
fn dir_or(v: Vec3, fallback: Vec3) -> Vec3 {
    let l = v.length();
    if l > 1e-9 { v / l } else { fallback }
}

/// `n` unit directions spread evenly over the sphere (a Fibonacci lattice).
pub fn fibonacci_sphere(n: usize) -> impl Iterator<Item = Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n).map(move |i| {
        let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
        let r = (1.0 - y * y).max(0.0).sqrt();
        let a = golden * i as f32;
        Vec3::new(r * a.cos(), y, r * a.sin())
    })
}

/// Points evenly spread on a sphere about `spacing` apart (12 to 2,000 of them): the
/// static virtual particles that sample a target's body (paper 000 Sec. V-B).
pub fn sphere_samples(center: Vec3, radius: f32, spacing: f32) -> Vec<Vec3> {
    let area = 4.0 * std::f32::consts::PI * radius * radius;
    let n = ((area / (spacing * spacing)).ceil() as usize).clamp(12, 2000);
    fibonacci_sphere(n).map(|d| center + d * radius).collect()
}

/// The point nearest `p`, among a fixed set of candidates on spheres of growing radius
/// around it (deterministic, no randomness), that lies at least `clearance` outside every
/// shape; `p` itself when it already does, `None` when nothing within a kilometre does.
/// For placing a body where overlapping obstacles leave no room at the obvious spot.
pub fn free_point_near(shapes: &[Shape], p: Vec3, clearance: f32) -> Option<Vec3> {
    let free = |q: Vec3| shapes.iter().all(|s| signed_distance(s, q) >= clearance);
    if free(p) {
        return Some(p);
    }
    // 64 directions spread over the sphere, radii growing from the clearance up to a
    // kilometre.
    let mut radius = clearance.max(1e-4);
    while radius < 1000.0 {
        if let Some(q) = fibonacci_sphere(64)
            .map(|d| p + d * radius)
            .find(|q| free(*q))
        {
            return Some(q);
        }
        radius *= 1.5;
    }
    None
}

pub fn signed_distance(shape: &Shape, p: Vec3) -> f32 {
    query(shape, p).distance
}

pub fn query(shape: &Shape, p: Vec3) -> SurfaceQuery {
    match *shape {
        Shape::Mesh {
            ref mesh,
            pose: None,
        } => mesh.query(p),
        // A moving mesh is asked in its rest frame, where its hierarchy and far-field
        // grid were built; the answer is carried back (distances are unchanged by a
        // rigid motion).
        Shape::Mesh {
            ref mesh,
            pose: Some(pose),
        } => {
            let q = mesh.query(pose.to_rest(p));
            SurfaceQuery {
                distance: q.distance,
                point: pose.to_world(q.point),
                normal: pose.rotation * q.normal,
            }
        }
        Shape::Sphere { center, radius } => {
            let n = dir_or(p - center, Vec3::Y);
            SurfaceQuery {
                distance: (p - center).length() - radius,
                point: center + n * radius,
                normal: n,
            }
        }
        Shape::Plane { point, normal } => {
            let d = (p - point).dot(normal);
            SurfaceQuery {
                distance: d,
                point: p - normal * d,
                normal,
            }
        }
        Shape::Capsule { a, b, radius } => {
            let ab = b - a;
            let t = if ab.length_squared() > 1e-12 {
                ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let c = a + ab * t;
            // Any direction perpendicular to the axis serves on the axis itself.
            let n = dir_or(p - c, dir_or(ab.any_orthonormal_vector(), Vec3::Y));
            SurfaceQuery {
                distance: (p - c).length() - radius,
                point: c + n * radius,
                normal: n,
            }
        }
        Shape::Box {
            center,
            half,
            rotation,
        } => {
            let inv = rotation.inverse();
            let q = box_local(inv * (p - center), half);
            SurfaceQuery {
                distance: q.distance,
                point: center + rotation * q.point,
                normal: rotation * q.normal,
            }
        }
        Shape::Cylinder {
            center,
            radius,
            half_height,
            rotation,
        } => {
            let inv = rotation.inverse();
            let q = cylinder_local(inv * (p - center), radius, half_height);
            SurfaceQuery {
                distance: q.distance,
                point: center + rotation * q.point,
                normal: rotation * q.normal,
            }
        }
    }
}

/// Axis-aligned box centred at the origin.
fn box_local(p: Vec3, half: Vec3) -> SurfaceQuery {
    let d = p.abs() - half;
    if d.max_element() > 0.0 {
        // Outside: clamp onto the box.
        let c = p.clamp(-half, half);
        let n = dir_or(p - c, Vec3::Y);
        SurfaceQuery {
            distance: (p - c).length(),
            point: c,
            normal: n,
        }
    } else {
        // Inside: leave through the nearest face.
        let axis = if d.x >= d.y && d.x >= d.z {
            0
        } else if d.y >= d.z {
            1
        } else {
            2
        };
        let mut n = Vec3::ZERO;
        let s = if p[axis] >= 0.0 { 1.0 } else { -1.0 };
        n[axis] = s;
        let mut c = p;
        c[axis] = s * half[axis];
        SurfaceQuery {
            distance: d[axis],
            point: c,
            normal: n,
        }
    }
}

/// Cylinder along local Y centred at the origin.
fn cylinder_local(p: Vec3, radius: f32, hh: f32) -> SurfaceQuery {
    let radial = Vec3::new(p.x, 0.0, p.z);
    let r = radial.length();
    let rdir = dir_or(radial, Vec3::X);
    let dr = r - radius;
    let dy = p.y.abs() - hh;
    let sy = if p.y >= 0.0 { 1.0 } else { -1.0 };
    if dr > 0.0 || dy > 0.0 {
        // Outside: the closest point is on the side, a cap, or the rim.
        let c = rdir * r.min(radius) + Vec3::Y * p.y.clamp(-hh, hh);
        let n = dir_or(p - c, if dr > dy { rdir } else { Vec3::Y * sy });
        SurfaceQuery {
            distance: (p - c).length(),
            point: c,
            normal: n,
        }
    } else if dr > dy {
        SurfaceQuery {
            distance: dr,
            point: rdir * radius + Vec3::Y * p.y,
            normal: rdir,
        }
    } else {
        SurfaceQuery {
            distance: dy,
            point: Vec3::new(p.x, sy * hh, p.z),
            normal: Vec3::Y * sy,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_samples_lie_on_the_sphere() {
        let s = sphere_samples(Vec3::ONE, 0.1, 0.03);
        assert!(s.len() >= 12);
        assert!(
            s.iter()
                .all(|p| ((*p - Vec3::ONE).length() - 0.1).abs() < 1e-5)
        );
    }
    use glam::Quat;

    fn check_consistent(shape: &Shape, p: Vec3) {
        let q = query(shape, p);
        assert!(
            q.distance.is_finite() && q.point.is_finite() && q.normal.is_finite(),
            "{shape:?} at {p}"
        );
        assert!((q.normal.length() - 1.0).abs() < 1e-4);
        // The closest point lies on the surface.
        assert!(
            signed_distance(shape, q.point).abs() < 1e-4,
            "{shape:?} at {p}: {q:?}"
        );
        // Stepping along the normal from the closest point moves outward by that much.
        let out = q.point + q.normal * 0.01;
        assert!(
            (signed_distance(shape, out) - 0.01).abs() < 2e-3,
            "{shape:?} at {p}: {q:?}"
        );
    }

    #[test]
    fn every_shape_gives_consistent_points_and_normals_including_degenerate_points() {
        let shapes = [
            Shape::Sphere {
                center: Vec3::ONE,
                radius: 0.5,
            },
            Shape::Plane {
                point: Vec3::ZERO,
                normal: Vec3::Y,
            },
            Shape::Capsule {
                a: Vec3::ZERO,
                b: Vec3::Y,
                radius: 0.1,
            },
            Shape::Capsule {
                a: Vec3::ZERO,
                b: Vec3::ZERO,
                radius: 0.1,
            },
            Shape::Box {
                center: Vec3::new(0.0, 1.0, 0.0),
                half: Vec3::new(0.5, 0.2, 0.3),
                rotation: Quat::from_rotation_y(0.7),
            },
            Shape::Cylinder {
                center: Vec3::ZERO,
                radius: 0.2,
                half_height: 0.5,
                rotation: Quat::from_rotation_z(0.3),
            },
        ];
        let pts = [
            Vec3::ZERO,
            Vec3::ONE,
            Vec3::new(0.0, 0.5, 0.0),
            Vec3::new(0.3, 0.9, -0.2),
            Vec3::new(2.0, -1.0, 0.5),
            Vec3::new(0.05, 0.2, 0.0),
        ];
        for s in &shapes {
            for p in pts {
                check_consistent(s, p);
            }
        }
    }

    #[test]
    fn signs_are_negative_inside() {
        let c = Shape::Cylinder {
            center: Vec3::ZERO,
            radius: 0.2,
            half_height: 0.5,
            rotation: Quat::IDENTITY,
        };
        assert!(signed_distance(&c, Vec3::new(0.1, 0.0, 0.0)) < 0.0);
        assert!((signed_distance(&c, Vec3::new(0.5, 0.0, 0.0)) - 0.3).abs() < 1e-6);
        let b = Shape::Box {
            center: Vec3::ZERO,
            half: Vec3::ONE,
            rotation: Quat::IDENTITY,
        };
        assert!((signed_distance(&b, Vec3::new(0.5, 0.0, 0.0)) + 0.5).abs() < 1e-6);
    }
}
