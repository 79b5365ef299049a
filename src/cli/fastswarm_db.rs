//! `beeswarm fastswarm-db`: builds a FASTSWARM velocity database (paper 003's D) from a
//! recording or from our own tracks CSV (docs/model.md, "Paper 003").

use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use crate::eval::{resample, tracks};
use crate::model::fastswarm::database::{self, BuildOptions};
use clap::Args;
use std::io::Write as _;
use std::path::PathBuf;

#[derive(Args, Debug)]
#[command(
    about = "Build a FASTSWARM velocity database from recorded tracks",
    after_help = "Examples:\n  beeswarm fastswarm-db ../shared/data/mosquito_flights.csv --out mosquito_db.csv\n  beeswarm fastswarm-db out/swarm.tracks.csv --out mine.csv --dt 0.0104167 --samples 3000"
)]
pub struct FastswarmDbArgs {
    /// Tracks: splined flight tracks (the mosquito recording) or a beeswarm tracks CSV.
    pub tracks: PathBuf,
    /// Where to write the database.
    #[arg(long)]
    pub out: PathBuf,
    /// The simulation step to resample to, s (a shot's 1 / (fps × substeps)).
    #[arg(long, default_value_t = 0.02)]
    pub dt: f64,
    /// At most this many samples, taken evenly over the speed ranks (300: the paper's k; an
    /// agent weighs at most 3/5 of them, so the cost per agent grows with this).
    #[arg(long, default_value_t = 300)]
    pub samples: usize,
    /// Samples slower than this (an insect at rest) are left out, m/s.
    #[arg(long, default_value_t = 0.01)]
    pub min_speed: f64,
    /// Build from part I of N of the tracks only: their ids numbered 0, 1, … in order of
    /// first appearance, those equal to I mod N kept (hold the others out for `beeswarm
    /// eval --reference-part`).
    #[arg(long, value_name = "I/N")]
    pub part: Option<tracks::Part>,
    /// A line of provenance for the file's header (source, licence).
    #[arg(long)]
    pub note: Vec<String>,
}

pub fn run(a: FastswarmDbArgs) -> Result<()> {
    if !(a.dt > 0.0 && a.dt <= 1.0) {
        return Err(Error::input(format!(
            "--dt: expected a step from 0 to 1 s, found {}",
            a.dt
        )));
    }
    if !(a.min_speed >= 0.0 && a.min_speed.is_finite()) {
        return Err(Error::input(format!(
            "--min-speed: expected a speed ≥ 0 m/s, found {}",
            a.min_speed
        )));
    }
    let mut ds = tracks::read(&a.tracks)?;
    if let Some(p) = a.part {
        ds = ds.part(p);
    }
    let series = resample::resample(&ds, a.dt);
    let velocities: Vec<&[glam::DVec3]> = series.iter().map(|u| u.velocity.as_slice()).collect();
    let opts = BuildOptions {
        dt: a.dt,
        z_up: ds.format == tracks::TrackFormat::Splined,
        max_samples: a.samples,
        min_speed: a.min_speed,
    };
    let db = database::build(&velocities, &opts)
        .map_err(|e| Error::input(format!("{}: {e}", a.tracks.display())))?;
    let name = a
        .tracks
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut provenance = format!(
        "FASTSWARM velocity database (paper 003's D): vx,vy,vz m/s, ax,ay,az m/s², world Y-up.\n\
         Built by: beeswarm fastswarm-db {name} --dt {} --samples {} --min-speed {}{}\n\
         From {} tracks, {} samples; {} kept, evenly over the speed ranks.",
        a.dt,
        a.samples,
        a.min_speed,
        a.part.map_or(String::new(), |p| format!(" --part {p}")),
        ds.tracks.len(),
        ds.sample_count(),
        db.samples.len()
    );
    for n in &a.note {
        provenance.push('\n');
        provenance.push_str(n);
    }
    let mut f = AtomicFile::create(&a.out)?;
    f.writer()
        .write_all(db.to_text(&provenance).as_bytes())
        .map_err(|e| Error::io(&a.out, e))?;
    let path = f.seal()?.commit()?;
    eprintln!(
        "wrote {} ({} samples in {} speed groups, dt {} s)",
        path.display(),
        db.samples.len(),
        db.groups(),
        db.dt
    );
    Ok(())
}
