//! Triangle-mesh obstacles: signed distance, closest point and outward normal of any
//! mesh, through the same [`super::query`] as the primitives, so that every model (vision,
//! velocity tuning, the contact guard, the sweep) avoids a tree or a set as it avoids a box.
//!
//! World space, metres, Y-up. Closest points come from parry3d's bounding-volume
//! hierarchy over the triangles; inside/outside from its angle-weighted pseudo-normals
//! (Bærentzen & Aanæs 2005), exact for a closed, consistently oriented mesh.
//!
//! Two modes:
//! - **solid**: every connected piece must be closed (each edge shared by exactly two
//!   triangles, wound consistently); it has an inside, the distance is negative there.
//!   Pieces may overlap (a trunk and its branches as separate shells): the obstacle is
//!   their union. A piece wound inside out is turned outward.
//! - **shell**: any mesh, open or not (terrain, a leaf, a wall of single faces). It is
//!   thickened by `thickness` and avoided from both sides: the distance is the distance to
//!   the nearest triangle minus half the thickness. It has no inside beyond the thickness.
//!
//! Degenerate input never yields NaN: triangles that repeat a vertex are dropped, zero-area
//! (collinear) triangles count for closedness but are left out of the queries, and a point
//! exactly on the surface gets the triangle's normal.

use glam::Vec3;
use parry3d::query::PointQueryWithLocation;
use parry3d::shape::{TriMesh, TriMeshFlags};
use std::collections::HashMap;

/// The most triangles an obstacle mesh may have (memory of the hierarchy ~ 100 B each).
pub const MAX_TRIANGLES: usize = 5_000_000;

/// How a mesh is avoided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MeshMode {
    /// Closed pieces with an inside.
    Solid,
    /// A surface thickened by `thickness` (m), avoided from both sides.
    Shell { thickness: f32 },
}

/// Why a mesh cannot be an obstacle.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshError {
    /// No triangle with an area.
    Empty,
    TooLarge(usize),
    /// A vertex coordinate is NaN or infinite (after the transform).
    NotFinite(usize),
    /// Solid mode on a mesh that is not closed: edges used by one triangle, edges used by
    /// more than two, and where the first of them is (world space).
    NotClosed {
        open: usize,
        non_manifold: usize,
        at: Vec3,
    },
    /// Solid mode on a mesh whose neighbouring triangles are wound oppositely.
    Inconsistent {
        edges: usize,
        at: Vec3,
    },
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let xyz = |v: Vec3| format!("[{:.4}, {:.4}, {:.4}]", v.x, v.y, v.z);
        match self {
            MeshError::Empty => write!(f, "the mesh has no triangle with an area"),
            MeshError::TooLarge(n) => write!(
                f,
                "the mesh has {n} triangles; at most {MAX_TRIANGLES} are supported"
            ),
            MeshError::NotFinite(i) => {
                write!(f, "vertex {} is not a finite position", i + 1)
            }
            MeshError::NotClosed {
                open,
                non_manifold,
                at,
            } => write!(
                f,
                "the mesh is not closed, so it has no inside: {open} open edges and \
                 {non_manifold} edges shared by more than two triangles (the first near {})",
                xyz(*at)
            ),
            MeshError::Inconsistent { edges, at } => write!(
                f,
                "the mesh's triangles are not wound consistently: {edges} edges join \
                 triangles facing opposite ways (the first near {})",
                xyz(*at)
            ),
        }
    }
}

/// A mesh obstacle, ready for queries.
pub struct Mesh {
    /// Unique in the process (never reused, unlike an address once a mesh is freed): the
    /// key of each thread's last-answer memo.
    id: u64,
    mode: MeshMode,
    /// Solid: one per closed connected piece. Shell: one for the whole mesh.
    parts: Vec<Part>,
    triangles: usize,
    min: Vec3,
    max: Vec3,
    far: FarField,
}

struct Part {
    mesh: TriMesh,
    min: Vec3,
    max: Vec3,
}

/// Meshes are equal only to themselves (a shot's meshes are loaded once and shared).
impl PartialEq for Mesh {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

impl std::fmt::Debug for Mesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mesh")
            .field("mode", &self.mode)
            .field("triangles", &self.triangles)
            .field("pieces", &self.parts.len())
            .field("min", &self.min)
            .field("max", &self.max)
            .finish()
    }
}

fn pv(v: Vec3) -> parry3d::math::Vector {
    parry3d::math::Vector::new(v.x, v.y, v.z)
}

fn gv(v: parry3d::math::Vector) -> Vec3 {
    Vec3::new(v.x, v.y, v.z)
}

/// Distance from `p` to the box [min, max]; 0 inside.
fn box_distance(p: Vec3, min: Vec3, max: Vec3) -> f32 {
    (min - p).max(p - max).max(Vec3::ZERO).length()
}

fn bounds(points: impl Iterator<Item = Vec3>) -> (Vec3, Vec3) {
    points.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    })
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

