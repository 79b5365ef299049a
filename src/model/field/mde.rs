//! Minimum distance enforcement (paper 001 Sec. 6, after Treuille et al. 2006): once an
//! agent has moved, every pair closer than d_min is pushed apart.
//!
//! The paper runs it as a pass over the pairs in each grid cell after all agents moved. A
//! step here sees only the previous state of the others, so each agent predicts where each
//! listed neighbour moves (its position plus its last velocity times Δt) and takes its own
//! half of the separation, (d_min − |Δ|) / 2 along Δ; the neighbour does the same from its
//! side. Neighbours are those within d_min of the world's list (not only the same cell), in
//! a fixed order, so the result does not depend on threads.

use crate::model::context::Context;
use glam::Vec3;

/// Agent `i`'s position `q` after its move, pushed away from every neighbour predicted
/// within `d_min`; true if it was pushed. `ri` is its body radius.
#[inline]
pub fn enforce(cx: &Context, i: usize, q: Vec3, dt: f32, d_min: f32, ri: f32) -> (Vec3, bool) {
    if d_min <= 0.0 {
        return (q, false);
    }
    let mut push = Vec3::ZERO;
    let mut pushed = false;
    cx.for_each_neighbour(i, d_min + ri + cx.max_body_radius, |j, pj, _| {
        let qj = pj + cx.agents[j].vel * dt;
        let delta = q - qj;
        let dist = delta.length();
        if dist < d_min {
            let away = if dist > 1e-7 {
                delta / dist
            } else {
                cx.separation_fallback(i, j)
            };
            push += away * (0.5 * (d_min - dist));
            pushed = true;
        }
    });
    (q + push, pushed)
}
