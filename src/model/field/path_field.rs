//! Paper 001's global path field, Eqs. 4–8: a grid of cells over the domain, each with the
//! cost of flying through it (path length plus repulsion near obstacles), a minimum-cost
//! field C solved from the goals by fast marching, and the direction −∇C/|∇C| agents fly.
//!
//! Metres; the lattice's cells are cubes of side l, centres at origin + (i + ½) l.

use crate::geometry::{self, Shape};
use glam::Vec3;
use rayon::prelude::*;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The regular grid of the path field: the domain box cut into cubes of side `cell`.
#[derive(Clone, Debug, PartialEq)]
pub struct Lattice {
    /// Minimum corner of the domain, m.
    pub origin: Vec3,
    /// Side l of a cell, m.
    pub cell: f32,
    /// Cells along x, y, z.
    pub dims: [usize; 3],
}

impl Lattice {
    /// Cells of side `cell` (m) covering the box (centre, half extents); `cell` grows if
    /// the grid would have more than `max_cells` cells.
    pub fn over(center: Vec3, half: Vec3, cell: f32, max_cells: usize) -> Self {
        let size = half * 2.0;
        let mut cell = cell;
        loop {
            let dims = [0, 1, 2].map(|a| ((size[a] / cell).ceil() as usize).max(1));
            if dims[0] * dims[1] * dims[2] <= max_cells {
                return Lattice {
                    origin: center - half,
                    cell,
                    dims,
                };
            }
            cell *= 1.05;
        }
    }

    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    #[inline]
    pub fn coords(&self, idx: usize) -> [usize; 3] {
        let i = idx % self.dims[0];
        let j = (idx / self.dims[0]) % self.dims[1];
        [i, j, idx / (self.dims[0] * self.dims[1])]
    }

    #[inline]
    pub fn center(&self, idx: usize) -> Vec3 {
        let [i, j, k] = self.coords(idx);
        self.origin + (Vec3::new(i as f32, j as f32, k as f32) + 0.5) * self.cell
    }

    /// The 6-connected neighbours of a cell: (axis, side, index), side −1 or +1.
    #[inline]
    fn neighbours(&self, idx: usize) -> impl Iterator<Item = (usize, i32, usize)> + '_ {
        let c = self.coords(idx);
        let strides = [1, self.dims[0], self.dims[0] * self.dims[1]];
        (0..3).flat_map(move |a| {
            [-1i32, 1].into_iter().filter_map(move |s| {
                let x = c[a] as i64 + s as i64;
                (x >= 0 && (x as usize) < self.dims[a]).then(|| {
                    let n = if s < 0 {
                        idx - strides[a]
                    } else {
                        idx + strides[a]
                    };
                    (a, s, n)
                })
            })
        })
    }

    /// Trilinear weights of `p`: the eight corner cells and their weights (points beyond
    /// the outer cell centres clamp to them).
    #[inline]
    fn corners(&self, p: Vec3) -> [(usize, f32); 8] {
        let u = (p - self.origin) / self.cell - 0.5;
        let mut base = [0usize; 3];
        let mut frac = [0.0f32; 3];
        for a in 0..3 {
            let hi = self.dims[a] - 1;
            let x = u[a].clamp(0.0, hi as f32);
            let i = (x as usize).min(hi.saturating_sub(1));
            base[a] = i;
            frac[a] = if hi == 0 { 0.0 } else { x - i as f32 };
        }
        let step = |a: usize, b: usize| if b == 1 && self.dims[a] > 1 { 1 } else { 0 };
        std::array::from_fn(|c| {
            let (bx, by, bz) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
            let idx = self.index(
                base[0] + step(0, bx),
                base[1] + step(1, by),
                base[2] + step(2, bz),
            );
            let w = (if bx == 1 { frac[0] } else { 1.0 - frac[0] })
                * (if by == 1 { frac[1] } else { 1.0 - frac[1] })
                * (if bz == 1 { frac[2] } else { 1.0 - frac[2] });
            (idx, w)
        })
    }
}

/// Eq. 6, the bell-shaped repulsion h(r) = 1 − 4/9 r⁶ + 17/9 r⁴ − 22/9 r² on [0, 1]: 1 inside
/// an obstacle (r < 0), 0 beyond r = 1.
#[inline]
pub fn repulsion(r: f32) -> f32 {
    if r < 0.0 {
        1.0
    } else if r > 1.0 {
        0.0
    } else {
        let r2 = r * r;
        1.0 - r2 * (22.0 / 9.0 - r2 * (17.0 / 9.0 - r2 * (4.0 / 9.0)))
    }
}