impl Mesh {
    /// A mesh obstacle from world-space `vertices` and `triangles` (indices into them,
    /// counter-clockwise seen from outside).
    pub fn new(
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        mode: MeshMode,
    ) -> Result<Mesh, MeshError> {
        if triangles.len() > MAX_TRIANGLES {
            return Err(MeshError::TooLarge(triangles.len()));
        }
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(MeshError::NotFinite(i));
        }
        // Weld vertices at the same position (STL repeats them per triangle), so that
        // neighbouring triangles share edges; +0.0 folds -0.0 into 0.0.
        let mut index_of: HashMap<[u32; 3], u32> = HashMap::new();
        let mut verts: Vec<Vec3> = Vec::new();
        let remap: Vec<u32> = vertices
            .iter()
            .map(|v| {
                let v = *v + Vec3::ZERO;
                *index_of
                    .entry([v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                    .or_insert_with(|| {
                        verts.push(v);
                        verts.len() as u32 - 1
                    })
            })
            .collect();
        let tris: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| remap[i as usize]))
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect();
        let has_area = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| verts[i as usize]);
            (b - a).cross(c - a).length_squared() > 0.0
        };
        let parts = match mode {
            MeshMode::Shell { .. } => {
                let shown: Vec<[u32; 3]> = tris.iter().copied().filter(has_area).collect();
                part(&verts, &shown, TriMeshFlags::empty())
                    .into_iter()
                    .collect()
            }
            MeshMode::Solid => solid_parts(&verts, &tris, has_area)?,
        };
        if parts.is_empty() {
            return Err(MeshError::Empty);
        }
        let (min, max) = bounds(parts.iter().flat_map(|p| [p.min, p.max]));
        static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        let mut mesh = Mesh {
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            mode,
            triangles: parts.iter().map(|p| p.mesh.num_triangles()).sum(),
            parts,
            min,
            max,
            far: FarField {
                origin: Vec3::ZERO,
                cell: 1.0,
                dims: [0; 3],
                side: Vec::new(),
                near: Vec::new(),
                near_side: Vec::new(),
                half: 0.0,
                reach: 0.0,
                band: f32::MAX,
            },
        };
        mesh.far = FarField::build(&mesh);
        Ok(mesh)
    }

    pub fn mode(&self) -> MeshMode {
        self.mode
    }

    /// Triangles used by the queries.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// Closed pieces (solid) or 1 (shell).
    pub fn piece_count(&self) -> usize {
        self.parts.len()
    }

    /// World-space bounding box (min, max), m.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.min, self.max)
    }

    /// Approximate memory held by the query structures, bytes.
    pub fn memory_bytes(&self) -> usize {
        self.parts
            .iter()
            .map(|p| p.mesh.total_memory_size())
            .sum::<usize>()
            + self.far.side.len()
            + 4 * self.far.near.len()
    }

    /// Every triangle's corners, world space (for drawing).
    pub fn triangles(&self) -> impl Iterator<Item = [Vec3; 3]> + '_ {
        self.parts
            .iter()
            .flat_map(|p| p.mesh.triangles().map(|t| [gv(t.a), gv(t.b), gv(t.c)]))
    }

    /// Signed distance, closest point and outward normal at `p` (see the module docs):
    /// exact within [`Mesh::exact_band`] of the surface and inside a solid; farther out, a
    /// lower bound of the distance (see [`Mesh::far`]).
    pub fn query(&self, p: Vec3) -> super::SurfaceQuery {
        if !p.is_finite() {
            // No NaN out, whatever comes in: "far away".
            return super::SurfaceQuery {
                distance: f32::MAX,
                point: self.min,
                normal: Vec3::Y,
            };
        }
        let reach = match self.far.classify(p) {
            Reach::FarOutside => return self.far_outside(p),
            Reach::Beyond { distance, normal } => {
                return super::SurfaceQuery {
                    distance,
                    point: p - normal * distance,
                    normal,
                };
            }
            r => r,
        };
        // The models ask about the same point several times a step (vision, velocity
        // tuning, the sweep's start), and a body's next step starts where the contact
        // guard last asked: each thread keeps its recent exact answers by point. A pure
        // function's memo, so results do not depend on threads or order.
        let key = (self.id, p.to_array().map(f32::to_bits));
        let slot = memo_slot(&key);
        if let Some(q) = MEMO.with_borrow(|m| m.get(slot).and_then(|e| (e.0 == key).then_some(e.1)))
        {
            return q;
        }
        // Any point of the surface bounds the distance to it: the last closest point this
        // thread found (most often the same body's, a step or a few millimetres back)
        // narrows the hierarchy's search from the first node. The answer is the same
        // with any bound at least the true distance (exact, first found on ties).
        let bound = match LAST_POINT.get() {
            Some((id, c)) if id == self.id => (p - c).length() * (1.0 + 1e-5) + 1e-6,
            _ => f32::MAX,
        };
        let q = match reach {
            Reach::FarOutside | Reach::Beyond { .. } => self.far_outside(p),
            Reach::Near(within) => self
                .exact(p, within.min(bound))
                .or_else(|| self.exact(p, f32::MAX))
                .unwrap_or_else(|| self.far_outside(p)),
            Reach::FarInside => self
                .exact(p, bound)
                .or_else(|| self.exact(p, f32::MAX))
                .unwrap_or_else(|| self.far_outside(p)),
        };
        LAST_POINT.set(Some((self.id, q.point)));
        MEMO.with_borrow_mut(|m| {
            if m.is_empty() {
                m.resize(MEMO_SLOTS, ((0, [0; 3]), q));
            }
            m[slot] = (key, q);
        });
        q
    }

    /// Distance within which [`Mesh::query`] is exact, m.
    pub fn exact_band(&self) -> f32 {
        self.far.band
    }

    /// The answer far outside: at least the exact band away, and at least as far as the
    /// bounding box; the normal points away from the box (from its centre inside it), the
    /// point lies that far back along it. A lower bound, so a sphere-traced sweep never
    /// steps over the surface.
    fn far_outside(&self, p: Vec3) -> super::SurfaceQuery {
        let on_box = p.clamp(self.min, self.max);
        let n = super::dir_or(
            p - on_box,
            super::dir_or(p - 0.5 * (self.min + self.max), Vec3::Y),
        );
        let distance = (p - on_box).length().max(self.far.band);
        super::SurfaceQuery {
            distance,
            point: p - n * distance,
            normal: n,
        }
    }

    /// The exact answer if the surface is within `max_dist` of `p`.
    fn exact(&self, p: Vec3, max_dist: f32) -> Option<super::SurfaceQuery> {
        match self.mode {
            MeshMode::Shell { thickness } => {
                let (c, face, _) = project(&self.parts[0].mesh, p, max_dist)?;
                let half = 0.5 * thickness;
                let n = super::dir_or(p - c, face);
                Some(super::SurfaceQuery {
                    distance: (p - c).length() - half,
                    point: c + n * half,
                    normal: n,
                })
            }
            MeshMode::Solid => {
                // The union of the pieces: inside if inside any (then the deepest counts),
                // else the nearest. A piece whose box is farther than the nearest surface
                // found so far is skipped.
                let mut outside: Option<(f32, Vec3, Vec3)> = None;
                let mut inside: Option<(f32, Vec3, Vec3)> = None;
                for part in &self.parts {
                    let lb = box_distance(p, part.min, part.max);
                    if lb > max_dist || (lb > 0.0 && outside.is_some_and(|(d, ..)| lb >= d)) {
                        continue;
                    }
                    // Inside a piece's box with its surface out of reach: it may still hold
                    // `p` deep inside, under another piece's surface; ask without bound.
                    let unbounded = lb == 0.0 && self.parts.len() > 1;
                    let Some((c, face, is_inside)) =
                        project(&part.mesh, p, max_dist).or_else(|| {
                            unbounded
                                .then(|| project(&part.mesh, p, f32::MAX))
                                .flatten()
                        })
                    else {
                        continue;
                    };
                    let d = (p - c).length();
                    if is_inside {
                        if inside.is_none_or(|(depth, ..)| d > depth) {
                            inside = Some((d, c, face));
                        }
                    } else if outside.is_none_or(|(best, ..)| d < best) {
                        outside = Some((d, c, face));
                    }
                }
                match (inside, outside) {
                    (Some((depth, c, face)), _) => Some(super::SurfaceQuery {
                        distance: -depth,
                        point: c,
                        normal: super::dir_or(c - p, face),
                    }),
                    (None, Some((d, c, face))) => Some(super::SurfaceQuery {
                        distance: d,
                        point: c,
                        normal: super::dir_or(p - c, face),
                    }),
                    (None, None) => None,
                }
            }
        }
    }
}

