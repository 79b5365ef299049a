//! A chart panel: a pixel rectangle on a canvas mapped to a data range, with a frame,
//! "nice" ticks, tick labels, axis labels, a title and a legend.

use super::canvas::{Canvas, Rgb};
use super::font::GLYPH;
use super::palette;

/// A plot area: `(left, top)`–`(right, bottom)` in pixels shows `x` and `y` ranges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chart {
    pub left: i64,
    pub top: i64,
    pub right: i64,
    pub bottom: i64,
    pub x: (f64, f64),
    pub y: (f64, f64),
}

/// Tick positions covering [lo, hi] with about `target` steps of 1, 2 or 5 × 10^n.
/// Returns the ticks inside the range and the step. Degenerate ranges get one tick.
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return (vec![if lo.is_finite() { lo } else { 0.0 }], 1.0);
    }
    let raw = (hi - lo) / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let ticks = (first..=last)
        .map(|i| {
            let v = i as f64 * step;
            if v.abs() < step * 1e-9 { 0.0 } else { v }
        })
        .collect();
    (ticks, step)
}

/// Formats a tick value with just enough decimals for `step`.
pub fn tick_label(v: f64, step: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        return format!("{v:.0e}");
    }
    // Steps are 1, 2 or 5 × 10^n, so the exponent alone fixes the decimals.
    let decimals = (-(step.log10() + 1e-9).floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

impl Chart {
    /// A chart whose ranges are widened when empty or degenerate, so mapping never
    /// divides by zero. A range given high-to-low flips that axis.
    pub fn new(left: i64, top: i64, right: i64, bottom: i64, x: (f64, f64), y: (f64, f64)) -> Self {
        Chart {
            left,
            top,
            right,
            bottom,
            x: widen(x),
            y: widen(y),
        }
    }

    pub fn px_x(&self, x: f64) -> f64 {
        self.left as f64 + (x - self.x.0) / (self.x.1 - self.x.0) * (self.right - self.left) as f64
    }
    pub fn px_y(&self, y: f64) -> f64 {
        self.bottom as f64
            - (y - self.y.0) / (self.y.1 - self.y.0) * (self.bottom - self.top) as f64
    }
    pub fn px(&self, x: f64, y: f64) -> (f64, f64) {
        (self.px_x(x), self.px_y(y))
    }

    /// Restricts drawing on `c` to the plot area (inside the frame) until `unclip`.
    pub fn clip(&self, c: &mut Canvas) {
        c.set_clip(Some((
            self.left + 1,
            self.top + 1,
            self.right - 1,
            self.bottom - 1,
        )));
    }
    pub fn unclip(&self, c: &mut Canvas) {
        c.set_clip(None);
    }

    /// Draws the frame, light grid lines, ticks with labels, axis labels and a title.
    pub fn frame(&self, c: &mut Canvas, title: &str, xlabel: &str, ylabel: &str) {
        let (xt, xs) = nice_ticks(self.x.0.min(self.x.1), self.x.0.max(self.x.1), 5);
        let (yt, ys) = nice_ticks(self.y.0.min(self.y.1), self.y.0.max(self.y.1), 4);
        for &t in &xt {
            let px = self.px_x(t).round() as i64;
            c.fill_rect(px, self.top + 1, px, self.bottom - 1, palette::GRID);
        }
        for &t in &yt {
            let py = self.px_y(t).round() as i64;
            c.fill_rect(self.left + 1, py, self.right - 1, py, palette::GRID);
        }
        c.rect(self.left, self.top, self.right, self.bottom, palette::BLACK);
        let g = GLYPH as i64;
        for &t in &xt {
            let px = self.px_x(t).round() as i64;
            c.fill_rect(px, self.bottom, px, self.bottom + 4, palette::BLACK);
            let s = tick_label(t, xs);
            c.text(
                px - Canvas::text_width(&s, 1) / 2,
                self.bottom + 7,
                &s,
                palette::BLACK,
                1,
            );
        }
        let mut widest = 0;
        for &t in &yt {
            let py = self.px_y(t).round() as i64;
            c.fill_rect(self.left - 4, py, self.left, py, palette::BLACK);
            let s = tick_label(t, ys);
            let w = Canvas::text_width(&s, 1);
            widest = widest.max(w);
            c.text(self.left - 7 - w, py - g / 2, &s, palette::BLACK, 1);
        }
        if !xlabel.is_empty() {
            let w = Canvas::text_width(xlabel, 1);
            let cx = (self.left + self.right) / 2;
            c.text(
                cx - w / 2,
                self.bottom + 7 + g + 5,
                xlabel,
                palette::BLACK,
                1,
            );
        }
        if !ylabel.is_empty() {
            let h = Canvas::text_width(ylabel, 1);
            let cy = (self.top + self.bottom) / 2;
            c.text_up(
                self.left - 12 - widest - g,
                cy - h / 2,
                ylabel,
                palette::BLACK,
                1,
            );
        }
        if !title.is_empty() {
            let w = Canvas::text_width(title, 1);
            let cx = (self.left + self.right) / 2;
            c.text(cx - w / 2, self.top - g - 6, title, palette::BLACK, 1);
        }
    }

    /// Clips a data-space polyline to the x/y range and draws it.
    pub fn polyline(&self, c: &mut Canvas, pts: &[(f64, f64)], color: Rgb, width: u32) {
        let px: Vec<(f64, f64)> = pts
            .iter()
            .map(|&(x, y)| {
                let (a, b) = self.px(x, y);
                (
                    a.clamp(self.left as f64, self.right as f64),
                    b.clamp(self.top as f64, self.bottom as f64),
                )
            })
            .collect();
        c.polyline(&px, color, width);
    }

    /// A histogram drawn as a step outline over bins with the given edges.
    pub fn steps(&self, c: &mut Canvas, edges: &[f64], heights: &[f64], color: Rgb, width: u32) {
        let mut pts = Vec::with_capacity(heights.len() * 2 + 2);
        if let Some(&e0) = edges.first() {
            pts.push((e0, self.y.0.max(0.0)));
        }
        for (i, &h) in heights.iter().enumerate() {
            pts.push((edges[i], h));
            pts.push((edges[i + 1], h));
        }
        if let Some(&e) = edges.get(heights.len()) {
            pts.push((e, self.y.0.max(0.0)));
        }
        self.polyline(c, &pts, color, width);
    }

    /// A histogram drawn as filled bars (for the reference distribution).
    pub fn bars(&self, c: &mut Canvas, edges: &[f64], heights: &[f64], color: Rgb) {
        let base = self.px_y(self.y.0.max(0.0)).round() as i64;
        for (i, &h) in heights.iter().enumerate() {
            let x0 = self.px_x(edges[i]).round() as i64;
            let x1 = self.px_x(edges[i + 1]).round() as i64;
            let top = self.px_y(h.min(self.y.1)).round() as i64;
            if top < base {
                c.fill_rect(
                    x0.max(self.left + 1),
                    top,
                    (x1 - 1).min(self.right - 1),
                    base - 1,
                    color,
                );
            }
        }
    }
}

fn widen((lo, hi): (f64, f64)) -> (f64, f64) {
    let (lo, hi) = (
        if lo.is_finite() { lo } else { 0.0 },
        if hi.is_finite() { hi } else { 1.0 },
    );
    if hi != lo {
        // A reversed range is kept: it flips the axis (e.g. a top view with +z down).
        (lo, hi)
    } else {
        let pad = if lo.abs() > 0.0 { lo.abs() * 0.5 } else { 0.5 };
        (lo - pad, lo + pad)
    }
}

/// How a legend entry is marked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LegendMark {
    Line,
    Box,
}

