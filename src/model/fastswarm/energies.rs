//! The energy E of paper 003 Eq. 2–14 for one agent and one candidate velocity, with
//! everything that does not depend on the candidate prepared once per agent per step.
//!
//! Conventions: metres, seconds, world Y-up; a "direction" is a unit vector (zero where
//! a velocity has no direction).

use super::database::{LANES, Soa, turn};
use super::neighbours::{Batch, CellIndex, Nearest};
use crate::math::normalize_or;
use crate::model::context::MAX_NEIGHBOURS;
use glam::{Mat3, Vec3};
use std::mem::MaybeUninit;

/// e^x for the energies: 2^(x log₂e) from the exponent bits and a degree-4 polynomial for
/// the fraction, within 1e-5 of `f32::exp` relative on [−87, 87] (clamped beyond). Plain
/// multiplies and adds, so it gives the same bits on every platform (libm's `exp` need
/// not), and it vectorises: the integer part is rounded by adding 1.5 × 2²³, which leaves
/// it in the low mantissa bits (no float-to-int conversion), and the selection evaluates
/// it for a whole batch of candidates at once.
#[inline(always)]
pub fn fast_exp(x: f32) -> f32 {
    exp_within(x.clamp(-87.0, 87.0))
}

/// [`fast_exp`] of an `x` known to lie in [−87, 87] (there the clamp changes nothing, so
/// the bits are the same), two instructions fewer per lane: the direction terms of the
/// selection (Eq. 7–14 and Eq. 10's), whose exponent ρ‖â − b̂‖ is at most 20 × 2 (ρ is
/// validated to [0, 20]; ‖â − b̂‖ ≤ 2 for unit vectors).
#[inline(always)]
pub fn exp_within(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0;
    let t = x * std::f32::consts::LOG2_E;
    let m = t + MAGIC;
    let f = t - (m - MAGIC);
    // 2^f for f in [−½, ½]: a degree-4 fit of least relative error (Lawson's iteration on
    // 4,001 Chebyshev points: 2.9e-6 at most, evaluated in f32). The degree-6 Taylor
    // series it replaced was exact to 1e-7 but cost two more multiply-adds per lane, 7 %
    // of fastswarm's step (docs/model.md, "Paper 003").
    let p = 1.0 + f * (0.693_124_2 + f * (0.240_241 + f * (0.055_906_43 + f * 0.009_582_85)));
    // m's bits minus MAGIC's are the rounded t as a two's-complement integer.
    let i = m.to_bits().wrapping_sub(MAGIC.to_bits());
    f32::from_bits(i.wrapping_add(127) << 23) * p
}

/// Eq. 6's sum over the attraction neighbours as a function of the move δ = vΔt, expanded
/// to second order about δ = 0 and gathered one neighbour at a time, once per agent per
/// step, so that weighing a candidate costs the same whatever the number of neighbours.
///
/// Each term f(δ) = e^{ρ(‖p + δ − p_j‖/d_att1 − 1)}: with r = p − p_j, d = ‖r‖, r̂ = r/d and
/// k = ρ/d_att1, ∇f = f k r̂ and ∇²f = f (k² r̂r̂ᵀ + k (I − r̂r̂ᵀ)/d) = f (k/d) I +
/// f (k² − k/d) r̂r̂ᵀ, so the sums are F = Σf, g = Σ f k r̂, a scalar Σ f k/d and the six
/// entries of the symmetric Σ f (k² − k/d) r̂r̂ᵀ. The error is bounded in the tests below.
///
/// Neighbours are buffered [`ATT_LANES`] at a time: each one's terms are computed for the
/// whole buffer at once (independent, so in SIMD), then added to the sums one neighbour
/// after the other, in the order they were added (the same sums, bit for bit, as adding
/// each as it comes).
#[derive(Clone, Copy, Debug)]
pub struct Attraction {
    rho: f32,
    k: f32,
    inv_d1: f32,
    p: Vec3,
    /// Neighbours added.
    pub n: usize,
    /// F, g (x, y, z), Σ f k/d and the matrix's xx, yy, zz, xy, xz, yz, in this order
    /// (indices [`F`], [`G`], [`S_I`], [`M`]), then zeros: one row of sums per term, so
    /// that a neighbour's terms are added to them as two vectors.
    sums: [f32; 16],
    /// Neighbours added but not yet summed: positions by component, and how many (fewer
    /// than [`ATT_LANES`] between calls; room for a whole batch more).
    pending: [[f32; 2 * ATT_LANES]; 3],
    n_pending: usize,
}

/// Neighbours an [`Attraction`] buffers before summing them.
const ATT_LANES: usize = 8;

/// Where each sum sits in [`Attraction`]'s row of sums.
const F: usize = 0;
const G: usize = 1;
const S_I: usize = 4;
const M: usize = 5;
/// Terms per neighbour.
const TERMS: usize = 11;

/// The most neighbours [`Attraction::gather`] sums at once: 32 in the AVX-512 build (two
/// registers per quantity: two independent chains of roots, divisions and exponentials
/// in flight; 16 and 48 measured slower), 8 in the others (16 there measured slower).
const MAX_GROUP: usize = 32;

/// What [`Attraction::gather`] looks for: Eq. 6's zone r1 ≤ d < r2 (at most `limit` of
/// it) and Eq. 4's, d < r0; m.
#[derive(Clone, Copy, Debug)]
pub struct Zone {
    pub r0: f32,
    pub r1: f32,
    pub r2: f32,
    pub limit: usize,
}

/// The most neighbours [`Attraction::gather`] takes: a whole 500-agent shape fits, and a
/// bound keeps the step's cost bounded.
pub const MAX_GATHER: usize = 512;

impl Attraction {
    /// Empty sums for an agent at `p`.
    pub fn new(rho: f32, d_att1: f32, p: Vec3) -> Self {
        Attraction {
            rho,
            k: rho / d_att1,
            inv_d1: 1.0 / d_att1,
            p,
            n: 0,
            sums: [0.0; 16],
            pending: [[0.0; 2 * ATT_LANES]; 3],
            n_pending: 0,
        }
    }

    /// Adds the neighbour at `q`.
    #[inline]
    pub fn add(&mut self, q: Vec3) {
        self.add_lanes(&[q.x; ATT_LANES], &[q.y; ATT_LANES], &[q.z; ATT_LANES], 1);
    }

