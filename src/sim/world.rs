//! The world: every swarm's agents, the targets and obstacles, and the fixed-step passes.
//!
//! Each swarm runs its own model (`crate::model`) through a [`Runner`], monomorphised per
//! model: the world calls it once per swarm per pass, never per agent. Each substep reads
//! the previous state and writes a new one agent by agent (in parallel); neighbour sums run
//! in grid order, so results are identical for any number of threads.
//!
//! **Cell order.** Each swarm whose model lists neighbours keeps its agents stored in the
//! grid's cell order, renewed at each frame's first grid build
//! (`Simulation::store_in_cell_order`; within a frame agents move a few millimetres, so
//! the order stays close): agents near each other in space sit near each other in memory,
//! so every pass — records, lists, steps — reads its neighbours from cache, and each thread
//! works on its own part of space in every pass, instead of reading what another core
//! wrote the pass before. An agent's index (where it is stored) thus changes as it moves;
//! its *id* (its place in the shot's order) does not: ids seed its random numbers, name it
//! in the caches and checkpoints, order the grid's cells and the lists, so no result
//! depends on where it is stored.

use super::agent_bytes::AgentBytes;
use super::frame::{CacheMeta, SwarmFrame, SwarmMeta};
use super::skin;
use crate::geometry::{self, Found, Grid, Shape};
use crate::math::{Rng, normalize_or};
use crate::model::context::NeighbourList;
use crate::model::{
    Agent, Context, Model, Neighbour, Start, StartInside, SwarmSetup, TargetNow, with_model,
};
use crate::shot::{Region, Shot};
use glam::{Quat, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// The cancel flag of a simulation nobody cancels.
static NEVER: AtomicBool = AtomicBool::new(false);

/// One swarm's agents and model. Agents are double-buffered: a step reads `agents` and
/// writes `next`, then the two swap.
struct Runner<M: Model> {
    model: M,
    agents: Vec<M::Agent>,
    next: Vec<M::Agent>,
    /// Global index (and id) of the first agent.
    start: usize,
    /// Recording buffer, reused every frame: channel values agent by agent.
    values: Vec<f32>,
    /// Set by `permute`, until the step: where each agent of the new order is stored
    /// (global indices; empty: in place).
    moved: Vec<u32>,
    /// Neighbour candidates kept at the last rebuild (`super::skin`), agent after agent,
    /// and each agent's range of them (by agent; `NO_CANDIDATES`: queried afresh every
    /// substep).
    candidates: Vec<u32>,
    ranges: Vec<(u32, u32)>,
}

/// The largest skin, as a fraction of the largest neighbour radius. A rebuild searches out
/// to R + σ, (1 + σ/R)³ times the volume a fresh query covers, and the candidates grow
/// alike; measured (callgrind, `bench`, 10,000 agents): the bee and boids (about 1 cm per
/// substep, R 0.15 m, so σ/R of 0.15–0.3 for one reused substep) cost 6–18 % more per
/// step with lists than without, zonal's midges (0.3 mm per substep, R 0.27 m: σ/R
/// 0.013 for the whole frame) 9 % less (only zonal opts in: `Model::KEEPS_CANDIDATES`).
const SKIN_FRACTION: f32 = 0.05;

/// An agent without candidates (too many: a crowd).
const NO_CANDIDATES: (u32, u32) = (u32::MAX, 0);

/// How the gather pass lists neighbours this substep.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Listing {
    /// From the grid, for every agent (no candidates kept).
    Fresh,
    /// From the grid, keeping candidates for a skin of σ metres (`super::skin`).
    Build(f32),
    /// From the candidates of the last `Build` (the grid is stale unless some agent has
    /// none, in which case it was rebuilt for those).
    Reuse,
}

/// What the gather pass reads of the world.
#[derive(Clone, Copy)]
struct Gather<'a> {
    grid: &'a Grid,
    listing: Listing,
    /// Lists found afresh are put in id order too (see `Simulation::sorted`).
    sort: bool,
    agents: &'a [Neighbour],
    /// Every agent's position now, by global index.
    positions: &'a [Vec3],
    /// Every agent's id, by global index.
    ids: &'a [u32],
    targets: &'a [TargetNow],
    max_body_radius: f32,
    cancel: &'a AtomicBool,
}

/// What the world does with a swarm, whatever its model: one call per swarm per pass.
trait Swarm: Send + Sync {
    fn len(&self) -> usize;
    /// Writes the agents' neighbour records (pass 0, after a new order's `permute`).
    fn neighbour_records(&self, out: &mut [Neighbour], mass: f32, radius: f32);
    /// Writes every agent's position, and whether it is out of the world for now
    /// (`Agent::hidden`: no one's neighbour).
    fn positions(&self, out: &mut [Vec3], hidden: &mut [bool]);
    /// The largest squared speed of any agent, m²/s².
    fn fastest(&self) -> f32;
    /// Lists each agent's neighbours and runs the model's gather pass (pass 1); true if
    /// some agent keeps no candidates (so needs a fresh grid every substep).
    fn gather(
        &mut self,
        w: &Gather,
        lists: &mut [NeighbourList],
        gathered: &mut [(f32, f32)],
    ) -> bool;
    /// Steps every agent into the second buffer and swaps (pass 2).
    fn step(&mut self, cx: &Context, cancel: &AtomicBool);
    /// Moves the agents to their new indices: the one at global index `old_of_new[k]` to
    /// `start + k`, for this swarm's k (`Simulation::store_in_cell_order`). The move is
    /// made by this substep's step, which must follow.
    fn permute(&mut self, old_of_new: &[u32]);
    fn reach(&self) -> f32;
    fn lists_neighbours(&self) -> bool;
    /// The world may keep this swarm's neighbour candidates (`Model::KEEPS_CANDIDATES`, or
    /// it lists no neighbours).
    fn keeps_candidates(&self) -> bool;
    fn target_particle_spacing(&self) -> Option<f32>;
    /// Places the agent stored at (swarm) index `k`.
    fn place(&mut self, k: usize, position: Vec3, velocity: Vec3);
    /// Fills the frame record of this swarm, agents in id order: `slots[k]` is the global
    /// index of its agent with id `first_id + k`. Angular velocities over the last
    /// substep, `spin_dt` seconds, only when asked for (`None`: zeros).
    fn record(&mut self, f: &mut SwarmFrame, first_id: u64, spin_dt: Option<f32>, slots: &[u32]);
    /// Appends the agents' state in id order (checkpoints; `slots` as for `record`).
    fn agent_bytes(&self, out: &mut Vec<u8>, slots: &[u32]);
    /// Replaces the agents' state with bytes from `agent_bytes` (stored in id order); false
    /// if they do not fit.
    fn set_agent_bytes(&mut self, bytes: &[u8]) -> bool;
}

impl<M: Model> Runner<M> {
    /// The agent that goes to (swarm) index k: stored there, or, after a new order
    /// (`Swarm::permute`) until the step that moves it, at `moved[k]`. The records and the
    /// step read every agent anyway, so the move costs no pass of its own.
    #[inline(always)]
    fn old(&self, k: usize) -> &M::Agent {
        if self.moved.is_empty() {
            &self.agents[k]
        } else {
            &self.agents[self.moved[k] as usize - self.start]
        }
    }

    /// Asks the caches for the agent that will be at `k` in the new order, when a new
    /// order is pending in a swarm too large for the caches: it is read through the
    /// permutation, which the hardware prefetcher does not follow (100,000 bees: 7 % less
    /// CPU with the recording's prefetch; 10,000 fit, and prefetching cost them 1 %).
    #[inline(always)]
    fn prefetch_moved(&self, k: usize) {
        if self.agents.len() >= PREFETCH_FROM
            && let Some(&o) = self.moved.get(k)
        {
            prefetch(&self.agents[o as usize - self.start]);
        }
    }
}

