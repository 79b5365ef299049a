//! The command line: `bake`, `check`, `bench`, `models`, `eval`, `calibrate`,
//! `fitness-figure`, `fastswarm-db`, `wedge`, `gather`. `main.rs` only calls
//! [`main`]. Exit codes: 0 success, 1 a failure while working, 2 bad input.

mod bake;
mod bench;
mod check;
mod fastswarm_db;
pub mod models;
mod resources;
mod wedge;

use crate::error::Error;
use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(name = "beeswarm", version, about = "Simulate honeybee swarms and bake them into glTF, USD and CSV caches.", long_about = None,
    after_help = "Examples:\n  beeswarm bake                      bake the built-in demo shot into ./out/\n  beeswarm bake shot.toml --format usda,csv\n  beeswarm check shot.toml\n  beeswarm models\n  beeswarm bench --bees 10000 --frames 48")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    Bake(bake::BakeArgs),
    Check(check::CheckArgs),
    Bench(bench::BenchArgs),
    Models(models::ModelsArgs),
    Eval(crate::eval::EvalArgs),
    Calibrate(crate::eval::CalibrateArgs),
    FitnessFigure(crate::eval::calibrate::FitnessFigureArgs),
    FastswarmDb(fastswarm_db::FastswarmDbArgs),
    Wedge(wedge::WedgeArgs),
    Gather(wedge::GatherArgs),
}

/// Parses arguments, runs the command, prints any error, returns the exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    // A misspelt cap on the wide paths is an error, not silently the default.
    if let Err(e) = crate::simd::check_env() {
        return report(&Error::input(e));
    }
    let result = match cli.command {
        Command::Bake(a) => bake::run(a),
        Command::Check(a) => check::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Models(a) => models::run(a),
        Command::Eval(a) => crate::eval::run_eval(&a),
        Command::Calibrate(a) => crate::eval::run_calibrate(&a),
        Command::FitnessFigure(a) => crate::eval::calibrate::run_fitness_figure(&a),
        Command::FastswarmDb(a) => fastswarm_db::run(a),
        Command::Wedge(a) => wedge::run(a),
        Command::Gather(a) => wedge::gather(a),
    };
    match result {
        Ok(()) => 0,
        Err(e) => report(&e),
    }
}

/// Prints an error for a person and returns its exit code.
pub fn report(e: &Error) -> i32 {
    eprintln!("error: {e}");
    e.exit_code()
}

/// Parses `START:END` (inclusive frames).
pub fn parse_frames(s: &str) -> Result<(i32, i32), String> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("expected START:END, e.g. 1:120, found \"{s}\""))?;
    let a: i32 = a
        .trim()
        .parse()
        .map_err(|_| format!("expected a whole start frame, found \"{a}\""))?;
    let b: i32 = b
        .trim()
        .parse()
        .map_err(|_| format!("expected a whole end frame, found \"{b}\""))?;
    if a > b {
        return Err(format!(
            "the frame range {a}:{b} is reversed; write {b}:{a}"
        ));
    }
    // The same limits as `frames` in a shot (and no i32 overflow in the frame count).
    if a < -1_000_000 || b > 1_000_000 || b as i64 - a as i64 > 100_000 {
        return Err(format!(
            "expected at most 100000 frames within ±1000000, found {a}:{b}"
        ));
    }
    Ok((a, b))
}

/// Parses one format name; clap splits `--format glb,csv` at the commas.
pub fn parse_format(s: &str) -> Result<crate::export::Format, String> {
    crate::export::Format::parse(s).ok_or_else(|| {
        format!(
            "unknown format \"{}\": expected glb, gltf, usda or csv",
            s.trim()
        )
    })
}
