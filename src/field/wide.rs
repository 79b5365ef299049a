//! The curl-noise force for many points at once ([`CurlNoise::forces`]): sixteen with
//! AVX-512, eight with AVX2. Each lane does exactly the arithmetic of [`CurlNoise::force`]
//! for its point, in the same order (no fused multiply-add), so every result is
//! bit-identical to the one-point path on every machine; only the speed differs.
//!
//! The one-point path already evaluates the three potentials side by side in the lanes of
//! a 4-wide vector ([`super::noise::gradients3`]), but its 24 corner hashes and gradients
//! are scalar table reads. Here each of those is one gather or one in-register permute for
//! all the points of a batch.

use super::curl::CurlNoise;
use crate::simd::Level;
use glam::Vec3;

/// Points evaluated together with AVX-512.
pub const WIDTH: usize = 16;

/// Points evaluated together with AVX2.
#[cfg(target_arch = "x86_64")]
const NARROW: usize = 8;

/// The three potentials' permutation tables p₀, p₁, p₂ packed for gathers: where
/// `Perlin::corner_hashes` reads p[i] and p[i + 1] one after the other, one gather reads
/// both, and the first reads, at the same index for the three potentials, are one gather.
#[derive(Clone, Debug)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub struct WideTables {
    /// p₀[i] | p₁[i] << 8 | p₂[i] << 16.
    first: [u32; 512],
    /// Per potential: p[i] | p[i + 1] << 8 (p[512] taken as 0; never read).
    pairs: [[u32; 512]; 3],
}

impl WideTables {
    pub fn new(potentials: &[super::noise::Perlin; 3]) -> Self {
        let p = potentials.each_ref().map(|n| n.perm());
        let byte = |t: &[u8; 512], i: usize| t.get(i).copied().unwrap_or(0) as u32;
        WideTables {
            first: std::array::from_fn(|i| {
                byte(p[0], i) | byte(p[1], i) << 8 | byte(p[2], i) << 16
            }),
            pairs: p.map(|t| std::array::from_fn(|i| byte(t, i) | byte(t, i + 1) << 8)),
        }
    }
}

/// Coordinates (in lattice cells) below this magnitude convert to integers the same way
/// in the vector path as in the scalar one. Beyond it (2^30 noise cells from the origin, or
/// not finite) a batch takes the scalar path: `as i32` saturates where the vector
/// conversion returns i32::MIN.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
const SAFE: f32 = 1_073_741_824.0;

impl CurlNoise {
    /// `out[k] = self.force(pos(k))` for every k, bit for bit: sixteen at a time with
    /// AVX-512, eight with AVX2, where they run (`crate::simd`), one at a time elsewhere.
    pub fn forces(&self, pos: impl Fn(usize) -> Vec3, out: &mut [Vec3]) {
        self.forces_at(crate::simd::level(), pos, out)
    }

    /// [`CurlNoise::forces`] on the paths of `level` (at most the CPU's).
    fn forces_at(&self, level: Level, pos: impl Fn(usize) -> Vec3, out: &mut [Vec3]) {
        debug_assert!(level <= crate::simd::detected());
        #[cfg(target_arch = "x86_64")]
        match level {
            // SAFETY (both): the CPU has the level's instructions (`simd::level`).
            Level::Avx512 => {
                return self.batches(&pos, out, |t, x, g| unsafe { curl16(t, x, g) });
            }
            Level::Avx2 => return self.batches(&pos, out, |t, x, g| unsafe { curl8(t, x, g) }),
            Level::Portable => {}
        }
        let _ = level;
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.force(pos(k));
        }
    }

    /// `out` in batches of `W` points, each worked out by `curl` (`curl16` or `curl8`).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn batches<const W: usize>(
        &self,
        pos: &impl Fn(usize) -> Vec3,
        out: &mut [Vec3],
        curl: impl Fn(&WideTables, &[[f32; W]; 3], f32) -> [[f32; W]; 3],
    ) {
        let tables = self.hash_tables();
        for (c, chunk) in out.chunks_mut(W).enumerate() {
            // In lattice units, as `force`. Lanes past the end repeat the chunk's first
            // point, and are dropped.
            let x: [Vec3; W] = std::array::from_fn(|k| {
                pos(c * W + if k < chunk.len() { k } else { 0 }) * self.inv_cell()
            });
            let lanes = [x.map(|v| v.x), x.map(|v| v.y), x.map(|v| v.z)];
            let safe = lanes.iter().flatten().all(|v| v.abs() < SAFE);
            if !safe {
                for (k, o) in chunk.iter_mut().enumerate() {
                    *o = self.force(pos(c * W + k));
                }
                continue;
            }
            let f = curl(tables, &lanes, self.gain());
            for (k, o) in chunk.iter_mut().enumerate() {
                *o = Vec3::new(f[0][k], f[1][k], f[2][k]);
            }
        }
    }
}