/// The static part of the path field (Sec. 5.1): per cell, whether its centre lies inside
/// an obstacle, and the cost of flying through it, A + B g with g = h(f / 2a) of Eqs. 5–6
/// and a = √3 l, the cell's diagonal.
#[derive(Clone, Debug)]
pub struct CostMap {
    pub lattice: Lattice,
    /// Cost per metre, A + B g (Eq. 4's integrand); infinite in obstacle cells.
    density: Vec<f32>,
    /// Outward normal of the nearest obstacle, for cells inside one (zero elsewhere).
    normal: Vec<Vec3>,
}

impl CostMap {
    /// Eqs. 5–6 on every cell of `lattice`, with Eq. 4's weights `a_len` (A) and `b_rep` (B).
    pub fn new(lattice: Lattice, obstacles: &[Shape], a_len: f32, b_rep: f32) -> Self {
        let band = 2.0 * 3f32.sqrt() * lattice.cell; // 2a
        let cells: Vec<(f32, Vec3)> = (0..lattice.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|idx| {
                let c = lattice.center(idx);
                let mut f = f32::INFINITY;
                let mut n = Vec3::ZERO;
                for o in obstacles {
                    let q = geometry::query(o, c);
                    if q.distance < f {
                        f = q.distance;
                        n = q.normal;
                    }
                }
                if f < 0.0 {
                    (f32::INFINITY, n)
                } else {
                    (a_len + b_rep * repulsion(f / band), Vec3::ZERO)
                }
            })
            .collect();
        let (density, normal) = cells.into_iter().unzip();
        CostMap {
            lattice,
            density,
            normal,
        }
    }

    /// Whether a cell's centre lies inside an obstacle.
    #[inline]
    pub fn blocked(&self, idx: usize) -> bool {
        self.density[idx].is_infinite()
    }

    /// Bytes held per cell by the map and a solved field.
    pub const BYTES_PER_CELL: usize = 4 + 12 + 4 + 12;
}

/// The minimum-cost field C (Eq. 7) and the unit directions −∇C/|∇C| (Eq. 8) of one set of
/// goals.
#[derive(Clone, Debug)]
pub struct PathField {
    pub lattice: Lattice,
    /// C per cell (Eq. 4's units: A × metres of free flight), infinite where no path leads.
    cost: Vec<f32>,
    /// −∇C/|∇C| per free cell; zero in goal cells and unreachable ones; an obstacle
    /// cell holds the obstacle's outward normal, so flight near a wall is turned away.
    dir: Vec<Vec3>,
}

