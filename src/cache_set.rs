//! Cache sets: the files of one bake, replaced together and recorded in a manifest.
//!
//! A bake of shot `<name>` writes its files (`<name>.glb`, `<name>.usda` and its
//! `<name>.clips/`, `<name>.tracks.csv`, …) and `<name>.beeswarm.json`, the manifest: every
//! file of the set with its size and SHA-256, the shot's hash, seed, frame range and the
//! tool version. Several files cannot be renamed at once, so the manifest says whether the
//! set is whole:
//!
//! 1. every file is written and synced under a temporary name (`crate::atomic`);
//! 2. the manifest is replaced by one marked `"complete": false` that lists the new files
//!    and, under `replacing`, the previous set's files this bake no longer writes;
//! 3. the files are renamed into place, then the `replacing` files are removed;
//! 4. the manifest is replaced by the complete one (no `replacing`).
//!
//! Each manifest change is itself a rename, so at any moment (even after `kill -9` or a
//! power cut) the manifest either is complete and every file it lists is the one it
//! describes, or says that a replacement is under way. The next bake of the shot into the
//! folder reads it and, when it commits, removes every file of the unfinished set it does
//! not write itself: only files a manifest listed, never anything else. See docs/caches.md.

use crate::atomic::{Hashing, SealedFile, Written, hex};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::io::{Read, Write};
use std::path::{Component, Path, PathBuf};

/// The manifest format's version, written as `beeswarm_cache_set`.
pub const FORMAT_VERSION: u32 = 1;

/// The manifest of a cache set, `<name>.beeswarm.json` beside the files (JSON).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`FORMAT_VERSION`].
    pub beeswarm_cache_set: u32,
    /// False while a bake replaces the set: the files are then not one bake's.
    pub complete: bool,
    pub shot_name: String,
    /// SHA-256 of the resolved shot (see [`shot_sha256`]).
    pub shot_sha256: String,
    pub seed: u64,
    /// First and last frame, inclusive; frames per second.
    pub frame_start: i32,
    pub frame_end: i32,
    pub fps: f64,
    pub tool_version: String,
    /// The files of the set, in the order they are renamed into place.
    pub files: Vec<FileEntry>,
    /// While incomplete: files of the previous set still to be removed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub replacing: Vec<String>,
}

/// One file of a set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileEntry {
    /// Relative to the manifest's folder, `/`-separated (`hive.clips/hive.0001.usda`).
    pub path: String,
    pub bytes: u64,
    /// Lower-case hex, as `sha256sum` prints it.
    pub sha256: String,
}

/// What describes a bake besides its files.
#[derive(Clone, Debug)]
pub struct SetInfo {
    pub shot_name: String,
    pub shot_sha256: String,
    pub seed: u64,
    pub frame_start: i32,
    pub frame_end: i32,
    pub fps: f64,
    pub tool_version: String,
}

impl SetInfo {
    pub fn of(shot: &crate::shot::Shot) -> Self {
        SetInfo {
            shot_name: shot.name.clone(),
            shot_sha256: shot_sha256(shot),
            seed: shot.seed,
            frame_start: shot.frame_start,
            frame_end: shot.frame_end,
            fps: shot.fps,
            tool_version: env!("CARGO_PKG_VERSION").to_owned(),
        }
    }
}

/// SHA-256 of the resolved shot: every default, preset value and command-line override
/// filled in, in the tool's own text form, without the output folder (where the caches
/// go does not change them). Two bakes with the same value simulated the same input.
pub fn shot_sha256(shot: &crate::shot::Shot) -> String {
    let mut s = shot.clone();
    s.output.dir = PathBuf::new();
    hex(&Sha256::digest(format!("{s:?}").as_bytes()))
}

/// `<dir>/<name>.beeswarm.json`.
pub fn manifest_path(dir: &Path, shot_name: &str) -> PathBuf {
    dir.join(format!("{shot_name}.beeswarm.json"))
}

/// What a folder holds of a shot's cache set before a bake.
#[derive(Debug)]
pub enum Previous {
    /// No manifest: no set is known (nothing is removed but what a bake overwrites).
    None,
    /// A manifest, complete or not.
    Set(Manifest),
    /// A manifest that cannot be read or is not one of ours, and why. Its files are
    /// unknown, so nothing is removed but what a bake overwrites; the bake replaces it.
    Unreadable(String),
}

impl Previous {
    /// Every file the folder may hold of that set: its files and, when a replacement
    /// was under way, the files it was replacing.
    pub fn files(&self) -> Vec<String> {
        match self {
            Previous::Set(m) => m
                .files
                .iter()
                .map(|f| f.path.clone())
                .chain(m.replacing.iter().cloned())
                .collect(),
            _ => Vec::new(),
        }
    }

