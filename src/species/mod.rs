//! What a model records and how a species is drawn, as data: the writers (glTF, USDA,
//! CSV) read these descriptions instead of knowing about bees.
//!
//! A *model* records one [`Channel`] per scalar it tracks for every agent each frame (a
//! honeybee: pitch, roll, sway). A [`Species`] is the body the agents are drawn with:
//! named [`Part`]s in a hierarchy, each with its meshes and what drives it ([`Drive`]).
//! The CSV writes every channel as a column, the USDA writer as a per-instance primvar,
//! and the glTF writer animates the parts a channel drives.
//!
//! Conventions as everywhere: metres, seconds, Y-up right-handed; body frame X forward,
//! Y up, Z right; quaternions (x, y, z, w). This module sits below `sim`, `model`, `shot`
//! and `export` and uses none of them.

pub mod butterfly;
pub mod honeybee;

pub use butterfly::BUTTERFLY;
pub use honeybee::{BEE_CHANNELS, HONEYBEE};

use glam::Vec3;

/// A per-agent scalar a model records each frame (written as a CSV column, a USD primvar,
/// and glTF part animation where a part is driven by it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Channel {
    /// Identifier-safe name (`[a-z_][a-z0-9_]*`): the CSV column and `primvars:<name>`.
    pub name: &'static str,
    /// Unit of the values: `"deg"`, `"m"`, …
    pub unit: &'static str,
    /// One sentence for humans, written as the USD primvar's `doc`.
    pub doc: &'static str,
}

/// How a species is drawn: named parts in a hierarchy, each with its meshes and what
/// drives it.
pub struct Species {
    /// Identifier-safe name: the USD prototype is `Prototypes/<name>`.
    pub name: &'static str,
    /// Prefix of glTF node and mesh names: node `<agent>_000123`, its parts
    /// `<agent>_000123_<part>`, meshes `<agent>_<length in mm>mm_<part>`.
    pub agent: &'static str,
    /// Parts in document order; a part's parent comes before it.
    pub parts: &'static [Part],
    /// The channel (metres) giving the body's lateral offset from its path node along the
    /// heading frame's +Z (honeybee: `"sway"`); `None`, or a channel the swarm does not
    /// record, means 0.
    pub lateral_offset: Option<&'static str>,
    /// Materials the meshes refer to by index (glTF PBR materials, USD UsdPreviewSurface).
    pub materials: &'static [Material],
    /// Geometry for a body length in metres, one entry per part in part order: the glTF
    /// meshes and the USD prototype alike, so both formats draw the same insect.
    pub meshes: fn(f32) -> Vec<PartMesh>,
}

impl std::fmt::Debug for Species {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Species")
            .field("name", &self.name)
            .field("parts", &self.parts)
            .field("lateral_offset", &self.lateral_offset)
            .finish_non_exhaustive()
    }
}

impl PartialEq for Species {
    /// Species are statics: the same species is the same name.
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl Species {
    /// The index of a part by name.
    pub fn part(&self, name: &str) -> Option<usize> {
        self.parts.iter().position(|p| p.name == name)
    }

    /// Children of part `parent` (`None`: the root parts under the agent's path node).
    pub fn children(&self, parent: Option<usize>) -> impl Iterator<Item = usize> + '_ {
        (0..self.parts.len()).filter(move |&k| self.parts[k].parent == parent)
    }

    /// Checks the description against the channels a swarm records: parents come before
    /// their children and every channel a part is driven by is recorded.
    pub fn check(&self, channels: &[Channel]) -> std::result::Result<(), String> {
        for (k, p) in self.parts.iter().enumerate() {
            if p.parent.is_some_and(|q| q >= k) {
                return Err(format!(
                    "species {}: part {} must come after its parent",
                    self.name, p.name
                ));
            }
            let missing = match p.drive {
                Drive::Channel { channel, .. } => {
                    (!channels.iter().any(|c| c.name == channel)).then_some(channel)
                }
                _ => None,
            };
            if let Some(channel) = missing {
                return Err(format!(
                    "species {}: part {} is driven by channel \"{channel}\", which the \
                     model does not record",
                    self.name, p.name
                ));
            }
        }
        Ok(())
    }
}