impl<M: Model> Swarm for Runner<M>
where
    M::Agent: AgentBytes,
{
    fn len(&self) -> usize {
        self.agents.len()
    }

    fn neighbour_records(&self, out: &mut [Neighbour], mass: f32, radius: f32) {
        out.par_iter_mut()
            .enumerate()
            .with_min_len(1024)
            .for_each(|(k, o)| {
                let a = self.old(k);
                *o = Neighbour {
                    pos: a.position(),
                    radius: radius * a.size(),
                    vel: a.velocity(),
                    mass,
                    density: 0.0,
                    pressure: 0.0,
                };
            });
    }

    fn positions(&self, out: &mut [Vec3], hidden: &mut [bool]) {
        debug_assert!(self.moved.is_empty(), "a new order waits for its step");
        out.par_iter_mut()
            .zip(hidden.par_iter_mut())
            .zip(self.agents.par_iter())
            .with_min_len(1024)
            .for_each(|((p, h), a)| (*p, *h) = (a.position(), a.hidden()));
    }

    fn fastest(&self) -> f32 {
        self.agents
            .par_iter()
            .with_min_len(4096)
            .map(|a| a.velocity().length_squared())
            .reduce(|| 0.0, f32::max)
    }

    fn gather(
        &mut self,
        w: &Gather,
        lists: &mut [NeighbourList],
        gathered: &mut [(f32, f32)],
    ) -> bool {
        let Gather {
            grid,
            listing,
            sort,
            agents,
            positions,
            ids,
            targets,
            max_body_radius,
            cancel,
        } = *w;
        if !self.lists_neighbours() {
            lists.iter_mut().for_each(NeighbourList::clear);
            return false;
        }
        let (m, start, n) = (&self.model, self.start, self.agents.len());
        // The agents are stored in the grid's cell order (see the module notes), so going by
        // index, neighbouring queries read the same rows of the grid and the same
        // neighbours, which stay in cache (a hundred thousand agents' grid and records do
        // not). Each query is a fixed function of its agent and the grid (or its
        // candidates), so the order changes no result.
        // The model's gather sums over a list: the agent's own term, then its neighbours'.
        let sums = |i: usize, list: &NeighbourList| -> (f32, f32) {
            if !M::GATHERS {
                return (0.0, 0.0);
            }
            let me = &agents[i];
            let ri = me.radius;
            let own = m.gather_term(ri, me, 0.0);
            let sum = m
                .gather_list(me, agents, list.indices(), own)
                .unwrap_or_else(|| {
                    let mut sum = own;
                    for &j in list.indices() {
                        let o = &agents[j as usize];
                        sum += m.gather_term(ri, o, me.pos.distance_squared(o.pos));
                    }
                    sum
                });
            m.gather_finish(targets, me.pos, ri, sum)
        };
        let radius = |i: usize| m.reach() + agents[i].radius + max_body_radius;
        match listing {
            Listing::Fresh | Listing::Reuse => {
                let (candidates, ranges) = (&self.candidates, &self.ranges);
                let reuse = listing == Listing::Reuse;
                lists
                    .par_iter_mut()
                    .zip(gathered.par_iter_mut())
                    .enumerate()
                    .with_min_len(piece(n, 256))
                    .for_each_init(Found::default, |found, (k, (list, g))| {
                        // Cancelled: the rest of this pass is skipped (the state is abandoned).
                        if cancel.load(Ordering::Relaxed) {
                            return;
                        }
                        let i = start + k;
                        let (from, len) = if reuse { ranges[k] } else { NO_CANDIDATES };
                        if from == u32::MAX {
                            list.fill(grid, positions[i], radius(i), i, found);
                            // Among reused lists, in their order (see `Simulation::sorted`).
                            if reuse || sort {
                                list.sort(ids);
                            }
                        } else {
                            let c = &candidates[from as usize..(from + len) as usize];
                            skin::reselect(c, positions, ids, positions[i], radius(i), list);
                        }
                        *g = sums(i, list);
                    });
                !reuse || self.ranges.contains(&NO_CANDIDATES)
            }
            Listing::Build(sigma) => {
                // In chunks, each with its own candidates (joined below in index order:
                // the same whatever the number of threads).
                const CHUNK: usize = 256;
                let chunks: Vec<(Vec<u32>, Vec<u32>)> = lists
                    .par_chunks_mut(CHUNK)
                    .zip(gathered.par_chunks_mut(CHUNK))
                    .enumerate()
                    .map(|(c, (lists, gathered))| {
                        let mut candidates = Vec::new();
                        let mut lens = Vec::with_capacity(lists.len());
                        let mut scratch = vec![(0u32, 0.0f32); skin::SCRATCH];
                        for (t, (list, g)) in lists.iter_mut().zip(gathered).enumerate() {
                            if cancel.load(Ordering::Relaxed) {
                                lens.push(u32::MAX);
                                continue;
                            }
                            let i = start + c * CHUNK + t;
                            let before = candidates.len();
                            let kept = skin::build(
                                grid,
                                positions,
                                ids,
                                positions[i],
                                i,
                                radius(i),
                                sigma,
                                list,
                                &mut candidates,
                                &mut scratch,
                            );
                            lens.push(if kept {
                                (candidates.len() - before) as u32
                            } else {
                                u32::MAX
                            });
                            *g = sums(i, list);
                        }
                        (candidates, lens)
                    })
                    .collect();
                self.candidates.clear();
                self.ranges.clear();
                self.ranges.reserve(n);
                let mut fresh = false;
                for (candidates, lens) in &chunks {
                    let mut at = self.candidates.len() as u32;
                    for &len in lens {
                        if len == u32::MAX {
                            fresh = true;
                            self.ranges.push(NO_CANDIDATES);
                        } else {
                            self.ranges.push((at, len));
                            at += len;
                        }
                    }
                    self.candidates.extend_from_slice(candidates);
                }
                fresh
            }
        }
    }

    fn step(&mut self, cx: &Context, cancel: &AtomicBool) {
        self.model
            .prepare(cx, self.start..self.start + self.agents.len());
        let (m, start) = (&self.model, self.start);
        let mut next = std::mem::take(&mut self.next);
        next.clear();
        next.par_extend(
            (0..self.agents.len())
                .into_par_iter()
                .with_min_len(piece(self.agents.len(), 128))
                .map(|k| {
                    self.prefetch_moved(k + PREFETCH_AHEAD);
                    let a = self.old(k);
                    // Cancelled: agents are copied, not stepped (the state is abandoned).
                    if cancel.load(Ordering::Relaxed) {
                        *a
                    } else {
                        m.step(cx, start + k, a)
                    }
                }),
        );
        self.next = std::mem::replace(&mut self.agents, next);
        self.moved.clear();
    }

    fn permute(&mut self, old_of_new: &[u32]) {
        debug_assert!(self.moved.is_empty());
        self.moved.extend_from_slice(old_of_new);
    }

    fn reach(&self) -> f32 {
        self.model.reach()
    }

    fn lists_neighbours(&self) -> bool {
        M::GATHERS || self.model.lists_neighbours()
    }

    fn keeps_candidates(&self) -> bool {
        M::KEEPS_CANDIDATES || !self.lists_neighbours()
    }

    fn target_particle_spacing(&self) -> Option<f32> {
        self.model.target_particle_spacing()
    }

    fn place(&mut self, k: usize, position: Vec3, velocity: Vec3) {
        debug_assert!(self.moved.is_empty(), "a new order waits for its step");
        self.agents[k].place(position, velocity);
    }

    fn record(&mut self, f: &mut SwarmFrame, first_id: u64, spin_dt: Option<f32>, slots: &[u32]) {
        debug_assert!(self.moved.is_empty(), "a new order waits for its step");
        let n = self.agents.len();
        let channels = M::INFO.channels.len();
        let (m, agents, start) = (&self.model, &self.agents, self.start);
        // Every column is written in place, in parallel, each entry by its own agent: the
        // same values on any thread count, and no serial copy after the poses. (The
        // frame's buffers are reused, so after the first frame the resizes do nothing.)
        f.ids.resize(n, 0);
        f.position.resize(n, Vec3::ZERO);
        f.velocity.resize(n, Vec3::ZERO);
        f.orientation.resize(n, Quat::IDENTITY);
        f.heading.resize(n, Quat::IDENTITY);
        f.angular_velocity_deg.resize(n, Vec3::ZERO);
        f.scale.resize(n, 0.0);
        // Channel values agent by agent (a model writes its own as one row), turned into
        // columns below. One row per agent even without channels, so that the rows zip
        // with the agents.
        let row = channels.max(1);
        self.values.resize(n * row, 0.0);
        // Small swarms in pieces too: run on one thread, the poses of a few hundred agents
        // kept the other idle long enough to fall asleep, and the next pass woke it.
        // Four agents at a time (`Model::poses`), the last four padded with the last agent.
        let pieces = piece(n, 512).div_ceil(4);
        f.ids
            .par_chunks_mut(4)
            .zip(f.position.par_chunks_mut(4))
            .zip(f.velocity.par_chunks_mut(4))
            .zip(f.orientation.par_chunks_mut(4))
            .zip(f.heading.par_chunks_mut(4))
            .zip(f.angular_velocity_deg.par_chunks_mut(4))
            .zip(f.scale.par_chunks_mut(4))
            .zip(self.values.par_chunks_mut(4 * row))
            .zip(slots.par_chunks(4))
            .enumerate()
            .with_min_len(pieces)
            .for_each(
                |(c, ((((((((id, pos), vel), ori), head), ang), scale), values), four))| {
                    // Agents are stored in cell order and recorded in id order: in a large
                    // swarm each read misses the caches, so the agents a few ids on are
                    // asked for now (100,000 bees: the poses took 9 % of a bench, 2.6 % at
                    // 10,000).
                    let k0 = 4 * c;
                    for ahead in slots.iter().skip(k0 + PREFETCH_AHEAD).take(4) {
                        prefetch(&agents[*ahead as usize - start]);
                    }
                    let agent = |j: usize| &agents[four[j.min(four.len() - 1)] as usize - start];
                    let poses = m.poses(std::array::from_fn(agent), spin_dt);
                    for (j, pose) in poses.iter().enumerate().take(four.len()) {
                        let a = agent(j);
                        m.record(a, pose, &mut values[j * row..j * row + channels]);
                        id[j] = first_id + (k0 + j) as u64;
                        pos[j] = a.position();
                        vel[j] = a.velocity();
                        ori[j] = pose.orientation;
                        head[j] = pose.heading;
                        ang[j] = pose.angular_velocity_deg;
                        scale[j] = a.size();
                    }
                },
            );
        f.channels.resize_with(channels, Vec::new);
        let values = &self.values;
        for (c, column) in f.channels.iter_mut().enumerate() {
            column.resize(n, 0.0);
            column
                .par_iter_mut()
                .enumerate()
                .with_min_len(4096)
                .for_each(|(k, v)| *v = values[k * row + c]);
        }
    }

    fn agent_bytes(&self, out: &mut Vec<u8>, slots: &[u32]) {
        debug_assert!(self.moved.is_empty(), "a new order waits for its step");
        let by_id: Vec<M::Agent> = slots
            .iter()
            .map(|&i| self.agents[i as usize - self.start])
            .collect();
        super::agent_bytes::to_bytes(&by_id, out);
    }

    fn set_agent_bytes(&mut self, bytes: &[u8]) -> bool {
        match super::agent_bytes::from_bytes::<M::Agent>(bytes) {
            Some(agents) if agents.len() == self.agents.len() => {
                self.agents = agents;
                true
            }
            _ => false,
        }
    }
}

