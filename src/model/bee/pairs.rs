//! A bee's sums over its listed neighbours, many neighbours at a time: Eq. 10's density
//! (the gather pass) and Eq. 11's pressure push with Sec. VII's contact spring (the step).
//! Sixteen lanes with AVX-512 for a long list (its records gathered), eight with AVX2 for
//! a short one, or any list where AVX-512 does not run (its records loaded whole and
//! transposed). Each lane does exactly the arithmetic of
//! [`super::repulsion::density_term`], [`super::repulsion::pressure_term`] and
//! [`crate::model::collision`]'s spring for its neighbour (no fused multiply-add), and
//! the terms are then added in the list's order, so the sums are the same bits as the
//! one-at-a-time loops. Its square roots and divisions become one instruction per group.

use super::kernels::Kernels;
use crate::model::context::{MAX_NEIGHBOURS, Neighbour};
use glam::Vec3;

/// Lists at least this long take the sixteen lanes: for shorter ones (a sparse swarm's
/// seven or so) gathering the neighbours' fields into lanes costs more than the loop.
const WIDE_FROM: usize = 8;

/// Lists at least this long take the eight lanes (where the sixteen do not).
const NARROW_FROM: usize = 6;

/// The lanes that take a list here: sixteen, eight, or none (the one-at-a-time loop).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
enum Width {
    Loop,
    /// AVX2 (either level).
    Eight,
    /// AVX-512 F.
    Sixteen,
}

#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
impl Width {
    /// The width for a list of `len` neighbours, from `crate::simd`'s level.
    #[inline]
    fn of(len: usize) -> Width {
        use crate::simd::Level;
        if len < NARROW_FROM {
            return Width::Loop;
        }
        match crate::simd::level() {
            Level::Avx512 if len >= WIDE_FROM => Width::Sixteen,
            Level::Avx512 | Level::Avx2 => Width::Eight,
            Level::Portable => Width::Loop,
        }
    }
}

/// What the pair terms of one bee need besides its neighbours.
pub(super) struct Bee<'a> {
    pub kernels: &'a Kernels,
    pub pos: Vec3,
    pub vel: Vec3,
    /// Body radius, m.
    pub radius: f32,
    pub density: f32,
    pub pressure: f32,
    /// Neighbours at this distance or farther are left out, m.
    pub reach: f32,
    /// Contact spring stiffness, 1/s².
    pub spring: f32,
}

/// The sums over `list` (indices into `agents`) of the pressure terms and the contact
/// springs, as the step's loop adds them; `None` where no wide path runs (`crate::simd`),
/// the list is shorter than `NARROW_FROM`, or a neighbour within reach coincides with the
/// bee (the loop's fallback direction then separates them).
#[inline]
pub(super) fn sums(agents: &[Neighbour], list: &[u32], bee: &Bee) -> Option<(Vec3, Vec3)> {
    #[cfg(target_arch = "x86_64")]
    match Width::of(list.len()) {
        // SAFETY (both): the CPU has the width's instructions (`Width::of`).
        Width::Sixteen => return unsafe { sums16(agents, list, bee) },
        Width::Eight => return unsafe { sums8(agents, list, bee) },
        Width::Loop => {}
    }
    let _ = (agents, list, bee);
    None
}

