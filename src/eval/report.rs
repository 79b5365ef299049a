//! Comparing simulated tracks with a reference recording: per-metric distributions on
//! shared bins, their L1 distances, paper 000's fitness q and paper 002's entropy-weighted
//! score, gathered in a report that serialises to JSON without NaN (missing values are
//! `null` with a reason).
//!
//! Scores, for a candidate c and a metric m with reference masses P and candidate masses Q
//! on the shared bins (see `histogram`):
//! - `l1` = ΔE_m = Σ_i |P_i − Q_i| (Eq. 20), in [0, 2];
//! - `q` = 1 − ΔE_m / 2. This is paper 000's q = 1 − ΔE/(2k) with ΔE taken over the
//!   densities on Eq. 18's unit range (each density is k × its mass, so their L1 distance
//!   is at most 2k); in masses the k cancels. q = 1 for identical distributions, 0 for
//!   disjoint ones;
//! - `fitness` = the mean of q over the single-insect metrics (speed, acceleration,
//!   angular velocity, angular acceleration, jerk). Neighbour metrics are left out because
//!   recordings of a few insects (the mosquito cage: one to four in view, half the
//!   segments withheld) sample neighbours too sparsely and too incompletely to calibrate
//!   against; they are still reported;
//! - `q_all` = the mean of q over every metric applicable to both data sets;
//! - `entropy_score` = paper 002 Eq. 6, E = 1 − Σ w_φ E_φ over the paper's seven metrics
//!   applicable to all data sets, with E_φ the candidates' ΔE min–max normalised across the
//!   candidates (Eq. 8) and w_φ the entropy weights (Eq. 9) computed from those candidates.
//!   With a single candidate Eq. 8 and 9 are undefined (nothing to normalise against, ln 1
//!   = 0): weights are then equal and E_φ = ΔE_φ / 2, so the score equals q_all over those
//!   metrics. Because it is relative to the candidates compared, it ranks models in one
//!   report and is not comparable across reports; `entropy_weighted_q` = Σ w_φ q_φ is the
//!   same weighting applied to the absolute q.

use super::histogram::{Bins, Summary, l1};
use super::metrics::{Metric, MetricOptions, Samples, compute};
use super::resample::resample;
use super::tracks::Dataset;
use serde::Serialize;

/// A metric needs at least this many samples in a data set to be compared.
pub const MIN_SAMPLES: usize = 30;

/// Settings shared by every data set of one comparison.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Settings {
    /// Common time step, seconds.
    pub dt: f64,
    /// Bins per metric.
    pub bins: usize,
    /// h of the density kernel, metres.
    pub density_radius: f64,
    /// Speed below which no angular velocity is computed, m/s.
    pub min_speed: f64,
    /// Fraction of the reference cut from each tail to fix the bin range.
    pub tail: f64,
}

impl Settings {
    pub fn metric_options(&self, neighbours: bool) -> MetricOptions {
        MetricOptions {
            dt: self.dt,
            density_radius: self.density_radius,
            min_speed: self.min_speed,
            neighbours,
            ..MetricOptions::default()
        }
    }
}

/// What was read and measured of one data set.
#[derive(Clone, Debug, Serialize)]
pub struct DatasetInfo {
    pub name: String,
    pub format: super::tracks::TrackFormat,
    /// Uninterrupted tracks after splitting at gaps.
    pub tracks: usize,
    pub samples: usize,
    /// Median native time step, seconds.
    pub native_step: f64,
    /// Total tracked time over all tracks, seconds.
    pub tracked_seconds: f64,
    /// Instants at which two or more insects were tracked.
    pub shared_instants: usize,
}

/// A data set reduced to its metric samples.
#[derive(Clone, Debug)]
pub struct Measured {
    pub info: DatasetInfo,
    pub samples: Samples,
}

