//! Atomic output: write beside the destination, rename over it only on success.
//!
//! A bake that fails or is interrupted leaves the previous cache untouched and no partial
//! file behind: the temporary file is removed on drop unless `commit` ran.

/// Set by the SIGINT/SIGTERM handler; a bake stops within the simulation pass it is in,
/// or while the writers seal their files, and removes its temporary files, leaving any
/// previous cache untouched. Here, below the writers, so that a writer's long sealing
/// step (copying gigabytes into one USDA layer) can stop on it too.
pub static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The error of a bake stopped by [`INTERRUPTED`].
pub const INTERRUPTED_MESSAGE: &str =
    "interrupted: no cache was written; the previous cache is untouched";

/// Whether [`INTERRUPTED`] is set.
pub fn interrupted() -> bool {
    INTERRUPTED.load(std::sync::atomic::Ordering::Relaxed)
}

use crate::error::{Error, Result};
use sha2::{Digest, Sha256};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, mpsc};

/// A file's size in bytes and its SHA-256 (lower-case hex, as `sha256sum` prints it), as
/// the cache set's manifest records them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Written {
    pub bytes: u64,
    pub sha256: String,
}

/// A writer that hashes every byte it passes on, in order: a file written front to back
/// through it (no seeking) knows its [`Written`] when it is complete, so the bake need
/// not read it back after its last frame (the serial tail of issue 14: 0.25 s for a
/// 400 MB CSV).
pub struct Hashing<W> {
    inner: W,
    sha: Sha256,
    bytes: u64,
}

impl<W: Write> Hashing<W> {
    pub fn new(inner: W) -> Self {
        Hashing {
            inner,
            sha: Sha256::new(),
            bytes: 0,
        }
    }

    /// The writer and what went through it.
    pub fn finish(self) -> (W, Written) {
        let sha256 = hex(&self.sha.finalize());
        let written = Written {
            bytes: self.bytes,
            sha256,
        };
        (self.inner, written)
    }
}

impl<W: Write> Write for Hashing<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.sha.update(&buf[..n]);
        self.bytes += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Lower-case hex of `b`.
pub fn hex(b: &[u8]) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(2 * b.len());
    for x in b {
        let _ = write!(s, "{x:02x}");
    }
    s
}

/// Bytes an [`Output`] gathers before passing them on.
const CHUNK: usize = 1 << 20;
/// The most chunks an [`Output`] has at once (its own, and those its threads have yet to
/// hash and write): bounds its memory, and holds the caller back while they are behind.
const CHUNKS: usize = 4;
/// Bytes written between two requests that the kernel start writing them to the disk.
const WRITEBACK: u64 = 8 << 20;

/// An [`AtomicFile`]'s writer: buffered, hashing what it writes. Once it outgrows a chunk,
/// one thread hashes the full chunks and another writes them, in order, while the caller
/// makes the next: the SHA-256 and the write calls of a large cache then overlap the work
/// that produces its bytes and each other (most of a bake's tail after its last frame,
/// issue 14). The writing thread also asks the kernel to start putting each few MiB on
/// the disk at once, so that the `fsync` sealing the file has little left to wait for. A
/// file of one chunk is written on the caller's thread at the end, with no thread started.
pub struct Output {
    buf: Vec<u8>,
    sink: Sink,
}

type Hashed = (Sha256, u64);

enum Sink {
    /// No chunk passed on yet.
    Here(Hashing<File>),
    There {
        /// To the writing thread, then to the hashing one.
        full: [mpsc::Sender<Arc<Vec<u8>>>; 2],
        /// Chunks both threads are done with, to fill again.
        empty: mpsc::Receiver<Vec<u8>>,
        /// Chunks not yet allocated.
        unmade: usize,
        writing: std::thread::JoinHandle<std::io::Result<File>>,
        hashing: std::thread::JoinHandle<Hashed>,
    },
    /// Finished, or failed (the error was returned).
    Gone,
}