/// A running simulation of a shot.
pub struct Simulation {
    shot: Shot,
    swarms: Vec<Box<dyn Swarm>>,
    /// Every target at the current substep.
    targets: Vec<TargetNow>,
    obstacles: Vec<Shape>,
    /// Each moving obstacle's pose at the start of the current substep (`None`: static).
    obstacles_before: Vec<Option<geometry::Rigid>>,
    lists: Vec<NeighbourList>,
    gathered: Vec<(f32, f32)>,
    agents: Vec<Neighbour>,
    /// Per agent: out of the world this substep (`Agent::hidden`), left out of the grid.
    hidden: Vec<bool>,
    positions: Vec<Vec3>,
    /// Every agent's id by index, and its index by id (see the module notes, "Cell order").
    ids: Vec<u32>,
    slots: Vec<u32>,
    /// Buffers of `store_in_cell_order`, reused every substep.
    new_of_old: Vec<u32>,
    old_of_new: Vec<u32>,
    spare_positions: Vec<Vec3>,
    spare_flags: Vec<bool>,
    spare_ids: Vec<u32>,
    grid: Grid,
    grid_cell: f32,
    /// Neighbour candidates (`super::skin`): the skin σ of the last rebuild, m (0: none
    /// kept), the positions and hidden flags then, whether some agent keeps none (the
    /// grid is then rebuilt every substep for it), whether an agent was placed since, and
    /// how many rebuilds there were (for tests).
    skin: f32,
    built: Vec<Vec3>,
    built_hidden: Vec<bool>,
    needs_grid: bool,
    placed: bool,
    rebuilds: u64,
    /// This frame keeps candidates (decided at its first substep): only then are the
    /// positions of the last substep kept, in `previous`.
    keeps: bool,
    previous: Vec<Vec3>,
    /// Some substep of this frame kept candidates: every list of the rest of the frame is
    /// in id order, found afresh or not, so that when the lists are rebuilt (a fast
    /// agent) changes no sum. A frame without a skin keeps the grid's order and skips
    /// the sort.
    sorted: bool,
    /// The largest skin, as a fraction of the grid's cell ([`SKIN_FRACTION`]).
    skin_fraction: f32,
    /// Largest body radius of any agent, m: bounds every contact distance.
    max_body_radius: f32,
    frame: i32,
    step_index: u64,
    record: Vec<SwarmFrame>,
    /// Whether the record holds angular velocities ([`Simulation::record_spin`]).
    spin: bool,
    /// The record was handed over ([`Simulation::swap_record`]) since it was made.
    record_handed: bool,
    /// Set from outside (Ctrl-C) to stop a frame part-way; see [`Simulation::advance_or_cancel`].
    cancel: &'static AtomicBool,
}

/// Where agent k of swarm `si` starts (clear of `obstacles`, the shot's shapes), and the
/// random stream its model continues from.
fn start(shot: &Shot, obstacles: &[Shape], si: usize, k: usize) -> (Start, Rng) {
    let s = &shot.swarms[si];
    let mut rng = Rng::new(shot.seed, si as u64, k as u64);
    let mut pos = match s.spawn {
        Region::Box { center, half } => {
            center
                + Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                ) * half
        }
        Region::Sphere { center, radius } => loop {
            let v = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            if v.length_squared() <= 1.0 {
                break center + v * radius;
            }
        },
    };
    let var = s.variation;
    let size = 1.0 + var.size * rng.range(-1.0, 1.0);
    let speed_factor = 1.0 + var.speed * rng.range(-1.0, 1.0);
    // An agent spawned inside an obstacle starts just outside its surface; where
    // obstacles overlap, pushing it out of one can push it into another, so repeat.
    let r = s.bee.radius * size;
    for _ in 0..8 {
        let mut moved = false;
        for o in obstacles {
            let q = geometry::query(o, pos);
            if q.distance < r {
                pos = q.point + q.normal * (r + 1e-3);
                moved = true;
            }
        }
        if !moved {
            break;
        }
    }
    if obstacles
        .iter()
        .any(|o| geometry::signed_distance(o, pos) < r)
    {
        // A crevice between overlapping obstacles: the nearest free spot instead.
        pos = geometry::free_point_near(obstacles, pos, r + 1e-3).unwrap_or(pos);
    }
    let dir = normalize_or(
        Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-0.2, 0.2),
            rng.range(-1.0, 1.0),
        ),
        Vec3::X,
    );
    let inside = starts_inside(shot, obstacles, si, k, r, &mut rng);
    let start = Start {
        pos: inside.map_or(pos, |h| {
            shot.targets[h.target].position_at(shot.frame_start as f64) + h.offset
        }),
        dir,
        size,
        speed_factor,
        inside,
    };
    (start, rng)
}

