//! Models: how one swarm's agents decide, one folder per model, behind one interface.
//!
//! A model owns its parameters (declared once, see [`params`]), its per-agent state, its
//! per-step decision and the channels it records. The world (`crate::sim`) owns the
//! storage and the passes, and lends each step a read-only [`Context`]: neighbours in grid
//! order, obstacle queries, targets at their current positions, wind, time and step, and
//! deterministic per-agent random streams. The world calls a model once per swarm per
//! pass; every agent loop inside is monomorphised for that model (no dynamic call per
//! agent). docs/architecture.md walks through adding a model.
//!
//! Every function here returns accelerations (m/s²) or velocities (m/s) in the world frame
//! unless it says otherwise.

pub mod attitudes;
pub mod bee;
pub mod boids;
pub mod brownian;
pub mod butterfly;
pub mod collision;
pub mod context;
pub mod curl;
pub mod curl_now;
pub mod fastswarm;
pub mod field;
pub mod flight;
pub mod params;
pub mod targets;
pub mod vision;
pub mod zonal;

pub use bee::BeeParams;
pub use context::{Context, Neighbour, TargetNow};
pub use params::{ParamSpec, ParamValues, Preset};
pub use targets::TargetKind;

use crate::geometry::Shape;
use crate::math::Rng;
use crate::species::{Channel, Species};
use glam::{Quat, Vec3};

/// Every model of the tool: each line registers one model folder (its `model = "…"` name
/// and its type). `with_model!(kind, M => expr)` evaluates `expr` with `M` naming the
/// model's type, which is how the world builds a statically dispatched runner per swarm.
macro_rules! registry {
    ($d:tt $($variant:ident => $ty:path,)*) => {
        /// The model a swarm flies with (`model = "…"` in a shot).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum ModelKind { $($variant,)* }

        impl ModelKind {
            pub const ALL: &'static [ModelKind] = &[$(ModelKind::$variant,)*];

            /// What the model is: name, parameters, presets, channels, species.
            pub fn info(self) -> &'static ModelInfo {
                match self { $(ModelKind::$variant => &<$ty as Model>::INFO,)* }
            }
        }

        macro_rules! with_model {
            ($d kind:expr, $d m:ident => $d body:expr) => {
                match $d kind {
                    $($crate::model::ModelKind::$variant => {
                        type $d m = $ty;
                        $d body
                    })*
                }
            };
        }
        pub(crate) use with_model;
    };
}

registry! {$
    Bee => crate::model::bee::BeeModel,
    Curl => crate::model::curl::CurlModel,
    Brownian => crate::model::brownian::BrownianModel,
    Boids => crate::model::boids::BoidsModel,
    Field => crate::model::field::FieldModel,
    Fastswarm => crate::model::fastswarm::FastswarmModel,
    Zonal => crate::model::zonal::ZonalModel,
    Butterfly => crate::model::butterfly::ButterflyModel,
}

impl ModelKind {
    /// The name a shot uses: `model = "bee"`.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    pub fn parse(name: &str) -> Option<ModelKind> {
        Self::ALL.iter().copied().find(|m| m.name() == name)
    }

    /// The preset a swarm of this model starts from when it names none.
    pub fn default_preset(self) -> &'static str {
        self.info().presets[0].name
    }
}

/// The static description of a model, for the shot loader, `beeswarm models` and the
/// writers.
#[derive(Debug)]
pub struct ModelInfo {
    /// `model = "…"` in a shot.
    pub name: &'static str,
    /// One line: what it is and where it comes from.
    pub summary: &'static str,
    pub params: &'static [ParamSpec],
    /// Built-in presets; the first is the default.
    pub presets: &'static [Preset],
    /// What the model records per agent per frame, besides the pose.
    pub channels: &'static [Channel],
    /// How its agents are drawn.
    pub species: &'static Species,
}

