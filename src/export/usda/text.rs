//! Number text for USDA: shortest round-trip floats and half-precision quaternion parts.
//!
//! USD's text parser reads every number as a double and converts it to the attribute's
//! type, so the shortest decimal that converts back to the same `float` (or `half`) is
//! exact and also what `usdcat` itself would print. NaN and infinities are never written:
//! callers check `is_finite` first and report the offending bee instead.

use std::sync::OnceLock;

/// Appends the shortest decimal that reads back as exactly `v` (finite). `-0` is written
/// as `0` and integral values without a trailing `.0`, as `usdcat` writes them.
#[inline]
pub fn push_f32(out: &mut Vec<u8>, v: f32) {
    debug_assert!(v.is_finite());
    if v == 0.0 {
        out.push(b'0');
        return;
    }
    // Format straight into the output (no stack buffer and copy): this is the hot loop
    // of the writer, called for nearly every byte of a cache.
    out.reserve(16);
    let at = out.len();
    // SAFETY: `reserve` made room for 16 more bytes, ryu writes at most 16 for an f32
    // (e.g. "-1.2345678e-38"), and the bytes it reports written are initialised ASCII.
    unsafe {
        let n = ryu::raw::format32(v, out.as_mut_ptr().add(at));
        out.set_len(at + n);
    }
    if out.ends_with(b".0") {
        out.truncate(out.len() - 2);
    }
}

/// `push_f32` for doubles (frame rates and time codes in the layer header).
pub fn push_f64(out: &mut Vec<u8>, v: f64) {
    debug_assert!(v.is_finite());
    if v == 0.0 {
        out.push(b'0');
        return;
    }
    let mut b = ryu::Buffer::new();
    let s = b.format_finite(v);
    out.extend_from_slice(s.strip_suffix(".0").unwrap_or(s).as_bytes());
}

pub fn f64_text(v: f64) -> String {
    let mut out = Vec::new();
    push_f64(&mut out, v);
    String::from_utf8(out).expect("ryu writes ASCII")
}

/// IEEE binary16 bits of `x`, rounded to nearest, ties to even (as Imath's `half(float)`,
/// which USD uses for `quath`).
pub fn f32_to_f16(x: f32) -> u16 {
    let b = x.to_bits();
    let sign = ((b >> 16) & 0x8000) as u16;
    let exp = ((b >> 23) & 0xff) as i32;
    let man = b & 0x7f_ffff;
    if exp == 0xff {
        return sign | 0x7c00 | if man != 0 { 0x200 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 0x1f {
        return sign | 0x7c00;
    }
    if e <= 0 {
        // Half subnormal: value = m * 2^-24, m = M * 2^(exp - 126) with M the full
        // 24-bit significand, so m is M shifted right by (126 - exp) >= 14 bits.
        let shift = (126 - exp) as u32;
        if shift > 24 {
            return sign;
        }
        let m = man | 0x80_0000;
        let q = m >> shift;
        let r = m & ((1 << shift) - 1);
        let halfway = 1 << (shift - 1);
        let up = r > halfway || (r == halfway && q & 1 == 1);
        return sign | (q + up as u32) as u16;
    }
    let q = ((e as u32) << 10) | (man >> 13);
    let r = man & 0x1fff;
    // A carry out of the mantissa rolls into the exponent, up to infinity: that is the
    // correct rounding.
    let up = r > 0x1000 || (r == 0x1000 && q & 1 == 1);
    sign | (q + up as u32) as u16
}

/// The exact value of a binary16.
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = ((h as u32) & 0x8000) << 16;
    let exp = ((h >> 10) & 0x1f) as u32;
    let man = (h & 0x3ff) as u32;
    let bits = match exp {
        0 if man == 0 => sign,
        0 => {
            // Subnormal: man * 2^-24, exactly representable as a normal float.
            let v = man as f32 * f32::from_bits((127 - 24) << 23);
            return if sign != 0 { -v } else { v };
        }
        0x1f => sign | 0x7f80_0000 | (man << 13),
        _ => sign | ((exp + 127 - 15) << 23) | (man << 13),
    };
    f32::from_bits(bits)
}

/// Shortest text of one half, stored inline so the table is one allocation.
#[derive(Clone, Copy)]
struct HalfText {
    len: u8,
    bytes: [u8; 15],
}

/// The shortest decimal for every finite half (65,536 entries, built once, ~1 MB).
/// Formatting a quaternion part is then a table lookup, and the text is 4–6 characters
/// instead of the 9–11 a float would need, for the same value once USD reads it.
fn half_table() -> &'static [HalfText] {
    static TABLE: OnceLock<Box<[HalfText]>> = OnceLock::new();
    TABLE.get_or_init(|| (0..=u16::MAX).map(half_text).collect())
}

fn half_text(h: u16) -> HalfText {
    let mut t = HalfText {
        len: 0,
        bytes: [0; 15],
    };
    if (h >> 10) & 0x1f == 0x1f {
        return t; // not finite: never looked up
    }
    let v = f16_to_f32(h) as f64;
    let s = if v == 0.0 {
        "0".to_owned()
    } else {
        // The fewest significant digits that survive USD's text → double → float → half.
        let mut found = None;
        for digits in 1..=6 {
            let s = format!("{:.*e}", digits - 1, v);
            let d: f64 = s.parse().expect("Rust reads its own exponent form");
            if f32_to_f16(d as f32) == h {
                found = Some(d);
                break;
            }
        }
        let d = found.expect("6 significant digits always identify a half");
        if (1e-4..1e6).contains(&d.abs()) {
            format!("{d}")
        } else {
            format!("{d:e}")
        }
    };
    assert!(s.len() <= t.bytes.len(), "half text too long: {s}");
    t.bytes[..s.len()].copy_from_slice(s.as_bytes());
    t.len = s.len() as u8;
    t
}

