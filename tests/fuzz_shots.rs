//! The shot loader never panics, and a shot it accepts simulates without a NaN.
//!
//! - `tests/corpus/*.toml`: malformed shots found so far (add one with every bug): each is
//!   refused with a message naming a place in the text, and `beeswarm check` exits 2.
//! - A bounded fuzz run: thousands of mutants of the example shots (values swapped for
//!   extremes, wrong types, lines dropped or duplicated, bytes flipped), drawn from a fixed
//!   seed so a failure repeats; every accepted mutant is stepped a few frames.

// A shot error carries its file, place and source line (see src/lib.rs).
#![allow(clippy::result_large_err)]

use beeswarm::math::Rng;
use beeswarm::sim::Simulation;
use std::path::{Path, PathBuf};

fn files(dir: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    v
}

#[test]
fn every_corpus_shot_is_refused_with_a_located_error_and_exit_2() {
    let corpus = files("tests/corpus");
    assert!(corpus.len() >= 20, "the corpus is there: {}", corpus.len());
    for path in corpus {
        let err = match beeswarm::shot::load(&path) {
            Ok(_) => panic!("{} was accepted", path.display()),
            Err(e) => e,
        };
        let text = err.to_string();
        assert!(text.contains(&path.display().to_string()), "{text}");
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_beeswarm"))
            .arg("check")
            .arg(&path)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{}", path.display());
        assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
    }
}

/// Values a mutation puts in place of a value.
const EXTREMES: [&str; 16] = [
    "0",
    "-1",
    "1e308",
    "-1e308",
    "1e-308",
    "nan",
    "inf",
    "-inf",
    "9223372036854775807",
    "\"\"",
    "\"x\"",
    "true",
    "[]",
    "[1, 2]",
    "{}",
    "[[1]]",
];

fn mutate(src: &str, rng: &mut Rng) -> String {
    let mut lines: Vec<String> = src.lines().map(str::to_owned).collect();
    for _ in 0..1 + (rng.f32() * 3.0) as usize {
        if lines.is_empty() {
            break;
        }
        let k = ((rng.f32() * lines.len() as f32) as usize).min(lines.len() - 1);
        match (rng.f32() * 5.0) as u32 {
            // A value swapped for an extreme or a wrong type.
            0 | 1 => {
                if let Some((key, _)) = lines[k].split_once('=') {
                    let v = EXTREMES[((rng.f32() * 16.0) as usize).min(15)];
                    lines[k] = format!("{key}= {v}");
                }
            }
            2 => {
                lines.remove(k);
            }
            3 => {
                let l = lines[k].clone();
                lines.insert(k, l);
            }
            _ => {
                // A byte flipped somewhere in the line.
                let mut bytes = lines[k].clone().into_bytes();
                if !bytes.is_empty() {
                    let i = ((rng.f32() * bytes.len() as f32) as usize).min(bytes.len() - 1);
                    const SET: &[u8] = b"=[]{}\",.#x0-9\n";
                    bytes[i] = SET[((rng.f32() * SET.len() as f32) as usize).min(SET.len() - 1)];
                }
                lines[k] = String::from_utf8_lossy(&bytes).into_owned();
            }
        }
    }
    lines.join("\n")
}

#[test]
fn thousands_of_mutated_shots_never_panic_and_accepted_ones_stay_finite() {
    let seeds: Vec<String> = files("examples")
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    let mut rng = Rng::new(16, 0xF022, 0);
    let (mut accepted, mut refused) = (0, 0);
    let cases = 3000;
    for case in 0..cases {
        let src = mutate(&seeds[case % seeds.len()], &mut rng);
        let result = std::panic::catch_unwind(|| {
            beeswarm::shot::parse(&src, Path::new("fuzz.toml"), Path::new("examples"))
        });
        let Ok(parsed) = result else {
            panic!("case {case}: the loader panicked on\n{src}");
        };
        match parsed {
            Err(e) => {
                refused += 1;
                assert!(!e.to_string().is_empty());
            }
            Ok(mut shot) => {
                accepted += 1;
                // A few frames of a few agents: enough to meet every parameter.
                shot.frame_end = shot.frame_start + 2;
                for s in &mut shot.swarms {
                    s.count = s.count.min(20);
                }
                let mut sim = Simulation::new(&shot);
                while !sim.done() {
                    sim.advance();
                }
                for s in sim.record() {
                    assert!(
                        s.position.iter().chain(&s.velocity).all(|v| v.is_finite()),
                        "case {case}: a non-finite state from\n{src}"
                    );
                }
            }
        }
    }
    println!("{cases} mutants: {accepted} accepted and simulated, {refused} refused");
    assert!(
        accepted > 100 && refused > 1000,
        "{accepted} accepted, {refused} refused"
    );
}