/// Gives `chunk` back to the caller if the other thread is done with it too (exactly one
/// of the two gets it: `Arc::into_inner`).
fn recycle(chunk: Arc<Vec<u8>>, done: &mpsc::Sender<Vec<u8>>) {
    if let Some(mut chunk) = Arc::into_inner(chunk) {
        chunk.clear();
        let _ = done.send(chunk);
    }
}

impl Output {
    fn new(file: File) -> Self {
        Output {
            buf: Vec::with_capacity(CHUNK),
            sink: Sink::Here(Hashing::new(file)),
        }
    }

    /// Starts the threads, which take over the file and the hash so far.
    fn start(hashing: Hashing<File>) -> std::io::Result<Sink> {
        let Hashing {
            inner: mut file,
            mut sha,
            mut bytes,
        } = hashing;
        let (to_writing, chunks) = mpsc::channel::<Arc<Vec<u8>>>();
        let (to_hashing, hashed) = mpsc::channel::<Arc<Vec<u8>>>();
        let (done, empty) = mpsc::channel();
        let done2 = done.clone();
        let start = bytes;
        let writing = std::thread::Builder::new()
            .name("beeswarm-write".into())
            .spawn(move || {
                let (mut at, mut asked) = (start, start);
                for chunk in chunks {
                    file.write_all(&chunk)?;
                    at += chunk.len() as u64;
                    recycle(chunk, &done);
                    if at - asked >= WRITEBACK {
                        start_writeback(&file, asked, at - asked);
                        asked = at;
                    }
                }
                Ok(file)
            })?;
        let hashing = std::thread::Builder::new()
            .name("beeswarm-hash".into())
            .spawn(move || {
                for chunk in hashed {
                    sha.update(&chunk[..]);
                    bytes += chunk.len() as u64;
                    recycle(chunk, &done2);
                }
                (sha, bytes)
            })?;
        Ok(Sink::There {
            full: [to_writing, to_hashing],
            empty,
            unmade: CHUNKS - 1,
            writing,
            hashing,
        })
    }

    /// Passes the chunk to the threads (started at the first) and, unless it is the
    /// `last` before a flush or the end, takes an empty one; the writing thread's error,
    /// if it failed.
    fn pass_on(&mut self, last: bool) -> std::io::Result<()> {
        if let Sink::Here(_) = self.sink {
            let Sink::Here(hashing) = std::mem::replace(&mut self.sink, Sink::Gone) else {
                unreachable!()
            };
            self.sink = Output::start(hashing)?;
        }
        let Sink::There {
            full,
            empty,
            unmade,
            ..
        } = &mut self.sink
        else {
            return Err(gone());
        };
        let chunk = Arc::new(std::mem::take(&mut self.buf));
        // A send or a receive fails only once the writing thread has stopped on an error
        // (the hashing one cannot fail).
        let sent = full[0].send(chunk.clone()).is_ok() && full[1].send(chunk).is_ok();
        let next = if !sent {
            None
        } else if last {
            Some(Vec::new())
        } else if let Ok(chunk) = empty.try_recv() {
            Some(chunk)
        } else if *unmade > 0 {
            *unmade -= 1;
            Some(Vec::with_capacity(CHUNK))
        } else {
            empty.recv().ok()
        };
        match next {
            Some(chunk) => {
                self.buf = chunk;
                Ok(())
            }
            None => Err(self.join().err().unwrap_or_else(gone)),
        }
    }

    /// Stops the threads once they have written and hashed every chunk passed on.
    fn join(&mut self) -> std::io::Result<Hashing<File>> {
        match std::mem::replace(&mut self.sink, Sink::Gone) {
            Sink::Here(hashing) => Ok(hashing),
            Sink::There {
                full,
                empty,
                writing,
                hashing,
                ..
            } => {
                drop(full);
                drop(empty);
                let failed = || std::io::Error::other("the file's writer failed");
                let file = writing.join().unwrap_or_else(|_| Err(failed()));
                let (sha, bytes) = hashing.join().map_err(|_| failed())?;
                Ok(Hashing {
                    inner: file?,
                    sha,
                    bytes,
                })
            }
            Sink::Gone => Err(gone()),
        }
    }

