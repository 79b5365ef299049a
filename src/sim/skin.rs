//! Neighbour candidates reused over substeps (Verlet lists with a skin).
//!
//! An agent's neighbour list is the (at most) `k = MAX_NEIGHBOURS` agents nearest it
//! strictly within its radius R, ties broken by id, kept in increasing id order
//! (docs/model.md, "Bounded neighbours"; an agent's id is its place in the shot, its index
//! where the world stores it, `crate::model::Context::id`). Agents move a few millimetres per substep and R
//! is 0.15–0.3 m, so the grid query that finds them (most of the gather pass) mostly finds
//! the same agents again. At a rebuild each agent keeps, besides its list, every agent
//! within
//!
//! ```text
//! L = min(R, d_k + σ) + σ        (d_k: its k-th nearest distance then, R if fewer than k)
//! ```
//!
//! and until the next rebuild picks its list from those candidates alone, at their current
//! positions. **Why that is exact**: while every agent has moved at most σ/2 since the
//! rebuild, the distance between any two has changed by at most σ (triangle inequality,
//! σ/2 for each end). Now, (i) its k old nearest are still within d_k + σ, so if it had k
//! the k nearest now lie within d_k + σ; (ii) every agent within R now lies within R.
//! Both say the new list lies within min(R, d_k + σ) now, hence within L at the rebuild:
//! among the candidates. The world checks the largest displacement since the rebuild
//! every substep (a maximum over agents: the same whatever the thread count) and rebuilds
//! (grid and lists) as soon as twice it exceeds σ; also at the first substep of every
//! frame (so a run resumed from a checkpoint, taken between frames, steps exactly as one
//! that was not), when an agent is placed or restored, and when an agent went into or came
//! out of its hive (`Agent::hidden`: the grid leaves hidden agents out). Floating-point
//! rounding of the distances (a few units in the last place) is covered by a relative
//! slack of 1e-5 on L.
//!
//! A list picked from candidates is the list the grid would find (ties aside: the grid
//! breaks an exact tie at the k-th distance by its walk order, this by id), in the same
//! id order, so every sum over neighbours is the same bit for bit whether the list was
//! found afresh or reused (`reused_lists_step_exactly_as_fresh_ones`).
//!
//! An agent with more than [`MAX_CANDIDATES`] within L (a crowd: at 100,000 per m³ d_k is
//! 34 mm and a skin of a few centimetres holds hundreds) keeps none and is queried afresh
//! every substep, on a grid then rebuilt every substep.

use crate::geometry::{Found, Grid};
use crate::model::context::{MAX_NEIGHBOURS, NeighbourList};
use glam::Vec3;

/// The most candidates an agent keeps. At the default spawn density (500 per m³, about 7
/// within a bee's radius) a bee keeps about 15–20.
pub const MAX_CANDIDATES: usize = 48;

/// A rebuild's first search (everything within R + σ) gives up past this many: the size
/// of the scratch buffer [`build`] takes.
pub const SCRATCH: usize = 128;

/// Relative slack on L for floating-point rounding.
const SLACK: f32 = 1e-5;

/// The candidates' radius L for an agent of radius `radius` whose k-th nearest lies at
/// `kth` (`radius` if it has fewer than k), with skin `sigma`.
#[inline]
pub fn limit(radius: f32, kth: f32, sigma: f32) -> f32 {
    (radius.min(kth + sigma) + sigma) * (1.0 + SLACK)
}

/// Sorting key of a candidate: squared distance, then id (non-negative floats order as
/// their bits do).
#[inline(always)]
fn key(id: u32, d2: f32) -> u64 {
    ((d2.to_bits() as u64) << 32) | id as u64
}

/// The k-th smallest key of `found`'s entries strictly within `r2` (more than k of
/// them; any order): the k smallest so far, and the largest of those, replaced while a
/// nearer one comes (a selection over all of them cost zonal's rebuilds more). `ids`:
/// every agent's id by index.
fn kth_key(found: &[(u32, f32)], r2: f32, ids: &[u32]) -> u64 {
    let mut best = [u64::MAX; MAX_NEIGHBOURS];
    let (mut n, mut worst, mut at) = (0, u64::MAX, 0);
    for &(j, d2) in found {
        if d2 >= r2 {
            continue;
        }
        let k = key(ids[j as usize], d2);
        if n < MAX_NEIGHBOURS {
            best[n] = k;
            n += 1;
            if n < MAX_NEIGHBOURS {
                continue;
            }
        } else if k < worst {
            best[at] = k;
        } else {
            continue;
        }
        (at, worst) = best
            .iter()
            .enumerate()
            .fold((0, 0), |m, (t, &b)| if b > m.1 { (t, b) } else { m });
    }
    worst
}