/// One neighbour's terms, (Eq. 11's pressure push, Sec. VII's contact spring), for a
/// neighbour `o` at `pj` whose squared distance from the bee is `d2` (within reach):
/// what the lanes of `sums` each work out, and what the step adds one neighbour at a time
/// where they do not. `fallback` separates coincident bodies.
#[inline(always)]
pub(super) fn one(
    bee: &Bee,
    o: &Neighbour,
    pj: Vec3,
    d2: f32,
    fallback: impl Fn() -> Vec3 + Copy,
) -> (Vec3, Vec3) {
    let (r, dist) = (bee.pos - pj, d2.sqrt());
    let contact = bee.radius + o.radius;
    let rho_j = if o.density > 0.0 {
        o.density
    } else {
        bee.density
    };
    let push = super::repulsion::pressure_term(
        bee.kernels,
        r,
        dist,
        contact,
        o.mass,
        bee.pressure,
        o.pressure,
        bee.density,
        rho_j,
        fallback,
    );
    let rel = bee.vel - o.vel;
    let spring = crate::model::collision::spring_accel(r, dist, contact, rel, bee.spring, fallback);
    (push, spring)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn sums16(agents: &[Neighbour], list: &[u32], bee: &Bee) -> Option<(Vec3, Vec3)> {
    use std::arch::x86_64::*;
    // SAFETY: the CPU has AVX-512 F (this function's own target).
    let (valid, floats) = unsafe { records16(agents, list, ALL_WORDS) }?;
    let field = |offset: usize| floats[offset / 4];
    let (pos, vel) = (
        std::mem::offset_of!(Neighbour, pos),
        std::mem::offset_of!(Neighbour, vel),
    );
    let (px, py, pz) = (field(pos), field(pos + 4), field(pos + 8));
    let (vx, vy, vz) = (field(vel), field(vel + 4), field(vel + 8));
    let radius = field(std::mem::offset_of!(Neighbour, radius));
    let mass = field(std::mem::offset_of!(Neighbour, mass));
    let density = field(std::mem::offset_of!(Neighbour, density));
    let pressure = field(std::mem::offset_of!(Neighbour, pressure));

    let splat = _mm512_set1_ps;
    let (add, sub, mul, div) = (
        |a, b| _mm512_add_ps(a, b),
        |a, b| _mm512_sub_ps(a, b),
        |a, b| _mm512_mul_ps(a, b),
        |a, b| _mm512_div_ps(a, b),
    );
    let zero = _mm512_setzero_ps();
    // r = bee − neighbour; `for_each_neighbour`'s squared distance and reach.
    let (rx, ry, rz) = (
        sub(splat(bee.pos.x), px),
        sub(splat(bee.pos.y), py),
        sub(splat(bee.pos.z), pz),
    );
    let d2 = add(add(mul(rx, rx), mul(ry, ry)), mul(rz, rz));
    let within = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(valid, d2, splat(bee.reach * bee.reach));
    let dist = _mm512_sqrt_ps(d2);
    // Coincident bodies take the loop's fallback direction.
    if _mm512_mask_cmp_ps_mask::<_CMP_GT_OQ>(within, dist, splat(1e-9)) != within {
        return None;
    }
    let (dx, dy, dz) = (div(rx, dist), div(ry, dist), div(rz, dist));
    let contact = add(splat(bee.radius), radius);

    // Eq. 11 (`repulsion::pressure_term`).
    let k = bee.kernels;
    let s = _mm512_max_ps(sub(dist, contact), zero);
    let rho_i = splat(bee.density);
    let rho_j = _mm512_mask_blend_ps(
        _mm512_cmp_ps_mask::<_CMP_GT_OQ>(density, zero),
        rho_i,
        density,
    );
    let p_sum = add(splat(bee.pressure), pressure);
    let pushes = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(within, s, splat(k.h))
        & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(rho_j, zero)
        & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(p_sum, zero);
    let pushes = if bee.density > 0.0 { pushes } else { 0 };
    let x = sub(splat(k.h), s);
    let grad = mul(mul(splat(k.spiky_coef()), x), x);
    let scale = div(
        mul(mul(grad, mass), p_sum),
        mul(mul(splat(2.0), rho_i), rho_j),
    );
    let rep = [dx, dy, dz].map(|d| _mm512_maskz_mul_ps(pushes, d, scale));

    // Sec. VII (`collision::spring_accel`).
    let overlap = sub(contact, dist);
    let touches = _mm512_mask_cmp_ps_mask::<_CMP_GT_OQ>(within, overlap, zero);
    let (wx, wy, wz) = (
        sub(splat(bee.vel.x), vx),
        sub(splat(bee.vel.y), vy),
        sub(splat(bee.vel.z), vz),
    );
    let closing = _mm512_min_ps(add(add(mul(wx, dx), mul(wy, dy)), mul(wz, dz)), zero);
    let spring = splat(bee.spring);
    let damping = splat(2.0 * bee.spring.sqrt());
    let push = sub(mul(spring, overlap), mul(damping, closing));
    let col = [dx, dy, dz].map(|d| _mm512_maskz_mul_ps(touches, d, push));

    // Added in the list's order, every neighbour within reach (a zero term too, as the
    // loop adds it).
    let lanes = |v: __m512| {
        let mut a = [0.0f32; 16];
        // SAFETY: `a` holds sixteen f32s.
        unsafe { _mm512_storeu_ps(a.as_mut_ptr(), v) };
        a
    };
    let (rep, col) = (rep.map(lanes), col.map(lanes));
    let (mut a_rep, mut a_col) = (Vec3::ZERO, Vec3::ZERO);
    add_in_order(&rep, &col, within as u32, &mut a_rep, &mut a_col);
    Some((a_rep, a_col))
}

/// Adds to `a_rep` and `a_col` the terms (x, y, z by lane) of the lanes set in `within`,
/// in lane order, the list's: a zero term too, as the loop adds it.
#[inline(always)]
fn add_in_order<const W: usize>(
    rep: &[[f32; W]; 3],
    col: &[[f32; W]; 3],
    within: u32,
    a_rep: &mut Vec3,
    a_col: &mut Vec3,
) {
    let mut left = within;
    while left != 0 {
        let l = left.trailing_zeros() as usize;
        left &= left - 1;
        *a_rep += Vec3::new(rep[0][l], rep[1][l], rep[2][l]);
        *a_col += Vec3::new(col[0][l], col[1][l], col[2][l]);
    }
}

/// A record's five pairs of f32s, by bit: all of them.
#[cfg(target_arch = "x86_64")]
const ALL_WORDS: u8 = 0b11111;

/// The records of `list` (at most sixteen indices into `agents`), field by field in the
/// lanes of ten vectors (f32 `k` of each record in vector `k`; lanes past the list are
/// zero), and the mask of the list's lanes; only the pairs of f32s whose bits are set in
/// `words` are read (the rest stay zero). `None` if the list is longer than sixteen or an
/// index lies outside `agents`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn records16(
    agents: &[Neighbour],
    list: &[u32],
    words: u8,
) -> Option<(
    std::arch::x86_64::__mmask16,
    [std::arch::x86_64::__m512; 10],
)> {
    use std::arch::x86_64::*;
    const _: () = assert!(MAX_NEIGHBOURS <= 16);
    if list.len() > 16 {
        return None;
    }
    let valid: __mmask16 = ((1u32 << list.len()) - 1) as u16;
    // SAFETY: lanes past `n` are masked out of the load.
    let idx = unsafe { _mm512_maskz_loadu_epi32(valid, list.as_ptr().cast()) };
    // Every index must lie in `agents` before it is gathered from.
    let len = _mm512_set1_epi32(agents.len().min(i32::MAX as usize) as i32);
    if _mm512_mask_cmpge_epu32_mask(valid, idx, len) != 0 {
        return None;
    }
    // The records, ten f32s each, gathered two f32s at a time (each half of the list's
    // indices gathers eight pairs), then each pair split into its two fields' lanes.
    const WORDS: usize = size_of::<Neighbour>() / 8;
    const _: () = assert!(size_of::<Neighbour>() == 40);
    let base = _mm512_mullo_epi32(idx, _mm512_set1_epi32(WORDS as i32));
    let (lo_half, hi_half) = (
        _mm512_castsi512_si256(base),
        _mm512_extracti64x4_epi64::<1>(base),
    );
    let (even, odd) = (
        _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30),
        _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31),
    );
    let mut floats = [_mm512_setzero_ps(); 10];
    for w in 0..WORDS {
        if words & (1 << w) == 0 {
            continue;
        }
        let gather = |half: __m256i, mask: __mmask8| {
            let at = _mm256_add_epi32(half, _mm256_set1_epi32(w as i32));
            // SAFETY: every index is below `agents.len()` (checked above) and word w
            // lies within its record: the reads stay inside `agents`.
            unsafe {
                _mm512_mask_i32gather_epi64::<8>(
                    _mm512_setzero_si512(),
                    mask,
                    at,
                    agents.as_ptr().cast(),
                )
            }
        };
        let lo = _mm512_castsi512_ps(gather(lo_half, valid as u8));
        let hi = _mm512_castsi512_ps(gather(hi_half, (valid >> 8) as u8));
        floats[2 * w] = _mm512_permutex2var_ps(lo, even, hi);
        floats[2 * w + 1] = _mm512_permutex2var_ps(lo, odd, hi);
    }
    Some((valid, floats))
}

