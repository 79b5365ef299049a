//! The maneuvering functions of paper 004 (Sec. 4.1): Eq. 1 gives each of the five angles
//! as an oscillation, Eq. 2–3 its frequency and amplitude from the speed at the start of
//! a flapping cycle through one sigmoid, and Eq. 12 smooths both over the last cycles.
//!
//! Table 3 is followed where it and the text disagree (docs/model.md, "Paper 004"):
//! - phases φ_p: the table's −90° for feathering ζ and sweeping ψ (the text says 0° for
//!   every wing angle);
//! - the blank frequency ranges of flapping γ and the abdomen φ are the text's 0–11 Hz
//!   (the abdomen must share the flap's frequency to move "with the opposite phase");
//! - the garbled mean of ψ ("U") is 0°;
//! - the amplitude ranges R_θa are read as peak-to-peak: the cosine's amplitude is half
//!   of them (150° of flapping as ±75° about the 10° mean, not ±150°, which would sweep
//!   the wings through each other under the body).
//!
//! Angles are in degrees (as the paper and the caches give them), times in seconds.

/// The five maneuvering angles, in the order of the paper's χ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Angle {
    /// θ_β: thorax pitch, nose up positive.
    Pitch,
    /// θ_γ: wing flapping, tips up positive.
    Flap,
    /// θ_ζ: forewing feathering, leading edge up positive.
    Feather,
    /// θ_ψ: forewing sweeping, tips forward positive.
    Sweep,
    /// θ_φ: abdomen rotation about the body's long axis.
    Abdomen,
}

/// One row of Table 3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// R_f: frequency range, Hz (Eq. 2).
    pub freq_range: f32,
    /// R_θa: amplitude range, degrees, peak to peak (Eq. 3).
    pub amp_range: f32,
    /// φ_p: phase, degrees.
    pub phase: f32,
    /// φ_m: mean, degrees.
    pub mean: f32,
}

/// Table 3, rows β, γ, ζ, ψ, φ.
pub const TABLE3: [Row; 5] = [
    Row {
        freq_range: 3.0,
        amp_range: 30.0,
        phase: -90.0,
        mean: 0.0,
    },
    Row {
        freq_range: 11.0,
        amp_range: 150.0,
        phase: 0.0,
        mean: 10.0,
    },
    Row {
        freq_range: 11.0,
        amp_range: 10.0,
        phase: -90.0,
        mean: 0.0,
    },
    Row {
        freq_range: 11.0,
        amp_range: 20.0,
        phase: -90.0,
        mean: 0.0,
    },
    Row {
        freq_range: 11.0,
        amp_range: 35.0,
        phase: -180.0,
        mean: -10.0,
    },
];

impl Angle {
    pub const ALL: [Angle; 5] = [
        Angle::Pitch,
        Angle::Flap,
        Angle::Feather,
        Angle::Sweep,
        Angle::Abdomen,
    ];

    pub fn row(self) -> &'static Row {
        &TABLE3[self as usize]
    }
}

/// The sigmoid of Eq. 2–3: 1 / (1 + e^(−16(|u|/|u_max| − 0.5))), in (0, 1).
#[inline]
pub fn sigmoid(speed: f32, max_speed: f32) -> f32 {
    1.0 / (1.0 + (-16.0 * (speed / max_speed - 0.5)).exp())
}

/// Eq. 2 for angle `a`: the frequency, Hz, at sigmoid value `s`.
#[inline]
pub fn frequency(a: Angle, s: f32) -> f32 {
    a.row().freq_range * s
}

/// Eq. 3 for angle `a`: the cosine's amplitude, degrees (half the peak-to-peak range).
#[inline]
pub fn amplitude(a: Angle, s: f32) -> f32 {
    0.5 * a.row().amp_range * s
}

/// Eq. 1 for angle `a` with amplitude factor `s` (the smoothed sigmoid) at oscillator
/// phase `phase` (radians, 2π f t): θ = φ_a cos(2π f t + φ_p) + φ_m, degrees.
#[inline]
pub fn angle(a: Angle, s: f32, phase: f32) -> f32 {
    let r = a.row();
    amplitude(a, s) * (phase + r.phase.to_radians()).cos() + r.mean
}

