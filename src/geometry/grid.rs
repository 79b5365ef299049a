//! Uniform-grid neighbour search with a bounded number of neighbours per agent. Paper 000
//! (Sec. V-B) accelerates its neighbour sums with a spatial hash; a dense grid over the
//! swarm's bounding box does the same job with fewer instructions (no hashing, no bucket
//! collisions to filter).
//!
//! An agent interacts with at most `k` neighbours: the nearest within the interaction
//! radius (docs/model.md, "Bounded neighbours"). The cell edge follows the swarm's density
//! — about two agents per cell where a typical agent is, never more than the radius. In a
//! sparse cloud a query scans the 9 rows of 3 cells around it; in a very sparse one (a
//! swarm spread thin) the cells may be twice the radius, and a query scans at most 2 × 2
//! rows of 2, listing what it finds in the order the finer walk would (`FineCells`, so the
//! same answers in the same order either way). In a crowd the cells are
//! smaller and 4 times thinner along x, and a query walks rows of cells along x in rings of
//! growing distance in y and z, each row trimmed to the chord the search sphere cuts
//! through it, out to a guess of the k-th neighbour's distance from the local density
//! (further only if fewer than k lie within it). A step then costs about the same per
//! agent in a crowd of 100,000 per m³ as in a sparse cloud.
//!
//! A query first collects every candidate within its reach, four at a time and without a
//! branch per candidate (which neighbours fall within reach is data a branch predictor
//! cannot guess, and its misses cost more than the arithmetic), and then keeps the k
//! nearest, in the order they were collected.
//!
//! Agent indices are counting-sorted by cell, within a cell in the build's visiting order
//! (increasing index, or the world's ids: `Grid::build_visiting`), and the walk is a
//! fixed function of the query point and the grid, so the neighbours found — and the order
//! every floating-point sum visits them in — are the same whatever the number of threads.

use glam::{IVec3, Vec3, Vec4};
use rayon::prelude::*;
use std::mem::MaybeUninit;

/// A crowd query first looks for its k nearest within this multiple of the distance that
/// holds k at the local density, and then within `RETRY_MARGIN` times that.
const GUESS_MARGIN: f32 = 1.12;
const RETRY_MARGIN: f32 = 1.3;

/// Candidates tested together by the portable scan.
const LANES: usize = 4;

/// How many candidates a query's scan tests at a time: the level of the CPU's wide paths
/// (`crate::simd`). Every width collects the same candidates in the same order.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Lanes {
    /// Four (SSE2 on x86-64, or the target's own vectors).
    Four,
    /// Eight with AVX2, their squared distances kept for the ranking.
    Eight,
    /// Sixteen with AVX-512, and candidates ranked sixteen at a time.
    Sixteen,
}

impl Lanes {
    /// The widest the wide paths allow here.
    #[inline]
    fn of_cpu() -> Self {
        match crate::simd::level() {
            crate::simd::Level::Avx512 => Lanes::Sixteen,
            crate::simd::Level::Avx2 => Lanes::Eight,
            crate::simd::Level::Portable => Lanes::Four,
        }
    }

    /// Every width up to the CPU's, for tests.
    #[cfg(test)]
    fn available() -> Vec<Self> {
        let all = [Lanes::Four, Lanes::Eight, Lanes::Sixteen];
        let widest = Lanes::of_cpu();
        all.into_iter()
            .take_while(|&l| l != widest)
            .chain([widest])
            .collect()
    }
}

/// Agents per cell a typical agent sees (bee-weighted mean occupancy) that the cell edge
/// aims at in crowds: small enough that the ring walk tests few far candidates, large
/// enough that few cells are empty.
const TARGET_OCCUPANCY: f32 = 16.0;
/// In a crowd, cells are this many times thinner along x than along y and z. A query visits
/// whole rows of cells along x (contiguous in the sorted arrays), so thin x cells cost
/// nothing per row, and let each row be trimmed to the chord the query's sphere cuts
/// through it: fewer candidates than whole cells, for a few instructions per row. (In a
/// sparse cloud a row holds a few agents, and trimming costs more than it saves.)
const X_SPLIT: i32 = 4;
/// The cell edge never drops below this fraction of the radius, which bounds the rings a
/// query in a sparse part of a mixed scene walks (at most 8).
const MIN_CELL_FRACTION: f32 = 0.125;

#[derive(Clone, Debug, Default)]
pub struct Grid {
    origin: Vec3,
    /// Cell edge along y and z, m; along x the cells are `split` times thinner.
    cell: f32,
    /// Cells per cell edge along x: 1, or [`X_SPLIT`] in a crowd.
    split: i32,
    /// 1 / cell edge along each axis (x: the thin edge).
    inv_cell: Vec3,
    dims: IVec3,
    /// `starts[c]..starts[c + 1]` indexes `items` for cell c.
    starts: Vec<u32>,
    /// Padded past the end by `LANES - 1` entries (u32::MAX), as the position arrays.
    items: Vec<u32>,
    /// Each point's place in `items` (u32::MAX for points left out), and a buffer for
    /// `relabel`.
    slot: Vec<u32>,
    spare: Vec<u32>,
    /// Positions in `items` order, one array per axis, so candidate tests read
    /// contiguous memory.
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    cells: Vec<u32>,
    /// The parallel counting sort's per-piece counts, then cursors: piece p's for cell c
    /// at `p * cells + c`.
    cursors: Vec<u32>,
    /// Coarse cells (twice the fine edge, see [`COARSE_CROWD`]) are allowed, and this
    /// build has them.
    coarse_allowed: bool,
    coarse: bool,
    /// The next build tries coarse cells first (the last one found the swarm sparse).
    try_coarse: bool,
    /// Tests: coarse cells whatever the occupancy.
    force_coarse: bool,
    /// The fine layout a coarse build stands in for: its cells order a query's answer.
    fine: FineCells,
}

/// The layout of cells as large as the radius (the sparse layout) that a coarse build
/// stands in for: a query on coarse cells lists its neighbours in the order a walk over
/// these cells lists them (by cell index, then in visiting order within a cell), so
/// both builds give the same answers in the same order.
#[derive(Clone, Copy, Debug, Default)]
struct FineCells {
    cell: f32,
    inv_cell: Vec3,
    dims: IVec3,
}

/// 1 / cell edge along each axis, for cells `split` times thinner along x.
fn inv_cell(cell: f32, split: i32) -> Vec3 {
    Vec3::new(split as f32 / cell, 1.0 / cell, 1.0 / cell)
}

/// Cells along each axis of a layout over the box `lo..hi` with `inv_cell`.
fn dims_in(lo: Vec3, hi: Vec3, inv_cell: Vec3) -> IVec3 {
    let extent = (hi - lo).max(Vec3::splat(1e-6));
    ((extent * inv_cell).floor().as_ivec3() + IVec3::ONE).max(IVec3::ONE)
}

/// Cell coordinates of `p` in a layout at `origin` with `inv_cell` and `dims`, clamped
/// into it.
#[inline(always)]
fn cell_in(p: Vec3, origin: Vec3, inv_cell: Vec3, dims: IVec3) -> IVec3 {
    // Clamped into [0, dims − 1] in floats, then truncated: at or above 0 truncation is
    // the floor, and the bounds are whole numbers (exact in f32), so this is the floor
    // clamped into the grid, without a branch per axis. NaN-free positions are guaranteed.
    let max = (dims - IVec3::ONE).as_vec3();
    let c = ((p - origin) * inv_cell).max(Vec3::ZERO).min(max);
    // Truncated without `as`, whose saturation (a compare and two selects per axis for
    // values out of range or NaN, which cannot come here) cost about 90 instructions a
    // query in a thin swarm, counting the fine order of its candidates.
    // SAFETY: each axis is finite and in [0, dims − 1] (glam's max and min pick the bound
    // for a NaN or an infinity), and dims − 1 < 2^25 fits an i32.
    unsafe {
        IVec3::new(
            c.x.to_int_unchecked(),
            c.y.to_int_unchecked(),
            c.z.to_int_unchecked(),
        )
    }
}

/// The index of cell `c` in a layout with `dims` (rows along x, then y, then z).
#[inline(always)]
fn index_in(c: IVec3, dims: IVec3) -> usize {
    (c.x + dims.x * (c.y + dims.y * c.z)) as usize
}

/// A build tries cells of twice the radius (a query then walks the 2 × 2 rows of 2 cells
/// its sphere can reach, instead of 3 × 3 rows of 3) where the last build's cells of the
/// radius held at most this agent-weighted occupancy (about 0.3 agents a cell on average:
/// a swarm spread thin, as the default shot's bees after a few seconds)...
const FINE_CROWD_FOR_COARSE: f64 = 1.3;
/// ...and keeps them while their own occupancy stays at most this (about 3 agents a
/// coarse cell: a query then scans about 24 candidates in its 4 rows).
const COARSE_CROWD: f64 = 4.0;

/// The largest `k` a query takes.
pub const MAX_K: usize = 32;

impl Grid {
    /// Cell coordinates of `p`, clamped into the grid (points outside the bounding box of
    /// the last build land in the border cells, which keeps queries valid).
    #[inline]
    fn cell_of(&self, p: Vec3) -> IVec3 {
        cell_in(p, self.origin, self.inv_cell, self.dims)
    }

    #[inline]
    fn index(&self, c: IVec3) -> usize {
        index_in(c, self.dims)
    }

    /// Every point's index, cell by cell (rows of cells along x; within a cell, in the
    /// build's visiting order, by default increasing index): queries run in this order
    /// share the rows they read.
    pub fn order(&self) -> &[u32] {
        &self.items[..self.len()]
    }

    /// Each point's place in [`Grid::order`] (`u32::MAX` for points left out).
    pub fn places(&self) -> &[u32] {
        &self.slot
    }

    /// Number of points in the grid (those not left out).
    fn len(&self) -> usize {
        self.items.len().saturating_sub(LANES - 1)
    }

    /// The cell edge, m.
    pub fn cell(&self) -> f32 {
        if self.coarse {
            self.fine.cell
        } else {
            self.cell
        }
    }

    /// Rebuilds the grid over `positions` for queries within `radius` metres: cells of at
    /// most `radius`, smaller where the agents crowd (see the module notes), and larger
    /// when the swarm is spread so widely that the grid would need more than the cell
    /// budget (32 per agent, at most 2^25).
    pub fn build(&mut self, positions: &[Vec3], radius: f32) {
        self.build_except(positions, radius, &[]);
    }

    /// As [`Grid::build`], leaving out every point `i` with `except[i]` (agents out of
    /// the world, such as bees inside their hive): queries never return them. `except` is
    /// empty (leave out none) or one flag per point.
    pub fn build_except(&mut self, positions: &[Vec3], radius: f32, except: &[bool]) {
        self.build_visiting(positions, radius, except, &[]);
    }

    /// As [`Grid::build_except`], putting the points into their cells in the order of
    /// `visit` (every point's index once; empty: increasing index), which is then their
    /// order within each cell, so also the order queries list them in. The world visits
    /// agents by id, so that neither depends on where it stores them.
    pub fn build_visiting(
        &mut self,
        positions: &[Vec3],
        radius: f32,
        except: &[bool],
        visit: &[u32],
    ) {
        debug_assert!(except.is_empty() || except.len() == positions.len());
        debug_assert!(visit.is_empty() || visit.len() == positions.len());
        let n = positions.len();
        let empty = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        let (lo, hi) = positions
            .par_iter()
            .with_min_len(4096)
            .fold(|| empty, |(a, b), p| (a.min(*p), b.max(*p)))
            .reduce(|| empty, |(a, b), (c, d)| (a.min(c), b.max(d)));
        let (lo, hi) = if n == 0 {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        };
        let radius = radius.max(1e-6);
        let fine = self.capped(lo, hi, radius, n, 1);
        self.coarse = false;
        if self.coarse_allowed && (self.try_coarse || self.force_coarse) {
            // A sparse swarm last time: cells of twice the edge, kept if still sparse.
            self.layout(lo, hi, 2.0 * fine, 1);
            self.sort(positions, except, visit);
            if self.crowd(n) <= COARSE_CROWD || self.force_coarse {
                self.coarse = true;
                let inv_cell = inv_cell(fine, 1);
                self.fine = FineCells {
                    cell: fine,
                    inv_cell,
                    dims: dims_in(lo, hi, inv_cell),
                };
                return;
            }
            self.try_coarse = false;
        }
        self.layout(lo, hi, fine, 1);
        self.sort(positions, except, visit);
        let crowd = self.crowd(n);
        self.try_coarse = crowd <= FINE_CROWD_FOR_COARSE;
        if crowd > (TARGET_OCCUPANCY as f64) * 2.0 {
            // Crowded: the edge that holds about TARGET_OCCUPANCY agents at that density.
            let cell = self.cell * (TARGET_OCCUPANCY / crowd as f32).cbrt();
            let cell = self.capped(lo, hi, cell.max(radius * MIN_CELL_FRACTION), n, X_SPLIT);
            if cell < self.cell * 0.9 {
                self.layout(lo, hi, cell, X_SPLIT);
                self.sort(positions, except, visit);
            }
        }
    }

    /// How crowded a typical agent's cell is: the agent-weighted mean occupancy,
    /// Σ count² over the cells (an exact integer either way it is summed: over the cells,
    /// or over the agents where there are fewer of them: a small swarm spread wide has
    /// many more cells than agents), over `n`.
    fn crowd(&self, n: usize) -> f64 {
        let occupancy = |c: usize| (self.starts[c + 1] - self.starts[c]) as u64;
        let squares: u64 = if self.starts.len() - 1 <= self.len() {
            (0..self.starts.len() - 1)
                .map(|c| occupancy(c).pow(2))
                .sum()
        } else {
            self.items[..self.len()]
                .iter()
                .map(|&i| occupancy(self.cells[i as usize] as usize))
                .sum()
        };
        squares as f64 / n.max(1) as f64
    }

    /// Lets builds use coarse cells where the swarm is sparse (see [`COARSE_CROWD`]):
    /// the same answers from [`Grid::nearest`], in the same order, for fewer
    /// instructions. Off by default, as for callers of [`Grid::within`], whose answers
    /// come in the walk's order.
    pub fn allow_coarse(&mut self, allow: bool) {
        self.coarse_allowed = allow;
    }