/// Eq. 10's density sum over `list` for the bee whose record is `me`, starting from `own`
/// (its own term), as the gather pass adds it one neighbour at a time
/// (`BeeModel::gather_term`, with the bee's body radius `me.radius`); `None` where no wide
/// path runs (`crate::simd`) or the list is short.
#[inline]
pub(super) fn density_sum(
    k: &Kernels,
    agents: &[Neighbour],
    list: &[u32],
    me: &Neighbour,
    own: f32,
) -> Option<f32> {
    #[cfg(target_arch = "x86_64")]
    match Width::of(list.len()) {
        // SAFETY (both): the CPU has the width's instructions (`Width::of`).
        Width::Sixteen => return unsafe { density16(k, agents, list, me, own) },
        Width::Eight => return unsafe { density8(k, agents, list, me, own) },
        Width::Loop => {}
    }
    let _ = (k, agents, list, me, own);
    None
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn density16(
    k: &Kernels,
    agents: &[Neighbour],
    list: &[u32],
    me: &Neighbour,
    own: f32,
) -> Option<f32> {
    let ri = me.radius;
    use std::arch::x86_64::*;
    let (pos, radius, mass) = (
        std::mem::offset_of!(Neighbour, pos),
        std::mem::offset_of!(Neighbour, radius),
        std::mem::offset_of!(Neighbour, mass),
    );
    // Only the pairs that hold the position, body radius and mass.
    let words = [pos, pos + 4, pos + 8, radius, mass]
        .iter()
        .fold(0u8, |w, &o| w | 1 << (o / 8));
    // SAFETY: the CPU has AVX-512 F (this function's own target).
    let (valid, floats) = unsafe { records16(agents, list, words) }?;
    let field = |offset: usize| floats[offset / 4];
    let splat = _mm512_set1_ps;
    // `me.pos.distance_squared(o.pos)`: (me − o)², summed x, y, z.
    let (rx, ry, rz) = (
        _mm512_sub_ps(splat(me.pos.x), field(pos)),
        _mm512_sub_ps(splat(me.pos.y), field(pos + 4)),
        _mm512_sub_ps(splat(me.pos.z), field(pos + 8)),
    );
    let d2 = _mm512_add_ps(
        _mm512_add_ps(_mm512_mul_ps(rx, rx), _mm512_mul_ps(ry, ry)),
        _mm512_mul_ps(rz, rz),
    );
    // `repulsion::density_term`: m_j W_poly6(max(d − (r_i + r_j), 0)), zero from h on.
    let contact = _mm512_add_ps(splat(ri), field(radius));
    let s = _mm512_max_ps(
        _mm512_sub_ps(_mm512_sqrt_ps(d2), contact),
        _mm512_setzero_ps(),
    );
    let inside = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(valid, s, splat(k.h));
    let x = _mm512_sub_ps(splat(k.h * k.h), _mm512_mul_ps(s, s));
    let w = _mm512_mul_ps(_mm512_mul_ps(_mm512_mul_ps(splat(k.poly6_coef()), x), x), x);
    // m_j · 0 where the kernel is zero, as the loop multiplies it.
    let terms = _mm512_mul_ps(field(mass), _mm512_maskz_mov_ps(inside, w));
    let mut lanes = [0.0f32; 16];
    // SAFETY: `lanes` holds sixteen f32s.
    unsafe { _mm512_storeu_ps(lanes.as_mut_ptr(), terms) };
    // Added in the list's order (a zero term too, as the loop adds it).
    let mut sum = own;
    for t in &lanes[..list.len()] {
        sum += t;
    }
    Some(sum)
}

/// Up to eight of `list`'s records (from place `from`), field by field in the lanes of
/// ten vectors (f32 `k` of each record in vector `k`; lanes past the list are a zero
/// record), and the bits of the lanes that hold one. Each record is one load of its first
/// eight f32s and one of its last two, put in lanes by a transpose. `None` if an index
/// lies outside `agents`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn records8(
    agents: &[Neighbour],
    list: &[u32],
    from: usize,
    tail: bool,
) -> Option<(u32, [std::arch::x86_64::__m256; 10])> {
    use std::arch::x86_64::*;
    const _: () = assert!(size_of::<Neighbour>() == 40);
    let zero = Neighbour::default();
    let n = list.len().saturating_sub(from).min(8);
    let mut recs = [&zero; 8];
    for (r, &j) in recs.iter_mut().zip(&list[from..from + n]) {
        *r = agents.get(j as usize)?;
    }
    // SAFETY: each record holds ten f32s: eight from its start, two from its ninth.
    let head = |r: &Neighbour| unsafe { _mm256_loadu_ps((r as *const Neighbour).cast()) };
    let (t0, t1, t2, t3, t4, t5, t6, t7) = (
        _mm256_unpacklo_ps(head(recs[0]), head(recs[1])),
        _mm256_unpackhi_ps(head(recs[0]), head(recs[1])),
        _mm256_unpacklo_ps(head(recs[2]), head(recs[3])),
        _mm256_unpackhi_ps(head(recs[2]), head(recs[3])),
        _mm256_unpacklo_ps(head(recs[4]), head(recs[5])),
        _mm256_unpackhi_ps(head(recs[4]), head(recs[5])),
        _mm256_unpacklo_ps(head(recs[6]), head(recs[7])),
        _mm256_unpackhi_ps(head(recs[6]), head(recs[7])),
    );
    let (s0, s1, s2, s3) = (
        _mm256_shuffle_ps::<0x44>(t0, t2),
        _mm256_shuffle_ps::<0xEE>(t0, t2),
        _mm256_shuffle_ps::<0x44>(t1, t3),
        _mm256_shuffle_ps::<0xEE>(t1, t3),
    );
    let (s4, s5, s6, s7) = (
        _mm256_shuffle_ps::<0x44>(t4, t6),
        _mm256_shuffle_ps::<0xEE>(t4, t6),
        _mm256_shuffle_ps::<0x44>(t5, t7),
        _mm256_shuffle_ps::<0xEE>(t5, t7),
    );
    let mut f = [_mm256_setzero_ps(); 10];
    f[0] = _mm256_permute2f128_ps::<0x20>(s0, s4);
    f[1] = _mm256_permute2f128_ps::<0x20>(s1, s5);
    f[2] = _mm256_permute2f128_ps::<0x20>(s2, s6);
    f[3] = _mm256_permute2f128_ps::<0x20>(s3, s7);
    f[4] = _mm256_permute2f128_ps::<0x31>(s0, s4);
    f[5] = _mm256_permute2f128_ps::<0x31>(s1, s5);
    f[6] = _mm256_permute2f128_ps::<0x31>(s2, s6);
    f[7] = _mm256_permute2f128_ps::<0x31>(s3, s7);
    if tail {
        // SAFETY: f32s 8 and 9 of a record, 8 bytes from byte 32 of its 40.
        let last = |r: &Neighbour| unsafe {
            _mm_castpd_ps(_mm_load_sd((r as *const Neighbour).cast::<f64>().add(4)))
        };
        let half = |a: usize| {
            let lo = _mm_unpacklo_ps(last(recs[a]), last(recs[a + 1]));
            let hi = _mm_unpacklo_ps(last(recs[a + 2]), last(recs[a + 3]));
            (_mm_movelh_ps(lo, hi), _mm_movehl_ps(hi, lo))
        };
        let ((d0, p0), (d1, p1)) = (half(0), half(4));
        f[8] = _mm256_set_m128(d1, d0);
        f[9] = _mm256_set_m128(p1, p0);
    }
    Some(((1u32 << n) - 1, f))
}

