//! Hovering, sharp turns and brief backward flight (issue 17): the stroke-plane command.
//!
//! Paper 000 Sec. II: honeybees "maintain hovering flights or turn rapidly by adjusting the
//! flapping amplitudes and average flapping angles of wings" [45], [46]; Fig. 11's bees fly
//! backwards. Eq. 2's thrust m g θ_pitch is the forward tilt of a weight-bearing wing force,
//! so it always pushes forward, and drag settles every bee at its preferred speed. A bee in
//! a tight spot — slow, or at a nest or flower — instead tilts its stroke plane towards where
//! the other forces of Eq. 1 (noise, pull, repulsion) send it: its thrust is scaled by the
//! command k ∈ [−1, 1], 1 in cruise, near 0 (a hover) when those forces are weak or sideways,
//! negative (backwards, without yawing round) when they point behind it; meanwhile it turns
//! on the spot to face where it wants to go (or, at a target, the target). Horizontal
//! vectors throughout; Y up. See docs/model.md, "Hovering, sharp turns, backward flight".

use crate::model::flight;
use glam::Vec3;

/// A bee slower than this fraction of its cruising speed is in a tight spot: fully so when
/// stopped, not at all at this speed.
const SLOW_FRACTION: f32 = 0.5;
/// Above this weight the bee manoeuvres (turns on the spot to face its aim) rather than
/// letting its heading follow its velocity.
const MANOEUVRING: f32 = 0.5;
/// Largest yaw rate of a manoeuvring bee, rad/s (540°/s): bees turn in quick body
/// saccades (docs/model.md).
const TURN_RATE: f32 = 3.0 * std::f32::consts::PI;
/// Above this weight a bee drifting backwards keeps facing forward.
const HOLDING: f32 = 0.2;

/// What the bee's wings do this substep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Command {
    /// Scale of Eq. 2's thrust, in [−1, 1]: 1 forward flight, 0 hover, −1 full reverse.
    pub thrust: f32,
    /// How much the bee is in a tight spot, in [0, 1] (0: cruising).
    pub weight: f32,
    /// The horizontal direction it turns to face while manoeuvring.
    pub aim: Vec3,
}

/// Where a bee is and what the forces ask of it. Vectors in the world frame (Y up); only
/// their horizontal parts count.
#[derive(Clone, Copy, Debug)]
pub struct Situation {
    /// The body's horizontal axis (unit vector).
    pub forward: Vec3,
    /// Velocity, m/s.
    pub vel: Vec3,
    /// Cruising (preferred) speed, m/s.
    pub cruise: f32,
    /// The acceleration Eq. 1's noise, pull and repulsion (and the way out of a nearby
    /// surface) ask for, m/s².
    pub want: Vec3,
    /// The mean thrust of Eq. 2, m/s².
    pub thrust: f32,
    /// How close it is to a nest or flower, in [0, 1] (1 at its surface).
    pub near: f32,
    /// The targets' pull, m/s².
    pub pull: Vec3,
}

/// The stroke-plane command for situation `s`; `gain` is the `manoeuvre` parameter (0:
/// the paper's forward thrust).
pub fn command(s: &Situation, gain: f32) -> Command {
    let (forward, cruise, thrust, near) = (s.forward, s.cruise, s.thrust, s.near);
    let flat = |v: Vec3| Vec3::new(v.x, 0.0, v.z);
    let (want, vel, pull) = (flat(s.want), flat(s.vel), flat(s.pull));
    let slow = (1.0 - vel.length() / (SLOW_FRACTION * cruise).max(1e-6)).clamp(0.0, 1.0);
    let weight = gain * slow.max(near);
    // The share of full thrust along the body that the wanted acceleration asks for: the
    // cosine of its angle to the body; at a target, against the mean thrust when it is
    // weaker (the bee is where it wants to be: a hover). Wanting nothing in the open, it
    // flies on.
    let denom = want.length().max(near * thrust);
    let along = if denom > 1e-6 {
        want.dot(forward) / denom
    } else {
        1.0
    };
    // At a target it faces the target, as bees face an entrance they hover at; elsewhere
    // it faces where the forces send it.
    let aim = if near >= slow && pull.length_squared() > 1e-8 {
        pull
    } else {
        want
    };
    Command {
        thrust: 1.0 - weight * (1.0 - along),
        weight,
        aim,
    }
}

