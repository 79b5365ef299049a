//! The reference database D of paper 003 (Sec. 3–4): recorded (velocity, acceleration)
//! samples, sorted by speed and split into speed groups for the per-step search.
//!
//! Conventions: world Y-up right-handed, metres, seconds; velocities in m/s, accelerations
//! in m/s² (forward differences of the recorded velocity over the database's step `dt`).
//!
//! **File format** (text, written by `beeswarm fastswarm-db`): lines starting with `#` are
//! provenance comments; then `dt = S`; then one sample per line, `vx,vy,vz,ax,ay,az`,
//! sorted by speed. Values are rounded to 1 mm/s and 1 mm/s², so a database is a few
//! tens of kilobytes and the same recording always gives the same bytes.

use glam::{DVec3, Vec3};
use std::fmt::Write as _;

/// Samples per speed group. An agent searches its own group and the two beside it, so it
/// weighs at most 3 × 100 = 300 candidates: the paper's k = 300 (Sec. 5.2.1).
pub const GROUP_SIZE: usize = 100;

/// One recorded sample d_v = [v, a] (paper 003 Sec. 4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Velocity, m/s, Y-up.
    pub v: Vec3,
    /// Acceleration over the next step, m/s², Y-up.
    pub a: Vec3,
}

/// A sample with what every step would otherwise recompute for it: its unit vectors, |a|,
/// and the horizontal direction of the velocity it was recorded coming from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prepared {
    pub v: Vec3,
    pub a: Vec3,
    /// v̂ (zero when v is).
    pub v_unit: Vec3,
    /// â (zero when a is).
    pub a_unit: Vec3,
    pub a_len: f32,
    /// Unit horizontal (x, z) direction of v − aΔt, the velocity one recorded step
    /// earlier; (0, 0) when it has none.
    pub back: (f32, f32),
}

impl Prepared {
    /// `d` prepared for a database of step `dt`.
    pub fn new(d: Sample, dt: f32) -> Self {
        let unit = |u: Vec3| crate::math::normalize_or(u, Vec3::ZERO);
        let b = d.v - d.a * dt;
        let h = (b.x * b.x + b.z * b.z).sqrt();
        Prepared {
            v: d.v,
            a: d.a,
            v_unit: unit(d.v),
            a_unit: unit(d.a),
            a_len: d.a.length(),
            back: if h > 1e-6 {
                (b.x / h, b.z / h)
            } else {
                (0.0, 0.0)
            },
        }
    }
}

/// The database: samples sorted by speed, in groups of [`GROUP_SIZE`].
#[derive(Clone, Debug, PartialEq)]
pub struct Database {
    /// Step the accelerations were differenced over, s.
    pub dt: f64,
    pub samples: Vec<Sample>,
    /// `samples`, prepared for the search.
    prepared: Vec<Prepared>,
    /// Upper speed of each group (the speed of its fastest sample), m/s.
    group_top: Vec<f32>,
    /// Mean |a| over the samples, m/s²: the scale of Eq. 10's magnitude term.
    pub mean_accel: f32,
}

/// The database shipped with beeswarm, built from the mosquito recording (its header says
/// how; docs/model.md, "Paper 003").
pub const DEFAULT_TEXT: &str = include_str!("mosquito_db.csv");

/// Options of [`build`].
#[derive(Clone, Copy, Debug)]
pub struct BuildOptions {
    /// The step the velocity series are sampled at (the simulation step), s.
    pub dt: f64,
    /// The series are Z-up (the splined recordings), not Y-up (our tracks CSV).
    pub z_up: bool,
    /// At most this many samples, chosen evenly over the speed ranks.
    pub max_samples: usize,
    /// Samples slower than this are an insect at rest (no heading) and are left out, m/s.
    pub min_speed: f64,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            dt: 0.02,
            z_up: true,
            max_samples: 1200,
            min_speed: 0.01,
        }
    }
}

/// A recording's axes mapped to the world's Y-up: the splined recordings are Z-up (their Z
/// spans the cage's 1.2 m height, and the floor is at z ≈ 0), so (x, y, z) → (x, z, −y),
/// a rotation that keeps them right-handed. Our own tracks CSV is already Y-up.
fn to_y_up(z_up: bool, v: DVec3) -> DVec3 {
    if z_up { DVec3::new(v.x, v.z, -v.y) } else { v }
}

