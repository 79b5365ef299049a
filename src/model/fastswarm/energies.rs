//! The energy E of paper 003 Eq. 2–14 for one agent and one candidate velocity, with
//! everything that does not depend on the candidate prepared once per agent per step.
//!
//! Conventions: metres, seconds, world Y-up; a "direction" is a unit vector (zero where
//! a velocity has no direction).

use crate::math::normalize_or;
use crate::model::context::MAX_NEIGHBOURS;
use glam::{Mat3, Vec3};

/// e^x for the energies: 2^(x log₂e) from the exponent bits and a degree-5 polynomial for
/// the fraction, within 1e-5 of `f32::exp` relative on [−87, 87] (clamped beyond). Plain
/// multiplies and adds, so it gives the same bits on every platform (libm's `exp` need
/// not), and it is several times faster: the selection evaluates it ~10⁴ times per agent
/// per step.
#[inline(always)]
pub fn fast_exp(x: f32) -> f32 {
    let t = x.clamp(-87.0, 87.0) * std::f32::consts::LOG2_E;
    let i = t.round();
    let f = t - i;
    // 2^f for f in [−½, ½]: the Taylor series of e^(f ln 2) to degree 6.
    let p = 1.0
        + f * (std::f32::consts::LN_2
            + f * (0.240_226_5
                + f * (0.055_504_11
                    + f * (0.009_618_129 + f * (0.001_333_355 + f * 0.000_154_035_3)))));
    f32::from_bits((((i as i32) + 127) as u32) << 23) * p
}

/// The most direction terms an agent has: swarm centre (Eq. 7), own direction (Eq. 9),
/// noise (Eq. 13), key point (Eq. 14) and an attracting stimulus (Eq. 11–12).
const MAX_DIRECTIONS: usize = 5;
/// The most stimuli an agent weighs at once.
pub const MAX_STIMULI: usize = 4;

/// One agent's energy terms at one step: E(v, a) for any candidate (v, a).
#[derive(Clone, Debug)]
pub struct Energy {
    /// ρ (Sec. 5).
    pub rho: f32,
    /// Step, s.
    pub dt: f32,
    /// The agent's position p_{i,t}.
    pub p: Vec3,
    /// The agent's velocity v_{i,t}.
    pub v: Vec3,
    /// (w, û) of every term w·e^{ρ‖v̂ − û‖} (Eq. 7, 9, 11 attracted, 13, 14).
    dirs: [(f32, Vec3); MAX_DIRECTIONS],
    n_dirs: usize,
    /// w_rep / |RN| and 1 / d_rep (Eq. 4).
    rep_w: f32,
    inv_d_rep: f32,
    /// Neighbours' predicted positions p'_{j,t+1} = p_j + v_j Δt, repulsion zone (Eq. 4).
    rep: [Vec3; MAX_NEIGHBOURS],
    n_rep: usize,
    /// Eq. 6 as a function of the move δ = vΔt, expanded to second order about δ = 0:
    /// w_oa/|AN| · (F + g·δ + ½ δᵀHδ), summed over the attraction neighbours once per
    /// step instead of once per candidate (see [`Energy::attraction`]).
    att_f: f32,
    att_g: Vec3,
    att_h: Mat3,
    /// w_acc and 1 / mean |a| of the database (Eq. 10, see [`Energy::accel`]).
    acc_w: f32,
    inv_mean_accel: f32,
    /// (w_env, p_sti, 1 / d_danger) of every startling stimulus within reach (Eq. 12).
    startle: [(f32, Vec3, f32); MAX_STIMULI],
    n_startle: usize,
}

impl Energy {
    pub fn new(rho: f32, dt: f32, p: Vec3, v: Vec3) -> Self {
        Energy {
            rho,
            dt,
            p,
            v,
            dirs: [(0.0, Vec3::ZERO); MAX_DIRECTIONS],
            n_dirs: 0,
            rep_w: 0.0,
            inv_d_rep: 0.0,
            rep: [Vec3::ZERO; MAX_NEIGHBOURS],
            n_rep: 0,
            att_f: 0.0,
            att_g: Vec3::ZERO,
            att_h: Mat3::ZERO,
            acc_w: 0.0,
            inv_mean_accel: 0.0,
            startle: [(0.0, Vec3::ZERO, 0.0); MAX_STIMULI],
            n_startle: 0,
        }
    }

    /// Adds a term w·e^{ρ‖v̂ − dir‖} (Eq. 7, 9, 11, 13, 14 share this form); `dir` need
    /// not be unit. A zero weight or a direction-less `dir` adds nothing.
    pub fn direction(&mut self, w: f32, dir: Vec3) {
        let u = normalize_or(dir, Vec3::ZERO);
        if w > 0.0 && u != Vec3::ZERO && self.n_dirs < MAX_DIRECTIONS {
            self.dirs[self.n_dirs] = (w, u);
            self.n_dirs += 1;
        }
    }