/// A lookup handle for half text (fetches the table once per caller, not per number).
#[derive(Clone, Copy)]
pub struct HalfFormatter(&'static [HalfText]);

impl HalfFormatter {
    pub fn new() -> Self {
        HalfFormatter(half_table())
    }
    /// Appends the shortest text that USD reads back as the half nearest to `v` (finite).
    #[inline]
    pub fn push(&self, out: &mut Vec<u8>, v: f32) {
        let mut h = f32_to_f16(v);
        if h == 0x8000 {
            h = 0; // no "-0"
        }
        let t = &self.0[h as usize];
        debug_assert!(t.len > 0, "non-finite half");
        out.extend_from_slice(&t.bytes[..t.len as usize]);
    }
}

impl Default for HalfFormatter {
    fn default() -> Self {
        Self::new()
    }
}

/// A USDA string literal: quoted, with `\` and `"` and control characters escaped.
pub fn quoted(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\x{:02x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A prim name from any text: identifier characters kept, others become `_`.
pub fn prim_name(s: &str) -> String {
    let mut out: String = s
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, '_');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f32_text(v: f32) -> String {
        let mut out = Vec::new();
        push_f32(&mut out, v);
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn floats_are_shortest_and_round_trip() {
        assert_eq!(f32_text(0.0), "0");
        assert_eq!(f32_text(-0.0), "0");
        assert_eq!(f32_text(1.0), "1");
        assert_eq!(f32_text(-2.5), "-2.5");
        assert_eq!(f32_text(0.1), "0.1");
        assert_eq!(f32_text(1e-7), "1e-7");
        assert_eq!(f32_text(0.012), "0.012");
        assert_eq!(f64_text(24.0), "24");
        assert_eq!(f64_text(23.976), "23.976");
        // Round trip on awkward values.
        let mut x = 1.2345e-30f32;
        while x < 1e30 {
            for v in [x, -x, x * 1.000_001, x.next_up_compat()] {
                assert_eq!(f32_text(v).parse::<f32>().unwrap(), v);
            }
            x *= 3.7;
        }
    }

    trait NextUp {
        fn next_up_compat(self) -> f32;
    }
    impl NextUp for f32 {
        fn next_up_compat(self) -> f32 {
            f32::from_bits(self.to_bits() + 1)
        }
    }

    /// Reference half conversion through exact rational arithmetic on doubles: the
    /// nearest representable half, ties to the even mantissa.
    fn f16_reference(x: f32) -> u16 {
        let mut best = 0u16;
        let mut best_err = f64::INFINITY;
        for h in 0..=u16::MAX {
            if (h >> 10) & 0x1f == 0x1f {
                continue;
            }
            let err = (f16_to_f32(h) as f64 - x as f64).abs();
            if err < best_err || (err == best_err && h & 1 == 0 && best & 1 == 1) {
                best = h;
                best_err = err;
            }
        }
        if best_err == 0.0 && x.is_sign_negative() {
            best |= 0x8000;
        }
        best
    }

    #[test]
    fn half_conversion_matches_a_brute_force_reference() {
        for &x in &[
            0.0f32,
            1.0,
            -1.0,
            0.707_106_77,
            -0.5,
            1e-5,
            3e-8,
            2.98e-8,
            6.1e-5,
            0.333_333_34,
            0.000_976_562_5,
            1.000_488_3, // exactly halfway between 1 and 1 + 2^-10: ties to even → 1
            1.001_464_8, // halfway between 1+2^-10 and 1+2^-9: ties to even → 1+2^-9
            65504.0,
        ] {
            assert_eq!(f32_to_f16(x), f16_reference(x), "{x}");
        }
        assert_eq!(f32_to_f16(1e6), 0x7c00);
        assert_eq!(f32_to_f16(1.000_488_3), 0x3c00);
        assert_eq!(f32_to_f16(1.001_464_8), 0x3c02);
    }

    #[test]
    fn every_finite_half_round_trips_through_its_text() {
        let fmt = HalfFormatter::new();
        for h in 0..=u16::MAX {
            if (h >> 10) & 0x1f == 0x1f || h == 0x8000 {
                continue;
            }
            let v = f16_to_f32(h);
            assert_eq!(f32_to_f16(v), h, "exact value of {h:#x}");
            let mut out = Vec::new();
            fmt.push(&mut out, v);
            let s = std::str::from_utf8(&out).unwrap();
            let d: f64 = s.parse().unwrap();
            assert_eq!(f32_to_f16(d as f32), h, "{h:#x} written as {s}");
        }
        let text = |v: f32| {
            let mut out = Vec::new();
            fmt.push(&mut out, v);
            String::from_utf8(out).unwrap()
        };
        assert_eq!(text(1.0), "1");
        assert_eq!(text(-0.0), "0");
        assert_eq!(text(0.707_106_77), "0.707");
        assert_eq!(text(0.5), "0.5");
    }

    #[test]
    fn strings_and_names_are_escaped() {
        assert_eq!(quoted("a\"b\\c\nd"), "\"a\\\"b\\\\c\\nd\"");
        assert_eq!(prim_name("shot-01.v2"), "shot_01_v2");
        assert_eq!(prim_name("3d"), "_3d");
        assert_eq!(prim_name(""), "_");
    }
}