    /// Writes what is left; the file and what was written to it.
    fn finish(mut self) -> std::io::Result<(File, Written)> {
        if !self.buf.is_empty() {
            self.pass_on_last()?;
        }
        Ok(self.join()?.finish())
    }

    /// The last, partial chunk: to the threads if they run, else written here.
    fn pass_on_last(&mut self) -> std::io::Result<()> {
        match &mut self.sink {
            Sink::Here(hashing) => {
                let r = hashing.write_all(&self.buf);
                self.buf.clear();
                r
            }
            _ => self.pass_on(true),
        }
    }
}

/// Asks the kernel to start writing `len` bytes of `file` from `offset` to the disk, and
/// returns at once (Linux; elsewhere the `fsync` at the end does it all).
fn start_writeback(file: &File, offset: u64, len: u64) {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        // SAFETY: a plain system call on an open descriptor; its failure (a filesystem
        // that does not support it) only leaves the work to `fsync`.
        unsafe {
            libc::sync_file_range(
                file.as_raw_fd(),
                offset as libc::off64_t,
                len as libc::off64_t,
                libc::SYNC_FILE_RANGE_WRITE,
            );
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (file, offset, len);
}

fn gone() -> std::io::Error {
    std::io::Error::other("write after the file was finished")
}

impl Write for Output {
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        if self.buf.len() == CHUNK {
            self.pass_on(false)?;
        }
        let n = data.len().min(CHUNK - self.buf.len());
        self.buf.extend_from_slice(&data[..n]);
        Ok(n)
    }

    /// Writes everything so far to the file (waiting for the sink, if one runs).
    fn flush(&mut self) -> std::io::Result<()> {
        if !self.buf.is_empty() {
            self.pass_on_last()?;
        }
        if let Sink::There { .. } = self.sink {
            // Everything passed on is written once the sink has stopped; it starts again
            // at the next full chunk.
            let hashing = self.join()?;
            self.sink = Sink::Here(hashing);
        }
        Ok(())
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        // Not left running behind a file being removed.
        let _ = self.join();
    }
}

pub struct AtomicFile {
    tmp: PathBuf,
    dest: PathBuf,
    writer: Option<Output>,
}

impl AtomicFile {
    /// Opens a temporary file in `dest`'s folder (same filesystem, so the rename is atomic).
    pub fn create(dest: &Path) -> Result<Self> {
        let dir = dest
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let name = dest
            .file_name()
            .ok_or_else(|| Error::bake(format!("not a file path: {}", dest.display())))?
            .to_string_lossy()
            .into_owned();
        // The name is checked (a file path), but not embedded: temporary names are ours
        // alone, whatever the user named the shot.
        let _ = name;
        let tmp = temp_path(dir);
        let file = File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        Ok(AtomicFile {
            tmp,
            dest: dest.to_path_buf(),
            writer: Some(Output::new(file)),
        })
    }

    pub fn dest(&self) -> &Path {
        &self.dest
    }

    pub fn writer(&mut self) -> &mut Output {
        self.writer.as_mut().expect("writer present until commit")
    }

    /// Flushes and syncs the file under its temporary name: the first phase of a commit.
    /// On failure the temporary file is removed (Drop no longer sees a writer).
    pub fn seal(mut self) -> Result<SealedFile> {
        let w = self.writer.take().expect("writer present until sealed");
        let result = w
            .finish()
            .map_err(|e| Error::io(&self.tmp, e))
            .and_then(|(file, written)| {
                file.sync_all().map_err(|e| Error::io(&self.tmp, e))?;
                Ok(written)
            });
        let tmp = std::mem::take(&mut self.tmp);
        let written = match result {
            Ok(written) => written,
            Err(e) => {
                let _ = std::fs::remove_file(&tmp);
                return Err(e);
            }
        };
        Ok(SealedFile {
            tmp,
            dest: std::mem::take(&mut self.dest),
            committed: false,
            obsolete: Vec::new(),
            written: Some(written),
        })
    }