/// Agent k of swarm `si` (body radius `r`) starts inside a hive if it is among the
/// swarm's first `start_inside` fraction: the hives that attract the swarm take them in
/// turn. It sits on the entrance (a random point of the target's sphere, moved clear of
/// `obstacles`), and comes out after a time drawn uniformly from 0 to the hive's longest
/// stay inside, so that bees come out from the first frame on.
fn starts_inside(
    shot: &Shot,
    obstacles: &[Shape],
    si: usize,
    k: usize,
    r: f32,
    rng: &mut Rng,
) -> Option<StartInside> {
    let s = &shot.swarms[si];
    let n = (s.start_inside as f64 * s.count as f64).round() as usize;
    if k >= n {
        return None;
    }
    let hives: Vec<usize> = (0..shot.targets.len())
        .filter(|&ti| shot.targets[ti].inside.is_some() && shot.targets[ti].swarms.contains(&si))
        .collect();
    let target = *hives.get(k % hives.len().max(1))?;
    let t = &shot.targets[target];
    let center = t.position_at(shot.frame_start as f64);
    let dir = loop {
        let v = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        if (0.01..=1.0).contains(&v.length_squared()) {
            break v.normalize();
        }
    };
    let mut pos = center + dir * (t.radius + r);
    for o in obstacles {
        let q = geometry::query(o, pos);
        if q.distance < r {
            pos = q.point + q.normal * (r + 1e-3);
        }
    }
    let longest = t.inside.map_or(0.0, |(_, hi)| hi);
    Some(StartInside {
        target,
        offset: pos - center,
        time_left: longest * rng.f32(),
    })
}

impl Simulation {
    pub fn new(shot: &Shot) -> Self {
        let shot = shot.clone();
        let mut obstacles: Vec<Shape> = shot.obstacles.iter().map(|o| o.shape.clone()).collect();
        // The shot places moving meshes at its file's first frame; `--frames` may start
        // elsewhere.
        place_obstacles(&mut obstacles, &shot, shot.frame_start as f64);
        let mut swarms: Vec<Box<dyn Swarm>> = Vec::with_capacity(shot.swarms.len());
        let mut first = 0;
        for (si, s) in shot.swarms.iter().enumerate() {
            let setup = SwarmSetup {
                index: si,
                seed: shot.seed,
                dt: shot.dt(),
                params: &s.params,
                body: s.bee,
                variation: s.variation,
                bounds: s.bounds,
                database: s.database.clone(),
                targets: shot
                    .targets
                    .iter()
                    .enumerate()
                    .filter(|(_, t)| t.swarms.contains(&si))
                    .map(|(ti, _)| ti)
                    .collect(),
                obstacles: &obstacles,
            };
            swarms.push(with_model!(s.model, M => {
                let model = M::new(&setup);
                let agents: Vec<_> = (0..s.count)
                    .map(|k| {
                        let (start, mut rng) = start(&shot, &obstacles, si, k);
                        model.spawn(&start, &mut rng)
                    })
                    .collect();
                Box::new(Runner::<M> {
                    model,
                    next: Vec::with_capacity(agents.len()),
                    agents,
                    start: first,
                    values: Vec::new(),
                    moved: Vec::new(),
                    candidates: Vec::new(),
                    ranges: Vec::new(),
                })
            }));
            first += s.count;
        }
        // Target bodies are sampled as finely as the finest model that feels them asks.
        let spacing = swarms
            .iter()
            .filter_map(|s| s.target_particle_spacing())
            .fold(f32::INFINITY, f32::min);
        let targets = shot
            .targets
            .iter()
            .map(|t| TargetNow {
                kind: t.kind,
                center: t.position_at(shot.frame_start as f64),
                normal: t.normal,
                strength: t.strength,
                reach: t.reach,
                radius: t.radius,
                land: t.land,
                stay: t.stay,
                inside: t.inside,
                particles: if t.kind.has_body() && spacing.is_finite() {
                    geometry::sphere_samples(Vec3::ZERO, t.radius, spacing.max(t.radius * 0.3))
                } else {
                    Vec::new()
                },
            })
            .collect();
        let max_body_radius = shot
            .swarms
            .iter()
            .map(|s| s.bee.radius * (1.0 + s.variation.size))
            .fold(0.0, f32::max);
        let grid_cell = swarms
            .iter()
            .map(|s| s.reach() + 2.0 * max_body_radius)
            .fold(0.0, f32::max);
        // Candidates only where every model that lists neighbours opts in (`Model::
        // KEEPS_CANDIDATES`); otherwise no skin, and the lists are the grid's, as before.
        let skin_fraction = if swarms.iter().all(|s| s.keeps_candidates()) {
            SKIN_FRACTION
        } else {
            0.0
        };
        let mut sim = Simulation {
            frame: shot.frame_start,
            obstacles_before: shot.obstacles.iter().map(|_| None).collect(),
            obstacles,
            shot,
            swarms,
            targets,
            lists: Vec::new(),
            gathered: Vec::new(),
            agents: Vec::new(),
            hidden: Vec::new(),
            positions: Vec::new(),
            ids: Vec::new(),
            slots: Vec::new(),
            new_of_old: Vec::new(),
            old_of_new: Vec::new(),
            spare_positions: Vec::new(),
            spare_flags: Vec::new(),
            spare_ids: Vec::new(),
            grid: Grid::default(),
            grid_cell,
            skin: 0.0,
            built: Vec::new(),
            built_hidden: Vec::new(),
            needs_grid: true,
            placed: true,
            rebuilds: 0,
            keeps: false,
            previous: Vec::new(),
            sorted: false,
            skin_fraction,
            max_body_radius,
            step_index: 0,
            record: Vec::new(),
            spin: true,
            record_handed: false,
            cancel: &NEVER,
        };
        sim.store_by_id();
        sim.update_record();
        sim
    }

    /// Every agent stored at the index of its id (at the start, and after a restore).
    fn store_by_id(&mut self) {
        let n = self.shot.bee_count();
        self.ids.clear();
        self.ids.extend(0..n as u32);
        self.slots.clone_from(&self.ids);
    }

    /// Places agent `index` (shot order: its id) at `position` with `velocity` and
    /// re-records the current frame: for tests and tools that need exact starting
    /// conditions.
    pub fn set_bee(&mut self, index: usize, position: Vec3, velocity: Vec3) {
        // Where it is stored: within its swarm's range, as its id.
        let mut k = self.slots[index] as usize;
        for s in &mut self.swarms {
            if k < s.len() {
                s.place(k, position, velocity);
                self.placed = true;
                break;
            }
            k -= s.len();
        }
        self.update_record();
    }

    pub fn shot(&self) -> &Shot {
        &self.shot
    }

    /// The current frame number.
    pub fn frame(&self) -> i32 {
        self.frame
    }

