//! Blade-element aerodynamics of paper 004 (Sec. 5.1, Eq. 4–6) on the four wings.
//!
//! Each wing is a few strips from root to tip (blade elements; the paper sums over the
//! polygons of its mesh, Eq. 6). Per element, V is the air's velocity relative to the
//! element: the wind minus the body's velocity minus the element's own velocity from the
//! wing's rotation (flap, feather, sweep of Eq. 1). Eq. 5's angle of attack is
//! α = arctan(|Vⁿ| / |Vᵗ|) with Vⁿ along the wing's normal and Vᵗ in the wing's plane
//! *across* the span (the paper writes "base-to-tip", i.e. along the span, but flow along
//! the span makes no angle of attack: every flapping element would sit at 90°). Eq. 4:
//! |F| = ½ ρ A |V|² C(α), drag along V, lift perpendicular to V towards the side of the
//! wing the air pushes on.
//!
//! Fig. 6's coefficients, α in degrees. The drag polynomial is printed as is (0.51 at 0°,
//! 4.6 at 90°, flat at 90°: the shape of a flapping wing's drag). The printed lift
//! polynomial, −0.0095953α² + 0.090635α − 0.34182, is negative for every α (its
//! discriminant is negative) and reaches −70 at 90°. Read with a quadratic coefficient ten
//! times smaller, −0.00095953α² + 0.090635α − 0.34182, it is the lift curve of a flapping
//! wing: zero near 4° and 90°, at most 1.80 at 47° (docs/model.md, "Paper 004: lift").
//!
//! Body frame as everywhere: X forward, Y up, Z right; metres, seconds; forces in newtons.

use super::maneuvering::{Angle, angle, angle_rate};
use crate::math::normalize_or;
use crate::species::butterfly::{FORE_HINGE, HIND_BACK_DEG, HIND_HINGE};
use glam::{Quat, Vec3};

/// C_l(α), α in degrees (Fig. 6 with the quadratic coefficient read as −0.00095953).
#[inline]
pub fn lift_coefficient(alpha_deg: f32) -> f32 {
    let a = alpha_deg;
    -0.000_959_53 * a * a + 0.090_635 * a - 0.341_82
}

/// C_d(α), α in degrees (Fig. 6 as printed).
#[inline]
pub fn drag_coefficient(alpha_deg: f32) -> f32 {
    let a = alpha_deg;
    ((-0.000_007_951_8 * a + 0.001_152_7) * a + 0.006_314_8) * a + 0.511_27
}

/// Blade elements per wing.
pub const ELEMENTS: usize = 4;
/// Share of the wing area on the forewings (the rest on the hindwings).
const FORE_SHARE: f32 = 0.55;

/// One strip of a wing, in the wing frame (span +Z, chord forward +X, upper side +Y) of a
/// right wing, for a butterfly of span 1 m and wing area 1 m².
#[derive(Clone, Copy, Debug)]
struct Element {
    /// Centre of the strip.
    at: Vec3,
    /// Its share of the total wing area.
    area: f32,
}

/// A right wing; the left one is its mirror image (z → −z). Hinges and the hindwings' rest
/// angle are the drawn butterfly's (`species::butterfly`).
#[derive(Clone, Copy, Debug)]
struct Wing {
    /// Hinge on the thorax, body frame, for span 1 m.
    hinge: Vec3,
    /// Wing frame → body frame at rest.
    rest: Quat,
    /// A forewing flaps, feathers and sweeps; a hindwing only flaps (Sec. 4.1).
    fore: bool,
    elements: [Element; ELEMENTS],
}

impl Wing {
    fn new(
        hinge: Vec3,
        rest: Quat,
        fore: bool,
        length: f32,
        root_chord: f32,
        tip_chord: f32,
        share: f32,
    ) -> Self {
        let chord = |u: f32| root_chord + (tip_chord - root_chord) * u;
        let dr = length / ELEMENTS as f32;
        let raw: [f32; ELEMENTS] =
            std::array::from_fn(|k| chord((k as f32 + 0.5) / ELEMENTS as f32) * dr);
        let total: f32 = raw.iter().sum();
        let elements = std::array::from_fn(|k| {
            let u = (k as f32 + 0.5) / ELEMENTS as f32;
            Element {
                // The leading edge runs along the span axis; the strip's centre is half a
                // chord behind it.
                at: Vec3::new(-0.5 * chord(u), 0.0, u * length),
                area: share * raw[k] / total,
            }
        });
        Wing {
            hinge,
            rest,
            fore,
            elements,
        }
    }

    /// Wing frame → body frame for the angles (degrees) flap, feather and sweep.
    /// `flap` is the flap rotation, `Quat::from_rotation_x(-flap°)`, the same for both
    /// wings: computed once per instant.
    fn rotation(&self, flap: Quat, feather: f32, sweep: f32) -> Quat {
        if self.fore {
            Quat::from_rotation_y(sweep.to_radians())
                * flap
                * self.rest
                * Quat::from_rotation_z(feather.to_radians())
        } else {
            flap * self.rest
        }
    }
}

