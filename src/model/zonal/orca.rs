//! 3D optimal reciprocal collision avoidance (ORCA; van den Berg, Guy, Lin & Manocha 2011,
//! paper 002's reference [23], its f_R): the velocity closest to the preferred one that
//! keeps an agent from touching any neighbour within `time_horizon` seconds, each pair
//! sharing the avoidance half and half; static obstacles take none of it.
//!
//! Each neighbour (and each obstacle) gives a half-space of permitted velocities bounded by
//! a plane; the new velocity is the point of the intersection of those half-spaces and the
//! ball of radius `max_speed` nearest the preferred velocity: an incremental linear program
//! (1D on a line, 2D on a plane, 3D in the ball, planes taken in a fixed order so the
//! result is reproducible), and when the constraints leave nothing, the velocity that
//! violates the worst of them least (the fallback of the authors' RVO2-3D library).
//! Velocities in m/s, world frame.
//!
//! Written here rather than taken from the `dodgy_3d` crate: that crate draws a random
//! direction from the thread's generator for coincident agents (not reproducible), builds
//! on another glam version, allocates per agent and has no obstacles.

use glam::Vec3;

/// Most constraint planes one agent solves with: its neighbours and the nearest obstacles.
pub const MAX_PLANES: usize = 32;

/// Below this, a squared length or a denominator counts as zero.
const EPS: f32 = 1e-6;

/// Permitted velocities v satisfy (v − point) · normal ≥ 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Plane {
    pub point: Vec3,
    /// Unit normal into the permitted side.
    pub normal: Vec3,
}

/// Up to [`MAX_PLANES`] planes, on the stack.
#[derive(Clone, Copy, Debug)]
pub struct Planes {
    len: usize,
    planes: [Plane; MAX_PLANES],
}

impl Default for Planes {
    fn default() -> Self {
        Planes {
            len: 0,
            planes: [Plane::default(); MAX_PLANES],
        }
    }
}

impl Planes {
    /// Adds a plane; false (and nothing added) when full.
    pub fn push(&mut self, p: Plane) -> bool {
        if self.len == MAX_PLANES {
            return false;
        }
        self.planes[self.len] = p;
        self.len += 1;
        true
    }

    pub fn as_slice(&self) -> &[Plane] {
        &self.planes[..self.len]
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// A moving body: position (m) and velocity (m/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mover {
    pub pos: Vec3,
    pub vel: Vec3,
}

/// ORCA's two times, seconds: the horizon within which no collision is allowed, and the
/// step, within which bodies that already overlap are pushed apart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Times {
    pub horizon: f32,
    pub dt: f32,
}

/// The ORCA plane agent `a` gets from neighbour `b`, bodies of radii summing to `contact`.
/// `a` takes half the avoidance (`share` = 0.5) against another agent, all of it (1)
/// against a static body. `fallback` is a deterministic direction for coincident agents.
pub fn agent_plane(
    a: Mover,
    b: Mover,
    contact: f32,
    times: Times,
    share: f32,
    fallback: Vec3,
) -> Plane {
    let (va, time_horizon, dt) = (a.vel, times.horizon, times.dt);
    let rel_pos = b.pos - a.pos;
    let rel_vel = a.vel - b.vel;
    let dist2 = rel_pos.length_squared();
    let r2 = contact * contact;
    let (normal, u);
    if dist2 > r2 {
        let inv_tau = 1.0 / time_horizon;
        // w: from the centre of the cut-off sphere to the relative velocity.
        let w = rel_vel - rel_pos * inv_tau;
        let w2 = w.length_squared();
        let dot = w.dot(rel_pos);
        if dot < 0.0 && dot * dot > r2 * w2 {
            // Nearest the cut-off sphere (collision later than the horizon's front).
            let wl = w2.sqrt();
            let unit = if wl > EPS { w / wl } else { -fallback };
            normal = unit;
            u = unit * (contact * inv_tau - wl);
        } else {
            // Nearest the cone's side: project the relative velocity on it.
            let a = dist2;
            let b = rel_pos.dot(rel_vel);
            let c =
                rel_vel.length_squared() - rel_pos.cross(rel_vel).length_squared() / (dist2 - r2);
            let t = (b + (b * b - a * c).max(0.0).sqrt()) / a;
            let w = rel_vel - rel_pos * t;
            let wl = w.length();
            let unit = if wl > EPS { w / wl } else { -fallback };
            normal = unit;
            u = unit * (contact * t - wl);
        }
    } else {
        // Already touching: get out of the cut-off sphere of one step.
        let inv_dt = 1.0 / dt;
        let w = rel_vel - rel_pos * inv_dt;
        let wl = w.length();
        let unit = if wl > EPS { w / wl } else { -fallback };
        normal = unit;
        u = unit * (contact * inv_dt - wl);
    }
    Plane {
        point: va + u * share,
        normal,
    }
}

