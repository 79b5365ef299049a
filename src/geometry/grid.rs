//! Uniform-grid neighbour search. Paper 000 (Sec. V-B) accelerates it with a spatial hash;
//! a dense grid over the swarm's bounding box does the same job with fewer instructions
//! (no hashing, no bucket collisions to filter).
//!
//! Bee indices are counting-sorted by cell in increasing index order, so neighbour
//! iteration order — and with it every floating-point sum — is the same whatever the
//! number of threads. A query visits 9 rows of 3 adjacent cells, each one contiguous run
//! of the sorted array.

use glam::{IVec3, Vec3};

#[derive(Clone, Debug, Default)]
pub struct Grid {
    origin: Vec3,
    inv_cell: f32,
    dims: IVec3,
    /// `starts[c]..starts[c + 1]` indexes `items` for cell c.
    starts: Vec<u32>,
    items: Vec<u32>,
    /// Positions in `items` order, so candidate tests read one contiguous array.
    sorted: Vec<Vec3>,
    cells: Vec<u32>,
}

impl Grid {
    /// Cell coordinates of `p`, clamped into the grid (points outside the bounding box of
    /// the last build land in the border cells, which keeps queries valid).
    #[inline]
    fn cell_of(&self, p: Vec3) -> IVec3 {
        let c = ((p - self.origin) * self.inv_cell).floor();
        let max = (self.dims - IVec3::ONE).as_vec3();
        c.clamp(Vec3::ZERO, max).as_ivec3()
    }

    #[inline]
    fn index(&self, c: IVec3) -> usize {
        (c.x + self.dims.x * (c.y + self.dims.y * c.z)) as usize
    }

    /// Rebuilds the grid over `positions`; cells are at least `min_cell` metres (the
    /// interaction radius) and grow when the swarm is spread so widely that the grid would
    /// need more than about 8 cells per bee.
    pub fn build(&mut self, positions: &[Vec3], min_cell: f32) {
        use rayon::prelude::*;
        let n = positions.len();
        let empty = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        let (lo, hi) = positions
            .par_iter()
            .fold(|| empty, |(a, b), p| (a.min(*p), b.max(*p)))
            .reduce(|| empty, |(a, b), (c, d)| (a.min(c), b.max(d)));
        let (lo, hi) = if n == 0 {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        };
        let extent = (hi - lo).max(Vec3::splat(1e-6));
        let budget = (8 * n).max(32_768) as f32;
        let volume_cells =
            (extent.x / min_cell + 1.0) * (extent.y / min_cell + 1.0) * (extent.z / min_cell + 1.0);
        let cell = if volume_cells > budget {
            min_cell * (volume_cells / budget).cbrt() * 1.01
        } else {
            min_cell
        };
        self.origin = lo;
        self.inv_cell = 1.0 / cell;
        self.dims = ((extent / cell).floor().as_ivec3() + IVec3::ONE).max(IVec3::ONE);
        let total = (self.dims.x * self.dims.y * self.dims.z) as usize;

        let cells: Vec<u32> = positions
            .par_iter()
            .map(|p| self.index(self.cell_of(*p)) as u32)
            .collect();
        self.cells = cells;
        self.starts.clear();
        self.starts.resize(total + 1, 0);
        for &c in &self.cells {
            self.starts[c as usize + 1] += 1;
        }
        for i in 0..total {
            self.starts[i + 1] += self.starts[i];
        }
        self.items.resize(n, 0);
        let mut fill = self.starts[..total].to_vec();
        for (i, &c) in self.cells.iter().enumerate() {
            self.items[fill[c as usize] as usize] = i as u32;
            fill[c as usize] += 1;
        }
        self.sorted.clear();
        self.sorted
            .extend(self.items.iter().map(|&i| positions[i as usize]));
    }

    /// Calls `f(j, p_j)` for every point within `radius` of `p` (radius ≤ the cell edge),
    /// in a fixed order.
    #[inline]
    pub fn for_each_within(&self, p: Vec3, radius: f32, mut f: impl FnMut(usize, Vec3, f32)) {
        let r2 = radius * radius;
        self.for_each_range(p, |a, b| {
            for (k, q) in self.sorted[a..b].iter().enumerate() {
                let d2 = p.distance_squared(*q);
                if d2 < r2 {
                    f(self.items[a + k] as usize, *q, d2);
                }
            }
        });
    }

    /// Calls `f(j)` for every indexed point in the 27 cells around `p` (a superset of the
    /// points within one cell edge of `p`; callers test the distance).
    #[inline]
    pub fn for_each_near(&self, p: Vec3, mut f: impl FnMut(usize)) {
        self.for_each_range(p, |a, b| {
            for &j in &self.items[a..b] {
                f(j as usize);
            }
        });
    }

    /// The 9 runs of `items` covering the 27 cells around `p`.
    #[inline]
    fn for_each_range(&self, p: Vec3, mut f: impl FnMut(usize, usize)) {
        let c = self.cell_of(p);
        let x0 = (c.x - 1).max(0);
        let x1 = (c.x + 1).min(self.dims.x - 1);
        for z in (c.z - 1).max(0)..=(c.z + 1).min(self.dims.z - 1) {
            for y in (c.y - 1).max(0)..=(c.y + 1).min(self.dims.y - 1) {
                let a = self.starts[self.index(IVec3::new(x0, y, z))] as usize;
                let b = self.starts[self.index(IVec3::new(x1, y, z)) + 1] as usize;
                f(a, b);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    fn check(pts: &[Vec3], r: f32) {
        let mut g = Grid::default();
        g.build(pts, r);
        for i in (0..pts.len()).step_by(7) {
            let mut found = Vec::new();
            g.for_each_near(pts[i], |j| {
                if pts[j].distance(pts[i]) < r {
                    found.push(j)
                }
            });
            let mut within = Vec::new();
            g.for_each_within(pts[i], r, |j, q, d2| {
                assert_eq!(q, pts[j]);
                assert!((d2 - q.distance_squared(pts[i])).abs() < 1e-9);
                within.push(j)
            });
            within.sort();
            let mut brute: Vec<usize> = (0..pts.len())
                .filter(|&j| pts[j].distance(pts[i]) < r)
                .collect();
            found.sort();
            brute.sort();
            assert_eq!(found, brute);
            assert_eq!(within, brute);
        }
    }

    #[test]
    fn finds_exactly_the_neighbours_brute_force_finds() {
        let mut rng = Rng::new(1, 1, 1);
        let pts: Vec<Vec3> = (0..2000)
            .map(|_| {
                Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                )
            })
            .collect();
        check(&pts, 0.1);
    }

    #[test]
    fn widely_spread_points_and_outliers_still_work() {
        let mut rng = Rng::new(2, 1, 1);
        let mut pts: Vec<Vec3> = (0..1000)
            .map(|_| {
                Vec3::new(
                    rng.range(-0.5, 0.5),
                    rng.range(-0.5, 0.5),
                    rng.range(-0.5, 0.5),
                )
            })
            .collect();
        pts.push(Vec3::new(500.0, -300.0, 1e4));
        pts.push(Vec3::new(500.0, -300.0, 1e4)); // coincident
        check(&pts, 0.05);
        check(&[Vec3::ONE], 0.1);
        check(&[], 0.1);
    }
}
