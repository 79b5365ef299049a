//! Shots: the TOML file an artist writes (schema), its defaults, and its validation.
//!
//! `load` reads a file, `parse` reads text; both return a fully resolved [`Shot`] or a
//! [`ShotError`] naming file, line, column and key. See docs/shot-format.md.

pub mod defaults;
pub mod locate;
pub mod mesh_file;
mod mesh_gltf;
mod mesh_ply;
mod output;
mod resolve;
pub mod schema;

use crate::error::ShotError;
pub use crate::geometry::{Shape, euler_deg};
use crate::model::ParamValues;
pub use crate::model::{Body, ModelKind, TargetKind, Variation};
use glam::Vec3;
pub use output::{Format, GltfLayout, OutputOptions, WingDisplay};
use std::path::{Path, PathBuf};

/// The default shot baked by `beeswarm bake` without a file.
pub const EMBEDDED_DEFAULT: &str = include_str!("default_shot.toml");

/// A validated shot with every default filled in.
#[derive(Clone, Debug)]
pub struct Shot {
    /// File name stem used for every output (`<name>.glb`, ...).
    pub name: String,
    pub fps: f64,
    /// First and last frame, inclusive; the first frame records the initial state.
    pub frame_start: i32,
    pub frame_end: i32,
    /// Integration steps per frame.
    pub substeps: u32,
    pub seed: u64,
    pub swarms: Vec<Swarm>,
    pub obstacles: Vec<Obstacle>,
    pub targets: Vec<Target>,
    /// Constant wind velocity, m/s.
    pub wind: Vec3,
    pub output: Output,
}

impl Shot {
    pub fn frame_count(&self) -> usize {
        (self.frame_end - self.frame_start + 1) as usize
    }
    pub fn bee_count(&self) -> usize {
        self.swarms.iter().map(|s| s.count).sum()
    }
    /// Integration time step, seconds.
    pub fn dt(&self) -> f64 {
        1.0 / (self.fps * self.substeps as f64)
    }
}

#[derive(Clone, Debug)]
pub struct Swarm {
    /// Identifier-safe name, unique in the shot.
    pub name: String,
    pub count: usize,
    pub model: ModelKind,
    /// Name of the preset the parameters started from (or the preset file path).
    pub preset: String,
    pub params: ParamValues,
    pub spawn: Region,
    pub variation: Variation,
    /// The insect's body (`[swarm.bee]`).
    pub bee: Body,
    /// Soft containment box (centre, half extents); `None` = unbounded.
    pub bounds: Option<(Vec3, Vec3)>,
    /// FASTSWARM's velocity database from the shot's `database` file; `None`: the
    /// shipped one.
    pub database: Option<std::sync::Arc<crate::model::fastswarm::database::Database>>,
    /// Fraction of the bees (the first ones, by id) that start inside the hives of the
    /// targets that attract the swarm (`Target::inside`), 0 to 1; bee model only.
    pub start_inside: f32,
}

/// A volume bees are spawned in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Region {
    Box { center: Vec3, half: Vec3 },
    Sphere { center: Vec3, radius: f32 },
}

impl Region {
    pub fn center(&self) -> Vec3 {
        match *self {
            Region::Box { center, .. } | Region::Sphere { center, .. } => center,
        }
    }
    /// Half extents of the bounding box.
    pub fn half_extents(&self) -> Vec3 {
        match *self {
            Region::Box { half, .. } => half,
            Region::Sphere { radius, .. } => Vec3::splat(radius),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    pub name: String,
    /// Where the obstacle stands at the shot's first frame.
    pub shape: Shape,
    /// Placement keys (frame, placement), sorted by frame, of a moving mesh obstacle
    /// (whose `shape` then has a pose); empty for an obstacle that never moves.
    pub keys: Vec<(f64, Placement)>,
}

impl Obstacle {
    /// Where a moving obstacle stands at a (fractional) frame (`None` for a static one):
    /// its keys interpolated as a target's.
    pub fn pose_at(&self, frame: f64) -> Option<crate::geometry::Rigid> {
        if self.keys.is_empty() {
            return None;
        }
        let p = interpolate_keys(&self.keys, frame, |a, b, t| Placement {
            position: a.position.lerp(b.position, t),
            rotation_deg: a.rotation_deg.lerp(b.rotation_deg, t),
        });
        Some(crate::geometry::Rigid {
            rotation: euler_deg(p.rotation_deg),
            translation: p.position,
        })
    }
}

/// A keyed placement of a moving obstacle: where its rest frame's origin is (m) and how
/// it is turned (Euler angles in degrees, X then Y then Z about world axes, as an
/// obstacle's `rotation`). Angles are interpolated, not quaternions, so that keys from 0°
/// to 360° turn the obstacle once round, as in Blender.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub position: Vec3,
    pub rotation_deg: Vec3,
}

/// The value of keys (frame, value), sorted by frame, at a (fractional) frame: `mix`ed
/// linearly between the two keys around it, held before the first and after the last.
/// The one keyframe rule of a shot, for targets and moving obstacles alike.
pub fn interpolate_keys<T: Copy>(keys: &[(f64, T)], frame: f64, mix: impl Fn(T, T, f32) -> T) -> T {
    if frame <= keys[0].0 {
        return keys[0].1;
    }
    for w in keys.windows(2) {
        let ((f0, v0), (f1, v1)) = (w[0], w[1]);
        if frame <= f1 {
            let t = if f1 > f0 {
                ((frame - f0) / (f1 - f0)) as f32
            } else {
                1.0
            };
            return mix(v0, v1, t);
        }
    }
    keys[keys.len() - 1].1
}

#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    pub name: String,
    pub kind: TargetKind,
    /// Position keys (frame, position), sorted by frame; one key = static.
    pub keys: Vec<(f64, Vec3)>,
    /// Size of the target body, m (nests and flowers are sampled on this sphere).
    pub radius: f32,
    /// Attraction, m/s².
    pub strength: f32,
    /// Attraction acts within this distance, m; `f32::INFINITY` = everywhere. For a surface,
    /// the distance from its plane.
    pub reach: f32,
    /// A surface's unit normal, pointing to the side the bees come from (`Vec3::ZERO` for
    /// the other kinds).
    pub normal: Vec3,
    /// Indices of the swarms it attracts (all when the shot names none).
    pub swarms: Vec<usize>,
    /// Bees land on it (a nest or flower with `land = true`), staying a time drawn
    /// uniformly from `stay` (seconds, min ≤ max) before taking off again.
    pub land: bool,
    pub stay: (f32, f32),
    /// A hive entrance (a nest with `land = true` and `inside`): a bee that has stayed its
    /// `stay` on it goes inside for a time drawn uniformly from this range (seconds),
    /// hidden, then comes out onto the entrance, stays again and takes off. `None`: bees
    /// only land on it.
    pub inside: Option<(f32, f32)>,
}