/// dθ/dt of Eq. 1 at constant f and φ_a, degrees per second (`hz` the angle's frequency).
#[inline]
pub fn angle_rate(a: Angle, s: f32, phase: f32, hz: f32) -> f32 {
    let r = a.row();
    -amplitude(a, s) * std::f32::consts::TAU * hz * (phase + r.phase.to_radians()).sin()
}

/// The largest window Eq. 12 smooths over (the paper's k = 10).
pub const WINDOW: usize = 10;

/// Eq. 12's sliding window over the values of Eq. 2–3 at the starts of the last cycles.
///
/// f and φ_a of every angle are R times the same sigmoid value at the same cycle start,
/// and Eq. 12 is linear, so smoothing the sigmoid once and scaling it by each R gives
/// every c* of Eq. 12 exactly. Uniform weights w_i = 1 / (number of earlier cycles in the
/// window). Plain f32 fields: part of the agent's checkpoint bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window {
    /// Sigmoid values of earlier cycles, newest first (only `len` are valid).
    pub past: [f32; WINDOW],
    /// How many of `past` are valid, as f32 (the agent state is all 4-byte floats).
    pub len: f32,
}

impl Window {
    pub fn new() -> Self {
        Window {
            past: [0.0; WINDOW],
            len: 0.0,
        }
    }

    /// Eq. 12: the value for the next cycle from this cycle's raw value `now` and the
    /// earlier ones, max(n − k, 1) … n − 1 (`k` cycles at most); then `now` joins them.
    pub fn next(&mut self, now: f32, k: usize) -> f32 {
        let k = k.min(WINDOW);
        let n = (self.len as usize).min(k);
        let c = if n == 0 {
            // No earlier cycle: the sum of Eq. 12 is empty and Σw_i = 1 cannot hold; the
            // first cycle takes its own value.
            now
        } else {
            let mean = self.past[..n].iter().sum::<f32>() / n as f32;
            0.5 * mean + 0.5 * now
        };
        self.past.copy_within(0..WINDOW - 1, 1);
        self.past[0] = now;
        self.len = (self.len + 1.0).min(WINDOW as f32);
        c
    }
}

impl Default for Window {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigmoid_is_half_at_half_the_max_speed() {
        assert!((sigmoid(1.0, 2.0) - 0.5).abs() < 1e-6);
        assert!((frequency(Angle::Flap, sigmoid(1.0, 2.0)) - 5.5).abs() < 1e-5);
        assert!(sigmoid(0.0, 2.0) < 1e-3 && sigmoid(2.0, 2.0) > 0.999);
    }

    #[test]
    fn table3_phases_and_means() {
        // At phase 0 (cycle start, wings highest) the flap is at its top, the abdomen at
        // its bottom, feathering and sweeping pass their means.
        let s = 1.0;
        assert!((angle(Angle::Flap, s, 0.0) - 85.0).abs() < 1e-4);
        assert!((angle(Angle::Abdomen, s, 0.0) - (-27.5)).abs() < 1e-4);
        assert!(angle(Angle::Feather, s, 0.0).abs() < 1e-4);
        assert!(angle(Angle::Sweep, s, 0.0).abs() < 1e-4);
        // The rate is the derivative of the angle.
        let (ph, hz, h) = (0.7f32, 11.0f32, 1e-3f32);
        let dph = std::f32::consts::TAU * hz * h;
        let d = (angle(Angle::Flap, s, ph + dph) - angle(Angle::Flap, s, ph - dph)) / (2.0 * h);
        assert!((d - angle_rate(Angle::Flap, s, ph, hz)).abs() < 0.02 * d.abs());
    }

    #[test]
    fn window_halves_the_new_value_with_the_mean_of_the_old() {
        let mut w = Window::new();
        assert_eq!(w.next(0.2, 10), 0.2);
        assert!((w.next(0.6, 10) - 0.4).abs() < 1e-6);
        // Earlier 0.6 and 0.2: mean 0.4; now 1.0 → 0.7.
        assert!((w.next(1.0, 10) - 0.7).abs() < 1e-6);
        // Window 1: only the last earlier value (1.0).
        assert!((w.next(0.0, 1) - 0.5).abs() < 1e-6);
        // k = 0: no earlier cycle in the window, the current value alone.
        let mut z = Window::new();
        z.next(0.3, 0);
        assert_eq!(z.next(0.9, 0), 0.9);
    }
}
