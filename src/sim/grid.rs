//! Uniform-grid neighbour search with spatial hashing (paper 000 Sec. V-B: "a space-based
//! hash table is employed to accelerate neighbour search").
//!
//! Cells of edge `cell` are hashed into a power-of-two table; a counting sort places bee
//! indices bucket by bucket in increasing index order, so neighbour iteration order — and
//! with it every floating-point sum — is the same whatever the number of threads.

use glam::{IVec3, Vec3};

#[derive(Clone, Debug, Default)]
pub struct Grid {
    inv_cell: f32,
    mask: usize,
    /// `starts[b]..starts[b + 1]` indexes `items` for bucket b.
    starts: Vec<u32>,
    items: Vec<u32>,
    buckets: Vec<u32>,
}

#[inline]
fn hash(c: IVec3) -> usize {
    (c.x.wrapping_mul(73_856_093) ^ c.y.wrapping_mul(19_349_663) ^ c.z.wrapping_mul(83_492_791))
        as u32 as usize
}

impl Grid {
    #[inline]
    fn cell_of(&self, p: Vec3) -> IVec3 {
        // Clamp so that far-away or huge coordinates cannot overflow the cast.
        (p * self.inv_cell)
            .floor()
            .clamp(Vec3::splat(-1e9), Vec3::splat(1e9))
            .as_ivec3()
    }

    /// Rebuilds the grid over `positions` with cells of edge `cell` metres.
    pub fn build(&mut self, positions: &[Vec3], cell: f32) {
        use rayon::prelude::*;
        let n = positions.len();
        let size = (2 * n).next_power_of_two().max(1024);
        self.inv_cell = 1.0 / cell;
        self.mask = size - 1;
        let (inv, mask) = (self.inv_cell, self.mask);
        positions
            .par_iter()
            .map(|p| {
                (hash(
                    (*p * inv)
                        .floor()
                        .clamp(Vec3::splat(-1e9), Vec3::splat(1e9))
                        .as_ivec3(),
                ) & mask) as u32
            })
            .collect_into_vec(&mut self.buckets);
        self.starts.clear();
        self.starts.resize(size + 1, 0);
        for &b in &self.buckets {
            self.starts[b as usize + 1] += 1;
        }
        for i in 0..size {
            self.starts[i + 1] += self.starts[i];
        }
        self.items.resize(n, 0);
        let mut fill = self.starts[..size].to_vec();
        for (i, &b) in self.buckets.iter().enumerate() {
            self.items[fill[b as usize] as usize] = i as u32;
            fill[b as usize] += 1;
        }
    }

    /// Calls `f(j)` for every indexed point in the 27 cells around `p` (a superset of the
    /// points within one cell edge of `p`; callers test the distance).
    #[inline]
    pub fn for_each_near(&self, p: Vec3, mut f: impl FnMut(usize)) {
        let c = self.cell_of(p);
        let mut seen = [usize::MAX; 27];
        let mut k = 0;
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let b = hash(c + IVec3::new(dx, dy, dz)) & self.mask;
                    // Two cells may share a bucket: visit each bucket once.
                    if seen[..k].contains(&b) {
                        continue;
                    }
                    seen[k] = b;
                    k += 1;
                    for &j in &self.items[self.starts[b] as usize..self.starts[b + 1] as usize] {
                        f(j as usize);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

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
        let mut g = Grid::default();
        let r = 0.1;
        g.build(&pts, r);
        for i in (0..pts.len()).step_by(37) {
            let mut found = Vec::new();
            g.for_each_near(pts[i], |j| {
                if pts[j].distance(pts[i]) < r {
                    found.push(j)
                }
            });
            let mut brute: Vec<usize> = (0..pts.len())
                .filter(|&j| pts[j].distance(pts[i]) < r)
                .collect();
            found.sort();
            brute.sort();
            assert_eq!(found, brute);
        }
    }
}