    /// Adds the neighbours at (x[l], y[l], z[l]) for every bit l of `mask`, in lane order:
    /// every lane is written to the buffer and the count advanced by its bit, so there is
    /// no branch per neighbour (whether a scanned agent is one is unpredictable).
    #[inline(always)]
    pub fn add_lanes(
        &mut self,
        x: &[f32; ATT_LANES],
        y: &[f32; ATT_LANES],
        z: &[f32; ATT_LANES],
        mask: u32,
    ) {
        let mut k = self.n_pending;
        for l in 0..ATT_LANES {
            // k < ATT_LANES + l here, so the mask changes nothing (it spares a bounds check).
            let slot = k & (2 * ATT_LANES - 1);
            self.pending[0][slot] = x[l];
            self.pending[1][slot] = y[l];
            self.pending[2][slot] = z[l];
            k += ((mask >> l) & 1) as usize;
        }
        self.n += k - self.n_pending;
        self.n_pending = k;
        if k >= ATT_LANES {
            self.sum_pending();
        }
    }

    /// Adds the neighbours in the attraction zone, r1 ≤ d < r2, of `cells` (the agent
    /// `exclude`, itself, left out), at most `limit` (and [`MAX_GATHER`]) in all: the first
    /// found, in [`CellIndex::for_each_in_shell`]'s order. The sums must be empty. The same
    /// scan finds Eq. 4's neighbours, those strictly within r0, for `nearest`.
    #[inline]
    pub fn gather(&mut self, cells: &CellIndex, exclude: usize, zone: Zone, nearest: &mut Nearest) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx512() {
            // SAFETY: the CPU has AVX-512 F and VL and AVX2 (`simd::avx512`).
            return unsafe { self.gather_avx512(cells, exclude, zone, nearest) };
        }
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2() {
            // SAFETY: the CPU has AVX2 (`simd::avx2`).
            return unsafe { self.gather_avx2(cells, exclude, zone, nearest) };
        }
        self.gather_batches::<false, false, 8>(cells, exclude, zone, nearest);
    }

    /// [`Self::gather_batches`] compiled for AVX2: Eq. 6's terms for eight neighbours in
    /// one instruction instead of two, the same operations, so the same bits (no fused
    /// multiply-add, as in selection.rs).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn gather_avx2(&mut self, cells: &CellIndex, exclude: usize, zone: Zone, near: &mut Nearest) {
        self.gather_batches::<true, false, 8>(cells, exclude, zone, near);
    }

    /// [`Self::gather_batches`] compiled for AVX-512, summing 32 neighbours at once (two
    /// registers per quantity): the same additions in the same order, so the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn gather_avx512(&mut self, cells: &CellIndex, exclude: usize, zone: Zone, near: &mut Nearest) {
        self.gather_batches::<true, true, 32>(cells, exclude, zone, near);
    }

    /// In two passes: the scan collects the neighbours' positions in a buffer, then their
    /// terms are summed `N` at a time in the order found. Summing as the scan goes
    /// chained each group's arithmetic to the scan's scattered stores; apart, the sums'
    /// loop has no dependence but the sums themselves.
    #[inline(always)]
    fn gather_batches<const WIDE: bool, const COMPRESS: bool, const N: usize>(
        &mut self,
        cells: &CellIndex,
        exclude: usize,
        zone: Zone,
        nearest: &mut Nearest,
    ) {
        debug_assert_eq!(self.n, 0, "gathers into empty sums");
        let Zone { r0, r1, r2, limit } = zone;
        let limit = limit.min(MAX_GATHER);
        let p = self.p;
        // Left uninitialised: zeroing 6 kB per agent was 2 % of the step. Every slot read
        // below is written first (see `filled`).
        let mut buf = [[MaybeUninit::<f32>::uninit(); MAX_GATHER + MAX_GROUP]; 3];
        let mut n = 0;
        // The agent itself, at distance 0, is in the shell only when r1² is 0 (the test
        // of every lane's index against it was 3 % of the step).
        let may_hold_self = r1 * r1 <= 0.0;
        cells.for_each_batch_in_shell(p, r1, r2, r0, |b, mut hits, close| {
            nearest.note(cells, &b, close, p, exclude);
            if may_hold_self {
                for (l, &j) in b.index.iter().enumerate() {
                    hits &= !(u32::from(j as usize == exclude) << l);
                }
            }
            // Past the limit, only the first hits (rare: a crowd of more than `limit`).
            let room = limit - n;
            while hits.count_ones() as usize > room {
                hits &= !(1 << (31 - hits.leading_zeros()));
            }
            #[cfg(target_arch = "x86_64")]
            if COMPRESS {
                // SAFETY: COMPRESS is set only under gather_avx512, run once AVX-512 F and
                // VL were detected; n ≤ limit, so the 8 slots from n are in the buffer.
                unsafe { append_compressed(&mut buf, n, &b, hits) };
                n += hits.count_ones() as usize;
                return;
            }
            // Every lane is written and the count advanced by its bit: no branch per hit
            // (whether a scanned agent is in the zone is unpredictable). n ≤ limit, so
            // n + l < MAX_GATHER + ATT_LANES.
            for l in 0..ATT_LANES {
                buf[0][n].write(b.x[l]);
                buf[1][n].write(b.y[l]);
                buf[2][n].write(b.z[l]);
                n += ((hits >> l) & 1) as usize;
            }
        });
        nearest.finish(cells, p, exclude);
        // The last group reads up to N slots past the n found (lanes it then leaves out).
        for a in &mut buf {
            for slot in &mut a[n..n + N] {
                slot.write(0.0);
            }
        }
        // Slots 0..n were each written when the count reached them, n..n + N just above.
        let filled = |a: &[MaybeUninit<f32>; MAX_GATHER + MAX_GROUP]| -> &[f32] {
            let a = &a[..n + N];
            // SAFETY: every slot of `a` is initialised (above), and MaybeUninit<f32> has
            // f32's layout.
            unsafe { &*(a as *const [MaybeUninit<f32>] as *const [f32]) }
        };
        let buf = [filled(&buf[0]), filled(&buf[1]), filled(&buf[2])];
        for start in (0..n).step_by(N) {
            let lanes = |a: &[f32]| -> [f32; N] {
                a[start..start + N]
                    .try_into()
                    .expect("room for a whole group")
            };
            let count = (n - start).min(N);
            self.sum_lanes::<WIDE, N>(&lanes(buf[0]), &lanes(buf[1]), &lanes(buf[2]), count);
        }
        self.n = n;
    }

    /// Sums the first [`ATT_LANES`] buffered neighbours (all, when fewer) into F, g,
    /// Σ f k/d and the matrix, and moves the rest to the front.
    #[inline(always)]
    fn sum_pending(&mut self) {
        let [qx, qy, qz] = self.pending.map(|q| {
            let first: [f32; ATT_LANES] = q[..ATT_LANES].try_into().expect("a group");
            first
        });
        let count = self.n_pending.min(ATT_LANES);
        self.sum_lanes::<false, ATT_LANES>(&qx, &qy, &qz, count);
        for q in &mut self.pending {
            q.copy_within(ATT_LANES.., 0);
        }
        self.n_pending -= count;
    }

    /// Sums the neighbours at (qx[l], qy[l], qz[l]), l < `count`, into F, g, Σ f k/d and
    /// the matrix, in lane order; `WIDE` (only where AVX is known to be there) adds them
    /// as vectors.
    #[inline(always)]
    fn sum_lanes<const WIDE: bool, const N: usize>(
        &mut self,
        qx: &[f32; N],
        qy: &[f32; N],
        qz: &[f32; N],
        count: usize,
    ) {
        let (p, k) = (self.p, self.k);
        // Per neighbour, as one would write it for a single one:
        // r = p − q, d = ‖r‖, u = r/d, f = e^{ρ(d/d_att1 − 1)}, c = f (k² − k/d).
        // Left uninitialised (every entry is written just below): zeroed, it was a call to
        // memset of 1.4 kB per group of 32, with the registers saved around it.
        let mut t = [[MaybeUninit::<f32>::uninit(); N]; TERMS];
        for l in 0..N {
            let (rx, ry, rz) = (p.x - qx[l], p.y - qy[l], p.z - qz[l]);
            let d = (rx * rx + ry * ry + rz * rz).sqrt().max(1e-6);
            let inv = 1.0 / d;
            let (ux, uy, uz) = (rx * inv, ry * inv, rz * inv);
            let fj = fast_exp(self.rho * (d * self.inv_d1 - 1.0));
            let fk = fj * k;
            let c = fj * (k * k - k * inv);
            t[0][l].write(fj);
            t[1][l].write(ux * fk);
            t[2][l].write(uy * fk);
            t[3][l].write(uz * fk);
            t[4][l].write(fk * inv);
            t[5][l].write(c * ux * ux);
            t[6][l].write(c * uy * uy);
            t[7][l].write(c * uz * uz);
            t[8][l].write(c * ux * uy);
            t[9][l].write(c * ux * uz);
            t[10][l].write(c * uy * uz);
        }
        // SAFETY: every entry of every row was written in the loop above, and
        // MaybeUninit<f32> is laid out as f32 (a view, not a copy).
        let t: &[[f32; N]; TERMS] = unsafe { &*(t.as_ptr() as *const [[f32; N]; TERMS]) };
        #[cfg(target_arch = "x86_64")]
        if WIDE && count == N && N.is_multiple_of(ATT_LANES) {
            // Each block of eight is read straight from `t`: a copy of it (what the compiler
            // made of taking it by value when it did not unroll this loop) stored whole
            // rows and read them back in parts, a stall per part, and the gather ran 2.4
            // times slower in builds where other code had changed.
            for h in (0..N).step_by(ATT_LANES) {
                // SAFETY: WIDE is set only under gather_avx2, run once AVX2 was detected;
                // h + ATT_LANES ≤ N.
                unsafe { add_columns_avx(&mut self.sums, t, h) };
            }
            return;
        }
        for l in 0..count {
            for (sum, row) in self.sums.iter_mut().zip(t) {
                *sum += row[l];
            }
        }
    }
}