/// [`sums16`] eight lanes at a time with AVX2 (lists of up to sixteen in two groups, the
/// terms added in the list's order across them).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn sums8(agents: &[Neighbour], list: &[u32], bee: &Bee) -> Option<(Vec3, Vec3)> {
    use std::arch::x86_64::*;
    let field = |offset: usize| offset / 4;
    let (pos, vel) = (
        std::mem::offset_of!(Neighbour, pos),
        std::mem::offset_of!(Neighbour, vel),
    );
    let splat = _mm256_set1_ps;
    let (add, sub, mul, div) = (
        |a, b| _mm256_add_ps(a, b),
        |a, b| _mm256_sub_ps(a, b),
        |a, b| _mm256_mul_ps(a, b),
        |a, b| _mm256_div_ps(a, b),
    );
    let (lt, gt) = (
        |a, b| _mm256_cmp_ps::<_CMP_LT_OQ>(a, b),
        |a, b| _mm256_cmp_ps::<_CMP_GT_OQ>(a, b),
    );
    let zero = _mm256_setzero_ps();
    let k = bee.kernels;
    let (mut a_rep, mut a_col) = (Vec3::ZERO, Vec3::ZERO);
    for from in (0..list.len()).step_by(8) {
        // SAFETY: the CPU has AVX2 (this function's own target).
        let (valid, f) = unsafe { records8(agents, list, from, true) }?;
        let (px, py, pz) = (f[field(pos)], f[field(pos + 4)], f[field(pos + 8)]);
        let (vx, vy, vz) = (f[field(vel)], f[field(vel + 4)], f[field(vel + 8)]);
        let radius = f[field(std::mem::offset_of!(Neighbour, radius))];
        let mass = f[field(std::mem::offset_of!(Neighbour, mass))];
        let density = f[field(std::mem::offset_of!(Neighbour, density))];
        let pressure = f[field(std::mem::offset_of!(Neighbour, pressure))];
        // r = bee − neighbour; `for_each_neighbour`'s squared distance and reach.
        let (rx, ry, rz) = (
            sub(splat(bee.pos.x), px),
            sub(splat(bee.pos.y), py),
            sub(splat(bee.pos.z), pz),
        );
        let d2 = add(add(mul(rx, rx), mul(ry, ry)), mul(rz, rz));
        let within = _mm256_movemask_ps(lt(d2, splat(bee.reach * bee.reach))) as u32 & valid;
        let dist = _mm256_sqrt_ps(d2);
        // Coincident bodies take the loop's fallback direction.
        if _mm256_movemask_ps(gt(dist, splat(1e-9))) as u32 & within != within {
            return None;
        }
        let (dx, dy, dz) = (div(rx, dist), div(ry, dist), div(rz, dist));
        let contact = add(splat(bee.radius), radius);

        // Eq. 11 (`repulsion::pressure_term`); a lane's mask is all ones or zero.
        let s = _mm256_max_ps(sub(dist, contact), zero);
        let rho_i = splat(bee.density);
        let rho_j = _mm256_blendv_ps(rho_i, density, gt(density, zero));
        let p_sum = add(splat(bee.pressure), pressure);
        let pushes = _mm256_and_ps(
            _mm256_and_ps(lt(s, splat(k.h)), gt(rho_j, zero)),
            gt(p_sum, zero),
        );
        let pushes = if bee.density > 0.0 { pushes } else { zero };
        let x = sub(splat(k.h), s);
        let grad = mul(mul(splat(k.spiky_coef()), x), x);
        let scale = div(
            mul(mul(grad, mass), p_sum),
            mul(mul(splat(2.0), rho_i), rho_j),
        );
        // +0.0 where masked, as the AVX-512 path's zeroing multiply.
        let rep = [dx, dy, dz].map(|d| _mm256_and_ps(pushes, mul(d, scale)));

        // Sec. VII (`collision::spring_accel`).
        let overlap = sub(contact, dist);
        let touches = gt(overlap, zero);
        let (wx, wy, wz) = (
            sub(splat(bee.vel.x), vx),
            sub(splat(bee.vel.y), vy),
            sub(splat(bee.vel.z), vz),
        );
        let closing = _mm256_min_ps(add(add(mul(wx, dx), mul(wy, dy)), mul(wz, dz)), zero);
        let spring = splat(bee.spring);
        let damping = splat(2.0 * bee.spring.sqrt());
        let push = sub(mul(spring, overlap), mul(damping, closing));
        let col = [dx, dy, dz].map(|d| _mm256_and_ps(touches, mul(d, push)));

        // Added in the list's order, every neighbour within reach (a zero term too, as
        // the loop adds it).
        let lanes = |v: __m256| {
            let mut a = [0.0f32; 8];
            // SAFETY: `a` holds eight f32s.
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), v) };
            a
        };
        let (rep, col) = (rep.map(lanes), col.map(lanes));
        add_in_order(&rep, &col, within, &mut a_rep, &mut a_col);
    }
    Some((a_rep, a_col))
}