impl Target {
    /// Position at a (fractional) frame: linear between keys, held outside them.
    pub fn position_at(&self, frame: f64) -> Vec3 {
        interpolate_keys(&self.keys, frame, Vec3::lerp)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    /// Output folder (relative paths are relative to the shot file's folder).
    pub dir: PathBuf,
    pub formats: Vec<Format>,
    pub preview: bool,
    pub options: OutputOptions,
}

/// The largest shot or preset file read, bytes: far beyond any hand-written or generated
/// shot, and a bound on what a path to an endless file (`/dev/zero`) can make us read.
pub const MAX_FILE_BYTES: u64 = 16 << 20;

/// Reads a whole file of at most [`MAX_FILE_BYTES`]; a larger one (or an endless one)
/// is an `InvalidData` error saying so, read no further than the limit.
pub fn read_bounded(path: &Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "larger than {} MB: not a shot or preset file",
                MAX_FILE_BYTES >> 20
            ),
        ));
    }
    Ok(bytes)
}

/// An error about `key` (a dotted path such as `swarm[0].count`) of a shot already read,
/// located in its text `src` (the file `file`): for limits found after the shot resolved.
pub fn error_at(
    file: &Path,
    src: &str,
    key: &str,
    message: String,
    hint: Option<String>,
) -> ShotError {
    let loc = locate::Locator::new(src);
    let (line, column, source_line) = match loc.span_of(key) {
        Some(span) => {
            let (l, c, s) = loc.line_col(span.start);
            (l, c, Some(s))
        }
        None => (0, 0, None),
    };
    ShotError {
        file: file.to_path_buf(),
        line,
        column,
        key: key.to_owned(),
        message,
        source_line,
        hint,
    }
}

/// Reads and resolves a shot file.
pub fn load(path: &Path) -> Result<Shot, ShotError> {
    let error = |line, column, message: String, hint: Option<&str>| ShotError {
        file: path.to_path_buf(),
        line,
        column,
        key: String::new(),
        message,
        source_line: None,
        hint: hint.map(str::to_owned),
    };
    let bytes = read_bounded(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => error(
            0,
            0,
            "no such shot file".to_owned(),
            Some("check the path; `beeswarm bake` without a file bakes the built-in demo shot"),
        ),
        std::io::ErrorKind::IsADirectory => {
            error(0, 0, "this is a folder, not a shot file".to_owned(), None)
        }
        _ => error(0, 0, format!("cannot read the shot file: {e}"), None),
    })?;
    let src = String::from_utf8(bytes).map_err(|e| {
        // Point at the first byte that is not UTF-8 (binary data, or another encoding).
        let valid = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let before = String::from_utf8_lossy(&bytes[..valid]);
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
        error(
            line,
            column,
            format!(
                "not a text file: byte 0x{:02x} is not UTF-8 (expected TOML text in UTF-8)",
                bytes[valid]
            ),
            Some("save the shot as UTF-8 text, or check that this is the right file"),
        )
    })?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    parse(&src, path, &base)
}

/// Resolves shot text. `file` names it in errors; `base` is the folder relative paths
/// (preset files, the output folder) are resolved against.
pub fn parse(src: &str, file: &Path, base: &Path) -> Result<Shot, ShotError> {
    resolve::resolve(src, file, base)
}

/// The embedded default shot (a hive entrance with an obstacle), writing to `./out/`.
pub fn embedded_default() -> Shot {
    parse(
        EMBEDDED_DEFAULT,
        Path::new("<embedded default shot>"),
        Path::new("."),
    )
    .expect("the embedded default shot is valid")
}