impl Measured {
    /// Several runs (seeds) of one model as one sample: their metric samples concatenated,
    /// their counts summed. Neighbour metrics stay within each run.
    pub fn pool(name: &str, parts: Vec<Measured>) -> Measured {
        let mut it = parts.into_iter();
        let mut out = it.next().expect("a candidate has at least one run");
        out.info.name = name.to_owned();
        for p in it {
            out.info.tracks += p.info.tracks;
            out.info.samples += p.info.samples;
            out.info.tracked_seconds += p.info.tracked_seconds;
            out.info.shared_instants += p.info.shared_instants;
            out.samples.shared_instants += p.samples.shared_instants;
            for (a, b) in out.samples.values.iter_mut().zip(p.samples.values) {
                a.extend(b);
            }
        }
        out
    }
}

/// Resamples a data set to `settings.dt` and computes every metric.
pub fn measure(ds: &Dataset, settings: &Settings, neighbours: bool) -> Measured {
    let uni = resample(ds, settings.dt);
    let samples = compute(&uni, &settings.metric_options(neighbours));
    Measured {
        info: DatasetInfo {
            name: ds.name.clone(),
            format: ds.format,
            tracks: ds.tracks.len(),
            samples: ds.sample_count(),
            native_step: ds.median_step(),
            tracked_seconds: ds.tracks.iter().map(|t| t.duration()).sum(),
            shared_instants: samples.shared_instants,
        },
        samples,
    }
}

/// The reference reduced to bins and masses per metric, reusable against many candidates
/// (the calibration scores thousands of simulations against one recording).
#[derive(Clone, Debug)]
pub struct Reference {
    pub measured: Measured,
    /// Per metric (by `Metric::index`): bins and masses, or why the metric is not applicable.
    pub per_metric: Vec<Result<(Bins, Vec<f64>), String>>,
}

impl Reference {
    pub fn new(measured: Measured, bins: usize) -> Reference {
        let per_metric = Metric::ALL
            .iter()
            .map(|&m| {
                let v = measured.samples.get(m);
                applicable(m, v.len(), "the reference")?;
                let b = Bins::from_reference(v, bins).ok_or("no reference samples")?;
                let masses = b.masses(v);
                Ok((b, masses))
            })
            .collect();
        Reference {
            measured,
            per_metric,
        }
    }

    /// An input error when the reference supports none of the single-insect metrics (every
    /// track too short, or resting): nothing could be compared with it, so a report or a
    /// calibration against it would be empty.
    pub fn check_usable(&self, name: &str) -> crate::error::Result<()> {
        let single: Vec<&Result<(Bins, Vec<f64>), String>> = Metric::SINGLE
            .iter()
            .map(|m| &self.per_metric[m.index()])
            .collect();
        if single.iter().any(|r| r.is_ok()) {
            return Ok(());
        }
        let why = single
            .first()
            .and_then(|r| r.as_ref().err())
            .cloned()
            .unwrap_or_default();
        Err(crate::error::Error::input(format!(
            "{name}: no usable track in the reference ({why}); it needs insects tracked \
             over at least {MIN_SAMPLES} samples"
        )))
    }

    /// ΔE (Eq. 20) of a candidate per metric, or why it cannot be computed.
    pub fn distance(&self, m: Metric, candidate: &Samples) -> Result<f64, String> {
        let (b, p) = self.per_metric[m.index()].as_ref().map_err(Clone::clone)?;
        let v = candidate.get(m);
        applicable(m, v.len(), "this data set")?;
        Ok(l1(p, &b.masses(v)))
    }

    /// The calibration fitness: mean q over the single-insect metrics the reference has.
    pub fn fitness(&self, candidate: &Samples) -> f64 {
        let qs: Vec<f64> = Metric::SINGLE
            .iter()
            .filter(|m| self.per_metric[m.index()].is_ok())
            .map(|&m| self.distance(m, candidate).map_or(0.0, |d| 1.0 - d / 2.0))
            .collect();
        if qs.is_empty() {
            0.0
        } else {
            qs.iter().sum::<f64>() / qs.len() as f64
        }
    }
}