    /// Eq. 4's neighbours: predicted positions of those within d_rep.
    pub fn repulsion(&mut self, w: f32, d_rep: f32, predicted: &[Vec3]) {
        let n = predicted.len().min(MAX_NEIGHBOURS);
        self.rep[..n].copy_from_slice(&predicted[..n]);
        self.n_rep = if w > 0.0 { n } else { 0 };
        self.rep_w = if n > 0 { w / n as f32 } else { 0.0 };
        self.inv_d_rep = 1.0 / d_rep;
    }

    /// Eq. 6's neighbours: current positions p_j of those between d_att1 and d_att2 (Eq. 6
    /// uses p_j, not p'_j).
    ///
    /// Each term f(δ) = e^{ρ(‖p + δ − p_j‖/d_att1 − 1)} is summed as its second-order
    /// expansion about δ = 0: with r = p − p_j, d = ‖r‖, r̂ = r/d and k = ρ/d_att1,
    /// ∇f = f k r̂ and ∇²f = f (k² r̂r̂ᵀ + k (I − r̂r̂ᵀ)/d). The neighbours are at least
    /// d_att1 away and a step moves |δ| ≤ 1 m/s × 0.02 s, so the neglected third-order
    /// term is below (k|δ|)³/6 of f: under 1 % for moves up to 2 cm at d_att1 = 8 cm.
    pub fn attraction(&mut self, w: f32, d_att1: f32, positions: &[Vec3]) {
        let n = positions.len();
        let (mut f, mut g, mut h) = (0.0f32, Vec3::ZERO, Mat3::ZERO);
        if w > 0.0 && n > 0 {
            let k = self.rho / d_att1;
            for &q in &positions[..n] {
                let r = self.p - q;
                let d = r.length().max(1e-6);
                let u = r / d;
                let fj = fast_exp(self.rho * (d / d_att1 - 1.0));
                let uu = Mat3::from_cols(u * u.x, u * u.y, u * u.z);
                f += fj;
                g += u * (fj * k);
                h += (uu * (k * k) + (Mat3::IDENTITY - uu) * (k / d)) * fj;
            }
            let wn = w / n as f32;
            (f, g, h) = (f * wn, g * wn, h * wn);
        }
        self.att_f = f;
        self.att_g = g;
        self.att_h = h * 0.5;
    }

    /// Eq. 10 with weight `w` and the database's mean |a|.
    pub fn acceleration(&mut self, w: f32, mean_accel: f32) {
        self.acc_w = w;
        self.inv_mean_accel = 1.0 / mean_accel;
    }

    /// Eq. 12, startled: a danger at `at` within `d_danger` of the agent.
    pub fn startle(&mut self, w: f32, at: Vec3, d_danger: f32) {
        if w > 0.0 && self.n_startle < MAX_STIMULI {
            self.startle[self.n_startle] = (w, at, 1.0 / d_danger);
            self.n_startle += 1;
        }
    }

    /// E(i, v, a, S_t) of Eq. 2 for candidate velocity `v` with recorded acceleration `a`.
    pub fn of(&self, v: Vec3, a: Vec3) -> f32 {
        let unit = |u: Vec3| normalize_or(u, Vec3::ZERO);
        self.of_unit(v, unit(v), unit(a), a.length())
    }

    /// [`Energy::of`] with the candidate's v̂, â and |a| given (the database prepares them).
    #[inline]
    pub fn of_unit(&self, v: Vec3, vh: Vec3, ah: Vec3, a_len: f32) -> f32 {
        self.of_unit_below(v, vh, ah, a_len, f32::INFINITY)
            .unwrap_or(f32::INFINITY)
    }

    /// [`Energy::of_unit`] if it is below `best`, else `None`, found without finishing the
    /// sum as soon as the terms so far reach `best`: every term is positive (the expanded
    /// attraction too: per neighbour it is at least half its value at δ = 0), and adding
    /// a positive float never lowers a sum, so what is left out could not have won.
    #[inline]
    pub fn of_unit_below(&self, v: Vec3, vh: Vec3, ah: Vec3, a_len: f32, best: f32) -> Option<f32> {
        let rho = self.rho;
        let p1 = self.p + v * self.dt;
        let mut e = 0.0f32;
        for &(w, u) in &self.dirs[..self.n_dirs] {
            // ‖v̂ − û‖ = √(2 − 2 v̂·û) for unit vectors (v̂ = 0 gives 1, as it should).
            let dist = if vh == Vec3::ZERO {
                1.0
            } else {
                (2.0 - 2.0 * vh.dot(u)).max(0.0).sqrt()
            };
            e += w * fast_exp(rho * dist);
        }
        let mut rep = 0.0;
        for &q in &self.rep[..self.n_rep] {
            rep += fast_exp(rho * (1.0 - (p1 - q).length() * self.inv_d_rep));
        }
        e += rep * self.rep_w;
        let d = v * self.dt;
        e += self.att_f + self.att_g.dot(d) + d.dot(self.att_h * d);
        for &(w, at, inv_d) in &self.startle[..self.n_startle] {
            e += w * fast_exp(rho * (1.0 - (p1 - at).length() * inv_d));
        }
        // Acceleration continuity costs the most: skip it for a candidate already lost.
        if e.partial_cmp(&best) != Some(std::cmp::Ordering::Less) {
            return None;
        }
        if self.acc_w > 0.0 {
            e += self.acc_w * self.accel(v, ah, a_len);
        }
        (e < best).then_some(e)
    }

