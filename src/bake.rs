//! Baking: run a shot's simulation and stream every frame to the cache writers.

use crate::error::{Error, Result};
use crate::export::{self, CacheWriter, Format};
use crate::shot::Shot;
use crate::sim::{Frame, Simulation, SwarmFrame};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::Instant;

pub use crate::atomic::INTERRUPTED;
use crate::atomic::INTERRUPTED_MESSAGE;
use crate::cache_set::{SetInfo, pause_point, pausing};

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
    crate::atomic::probe_writable(dir).map_err(|e| {
        Error::input(format!(
            "the output folder {} is not writable: {e}",
            dir.display()
        ))
    })
}

/// The most worker threads a command accepts: four per core. More only adds switching
/// (results are the same for any count), and `--threads 100000` would spawn them all.
pub fn max_threads() -> usize {
    4 * std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `--threads`: 0 (all cores) up to [`max_threads`], else an input error.
pub fn check_threads(threads: usize) -> Result<usize> {
    if threads > max_threads() {
        return Err(Error::input(format!(
            "--threads: expected 0 (all cores) up to {} (four per core), found {threads}",
            max_threads()
        )));
    }
    Ok(threads)
}

/// Runs `f` on a pool of `threads` workers (0 = all cores).
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> Result<T> {
    let threads = check_threads(threads)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::bake(format!("cannot start worker threads: {e}")))?;
    Ok(pool.install(f))
}

/// What the simulation thread sends the writer thread.
enum Message {
    Frame {
        frame: i32,
        time: f64,
        swarms: Vec<SwarmFrame>,
    },
    /// Every frame was sent: the writers may complete their files.
    Done,
}

/// Bakes `shot` into the requested caches; returns the written paths (the cache set's
/// files, then its manifest).
///
/// The simulation and the writers run concurrently: frames go to a writer thread through a
/// channel that holds at most two frames, so memory stays bounded while formatting one
/// frame overlaps simulating the next. Writers complete only after the last frame, and
/// their files replace the previous set as one (`crate::cache_set`); an error or an
/// interrupt before that drops them, which removes their temporary files.
pub fn bake(
    shot: &Shot,
    opts: &BakeOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Vec<PathBuf>> {
    bake_resumable(shot, opts, None, progress)
}

/// [`bake`] with checkpoints (`--checkpoint-every`, `--resume`; see `crate::checkpoint`):
/// frames before a restored checkpoint are replayed from its journal, the rest simulated.
pub fn bake_resumable(
    shot: &Shot,
    opts: &BakeOptions,
    checkpoints: Option<&crate::checkpoint::CheckpointOptions>,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Vec<PathBuf>> {
    prepare_out_dir(opts.out_dir)?;
    // One bake of a shot into a folder at a time; held until the set is committed.
    let _lock = crate::cache_set::lock(opts.out_dir, &shot.name)?;
    // What bakes killed outright (kill -9, out of memory) left here goes first.
    crate::cache_set::remove_stale_temporaries(opts.out_dir, &shot.name);
    let start = Instant::now();
    let mut sim = Simulation::new(shot);
    sim.set_cancel(&INTERRUPTED);
    let (mut checkpointer, mut replay) = match checkpoints {
        Some(c) => {
            let (ck, replay) = crate::checkpoint::open(c, shot, opts.out_dir, &mut sim)?;
            (ck, Some(replay))
        }
        None => (None, None),
    };
    // Angular velocities only for the caches that hold them, and the journal, whose
    // frames a resumed bake sends to its writers as they were.
    sim.record_spin(opts.formats.contains(&Format::Usda) || checkpoints.is_some());
    let meta = sim.meta();
    let info = SetInfo::of(shot);
    let out_dir = opts.out_dir;
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
    std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Message>(2);
        // Frames written go back to the simulation, which records later frames into them.
        let (recycle, written) = std::sync::mpsc::channel::<Vec<SwarmFrame>>();
        let writer = scope.spawn(move || -> Result<Vec<PathBuf>> {
            for msg in rx {
                match msg {
                    Message::Frame {
                        frame,
                        time,
                        swarms,
                    } => {
                        let f = Frame {
                            frame,
                            time,
                            swarms: &swarms,
                        };
                        for w in writers.iter_mut() {
                            w.write_frame(&f)?;
                        }
                        let _ = recycle.send(swarms);
                    }
                    Message::Done => {
                        // Seal every file of every format, then replace the set. An
                        // interrupt while sealing (which can take seconds) drops the
                        // sealed files; the renames themselves take milliseconds and,
                        // once begun, complete, so the set is never left half replaced.
                        let mut sealed = Vec::new();
                        for (k, w) in writers.into_iter().enumerate() {
                            if INTERRUPTED.load(Ordering::Relaxed) {
                                return Err(Error::bake(INTERRUPTED_MESSAGE));
                            }
                            sealed.extend(w.finish()?);
                            pause_point(&format!("sealed {}", k + 1));
                        }
                        if INTERRUPTED.load(Ordering::Relaxed) {
                            return Err(Error::bake(INTERRUPTED_MESSAGE));
                        }
                        let mut written = crate::cache_set::commit(out_dir, &info, sealed)?;
                        written.push(crate::cache_set::manifest_path(out_dir, &info.shot_name));
                        return Ok(written);
                    }
                }
            }
            Err(Error::bake(INTERRUPTED_MESSAGE))
        });
        let simulated = with_threads(opts.threads, || -> Result<()> {
            let written = written; // (moved in: a receiver is not shared between threads)
            for done in 1..=total {
                let replayed = replay.as_mut().map(|r| r.next_frame()).transpose()?;
                let (frame, msg) = if let Some(f) = replayed.flatten() {
                    // Made before the checkpoint: sent from its journal as it was.
                    let msg = Message::Frame {
                        frame: f.frame,
                        time: f.time,
                        swarms: f.swarms,
                    };
                    (f.frame, msg)
                } else {
                    if done > 1 && !sim.advance_or_cancel() {
                        return Err(Error::bake(INTERRUPTED_MESSAGE));
                    }
                    if INTERRUPTED.load(Ordering::Relaxed) {
                        return Err(Error::bake(INTERRUPTED_MESSAGE));
                    }
                    if let Some(ck) = checkpointer.as_mut() {
                        ck.after_frame(&sim)?;
                    }
                    let mut swarms = written.try_recv().unwrap_or_default();
                    sim.swap_record(&mut swarms);
                    let msg = Message::Frame {
                        frame: sim.frame(),
                        time: sim.time(),
                        swarms,
                    };
                    (sim.frame(), msg)
                };
                if tx.send(msg).is_err() {
                    // The writer stopped on an error; it reports it below.
                    return Ok(());
                }
                progress(Progress {
                    done,
                    total,
                    frame,
                    elapsed_s: start.elapsed().as_secs_f64(),
                });
                if pausing() {
                    pause_point(&format!("frame {done}"));
                }
            }
            let _ = tx.send(Message::Done);
            Ok(())
        })?;
        drop(tx);
        let written = writer
            .join()
            .unwrap_or_else(|_| Err(Error::bake("a cache writer failed unexpectedly")));
        simulated?;
        let written = written?;
        // The caches are in place: the checkpoint has done its work.
        if let Some(ck) = checkpointer {
            ck.finish();
        }
        if checkpoints.is_some() {
            let _ = std::fs::remove_dir_all(crate::checkpoint::folder(opts.out_dir, shot));
        }
        Ok(written)
    })
}
