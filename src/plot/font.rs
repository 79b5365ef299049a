//! The 8×8 bitmap font of the `font8x8` crate: basic Latin, Latin-1 (for ², ³, µ, °) and
//! Greek (for ω, α, ρ, κ), so axis labels can carry units and symbols without system fonts.

use font8x8::legacy::{BASIC_LEGACY, GREEK_LEGACY, LATIN_LEGACY};

/// Glyph cell size in pixels at scale 1.
pub const GLYPH: u32 = 8;

/// The 8 rows of a character; bit `i` of a row is column `i` from the left.
/// Characters the font lacks are drawn as `?` so a missing glyph is visible, not blank.
pub fn glyph(c: char) -> [u8; 8] {
    let u = c as u32;
    match u {
        0x20..=0x7E => BASIC_LEGACY[u as usize],
        0xA0..=0xFF => LATIN_LEGACY[(u - 0xA0) as usize],
        0x390..=0x3C9 => GREEK_LEGACY[(u - 0x390) as usize],
        _ => BASIC_LEGACY['?' as usize],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn space_is_blank_and_letters_are_not() {
        assert_eq!(glyph(' '), [0; 8]);
        assert_ne!(glyph('A'), [0; 8]);
        assert_ne!(glyph('ω'), [0; 8]);
        assert_ne!(glyph('²'), [0; 8]);
        assert_eq!(glyph('\u{4e00}'), glyph('?'));
    }
}
