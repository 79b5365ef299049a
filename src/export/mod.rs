//! Cache writers: glTF 2.0 (`.glb`/`.gltf`), USDA PointInstancer (`.usda`), tracks CSV.
//!
//! Every writer receives frames one at a time (`CacheWriter::write_frame`) so that no
//! writer needs the whole history of every bee in memory, and every file is written
//! atomically (see `atomic`): a failed or interrupted bake leaves the previous cache.

pub mod atomic;
pub mod csv;
pub mod gltf;
pub mod preview;
pub mod usda;

use crate::error::{Error, Result};
use crate::sim::{CacheMeta, Frame};
use std::path::Path;

/// A cache format the bake can write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Format {
    Glb,
    Gltf,
    Usda,
    Csv,
}

impl Format {
    pub const ALL: [Format; 4] = [Format::Glb, Format::Gltf, Format::Usda, Format::Csv];

    pub fn name(self) -> &'static str {
        match self {
            Format::Glb => "glb",
            Format::Gltf => "gltf",
            Format::Usda => "usda",
            Format::Csv => "csv",
        }
    }

    pub fn parse(s: &str) -> Option<Format> {
        Format::ALL
            .into_iter()
            .find(|f| f.name() == s.trim().to_ascii_lowercase())
    }

    /// The file a format writes for a shot (gltf also writes `<name>.bin` beside it).
    pub fn file_name(self, shot_name: &str) -> String {
        match self {
            Format::Csv => format!("{shot_name}.tracks.csv"),
            f => format!("{shot_name}.{}", f.name()),
        }
    }
}

/// Per-format settings from the shot's `[output]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputOptions {
    /// Visible wing flap rate written to glTF wing tracks, Hz. 0 = a static blurred pose.
    pub gltf_wing_flap_hz: f64,
    /// Split USDA time samples into value clips of this many frames (0 = one file).
    pub usda_clip_frames: u32,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            gltf_wing_flap_hz: 0.0,
            usda_clip_frames: 0,
        }
    }
}

/// A writer that receives every recorded frame in order, then is finished.
pub trait CacheWriter: Send {
    /// Called once per frame, in frame order, for every frame of the range.
    fn write_frame(&mut self, frame: &Frame) -> Result<()>;
    /// Completes the files and returns them sealed under temporary names, in the order
    /// they must be renamed into place (the bake renames them only once every writer has
    /// sealed, so a failure in any format leaves every previous cache untouched).
    fn finish(self: Box<Self>) -> Result<Vec<atomic::SealedFile>>;
}

/// The frame contract of writers that lay out their files from the first frame: frames
/// arrive in order, one per frame of the range, each with every swarm of the shot.
/// `writer` names the format in the error; `next_frame` is the frame expected now.
pub(crate) fn check_frame_order(
    writer: &str,
    meta: &CacheMeta,
    next_frame: i32,
    frame: &Frame,
) -> Result<()> {
    if frame.frame != next_frame || frame.frame > meta.frame_end {
        return Err(Error::bake(format!(
            "{writer} writer: got frame {}, expected {next_frame} (range {}..={})",
            frame.frame, meta.frame_start, meta.frame_end
        )));
    }
    if frame.swarms.len() != meta.swarms.len() {
        return Err(Error::bake(format!(
            "{writer} writer: frame {} has {} swarms, the shot has {}",
            frame.frame,
            frame.swarms.len(),
            meta.swarms.len()
        )));
    }
    Ok(())
}

/// At `finish`: every frame of the range was written (`next_frame` is one past the last).
pub(crate) fn check_all_frames_written(
    writer: &str,
    meta: &CacheMeta,
    next_frame: i32,
) -> Result<()> {
    if next_frame != meta.frame_end + 1 {
        return Err(Error::bake(format!(
            "{writer} writer: finished after frame {} of {}..={}",
            next_frame - 1,
            meta.frame_start,
            meta.frame_end
        )));
    }
    Ok(())
}

/// Opens the preview writer (`<name>.preview.png`, a plot of the trajectories).
pub fn open_preview(
    shot: &crate::shot::Shot,
    meta: &CacheMeta,
    dir: &Path,
) -> Result<Box<dyn CacheWriter>> {
    Ok(Box::new(preview::PreviewWriter::create(shot, meta, dir)?))
}

/// Opens the writer for one format in `dir`.
pub fn open_writer(
    format: Format,
    meta: &CacheMeta,
    dir: &Path,
    opts: &OutputOptions,
) -> Result<Box<dyn CacheWriter>> {
    let path = dir.join(format.file_name(&meta.shot_name));
    match format {
        Format::Csv => Ok(Box::new(csv::CsvWriter::create(&path, meta)?)),
        Format::Glb => Ok(Box::new(gltf::GltfWriter::create(
            gltf::Container::Glb,
            &path,
            meta,
            opts,
        )?)),
        Format::Gltf => Ok(Box::new(gltf::GltfWriter::create(
            gltf::Container::Gltf,
            &path,
            meta,
            opts,
        )?)),
        Format::Usda => Ok(Box::new(usda::UsdaWriter::create(
            &path,
            meta,
            opts.usda_clip_frames,
        )?)),
    }
}
