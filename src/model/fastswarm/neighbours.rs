//! Every agent within the attraction zone (paper 003 Sec. 5.2.1, "fast indexing": space cut
//! into a grid, each agent searching the cells around it). Eq. 6 averages over all the
//! attraction neighbours, so the world's bounded list (the 16 nearest, most of them inside
//! d_att1 in a dense swarm) would leave out the rest of the swarm: a swarm split by a
//! predator would then only hold together through the weak swarm-centre term (Eq. 7).
//!
//! Conventions: metres, world Y-up.

use crate::model::context::MAX_NEIGHBOURS;
use glam::Vec3;

/// Entries tested at once in a scan.
pub const LANES: usize = 8;

/// Eq. 4's repulsion neighbours, found by the same scan as Eq. 6's: the
/// [`MAX_NEIGHBOURS`] nearest strictly within the repulsion radius, so at most k as for
/// every model that sums over neighbours (docs/model.md, "Bounded neighbours"). In the
/// scan's order (cell by cell, each in index order); when more than k are that close,
/// the k nearest (equal distances by agent index), nearest first.
#[derive(Clone, Copy, Debug)]
pub struct Nearest {
    /// How many were found: at most [`NEAR_ROOM`] during the scan, at most
    /// [`MAX_NEIGHBOURS`] after [`Nearest::finish`].
    pub n: usize,
    d2: [f32; NEAR_ROOM],
    /// Agent index and position of each, m.
    pub index: [u32; NEAR_ROOM],
    pub pos: [Vec3; NEAR_ROOM],
    /// Batches noted during the scan with some lane within the radius: where each starts
    /// and which lanes.
    pending: [(u32, u32); PENDING],
    n_pending: usize,
}

/// Room for the close agents a scan finds; past it, only the nearest are kept.
const NEAR_ROOM: usize = 2 * MAX_NEIGHBOURS;

/// Batches noted before they are taken.
const PENDING: usize = 16;

impl Default for Nearest {
    fn default() -> Self {
        Nearest {
            n: 0,
            d2: [0.0; NEAR_ROOM],
            index: [0; NEAR_ROOM],
            pos: [Vec3::ZERO; NEAR_ROOM],
            pending: [(0, 0); PENDING],
            n_pending: 0,
        }
    }
}

impl Nearest {
    /// Notes batch `b` of `cells` if some lane is set in `close`, to be taken after the
    /// scan (or when the notes are full): written every time and counted by whether it
    /// holds any, so that the scan's loop has no branch on it.
    #[inline(always)]
    pub fn note(&mut self, cells: &CellIndex, b: &Batch<'_>, close: u32, p: Vec3, exclude: usize) {
        self.pending[self.n_pending] = (b.at as u32, close);
        self.n_pending += usize::from(close != 0);
        if self.n_pending == PENDING {
            self.take_noted(cells, p, exclude);
        }
    }

    /// Takes the batches noted.
    fn take_noted(&mut self, cells: &CellIndex, p: Vec3, exclude: usize) {
        for k in 0..self.n_pending {
            let (at, close) = self.pending[k];
            self.take(&cells.batch(at as usize), close, p, exclude);
        }
        self.n_pending = 0;
    }

    /// Takes the agents of `b`'s lanes set in `hits` (within the radius) but `exclude`,
    /// each at squared distance (q − p)·(q − p). Few agents are this close (about six at
    /// the bench's aggregation), so a branch per hit costs little.
    #[inline(always)]
    fn take(&mut self, b: &Batch<'_>, mut hits: u32, p: Vec3, exclude: usize) {
        while hits != 0 {
            let l = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            let j = b.index[l];
            if j as usize != exclude {
                let q = Vec3::new(b.x[l], b.y[l], b.z[l]);
                let d2 = q.distance_squared(p);
                if self.n < NEAR_ROOM {
                    (self.d2[self.n], self.index[self.n], self.pos[self.n]) = (d2, j, q);
                    self.n += 1;
                } else {
                    self.displace(d2, j, q);
                }
            }
        }
    }

