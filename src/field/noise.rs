//! Improved Perlin gradient noise (Perlin 2002) in 3D with its analytic gradient.
//!
//! The curl-noise force (Eq. 8–9) needs the derivatives of three noise potentials; the
//! analytic gradient is exact and about as cheap as one extra noise sample, where finite
//! differences would need six samples per potential and add truncation error.

use glam::{Vec3, Vec4};

/// One seeded noise function.
#[derive(Clone, Debug)]
pub struct Perlin {
    perm: [u8; 512],
}

impl Perlin {
    /// The permutation table (for `super::wide`'s own tables).
    pub(super) fn perm(&self) -> &[u8; 512] {
        &self.perm
    }
}

/// The 12 edge-midpoint gradients of improved Perlin noise (plus 4 repeats to make 16).
pub(super) const GRADS: [[f32; 3]; 16] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
    [1.0, 1.0, 0.0],
    [0.0, -1.0, 1.0],
    [-1.0, 1.0, 0.0],
    [0.0, -1.0, -1.0],
];

/// `GRADS[h & 15]` for every byte h, so that a corner hash indexes it directly.
const GRADS_BY_HASH: [[f32; 3]; 256] = {
    let mut t = [[0.0f32; 3]; 256];
    let mut h = 0;
    while h < 256 {
        t[h] = GRADS[h & 15];
        h += 1;
    }
    t
};

/// Perlin's quintic fade 6t⁵ − 15t⁴ + 10t³ and its derivative, lane by lane (the three
/// axes side by side: each lane is the scalar polynomial's arithmetic, in its order).
#[inline]
fn fade(t: Vec4) -> Vec4 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[inline]
fn dfade(t: Vec4) -> Vec4 {
    30.0 * t * t * (t * (t - 2.0) + 1.0)
}

impl Perlin {
    pub fn new(seed: u64) -> Self {
        let mut p: [u8; 256] = std::array::from_fn(|i| i as u8);
        let mut rng = crate::math::Rng::new(seed, 0x5045_524C, 0);
        for i in (1..256).rev() {
            let j = (rng.next_u64() % (i as u64 + 1)) as usize;
            p.swap(i, j);
        }
        let mut perm = [0u8; 512];
        for i in 0..512 {
            perm[i] = p[i & 255];
        }
        Perlin { perm }
    }

    /// Corner hashes p[p[p[x] + y] + z] of the lattice cell at (ix, iy, iz), sharing the
    /// inner lookups between corners (14 table reads instead of 24). Corner order: bit 0 =
    /// x, bit 1 = y, bit 2 = z. Every index is a byte plus a byte plus at most 1, under
    /// 512: the compiler sees that from the types and drops the bounds checks.
    #[inline]
    fn corner_hashes(&self, ix: u8, iy: u8, iz: u8) -> [u8; 8] {
        let p = &self.perm;
        let (ix, iy, iz) = (ix as usize, iy as usize, iz as usize);
        let a = p[ix] as usize + iy;
        let b = p[ix + 1] as usize + iy;
        let (aa, ab) = (p[a] as usize + iz, p[a + 1] as usize + iz);
        let (ba, bb) = (p[b] as usize + iz, p[b + 1] as usize + iz);
        [
            p[aa],
            p[ba],
            p[ab],
            p[bb],
            p[aa + 1],
            p[ba + 1],
            p[ab + 1],
            p[bb + 1],
        ]
    }

    /// Noise value and its gradient at `x` (lattice spacing 1).
    pub fn sample(&self, x: Vec3) -> (f32, Vec3) {
        self.sample_at(&LatticePoint::new(x))
    }

    /// As [`Perlin::sample`], at a point whose lattice cell and blend weights are already
    /// known: several noise functions sampled at one point share that work.
    pub fn sample_at(&self, lp: &LatticePoint) -> (f32, Vec3) {
        let LatticePoint {
            ix,
            iy,
            iz,
            f: [fx, fy, fz],
            w: [u, v, w],
            dw: [du, dv, dw],
        } = *lp;
        let hashes = self.corner_hashes(ix, iy, iz);
        let mut g = [[0.0f32; 3]; 8];
        let mut c = [0.0f32; 8];
        for (k, h) in hashes.into_iter().enumerate() {
            g[k] = GRADS_BY_HASH[h as usize];
            let d = [
                fx - (k & 1) as f32,
                fy - ((k >> 1) & 1) as f32,
                fz - ((k >> 2) & 1) as f32,
            ];
            c[k] = g[k][0] * d[0] + g[k][1] * d[1] + g[k][2] * d[2];
        }
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let lerp3 = |a: [f32; 3], b: [f32; 3], t: f32| {
            [
                lerp(a[0], b[0], t),
                lerp(a[1], b[1], t),
                lerp(a[2], b[2], t),
            ]
        };

        // Interpolate along x, then y, then z, carrying the weight derivatives along:
        // ∂N/∂x = du · (interpolated x-differences), and so on for y and z.
        let x00 = lerp(c[0], c[1], u);
        let x10 = lerp(c[2], c[3], u);
        let x01 = lerp(c[4], c[5], u);
        let x11 = lerp(c[6], c[7], u);
        let y0 = lerp(x00, x10, v);
        let y1 = lerp(x01, x11, v);
        let value = lerp(y0, y1, w);
        let dx = lerp(
            lerp(c[1] - c[0], c[3] - c[2], v),
            lerp(c[5] - c[4], c[7] - c[6], v),
            w,
        ) * du;
        let dy = lerp(x10 - x00, x11 - x01, w) * dv;
        let dz = (y1 - y0) * dw;
        // The corner values depend on position too: add the interpolated corner gradients.
        let gx0 = lerp3(lerp3(g[0], g[1], u), lerp3(g[2], g[3], u), v);
        let gx1 = lerp3(lerp3(g[4], g[5], u), lerp3(g[6], g[7], u), v);
        let gb = lerp3(gx0, gx1, w);
        (value, Vec3::new(gb[0] + dx, gb[1] + dy, gb[2] + dz))
    }
}