    /// `cell`, grown if the box would need more than the cell budget.
    fn capped(&self, lo: Vec3, hi: Vec3, cell: f32, n: usize, split: i32) -> f32 {
        let extent = (hi - lo).max(Vec3::splat(1e-6));
        // Up to 32 cells per agent (a crowd inside a wide sparse cloud needs fine cells
        // over the whole box), capped at 2^25 cells (128 MB of cell starts). A small
        // swarm gets at least 1,024: every build walks every cell, and for a few dozen
        // agents a larger floor made the build cost more than their step.
        let budget = (32 * n).min(1 << 25).max(8 * n).max(1_024) as f32;
        let split = split as f32;
        let cells =
            (extent.x * split / cell + 1.0) * (extent.y / cell + 1.0) * (extent.z / cell + 1.0);
        if cells > budget {
            cell * (cells / budget).cbrt() * 1.01
        } else {
            cell
        }
    }

    fn layout(&mut self, lo: Vec3, hi: Vec3, cell: f32, split: i32) {
        self.origin = lo;
        self.cell = cell;
        self.split = split;
        self.inv_cell = inv_cell(cell, split);
        self.dims = dims_in(lo, hi, self.inv_cell);
    }

    /// Counting sort of the agents by cell, in the order of `visit` (empty: by index),
    /// leaving out those flagged in `except`.
    fn sort(&mut self, positions: &[Vec3], except: &[bool], visit: &[u32]) {
        let n = positions.len() - except.iter().filter(|&&x| x).count();
        let total = (self.dims.x * self.dims.y * self.dims.z) as usize;
        let mut cells = std::mem::take(&mut self.cells);
        cells.clear();
        cells.par_extend(
            positions
                .par_iter()
                .with_min_len(1024)
                .map(|p| self.index(self.cell_of(*p)) as u32),
        );
        self.starts.clear();
        self.starts.resize(total + 1, 0);
        self.items.clear();
        self.items.resize(n + LANES - 1, u32::MAX);
        self.slot.clear();
        self.slot.resize(positions.len(), u32::MAX);
        let pieces = if sorts_in_pieces(cells.len(), total) {
            rayon::current_num_threads().clamp(1, MAX_SORT_PIECES)
        } else {
            1
        };
        if pieces > 1 {
            self.place_in_pieces(&cells, except, visit, pieces);
        } else {
            // Counts, then each cell's end; the agents placed from the last visited back,
            // each cell filled from its end, leaves every start where its cell begins (and
            // each cell in visit order) without a copy of the starts to fill from.
            // (Counted by index: the order does not matter there.)
            for_each_placed(0..cells.len(), &cells, except, &[], |_, c| {
                self.starts[c] += 1
            });
            // The running sum in a register: `starts[i] += starts[i - 1]` waits on each
            // store coming back from memory (most of a sparse grid's sort, whose cells far
            // outnumber its agents).
            let mut sum = 0;
            for s in &mut self.starts[..total] {
                sum += *s;
                *s = sum;
            }
            self.starts[total] = n as u32;
            let (starts, items, slot) = (&mut self.starts, &mut self.items, &mut self.slot);
            for_each_placed((0..cells.len()).rev(), &cells, except, visit, |i, c| {
                let f = &mut starts[c];
                *f -= 1;
                items[*f as usize] = i as u32;
                slot[i] = *f;
            });
        }
        self.cells = cells;
        // Positions in items order: one pass filling the three axes (three passes each
        // read every position again, and cost 90 instructions a point in all).
        for out in [&mut self.xs, &mut self.ys, &mut self.zs] {
            out.clear();
            out.resize(n + LANES - 1, f32::MAX);
        }
        self.xs[..n]
            .par_iter_mut()
            .zip(self.ys[..n].par_iter_mut())
            .zip(self.zs[..n].par_iter_mut())
            .zip(self.items[..n].par_iter())
            .with_min_len(1024)
            .for_each(|(((x, y), z), &i)| {
                let p = positions[i as usize];
                (*x, *y, *z) = (p.x, p.y, p.z);
            });
    }

    /// The counting sort's placing, in `pieces` pieces of the visiting order at once, with
    /// the serial sort's result: cell by cell, piece by piece, each piece's agents in
    /// visiting order. Each piece counts its agents per cell; a scan over the cells, cut
    /// into as many runs, turns the counts into where each piece starts writing in each
    /// cell (and the cells' starts); then every piece writes its own agents.
    fn place_in_pieces(&mut self, cells: &[u32], except: &[bool], visit: &[u32], pieces: usize) {
        let (len, total) = (cells.len(), self.starts.len() - 1);
        let piece = len.div_ceil(pieces);
        // Piece p's places in the visiting order.
        let range = |p: usize| p * piece..((p + 1) * piece).min(len);
        let run = total.div_ceil(pieces);
        // Zeroed by each piece on its own thread (a serial fill of every piece's counts
        // over every cell cost as much as the sort in a sparse grid).
        self.cursors.resize(pieces * total, 0);
        self.cursors[..pieces * total]
            .par_chunks_mut(total)
            .enumerate()
            .for_each(|(p, counts)| {
                counts.fill(0);
                for_each_placed(range(p), cells, except, visit, |_, c| counts[c] += 1);
            });
        // Each run of cells: its agents, then where it begins; then each cell's start and
        // each piece's cursor in it.
        let cursors = Scatter::new(&mut self.cursors);
        let in_run: Vec<u32> = (0..pieces)
            .into_par_iter()
            .map(|r| {
                let mut sum = 0;
                for c in r * run..((r + 1) * run).min(total) {
                    for p in 0..pieces {
                        // SAFETY: in bounds; nothing writes the cursors in this pass.
                        sum += unsafe { cursors.read(p * total + c) };
                    }
                }
                sum
            })
            .collect();
        let mut begin = Vec::with_capacity(pieces);
        let mut at = 0;
        for &k in &in_run {
            begin.push(at);
            at += k;
        }
        let starts = Scatter::new(&mut self.starts);
        (0..pieces).into_par_iter().for_each(|r| {
            let mut at = begin[r];
            for c in r * run..((r + 1) * run).min(total) {
                // SAFETY: cell c belongs to run r alone, so these places are this task's.
                unsafe {
                    starts.write(c, at);
                    for p in 0..pieces {
                        let k = cursors.read(p * total + c);
                        cursors.write(p * total + c, at);
                        at += k;
                    }
                }
            }
        });
        self.starts[total] = at;
        let (items, slot) = (Scatter::new(&mut self.items), Scatter::new(&mut self.slot));
        self.cursors[..pieces * total]
            .par_chunks_mut(total)
            .enumerate()
            .for_each(|(p, cursor)| {
                for_each_placed(range(p), cells, except, visit, |i, c| {
                    let f = &mut cursor[c];
                    // SAFETY: piece p's cursors run over places no other piece's reach (the
                    // scan above), and each agent is visited once.
                    unsafe {
                        items.write(*f as usize, i as u32);
                        slot.write(i, *f);
                    }
                    *f += 1;
                })
            });
    }

    /// Renames the points: point i becomes point `new_of_old[i]` (a permutation of the
    /// indices, `old_of_new` its inverse), in the same cell and the same place in it. For
    /// the world, which moves its agents into the grid's order after a build
    /// (`crate::sim::world`, "Cell order"). Two gathers, in parallel.
    pub fn relabel(&mut self, new_of_old: &[u32], old_of_new: &[u32]) {
        debug_assert_eq!(new_of_old.len(), self.slot.len());
        let n = self.len();
        self.items[..n]
            .par_iter_mut()
            .with_min_len(4096)
            .for_each(|i| *i = new_of_old[*i as usize]);
        let old = std::mem::take(&mut self.slot);
        let mut slot = std::mem::take(&mut self.spare);
        slot.clear();
        slot.par_extend(
            old_of_new
                .par_iter()
                .with_min_len(4096)
                .map(|&o| old[o as usize]),
        );
        self.slot = slot;
        self.spare = old;
    }

    /// Writes into `out` the indices of the (at most) `k` points nearest `p` strictly
    /// within `radius` (radius ≤ the one the grid was built for), leaving out index
    /// `skip`; returns how many. They are listed in the order of the walk, and ties at the
    /// k-th distance go to the first walked: a fixed function of `p` and the grid.
    pub fn nearest(&self, p: Vec3, radius: f32, k: usize, skip: usize, out: &mut [u32]) -> usize {
        self.nearest_with(p, radius, k, skip, out, &mut Found::default())
    }

    /// [`Grid::nearest`] collecting its candidates in `found`, a buffer kept across
    /// queries (a fresh one is zeroed, about 90 instructions a query in a thin swarm).
    pub fn nearest_with(
        &self,
        p: Vec3,
        radius: f32,
        k: usize,
        skip: usize,
        out: &mut [u32],
        found: &mut Found,
    ) -> usize {
        self.nearest_scanning(p, radius, k, skip, out, Lanes::of_cpu(), found)
    }

    /// [`Grid::nearest`], runs scanned `lanes` candidates at a time (at most the CPU's
    /// width, [`Lanes::of_cpu`]).
    #[allow(clippy::too_many_arguments)]
    fn nearest_scanning(
        &self,
        p: Vec3,
        radius: f32,
        k: usize,
        skip: usize,
        out: &mut [u32],
        lanes: Lanes,
        found: &mut Found,
    ) -> usize {
        let k = k.min(MAX_K).min(out.len());
        if k == 0 || self.len() == 0 {
            return 0;
        }
        let scan = Scan {
            xs: &self.xs,
            ys: &self.ys,
            zs: &self.zs,
            p: (Vec4::splat(p.x), Vec4::splat(p.y), Vec4::splat(p.z)),
            skip_slot: self.slot.get(skip).copied().unwrap_or(u32::MAX),
            k,
            lanes,
            fine: self.coarse.then_some((self.origin, self.fine)),
        };
        found.len = 0;
        if self.coarse {
            self.walk_coarse(p, radius, &scan, found);
            if found.len <= k {
                scan.in_fine_order(found);
            }
        } else if self.cell >= radius {
            // Cells as large as the radius: the 27 around p hold every neighbour. One pass
            // over 9 rows of 3 cells, rows beyond the radius skipped.
            self.walk_cube(p, radius * radius, &scan, found);
        } else {
            // A crowd: first a walk out to a guess of the k-th neighbour's distance from
            // the local density, which bounds the rows walked and the candidates collected.
            // Finding k within the guess proves the k nearest among them; otherwise the
            // walk is redone a little further, then to the radius. The guess is a fixed
            // function of the grid and p's cell, so the answer and its order stay a fixed
            // function of p and the grid.
            let c = self.cell_of(p);
            let guess = self.kth_distance_guess(c, k);
            let mut reaches = [guess, guess * RETRY_MARGIN, radius].into_iter();
            loop {
                let reach = reaches.next().unwrap_or(radius).min(radius);
                found.len = 0;
                self.walk(p, c, reach, &scan, found);
                if found.len >= k || reach >= radius {
                    break;
                }
            }
        }
        scan.keep_nearest(found);
        for (o, &s) in out.iter_mut().zip(&found.slots[..found.len]) {
            *o = self.items[s as usize];
        }
        found.len
    }

    /// Writes into `out` every point strictly within `radius` of `p` (any radius, unlike
    /// [`Grid::nearest`]), leaving out index `skip`, with its squared distance; returns
    /// how many, or `None` if they do not fit in `out`. The rows of cells the sphere's box
    /// covers, each trimmed to the sphere's chord, in a fixed order (the squared distances
    /// are computed exactly as `nearest` computes them). For candidate lists reused over
    /// substeps (`crate::sim::skin`).
    pub fn within(
        &self,
        p: Vec3,
        radius: f32,
        skip: usize,
        out: &mut [(u32, f32)],
    ) -> Option<usize> {
        if self.len() == 0 {
            return Some(0);
        }
        let o = self.origin;
        let r2 = radius * radius;
        let (lo, hi) = (
            self.cell_of(p - Vec3::splat(radius)),
            self.cell_of(p + Vec3::splat(radius)),
        );
        let (px, py, pz) = (Vec4::splat(p.x), Vec4::splat(p.y), Vec4::splat(p.z));
        let mut len = 0;
        for z in lo.z..=hi.z {
            let dz2 = self.slab_d2(p.z, o.z, z);
            if dz2 >= r2 {
                continue;
            }
            for y in lo.y..=hi.y {
                let dyz2 = dz2 + self.slab_d2(p.y, o.y, y);
                if dyz2 >= r2 {
                    continue;
                }
                let (s, e) = self.chord(p, y, z, (r2 - dyz2).sqrt());
                let (s, e) = (s as usize, e as usize);
                // Four at a time, as `Scan::run` (the arrays are padded past the end).
                let end = e + LANES - 1;
                let (xs, ys, zs) = (&self.xs[s..end], &self.ys[s..end], &self.zs[s..end]);
                let items = &self.items[s..e];
                let mut g = 0;
                while g < e - s {
                    let dx = Vec4::from_slice(&xs[g..]) - px;
                    let dy = Vec4::from_slice(&ys[g..]) - py;
                    let dz = Vec4::from_slice(&zs[g..]) - pz;
                    let d2 = dx * dx + dy * dy + dz * dz;
                    let mut hits = d2.cmplt(Vec4::splat(r2)).bitmask();
                    if e - s - g < LANES {
                        hits &= (1 << (e - s - g)) - 1;
                    }
                    while hits != 0 {
                        let m = hits.trailing_zeros() as usize;
                        hits &= hits - 1;
                        let j = items[g + m];
                        if j as usize != skip {
                            *out.get_mut(len)? = (j, d2[m]);
                            len += 1;
                        }
                    }
                    g += LANES;
                }
            }
        }
        Some(len)
    }

