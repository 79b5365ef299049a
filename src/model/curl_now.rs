//! The curl-noise force (Eq. 8–9) at every agent of a swarm for one substep, worked out
//! together before the step pass: sixteen agents at a time with AVX-512
//! ([`CurlNoise::forces`]), where a step asking for its own agent's force one at a time
//! cost about 14 % of a bee-step. Every force is bit-identical to [`CurlNoise::force`]'s,
//! so the caches are the same as when each step worked out its own.

use super::Context;
use crate::field::CurlNoise;
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// Agents per piece of the parallel pass (a multiple of the sixteen lanes).
const PIECE: usize = 128;

/// The forces at the agents' positions at the start of one substep.
#[derive(Clone, Debug, Default)]
pub struct CurlNow {
    /// The substep's time, s.
    t: f64,
    /// The swarm's first agent in the context's agents.
    first: usize,
    forces: Vec<Vec3>,
}

impl CurlNow {
    /// Works out `curl`'s force at each of `agents` (a swarm's range in `cx.agents`), in
    /// parallel.
    pub fn fill(&mut self, curl: &CurlNoise, cx: &Context, agents: Range<usize>) {
        self.t = cx.t;
        self.first = agents.start;
        self.forces.resize(agents.len(), Vec3::ZERO);
        let recs = &cx.agents[agents];
        self.forces
            .par_chunks_mut(PIECE)
            .enumerate()
            .for_each(|(c, out)| curl.forces(|k| recs[c * PIECE + k].pos, out));
    }

    /// `curl`'s force at `pos`, agent `i`'s position in `cx`: the one worked out by
    /// `fill` for this substep, or (a step outside the world's loop, or a position that is
    /// not the agent's record) worked out now.
    #[inline]
    pub fn at(&self, curl: &CurlNoise, cx: &Context, i: usize, pos: Vec3) -> Vec3 {
        match self.forces.get(i.wrapping_sub(self.first)) {
            Some(&f) if self.t == cx.t && cx.agents[i].pos == pos => f,
            _ => curl.force(pos),
        }
    }
}
