//! Discrete distributions on shared bins, their L1 distance (paper 000 Eq. 19–20), and
//! summary statistics.
//!
//! Why shared bins fixed by the reference, and not Eq. 18's min–max scaling: Eq. 18 scales
//! each data set to [0, 1] by its own extremes, so a simulation flying uniformly ten times
//! too fast has the same normalised distribution as the real insects and scores perfectly.
//! Here both data sets are binned on one physical axis: `k` equal bins spanning the
//! reference's central 99 % (its 0.5 % and 99.5 % quantiles). Values outside are counted
//! in the first or last bin, so mass a candidate puts beyond the real range still counts
//! against it, while a handful of tracking glitches in the recording cannot stretch the
//! axis until all real mass sits in one bin (as a pooled min–max range would). Because the
//! bins depend on the reference only, a candidate's distance does not change with which
//! other candidates are evaluated with it, and the calibration's fitness landscape stays
//! fixed from one generation to the next.

use serde::Serialize;

/// Fraction of the reference cut from each tail when choosing the bin range.
pub const TAIL: f64 = 0.005;

/// `k` equal bins over [lo, hi].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Bins {
    pub lo: f64,
    pub hi: f64,
    pub k: usize,
}

impl Bins {
    /// Bins over the reference's robust range. `None` when there are no reference samples.
    pub fn from_reference(reference: &[f64], k: usize) -> Option<Bins> {
        if reference.is_empty() {
            return None;
        }
        let mut v = reference.to_vec();
        v.sort_by(f64::total_cmp);
        let (mut lo, mut hi) = (quantile_sorted(&v, TAIL), quantile_sorted(&v, 1.0 - TAIL));
        if hi <= lo {
            // A (nearly) constant reference: give the bins a width around that value.
            let pad = if lo.abs() > 0.0 { lo.abs() * 0.5 } else { 1e-6 };
            lo -= pad;
            hi += pad;
        }
        Some(Bins {
            lo,
            hi,
            k: k.max(1),
        })
    }

    pub fn width(&self) -> f64 {
        (self.hi - self.lo) / self.k as f64
    }

    pub fn edges(&self) -> Vec<f64> {
        (0..=self.k)
            .map(|i| self.lo + (self.hi - self.lo) * i as f64 / self.k as f64)
            .collect()
    }

    /// Bin of a value; values beyond the range go to the end bins.
    pub fn bin(&self, x: f64) -> usize {
        let f = (x - self.lo) / (self.hi - self.lo) * self.k as f64;
        if f.is_nan() || f < 0.0 {
            0
        } else {
            (f as usize).min(self.k - 1)
        }
    }

    /// Probability mass per bin (Eq. 19: |S_i| / |S|); all zeros for no samples.
    pub fn masses(&self, samples: &[f64]) -> Vec<f64> {
        let mut h = vec![0.0; self.k];
        for &x in samples {
            h[self.bin(x)] += 1.0;
        }
        let n = samples.len() as f64;
        if n > 0.0 {
            for x in &mut h {
                *x /= n;
            }
        }
        h
    }
}

/// Eq. 20: Σ_i |P_i − Q_i| over probability masses, in [0, 2].
pub fn l1(p: &[f64], q: &[f64]) -> f64 {
    p.iter().zip(q).map(|(a, b)| (a - b).abs()).sum()
}

/// Linear-interpolated quantile of sorted data (`q` in [0, 1]).
pub fn quantile_sorted(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let pos = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let i = pos.floor() as usize;
    let f = pos - i as f64;
    if i + 1 < v.len() {
        v[i] + (v[i + 1] - v[i]) * f
    } else {
        v[i]
    }
}

/// Count, mean and quantiles of a metric's samples (all zero when there are none).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Summary {
    pub n: usize,
    pub mean: f64,
    pub p05: f64,
    pub median: f64,
    pub p95: f64,
}

impl Summary {
    pub fn of(samples: &[f64]) -> Summary {
        if samples.is_empty() {
            return Summary::default();
        }
        let mut v = samples.to_vec();
        v.sort_by(f64::total_cmp);
        Summary {
            n: v.len(),
            mean: v.iter().sum::<f64>() / v.len() as f64,
            p05: quantile_sorted(&v, 0.05),
            median: quantile_sorted(&v, 0.5),
            p95: quantile_sorted(&v, 0.95),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_samples_have_zero_distance_and_disjoint_ones_two() {
        let a: Vec<f64> = (0..1000).map(|i| i as f64 / 1000.0).collect();
        let b = Bins::from_reference(&a, 20).unwrap();
        assert_eq!(l1(&b.masses(&a), &b.masses(&a)), 0.0);
        // Far beyond the range: all mass lands in the last bin, which holds 1/20 of the
        // reference, so ΔE = (1 − 0.05) + (1 − 0.05).
        let far: Vec<f64> = a.iter().map(|x| x + 10.0).collect();
        assert!((l1(&b.masses(&a), &b.masses(&far)) - 1.9).abs() < 0.01);
    }

    #[test]
    fn scale_mismatch_is_seen() {
        // Min–max scaling per data set (Eq. 18) would call these identical.
        let a: Vec<f64> = (0..1000).map(|i| i as f64 / 1000.0).collect();
        let b: Vec<f64> = a.iter().map(|x| 3.0 * x).collect();
        let bins = Bins::from_reference(&a, 20).unwrap();
        let d = l1(&bins.masses(&a), &bins.masses(&b));
        assert!(d > 1.0, "{d}");
    }

    #[test]
    fn tails_are_clamped_and_masses_sum_to_one() {
        let bins = Bins {
            lo: 0.0,
            hi: 1.0,
            k: 4,
        };
        let m = bins.masses(&[-5.0, 0.1, 0.99, 1.0, 7.0, f64::NAN]);
        assert_eq!(bins.bin(-5.0), 0);
        assert_eq!(bins.bin(7.0), 3);
        assert!((m.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert_eq!(
            Bins {
                lo: 0.0,
                hi: 1.0,
                k: 4
            }
            .masses(&[]),
            vec![0.0; 4]
        );
    }

    #[test]
    fn constant_reference_gets_a_usable_range() {
        let b = Bins::from_reference(&[0.0; 10], 5).unwrap();
        assert!(b.hi > b.lo);
        assert!(Bins::from_reference(&[], 5).is_none());
        let s = Summary::of(&[1.0, 2.0, 3.0]);
        assert_eq!((s.n, s.median, s.mean), (3, 2.0, 2.0));
    }
}