    /// Seals and renames onto the destination at once.
    pub fn commit(self) -> Result<PathBuf> {
        self.seal()?.commit()
    }
}

/// A complete file on disk under its temporary name, waiting to be renamed into place.
/// A bake seals every file of every format first and renames them only when all sealed,
/// so a failure leaves every previous cache untouched. Dropped uncommitted, it is removed.
#[must_use = "a sealed file is removed unless committed"]
pub struct SealedFile {
    tmp: PathBuf,
    dest: PathBuf,
    committed: bool,
    /// Files made obsolete by this one, removed once it is in place.
    obsolete: Vec<PathBuf>,
    /// Its size and hash, when worked out as it was written.
    written: Option<Written>,
}

impl SealedFile {
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Where the complete file is until it is committed.
    pub fn temp_path(&self) -> &Path {
        &self.tmp
    }

    /// Its size and hash, if they were worked out as it was written (else read the file).
    pub fn written(&self) -> Option<&Written> {
        self.written.as_ref()
    }

    /// Files to delete once this one is in place (e.g. value clips a new cache no longer
    /// uses); their folders go too when that leaves them empty.
    pub fn remove_after_commit(mut self, paths: Vec<PathBuf>) -> Self {
        self.obsolete = paths;
        self
    }

    /// Renames the file into place. On failure the temporary file is removed.
    pub fn commit(mut self) -> Result<PathBuf> {
        self.committed = true;
        if let Err(e) = std::fs::rename(&self.tmp, &self.dest) {
            let _ = std::fs::remove_file(&self.tmp);
            return Err(Error::io(&self.dest, e));
        }
        for p in &self.obsolete {
            let _ = std::fs::remove_file(p);
            if let Some(dir) = p.parent() {
                let _ = std::fs::remove_dir(dir); // only succeeds when empty
            }
        }
        Ok(std::mem::take(&mut self.dest))
    }
}

/// Renames sealed files into place in order; returns their final paths. A destination
/// that cannot be replaced (a folder stands there) is found before anything is renamed.
pub fn commit_all(files: Vec<SealedFile>) -> Result<Vec<PathBuf>> {
    check_destinations(&files)?;
    files.into_iter().map(SealedFile::commit).collect()
}

/// Refuses sealed files whose destination cannot be replaced (a folder stands there),
/// so that a set is refused before any of its files is renamed.
pub fn check_destinations(files: &[SealedFile]) -> Result<()> {
    match files.iter().find(|f| f.dest.is_dir()) {
        Some(f) => Err(Error::bake(format!(
            "cannot write {}: a folder stands there",
            f.dest.display()
        ))),
        None => Ok(()),
    }
}

impl Drop for SealedFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.writer().write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.writer().flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// A scratch file that is always deleted on drop (for writers that spill data to disk to
/// bound memory and assemble the final file at the end).
pub struct ScratchFile {
    pub path: PathBuf,
}

impl ScratchFile {
    /// A scratch file's path in `dir` (nothing is created). `tag` says what it is for, in
    /// messages only: the name on disk never embeds a user's names.
    pub fn new(dir: &Path, tag: &str) -> Self {
        let _ = tag;
        ScratchFile {
            path: temp_path(dir),
        }
    }
}

/// Every temporary file of ours is `.beeswarm-<pid>-<n>.tmp`: recognisable, short
/// whatever the shot and swarm names, and telling which process owns it.
fn temp_path(dir: &Path) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    dir.join(format!(".beeswarm-{}-{n}.tmp", std::process::id()))
}