/// The plane of an obstacle seen as its tangent half-space: the closest surface point is
/// `distance` metres away along `-outward` (the obstacle's outward normal there), and a
/// body of radius `radius` may approach it no faster than to touch it after `time_horizon`
/// seconds; a body already closer than `radius` must leave within one step `dt`. For the
/// convex shapes of a shot the tangent half-space holds the whole obstacle, so this is
/// conservative. `surface_speed` is the surface's own speed along `outward` (a moving mesh
/// coming at the body: > 0; 0 for a static obstacle): the approach is measured relative to
/// it, so the body must also get out of the surface's way.
pub fn obstacle_plane(
    outward: Vec3,
    distance: f32,
    radius: f32,
    surface_speed: f32,
    times: Times,
) -> Plane {
    let gap = distance - radius;
    let mut min_normal_speed = if gap >= 0.0 {
        -gap / times.horizon
    } else {
        -gap / times.dt
    };
    // Only a moving surface shifts the plane (a static one keeps its bits exactly).
    if surface_speed != 0.0 {
        min_normal_speed += surface_speed;
    }
    Plane {
        point: outward * min_normal_speed,
        normal: outward,
    }
}

/// The velocity nearest `preferred` within speed `max_speed` that satisfies every plane, or
/// when none does, the one whose worst violation is least. Returns (velocity, whether every
/// plane was satisfied).
pub fn solve(planes: &[Plane], max_speed: f32, preferred: Vec3) -> (Vec3, bool) {
    let mut result = Vec3::ZERO;
    let goal = Goal {
        opt: preferred,
        direction: false,
    };
    let failed = program3(planes, max_speed, goal, &mut result);
    if failed < planes.len() {
        program4(planes, failed, max_speed, &mut result);
        (result, false)
    } else {
        (result, true)
    }
}

/// Violation of plane `p` by `v` (> 0: outside).
#[inline]
fn violation(p: &Plane, v: Vec3) -> f32 {
    p.normal.dot(p.point - v)
}

/// What a program optimises: the point nearest `opt`, or with `direction` the point
/// furthest along the unit vector `opt`.
#[derive(Clone, Copy, Debug)]
struct Goal {
    opt: Vec3,
    direction: bool,
}

/// On the line `point + t·dir` within the ball, the goal's optimum that satisfies
/// planes[..n].
fn program1(
    planes: &[Plane],
    n: usize,
    (point, dir): (Vec3, Vec3),
    radius: f32,
    goal: Goal,
    result: &mut Vec3,
) -> bool {
    let Goal { opt, direction } = goal;
    let dot = point.dot(dir);
    let disc = dot * dot + radius * radius - point.length_squared();
    if disc < 0.0 {
        return false;
    }
    let s = disc.sqrt();
    let (mut t_left, mut t_right) = (-dot - s, -dot + s);
    for p in &planes[..n] {
        let num = (p.point - point).dot(p.normal);
        let den = dir.dot(p.normal);
        if den * den <= EPS {
            if num > 0.0 {
                return false;
            }
            continue;
        }
        let t = num / den;
        if den >= 0.0 {
            t_left = t_left.max(t);
        } else {
            t_right = t_right.min(t);
        }
        if t_left > t_right {
            return false;
        }
    }
    *result = if direction {
        if opt.dot(dir) > 0.0 {
            point + dir * t_right
        } else {
            point + dir * t_left
        }
    } else {
        point + dir * dir.dot(opt - point).clamp(t_left, t_right)
    };
    true
}

