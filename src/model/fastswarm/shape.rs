//! Shape constraints (paper 003 Sec. 5.1.2, Eq. 15): each agent traverses the key points
//! of a bidirectional curve, heading for its goal key point and moving on to the next one
//! on arrival. The key points are the swarm's targets in shot order (a heart is eleven
//! `[[target]]` points, a star ten).
//!
//! Conventions: metres, world Y-up.

use crate::math::Rng;
use glam::Vec3;

/// An agent's task on the curve.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tour {
    /// Index of the goal key point among the swarm's targets.
    pub goal: u32,
    /// +1 or −1: the way along the curve (it is bidirectional).
    pub way: i8,
}

impl Tour {
    /// A random goal among `n` key points and a random way along the curve.
    pub fn draw(n: usize, rng: &mut Rng) -> Tour {
        Tour {
            goal: if n > 0 {
                (rng.next_u64() % n as u64) as u32
            } else {
                0
            },
            way: if rng.next_u64() & 1 == 0 { 1 } else { -1 },
        }
    }

    /// The tour after an agent at `p` checks its goal at `goal_at`: the next key point
    /// once within `arrival` of it (Eq. 15's "reaches its current goal").
    pub fn advance(self, p: Vec3, goal_at: Vec3, arrival: f32, n: usize) -> Tour {
        if n == 0 || p.distance_squared(goal_at) > arrival * arrival {
            return self;
        }
        let next = (self.goal as i64 + self.way as i64).rem_euclid(n as i64) as u32;
        Tour { goal: next, ..self }
    }
}

/// Eq. 15: the control direction v̂^cd, from the agent to its goal key point (unnormalised;
/// the energy normalises it).
pub fn control_direction(p: Vec3, goal_at: Vec3) -> Vec3 {
    goal_at - p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrival_moves_the_goal_along_the_curve_both_ways() {
        let t = Tour { goal: 0, way: -1 };
        assert_eq!(t.advance(Vec3::ZERO, Vec3::X, 0.1, 5), t, "not there yet");
        assert_eq!(
            t.advance(Vec3::X, Vec3::X, 0.1, 5).goal,
            4,
            "wraps backwards"
        );
        let t = Tour { goal: 4, way: 1 };
        assert_eq!(
            t.advance(Vec3::X, Vec3::X, 0.1, 5).goal,
            0,
            "wraps forwards"
        );
    }
}