    /// A crowd: the room is full, so the farthest kept gives way to a nearer one.
    #[cold]
    fn displace(&mut self, d2: f32, j: u32, q: Vec3) {
        let key = |k: usize| (self.d2[k], self.index[k]);
        let far = (1..NEAR_ROOM).fold(0, |m, k| if key(k) > key(m) { k } else { m });
        if (d2, j) < key(far) {
            (self.d2[far], self.index[far], self.pos[far]) = (d2, j, q);
        }
    }

    /// The agents found, by index (tests).
    #[cfg(test)]
    pub fn found(&self) -> Vec<u32> {
        self.index[..self.n].to_vec()
    }

    /// After the scan: takes the batches noted; more than k found keeps the k nearest,
    /// nearest first.
    pub fn finish(&mut self, cells: &CellIndex, p: Vec3, exclude: usize) {
        self.take_noted(cells, p, exclude);
        if self.n <= MAX_NEIGHBOURS {
            return;
        }
        let mut order: [usize; NEAR_ROOM] = std::array::from_fn(|k| k);
        let order = &mut order[..self.n];
        order.sort_unstable_by(|&a, &b| {
            (self.d2[a], self.index[a])
                .partial_cmp(&(self.d2[b], self.index[b]))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let kept = *self;
        for (k, &o) in order.iter().take(MAX_NEIGHBOURS).enumerate() {
            (self.d2[k], self.index[k], self.pos[k]) = (kept.d2[o], kept.index[o], kept.pos[o]);
        }
        self.n = MAX_NEIGHBOURS;
    }
}

/// The most cells a dense table may hold per indexed agent (beyond a floor of
/// [`MIN_TABLE`]); a swarm spread wider is searched by binary search in the sorted keys.
const CELLS_PER_AGENT: usize = 8;
const MIN_TABLE: usize = 4096;

/// Agents sorted by grid cell, rebuilt once per step, with their positions stored in the
/// same order (a struct of arrays) so that a scan reads contiguous memory.
///
/// The order is by cell — x, then y, then z cell coordinate — and by agent index within a
/// cell. When the cells the agents occupy fit a box of at most [`CELLS_PER_AGENT`] per
/// agent, they are placed by a counting sort into a dense table of where each cell's run
/// starts (a row is then two reads); otherwise by sorting their packed cell keys (a row is
/// then two binary searches). Both give the same order.
#[derive(Clone, Debug, Default)]
pub struct CellIndex {
    cell: f32,
    /// Agent index of each entry, padded as the positions with [`LANES`] `u32::MAX`.
    index: Vec<u32>,
    /// Position components of each entry, m, padded with [`LANES`] entries at +∞ so that
    /// a batch may start anywhere.
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    /// Where each cell's run starts (dense), or every entry's packed key (sparse).
    lookup: Lookup,
    /// Scratch of `build`: each agent's cell and (sparse) the (key, index) pairs sorted.
    cells: Vec<[i64; 3]>,
    pairs: Vec<(u64, u32)>,
}

/// [`LANES`] consecutive entries of a [`CellIndex`]: positions by component, m, and
/// agent indices (entries past the end: +∞ and `u32::MAX`).
#[derive(Clone, Copy, Debug)]
pub struct Batch<'a> {
    /// Where the batch starts in the index.
    pub at: usize,
    pub x: &'a [f32; LANES],
    pub y: &'a [f32; LANES],
    pub z: &'a [f32; LANES],
    pub index: &'a [u32; LANES],
}

#[derive(Clone, Debug, Default)]
enum Lookup {
    #[default]
    Empty,
    /// The box of cells `origin .. origin + dims`; `starts[c]` is the first entry of cell
    /// c = (x·dims_y + y)·dims_z + z (box coordinates), `starts[c + 1]` its end.
    Dense {
        origin: [i64; 3],
        dims: [i64; 3],
        starts: Vec<u32>,
    },
    /// Every entry's packed cell key ([`key`]), ascending.
    Sparse(Vec<u64>),
}

/// A cell coordinate, clamped so that any finite position has a key.
fn coord(x: f32, cell: f32) -> i64 {
    ((x / cell).floor() as i64).clamp(-(1 << 20), (1 << 20) - 1)
}

fn key(c: [i64; 3]) -> u64 {
    let b = |v: i64| ((v + (1 << 20)) as u64) & 0x1F_FFFF;
    (b(c[0]) << 42) | (b(c[1]) << 21) | b(c[2])
}

impl CellIndex {
    /// Indexes `positions` in cells of edge `cell` (the search radius).
    pub fn build(&mut self, positions: &[Vec3], cell: f32) {
        self.cell = cell;
        self.cells.clear();
        self.cells.extend(
            positions
                .iter()
                .map(|p| [coord(p.x, cell), coord(p.y, cell), coord(p.z, cell)]),
        );
        self.index.clear();
        self.lookup = Lookup::Empty;
        if let Some((origin, dims)) = self.dense_box(positions.len()) {
            let linear = |c: &[i64; 3]| {
                (((c[0] - origin[0]) * dims[1] + (c[1] - origin[1])) * dims[2] + (c[2] - origin[2]))
                    as usize
            };
            let mut starts = match std::mem::take(&mut self.lookup) {
                Lookup::Dense { starts, .. } => starts,
                _ => Vec::new(),
            };
            starts.clear();
            starts.resize((dims[0] * dims[1] * dims[2]) as usize + 1, 0);
            for c in &self.cells {
                starts[linear(c) + 1] += 1;
            }
            for k in 1..starts.len() {
                starts[k] += starts[k - 1];
            }
            // Agents in index order into their cells' runs: each run in index order.
            let mut next = starts.clone();
            self.index.resize(positions.len(), 0);
            for (j, c) in self.cells.iter().enumerate() {
                let slot = &mut next[linear(c)];
                self.index[*slot as usize] = j as u32;
                *slot += 1;
            }
            self.lookup = Lookup::Dense {
                origin,
                dims,
                starts,
            };
        } else {
            self.pairs.clear();
            self.pairs.extend(
                self.cells
                    .iter()
                    .enumerate()
                    .map(|(j, &c)| (key(c), j as u32)),
            );
            self.pairs.sort_unstable();
            self.index.extend(self.pairs.iter().map(|e| e.1));
            self.lookup = Lookup::Sparse(self.pairs.iter().map(|e| e.0).collect());
        }
        for (out, axis) in [(&mut self.x, 0), (&mut self.y, 1), (&mut self.z, 2)] {
            out.clear();
            out.extend(self.index.iter().map(|&j| positions[j as usize][axis]));
            out.extend([f32::INFINITY; LANES]);
        }
        // Padded as the positions are (no agent has this index).
        self.index.extend([u32::MAX; LANES]);
    }

