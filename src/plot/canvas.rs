//! An RGB raster with clipped drawing primitives and PNG output.
//!
//! Coordinates are pixels, origin top-left, y down. Everything is clipped, so callers can
//! draw data that strays outside a panel without bounds checks. Lines are plain Bresenham
//! with a square brush: no anti-aliasing, which keeps output bit-exact across platforms
//! (floating-point blending differs in the last bit between compilers and CPUs).

use super::font::{GLYPH, glyph};
use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

pub type Rgb = [u8; 3];

#[derive(Clone, Debug, PartialEq)]
pub struct Canvas {
    width: u32,
    height: u32,
    /// Row-major RGB, 3 bytes per pixel.
    px: Vec<u8>,
    /// Drawing is limited to this rectangle (inclusive), e.g. a chart's plot area.
    clip: (i64, i64, i64, i64),
}

impl Canvas {
    pub fn new(width: u32, height: u32, background: Rgb) -> Self {
        let mut px = Vec::with_capacity(width as usize * height as usize * 3);
        for _ in 0..width as usize * height as usize {
            px.extend_from_slice(&background);
        }
        Canvas {
            width,
            height,
            px,
            clip: (0, 0, width as i64 - 1, height as i64 - 1),
        }
    }

    /// Limits drawing to the rectangle (x0, y0)–(x1, y1) inclusive, within the canvas;
    /// `None` restores the whole canvas.
    pub fn set_clip(&mut self, rect: Option<(i64, i64, i64, i64)>) {
        let (w, h) = (self.width as i64 - 1, self.height as i64 - 1);
        self.clip = match rect {
            Some((x0, y0, x1, y1)) => (x0.max(0), y0.max(0), x1.min(w), y1.min(h)),
            None => (0, 0, w, h),
        };
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Raw RGB bytes, row-major.
    pub fn pixels(&self) -> &[u8] {
        &self.px
    }

    pub fn get(&self, x: i64, y: i64) -> Option<Rgb> {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return None;
        }
        let i = (y as usize * self.width as usize + x as usize) * 3;
        Some([self.px[i], self.px[i + 1], self.px[i + 2]])
    }

    /// Sets one pixel; outside the canvas or the clip rectangle it does nothing.
    pub fn set(&mut self, x: i64, y: i64, c: Rgb) {
        let (x0, y0, x1, y1) = self.clip;
        if x < x0 || y < y0 || x > x1 || y > y1 {
            return;
        }
        let i = (y as usize * self.width as usize + x as usize) * 3;
        self.px[i..i + 3].copy_from_slice(&c);
    }

