//! The honeybee's USD prototype geometry: a small procedural bee at real scale, in metres.
//!
//! Body along +X (head forward), wings spanning ±Z, Y up; the origin is near the centre
//! of mass (over the thorax), because instance positions are the bee's centre of mass.
//! Proportions follow a worker honeybee: 12 mm long, thorax about 4 mm across, forewing
//! span about 1.6 body lengths. Everything scales with the swarm's body length.

use crate::species::{PolyMesh as Mesh, newell_normal};
use glam::Vec3;

/// Body profile (x, radius) from head tip to abdomen tip, in body lengths: head,
/// neck, thorax, waist (petiole), abdomen.
const PROFILE: [(f32, f32); 12] = [
    (0.50, 0.0),
    (0.46, 0.07),
    (0.39, 0.09),
    (0.33, 0.06),
    (0.26, 0.12),
    (0.12, 0.14),
    (0.03, 0.08),
    (-0.04, 0.14),
    (-0.18, 0.17),
    (-0.33, 0.14),
    (-0.45, 0.07),
    (-0.50, 0.0),
];
const AROUND: usize = 8;

/// The body: a lathe of `PROFILE` around the X axis, faces wound counter-clockwise seen
/// from outside (USD's default right-handed orientation).
pub fn body(length: f32) -> Mesh {
    let rings = &PROFILE[1..PROFILE.len() - 1];
    let mut points = vec![Vec3::new(PROFILE[0].0, 0.0, 0.0) * length];
    for &(x, r) in rings {
        for k in 0..AROUND {
            let a = std::f32::consts::TAU * k as f32 / AROUND as f32;
            points.push(Vec3::new(x, r * a.cos(), r * a.sin()) * length);
        }
    }
    points.push(Vec3::new(PROFILE[PROFILE.len() - 1].0, 0.0, 0.0) * length);
    let tail = (points.len() - 1) as i32;
    let ring = |j: usize, k: usize| (1 + j * AROUND + k % AROUND) as i32;

    let mut face_counts = Vec::new();
    let mut face_indices = Vec::new();
    for k in 0..AROUND {
        face_counts.push(3);
        face_indices.extend([0, ring(0, k), ring(0, k + 1)]);
    }
    for j in 0..rings.len() - 1 {
        for k in 0..AROUND {
            face_counts.push(4);
            face_indices.extend([
                ring(j, k),
                ring(j + 1, k),
                ring(j + 1, k + 1),
                ring(j, k + 1),
            ]);
        }
    }
    let last = rings.len() - 1;
    for k in 0..AROUND {
        face_counts.push(3);
        face_indices.extend([tail, ring(last, k + 1), ring(last, k)]);
    }
    Mesh {
        points,
        face_counts,
        face_indices,
    }
}

/// One flat wing (one face) over the thorax, swept back, spanning +Z (right) or -Z
/// (left); it faces up (+Y) and is meant to be rendered double-sided.
pub fn wing(length: f32, right: bool) -> Mesh {
    const SEGMENTS: usize = 10;
    let y = 0.13;
    let side = if right { 1.0f32 } else { -1.0 };
    // An ellipse from the wing root (near the body's midline) to the tip.
    let span_dir = Vec3::new(-0.25, 0.0, side).normalize();
    let chord_dir = Vec3::new(span_dir.z, 0.0, -span_dir.x) * side;
    let centre = Vec3::new(0.02, y, 0.0) + span_dir * 0.42;
    let points: Vec<Vec3> = (0..SEGMENTS)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / SEGMENTS as f32;
            (centre + span_dir * (0.40 * a.cos()) + chord_dir * (0.11 * a.sin())) * length
        })
        .collect();
    let mut face: Vec<i32> = (0..SEGMENTS as i32).collect();
    // Wind the face so its normal points up, whichever way the ellipse went round.
    if newell_normal(&points, &face).y < 0.0 {
        face.reverse();
    }
    Mesh {
        points,
        face_counts: vec![SEGMENTS as i32],
        face_indices: face,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn faces(m: &Mesh) -> Vec<Vec<i32>> {
        let mut out = Vec::new();
        let mut at = 0usize;
        for &c in &m.face_counts {
            out.push(m.face_indices[at..at + c as usize].to_vec());
            at += c as usize;
        }
        assert_eq!(at, m.face_indices.len());
        out
    }

    #[test]
    fn body_is_a_closed_outward_facing_bee_of_the_right_size() {
        let m = body(0.012);
        let [lo, hi] = m.extent();
        assert!((hi.x - lo.x - 0.012).abs() < 1e-6, "12 mm long");
        assert!(
            hi.y - lo.y < 0.005 && hi.z - lo.z < 0.005,
            "about 4 mm thick"
        );
        for f in faces(&m) {
            assert!(f.iter().all(|&i| (i as usize) < m.points.len()));
            let n = newell_normal(&m.points, &f);
            let c: Vec3 = f.iter().map(|&i| m.points[i as usize]).sum::<Vec3>() / f.len() as f32;
            // Outward: away from the X axis, or along ±X at the tips.
            let out = Vec3::new(c.x.signum() * 1e-3, c.y, c.z);
            assert!(n.dot(out) > 0.0, "face {f:?} points inward");
        }
        // Closed: every edge is shared by exactly two faces, in opposite directions.
        let mut edges = std::collections::HashMap::new();
        for f in faces(&m) {
            for i in 0..f.len() {
                *edges.entry((f[i], f[(i + 1) % f.len()])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1);
            assert_eq!(edges.get(&(b, a)), Some(&1));
        }
    }

    #[test]
    fn wings_span_z_and_face_up() {
        let (r, l) = (wing(0.012, true), wing(0.012, false));
        assert!(
            r.extent()[1].z > 0.009 && l.extent()[0].z < -0.009,
            "span about 19 mm"
        );
        for m in [&r, &l] {
            assert!(m.extent()[0].y > 0.0, "above the body axis");
            for f in faces(m) {
                assert!(newell_normal(&m.points, &f).y > 0.0);
            }
            let radius = m.points.iter().map(|p| p.length()).fold(0.0, f32::max);
            assert!(radius > 0.009 && radius < 0.012);
        }
        // Mirror images.
        for (a, b) in r.points.iter().zip(&l.points) {
            assert_eq!(*a * Vec3::new(1.0, 1.0, -1.0), *b);
        }
    }

    #[test]
    fn bound_radius_holds_the_prototype_box() {
        let proxies = (crate::species::HONEYBEE.proxies)(0.012);
        let r = crate::species::bound_radius(&proxies);
        for m in [body(0.012), wing(0.012, true), wing(0.012, false)] {
            let [lo, hi] = m.extent();
            for x in [lo.x, hi.x] {
                for y in [lo.y, hi.y] {
                    for z in [lo.z, hi.z] {
                        assert!(Vec3::new(x, y, z).length() <= r * 1.000_001);
                    }
                }
            }
        }
    }
}