/// The heading, radians about +Y, after a substep: while manoeuvring the bee turns on the
/// spot towards its aim at up to π rad/s; otherwise `None` (the heading follows the
/// velocity as before), except that a bee drifting backwards keeps facing forward: it
/// does not yaw round onto its velocity.
pub fn heading(cmd: &Command, yaw: f32, vel: Vec3, dt: f32) -> Option<f32> {
    // The body axis only when it is asked for: a cruising bee (weight 0) skips the trig.
    let backwards =
        || Vec3::new(vel.x, 0.0, vel.z).dot(Vec3::new(yaw.cos(), 0.0, -yaw.sin())) < 0.0;
    if cmd.weight > MANOEUVRING && cmd.aim.length_squared() > 1e-8 {
        Some(flight::turn_towards(yaw, cmd.aim, TURN_RATE, dt))
    } else if cmd.weight > HOLDING && backwards() {
        Some(yaw)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const F: Vec3 = Vec3::X;

    /// `command` for a bee along +X with cruising speed 1 m/s and mean thrust 2.8 m/s².
    fn cmd(vel: Vec3, want: Vec3, near: f32, pull: Vec3, gain: f32) -> Command {
        let s = Situation {
            forward: F,
            vel,
            cruise: 1.0,
            want,
            thrust: 2.8,
            near,
            pull,
        };
        command(&s, gain)
    }

    #[test]
    fn cruising_bees_keep_the_paper_s_forward_thrust() {
        // At cruising speed, far from targets, whatever the forces want.
        let c = cmd(F, -3.0 * F, 0.0, Vec3::ZERO, 1.0);
        assert_eq!((c.thrust, c.weight), (1.0, 0.0));
        // With the rule off, even a stopped bee at a nest.
        let c = cmd(Vec3::ZERO, -3.0 * F, 1.0, -F, 0.0);
        assert_eq!(c.thrust, 1.0);
    }

    #[test]
    fn a_stopped_bee_hovers_reverses_or_goes_as_the_forces_ask() {
        let stop = Vec3::ZERO;
        // Sent straight back, harder than its thrust: full reverse.
        assert_eq!(cmd(stop, -5.0 * F, 0.0, stop, 1.0).thrust, -1.0);
        // Sent sideways: a hover; sent nowhere, at a nest: a hover; in the open: on.
        assert!(cmd(stop, 3.0 * Vec3::Z, 0.0, stop, 1.0).thrust.abs() < 1e-6);
        assert!(cmd(stop, 0.1 * F, 1.0, -F, 1.0).thrust < 0.05);
        assert_eq!(cmd(stop, Vec3::ZERO, 0.0, stop, 1.0).thrust, 1.0);
        // Sent ahead: full thrust.
        assert_eq!(cmd(stop, 5.0 * F, 0.0, stop, 1.0).thrust, 1.0);
        // Half the cruising speed or more: cruising.
        assert_eq!(cmd(0.5 * F, -5.0 * F, 0.0, stop, 1.0).thrust, 1.0);
    }

    #[test]
    fn a_manoeuvring_bee_turns_on_the_spot_and_a_backing_one_does_not_yaw_round() {
        let dt = 0.01;
        // Stopped, sent to its left (+Y turn, towards −Z): turns at the full rate.
        let c = cmd(Vec3::ZERO, -3.0 * Vec3::Z, 0.0, Vec3::ZERO, 1.0);
        let yaw = heading(&c, 0.0, Vec3::ZERO, dt).unwrap();
        assert!((yaw - TURN_RATE * dt).abs() < 1e-5, "{yaw}");
        // At a nest it faces the nest, whatever pushes it.
        let c = cmd(Vec3::ZERO, -3.0 * F, 1.0, Vec3::Z, 1.0);
        assert_eq!(c.aim, Vec3::Z);
        // Moving backwards at a third of its cruise, the forces ahead: it holds its heading.
        let back = -0.35 * F;
        let c = cmd(back, 3.0 * F, 0.0, Vec3::ZERO, 1.0);
        assert!(c.weight > 0.0 && c.weight <= MANOEUVRING);
        assert_eq!(heading(&c, 0.0, back, dt), Some(0.0));
    }
}
