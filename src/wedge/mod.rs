//! Wedges: one shot baked many ways (seeds, speeds, presets) and looked at side by side.
//!
//! `beeswarm wedge` writes a wedge folder:
//!
//! ```text
//! DIR/wedge.json                 what the wedge is: the shot, every variant and its values
//! DIR/variants/<name>_<k>.toml   variant k's shot (k = 1, 2, …), checked, standing alone
//! DIR/presets/                   preset files the variants use, copied
//! DIR/job.yaml                   the Open Job Description job (see `job`)
//! DIR/template.yaml              the same, by the name an AWS Deadline Cloud job bundle
//!                                uses: DIR is also a bundle (deadline bundle submit DIR)
//! DIR/caches/<name>_<k>/         variant k's caches and preview, once baked
//! DIR/<name>.contact.png         the contact sheet, once gathered
//! DIR/reference.csv              with --reference: the recording the variants are ranked
//! DIR/<name>.eval.md, .eval.json   against, and the ranking, once gathered
//! ```
//!
//! Every variant is resolved and checked before anything is written, so a bad variant
//! fails the whole wedge with a located error. See docs/farm.md.

pub mod contact_sheet;
pub mod job;
pub mod ranking;
pub mod runner;
pub mod variant_shot;
pub mod vary;

use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
pub use vary::{Variant, Vary};

/// The name of a wedge folder's manifest.
pub const MANIFEST: &str = "wedge.json";
/// The recording copied into a wedge folder (so the folder is all a farm needs).
pub const REFERENCE: &str = "reference.csv";

/// `DIR/wedge.json`: what `gather` and the runner read back.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Manifest {
    /// The wedged shot's scene name.
    pub name: String,
    /// The wedged shot file, as given.
    pub shot: String,
    pub variants: Vec<ManifestVariant>,
    /// The recording the variants are ranked against, relative to the wedge folder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<String>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ManifestVariant {
    /// 1-based; the OpenJD task parameter `Variant`.
    pub index: usize,
    /// `<name>_<index>`: the variant's scene name, shot file stem and cache folder.
    pub name: String,
    pub label: String,
    /// (key, TOML value) pairs, as given on the command line.
    pub values: Vec<(String, String)>,
}

impl ManifestVariant {
    /// The variant's shot, relative to the wedge folder.
    pub fn shot(&self) -> PathBuf {
        Path::new("variants").join(format!("{}.toml", self.name))
    }
    /// The variant's cache folder, relative to the wedge folder.
    pub fn caches(&self) -> PathBuf {
        Path::new("caches").join(&self.name)
    }
    /// The variant's preview image, relative to the wedge folder.
    pub fn preview(&self) -> PathBuf {
        self.caches().join(format!("{}.preview.png", self.name))
    }
}

/// What `beeswarm wedge` was asked for.
pub struct WedgeSpec<'a> {
    pub shot: &'a Path,
    pub variants: &'a [Variant],
    pub out: &'a Path,
    /// The program the job's tasks run.
    pub beeswarm: &'a str,
    /// Frames between a task's checkpoints (0: none).
    pub checkpoint_every: u32,
    /// A recording (tracks CSV) to rank the variants against in the gather step.
    pub reference: Option<&'a Path>,
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<PathBuf> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes).map_err(|e| Error::io(path, e))?;
    f.commit()
}

fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::input(format!("cannot create the folder {}: {e}", dir.display())))
}

