//! Wing display, shared by the glTF and USD writers so both formats draw the same wings.
//!
//! A honeybee beats its wings at about 230 Hz; sampled once per frame at 24–60 fps that
//! aliases into noise (or into a slow, wrong-way beat). The caches draw one of three
//! stand-ins instead ([`WingDisplay`], `[output] wings`):
//!
//! - **still**: the wing held at mid-stroke, a clear membrane (alpha [`ALPHA_CLEAR`]).
//! - **blur**: [`BLUR_COPIES`] faint copies of the wing fanned over the whole stroke, static:
//!   what a long exposure of the real beat shows. The copies are baked into the wing mesh.
//! - **flap**: a stylised flap at a visible rate, rotating about the hinge, in
//!   [`PHASES`] phase groups by agent id, so a swarm does not beat in lockstep while every
//!   agent of a group shares one track (glTF) or one prototype (USD).
//!
//! Conventions as in `species`: a `Drive::Flap` part turns about its own X axis (the hinge
//! line), tip up positive; the right wing's tip points +Z, so raising it is a negative turn.

pub use crate::shot::WingDisplay;
use crate::species::Primitive;
use glam::{Quat, Vec3};

/// Mid-stroke: the wing raised this many degrees. The still pose and the centre of the
/// flap and of the blur fan.
pub const MID_DEG: f32 = 15.0;
/// Half the stroke, degrees: the flap swings `MID_DEG ± AMPLITUDE_DEG`.
pub const AMPLITUDE_DEG: f32 = 50.0;
/// Phase groups of a flapping swarm (agent id modulo this).
pub const PHASES: u64 = 8;
/// Opacity of a still or flapping wing membrane.
pub const ALPHA_CLEAR: f32 = 0.45;
/// Opacity of each ghosted copy in the blur fan: faint, so the fan reads as a blur and the
/// overlap near the hinge (where every copy meets) stays see-through.
pub const ALPHA_BLUR: f32 = 0.16;
/// Ghosted copies in the blur fan, spread evenly over the stroke.
pub const BLUR_COPIES: usize = 5;

/// Butterflies (a species whose parts turn by a recorded `flap` channel, `Drive::Channel`)
/// are drawn in USD by prototypes with the wings posed at [`FLAP_BINS`] flap angles,
/// [`FLAP_BIN_DEG`] apart from [`FLAP_BIN_LO_DEG`] (−90° … +90°), and each instance takes,
/// frame by frame, the prototype of the bin nearest its recorded angle (`protoIndices`
/// time-sampled). 10° bins: the drawn wing is within 5° of the recorded one over a stroke
/// of about 150°, and 19 prototypes cost one reference each, the meshes written once.
pub const FLAP_BINS: usize = 19;
/// Width of a flap bin, degrees.
pub const FLAP_BIN_DEG: f32 = 10.0;
/// Flap angle of bin 0, degrees (tips down).
pub const FLAP_BIN_LO_DEG: f32 = -90.0;

/// The flap angle, degrees, a bin's prototype poses its wings at.
pub fn flap_bin_deg(bin: usize) -> f32 {
    FLAP_BIN_LO_DEG + FLAP_BIN_DEG * bin as f32
}

/// The bin nearest a recorded flap angle (degrees, finite); angles beyond ±90° take the
/// last bin on their side.
pub fn flap_bin(flap_deg: f32) -> usize {
    let k = ((flap_deg - FLAP_BIN_LO_DEG) / FLAP_BIN_DEG).round();
    k.clamp(0.0, (FLAP_BINS - 1) as f32) as usize
}

/// The phase group of an agent.
pub fn group(id: u64) -> usize {
    (id % PHASES) as usize
}

/// The membrane opacity a display draws wings with.
pub fn alpha(display: WingDisplay) -> f32 {
    match display {
        WingDisplay::Blur => ALPHA_BLUR,
        WingDisplay::Still | WingDisplay::Flap { .. } => ALPHA_CLEAR,
    }
}

/// Wing elevation, degrees, at `t` seconds after the first frame for phase group `group`.
pub fn angle(flap_hz: f64, t: f64, group: usize) -> f32 {
    let phase = std::f64::consts::TAU * (flap_hz * t + group as f64 / PHASES as f64);
    MID_DEG + AMPLITUDE_DEG * phase.sin() as f32
}

