//! Model parameters of paper 000 at real scale, and the paper's Table I presets.
//!
//! The paper works in unstated scene units. We map one scene length unit to
//! [`SCENE_UNIT_M`] metres (a few bee lengths, see docs/model.md), so Table I's
//! h = 3 becomes 0.15 m and L = 2.2 becomes 0.11 m. Times are seconds.

pub use crate::field::curl::SCENE_UNIT_M;

/// Every tunable of the bee model. Lengths in metres, speeds in m/s, times in seconds.
#[derive(Clone, Debug, PartialEq)]
pub struct BeeParams {
    /// κ1: weight of the body oscillation force F_o (Eq. 1).
    pub kappa1: f64,
    /// κ2: weight of the curl-noise force F_curl (Eq. 1).
    pub kappa2: f64,
    /// κ3: weight of the repulsion force F_repul (Eq. 1).
    pub kappa3: f64,
    /// L: edge length of the noise lattice (Eq. 8), metres.
    pub noise_cell: f64,
    /// ε: gain of the noise potential (Eq. 8).
    pub noise_gain: f64,
    /// h: SPH neighbourhood radius (Eq. 10–11), metres.
    pub neighbour_radius: f64,
    /// Preferred cruising speed, m/s: the speed at which drag balances mean thrust.
    pub speed: f64,
    /// d0: distance at which a bee starts avoiding an obstacle it sees (Eq. 5–6), metres.
    pub avoid_distance: f64,
    /// σ of the preferred speed's slow wandering over time, in natural-log units (0: a
    /// constant preferred speed).
    pub speed_wander: f64,
    /// Correlation time of that wandering, seconds.
    pub speed_wander_time: f64,
    /// Optic-flow speed control: the preferred speed at a surface, as a fraction of
    /// `speed` (1: no slowing). See [`surface_speed_factor`](crate::model::vision::surface_speed_factor).
    pub surface_speed: f64,
    /// Distance over which the preferred speed recovers from `surface_speed` towards
    /// `speed` (e-folding length), metres.
    pub surface_speed_distance: f64,
    /// Time constant with which the body's heading follows the direction of travel,
    /// seconds (Sec. V-A: the body and the velocity need not align).
    pub heading_lag: f64,
    /// Half-angle of the field of view (Sec. IV-B: ±45°), degrees.
    pub fov_deg: f64,
    /// Largest roll-to-avoid angle (Eq. 6: 45°), degrees.
    pub roll_max_deg: f64,
    /// Seconds per unit of t in the maneuvering functions Eq. 3–4.
    pub oscillation_time_unit: f64,
    /// Pressure stiffness k in p = k (ρ − ρ0) (Eq. 11), m²/s² per unit density ratio.
    pub pressure_stiffness: f64,
    /// Spring stiffness of bee-bee contact (Sec. VII), 1/s².
    pub collision_stiffness: f64,
    /// Scale of target attraction (multiplies each target's strength).
    pub attraction: f64,
    /// Acceleration pulling bees back inside the swarm bounds, m/s² per metre outside.
    pub containment: f64,
}

impl BeeParams {
    /// Table I "over grassland" (1000 bees).
    pub fn grassland() -> Self {
        Self::from_table(3.0, 2.2, 1.5, 5.0, 0.9, 2.0)
    }
    /// Table I "around nest" (350 bees).
    pub fn nest() -> Self {
        Self::from_table(3.0, 2.2, 1.0, 2.5, 1.7, 2.0)
    }
    /// Table I "optimized values" (the genetic algorithm's result in the paper).
    pub fn optimized() -> Self {
        Self::from_table(3.0, 2.7, 1.4, 2.3, 1.2, 1.7)
    }

    /// A preset by name.
    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "grassland" => Some(Self::grassland()),
            "nest" => Some(Self::nest()),
            "optimized" => Some(Self::optimized()),
            _ => None,
        }
    }

    pub const PRESETS: [&'static str; 3] = ["grassland", "nest", "optimized"];

    /// Builds parameters from Table I's scene-unit values.
    fn from_table(h: f64, l: f64, k1: f64, k2: f64, k3: f64, eps: f64) -> Self {
        BeeParams {
            kappa1: k1,
            kappa2: k2,
            kappa3: k3,
            noise_cell: l * SCENE_UNIT_M,
            noise_gain: eps,
            neighbour_radius: h * SCENE_UNIT_M,
            speed: 1.0,
            avoid_distance: 0.12,
            heading_lag: 0.06,
            speed_wander: 0.0,
            speed_wander_time: 2.0,
            surface_speed: 1.0,
            surface_speed_distance: 0.15,
            fov_deg: 45.0,
            roll_max_deg: 45.0,
            oscillation_time_unit: 0.005,
            pressure_stiffness: 1.0,
            collision_stiffness: 4000.0,
            attraction: 1.0,
            containment: 4.0,
        }
    }
}

impl Default for BeeParams {
    fn default() -> Self {
        Self::nest()
    }
}