/// The physical insect. Defaults are a honeybee worker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Body length, m.
    pub length: f32,
    /// Capsule radius r of paper 000 Eq. 10–11, m.
    pub radius: f32,
    /// Mass, kg.
    pub mass: f32,
    /// Total wing area A of paper 000 Eq. 2, m².
    pub wing_area: f32,
    /// Real wing beat frequency, Hz.
    pub wing_beat_hz: f32,
}

/// Per-agent variation, as fractions: each agent draws a factor in [1 − v, 1 + v].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variation {
    pub size: f32,
    pub speed: f32,
    /// Spread of the oscillation phase as a fraction of a cycle (1 = fully random).
    pub phase: f32,
}

/// Everything a model is built from, for one swarm of a shot.
#[derive(Clone, Debug)]
pub struct SwarmSetup<'a> {
    /// The swarm's index in the shot (separates its random streams and noise fields).
    pub index: usize,
    pub seed: u64,
    /// Substep length, seconds.
    pub dt: f64,
    pub params: &'a ParamValues,
    pub body: Body,
    pub variation: Variation,
    /// Soft containment box (centre, half extents).
    pub bounds: Option<(Vec3, Vec3)>,
    /// Indices of the targets that attract this swarm.
    pub targets: Vec<usize>,
    /// The shot's obstacles where they stand at the first frame: what a model precomputes
    /// a field from once per shot (a distance or path field; such a model sets
    /// [`Model::STATIC_OBSTACLES`]), besides querying them each step through the `Context`.
    pub obstacles: &'a [Shape],
    /// The recorded velocity database a FASTSWARM swarm draws from (the shot's
    /// `database`); `None`: the shipped mosquito database. Other models ignore it.
    pub database: Option<std::sync::Arc<crate::model::fastswarm::database::Database>>,
}

/// Where and how the world places a new agent; the model adds its own state.
#[derive(Clone, Copy, Debug)]
pub struct Start {
    pub pos: Vec3,
    /// Unit direction of travel.
    pub dir: Vec3,
    /// Body scale factor (variation).
    pub size: f32,
    /// Factor on the model's preferred speed (variation): 1 ± `variation.speed`.
    pub speed_factor: f32,
    /// The agent starts inside a hive (the swarm's `start_inside`); `pos` is then on the
    /// hive's entrance. Only bee swarms get one.
    pub inside: Option<StartInside>,
}

/// Where an agent that starts inside a hive is.
#[derive(Clone, Copy, Debug)]
pub struct StartInside {
    /// The hive's target index.
    pub target: usize,
    /// The agent's place on the entrance, from the target's centre, m.
    pub offset: Vec3,
    /// Seconds before it comes out.
    pub time_left: f32,
}

/// What every agent state exposes to the world.
pub trait Agent: Copy + Send + Sync {
    fn position(&self) -> Vec3;
    fn velocity(&self) -> Vec3;
    /// Body scale factor.
    fn size(&self) -> f32;
    /// Places the agent (tools and tests that need exact starting conditions).
    fn place(&mut self, position: Vec3, velocity: Vec3);
    /// Whether the agent is out of the world for now (a bee inside its hive): it is no
    /// other agent's neighbour, and the caches hide it (`Model::HIDDEN_STATE`).
    fn hidden(&self) -> bool {
        false
    }
}

/// An agent's attitude for the caches.
#[derive(Clone, Copy, Debug)]
pub struct Pose {
    /// Full body orientation, body → world (glam `Quat`, x y z w).
    pub orientation: Quat,
    /// Heading only: rotation about world +Y.
    pub heading: Quat,
    /// Angular velocity over the last substep, degrees per second, world frame (zero
    /// when not asked for: `Model::poses`).
    pub angular_velocity_deg: Vec3,
}

