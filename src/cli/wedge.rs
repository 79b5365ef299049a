//! `beeswarm wedge` (a shot baked many ways, as an Open Job Description job) and
//! `beeswarm gather` (the wedge's contact sheet). See docs/farm.md.

use crate::error::Result;
use crate::wedge::{self, Variant, Vary};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
#[command(
    about = "Write a wedge: variant shots and an Open Job Description job that bakes them",
    after_help = "Examples:\n  beeswarm wedge shot.toml --vary seed=1..8 --out wedge         8 variants\n  beeswarm wedge shot.toml --vary seed=1..4 --vary swarm.bees.params.speed=0.8,1.2 --out w\n  beeswarm wedge shot.toml --variant 'seed=3;swarm.bees.preset=nest' --variant seed=9 --out w\n  beeswarm wedge shot.toml --vary seed=1..8 --out wedge --run   bake here, all cores\n  openjd run wedge/job.yaml                                      bake with openjd-cli\n\nKeys are the shot's dotted keys (a bare key is a [scene] key); [[swarm]], [[obstacle]]\nand [[target]] entries are named by their `name`. See docs/farm.md."
)]
pub struct WedgeArgs {
    /// The shot file (TOML) to wedge.
    pub shot: PathBuf,
    /// KEY=VALUES: values of one key (comma-separated TOML values; A..B = every whole
    /// number from A to B). Several --vary make every combination.
    #[arg(long, value_parser = wedge::vary::parse_vary)]
    pub vary: Vec<Vary>,
    /// KEY=VALUE;KEY=VALUE: one explicit variant (instead of --vary).
    #[arg(long, value_parser = wedge::vary::parse_variant)]
    pub variant: Vec<Variant>,
    /// The wedge folder to write.
    #[arg(long)]
    pub out: PathBuf,
    /// The beeswarm program the job's tasks run (default: this one, by its full path).
    #[arg(long)]
    pub beeswarm: Option<String>,
    /// Frames between a bake task's checkpoints: a pre-empted task run again loses at
    /// most this many frames (0: no checkpoints).
    #[arg(long, default_value_t = 24, value_name = "N")]
    pub checkpoint_every: u32,
    /// A recording (tracks CSV, as `beeswarm eval --reference`): the gather step ranks
    /// the variants against it (<out>/<shot>.eval.md); the variants also write CSV.
    #[arg(long, value_name = "REAL")]
    pub reference: Option<PathBuf>,
    /// Also bake every variant here and gather the contact sheet (no farm needed).
    #[arg(long)]
    pub run: bool,
    /// With --run: bakes at once (default 0: one per core; never more than the cores).
    #[arg(long, default_value_t = 0)]
    pub jobs: usize,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
#[command(
    about = "Gather a baked wedge: the contact sheet of every variant's preview, and with a reference the ranking"
)]
pub struct GatherArgs {
    /// The wedge folder (written by beeswarm wedge).
    pub dir: PathBuf,
}

pub fn run(a: WedgeArgs) -> Result<()> {
    let variants = wedge::vary::expand(&a.vary, &a.variant)?;
    let beeswarm = match &a.beeswarm {
        Some(b) => b.clone(),
        None => std::env::current_exe()
            .map(|p| p.display().to_string())
            .unwrap_or_else(|_| "beeswarm".to_owned()),
    };
    let manifest = wedge::write(&wedge::WedgeSpec {
        shot: &a.shot,
        variants: &variants,
        out: &a.out,
        beeswarm: &beeswarm,
        checkpoint_every: a.checkpoint_every,
        reference: a.reference.as_deref(),
    })?;
    if !a.quiet {
        eprintln!(
            "wrote a wedge of {} variants of \"{}\" in {}",
            manifest.variants.len(),
            manifest.name,
            a.out.display()
        );
        for v in &manifest.variants {
            eprintln!("  {}  {}", v.shot().display(), v.label);
        }
        eprintln!(
            "  job.yaml (openjd run {0}/job.yaml); {0} is a Deadline Cloud job bundle too (deadline bundle submit {0})",
            a.out.display()
        );
    }
    if a.run {
        let _ = ctrlc::set_handler(|| {
            crate::atomic::INTERRUPTED.store(true, std::sync::atomic::Ordering::Relaxed)
        });
        let written = wedge::runner::run(&a.out, &manifest, a.jobs, a.checkpoint_every, a.quiet)?;
        if !a.quiet {
            for p in written {
                eprintln!("wrote {}", p.display());
            }
        }
    }
    Ok(())
}

pub fn gather(a: GatherArgs) -> Result<()> {
    for p in wedge::gather(&a.dir)? {
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}
