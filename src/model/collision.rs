//! Collisions in the air (paper 000 Sec. VII): bees whose bodies still touch are separated
//! by a damped spring.

use glam::Vec3;

/// Spring acceleration on a bee overlapping a neighbour by `contact − dist` metres.
/// `r` = bee − neighbour, `rel_vel` = bee velocity − neighbour velocity.
#[inline]
pub fn spring_accel(
    r: Vec3,
    dist: f32,
    contact: f32,
    rel_vel: Vec3,
    stiffness: f32,
    fallback: impl FnOnce() -> Vec3,
) -> Vec3 {
    let overlap = contact - dist;
    if overlap <= 0.0 {
        return Vec3::ZERO;
    }
    let n = if dist > 1e-9 { r / dist } else { fallback() };
    // Critical damping for a unit-mass pair: c = 2 √k; only the approaching part is damped.
    let closing = rel_vel.dot(n).min(0.0);
    n * (stiffness * overlap - 2.0 * stiffness.sqrt() * closing)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn springs_act_only_on_touching_bees() {
        assert_eq!(
            spring_accel(Vec3::X * 0.01, 0.01, 0.004, Vec3::ZERO, 4000.0, || Vec3::Y),
            Vec3::ZERO
        );
        let a = spring_accel(Vec3::X * 0.002, 0.002, 0.004, -Vec3::X, 4000.0, || Vec3::Y);
        assert!(a.x > 4000.0 * 0.002);
        assert!(spring_accel(Vec3::ZERO, 0.0, 0.004, Vec3::ZERO, 4000.0, || Vec3::Y).y > 0.0);
    }
}