/// A boxed list of labelled colour marks.
#[derive(Clone, Debug, Default)]
pub struct Legend {
    pub entries: Vec<(String, Rgb, LegendMark)>,
}

impl Legend {
    pub fn add(&mut self, label: impl Into<String>, color: Rgb, mark: LegendMark) {
        self.entries.push((label.into(), color, mark));
    }

    /// Pixel size of the legend box.
    pub fn size(&self) -> (i64, i64) {
        let g = GLYPH as i64;
        let w = self
            .entries
            .iter()
            .map(|(l, ..)| Canvas::text_width(l, 1))
            .max()
            .unwrap_or(0);
        (w + 3 * g + 12, self.entries.len() as i64 * (g + 6) + 8)
    }

    /// Draws the legend with its top-left corner at (x, y).
    pub fn draw(&self, c: &mut Canvas, x: i64, y: i64) {
        if self.entries.is_empty() {
            return;
        }
        let g = GLYPH as i64;
        let (w, h) = self.size();
        c.fill_rect(x, y, x + w, y + h, palette::WHITE);
        c.rect(x, y, x + w, y + h, palette::GREY);
        for (i, (label, color, mark)) in self.entries.iter().enumerate() {
            let ly = y + 6 + i as i64 * (g + 6);
            match mark {
                LegendMark::Line => {
                    c.fill_rect(x + 6, ly + g / 2 - 1, x + 6 + 2 * g, ly + g / 2 + 1, *color)
                }
                LegendMark::Box => c.fill_rect(x + 6, ly, x + 6 + 2 * g, ly + g - 1, *color),
            }
            c.text(x + 12 + 2 * g, ly, label, palette::BLACK, 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_nice_and_inside() {
        let (t, s) = nice_ticks(0.0, 1.0, 5);
        assert_eq!(s, 0.2);
        assert_eq!(t.len(), 6);
        let (t, s) = nice_ticks(-3.7, 12.2, 4);
        assert_eq!(s, 5.0);
        assert_eq!(t, vec![0.0, 5.0, 10.0]);
        let (t, _) = nice_ticks(2.0, 2.0, 4);
        assert_eq!(t, vec![2.0]);
    }

    #[test]
    fn labels_have_enough_decimals() {
        assert_eq!(tick_label(0.4, 0.2), "0.4");
        assert_eq!(tick_label(10.0, 5.0), "10");
        assert_eq!(tick_label(0.25, 0.05), "0.25");
        assert_eq!(tick_label(0.0, 0.05), "0.00");
    }

    #[test]
    fn mapping_is_monotone_and_degenerate_ranges_are_widened() {
        let ch = Chart::new(10, 10, 110, 60, (0.0, 0.0), (1.0, 2.0));
        assert!(ch.x.1 > ch.x.0);
        assert!(ch.px_x(0.1) > ch.px_x(0.0));
        assert!(ch.px_y(2.0) < ch.px_y(1.0));
        assert_eq!(ch.px_y(1.0), 60.0);
    }
}
