//! `beeswarm wedge --run`: the plain local runner for people without a farm. It runs the
//! job's tasks itself — each variant baked by a `beeswarm bake` child process, exactly the
//! command a farm task runs — several at once but never more than there are cores, then
//! gathers the contact sheet.

use super::{Manifest, ManifestVariant};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// How many bakes run at once and with how many threads each: `jobs` (0 = one per core)
/// bakes, never more than the variants nor the cores; the cores shared among them.
pub fn plan(jobs: usize, variants: usize) -> (usize, usize) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let parallel = if jobs == 0 { cores } else { jobs.min(cores) }
        .min(variants)
        .max(1);
    (parallel, (cores / parallel).max(1))
}

/// The command that bakes one variant (the job template's `Bake` task).
pub fn bake_command(
    exe: &Path,
    dir: &Path,
    v: &ManifestVariant,
    threads: usize,
    checkpoint_every: u32,
) -> Command {
    let mut c = Command::new(exe);
    c.arg("bake")
        .arg(dir.join(v.shot()))
        .arg("--threads")
        .arg(threads.to_string())
        .arg("--quiet");
    if checkpoint_every > 0 {
        c.arg("--checkpoint-every")
            .arg(checkpoint_every.to_string())
            .arg("--resume");
    }
    c
}

/// Bakes every variant of the wedge in `dir`, `parallel` at a time, reporting each as it
/// ends; then gathers (the contact sheet, and the ranking with a reference). A failed variant fails the run (after the others
/// finish), naming it.
pub fn run(
    dir: &Path,
    manifest: &Manifest,
    jobs: usize,
    checkpoint_every: u32,
    quiet: bool,
) -> Result<Vec<PathBuf>> {
    let exe = std::env::current_exe()
        .map_err(|e| Error::bake(format!("cannot find the beeswarm program: {e}")))?;
    let (parallel, threads) = plan(jobs, manifest.variants.len());
    if !quiet {
        eprintln!(
            "baking {} variants, {parallel} at a time ({threads} threads each)",
            manifest.variants.len()
        );
    }
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::<String>::new());
    std::thread::scope(|s| {
        for _ in 0..parallel {
            s.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(v) = manifest.variants.get(k) else {
                        break;
                    };
                    if crate::atomic::interrupted() {
                        break;
                    }
                    let status = bake_command(&exe, dir, v, threads, checkpoint_every).status();
                    let failed = match status {
                        Ok(s) if s.success() => None,
                        Ok(s) => Some(format!("variant {} ({}) failed: {s}", v.index, v.label)),
                        Err(e) => Some(format!(
                            "variant {} ({}): cannot run: {e}",
                            v.index, v.label
                        )),
                    };
                    if !quiet {
                        match &failed {
                            None => eprintln!("  baked variant {} ({})", v.index, v.label),
                            Some(f) => eprintln!("  {f}"),
                        }
                    }
                    if let Some(f) = failed {
                        failures.lock().expect("no panics hold it").push(f);
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().expect("no panics hold it");
    if crate::atomic::interrupted() {
        return Err(Error::bake("interrupted: the wedge was not finished"));
    }
    if !failures.is_empty() {
        return Err(Error::bake(failures.join("\n")));
    }
    super::gather(dir)
}

#[cfg(test)]
mod tests {
    #[test]
    fn never_more_bakes_than_cores_or_variants() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let (p, t) = super::plan(0, 100);
        assert_eq!(p, cores);
        assert_eq!(t, 1);
        assert_eq!(super::plan(0, 1), (1, cores));
        assert_eq!(super::plan(1000, 1000).0, cores);
    }
}