/// The four wings' geometry of a butterfly of span 1 m and wing area 1 m² (scaled per
/// swarm): forewings from just behind the head, hindwings swept back behind them.
#[derive(Clone, Debug)]
pub struct Wings {
    right: [Wing; 2],
}

/// The wing angles at one instant, degrees, and their rates, degrees per second.
#[derive(Clone, Copy, Debug, Default)]
pub struct WingState {
    pub flap: f32,
    pub feather: f32,
    pub sweep: f32,
    pub flap_rate: f32,
    pub feather_rate: f32,
    pub sweep_rate: f32,
}

impl WingState {
    /// Eq. 1 for the wing angles at flapping phase `phase` (radians), smoothed sigmoid
    /// `s` and flap frequency `hz`.
    pub fn at(s: f32, phase: f32, hz: f32) -> Self {
        WingState {
            flap: angle(Angle::Flap, s, phase),
            feather: angle(Angle::Feather, s, phase),
            sweep: angle(Angle::Sweep, s, phase),
            flap_rate: angle_rate(Angle::Flap, s, phase, hz),
            feather_rate: angle_rate(Angle::Feather, s, phase, hz),
            sweep_rate: angle_rate(Angle::Sweep, s, phase, hz),
        }
    }
}

/// The air a butterfly flies through and how it is built, for one evaluation of Eq. 4–6.
#[derive(Clone, Copy, Debug)]
pub struct Flow {
    /// Body → world.
    pub orientation: Quat,
    /// Body velocity, world frame, m/s.
    pub velocity: Vec3,
    /// Wind, world frame, m/s.
    pub wind: Vec3,
    /// Span, m.
    pub span: f32,
    /// Total wing area, m².
    pub area: f32,
    /// ρ, kg/m³.
    pub density: f32,
}

impl Wings {
    pub fn new() -> Self {
        let fore = Wing::new(
            FORE_HINGE,
            Quat::IDENTITY,
            true,
            0.46,
            0.30,
            0.18,
            FORE_SHARE,
        );
        let hind = Wing::new(
            HIND_HINGE,
            Quat::from_rotation_y(-HIND_BACK_DEG.to_radians()),
            false,
            0.34,
            0.36,
            0.26,
            1.0 - FORE_SHARE,
        );
        Wings {
            right: [fore, hind],
        }
    }

    /// The hinge of the right forewing (`fore`) or hindwing on the thorax, body frame, m,
    /// for a butterfly of span `span` (the left hinges mirror them, z → −z).
    pub fn hinge(&self, fore: bool, span: f32) -> Vec3 {
        self.right[usize::from(!fore)].hinge * span
    }

    /// Eq. 6 summed over the four wings (Σ_j F_j of Eq. 10): the aerodynamic force, N,
    /// world frame.
    pub fn force(&self, w: &WingState, flow: &Flow) -> Vec3 {
        // Rotations now and a moment ago, for each element's velocity from the wing's turn.
        const H: f32 = 1e-3;
        // Everything in the body frame, the left wing as the mirror image of the right one
        // in mirrored air: Eq. 4–5 use only dot products and projections, so mirroring
        // the air and then the force back is exact, and the right wing's geometry serves
        // both sides.
        let mirror = Vec3::new(1.0, 1.0, -1.0);
        let to_body = flow.orientation.inverse();
        let air = to_body * (flow.wind - flow.velocity);
        let air_mirrored = air * mirror;
        let (mut right, mut left) = (Vec3::ZERO, Vec3::ZERO);
        let flap_now = Quat::from_rotation_x(-w.flap.to_radians());
        let flap_before = Quat::from_rotation_x(-(w.flap - w.flap_rate * H).to_radians());
        for wing in &self.right {
            let now = glam::Mat3::from_quat(wing.rotation(flap_now, w.feather, w.sweep));
            let before = glam::Mat3::from_quat(wing.rotation(
                flap_before,
                w.feather - w.feather_rate * H,
                w.sweep - w.sweep_rate * H,
            ));
            let turn = (now - before) * (1.0 / H);
            let (normal, span) = (now.y_axis, now.z_axis);
            // The air's components along the wing's normal and span, once per wing and
            // side; each element subtracts its own turning velocity's.
            let (air_n, air_s) = (air.dot(normal), air.dot(span));
            let (mir_n, mir_s) = (air_mirrored.dot(normal), air_mirrored.dot(span));
            for e in &wing.elements {
                let v_turn = turn * (e.at * flow.span);
                let (turn_n, turn_s) = (v_turn.dot(normal), v_turn.dot(span));
                // Each side carries half the area.
                let area = 0.5 * e.area * flow.area;
                right += element_force_along(
                    air - v_turn,
                    air_n - turn_n,
                    air_s - turn_s,
                    normal,
                    area,
                    flow.density,
                );
                left += element_force_along(
                    air_mirrored - v_turn,
                    mir_n - turn_n,
                    mir_s - turn_s,
                    normal,
                    area,
                    flow.density,
                );
            }
        }
        flow.orientation * (right + left * mirror)
    }
}