type QueryKey = (u64, [u32; 3]);

/// Entries of each thread's memo of exact answers: one per body of a 16,000-bee swarm
/// near a mesh, 0.8 MB a thread.
const MEMO_SLOTS: usize = 1 << 14;

/// Where `key` lives in the memo (direct-mapped: a newer answer replaces an older one).
fn memo_slot(key: &QueryKey) -> usize {
    let [x, y, z] = key.1.map(u64::from);
    let h = (key.0 ^ x.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ y.wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
        .wrapping_add(z.wrapping_mul(0x1656_67B1_9E37_79F9));
    ((h ^ (h >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9) >> 50) as usize & (MEMO_SLOTS - 1)
}

thread_local! {
    /// Recent exact answers of this thread, by (mesh id, point bits). Mesh ids start at
    /// 1, so the empty entries' id 0 never matches.
    static MEMO: std::cell::RefCell<Vec<(QueryKey, super::SurfaceQuery)>> =
        const { std::cell::RefCell::new(Vec::new()) };
    /// The closest point of this thread's last exact answer, and its mesh.
    static LAST_POINT: std::cell::Cell<Option<(u64, Vec3)>> = const { std::cell::Cell::new(None) };
}

/// Where a point stands, by the far-field grid.
enum Reach {
    /// Possibly within `reach` of the surface: ask the hierarchy, which finds the surface
    /// within this distance of the point (an upper bound from the near cell corners).
    Near(f32),
    /// Outside and, by the near nodes around it, at least the exact band from the
    /// surface: this lower bound of the distance (the distance is 1-Lipschitz), and the
    /// direction in which the grid's distances grow.
    Beyond {
        distance: f32,
        normal: Vec3,
    },
    FarOutside,
    FarInside,
}

/// A coarse grid over the mesh's box (grown by `reach`) that tells, in a few nanoseconds,
/// which points are far from the surface, and on which side: most bees most of the time.
/// Nodes within `reach` (4 cells) of the surface keep their exact distance and side; the
/// other nodes only keep their side, found by flooding from the near ones (no edge between
/// two far nodes can cross the surface, they are 4 cells from it and an edge is 1 long).
/// A point whose 8 cell corners are all far is at least `band` = reach − cell·√3 from
/// the surface; any other point is within `reach` + cell·√3 of it.
struct FarField {
    origin: Vec3,
    cell: f32,
    dims: [usize; 3],
    /// +1 far outside, −1 far inside, 0 near.
    side: Vec<i8>,
    /// Near nodes: the distance to the nearest triangle (thickness aside); far: ∞.
    near: Vec<f32>,
    /// Near nodes: +1 outside, −1 inside (solid) or within the thickness (shell).
    near_side: Vec<i8>,
    /// Half the shell's thickness (0 for a solid): the distance is the triangles' less this.
    half: f32,
    /// Within this of a near node, the hierarchy was asked; far nodes are at least this far.
    reach: f32,
    band: f32,
}

impl FarField {
    fn build(mesh: &Mesh) -> FarField {
        let size = mesh.max - mesh.min;
        // About 56 cells across the largest side, at least 5 cm, so the grid stays under
        // 64³ nodes (256 KB) and the exact band is at least ~11 cm wide.
        let cell = (size.max_element() / 56.0).max(0.05);
        let reach = 4.0 * cell;
        let origin = mesh.min - Vec3::splat(reach + cell);
        let dims = ((size + Vec3::splat(2.0 * (reach + cell))) / cell)
            .ceil()
            .as_uvec3()
            .to_array()
            .map(|n| n as usize + 1);
        let node = |i: usize| {
            let (x, y, z) = (
                i % dims[0],
                (i / dims[0]) % dims[1],
                i / (dims[0] * dims[1]),
            );
            origin + cell * Vec3::new(x as f32, y as f32, z as f32)
        };
        let count = dims[0] * dims[1] * dims[2];
        // Near nodes from the hierarchy (in parallel; each node on its own, so the result
        // does not depend on the thread count): 0, and far nodes 2 (side unknown yet).
        use rayon::prelude::*;
        let half = match mesh.mode {
            MeshMode::Shell { thickness } => 0.5 * thickness,
            MeshMode::Solid => 0.0,
        };
        let nodes: Vec<(i8, i8, f32)> = (0..count)
            .into_par_iter()
            .map(|i| match mesh.exact(node(i), reach) {
                Some(q) if q.distance < 0.0 => (0, -1, -q.distance + half),
                Some(q) => (0, 1, q.distance + half),
                None => (2, 0, f32::INFINITY),
            })
            .collect();
        let mut side: Vec<i8> = nodes.iter().map(|n| n.0).collect();
        let near_side: Vec<i8> = nodes.iter().map(|n| n.1).collect();
        let near: Vec<f32> = nodes.iter().map(|n| n.2).collect();
        // Flood each far region from the side of a near node next to it; the grid's rim
        // is outside.
        let at = |x: usize, y: usize, z: usize| x + dims[0] * (y + dims[1] * z);
        for start in 0..count {
            if side[start] != 2 {
                continue;
            }
            let mut region = vec![start];
            let mut found = 0i8;
            side[start] = 3;
            let mut k = 0;
            while k < region.len() {
                let i = region[k];
                k += 1;
                let (x, y, z) = (
                    i % dims[0],
                    (i / dims[0]) % dims[1],
                    i / (dims[0] * dims[1]),
                );
                let on_rim = [x, y, z]
                    .iter()
                    .zip(dims)
                    .any(|(c, d)| *c == 0 || *c == d - 1);
                if on_rim && found == 0 {
                    found = 1;
                }
                let mut next = Vec::with_capacity(6);
                if x > 0 {
                    next.push(at(x - 1, y, z));
                }
                if x + 1 < dims[0] {
                    next.push(at(x + 1, y, z));
                }
                if y > 0 {
                    next.push(at(x, y - 1, z));
                }
                if y + 1 < dims[1] {
                    next.push(at(x, y + 1, z));
                }
                if z > 0 {
                    next.push(at(x, y, z - 1));
                }
                if z + 1 < dims[2] {
                    next.push(at(x, y, z + 1));
                }
                for j in next {
                    match side[j] {
                        2 => {
                            side[j] = 3;
                            region.push(j);
                        }
                        0 if found == 0 => found = near_side[j],
                        _ => {}
                    }
                }
            }
            let s = if found == 0 { 1 } else { found };
            for i in region {
                side[i] = s;
            }
        }
        FarField {
            origin,
            cell,
            dims,
            side,
            near,
            near_side,
            half,
            reach,
            band: reach - cell * 3f32.sqrt(),
        }
    }

    fn classify(&self, p: Vec3) -> Reach {
        let g = (p - self.origin) / self.cell;
        let top = Vec3::new(
            (self.dims[0] - 1) as f32,
            (self.dims[1] - 1) as f32,
            (self.dims[2] - 1) as f32,
        );
        if g.min_element() < 0.0 || g.cmpge(top).any() {
            // Beyond the grid: more than `reach` from the mesh's box.
            return Reach::FarOutside;
        }
        let b = g.floor().as_uvec3();
        let (x, y, z) = (b.x as usize, b.y as usize, b.z as usize);
        let mut all = 0i32;
        let mut within = f32::INFINITY;
        // The triangles' distance at the corners (a far outside corner: at least `reach`),
        // and the largest lower bound they give at `p`.
        let mut at = [0f32; 8];
        let mut lower = f32::NEG_INFINITY;
        let mut outside = true;
        for (k, v) in at.iter_mut().enumerate() {
            let c = [x + (k & 1), y + ((k >> 1) & 1), z + (k >> 2)];
            let i = c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2]);
            let s = self.side[i];
            let corner = self.origin + self.cell * Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32);
            let way = (p - corner).length();
            if s == 0 {
                // The surface is within the corner's distance plus the way to it.
                within = within.min(self.near[i] + way);
                outside &= self.near_side[i] > 0;
                *v = self.near[i];
            } else {
                outside &= s > 0;
                *v = self.reach;
            }
            lower = lower.max(*v - way);
            all += s as i32;
        }
        if within.is_finite() {
            // A hair less for rounding.
            let lower = lower * (1.0 - 1e-5) - 1e-6 - self.half;
            if outside && lower >= self.band {
                // Most bodies near a mesh are not at its surface: beyond the exact band
                // they get the bound, and the trilinear gradient of the corners'
                // distances as the normal, without asking the hierarchy.
                let f = g - g.floor();
                let w = |bit: usize, t: f32| if bit == 1 { t } else { 1.0 - t };
                let mut grad = Vec3::ZERO;
                for (k, v) in at.iter().enumerate() {
                    let (bx, by, bz) = (k & 1, (k >> 1) & 1, k >> 2);
                    let s = |bit: usize| if bit == 1 { 1.0 } else { -1.0 };
                    grad += *v
                        * Vec3::new(
                            s(bx) * w(by, f.y) * w(bz, f.z),
                            w(bx, f.x) * s(by) * w(bz, f.z),
                            w(bx, f.x) * w(by, f.y) * s(bz),
                        );
                }
                let centre = 0.5 * (self.origin + self.origin + self.cell * top);
                let normal = super::dir_or(grad, super::dir_or(p - centre, Vec3::Y));
                return Reach::Beyond {
                    distance: lower,
                    normal,
                };
            }
            // A hair more for rounding.
            return Reach::Near(within * (1.0 + 1e-5) + 1e-6);
        }
        // Corners on both sides cannot happen (see the type's docs); be exact if they do.
        match all {
            8 => Reach::FarOutside,
            -8 => Reach::FarInside,
            _ => Reach::Near(f32::MAX),
        }
    }
}