/// Writes the hits of `b` (bit l of `hits` for lane l) to `buf` from slot `n`, in lane
/// order, by one compress per component (in a register: AVX-512's compress to memory is
/// slow on some CPUs) and one 8-lane store, where the portable loop stores every lane.
/// The slots past the hits get zeros; the caller advances `n` by the hits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl")]
#[inline]
unsafe fn append_compressed(
    buf: &mut [[MaybeUninit<f32>; MAX_GATHER + MAX_GROUP]; 3],
    n: usize,
    b: &Batch<'_>,
    hits: u32,
) {
    use std::arch::x86_64::*;
    let k = hits as __mmask8;
    for (out, lanes) in buf.iter_mut().zip([b.x, b.y, b.z]) {
        let slots = &mut out[n..n + ATT_LANES];
        // SAFETY: `lanes` holds 8 floats and `slots` 8 (MaybeUninit<f32> is laid out as
        // f32); unaligned load and store.
        unsafe {
            let v = _mm256_maskz_compress_ps(k, _mm256_loadu_ps(lanes.as_ptr()));
            _mm256_storeu_ps(slots.as_mut_ptr().cast::<f32>(), v);
        }
    }
}

/// Adds to `sums` each of the columns `h .. h + 8` of `t` (one neighbour's terms) in turn,
/// column h first: the same additions, so the same bits, as term by term, but two vector
/// additions per neighbour instead of eleven scalar ones, after a transpose. `h + 8` must
/// be at most `N`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn add_columns_avx<const N: usize>(sums: &mut [f32; 16], t: &[[f32; N]; TERMS], h: usize) {
    use std::arch::x86_64::*;
    /// The columns of the 8 × 8 block of rows `r`, one register each.
    #[target_feature(enable = "avx")]
    #[inline]
    fn transpose(r: [__m256; 8]) -> [__m256; 8] {
        let u = [
            _mm256_unpacklo_ps(r[0], r[1]),
            _mm256_unpackhi_ps(r[0], r[1]),
            _mm256_unpacklo_ps(r[2], r[3]),
            _mm256_unpackhi_ps(r[2], r[3]),
            _mm256_unpacklo_ps(r[4], r[5]),
            _mm256_unpackhi_ps(r[4], r[5]),
            _mm256_unpacklo_ps(r[6], r[7]),
            _mm256_unpackhi_ps(r[6], r[7]),
        ];
        // v[c] holds rows 0–3 (low half: column c, high half: column c + 4), w[c] rows 4–7.
        let v = [
            _mm256_shuffle_ps::<0x44>(u[0], u[2]),
            _mm256_shuffle_ps::<0xEE>(u[0], u[2]),
            _mm256_shuffle_ps::<0x44>(u[1], u[3]),
            _mm256_shuffle_ps::<0xEE>(u[1], u[3]),
        ];
        let w = [
            _mm256_shuffle_ps::<0x44>(u[4], u[6]),
            _mm256_shuffle_ps::<0xEE>(u[4], u[6]),
            _mm256_shuffle_ps::<0x44>(u[5], u[7]),
            _mm256_shuffle_ps::<0xEE>(u[5], u[7]),
        ];
        [
            _mm256_permute2f128_ps::<0x20>(v[0], w[0]),
            _mm256_permute2f128_ps::<0x20>(v[1], w[1]),
            _mm256_permute2f128_ps::<0x20>(v[2], w[2]),
            _mm256_permute2f128_ps::<0x20>(v[3], w[3]),
            _mm256_permute2f128_ps::<0x31>(v[0], w[0]),
            _mm256_permute2f128_ps::<0x31>(v[1], w[1]),
            _mm256_permute2f128_ps::<0x31>(v[2], w[2]),
            _mm256_permute2f128_ps::<0x31>(v[3], w[3]),
        ]
    }
    debug_assert!(h + ATT_LANES <= N);
    // SAFETY (loads and stores): each reads or writes 8 floats of an array of 16, or of
    // one of N from h, h + 8 ≤ N (the caller's promise).
    unsafe {
        let row = |k: usize| {
            if k < TERMS {
                _mm256_loadu_ps(t[k].as_ptr().add(h))
            } else {
                _mm256_setzero_ps()
            }
        };
        let a = transpose(std::array::from_fn(row));
        let b = transpose(std::array::from_fn(|k| row(k + 8)));
        let (mut sa, mut sb) = (
            _mm256_loadu_ps(sums.as_ptr()),
            _mm256_loadu_ps(sums[8..].as_ptr()),
        );
        for l in 0..ATT_LANES {
            sa = _mm256_add_ps(sa, a[l]);
            sb = _mm256_add_ps(sb, b[l]);
        }
        _mm256_storeu_ps(sums.as_mut_ptr(), sa);
        _mm256_storeu_ps(sums[8..].as_mut_ptr(), sb);
    }
}

