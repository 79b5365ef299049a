//! The honeybee: a worker bee recorded with pitch, roll and sway, drawn as a striped body
//! with two wings (the same geometry in glTF and USD).
//!
//! ```text
//! body      Attitude: the simulated pitch/roll wobble, offset sideways by `sway`
//! ├─ wing_l  Flap (left), hinged on the thorax
//! └─ wing_r  Flap (right)
//! ```

mod mesh;

use super::{Alpha, Channel, Drive, Material, Part, PartMesh, Species};

pub use mesh::BeeMesh;

/// What the bee model records per bee each frame.
pub const BEE_CHANNELS: [Channel; 4] = [
    Channel {
        name: "pitch",
        unit: "deg",
        doc: "Body pitch, degrees, nose up positive (about body +Z).",
    },
    Channel {
        name: "roll",
        unit: "deg",
        doc: "Body roll, degrees, right wing down positive (about body +X).",
    },
    Channel {
        name: "sway",
        unit: "m",
        doc: "Lateral offset from the mean path, metres, along the heading's +Z.",
    },
    Channel {
        name: "state",
        unit: "1",
        doc: "0 flying, 1 hovering (slower than 0.1 m/s), 2 landed on a target with `land = true`, 3 inside a hive (hidden).",
    },
];

/// Indices of the honeybee's parts.
pub const BODY: usize = 0;
pub const WING_L: usize = 1;
pub const WING_R: usize = 2;

/// Indices of the honeybee's materials.
const YELLOW: usize = 0;
const BLACK: usize = 1;
const WING: usize = 2;

pub static HONEYBEE: Species = Species {
    name: "honeybee",
    agent: "bee",
    parts: &[
        Part {
            name: "body",
            parent: None,
            drive: Drive::Attitude,
        },
        Part {
            name: "wing_l",
            parent: Some(BODY),
            drive: Drive::Flap { right: false },
        },
        Part {
            name: "wing_r",
            parent: Some(BODY),
            drive: Drive::Flap { right: true },
        },
    ],
    lateral_offset: Some("sway"),
    materials: &[
        Material {
            name: "bee_yellow",
            rgb: [0.85, 0.55, 0.05],
            roughness: 0.6,
            alpha: Alpha::Opaque,
        },
        Material {
            name: "bee_black",
            rgb: [0.03, 0.025, 0.02],
            roughness: 0.45,
            alpha: Alpha::Opaque,
        },
        Material {
            name: "bee_wing",
            rgb: [0.8, 0.85, 0.9],
            roughness: 0.25,
            alpha: Alpha::Membrane,
        },
    ],
    meshes,
};

/// The striped body (yellow and black bands) and two wings at their hinges, for glTF and USD.
fn meshes(length: f32) -> Vec<PartMesh> {
    let bee = BeeMesh::new(length);
    let h = bee.wing_hinge_right;
    vec![
        PartMesh {
            primitives: vec![(bee.body_yellow, YELLOW), (bee.body_black, BLACK)],
            offset: glam::Vec3::ZERO,
        },
        PartMesh {
            primitives: vec![(bee.wing_left, WING)],
            offset: glam::Vec3::new(h.x, h.y, -h.z),
        },
        PartMesh {
            primitives: vec![(bee.wing_right, WING)],
            offset: h,
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_description_is_consistent() {
        HONEYBEE.check(&BEE_CHANNELS).unwrap();
        assert_eq!(HONEYBEE.part("wing_r"), Some(WING_R));
        assert_eq!(HONEYBEE.part("wing_l"), Some(WING_L));
        assert_eq!(
            HONEYBEE.children(Some(BODY)).collect::<Vec<_>>(),
            [WING_L, WING_R]
        );
        assert_eq!((HONEYBEE.meshes)(0.012).len(), HONEYBEE.parts.len());
        let lateral = HONEYBEE.lateral_offset.unwrap();
        assert!(
            BEE_CHANNELS
                .iter()
                .any(|c| c.name == lateral && c.unit == "m")
        );
    }
}
