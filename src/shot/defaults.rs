//! Every default value of the shot format, in one place (documented in docs/shot-format.md).

pub const SHOT_NAME: &str = "beeswarm";
pub const FPS: f64 = 24.0;
pub const FRAMES: [i64; 2] = [1, 120];
pub const SUBSTEPS: i64 = 4;
pub const SEED: i64 = 1;

pub const SWARM_NAME: &str = "swarm";
pub const MODEL: &str = "bee";

pub const SPAWN_CENTER: [f64; 3] = [0.0, 1.0, 0.0];
pub const SPAWN_SIZE: [f64; 3] = [1.0, 1.0, 1.0];
/// A spawn box without a `size` holds at most this many agents per cubic metre: it is the
/// 1 m cube up to 500 agents and grows with the count beyond (a real swarm cluster is
/// denser, but a shot that names no region wants room to fly, not a crush).
pub const SPAWN_DENSITY: f64 = 500.0;

/// The default spawn box for `count` agents: `SPAWN_SIZE` up to `SPAWN_DENSITY` agents per
/// m³, else a cube of `count / SPAWN_DENSITY` m³; its default centre keeps it above the
/// ground (y = 0) at `SPAWN_CENTER`'s height or higher. Returns (centre, size).
pub fn spawn_box(count: i64) -> ([f64; 3], [f64; 3]) {
    let side = (count as f64 / SPAWN_DENSITY).cbrt().max(SPAWN_SIZE[0]);
    let y = SPAWN_CENTER[1].max(side / 2.0);
    ([SPAWN_CENTER[0], y, SPAWN_CENTER[2]], [side; 3])
}
/// Default soft bounds: the spawn box grown by this margin on every side, m.
pub const BOUNDS_MARGIN: f64 = 1.5;

pub const VARIATION_SIZE: f64 = 0.1;
pub const VARIATION_SPEED: f64 = 0.15;
pub const VARIATION_PHASE: f64 = 1.0;

/// A honeybee worker (Apis mellifera).
pub const BEE_LENGTH: f64 = 0.012;
pub const BEE_RADIUS: f64 = 0.002;
pub const BEE_MASS: f64 = 1.0e-4;
pub const BEE_WING_AREA: f64 = 4.0e-5;
pub const BEE_WING_BEAT_HZ: f64 = 230.0;

/// Per target kind: (radius m, strength m/s²).
pub const NEST: (f64, f64) = (0.08, 3.0);
/// How long a bee stays on a target it lands on, seconds: drawn uniformly from this range.
pub const STAY_S: (f64, f64) = (2.0, 6.0);
pub const FLOWER: (f64, f64) = (0.03, 2.0);
pub const ATTRACTOR: (f64, f64) = (0.05, 2.0);
pub const SURFACE: (f64, f64) = (0.05, 1.0);
/// Paper 002's stimuli: their strength multiplies the zonal model's χ_res.
pub const STIMULUS: (f64, f64) = (0.05, 1.0);

pub const OUTPUT_DIR: &str = "out";
pub const OUTPUT_FORMATS: [&str; 2] = ["glb", "usda"];
/// How wings are drawn when the shot does not say: a blurred stroke, what a camera sees of
/// a real 230 Hz beat (see docs/caches.md, Wings).
pub const WINGS: &str = "blur";
/// The visible flap rate of `wings = "flap"` when `wing_flap_hz` is not given: 6 Hz, or a
/// sixth of the frame rate if that is less (4 Hz at 24 fps: six keys per beat, so every
/// phase group shows a full stroke).
pub const WING_FLAP_HZ: f64 = 6.0;
/// The glTF layout when the shot does not say: today's node per part.
pub const GLTF_LAYOUT: &str = "parts";

/// Thickness of a `mode = "shell"` mesh obstacle, m: a thin board, so bees never graze
/// an open surface edge-on.
pub const MESH_SHELL_THICKNESS: f64 = 0.01;