    /// The distance within which a query in cell `c` should find `k` points, from the
    /// points in the (up to) 27 cells around it taken as a uniform density, with a margin
    /// of `GUESS_MARGIN`: in a uniform crowd fewer than k lie within it in about 8 % of
    /// queries (Poisson with mean 1.12³ k = 22.5 for k = 16), which then walk again out to
    /// 1.3 times as far. A wider margin (1.25) fails once in a thousand queries but offers
    /// every query more candidates: 4 % more instructions (callgrind, 100,000 per m³).
    fn kth_distance_guess(&self, c: IVec3, k: usize) -> f32 {
        let d = self.dims;
        let reach = IVec3::new(self.split, 1, 1);
        let (lo, hi) = (
            (c - reach).max(IVec3::ZERO),
            (c + reach).min(d - IVec3::ONE),
        );
        let mut count = 0u32;
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                let row = (d.x * (y + d.y * z)) as usize;
                count += self.starts[row + hi.x as usize + 1] - self.starts[row + lo.x as usize];
            }
        }
        let cells = (hi - lo + IVec3::ONE).element_product() as f32 / self.split as f32;
        rough_cbrt(self.kth_distance_cubed(k, count, cells))
    }

    /// The cube of `kth_distance_guess`'s distance for `count` points in `cells` whole
    /// cells: margin³ · 3 k / (4 π ρ) with ρ = count / (cells · cell³) (infinite without
    /// points).
    fn kth_distance_cubed(&self, k: usize, count: u32, cells: f32) -> f32 {
        if count == 0 {
            return f32::INFINITY;
        }
        let r3 = 3.0 * k as f32 * cells / (4.0 * std::f32::consts::PI * count as f32);
        let margin3 = GUESS_MARGIN * GUESS_MARGIN * GUESS_MARGIN;
        margin3 * r3 * (self.cell * self.cell * self.cell)
    }

    /// Coarse cells (twice the radius at least): collects the rows of cells the box of
    /// the sphere of `radius` around p reaches (at most 2 × 2 rows of 2 cells, the box
    /// widened by a hair against rounding), rows beyond the radius skipped.
    fn walk_coarse(&self, p: Vec3, radius: f32, scan: &Scan, found: &mut Found) {
        debug_assert!(radius <= self.fine.cell, "a query within the grid's radius");
        // SAFETY: AVX2 wherever the scan is eight lanes wide or more (`Lanes::of_cpu`).
        #[cfg(target_arch = "x86_64")]
        if scan.lanes != Lanes::Four
            && unsafe { self.walk_coarse8(p.x, p.y, p.z, radius, scan, found) }
        {
            return;
        }
        let r2 = radius * radius;
        let (lo, hi) = self.coarse_box(p, radius);
        let (d, o) = (self.dims, self.origin);
        // The y slabs' distances once, not once per z (at most 3 slabs: the box is at
        // most a hair wider than one coarse cell).
        let mut dy2 = [0.0; 3];
        for (y, slab) in (lo.y..=hi.y).zip(&mut dy2) {
            *slab = self.slab_d2(p.y, o.y, y);
        }
        let mut rows = [(0u32, 0u32, 0.0f32); 9];
        let mut m = 0;
        for z in lo.z..=hi.z {
            let dz2 = self.slab_d2(p.z, o.z, z);
            for (y, &dy2) in (lo.y..=hi.y).zip(&dy2) {
                let row = (d.x * (y + d.y * z)) as usize;
                let (s, e) = (
                    self.starts[row + lo.x as usize],
                    self.starts[row + hi.x as usize + 1],
                );
                if m == rows.len() {
                    // (Only past the contract: a radius beyond the fine cell's.)
                    scan.collect_rows(&rows, r2, found);
                    m = 0;
                }
                rows[m] = (s, e, dz2 + dy2);
                m += 1;
            }
        }
        scan.collect_rows(&rows[..m], r2, found);
    }

    /// The coarse cells `lo..=hi` the box of the sphere of `radius` around p reaches,
    /// widened by a hair against rounding.
    #[inline(always)]
    fn coarse_box(&self, p: Vec3, radius: f32) -> (IVec3, IVec3) {
        let reach = Vec3::splat(radius * (1.0 + 1e-5) + 1e-7);
        (self.cell_of(p - reach), self.cell_of(p + reach))
    }

    /// [`Grid::walk_coarse`] with AVX2, for a box of at most 3 × 3 rows (the contract):
    /// its first eight rows in lanes, as [`Grid::walk_cube8`] lists the cube's, those past
    /// the box dropped, the ninth as there. The same rows in the same order. Returns false,
    /// having collected nothing, for a box beyond the contract. (The point comes as
    /// scalars, as in `walk_cube8`, and why.)
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn walk_coarse8(
        &self,
        px: f32,
        py: f32,
        pz: f32,
        radius: f32,
        scan: &Scan,
        found: &mut Found,
    ) -> bool {
        use std::arch::x86_64::*;
        let p = Vec3::new(px, py, pz);
        let (lo, hi) = self.coarse_box(p, radius);
        if (hi - lo).max_element() > 2 {
            return false;
        }
        let r2 = radius * radius;
        let d = self.dims;
        // The rows around lo + 1 in y and z: lo.y..=lo.y + 2 and lo.z..=lo.z + 2.
        let c = lo + IVec3::new(0, 1, 1);
        let (dz2, dy2) = self.slabs_around(p, c);
        let (inside, slab, row) = self.rows8(c, (dz2, dy2), &CUBE_ROWS);
        let int = _mm256_set1_epi32;
        let (s, e) = self.runs8(row, int(lo.x), int(hi.x));
        let (mut starts, mut ends) = ([0u32; 9], [0u32; 9]);
        // SAFETY: each array holds at least eight lanes.
        unsafe {
            _mm256_storeu_si256(starts.as_mut_ptr().cast(), s);
            _mm256_storeu_si256(ends.as_mut_ptr().cast(), e);
        }
        // Rows within the box: y ≤ hi.y and z ≤ hi.z, lane by lane, and the ninth.
        let (ny, nz) = ((hi.y - lo.y) as usize, (hi.z - lo.z) as usize);
        let mut rows = _mm256_movemask_ps(_mm256_castsi256_ps(inside)) as u32 & IN_BOX[nz][ny];
        if ny == 2 && nz == 2 {
            let row = (d.x * (lo.y + 2 + d.y * (lo.z + 2))) as usize;
            (starts[8], ends[8]) = (
                self.starts[row + lo.x as usize],
                self.starts[row + hi.x as usize + 1],
            );
            rows |= 1 << 8;
        }
        let near = _mm256_cmp_ps::<_CMP_LT_OQ>(slab, _mm256_set1_ps(r2));
        let keep = rows & (_mm256_movemask_ps(near) as u32 | ((dz2[2] + dy2[2] < r2) as u32) << 8);
        let mut runs = Runs::new();
        for l in 0..9 {
            runs.put((starts[l], ends[l]), (keep >> l) & 1 != 0);
        }
        runs.flush(scan, r2, found);
        true
    }

    /// Cells as large as the radius: collects the 9 rows of 3 cells around p, rows beyond
    /// the radius (squared: `r2`) skipped. Where the 27 cells hold more points than k
    /// within the radius at their density (the core of a nest, in a swarm sparse
    /// elsewhere), it first collects only out to a guess of the k-th neighbour's distance,
    /// as a crowd's walk does: finding k there proves the k nearest are among them, and
    /// the query keeps fewer candidates; otherwise it collects out to the radius.
    fn walk_cube(&self, p: Vec3, r2: f32, scan: &Scan, found: &mut Found) {
        #[cfg(target_arch = "x86_64")]
        if scan.lanes != Lanes::Four {
            // SAFETY: AVX2 wherever the scan is eight lanes wide or more (`Lanes::of_cpu`).
            return unsafe { self.walk_cube8(p.x, p.y, p.z, r2, scan, found) };
        }
        let c = self.cell_of(p);
        let (d, o) = (self.dims, self.origin);
        let (x0, x1) = (
            (c.x - self.split).max(0) as usize,
            (c.x + self.split).min(d.x - 1) as usize,
        );
        let (ys, zs) = (
            (c.y - 1).max(0)..=(c.y + 1).min(d.y - 1),
            (c.z - 1).max(0)..=(c.z + 1).min(d.z - 1),
        );
        // The three y slabs' distances once, not once per z.
        let mut dy2 = [0.0; 3];
        for (y, slab) in ys.clone().zip(&mut dy2) {
            *slab = self.slab_d2(p.y, o.y, y);
        }
        // Every row with its slab's squared distance; which of them lie within reach is
        // picked below without a branch (it depends on where p lies in its cell).
        let mut rows = [(0u32, 0u32, 0.0f32); 9];
        let (mut m, mut count) = (0, 0);
        for z in zs.clone() {
            let dz2 = self.slab_d2(p.z, o.z, z);
            for (y, &dy2) in ys.clone().zip(&dy2) {
                let row = (d.x * (y + d.y * z)) as usize;
                let (s, e) = (self.starts[row + x0], self.starts[row + x1 + 1]);
                rows[m] = (s, e, dz2 + dy2);
                m += 1;
                count += e - s;
            }
        }
        let cells = ((x1 - x0 + 1) * ys.count() * zs.count()) as f32 / self.split as f32;
        // Compared cubed first: the cube root is a library call, and a sparse query (the
        // common case) does not need it.
        let cubed = self.kth_distance_cubed(scan.k, count, cells);
        if cubed < r2 * r2.sqrt() {
            // (Never past the radius, whatever the cube root's rounding.)
            let guess = rough_cbrt(cubed);
            scan.collect_rows(&rows[..m], (guess * guess).min(r2), found);
            if found.len >= scan.k {
                return;
            }
            found.len = 0;
        }
        scan.collect_rows(&rows[..m], r2, found);
    }

    /// Eight rows of cells along x around cell `c`, at y offsets `offsets[0]` and z offsets
    /// `offsets[1]`, one per lane, with AVX2: whether each lies in the grid (all ones),
    /// its slab's squared distance `dz2[dz + 1] + dy2[dy + 1]` (`slabs_around`), and its
    /// index (a row outside the grid clamped into it: read, then dropped).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn rows8(
        &self,
        c: IVec3,
        (dz2, dy2): ([f32; 3], [f32; 3]),
        offsets: &[[i32; 8]; 2],
    ) -> (
        std::arch::x86_64::__m256i,
        std::arch::x86_64::__m256,
        std::arch::x86_64::__m256i,
    ) {
        use std::arch::x86_64::*;
        let (d, int) = (self.dims, _mm256_set1_epi32);
        // SAFETY (the loads): each array holds eight lanes.
        let (dy, dz) = unsafe {
            (
                _mm256_loadu_si256(offsets[0].as_ptr().cast()),
                _mm256_loadu_si256(offsets[1].as_ptr().cast()),
            )
        };
        let (y, z) = (
            _mm256_add_epi32(int(c.y), dy),
            _mm256_add_epi32(int(c.z), dz),
        );
        let within = |v, n| {
            _mm256_and_si256(
                _mm256_cmpgt_epi32(v, int(-1)),
                _mm256_cmpgt_epi32(int(n), v),
            )
        };
        let inside = _mm256_and_si256(within(y, d.y), within(z, d.z));
        let table = |t: [f32; 3]| _mm256_setr_ps(t[0], t[1], t[2], 0.0, 0.0, 0.0, 0.0, 0.0);
        let dyz2 = _mm256_add_ps(
            _mm256_permutevar8x32_ps(table(dz2), _mm256_add_epi32(dz, int(1))),
            _mm256_permutevar8x32_ps(table(dy2), _mm256_add_epi32(dy, int(1))),
        );
        let clamp = |v, hi| _mm256_min_epi32(_mm256_max_epi32(v, int(0)), int(hi));
        let row = _mm256_mullo_epi32(
            int(d.x),
            _mm256_add_epi32(
                clamp(y, d.y - 1),
                _mm256_mullo_epi32(int(d.y), clamp(z, d.z - 1)),
            ),
        );
        (inside, dyz2, row)
    }

    /// The starts and ends in the sorted arrays of the runs of cells `a..=b` (each in
    /// `0..d.x`) along the rows `row` ([`Grid::rows8`]), gathered with AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn runs8(
        &self,
        row: std::arch::x86_64::__m256i,
        a: std::arch::x86_64::__m256i,
        b: std::arch::x86_64::__m256i,
    ) -> (std::arch::x86_64::__m256i, std::arch::x86_64::__m256i) {
        use std::arch::x86_64::*;
        let d = self.dims;
        assert_eq!(self.starts.len(), (d.x * d.y * d.z) as usize + 1);
        // SAFETY: rows lie in the grid (`rows8` clamps them) and a ≤ b ≤ d.x − 1 (the
        // callers' clamps), so every index is at most d.x·d.y·d.z, within `starts`
        // (asserted above).
        unsafe {
            let at = |i| _mm256_i32gather_epi32::<4>(self.starts.as_ptr().cast(), i);
            (
                at(_mm256_add_epi32(row, a)),
                at(_mm256_add_epi32(
                    _mm256_add_epi32(row, b),
                    _mm256_set1_epi32(1),
                )),
            )
        }
    }

    /// [`Grid::walk_cube`] with AVX2: its first eight rows in eight lanes (the row index,
    /// whether it lies in the grid, its slab distance, its start and end gathered), the
    /// ninth as there. The same rows in the same order, the same count for the guess, so
    /// the same runs.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn walk_cube8(&self, px: f32, py: f32, pz: f32, r2: f32, scan: &Scan, found: &mut Found) {
        use std::arch::x86_64::*;
        // The point comes as three scalars, in registers, and its cell is worked out here:
        // a `Vec3` or `IVec3` argument goes by reference to the caller's stack, and the
        // 8-byte load of its y and z there spans two of the caller's stores, which the CPU
        // cannot forward (about a sixth of this function's time under `perf`).
        let p = Vec3::new(px, py, pz);
        let c = self.cell_of(p);
        let d = self.dims;
        let (x0, x1) = (
            (c.x - self.split).max(0) as usize,
            (c.x + self.split).min(d.x - 1) as usize,
        );
        let (dz2, dy2) = self.slabs_around(p, c);
        let int = _mm256_set1_epi32;
        let (inside, slab, row) = self.rows8(c, (dz2, dy2), &CUBE_ROWS);
        let (s, e) = self.runs8(row, int(x0 as i32), int(x1 as i32));
        let (mut starts, mut ends) = ([0u32; 9], [0u32; 9]);
        // SAFETY: each array holds at least eight lanes.
        unsafe {
            _mm256_storeu_si256(starts.as_mut_ptr().cast(), s);
            _mm256_storeu_si256(ends.as_mut_ptr().cast(), e);
        }
        let mut rows = _mm256_movemask_ps(_mm256_castsi256_ps(inside)) as u32;
        // The ninth row, (dy, dz) = (1, 1).
        if c.y + 1 < d.y && c.z + 1 < d.z {
            let row = (d.x * (c.y + 1 + d.y * (c.z + 1))) as usize;
            (starts[8], ends[8]) = (self.starts[row + x0], self.starts[row + x1 + 1]);
            rows |= 1 << 8;
        }
        let slab8 = dz2[2] + dy2[2];
        // Σ (end − start) over the rows in the grid: the first eight in lanes.
        let lengths = _mm256_and_si256(_mm256_sub_epi32(e, s), inside);
        let sum = _mm_add_epi32(
            _mm256_castsi256_si128(lengths),
            _mm256_extracti128_si256::<1>(lengths),
        );
        let sum = _mm_add_epi32(sum, _mm_unpackhi_epi64(sum, sum));
        let sum = _mm_add_epi32(sum, _mm_shuffle_epi32::<0b01>(sum));
        let count = _mm_cvtsi128_si32(sum) as u32 + (ends[8] - starts[8]) * (rows >> 8);
        let cells = ((x1 - x0 + 1) as u32 * rows.count_ones()) as f32 / self.split as f32;
        // Out to the guess, if it falls short of the radius, then (if that found fewer than
        // k) out to the radius. (One place collects, for both: a closure called twice was
        // not inlined.)
        let cubed = self.kth_distance_cubed(scan.k, count, cells);
        let mut reach = r2;
        if cubed < r2 * r2.sqrt() {
            let guess = rough_cbrt(cubed);
            reach = (guess * guess).min(r2);
        }
        loop {
            // The rows in the grid whose slab lies within reach, in order.
            let near = _mm256_cmp_ps::<_CMP_LT_OQ>(slab, _mm256_set1_ps(reach));
            let keep = rows & (_mm256_movemask_ps(near) as u32 | ((slab8 < reach) as u32) << 8);
            let mut runs = Runs::new();
            for l in 0..9 {
                runs.put((starts[l], ends[l]), (keep >> l) & 1 != 0);
            }
            runs.flush(scan, reach, found);
            if reach == r2 || found.len >= scan.k {
                return;
            }
            found.len = 0;
            reach = r2;
        }
    }

    /// Collects rows of cells along x, in rings of growing Chebyshev distance from p's row
    /// in y and z, each trimmed to the chord of the sphere of `radius` through it, out to
    /// `radius`. (Not inlined: in a crowd only, and inlined it changed how the compiler
    /// laid out the sparse query beside it, 4 % slower.)
    #[inline(never)]
    fn walk(&self, p: Vec3, c: IVec3, radius: f32, scan: &Scan, found: &mut Found) {
        let r2 = radius * radius;
        let margin = self.row_margin(p, c);
        // Where ring 2 lies beyond reach (a crowd's guess is about two thirds of a cell),
        // rings 0 and 1 are listed without a branch per row (`near_rows`), the rows the
        // ring walk below would list, in its order.
        if beyond(self.cell + margin, radius, r2) {
            let ring1 = !beyond(margin, radius, r2);
            let mut runs = Runs::new();
            #[cfg(target_arch = "x86_64")]
            match scan.lanes {
                // SAFETY (both): a width only where the CPU has it (`Lanes::of_cpu`).
                Lanes::Sixteen => unsafe { self.near_rows_wide(p, c, r2, ring1, &mut runs) },
                Lanes::Eight => unsafe { self.near_rows8(p, c, r2, ring1, &mut runs) },
                Lanes::Four => self.near_rows(p, c, r2, ring1, &mut runs),
            }
            #[cfg(not(target_arch = "x86_64"))]
            self.near_rows(p, c, r2, ring1, &mut runs);
            runs.flush(scan, r2, found);
        } else {
            self.walk_rings(p, c, radius, margin, scan, found);
        }
    }

    /// The distance from p (in cell `c`) to the nearest y or z face of its row: ring q + 1
    /// and beyond lie at least q cells plus this far away.
    #[inline(always)]
    fn row_margin(&self, p: Vec3, c: IVec3) -> f32 {
        let o = self.origin;
        let (ly, lz) = (o.y + c.y as f32 * self.cell, o.z + c.z as f32 * self.cell);
        (p.y - ly)
            .min(ly + self.cell - p.y)
            .min(p.z - lz)
            .min(lz + self.cell - p.z)
            .max(0.0)
    }

    /// [`Grid::walk`] ring by ring, `margin` being [`Grid::row_margin`].
    fn walk_rings(
        &self,
        p: Vec3,
        c: IVec3,
        radius: f32,
        margin: f32,
        scan: &Scan,
        found: &mut Found,
    ) {
        let (d, o) = (self.dims, self.origin);
        let r2 = radius * radius;
        // Each ring's rows are first listed, then collected: the chord's arithmetic and the
        // two reads of where its cells begin are then independent from row to row, instead
        // of waiting each time for the last row's scan (whose end the branch predictor
        // cannot foresee).
        let mut runs = Runs::new();
        for q in 0.. {
            if q > 0 && beyond((q - 1) as f32 * self.cell + margin, radius, r2) {
                break;
            }
            // The rows at Chebyshev distance exactly q (clipped to the grid) in a fixed
            // order; rows whose slab lies beyond the radius are skipped.
            for z in (c.z - q).max(0)..=(c.z + q).min(d.z - 1) {
                let dz2 = self.slab_d2(p.z, o.z, z);
                if dz2 >= r2 {
                    continue;
                }
                let mut row = |y: i32| self.row(p, y, z, dz2, r2, scan, found, &mut runs);
                if (z - c.z).abs() == q {
                    for y in (c.y - q).max(0)..=(c.y + q).min(d.y - 1) {
                        row(y);
                    }
                } else {
                    // Off the z faces only the ring's two y ends belong to it.
                    if c.y - q >= 0 {
                        row(c.y - q);
                    }
                    if c.y + q < d.y {
                        row(c.y + q);
                    }
                }
            }
            runs.flush(scan, r2, found);
        }
    }

    /// The rows of rings 0 and 1 (ring 1 only if `ring1`) in [`Grid::walk`]'s order, each
    /// trimmed to the chord of the sphere of squared radius `r2` through it, as
    /// [`Grid::row`] lists them: every one of the nine is worked out, and the count
    /// advanced by whether it lies in the grid and within reach. Which rows those are
    /// depends on where p lies in its cell, which the branch predictor cannot foresee:
    /// a branch per row missed about as often as it was taken.
    #[inline(always)]
    fn near_rows(&self, p: Vec3, c: IVec3, r2: f32, ring1: bool, runs: &mut Runs) {
        let slabs = self.slabs_around(p, c);
        for row in NEAR_ROWS {
            self.near_row(p, c, slabs, r2, ring1, row, runs);
        }
    }

    /// The squared distances from p to the slabs of c.z − 1, c.z, c.z + 1 and of c.y − 1,
    /// c.y, c.y + 1, as `walk` and `row` work them out (those of slabs outside the grid are
    /// not used): what every width of `near_rows` starts from.
    #[inline(always)]
    fn slabs_around(&self, p: Vec3, c: IVec3) -> ([f32; 3], [f32; 3]) {
        let o = self.origin;
        (
            [-1, 0, 1].map(|k| self.slab_d2(p.z, o.z, c.z + k)),
            [-1, 0, 1].map(|k| self.slab_d2(p.y, o.y, c.y + k)),
        )
    }

    /// One of `near_rows`' rows, `(y offset, z offset, in ring 1)`, given the squared
    /// distances to the slabs around `c` along z and y.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn near_row(
        &self,
        p: Vec3,
        c: IVec3,
        (dz2, dy2): ([f32; 3], [f32; 3]),
        r2: f32,
        ring1: bool,
        (dy, dz, outer): (i32, i32, bool),
        runs: &mut Runs,
    ) {
        let d = self.dims;
        let (y, z) = (c.y + dy, c.z + dz);
        let inside = y >= 0 && y < d.y && z >= 0 && z < d.z;
        let dyz2 = dz2[(dz + 1) as usize] + dy2[(dy + 1) as usize];
        let keep = inside & (ring1 | !outer) & (dyz2 < r2);
        let w = (r2 - dyz2).max(0.0).sqrt();
        let (y, z) = (y.clamp(0, d.y - 1), z.clamp(0, d.z - 1));
        runs.put(self.chord(p, y, z, w), keep);
    }

    /// [`Grid::near_rows`] with AVX2: ring 0's row as there, then ring 1's eight rows in
    /// eight lanes, each lane `near_row`'s arithmetic and the rows' starts gathered, so the
    /// same runs in the same order.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn near_rows8(&self, p: Vec3, c: IVec3, r2: f32, ring1: bool, runs: &mut Runs) {
        use std::arch::x86_64::*;
        let (d, o) = (self.dims, self.origin);
        let (dz2, dy2) = self.slabs_around(p, c);
        self.near_row(p, c, (dz2, dy2), r2, ring1, NEAR_ROWS[0], runs);
        if !ring1 {
            // Ring 1's rows would be listed only to be dropped.
            return;
        }
        // `NEAR_ROWS[1..]`, lane by lane: y and z offsets.
        const OFFSETS: [[i32; 8]; 2] = [[-1, 0, 1, -1, 1, -1, 0, 1], [-1, -1, -1, 0, 0, 1, 1, 1]];
        const {
            let mut l = 0;
            while l < 8 {
                assert!(NEAR_ROWS[l + 1].0 == OFFSETS[0][l] && NEAR_ROWS[l + 1].1 == OFFSETS[1][l]);
                l += 1;
            }
        }
        let (inside, dyz2, row) = self.rows8(c, (dz2, dy2), &OFFSETS);
        let r2v = _mm256_set1_ps(r2);
        let near = _mm256_cmp_ps::<_CMP_LT_OQ>(dyz2, r2v);
        let keep = _mm256_movemask_ps(_mm256_and_ps(_mm256_castsi256_ps(inside), near));
        let zero = _mm256_setzero_ps();
        let w = _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(r2v, dyz2), zero));
        // `chord`.
        let (px, ox) = (_mm256_set1_ps(p.x), _mm256_set1_ps(o.x));
        let (inv, last) = (
            _mm256_set1_ps(self.inv_cell.x),
            _mm256_set1_ps((d.x - 1) as f32),
        );
        let cell_x = |x| {
            let v = _mm256_mul_ps(_mm256_sub_ps(x, ox), inv);
            _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(v, zero), last))
        };
        let (a, b) = (cell_x(_mm256_sub_ps(px, w)), cell_x(_mm256_add_ps(px, w)));
        let (s, e) = self.runs8(row, a, b);
        let (mut starts, mut ends) = ([0u32; 8], [0u32; 8]);
        // SAFETY: each array holds eight u32s.
        unsafe {
            _mm256_storeu_si256(starts.as_mut_ptr().cast(), s);
            _mm256_storeu_si256(ends.as_mut_ptr().cast(), e);
        }
        for l in 0..8 {
            runs.put((starts[l], ends[l]), (keep >> l) & 1 != 0);
        }
    }

    /// [`Grid::near_rows`] with AVX-512: the nine rows in nine lanes, each lane the same
    /// arithmetic (slab distances, chord, clamps, truncation) and the rows' starts
    /// gathered, so the same runs in the same order.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn near_rows_wide(&self, p: Vec3, c: IVec3, r2: f32, ring1: bool, runs: &mut Runs) {
        use std::arch::x86_64::*;
        let (d, o) = (self.dims, self.origin);
        let (dz2, dy2) = self.slabs_around(p, c);
        // `NEAR_ROWS`, lane by lane (lanes 9 to 15 unused): y and z offsets.
        const DY: [i32; 16] = [0, -1, 0, 1, -1, 1, -1, 0, 1, 0, 0, 0, 0, 0, 0, 0];
        const DZ: [i32; 16] = [0, -1, -1, -1, 0, 0, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0];
        const NINE: __mmask16 = 0x1FF;
        const RING1: __mmask16 = 0x1FE;
        let int = _mm512_set1_epi32;
        // SAFETY (the loads): each array holds sixteen lanes.
        let (dy, dz) = unsafe {
            (
                _mm512_loadu_si512(DY.as_ptr().cast()),
                _mm512_loadu_si512(DZ.as_ptr().cast()),
            )
        };
        let (y, z) = (
            _mm512_add_epi32(int(c.y), dy),
            _mm512_add_epi32(int(c.z), dz),
        );
        let inside = _mm512_mask_cmpge_epi32_mask(NINE, y, int(0))
            & _mm512_cmplt_epi32_mask(y, int(d.y))
            & _mm512_cmpge_epi32_mask(z, int(0))
            & _mm512_cmplt_epi32_mask(z, int(d.z));
        // dz2[dz + 1] + dy2[dy + 1], lane by lane.
        let table = |t: [f32; 3]| {
            _mm512_setr_ps(
                t[0], t[1], t[2], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
            )
        };
        let dyz2 = _mm512_add_ps(
            _mm512_permutexvar_ps(_mm512_add_epi32(dz, int(1)), table(dz2)),
            _mm512_permutexvar_ps(_mm512_add_epi32(dy, int(1)), table(dy2)),
        );
        let r2v = _mm512_set1_ps(r2);
        let ring = if ring1 { NINE } else { NINE & !RING1 };
        let keep = inside & ring & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(dyz2, r2v);
        let zero = _mm512_setzero_ps();
        let w = _mm512_sqrt_ps(_mm512_max_ps(_mm512_sub_ps(r2v, dyz2), zero));
        let clamp = |v, hi| _mm512_min_epi32(_mm512_max_epi32(v, int(0)), int(hi));
        let (y, z) = (clamp(y, d.y - 1), clamp(z, d.z - 1));
        // `chord`.
        let (px, ox) = (_mm512_set1_ps(p.x), _mm512_set1_ps(o.x));
        let (inv, last) = (
            _mm512_set1_ps(self.inv_cell.x),
            _mm512_set1_ps((d.x - 1) as f32),
        );
        let cell_x = |x| {
            let v = _mm512_mul_ps(_mm512_sub_ps(x, ox), inv);
            _mm512_cvttps_epi32(_mm512_min_ps(_mm512_max_ps(v, zero), last))
        };
        let (a, b) = (cell_x(_mm512_sub_ps(px, w)), cell_x(_mm512_add_ps(px, w)));
        let row = _mm512_mullo_epi32(
            int(d.x),
            _mm512_add_epi32(y, _mm512_mullo_epi32(int(d.y), z)),
        );
        assert_eq!(self.starts.len(), (d.x * d.y * d.z) as usize + 1);
        // SAFETY: y and z are clamped into the grid and a ≤ b ≤ d.x − 1, so every index
        // is at most d.x·d.y·d.z, within `starts` (asserted above).
        let (s, e) = unsafe {
            let at = |i| {
                _mm512_mask_i32gather_epi32::<4>(
                    _mm512_setzero_si512(),
                    NINE,
                    i,
                    self.starts.as_ptr().cast(),
                )
            };
            (
                at(_mm512_add_epi32(row, a)),
                at(_mm512_add_epi32(_mm512_add_epi32(row, b), int(1))),
            )
        };
        let (mut starts, mut ends) = ([0u32; 16], [0u32; 16]);
        // SAFETY: each array holds sixteen u32s.
        unsafe {
            _mm512_storeu_si512(starts.as_mut_ptr().cast(), s);
            _mm512_storeu_si512(ends.as_mut_ptr().cast(), e);
        }
        for l in 0..9 {
            runs.put((starts[l], ends[l]), (keep >> l) & 1 != 0);
        }
    }

    /// Lists in `runs` row (y, z) over the chord of the sphere of squared radius `r2`
    /// through it (`dz2`: the squared distance from p to the row's z slab), collecting
    /// the runs listed so far when `runs` is full.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn row(
        &self,
        p: Vec3,
        y: i32,
        z: i32,
        dz2: f32,
        r2: f32,
        scan: &Scan,
        found: &mut Found,
        runs: &mut Runs,
    ) {
        let dyz2 = dz2 + self.slab_d2(p.y, self.origin.y, y);
        if dyz2 < r2 {
            runs.push(self.chord(p, y, z, (r2 - dyz2).sqrt()));
            if runs.len == RUNS {
                runs.flush(scan, r2, found);
            }
        }
    }

    /// The run of the sorted arrays (start, end) that row (y, z), a row of the grid, holds
    /// over the chord from p.x − `w` to p.x + `w`, in whole x cells clamped to the grid
    /// (clamped in floats, where truncation is the floor). `max` and `min` rather than
    /// `clamp`, whose check that its bounds are ordered costs more than the rest here.
    #[inline(always)]
    fn chord(&self, p: Vec3, y: i32, z: i32, w: f32) -> (u32, u32) {
        let (d, o) = (self.dims, self.origin);
        let last = (d.x - 1) as f32;
        let a = ((p.x - w - o.x) * self.inv_cell.x).max(0.0).min(last) as usize;
        let b = ((p.x + w - o.x) * self.inv_cell.x).max(0.0).min(last) as usize;
        let row = (d.x * (y + d.y * z)) as usize;
        (self.starts[row + a], self.starts[row + b + 1])
    }

    /// Squared distance from coordinate `v` to cell `i`'s slab along one axis.
    #[inline(always)]
    fn slab_d2(&self, v: f32, origin: f32, i: i32) -> f32 {
        // Along y and z (the cell edge is the whole one).
        let lo = origin + i as f32 * self.cell;
        // Plain compares rather than `f32::max`, whose NaN rules cost three instructions
        // more each (nothing here is NaN).
        let max = |a: f32, b: f32| if a > b { a } else { b };
        let d = max(max(lo - v, v - (lo + self.cell)), 0.0);
        d * d
    }
}