/// On plane n within the ball, the optimum satisfying planes[..n].
fn program2(planes: &[Plane], n: usize, radius: f32, goal: Goal, result: &mut Vec3) -> bool {
    let Goal { opt, direction } = goal;
    let pn = planes[n];
    let plane_dist = pn.point.dot(pn.normal);
    let plane_dist2 = plane_dist * plane_dist;
    let r2 = radius * radius;
    if plane_dist2 > r2 {
        return false;
    }
    let plane_r2 = r2 - plane_dist2;
    let centre = pn.normal * plane_dist;
    if direction {
        let on_plane = opt - pn.normal * opt.dot(pn.normal);
        let l2 = on_plane.length_squared();
        *result = if l2 <= EPS {
            centre
        } else {
            centre + on_plane * (plane_r2 / l2).sqrt()
        };
    } else {
        *result = opt + pn.normal * (pn.point - opt).dot(pn.normal);
        if result.length_squared() > r2 {
            let off = *result - centre;
            let l2 = off.length_squared().max(1e-30);
            *result = centre + off * (plane_r2 / l2).sqrt();
        }
    }
    for i in 0..n {
        let pi = planes[i];
        if violation(&pi, *result) > 0.0 {
            let cross = pi.normal.cross(pn.normal);
            if cross.length_squared() <= EPS {
                // Parallel planes facing apart: nothing satisfies both.
                return false;
            }
            let dir = cross.normalize();
            let line_normal = dir.cross(pn.normal);
            let point = pn.point
                + line_normal * ((pi.point - pn.point).dot(pi.normal) / line_normal.dot(pi.normal));
            if !program1(planes, i, (point, dir), radius, goal, result) {
                return false;
            }
        }
    }
    true
}

/// In the ball, the optimum satisfying every plane; returns the index of the first plane
/// it could not satisfy (`planes.len()` on success), `result` then holding the optimum of
/// the planes before it.
fn program3(planes: &[Plane], radius: f32, goal: Goal, result: &mut Vec3) -> usize {
    let Goal { opt, direction } = goal;
    *result = if direction {
        opt * radius
    } else if opt.length_squared() > radius * radius {
        opt.normalize() * radius
    } else {
        opt
    };
    for i in 0..planes.len() {
        if violation(&planes[i], *result) > 0.0 {
            let keep = *result;
            if !program2(planes, i, radius, goal, result) {
                *result = keep;
                return i;
            }
        }
    }
    planes.len()
}