impl PathField {
    /// Fast marching (first order, Sethian 1996) from every free cell whose centre lies
    /// within `goal_radius` of a goal (or, if none does, the free cell nearest each goal),
    /// through free cells, each costing its `density` per metre.
    pub fn solve(map: &CostMap, goals: &[Vec3], goal_radius: f32) -> Self {
        let lat = &map.lattice;
        let n = lat.len();
        let mut c = vec![f64::INFINITY; n];
        let mut done = vec![false; n];
        let mut heap = BinaryHeap::new();
        let mut seeded = false;
        // Cells within two cells of a goal area start at their straight-line cost (its
        // density times the distance to the area's edge), so that the marching front
        // starts as a smooth sphere, not a voxel staircase: first-order fast marching
        // from a point is several per cent off along diagonals otherwise.
        let band = goal_radius + 2.0 * lat.cell;
        for (idx, ci) in c.iter_mut().enumerate() {
            if map.blocked(idx) {
                continue;
            }
            let p = lat.center(idx);
            let d = goals
                .iter()
                .map(|g| g.distance(p))
                .fold(f32::INFINITY, f32::min);
            if d <= goal_radius {
                *ci = 0.0;
                seeded = true;
            } else if d <= band {
                *ci = (map.density[idx] * (d - goal_radius)) as f64;
                seeded = true;
            } else {
                continue;
            }
            heap.push(Reverse((ci.to_bits(), idx as u32)));
        }
        if !seeded {
            for g in goals {
                let best = (0..n).filter(|&i| !map.blocked(i)).min_by(|&a, &b| {
                    lat.center(a)
                        .distance_squared(*g)
                        .total_cmp(&lat.center(b).distance_squared(*g))
                });
                if let Some(i) = best {
                    c[i] = 0.0;
                    heap.push(Reverse((0u64, i as u32)));
                }
            }
        }
        let h = lat.cell as f64;
        while let Some(Reverse((bits, idx))) = heap.pop() {
            let idx = idx as usize;
            if done[idx] || f64::from_bits(bits) > c[idx] {
                continue;
            }
            done[idx] = true;
            for (_, _, nb) in lat.neighbours(idx) {
                if done[nb] || map.blocked(nb) {
                    continue;
                }
                let t = update(lat, &c, &done, nb, map.density[nb] as f64 * h);
                if t < c[nb] {
                    c[nb] = t;
                    // Ties pop in index order: the result never depends on anything else.
                    heap.push(Reverse((t.to_bits(), nb as u32)));
                }
            }
        }
        let cost: Vec<f32> = c.iter().map(|&x| x as f32).collect();
        let dir = (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .map(|idx| {
                if map.blocked(idx) {
                    return map.normal[idx];
                }
                let ci = cost[idx];
                if ci == 0.0 || !ci.is_finite() {
                    return Vec3::ZERO;
                }
                // Upwind differences, the fast marching scheme's own: towards the cheaper
                // neighbour on each axis.
                let mut grad = Vec3::ZERO;
                let mut lo = [f32::INFINITY; 3];
                let mut hi = [f32::INFINITY; 3];
                for (a, s, nb) in lat.neighbours(idx) {
                    if s < 0 {
                        lo[a] = cost[nb];
                    } else {
                        hi[a] = cost[nb];
                    }
                }
                for a in 0..3 {
                    if lo[a] <= hi[a] && lo[a] < ci {
                        grad[a] = (ci - lo[a]) / lat.cell;
                    } else if hi[a] < ci {
                        grad[a] = (hi[a] - ci) / lat.cell;
                    }
                }
                -grad.normalize_or_zero()
            })
            .collect();
        PathField {
            lattice: lat.clone(),
            cost,
            dir,
        }
    }

    /// The interpolated direction (length ≤ 1: it fades to zero across the goal's edge)
    /// and cost C at `p`; the cost is −1 where no corner cell has a path.
    #[inline]
    pub fn sample(&self, p: Vec3) -> (Vec3, f32) {
        let mut dir = Vec3::ZERO;
        let (mut cost, mut w_sum) = (0.0f32, 0.0f32);
        for (idx, w) in self.lattice.corners(p) {
            dir += self.dir[idx] * w;
            let c = self.cost[idx];
            if c.is_finite() && w > 0.0 {
                cost += c * w;
                w_sum += w;
            }
        }
        let cost = if w_sum > 1e-6 { cost / w_sum } else { -1.0 };
        (dir, cost)
    }

    /// C of a cell.
    pub fn cost(&self, idx: usize) -> f32 {
        self.cost[idx]
    }

    /// The unit direction stored at a cell.
    pub fn direction(&self, idx: usize) -> Vec3 {
        self.dir[idx]
    }
}

/// The first-order upwind solution of |∇C| = F at cell `idx` (F h = `fh`) from its
/// accepted neighbours.
fn update(lat: &Lattice, c: &[f64], done: &[bool], idx: usize, fh: f64) -> f64 {
    let mut m = [f64::INFINITY; 3];
    for (a, _, nb) in lat.neighbours(idx) {
        if done[nb] && c[nb] < m[a] {
            m[a] = c[nb];
        }
    }
    m.sort_by(f64::total_cmp);
    let mut t = m[0] + fh;
    if t > m[1] {
        let disc = 2.0 * fh * fh - (m[0] - m[1]).powi(2);
        if disc >= 0.0 {
            t = (m[0] + m[1] + disc.sqrt()) / 2.0;
            if t > m[2] {
                let s = m[0] + m[1] + m[2];
                let q = m[0] * m[0] + m[1] * m[1] + m[2] * m[2];
                let disc = s * s - 3.0 * (q - fh * fh);
                if disc >= 0.0 {
                    t = (s + disc.sqrt()) / 3.0;
                }
            }
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    #[test]
    fn the_repulsion_bell_runs_from_one_to_zero() {
        assert_eq!(repulsion(-0.1), 1.0);
        assert!((repulsion(0.0) - 1.0).abs() < 1e-6);
        assert!((repulsion(0.5) - 0.5).abs() < 1e-6);
        assert!(repulsion(1.0).abs() < 1e-6);
        assert_eq!(repulsion(1.5), 0.0);
    }

    #[test]
    fn fast_marching_in_an_empty_box_is_within_a_few_percent_of_the_distance() {
        let lat = Lattice::over(Vec3::ZERO, Vec3::splat(2.0), 0.1, 1 << 24);
        let map = CostMap::new(lat.clone(), &[], 0.6, 0.4);
        let goal = Vec3::new(-1.0, 0.3, 0.2);
        let f = PathField::solve(&map, &[goal], 0.25);
        let mut worst = 0.0f32;
        let mut sum = 0.0f32;
        let mut k = 0;
        for idx in 0..lat.len() {
            let d = lat.center(idx).distance(goal) - 0.25;
            if d > 0.5 {
                let err = (f.cost(idx) / 0.6 - d).abs() / d;
                worst = worst.max(err);
                sum += err;
                k += 1;
            }
        }
        println!(
            "fast marching, empty 4 m box, l = 0.1 m: C/A vs distance, mean error {:.2} %, largest {:.2} % over {k} cells",
            100.0 * sum / k as f32,
            100.0 * worst
        );
        assert!(worst < 0.08, "largest relative error {worst}");
        assert!(sum / (k as f32) < 0.04);
    }

    fn blocks() -> (CostMap, Vec3) {
        let lat = Lattice::over(
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(3.0, 2.0, 5.6),
            0.1,
            1 << 24,
        );
        let obstacles = [
            Shape::Box {
                center: Vec3::new(-1.8, 1.5, 0.0),
                half: Vec3::new(1.4, 1.5, 1.0),
                rotation: Quat::IDENTITY,
            },
            Shape::Box {
                center: Vec3::new(1.8, 1.5, 0.0),
                half: Vec3::new(1.4, 1.5, 1.0),
                rotation: Quat::IDENTITY,
            },
            Shape::Sphere {
                center: Vec3::new(0.0, 3.0, 3.0),
                radius: 0.6,
            },
        ];
        (
            CostMap::new(lat, &obstacles, 0.6, 0.4),
            Vec3::new(0.0, 2.0, 4.6),
        )
    }

    #[test]
    fn following_the_path_field_reaches_the_goal_from_every_free_cell() {
        let (map, goal) = blocks();
        let f = PathField::solve(&map, &[goal], 0.5);
        let lat = &map.lattice;
        let (mut free, mut reached) = (0, 0);
        let mut unreached = Vec::new();
        // Stream lines of the interpolated direction field, as agents fly it.
        for idx in (0..lat.len()).step_by(7) {
            if map.blocked(idx) {
                continue;
            }
            free += 1;
            let mut p = lat.center(idx);
            let mut ok = false;
            for _ in 0..4000 {
                if p.distance(goal) <= 0.5 + lat.cell {
                    ok = true;
                    break;
                }
                let (d, _) = f.sample(p);
                p += d.normalize_or_zero() * (0.25 * lat.cell);
            }
            if ok {
                reached += 1;
            } else {
                unreached.push(lat.center(idx));
            }
        }
        println!("path field: {reached} of {free} sampled free cells reach the goal along −∇C");
        assert!(free > 10_000);
        assert_eq!(
            reached,
            free,
            "stuck from {:?}",
            &unreached[..unreached.len().min(5)]
        );
    }

    #[test]
    fn paths_avoid_obstacles_and_cost_grows_near_them() {
        let (map, goal) = blocks();
        let f = PathField::solve(&map, &[goal], 0.5);
        let lat = &map.lattice;
        // Every cell's cost exceeds A × its straight distance to the goal's edge.
        for idx in 0..lat.len() {
            if !map.blocked(idx) {
                let d = (lat.center(idx).distance(goal) - 0.5).max(0.0);
                assert!(f.cost(idx) >= 0.6 * d * 0.97, "{idx}");
            }
        }
        // Behind a block (x = −1.75, z = −3.55), the way round it is longer than the
        // straight line through it.
        let behind = lat.index(12, 15, 20);
        let c = lat.center(behind);
        let straight = 0.6 * (c.distance(goal) - 0.5);
        println!(
            "behind a block: C {:.3} vs straight {straight:.3}",
            f.cost(behind)
        );
        assert!(f.cost(behind) > straight * 1.02);
    }
}