/// Whether everything at least `gap` from p lies beyond a walk's reach (`radius`, squared
/// `r2`): the test that ends the ring walk, and that picks rings 0 and 1 for `near_rows`,
/// which must agree with it comparison for comparison.
#[inline(always)]
fn beyond(gap: f32, radius: f32, r2: f32) -> bool {
    gap >= radius || gap * gap >= r2
}

/// The cube root of `x` (positive, or infinite) to about 0.2 %: the exponent divided by
/// three in the bits, then one Newton step. For the k-th distance guesses, which only
/// bound a walk (any bound gives the same answer; the guess's margin is 12 %), where
/// libm's `cbrtf` was 3 % of a crowd's time.
#[inline(always)]
fn rough_cbrt(x: f32) -> f32 {
    let y = f32::from_bits(x.to_bits() / 3 + 0x2A51_67AF);
    (2.0 * y + x / (y * y)) * (1.0 / 3.0)
}

/// Calls `f(i, cell)` for the agents visited at `places` of `visit` (empty: agent j is the
/// j-th visited) that go into the grid (not flagged in `except`), in the order given.
#[inline(always)]
fn for_each_placed(
    places: impl Iterator<Item = usize>,
    cells: &[u32],
    except: &[bool],
    visit: &[u32],
    mut f: impl FnMut(usize, usize),
) {
    for j in places {
        let i = if visit.is_empty() {
            j
        } else {
            visit[j] as usize
        };
        if except.is_empty() || !except[i] {
            f(i, cells[i] as usize);
        }
    }
}

