//! What the simulation records each frame: the contract between `sim` and `export`.
//!
//! Conventions (every field): metres, seconds, Y-up right-handed world; body frame X forward
//! (thrust), Y up (lift), Z right (sway). Quaternions are glam's `Quat`, component order
//! (x, y, z, w), rotating body → world. What else a model records per agent (a honeybee:
//! pitch, roll, sway) is a list of named channels described by `SwarmMeta::channels`, and
//! how the agents are drawn is `SwarmMeta::species`.

use crate::species::{Channel, Species};
use glam::{Quat, Vec3};

/// One swarm's state at one recorded frame. Every vector has one entry per agent, in the
/// same order in every frame (the order of `ids`).
#[derive(Clone, Debug, Default)]
pub struct SwarmFrame {
    /// Stable agent ids, unique across the whole shot and constant through it.
    pub ids: Vec<u64>,
    /// Position of the body's centre of mass, metres.
    pub position: Vec<Vec3>,
    /// Velocity, metres per second.
    pub velocity: Vec<Vec3>,
    /// Full body orientation, body → world.
    pub orientation: Vec<Quat>,
    /// Heading only: rotation about world +Y that turns body +X onto the horizontal
    /// direction of travel; `heading⁻¹ · orientation` is the body's attitude (a honeybee:
    /// `Rz(pitch) · Rx(roll)`).
    pub heading: Vec<Quat>,
    /// Angular velocity of the body, degrees per second, world frame.
    pub angular_velocity_deg: Vec<Vec3>,
    /// Uniform scale of the prototype (1 = the swarm's nominal body length). Constant
    /// per agent through a shot: the USDA writer writes it once and refuses a change.
    pub scale: Vec<f32>,
    /// The model's channels: one column per entry of `SwarmMeta::channels`, in that order,
    /// each with one value per agent, in the channel's unit.
    pub channels: Vec<Vec<f32>>,
}

impl SwarmFrame {
    pub fn len(&self) -> usize {
        self.ids.len()
    }
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Whether agent `i` is hidden at this frame, by its swarm's `SwarmMeta::hidden`.
    pub fn is_hidden(&self, rule: Option<(usize, f32)>, i: usize) -> bool {
        rule.is_some_and(|(c, v)| self.channels[c][i] == v)
    }

    /// Agent `i`'s value of channel column `column` (`None`: 0), e.g. the lateral offset.
    pub fn channel_or_zero(&self, column: Option<usize>, i: usize) -> f32 {
        column.map_or(0.0, |c| self.channels[c][i])
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

/// Static facts about one swarm.
#[derive(Clone, Debug)]
pub struct SwarmMeta {
    /// Unique, identifier-safe name (`[A-Za-z_][A-Za-z0-9_]*`).
    pub name: String,
    pub count: usize,
    /// How the agents are drawn (parts, meshes, what drives each part).
    pub species: &'static Species,
    /// What the model records per agent each frame, the order of `SwarmFrame::channels`.
    pub channels: Vec<Channel>,
    /// Nominal body length of an agent of scale 1, metres (a honeybee: 0.012).
    pub body_length_m: f32,
    /// Wing beat frequency of the real insect, Hz (a honeybee: about 230).
    pub wing_beat_hz: f32,
    /// Agents hidden from view at a frame (bees inside their hive) are those whose channel
    /// column `.0` holds `.1` then. `None`: the swarm never hides one, and its caches carry
    /// no visibility data (a bee swarm without a hive).
    pub hidden: Option<(usize, f32)>,
}

impl SwarmMeta {
    /// The column of `SwarmFrame::channels` holding the channel called `name`.
    pub fn channel(&self, name: &str) -> Option<usize> {
        self.channels.iter().position(|c| c.name == name)
    }

    /// The column holding the body's lateral offset (`species.lateral_offset`), if the
    /// swarm records it.
    pub fn lateral_offset(&self) -> Option<usize> {
        self.species.lateral_offset.and_then(|n| self.channel(n))
    }
}
