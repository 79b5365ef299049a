//! The bundled font (Roboto, subset; see assets/fonts/README.md), registered with
//! `plotters` under the family name "sans-serif" that its charts use by default.

use super::figure::SUPERSAMPLE;
use plotters::style::{FontStyle, IntoFont, RGBColor, TextStyle, register_font};
use std::sync::Once;

const REGULAR: &[u8] = include_bytes!("../../assets/fonts/Roboto-Regular.ttf");
const MEDIUM: &[u8] = include_bytes!("../../assets/fonts/Roboto-Medium.ttf");
const FAMILY: &str = "sans-serif";

/// Registers the fonts once per process (the registry is global and shared by threads).
pub(super) fn register() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // Both files are compiled in and parsed by the tests, so this cannot fail at run
        // time; a failure here is a broken build.
        let ok = register_font(FAMILY, FontStyle::Normal, REGULAR).is_ok()
            && register_font(FAMILY, FontStyle::Bold, MEDIUM).is_ok();
        assert!(
            ok,
            "the bundled fonts in assets/fonts are not valid TrueType"
        );
    });
}

/// Regular text `size` output pixels high (the font's ascent to descent), in `color`.
pub fn text(size: f64, color: RGBColor) -> TextStyle<'static> {
    (FAMILY, size * SUPERSAMPLE as f64)
        .into_font()
        .color(&color)
}

/// Medium-weight text for titles.
pub fn bold(size: f64, color: RGBColor) -> TextStyle<'static> {
    (FAMILY, size * SUPERSAMPLE as f64, FontStyle::Bold)
        .into_font()
        .color(&color)
}