    /// The box of the occupied cells, (first cell, cells per axis), when a dense table of
    /// it is small enough for `n` agents.
    fn dense_box(&self, n: usize) -> Option<([i64; 3], [i64; 3])> {
        let first = self.cells.first()?;
        let (mut lo, mut hi) = (*first, *first);
        for c in &self.cells {
            for a in 0..3 {
                lo[a] = lo[a].min(c[a]);
                hi[a] = hi[a].max(c[a]);
            }
        }
        let dims = [0, 1, 2].map(|a| hi[a] - lo[a] + 1);
        let limit = (n * CELLS_PER_AGENT).max(MIN_TABLE) as i64;
        // Each factor is at most 2²¹ (`coord`), so the products cannot overflow i64.
        (dims[0] * dims[1] * dims[2] <= limit).then_some((lo, dims))
    }

    /// The entries of the cells (x, y, z_lo ..= z_hi): one run, as the cells of a row
    /// along z are consecutive in the order.
    #[inline]
    fn row(&self, x: i64, y: i64, z_lo: i64, z_hi: i64) -> std::ops::Range<usize> {
        match &self.lookup {
            Lookup::Empty => 0..0,
            Lookup::Dense {
                origin,
                dims,
                starts,
            } => {
                let (x, y) = (x - origin[0], y - origin[1]);
                let (z_lo, z_hi) = (
                    (z_lo - origin[2]).max(0),
                    (z_hi - origin[2]).min(dims[2] - 1),
                );
                if x < 0 || x >= dims[0] || y < 0 || y >= dims[1] || z_lo > z_hi {
                    return 0..0;
                }
                let c = ((x * dims[1] + y) * dims[2]) as usize;
                starts[c + z_lo as usize] as usize..starts[c + z_hi as usize + 1] as usize
            }
            Lookup::Sparse(keys) => {
                // No cell lies beyond the clamp bounds (`coord`), so the row stops there.
                let lo = key([x, y, z_lo.max(-(1 << 20))]);
                let hi = key([x, y, z_hi.min((1 << 20) - 1)]);
                let start = keys.partition_point(|&k| k < lo);
                start..start + keys[start..].partition_point(|&k| k <= hi)
            }
        }
    }