/// The closest point of `mesh` to `p` within `max_dist`, the unit normal of its triangle,
/// and whether `p` is inside (by the pseudo-normals; meaningful for a closed, oriented
/// mesh only).
fn project(mesh: &TriMesh, p: Vec3, max_dist: f32) -> Option<(Vec3, Vec3, bool)> {
    let (proj, (tri, _)) =
        mesh.project_local_point_and_get_location_with_max_dist(pv(p), false, max_dist)?;
    let face = mesh
        .triangle(tri)
        .normal()
        .map(gv)
        .filter(|n| n.is_finite())
        .unwrap_or(Vec3::Y);
    Some((gv(proj.point), face, proj.is_inside))
}

/// A query structure over `tris` (indices into `verts`), with only the vertices it uses.
fn part(verts: &[Vec3], tris: &[[u32; 3]], flags: TriMeshFlags) -> Option<Part> {
    let mut local: HashMap<u32, u32> = HashMap::new();
    let mut vs = Vec::new();
    let idx: Vec<[u32; 3]> = tris
        .iter()
        .map(|t| {
            t.map(|i| {
                *local.entry(i).or_insert_with(|| {
                    vs.push(pv(verts[i as usize]));
                    vs.len() as u32 - 1
                })
            })
        })
        .collect();
    if idx.is_empty() {
        return None;
    }
    let (min, max) = bounds(vs.iter().map(|v| gv(*v)));
    let mesh = TriMesh::with_flags(vs, idx, flags).ok()?;
    Some(Part { mesh, min, max })
}