/// Rows a ring walk lists before collecting them.
const RUNS: usize = 32;

/// `Grid::near_rows`' rows, (y offset, z offset, in ring 1): ring 0's row, then ring 1's
/// in the ring walk's order.
const NEAR_ROWS: [(i32, i32, bool); 9] = [
    (0, 0, false),
    (-1, -1, true),
    (0, -1, true),
    (1, -1, true),
    (-1, 0, true),
    (1, 0, true),
    (-1, 1, true),
    (0, 1, true),
    (1, 1, true),
];

/// Runs `(start, end)` of the sorted arrays listed for collecting, in walk order. The
/// list starts uninitialised: zeroing its 256 bytes at every walk was a `memset` call, 1 %
/// of a crowd's time, and only the first `len` entries, all written, are ever read.
struct Runs {
    runs: MaybeUninit<[(u32, u32); RUNS]>,
    len: usize,
}

impl Runs {
    #[inline(always)]
    fn new() -> Self {
        // Not `Runs { runs: MaybeUninit::uninit(), len: 0 }`: the compiler makes that a
        // constant, and a constant of zeros and uninitialised bytes is written with a
        // `memset` of the whole.
        let mut runs = MaybeUninit::<Runs>::uninit();
        // SAFETY: `len` is written before `assume_init`; `runs` may stay uninitialised.
        unsafe {
            (&raw mut (*runs.as_mut_ptr()).len).write(0);
            runs.assume_init()
        }
    }

    /// Writes `run` at the end of the list, which then grows by one if `keep` (a list of
    /// runs some of which are dropped, without a branch per run). The list must have room.
    #[inline(always)]
    fn put(&mut self, run: (u32, u32), keep: bool) {
        assert!(self.len < RUNS);
        // SAFETY: within the array (asserted).
        unsafe {
            self.runs
                .as_mut_ptr()
                .cast::<(u32, u32)>()
                .add(self.len)
                .write(run)
        };
        self.len += keep as usize;
    }

    #[inline(always)]
    fn push(&mut self, run: (u32, u32)) {
        self.put(run, true);
    }

    /// Collects every run listed, in order, and empties the list.
    #[inline(always)]
    fn flush(&mut self, scan: &Scan, r2: f32, found: &mut Found) {
        // SAFETY: entries 0..len were written (`put`).
        let runs: &[(u32, u32)] =
            unsafe { std::slice::from_raw_parts(self.runs.as_ptr().cast(), self.len) };
        scan.collect_runs(runs, r2, found);
        self.len = 0;
    }
}

/// Agents from which the counting sort places them in pieces on several threads: below,
/// the serial sort is quicker than the pieces' scans over every cell and their four
/// forks and joins.
const PARALLEL_SORT: usize = 32_768;
/// The most cells per agent for which the sort goes in pieces. Pieces halve the agents'
/// share of the sort (scattered writes, a few ns each) but add passes over every cell
/// (a fraction of a ns each): where cells far outnumber agents (a swarm spread thin, as
/// the default shot's bees are after a few seconds) the serial sort is quicker, and frees
/// the other thread.
const SORT_CELLS_PER_AGENT: usize = 2;

/// Whether a counting sort of `agents` over `cells` cells goes in pieces (see
/// [`PARALLEL_SORT`] and [`SORT_CELLS_PER_AGENT`]).
fn sorts_in_pieces(agents: usize, cells: usize) -> bool {
    agents >= PARALLEL_SORT && cells <= SORT_CELLS_PER_AGENT * agents
}

/// At most this many pieces (each has its own counts over every cell).
const MAX_SORT_PIECES: usize = 8;

/// A slice that several threads write at once, each at places no other touches (the
/// counting sort's scatter). Places are bounds-checked; that no two threads touch the
/// same place is the callers' to keep.
struct Scatter<'a, T> {
    ptr: *mut T,
    len: usize,
    _slice: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: the callers' places are disjoint between threads (see `Grid::place_in_pieces`).
unsafe impl<T: Send> Sync for Scatter<'_, T> {}

impl<'a, T: Copy> Scatter<'a, T> {
    fn new(v: &'a mut [T]) -> Self {
        Scatter {
            ptr: v.as_mut_ptr(),
            len: v.len(),
            _slice: std::marker::PhantomData,
        }
    }

    /// SAFETY: no other thread writes place i meanwhile.
    unsafe fn read(&self, i: usize) -> T {
        assert!(i < self.len);
        unsafe { self.ptr.add(i).read() }
    }

    /// SAFETY: no other thread reads or writes place i meanwhile.
    unsafe fn write(&self, i: usize, v: T) {
        assert!(i < self.len);
        unsafe { self.ptr.add(i).write(v) }
    }
}

/// The y and z offsets of the first eight of the 3 × 3 rows around a cell, z outer and y
/// inner (`Grid::walk_cube`'s order), one per lane; the ninth is (+1, +1).
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
const CUBE_ROWS: [[i32; 8]; 2] = [[-1, 0, 1, -1, 0, 1, -1, 0], [-1, -1, -1, 0, 0, 0, 1, 1]];

/// Of [`CUBE_ROWS`]' eight lanes, those within a box of `nz + 1` slabs in z and `ny + 1` in
/// y from its lowest: `IN_BOX[nz][ny]`.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
const IN_BOX: [[u32; 3]; 3] = {
    let mut t = [[0; 3]; 3];
    let mut nz = 0;
    while nz < 3 {
        let mut ny = 0;
        while ny < 3 {
            let mut l = 0;
            while l < 8 {
                if CUBE_ROWS[0][l] < ny as i32 && CUBE_ROWS[1][l] < nz as i32 {
                    t[nz][ny] |= 1 << l;
                }
                l += 1;
            }
            ny += 1;
        }
        nz += 1;
    }
    t
};

/// Candidates a query holds: with more, it keeps the k nearest so far and goes on.
const COLLECT: usize = 64;

/// For each mask of 4 lanes, the lanes set, first to last (the rest 0).
const PACKED: [[u32; LANES]; 16] = {
    let mut t = [[0; LANES]; 16];
    let mut h = 0;
    while h < 16 {
        let (mut lane, mut n) = (0, 0);
        while lane < LANES {
            if h & (1 << lane) != 0 {
                t[h][n] = lane as u32;
                n += 1;
            }
            lane += 1;
        }
        h += 1;
    }
    t
};

/// Candidates the AVX-512 scan tests together.
const WIDE_LANES: usize = 16;

/// Candidates the AVX2 scan tests together.
const NARROW_LANES: usize = 8;

/// For each mask of 8 lanes, the lanes set, first to last (the rest 0): the AVX2 scan's
/// permute, for want of AVX-512's compress.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
const PACKED8: [[u8; NARROW_LANES]; 256] = {
    let mut t = [[0; NARROW_LANES]; 256];
    let mut h = 0;
    while h < 256 {
        let (mut lane, mut n) = (0, 0);
        while lane < NARROW_LANES {
            if h & (1 << lane) != 0 {
                t[h][n] = lane as u8;
                n += 1;
            }
            lane += 1;
        }
        h += 1;
    }
    t
};

/// Places in the sorted arrays of candidates collected, in the order of the scan: a
/// query's working buffer, which a caller making many queries keeps
/// ([`Grid::nearest_with`]). Whatever a query left in it is never read by the next.
pub struct Found {
    /// `WIDE_LANES` spare entries: each group writes all its lanes and keeps as many as it
    /// found.
    slots: [u32; COLLECT + WIDE_LANES],
    /// Their squared distances, where the AVX-512 scan found them (the four-lane scan
    /// leaves them to `Scan::keep_nearest`).
    d2: [f32; COLLECT + WIDE_LANES],
    len: usize,
}

impl Default for Found {
    fn default() -> Self {
        Found {
            slots: [0; COLLECT + WIDE_LANES],
            d2: [0.0; COLLECT + WIDE_LANES],
            len: 0,
        }
    }
}

/// A query's view of the sorted arrays.
struct Scan<'a> {
    xs: &'a [f32],
    ys: &'a [f32],
    zs: &'a [f32],
    p: (Vec4, Vec4, Vec4),
    /// The query's own point's place in the sorted arrays (u32::MAX if it has none).
    skip_slot: u32,
    /// Neighbours wanted (at most `MAX_K`).
    k: usize,
    /// Candidates tested at a time (at most the CPU's width, `Lanes::of_cpu`).
    lanes: Lanes,
    /// On coarse cells: the grid's origin and the fine layout, whose walk order the
    /// candidates are put in before any are kept (`Scan::in_fine_order`).
    fine: Option<(Vec3, FineCells)>,
}

