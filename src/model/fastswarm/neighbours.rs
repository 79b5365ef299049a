//! Every agent within the attraction zone (paper 003 Sec. 5.2.1, "fast indexing": space cut
//! into a grid, each agent searching the cells around it). Eq. 6 averages over all the
//! attraction neighbours, so the world's bounded list (the 16 nearest, most of them inside
//! d_att1 in a dense swarm) would leave out the rest of the swarm: a swarm split by a
//! predator would then only hold together through the weak swarm-centre term (Eq. 7).
//!
//! Conventions: metres, world Y-up.

use glam::Vec3;

/// Agents sorted by grid cell, rebuilt once per step.
#[derive(Clone, Debug, Default)]
pub struct CellIndex {
    cell: f32,
    /// (cell key, agent index), sorted: each cell's agents in index order.
    sorted: Vec<(u64, u32)>,
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
    pub fn build(&mut self, positions: impl Iterator<Item = Vec3>, cell: f32) {
        self.cell = cell;
        self.sorted.clear();
        self.sorted.extend(positions.enumerate().map(|(j, p)| {
            (
                key([coord(p.x, cell), coord(p.y, cell), coord(p.z, cell)]),
                j as u32,
            )
        }));
        self.sorted.sort_unstable();
    }

    /// Calls `f(j)` for every indexed agent in the 27 cells around `p` (all those within
    /// one cell edge of it, and some farther), in a fixed order: cell by cell, each in
    /// index order, so that sums over them do not depend on threads. The three cells of a
    /// row along z have consecutive keys, so each row is one run of the sorted list.
    #[inline]
    pub fn for_each_near(&self, p: Vec3, mut f: impl FnMut(usize)) {
        if self.sorted.is_empty() {
            return;
        }
        let c = [p.x, p.y, p.z].map(|x| coord(x, self.cell));
        for dx in -1..=1 {
            for dy in -1..=1 {
                // No cell lies beyond the clamp bounds (`coord`), so the row stops there.
                let lo = key([c[0] + dx, c[1] + dy, (c[2] - 1).max(-(1 << 20))]);
                let hi = key([c[0] + dx, c[1] + dy, (c[2] + 1).min((1 << 20) - 1)]);
                let start = self.sorted.partition_point(|e| e.0 < lo);
                for e in self.sorted[start..].iter().take_while(|e| e.0 <= hi) {
                    f(e.1 as usize);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_exactly_what_brute_force_finds_within_a_cell_edge() {
        let mut rng = crate::math::Rng::new(7, 0, 0);
        let pts: Vec<Vec3> = (0..500)
            .map(|_| {
                Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                )
            })
            .collect();
        let mut idx = CellIndex::default();
        idx.build(pts.iter().copied(), 0.3);
        for &p in &pts[..50] {
            let mut got = Vec::new();
            idx.for_each_near(p, |j| {
                if pts[j].distance(p) < 0.3 {
                    got.push(j)
                }
            });
            got.sort_unstable();
            let want: Vec<usize> = (0..pts.len())
                .filter(|&j| pts[j].distance(p) < 0.3)
                .collect();
            assert_eq!(got, want);
        }
    }
}
