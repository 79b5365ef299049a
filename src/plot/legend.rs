//! A figure-wide legend: entries laid out in rows, left to right, each a small mark and
//! its label. `plotters` draws legends inside one chart; figures with several panels
//! (the preview's two views, the eval figure's metrics) need one legend for all of them.

use super::figure::{Area, DrawResult, SUPERSAMPLE, px};
use super::font::text;
use super::palette;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// How an entry is marked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mark {
    /// A line segment (a path, a curve).
    Line(RGBAColor),
    /// A filled box with an edge (an area, a bar, an obstacle).
    Area { fill: RGBAColor, edge: RGBColor },
    /// A hollow circle (a start point).
    Ring(RGBColor),
    /// A filled dot (an end point).
    Dot(RGBColor),
}

#[derive(Clone, Debug, Default)]
pub struct Legend {
    entries: Vec<(String, Mark)>,
}

/// Output pixels: text size, row height, mark width, gap after a mark and between entries.
const SIZE: f64 = 14.0;
const ROW: f64 = 22.0;
const MARK: f64 = 26.0;
const GAP: f64 = 7.0;
const SPACING: f64 = 22.0;

impl Legend {
    pub fn add(&mut self, label: impl Into<String>, mark: Mark) {
        self.entries.push((label.into(), mark));
    }

    /// The (x, y) offset of each entry in output pixels when rows may be `width` wide.
    fn layout(&self, area: &Area, width: f64) -> DrawResult<Vec<(f64, f64)>> {
        let style = text(SIZE, palette::TEXT);
        let (mut x, mut y) = (0.0, 0.0);
        let mut at = Vec::with_capacity(self.entries.len());
        for (label, _) in &self.entries {
            let w = area.estimate_text_size(label, &style)?.0 as f64 / SUPERSAMPLE as f64;
            let entry = MARK + GAP + w;
            if x > 0.0 && x + entry > width {
                (x, y) = (0.0, y + ROW);
            }
            at.push((x, y));
            x += entry + SPACING;
        }
        Ok(at)
    }

    /// Height in output pixels of the legend drawn in rows at most `width` wide.
    pub fn height(&self, area: &Area, width: f64) -> DrawResult<f64> {
        Ok(match self.layout(area, width)?.last() {
            Some(&(_, y)) => y + ROW,
            None => 0.0,
        })
    }

    /// Draws the legend with its top-left corner at (x, y), output pixels.
    pub fn draw(&self, area: &Area, x: f64, y: f64, width: f64) -> DrawResult {
        let style = text(SIZE, palette::TEXT).pos(Pos::new(HPos::Left, VPos::Center));
        for ((label, mark), (ex, ey)) in self.entries.iter().zip(self.layout(area, width)?) {
            let (x0, cy) = (x + ex, y + ey + ROW / 2.0);
            let p = |dx: f64, dy: f64| (px(x0 + dx), px(cy + dy));
            match *mark {
                Mark::Line(c) => {
                    area.draw(&PathElement::new(
                        vec![p(0.0, 0.0), p(MARK, 0.0)],
                        c.stroke_width(px(2.5) as u32),
                    ))?;
                }
                Mark::Area { fill, edge } => {
                    area.draw(&Rectangle::new(
                        [p(2.0, -6.0), p(MARK - 2.0, 6.0)],
                        fill.filled(),
                    ))?;
                    area.draw(&Rectangle::new(
                        [p(2.0, -6.0), p(MARK - 2.0, 6.0)],
                        edge.stroke_width(px(1.0) as u32),
                    ))?;
                }
                Mark::Ring(c) => {
                    area.draw(&Circle::new(
                        p(MARK / 2.0, 0.0),
                        px(4.5),
                        c.stroke_width(px(1.5) as u32),
                    ))?;
                }
                Mark::Dot(c) => {
                    area.draw(&Circle::new(p(MARK / 2.0, 0.0), px(3.5), c.filled()))?;
                }
            }
            // Nudged down: the font's centre line sits above the visual centre of lower case.
            area.draw_text(label, &style, p(MARK + GAP, 2.5))?;
        }
        Ok(())
    }
}