impl Scan<'_> {
    /// Runs are scanned, and candidates ranked, with AVX-512.
    #[inline(always)]
    fn wide(&self) -> bool {
        self.lanes == Lanes::Sixteen
    }

    /// The lanes of the group of four from place `l` whose squared distance `d2` is below
    /// `r2`, other than those past the run's end `b` and the query's own point.
    #[inline(always)]
    fn hits(&self, d2: Vec4, r2: Vec4, l: usize, b: usize) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // The two masks as integer compares of the lanes' places, in the vector
            // registers: as scalar shifts and selects they were a third of the group's
            // instructions. (Places fit an i32: a shot holds at most 10 million agents,
            // and `skip_slot`'s u32::MAX, as −1, is no place.)
            // SAFETY: SSE2 is part of x86-64.
            unsafe {
                let at = _mm_add_epi32(_mm_set1_epi32(l as i32), _mm_setr_epi32(0, 1, 2, 3));
                let in_run = _mm_cmplt_epi32(at, _mm_set1_epi32(b as i32));
                let own = _mm_cmpeq_epi32(at, _mm_set1_epi32(self.skip_slot as i32));
                let keep = _mm_castsi128_ps(_mm_andnot_si128(own, in_run));
                let near = _mm_cmplt_ps(d2.into(), r2.into());
                _mm_movemask_ps(_mm_and_ps(near, keep)) as u32
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut hits = d2.cmplt(r2).bitmask();
            hits &= (1 << (b - l).min(LANES)) - 1;
            let own = self.skip_slot.wrapping_sub(l as u32);
            hits & !(((own < LANES as u32) as u32) << (own & 3))
        }
    }

    /// Collects into `found` the place of every point of the sorted run `a..b` strictly
    /// within `r2` (squared) other than the query's own, four candidates at a time and
    /// without a branch per hit; when `found` is full it keeps the k nearest and goes on.
    #[inline(always)]
    fn collect(&self, a: usize, b: usize, r2: f32, found: &mut Found) {
        let (px, py, pz) = self.p;
        let end = b + LANES - 1;
        let (xs, ys, zs) = (&self.xs[a..end], &self.ys[a..end], &self.zs[a..end]);
        let r2 = Vec4::splat(r2);
        // The count in a local, written back only around the calls that cut the buffer:
        // kept in `found` it was stored and reloaded at every group, a loop-carried wait
        // on the store.
        let mut len = found.len;
        let mut l = a;
        while l < b {
            if len > COLLECT - LANES {
                found.len = len;
                self.keep_nearest(found);
                len = found.len;
            }
            let g = l - a;
            // SAFETY: g < b − a, so g + LANES ≤ end − a, the slices' length.
            let (x, y, z) = unsafe {
                (
                    xs.get_unchecked(g..g + LANES),
                    ys.get_unchecked(g..g + LANES),
                    zs.get_unchecked(g..g + LANES),
                )
            };
            let dx = Vec4::from_slice(x) - px;
            let dy = Vec4::from_slice(y) - py;
            let dz = Vec4::from_slice(z) - pz;
            let d2 = dx * dx + dy * dy + dz * dz;
            let hits = self.hits(d2, r2, l, b);
            let lanes = &PACKED[hits as usize];
            let out = &mut found.slots[len..len + LANES];
            for (o, &lane) in out.iter_mut().zip(lanes) {
                *o = l as u32 + lane;
            }
            len += hits.count_ones() as usize;
            l += LANES;
        }
        found.len = len;
    }

    /// [`Scan::collect`] sixteen candidates at a time with AVX-512: the same squared
    /// distances (the same operations in the same order: no fused multiply-add), the same
    /// comparison, and the hits packed into `found` in the same order, so the same
    /// candidates in the same order. A full `found` keeps the k nearest at other points
    /// than the four-lane scan, which changes nothing: the k nearest by distance and order
    /// of the candidates so far, and then of those and the rest, are the k nearest of all.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn collect_wide(&self, a: usize, b: usize, r2: f32, found: &mut Found) {
        use std::arch::x86_64::*;
        assert!(b <= self.xs.len() && b <= self.ys.len() && b <= self.zs.len());
        let (px, py, pz) = (
            _mm512_set1_ps(self.p.0.x),
            _mm512_set1_ps(self.p.1.x),
            _mm512_set1_ps(self.p.2.x),
        );
        let r2 = _mm512_set1_ps(r2);
        let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
        let mut l = a;
        while l < b {
            if found.len > COLLECT - WIDE_LANES {
                self.keep_nearest(found);
            }
            let valid: __mmask16 = if b - l >= WIDE_LANES {
                u16::MAX
            } else {
                (1u16 << (b - l)) - 1
            };
            // SAFETY: lanes past the run are masked out of the loads, so only places
            // below b ≤ the arrays' lengths (asserted above) are read.
            let (x, y, z) = unsafe {
                (
                    _mm512_maskz_loadu_ps(valid, self.xs.as_ptr().add(l)),
                    _mm512_maskz_loadu_ps(valid, self.ys.as_ptr().add(l)),
                    _mm512_maskz_loadu_ps(valid, self.zs.as_ptr().add(l)),
                )
            };
            let (dx, dy, dz) = (
                _mm512_sub_ps(x, px),
                _mm512_sub_ps(y, py),
                _mm512_sub_ps(z, pz),
            );
            let d2 = _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)),
                _mm512_mul_ps(dz, dz),
            );
            let mut hits = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(valid, d2, r2);
            let own = self.skip_slot.wrapping_sub(l as u32);
            hits &= !(((own < WIDE_LANES as u32) as u16) << (own & 15));
            let places = _mm512_add_epi32(_mm512_set1_epi32(l as i32), lane);
            // SAFETY: found.len ≤ COLLECT − WIDE_LANES (cut above); AVX-512 F is this
            // function's own target.
            found.len = unsafe { pack16(found, found.len, hits, places, d2) };
            l += WIDE_LANES;
        }
    }

    /// Collects the rows `(start, end, slab distance²)` whose slab lies within `r2`.
    #[inline(always)]
    fn collect_rows(&self, rows: &[(u32, u32, f32)], r2: f32, found: &mut Found) {
        let mut runs = [(0u32, 0u32); 9];
        let mut n = 0;
        for &(s, e, slab) in rows {
            runs[n] = (s, e);
            n += (slab < r2) as usize;
        }
        self.collect_runs(&runs[..n], r2, found);
    }

    /// Collects the runs `(start, end)` in order: with AVX-512 or AVX2 in one call where
    /// the scan is that wide, else four lanes at a time.
    #[inline(always)]
    fn collect_runs(&self, runs: &[(u32, u32)], r2: f32, found: &mut Found) {
        #[cfg(target_arch = "x86_64")]
        match self.lanes {
            // SAFETY (both): a width only where the CPU has it (`Lanes::of_cpu`).
            Lanes::Sixteen => return unsafe { self.collect_runs_wide(runs, r2, found) },
            Lanes::Eight => return unsafe { self.collect_runs8(runs, r2, found) },
            Lanes::Four => {}
        }
        for &(s, e) in runs {
            self.collect(s as usize, e as usize, r2, found);
        }
    }

    /// [`Scan::collect_runs`] with AVX2: every run eight candidates at a time, and their
    /// squared distances kept for `keep_nearest`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn collect_runs8(&self, runs: &[(u32, u32)], r2: f32, found: &mut Found) {
        for &(s, e) in runs {
            self.collect8(s as usize, e as usize, r2, found);
        }
    }

    /// [`Scan::collect`] eight candidates at a time with AVX2: the same squared distances
    /// and comparison, and the hits packed (by a permute from `PACKED8`) into `found` in the
    /// same order, with their squared distances, as [`Scan::collect_wide`] leaves them.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn collect8(&self, a: usize, b: usize, r2: f32, found: &mut Found) {
        use std::arch::x86_64::*;
        assert!(b <= self.xs.len() && b <= self.ys.len() && b <= self.zs.len());
        let (px, py, pz) = (
            _mm256_set1_ps(self.p.0.x),
            _mm256_set1_ps(self.p.1.x),
            _mm256_set1_ps(self.p.2.x),
        );
        let r2 = _mm256_set1_ps(r2);
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        // The count in a local, as in `collect`.
        let mut len = found.len;
        let mut l = a;
        while l < b {
            if len > COLLECT - NARROW_LANES {
                found.len = len;
                self.keep_nearest(found);
                len = found.len;
            }
            let left = (b - l).min(NARROW_LANES);
            // All ones in the lanes before the run's end.
            let valid = _mm256_cmpgt_epi32(_mm256_set1_epi32(left as i32), lane);
            // SAFETY: lanes past the run are masked out of the loads, so only places
            // below b ≤ the arrays' lengths (asserted above) are read.
            let (x, y, z) = unsafe {
                (
                    _mm256_maskload_ps(self.xs.as_ptr().add(l), valid),
                    _mm256_maskload_ps(self.ys.as_ptr().add(l), valid),
                    _mm256_maskload_ps(self.zs.as_ptr().add(l), valid),
                )
            };
            let (dx, dy, dz) = (
                _mm256_sub_ps(x, px),
                _mm256_sub_ps(y, py),
                _mm256_sub_ps(z, pz),
            );
            let d2 = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                _mm256_mul_ps(dz, dz),
            );
            let near = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(d2, r2)) as u32;
            let mut hits = near & ((1u32 << left) - 1);
            let own = self.skip_slot.wrapping_sub(l as u32);
            hits &= !(((own < NARROW_LANES as u32) as u32) << (own & 7));
            let places = _mm256_add_epi32(_mm256_set1_epi32(l as i32), lane);
            // SAFETY: len ≤ COLLECT − NARROW_LANES (cut above); AVX2 is this function's
            // own target.
            len = unsafe { pack8(found, len, hits as u8, places, d2) };
            l += NARROW_LANES;
        }
        found.len = len;
    }

    /// [`Scan::collect_runs`] with AVX-512: every run sixteen candidates at a time (a short
    /// run is one masked group), and their squared distances kept for `keep_nearest`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn collect_runs_wide(&self, runs: &[(u32, u32)], r2: f32, found: &mut Found) {
        for &(s, e) in runs {
            self.collect_wide(s as usize, e as usize, r2, found);
        }
    }

    /// On coarse cells, puts the candidates in the order a walk over the fine cells
    /// collects them: by fine cell index (rows along x, then y, then z), then by place in
    /// the sorted arrays, which within a fine cell (inside one coarse cell) is the
    /// visiting order. An insertion sort: a sparse query has a few.
    #[inline]
    fn in_fine_order(&self, found: &mut Found) {
        let Some((origin, fine)) = self.fine else {
            return;
        };
        let n = found.len;
        if n < 2 {
            return;
        }
        let key = |s: u32| -> u64 {
            let i = s as usize;
            let q = Vec3::new(self.xs[i], self.ys[i], self.zs[i]);
            let c = cell_in(q, origin, fine.inv_cell, fine.dims);
            ((index_in(c, fine.dims) as u64) << 32) | s as u64
        };
        let mut keys = [0u64; COLLECT + WIDE_LANES];
        for (k, &s) in keys.iter_mut().zip(&found.slots[..n]) {
            *k = key(s);
        }
        for i in 1..n {
            let (kk, s, d) = (keys[i], found.slots[i], found.d2[i]);
            let mut j = i;
            while j > 0 && keys[j - 1] > kk {
                keys[j] = keys[j - 1];
                found.slots[j] = found.slots[j - 1];
                found.d2[j] = found.d2[j - 1];
                j -= 1;
            }
            keys[j] = kk;
            found.slots[j] = s;
            found.d2[j] = d;
        }
    }

    /// Keeps in `found` only the k nearest of its candidates, in their order, ties at the
    /// k-th distance going to the first. Their squared distances are the eight- or
    /// sixteen-lane scan's, or worked out again as `collect` does (so the same bits). Up to
    /// `RANKED` candidates (the usual case; with AVX2 or AVX-512, all): each one's rank,
    /// the number of candidates strictly nearer, counted for four (or eight, or sixteen)
    /// at a time
    /// against every other, with no branch on the values (a sort's comparisons
    /// mispredict) and no chain of dependent steps; exactly k ranked below k are the k
    /// nearest. More, or a tie at the k-th distance (then more than k rank below k): the
    /// k-th distance by selection. Either way one pass then keeps the rest in order.
    #[inline(never)]
    fn keep_nearest(&self, found: &mut Found) {
        let (n, k) = (found.len, self.k);
        if n <= k {
            return;
        }
        // Ties at the k-th distance go to the first in the fine walk's order.
        self.in_fine_order(found);
        let (px, py, pz) = (self.p.0.x, self.p.1.x, self.p.2.x);
        // ∞: no candidate, nearer than none.
        let mut d2 = [f32::INFINITY; COLLECT + LANES];
        if self.lanes != Lanes::Four {
            d2[..n].copy_from_slice(&found.d2[..n]);
        } else {
            for (d, &s) in d2.iter_mut().zip(&found.slots[..n]) {
                let s = s as usize;
                let (dx, dy, dz) = (self.xs[s] - px, self.ys[s] - py, self.zs[s] - pz);
                *d = dx * dx + dy * dy + dz * dz;
            }
        }
        let kept = match n.div_ceil(LANES) {
            // SAFETY: sixteen lanes only where the CPU has AVX-512 F (`Lanes::of_cpu`).
            #[cfg(target_arch = "x86_64")]
            g if self.wide() && g <= 2 * LANES => unsafe { ranked_below_wide::<2>(&d2, n, k) },
            #[cfg(target_arch = "x86_64")]
            g if self.wide() && g <= 3 * LANES => unsafe { ranked_below_wide::<3>(&d2, n, k) },
            #[cfg(target_arch = "x86_64")]
            _ if self.wide() => unsafe { ranked_below_wide::<4>(&d2, n, k) },
            // SAFETY: eight lanes only where the CPU has AVX2 (`Lanes::of_cpu`).
            #[cfg(target_arch = "x86_64")]
            g if self.lanes == Lanes::Eight && g <= 4 => unsafe { ranked_below8::<2>(&d2, n, k) },
            #[cfg(target_arch = "x86_64")]
            g if self.lanes == Lanes::Eight && g <= 8 => unsafe { ranked_below8::<4>(&d2, n, k) },
            #[cfg(target_arch = "x86_64")]
            _ if self.lanes == Lanes::Eight => unsafe { ranked_below8::<8>(&d2, n, k) },
            5 => ranked_below::<5>(&d2, n, k),
            6 => ranked_below::<6>(&d2, n, k),
            7 => ranked_below::<7>(&d2, n, k),
            8 => ranked_below::<8>(&d2, n, k),
            g if g < 5 => ranked_below::<4>(&d2, n, k),
            _ => 0,
        };
        let mut w = 0;
        if kept.count_ones() as usize == k {
            // In place: the write position never passes the read position. A group of
            // lanes at a time where the CPU has them (a crowd's query keeps 16 of 20–40).
            #[cfg(target_arch = "x86_64")]
            match self.lanes {
                // SAFETY (both): a width only where the CPU has it (`Lanes::of_cpu`).
                Lanes::Sixteen => return unsafe { compact_wide(found, &d2, n, kept) },
                Lanes::Eight => return unsafe { compact8(found, &d2, n, kept) },
                Lanes::Four => {}
            }
            for (r, &d) in d2[..n].iter().enumerate() {
                found.slots[w] = found.slots[r];
                found.d2[w] = d;
                w += (kept >> r) as usize & 1;
            }
        } else {
            let mut sorted = d2;
            let (_, &mut kth, _) = sorted[..n].select_nth_unstable_by(k - 1, f32::total_cmp);
            let mut ties = k - d2[..n].iter().filter(|&&d| d < kth).count();
            for (r, &d) in d2[..n].iter().enumerate() {
                let tie = (d == kth) & (ties > 0);
                found.slots[w] = found.slots[r];
                found.d2[w] = d;
                w += ((d < kth) | tie) as usize;
                ties -= tie as usize;
            }
        }
        found.len = w;
    }
}

