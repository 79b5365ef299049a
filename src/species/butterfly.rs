//! The butterfly of paper 004: thorax with head, an abdomen and four patterned, opaque
//! wings, each part turned by the angle channel the butterfly model records, so glTF
//! animates flapping, feathering, sweeping and the abdomen per butterfly.
//!
//! ```text
//! body                 Attitude: heading and thorax pitch θ_β
//! ├─ abdomen           channel abdomen (θ_φ), about −Z: tip up positive
//! ├─ forewing_l_sweep  channel sweep (θ_ψ), about −Y: tip forward positive (no mesh)
//! │  └─ forewing_l_flap   channel flap (θ_γ), about +X: tip up positive (no mesh)
//! │     └─ forewing_l     channel feather (θ_ζ), about +Z: leading edge up positive
//! ├─ forewing_r_sweep  … mirrored: about +Y, −X, +Z
//! ├─ hindwing_l        channel flap, about +X
//! └─ hindwing_r        channel flap, about −X
//! ```
//!
//! The chain sweep → flap → feather is the order of the model's blade elements
//! (`model::butterfly::aerodynamics`), so the drawn wings are the wings that fly. Scale:
//! the span is [`SPAN_PER_LENGTH`] body lengths (a 25 mm body gives about 6 cm).
//! Body frame as everywhere: X forward, Y up, Z right; metres.

use super::{Alpha, Drive, Material, Part, PartMesh, Primitive, Species};
use glam::{Quat, Vec3};

/// Wing span, tip to tip, in body lengths.
pub const SPAN_PER_LENGTH: f32 = 2.4;

/// Indices of the butterfly's materials.
const BODY_DARK: usize = 0;
const WING_ORANGE: usize = 1;
const WING_BLACK: usize = 2;
const WING_WHITE: usize = 3;

const fn channel(parent: usize, name: &'static str, channel: &'static str, axis: Vec3) -> Part {
    Part {
        name,
        parent: Some(parent),
        drive: Drive::Channel { channel, axis },
    }
}

pub static BUTTERFLY: Species = Species {
    name: "butterfly",
    agent: "butterfly",
    parts: &[
        Part {
            name: "body",
            parent: None,
            drive: Drive::Attitude,
        },
        channel(0, "abdomen", "abdomen", Vec3::NEG_Z),
        channel(0, "forewing_l_sweep", "sweep", Vec3::NEG_Y),
        channel(2, "forewing_l_flap", "flap", Vec3::X),
        channel(3, "forewing_l", "feather", Vec3::Z),
        channel(0, "forewing_r_sweep", "sweep", Vec3::Y),
        channel(5, "forewing_r_flap", "flap", Vec3::NEG_X),
        channel(6, "forewing_r", "feather", Vec3::Z),
        channel(0, "hindwing_l", "flap", Vec3::X),
        channel(0, "hindwing_r", "flap", Vec3::NEG_X),
    ],
    lateral_offset: None,
    materials: &[
        Material {
            name: "butterfly_body",
            rgb: [0.02, 0.018, 0.015],
            roughness: 0.7,
            alpha: Alpha::Opaque,
        },
        Material {
            name: "butterfly_orange",
            rgb: [0.9, 0.28, 0.02],
            roughness: 0.55,
            alpha: Alpha::Opaque,
        },
        Material {
            name: "butterfly_black",
            rgb: [0.01, 0.01, 0.01],
            roughness: 0.6,
            alpha: Alpha::Opaque,
        },
        Material {
            name: "butterfly_white",
            rgb: [0.9, 0.9, 0.85],
            roughness: 0.6,
            alpha: Alpha::Opaque,
        },
    ],
    meshes,
};

/// Outline of a right forewing in its frame (x along the chord, forward; z along the
/// span), in spans: leading edge near x = 0 from root to tip, then back along the
/// trailing edge. The model's blade elements span 0.46 (root chord 0.30, tip 0.18).
const FORE: [(f32, f32); 8] = [
    (0.01, 0.0),
    (0.03, 0.22),
    (0.02, 0.46),
    (-0.08, 0.47),
    (-0.18, 0.42),
    (-0.25, 0.28),
    (-0.29, 0.12),
    (-0.28, 0.0),
];