/// Rounds to 1 mm (/s, /s²): what the file stores.
fn round3(x: f64) -> f64 {
    let r = (x * 1000.0).round() / 1000.0;
    if r == 0.0 { 0.0 } else { r } // no "-0"
}

/// Builds a database from recorded velocity series, each uninterrupted and sampled every
/// `opts.dt` (`beeswarm fastswarm-db` resamples the tracks, never across a gap):
/// a = (v_{k+1} − v_k) / dt by forward differences (the paper's), axes to Y-up, at-rest
/// samples dropped, then `max_samples` taken evenly over the speed ranks so the speed
/// distribution is kept. Deterministic.
pub fn build(series: &[&[DVec3]], opts: &BuildOptions) -> Result<Database, String> {
    if !(opts.dt > 0.0 && opts.dt.is_finite()) {
        return Err(format!("expected a positive step, found {}", opts.dt));
    }
    let mut all: Vec<(f64, [f64; 6])> = Vec::new();
    for u in series {
        for k in 0..u.len().saturating_sub(1) {
            let v = to_y_up(opts.z_up, u[k]);
            let a = to_y_up(opts.z_up, (u[k + 1] - u[k]) / opts.dt);
            let s = v.length();
            if s < opts.min_speed || !v.is_finite() || !a.is_finite() {
                continue;
            }
            let row = [v.x, v.y, v.z, a.x, a.y, a.z].map(round3);
            all.push((s, row));
        }
    }
    if all.len() < 3 * GROUP_SIZE {
        return Err(format!(
            "{} flying samples at a {} s step; a database needs at least {}",
            all.len(),
            opts.dt,
            3 * GROUP_SIZE
        ));
    }
    // Sort by speed, ties by the values themselves, so the order never depends on the
    // sort's stability or the file's track order.
    all.sort_by(|x, y| {
        x.0.total_cmp(&y.0)
            .then_with(|| x.1.partial_cmp(&y.1).unwrap_or(std::cmp::Ordering::Equal))
    });
    let n = all.len().min(opts.max_samples.max(3 * GROUP_SIZE));
    let samples = (0..n)
        .map(|i| {
            let r = all[i * all.len() / n].1;
            Sample {
                v: DVec3::new(r[0], r[1], r[2]).as_vec3(),
                a: DVec3::new(r[3], r[4], r[5]).as_vec3(),
            }
        })
        .collect();
    Ok(Database::new(opts.dt, samples))
}

impl Database {
    /// A database from samples (sorted here by speed) and their step.
    pub fn new(dt: f64, mut samples: Vec<Sample>) -> Self {
        samples.sort_by(|x, y| x.v.length().total_cmp(&y.v.length()));
        let group_top = samples
            .chunks(GROUP_SIZE)
            .map(|c| c.last().map_or(0.0, |s| s.v.length()))
            .collect();
        let mean_accel = (samples.iter().map(|s| s.a.length() as f64).sum::<f64>()
            / samples.len().max(1) as f64)
            .max(1e-6) as f32;
        let prepared = samples
            .iter()
            .map(|&d| Prepared::new(d, dt as f32))
            .collect();
        Database {
            dt,
            samples,
            prepared,
            group_top,
            mean_accel,
        }
    }

