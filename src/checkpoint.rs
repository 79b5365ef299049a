//! Resumable bakes: `bake --checkpoint-every N` and `--resume`.
//!
//! A bake with checkpoints keeps, in `<out>/<name>.checkpoint/`:
//!
//! - `frames.bin`, the journal: every frame recorded so far, appended as it is made;
//! - `state.bin`, the checkpoint: every N frames, the simulation's whole state and how
//!   much of the journal belongs to it, written atomically.
//!
//! A bake started again with `--resume` restores the state, replays the journal's frames
//! into fresh cache writers and simulates on from there, so its caches are byte-identical
//! to an uninterrupted bake's: the caches themselves are still written to temporary files
//! and renamed into place only at the end. The folder is removed once the caches are in
//! place. File layout (little-endian): docs/farm.md, "Checkpoints".

use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use crate::shot::Shot;
use crate::sim::{Simulation, SwarmFrame};
use glam::{Quat, Vec3};
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, Write};
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 22] = b"BEESWARM CHECKPOINT 1\n";

/// What the command line asked for.
#[derive(Clone, Copy, Debug, Default)]
pub struct CheckpointOptions {
    /// Frames between checkpoints; 0 writes none.
    pub every: u32,
    /// Continue from the checkpoint in the output folder, if there is one that fits.
    pub resume: bool,
    /// Print nothing but errors.
    pub quiet: bool,
}

/// One recorded frame, as the bake sends it to the writers.
pub struct JournalFrame {
    pub frame: i32,
    pub time: f64,
    pub swarms: Vec<SwarmFrame>,
}

/// The checkpoint folder of a shot's bake in `out_dir`.
pub fn folder(out_dir: &Path, shot: &Shot) -> PathBuf {
    out_dir.join(format!("{}.checkpoint", shot.name))
}

/// FNV-1a, 64-bit: a checksum and a fingerprint, the same on every machine.
fn fnv(bytes: &[u8], mut h: u64) -> u64 {
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}
const FNV_START: u64 = 0xcbf2_9ce4_8422_2325;

/// What a checkpoint must match: the resolved shot (seed, frames, every parameter), the
/// tool's version and the machine's byte order.
fn fingerprint(shot: &Shot) -> u64 {
    let text = format!(
        "{shot:?} {} {}",
        env!("CARGO_PKG_VERSION"),
        cfg!(target_endian = "little")
    );
    fnv(text.as_bytes(), FNV_START)
}

/// Writes checkpoints and the journal during a bake.
pub struct Checkpointer {
    dir: PathBuf,
    every: u32,
    fingerprint: u64,
    frame_start: i32,
    journal: BufWriter<File>,
    journal_len: u64,
}

/// Frames to replay from the journal before simulating on.
pub struct Replay {
    reader: Option<BufReader<File>>,
    left: usize,
}

impl Replay {
    fn none() -> Self {
        Replay {
            reader: None,
            left: 0,
        }
    }

    /// The next journal frame, or `None` once replayed.
    pub fn next_frame(&mut self) -> Result<Option<JournalFrame>> {
        if self.left == 0 {
            return Ok(None);
        }
        let r = self
            .reader
            .as_mut()
            .expect("a reader while frames are left");
        self.left -= 1;
        read_frame(r)
            .map(Some)
            .map_err(|e| Error::bake(format!("cannot read the checkpoint's frames: {e}")))
    }
}

/// Prepares a bake of `shot` into `out_dir`: with `--resume` and a checkpoint that fits,
/// restores `sim` to it and returns the journal's frames to replay; otherwise starts a new
/// checkpoint folder (with checkpoints asked for) and replays nothing.
pub fn open(
    opts: &CheckpointOptions,
    shot: &Shot,
    out_dir: &Path,
    sim: &mut Simulation,
) -> Result<(Option<Checkpointer>, Replay)> {
    let dir = folder(out_dir, shot);
    let fp = fingerprint(shot);
    let mut replay = Replay::none();
    let mut journal_len = 0;
    if opts.resume {
        match read_state(&dir, fp) {
            Ok(Some((len, state))) => {
                // A failed restore leaves `sim` unusable: rebuild it before baking afresh.
                match sim.restore_state(&state) {
                    Ok(()) => {
                        let frames = (sim.frame() - shot.frame_start + 1) as usize;
                        let file = File::open(dir.join("frames.bin"))
                            .map_err(|e| Error::io(&dir.join("frames.bin"), e))?;
                        replay = Replay {
                            reader: Some(BufReader::new(file)),
                            left: frames,
                        };
                        journal_len = len;
                        if !opts.quiet {
                            eprintln!(
                                "resuming from the checkpoint at frame {} in {}",
                                sim.frame(),
                                dir.display()
                            );
                        }
                    }
                    Err(e) => {
                        note(opts, &dir, &e);
                        let new = fresh(sim);
                        *sim = new;
                    }
                }
            }
            Ok(None) => {
                if !opts.quiet {
                    eprintln!(
                        "no checkpoint in {}: baking from the first frame",
                        dir.display()
                    );
                }
            }
            Err(e) => note(opts, &dir, &e),
        }
    }
    if opts.every == 0 {
        return Ok((None, replay));
    }
    if journal_len == 0 {
        let _ = std::fs::remove_dir_all(&dir);
    }
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let path = dir.join("frames.bin");
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .write(true)
        .truncate(journal_len == 0)
        .open(&path)
        .map_err(|e| Error::io(&path, e))?;
    // Frames written after the checkpoint are made again: drop them.
    file.set_len(journal_len)
        .and_then(|()| file.seek(std::io::SeekFrom::Start(journal_len)).map(|_| ()))
        .map_err(|e| Error::io(&path, e))?;
    Ok((
        Some(Checkpointer {
            dir,
            every: opts.every,
            fingerprint: fp,
            frame_start: shot.frame_start,
            journal: BufWriter::new(file),
            journal_len,
        }),
        replay,
    ))
}

