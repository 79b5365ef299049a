//! Resampling to a common time step on a shared clock.
//!
//! Every data set is brought to samples at exact multiples of `dt` (t = k·dt), so metrics
//! that difference over one step mean the same thing for every data set whatever its
//! native rate, and samples of different insects taken at the same instant share the same
//! index k (which the neighbour metrics need). Positions and velocities are interpolated
//! linearly between the native samples; nothing is extrapolated past a track's ends.

use super::tracks::{Dataset, Track};
use glam::DVec3;

/// A track on the shared clock: sample `i` is at time `(start + i) · dt`.
#[derive(Clone, Debug, PartialEq)]
pub struct Uniform {
    pub id: String,
    /// Grid index of the first sample.
    pub start: i64,
    pub position: Vec<DVec3>,
    pub velocity: Vec<DVec3>,
}

impl Uniform {
    pub fn len(&self) -> usize {
        self.position.len()
    }
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }
}

/// Native samples closer than this fraction of `dt` to a grid time count as on it, so
/// data recorded at the grid rate (t = 0.48 stored as 0.4800000001) is not shifted by a
/// whole step.
const SNAP: f64 = 1e-6;

/// Resamples one track; `None` when it spans no grid time.
pub fn resample_track(track: &Track, dt: f64) -> Option<Uniform> {
    let (&t0, &t1) = (track.time.first()?, track.time.last()?);
    let k0 = (t0 / dt - SNAP).ceil() as i64;
    let k1 = (t1 / dt + SNAP).floor() as i64;
    if k1 < k0 {
        return None;
    }
    let n = (k1 - k0 + 1) as usize;
    let mut out = Uniform {
        id: track.id.clone(),
        start: k0,
        position: Vec::with_capacity(n),
        velocity: Vec::with_capacity(n),
    };
    let mut j = 0; // native segment [j, j+1] holding the current grid time
    for k in k0..=k1 {
        let t = (k as f64 * dt).clamp(t0, t1);
        while j + 1 < track.len() && track.time[j + 1] < t {
            j += 1;
        }
        if j + 1 >= track.len() {
            out.position.push(track.position[j]);
            out.velocity.push(track.velocity[j]);
            continue;
        }
        let (ta, tb) = (track.time[j], track.time[j + 1]);
        let s = if tb > ta {
            ((t - ta) / (tb - ta)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.position
            .push(track.position[j].lerp(track.position[j + 1], s));
        out.velocity
            .push(track.velocity[j].lerp(track.velocity[j + 1], s));
    }
    Some(out)
}

/// Resamples every track of a data set.
pub fn resample(ds: &Dataset, dt: f64) -> Vec<Uniform> {
    ds.tracks
        .iter()
        .filter_map(|t| resample_track(t, dt))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(times: &[f64]) -> Track {
        Track {
            id: "a".into(),
            time: times.to_vec(),
            position: times.iter().map(|&t| DVec3::new(t, 0.0, 0.0)).collect(),
            velocity: times.iter().map(|_| DVec3::X).collect(),
        }
    }

    #[test]
    fn grid_samples_are_kept_and_in_between_ones_interpolated() {
        let u = resample_track(&line(&[0.48, 0.5, 0.52000000001]), 0.02).unwrap();
        assert_eq!(u.start, 24);
        assert_eq!(u.len(), 3);
        let u = resample_track(&line(&[0.0, 0.1, 0.2]), 0.04).unwrap();
        assert_eq!(u.len(), 6);
        assert!((u.position[1].x - 0.04).abs() < 1e-12);
        assert!((u.position[5].x - 0.2).abs() < 1e-12);
    }

    #[test]
    fn a_track_between_grid_times_is_dropped() {
        assert!(resample_track(&line(&[0.01, 0.015]), 0.02).is_none());
    }
}