/// The most direction terms an agent has: swarm centre (Eq. 7), own direction (Eq. 9),
/// noise (Eq. 13), key point (Eq. 14) and an attracting stimulus (Eq. 11–12).
const MAX_DIRECTIONS: usize = 5;
/// The most stimuli an agent weighs at once.
pub const MAX_STIMULI: usize = 4;

/// One agent's energy terms at one step: E(v, a) for any candidate (v, a).
#[derive(Clone, Debug)]
pub struct Energy {
    /// ρ (Sec. 5).
    pub rho: f32,
    /// Step, s.
    pub dt: f32,
    /// The agent's position p_{i,t}.
    pub p: Vec3,
    /// The agent's velocity v_{i,t}.
    pub v: Vec3,
    /// (w, û) of every term w·e^{ρ‖v̂ − û‖} (Eq. 7, 9, 11 attracted, 13, 14).
    dirs: [(f32, Vec3); MAX_DIRECTIONS],
    n_dirs: usize,
    /// w_rep / |RN| and 1 / d_rep (Eq. 4).
    rep_w: f32,
    inv_d_rep: f32,
    /// Neighbours' predicted positions p'_{j,t+1} = p_j + v_j Δt, repulsion zone (Eq. 4).
    rep: [Vec3; MAX_NEIGHBOURS],
    n_rep: usize,
    /// Eq. 6 as a function of the move δ = vΔt, expanded to second order about δ = 0:
    /// w_oa/|AN| · (F + g·δ + ½ δᵀHδ), summed over the attraction neighbours once per
    /// step instead of once per candidate (see [`Energy::attraction`]).
    att_f: f32,
    att_g: Vec3,
    att_h: Mat3,
    /// w_acc and 1 / mean |a| of the database (Eq. 10, see [`Energy::acceleration`]).
    acc_w: f32,
    inv_mean_accel: f32,
    /// (w_env, p_sti, 1 / d_danger) of every startling stimulus within reach (Eq. 12).
    startle: [(f32, Vec3, f32); MAX_STIMULI],
    n_startle: usize,
}

impl Energy {
    pub fn new(rho: f32, dt: f32, p: Vec3, v: Vec3) -> Self {
        // The direction terms' exponents, ρ × at most 2, must stay within `exp_within`'s
        // range (the parameter's own range is [0, 20]).
        debug_assert!((0.0..=43.0).contains(&rho), "ρ = {rho}");
        Energy {
            rho,
            dt,
            p,
            v,
            dirs: [(0.0, Vec3::ZERO); MAX_DIRECTIONS],
            n_dirs: 0,
            rep_w: 0.0,
            inv_d_rep: 0.0,
            rep: [Vec3::ZERO; MAX_NEIGHBOURS],
            n_rep: 0,
            att_f: 0.0,
            att_g: Vec3::ZERO,
            att_h: Mat3::ZERO,
            acc_w: 0.0,
            inv_mean_accel: 0.0,
            startle: [(0.0, Vec3::ZERO, 0.0); MAX_STIMULI],
            n_startle: 0,
        }
    }

    /// Adds a term w·e^{ρ‖v̂ − dir‖} (Eq. 7, 9, 11, 13, 14 share this form); `dir` need
    /// not be unit. A zero weight or a direction-less `dir` adds nothing.
    pub fn direction(&mut self, w: f32, dir: Vec3) {
        let u = normalize_or(dir, Vec3::ZERO);
        if w > 0.0 && u != Vec3::ZERO && self.n_dirs < MAX_DIRECTIONS {
            self.dirs[self.n_dirs] = (w, u);
            self.n_dirs += 1;
        }
    }

    /// Eq. 4's neighbours: predicted positions of those within d_rep.
    pub fn repulsion(&mut self, w: f32, d_rep: f32, predicted: &[Vec3]) {
        let n = predicted.len().min(MAX_NEIGHBOURS);
        self.rep[..n].copy_from_slice(&predicted[..n]);
        self.n_rep = if w > 0.0 { n } else { 0 };
        self.rep_w = if n > 0 { w / n as f32 } else { 0.0 };
        self.inv_d_rep = 1.0 / d_rep;
    }

    /// Eq. 6's neighbours: current positions p_j of those between d_att1 and d_att2 (Eq. 6
    /// uses p_j, not p'_j). See [`Attraction`] for how they are summed.
    pub fn attraction(&mut self, w: f32, d_att1: f32, positions: &[Vec3]) {
        let mut a = Attraction::new(self.rho, d_att1, self.p);
        if w > 0.0 {
            positions.iter().for_each(|&q| a.add(q));
        }
        self.attraction_sums(w, &a);
    }