fn applicable(m: Metric, n: usize, who: &str) -> Result<(), String> {
    if n >= MIN_SAMPLES {
        return Ok(());
    }
    Err(if m.needs_neighbours() && n == 0 {
        format!("not applicable: {who} never has two insects in view at once")
    } else {
        format!("not applicable: {who} has {n} samples (fewer than {MIN_SAMPLES})")
    })
}

#[derive(Clone, Debug, Serialize)]
pub struct CandidateMetric {
    pub name: String,
    pub summary: Summary,
    /// Probability mass per shared bin.
    pub masses: Vec<f64>,
    /// ΔE, Eq. 20; `null` when not applicable.
    pub l1: Option<f64>,
    /// 1 − ΔE/2; `null` when not applicable.
    pub q: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

#[derive(Clone, Debug, Serialize)]
pub struct MetricReport {
    pub metric: Metric,
    pub unit: &'static str,
    /// Whether the reference has this metric (else `note` says why).
    pub applicable: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    pub bins: Option<Bins>,
    pub reference: Summary,
    pub reference_masses: Vec<f64>,
    pub candidates: Vec<CandidateMetric>,
}

#[derive(Clone, Debug, Serialize)]
pub struct CandidateScore {
    pub name: String,
    /// Mean q over the single-insect metrics (the calibration's fitness).
    pub fitness: f64,
    /// Mean q over every metric applicable to the reference and this candidate.
    pub q_all: f64,
    /// Paper 002 Eq. 6 relative to the candidates in this report.
    pub entropy_score: f64,
    /// Σ w_φ q_φ with the entropy weights.
    pub entropy_weighted_q: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub settings: Settings,
    pub reference: DatasetInfo,
    pub candidates: Vec<DatasetInfo>,
    pub metrics: Vec<MetricReport>,
    /// Paper 002 entropy weights (Eq. 9) per metric key.
    pub entropy_weights: Vec<(Metric, f64)>,
    pub scores: Vec<CandidateScore>,
}

/// Builds the full comparison.
pub fn compare(settings: Settings, reference: &Reference, candidates: &[Measured]) -> Report {
    let mut metrics = Vec::new();
    for &m in &Metric::ALL {
        let rv = reference.measured.samples.get(m);
        let (bins, rmass, note) = match &reference.per_metric[m.index()] {
            Ok((b, p)) => (Some(*b), p.clone(), None),
            Err(e) => (None, Vec::new(), Some(e.clone())),
        };
        let cands = candidates
            .iter()
            .map(|c| {
                let v = c.samples.get(m);
                let d = reference.distance(m, &c.samples);
                CandidateMetric {
                    name: c.info.name.clone(),
                    summary: Summary::of(v),
                    masses: bins.map(|b| b.masses(v)).unwrap_or_default(),
                    l1: d.as_ref().ok().copied(),
                    q: d.as_ref().ok().map(|d| 1.0 - d / 2.0),
                    note: d.err().filter(|_| bins.is_some()),
                }
            })
            .collect();
        metrics.push(MetricReport {
            metric: m,
            unit: m.unit(),
            applicable: bins.is_some(),
            note,
            bins,
            reference: Summary::of(rv),
            reference_masses: rmass,
            candidates: cands,
        });
    }

    // Paper 002: metrics of Φ that every candidate has.
    let phi: Vec<Metric> = Metric::PAPER_002
        .iter()
        .copied()
        .filter(|m| metrics[m.index()].candidates.iter().all(|c| c.l1.is_some()))
        .collect();
    let x: Vec<Vec<f64>> = (0..candidates.len())
        .map(|i| {
            phi.iter()
                .map(|m| metrics[m.index()].candidates[i].l1.unwrap_or(2.0))
                .collect()
        })
        .collect();
    let (weights, normalised) = entropy_weights(&x);

    let scores = (0..candidates.len())
        .map(|i| {
            let q_of = |ms: &[Metric]| {
                let qs: Vec<f64> = ms
                    .iter()
                    .filter_map(|m| metrics[m.index()].candidates[i].q)
                    .collect();
                mean(&qs)
            };
            let single: Vec<Metric> = Metric::SINGLE
                .iter()
                .copied()
                .filter(|m| metrics[m.index()].applicable)
                .collect();
            CandidateScore {
                name: candidates[i].info.name.clone(),
                // A single-insect metric the candidate lacks scores 0, as in `fitness`.
                fitness: if single.is_empty() {
                    0.0
                } else {
                    single
                        .iter()
                        .map(|m| metrics[m.index()].candidates[i].q.unwrap_or(0.0))
                        .sum::<f64>()
                        / single.len() as f64
                },
                q_all: q_of(&Metric::ALL),
                entropy_score: 1.0
                    - weights
                        .iter()
                        .zip(&normalised[i])
                        .map(|(w, e)| w * e)
                        .sum::<f64>(),
                entropy_weighted_q: weights
                    .iter()
                    .zip(&x[i])
                    .map(|(w, d)| w * (1.0 - d / 2.0))
                    .sum(),
            }
        })
        .collect();

    Report {
        settings,
        reference: reference.measured.info.clone(),
        candidates: candidates.iter().map(|c| c.info.clone()).collect(),
        metrics,
        entropy_weights: phi.iter().copied().zip(weights).collect(),
        scores,
    }
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Paper 002 Eq. 8–9. `x[i][j]` is ΔE of model i on metric j. Returns the weights w_j and
/// the normalised energies E_ij (Eq. 8). See the module docs for the one-model case.
pub fn entropy_weights(x: &[Vec<f64>]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let m = x.len();
    let n = x.first().map_or(0, Vec::len);
    if n == 0 {
        return (Vec::new(), vec![Vec::new(); m]);
    }
    let equal = vec![1.0 / n as f64; n];
    if m < 2 {
        return (
            equal,
            x.iter()
                .map(|r| r.iter().map(|d| d / 2.0).collect())
                .collect(),
        );
    }
    let mut norm = vec![vec![0.0; n]; m];
    let mut one_minus_e = vec![0.0; n];
    for j in 0..n {
        let lo = x.iter().map(|r| r[j]).fold(f64::INFINITY, f64::min);
        let hi = x.iter().map(|r| r[j]).fold(f64::NEG_INFINITY, f64::max);
        let p2 = hi - lo;
        for i in 0..m {
            // Every model alike on this metric: it cannot tell them apart (weight 0 below).
            norm[i][j] = if p2 > 0.0 { (x[i][j] - lo) / p2 } else { 0.0 };
        }
        let r: Vec<f64> = (0..m).map(|i| 1.0 - norm[i][j]).collect();
        let total: f64 = r.iter().sum();
        let e = if p2 <= 0.0 {
            1.0 // exactly: the sum below rounds to 1 − 3e-16
        } else if total > 0.0 {
            -r.iter()
                .map(|ri| {
                    let g = ri / total;
                    if g > 0.0 { g * g.ln() } else { 0.0 }
                })
                .sum::<f64>()
                / (m as f64).ln()
        } else {
            1.0
        };
        one_minus_e[j] = (1.0 - e).max(0.0);
    }
    let s: f64 = one_minus_e.iter().sum();
    let w = if s > 0.0 {
        one_minus_e.iter().map(|v| v / s).collect()
    } else {
        equal
    };
    (w, norm)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entropy_weights_sum_to_one_and_ignore_undiscriminating_metrics() {
        let x = vec![
            vec![0.1, 0.5, 1.0],
            vec![0.3, 0.5, 0.2],
            vec![0.9, 0.5, 0.4],
        ];
        let (w, e) = entropy_weights(&x);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert_eq!(w[1], 0.0);
        assert_eq!(e[0][0], 0.0);
        assert_eq!(e[2][0], 1.0);
        assert!(w.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn one_model_gets_equal_weights() {
        let (w, e) = entropy_weights(&[vec![0.2, 1.0]]);
        assert_eq!(w, vec![0.5, 0.5]);
        assert_eq!(e, vec![vec![0.1, 0.5]]);
        let (w, _) = entropy_weights(&[]);
        assert!(w.is_empty());
    }
}