fn note(opts: &CheckpointOptions, dir: &Path, why: &str) {
    if !opts.quiet {
        eprintln!(
            "note: ignoring the checkpoint in {} ({why}): baking from the first frame",
            dir.display()
        );
    }
}

/// A new simulation of the same shot, cancelled by the same flag.
fn fresh(sim: &Simulation) -> Simulation {
    let mut s = Simulation::new(sim.shot());
    s.set_cancel(&crate::atomic::INTERRUPTED);
    s
}

impl Checkpointer {
    /// Journals a simulated frame; every `every` frames, writes the checkpoint.
    pub fn after_frame(&mut self, sim: &Simulation) -> Result<()> {
        let path = self.dir.join("frames.bin");
        let mut bytes = Vec::new();
        write_frame(&mut bytes, sim.frame(), sim.time(), sim.record());
        self.journal
            .write_all(&bytes)
            .map_err(|e| Error::io(&path, e))?;
        self.journal_len += bytes.len() as u64;
        let done = (sim.frame() - self.frame_start + 1) as u32;
        if done.is_multiple_of(self.every) {
            // The journal reaches the disk before the checkpoint that counts on it.
            self.journal
                .flush()
                .and_then(|()| self.journal.get_ref().sync_data())
                .map_err(|e| Error::io(&path, e))?;
            self.write_state(sim)?;
        }
        if crate::cache_set::pausing() {
            // Tests kill the bake here, between checkpoints, as a farm pre-empts a task.
            crate::cache_set::pause_point(&format!("journaled {}", sim.frame()));
        }
        Ok(())
    }

    fn write_state(&self, sim: &Simulation) -> Result<()> {
        let state = sim.state_bytes();
        let mut out = Vec::with_capacity(state.len() + 64);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&self.fingerprint.to_le_bytes());
        out.extend_from_slice(&self.journal_len.to_le_bytes());
        out.extend_from_slice(&(state.len() as u64).to_le_bytes());
        out.extend_from_slice(&state);
        out.extend_from_slice(&fnv(&out, FNV_START).to_le_bytes());
        let path = self.dir.join("state.bin");
        let mut f = AtomicFile::create(&path)?;
        f.write_all(&out).map_err(|e| Error::io(&path, e))?;
        f.commit().map(|_| ())
    }

    /// The caches are in place: the checkpoint is no longer needed.
    pub fn finish(self) {
        drop(self.journal);
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The checkpoint in `dir`: (journal length, simulation state); `None` if there is none;
/// an error saying why one does not fit.
fn read_state(dir: &Path, fp: u64) -> std::result::Result<Option<(u64, Vec<u8>)>, String> {
    let bytes = match std::fs::read(dir.join("state.bin")) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e.to_string()),
    };
    let head = MAGIC.len() + 24;
    if bytes.len() < head + 8 || &bytes[..MAGIC.len()] != MAGIC {
        return Err("not a beeswarm checkpoint".to_owned());
    }
    let (body, sum) = bytes.split_at(bytes.len() - 8);
    if fnv(body, FNV_START).to_le_bytes() != sum {
        return Err("its checksum does not match: damaged".to_owned());
    }
    let word = |at: usize| u64::from_le_bytes(body[at..at + 8].try_into().expect("8 bytes"));
    if word(MAGIC.len()) != fp {
        return Err("it was written for another shot, seed, frame range or version".to_owned());
    }
    let journal_len = word(MAGIC.len() + 8);
    let state_len = word(MAGIC.len() + 16);
    if state_len != (body.len() - head) as u64 {
        return Err("its length does not match".to_owned());
    }
    let journal = std::fs::metadata(dir.join("frames.bin")).map_err(|e| e.to_string())?;
    if journal.len() < journal_len {
        return Err("its frames file is shorter than it says".to_owned());
    }
    Ok(Some((journal_len, body[head..].to_vec())))
}