impl Default for Wings {
    fn default() -> Self {
        Self::new()
    }
}

/// Eq. 4–5 on one element of area `area` (m²) with unit `normal` and unit `span` (world
/// frame), in air moving at `v` (m/s) relative to it: lift plus drag, N.
#[inline]
pub fn element_force(v: Vec3, normal: Vec3, span: Vec3, area: f32, density: f32) -> Vec3 {
    element_force_along(v, v.dot(normal), v.dot(span), normal, area, density)
}

/// `element_force` given the air's components `vn` = v·normal and `vs` = v·span.
#[inline]
fn element_force_along(v: Vec3, vn: f32, vs: f32, normal: Vec3, area: f32, density: f32) -> Vec3 {
    let speed2 = v.length_squared();
    // Still air (or a non-finite one, caught by the caller) exerts nothing.
    if speed2 <= 1e-12 || speed2.is_nan() {
        return Vec3::ZERO;
    }
    // |Vᵗ|² by Pythagoras (normal and span are orthonormal) instead of building the vector.
    let across = (speed2 - vn * vn - vs * vs).max(0.0).sqrt();
    // The polynomial atan2 the bee model uses: the library's was a third of these
    // instructions.
    let alpha = crate::math::atan2(vn.abs(), across).to_degrees();
    let q = 0.5 * density * area * speed2;
    let dir = v / speed2.sqrt();
    // The air pushes the wing towards the side it flows to.
    let push = normal * vn.signum();
    let lift_dir = normalize_or(push - dir * push.dot(dir), Vec3::ZERO);
    dir * (q * drag_coefficient(alpha)) + lift_dir * (q * lift_coefficient(alpha))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficients_as_read() {
        // Lift: about zero near 4° and 90°, largest (1.80) near 47°.
        assert!(lift_coefficient(4.0).abs() < 0.03);
        assert!(lift_coefficient(90.0).abs() < 0.05);
        assert!((lift_coefficient(47.2) - 1.80).abs() < 0.01);
        // Drag as printed: 0.51 at 0°, 4.6 at 90°.
        assert!((drag_coefficient(0.0) - 0.51127).abs() < 1e-5);
        assert!((drag_coefficient(90.0) - 4.62).abs() < 0.01);
    }

    #[test]
    fn a_plate_face_on_to_the_air_is_pushed_along_the_air() {
        // Air from below on a horizontal plate: pure drag, upwards, ½ρA|V|²C_d(90°).
        let f = element_force(Vec3::Y * 2.0, Vec3::Y, Vec3::Z, 0.01, 1.2);
        let expect = 0.5 * 1.2 * 0.01 * 4.0 * drag_coefficient(90.0);
        assert!((f - Vec3::Y * expect).length() < 1e-3 * expect, "{f}");
        // Air from ahead, 45° below the plate: lift upwards, drag backwards.
        let v = Vec3::new(-1.0, 1.0, 0.0);
        let f = element_force(v, Vec3::Y, Vec3::Z, 0.01, 1.2);
        assert!(f.y > 0.0 && f.x < 0.0, "{f}");
    }

    #[test]
    fn element_areas_add_up_to_the_wing_area() {
        let w = Wings::new();
        let sum: f32 = w
            .right
            .iter()
            .flat_map(|x| x.elements.iter())
            .map(|e| e.area)
            .sum();
        assert!((sum - 1.0).abs() < 1e-5, "{sum}");
    }

    #[test]
    fn a_down_stroke_lifts_and_an_up_stroke_pushes_down() {
        let wings = Wings::new();
        let flow = Flow {
            orientation: Quat::IDENTITY,
            velocity: Vec3::ZERO,
            wind: Vec3::ZERO,
            span: 0.06,
            area: 26e-4,
            density: 1.225,
        };
        // Mid down-stroke (phase π/2: flap falling fastest) and mid up-stroke.
        let down = wings.force(
            &WingState::at(1.0, std::f32::consts::FRAC_PI_2, 11.0),
            &flow,
        );
        let up = wings.force(&WingState::at(1.0, 1.5 * std::f32::consts::PI, 11.0), &flow);
        assert!(down.y > 0.0 && up.y < 0.0, "{down} {up}");
        // Symmetric wings: no side force.
        assert!(down.z.abs() < 1e-6 * down.length());
    }
}