/// The gradients of three noise functions at one point (the curl's three potentials),
/// side by side in the lanes of a 4-wide vector: each lane does exactly the arithmetic of
/// [`Perlin::sample_at`], in the same order, so each gradient is bit-identical to that
/// function's, at about half its cost. The cell's two faces (z = 0 and z = 1) are
/// interpolated along x and y one after the other, so that fewer values are live at once.
pub fn gradients3(noise: &[Perlin; 3], lp: &LatticePoint) -> [Vec3; 3] {
    let LatticePoint {
        ix,
        iy,
        iz,
        f,
        w: [_, _, w],
        dw: [du, dv, dw],
    } = *lp;
    let hashes = [
        noise[0].corner_hashes(ix, iy, iz),
        noise[1].corner_hashes(ix, iy, iz),
        noise[2].corner_hashes(ix, iy, iz),
    ];
    let lower = Face::new(&hashes, 0, f, lp);
    let upper = Face::new(&hashes, 4, f, lp);
    let lerp = |a: Vec4, b: Vec4, t: f32| a + (b - a) * t;
    // As `sample_at`: ∂N/∂x = du · (x-differences interpolated along y, then z), and so on.
    let dx = lerp(lower.dx, upper.dx, w) * du;
    let dy = lerp(lower.dy, upper.dy, w) * dv;
    let dz = (upper.value - lower.value) * dw;
    let bx = lerp(lower.gx, upper.gx, w) + dx;
    let by = lerp(lower.gy, upper.gy, w) + dy;
    let bz = lerp(lower.gz, upper.gz, w) + dz;
    [
        Vec3::new(bx.x, by.x, bz.x),
        Vec3::new(bx.y, by.y, bz.y),
        Vec3::new(bx.z, by.z, bz.z),
    ]
}

/// One face of a lattice cell (its four corners at z = 0 or z = 1) interpolated along x
/// and y for three noise functions at once (one per lane): what [`gradients3`] then
/// interpolates along z.
struct Face {
    /// The noise value on the face (`y0` or `y1` of `sample_at`).
    value: Vec4,
    /// x-differences of the corner values, interpolated along y.
    dx: Vec4,
    /// y-difference of the x-interpolated values.
    dy: Vec4,
    /// The corner gradients interpolated along x and y, by component.
    gx: Vec4,
    gy: Vec4,
    gz: Vec4,
}

impl Face {
    /// Corners `first..first + 4` (0 or 4) of the cell whose corner hashes are `hashes`.
    #[inline(always)]
    fn new(hashes: &[[u8; 8]; 3], first: usize, f: [f32; 3], lp: &LatticePoint) -> Self {
        let [fx, fy, fz] = f;
        let [u, v, _] = lp.w;
        let mut gx = [Vec4::ZERO; 4];
        let mut gy = [Vec4::ZERO; 4];
        let mut gz = [Vec4::ZERO; 4];
        let mut c = [Vec4::ZERO; 4];
        for j in 0..4 {
            let k = first + j;
            let g = |n: usize| GRADS_BY_HASH[hashes[n][k] as usize];
            let (g0, g1, g2) = (g(0), g(1), g(2));
            gx[j] = Vec4::new(g0[0], g1[0], g2[0], 0.0);
            gy[j] = Vec4::new(g0[1], g1[1], g2[1], 0.0);
            gz[j] = Vec4::new(g0[2], g1[2], g2[2], 0.0);
            let d = [
                fx - (k & 1) as f32,
                fy - ((k >> 1) & 1) as f32,
                fz - ((k >> 2) & 1) as f32,
            ];
            c[j] = gx[j] * d[0] + gy[j] * d[1] + gz[j] * d[2];
        }
        let lerp = |a: Vec4, b: Vec4, t: f32| a + (b - a) * t;
        let x0 = lerp(c[0], c[1], u);
        let x1 = lerp(c[2], c[3], u);
        let blend = |g: &[Vec4; 4]| lerp(lerp(g[0], g[1], u), lerp(g[2], g[3], u), v);
        Face {
            value: lerp(x0, x1, v),
            dx: lerp(c[1] - c[0], c[3] - c[2], v),
            dy: x1 - x0,
            gx: blend(&gx),
            gy: blend(&gy),
            gz: blend(&gz),
        }
    }
}