    /// A sentence for the user when the folder's set is not whole, else `None`.
    pub fn problem(&self, dir: &Path, shot_name: &str) -> Option<String> {
        let path = manifest_path(dir, shot_name);
        match self {
            Previous::Set(m) if !m.complete => Some(format!(
                "{} says a bake was stopped while replacing its files: the files of \"{shot_name}\" \
                 there may be of two bakes; a bake replaces them all",
                path.display()
            )),
            Previous::Unreadable(why) => Some(format!(
                "{} is not a beeswarm manifest ({why}): the files it listed are unknown, so only \
                 the files a bake writes are replaced",
                path.display()
            )),
            _ => None,
        }
    }
}

/// Reads the manifest of shot `shot_name` in `dir`.
pub fn read(dir: &Path, shot_name: &str) -> Previous {
    let path = manifest_path(dir, shot_name);
    let text = match std::fs::read(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Previous::None,
        Err(e) => return Previous::Unreadable(e.to_string()),
    };
    // A manifest is a few kB per file; one of 16 MB is not ours.
    if text.len() > 16 << 20 {
        return Previous::Unreadable(format!("{} bytes", text.len()));
    }
    let m: Manifest = match serde_json::from_slice(&text) {
        Ok(m) => m,
        Err(e) => return Previous::Unreadable(e.to_string()),
    };
    if m.beeswarm_cache_set != FORMAT_VERSION {
        return Previous::Unreadable(format!(
            "format version {}, this tool reads {FORMAT_VERSION}",
            m.beeswarm_cache_set
        ));
    }
    if m.shot_name != shot_name {
        return Previous::Unreadable(format!("it is the manifest of \"{}\"", m.shot_name));
    }
    // Only ever remove what is plainly a file of this set: never a path that leaves the
    // folder, a hidden file, or another shot's.
    let listed = m
        .files
        .iter()
        .map(|f| f.path.as_str())
        .chain(m.replacing.iter().map(String::as_str));
    for p in listed {
        if !is_member_path(shot_name, p) {
            return Previous::Unreadable(format!("it lists \"{p}\", not a file of this set"));
        }
    }
    Previous::Set(m)
}

/// Whether `path` can name a file of shot `shot_name`'s set: `<name>.<ext>` in the
/// folder, or `<name>.clips/<file>` (USDA value clips).
fn is_member_path(shot_name: &str, path: &str) -> bool {
    let comps: Vec<Component> = Path::new(path).components().collect();
    let normal =
        |c: &Component| matches!(c, Component::Normal(s) if !s.to_string_lossy().starts_with('.'));
    let prefix = format!("{shot_name}.");
    let manifest = format!("{shot_name}.beeswarm.json");
    match comps.as_slice() {
        [f] => normal(f) && path.starts_with(&prefix) && path != manifest,
        [d, f] => normal(d) && normal(f) && d.as_os_str() == format!("{shot_name}.clips").as_str(),
        _ => false,
    }
}

/// Removes what bakes of this shot killed outright left in `dir` and in its clips folder
/// `<name>.clips/` (see `crate::atomic::remove_stale_temporaries`), whatever formats this
/// bake writes; the clips folder goes too if that empties it (a killed bake may have made
/// it). Returns how many files went.
pub fn remove_stale_temporaries(dir: &Path, shot_name: &str) -> usize {
    let clips = dir.join(format!("{shot_name}.clips"));
    let removed = crate::atomic::remove_stale_temporaries(dir)
        + crate::atomic::remove_stale_temporaries(&clips);
    let _ = std::fs::remove_dir(&clips); // only when empty
    removed
}

/// The right to write shot `<name>`'s set into a folder, held for a whole bake: a second
/// bake of the same shot into the same folder would interleave its renames with the
/// first's (a set mixing two bakes) and remove the other's checkpoint. The lock is an
/// advisory file lock (`flock`) on `.<name>.beeswarm.lock`, which the system releases
/// when the process ends however it ends, so a killed bake never blocks the next one. The
/// file holds the owner's process id, for the error message, and is removed when the
/// lock is dropped.
#[derive(Debug)]
pub struct BakeLock {
    path: PathBuf,
    _file: std::fs::File,
}

/// The lock file of shot `shot_name` in `dir`.
pub fn lock_path(dir: &Path, shot_name: &str) -> PathBuf {
    dir.join(format!(".{shot_name}.beeswarm.lock"))
}