/// Lists into `list` the (at most) `MAX_NEIGHBOURS` of `found` (indices with squared
/// distances, in increasing id order) nearest strictly within `radius`, ties broken by
/// id, in `found`'s order; returns the k-th nearest distance (`radius` if fewer than k
/// were within it).
#[inline(always)]
fn pick(found: &[(u32, f32)], radius: f32, ids: &[u32], list: &mut NeighbourList) -> f32 {
    let r2 = radius * radius;
    let mut m = 0;
    let mut far = 0.0f32;
    list.clear();
    for &(j, d2) in found {
        if d2 < r2 {
            if m < MAX_NEIGHBOURS {
                list.push(j);
            }
            m += 1;
            far = far.max(d2);
        }
    }
    if m < MAX_NEIGHBOURS {
        radius
    } else if m == MAX_NEIGHBOURS {
        far.sqrt()
    } else {
        // More than k within the radius (a denser spot): those up to the k-th key.
        let kth = kth_key(found, r2, ids);
        list.clear();
        for &(j, d2) in found {
            if d2 < r2 && key(ids[j as usize], d2) <= kth {
                list.push(j);
            }
        }
        f32::from_bits((kth >> 32) as u32).sqrt()
    }
}

/// A substep after a rebuild: `list` from agent candidates `cands` (in increasing id
/// order) at their current `positions`, for an agent at `p` of radius `radius`.
#[inline]
pub fn reselect(
    cands: &[u32],
    positions: &[Vec3],
    ids: &[u32],
    p: Vec3,
    radius: f32,
    list: &mut NeighbourList,
) {
    let mut found = [(0u32, 0.0f32); MAX_CANDIDATES];
    for (f, &j) in found.iter_mut().zip(cands) {
        // The grid's arithmetic: (q - p)², summed x, y, z (negation is exact).
        *f = (j, p.distance_squared(positions[j as usize]));
    }
    pick(&found[..cands.len()], radius, ids, list);
}

