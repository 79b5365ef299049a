//! What the world lends a model during a step: read-only, shared by every agent.
//!
//! Conventions: metres, seconds, world Y-up right-handed. Agent indices are global (shot
//! order, every swarm's agents one after another), so a model sees other swarms' agents as
//! neighbours too.

use super::targets::TargetKind;
use crate::geometry::{Grid, Shape, SurfaceQuery};
use crate::math::Rng;
use glam::Vec3;

/// What other agents' neighbour loops read of an agent, packed in 40 bytes so that those
/// loops touch less memory than a whole agent state would take.
#[derive(Clone, Copy, Debug, Default)]
pub struct Neighbour {
    pub pos: Vec3,
    /// Body (capsule) radius, m: the swarm's body radius times the agent's size.
    pub radius: f32,
    pub vel: Vec3,
    /// Mass, kg.
    pub mass: f32,
    /// What the agent's model gathered this step (paper 000: SPH density and pressure);
    /// zero for models without a gather pass.
    pub density: f32,
    pub pressure: f32,
}

/// Neighbours cached per agent by the gather pass for the step pass: one grid walk per
/// substep instead of two. An agent with more neighbours than fit falls back to the grid.
pub const CACHED_NEIGHBOURS: usize = 40;

#[derive(Clone, Copy)]
pub struct NeighbourList {
    len: u8,
    overflow: bool,
    idx: [u32; CACHED_NEIGHBOURS],
}

impl Default for NeighbourList {
    fn default() -> Self {
        NeighbourList {
            len: 0,
            overflow: false,
            idx: [0; CACHED_NEIGHBOURS],
        }
    }
}

impl NeighbourList {
    pub(crate) fn clear(&mut self) {
        self.len = 0;
        self.overflow = false;
    }
    pub(crate) fn push(&mut self, j: usize) {
        if (self.len as usize) < CACHED_NEIGHBOURS {
            self.idx[self.len as usize] = j as u32;
            self.len += 1;
        } else {
            self.overflow = true;
        }
    }
}

/// A target at the current substep, as models see it.
#[derive(Clone, Debug)]
pub struct TargetNow {
    pub kind: TargetKind,
    /// Current centre (a surface: a point on its plane), m.
    pub center: Vec3,
    /// A surface's unit normal (zero for the other kinds).
    pub normal: Vec3,
    /// Attraction, m/s² (before the swarm's own `attraction` scale).
    pub strength: f32,
    /// Attraction acts within this distance, m (`INFINITY`: everywhere).
    pub reach: f32,
    /// Radius of the target's body, m.
    pub radius: f32,
    /// Static virtual particles on the body (offsets from `center`), for models that
    /// feel them (paper 000 Sec. V-B); empty for targets without a body.
    pub particles: Vec<Vec3>,
}

/// The read-only world a step sees.
pub struct Context<'a> {
    /// Time at the start of this substep, seconds since the first frame.
    pub t: f64,
    /// Substep length, seconds.
    pub dt: f32,
    /// Index of this substep since the first frame.
    pub step: u64,
    pub seed: u64,
    /// Constant wind velocity, m/s.
    pub wind: Vec3,
    pub obstacles: &'a [Shape],
    pub targets: &'a [TargetNow],
    /// Largest body radius of any agent, m: bounds every contact distance.
    pub max_body_radius: f32,
    /// Every agent's neighbour record (previous state), by global index.
    pub agents: &'a [Neighbour],
    pub(crate) lists: &'a [NeighbourList],
    pub(crate) grid: &'a Grid,
}

impl Context<'_> {
    /// A deterministic random stream for agent `i` at this step: the same numbers whatever
    /// the number of threads. `stream` separates a model's independent uses.
    #[inline]
    pub fn rng(&self, stream: u64, i: usize) -> Rng {
        Rng::new(self.seed ^ stream, i as u64, self.step)
    }

    /// Every other agent within `reach` of agent i, in grid order (so sums are the same
    /// whatever the number of threads): `f(j, position, squared distance)`. `reach` must
    /// not exceed the one the gather pass listed neighbours with (the model's reach plus
    /// both body radii); further agents are not listed.
    #[inline(always)]
    pub fn for_each_neighbour(&self, i: usize, reach: f32, mut f: impl FnMut(usize, Vec3, f32)) {
        let p = self.agents[i].pos;
        let n = &self.lists[i];
        if n.overflow {
            self.grid.for_each_within(p, reach, |j, pj, d2| {
                if j != i {
                    f(j, pj, d2)
                }
            });
        } else {
            for &j in &n.idx[..n.len as usize] {
                let pj = self.agents[j as usize].pos;
                f(j as usize, pj, p.distance_squared(pj));
            }
        }
    }

    /// Distance, closest point and normal of every obstacle from `p`.
    #[inline]
    pub fn obstacle_queries(&self, p: Vec3) -> impl Iterator<Item = SurfaceQuery> + '_ {
        self.obstacles
            .iter()
            .map(move |o| crate::geometry::query(o, p))
    }
}