/// Infeasible from plane `begin` on: the velocity minimising the largest violation, found
/// plane by plane by projecting the earlier planes onto the violated one.
fn program4(planes: &[Plane], begin: usize, radius: f32, result: &mut Vec3) {
    let mut distance = 0.0f32;
    for i in begin..planes.len() {
        let pi = planes[i];
        if violation(&pi, *result) > distance {
            let mut projected = [Plane::default(); MAX_PLANES];
            let mut m = 0;
            for pj in &planes[..i] {
                let cross = pj.normal.cross(pi.normal);
                let point = if cross.length_squared() <= EPS {
                    if pi.normal.dot(pj.normal) > 0.0 {
                        // Same direction: plane i already bounds it.
                        continue;
                    }
                    (pi.point + pj.point) * 0.5
                } else {
                    let line_normal = cross.cross(pi.normal);
                    pi.point
                        + line_normal
                            * ((pj.point - pi.point).dot(pj.normal) / line_normal.dot(pj.normal))
                };
                let normal = (pj.normal - pi.normal).normalize_or_zero();
                if m < MAX_PLANES {
                    projected[m] = Plane { point, normal };
                    m += 1;
                }
            }
            let keep = *result;
            let goal = Goal {
                opt: pi.normal,
                direction: true,
            };
            if program3(&projected[..m], radius, goal, result) < m {
                // Only rounding can make this fail; keep the previous answer.
                *result = keep;
            }
            distance = violation(&pi, *result);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Moves two agents along their ORCA velocities and returns their closest distance.
    fn head_on(offset: f32) -> f32 {
        let (r, dt, tau) = (0.1, 0.02, 1.0);
        let mut p = [Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, offset, 0.0)];
        let pref = [Vec3::X, -Vec3::X];
        let mut v = pref;
        let mut closest = f32::INFINITY;
        for _ in 0..200 {
            let mut next = v;
            for a in 0..2 {
                let b = 1 - a;
                let plane = agent_plane(
                    Mover {
                        pos: p[a],
                        vel: v[a],
                    },
                    Mover {
                        pos: p[b],
                        vel: v[b],
                    },
                    2.0 * r,
                    Times { horizon: tau, dt },
                    0.5,
                    Vec3::Y,
                );
                next[a] = solve(&[plane], 2.0, pref[a]).0;
            }
            v = next;
            for a in 0..2 {
                p[a] += v[a] * dt;
            }
            closest = closest.min(p[0].distance(p[1]));
        }
        closest
    }

    #[test]
    fn two_agents_flying_head_on_pass_without_touching() {
        for offset in [0.0, 0.01, 0.05, 0.15] {
            let d = head_on(offset);
            assert!(d >= 0.2 * 0.999, "offset {offset}: closest {d}");
        }
    }

    #[test]
    fn an_unconstrained_agent_keeps_its_preferred_velocity() {
        let far = agent_plane(
            Mover {
                pos: Vec3::ZERO,
                vel: Vec3::X,
            },
            Mover {
                pos: Vec3::new(0.0, 5.0, 0.0),
                vel: Vec3::ZERO,
            },
            0.2,
            Times {
                horizon: 1.0,
                dt: 0.02,
            },
            0.5,
            Vec3::Y,
        );
        let (v, ok) = solve(&[far], 3.0, Vec3::X);
        assert!(ok && (v - Vec3::X).length() < 1e-6, "{v}");
        // The speed limit is the ball.
        let (v, _) = solve(&[], 1.0, Vec3::new(3.0, 4.0, 0.0));
        assert!((v.length() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn the_solution_satisfies_every_plane_or_violates_the_worst_least() {
        let planes = [
            Plane {
                point: Vec3::new(0.5, 0.0, 0.0),
                normal: Vec3::X,
            },
            Plane {
                point: Vec3::new(0.0, 0.5, 0.0),
                normal: Vec3::Y,
            },
        ];
        let (v, ok) = solve(&planes, 2.0, Vec3::ZERO);
        assert!(ok);
        assert!((v - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-5, "{v}");
        // Contradictory: x ≥ 0.5 and x ≤ −0.5. The least worst violation is at x = 0.
        let planes = [
            planes[0],
            Plane {
                point: Vec3::new(-0.5, 0.0, 0.0),
                normal: -Vec3::X,
            },
        ];
        let (v, ok) = solve(&planes, 2.0, Vec3::new(0.3, 0.2, 0.0));
        assert!(!ok);
        assert!(v.x.abs() < 1e-4, "{v}");
    }

    #[test]
    fn an_obstacle_plane_lets_an_agent_touch_the_wall_no_sooner_than_the_horizon() {
        let times = Times {
            horizon: 2.0,
            dt: 0.02,
        };
        let wall = obstacle_plane(Vec3::Y, 1.1, 0.1, 0.0, times);
        let (v, _) = solve(&[wall], 5.0, -Vec3::Y * 3.0);
        assert!((v.y + 0.5).abs() < 1e-5, "{v}");
        // Inside by 5 cm: leaves within one step.
        let inside = obstacle_plane(Vec3::Y, 0.05, 0.1, 0.0, times);
        let (v, _) = solve(&[inside], 5.0, Vec3::ZERO);
        assert!((v.y - 2.5).abs() < 1e-4, "{v}");
    }

    #[test]
    fn a_wall_coming_at_an_agent_makes_it_back_away_at_the_wall_speed_and_more() {
        let times = Times {
            horizon: 2.0,
            dt: 0.02,
        };
        // 1 m of gap, the wall coming at 1.5 m/s: at least 1.5 − 1/2 = 1 m/s away from it,
        // so the gap closes no faster than to touch at the horizon.
        let wall = obstacle_plane(Vec3::Y, 1.1, 0.1, 1.5, times);
        let (v, ok) = solve(&[wall], 5.0, Vec3::new(0.3, 0.0, 0.0));
        assert!(ok);
        assert!((v.y - 1.0).abs() < 1e-5 && (v.x - 0.3).abs() < 1e-5, "{v}");
        // Moving away at 1 m/s: the agent may follow it faster than to a static wall.
        let away = obstacle_plane(Vec3::Y, 1.1, 0.1, -1.0, times);
        let (v, _) = solve(&[away], 5.0, -Vec3::Y * 3.0);
        assert!((v.y + 1.5).abs() < 1e-5, "{v}");
    }
}