    /// Calls `f(j, p_j)` for every indexed agent j with r1 ≤ ‖p_j − p‖ < r2 (compared
    /// squared, as (p_j − p)·(p_j − p) ≥ r1² and < r2² in f32) among the 27 cells around
    /// `p`, so every one within one cell edge of it when r2 is at most the edge; in a fixed
    /// order: cell by cell, each in index order, so that sums over them do not depend on
    /// threads. A row of three cells along z is one run, tested [`LANES`] at a time.
    #[inline]
    pub fn for_each_in_shell(&self, p: Vec3, r1: f32, r2: f32, mut f: impl FnMut(usize, Vec3)) {
        self.for_each_batch_in_shell(p, r1, r2, 0.0, |b, mut hits, _| {
            while hits != 0 {
                let l = hits.trailing_zeros() as usize;
                hits &= hits - 1;
                f(b.index[l] as usize, Vec3::new(b.x[l], b.y[l], b.z[l]));
            }
        });
    }

    /// [`Self::for_each_in_shell`] a batch at a time: `f(batch, hits, close)` for every
    /// [`LANES`] entries scanned, bit l of `hits` set where lane l is in the shell, and of
    /// `close` where it is strictly within `r0` (the agent at `p` itself included; lanes
    /// past the run are never set), in the same order. The caller takes the hits without
    /// a branch per hit: a hit or a miss is a coin toss the branch predictor loses (about
    /// one in seven scanned agents is in the shell at the bench's density).
    #[inline(always)]
    pub fn for_each_batch_in_shell(
        &self,
        p: Vec3,
        r1: f32,
        r2: f32,
        r0: f32,
        f: impl FnMut(Batch<'_>, u32, u32),
    ) {
        let c = [p.x, p.y, p.z].map(|x| coord(x, self.cell));
        let radii = [r1, r2, r0].map(|r| r * r);
        self.for_each_batch_in_cells(p, radii, c.map(|c| c - 1), c.map(|c| c + 1), f);
    }

    /// The Eq. 4 neighbours of the agent `exclude` at `p`: the [`Nearest`] strictly within
    /// `r0` (at most one cell edge). Only the cells the sphere of radius r0 reaches are
    /// scanned (one to eight, against Eq. 6's 27).
    pub fn nearest_within(&self, p: Vec3, r0: f32, exclude: usize, nearest: &mut Nearest) {
        let c = [p.x, p.y, p.z].map(|x| coord(x, self.cell));
        let (lo, hi) = (p - Vec3::splat(r0), p + Vec3::splat(r0));
        // Within one cell of p's, however the rounding of p ± r0 falls.
        let lo = [lo.x, lo.y, lo.z].map(|x| coord(x, self.cell));
        let hi = [hi.x, hi.y, hi.z].map(|x| coord(x, self.cell));
        let lo = std::array::from_fn(|a| lo[a].clamp(c[a] - 1, c[a]));
        let hi = std::array::from_fn(|a| hi[a].clamp(c[a], c[a] + 1));
        // An empty shell: only the lanes within r0 (the agent itself too, left out by
        // `take`).
        self.for_each_batch_in_cells(p, [0.0, 0.0, r0 * r0], lo, hi, |b, _, close| {
            nearest.note(self, &b, close, p, exclude);
        });
        nearest.finish(self, p, exclude);
    }

    /// [`Self::for_each_batch_in_shell`] over the cells `lo ..= hi` (per axis), rows along
    /// z in x then y order; `radii` are r1², r2² and r0².
    #[inline(always)]
    fn for_each_batch_in_cells(
        &self,
        p: Vec3,
        radii: [f32; 3],
        lo: [i64; 3],
        hi: [i64; 3],
        mut f: impl FnMut(Batch<'_>, u32, u32),
    ) {
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                let run = self.row(x, y, lo[2], hi[2]);
                for b in run.clone().step_by(LANES) {
                    let (mut hits, mut close) = self.shell_lanes(b, p, radii);
                    if run.end - b < LANES {
                        let within = (1 << (run.end - b)) - 1;
                        (hits, close) = (hits & within, close & within);
                    }
                    f(self.batch(b), hits, close);
                }
            }
        }
    }