    /// True once the last frame of the range has been reached.
    pub fn done(&self) -> bool {
        self.frame >= self.shot.frame_end
    }

    /// Seconds since the first frame.
    pub fn time(&self) -> f64 {
        (self.frame - self.shot.frame_start) as f64 / self.shot.fps
    }

    /// Whether the frames recorded from now on hold each agent's angular velocity (on by
    /// default). Only USDA's `angularVelocities` and the checkpoint journal read it; a bake
    /// writing neither turns it off, and its poses skip that work (about a third of the
    /// bee's: the attitude a substep earlier, three sines and cosines, and the turn
    /// between them). Off, `SwarmFrame::angular_velocity_deg` holds zeros.
    pub fn record_spin(&mut self, on: bool) {
        // The current frame's record follows at once (it was made when the world was
        // built), unless it has been handed over.
        if on != self.spin {
            self.spin = on;
            if !self.record_handed {
                self.update_record();
            }
        }
    }

    /// The state at the current frame, one entry per swarm.
    pub fn record(&self) -> &[SwarmFrame] {
        debug_assert!(
            !self.record_handed,
            "the record was handed over (`swap_record`)"
        );
        &self.record
    }

    /// Hands over the current frame's record (`record`) in exchange for `spare`, an older
    /// frame's record that is no longer needed (or an empty one), whose buffers the next
    /// frame's record is written into: no copy, no allocation. Until the next frame
    /// `record` is not to be read.
    pub fn swap_record(&mut self, spare: &mut Vec<SwarmFrame>) {
        std::mem::swap(&mut self.record, spare);
        self.record_handed = true;
    }

    pub fn meta(&self) -> CacheMeta {
        CacheMeta {
            shot_name: self.shot.name.clone(),
            fps: self.shot.fps,
            frame_start: self.shot.frame_start,
            frame_end: self.shot.frame_end,
            seed: self.shot.seed,
            tool_version: env!("CARGO_PKG_VERSION").to_owned(),
            swarms: self
                .shot
                .swarms
                .iter()
                .enumerate()
                .map(|(si, s)| {
                    let info = s.model.info();
                    // Agents are hidden only in swarms that a hive attracts.
                    let hive = self
                        .shot
                        .targets
                        .iter()
                        .any(|t| t.inside.is_some() && t.swarms.contains(&si));
                    let rule = with_model!(s.model, M => M::HIDDEN_STATE);
                    let hidden = rule.filter(|_| hive).and_then(|(name, value)| {
                        let column = info.channels.iter().position(|c| c.name == name)?;
                        Some((column, value))
                    });
                    SwarmMeta {
                        name: s.name.clone(),
                        count: s.count,
                        species: info.species,
                        channels: info.channels.to_vec(),
                        body_length_m: s.bee.length,
                        wing_beat_hz: s.bee.wing_beat_hz,
                        hidden,
                    }
                })
                .collect(),
        }
    }

    /// Advances one frame (`substeps` integration steps) and records it; with a cancel
    /// flag set (see [`Simulation::set_cancel`]) it stops as [`Simulation::advance_or_cancel`].
    pub fn advance(&mut self) {
        self.advance_or_cancel();
    }

    /// A flag that stops the simulation part-way through a frame once set (a frame of a
    /// dense 10-million-agent shot can take minutes): see [`Simulation::advance_or_cancel`].
    pub fn set_cancel(&mut self, flag: &'static AtomicBool) {
        self.cancel = flag;
    }

    /// As [`Simulation::advance`], but stops between substeps and within each pass as
    /// soon as the cancel flag is set; returns false then, and the simulation is no
    /// longer usable.
    pub fn advance_or_cancel(&mut self) -> bool {
        let dt = self.shot.dt() as f32;
        for k in 0..self.shot.substeps {
            if self.cancel.load(Ordering::Relaxed) {
                return false;
            }
            let t = self.time() + (k as f64) * self.shot.dt();
            self.step(t, dt, k);
        }
        if self.cancel.load(Ordering::Relaxed) {
            return false;
        }
        self.frame += 1;
        self.update_record();
        true
    }

    fn update_targets(&mut self, t: f64) {
        let frame = self.shot.frame_start as f64 + t * self.shot.fps;
        for (now, target) in self.targets.iter_mut().zip(&self.shot.targets) {
            now.center = target.position_at(frame);
        }
    }

    /// Moves the moving obstacles to where they stand at time `t + dt`, and notes where
    /// they stood at `t` (their motion over the substep). Both from the keys, so a resumed
    /// simulation moves them exactly as an uninterrupted one.
    fn update_obstacles(&mut self, t: f64, dt: f64) {
        let frame = |t: f64| self.shot.frame_start as f64 + t * self.shot.fps;
        for (before, o) in self.obstacles_before.iter_mut().zip(&self.shot.obstacles) {
            *before = o.pose_at(frame(t));
        }
        place_obstacles(&mut self.obstacles, &self.shot, frame(t + dt));
    }

    /// One integration step of `dt` seconds starting at time `t`, substep `substep` of
    /// the frame.
    fn step(&mut self, t: f64, dt: f32, substep: u32) {
        let n = self.shot.bee_count();
        if n == 0 {
            return;
        }
        self.update_targets(t);
        // Obstacles where they stand at the end of this step: the positions it makes
        // must be clear of them then (the frame recorded after the last substep shows the
        // obstacles at that frame), so the contact guard pushes out a body a moving
        // obstacle has come onto.
        self.update_obstacles(t, self.shot.dt());
        // Pass 0: the grid over the agents' positions, then every agent's neighbour
        // record, in the grid's order. The grid only for shots where some model reads
        // neighbours; hidden agents (bees inside their hive) are not in it, so no one
        // meets them.
        let lists = self.swarms.iter().any(|s| s.lists_neighbours());
        let mut listing = Listing::Fresh;
        let mut regrid = lists;
        if lists {
            self.positions.resize(n, Vec3::ZERO);
            self.hidden.resize(n, false);
            let per_swarm =
                split(&mut self.positions, &self.swarms).zip(split(&mut self.hidden, &self.swarms));
            for (swarm, (positions, hidden)) in self.swarms.iter().zip(per_swarm) {
                swarm.positions(positions, hidden);
            }
            listing = self.listing(substep);
            regrid = listing != Listing::Reuse || self.needs_grid;
        }
        if regrid {
            // (A shot without a hive skips the flags: the common case costs nothing.)
            let except: &[bool] = if self.hidden.contains(&true) {
                &self.hidden
            } else {
                &[]
            };
            // Coarse cells where sparse: the same lists in the same order, but a frame
            // keeping candidates searches them with `Grid::within`, whose order is the
            // walk's own.
            self.grid.allow_coarse(!self.keeps);
            // Visited by id: the order within the grid's cells, so the lists' order, is
            // then the same wherever the agents are stored.
            self.grid
                .build_visiting(&self.positions, self.grid_cell, except, &self.slots);
            // Between rebuilds the candidates name agents by index: keep them in place.
            // Once a frame: within a frame agents move a few millimetres, so the order
            // of its first substep stays close to the grid's for the rest.
            if listing != Listing::Reuse && substep == 0 {
                self.store_in_cell_order();
            }
        }
        self.agents.resize(n, Neighbour::default());
        for (s, (swarm, records)) in self.shot.swarms.iter().zip(
            self.swarms
                .iter()
                .zip(split(&mut self.agents, &self.swarms)),
        ) {
            swarm.neighbour_records(records, s.bee.mass, s.bee.radius);
        }

        // Pass 1: neighbour lists and the models' gather passes, written in place.
        self.lists.resize(n, NeighbourList::default());
        self.gathered.resize(n, (0.0, 0.0));
        let shared = Gather {
            grid: &self.grid,
            listing,
            sort: self.sorted,
            agents: &self.agents,
            positions: &self.positions,
            ids: &self.ids,
            targets: &self.targets,
            max_body_radius: self.max_body_radius,
            cancel: self.cancel,
        };
        let per_swarm =
            split(&mut self.lists, &self.swarms).zip(split(&mut self.gathered, &self.swarms));
        let mut needs_grid = false;
        for (swarm, (lists, gathered)) in self.swarms.iter_mut().zip(per_swarm) {
            needs_grid |= swarm.gather(&shared, lists, gathered);
        }
        if listing != Listing::Reuse {
            self.needs_grid = needs_grid;
        }
        self.agents
            .par_iter_mut()
            .zip(self.gathered.par_iter())
            .with_min_len(4096)
            .for_each(|(a, &(d, p))| (a.density, a.pressure) = (d, p));

        // Pass 2: every model's step.
        let cx = Context {
            t,
            dt,
            step: self.step_index,
            seed: self.shot.seed,
            wind: self.shot.wind,
            obstacles: &self.obstacles,
            obstacles_before: &self.obstacles_before,
            targets: &self.targets,
            max_body_radius: self.max_body_radius,
            agents: &self.agents,
            lists: &self.lists,
            ids: &self.ids,
            slots: &self.slots,
        };
        for swarm in &mut self.swarms {
            swarm.step(&cx, self.cancel);
        }
        self.step_index += 1;
    }

