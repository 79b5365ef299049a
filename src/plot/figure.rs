//! A figure: drawn by `plotters` on a canvas `SUPERSAMPLE` times the output size, then
//! box-filtered down. `plotters`' bitmap backend anti-aliases text and 1-pixel lines but
//! not filled shapes or thick lines; averaging 2×2 samples smooths every edge.
//!
//! Output is deterministic: drawing is single-threaded integer and IEEE arithmetic, the
//! downsampling is integer, and the PNG carries only pixel data (no time stamp, gamma or
//! text chunks) with fixed compression settings, so identical input gives identical bytes.

use super::font;
use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Samples per output pixel along each axis.
pub const SUPERSAMPLE: u32 = 2;

/// The drawing surface a figure's painter receives (supersampled pixels).
pub type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
/// What drawing calls return; any error ends the figure with a message.
pub type DrawResult<T = ()> = std::result::Result<
    T,
    DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>,
>;

/// Output pixels to supersampled canvas pixels.
pub fn px(v: f64) -> i32 {
    (v * SUPERSAMPLE as f64).round() as i32
}

/// An RGB image, row-major, 3 bytes per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
}

impl Figure {
    /// Draws a `width` × `height` figure (output pixels) on a white background with `paint`.
    pub fn draw(width: u32, height: u32, paint: impl FnOnce(&Area) -> DrawResult) -> Result<Self> {
        font::register();
        let (sw, sh) = (width * SUPERSAMPLE, height * SUPERSAMPLE);
        let mut big = vec![255u8; sw as usize * sh as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut big, (sw, sh)).into_drawing_area();
            paint(&root)
                .and_then(|()| root.present())
                .map_err(|e| Error::bake(format!("cannot draw figure: {e}")))?;
        }
        Ok(Figure {
            width,
            height,
            rgb: downsample(&big, width, height),
        })
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Raw RGB bytes, row-major.
    pub fn pixels(&self) -> &[u8] {
        &self.rgb
    }
    /// The colour at (x, y), or `None` outside the image.
    pub fn get(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y as usize * self.width as usize + x as usize) * 3;
        Some([self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]])
    }

    /// Pastes an RGB image (`w` × `h`, row-major, 3 bytes per pixel) with its top-left
    /// corner at (x, y), clipped to the figure: for figures made of pictures (a wedge's
    /// contact sheet of previews).
    pub fn paste(&mut self, x: u32, y: u32, w: u32, h: u32, rgb: &[u8]) {
        let cols = w.min(self.width.saturating_sub(x)) as usize;
        for row in 0..h.min(self.height.saturating_sub(y)) as usize {
            let src = row * w as usize * 3;
            let dst = ((y as usize + row) * self.width as usize + x as usize) * 3;
            self.rgb[dst..dst + cols * 3].copy_from_slice(&rgb[src..src + cols * 3]);
        }
    }

    /// Encodes the figure as an 8-bit RGB PNG.
    pub fn encode_png(&self) -> Result<Vec<u8>> {
        let err = |e: png::EncodingError| Error::bake(format!("cannot encode PNG: {e}"));
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.width, self.height);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_compression(png::Compression::High);
            enc.set_filter(png::Filter::Adaptive);
            let mut w = enc.write_header().map_err(err)?;
            w.write_image_data(&self.rgb).map_err(err)?;
            w.finish().map_err(err)?;
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

/// Averages each SUPERSAMPLE × SUPERSAMPLE block of `big` (rounded to nearest).
fn downsample(big: &[u8], width: u32, height: u32) -> Vec<u8> {
    let s = SUPERSAMPLE as usize;
    let (w, h) = (width as usize, height as usize);
    let n = (s * s) as u32;
    let mut out = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let mut sum = 0u32;
                for dy in 0..s {
                    let row = (y * s + dy) * w * s;
                    for dx in 0..s {
                        sum += big[(row + x * s + dx) * 3 + c] as u32;
                    }
                }
                out.push(((sum + n / 2) / n) as u8);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsampling_averages_blocks() {
        // 2×1 output from a 4×2 canvas: left block black/white half and half, right white.
        let mut big = vec![255u8; 4 * 2 * 3];
        big[..3].copy_from_slice(&[0, 0, 0]);
        big[4 * 3..4 * 3 + 3].copy_from_slice(&[0, 0, 0]);
        let out = downsample(&big, 2, 1);
        assert_eq!(out, vec![128, 128, 128, 255, 255, 255]);
    }

    #[test]
    fn text_and_lines_are_anti_aliased() {
        let fig = Figure::draw(120, 40, |a| {
            a.draw(&PathElement::new(
                vec![(px(5.0), px(5.0)), (px(115.0), px(30.0))],
                BLACK.stroke_width(px(1.5) as u32),
            ))?;
            // A character the font lacks (CJK) draws as its empty glyph, not an error.
            a.draw_text(
                "Tq ω² \u{4e00}",
                &super::font::text(16.0, BLACK),
                (px(10.0), px(12.0)),
            )
        })
        .unwrap();
        let greys = fig
            .pixels()
            .chunks(3)
            .filter(|p| p[0] > 20 && p[0] < 235)
            .count();
        let blacks = fig.pixels().chunks(3).filter(|p| p[0] <= 20).count();
        // Edges blend into the background: partly covered pixels are grey, not black or white.
        assert!(greys > 100 && blacks > 20, "greys {greys}, blacks {blacks}");
    }
}