/// Takes [`BakeLock`] for `shot_name` in `dir`, or fails at once (exit code 1) naming the
/// process that holds it; never waits.
pub fn lock(dir: &Path, shot_name: &str) -> Result<BakeLock> {
    use std::io::{Seek, Write};
    let path = lock_path(dir, shot_name);
    // A holder removes the file before it unlocks; a file we opened just before that
    // removal is no longer the one at `path` once we hold its lock, so open again.
    for _ in 0..8 {
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let mut owner = String::new();
                let _ = file.read_to_string(&mut owner);
                let owner = match owner.trim().parse::<u32>() {
                    Ok(pid) => format!("process {pid}"),
                    Err(_) => "another process".to_string(),
                };
                return Err(Error::bake(format!(
                    "another bake ({owner}) is writing shot '{shot_name}' into {}; wait for it \
                     to finish or bake into another folder (--out)",
                    dir.display()
                )));
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(Error::io(&path, e)),
        }
        if !same_file(&file, &path) {
            continue;
        }
        let written = file
            .set_len(0)
            .and_then(|_| file.rewind())
            .and_then(|_| writeln!(file, "{}", std::process::id()));
        written.map_err(|e| Error::io(&path, e))?;
        return Ok(BakeLock { path, _file: file });
    }
    Err(Error::bake(format!(
        "could not lock {}: it kept being replaced",
        path.display()
    )))
}

/// Whether the open `file` is the one now at `path`.
fn same_file(file: &std::fs::File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (file.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = file;
        path.exists()
    }
}