/// One part of a species' body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Part {
    /// Identifier-safe name, unique in the species.
    pub name: &'static str,
    /// Index of the parent part; `None` = a root body under the agent's path node.
    pub parent: Option<usize>,
    pub drive: Drive,
}

/// What moves a part (glTF node animation; USD instances share prototypes, so only a
/// wing flap, and a `flap` channel by posed prototypes, moves there: `export::usda`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Drive {
    /// The simulated attitude (the body part): rotation heading⁻¹·orientation,
    /// translation (0, 0, lateral offset), the agent's scale. Sits at the agent's centre.
    Attitude,
    /// A wing drawn as the output's wing display says (`export::wings`: still, a blurred
    /// fan, or a visible flap) about the part's X axis (the hinge line), tip up positive;
    /// the right wing's tip points +Z.
    Flap { right: bool },
    /// Rotation about `axis` (part frame) by the channel's value in degrees.
    Channel { channel: &'static str, axis: Vec3 },
    /// Not animated.
    Static,
}

/// Transparency of a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Alpha {
    /// Opaque, single-sided.
    Opaque,
    /// A wing membrane: blended and double-sided, its opacity set by the writer (more
    /// transparent when wings are drawn as a still blur).
    Membrane,
}

/// A material: base colour (linear RGB), roughness, non-metallic. glTF writes it as a PBR
/// material, USD as a `UsdPreviewSurface`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub name: &'static str,
    pub rgb: [f32; 3],
    pub roughness: f32,
    pub alpha: Alpha,
}

/// One indexed triangle list in part-local metres.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Primitive {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub indices: Vec<u16>,
}

impl Primitive {
    /// Adds a vertex with a normalised normal; returns its index.
    pub fn vertex(&mut self, p: Vec3, n: Vec3) -> u16 {
        let i = self.positions.len();
        self.positions.push(p.to_array());
        self.normals.push(n.normalize().to_array());
        u16::try_from(i).expect("a part mesh is far below 65,536 vertices")
    }

    /// Adds a triangle facing the side its vertex normals point to, so winding never
    /// depends on which way a loop happened to run (glTF front faces are counter-clockwise).
    pub fn triangle(&mut self, a: u16, b: u16, c: u16) {
        let p = |i: u16| Vec3::from(self.positions[i as usize]);
        let n = |i: u16| Vec3::from(self.normals[i as usize]);
        let face = (p(b) - p(a)).cross(p(c) - p(a));
        if face.dot(n(a) + n(b) + n(c)) >= 0.0 {
            self.indices.extend([a, b, c]);
        } else {
            self.indices.extend([a, c, b]);
        }
    }

    /// The primitive turned by `rotation`, then moved by `offset` (normals turned too).
    pub fn transformed(&self, rotation: glam::Quat, offset: Vec3) -> Primitive {
        Primitive {
            positions: self
                .positions
                .iter()
                .map(|p| (rotation * Vec3::from(*p) + offset).to_array())
                .collect(),
            normals: self
                .normals
                .iter()
                .map(|n| (rotation * Vec3::from(*n)).normalize().to_array())
                .collect(),
            indices: self.indices.clone(),
        }
    }

    /// Appends another primitive's vertices and triangles.
    pub fn extend(&mut self, other: &Primitive) {
        let base =
            u16::try_from(self.positions.len()).expect("a part mesh is far below 65,536 vertices");
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.indices.extend(other.indices.iter().map(|i| base + i));
    }

    /// Component-wise bounds of the positions (glTF requires them on POSITION).
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }
}

/// The glTF geometry of one part.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PartMesh {
    /// Primitives with the index of their material in `Species::materials`; empty = the
    /// part has no mesh.
    pub primitives: Vec<(Primitive, usize)>,
    /// Rest translation of the part in its parent's frame (a wing: its hinge). Ignored for
    /// `Drive::Attitude` parts, which sit at the agent's centre.
    pub offset: Vec3,
}
