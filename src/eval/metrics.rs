//! The per-sample flight metrics of paper 000 (Eq. 12–17) and paper 002 (seven
//! time-varying metrics), computed on tracks resampled to a common step `dt`.
//!
//! With v_i the velocity at sample i of one track (one step dt apart):
//! - speed `|v_i|` (paper 000 Eq. 13, paper 002 v);
//! - acceleration `|v_i − v_{i−1}| / dt` (Eq. 12, a);
//! - angular velocity `∠(v_{i−1}, v_i) / dt`, rad/s (Eq. 16, ω), only where both speeds
//!   exceed `min_speed` (a direction is undefined at rest and noise there is not turning);
//! - angular acceleration `(ω_i − ω_{i−1}) / dt`, rad/s², signed (Eq. 17, α);
//! - jerk `|v_{i+1} − 2 v_i + v_{i−1}| / dt²` (paper 002 μ, Cartesian jerk);
//!
//! and, at every instant at which at least two insects are tracked, for each of them:
//! - nearest-neighbour distance d (paper 002), metres;
//! - velocity difference `|u_nei − u| / d` to that neighbour (Eq. 14), 1/s;
//! - local density `Σ_{j≠i} W_poly6(|r_i − r_j|, h)` (Eq. 10 with unit masses and point
//!   bodies, since recorded insects have neither), 1/m³. The self term is left out: it is
//!   the same constant for everybody and would only shift the distribution.
//!
//! The angle is computed as `atan2(|a × b|, a · b)`, equal to the papers' arccos of the
//! normalised dot product but exact near 0 and π where arccos loses precision.

use super::resample::Uniform;
use glam::DVec3;
use std::collections::BTreeMap;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    Speed,
    Acceleration,
    AngularVelocity,
    AngularAcceleration,
    Jerk,
    NeighbourDistance,
    VelocityDifference,
    Density,
}

impl Metric {
    pub const ALL: [Metric; 8] = [
        Metric::Speed,
        Metric::Acceleration,
        Metric::AngularVelocity,
        Metric::AngularAcceleration,
        Metric::Jerk,
        Metric::NeighbourDistance,
        Metric::VelocityDifference,
        Metric::Density,
    ];
    /// Metrics of one insect's own flight: defined for any data set, even of single insects.
    pub const SINGLE: [Metric; 5] = [
        Metric::Speed,
        Metric::Acceleration,
        Metric::AngularVelocity,
        Metric::AngularAcceleration,
        Metric::Jerk,
    ];
    /// Paper 002's seven metrics Φ = {v, a, ω, α, μ, d, η}.
    pub const PAPER_002: [Metric; 7] = [
        Metric::Speed,
        Metric::Acceleration,
        Metric::AngularVelocity,
        Metric::AngularAcceleration,
        Metric::Jerk,
        Metric::NeighbourDistance,
        Metric::VelocityDifference,
    ];

    pub fn index(self) -> usize {
        self as usize
    }
    pub fn key(self) -> &'static str {
        match self {
            Metric::Speed => "speed",
            Metric::Acceleration => "acceleration",
            Metric::AngularVelocity => "angular_velocity",
            Metric::AngularAcceleration => "angular_acceleration",
            Metric::Jerk => "jerk",
            Metric::NeighbourDistance => "neighbour_distance",
            Metric::VelocityDifference => "velocity_difference",
            Metric::Density => "density",
        }
    }
    /// Axis label with unit (the plot font has ², ³, ω, α, ρ).
    pub fn label(self) -> &'static str {
        match self {
            Metric::Speed => "speed |u| (m/s)",
            Metric::Acceleration => "acceleration |a| (m/s²)",
            Metric::AngularVelocity => "angular velocity ω (rad/s)",
            Metric::AngularAcceleration => "angular acceleration α (rad/s²)",
            Metric::Jerk => "jerk μ (m/s³)",
            Metric::NeighbourDistance => "nearest-neighbour distance d (m)",
            Metric::VelocityDifference => "velocity difference |Δu|/d (1/s)",
            Metric::Density => "density ρ (1/m³)",
        }
    }
    pub fn unit(self) -> &'static str {
        match self {
            Metric::Speed => "m/s",
            Metric::Acceleration => "m/s^2",
            Metric::AngularVelocity => "rad/s",
            Metric::AngularAcceleration => "rad/s^2",
            Metric::Jerk => "m/s^3",
            Metric::NeighbourDistance => "m",
            Metric::VelocityDifference => "1/s",
            Metric::Density => "1/m^3",
        }
    }
    pub fn needs_neighbours(self) -> bool {
        matches!(
            self,
            Metric::NeighbourDistance | Metric::VelocityDifference | Metric::Density
        )
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetricOptions {
    /// Common time step, seconds.
    pub dt: f64,
    /// h of the density kernel, metres.
    pub density_radius: f64,
    /// Speeds below this (m/s) have no direction: no angular velocity there.
    pub min_speed: f64,
    /// Compute the neighbour metrics (calibration against single insects skips them).
    pub neighbours: bool,
    /// At most this many insects per instant are taken as focal insects for the
    /// neighbour metrics (all insects still count as neighbours); bounds the cost to
    /// O(cap · n) per instant for large swarms.
    pub neighbour_cap: usize,
}

impl Default for MetricOptions {
    fn default() -> Self {
        MetricOptions {
            dt: 0.02,
            density_radius: 0.15,
            min_speed: 1e-3,
            neighbours: true,
            neighbour_cap: 300,
        }
    }
}

/// Samples of every metric; `values[m.index()]` holds metric `m`. All values are finite.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Samples {
    pub values: [Vec<f64>; 8],
    /// Instants with at least two insects (where neighbour metrics exist).
    pub shared_instants: usize,
}