    /// The database shipped with beeswarm (parsed once, shared).
    pub fn default_mosquito() -> &'static std::sync::Arc<Database> {
        static DB: std::sync::OnceLock<std::sync::Arc<Database>> = std::sync::OnceLock::new();
        DB.get_or_init(|| {
            std::sync::Arc::new(Database::parse(DEFAULT_TEXT).expect("the shipped database parses"))
        })
    }

    /// The candidates for an agent flying at `speed`: its speed group and the groups
    /// beside it (paper 003 Sec. 5.2.1, "reduced search space").
    pub fn candidates(&self, speed: f32) -> &[Prepared] {
        let g = self
            .group_top
            .partition_point(|&top| top < speed)
            .min(self.group_top.len() - 1);
        let lo = g.saturating_sub(1) * GROUP_SIZE;
        let hi = ((g + 2) * GROUP_SIZE).min(self.samples.len());
        &self.prepared[lo..hi]
    }

    /// Number of speed groups.
    pub fn groups(&self) -> usize {
        self.group_top.len()
    }

    /// The file text: `provenance` lines as comments, then the step and the samples.
    pub fn to_text(&self, provenance: &str) -> String {
        let mut s = String::new();
        for line in provenance.lines() {
            let _ = writeln!(s, "# {line}");
        }
        let _ = writeln!(s, "dt = {}", self.dt);
        for d in &self.samples {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{}",
                d.v.x, d.v.y, d.v.z, d.a.x, d.a.y, d.a.z
            );
        }
        s
    }

    /// Parses the file text; errors name the line and what was expected.
    pub fn parse(text: &str) -> Result<Database, String> {
        Database::parse_located(text).map_err(|(line, m)| {
            if line > 0 {
                format!("line {line}: {m}")
            } else {
                m
            }
        })
    }

    /// [`Database::parse`] with the error's 1-based line apart (0: the whole file).
    pub fn parse_located(text: &str) -> Result<Database, (usize, String)> {
        let mut dt = None;
        let mut samples = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            if let Some(rest) = line.strip_prefix("dt") {
                let v = rest.trim_start().strip_prefix('=').map(str::trim);
                let v: f64 = v
                    .and_then(|v| v.parse().ok())
                    .ok_or_else(|| (n + 1, format!("expected `dt = <seconds>`, found `{line}`")))?;
                if !(v > 0.0 && v < 10.0) {
                    return Err((n + 1, format!("expected a step from 0 to 10 s, found {v}")));
                }
                dt = Some(v);
                continue;
            }
            let f: Vec<f32> = line
                .split(',')
                .map(|x| x.trim().parse::<f32>())
                .collect::<Result<_, _>>()
                .map_err(|_| {
                    (
                        n + 1,
                        format!("expected six numbers vx,vy,vz,ax,ay,az, found `{line}`"),
                    )
                })?;
            if f.len() != 6 || f.iter().any(|x| !x.is_finite() || x.abs() > 1000.0) {
                return Err((
                    n + 1,
                    format!(
                        "expected six finite numbers within ±1000 (vx,vy,vz,ax,ay,az), found `{line}`"
                    ),
                ));
            }
            samples.push(Sample {
                v: Vec3::new(f[0], f[1], f[2]),
                a: Vec3::new(f[3], f[4], f[5]),
            });
        }
        let dt = dt.ok_or((0, "no `dt = <seconds>` line".to_owned()))?;
        if samples.len() < 3 * GROUP_SIZE {
            return Err((
                0,
                format!(
                    "{} samples; a database needs at least {} (three speed groups of {GROUP_SIZE})",
                    samples.len(),
                    3 * GROUP_SIZE
                ),
            ));
        }
        Ok(Database::new(dt, samples))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_database_parses_and_its_groups_hold_the_papers_k() {
        let db = Database::default_mosquito();
        assert!((db.dt - 0.02).abs() < 1e-12);
        assert!(db.samples.len() >= 1000, "{}", db.samples.len());
        assert!(DEFAULT_TEXT.len() < 100_000, "kilobytes, not more");
        // Sorted by speed; every search covers at most 300 samples and contains its speed.
        for w in db.samples.windows(2) {
            assert!(w[0].v.length() <= w[1].v.length());
        }
        for speed in [0.0, 0.1, 0.2, 0.5, 5.0] {
            let c = db.candidates(speed);
            assert!(c.len() <= 3 * GROUP_SIZE && c.len() >= 2 * GROUP_SIZE);
            let (lo, hi) = (c[0].v.length(), c[c.len() - 1].v.length());
            assert!(
                (lo <= speed || lo == db.samples[0].v.length())
                    && (hi >= speed || c.len() < 3 * GROUP_SIZE),
                "speed {speed}: [{lo}, {hi}]"
            );
        }
    }

    #[test]
    fn text_round_trips_and_bad_lines_are_named() {
        let db = Database::default_mosquito();
        let again = Database::parse(&db.to_text("x")).unwrap();
        assert_eq!(&again, &**db);
        let e = Database::parse("dt = 0.02\n1,2,3\n").unwrap_err();
        assert!(e.contains("line 2"), "{e}");
        assert!(Database::parse("1,2,3,4,5,6\n").is_err());
    }
}
