//! The contact sheet: every variant's preview (top and side views of the trajectories,
//! `--preview`) shrunk into one labelled grid, so a wedge is judged at a glance.

use crate::error::{Error, Result};
use crate::plot::{Figure, palette, px, text};
use plotters::prelude::*;
use std::path::Path;

/// Width of one variant's thumbnail at most, pixels: half a preview (1,320 pixels wide),
/// which shrinks by a whole factor.
const THUMB_W: usize = 660;
const COLUMNS: usize = 4;
const GAP: usize = 16;
const LABEL_H: usize = 30;
const TITLE_H: usize = 44;

/// An 8-bit RGB image.
struct Image {
    width: usize,
    height: usize,
    rgb: Vec<u8>,
}

fn read_png(path: &Path) -> Result<Image> {
    let file = std::fs::File::open(path).map_err(|e| {
        Error::bake(format!(
            "cannot read the preview {}: {e} (did this variant bake?)",
            path.display()
        ))
    })?;
    let bad = |e: String| Error::bake(format!("{}: not a preview PNG: {e}", path.display()));
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(|e| bad(e.to_string()))?;
    let mut buf = vec![
        0;
        reader
            .output_buffer_size()
            .ok_or_else(|| bad("too large".into()))?
    ];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| bad(e.to_string()))?;
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = match info.color_type {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Indexed => return Err(bad("indexed colour".into())),
    };
    let mut rgb = Vec::with_capacity(w * h * 3);
    for px in buf[..w * h * channels].chunks_exact(channels) {
        match channels {
            1 | 2 => rgb.extend_from_slice(&[px[0]; 3]),
            _ => rgb.extend_from_slice(&px[..3]),
        }
    }
    Ok(Image {
        width: w,
        height: h,
        rgb,
    })
}

/// Shrinks by a whole factor, averaging each block (integer arithmetic: the same bytes on
/// every machine).
fn shrink(img: &Image, max_width: usize) -> Image {
    let f = img.width.div_ceil(max_width).max(1);
    let (w, h) = (img.width / f, img.height / f);
    let mut rgb = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0u32; 3];
            for dy in 0..f {
                let row = (y * f + dy) * img.width;
                for dx in 0..f {
                    let p = (row + x * f + dx) * 3;
                    for (s, &v) in sum.iter_mut().zip(&img.rgb[p..p + 3]) {
                        *s += v as u32;
                    }
                }
            }
            let n = (f * f) as u32;
            rgb.extend(sum.iter().map(|s| ((s + n / 2) / n) as u8));
        }
    }
    Image {
        width: w,
        height: h,
        rgb,
    }
}

/// Width of a character of the bundled font, as a share of the text size: a little more
/// than Roboto's average, so that cut labels always fit.
const CHAR_WIDTH: f64 = 0.6;
/// Text sizes of the title and the labels, pixels.
const TITLE_SIZE: f64 = 26.0;
const LABEL_SIZE: f64 = 18.0;

/// `label` cut to at most `width` pixels of text `size` pixels high.
fn fit(label: &str, width: usize, size: f64) -> String {
    let max = (width as f64 / (CHAR_WIDTH * size)) as usize;
    if label.chars().count() <= max {
        return label.to_owned();
    }
    let mut s: String = label.chars().take(max.saturating_sub(3)).collect();
    s.push_str("...");
    s
}

/// Draws the sheet: `title` on top, then one cell per `(label, preview path)`.
pub fn render(title: &str, cells: &[(String, std::path::PathBuf)]) -> Result<Figure> {
    let thumbs: Vec<Image> = cells
        .iter()
        .map(|(_, p)| read_png(p).map(|i| shrink(&i, THUMB_W)))
        .collect::<Result<_>>()?;
    let cols = cells.len().clamp(1, COLUMNS);
    let rows = cells.len().div_ceil(cols).max(1);
    let cell_w = thumbs.iter().map(|t| t.width).max().unwrap_or(THUMB_W);
    let cell_h = thumbs.iter().map(|t| t.height).max().unwrap_or(0) + LABEL_H;
    let width = GAP + cols * (cell_w + GAP);
    let height = TITLE_H + rows * (cell_h + GAP);
    let origin = |k: usize| {
        (
            GAP + (k % cols) * (cell_w + GAP),
            TITLE_H + (k / cols) * (cell_h + GAP),
        )
    };
    // Text and frames drawn by plotters; the thumbnails pasted in afterwards, pixel for
    // pixel.
    let mut sheet = Figure::draw(width as u32, height as u32, |area| {
        let at = |x: usize, y: usize| (px(x as f64), px(y as f64));
        area.draw(&Text::new(
            fit(title, width - 2 * GAP, TITLE_SIZE),
            at(GAP, 8),
            text(TITLE_SIZE, palette::BLACK),
        ))?;
        for (k, ((label, _), t)) in cells.iter().zip(&thumbs).enumerate() {
            let (x0, y0) = origin(k);
            area.draw(&Text::new(
                fit(label, cell_w, LABEL_SIZE),
                at(x0, y0 + 4),
                text(LABEL_SIZE, palette::BLACK),
            ))?;
            let top = y0 + LABEL_H;
            area.draw(&Rectangle::new(
                [at(x0 - 1, top - 1), at(x0 + t.width, top + t.height)],
                palette::LIGHT_GREY.stroke_width(px(1.0) as u32),
            ))?;
        }
        Ok(())
    })?;
    for (k, t) in thumbs.iter().enumerate() {
        let (x0, y0) = origin(k);
        sheet.paste(
            x0 as u32,
            (y0 + LABEL_H) as u32,
            t.width as u32,
            t.height as u32,
            &t.rgb,
        );
    }
    Ok(sheet)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shrinking_averages_blocks() {
        let img = Image {
            width: 4,
            height: 2,
            rgb: [[0u8, 0, 0], [255, 255, 255], [10, 20, 30], [10, 20, 30]]
                .iter()
                .cycle()
                .take(8)
                .flatten()
                .copied()
                .collect(),
        };
        let s = shrink(&img, 2);
        assert_eq!((s.width, s.height), (2, 1));
        assert_eq!(s.rgb, [128, 128, 128, 10, 20, 30]);
    }

    #[test]
    fn long_labels_are_cut() {
        // 36 pixels hold 6 characters 10 pixels high.
        assert_eq!(fit("abcdef", 36, 10.0), "abcdef");
        assert_eq!(fit("abcdefgh", 36, 10.0), "abc...");
    }
}