/// The curl of the three potentials whose permutation tables are packed in `tables`, at
/// sixteen points given in lattice units (`x[axis][lane]`), times `gain`: the
/// arithmetic of `LatticePoint::new`, `gradients3` and `CurlNoise::force`, lane by lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn curl16(tables: &WideTables, x: &[[f32; WIDTH]; 3], gain: f32) -> [[f32; WIDTH]; 3] {
    use std::arch::x86_64::*;
    let splat = _mm512_set1_ps;
    let (add, sub, mul) = (
        |a, b| _mm512_add_ps(a, b),
        |a, b| _mm512_sub_ps(a, b),
        |a, b| _mm512_mul_ps(a, b),
    );
    let lerp = |a, b, t| add(a, mul(sub(b, a), t));
    // `split`: the cell (floor, by truncation and a compare) and the fraction.
    let mut cell = [_mm512_setzero_si512(); 3];
    let mut frac = [splat(0.0); 3];
    for a in 0..3 {
        // SAFETY: `x[a]` holds sixteen f32s.
        let v = unsafe { _mm512_loadu_ps(x[a].as_ptr()) };
        let t = _mm512_cvttps_epi32(v);
        let above = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(_mm512_cvtepi32_ps(t), v);
        let i = _mm512_mask_sub_epi32(t, above, t, _mm512_set1_epi32(1));
        cell[a] = _mm512_and_si512(i, _mm512_set1_epi32(255));
        frac[a] = sub(v, _mm512_cvtepi32_ps(i));
    }
    // `fade` and `dfade`, each lane the scalar polynomial's operations in order.
    let fade = |t| {
        mul(
            mul(mul(t, t), t),
            add(mul(t, sub(mul(t, splat(6.0)), splat(15.0))), splat(10.0)),
        )
    };
    let dfade = |t| {
        mul(
            mul(mul(splat(30.0), t), t),
            add(mul(t, sub(t, splat(2.0))), splat(1.0)),
        )
    };
    let (u, v, w) = (fade(frac[0]), fade(frac[1]), fade(frac[2]));
    let (du, dv, dw) = (dfade(frac[0]), dfade(frac[1]), dfade(frac[2]));
    // The twelve edge gradients (and four repeats), one table per component.
    let grads = |axis: usize| {
        let g: [f32; 16] = std::array::from_fn(|h| super::noise::GRADS[h][axis]);
        // SAFETY: `g` holds sixteen f32s.
        unsafe { _mm512_loadu_ps(g.as_ptr()) }
    };
    let (tx, ty, tz) = (grads(0), grads(1), grads(2));
    let one = _mm512_set1_epi32(1);
    // The corners' offsets from the point: the fraction, or the fraction less one.
    let d = |a: usize, bit: usize| {
        if bit == 0 {
            sub(frac[a], splat(0.0))
        } else {
            sub(frac[a], splat(1.0))
        }
    };
    // Per potential: ∂/∂x, ∂/∂y, ∂/∂z of the noise (`gradients3`'s bx, by, bz lanes),
    // each only where the curl uses it: potential n's derivative along axis n is not.
    let mut grad = [[splat(0.0); 3]; 3];
    // SAFETY (every gather): each index is a byte plus a byte (under 511), as in
    // `Perlin::corner_hashes`; the tables hold 512 entries.
    let gather = |idx, table: &[u32; 512]| unsafe {
        _mm512_i32gather_epi32::<4>(idx, table.as_ptr().cast())
    };
    let bytes = _mm512_set1_epi32(255);
    // Byte `at` of each lane.
    let byte = |v, at: u32| {
        _mm512_and_si512(
            _mm512_srlv_epi32(v, _mm512_set1_epi32(at as i32 * 8)),
            bytes,
        )
    };
    let (ix, iy, iz) = (cell[0], cell[1], cell[2]);
    let (first_0, first_1) = (
        gather(ix, &tables.first),
        gather(_mm512_add_epi32(ix, one), &tables.first),
    );
    for (n, table) in tables.pairs.iter().enumerate() {
        let used = |axis: usize| axis != n;
        let a = _mm512_add_epi32(byte(first_0, n as u32), iy);
        let b = _mm512_add_epi32(byte(first_1, n as u32), iy);
        // p[a] and p[a + 1] together, and so on.
        let (pa, pb) = (gather(a, table), gather(b, table));
        let aa = _mm512_add_epi32(byte(pa, 0), iz);
        let ab = _mm512_add_epi32(byte(pa, 1), iz);
        let ba = _mm512_add_epi32(byte(pb, 0), iz);
        let bb = _mm512_add_epi32(byte(pb, 1), iz);
        let (paa, pba, pab, pbb) = (
            gather(aa, table),
            gather(ba, table),
            gather(ab, table),
            gather(bb, table),
        );
        // The corner hashes p[aa], p[ba], p[ab], p[bb], then at z + 1: the permute below
        // reads only their low 4 bits, so the bytes above need no masking.
        let high = |v| _mm512_srli_epi32::<8>(v);
        let hashes = [
            paa,
            pba,
            pab,
            pbb,
            high(paa),
            high(pba),
            high(pab),
            high(pbb),
        ];
        // One face of the cell (corners `first..first + 4`), as `Face::new`.
        let face = |first: usize| {
            let mut g = [[splat(0.0); 4]; 3];
            let mut c = [splat(0.0); 4];
            for j in 0..4 {
                let k = first + j;
                // `GRADS_BY_HASH[h]` is `GRADS[h & 15]`: the permute reads the low 4 bits.
                let h = hashes[k];
                g[0][j] = _mm512_permutexvar_ps(h, tx);
                g[1][j] = _mm512_permutexvar_ps(h, ty);
                g[2][j] = _mm512_permutexvar_ps(h, tz);
                let (dx, dy, dz) = (d(0, k & 1), d(1, (k >> 1) & 1), d(2, (k >> 2) & 1));
                c[j] = add(add(mul(g[0][j], dx), mul(g[1][j], dy)), mul(g[2][j], dz));
            }
            let x0 = lerp(c[0], c[1], u);
            let x1 = lerp(c[2], c[3], u);
            let blend = |axis: usize| {
                let g = g[axis];
                if used(axis) {
                    lerp(lerp(g[0], g[1], u), lerp(g[2], g[3], u), v)
                } else {
                    splat(0.0)
                }
            };
            (
                lerp(x0, x1, v),
                lerp(sub(c[1], c[0]), sub(c[3], c[2]), v),
                sub(x1, x0),
                [blend(0), blend(1), blend(2)],
            )
        };
        let (lo_value, lo_dx, lo_dy, lo_g) = face(0);
        let (up_value, up_dx, up_dy, up_g) = face(4);
        let along = [
            (lo_dx, up_dx, du),
            (lo_dy, up_dy, dv),
            (lo_value, up_value, dw),
        ];
        for (axis, (lo, up, dweight)) in along.into_iter().enumerate() {
            if !used(axis) {
                continue;
            }
            // `gradients3`: dx and dy interpolated along z, dz the faces' difference.
            let d = if axis == 2 {
                mul(sub(up, lo), dweight)
            } else {
                mul(lerp(lo, up, w), dweight)
            };
            grad[n][axis] = add(lerp(lo_g[axis], up_g[axis], w), d);
        }
    }
    // Eq. 9: (∂ψz/∂y − ∂ψy/∂z, ∂ψx/∂z − ∂ψz/∂x, ∂ψy/∂x − ∂ψx/∂y), times the gain.
    let g = splat(gain);
    let curl = [
        mul(sub(grad[2][1], grad[1][2]), g),
        mul(sub(grad[0][2], grad[2][0]), g),
        mul(sub(grad[1][0], grad[0][1]), g),
    ];
    let mut out = [[0.0f32; WIDTH]; 3];
    for (o, c) in out.iter_mut().zip(curl) {
        // SAFETY: `o` holds sixteen f32s.
        unsafe { _mm512_storeu_ps(o.as_mut_ptr(), c) };
    }
    out
}