fn put_f32s(out: &mut Vec<u8>, values: impl Iterator<Item = f32>) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// Appends one frame to `out` (the journal's record layout, docs/farm.md).
fn write_frame(out: &mut Vec<u8>, frame: i32, time: f64, swarms: &[SwarmFrame]) {
    out.extend_from_slice(&frame.to_le_bytes());
    out.extend_from_slice(&time.to_le_bytes());
    out.extend_from_slice(&(swarms.len() as u32).to_le_bytes());
    for s in swarms {
        out.extend_from_slice(&(s.ids.len() as u64).to_le_bytes());
        out.extend_from_slice(&(s.channels.len() as u32).to_le_bytes());
        for id in &s.ids {
            out.extend_from_slice(&id.to_le_bytes());
        }
        put_f32s(out, s.position.iter().flat_map(|v| v.to_array()));
        put_f32s(out, s.velocity.iter().flat_map(|v| v.to_array()));
        put_f32s(out, s.orientation.iter().flat_map(|q| q.to_array()));
        put_f32s(out, s.heading.iter().flat_map(|q| q.to_array()));
        put_f32s(
            out,
            s.angular_velocity_deg.iter().flat_map(|v| v.to_array()),
        );
        put_f32s(out, s.scale.iter().copied());
        for c in &s.channels {
            put_f32s(out, c.iter().copied());
        }
    }
}

fn read_frame(r: &mut impl Read) -> std::io::Result<JournalFrame> {
    let mut b4 = [0u8; 4];
    let mut b8 = [0u8; 8];
    let mut u32_ = |r: &mut dyn Read| -> std::io::Result<u32> {
        r.read_exact(&mut b4)?;
        Ok(u32::from_le_bytes(b4))
    };
    let frame = u32_(r)? as i32;
    r.read_exact(&mut b8)?;
    let time = f64::from_le_bytes(b8);
    let swarms = u32_(r)? as usize;
    let mut out = Vec::with_capacity(swarms);
    for _ in 0..swarms {
        r.read_exact(&mut b8)?;
        let n = u64::from_le_bytes(b8) as usize;
        let channels = u32_(r)? as usize;
        let f32s = |r: &mut dyn Read, k: usize| -> std::io::Result<Vec<f32>> {
            let mut bytes = vec![0u8; k * 4];
            r.read_exact(&mut bytes)?;
            Ok(bytes
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
                .collect())
        };
        let mut ids = vec![0u8; n * 8];
        r.read_exact(&mut ids)?;
        let ids = ids
            .chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect();
        let vec3 = |v: Vec<f32>| v.chunks_exact(3).map(Vec3::from_slice).collect();
        let quat = |v: Vec<f32>| v.chunks_exact(4).map(Quat::from_slice).collect();
        let position = vec3(f32s(r, 3 * n)?);
        let velocity = vec3(f32s(r, 3 * n)?);
        let orientation = quat(f32s(r, 4 * n)?);
        let heading = quat(f32s(r, 4 * n)?);
        let angular_velocity_deg = vec3(f32s(r, 3 * n)?);
        let scale = f32s(r, n)?;
        let channels = (0..channels)
            .map(|_| f32s(r, n))
            .collect::<std::io::Result<_>>()?;
        out.push(SwarmFrame {
            ids,
            position,
            velocity,
            orientation,
            heading,
            angular_velocity_deg,
            scale,
            channels,
        });
    }
    Ok(JournalFrame {
        frame,
        time,
        swarms: out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHOT: &str = r#"
[scene]
frames = [1, 12]
[[swarm]]
name = "bees"
count = 40
[[swarm]]
name = "flies"
model = "boids"
count = 25
[[swarm]]
name = "drift"
model = "brownian"
count = 10
[[swarm]]
name = "midges"
model = "field"
count = 15
"#;

    /// A simulation restored from the state of another at frame 5 steps and records
    /// exactly as that one does; the journal gives back the records bit for bit.
    #[test]
    fn restored_state_continues_identically() {
        let shot = crate::shot::parse(SHOT, Path::new("t.toml"), Path::new(".")).unwrap();
        let mut a = Simulation::new(&shot);
        for _ in 0..4 {
            a.advance();
        }
        let state = a.state_bytes();
        let mut b = Simulation::new(&shot);
        b.restore_state(&state).unwrap();
        assert_eq!(b.frame(), 5);
        for _ in 0..7 {
            a.advance();
            b.advance();
            let mut ja = Vec::new();
            let mut jb = Vec::new();
            write_frame(&mut ja, a.frame(), a.time(), a.record());
            write_frame(&mut jb, b.frame(), b.time(), b.record());
            assert_eq!(ja, jb);
            let back = read_frame(&mut ja.as_slice()).unwrap();
            let mut again = Vec::new();
            write_frame(&mut again, back.frame, back.time, &back.swarms);
            assert_eq!(again, ja);
        }
        let mut other = Simulation::new(&shot);
        assert!(other.restore_state(&state[..state.len() - 1]).is_err());
    }
}