    /// Fills the rectangle with corners (x0, y0) and (x1, y1), both inclusive, any order.
    pub fn fill_rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: Rgb) {
        let (xa, xb) = (x0.min(x1).max(self.clip.0), x0.max(x1).min(self.clip.2));
        let (ya, yb) = (y0.min(y1).max(self.clip.1), y0.max(y1).min(self.clip.3));
        for y in ya..=yb {
            for x in xa..=xb {
                self.set(x, y, c);
            }
        }
    }

    /// Outline of a rectangle, corners inclusive.
    pub fn rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: Rgb) {
        self.fill_rect(x0, y0, x1, y0, c);
        self.fill_rect(x0, y1, x1, y1, c);
        self.fill_rect(x0, y0, x0, y1, c);
        self.fill_rect(x1, y0, x1, y1, c);
    }

    /// A line `width` pixels thick between two points (rounded to pixel centres).
    /// Non-finite coordinates are skipped rather than drawn to a wild place.
    pub fn line(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, c: Rgb, width: u32) {
        if !(x0.is_finite() && y0.is_finite() && x1.is_finite() && y1.is_finite()) {
            return;
        }
        // Far-off endpoints (a zoomed-in view of a long path) are clipped first so the
        // Bresenham walk stays bounded by the canvas size.
        let Some((x0, y0, x1, y1)) = self.clip(x0, y0, x1, y1, width as f64 + 1.0) else {
            return;
        };
        let (mut x, mut y) = (x0.round() as i64, y0.round() as i64);
        let (xe, ye) = (x1.round() as i64, y1.round() as i64);
        let dx = (xe - x).abs();
        let dy = -(ye - y).abs();
        let sx = if x < xe { 1 } else { -1 };
        let sy = if y < ye { 1 } else { -1 };
        let mut err = dx + dy;
        let w = width.max(1) as i64;
        let lo = -(w - 1) / 2;
        let hi = w / 2;
        loop {
            if w == 1 {
                self.set(x, y, c);
            } else {
                self.fill_rect(x + lo, y + lo, x + hi, y + hi, c);
            }
            if x == xe && y == ye {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }

    /// Liang–Barsky clipping of a segment to the canvas grown by `margin` pixels.
    fn clip(
        &self,
        x0: f64,
        y0: f64,
        x1: f64,
        y1: f64,
        margin: f64,
    ) -> Option<(f64, f64, f64, f64)> {
        let (xmin, ymin) = (-margin, -margin);
        let (xmax, ymax) = (self.width as f64 + margin, self.height as f64 + margin);
        let (dx, dy) = (x1 - x0, y1 - y0);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-dx, x0 - xmin),
            (dx, xmax - x0),
            (-dy, y0 - ymin),
            (dy, ymax - y0),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
                if t0 > t1 {
                    return None;
                }
            }
        }
        Some((x0 + t0 * dx, y0 + t0 * dy, x0 + t1 * dx, y0 + t1 * dy))
    }

    /// Connected segments through `points`.
    pub fn polyline(&mut self, points: &[(f64, f64)], c: Rgb, width: u32) {
        for w in points.windows(2) {
            self.line(w[0].0, w[0].1, w[1].0, w[1].1, c, width);
        }
    }

    /// Outline of a circle (midpoint algorithm).
    pub fn circle(&mut self, cx: f64, cy: f64, r: f64, c: Rgb) {
        if !(cx.is_finite() && cy.is_finite() && r.is_finite()) || r < 0.0 {
            return;
        }
        let (cx, cy, r) = (cx.round() as i64, cy.round() as i64, r.round() as i64);
        // Cap the radius: a huge circle around a far-off centre is invisible anyway.
        if r > 4 * (self.width.max(self.height) as i64) {
            return;
        }
        let (mut x, mut y, mut err) = (r, 0i64, 1 - r);
        while x >= y {
            for (px, py) in [
                (x, y),
                (y, x),
                (-y, x),
                (-x, y),
                (-x, -y),
                (-y, -x),
                (y, -x),
                (x, -y),
            ] {
                self.set(cx + px, cy + py, c);
            }
            y += 1;
            if err < 0 {
                err += 2 * y + 1;
            } else {
                x -= 1;
                err += 2 * (y - x) + 1;
            }
        }
    }

    /// A filled disc.
    pub fn fill_circle(&mut self, cx: f64, cy: f64, r: f64, c: Rgb) {
        if !(cx.is_finite() && cy.is_finite() && r.is_finite()) || r < 0.0 {
            return;
        }
        let ri = r.ceil() as i64;
        if ri > 4 * (self.width.max(self.height) as i64) {
            return;
        }
        let (x0, y0) = (cx.round() as i64, cy.round() as i64);
        for dy in -ri..=ri {
            for dx in -ri..=ri {
                if ((dx * dx + dy * dy) as f64) <= r * r {
                    self.set(x0 + dx, y0 + dy, c);
                }
            }
        }
    }

    /// Width in pixels of `s` drawn at `scale`.
    pub fn text_width(s: &str, scale: u32) -> i64 {
        (s.chars().count() as u32 * GLYPH * scale) as i64
    }

    /// Draws `s` with its top-left corner at (x, y), each font pixel `scale` pixels wide.
    pub fn text(&mut self, x: i64, y: i64, s: &str, c: Rgb, scale: u32) {
        let k = scale.max(1) as i64;
        for (n, ch) in s.chars().enumerate() {
            let g = glyph(ch);
            let ox = x + n as i64 * GLYPH as i64 * k;
            for (row, bits) in g.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        let px = ox + col * k;
                        let py = y + row as i64 * k;
                        self.fill_rect(px, py, px + k - 1, py + k - 1, c);
                    }
                }
            }
        }
    }

    /// Draws `s` rotated a quarter turn counter-clockwise (reading bottom to top), its
    /// bounding box's top-left at (x, y). For vertical axis labels.
    pub fn text_up(&mut self, x: i64, y: i64, s: &str, c: Rgb, scale: u32) {
        let k = scale.max(1) as i64;
        let len = Self::text_width(s, scale);
        for (n, ch) in s.chars().enumerate() {
            let g = glyph(ch);
            // Character n starts at the bottom and advances upwards.
            let base_y = y + len - n as i64 * GLYPH as i64 * k;
            for (row, bits) in g.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        let px = x + row as i64 * k;
                        let py = base_y - (col + 1) * k;
                        self.fill_rect(px, py, px + k - 1, py + k - 1, c);
                    }
                }
            }
        }
    }

    /// Encodes the canvas as an 8-bit RGB PNG. Only pixel data goes in (no time stamp,
    /// no gamma or text chunks), and the compression settings are fixed, so identical
    /// pixels give identical bytes.
    pub fn encode_png(&self) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.width, self.height);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_compression(png::Compression::Balanced);
            enc.set_filter(png::Filter::Adaptive);
            let mut w = enc
                .write_header()
                .map_err(|e| Error::bake(format!("cannot encode PNG: {e}")))?;
            w.write_image_data(&self.px)
                .map_err(|e| Error::bake(format!("cannot encode PNG: {e}")))?;
            w.finish()
                .map_err(|e| Error::bake(format!("cannot encode PNG: {e}")))?;
        }
        Ok(out)
    }

    /// Writes the PNG atomically: an interrupted run leaves the previous figure intact.
    pub fn save_png(&self, path: &Path) -> Result<PathBuf> {
        use std::io::Write;
        let bytes = self.encode_png()?;
        let mut f = AtomicFile::create(path)?;
        f.write_all(&bytes).map_err(|e| Error::io(path, e))?;
        f.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drawing_is_clipped_not_panicking() {
        let mut c = Canvas::new(10, 10, [255; 3]);
        c.line(-1e9, -5.0, 1e9, 5.0, [0; 3], 3);
        c.fill_rect(-5, -5, 100, 2, [1, 2, 3]);
        c.circle(5.0, 5.0, 1e12, [0; 3]);
        c.fill_circle(-50.0, 5.0, 3.0, [0; 3]);
        c.text(8, 8, "hello", [0; 3], 2);
        c.line(f64::NAN, 0.0, 1.0, 1.0, [9; 3], 1);
        assert_eq!(c.get(0, 0), Some([1, 2, 3]));
        assert_eq!(c.get(10, 0), None);
    }

    #[test]
    fn line_covers_both_endpoints() {
        let mut c = Canvas::new(20, 20, [255; 3]);
        c.line(2.0, 3.0, 17.0, 11.0, [0; 3], 1);
        assert_eq!(c.get(2, 3), Some([0; 3]));
        assert_eq!(c.get(17, 11), Some([0; 3]));
    }

    #[test]
    fn text_up_occupies_a_tall_box() {
        let mut c = Canvas::new(20, 40, [255; 3]);
        c.text_up(2, 2, "AB", [0; 3], 1);
        let dark: Vec<(i64, i64)> = (0..20)
            .flat_map(|x| (0..40).map(move |y| (x, y)))
            .filter(|&(x, y)| c.get(x, y) == Some([0; 3]))
            .collect();
        assert!(!dark.is_empty());
        assert!(
            dark.iter()
                .all(|&(x, y)| (2..10).contains(&x) && (2..18).contains(&y))
        );
    }
}