/// Splits a solid mesh into its connected pieces, checks each is closed and consistently
/// wound, turns inside-out pieces outward, and builds their query structures.
/// Each edge (a, b), a < b, of a triangle list: how many triangles use it, and the sum of
/// their directions (+1 a→b, −1 b→a). A closed, consistently wound surface uses every edge
/// twice, once each way; an edge used once is open.
pub fn edge_uses(tris: impl IntoIterator<Item = [u32; 3]>) -> HashMap<(u32, u32), (u32, i32)> {
    let mut edges: HashMap<(u32, u32), (u32, i32)> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let e = edges.entry((a.min(b), a.max(b))).or_insert((0, 0));
            e.0 += 1;
            e.1 += if a < b { 1 } else { -1 };
        }
    }
    edges
}

fn solid_parts(
    verts: &[Vec3],
    tris: &[[u32; 3]],
    has_area: impl Fn(&[u32; 3]) -> bool,
) -> Result<Vec<Part>, MeshError> {
    let edges = edge_uses(tris.iter().copied());
    let mid = |(a, b): (u32, u32)| 0.5 * (verts[a as usize] + verts[b as usize]);
    let mut sorted: Vec<_> = edges.iter().collect();
    sorted.sort_unstable_by_key(|(k, _)| **k);
    let open = sorted.iter().filter(|(_, u)| u.0 == 1).count();
    let non_manifold = sorted.iter().filter(|(_, u)| u.0 > 2).count();
    if open + non_manifold > 0 {
        let first = sorted.iter().find(|(_, u)| u.0 != 2).map(|(k, _)| **k);
        return Err(MeshError::NotClosed {
            open,
            non_manifold,
            at: first.map(mid).unwrap_or(Vec3::ZERO),
        });
    }
    let flipped: Vec<(u32, u32)> = sorted
        .iter()
        .filter(|(_, u)| u.1 != 0)
        .map(|(k, _)| **k)
        .collect();
    if let Some(first) = flipped.first() {
        return Err(MeshError::Inconsistent {
            edges: flipped.len(),
            at: mid(*first),
        });
    }
    // Connected pieces (union-find over shared vertices), in order of first triangle.
    let mut parent: Vec<u32> = (0..verts.len() as u32).collect();
    for t in tris {
        let r0 = find(&mut parent, t[0]);
        for &v in &t[1..] {
            let r = find(&mut parent, v);
            parent[r as usize] = r0;
        }
    }
    let mut piece_of_root: HashMap<u32, usize> = HashMap::new();
    let mut pieces: Vec<Vec<[u32; 3]>> = Vec::new();
    for t in tris {
        let root = find(&mut parent, t[0]);
        let n = pieces.len();
        let k = *piece_of_root.entry(root).or_insert(n);
        if k == n {
            pieces.push(Vec::new());
        }
        pieces[k].push(*t);
    }
    let mut parts = Vec::new();
    for mut piece in pieces {
        // Signed volume (divergence theorem, about the piece's first vertex for
        // precision): negative when wound inside out.
        let o = verts[piece[0][0] as usize];
        let volume: f64 = piece
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| (verts[i as usize] - o).as_dvec3());
                a.dot(b.cross(c))
            })
            .sum();
        if volume < 0.0 {
            for t in &mut piece {
                t.swap(1, 2);
            }
        }
        piece.retain(&has_area);
        if let Some(p) = part(verts, &piece, TriMeshFlags::ORIENTED) {
            parts.push(p);
        }
    }
    Ok(parts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Shape, SurfaceQuery, fibonacci_sphere};

    /// A UV sphere: `rings` latitude bands, `segments` around, outward winding.
    pub fn uv_sphere(
        center: Vec3,
        r: f32,
        rings: u32,
        segments: u32,
    ) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut v = vec![center + Vec3::Y * r];
        for i in 1..rings {
            let th = std::f32::consts::PI * i as f32 / rings as f32;
            for j in 0..segments {
                let ph = std::f32::consts::TAU * j as f32 / segments as f32;
                v.push(center + r * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()));
            }
        }
        v.push(center - Vec3::Y * r);
        let bottom = v.len() as u32 - 1;
        let at = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
        let mut t = Vec::new();
        for j in 0..segments {
            t.push([0, at(1, j + 1), at(1, j)]);
            t.push([bottom, at(rings - 1, j), at(rings - 1, j + 1)]);
        }
        for i in 1..rings - 1 {
            for j in 0..segments {
                t.push([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
                t.push([at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
            }
        }
        (v, t)
    }

    /// An axis-aligned box as 12 triangles, outward winding.
    pub fn box_mesh(c: Vec3, h: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let v: Vec<Vec3> = (0..8)
            .map(|i| {
                c + h * Vec3::new(
                    if i & 1 != 0 { 1.0 } else { -1.0 },
                    if i & 2 != 0 { 1.0 } else { -1.0 },
                    if i & 4 != 0 { 1.0 } else { -1.0 },
                )
            })
            .collect();
        let quads = [
            [0, 4, 6, 2], // -x
            [1, 3, 7, 5], // +x
            [0, 1, 5, 4], // -y
            [2, 6, 7, 3], // +y
            [0, 2, 3, 1], // -z
            [4, 5, 7, 6], // +z
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (v, t)
    }

    fn probe_points() -> Vec<Vec3> {
        let mut pts = Vec::new();
        for (k, d) in fibonacci_sphere(200).enumerate() {
            // Radii from deep inside to well outside.
            let r = 0.05 + 2.5 * (k as f32 / 200.0);
            pts.push(Vec3::new(0.1, 0.2, -0.1) + d * r);
        }
        pts
    }

    /// Far from the surface (outside, beyond the exact band) a query is a lower bound of
    /// at least the band, pointing away: checks that and says so.
    fn far_checked(m: &Mesh, q: &SurfaceQuery, exact: &SurfaceQuery, tol: f32) -> bool {
        if exact.distance < m.exact_band() + tol {
            return false;
        }
        assert!(
            q.distance >= m.exact_band() && q.distance <= exact.distance + tol,
            "{q:?} {exact:?}"
        );
        assert!(q.normal.is_finite() && (q.normal.length() - 1.0).abs() < 1e-4);
        // Near the mesh the normal follows the grid's distances: away from the surface.
        if exact.distance < 2.0 * m.exact_band() {
            assert!(q.normal.dot(exact.normal) > 0.5, "{q:?} {exact:?}");
        }
        true
    }

    #[test]
    fn far_and_deep_points_get_bounds_and_exact_depths() {
        let (v, t) = uv_sphere(Vec3::ZERO, 1.0, 24, 48);
        let m = Mesh::new(&v, &t, MeshMode::Solid).unwrap();
        assert!(m.exact_band() > 0.1, "{}", m.exact_band());
        // Deep inside: exact (the hierarchy, unbounded).
        let q = m.query(Vec3::new(0.0, 0.1, 0.0));
        assert!((q.distance + 0.9).abs() < 0.01, "{q:?}");
        assert!(q.normal.y > 0.99);
        // Far outside, beyond the grid and within it: lower bounds, pointing away.
        for p in [
            Vec3::new(30.0, 0.0, 0.0),
            Vec3::new(0.0, 1.5, 0.0),
            Vec3::new(0.9, 0.9, 0.9),
        ] {
            let q = m.query(p);
            let exact = p.length() - 1.0;
            assert!(
                q.distance >= m.exact_band() && q.distance <= exact + 1e-4,
                "{p}: {q:?}"
            );
            assert!(q.normal.dot(p) > 0.0);
        }
    }

    fn assert_close(mesh: &SurfaceQuery, exact: &SurfaceQuery, tol: f32, p: Vec3) {
        assert!(
            (mesh.distance - exact.distance).abs() < tol,
            "at {p}: mesh {mesh:?} exact {exact:?}"
        );
        assert!((mesh.point - exact.point).length() < 3.0 * tol, "at {p}");
        assert!(mesh.normal.is_finite() && (mesh.normal.length() - 1.0).abs() < 1e-4);
    }

    #[test]
    fn a_meshed_box_matches_the_analytic_box() {
        let (v, t) = box_mesh(Vec3::new(0.1, 0.2, -0.1), Vec3::new(0.5, 0.3, 0.8));
        let m = Mesh::new(&v, &t, MeshMode::Solid).unwrap();
        let b = Shape::Box {
            center: Vec3::new(0.1, 0.2, -0.1),
            half: Vec3::new(0.5, 0.3, 0.8),
            rotation: glam::Quat::IDENTITY,
        };
        for p in probe_points() {
            let exact = crate::geometry::query(&b, p);
            let q = m.query(p);
            if far_checked(&m, &q, &exact, 1e-4) {
                continue;
            }
            assert_close(&q, &exact, 1e-4, p);
            // Face normals are exact away from edges and corners.
            if exact.distance < -1e-3 || (p - exact.point).abs().min_element() > 1e-3 {
                assert!(
                    (q.normal - exact.normal).length() < 1e-3,
                    "at {p}: {q:?} {exact:?}"
                );
            }
        }
    }

    /// A mesh built in its rest frame and placed by a pose answers as the oriented box it
    /// then is: distance, closest point and normal carried into the world.
    #[test]
    fn a_posed_mesh_matches_the_box_it_is_moved_to() {
        let half = Vec3::new(0.5, 0.3, 0.8);
        let (v, t) = box_mesh(Vec3::ZERO, half);
        let mesh = std::sync::Arc::new(Mesh::new(&v, &t, MeshMode::Solid).unwrap());
        for (rotation, translation) in [
            (glam::Quat::from_rotation_y(0.7), Vec3::new(1.0, 2.0, -0.5)),
            (
                crate::geometry::euler_deg(Vec3::new(30.0, 200.0, -45.0)),
                Vec3::new(-3.0, 0.4, 2.0),
            ),
        ] {
            let posed = Shape::Mesh {
                mesh: mesh.clone(),
                pose: Some(crate::geometry::Rigid {
                    rotation,
                    translation,
                }),
            };
            let b = Shape::Box {
                center: translation,
                half,
                rotation,
            };
            for p in probe_points() {
                let p = translation + rotation * p;
                let exact = crate::geometry::query(&b, p);
                let q = crate::geometry::query(&posed, p);
                if exact.distance > mesh.exact_band() + 1e-4 {
                    // Far off: a lower bound of at least the band, as for a static mesh.
                    // (Its normal, the far-field grid's gradient, is not checked: near
                    // a box's edges it strays for a static mesh as for a posed one.)
                    assert!(
                        q.distance >= mesh.exact_band() && q.distance <= exact.distance + 1e-4,
                        "at {p}: {q:?} {exact:?}"
                    );
                    assert!((q.normal.length() - 1.0).abs() < 1e-4);
                    continue;
                }
                assert_close(&q, &exact, 2e-4, p);
                if exact.distance < -1e-3
                    || (rotation.conjugate() * (p - exact.point))
                        .abs()
                        .min_element()
                        > 1e-3
                {
                    assert!(
                        (q.normal - exact.normal).length() < 1e-3,
                        "at {p}: {q:?} {exact:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_meshed_sphere_is_within_its_chord_error_of_the_analytic_sphere() {
        let c = Vec3::new(0.1, 0.2, -0.1);
        let (v, t) = uv_sphere(c, 1.0, 48, 96);
        let m = Mesh::new(&v, &t, MeshMode::Solid).unwrap();
        let s = Shape::Sphere {
            center: c,
            radius: 1.0,
        };
        // How far a facet's middle lies inside the sphere: 1 − cos of half its diagonal's
        // angle (cells of π/48 × π/48 at most).
        let tol = 1.0 - (std::f32::consts::SQRT_2 * std::f32::consts::PI / 96.0).cos() + 1e-5;
        for p in probe_points() {
            let exact = crate::geometry::query(&s, p);
            let q = m.query(p);
            if far_checked(&m, &q, &exact, tol) {
                continue;
            }
            assert!(
                (q.distance - exact.distance).abs() < tol,
                "at {p}: {q:?} {exact:?}"
            );
            assert_eq!(q.distance < 0.0, exact.distance < 0.0, "sign at {p}");
            if exact.distance.abs() > 0.05 {
                assert!((q.normal - exact.normal).length() < 0.1, "at {p}: {q:?}");
            }
        }
    }

    #[test]
    fn closest_points_lie_on_the_surface_and_normals_point_out() {
        let (v, t) = uv_sphere(Vec3::ZERO, 0.5, 12, 24);
        for mode in [MeshMode::Solid, MeshMode::Shell { thickness: 0.02 }] {
            let m = Mesh::new(&v, &t, mode).unwrap();
            for p in probe_points() {
                let q = m.query(p);
                if q.distance >= m.exact_band() {
                    continue;
                }
                assert!(
                    m.query(q.point).distance.abs() < 1e-4,
                    "{mode:?} at {p}: {q:?}"
                );
                let out = m.query(q.point + q.normal * 0.01).distance;
                assert!((out - 0.01).abs() < 2e-3, "{mode:?} at {p}: {q:?} → {out}");
            }
        }
    }

    #[test]
    fn overlapping_pieces_are_their_union_and_inside_out_pieces_are_turned() {
        let (mut v, mut t) = box_mesh(Vec3::ZERO, Vec3::splat(0.5));
        let (v2, t2) = box_mesh(Vec3::new(0.6, 0.0, 0.0), Vec3::splat(0.5));
        let n = v.len() as u32;
        v.extend(v2);
        // The second box wound inside out.
        t.extend(t2.iter().map(|tr| [tr[0] + n, tr[2] + n, tr[1] + n]));
        let m = Mesh::new(&v, &t, MeshMode::Solid).unwrap();
        assert_eq!(m.piece_count(), 2);
        // In the overlap, inside both: 0.05 deep in the first box, 0.35 in the second;
        // the union's depth is the larger.
        let q = m.query(Vec3::new(0.45, 0.0, 0.0));
        assert!((q.distance + 0.35).abs() < 1e-5, "{q:?}");
        assert!(m.query(Vec3::new(0.9, 0.0, 0.0)).distance < 0.0);
        assert!((m.query(Vec3::new(1.2, 0.0, 0.0)).distance - 0.1).abs() < 1e-5);
        assert!((m.query(Vec3::new(-0.6, 0.0, 0.0)).distance - 0.1).abs() < 1e-5);
        // Just outside the first box, deep in the second: inside.
        assert!(m.query(Vec3::new(0.51, 0.0, 0.0)).distance < -0.3);
    }

    #[test]
    fn open_meshes_are_refused_as_solids_and_avoided_as_shells() {
        let (v, mut t) = box_mesh(Vec3::ZERO, Vec3::splat(0.5));
        t.truncate(10); // no +z face
        match Mesh::new(&v, &t, MeshMode::Solid) {
            Err(MeshError::NotClosed {
                open, non_manifold, ..
            }) => {
                assert_eq!((open, non_manifold), (4, 0));
            }
            other => panic!("{other:?}"),
        }
        let m = Mesh::new(&v, &t, MeshMode::Shell { thickness: 0.1 }).unwrap();
        // Within the open box: 0.1 from the nearest wall minus half the thickness.
        assert!((m.query(Vec3::new(0.4, 0.0, 0.0)).distance - 0.05).abs() < 1e-5);
        // Beyond the missing face: distance to the rim.
        let q = m.query(Vec3::new(0.45, 0.0, 0.55));
        assert!(
            (q.distance - (0.05f32.hypot(0.05) - 0.05)).abs() < 1e-5,
            "{q:?}"
        );
    }

    #[test]
    fn degenerate_and_bad_input_never_gives_nan() {
        let (mut v, mut t) = box_mesh(Vec3::ZERO, Vec3::splat(0.5));
        // A repeated-vertex triangle and a zero-area sliver on its own.
        t.push([0, 0, 1]);
        let n = v.len() as u32;
        v.extend([
            Vec3::new(3.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(5.0, 0.0, 0.0),
        ]);
        t.push([n, n + 1, n + 2]);
        let shell = Mesh::new(&v, &t, MeshMode::Shell { thickness: 0.0 }).unwrap();
        for p in [
            Vec3::ZERO,
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::NAN,
        ] {
            let q = shell.query(p);
            assert!(
                q.distance.is_finite() && q.point.is_finite() && q.normal.is_finite(),
                "{q:?}"
            );
        }
        // On the surface exactly: the face normal.
        let q = shell.query(Vec3::new(0.0, 0.5, 0.0));
        assert_eq!(q.normal.abs(), Vec3::Y);
        assert_eq!(
            Mesh::new(&v, &[], MeshMode::Solid).unwrap_err(),
            MeshError::Empty
        );
        assert_eq!(
            Mesh::new(
                &v[n as usize..],
                &[[0, 1, 2]],
                MeshMode::Shell { thickness: 0.1 }
            )
            .unwrap_err(),
            MeshError::Empty
        );
        let mut bad = v.clone();
        bad[3].y = f32::NAN;
        assert_eq!(
            Mesh::new(&bad, &t, MeshMode::Solid).unwrap_err(),
            MeshError::NotFinite(3)
        );
    }

    #[test]
    fn inconsistent_winding_is_refused() {
        let (v, mut t) = box_mesh(Vec3::ZERO, Vec3::splat(0.5));
        t[0].swap(1, 2);
        assert!(matches!(
            Mesh::new(&v, &t, MeshMode::Solid),
            Err(MeshError::Inconsistent { edges: 3, .. })
        ));
    }
}