    /// Stores every swarm that lists neighbours in the order of the grid just built, the
    /// agents it leaves out (hidden) after the rest, by id; the other swarms stay in id
    /// order. Every per-agent array follows, and the grid is relabelled to the new
    /// indices. The new order is a function of the state alone (the grid's cells visited by
    /// id), so a run resumed from a checkpoint stores its agents as one never stopped.
    fn store_in_cell_order(&mut self) {
        let n = self.ids.len();
        let ranges: Vec<(usize, usize, bool)> = {
            let mut at = 0;
            self.swarms
                .iter()
                .map(|s| {
                    at += s.len();
                    (at - s.len(), at, s.lists_neighbours())
                })
                .collect()
        };
        let order = self.grid.order();
        if ranges.len() == 1 && ranges[0].2 && order.len() == n {
            // One swarm, all of it in the grid (the common case): the new order is the
            // grid's, and each agent's new index its place in it. Copies, in parallel.
            self.new_of_old.clear();
            self.new_of_old
                .par_extend(self.grid.places().par_iter().with_min_len(4096));
            self.old_of_new.clear();
            self.old_of_new
                .par_extend(order.par_iter().with_min_len(4096));
        } else {
            self.renumber(&ranges);
        }
        let (new_of_old, old_of_new) = (&self.new_of_old, &self.old_of_new);
        // Positions, flags and ids in one pass.
        self.spare_positions.resize(n, Vec3::ZERO);
        self.spare_flags.resize(n, false);
        self.spare_ids.resize(n, 0);
        let (positions, hidden, ids) = (&self.positions, &self.hidden, &self.ids);
        self.spare_positions
            .par_iter_mut()
            .zip(self.spare_flags.par_iter_mut())
            .zip(self.spare_ids.par_iter_mut())
            .zip(old_of_new.par_iter())
            .with_min_len(4096)
            .for_each(|(((p, h), i), &o)| {
                let o = o as usize;
                (*p, *h, *i) = (positions[o], hidden[o], ids[o]);
            });
        std::mem::swap(&mut self.positions, &mut self.spare_positions);
        std::mem::swap(&mut self.hidden, &mut self.spare_flags);
        std::mem::swap(&mut self.ids, &mut self.spare_ids);
        // The skin's copies, when kept (`listing`).
        if self.built.len() == n {
            permute(&mut self.built, old_of_new, &mut self.spare_positions);
            permute(&mut self.built_hidden, old_of_new, &mut self.spare_flags);
        }
        if self.previous.len() == n {
            permute(&mut self.previous, old_of_new, &mut self.spare_positions);
        }
        self.slots
            .par_iter_mut()
            .with_min_len(4096)
            .for_each(|k| *k = new_of_old[*k as usize]);
        self.grid.relabel(new_of_old, old_of_new);
        for (swarm, &(from, to, permutes)) in self.swarms.iter_mut().zip(&ranges) {
            if permutes {
                swarm.permute(&old_of_new[from..to]);
            }
        }
    }

    /// `store_in_cell_order`'s new indices in general (several swarms, or agents left out
    /// of the grid): each swarm `(from, to, permutes)` that permutes takes its agents in
    /// the grid's order, then those left out by id; the others keep theirs.
    fn renumber(&mut self, ranges: &[(usize, usize, bool)]) {
        let n = self.ids.len();
        let mut next: Vec<u32> = ranges.iter().map(|r| r.0 as u32).collect();
        let new_of_old = &mut self.new_of_old;
        new_of_old.clear();
        new_of_old.resize(n, u32::MAX);
        let single = ranges.len() == 1;
        for &o in self.grid.order() {
            let s = if single {
                0
            } else {
                ranges.partition_point(|r| r.1 <= o as usize)
            };
            if ranges[s].2 {
                new_of_old[o as usize] = next[s];
                next[s] += 1;
            }
        }
        for (s, &(from, to, _)) in ranges.iter().enumerate() {
            if next[s] as usize == to {
                continue;
            }
            for &o in &self.slots[from..to] {
                if new_of_old[o as usize] == u32::MAX {
                    new_of_old[o as usize] = next[s];
                    next[s] += 1;
                }
            }
        }
        self.old_of_new.resize(n, 0);
        for (o, &k) in new_of_old.iter().enumerate() {
            self.old_of_new[k as usize] = o as u32;
        }
    }

    /// Whether this substep (`substep` of the frame) reuses the neighbour candidates of
    /// the last rebuild or rebuilds them, and with what skin (`super::skin`); a rebuild
    /// records the positions and hidden flags it was made at.
    fn listing(&mut self, substep: u32) -> Listing {
        // Whether this frame may keep candidates at all is decided once, at its first
        // substep, from the state alone (as in a run resumed there). A frame that keeps
        // none (the bee, boids: too fast, and not opted in) costs nothing more than plain grid
        // queries: no displacement checks, no copies of positions.
        if substep == 0 {
            self.sorted = false;
            self.skin = self.skin_for(0);
            self.keeps = self.skin > 0.0;
        } else if !self.keeps {
            self.rebuilds += 1;
            return Listing::Fresh;
        }
        let n = self.positions.len();
        // Every agent has moved at most σ/2 since the rebuild; the largest displacement is
        // a maximum, the same in any order.
        let reuse = substep > 0
            && self.skin > 0.0
            && !self.placed
            && self.built.len() == n
            && self.hidden == self.built_hidden
            && 2.0 * largest_move(&self.positions, &self.built) <= self.skin;
        let listing = if reuse {
            Listing::Reuse
        } else {
            self.placed = false;
            self.rebuilds += 1;
            if substep > 0 {
                self.skin = self.skin_for(substep);
            }
            if self.skin > 0.0 {
                self.sorted = true;
                self.built.clone_from(&self.positions);
                self.built_hidden.clone_from(&self.hidden);
                Listing::Build(self.skin)
            } else {
                Listing::Fresh
            }
        };
        // The last substep's moves, for a later rebuild's skin (`skin_for`).
        if self.keeps {
            self.previous.clone_from(&self.positions);
        }
        listing
    }