    /// Eq. 6 from sums gathered one neighbour at a time.
    pub fn attraction_sums(&mut self, w: f32, a: &Attraction) {
        let mut a = *a;
        a.sum_pending();
        let (f, g, h) = if w > 0.0 && a.n > 0 {
            let (m, s_i) = (&a.sums[M..M + 6], a.sums[S_I]);
            let h = Mat3::from_cols(
                Vec3::new(m[0] + s_i, m[3], m[4]),
                Vec3::new(m[3], m[1] + s_i, m[5]),
                Vec3::new(m[4], m[5], m[2] + s_i),
            );
            let wn = w / a.n as f32;
            let g = Vec3::from_slice(&a.sums[G..G + 3]);
            (a.sums[F] * wn, g * wn, h * wn)
        } else {
            (0.0, Vec3::ZERO, Mat3::ZERO)
        };
        self.att_f = f;
        self.att_g = g;
        self.att_h = h * 0.5;
    }

    /// Eq. 10 with weight `w` and the database's mean |a| (ā): per candidate
    /// w (e^{ρ‖â′ − â‖} + |‖a′‖ − ‖a‖| / ā). The paper's a′ = v − v_t is a velocity change,
    /// compared with a recorded acceleration; we use a′ = (v − v_t)/Δt, an acceleration,
    /// and divide the magnitude difference by ā so that both parts are unitless and of
    /// order one.
    pub fn acceleration(&mut self, w: f32, mean_accel: f32) {
        self.acc_w = w;
        self.inv_mean_accel = 1.0 / mean_accel;
    }

    /// Eq. 12, startled: a danger at `at` within `d_danger` of the agent.
    pub fn startle(&mut self, w: f32, at: Vec3, d_danger: f32) {
        if w > 0.0 && self.n_startle < MAX_STIMULI {
            self.startle[self.n_startle] = (w, at, 1.0 / d_danger);
            self.n_startle += 1;
        }
    }

    /// E(i, v, a, S_t) of Eq. 2 for candidate velocity `v` with recorded acceleration `a`
    /// (one candidate through the batch evaluation the selection uses).
    pub fn of(&self, v: Vec3, a: Vec3) -> f32 {
        let one = Soa::new(std::iter::once((v, a)));
        self.frame(1.0, 0.0).energies(&one, 0, 1, f32::INFINITY)[0]
    }

    /// The terms in the frame of a family of candidates flown as R s, R the rotation about
    /// +Y by (cos, sin) = (`c`, `s`) (database::turn): every vector turned by Rᵀ, so that
    /// a stored sample s is weighed as it is (R keeps lengths and dot products).
    pub fn frame(&self, c: f32, s: f32) -> Frame {
        let back = |u: Vec3| turn(u, c, -s).to_array();
        let r = Mat3::from_cols(turn(Vec3::X, c, s), Vec3::Y, turn(Vec3::Z, c, s));
        // δ = R s Δt: g·δ = (Rᵀg Δt)·s and δᵀHδ = sᵀ(RᵀHR Δt²)s, H symmetric.
        let h = r.transpose() * self.att_h * r * (self.dt * self.dt);
        let mut f = Frame {
            rho: self.rho,
            dt: self.dt,
            inv_dt: 1.0 / self.dt,
            dirs: [(0.0, [0.0; 3]); MAX_DIRECTIONS],
            n_dirs: self.n_dirs,
            rep: [[0.0; 3]; MAX_NEIGHBOURS],
            n_rep: self.n_rep,
            rep_w: self.rep_w,
            inv_d_rep: self.inv_d_rep,
            startle: [(0.0, [0.0; 3], 0.0); MAX_STIMULI],
            n_startle: self.n_startle,
            att_f: self.att_f,
            att_g: back(self.att_g * self.dt),
            att_h: [
                h.x_axis.x,
                h.y_axis.y,
                h.z_axis.z,
                h.y_axis.x + h.x_axis.y,
                h.z_axis.x + h.x_axis.z,
                h.z_axis.y + h.y_axis.z,
            ],
            v: back(self.v),
            acc_w: self.acc_w,
            inv_mean_accel: self.inv_mean_accel,
        };
        for (k, &(w, u)) in self.dirs[..self.n_dirs].iter().enumerate() {
            f.dirs[k] = (w, back(u));
        }
        for (k, &q) in self.rep[..self.n_rep].iter().enumerate() {
            f.rep[k] = back(self.p - q);
        }
        for (k, &(w, at, inv_d)) in self.startle[..self.n_startle].iter().enumerate() {
            f.startle[k] = (w, back(self.p - at), inv_d);
        }
        f
    }
}

/// One agent's energy terms in the frame of one family of candidates ([`Energy::frame`]):
/// everything that does not depend on the candidate, so that weighing one costs the same
/// whatever the number of attraction neighbours.
#[derive(Clone, Debug)]
pub struct Frame {
    rho: f32,
    dt: f32,
    inv_dt: f32,
    /// (w, Rᵀû) of every direction term.
    dirs: [(f32, [f32; 3]); MAX_DIRECTIONS],
    n_dirs: usize,
    /// Rᵀ(p − p'_j) of every repulsion neighbour (Eq. 4).
    rep: [[f32; 3]; MAX_NEIGHBOURS],
    n_rep: usize,
    rep_w: f32,
    inv_d_rep: f32,
    /// (w, Rᵀ(p − p_sti), 1/d_danger) of every startling stimulus (Eq. 12).
    startle: [(f32, [f32; 3], f32); MAX_STIMULI],
    n_startle: usize,
    /// Eq. 6 expanded: F, RᵀgΔt and the six coefficients of sᵀ(Rᵀ½HR Δt²)s
    /// (xx, yy, zz, xy, xz, yz; the mixed ones doubled).
    att_f: f32,
    att_g: [f32; 3],
    att_h: [f32; 6],
    /// Rᵀv_t, m/s (Eq. 10).
    v: [f32; 3],
    acc_w: f32,
    inv_mean_accel: f32,
}