impl Samples {
    pub fn get(&self, m: Metric) -> &[f64] {
        &self.values[m.index()]
    }
    fn push(&mut self, m: Metric, v: f64) {
        // Division by tiny distances or steps can overflow; such a sample says nothing.
        if v.is_finite() {
            self.values[m.index()].push(v);
        }
    }
}

/// Unsigned angle between two vectors, radians, or `None` if either is shorter than `min`.
pub fn angle_between(a: DVec3, b: DVec3, min: f64) -> Option<f64> {
    if a.length() <= min || b.length() <= min {
        return None;
    }
    Some(a.cross(b).length().atan2(a.dot(b)))
}

/// Poly6 kernel of Müller et al. 2003: 315 / (64 π h⁹) (h² − r²)³ for r < h.
pub fn poly6(r: f64, h: f64) -> f64 {
    if r >= h || h <= 0.0 {
        return 0.0;
    }
    let d = h * h - r * r;
    315.0 / (64.0 * std::f64::consts::PI * h.powi(9)) * d * d * d
}

/// Computes every metric over resampled tracks.
pub fn compute(tracks: &[Uniform], opts: &MetricOptions) -> Samples {
    let mut s = Samples::default();
    let dt = opts.dt;
    for t in tracks {
        let v = &t.velocity;
        for x in v {
            s.push(Metric::Speed, x.length());
        }
        let mut prev_omega: Option<f64> = None;
        for i in 1..v.len() {
            s.push(Metric::Acceleration, (v[i] - v[i - 1]).length() / dt);
            let omega = angle_between(v[i - 1], v[i], opts.min_speed).map(|a| a / dt);
            if let Some(w) = omega {
                s.push(Metric::AngularVelocity, w);
                if let Some(pw) = prev_omega {
                    s.push(Metric::AngularAcceleration, (w - pw) / dt);
                }
            }
            prev_omega = omega;
            if i + 1 < v.len() {
                s.push(
                    Metric::Jerk,
                    (v[i + 1] - 2.0 * v[i] + v[i - 1]).length() / (dt * dt),
                );
            }
        }
    }
    if opts.neighbours {
        neighbour_metrics(tracks, opts, &mut s);
    }
    s
}

fn neighbour_metrics(tracks: &[Uniform], opts: &MetricOptions, s: &mut Samples) {
    // Insects present at each grid instant, in track order (deterministic).
    let mut at: BTreeMap<i64, Vec<(usize, usize)>> = BTreeMap::new();
    for (ti, t) in tracks.iter().enumerate() {
        for i in 0..t.len() {
            at.entry(t.start + i as i64).or_default().push((ti, i));
        }
    }
    let h = opts.density_radius;
    for present in at.values() {
        let n = present.len();
        if n < 2 {
            continue;
        }
        s.shared_instants += 1;
        let pos: Vec<DVec3> = present
            .iter()
            .map(|&(t, i)| tracks[t].position[i])
            .collect();
        let vel: Vec<DVec3> = present
            .iter()
            .map(|&(t, i)| tracks[t].velocity[i])
            .collect();
        // Focal insects: all, or an even stride through them when there are too many.
        let stride = n.div_ceil(opts.neighbour_cap.max(1));
        for a in (0..n).step_by(stride) {
            let mut best = f64::INFINITY;
            let mut nb = a;
            let mut rho = 0.0;
            for b in 0..n {
                if b == a {
                    continue;
                }
                let d = pos[a].distance(pos[b]);
                if d < best {
                    best = d;
                    nb = b;
                }
                rho += poly6(d, h);
            }
            s.push(Metric::NeighbourDistance, best);
            if best > 1e-9 {
                s.push(
                    Metric::VelocityDifference,
                    (vel[nb] - vel[a]).length() / best,
                );
            }
            s.push(Metric::Density, rho);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angle_is_exact_and_guarded() {
        assert_eq!(angle_between(DVec3::X, DVec3::X, 0.0), Some(0.0));
        let a = angle_between(DVec3::X, -DVec3::X, 0.0).unwrap();
        assert!((a - std::f64::consts::PI).abs() < 1e-15);
        assert_eq!(angle_between(DVec3::ZERO, DVec3::X, 1e-3), None);
    }

    #[test]
    fn poly6_integrates_to_one() {
        // ∫ W dV = 1 over the ball of radius h.
        let h = 0.2;
        let n = 2000;
        let dr = h / n as f64;
        let total: f64 = (0..n)
            .map(|i| {
                let r = (i as f64 + 0.5) * dr;
                4.0 * std::f64::consts::PI * r * r * poly6(r, h) * dr
            })
            .sum();
        assert!((total - 1.0).abs() < 1e-4, "{total}");
    }
}