/// Outline of a right hindwing at rest, before it is swept back (span 0.34, chords 0.36 to 0.26).
const HIND: [(f32, f32); 8] = [
    (0.0, 0.0),
    (0.02, 0.17),
    (-0.03, 0.33),
    (-0.14, 0.35),
    (-0.27, 0.28),
    (-0.35, 0.14),
    (-0.34, 0.03),
    (-0.25, 0.0),
];

/// Hinges of the right wings in spans, body frame (the model's blade elements use these).
pub const FORE_HINGE: Vec3 = Vec3::new(0.06, 0.02, 0.04);
pub const HIND_HINGE: Vec3 = Vec3::new(-0.02, 0.01, 0.04);
/// Hindwings at rest point this far back from the body's side, degrees.
pub const HIND_BACK_DEG: f32 = 35.0;

/// Adds a triangle seen from both sides (the wing is a membrane, drawn opaque and
/// single-sided: one face up, one down).
fn two_sided(p: &mut Primitive, a: Vec3, b: Vec3, c: Vec3, normal: Vec3) {
    for n in [normal, -normal] {
        let (i, j, k) = (p.vertex(a, n), p.vertex(b, n), p.vertex(c, n));
        p.triangle(i, j, k);
    }
}

/// One wing from its outline (spans, wing frame) at `span` metres, mirrored to the left
/// side when `left`, turned by `rest`: an orange field, a black border with white spots.
fn wing(outline: &[(f32, f32)], span: f32, left: bool, rest: Quat) -> [Primitive; 3] {
    let side = if left { -1.0 } else { 1.0 };
    let at = |x: f32, z: f32| rest * Vec3::new(x * span, 0.0, side * z * span);
    let up = rest * Vec3::Y;
    let n = outline.len() as f32;
    let (cx, cz) = outline
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, z)| (a + x / n, b + z / n));
    let toward = |(x, z): (f32, f32), f: f32| (cx + (x - cx) * f, cz + (z - cz) * f);
    let [mut orange, mut black, mut white] = [
        Primitive::default(),
        Primitive::default(),
        Primitive::default(),
    ];
    for k in 0..outline.len() {
        let (a, b) = (outline[k], outline[(k + 1) % outline.len()]);
        let (ia, ib) = (toward(a, 0.72), toward(b, 0.72));
        let c = at(cx, cz);
        two_sided(&mut orange, c, at(ia.0, ia.1), at(ib.0, ib.1), up);
        two_sided(&mut black, at(ia.0, ia.1), at(a.0, a.1), at(b.0, b.1), up);
        two_sided(&mut black, at(ia.0, ia.1), at(b.0, b.1), at(ib.0, ib.1), up);
        // A white spot in the border, half-way along the edge, just above the black.
        let m = ((a.0 + b.0) * 0.5, (a.1 + b.1) * 0.5);
        let spot = toward(m, 0.86);
        let r = 0.012;
        let lift = up * (0.02 * r * span);
        two_sided(
            &mut white,
            at(spot.0 + r, spot.1) + lift,
            at(spot.0 - r, spot.1 + r) + lift,
            at(spot.0 - r, spot.1 - r) + lift,
            up,
        );
    }
    [orange, black, white]
}

/// An ellipsoid centred at `c` with half axes `r`, as a latitude-longitude mesh.
fn ellipsoid(p: &mut Primitive, c: Vec3, r: Vec3) {
    const RINGS: usize = 8;
    const SEGMENTS: usize = 10;
    let base = p.positions.len();
    for i in 0..=RINGS {
        let th = std::f32::consts::PI * i as f32 / RINGS as f32;
        for j in 0..SEGMENTS {
            let ph = std::f32::consts::TAU * j as f32 / SEGMENTS as f32;
            let u = Vec3::new(th.cos(), th.sin() * ph.cos(), th.sin() * ph.sin());
            p.vertex(c + u * r, u / r);
        }
    }
    let idx = |i: usize, j: usize| (base + i * SEGMENTS + j % SEGMENTS) as u16;
    for i in 0..RINGS {
        for j in 0..SEGMENTS {
            if i > 0 {
                p.triangle(idx(i, j), idx(i + 1, j), idx(i, j + 1));
            }
            if i + 1 < RINGS {
                p.triangle(idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1));
            }
        }
    }
}