/// A rebuild (the grid built over `positions`; `ids`: every agent's id by index): lists
/// agent `me`'s neighbours (at `p`, radius `radius`) into `list` and appends its
/// candidates for skin `sigma` to `out`, in increasing id order; false if it has more than [`MAX_CANDIDATES`] (nothing
/// appended: it is queried afresh). `scratch` holds [`SCRATCH`] entries (its contents are
/// not read).
#[allow(clippy::too_many_arguments)]
pub fn build(
    grid: &Grid,
    positions: &[Vec3],
    ids: &[u32],
    p: Vec3,
    me: usize,
    radius: f32,
    sigma: f32,
    list: &mut NeighbourList,
    out: &mut Vec<u32>,
    scratch: &mut [(u32, f32)],
) -> bool {
    // Where the grid's cells are as large as R (a sparse cloud), one search out to R + σ
    // gives the k-th distance and the candidates (then the list, from those); in a crowd
    // that sphere holds thousands, so the list comes from the grid's own k-nearest walk
    // and the candidates, if few enough are expected, from a second search out to L.
    // (Choosing the second way wherever more than about k lie within R, from the local
    // density, cost zonal's midges 3 % more: callgrind, `bench --model zonal`.)
    let r2 = radius * radius;
    let found = if grid.cell() >= radius
        && let Some(n) = grid.within(p, radius + sigma, me, scratch)
    {
        let found = &mut scratch[..n];
        let m = found.iter().filter(|f| f.1 < r2).count();
        let kth = match m {
            m if m < MAX_NEIGHBOURS => radius,
            MAX_NEIGHBOURS => found
                .iter()
                .filter(|f| f.1 < r2)
                .fold(0.0f32, |a, f| a.max(f.1))
                .sqrt(),
            _ => f32::from_bits((kth_key(found, r2, ids) >> 32) as u32).sqrt(),
        };
        let l = limit(radius, kth, sigma);
        let l2 = l * l;
        // The candidates, moved to the front.
        let mut kept = 0;
        for t in 0..n {
            if found[t].1 < l2 {
                found.swap(kept, t);
                kept += 1;
            }
        }
        if kept > MAX_CANDIDATES {
            // Too many to keep: the list alone, from everything found.
            found.sort_unstable_by_key(|f| ids[f.0 as usize]);
            pick(found, radius, ids, list);
            return false;
        }
        &mut found[..kept]
    } else {
        list.fill(grid, p, radius, me, &mut Found::default());
        list.sort(ids);
        let n = list.indices().len();
        let kth = if n == MAX_NEIGHBOURS {
            list.indices()
                .iter()
                .map(|&j| p.distance_squared(positions[j as usize]))
                .fold(0.0f32, f32::max)
                .sqrt()
        } else {
            radius
        };
        let l = limit(radius, kth, sigma);
        // Expected within L at a uniform density like that within kth.
        if n as f32 * (l / kth).powi(3) > 1.5 * MAX_CANDIDATES as f32 {
            return false;
        }
        match grid.within(p, l, me, &mut scratch[..MAX_CANDIDATES]) {
            Some(n) => &mut scratch[..n],
            None => return false,
        }
    };
    // Insertion sort by id: a few dozen at most.
    for i in 1..found.len() {
        let v = found[i];
        let mut j = i;
        while j > 0 && ids[found[j - 1].0 as usize] > ids[v.0 as usize] {
            found[j] = found[j - 1];
            j -= 1;
        }
        found[j] = v;
    }
    pick(found, radius, ids, list);
    out.extend(found.iter().map(|f| f.0));
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    use crate::math::random_cloud as cloud;

    /// The set of agent `i`'s neighbours the grid finds afresh, in id order.
    fn fresh(pts: &[Vec3], ids: &[u32], i: usize, radius: f32) -> (Vec<u32>, bool) {
        let mut g = Grid::default();
        g.build(pts, radius);
        let mut list = NeighbourList::default();
        list.fill(&g, pts[i], radius, i, &mut Found::default());
        list.sort(ids);
        // A tie at the k-th distance: either choice is right.
        let r2 = radius * radius;
        let mut d: Vec<f32> = (0..pts.len())
            .filter(|&j| j != i)
            .map(|j| pts[i].distance_squared(pts[j]))
            .filter(|&d2| d2 < r2)
            .collect();
        d.sort_by(f32::total_cmp);
        let tie = d.len() > MAX_NEIGHBOURS && d[MAX_NEIGHBOURS - 1] == d[MAX_NEIGHBOURS];
        (list.indices().to_vec(), tie)
    }

    #[test]
    fn lists_picked_from_candidates_equal_fresh_ones_while_agents_stay_within_the_skin() {
        // A sparse cloud (fewer than k within R), a denser one (k within R) and a crowd
        // (most agents keep no candidates); every agent moves randomly, in total at most
        // σ/2 from where the candidates were kept. Ids run against the indices (as for
        // agents stored in cell order), so that ordering by index would fail.
        let mut rng = Rng::new(7, 1, 2);
        for (n, half, radius, sigma) in [
            (1500, 1.0, 0.2, 0.04),
            (1500, 0.4, 0.2, 0.03),
            (3000, 0.1, 0.15, 0.01),
        ] {
            let mut pts = cloud(&mut rng, n, half);
            let ids: Vec<u32> = (0..n as u32).rev().collect();
            let mut g = Grid::default();
            g.build(&pts, radius);
            let mut out = Vec::new();
            let mut ranges = Vec::new();
            let mut scratch = vec![(0u32, 0.0f32); SCRATCH];
            let mut kept = 0;
            for i in 0..n {
                let mut list = NeighbourList::default();
                let before = out.len();
                let ok = build(
                    &g,
                    &pts,
                    &ids,
                    pts[i],
                    i,
                    radius,
                    sigma,
                    &mut list,
                    &mut out,
                    &mut scratch,
                );
                ranges.push(ok.then_some(before..out.len()));
                kept += ok as usize;
                let (want, tie) = fresh(&pts, &ids, i, radius);
                if !tie {
                    assert_eq!(list.indices(), &want[..], "rebuild, agent {i}");
                }
            }
            assert!(kept > 0, "some agents keep candidates ({n} in {half} m)");
            let start = pts.clone();
            for step in 0..4 {
                for (p, s) in pts.iter_mut().zip(&start) {
                    // A random walk, clamped to σ/2 from the start.
                    let d = *p + cloud(&mut rng, 1, sigma * 0.3)[0] - *s;
                    *p = *s + d.clamp_length_max(sigma * 0.5 * 0.999);
                }
                for i in 0..n {
                    let Some(r) = ranges[i].clone() else { continue };
                    let mut list = NeighbourList::default();
                    reselect(&out[r], &pts, &ids, pts[i], radius, &mut list);
                    let (want, tie) = fresh(&pts, &ids, i, radius);
                    if !tie {
                        assert_eq!(
                            list.indices(),
                            &want[..],
                            "step {step}, agent {i} ({n} in {half} m)"
                        );
                    }
                }
            }
        }
    }
}