/// The turn about the hinge (part X axis), degrees, that raises a wing by `up_deg`.
pub fn turn_deg(up_deg: f32, right: bool) -> f32 {
    if right { -up_deg } else { up_deg }
}

/// Rotation of a wing raised by `up_deg` (tip up).
pub fn rotation(up_deg: f32, right: bool) -> Quat {
    Quat::from_rotation_x(turn_deg(up_deg, right).to_radians())
}

/// The rest elevation of a wing under a display: mid-stroke, except in the blur, whose fan
/// already spans the stroke in the mesh; a flap starts where group `group` is at t = 0.
pub fn rest_up_deg(display: WingDisplay, group: usize) -> f32 {
    match display {
        WingDisplay::Still => MID_DEG,
        WingDisplay::Blur => 0.0,
        WingDisplay::Flap { hz } => angle(hz, 0.0, group),
    }
}

/// The wing mesh a display draws: the wing itself, or for the blur its fan of
/// [`BLUR_COPIES`] copies turned about the hinge from `MID − AMPLITUDE` to `MID + AMPLITUDE`.
pub fn mesh(wing: &Primitive, display: WingDisplay, right: bool) -> Primitive {
    if display != WingDisplay::Blur {
        return wing.clone();
    }
    let mut fan = Primitive::default();
    for k in 0..BLUR_COPIES {
        let f = k as f32 / (BLUR_COPIES - 1) as f32;
        let up = MID_DEG - AMPLITUDE_DEG + 2.0 * AMPLITUDE_DEG * f;
        fan.extend(&wing.transformed(rotation(up, right), Vec3::ZERO));
    }
    fan
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flap_angles_span_the_stroke_and_groups_are_shifted() {
        let hz = 4.0;
        let a: Vec<f32> = (0..48).map(|k| angle(hz, k as f64 / 48.0, 0)).collect();
        let hi = a.iter().copied().fold(f32::MIN, f32::max);
        let lo = a.iter().copied().fold(f32::MAX, f32::min);
        assert!((hi - (MID_DEG + AMPLITUDE_DEG)).abs() < 1e-3);
        assert!((lo - (MID_DEG - AMPLITUDE_DEG)).abs() < 1e-3);
        assert!((angle(hz, 0.0, 2) - (MID_DEG + AMPLITUDE_DEG)).abs() < 1e-3);
        assert_ne!(angle(hz, 0.1, 1), angle(hz, 0.1, 2));
    }

    #[test]
    fn flap_bins_are_nearest_and_clamped() {
        assert_eq!(flap_bin(-90.0), 0);
        assert_eq!(flap_bin(-200.0), 0);
        assert_eq!(flap_bin(200.0), FLAP_BINS - 1);
        assert_eq!(flap_bin_deg(FLAP_BINS - 1), 90.0);
        for a in [-84.9f32, -3.0, 0.0, 4.9, 10.0, 37.6, 85.0] {
            assert!(
                (flap_bin_deg(flap_bin(a)) - a).abs() <= 0.5 * FLAP_BIN_DEG + 1e-4,
                "{a}"
            );
        }
    }

    #[test]
    fn blur_fan_holds_the_wing_at_every_copy_angle() {
        let m = crate::species::honeybee::BeeMesh::new(0.012);
        let fan = mesh(&m.wing_right, WingDisplay::Blur, true);
        let n = m.wing_right.positions.len();
        assert_eq!(fan.positions.len(), BLUR_COPIES * n);
        assert_eq!(fan.indices.len(), BLUR_COPIES * m.wing_right.indices.len());
        // The tip (largest z) of the first and last copies: the stroke's two ends.
        let tip = |copy: usize| {
            fan.positions[copy * n..(copy + 1) * n]
                .iter()
                .map(|p| Vec3::from(*p))
                .max_by(|a, b| a.length().total_cmp(&b.length()))
                .unwrap()
        };
        let up = |p: Vec3| p.y.atan2(p.z).to_degrees();
        assert!((up(tip(0)) - (MID_DEG - AMPLITUDE_DEG)).abs() < 1.0);
        assert!((up(tip(BLUR_COPIES - 1)) - (MID_DEG + AMPLITUDE_DEG)).abs() < 1.0);
        assert_eq!(mesh(&m.wing_right, WingDisplay::Still, true), m.wing_right);
    }
}