/// Head and thorax, the abdomen on its joint, and the four wings on their hinges, for a
/// body `length` metres long.
fn meshes(length: f32) -> Vec<PartMesh> {
    let span = SPAN_PER_LENGTH * length;
    let mut body = Primitive::default();
    ellipsoid(
        &mut body,
        Vec3::new(0.40 * length, 0.0, 0.0),
        Vec3::splat(0.08 * length),
    );
    ellipsoid(
        &mut body,
        Vec3::new(0.15 * length, 0.0, 0.0),
        Vec3::new(0.19, 0.10, 0.09) * length,
    );
    let mut abdomen = Primitive::default();
    ellipsoid(
        &mut abdomen,
        Vec3::new(-0.28 * length, 0.0, 0.0),
        Vec3::new(0.30, 0.065, 0.065) * length,
    );
    let empty = |offset: Vec3| PartMesh {
        primitives: Vec::new(),
        offset,
    };
    let mirror = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
    let wing_mesh = |outline: &[(f32, f32)], left: bool, rest: Quat, offset: Vec3| {
        let [o, b, w] = wing(outline, span, left, rest);
        PartMesh {
            primitives: vec![(o, WING_ORANGE), (b, WING_BLACK), (w, WING_WHITE)],
            offset,
        }
    };
    let hind_back = Quat::from_rotation_y(-HIND_BACK_DEG.to_radians());
    let (fore_h, hind_h) = (FORE_HINGE * span, HIND_HINGE * span);
    vec![
        PartMesh {
            primitives: vec![(body, BODY_DARK)],
            offset: Vec3::ZERO,
        },
        PartMesh {
            primitives: vec![(abdomen, BODY_DARK)],
            offset: Vec3::new(-0.02 * length, 0.0, 0.0),
        },
        empty(mirror(fore_h)),
        empty(Vec3::ZERO),
        wing_mesh(&FORE, true, Quat::IDENTITY, Vec3::ZERO),
        empty(fore_h),
        empty(Vec3::ZERO),
        wing_mesh(&FORE, false, Quat::IDENTITY, Vec3::ZERO),
        wing_mesh(&HIND, true, mirror_quat(hind_back), mirror(hind_h)),
        wing_mesh(&HIND, false, hind_back, hind_h),
    ]
}

/// The mirror image (z → −z) of a rotation about Y: the opposite turn.
fn mirror_quat(q: Quat) -> Quat {
    Quat::from_xyzw(-q.x, q.y, -q.z, q.w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn about_six_centimetres_across() {
        let meshes = (BUTTERFLY.meshes)(0.025);
        assert_eq!(meshes.len(), BUTTERFLY.parts.len());
        // Span: the farthest wing vertex from the body's midplane, both sides, with the
        // wings' hinge offsets (the flap parts sit at zero under their sweep parts).
        let mut reach = 0.0f32;
        for (k, m) in meshes.iter().enumerate() {
            let mut offset = m.offset;
            let mut p = BUTTERFLY.parts[k].parent;
            while let Some(q) = p {
                offset += meshes[q].offset;
                p = BUTTERFLY.parts[q].parent;
            }
            for (prim, _) in &m.primitives {
                for v in &prim.positions {
                    reach = reach.max((Vec3::from(*v) + offset).z.abs());
                }
            }
        }
        assert!((2.0 * reach - 0.06).abs() < 0.004, "span {}", 2.0 * reach);
    }

    #[test]
    fn wings_are_opaque_and_seen_from_both_sides() {
        let meshes = (BUTTERFLY.meshes)(0.025);
        let fore = &meshes[BUTTERFLY.part("forewing_r").unwrap()];
        assert_eq!(fore.primitives.len(), 3);
        for (p, m) in &fore.primitives {
            assert_eq!(BUTTERFLY.materials[*m].alpha, Alpha::Opaque);
            let up = p.normals.iter().filter(|n| n[1] > 0.9).count();
            let down = p.normals.iter().filter(|n| n[1] < -0.9).count();
            assert!(up > 0 && up == down);
        }
    }
}
