//! The shot file as written by an artist: every key optional, unknown keys refused.
//! `shot::resolve` turns this into a fully defaulted, validated [`super::Shot`].
//!
//! Units: metres, seconds, degrees for angles; world Y-up, right-handed.

use serde::Deserialize;

pub type V3 = [f64; 3];

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawShot {
    pub scene: Option<RawScene>,
    #[serde(default)]
    pub swarm: Vec<RawSwarm>,
    #[serde(default)]
    pub obstacle: Vec<RawObstacle>,
    #[serde(default)]
    pub target: Vec<RawTarget>,
    pub wind: Option<RawWind>,
    pub output: Option<RawOutput>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawScene {
    pub name: Option<String>,
    pub fps: Option<f64>,
    pub frames: Option<[i64; 2]>,
    pub substeps: Option<i64>,
    pub seed: Option<i64>,
}

/// Model parameter values by name (`params = { speed = 1.2 }`); which names are valid
/// depends on the swarm's model, checked when the shot is resolved.
pub type RawParams = std::collections::BTreeMap<String, f64>;

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawSwarm {
    pub name: Option<String>,
    pub count: Option<i64>,
    pub model: Option<String>,
    pub preset: Option<String>,
    pub spawn: Option<RawSpawn>,
    pub variation: Option<RawVariation>,
    pub bee: Option<RawBee>,
    /// Soft containment box; bees outside it are pushed back.
    pub bounds: Option<RawBounds>,
    /// Model parameter overrides, applied over the preset.
    pub params: Option<RawParams>,
    /// FASTSWARM: the velocity database file (relative to the shot).
    pub database: Option<String>,
    /// Fraction of the swarm's bees that start inside a hive (a nest with `inside`).
    pub start_inside: Option<f64>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawSpawn {
    pub shape: Option<String>,
    pub center: Option<V3>,
    pub size: Option<V3>,
    pub radius: Option<f64>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawVariation {
    pub size: Option<f64>,
    pub speed: Option<f64>,
    pub phase: Option<f64>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawBee {
    pub length: Option<f64>,
    pub radius: Option<f64>,
    pub mass: Option<f64>,
    pub wing_area: Option<f64>,
    pub wing_beat_hz: Option<f64>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawBounds {
    pub center: Option<V3>,
    pub size: Option<V3>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawObstacle {
    #[serde(rename = "type")]
    pub kind: Option<String>,
    pub name: Option<String>,
    pub center: Option<V3>,
    pub radius: Option<f64>,
    pub size: Option<V3>,
    pub height: Option<f64>,
    /// Euler angles in degrees, applied X then Y then Z (world axes).
    pub rotation: Option<V3>,
    pub a: Option<V3>,
    pub b: Option<V3>,
    pub point: Option<V3>,
    pub normal: Option<V3>,
    /// Mesh obstacles: the mesh file (relative to the shot), how it is avoided, and its
    /// placement (scale, then rotation, then position).
    pub file: Option<String>,
    /// glTF: the node whose meshes (with its children's) are the obstacle.
    pub node: Option<String>,
    pub mode: Option<String>,
    pub thickness: Option<f64>,
    pub position: Option<V3>,
    pub scale: Option<V3>,
    /// Mesh obstacles: placement keys (frame, position, rotation) instead of `position`
    /// and `rotation`: the mesh moves.
    pub keys: Option<Vec<RawKey>>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawTarget {
    #[serde(rename = "type")]
    pub kind: Option<String>,
    pub name: Option<String>,
    pub position: Option<V3>,
    pub radius: Option<f64>,
    pub strength: Option<f64>,
    pub reach: Option<f64>,
    pub normal: Option<V3>,
    pub swarms: Option<Vec<String>>,
    pub keys: Option<Vec<RawKey>>,
    /// Points of a polyline (first = last: closed): the target stands for `samples` targets
    /// spread evenly along it (FASTSWARM's key points, paper 003 Eq. 15).
    pub curve: Option<Vec<V3>>,
    pub samples: Option<i64>,
    pub land: Option<bool>,
    pub stay: Option<Vec<f64>>,
    pub inside: Option<Vec<f64>>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawKey {
    pub frame: Option<f64>,
    pub position: Option<V3>,
    /// Moving mesh obstacles only: Euler angles in degrees, as an obstacle's `rotation`.
    pub rotation: Option<V3>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawWind {
    pub velocity: Option<V3>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawOutput {
    pub dir: Option<String>,
    pub formats: Option<Vec<String>>,
    pub preview: Option<bool>,
    pub wings: Option<String>,
    pub wing_flap_hz: Option<f64>,
    pub gltf_layout: Option<String>,
    pub usda_clip_frames: Option<i64>,
}

/// A preset file (`beeswarm calibrate` writes these; `preset = "file.toml"` loads one).
#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawPresetFile {
    pub preset: RawPresetHeader,
    pub params: Option<RawParams>,
}

#[derive(Deserialize, Debug, Default, Clone)]
#[serde(deny_unknown_fields)]
pub struct RawPresetHeader {
    pub name: Option<String>,
    /// The model the preset is for (`bee` when absent).
    pub model: Option<String>,
    pub base: Option<String>,
    pub description: Option<String>,
    /// Free-form provenance: the command that produced the preset, fitness, date.
    pub provenance: Option<String>,
}