impl Drop for BakeLock {
    fn drop(&mut self) {
        // Removed while still locked (the file closes after this), see `lock`.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Size and SHA-256 of a file, read in 1 MiB blocks through the same [`Hashing`] writer
/// the bake's files are hashed by as they are written; stops on an interrupt.
pub fn hash_file(path: &Path) -> Result<Written> {
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut h = Hashing::new(std::io::sink());
    let mut buf = vec![0u8; 1 << 20];
    loop {
        if crate::atomic::interrupted() {
            return Err(Error::bake(crate::atomic::INTERRUPTED_MESSAGE));
        }
        let n = f.read(&mut buf).map_err(|e| Error::io(path, e))?;
        if n == 0 {
            break;
        }
        h.write_all(&buf[..n]).map_err(|e| Error::io(path, e))?;
    }
    Ok(h.finish().1)
}

/// `path` relative to `dir`, `/`-separated.
fn relative(dir: &Path, path: &Path) -> Result<String> {
    let rel = path.strip_prefix(dir).map_err(|_| {
        Error::bake(format!(
            "{} is not in the output folder {}",
            path.display(),
            dir.display()
        ))
    })?;
    let parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    Ok(parts.join("/"))
}

/// Writes `m` as the manifest of its shot in `dir` (atomically: temporary file, rename).
fn write_manifest(dir: &Path, m: &Manifest) -> Result<()> {
    let path = manifest_path(dir, &m.shot_name);
    let mut text = serde_json::to_string_pretty(m)
        .map_err(|e| Error::bake(format!("cannot write {}: {e}", path.display())))?;
    text.push('\n');
    let mut f = crate::atomic::AtomicFile::create(&path)?;
    std::io::Write::write_all(&mut f, text.as_bytes()).map_err(|e| Error::io(&path, e))?;
    f.commit()?;
    sync_dir(dir);
    Ok(())
}

/// Makes renames in `dir` durable (a power cut keeps their order). Best effort: some
/// filesystems cannot sync a folder, and a kill does not need it.
fn sync_dir(dir: &Path) {
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Replaces the cache set of `info.shot_name` in `dir` with the sealed `files` (every file
/// of the new set, in rename order) as described in the module doc; returns their final
/// paths. Files their writers did not hash as they wrote them are hashed first (an
/// interrupt there still drops them all and leaves the previous set whole); once the
/// manifest says the set is being replaced, the renames and removals run to the end
/// whatever signal comes.
pub fn commit(dir: &Path, info: &SetInfo, files: Vec<SealedFile>) -> Result<Vec<PathBuf>> {
    use rayon::prelude::*;
    crate::atomic::check_destinations(&files)?;
    // Files are hashed in parallel: a set of USDA clips is many files of similar size.
    let entries = files
        .par_iter()
        .map(|f| -> Result<FileEntry> {
            // Hashed as it was written, or read back now.
            let Written { bytes, sha256 } = match f.written() {
                Some(w) => w.clone(),
                None => hash_file(f.temp_path())?,
            };
            Ok(FileEntry {
                path: relative(dir, f.dest())?,
                bytes,
                sha256,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    pause_point("hashed");
    if crate::atomic::interrupted() {
        return Err(Error::bake(crate::atomic::INTERRUPTED_MESSAGE));
    }
    let previous = read(dir, &info.shot_name);
    let mut replacing: Vec<String> = Vec::new();
    for p in previous.files() {
        if !entries.iter().any(|e| e.path == p) && !replacing.contains(&p) {
            replacing.push(p);
        }
    }
    let mut manifest = Manifest {
        beeswarm_cache_set: FORMAT_VERSION,
        complete: false,
        shot_name: info.shot_name.clone(),
        shot_sha256: info.shot_sha256.clone(),
        seed: info.seed,
        frame_start: info.frame_start,
        frame_end: info.frame_end,
        fps: info.fps,
        tool_version: info.tool_version.clone(),
        files: entries,
        replacing,
    };
    write_manifest(dir, &manifest)?;
    pause_point("replacing");
    let mut written = Vec::with_capacity(files.len());
    for (i, f) in files.into_iter().enumerate() {
        written.push(f.commit()?);
        pause_point(&format!("renamed {}", i + 1));
    }
    for p in std::mem::take(&mut manifest.replacing) {
        let path = dir.join(&p);
        let _ = std::fs::remove_file(&path);
        if p.contains('/')
            && let Some(parent) = path.parent()
        {
            let _ = std::fs::remove_dir(parent); // only when empty
        }
    }
    sync_dir(dir);
    pause_point("removed");
    manifest.complete = true;
    write_manifest(dir, &manifest)?;
    Ok(written)
}

/// Why a folder's cache set is not whole.
pub fn verify(dir: &Path, shot_name: &str) -> std::result::Result<Manifest, String> {
    let m = match read(dir, shot_name) {
        Previous::Set(m) => m,
        Previous::None => return Err("no manifest".to_owned()),
        Previous::Unreadable(why) => return Err(why),
    };
    if !m.complete {
        return Err("the manifest says a replacement is under way".to_owned());
    }
    for f in &m.files {
        let w = hash_file(&dir.join(&f.path)).map_err(|e| e.to_string())?;
        if w.bytes != f.bytes || w.sha256 != f.sha256 {
            return Err(format!("{} is not the file the manifest lists", f.path));
        }
    }
    Ok(m)
}

/// For tests of what a kill leaves (tests/cache_set_kills.rs): when the environment
/// variable `BEESWARM_PAUSE_AT` names this point, the process says so on stderr and
/// waits, to be killed there. Points: `frame <n>` (after frame n of the range, counted
/// from 1, went to the writers), `journaled <f>` (shot frame f is in the checkpoint
/// journal, `--checkpoint-every`), `sealed <k>` (after the k-th format's files were
/// sealed), `hashed`, `replacing` (the manifest says so, nothing renamed yet),
/// `renamed <i>` (after the i-th rename), `removed` (before the complete manifest).
/// An interrupt (Ctrl-C) ends the wait and the bake goes on to stop as usual.
pub fn pause_point(point: &str) {
    if pausing() && PAUSE_AT.get().and_then(Option::as_deref) == Some(point) {
        eprintln!("beeswarm: paused at {point} (BEESWARM_PAUSE_AT)");
        while !crate::atomic::interrupted() {
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
    }
}

static PAUSE_AT: std::sync::OnceLock<Option<String>> = std::sync::OnceLock::new();

/// Whether `BEESWARM_PAUSE_AT` is set (so that per-frame points need not format a name).
pub fn pausing() -> bool {
    PAUSE_AT
        .get_or_init(|| std::env::var("BEESWARM_PAUSE_AT").ok())
        .is_some()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn member_paths_stay_in_the_set() {
        for ok in ["hive.glb", "hive.tracks.csv", "hive.clips/hive.0001.usda"] {
            assert!(is_member_path("hive", ok), "{ok}");
        }
        for bad in [
            "../hive.glb",
            "/etc/passwd",
            "other.glb",
            "hive",
            ".hive.glb",
            "hive.beeswarm.json",
            "hive.clips/../x",
            "hive.clips/.beeswarm-1-2.tmp",
            "other.clips/hive.0001.usda",
            "hive.clips/a/b",
        ] {
            assert!(!is_member_path("hive", bad), "{bad}");
        }
    }

    /// What hashing adds to a bake, per GB of caches (docs/caches.md):
    /// `cargo test --release --lib hash_throughput -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn hash_throughput() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a");
        let block: Vec<u8> = (0..1 << 20).map(|i| (i * 7 % 251) as u8).collect();
        let mut f = std::fs::File::create(&p).unwrap();
        for _ in 0..512 {
            std::io::Write::write_all(&mut f, &block).unwrap();
        }
        drop(f);
        for _ in 0..3 {
            let t = std::time::Instant::now();
            let bytes = hash_file(&p).unwrap().bytes;
            let s = t.elapsed().as_secs_f64();
            println!(
                "{} MB in {s:.2} s: {:.0} MB/s",
                bytes / 1_000_000,
                bytes as f64 / s / 1e6
            );
        }
    }

    #[test]
    fn sha256_is_the_standard_one() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("abc");
        std::fs::write(&p, "abc").unwrap();
        assert_eq!(
            hash_file(&p).unwrap(),
            Written {
                bytes: 3,
                sha256: "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
                    .to_owned()
            }
        );
    }
}