/// Writes the lanes of `slots` and `d2` set in `lanes` into `found`'s buffers from entry
/// `at` on, in lane order (a permute from `PACKED8`: AVX2 has no compress), and returns
/// `at` plus how many. All eight lanes are written.
///
/// # Safety
/// `at` ≤ `COLLECT` (the buffers hold `WIDE_LANES` more), and the CPU has AVX2. (Unsafe
/// rather than checked: a check here cost 16 instructions a sparse query, in its hottest
/// loop, whose callers bound `at` already.)
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn pack8(
    found: &mut Found,
    at: usize,
    lanes: u8,
    slots: std::arch::x86_64::__m256i,
    d2: std::arch::x86_64::__m256,
) -> usize {
    use std::arch::x86_64::*;
    debug_assert!(at <= COLLECT);
    // SAFETY: PACKED8's rows are eight bytes; eight entries from at ≤ COLLECT (the
    // caller's promise) fit in buffers of COLLECT + WIDE_LANES.
    unsafe {
        let order = _mm256_cvtepu8_epi32(_mm_loadl_epi64(PACKED8[lanes as usize].as_ptr().cast()));
        _mm256_storeu_si256(
            found.slots.as_mut_ptr().add(at).cast(),
            _mm256_permutevar8x32_epi32(slots, order),
        );
        _mm256_storeu_ps(
            found.d2.as_mut_ptr().add(at),
            _mm256_permutevar8x32_ps(d2, order),
        );
    }
    at + lanes.count_ones() as usize
}

/// [`pack8`] for sixteen lanes with AVX-512's compress.
///
/// # Safety
/// As [`pack8`], and the CPU has AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn pack16(
    found: &mut Found,
    at: usize,
    lanes: u16,
    slots: std::arch::x86_64::__m512i,
    d2: std::arch::x86_64::__m512,
) -> usize {
    use std::arch::x86_64::*;
    debug_assert!(at <= COLLECT);
    // SAFETY: sixteen entries from at ≤ COLLECT (the caller's promise) fit in buffers of
    // COLLECT + WIDE_LANES.
    unsafe {
        _mm512_storeu_si512(
            found.slots.as_mut_ptr().add(at).cast(),
            _mm512_maskz_compress_epi32(lanes, slots),
        );
        _mm512_storeu_ps(
            found.d2.as_mut_ptr().add(at),
            _mm512_maskz_compress_ps(lanes, d2),
        );
    }
    at + lanes.count_ones() as usize
}

/// Keeps in `found` the first `n` candidates whose bit is set in `kept`, in their order,
/// with their squared distances `d2`, eight at a time with AVX2 (a permute from
/// `PACKED8`), in place: each group is read before any write reaches it.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn compact8(found: &mut Found, d2: &[f32; COLLECT + LANES], n: usize, kept: u64) {
    use std::arch::x86_64::*;
    assert!(n <= COLLECT);
    let (mut w, mut g) = (0, 0);
    while g < n {
        let keep = ((kept >> g) as u32 & 0xFF) & ((1u32 << (n - g).min(NARROW_LANES)) - 1);
        // SAFETY: g < n ≤ COLLECT, a multiple of eight, so eight entries from g lie in
        // `d2` (COLLECT + LANES) and `found.slots`.
        let (slots, dists) = unsafe {
            (
                _mm256_loadu_si256(found.slots.as_ptr().add(g).cast()),
                _mm256_loadu_ps(d2.as_ptr().add(g)),
            )
        };
        // SAFETY: w ≤ g < COLLECT; AVX2 is this function's own target.
        w = unsafe { pack8(found, w, keep as u8, slots, dists) };
        g += NARROW_LANES;
    }
    found.len = w;
}

/// [`compact8`] sixteen at a time with AVX-512's compress.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn compact_wide(found: &mut Found, d2: &[f32; COLLECT + LANES], n: usize, kept: u64) {
    use std::arch::x86_64::*;
    assert!(n <= COLLECT);
    let (mut w, mut g) = (0, 0);
    while g < n {
        let all = ((1u32 << (n - g).min(WIDE_LANES)) - 1) as u16;
        let keep = (kept >> g) as u16 & all;
        // SAFETY: g < n ≤ COLLECT, a multiple of sixteen, so sixteen entries from g lie in
        // `d2` (COLLECT + LANES) and `found.slots`.
        let (slots, dists) = unsafe {
            (
                _mm512_loadu_si512(found.slots.as_ptr().add(g).cast()),
                _mm512_loadu_ps(d2.as_ptr().add(g)),
            )
        };
        // SAFETY: w ≤ g < COLLECT; AVX-512 F is this function's own target.
        w = unsafe { pack16(found, w, keep, slots, dists) };
        g += WIDE_LANES;
    }
    found.len = w;
}

/// Candidates up to which `Scan::keep_nearest` ranks them (beyond, it selects).
const RANKED: usize = 8 * LANES;

/// Bit j set for each of the first `n` squared distances `d2` (the rest ∞) with fewer
/// than `k` strictly smaller: the k nearest if exactly k bits are set, else a tie at the
/// k-th distance. `G` groups of four lanes hold the `n`; for each candidate i every lane j
/// adds 1 if d_i < d_j, so all the comparisons are independent.
#[inline(always)]
fn ranked_below<const G: usize>(d2: &[f32], n: usize, k: usize) -> u64 {
    const { assert!(G * LANES <= RANKED) };
    let groups: [Vec4; G] = std::array::from_fn(|g| Vec4::from_slice(&d2[g * LANES..]));
    let mut nearer = [Vec4::ZERO; G];
    for &di in &d2[..n] {
        let di = Vec4::splat(di);
        for (c, &dj) in nearer.iter_mut().zip(&groups) {
            *c += Vec4::select(di.cmplt(dj), Vec4::ONE, Vec4::ZERO);
        }
    }
    let k = Vec4::splat(k as f32);
    let mut below = 0u64;
    for (g, c) in nearer.iter().enumerate() {
        below |= (c.cmplt(k).bitmask() as u64) << (g * LANES);
    }
    below & ((1u64 << n) - 1)
}

/// [`ranked_below`] with AVX-512, for up to `R` × 16 (at most 64) candidates: the
/// distances in `R` registers, each candidate's comparison with all of them one mask per
/// register, the counts integers. The same comparisons, so the same bits set; and cheap
/// enough that a full `found` (up to 64) is ranked too rather than selected.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn ranked_below_wide<const R: usize>(d2: &[f32; COLLECT + LANES], n: usize, k: usize) -> u64 {
    use std::arch::x86_64::*;
    const { assert!(R * WIDE_LANES <= COLLECT && R * WIDE_LANES <= 64) };
    debug_assert!(n <= R * WIDE_LANES);
    // SAFETY: every load lies within `d2` (asserted above).
    let groups: [__m512; R] =
        std::array::from_fn(|r| unsafe { _mm512_loadu_ps(d2.as_ptr().add(r * WIDE_LANES)) });
    let one = _mm512_set1_epi32(1);
    let mut nearer = [_mm512_setzero_si512(); R];
    for &di in &d2[..n] {
        let di = _mm512_set1_ps(di);
        for (c, &dj) in nearer.iter_mut().zip(&groups) {
            let m = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(di, dj);
            *c = _mm512_mask_add_epi32(*c, m, *c, one);
        }
    }
    let k = _mm512_set1_epi32(k as i32);
    let mut below = 0u64;
    for (r, &c) in nearer.iter().enumerate() {
        below |= (_mm512_cmplt_epi32_mask(c, k) as u64) << (r * WIDE_LANES);
    }
    // (n = 64 keeps every bit.)
    below & (u64::MAX >> (64 - n))
}

