//! A small raster plotting library: an RGB canvas with lines, shapes and bitmap text,
//! a chart frame with nice ticks, legends, and deterministic PNG output.
//!
//! Used by `beeswarm eval` (distribution figures), `beeswarm calibrate` (fitness over
//! generations) and the bake preview (top and side views of trajectories). It needs no
//! system fonts (text is drawn with the `font8x8` bitmap font) and its PNG bytes depend
//! only on the pixels, so the same figure is byte-identical on every machine.

mod canvas;
mod chart;
mod font;

pub use canvas::{Canvas, Rgb};
pub use chart::{Chart, Legend, LegendMark, nice_ticks};
pub use font::{GLYPH, glyph};

/// Colours used across figures, chosen to stay distinguishable on white and when printed.
pub mod palette {
    use super::Rgb;
    pub const WHITE: Rgb = [255, 255, 255];
    pub const BLACK: Rgb = [0, 0, 0];
    pub const GREY: Rgb = [128, 128, 128];
    pub const LIGHT_GREY: Rgb = [215, 215, 215];
    pub const GRID: Rgb = [235, 235, 235];
    /// Okabe–Ito colour-blind-safe series colours.
    pub const SERIES: [Rgb; 7] = [
        [0, 114, 178],   // blue
        [213, 94, 0],    // vermillion
        [0, 158, 115],   // bluish green
        [204, 121, 167], // reddish purple
        [230, 159, 0],   // orange
        [86, 180, 233],  // sky blue
        [240, 228, 66],  // yellow
    ];
    /// The `i`-th series colour, cycling.
    pub fn series(i: usize) -> Rgb {
        SERIES[i % SERIES.len()]
    }
    /// Mixes `c` towards white by `t` in [0, 1].
    pub fn lighten(c: Rgb, t: f64) -> Rgb {
        let t = t.clamp(0.0, 1.0);
        c.map(|v| (v as f64 + (255.0 - v as f64) * t).round() as u8)
    }
    /// Mixes `c` towards black by `t` in [0, 1].
    pub fn darken(c: Rgb, t: f64) -> Rgb {
        let t = t.clamp(0.0, 1.0);
        c.map(|v| (v as f64 * (1.0 - t)).round() as u8)
    }
}
