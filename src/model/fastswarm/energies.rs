//! The energy E of paper 003 Eq. 2–14 for one agent and one candidate velocity, with
//! everything that does not depend on the candidate prepared once per agent per step.
//!
//! Conventions: metres, seconds, world Y-up; a "direction" is a unit vector (zero where
//! a velocity has no direction).

use crate::math::normalize_or;
use crate::model::context::MAX_NEIGHBOURS;
use glam::Vec3;

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
    /// w_oa / |AN| and 1 / d_att1 (Eq. 6).
    att_w: f32,
    inv_d_att1: f32,
    /// Neighbours' current positions p_{j,t}, attraction zone (Eq. 6 uses p_j, not p'_j).
    att: [Vec3; MAX_NEIGHBOURS],
    n_att: usize,
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
            att_w: 0.0,
            inv_d_att1: 0.0,
            att: [Vec3::ZERO; MAX_NEIGHBOURS],
            n_att: 0,
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

    /// Eq. 6's neighbours: current positions of those between d_att1 and d_att2.
    pub fn attraction(&mut self, w: f32, d_att1: f32, positions: &[Vec3]) {
        let n = positions.len().min(MAX_NEIGHBOURS);
        self.att[..n].copy_from_slice(&positions[..n]);
        self.n_att = if w > 0.0 { n } else { 0 };
        self.att_w = if n > 0 { w / n as f32 } else { 0.0 };
        self.inv_d_att1 = 1.0 / d_att1;
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
    #[inline]
    pub fn of(&self, v: Vec3, a: Vec3) -> f32 {
        let rho = self.rho;
        let p1 = self.p + v * self.dt;
        let vh = normalize_or(v, Vec3::ZERO);
        let mut e = 0.0;
        for &(w, u) in &self.dirs[..self.n_dirs] {
            e += w * (rho * (vh - u).length()).exp();
        }
        let mut rep = 0.0;
        for &q in &self.rep[..self.n_rep] {
            rep += (rho * (1.0 - (p1 - q).length() * self.inv_d_rep)).exp();
        }
        let mut att = 0.0;
        for &q in &self.att[..self.n_att] {
            att += (rho * ((p1 - q).length() * self.inv_d_att1 - 1.0)).exp();
        }
        e += rep * self.rep_w + att * self.att_w;
        for &(w, at, inv_d) in &self.startle[..self.n_startle] {
            e += w * (rho * (1.0 - (p1 - at).length() * inv_d)).exp();
        }
        if self.acc_w > 0.0 {
            e += self.acc_w * self.accel(v, a);
        }
        e
    }

    /// Eq. 10 without its weight: e^{ρ‖â′ − â‖} + |‖a′‖ − ‖a‖| / ā. The paper's
    /// a′ = v − v_t is a velocity change, compared with a recorded acceleration; we use
    /// a′ = (v − v_t)/Δt, an acceleration, and divide the magnitude difference by the
    /// database's mean |a| (ā) so that both parts are unitless and of order one.
    #[inline]
    fn accel(&self, v: Vec3, a: Vec3) -> f32 {
        let a1 = (v - self.v) / self.dt;
        let dir = (normalize_or(a1, Vec3::ZERO) - normalize_or(a, Vec3::ZERO)).length();
        (self.rho * dir).exp() + (a1.length() - a.length()).abs() * self.inv_mean_accel
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