/// Checks every variant, then writes the wedge folder; returns its manifest.
pub fn write(spec: &WedgeSpec) -> Result<Manifest> {
    let shot = crate::shot::load(spec.shot)?;
    if let Some(r) = spec.reference {
        // Read now: a bad recording fails the wedge before any bake.
        crate::eval::tracks::read(r)?;
    }
    // Ranking needs every variant's tracks: CSV joins the shot's formats.
    let mut formats = shot.output.formats.clone();
    if spec.reference.is_some() && !formats.contains(&crate::shot::Format::Csv) {
        formats.push(crate::shot::Format::Csv);
    }
    // Read again as text: variants are the shot's own text with keys set.
    let src = String::from_utf8(
        crate::shot::read_bounded(spec.shot).map_err(|e| Error::io(spec.shot, e))?,
    )
    .map_err(|_| Error::input(format!("{}: not UTF-8", spec.shot.display())))?;
    let shot_dir = spec
        .shot
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let mut presets = variant_shot::CopiedPresets::default();
    let mut texts = Vec::with_capacity(spec.variants.len());
    let mut entries = Vec::with_capacity(spec.variants.len());
    for (k, v) in spec.variants.iter().enumerate() {
        let index = k + 1;
        let name = format!("{}_{index}", shot.name);
        let varied = variant_shot::varied_text(&src, spec.shot, index, v)?;
        let text =
            variant_shot::standalone_text(&varied, &shot_dir, &name, &formats, &mut presets)?;
        texts.push(text);
        entries.push(ManifestVariant {
            index,
            name,
            label: v.label(),
            values: v.assignments.clone(),
        });
    }
    create_dir(spec.out)?;
    let dir = spec
        .out
        .canonicalize()
        .map_err(|e| Error::io(spec.out, e))?;
    create_dir(&dir.join("variants"))?;
    // The standalone variants must parse where they will live.
    if !presets.files.is_empty() {
        create_dir(&dir.join("presets"))?;
        for (source, name) in &presets.files {
            let bytes = crate::shot::read_bounded(source).map_err(|err| Error::io(source, err))?;
            write_file(&dir.join("presets").join(name), &bytes)?;
        }
    }
    for (text, e) in texts.iter().zip(&entries) {
        let path = dir.join(e.shot());
        crate::shot::parse(text, &path, &dir.join("variants")).map_err(|err| {
            Error::bake(format!("variant {} does not stand alone: {err}", e.index))
        })?;
    }
    for (text, e) in texts.iter().zip(&entries) {
        write_file(&dir.join(e.shot()), text.as_bytes())?;
    }
    remove_stale_variants(&dir, &entries);
    let reference = match spec.reference {
        Some(r) => {
            let bytes = std::fs::read(r).map_err(|e| Error::io(r, e))?;
            write_file(&dir.join(REFERENCE), &bytes)?;
            Some(REFERENCE.to_owned())
        }
        None => None,
    };
    let manifest = Manifest {
        name: shot.name.clone(),
        shot: spec.shot.display().to_string(),
        variants: entries,
        reference,
    };
    let json = serde_json::to_string_pretty(&manifest).expect("a manifest serialises");
    write_file(&dir.join(MANIFEST), format!("{json}\n").as_bytes())?;
    let spec_for = |wedge_dir| job::JobSpec {
        name: &shot.name,
        variants: manifest.variants.len(),
        wedge_dir,
        beeswarm: spec.beeswarm,
        checkpoint_every: spec.checkpoint_every,
    };
    // The wedge folder is also a Deadline Cloud job bundle, which names its template
    // template.yaml; OpenJD refuses a default path outside the template's folder, so the
    // bundle is the wedge folder itself.
    let template = job::template(&spec_for("."));
    write_file(&dir.join("job.yaml"), template.as_bytes())?;
    write_file(&dir.join("template.yaml"), template.as_bytes())?;
    Ok(manifest)
}

/// A wedge rewritten with fewer (or other) variants: the previous wedge's variants this one
/// no longer has go, with their caches, so the folder holds one wedge. Only what the
/// previous manifest named, and only plain names (a manifest naming `../x` removes
/// nothing).
fn remove_stale_variants(dir: &Path, entries: &[ManifestVariant]) {
    let Ok(old) = read_manifest(dir) else {
        return;
    };
    let plain = |name: &str| {
        !name.is_empty()
            && name != "."
            && name != ".."
            && Path::new(name).file_name() == Some(std::ffi::OsStr::new(name))
    };
    for v in &old.variants {
        if plain(&v.name) && !entries.iter().any(|e| e.name == v.name) {
            let _ = std::fs::remove_file(dir.join(v.shot()));
            let _ = std::fs::remove_dir_all(dir.join(v.caches()));
        }
    }
}

/// Reads a wedge folder's manifest.
pub fn read_manifest(dir: &Path) -> Result<Manifest> {
    let path = dir.join(MANIFEST);
    let bytes = std::fs::read(&path).map_err(|e| {
        Error::input(format!(
            "{}: {e} (expected a wedge folder written by beeswarm wedge)",
            path.display()
        ))
    })?;
    serde_json::from_slice(&bytes)
        .map_err(|e| Error::input(format!("{}: not a wedge manifest: {e}", path.display())))
}

/// The gather step: the contact sheet of every variant's preview, `DIR/<name>.contact.png`,
/// and with a reference recording the ranking, `DIR/<name>.eval.md` (and `.eval.json`).
pub fn gather(dir: &Path) -> Result<Vec<PathBuf>> {
    let manifest = read_manifest(dir)?;
    let cells: Vec<(String, PathBuf)> = manifest
        .variants
        .iter()
        .map(|v| (format!("{}: {}", v.index, v.label), dir.join(v.preview())))
        .collect();
    let title = format!(
        "wedge {} - {} variants",
        manifest.name,
        manifest.variants.len()
    );
    let sheet = contact_sheet::render(&title, &cells)?;
    let mut written = vec![sheet.save_png(&dir.join(format!("{}.contact.png", manifest.name)))?];
    if let Some(reference) = &manifest.reference {
        written.extend(ranking::write(dir, &manifest, &dir.join(reference))?);
    }
    Ok(written)
}
