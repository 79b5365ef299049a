//! Parameters of paper 000's bee model at real scale, and the paper's Table I presets.
//!
//! The paper works in unstated scene units. We map one scene length unit to
//! [`SCENE_UNIT_M`] metres (a few bee lengths, see docs/model.md), so Table I's
//! h = 3 becomes 0.15 m and L = 2.2 becomes 0.11 m. Times are seconds.

pub use crate::field::curl::SCENE_UNIT_M;
use crate::model::params::Preset;

crate::declare_params! {
    /// Every tunable of the bee model. Lengths in metres, speeds in m/s, times in seconds.
    /// Defaults are Table I "around nest".
    pub struct BeeParams {
        /// κ1: weight of the body oscillation force F_o (Eq. 1).
        kappa1: "1", 1.0, [0.0, 100.0], "a weight from 0 to 100";
        /// κ2: weight of the curl-noise force F_curl (Eq. 1).
        kappa2: "1", 2.5, [0.0, 100.0], "a weight from 0 to 100";
        /// κ3: weight of the repulsion force F_repul (Eq. 1).
        kappa3: "1", 1.7, [0.0, 100.0], "a weight from 0 to 100";
        /// L: edge length of the noise lattice (Eq. 8).
        noise_cell: "m", 2.2 * SCENE_UNIT_M, [1e-3, 100.0], "a noise cell size from 0.001 to 100 m";
        /// ε: gain of the noise potential (Eq. 8).
        noise_gain: "1", 2.0, [0.0, 1000.0], "a noise gain from 0 to 1000";
        /// h: SPH neighbourhood radius (Eq. 10–11).
        neighbour_radius: "m", 3.0 * SCENE_UNIT_M, [1e-3, 10.0], "a neighbourhood radius from 0.001 to 10 m";
        /// Preferred cruising speed: the speed at which drag balances mean thrust.
        speed: "m/s", 1.0, [0.01, 50.0], "a speed from 0.01 to 50 m/s";
        /// d0: distance at which a bee starts avoiding an obstacle it sees (Eq. 5–6).
        avoid_distance: "m", 0.12, [1e-3, 10.0], "a distance from 0.001 to 10 m";
        /// Time constant with which the body's heading follows the direction of travel (Sec. V-A: body and velocity need not align).
        heading_lag: "s", 0.06, [1e-3, 100.0], "a time constant from 0.001 to 100 s";
        /// σ of the preferred speed's slow wandering, in natural-log units (0: a constant preferred speed).
        speed_wander: "1", 0.0, [0.0, 3.0], "a log-speed spread from 0 to 3";
        /// Correlation time of that wandering.
        speed_wander_time: "s", 2.0, [1e-2, 1000.0], "a correlation time from 0.01 to 1000 s";
        /// Optic-flow speed control: the preferred speed at a surface, as a fraction of `speed` (1: no slowing).
        surface_speed: "1", 1.0, [0.0, 1.0], "a fraction of the speed from 0 to 1";
        /// Distance over which the preferred speed recovers from `surface_speed` towards `speed` (e-folding length).
        surface_speed_distance: "m", 0.15, [1e-3, 10.0], "a distance from 0.001 to 10 m";
        /// Half-angle of the field of view (Sec. IV-B: ±45°).
        fov_deg: "deg", 45.0, [1.0, 180.0], "a half-angle from 1 to 180 degrees";
        /// Largest roll-to-avoid angle (Eq. 6: 45°).
        roll_max_deg: "deg", 45.0, [0.0, 90.0], "an angle from 0 to 90 degrees";
        /// Seconds per unit of t in the maneuvering functions Eq. 3–4 (2.5 ms: pitch at 5.6 Hz, roll at 2.2 Hz; docs/model.md).
        oscillation_time_unit: "s", 0.0025, [1e-4, 10.0], "seconds per unit of t, from 0.0001 to 10";
        /// 1: Eq. 2's lift at the wing speed whose mean lift carries the weight, so the body bobs visibly; 0: at the body's air speed, as the paper writes it.
        wing_lift: "1", 1.0, [0.0, 1.0], "0 (off) or 1 (on)";
        /// Weight of the stroke-plane manoeuvres of a bee that is slow or at a nest or flower: it hovers, turns on the spot and flies backwards as the other forces ask (0: Eq. 2's thrust always forward).
        manoeuvre: "1", 1.0, [0.0, 1.0], "a weight from 0 to 1";
        /// Pressure stiffness k in p = k (ρ − ρ0) (Eq. 11), m²/s² per unit density ratio.
        pressure_stiffness: "m²/s²", 1.0, [0.0, 1e6], "a stiffness from 0 to 1e6";
        /// Spring stiffness of agent–agent contact (Sec. VII).
        collision_stiffness: "1/s²", 4000.0, [0.0, 1e7], "a stiffness from 0 to 1e7";
        /// Scale of target attraction (multiplies each target's strength).
        attraction: "1", 1.0, [0.0, 100.0], "a factor from 0 to 100";
        /// Acceleration pulling agents back inside the swarm bounds, per metre outside.
        containment: "1/s²", 4.0, [0.0, 1000.0], "an acceleration from 0 to 1000";
        /// Preferred speed at a nest's or flower's surface, as a fraction of `speed`, recovering over `neighbour_radius` (the reach of its virtual particles): bees slow to a hover as they arrive (1: no slowing).
        arrival_speed: "1", 0.1, [0.0, 1.0], "a fraction of the speed from 0 to 1";
    }
}

