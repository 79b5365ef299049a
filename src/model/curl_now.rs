//! The curl-noise force (Eq. 8–9) at every agent of a swarm for one substep, worked out
//! together before the step pass: sixteen agents at a time with AVX-512, eight with AVX2
//! ([`CurlNoise::forces`]), where a step asking for its own agent's force one at a time
//! cost about 14 % of a bee-step. Every force is bit-identical to [`CurlNoise::force`]'s,
//! so the caches are the same as when each step worked out its own.

use super::Context;
use crate::field::CurlNoise;
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// Agents per piece of the parallel pass (a multiple of the sixteen or eight lanes).
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
            Some(&f) if self.t == cx.t && cx.agents.get(i).is_some_and(|r| r.pos == pos) => f,
            _ => curl.force(pos),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Neighbour;

    fn context<'a>(t: f64, agents: &'a [Neighbour]) -> Context<'a> {
        Context {
            t,
            dt: 0.01,
            step: 0,
            seed: 1,
            wind: Vec3::ZERO,
            obstacles: &[],
            obstacles_before: &[],
            targets: &[],
            max_body_radius: 0.0,
            agents,
            lists: &[],
            ids: &[],
            slots: &[],
        }
    }

    #[test]
    fn each_agent_reads_its_own_force_and_anything_else_is_worked_out() {
        let curl = CurlNoise::new(9, 0.11, 2.0);
        let mut rng = crate::math::Rng::new(3, 4, 5);
        // 300 agents, the swarm the 37 from index 200 (not a multiple of sixteen).
        let agents: Vec<Neighbour> = crate::math::random_cloud(&mut rng, 300, 2.0)
            .into_iter()
            .map(|pos| Neighbour {
                pos,
                ..Neighbour::default()
            })
            .collect();
        let cx = context(0.5, &agents);
        let mut now = CurlNow::default();
        now.fill(&curl, &cx, 200..237);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for (k, a) in agents[200..237].iter().enumerate() {
            assert_eq!(bits(now.forces[k]), bits(curl.force(a.pos)));
        }
        // Which stored force a step reads: marked, its own and only its own.
        for (k, f) in now.forces.iter_mut().enumerate() {
            *f = Vec3::splat(k as f32 + 0.5);
        }
        for (i, a) in agents.iter().enumerate().take(237).skip(200) {
            assert_eq!(
                now.at(&curl, &cx, i, a.pos),
                Vec3::splat((i - 200) as f32 + 0.5)
            );
        }
        // Another agent's position, an agent of another swarm, another substep: worked
        // out where asked.
        let elsewhere = agents[201].pos;
        assert_eq!(
            bits(now.at(&curl, &cx, 200, elsewhere)),
            bits(curl.force(elsewhere))
        );
        let other = agents[5].pos;
        assert_eq!(bits(now.at(&curl, &cx, 5, other)), bits(curl.force(other)));
        let later = context(0.51, &agents);
        let mine = agents[210].pos;
        assert_eq!(
            bits(now.at(&curl, &later, 210, mine)),
            bits(curl.force(mine))
        );
    }
}
