//! Baking: run a shot's simulation and stream every frame to the cache writers.

use crate::error::{Error, Result};
use crate::export::{self, CacheWriter, Format};
use crate::shot::Shot;
use crate::sim::{Frame, Simulation};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Set by the SIGINT/SIGTERM handler; the bake stops at the next frame and removes its
/// temporary files, leaving any previous cache untouched.
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Progress of a bake, reported after every frame.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// Frames written so far (1-based count) and in total.
    pub done: usize,
    pub total: usize,
    pub frame: i32,
    pub elapsed_s: f64,
}

/// What a bake needs besides the shot.
pub struct BakeOptions<'a> {
    pub out_dir: &'a Path,
    pub formats: &'a [Format],
    pub preview: bool,
    /// Worker threads (0 = all cores).
    pub threads: usize,
}

/// Checks up front that the output folder can be written, so a bad `--out` fails before
/// any simulation time is spent.
pub fn prepare_out_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| {
        Error::input(format!(
            "cannot create the output folder {}: {e}",
            dir.display()
        ))
    })?;
    let probe = crate::export::atomic::ScratchFile::new(dir, "write-probe");
    std::fs::write(&probe.path, b"").map_err(|e| {
        Error::input(format!(
            "the output folder {} is not writable: {e}",
            dir.display()
        ))
    })?;
    Ok(())
}

/// Runs `f` on a pool of `threads` workers (0 = all cores).
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> Result<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::bake(format!("cannot start worker threads: {e}")))?;
    Ok(pool.install(f))
}

/// Bakes `shot` into the requested caches; returns the written paths.
pub fn bake(
    shot: &Shot,
    opts: &BakeOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Vec<PathBuf>> {
    prepare_out_dir(opts.out_dir)?;
    with_threads(opts.threads, || {
        let start = Instant::now();
        let mut sim = Simulation::new(shot);
        let meta = sim.meta();
        let mut writers: Vec<Box<dyn CacheWriter>> = Vec::new();
        for &f in opts.formats {
            writers.push(export::open_writer(
                f,
                &meta,
                opts.out_dir,
                &shot.output.options,
            )?);
        }
        if opts.preview {
            writers.push(export::open_preview(shot, &meta, opts.out_dir)?);
        }
        let total = shot.frame_count();
        for done in 1..=total {
            if done > 1 {
                sim.advance();
            }
            if INTERRUPTED.load(Ordering::Relaxed) {
                return Err(Error::bake(
                    "interrupted: no cache was written; the previous cache is untouched",
                ));
            }
            let frame = Frame {
                frame: sim.frame(),
                time: sim.time(),
                swarms: sim.record(),
            };
            for w in writers.iter_mut() {
                w.write_frame(&frame)?;
            }
            progress(Progress {
                done,
                total,
                frame: sim.frame(),
                elapsed_s: start.elapsed().as_secs_f64(),
            });
        }
        let mut outputs = Vec::new();
        for w in writers {
            outputs.extend(w.finish()?);
        }
        Ok(outputs)
    })?
}