    /// The [`LANES`] entries from `b`.
    #[inline(always)]
    fn batch(&self, b: usize) -> Batch<'_> {
        Batch {
            at: b,
            x: self.x[b..b + LANES].try_into().expect("padded"),
            y: self.y[b..b + LANES].try_into().expect("padded"),
            z: self.z[b..b + LANES].try_into().expect("padded"),
            index: self.index[b..b + LANES].try_into().expect("padded"),
        }
    }

    /// Bits l set where entry `b + l` is in the shell r1² ≤ d² < r2², and where d² < r0²
    /// (`radii`), d² the same f32 operations as `q.distance_squared(p)`, (q − p) · (q − p)
    /// summed x, y, z.
    #[inline(always)]
    fn shell_lanes(&self, b: usize, p: Vec3, radii: [f32; 3]) -> (u32, u32) {
        let [near2, far2, close2] = radii;
        let (x, y, z) = (
            &self.x[b..b + LANES],
            &self.y[b..b + LANES],
            &self.z[b..b + LANES],
        );
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE2 is part of x86_64; each load reads 4 floats of a slice of 8.
            unsafe {
                let (px, py, pz) = (_mm_set1_ps(p.x), _mm_set1_ps(p.y), _mm_set1_ps(p.z));
                let (near, far) = (_mm_set1_ps(near2), _mm_set1_ps(far2));
                let close = _mm_set1_ps(close2);
                let (mut hits, mut closer) = (0, 0);
                for h in [0, 4] {
                    let dx = _mm_sub_ps(_mm_loadu_ps(x[h..].as_ptr()), px);
                    let dy = _mm_sub_ps(_mm_loadu_ps(y[h..].as_ptr()), py);
                    let dz = _mm_sub_ps(_mm_loadu_ps(z[h..].as_ptr()), pz);
                    let d2 = _mm_add_ps(
                        _mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                        _mm_mul_ps(dz, dz),
                    );
                    let m = _mm_and_ps(_mm_cmpge_ps(d2, near), _mm_cmplt_ps(d2, far));
                    hits |= (_mm_movemask_ps(m) as u32) << h;
                    closer |= (_mm_movemask_ps(_mm_cmplt_ps(d2, close)) as u32) << h;
                }
                (hits, closer)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let (mut hits, mut closer) = (0, 0);
            for l in 0..LANES {
                let (dx, dy, dz) = (x[l] - p.x, y[l] - p.y, z[l] - p.z);
                let d2 = dx * dx + dy * dy + dz * dz;
                hits |= u32::from(d2 >= near2 && d2 < far2) << l;
                closer |= u32::from(d2 < close2) << l;
            }
            (hits, closer)
        }
    }
}