/// A point's lattice cell, fractional position, blend weights and their derivatives.
#[derive(Clone, Copy, Debug)]
pub struct LatticePoint {
    ix: u8,
    iy: u8,
    iz: u8,
    f: [f32; 3],
    w: [f32; 3],
    dw: [f32; 3],
}

impl LatticePoint {
    // Inlined into its callers, as the compiler chose by itself before other code moved it
    // into another unit (a call per sample in the bee's step otherwise).
    #[inline]
    pub fn new(x: Vec3) -> Self {
        let (ix, fx) = split(x.x);
        let (iy, fy) = split(x.y);
        let (iz, fz) = split(x.z);
        let f = Vec4::new(fx, fy, fz, 0.0);
        let (w, dw) = (fade(f), dfade(f));
        LatticePoint {
            ix,
            iy,
            iz,
            f: [fx, fy, fz],
            w: [w.x, w.y, w.z],
            dw: [dw.x, dw.y, dw.z],
        }
    }
}

/// Lattice cell (wrapped to the table) and fraction of one coordinate. An inline floor:
/// the portable `f32::floor` is a library call on baseline x86-64.
#[inline]
fn split(x: f32) -> (u8, f32) {
    let t = x as i32;
    let i = if (t as f32) > x { t - 1 } else { t };
    (i as u8, x - i as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn analytic_gradient_matches_finite_differences() {
        let p = Perlin::new(3);
        let e = 1e-3;
        for i in 0..200 {
            let x = Vec3::new(
                i as f32 * 0.137 - 7.0,
                i as f32 * 0.071 + 0.3,
                -(i as f32) * 0.053,
            );
            let (_, g) = p.sample(x);
            let fd = Vec3::new(
                (p.sample(x + Vec3::X * e).0 - p.sample(x - Vec3::X * e).0) / (2.0 * e),
                (p.sample(x + Vec3::Y * e).0 - p.sample(x - Vec3::Y * e).0) / (2.0 * e),
                (p.sample(x + Vec3::Z * e).0 - p.sample(x - Vec3::Z * e).0) / (2.0 * e),
            );
            assert!((g - fd).length() < 5e-3, "at {x}: {g} vs {fd}");
        }
    }

    #[test]
    fn three_gradients_side_by_side_are_bit_identical_to_one_at_a_time() {
        let noise = [Perlin::new(11), Perlin::new(11 ^ 0x1111), Perlin::new(12)];
        let mut rng = crate::math::Rng::new(4, 5, 6);
        for _ in 0..20_000 {
            let x = Vec3::new(
                rng.range(-300.0, 300.0),
                rng.range(-300.0, 300.0),
                rng.range(-300.0, 300.0),
            );
            let lp = LatticePoint::new(x);
            let three = gradients3(&noise, &lp);
            for (n, g) in noise.iter().zip(three) {
                let one = n.sample_at(&lp).1;
                assert_eq!(
                    g.to_array().map(f32::to_bits),
                    one.to_array().map(f32::to_bits),
                    "at {x}"
                );
            }
        }
    }

    #[test]
    fn lattice_weights_are_the_fade_polynomials_bit_for_bit() {
        let mut rng = crate::math::Rng::new(7, 8, 9);
        for _ in 0..20_000 {
            let x = Vec3::new(
                rng.range(-300.0, 300.0),
                rng.range(-3.0, 3.0),
                rng.range(-0.01, 0.01),
            );
            let lp = LatticePoint::new(x);
            for a in 0..3 {
                let t = lp.f[a];
                let fade = t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
                let dfade = 30.0 * t * t * (t * (t - 2.0) + 1.0);
                assert_eq!(lp.w[a].to_bits(), fade.to_bits(), "at {x}");
                assert_eq!(lp.dw[a].to_bits(), dfade.to_bits(), "at {x}");
            }
        }
    }

    #[test]
    fn noise_is_zero_on_lattice_points_and_bounded() {
        let p = Perlin::new(9);
        assert_eq!(p.sample(Vec3::new(3.0, -2.0, 5.0)).0, 0.0);
        for i in 0..1000 {
            let x = Vec3::new(i as f32 * 0.31, i as f32 * 0.17, i as f32 * 0.07);
            assert!(p.sample(x).0.abs() <= 1.5);
        }
    }
}
