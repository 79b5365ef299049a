//! What the world lends a model during a step: read-only, shared by every agent.
//!
//! Conventions: metres, seconds, world Y-up right-handed. An agent index `i` is where the
//! agent is stored this substep: global (every swarm's agents one after another, so a model
//! sees other swarms' agents as neighbours too), but within its swarm in the grid's cell
//! order, which the world renews as agents move (`crate::sim::world`, "Cell order"). An
//! agent's identity — its place in the shot's order, which seeds its random numbers and
//! names it in the caches — is [`Context::id`].

use super::targets::TargetKind;
use crate::geometry::{Found, Grid, Shape, SurfaceQuery};
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

/// The most neighbours an agent interacts with: the nearest within its model's radius
/// (topological interaction; docs/model.md, "Bounded neighbours"). In a sparse cloud every
/// neighbour within the radius counts; in a crowd the nearest 16, so a step costs about
/// the same per agent at any density.
pub const MAX_NEIGHBOURS: usize = 16;

/// An agent's neighbours, listed once per substep by the gather pass for the step pass.
#[derive(Clone, Copy)]
pub struct NeighbourList {
    len: u8,
    idx: [u32; MAX_NEIGHBOURS],
}

impl Default for NeighbourList {
    fn default() -> Self {
        NeighbourList {
            len: 0,
            idx: [0; MAX_NEIGHBOURS],
        }
    }
}

impl NeighbourList {
    /// Lists the (at most `MAX_NEIGHBOURS`) agents nearest `p` within `radius`, other than
    /// agent `me`, in the grid's order; the query collects its candidates in `found`
    /// (`Grid::nearest_with`).
    pub(crate) fn fill(&mut self, grid: &Grid, p: Vec3, radius: f32, me: usize, found: &mut Found) {
        self.len = grid.nearest_with(p, radius, MAX_NEIGHBOURS, me, &mut self.idx, found) as u8;
    }

    /// Puts the list in increasing id order (`ids`: every agent's id by index; insertion
    /// sort: at most 16 entries): the order lists reused over substeps (`crate::sim::skin`)
    /// are kept in, so that a list found by the grid and one picked from candidates are the
    /// same list, and every sum over it the same sum.
    pub(crate) fn sort(&mut self, ids: &[u32]) {
        let idx = &mut self.idx[..self.len as usize];
        for i in 1..idx.len() {
            let v = idx[i];
            let mut j = i;
            while j > 0 && ids[idx[j - 1] as usize] > ids[v as usize] {
                idx[j] = idx[j - 1];
                j -= 1;
            }
            idx[j] = v;
        }
    }

    /// Appends agent `j` (callers append in increasing id order, and at most
    /// `MAX_NEIGHBOURS`).
    #[inline]
    pub(crate) fn push(&mut self, j: u32) {
        self.idx[self.len as usize] = j;
        self.len += 1;
    }

    /// Empties the list (for a model that reads none).
    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    /// Global indices of the listed neighbours.
    #[inline]
    pub(crate) fn indices(&self) -> &[u32] {
        &self.idx[..self.len as usize]
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
    /// Bees land on it, and stay a time from this range, seconds (`Target::land`).
    pub land: bool,
    pub stay: (f32, f32),
    /// A hive entrance: bees go in for a time from this range, seconds (`Target::inside`).
    pub inside: Option<(f32, f32)>,
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
    /// The obstacles where they stand at the end of this substep.
    pub obstacles: &'a [Shape],
    /// Each moving obstacle's pose at the start of this substep, by obstacle (`None`:
    /// static): with `obstacles`, its motion over the substep.
    pub obstacles_before: &'a [Option<crate::geometry::Rigid>],
    pub targets: &'a [TargetNow],
    /// Largest body radius of any agent, m: bounds every contact distance.
    pub max_body_radius: f32,
    /// Every agent's neighbour record (previous state), by global index.
    pub agents: &'a [Neighbour],
    pub(crate) lists: &'a [NeighbourList],
    /// Every agent's id by index, and its index by id (see the module notes).
    pub(crate) ids: &'a [u32],
    pub(crate) slots: &'a [u32],
}

impl Context<'_> {
    /// A deterministic random stream for agent `i` at this step, drawn from its id: the
    /// same numbers whatever the number of threads and wherever the agent is stored.
    /// `stream` separates a model's independent uses.
    #[inline]
    pub fn rng(&self, stream: u64, i: usize) -> Rng {
        Rng::new(self.seed ^ stream, self.id(i) as u64, self.step)
    }

    /// Agent `i`'s id: its place in the shot's order (every swarm's agents one after
    /// another), the same all through the shot.
    #[inline]
    pub fn id(&self, i: usize) -> usize {
        self.ids[i] as usize
    }

    /// Every agent's index, in id order.
    #[inline]
    pub fn indices_by_id(&self) -> &[u32] {
        self.slots
    }

    /// A deterministic direction separating coincident agents i and j, opposite for j and
    /// i (from their ids).
    #[inline]
    pub fn separation_fallback(&self, i: usize, j: usize) -> Vec3 {
        crate::model::flight::separation_fallback(self.id(i), self.id(j))
    }

    /// Agent i's neighbours within `reach`, in a fixed order (so sums are the same
    /// whatever the number of threads): `f(j, position, squared distance)`. They are at
    /// most [`MAX_NEIGHBOURS`], the nearest, listed by the gather pass within the model's
    /// reach plus both body radii; `reach` must not exceed that.
    #[inline(always)]
    pub fn for_each_neighbour(&self, i: usize, reach: f32, mut f: impl FnMut(usize, Vec3, f32)) {
        let p = self.agents[i].pos;
        let r2 = reach * reach;
        for &j in self.lists[i].indices() {
            let pj = self.agents[j as usize].pos;
            let d2 = p.distance_squared(pj);
            if d2 < r2 {
                f(j as usize, pj, d2);
            }
        }
    }

    /// The velocity over this substep, m/s, of the point of obstacle `k` that is at
    /// `point` at the substep's end: where that point of the moving mesh was at the start,
    /// carried to where it is. Zero for a static obstacle.
    #[inline]
    pub fn obstacle_point_velocity(&self, k: usize, point: Vec3) -> Vec3 {
        match (&self.obstacles[k], self.obstacles_before.get(k)) {
            (
                Shape::Mesh {
                    pose: Some(now), ..
                },
                Some(Some(before)),
            ) if self.dt > 0.0 => (point - before.to_world(now.to_rest(point))) / self.dt,
            _ => Vec3::ZERO,
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