/// Checks up front that `dest` can be written (its folder exists and takes a new file),
/// so that a long computation does not end on an unwritable output: an input error
/// (exit 2) naming `option`. Probes with a temporary file it removes at once.
pub fn check_writable(dest: &Path, option: &str) -> Result<()> {
    let dir = dest
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if dest.is_dir() {
        return Err(Error::input(format!(
            "{option} {}: a folder stands there, not a file",
            dest.display()
        )));
    }
    if !dir.is_dir() {
        return Err(Error::input(format!(
            "{option} {}: the folder {} does not exist",
            dest.display(),
            dir.display()
        )));
    }
    probe_writable(dir).map_err(|e| {
        Error::input(format!(
            "{option} {}: cannot write in {}: {e}",
            dest.display(),
            dir.display()
        ))
    })
}

/// Whether a new file can be made in the folder `dir`: creates one of our temporary
/// files there and removes it at once.
pub fn probe_writable(dir: &Path) -> std::io::Result<()> {
    let probe = temp_path(dir);
    File::create(&probe)?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// The owning process id of one of our temporary files, from its name.
fn temp_owner(name: &str) -> Option<u32> {
    let rest = name.strip_prefix(".beeswarm-")?.strip_suffix(".tmp")?;
    let (pid, n) = rest.split_once('-')?;
    n.parse::<u64>().ok()?;
    pid.parse().ok()
}

/// Whether process `pid` is running. Where that cannot be known (no /proc), every
/// process counts as running, so nothing of a live bake is ever removed.
fn alive(pid: u32) -> bool {
    let proc = Path::new("/proc");
    !proc.is_dir() || proc.join(pid.to_string()).exists()
}

/// Removes the temporary files that bakes killed before they could clean up (`kill -9`,
/// out of memory, a power cut) left in `dir`: ours by name, owned by a process that is no
/// longer running. Another live bake's files are never touched. Returns how many went.
pub fn remove_stale_temporaries(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = name.to_str().and_then(temp_owner) else {
            continue;
        };
        if pid != std::process::id() && !alive(pid) && std::fs::remove_file(e.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

impl ScratchFile {
    /// Turns a complete scratch file into a sealed file for `dest` (same folder), synced to
    /// disk; it is no longer deleted on drop, but by the sealed file unless committed.
    /// The cache set hashes it when it commits (see `export::usda`'s clips for why).
    pub fn seal_as(mut self, dest: PathBuf) -> Result<SealedFile> {
        let tmp = std::mem::take(&mut self.path);
        let synced = std::fs::File::open(&tmp).and_then(|f| f.sync_all());
        if let Err(e) = synced {
            let _ = std::fs::remove_file(&tmp);
            return Err(Error::io(&tmp, e));
        }
        Ok(SealedFile {
            tmp,
            dest,
            committed: false,
            obsolete: Vec::new(),
            written: None,
        })
    }
}

impl Drop for ScratchFile {
    fn drop(&mut self) {
        if !self.path.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sealed_file_knows_the_size_and_sha256_of_what_is_on_disk() {
        let dir = tempfile::tempdir().unwrap();
        let mut f = AtomicFile::create(&dir.path().join("abc.txt")).unwrap();
        for piece in [&b"a"[..], b"", b"bc"] {
            f.write_all(piece).unwrap();
        }
        let sealed = f.seal().unwrap();
        // FIPS 180-2's example.
        let abc = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad";
        assert_eq!(sealed.written().unwrap().sha256, abc);
        assert_eq!(sealed.written().unwrap().bytes, 3);
        // Larger than the buffer, in odd pieces: what was hashed is what was stored.
        let mut f = AtomicFile::create(&dir.path().join("big.bin")).unwrap();
        let data: Vec<u8> = (0..3_000_017u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        for piece in data.chunks(65_521) {
            f.write_all(piece).unwrap();
        }
        let sealed = f.seal().unwrap();
        let on_disk = std::fs::read(sealed.temp_path()).unwrap();
        assert_eq!(on_disk, data);
        let want = hex(&Sha256::digest(&on_disk));
        assert_eq!(sealed.written().unwrap().sha256, want);
        assert_eq!(sealed.written().unwrap().bytes, data.len() as u64);
    }

    /// Bytes that tell their place: a shifted or repeated chunk shows.
    fn numbered(n: usize) -> Vec<u8> {
        (0..n as u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect()
    }

    #[test]
    fn many_chunks_and_a_flush_between_are_written_and_hashed_in_order() {
        // More chunks than are ever in flight, so every chunk is filled again after its
        // threads are done with it; a flush stops them and the next chunk restarts them.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("many.bin");
        let data = numbered(CHUNKS * CHUNK * 3 + 12_345);
        let mut f = AtomicFile::create(&path).unwrap();
        let (before, after) = data.split_at(CHUNK * 5 + 7);
        for piece in before.chunks(100_003) {
            f.write_all(piece).unwrap();
        }
        f.flush().unwrap();
        for piece in after.chunks(1 << 21) {
            f.write_all(piece).unwrap();
        }
        let sealed = f.seal().unwrap();
        assert!(std::fs::read(sealed.temp_path()).unwrap() == data);
        let want = hex(&Sha256::digest(&data));
        assert_eq!(sealed.written().unwrap().sha256, want);
        assert_eq!(sealed.written().unwrap().bytes, data.len() as u64);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_failing_disk_is_an_error_not_a_hang() {
        // /dev/full refuses every write (ENOSPC), as a full disk would: the writing
        // thread stops, and the caller hears of it on a later write or at the end.
        let Ok(full) = File::options().write(true).open("/dev/full") else {
            eprintln!("skipped: no /dev/full on this machine");
            return;
        };
        let mut out = Output::new(full);
        let data = numbered(CHUNK);
        let failed = (0..4 * CHUNKS).any(|_| out.write_all(&data).is_err());
        assert!(
            failed || out.finish().is_err(),
            "the writes to /dev/full went unreported"
        );
    }

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path();
        // Above Linux's largest pid (4,194,304): no such process runs.
        let dead = ".beeswarm-4194305-7.tmp";
        let mine = format!(".beeswarm-{}-0.tmp", std::process::id());
        let user = ".hive.usda.4194305.tmp"; // not ours by name
        for f in [dead, mine.as_str(), user, "hive.usda"] {
            std::fs::write(p.join(f), "x").unwrap();
        }
        let removed = remove_stale_temporaries(p);
        let mut left: Vec<String> = std::fs::read_dir(p)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        if Path::new("/proc").is_dir() {
            assert_eq!(removed, 1);
            assert!(!left.contains(&dead.to_owned()), "{left:?}");
        }
        assert!(left.contains(&mine) && left.contains(&user.to_owned()));
        assert!(left.contains(&"hive.usda".to_owned()));
        assert_eq!(temp_owner(".beeswarm-12-3.tmp"), Some(12));
        assert_eq!(temp_owner(".beeswarm-x-3.tmp"), None);
    }

    #[test]
    fn dropped_file_leaves_previous_content_and_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("a.txt");
        std::fs::write(&dest, "old").unwrap();
        {
            let mut f = AtomicFile::create(&dest).unwrap();
            f.write_all(b"new partial").unwrap();
        } // dropped without commit: an interrupted bake
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn failed_commit_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        // A folder where the file should go: the rename fails.
        let dest = dir.path().join("a.txt");
        std::fs::create_dir(&dest).unwrap();
        let mut f = AtomicFile::create(&dest).unwrap();
        f.write_all(b"new").unwrap();
        assert!(f.commit().is_err());
        assert!(dest.is_dir());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_sealed_file_dropped_before_commit_leaves_the_previous_content() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("a.txt");
        std::fs::write(&dest, "old").unwrap();
        let mut f = AtomicFile::create(&dest).unwrap();
        f.write_all(b"new").unwrap();
        let sealed = f.seal().unwrap();
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            2,
            "sealed under its temporary name"
        );
        drop(sealed);
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn commit_replaces_destination() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("a.txt");
        std::fs::write(&dest, "old").unwrap();
        let mut f = AtomicFile::create(&dest).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