impl Frame {
    /// E of Eq. 2 for the `count` (≤ [`LANES`]) samples of `d` from `start`, evaluated
    /// [`LANES`] at a time; lanes past `count` are +∞. When no lane is below `best` before
    /// the acceleration term (positive: e^x > 0, |·| ≥ 0, so adding it never lowers a sum),
    /// or, with repulsion neighbours, before the repulsion and startle terms, every lane
    /// is returned as +∞ without them: none could have won.
    #[inline(always)]
    pub fn energies(&self, d: &Soa, start: usize, count: usize, best: f32) -> [f32; LANES] {
        let ld = |a: &[f32]| -> [f32; LANES] {
            a[start..start + LANES]
                .try_into()
                .expect("padded to a whole batch")
        };
        let (vx, vy, vz) = (ld(&d.vx), ld(&d.vy), ld(&d.vz));
        let rho = self.rho;
        let mut e = [0.0f32; LANES];
        // Eq. 6, expanded to second order in δ = vΔt (Energy::attraction).
        let (g, h) = (self.att_g, self.att_h);
        for l in 0..LANES {
            let (x, y, z) = (vx[l], vy[l], vz[l]);
            e[l] = self.att_f
                + (g[0] * x + g[1] * y + g[2] * z)
                + (h[0] * x * x + h[1] * y * y + h[2] * z * z)
                + (h[3] * x * y + h[4] * x * z + h[5] * y * z);
        }
        // Eq. 7, 9, 11 (attracted), 13, 14: w e^{ρ‖ŝ − û‖}, ‖ŝ − û‖ = √(2 − 2ŝ·û) for unit
        // vectors, 1 for a direction-less s.
        let (ux, uy, uz, nodir) = (ld(&d.ux), ld(&d.uy), ld(&d.uz), ld(&d.nodir));
        for &(w, u) in &self.dirs[..self.n_dirs] {
            for l in 0..LANES {
                let c = ux[l] * u[0] + uy[l] * u[1] + uz[l] * u[2];
                let t = (2.0 - 2.0 * c - nodir[l]).max(0.0).sqrt();
                e[l] += w * exp_within(rho * t);
            }
        }
        // With repulsion neighbours, Eq. 10's term is weighed before them: the sum so far
        // plus it is a lower bound of E (the repulsion and startle terms left out are
        // positive, and rounded addition is monotone), so a batch none of whose lanes it
        // puts below `best` is dropped before its repulsion, at these densities the
        // costliest part (about 8 neighbours, one root and one exponential each per lane).
        let acc_first = self.acc_w > 0.0 && self.n_rep > 0;
        let mut acc = [0.0f32; LANES];
        if acc_first {
            acc = self.acceleration(d, start);
            let mut any = false;
            for l in 0..LANES {
                any |= (l < count) & (e[l] + acc[l] < best);
            }
            if !any {
                return [f32::INFINITY; LANES];
            }
        }
        // Eq. 4, exact: ‖p′ − p′_j‖ = ‖Rᵀ(p − p′_j) + sΔt‖.
        let dt = self.dt;
        let mut rep = [0.0f32; LANES];
        for r in &self.rep[..self.n_rep] {
            for l in 0..LANES {
                let (x, y, z) = (r[0] + vx[l] * dt, r[1] + vy[l] * dt, r[2] + vz[l] * dt);
                let len = (x * x + y * y + z * z).sqrt();
                rep[l] += fast_exp(rho * (1.0 - len * self.inv_d_rep));
            }
        }
        for l in 0..LANES {
            e[l] += rep[l] * self.rep_w;
        }
        // Eq. 12, startled, exact.
        for &(w, r, inv_d) in &self.startle[..self.n_startle] {
            for l in 0..LANES {
                let (x, y, z) = (r[0] + vx[l] * dt, r[1] + vy[l] * dt, r[2] + vz[l] * dt);
                let len = (x * x + y * y + z * z).sqrt();
                e[l] += w * fast_exp(rho * (1.0 - len * inv_d));
            }
        }
        for (l, x) in e.iter_mut().enumerate() {
            if l >= count {
                *x = f32::INFINITY;
            }
        }
        if self.acc_w > 0.0 {
            if !acc_first {
                if !e.iter().any(|&x| x < best) {
                    return [f32::INFINITY; LANES];
                }
                acc = self.acceleration(d, start);
            }
            for l in 0..LANES {
                e[l] += acc[l];
            }
        }
        e
    }