    /// The skin σ for a rebuild at substep `substep` of the frame, m. σ/2 must cover the
    /// moves until the next rebuild: a move is the fastest agent's speed times the substep
    /// (or the largest move over the last substep, if larger: some models' agents report no
    /// velocity), with 10 % for acceleration. The lists are kept for as many of the
    /// substeps left in the frame as a skin of at most `skin_fraction` of the grid's cell
    /// (the largest radius) covers, since the candidates, and a rebuild's search out to
    /// R + σ, grow as (1 + σ/R)³; none when not even one fits (no skin: every substep
    /// queries the grid). Should an agent outrun the skin, the check rebuilds earlier.
    fn skin_for(&self, substep: u32) -> f32 {
        if self.skin_fraction == 0.0 {
            return 0.0; // no candidates for this shot's models
        }
        let left = self.shot.substeps.saturating_sub(substep + 1);
        if left == 0 {
            return 0.0;
        }
        let fastest = self
            .swarms
            .iter()
            .map(|s| s.fastest())
            .fold(0.0, f32::max)
            .sqrt();
        let most = self.skin_fraction * self.grid_cell;
        let mut step = fastest * self.shot.dt() as f32;
        if 2.0 * 1.1 * step > most {
            return 0.0; // too fast for even one reused substep
        }
        // The last substep's moves only within a frame: the first substep's skin depends on
        // the state alone, as in a run resumed there.
        if substep > 0 && self.previous.len() == self.positions.len() {
            step = step.max(largest_move(&self.positions, &self.previous));
        }
        let per_move = 2.0 * 1.1 * step;
        let moves = left.min((most / per_move.max(1e-12)) as u32);
        per_move * moves as f32
    }

    /// The whole evolving state — frame, step count and every agent — as bytes, for a
    /// checkpoint (see docs/farm.md). Everything else is rebuilt from the shot every step.
    /// Native byte order: resumed on a machine of the same architecture.
    pub fn state_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(&self.frame.to_le_bytes());
        out.extend_from_slice(&self.step_index.to_le_bytes());
        out.extend_from_slice(&(self.swarms.len() as u64).to_le_bytes());
        let mut first = 0;
        for s in &self.swarms {
            let mut agents = Vec::new();
            s.agent_bytes(&mut agents, &self.slots[first..first + s.len()]);
            first += s.len();
            out.extend_from_slice(&(agents.len() as u64).to_le_bytes());
            out.extend_from_slice(&agents);
        }
        out
    }

    /// Continues from `state_bytes` of a simulation of the same shot: afterwards it steps
    /// and records exactly as that simulation did. An error says why the bytes do not fit
    /// (and leaves this simulation unusable).
    pub fn restore_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut rest = bytes;
        let mut take = |n: usize| -> Result<&[u8], String> {
            if rest.len() < n {
                return Err("the state ends early".to_owned());
            }
            let (head, tail) = rest.split_at(n);
            rest = tail;
            Ok(head)
        };
        let frame = i32::from_le_bytes(take(4)?.try_into().expect("4 bytes"));
        let step_index = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
        let swarms = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
        if swarms != self.swarms.len() as u64 {
            return Err(format!(
                "{swarms} swarms, the shot has {}",
                self.swarms.len()
            ));
        }
        if frame < self.shot.frame_start || frame > self.shot.frame_end {
            return Err(format!("frame {frame} is outside the shot's frames"));
        }
        for (i, s) in self.swarms.iter_mut().enumerate() {
            let n = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
            let agents = take(usize::try_from(n).map_err(|_| "too large".to_owned())?)?;
            if !s.set_agent_bytes(agents) {
                return Err(format!("swarm {i}'s agents do not match the shot"));
            }
        }
        if !rest.is_empty() {
            return Err("extra bytes after the state".to_owned());
        }
        self.frame = frame;
        self.step_index = step_index;
        self.placed = true;
        self.store_by_id();
        self.update_record();
        Ok(())
    }

    fn update_record(&mut self) {
        let spin_dt = self.spin.then_some(self.shot.dt() as f32);
        let mut rec = std::mem::take(&mut self.record);
        rec.resize_with(self.swarms.len(), SwarmFrame::default);
        let mut id = 0;
        for (swarm, f) in self.swarms.iter_mut().zip(&mut rec) {
            let n = swarm.len();
            swarm.record(f, id as u64, spin_dt, &self.slots[id..id + n]);
            id += n;
        }
        self.record = rec;
        self.record_handed = false;
    }
}

/// Puts the moving obstacles among `shapes` (the shot's, in order) where they stand at a
/// (fractional) frame.
fn place_obstacles(shapes: &mut [Shape], shot: &Shot, frame: f64) {
    for (shape, o) in shapes.iter_mut().zip(&shot.obstacles) {
        if let Shape::Mesh {
            pose: Some(pose), ..
        } = shape
            && let Some(now) = o.pose_at(frame)
        {
            *pose = now;
        }
    }
}

/// The largest distance between `now` and `then`, agent by agent, m: a maximum, the same
/// whatever the order (and the thread count).
fn largest_move(now: &[Vec3], then: &[Vec3]) -> f32 {
    now.par_iter()
        .zip(then.par_iter())
        .with_min_len(4096)
        .map(|(p, b)| p.distance_squared(*b))
        .reduce(|| 0.0, f32::max)
        .sqrt()
}

/// The fewest agents a thread takes at once in the gather pass or the step over `n`
/// agents: `most` in large swarms (from 2,048 agents on two threads), where fewer pieces
/// cost less to hand out, but at least 8 pieces per thread in small ones, so that a piece
/// holding a dense spot does not leave the other threads idle: pieces of 128 cut 300
/// agents into two halves. The recording's poses take pieces of up to 512 alike. (Pieces
/// change no result: each agent is computed alone.)
fn piece(n: usize, most: usize) -> usize {
    (n / (8 * rayon::current_num_threads())).clamp(16, most)
}

/// How many agents ahead the recording and the step ask the caches for.
const PREFETCH_AHEAD: usize = 8;

/// The fewest agents for which the step prefetches ([`Runner::prefetch_moved`]).
const PREFETCH_FROM: usize = 32_768;

