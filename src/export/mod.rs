//! Cache writers: glTF 2.0 (`.glb`/`.gltf`), USDA PointInstancer (`.usda`), tracks CSV.
//!
//! Every writer receives frames one at a time (`CacheWriter::write_frame`) so that no
//! writer needs the whole history of every bee in memory, and every file is written
//! atomically (see `crate::atomic`): a failed or interrupted bake leaves the previous cache.

pub mod csv;
pub mod gltf;
pub mod preview;
pub mod usda;
pub mod wings;

use crate::error::{Error, Result};
use crate::sim::{CacheMeta, Frame};
use std::path::Path;

pub use crate::shot::{Format, GltfLayout, OutputOptions};

/// A writer that receives every recorded frame in order, then is finished.
pub trait CacheWriter: Send {
    /// Called once per frame, in frame order, for every frame of the range.
    fn write_frame(&mut self, frame: &Frame) -> Result<()>;
    /// Completes the files and returns them sealed under temporary names, in the order
    /// they must be renamed into place (the bake renames them only once every writer has
    /// sealed, so a failure in any format leaves every previous cache untouched).
    fn finish(self: Box<Self>) -> Result<Vec<crate::atomic::SealedFile>>;
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
            opts.usda_clip_frames
                .unwrap_or_else(|| usda::auto_clip_frames(meta)),
            opts.wings,
        )?)),
    }
}