/// [`density16`] eight lanes at a time with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn density8(
    k: &Kernels,
    agents: &[Neighbour],
    list: &[u32],
    me: &Neighbour,
    own: f32,
) -> Option<f32> {
    use std::arch::x86_64::*;
    let field = |offset: usize| offset / 4;
    let (pos, radius, mass) = (
        std::mem::offset_of!(Neighbour, pos),
        std::mem::offset_of!(Neighbour, radius),
        std::mem::offset_of!(Neighbour, mass),
    );
    let splat = _mm256_set1_ps;
    let mut sum = own;
    for from in (0..list.len()).step_by(8) {
        // Position, body radius and mass are all in a record's first eight f32s.
        // SAFETY: the CPU has AVX2 (this function's own target).
        let (valid, f) = unsafe { records8(agents, list, from, false) }?;
        // `me.pos.distance_squared(o.pos)`: (me − o)², summed x, y, z.
        let (rx, ry, rz) = (
            _mm256_sub_ps(splat(me.pos.x), f[field(pos)]),
            _mm256_sub_ps(splat(me.pos.y), f[field(pos + 4)]),
            _mm256_sub_ps(splat(me.pos.z), f[field(pos + 8)]),
        );
        let d2 = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(rx, rx), _mm256_mul_ps(ry, ry)),
            _mm256_mul_ps(rz, rz),
        );
        // `repulsion::density_term`: m_j W_poly6(max(d − (r_i + r_j), 0)), zero from h on.
        let contact = _mm256_add_ps(splat(me.radius), f[field(radius)]);
        let s = _mm256_max_ps(
            _mm256_sub_ps(_mm256_sqrt_ps(d2), contact),
            _mm256_setzero_ps(),
        );
        let inside = _mm256_cmp_ps::<_CMP_LT_OQ>(s, splat(k.h));
        let x = _mm256_sub_ps(splat(k.h * k.h), _mm256_mul_ps(s, s));
        let w = _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(splat(k.poly6_coef()), x), x), x);
        // m_j · 0 where the kernel is zero, as the loop multiplies it.
        let terms = _mm256_mul_ps(f[field(mass)], _mm256_and_ps(inside, w));
        let mut lanes = [0.0f32; 8];
        // SAFETY: `lanes` holds eight f32s.
        unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), terms) };
        // Added in the list's order (a zero term too, as the loop adds it).
        for t in &lanes[..valid.count_ones() as usize] {
            sum += t;
        }
    }
    Some(sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::random_cloud;
    use crate::model::bee::repulsion;

    /// The step's loop, one neighbour at a time (`BeeModel::pairs_one_by_one`, whose
    /// `for_each_neighbour` keeps those within reach).
    fn one_by_one(agents: &[Neighbour], list: &[u32], bee: &Bee) -> (Vec3, Vec3) {
        let (mut a_rep, mut a_col) = (Vec3::ZERO, Vec3::ZERO);
        for &j in list {
            let o = &agents[j as usize];
            let d2 = bee.pos.distance_squared(o.pos);
            if d2 < bee.reach * bee.reach {
                let (push, spring) = one(bee, o, o.pos, d2, || Vec3::Y);
                a_rep += push;
                a_col += spring;
            }
        }
        (a_rep, a_col)
    }

    #[test]
    fn a_whole_list_at_once_sums_what_the_loop_sums_bit_for_bit() {
        let kernels = Kernels::new(0.15);
        let mut rng = crate::math::Rng::new(8, 9, 10);
        // A tight cloud, so that bodies touch, densities and pressures of every kind
        // (zero density: a record not yet gathered; zero pressure: below rest density).
        let cloud = random_cloud(&mut rng, 400, 0.1);
        let velocities = random_cloud(&mut rng, 400, 1.0);
        let agents: Vec<Neighbour> = (0..400)
            .map(|k| Neighbour {
                pos: cloud[k],
                radius: rng.range(0.003, 0.008),
                vel: velocities[k],
                mass: rng.range(5e-5, 2e-4),
                density: if rng.f32() < 0.2 {
                    0.0
                } else {
                    rng.range(0.5, 50.0)
                },
                pressure: if rng.f32() < 0.3 {
                    0.0
                } else {
                    rng.range(0.0, 20.0)
                },
            })
            .collect();
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut wide = [0; 2];
        for case in 0..4000 {
            let n = case % 17;
            let list: Vec<u32> = (0..n).map(|_| (rng.f32() * 400.0) as u32 % 400).collect();
            let me = &agents[(rng.f32() * 400.0) as usize % 400];
            let bee = Bee {
                kernels: &kernels,
                pos: me.pos,
                vel: me.vel,
                radius: me.radius,
                density: [0.0, me.density, 10.0][case % 3],
                pressure: [0.0, me.pressure][case % 2],
                reach: [0.16, 0.05, 0.02][case % 3],
                spring: [4000.0, 0.0][(case / 7) % 2],
            };
            let want = one_by_one(&agents, &list, &bee);
            // A list that holds the bee itself coincides with it: the loop's fallback.
            let coincident = list.iter().any(|&j| agents[j as usize].pos == me.pos);
            for (path, got) in paths(&agents, &list, &bee) {
                match got {
                    Some(got) => {
                        assert!(!coincident);
                        assert_eq!(
                            (bits(got.0), bits(got.1)),
                            (bits(want.0), bits(want.1)),
                            "{path}, case {case}"
                        );
                        wide[path] += 1;
                    }
                    None => assert!(coincident, "{path}, case {case}"),
                }
            }
            if sums(&agents, &list, &bee).is_none() {
                assert!(coincident || list.len() < NARROW_FROM || !crate::simd::avx2());
            }
        }
        // Where the CPU has the lanes, most cases went through them.
        assert!(
            !crate::simd::avx2() || wide[0] > 3000,
            "{wide:?} cases through the lanes"
        );
        assert!(!crate::simd::avx512() || wide[1] > 3000, "{wide:?}");
    }

    /// Each wide path the CPU has, by name (0: eight lanes, 1: sixteen), on a whole list.
    fn paths(agents: &[Neighbour], list: &[u32], bee: &Bee) -> Vec<(usize, Option<(Vec3, Vec3)>)> {
        let mut out = Vec::new();
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY (both): only where the CPU has the path's instructions.
            if crate::simd::avx2() {
                out.push((0, unsafe { sums8(agents, list, bee) }));
            }
            if crate::simd::avx512() {
                out.push((1, unsafe { sums16(agents, list, bee) }));
            }
        }
        let _ = (agents, list, bee);
        out
    }

    #[test]
    fn a_whole_list_at_once_sums_the_density_the_loop_sums_bit_for_bit() {
        let kernels = Kernels::new(0.15);
        let mut rng = crate::math::Rng::new(11, 12, 13);
        // Spread beyond the kernel's reach, so that some terms are zero.
        let agents: Vec<Neighbour> = random_cloud(&mut rng, 300, 0.2)
            .into_iter()
            .map(|pos| Neighbour {
                pos,
                radius: rng.range(0.003, 0.008),
                mass: rng.range(5e-5, 2e-4),
                ..Neighbour::default()
            })
            .collect();
        let mut wide = [0; 2];
        for case in 0..4000 {
            let list: Vec<u32> = (0..case % 17)
                .map(|_| (rng.f32() * 300.0) as u32 % 300)
                .collect();
            let me = &agents[case % 300];
            let own = repulsion::density_term(&kernels, me.mass, 0.0, 2.0 * me.radius);
            let mut want = own;
            for &j in &list {
                let o = &agents[j as usize];
                let d = me.pos.distance_squared(o.pos).sqrt();
                want += repulsion::density_term(&kernels, o.mass, d, me.radius + o.radius);
            }
            #[cfg(target_arch = "x86_64")]
            {
                let mut got = Vec::new();
                // SAFETY (both): only where the CPU has the path's instructions.
                if crate::simd::avx2() {
                    got.push((0, unsafe { density8(&kernels, &agents, &list, me, own) }));
                }
                if crate::simd::avx512() {
                    got.push((1, unsafe { density16(&kernels, &agents, &list, me, own) }));
                }
                for (path, sum) in got {
                    let sum = sum.expect("every index is in the agents");
                    assert_eq!(sum.to_bits(), want.to_bits(), "{path}, case {case}");
                    wide[path] += 1;
                }
            }
            if density_sum(&kernels, &agents, &list, me, own).is_none() {
                assert!(list.len() < NARROW_FROM || !crate::simd::avx2());
            }
        }
        assert!(!crate::simd::avx2() || wide[0] == 4000, "{wide:?}");
        assert!(!crate::simd::avx512() || wide[1] == 4000, "{wide:?}");
    }
}