/// Asks the CPU to bring `x` into the caches: a hint, which changes no result.
#[inline(always)]
fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // Every 64-byte line `x` touches: from its first byte in steps of 64, and its last
        // (a constant count: the loop unrolls).
        let (p, size) = ((x as *const T).cast::<i8>(), std::mem::size_of::<T>());
        if size == 0 {
            return;
        }
        let mut at = 0;
        while at < size + 63 {
            // SAFETY: a prefetch reads nothing architecturally and never faults.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(at.min(size - 1))) };
            at += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

/// Reorders `v`: entry k becomes the old entry `old_of_new[k]`, through `spare` (a buffer
/// kept between calls: no allocation per substep).
fn permute<T: Copy + Send + Sync>(v: &mut Vec<T>, old_of_new: &[u32], spare: &mut Vec<T>) {
    spare.clear();
    spare.par_extend(
        old_of_new
            .par_iter()
            .with_min_len(4096)
            .map(|&o| v[o as usize]),
    );
    std::mem::swap(v, spare);
}

/// A per-agent array cut into one slice per swarm, in shot order.
fn split<'a, T>(
    mut all: &'a mut [T],
    swarms: &[Box<dyn Swarm>],
) -> impl Iterator<Item = &'a mut [T]> + use<'a, T> {
    let lens: Vec<usize> = swarms.iter().map(|s| s.len()).collect();
    lens.into_iter().map(move |n| {
        let (head, tail) = std::mem::take(&mut all).split_at_mut(n);
        all = tail;
        head
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `beeswarm bench`'s scene: `bees` agents of `model` at 500 per m³ in soft bounds.
    fn sim(model: &str, bees: usize) -> Simulation {
        let side = (bees as f64 / 500.0).cbrt();
        let c = side / 2.0 + 0.5;
        let src = format!(
            "[scene]\nname = \"skin\"\nfps = 24\nframes = [1, 5]\nsubsteps = 4\nseed = 1\n\
             [[swarm]]\ncount = {bees}\nmodel = \"{model}\"\n\
             spawn = {{ shape = \"box\", center = [0, {c}, 0], size = [{side}, {side}, {side}] }}\n\
             bounds = {{ center = [0, {c}, 0], size = [{side}, {side}, {side}] }}\n"
        );
        let here = std::path::Path::new(".");
        let shot = crate::shot::parse(&src, std::path::Path::new("<test>"), here).expect("shot");
        Simulation::new(&shot)
    }

    fn positions(s: &Simulation) -> Vec<[u32; 3]> {
        s.record()
            .iter()
            .flat_map(|f| f.position.iter().map(|p| p.to_array().map(f32::to_bits)))
            .collect()
    }

    /// One substep of frame `s.frame()`, as `advance` runs it.
    fn substep(s: &mut Simulation, k: u32) {
        let dt = s.shot.dt();
        let t = s.time() + k as f64 * dt;
        s.step(t, dt as f32, k);
    }

    #[test]
    fn reused_lists_step_exactly_as_fresh_ones() {
        // Lists picked from candidates are the lists the grid finds, in the same order: a
        // run that reuses them steps bit for bit as one that rebuilds them every substep.
        // The bee (its density sums) with a skin forced wide enough to be reused, and
        // zonal with its own.
        for (model, fraction) in [("bee", 1.0), ("zonal", SKIN_FRACTION)] {
            let mut reused = sim(model, 400);
            let mut rebuilt = sim(model, 400);
            reused.skin_fraction = fraction;
            rebuilt.skin_fraction = fraction;
            for _ in 0..3 {
                for k in 0..4 {
                    substep(&mut reused, k);
                    rebuilt.placed = true;
                    substep(&mut rebuilt, k);
                }
                for s in [&mut reused, &mut rebuilt] {
                    s.frame += 1;
                    s.update_record();
                }
                assert_eq!(positions(&reused), positions(&rebuilt), "{model}");
            }
            assert!(
                reused.rebuilds < rebuilt.rebuilds,
                "{model}: lists were reused ({} rebuilds of {})",
                reused.rebuilds,
                rebuilt.rebuilds
            );
        }
    }

    #[test]
    fn reused_lists_resume_from_a_checkpoint_and_ignore_the_thread_count() {
        // Zonal reuses its lists over each frame; a run restored between frames (a
        // checkpoint) and runs on 1 and 3 threads step bit for bit alike.
        let run = |threads: usize, resume: bool| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut s = sim("zonal", 2000);
                for _ in 0..2 {
                    s.advance();
                }
                if resume {
                    let state = s.state_bytes();
                    s = sim("zonal", 2000);
                    s.restore_state(&state).unwrap();
                }
                for _ in 0..2 {
                    s.advance();
                }
                assert!(s.rebuilds < 4 * 4, "lists were reused");
                positions(&s)
            })
        };
        let one = run(1, false);
        assert_eq!(one, run(3, false), "1 and 3 threads");
        assert_eq!(one, run(1, true), "resumed after frame 2");
    }

    #[test]
    fn where_agents_are_stored_changes_no_result() {
        // Two swarms sharing a grid (so their agents interleave in its cells) and a third
        // that lists no neighbours (butterflies that chase none: kept in id order). One run
        // keeps its agents in cell order; the other is put back in id order before every
        // frame (a restore from a checkpoint stores them by id). Every frame must come out
        // bit for bit alike.
        let src = "[scene]\nname = \"order\"\nfps = 24\nframes = [1, 5]\nsubsteps = 3\n\
                   seed = 4\n\
                   [[swarm]]\ncount = 300\nmodel = \"bee\"\n\
                   spawn = { shape = \"box\", center = [0, 1, 0], size = [0.8, 0.8, 0.8] }\n\
                   [[swarm]]\ncount = 200\nmodel = \"boids\"\n\
                   spawn = { shape = \"box\", center = [0.2, 1, 0], size = [0.8, 0.8, 0.8] }\n\
                   [[swarm]]\ncount = 50\nmodel = \"butterfly\"\nparams = { chase = 0 }\n";
        let here = std::path::Path::new(".");
        let shot = crate::shot::parse(src, std::path::Path::new("<test>"), here).expect("shot");
        let mut kept = Simulation::new(&shot);
        let mut by_id = Simulation::new(&shot);
        for frame in 0..4 {
            let state = by_id.state_bytes();
            by_id = Simulation::new(&shot);
            by_id.restore_state(&state).unwrap();
            kept.advance();
            by_id.advance();
            assert_eq!(positions(&kept), positions(&by_id), "frame {frame}");
        }
        let moved = |r: std::ops::Range<usize>| r.clone().any(|i| kept.ids[i] != i as u32);
        assert!(
            moved(0..300) && moved(300..500),
            "the listing swarms are in cell order"
        );
        assert!(!moved(500..550), "the butterflies stay in id order");
    }

    #[test]
    fn a_frame_too_fast_for_a_skin_does_no_skin_work() {
        // The bee flies about 1 cm per substep, more than a 5 % skin allows: decided at
        // the frame's first substep, no substep keeps candidates or copies positions.
        let mut s = sim("bee", 400);
        for k in 0..4 {
            substep(&mut s, k);
        }
        assert!(!s.keeps && s.skin == 0.0 && !s.sorted);
        assert!(s.previous.is_empty() && s.built.is_empty());
    }

    #[test]
    fn a_record_without_spin_differs_only_in_its_zero_angular_velocities() {
        // Off (a bake writing no USDA), every model's poses skip the angular velocity:
        // the state and every other column stay the same bit for bit.
        let bits = |f: &SwarmFrame| -> Vec<u32> {
            let vecs = f
                .position
                .iter()
                .chain(&f.velocity)
                .flat_map(|v| v.to_array());
            let quats = f.orientation.iter().chain(&f.heading);
            vecs.chain(quats.flat_map(|q| q.to_array()))
                .chain(f.scale.iter().copied())
                .chain(f.channels.iter().flatten().copied())
                .map(f32::to_bits)
                .collect()
        };
        for kind in crate::model::ModelKind::ALL {
            let name = kind.info().name;
            let (mut with, mut without) = (sim(name, 200), sim(name, 200));
            without.record_spin(false);
            for frame in 0..4 {
                // The first frame's record too (made before spin was turned off).
                if frame > 0 {
                    with.advance();
                    without.advance();
                }
                let (a, b) = (&with.record()[0], &without.record()[0]);
                assert_eq!(a.ids, b.ids, "{name}");
                assert_eq!(bits(a), bits(b), "{name}");
                assert!(
                    b.angular_velocity_deg.iter().all(|&w| w == Vec3::ZERO),
                    "{name}"
                );
                assert_eq!(a.angular_velocity_deg.len(), b.len(), "{name}");
            }
            let turning = with.record()[0].angular_velocity_deg.iter();
            assert!(turning.filter(|w| w.length() > 1.0).count() > 10, "{name}");
        }
    }

    #[test]
    fn an_agent_past_half_the_skin_forces_a_rebuild() {
        let mut s = sim("zonal", 300);
        substep(&mut s, 0);
        assert!(s.skin > 0.0, "zonal keeps candidates");
        substep(&mut s, 1);
        let rebuilds = s.rebuilds;
        assert_eq!(rebuilds, 1, "substep 1 reuses the lists");
        // As if agent 7 had moved just over σ/2 since the rebuild.
        let away = s.built[7] - s.positions[7];
        s.built[7] += Vec3::X * s.skin * 0.51 - away;
        substep(&mut s, 2);
        assert_eq!(s.rebuilds, rebuilds + 1, "past σ/2: rebuilt");
        substep(&mut s, 3);
        // And at the start of every frame.
        let before = s.rebuilds;
        substep(&mut s, 0);
        assert_eq!(s.rebuilds, before + 1);
    }
}
