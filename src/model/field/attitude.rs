//! The body's attitude for the caches: heading along the smoothed velocity, pitched with its
//! climb and banked into turns as a coordinated turn banks, tan φ = v ω / g (paper 001
//! orients agents along their velocity and says no more).
//!
//! Radians; yaw about world +Y, positive roll drops the right wing (docs/model.md).

use crate::math;
use glam::Vec3;

/// Steepest climb or dive the body shows, radians.
const PITCH_MAX: f32 = 1.0;
const G: f32 = 9.81;

#[derive(Clone, Copy, Debug)]
pub struct Attitude {
    /// Smoothed velocity, m/s.
    pub smooth: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    pub roll: f32,
}

impl Attitude {
    /// Along `smooth` (heading and pitch) with no bank; `vel` is used where `smooth` is
    /// (nearly) zero.
    pub fn along(vel: Vec3, smooth: Vec3) -> Self {
        let s = if smooth.length_squared() > 1e-8 {
            smooth
        } else {
            vel
        };
        let horizontal = Vec3::new(s.x, 0.0, s.z).length();
        Attitude {
            smooth: s,
            yaw: if horizontal > 1e-6 {
                math::yaw_of(s)
            } else {
                0.0
            },
            pitch: s.y.atan2(horizontal).clamp(-PITCH_MAX, PITCH_MAX),
            roll: 0.0,
        }
    }

    /// The attitude after a substep of `dt` at velocity `vel`: the smoothed velocity
    /// follows with per-step `blend`, the heading and pitch follow it, and the bank is
    /// the coordinated turn's, at most `bank_max`, smoothed the same way.
    pub fn follow(&self, vel: Vec3, blend: f32, bank_max: f32, dt: f32) -> Self {
        let smooth = self.smooth + (vel - self.smooth) * blend;
        let horizontal = Vec3::new(smooth.x, 0.0, smooth.z).length();
        if horizontal < 1e-3 {
            // Hovering: hold the heading, level out.
            return Attitude {
                smooth,
                roll: self.roll * (1.0 - blend),
                ..*self
            };
        }
        let yaw = math::yaw_of(smooth);
        let turn = (yaw - self.yaw + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU)
            - std::f32::consts::PI;
        let yaw_rate = turn / dt;
        // A right turn (yaw decreasing) banks the right wing down: positive roll.
        let bank = (-yaw_rate * horizontal / G)
            .atan()
            .clamp(-bank_max, bank_max);
        Attitude {
            smooth,
            yaw,
            pitch: smooth.y.atan2(horizontal).clamp(-PITCH_MAX, PITCH_MAX),
            roll: self.roll + (bank - self.roll) * blend,
        }
    }

    /// Body → world (the recording works it out four at a time: `Model::poses`).
    #[cfg(test)]
    pub fn orientation(&self) -> glam::Quat {
        math::body_orientation(self.yaw, self.pitch, self.roll)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_body_banks_into_a_turn_and_heads_along_the_velocity() {
        let dt = 1.0 / 48.0;
        let blend = 1.0 - (-dt / 0.15f32).exp();
        // Circling to the right (clockwise seen from above: +X then +Z) at 2 m/s.
        let w = 2.0f32; // rad/s
        let v = |t: f32| Vec3::new((w * t).cos(), 0.0, (w * t).sin()) * 2.0;
        let mut a = Attitude::along(v(0.0), v(0.0));
        for k in 1..200 {
            a = a.follow(v(k as f32 * dt), blend, 0.8, dt);
        }
        // tan φ = v ω / g = 2·2/9.81.
        let expected = (4.0f32 / 9.81).atan();
        assert!(
            (a.roll - expected).abs() < 0.05,
            "roll {} vs {expected}",
            a.roll
        );
        // The right wing (body +Z) points down.
        assert!((a.orientation() * Vec3::Z).y < -0.2);
        // The nose points along the (smoothed, so slightly lagging) velocity.
        let nose = a.orientation() * Vec3::X;
        assert!(nose.dot(v(199.0 * dt).normalize()) > 0.95);
    }
}
