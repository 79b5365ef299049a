//! What the simulation records each frame: the contract between `sim` and `export`.
//!
//! Conventions (every field): metres, seconds, Y-up right-handed world; body frame X forward
//! (thrust), Y up (lift), Z right (sway). Quaternions are glam's `Quat`, component order
//! (x, y, z, w), rotating body → world. Angles stored as scalars are degrees.

use glam::{Quat, Vec3};

/// One swarm's state at one recorded frame. Every vector has one entry per bee, in the
/// same order in every frame (the order of `ids`).
#[derive(Clone, Debug, Default)]
pub struct SwarmFrame {
    /// Stable bee ids, unique across the whole shot and constant through it.
    pub ids: Vec<u64>,
    /// Position of the body's centre of mass, metres.
    pub position: Vec<Vec3>,
    /// Velocity, metres per second.
    pub velocity: Vec<Vec3>,
    /// Full body orientation (heading, then pitch, then roll), body → world.
    pub orientation: Vec<Quat>,
    /// Heading only: rotation about world +Y that turns body +X onto the horizontal
    /// direction of travel. `orientation = heading * Rz(pitch) * Rx(roll)`.
    pub heading: Vec<Quat>,
    /// Body pitch, degrees, nose up positive (rotation about body +Z).
    pub pitch_deg: Vec<f32>,
    /// Body roll, degrees, right wing down positive (rotation about body +X).
    pub roll_deg: Vec<f32>,
    /// Sway: lateral offset of the body from its mean path, metres, along the heading
    /// frame's +Z (right). See docs/model.md.
    pub sway_m: Vec<f32>,
    /// Angular velocity of the body, degrees per second, world frame.
    pub angular_velocity_deg: Vec<Vec3>,
    /// Uniform scale of the bee prototype (1 = the swarm's nominal bee length).
    pub scale: Vec<f32>,
}

impl SwarmFrame {
    pub fn len(&self) -> usize {
        self.ids.len()
    }
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }
}

/// Everything recorded at one frame.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    /// Frame number (the shot's frame range, inclusive).
    pub frame: i32,
    /// Seconds since the first frame: `(frame - start) / fps`.
    pub time: f64,
    /// One entry per swarm, in shot order.
    pub swarms: &'a [SwarmFrame],
}

/// Static facts about a cache, known before the first frame.
#[derive(Clone, Debug)]
pub struct CacheMeta {
    pub shot_name: String,
    pub fps: f64,
    /// First and last frame, inclusive.
    pub frame_start: i32,
    pub frame_end: i32,
    pub seed: u64,
    /// `CARGO_PKG_VERSION` of the tool that wrote the cache.
    pub tool_version: String,
    pub swarms: Vec<SwarmMeta>,
}

impl CacheMeta {
    pub fn frame_count(&self) -> usize {
        (self.frame_end - self.frame_start + 1) as usize
    }
}

#[derive(Clone, Debug)]
pub struct SwarmMeta {
    /// Unique, identifier-safe name (`[A-Za-z_][A-Za-z0-9_]*`).
    pub name: String,
    pub count: usize,
    /// Nominal body length of a bee of scale 1, metres (a honeybee: 0.012).
    pub bee_length_m: f32,
    /// Wing beat frequency of the real insect, Hz (a honeybee: about 230).
    pub wing_beat_hz: f32,
}