/// [`ranked_below`] with AVX2, for up to `R` × 8 (at most 64) candidates: each
/// candidate's comparison with all of them one compare per register, counted by
/// subtracting its all-ones (−1) lanes. The same comparisons, so the same bits set.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn ranked_below8<const R: usize>(d2: &[f32; COLLECT + LANES], n: usize, k: usize) -> u64 {
    use std::arch::x86_64::*;
    const { assert!(R * NARROW_LANES <= COLLECT && R * NARROW_LANES <= 64) };
    debug_assert!(n <= R * NARROW_LANES);
    // SAFETY: every load lies within `d2` (asserted above).
    let groups: [__m256; R] =
        std::array::from_fn(|r| unsafe { _mm256_loadu_ps(d2.as_ptr().add(r * NARROW_LANES)) });
    let mut nearer = [_mm256_setzero_si256(); R];
    for &di in &d2[..n] {
        let di = _mm256_set1_ps(di);
        for (c, &dj) in nearer.iter_mut().zip(&groups) {
            let m = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(di, dj));
            *c = _mm256_sub_epi32(*c, m);
        }
    }
    let k = _mm256_set1_epi32(k as i32);
    let mut below = 0u64;
    for (r, &c) in nearer.iter().enumerate() {
        let fewer = _mm256_castsi256_ps(_mm256_cmpgt_epi32(k, c));
        below |= (_mm256_movemask_ps(fewer) as u32 as u64) << (r * NARROW_LANES);
    }
    // (n = 64 keeps every bit.)
    below & (u64::MAX >> (64 - n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// The grid's answer against brute force: the same set of neighbours (the k nearest
    /// within r, ties aside).
    fn check(pts: &[Vec3], r: f32, k: usize) {
        let mut g = Grid::default();
        g.build(pts, r);
        let mut out = [0u32; MAX_K];
        for i in (0..pts.len()).step_by(7) {
            let len = g.nearest(pts[i], r, k, i, &mut out);
            let mut found: Vec<usize> = out[..len].iter().map(|&j| j as usize).collect();
            found.sort();
            let mut brute: Vec<(f32, usize)> = (0..pts.len())
                .filter(|&j| j != i && pts[j].distance_squared(pts[i]) < r * r)
                .map(|j| (pts[j].distance_squared(pts[i]), j))
                .collect();
            brute.sort_by(|a, b| a.partial_cmp(b).unwrap());
            assert_eq!(len, brute.len().min(k), "point {i}");
            if brute.len() > k && brute[k - 1].0 == brute[k].0 {
                continue; // a tie at the boundary: either is right
            }
            let mut want: Vec<usize> = brute.iter().take(k).map(|b| b.1).collect();
            want.sort();
            assert_eq!(found, want, "point {i}");
        }
    }

    fn cloud(seed: u64, n: usize, half: f32) -> Vec<Vec3> {
        crate::math::random_cloud(&mut Rng::new(seed, 1, 1), n, half)
    }

    #[test]
    fn finds_exactly_the_nearest_neighbours_brute_force_finds() {
        let pts = cloud(1, 2000, 1.0);
        check(&pts, 0.1, 16);
        check(&pts, 0.3, 16);
        check(&pts, 0.3, 1);
    }

    #[test]
    fn keeping_the_k_nearest_keeps_the_candidates_order_and_gives_ties_to_the_first() {
        // Candidates on a coarse lattice (many exact ties at every distance) and off it,
        // for every count up to a full `Found` and several k: the kept places must be the
        // k first of the candidates sorted by (distance, order found), in the order found.
        // At every scan width the CPU has: four lanes (the distances worked out again),
        // eight (the scan's distances) and sixteen (ranked sixteen at a time).
        let mut rng = Rng::new(7, 3, 1);
        let widths = Lanes::available();
        for trial in 0..12000 {
            let lanes = widths[trial % 3 % widths.len()];
            let trial = trial / 3;
            let n = 2 + trial % (COLLECT - 1);
            let k = [1, 4, 7, 16, 16, 16, 24, 32][trial % 8].min(n - 1);
            let coarse = trial % 2 == 0;
            let coord = |rng: &mut Rng| {
                if coarse {
                    (rng.range(-3.0, 3.0)).round() * 0.25
                } else {
                    rng.range(-1.0, 1.0)
                }
            };
            let pts: Vec<Vec3> = (0..n)
                .map(|_| Vec3::new(coord(&mut rng), coord(&mut rng), coord(&mut rng)))
                .collect();
            let (xs, ys, zs): (Vec<f32>, Vec<f32>, Vec<f32>) =
                pts.iter().map(|p| (p.x, p.y, p.z)).collect();
            let scan = Scan {
                xs: &xs,
                ys: &ys,
                zs: &zs,
                p: (Vec4::ZERO, Vec4::ZERO, Vec4::ZERO),
                skip_slot: u32::MAX,
                k,
                lanes,
                fine: None,
            };
            let mut found = Found::default();
            // Collected in a scrambled order, as a walk over cells would.
            for (i, s) in found.slots[..n].iter_mut().enumerate() {
                *s = ((i * 37 + trial) % n) as u32;
            }
            found.len = n;
            // With their squared distances, as the wider scans leave them.
            for (d, &s) in found.d2.iter_mut().zip(&found.slots[..n]) {
                let p = pts[s as usize];
                *d = p.x * p.x + p.y * p.y + p.z * p.z;
            }
            let order = found.slots;
            scan.keep_nearest(&mut found);
            let mut want: Vec<(f32, usize)> = (0..n)
                .map(|r| (pts[order[r] as usize].length_squared(), r))
                .collect();
            want.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let mut want: Vec<usize> = want[..k].iter().map(|w| w.1).collect();
            want.sort();
            let want: Vec<u32> = want.iter().map(|&r| order[r]).collect();
            assert_eq!(
                &found.slots[..found.len],
                &want[..],
                "trial {trial}: n {n}, k {k}, {lanes:?}"
            );
        }
    }

    #[test]
    fn a_relabelled_grid_answers_as_one_built_over_the_points_in_their_new_places() {
        // The world's cell order: build visiting points by id, move every point to its
        // place in the grid's order, relabel. A grid built afresh over the moved points,
        // visited by the same ids, must answer every query alike, in the same order.
        for (seed, n, size) in [(8, 3000, 1.0), (9, 6000, 0.1)] {
            let pts = cloud(seed, n, size);
            // Ids a fixed shuffle of the indices: id k is stored at index by_id[k].
            let mut by_id: Vec<u32> = (0..n as u32).collect();
            let mut rng = crate::math::Rng::new(seed, 1, 1);
            for k in (1..n).rev() {
                by_id.swap(k, (rng.next_u64() % (k as u64 + 1)) as usize);
            }
            let mut g = Grid::default();
            g.build_visiting(&pts, 0.2, &[], &by_id);
            let mut new_of_old = vec![0u32; n];
            for (t, &i) in g.order().iter().enumerate() {
                new_of_old[i as usize] = t as u32;
            }
            let old_of_new = g.order().to_vec();
            g.relabel(&new_of_old, &old_of_new);
            let mut moved = vec![Vec3::ZERO; n];
            for (i, p) in pts.iter().enumerate() {
                moved[new_of_old[i] as usize] = *p;
            }
            let moved_by_id: Vec<u32> = by_id.iter().map(|&i| new_of_old[i as usize]).collect();
            let mut fresh = Grid::default();
            fresh.build_visiting(&moved, 0.2, &[], &moved_by_id);
            assert!(g.order().iter().enumerate().all(|(t, &i)| i == t as u32));
            assert_eq!(g.order(), fresh.order());
            let (mut a, mut b) = ([0u32; MAX_K], [0u32; MAX_K]);
            for i in (0..n).step_by(7) {
                let la = g.nearest(moved[i], 0.2, 16, i, &mut a);
                let lb = fresh.nearest(moved[i], 0.2, 16, i, &mut b);
                assert_eq!(a[..la], b[..lb], "point {i}");
                assert!(!a[..la].contains(&(i as u32)));
            }
        }
    }

    #[test]
    fn every_scan_width_finds_what_the_four_lane_scan_finds() {
        // Eight candidates at a time with AVX2, sixteen (and ranked sixteen at a time)
        // with AVX-512, where the CPU has them: the same lists in the same order as four
        // at a time, in a sparse cloud, a middling one, a crowd (thin cells) and a lattice
        // full of ties, for k from 1 to 32 (a full buffer of candidates kept at other
        // points).
        let widths = Lanes::available();
        if widths.len() == 1 {
            eprintln!("skipped: no wide path runs here (`simd::level`)");
            return;
        }
        let lattice: Vec<Vec3> = (0..4096)
            .map(|i| Vec3::new((i % 16) as f32, (i / 16 % 16) as f32, (i / 256) as f32) * 0.01)
            .collect();
        let clouds = [
            (cloud(31, 4000, 2.0), 0.15),
            (cloud(32, 4000, 0.5), 0.15),
            (cloud(33, 20_000, 0.1), 0.15),
            (lattice, 0.035),
        ];
        for (c, (pts, r)) in clouds.iter().enumerate() {
            let mut g = Grid::default();
            g.build(pts, *r);
            let (mut a, mut b) = ([0u32; MAX_K], [0u32; MAX_K]);
            for (k, &lanes) in [1, 7, 16, 32]
                .iter()
                .flat_map(|k| widths[1..].iter().map(move |l| (*k, l)))
            {
                for i in (0..pts.len()).step_by(13) {
                    let la =
                        g.nearest_scanning(pts[i], *r, k, i, &mut a, lanes, &mut Found::default());
                    let four = Lanes::Four;
                    let lb =
                        g.nearest_scanning(pts[i], *r, k, i, &mut b, four, &mut Found::default());
                    assert_eq!(a[..la], b[..lb], "cloud {c}, k {k}, point {i}, {lanes:?}");
                }
            }
        }
    }

    #[test]
    fn the_rough_cube_root_is_within_its_stated_error() {
        for i in 0..10_000 {
            let x = 1e-12 * 1.0031f32.powi(i);
            let (r, exact) = (rough_cbrt(x), x.cbrt());
            assert!((r / exact - 1.0).abs() < 2e-3, "{x}: {r} against {exact}");
        }
        assert_eq!(rough_cbrt(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn sorting_in_pieces_on_several_threads_gives_the_serial_sort() {
        // From PARALLEL_SORT agents (and at most SORT_CELLS_PER_AGENT cells each) the
        // counting sort places them in one piece per thread; every cell must still list
        // its agents in visiting order, and the starts, the places and the answers must be
        // those of one thread. A sparse cloud and a crowd (thin cells), visited by a
        // shuffle of the ids, a tenth left out.
        for (seed, n, size) in [
            (21, PARALLEL_SORT + 2_000, 2.0),
            (22, 3 * PARALLEL_SORT, 0.05),
        ] {
            let pts = cloud(seed, n, size);
            let mut visit: Vec<u32> = (0..n as u32).collect();
            let mut rng = crate::math::Rng::new(seed, 1, 1);
            for k in (1..n).rev() {
                visit.swap(k, (rng.next_u64() % (k as u64 + 1)) as usize);
            }
            let except: Vec<bool> = (0..n).map(|i| i % 10 == 3).collect();
            let build = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| {
                    let mut g = Grid::default();
                    g.build_visiting(&pts, 0.15, &except, &visit);
                    g
                })
            };
            let one = build(1);
            assert_eq!(one.split > 1, size < 1.0, "the crowd has thin cells");
            assert!(sorts_in_pieces(n, one.starts.len() - 1), "sorted in pieces");
            for threads in [2, 3, 8] {
                let g = build(threads);
                assert_eq!(
                    (g.dims, g.split),
                    (one.dims, one.split),
                    "{threads} threads"
                );
                assert_eq!(g.starts, one.starts, "{threads} threads");
                assert_eq!(g.items, one.items, "{threads} threads");
                assert_eq!(g.slot, one.slot, "{threads} threads");
            }
            // Within each cell, in visiting order.
            let rank: Vec<usize> = {
                let mut r = vec![0; n];
                for (k, &i) in visit.iter().enumerate() {
                    r[i as usize] = k;
                }
                r
            };
            for c in one.starts.windows(2) {
                let run = &one.items[c[0] as usize..c[1] as usize];
                assert!(
                    run.windows(2)
                        .all(|w| rank[w[0] as usize] < rank[w[1] as usize])
                );
            }
            assert!(one.items[..one.len()].iter().all(|&i| !except[i as usize]));
            assert_eq!(one.len(), except.iter().filter(|&&x| !x).count());
        }
    }

    #[test]
    fn points_left_out_are_never_found_and_the_rest_are() {
        // Every third point left out (bees inside their hive): the answer is brute force's
        // over the others, in a sparse cloud and in a crowd.
        for (seed, n, size) in [(5, 2000, 1.0), (6, 6000, 0.1)] {
            let pts = cloud(seed, n, size);
            let except: Vec<bool> = (0..n).map(|i| i % 3 == 0).collect();
            let mut g = Grid::default();
            g.build_except(&pts, 0.2, &except);
            let mut out = [0u32; MAX_K];
            for i in (0..n).step_by(11) {
                let len = g.nearest(pts[i], 0.2, 16, i, &mut out);
                let mut found: Vec<usize> = out[..len].iter().map(|&j| j as usize).collect();
                found.sort_unstable();
                let mut brute: Vec<(f32, usize)> = (0..n)
                    .filter(|&j| j != i && !except[j])
                    .map(|j| (pts[i].distance_squared(pts[j]), j))
                    .filter(|&(d2, _)| d2 < 0.04)
                    .collect();
                brute.sort_by(|a, b| a.0.total_cmp(&b.0));
                let mut want: Vec<usize> = brute.iter().take(16).map(|&(_, j)| j).collect();
                want.sort_unstable();
                assert_eq!(found, want, "point {i}");
            }
        }
    }

    #[test]
    fn a_crowd_shrinks_the_cells_and_keeps_the_answer() {
        // 20,000 points in a 20 cm cube (2.5 million per m³) and a sparse halo.
        let mut pts = cloud(3, 20_000, 0.1);
        pts.extend(cloud(4, 200, 0.5));
        let mut g = Grid::default();
        g.build(&pts, 0.15);
        assert!(g.cell() < 0.15 * 0.3, "cell {} m", g.cell());
        check(&pts, 0.15, 16);
    }

    #[test]
    fn the_near_rows_collect_what_the_ring_walk_collects_in_its_order() {
        // Crowds filling their grids (so that their edges, where rows fall outside the grid,
        // have neighbours), walked out to reaches from a tenth of a cell to past two cells:
        // wherever `walk` lists rings 0 and 1 without branches, the candidates and their
        // order are the ring walk's.
        let (mut near, mut rings) = (0, 0);
        for (seed, half) in [(7, 0.1), (9, 0.123)] {
            let pts = cloud(seed, 20_000, half);
            let mut g = Grid::default();
            g.build(&pts, 0.15);
            assert!(g.split > 1, "a crowd's grid");
            let cell = g.cell();
            // Every 13th point, and the outermost along each axis, whose ring 1 leaves the
            // grid.
            let extreme = |key: fn(&Vec3) -> f32| {
                let by = |a: &usize, b: &usize| key(&pts[*a]).total_cmp(&key(&pts[*b]));
                let all = 0..pts.len();
                [all.clone().min_by(by).unwrap(), all.max_by(by).unwrap()]
            };
            let edges = [extreme(|p| p.x), extreme(|p| p.y), extreme(|p| p.z)];
            let queries = (0..pts.len())
                .step_by(13)
                .chain(edges.into_iter().flatten());
            for (i, n) in queries.flat_map(|i| (0..12).map(move |n| (i, n))) {
                let p = pts[i];
                let reach = cell * (0.1 + 0.2 * n as f32);
                for lanes in Lanes::available() {
                    let scan = Scan {
                        xs: &g.xs,
                        ys: &g.ys,
                        zs: &g.zs,
                        p: (Vec4::splat(p.x), Vec4::splat(p.y), Vec4::splat(p.z)),
                        skip_slot: g.slot[i],
                        k: MAX_K,
                        lanes,
                        fine: None,
                    };
                    let c = g.cell_of(p);
                    let margin = g.row_margin(p, c);
                    let (mut a, mut b) = (Found::default(), Found::default());
                    g.walk(p, c, reach, &scan, &mut a);
                    g.walk_rings(p, c, reach, margin, &scan, &mut b);
                    assert_eq!(a.slots[..a.len], b.slots[..b.len], "{i}, reach {reach}");
                    if cell + margin >= reach {
                        near += 1;
                    } else {
                        rings += 1;
                    }
                }
            }
        }
        assert!(
            near > 20_000 && rings > 20_000,
            "{near} near, {rings} ring walks"
        );
    }

    #[test]
    fn a_coarse_grid_answers_as_the_fine_grid_in_the_same_order() {
        // Sparse clouds (random; a lattice, whose equal distances make ties at the k-th,
        // broken by the fine walk's order; a few dense clumps in a sparse cloud, whose
        // queries keep k of many), some points left out and visited in a shuffled
        // order: every query's answer and its order as on the fine cells, on both scans.
        // The coarse queries share one candidate buffer, as the world's do; the fine ones
        // each start from a fresh one.
        let mut lattice = Vec::new();
        for x in 0..24 {
            for y in 0..24 {
                for z in 0..24 {
                    lattice.push(Vec3::new(x as f32, y as f32, z as f32) * 0.37);
                }
            }
        }
        let mut clumps = cloud(33, 3_000, 4.0);
        for c in 0..4 {
            let centre = Vec3::splat(c as f32 - 1.5);
            clumps.extend(cloud(40 + c, 40, 0.05).into_iter().map(|p| p + centre));
        }
        for (pts, radius) in [(cloud(31, 4_000, 4.0), 0.3), (lattice, 0.4), (clumps, 0.3)] {
            let n = pts.len();
            let mut visit: Vec<u32> = (0..n as u32).collect();
            let mut rng = crate::math::Rng::new(5, 1, 1);
            for k in (1..n).rev() {
                visit.swap(k, (rng.next_u64() % (k as u64 + 1)) as usize);
            }
            let except: Vec<bool> = (0..n).map(|i| i % 13 == 4).collect();
            let mut fine = Grid::default();
            fine.build_visiting(&pts, radius, &except, &visit);
            let mut coarse = Grid::default();
            coarse.allow_coarse(true);
            // The first build measures the swarm, the second takes coarse cells (the
            // random cloud is sparse enough; the others are made to).
            coarse.build_visiting(&pts, radius, &except, &visit);
            coarse.force_coarse = n != 4_000;
            coarse.build_visiting(&pts, radius, &except, &visit);
            assert!(!fine.coarse && coarse.coarse, "{n} points");
            assert_eq!(coarse.cell(), fine.cell());
            let mut kept = Found::default();
            for lanes in Lanes::available() {
                for k in [2, 5, 16] {
                    for (i, &p) in pts.iter().enumerate() {
                        let (mut a, mut b) = ([0u32; MAX_K], [0u32; MAX_K]);
                        let na = fine.nearest_scanning(
                            p,
                            radius,
                            k,
                            i,
                            &mut a,
                            lanes,
                            &mut Found::default(),
                        );
                        let nb = coarse.nearest_scanning(p, radius, k, i, &mut b, lanes, &mut kept);
                        assert_eq!(a[..na], b[..nb], "point {i}, k {k}, {lanes:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_sparse_grid_with_more_than_k_around_a_query_keeps_the_answer() {
        // About 10 points per radius-sized cell: not a crowd, so the cells stay as large as
        // the radius, but some 40 lie within it, so queries first look within a guess of
        // the 16th-nearest distance (and the rest of the cloud, sparser, does not).
        let mut pts = cloud(7, 1250, 0.5);
        pts.extend(cloud(8, 300, 2.0));
        let mut g = Grid::default();
        g.build(&pts, 0.2);
        assert!(g.cell() >= 0.2, "not a crowd: cell {} m", g.cell());
        check(&pts, 0.2, 16);
        check(&pts, 0.2, 5);
    }

    #[test]
    fn a_gap_in_a_crowd_fools_the_density_guess_but_not_the_answer() {
        // Two dense slabs 4 cm apart and points in the gap: a gap point's guess, from
        // the crowded cells around it, is far too short, so its walk is redone.
        let mut pts: Vec<Vec3> = cloud(5, 12_000, 0.1)
            .into_iter()
            .map(|p| Vec3::new(p.x, p.y * 0.2 + p.y.signum() * 0.02, p.z))
            .collect();
        pts.extend((0..50).map(|i| Vec3::new(i as f32 * 0.004 - 0.1, 0.0, 0.01)));
        let mut g = Grid::default();
        g.build(&pts, 0.15);
        assert!(g.cell() < 0.15, "a crowd: cell {} m", g.cell());
        check(&pts, 0.15, 16);
        let gap: Vec<usize> = (12_000..pts.len()).collect();
        let mut out = [0u32; MAX_K];
        for &i in &gap {
            let len = g.nearest(pts[i], 0.15, 16, i, &mut out);
            let mut brute: Vec<f32> = (0..pts.len())
                .filter(|&j| j != i)
                .map(|j| pts[j].distance_squared(pts[i]))
                .collect();
            brute.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let far = out[..len]
                .iter()
                .map(|&j| pts[j as usize].distance_squared(pts[i]))
                .fold(0.0f32, f32::max);
            assert_eq!((len, far), (16, brute[15]), "gap point {i}");
        }
    }

    #[test]
    fn widely_spread_points_and_outliers_still_work() {
        let mut pts = cloud(2, 1000, 0.5);
        pts.push(Vec3::new(500.0, -300.0, 1e4));
        pts.push(Vec3::new(500.0, -300.0, 1e4)); // coincident
        check(&pts, 0.05, 16);
        check(&[Vec3::ONE], 0.1, 16);
        check(&[], 0.1, 16);
    }
}
