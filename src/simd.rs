//! Which SIMD instruction sets the wide paths take: the grid's scan, ranking and near
//! rows, the bee's pair and density sums, the curl noise, and fastswarm's energies and
//! choice, each with AVX2 or AVX-512. Every wide path does the IEEE operations of its
//! portable fallback in the same order, so a cache is the same bytes whichever level ran
//! (`tests/determinism.rs` bakes a shot of every model on each level the CPU has): the
//! level changes speed only.
//!
//! `BEESWARM_SIMD` caps the level: `portable` (no wide path), `avx2`, or `native` (the
//! default: whatever the CPU has). A cap never raises the level above the CPU's. It is read
//! once, at the first check; the binary checks its value at start-up ([`check_env`]), so a
//! misspelt value is an error there rather than silently the default.

use std::sync::atomic::{AtomicU8, Ordering};

/// The environment variable that caps the level.
pub const ENV: &str = "BEESWARM_SIMD";

/// An instruction-set level, lowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// The portable code: SSE4.2-era x86-64 (the build's baseline) or any other target.
    Portable = 0,
    /// AVX2: every wide path in eight lanes.
    Avx2 = 1,
    /// AVX-512 F and VL (with AVX2): every wide path, most in sixteen lanes.
    Avx512 = 2,
}

impl Level {
    /// The name `BEESWARM_SIMD` and `beeswarm bench` use.
    pub fn name(self) -> &'static str {
        match self {
            Level::Portable => "portable",
            Level::Avx2 => "avx2",
            Level::Avx512 => "avx512",
        }
    }
}

/// The level the wide paths take: the CPU's, capped by `BEESWARM_SIMD`.
#[inline]
pub fn level() -> Level {
    // A relaxed load and a compare, as `is_x86_feature_detected!` costs: the search and
    // the pair sums ask once per agent and substep. (A `OnceLock` cost 19 instructions
    // per bee-step more under callgrind.) Threads racing to the first check work out the
    // same value.
    match LEVEL.load(Ordering::Relaxed) {
        0 => Level::Portable,
        1 => Level::Avx2,
        2 => Level::Avx512,
        _ => first_check(),
    }
}

/// The level as 0, 1 or 2, or `UNKNOWN` before the first check.
static LEVEL: AtomicU8 = AtomicU8::new(UNKNOWN);
const UNKNOWN: u8 = u8::MAX;

#[cold]
#[inline(never)]
fn first_check() -> Level {
    let cap = std::env::var(ENV)
        .ok()
        .and_then(|v| parse(&v).ok())
        .unwrap_or(Level::Avx512);
    let level = detected().min(cap);
    LEVEL.store(level as u8, Ordering::Relaxed);
    level
}

/// Whether the AVX-512 paths run (the CPU has AVX-512 F, VL and AVX2, and no cap below).
#[inline]
pub fn avx512() -> bool {
    level() >= Level::Avx512
}

/// Whether the AVX2 paths may run (the CPU has AVX2, and no cap below).
#[inline]
pub fn avx2() -> bool {
    level() >= Level::Avx2
}

/// The highest level this CPU has.
pub fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx2") && has!("avx512f") && has!("avx512vl") {
            return Level::Avx512;
        }
        if has!("avx2") {
            return Level::Avx2;
        }
    }
    Level::Portable
}

/// The cap a value of `BEESWARM_SIMD` names.
fn parse(value: &str) -> Result<Level, String> {
    match value.trim() {
        "portable" => Ok(Level::Portable),
        "avx2" => Ok(Level::Avx2),
        "native" | "" => Ok(Level::Avx512),
        other => Err(format!(
            "{ENV} is \"{other}\": expected portable, avx2 or native"
        )),
    }
}

/// The error for a `BEESWARM_SIMD` that names no level, if it is set to one.
pub fn check_env() -> Result<(), String> {
    match std::env::var(ENV) {
        Ok(v) => parse(&v).map(|_| ()),
        Err(std::env::VarError::NotPresent) => Ok(()),
        Err(std::env::VarError::NotUnicode(_)) => Err(format!(
            "{ENV} is not valid UTF-8: expected portable, avx2 or native"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cap_names_each_level_and_rejects_the_rest() {
        assert_eq!(parse("portable"), Ok(Level::Portable));
        assert_eq!(parse("avx2"), Ok(Level::Avx2));
        assert_eq!(parse("native"), Ok(Level::Avx512));
        assert_eq!(parse(" avx2\n"), Ok(Level::Avx2));
        let e = parse("avx512f").unwrap_err();
        assert!(e.contains("BEESWARM_SIMD") && e.contains("avx512f"), "{e}");
    }

    #[test]
    fn the_level_never_exceeds_the_cpu_s() {
        assert!(level() <= detected());
        assert_eq!(avx512(), level() == Level::Avx512);
        assert_eq!(avx2(), level() >= Level::Avx2);
    }
}