    /// Eq. 10 without its weight: e^{ρ‖â′ − â‖} + |‖a′‖ − ‖a‖| / ā. The paper's
    /// a′ = v − v_t is a velocity change, compared with a recorded acceleration; we use
    /// a′ = (v − v_t)/Δt, an acceleration, and divide the magnitude difference by the
    /// database's mean |a| (ā) so that both parts are unitless and of order one.
    #[inline]
    fn accel(&self, v: Vec3, ah: Vec3, a_len: f32) -> f32 {
        let a1 = (v - self.v) / self.dt;
        let l1 = a1.length();
        let a1h = if l1 > 1e-9 { a1 / l1 } else { Vec3::ZERO };
        let dir = (a1h - ah).length();
        fast_exp(self.rho * dir) + (l1 - a_len).abs() * self.inv_mean_accel
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_exp_is_exp() {
        let mut worst = 0.0f32;
        for k in -4000..=4000 {
            let x = k as f32 * 0.02;
            worst = worst.max((fast_exp(x) / x.exp() - 1.0).abs());
        }
        assert!(worst < 1e-5, "relative error {worst}");
    }

    #[test]
    fn the_expanded_attraction_matches_the_exact_sum() {
        let (rho, d1) = (2.5f32, 0.08f32);
        let p = Vec3::new(0.1, 1.0, -0.2);
        let nbrs = [
            p + Vec3::new(0.09, 0.0, 0.0),
            p + Vec3::new(-0.1, 0.2, 0.05),
            p + Vec3::new(0.0, -0.05, 0.25),
        ];
        let mut e = Energy::new(rho, 0.02, p, Vec3::ZERO);
        e.attraction(1.0, d1, &nbrs);
        let mut worst = 0.0f32;
        for v in [Vec3::X, -Vec3::X, Vec3::Y * 0.5, Vec3::new(0.3, -0.2, 0.6)] {
            let p1 = p + v * 0.02;
            let exact = nbrs
                .iter()
                .map(|q| (rho * ((p1 - *q).length() / d1 - 1.0)).exp())
                .sum::<f32>()
                / 3.0;
            worst = worst.max((e.of(v, Vec3::ZERO) / exact - 1.0).abs());
        }
        assert!(worst < 0.01, "relative error {worst}");
    }

    #[test]
    fn each_term_prefers_what_the_paper_says() {
        let dt = 0.02;
        // Direction terms: the candidate along the direction wins.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::X * 0.2);
        e.direction(1.0, Vec3::Z);
        assert!(e.of(Vec3::Z * 0.2, Vec3::ZERO) < e.of(Vec3::X * 0.2, Vec3::ZERO));
        assert!(
            (e.of(Vec3::Z * 0.2, Vec3::ZERO) - 1.0).abs() < 1e-6,
            "e^0 = 1"
        );
        // Repulsion: moving away from a close neighbour costs less.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::ZERO);
        e.repulsion(1.0, 0.03, &[Vec3::X * 0.01]);
        assert!(e.of(-Vec3::X * 0.3, Vec3::ZERO) < e.of(Vec3::X * 0.3, Vec3::ZERO));
        // Attraction: moving towards a far neighbour costs less.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::ZERO);
        e.attraction(1.0, 0.08, &[Vec3::X * 0.2]);
        assert!(e.of(Vec3::X * 0.3, Vec3::ZERO) < e.of(-Vec3::X * 0.3, Vec3::ZERO));
        // Startle: moving away from the danger costs less.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::ZERO);
        e.startle(2.0, Vec3::Y * 0.1, 0.3);
        assert!(e.of(-Vec3::Y * 0.5, Vec3::ZERO) < e.of(Vec3::Y * 0.5, Vec3::ZERO));
        // Acceleration continuity: the candidate whose change matches its recorded
        // acceleration (0.04 m/s over 0.02 s = 2 m/s² along +x) is cheapest.
        let mut e = Energy::new(2.5, dt, Vec3::ZERO, Vec3::X * 0.2);
        e.acceleration(1.0, 2.0);
        let good = e.of(Vec3::X * 0.24, Vec3::X * 2.0);
        assert!((good - 1.0).abs() < 1e-4, "{good}");
        assert!(good < e.of(Vec3::X * 0.24, -Vec3::X * 2.0));
        assert!(good < e.of(Vec3::X * 0.30, Vec3::X * 2.0));
    }
}