/// Table I's scene-unit values (h, L, κ1, κ2, κ3, ε) as parameter values.
macro_rules! table_i {
    ($h:expr, $l:expr, $k1:expr, $k2:expr, $k3:expr, $eps:expr) => {
        &[
            ("kappa1", $k1),
            ("kappa2", $k2),
            ("kappa3", $k3),
            ("noise_cell", $l * SCENE_UNIT_M),
            ("noise_gain", $eps),
            ("neighbour_radius", $h * SCENE_UNIT_M),
        ]
    };
}

/// Table I of paper 000.
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "nest",
        doc: "Table I \"around nest\" (350 bees): the defaults",
        values: table_i!(3.0, 2.2, 1.0, 2.5, 1.7, 2.0),
    },
    Preset {
        name: "grassland",
        doc: "Table I \"over grassland\" (1000 bees)",
        values: table_i!(3.0, 2.2, 1.5, 5.0, 0.9, 2.0),
    },
    Preset {
        name: "optimized",
        doc: "Table I \"optimized values\" (the paper's genetic-algorithm result)",
        values: table_i!(3.0, 2.7, 1.4, 2.3, 1.2, 1.7),
    },
];

impl BeeParams {
    /// Table I "over grassland" (1000 bees).
    pub fn grassland() -> Self {
        Self::named("grassland")
    }
    /// Table I "around nest" (350 bees).
    pub fn nest() -> Self {
        Self::named("nest")
    }
    /// Table I "optimized values".
    pub fn optimized() -> Self {
        Self::named("optimized")
    }

    fn named(name: &str) -> Self {
        use crate::model::{ModelKind, params::ParamValues};
        let v = ParamValues::preset(ModelKind::Bee, name).expect("a Table I preset");
        Self::from_values(&v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nest_preset_is_the_defaults_and_table_i_is_scaled_to_metres() {
        assert_eq!(BeeParams::nest(), BeeParams::default());
        let g = BeeParams::grassland();
        assert_eq!((g.kappa1, g.kappa2, g.kappa3), (1.5, 5.0, 0.9));
        assert!((g.neighbour_radius - 0.15).abs() < 1e-12);
        assert!((BeeParams::optimized().noise_cell - 0.135).abs() < 1e-12);
    }
}
