//! The honeybee's geometry (glTF meshes and USD prototype), shared by every bee: a striped body and two
//! translucent wings.
//!
//! Real scale: the body is exactly `length` metres long along +X (head at +X), centred on
//! the body node's origin, so the body node's world position is the bee's centre as
//! simulated. Body frame as everywhere: X forward, Y up, Z right.
//!
//! The body is a surface of revolution around X: head, thorax and abdomen are ellipsoids
//! and the profile is their upper envelope, which gives the narrow waists for free. It is
//! cut into colour bands (two primitives, yellow and black) so the stripes survive any
//! importer: vertex colours are not shaded by default in several DCCs, materials are.

use crate::species::Primitive;
use glam::Vec3;

/// The bee prototype for one body length.
#[derive(Clone, Debug, PartialEq)]
pub struct BeeMesh {
    /// Body bands drawn with the yellow material.
    pub body_yellow: Primitive,
    /// Body bands drawn with the black material.
    pub body_black: Primitive,
    /// Right wing, hinge at its origin, lying in its XZ plane, tip towards +Z.
    pub wing_right: Primitive,
    /// Mirror image of the right wing (tip towards -Z).
    pub wing_left: Primitive,
    /// Where the right wing hinge sits in the body frame (left: z negated).
    pub wing_hinge_right: Vec3,
}

/// Ellipsoid of revolution about X: centre x, half length, radius — all in body lengths.
struct Lobe {
    cx: f32,
    a: f32,
    b: f32,
}

/// Head (front), thorax, abdomen; spans exactly x ∈ [-0.5, 0.5].
const PARTS: [Lobe; 3] = [
    Lobe {
        cx: 0.40,
        a: 0.10,
        b: 0.11,
    },
    Lobe {
        cx: 0.17,
        a: 0.13,
        b: 0.15,
    },
    Lobe {
        cx: -0.20,
        a: 0.30,
        b: 0.17,
    },
];

/// Colour bands from tail to head: (x where the band ends, is yellow). Abdomen stripes,
/// golden thorax, dark head.
const BANDS: [(f32, bool); 9] = [
    (-0.40, false), // sting end
    (-0.31, true),
    (-0.24, false),
    (-0.15, true),
    (-0.08, false),
    (0.02, true),
    (0.06, false), // petiole (waist)
    (0.30, true),  // thorax
    (0.50, false), // head
];

/// Vertices around each ring of the body.
const SEGMENTS: usize = 14;
/// Rings per body length (bands add their own boundary rings).
const RINGS_PER_LENGTH: f32 = 48.0;

/// The part whose surface is outermost at `x` (body lengths) and its radius there.
fn profile(x: f32) -> (&'static Lobe, f32) {
    let mut best = (&PARTS[0], 0.0f32);
    for p in &PARTS {
        let u = (x - p.cx) / p.a;
        let r = if u.abs() < 1.0 {
            p.b * (1.0 - u * u).sqrt()
        } else {
            0.0
        };
        if r > best.1 {
            best = (p, r);
        }
    }
    best
}

/// The surface point and outward normal at body-length coordinate `x`, angle `phi`.
/// The normal is the ellipsoid gradient, which stays finite at the tips.
fn surface(x: f32, phi: f32) -> (Vec3, Vec3) {
    let (part, r) = profile(x);
    let (s, c) = phi.sin_cos();
    let p = Vec3::new(x, r * c, r * s);
    let n = Vec3::new(
        (x - part.cx) / (part.a * part.a),
        r * c / (part.b * part.b),
        r * s / (part.b * part.b),
    );
    (p, n)
}

fn body_band(prim: &mut Primitive, x0: f32, x1: f32, length: f32) {
    let steps = (((x1 - x0) * RINGS_PER_LENGTH).ceil() as usize).max(1);
    let mut prev: Option<Vec<u16>> = None;
    for i in 0..=steps {
        let x = x0 + (x1 - x0) * i as f32 / steps as f32;
        let (_, r) = profile(x);
        // A zero-radius ring is a tip: one apex vertex avoids degenerate triangles.
        let ring: Vec<u16> = if r < 1e-4 {
            let (p, n) = surface(x, 0.0);
            vec![prim.vertex(p * length, n)]
        } else {
            (0..SEGMENTS)
                .map(|j| {
                    let phi = std::f32::consts::TAU * j as f32 / SEGMENTS as f32;
                    let (p, n) = surface(x, phi);
                    prim.vertex(p * length, n)
                })
                .collect()
        };
        if let Some(prev) = prev {
            match (prev.len(), ring.len()) {
                (1, 1) => {}
                (1, _) | (_, 1) => {
                    let (apex, rim) = if prev.len() == 1 {
                        (prev[0], &ring)
                    } else {
                        (ring[0], &prev)
                    };
                    for j in 0..SEGMENTS {
                        prim.triangle(apex, rim[j], rim[(j + 1) % SEGMENTS]);
                    }
                }
                _ => {
                    for j in 0..SEGMENTS {
                        let k = (j + 1) % SEGMENTS;
                        prim.triangle(prev[j], ring[j], ring[k]);
                        prim.triangle(prev[j], ring[k], prev[k]);
                    }
                }
            }
        }
        prev = Some(ring);
    }
}