/// `n` points drawn evenly in the box of half-extents `half` about the origin (tests).
#[cfg(test)]
pub(crate) fn cloud(seed: u64, n: usize, half: Vec3) -> Vec<Vec3> {
    let mut rng = crate::math::Rng::new(seed, 0, 0);
    (0..n)
        .map(|_| {
            Vec3::new(
                rng.range(-half.x, half.x),
                rng.range(-half.y, half.y),
                rng.range(-half.z, half.z),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_exactly_what_brute_force_finds_within_a_cell_edge() {
        let pts = cloud(7, 500, Vec3::splat(1.0));
        let mut idx = CellIndex::default();
        idx.build(&pts, 0.3);
        for &p in &pts[..50] {
            let mut got = Vec::new();
            idx.for_each_in_shell(p, 0.08, 0.3, |j, q| {
                assert_eq!(q, pts[j]);
                got.push(j)
            });
            got.sort_unstable();
            let want: Vec<usize> = (0..pts.len())
                .filter(|&j| (0.08 * 0.08..0.3 * 0.3).contains(&pts[j].distance_squared(p)))
                .collect();
            assert_eq!(got, want);
        }
    }

    #[test]
    fn the_dense_table_and_the_sorted_keys_visit_in_the_same_order() {
        // One agent 1 km away makes the box of occupied cells too large for a table, so
        // the second index falls back to sorted keys; every query visits the same
        // agents in the same order (what keeps Eq. 6's float sums identical).
        let mut pts = cloud(11, 400, Vec3::new(1.0, 0.5, 1.0));
        let (mut dense, mut sparse) = (CellIndex::default(), CellIndex::default());
        dense.build(&pts, 0.3);
        pts.push(Vec3::splat(1000.0));
        sparse.build(&pts, 0.3);
        assert!(matches!(dense.lookup, Lookup::Dense { .. }));
        assert!(matches!(sparse.lookup, Lookup::Sparse(_)));
        for &p in &pts[..100] {
            let visit = |idx: &CellIndex| {
                let mut order = Vec::new();
                idx.for_each_in_shell(p, 0.05, 0.3, |j, _| order.push(j));
                order
            };
            let order = visit(&dense);
            assert!(!order.is_empty());
            assert_eq!(order, visit(&sparse));
        }
    }

    #[test]
    fn nearest_within_keeps_the_k_nearest_as_brute_force_does() {
        // A cloud dense enough that some agents have more than k within the larger radius.
        let pts = cloud(13, 400, Vec3::new(0.4, 0.3, 0.4));
        let mut idx = CellIndex::default();
        idx.build(&pts, 0.3);
        let (mut capped, mut some) = (0, 0);
        for (i, &p) in pts.iter().enumerate() {
            for r0 in [0.05, 0.12, 0.2, 0.3] {
                let mut want: Vec<(f32, u32)> = (0..pts.len())
                    .filter(|&j| j != i && pts[j].distance_squared(p) < r0 * r0)
                    .map(|j| (pts[j].distance_squared(p), j as u32))
                    .collect();
                want.sort_by(|a, b| a.partial_cmp(b).unwrap());
                let crowd = want.len() > MAX_NEIGHBOURS;
                want.truncate(MAX_NEIGHBOURS);
                let mut near = Nearest::default();
                idx.nearest_within(p, r0, i, &mut near);
                let got: Vec<(f32, u32)> = (0..near.n)
                    .map(|k| {
                        assert_eq!(near.pos[k], pts[near.index[k] as usize]);
                        (near.pos[k].distance_squared(p), near.index[k])
                    })
                    .collect();
                if crowd {
                    // More than k that close: the k nearest, nearest first.
                    assert_eq!(got, want, "agent {i}, r0 {r0}");
                    capped += 1;
                } else {
                    // Fewer: all of them, in the scan's order.
                    let mut sorted = got.clone();
                    sorted.sort_by(|a, b| a.partial_cmp(b).unwrap());
                    assert_eq!(sorted, want, "agent {i}, r0 {r0}");
                    some += usize::from(!got.is_empty());
                }
            }
        }
        assert!(
            capped > 100 && some > 500,
            "{capped} capped, {some} with some"
        );
    }
}