/// One model. `Self` holds the per-swarm constants (built once per shot); `Agent` is the
/// per-agent state the world stores and double-buffers.
pub trait Model: Sized + Send + Sync {
    type Agent: Agent;
    const INFO: ModelInfo;
    /// Whether the model has a gather pass (paper 000's SPH density) before the step.
    const GATHERS: bool = false;
    /// Whether the world may reuse this model's neighbour candidates over substeps (`sim::
    /// skin`). Reused lists come in id order, not the grid's, which changes the last
    /// bits of sums over neighbours; a model opts in once its results were checked with
    /// them (zonal). The bee and boids do not: their caches stay as without candidates,
    /// even where they fly slowly enough to keep some (the mosquito cage).
    const KEEPS_CANDIDATES: bool = false;
    /// The channel and value that mark an agent hidden at a frame in the recording (a bee
    /// inside its hive: `state` 3), so that the writers can hide it; the same agents as
    /// `Agent::hidden`. `None`: the model never hides one.
    const HIDDEN_STATE: Option<(&'static str, f32)> = None;
    /// Whether the model builds something from the obstacles once per shot (a path cost
    /// field) that would go stale if one moved: a shot refuses moving obstacles for it.
    const STATIC_OBSTACLES: bool = false;

    fn new(setup: &SwarmSetup) -> Self;

    /// How far beyond body contact this model looks at neighbours, m (0: contacts only).
    fn reach(&self) -> f32;

    /// Whether the step reads its neighbour list at all. A model that never does (paper
    /// 004's butterflies outside a chase) spares the world the list, and a shot of such
    /// models spares it the neighbour grid.
    fn lists_neighbours(&self) -> bool {
        true
    }

    /// Spacing of the virtual particles this model wants on target bodies, m (`None`: it
    /// does not feel target bodies).
    fn target_particle_spacing(&self) -> Option<f32> {
        None
    }

    /// Once per swarm per substep, before any agent steps, with the context the step pass
    /// will see and the swarm's range in its agents: for what a model derives from the
    /// world's moving parts (paper 001's path field follows its goals), or works out for
    /// all its agents at once (the curl noise). Nothing by default.
    fn prepare(&mut self, _cx: &Context, _agents: std::ops::Range<usize>) {}

    /// A new agent: the world drew its place, direction, size and speed from `rng`; the
    /// model draws the rest of its state from the same stream.
    fn spawn(&self, start: &Start, rng: &mut Rng) -> Self::Agent;

    /// Gather pass, per listed neighbour and once for the agent itself (at `d2` = 0): a term of the sum (`ri` is this agent's
    /// body radius, `d2` the squared distance).
    fn gather_term(&self, _ri: f32, _other: &Neighbour, _d2: f32) -> f32 {
        0.0
    }

    /// The gather pass's sum over a whole neighbour list (`agents` by index) at once, from
    /// `own` (the agent's own term), where the model can: the same bits as adding
    /// `gather_term` one neighbour at a time in the list's order. `None` (the default):
    /// one at a time.
    fn gather_list(
        &self,
        _me: &Neighbour,
        _agents: &[Neighbour],
        _list: &[u32],
        _own: f32,
    ) -> Option<f32> {
        None
    }

    /// Gather pass, per agent: (density, pressure) from the neighbours' sum.
    fn gather_finish(&self, _targets: &[TargetNow], _pos: Vec3, _ri: f32, _sum: f32) -> (f32, f32) {
        (0.0, 0.0)
    }

    /// The agent's next state after one substep. `i` is its global index.
    fn step(&self, cx: &Context, i: usize, agent: &Self::Agent) -> Self::Agent;

    /// Four agents' attitudes for the caches (the recording pass asks in fours, a swarm's
    /// last agent repeated to fill the last four); their angular velocities over the last
    /// substep, `spin_dt` seconds long, only when asked for (`None`: zero, and not worked
    /// out). Each agent's pose must depend on that agent alone. Models answer with
    /// [`attitudes::poses`], four agents in SIMD lanes.
    fn poses(&self, agents: [&Self::Agent; 4], spin_dt: Option<f32>) -> [Pose; 4];

    /// Writes one value per channel of `INFO.channels`.
    fn record(&self, agent: &Self::Agent, pose: &Pose, channels: &mut [f32]);
}
