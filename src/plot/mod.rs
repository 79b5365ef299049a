//! Figures drawn with the `plotters` crate: the bake preview, the `eval` distribution
//! figure and the `calibrate` fitness figure.
//!
//! This module adds what `plotters` leaves to its users: the bundled font (no system
//! fonts, so a figure looks the same on every machine), supersampled anti-aliasing,
//! deterministic PNG encoding, a figure-wide legend and the shared palette. Sizes given to
//! the helpers here are in output pixels; [`px`] converts them to the supersampled canvas.

mod figure;
mod font;
mod legend;

pub use figure::{Area, DrawResult, Figure, SUPERSAMPLE, px};
pub use font::{bold, text};
pub use legend::{Legend, Mark};

/// A tick label with no more decimals than needed ("0.5", "12", "−0.25"), a true minus
/// sign, and powers of ten for very large or small values.
pub fn tick_label(v: f64) -> String {
    let a = v.abs();
    let s = if a < 1e-12 {
        "0".to_owned()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    };
    s.replace('-', "\u{2212}")
}

/// [`tick_label`] in the shape plotters' label formatters take.
fn tick(v: &f64) -> String {
    tick_label(*v)
}

/// Every chart's axes: [`tick_label`] numbers, tick labels of `size` points and axis
/// titles one point larger, grid lines on the major ticks only, grey axes and 4 px tick
/// marks. Callers add their titles and label counts, and may override any of it.
pub fn house_axes<'m, 'a, 'b, X, Y, DB>(
    mesh: &'m mut plotters::chart::MeshStyle<'a, 'b, X, Y, DB>,
    size: f64,
) -> &'m mut plotters::chart::MeshStyle<'a, 'b, X, Y, DB>
where
    X: plotters::coord::ranged1d::Ranged<ValueType = f64>,
    Y: plotters::coord::ranged1d::Ranged<ValueType = f64>,
    DB: plotters::prelude::DrawingBackend,
{
    use plotters::style::{Color, TRANSPARENT};
    mesh.x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style(text(size, palette::TEXT))
        .axis_desc_style(text(size + 1.0, palette::TEXT))
        .bold_line_style(palette::GRID.stroke_width(px(1.0) as u32))
        .light_line_style(TRANSPARENT)
        .axis_style(palette::GREY.stroke_width(px(1.0) as u32))
        .set_all_tick_mark_size(px(4.0))
}

/// Colours used across figures, chosen to stay distinguishable on white and when printed.
pub mod palette {
    use plotters::style::RGBColor;
    pub const WHITE: RGBColor = RGBColor(255, 255, 255);
    pub const BLACK: RGBColor = RGBColor(0, 0, 0);
    pub const TEXT: RGBColor = RGBColor(30, 30, 30);
    pub const GREY: RGBColor = RGBColor(128, 128, 128);
    pub const LIGHT_GREY: RGBColor = RGBColor(205, 205, 205);
    pub const GRID: RGBColor = RGBColor(228, 228, 228);
    /// Okabe–Ito colour-blind-safe series colours.
    pub const SERIES: [RGBColor; 7] = [
        RGBColor(0, 114, 178),   // blue
        RGBColor(213, 94, 0),    // vermillion
        RGBColor(0, 158, 115),   // bluish green
        RGBColor(204, 121, 167), // reddish purple
        RGBColor(230, 159, 0),   // orange
        RGBColor(86, 180, 233),  // sky blue
        RGBColor(240, 228, 66),  // yellow
    ];
    /// The `i`-th series colour, cycling.
    pub fn series(i: usize) -> RGBColor {
        SERIES[i % SERIES.len()]
    }
    /// Mixes `c` towards black by `t` in [0, 1].
    pub fn darken(c: RGBColor, t: f64) -> RGBColor {
        let t = t.clamp(0.0, 1.0);
        let d = |v: u8| (v as f64 * (1.0 - t)).round() as u8;
        RGBColor(d(c.0), d(c.1), d(c.2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(0.5), "0.5");
        assert_eq!(tick_label(10.0), "10");
        assert_eq!(tick_label(-0.25), "\u{2212}0.25");
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(1e-17), "0");
        assert_eq!(tick_label(2e6), "2e6");
    }
}