/// Wing outline points: an ellipse from the hinge to the tip, swept back, in body lengths.
fn wing(length: f32, mirror: bool) -> Primitive {
    const SPAN: f32 = 0.70; // a honeybee forewing is about 3/4 of its body length
    const CHORD: f32 = 0.24;
    const SWEEP_DEG: f32 = 18.0; // tip trails behind the hinge
    const OUTLINE: usize = 20;
    let (ss, cs) = SWEEP_DEG.to_radians().sin_cos();
    let z_sign = if mirror { -1.0 } else { 1.0 };
    let place = |x: f32, z: f32| {
        // Sweep about Y so +Z (the tip) swings towards -X (backwards).
        let (x, z) = (x * cs - z * ss, x * ss + z * cs);
        // `+ 0.0` turns the mirrored hinge's -0.0 into 0.0 for tidy JSON bounds.
        Vec3::new(x * length, 0.0, z * z_sign * length + 0.0)
    };
    let mut prim = Primitive::default();
    let up = Vec3::Y;
    let centre = prim.vertex(place(0.0, SPAN / 2.0), up);
    let rim: Vec<u16> = (0..OUTLINE)
        .map(|k| {
            let t = std::f32::consts::TAU * k as f32 / OUTLINE as f32;
            // k = 0 is the hinge (z = 0), so the wing pivots about its own root.
            let z = SPAN / 2.0 * (1.0 - t.cos());
            let x = CHORD / 2.0 * t.sin();
            prim.vertex(place(x, z), up)
        })
        .collect();
    for k in 0..OUTLINE {
        prim.triangle(centre, rim[k], rim[(k + 1) % OUTLINE]);
    }
    prim
}

impl BeeMesh {
    /// Builds the bee for a body `length` in metres.
    pub fn new(length: f32) -> BeeMesh {
        let mut body_yellow = Primitive::default();
        let mut body_black = Primitive::default();
        let mut x0 = -0.5;
        for (x1, yellow) in BANDS {
            let prim = if yellow {
                &mut body_yellow
            } else {
                &mut body_black
            };
            body_band(prim, x0, x1, length);
            x0 = x1;
        }
        BeeMesh {
            body_yellow,
            body_black,
            wing_right: wing(length, false),
            wing_left: wing(length, true),
            // On top of the thorax, just behind its middle, slightly off the midline.
            wing_hinge_right: Vec3::new(0.20, 0.12, 0.05) * length,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(m: &BeeMesh) -> [&Primitive; 4] {
        [&m.body_yellow, &m.body_black, &m.wing_right, &m.wing_left]
    }

    #[test]
    fn body_is_exactly_the_bee_length_along_x() {
        let m = BeeMesh::new(0.012);
        let (ylo, yhi) = m.body_yellow.bounds();
        let (blo, bhi) = m.body_black.bounds();
        assert!((blo[0].min(ylo[0]) + 0.006).abs() < 1e-7);
        assert!((bhi[0].max(yhi[0]) - 0.006).abs() < 1e-7);
        // Stout but not round: the widest point is about a third of the length.
        let width = bhi[2].max(yhi[2]) - blo[2].min(ylo[2]);
        assert!(width > 0.3 * 0.012 && width < 0.4 * 0.012, "{width}");
    }

    #[test]
    fn normals_are_unit_and_faces_point_outwards() {
        let m = BeeMesh::new(0.012);
        for prim in all(&m) {
            assert!(!prim.indices.is_empty());
            for n in &prim.normals {
                assert!((Vec3::from(*n).length() - 1.0).abs() < 1e-5);
            }
            for t in prim.indices.chunks(3) {
                let p = |i: u16| Vec3::from(prim.positions[i as usize]);
                let n = |i: u16| Vec3::from(prim.normals[i as usize]);
                let face = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
                assert!(face.length() > 0.0, "degenerate triangle {t:?}");
                assert!(face.dot(n(t[0]) + n(t[1]) + n(t[2])) > 0.0);
            }
        }
    }

    #[test]
    fn wings_hinge_at_their_origin_and_mirror_each_other() {
        let m = BeeMesh::new(0.012);
        assert!(m.wing_right.positions.contains(&[0.0, 0.0, 0.0]));
        for (r, l) in m.wing_right.positions.iter().zip(&m.wing_left.positions) {
            assert_eq!([r[0], r[1], -r[2]], *l);
            assert!(r[2] >= 0.0);
        }
        // Swept back: the tip is behind the hinge.
        let tip = m
            .wing_right
            .positions
            .iter()
            .max_by(|a, b| a[2].total_cmp(&b[2]))
            .unwrap();
        assert!(tip[0] < 0.0);
    }
}