/// [`curl16`] for eight points with AVX2: the same arithmetic lane by lane. Where AVX-512
/// subtracts under a mask and permutes sixteen gradients in one instruction, this adds
/// the compare's −1 and picks between two permutes of eight by the hash's bit 3.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn curl8(tables: &WideTables, x: &[[f32; NARROW]; 3], gain: f32) -> [[f32; NARROW]; 3] {
    use std::arch::x86_64::*;
    let splat = _mm256_set1_ps;
    let (add, sub, mul) = (
        |a, b| _mm256_add_ps(a, b),
        |a, b| _mm256_sub_ps(a, b),
        |a, b| _mm256_mul_ps(a, b),
    );
    let lerp = |a, b, t| add(a, mul(sub(b, a), t));
    // `split`: the cell (floor, by truncation and a compare) and the fraction.
    let mut cell = [_mm256_setzero_si256(); 3];
    let mut frac = [splat(0.0); 3];
    for a in 0..3 {
        // SAFETY: `x[a]` holds eight f32s.
        let v = unsafe { _mm256_loadu_ps(x[a].as_ptr()) };
        let t = _mm256_cvttps_epi32(v);
        // All ones (−1) where truncation rounded up: a negative non-integer.
        let above = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_cvtepi32_ps(t), v));
        let i = _mm256_add_epi32(t, above);
        cell[a] = _mm256_and_si256(i, _mm256_set1_epi32(255));
        frac[a] = sub(v, _mm256_cvtepi32_ps(i));
    }
    // `fade` and `dfade`, each lane the scalar polynomial's operations in order.
    let fade = |t| {
        mul(
            mul(mul(t, t), t),
            add(mul(t, sub(mul(t, splat(6.0)), splat(15.0))), splat(10.0)),
        )
    };
    let dfade = |t| {
        mul(
            mul(mul(splat(30.0), t), t),
            add(mul(t, sub(t, splat(2.0))), splat(1.0)),
        )
    };
    let (u, v, w) = (fade(frac[0]), fade(frac[1]), fade(frac[2]));
    let (du, dv, dw) = (dfade(frac[0]), dfade(frac[1]), dfade(frac[2]));
    // The twelve edge gradients (and four repeats), one table per component, in two
    // halves of eight.
    let grads = |axis: usize, half: usize| {
        let g: [f32; 8] = std::array::from_fn(|h| super::noise::GRADS[8 * half + h][axis]);
        // SAFETY: `g` holds eight f32s.
        unsafe { _mm256_loadu_ps(g.as_ptr()) }
    };
    let tables_g = [0, 1, 2].map(|axis| (grads(axis, 0), grads(axis, 1)));
    // `GRADS_BY_HASH[h]` is `GRADS[h & 15]`: bits 0–2 pick within a half, bit 3 the half
    // (moved to the sign bit, which the blend reads).
    let gradient = |h: __m256i, axis: usize| {
        let (lo, hi) = tables_g[axis];
        _mm256_blendv_ps(
            _mm256_permutevar8x32_ps(lo, h),
            _mm256_permutevar8x32_ps(hi, h),
            _mm256_castsi256_ps(_mm256_slli_epi32::<28>(h)),
        )
    };
    let one = _mm256_set1_epi32(1);
    // The corners' offsets from the point: the fraction, or the fraction less one.
    let d = |a: usize, bit: usize| {
        if bit == 0 {
            sub(frac[a], splat(0.0))
        } else {
            sub(frac[a], splat(1.0))
        }
    };
    // Per potential: ∂/∂x, ∂/∂y, ∂/∂z of the noise, each only where the curl uses it.
    let mut grad = [[splat(0.0); 3]; 3];
    // SAFETY (every gather): each index is a byte plus a byte (under 511), as in
    // `Perlin::corner_hashes`; the tables hold 512 entries.
    let gather = |idx, table: &[u32; 512]| unsafe {
        _mm256_i32gather_epi32::<4>(table.as_ptr().cast(), idx)
    };
    let bytes = _mm256_set1_epi32(255);
    // Byte `at` of each lane.
    let byte = |v, at: u32| {
        _mm256_and_si256(
            _mm256_srlv_epi32(v, _mm256_set1_epi32(at as i32 * 8)),
            bytes,
        )
    };
    let (ix, iy, iz) = (cell[0], cell[1], cell[2]);
    let (first_0, first_1) = (
        gather(ix, &tables.first),
        gather(_mm256_add_epi32(ix, one), &tables.first),
    );
    for (n, table) in tables.pairs.iter().enumerate() {
        let used = |axis: usize| axis != n;
        let a = _mm256_add_epi32(byte(first_0, n as u32), iy);
        let b = _mm256_add_epi32(byte(first_1, n as u32), iy);
        let (pa, pb) = (gather(a, table), gather(b, table));
        let aa = _mm256_add_epi32(byte(pa, 0), iz);
        let ab = _mm256_add_epi32(byte(pa, 1), iz);
        let ba = _mm256_add_epi32(byte(pb, 0), iz);
        let bb = _mm256_add_epi32(byte(pb, 1), iz);
        let (paa, pba, pab, pbb) = (
            gather(aa, table),
            gather(ba, table),
            gather(ab, table),
            gather(bb, table),
        );
        // The corner hashes, then at z + 1: the gradient reads only their low 4 bits.
        let high = |v| _mm256_srli_epi32::<8>(v);
        let hashes = [
            paa,
            pba,
            pab,
            pbb,
            high(paa),
            high(pba),
            high(pab),
            high(pbb),
        ];
        // One face of the cell (corners `first..first + 4`), as `Face::new`.
        let face = |first: usize| {
            let mut g = [[splat(0.0); 4]; 3];
            let mut c = [splat(0.0); 4];
            for j in 0..4 {
                let k = first + j;
                let h = hashes[k];
                g[0][j] = gradient(h, 0);
                g[1][j] = gradient(h, 1);
                g[2][j] = gradient(h, 2);
                let (dx, dy, dz) = (d(0, k & 1), d(1, (k >> 1) & 1), d(2, (k >> 2) & 1));
                c[j] = add(add(mul(g[0][j], dx), mul(g[1][j], dy)), mul(g[2][j], dz));
            }
            let x0 = lerp(c[0], c[1], u);
            let x1 = lerp(c[2], c[3], u);
            let blend = |axis: usize| {
                let g = g[axis];
                if used(axis) {
                    lerp(lerp(g[0], g[1], u), lerp(g[2], g[3], u), v)
                } else {
                    splat(0.0)
                }
            };
            (
                lerp(x0, x1, v),
                lerp(sub(c[1], c[0]), sub(c[3], c[2]), v),
                sub(x1, x0),
                [blend(0), blend(1), blend(2)],
            )
        };
        let (lo_value, lo_dx, lo_dy, lo_g) = face(0);
        let (up_value, up_dx, up_dy, up_g) = face(4);
        let along = [
            (lo_dx, up_dx, du),
            (lo_dy, up_dy, dv),
            (lo_value, up_value, dw),
        ];
        for (axis, (lo, up, dweight)) in along.into_iter().enumerate() {
            if !used(axis) {
                continue;
            }
            let d = if axis == 2 {
                mul(sub(up, lo), dweight)
            } else {
                mul(lerp(lo, up, w), dweight)
            };
            grad[n][axis] = add(lerp(lo_g[axis], up_g[axis], w), d);
        }
    }
    // Eq. 9, times the gain.
    let g = splat(gain);
    let curl = [
        mul(sub(grad[2][1], grad[1][2]), g),
        mul(sub(grad[0][2], grad[2][0]), g),
        mul(sub(grad[1][0], grad[0][1]), g),
    ];
    let mut out = [[0.0f32; NARROW]; 3];
    for (o, c) in out.iter_mut().zip(curl) {
        // SAFETY: `o` holds eight f32s.
        unsafe { _mm256_storeu_ps(o.as_mut_ptr(), c) };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points over a wide range, and the awkward ones: lattice points, a hair either side
    /// of them, negative zero, the table's wrap at 256 cells.
    fn points() -> Vec<Vec3> {
        let mut rng = crate::math::Rng::new(21, 22, 23);
        let mut pts: Vec<Vec3> = (0..40_000)
            .map(|k| {
                let s = [0.3, 3.0, 30.0, 3_000.0][k % 4];
                Vec3::new(rng.range(-s, s), rng.range(-s, s), rng.range(-s, s))
            })
            .collect();
        let edges = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.11,
            -0.11,
            0.11 * 256.0,
            f32::from_bits(1.0f32.to_bits() - 1),
            f32::from_bits(1.0f32.to_bits() + 1),
            -f32::from_bits(1.0f32.to_bits() - 1),
            7.0 * 0.11,
            -7.0 * 0.11,
        ];
        for &a in &edges {
            for &b in &edges {
                for &c in &edges {
                    pts.push(Vec3::new(a, b, c));
                }
            }
        }
        // Far out, where a batch falls back to one point at a time.
        pts.push(Vec3::new(1e9, 0.5, -0.5));
        pts.push(Vec3::new(-3e12, 1.0, 2.0));
        pts
    }

    #[test]
    fn every_level_is_one_at_a_time_bit_for_bit() {
        let c = CurlNoise::new(5, 0.11, 2.0);
        let pts = points();
        let levels = [Level::Portable, Level::Avx2, Level::Avx512];
        for level in levels.into_iter().filter(|&l| l <= crate::simd::detected()) {
            // Odd lengths as well, so the last batch is partly empty.
            for n in [pts.len(), 1, 7, 9, 15, 17, 33] {
                let mut out = vec![Vec3::NAN; n];
                c.forces_at(level, |k| pts[k], &mut out);
                for (k, o) in out.iter().enumerate() {
                    let one = c.force(pts[k]);
                    assert_eq!(
                        o.to_array().map(f32::to_bits),
                        one.to_array().map(f32::to_bits),
                        "{level:?} at {}",
                        pts[k]
                    );
                }
            }
        }
    }
}