    /// Eq. 10's term (see Energy::acceleration) for the [`LANES`] samples of `d` from
    /// `start`: a′ = (s − Rᵀv_t)/Δt, so â′·â = b·â/‖b‖ with b = s − Rᵀv_t, and
    /// ‖â′ − â‖² = |â′|² + |â|² − 2â′·â, |·|² 1 or 0.
    #[inline(always)]
    fn acceleration(&self, d: &Soa, start: usize) -> [f32; LANES] {
        let ld = |a: &[f32]| -> [f32; LANES] {
            a[start..start + LANES]
                .try_into()
                .expect("padded to a whole batch")
        };
        let (vx, vy, vz) = (ld(&d.vx), ld(&d.vy), ld(&d.vz));
        let (ax, ay, az) = (ld(&d.ax), ld(&d.ay), ld(&d.az));
        let (ahas, alen) = (ld(&d.ahas), ld(&d.alen));
        let (v, rho) = (self.v, self.rho);
        let mut acc = [0.0f32; LANES];
        for l in 0..LANES {
            let (bx, by, bz) = (vx[l] - v[0], vy[l] - v[1], vz[l] - v[2]);
            let lb = (bx * bx + by * by + bz * bz).sqrt();
            let l1 = lb * self.inv_dt;
            let has = l1 > 1e-9;
            let inv = if has { 1.0 / lb } else { 0.0 };
            let m1 = if has { 1.0 } else { 0.0 };
            let cos = (bx * ax[l] + by * ay[l] + bz * az[l]) * inv;
            let dir = (m1 + ahas[l] - 2.0 * cos).max(0.0).sqrt();
            acc[l] =
                self.acc_w * (exp_within(rho * dir) + (l1 - alen[l]).abs() * self.inv_mean_accel);
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::super::database::Database;
    use super::*;

    #[test]
    fn fast_exp_is_exp() {
        let mut worst = 0.0f32;
        for k in -4000..=4000 {
            let x = k as f32 * 0.02;
            worst = worst.max((fast_exp(x) / x.exp() - 1.0).abs());
        }
        // 6.4e-6 measured (a degree-3 fit would be 4e-4).
        assert!(worst < 1e-5, "relative error {worst}");
    }

    #[test]
    fn exp_within_its_range_is_fast_exp_bit_for_bit() {
        // From −87 to 87 at a 2⁻¹⁰ step (the direction terms' exponents lie in [0, 86]):
        // the two must not drift apart.
        for k in -(87 << 10)..=(87 << 10) {
            let x = k as f32 / 1024.0;
            assert_eq!(exp_within(x).to_bits(), fast_exp(x).to_bits(), "{x}");
        }
    }

    #[test]
    fn buffered_attraction_sums_are_the_one_at_a_time_sums() {
        // 21 neighbours (two full buffers and a part): the sums bit for bit as adding
        // each neighbour's terms as it comes.
        let (rho, d1) = (2.5f32, 0.08f32);
        let p = Vec3::new(0.1, 1.0, -0.2);
        let mut rng = crate::math::Rng::new(3, 0, 0);
        let nbrs: Vec<Vec3> = (0..21)
            .map(|_| {
                p + Vec3::new(
                    rng.range(-0.3, 0.3),
                    rng.range(-0.3, 0.3),
                    rng.range(-0.3, 0.3),
                )
            })
            .collect();
        let mut a = Attraction::new(rho, d1, p);
        nbrs.iter().for_each(|&q| a.add(q));
        a.sum_pending();
        let k = rho / d1;
        let (mut f, mut g, mut s_i, mut m) = (0.0f32, Vec3::ZERO, 0.0f32, [0.0f32; 6]);
        for &q in &nbrs {
            let r = p - q;
            let d = r.length().max(1e-6);
            let inv = 1.0 / d;
            let u = r * inv;
            let fj = fast_exp(rho * (d * (1.0 / d1) - 1.0));
            f += fj;
            g += u * (fj * k);
            s_i += fj * k * inv;
            let c = fj * (k * k - k * inv);
            m[0] += c * u.x * u.x;
            m[1] += c * u.y * u.y;
            m[2] += c * u.z * u.z;
            m[3] += c * u.x * u.y;
            m[4] += c * u.x * u.z;
            m[5] += c * u.y * u.z;
        }
        assert_eq!(a.n, 21);
        let want = [f, g.x, g.y, g.z, s_i, m[0], m[1], m[2], m[3], m[4], m[5]];
        assert_eq!(
            a.sums[..TERMS]
                .iter()
                .map(|x| x.to_bits())
                .collect::<Vec<_>>(),
            want.map(f32::to_bits)
        );
    }

    #[test]
    fn gathering_by_batches_is_adding_one_at_a_time() {
        // The zone's neighbours taken a batch at a time without a branch per hit (and, on
        // CPUs with AVX2, summed eight to an instruction) against each added as the scan
        // finds it: the same neighbours, the same count and the same sums bit for bit,
        // also when the limit cuts a batch.
        let (rho, d1, d2) = (2.5f32, 0.08f32, 0.3f32);
        let pts = super::super::neighbours::cloud(13, 400, Vec3::new(0.4, 0.3, 0.4));
        let mut cells = CellIndex::default();
        cells.build(&pts, d2);
        let bits = |a: &Attraction| {
            let mut a = *a;
            a.sum_pending();
            (a.n, a.sums.map(f32::to_bits))
        };
        let mut cut = 0;
        for (i, &p) in pts.iter().enumerate().take(60) {
            // r1 = 0: the agent itself is in the shell, and must be left out.
            for (r1, limit) in [(d1, 512), (d1, 13), (0.0, 512)] {
                let mut one = Attraction::new(rho, d1, p);
                cells.for_each_in_shell(p, r1, d2, |j, q| {
                    if j != i && one.n < limit {
                        one.add(q);
                    }
                });
                let zone = Zone {
                    r0: 0.12,
                    r1,
                    r2: d2,
                    limit,
                };
                let mut near = Nearest::default();
                let mut batched = Attraction::new(rho, d1, p);
                batched.gather(&cells, i, zone, &mut near);
                let mut alone = Nearest::default();
                cells.nearest_within(p, 0.12, i, &mut alone);
                assert_eq!(near.found(), alone.found(), "agent {i}");
                cut += usize::from(limit == 13 && one.n == 13);
                assert_eq!(
                    bits(&one),
                    bits(&batched),
                    "agent {i}, r1 {r1}, limit {limit}"
                );
                // Every build, whichever `gather` picked on this CPU.
                let mut portable = Attraction::new(rho, d1, p);
                let mut near = Nearest::default();
                portable.gather_batches::<false, false, 8>(&cells, i, zone, &mut near);
                assert_eq!(near.found(), alone.found(), "agent {i}");
                assert_eq!(
                    bits(&one),
                    bits(&portable),
                    "agent {i}, r1 {r1}, limit {limit}"
                );
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2") {
                    let mut avx2 = Attraction::new(rho, d1, p);
                    let mut near = Nearest::default();
                    // SAFETY: AVX2 checked just above.
                    unsafe { avx2.gather_avx2(&cells, i, zone, &mut near) };
                    assert_eq!(near.found(), alone.found(), "agent {i}");
                    assert_eq!(bits(&one), bits(&avx2), "agent {i}, r1 {r1}, limit {limit}");
                }
            }
        }
        assert!(cut > 40, "{cut}");
    }

    #[test]
    fn the_expanded_attraction_matches_the_exact_sum() {
        let (rho, d1) = (2.5f32, 0.08f32);
        let p = Vec3::new(0.1, 1.0, -0.2);
        let nbrs = [
            p + Vec3::new(0.09, 0.0, 0.0),
            p + Vec3::new(-0.1, 0.2, 0.05),
            p + Vec3::new(0.0, -0.05, 0.25),
        ];
        let mut e = Energy::new(rho, 0.02, p, Vec3::ZERO);
        e.attraction(1.0, d1, &nbrs);
        let mut worst = 0.0f32;
        for v in [Vec3::X, -Vec3::X, Vec3::Y * 0.5, Vec3::new(0.3, -0.2, 0.6)] {
            let p1 = p + v * 0.02;
            let exact = nbrs
                .iter()
                .map(|q| (rho * ((p1 - *q).length() / d1 - 1.0)).exp())
                .sum::<f32>()
                / 3.0;
            worst = worst.max((e.of(v, Vec3::ZERO) / exact - 1.0).abs());
        }
        assert!(worst < 0.01, "relative error {worst}");
    }

    #[test]
    fn the_expansion_error_per_neighbour_is_bounded() {
        // Every neighbour from d_att1 to d_att2 in 24 × 12 directions, every move of up to
        // 1 cm (0.5 m/s at Δt = 0.02 s, faster than 96 % of the shipped samples) and 2 cm
        // in 24 × 12 directions: the expanded term against the exact one.
        let (rho, d1, d2) = (2.5f32, 0.08f32, 0.3f32);
        let dir = |a: usize, b: usize| {
            let (t, f) = (a as f32 * 0.2618, (b as f32 + 0.5) * 0.2618);
            Vec3::new(f.sin() * t.cos(), f.cos(), f.sin() * t.sin())
        };
        let mut worst = [0.0f32; 2];
        for step in 0..=10 {
            let d = d1 + (d2 - d1) * step as f32 / 10.0;
            for (a, b) in (0..24).flat_map(|a| (0..12).map(move |b| (a, b))) {
                let q = -dir(a, b) * d;
                let mut e = Energy::new(rho, 0.02, Vec3::ZERO, Vec3::ZERO);
                e.attraction(1.0, d1, &[q]);
                let frame = e.frame(1.0, 0.0);
                for (c, m) in (0..24).flat_map(|c| (0..12).map(move |m| (c, m))) {
                    for (k, len) in [0.01f32, 0.02].into_iter().enumerate() {
                        let delta = dir(c, m) * len;
                        let (ex, ey, ez) = (delta.x, delta.y, delta.z);
                        let (g, h) = (frame.att_g, frame.att_h);
                        let v = Vec3::new(ex, ey, ez) / 0.02;
                        let approx = frame.att_f
                            + (g[0] * v.x + g[1] * v.y + g[2] * v.z)
                            + (h[0] * v.x * v.x + h[1] * v.y * v.y + h[2] * v.z * v.z)
                            + (h[3] * v.x * v.y + h[4] * v.x * v.z + h[5] * v.y * v.z);
                        let exact = (rho * ((delta - q).length() / d1 - 1.0)).exp();
                        worst[k] = worst[k].max((approx / exact - 1.0).abs());
                    }
                }
            }
        }
        assert!(worst[0] < 0.007, "1 cm: relative error {}", worst[0]);
        assert!(worst[1] < 0.07, "2 cm: relative error {}", worst[1]);
    }

    #[test]
    fn a_batch_in_a_turned_frame_is_the_world_energy() {
        // Every term at once, for candidates flown as R s: the batch in R's frame against
        // Eq. 2 written out in the world frame.
        let (rho, dt) = (2.5f32, 0.02f32);
        let p = Vec3::new(0.1, 1.0, -0.2);
        let v = Vec3::new(0.15, 0.02, -0.1);
        let mut e = Energy::new(rho, dt, p, v);
        let dirs = [(1.0, v), (0.2, Vec3::new(0.3, -1.0, 0.2)), (0.05, -p)];
        for (w, u) in dirs {
            e.direction(w, u);
        }
        let rep = [
            p + Vec3::new(0.01, 0.005, 0.0),
            p + Vec3::new(-0.01, 0.0, 0.02),
        ];
        e.repulsion(1.0, 0.03, &rep);
        let att = [p + Vec3::new(0.1, 0.0, 0.05), p + Vec3::new(0.0, -0.2, 0.1)];
        e.attraction(1.0, 0.08, &att);
        let danger = p + Vec3::new(0.1, 0.1, 0.0);
        e.startle(2.0, danger, 0.3);
        e.acceleration(1.0, 2.0);
        let (s, c) = 1.1f32.sin_cos();
        let db = Database::default_mosquito();
        let f = db.family(super::super::database::Family::Free);
        let frame = e.frame(c, s);
        let energies = frame.energies(f, 100, LANES, f32::INFINITY);
        for (l, &got) in energies.iter().enumerate() {
            let sample = db.samples[super::super::database::Family::Free.index(100 + l)];
            let (vw, aw) = (turn(sample.v, c, s), turn(sample.a, c, s));
            let p1 = p + vw * dt;
            let unit = |u: Vec3| normalize_or(u, Vec3::ZERO);
            let mut want = 0.0;
            for (w, u) in dirs {
                want += w * (rho * (unit(vw) - unit(u)).length()).exp();
            }
            want += rep
                .iter()
                .map(|q| (rho * (1.0 - (p1 - *q).length() / 0.03)).exp())
                .sum::<f32>()
                / 2.0;
            let d = vw * dt;
            let h = e.att_h;
            want += e.att_f + e.att_g.dot(d) + d.dot(h * d);
            want += 2.0 * (rho * (1.0 - (p1 - danger).length() / 0.3)).exp();
            let a1 = (vw - v) / dt;
            want += (rho * (unit(a1) - unit(aw)).length()).exp()
                + (a1.length() - aw.length()).abs() / 2.0;
            assert!(
                (got / want - 1.0).abs() < 1e-4,
                "lane {l}: {got} against {want}"
            );
        }
    }

    #[test]
    fn each_term_prefers_what_the_paper_says() {
        let dt = 0.02;
        // Direction terms: the candidate along the direction wins.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::X * 0.2);
        e.direction(1.0, Vec3::Z);
        assert!(e.of(Vec3::Z * 0.2, Vec3::ZERO) < e.of(Vec3::X * 0.2, Vec3::ZERO));
        assert!(
            (e.of(Vec3::Z * 0.2, Vec3::ZERO) - 1.0).abs() < 1e-6,
            "e^0 = 1"
        );
        // Repulsion: moving away from a close neighbour costs less.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::ZERO);
        e.repulsion(1.0, 0.03, &[Vec3::X * 0.01]);
        assert!(e.of(-Vec3::X * 0.3, Vec3::ZERO) < e.of(Vec3::X * 0.3, Vec3::ZERO));
        // Attraction: moving towards a far neighbour costs less.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::ZERO);
        e.attraction(1.0, 0.08, &[Vec3::X * 0.2]);
        assert!(e.of(Vec3::X * 0.3, Vec3::ZERO) < e.of(-Vec3::X * 0.3, Vec3::ZERO));
        // Startle: moving away from the danger costs less.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::ZERO);
        e.startle(2.0, Vec3::Y * 0.1, 0.3);
        assert!(e.of(-Vec3::Y * 0.5, Vec3::ZERO) < e.of(Vec3::Y * 0.5, Vec3::ZERO));
        // Acceleration continuity: the candidate whose change matches its recorded
        // acceleration (0.04 m/s over 0.02 s = 2 m/s² along +x) is cheapest.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::X * 0.2);
        e.acceleration(1.0, 2.0);
        let good = e.of(Vec3::X * 0.24, Vec3::X * 2.0);
        assert!((good - 1.0).abs() < 1e-4, "{good}");
        assert!(good < e.of(Vec3::X * 0.24, -Vec3::X * 2.0));
        assert!(good < e.of(Vec3::X * 0.30, Vec3::X * 2.0));
    }
}
