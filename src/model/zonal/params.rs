//! Parameters of the zonal model and paper 002's Table 1 as presets.
//!
//! The paper states its parameters in unstated scene units. We read one paper length unit
//! as [`PAPER_UNIT_M`] metres (docs/model.md, "Paper 002: units") and convert each Table 1
//! value by its dimension: lengths × U, accelerations (χ) × U, γ (1/length) ÷ U,
//! gain (length²/s², see `noise.rs`) × U². Time is seconds in both.

use crate::model::params::Preset;

/// Metres per paper 002 length unit.
pub const PAPER_UNIT_M: f64 = 0.05;
const U: f64 = PAPER_UNIT_M;

crate::declare_params! {
    /// Parameters of the zonal model (paper 002, Eq. 2–5 and Algorithm 1).
    pub struct ZonalParams {
        /// γ: friction coefficient of F_fric = −γ|v|v.
        gamma: "1/m", 11.16 / 0.05, [0.0, 1e5], "a friction coefficient from 0 to 100000 per metre";
        /// scale: size of the noise field's features (the noise is sampled at r / scale).
        scale: "m", 2.20 * 0.05, [1e-3, 100.0], "a length from 0.001 to 100 m";
        /// gain: magnitude of the noise potential; the noise force is gain / scale times a unit-scale field.
        gain: "m²/s²", 2.51 * 0.05 * 0.05, [0.0, 100.0], "a gain from 0 to 100";
        /// χ_rep: weight of repulsion (Eq. 5).
        chi_rep: "m/s²", 5.61 * 0.05, [0.0, 1000.0], "an acceleration from 0 to 1000";
        /// r_rep: radius of the repulsion zone.
        r_rep: "m", 0.17 * 0.05, [0.0, 100.0], "a radius from 0 to 100 m";
        /// χ_ali: weight of alignment (Eq. 5).
        chi_ali: "m/s²", 0.0, [0.0, 1000.0], "an acceleration from 0 to 1000";
        /// r_ali*: width of the alignment zone, r_ali − r_rep (Table 1's increment).
        r_ali_star: "m", 0.0, [0.0, 100.0], "a width from 0 to 100 m";
        /// χ_att: weight of attraction (Eq. 5).
        chi_att: "m/s²", 14.29 * 0.05, [0.0, 1000.0], "an acceleration from 0 to 1000";
        /// r_att*: width of the attraction zone, r_att − r_ali (Table 1's increment).
        r_att_star: "m", 5.12 * 0.05, [0.0, 100.0], "a width from 0 to 100 m";
        /// χ_res: weight of the response to a predator, food or light target.
        chi_res: "m/s²", 0.0, [0.0, 1000.0], "an acceleration from 0 to 1000";
        /// r_res: how far the insects see a stimulus (the target's `reach` can only shorten it).
        r_res: "m", 0.0, [0.0, 1000.0], "a radius from 0 to 1000 m";
        /// The random force: 0 curl noise (the paper's choice), 1 white, 2 Gaussian, 3 Perlin.
        noise: "1", 0.0, [0.0, 3.0], "0 (curl), 1 (white), 2 (Gaussian) or 3 (Perlin)";
        /// 1: velocities pass through 3D ORCA (f_R); 0: the preferred velocity is flown as is.
        orca: "1", 1.0, [0.0, 1.0], "0 (off) or 1 (on)";
        /// τ: ORCA's time horizon; no collision within it is allowed.
        time_horizon: "s", 0.5, [1e-3, 100.0], "a time from 0.001 to 100 s";
        /// Largest speed ORCA may choose (the radius of its velocity ball).
        max_speed: "m/s", 1.0, [1e-3, 100.0], "a speed from 0.001 to 100 m/s";
        /// Pull back inside the swarm bounds, per metre outside (not in the paper: the project's soft bounds).
        containment: "1/s²", 4.0, [0.0, 1000.0], "an acceleration from 0 to 1000";
        /// Time constant with which the body's heading follows the direction of travel.
        heading_lag: "s", 0.06, [1e-3, 100.0], "a time constant from 0.001 to 100 s";
    }
}

/// One column of Table 1, in paper units: γ, scale, gain, χ_rep, r_rep, χ_att, r_att*
/// (the merged rows), then χ_ali, r_ali*, χ_res, r_res.
macro_rules! column {
    ($name:literal, $doc:literal,
     $g:expr, $s:expr, $gain:expr, $crep:expr, $rrep:expr, $catt:expr, $ratt:expr,
     $cali:expr, $rali:expr, $cres:expr, $rres:expr) => {
        Preset {
            name: $name,
            doc: $doc,
            values: &[
                ("gamma", $g / U),
                ("scale", $s * U),
                ("gain", $gain * U * U),
                ("chi_rep", $crep * U),
                ("r_rep", $rrep * U),
                ("chi_att", $catt * U),
                ("r_att_star", $ratt * U),
                ("chi_ali", $cali * U),
                ("r_ali_star", $rali * U),
                ("chi_res", $cres * U),
                ("r_res", $rres * U),
            ],
        }
    };
}

/// Table 1, one preset per behaviour. The merged cells of the rows γ … r_att* are read as
/// {midge, aggregation}, {fruit fly, mating}, {escape, bats}, then locust, phase and
/// phototaxis on their own (docs/model.md, "Paper 002: Table 1").
pub const PRESETS: &[Preset] = &[
    column!(
        "midge",
        "Table 1 midge: an interior midge swarm (100)",
        11.16,
        2.20,
        2.51,
        5.61,
        0.17,
        14.29,
        5.12,
        0.0,
        0.0,
        0.0,
        0.0
    ),
    column!(
        "aggregation",
        "Table 1 aggregation: stationary midge swarming (500, 3,000)",
        11.16,
        2.20,
        2.51,
        5.61,
        0.17,
        14.29,
        5.12,
        5.0,
        1.0,
        0.0,
        0.0
    ),
    column!(
        "fruitfly",
        "Table 1 fruit fly: an interior fruit-fly swarm (100)",
        8.76,
        2.75,
        1.79,
        1.74,
        1.48,
        10.39,
        4.49,
        0.0,
        0.0,
        0.0,
        0.0
    ),
    column!(
        "mating",
        "Table 1 mating: males pursue a female (a `food` target) (100)",
        8.76,
        2.75,
        1.79,
        1.74,
        1.48,
        10.39,
        4.49,
        3.0,
        10.0,
        10.0,
        2.0
    ),
    column!(
        "escape",
        "Table 1 escape: a swarm flees a `predator` target (100)",
        10.21,
        2.20,
        2.51,
        8.0,
        2.0,
        25.0,
        10.0,
        3.0,
        10.0,
        20.0,
        8.0
    ),
    column!(
        "bats",
        "Table 1 bats: echolocating bats in a cave (500)",
        10.21,
        2.20,
        2.51,
        8.0,
        2.0,
        25.0,
        10.0,
        20.0,
        3.0,
        10.0,
        10.0
    ),
    column!(
        "locust",
        "Table 1 locust: migration towards a `food` target (2,000)",
        1.40,
        1.72,
        0.36,
        3.0,
        0.45,
        5.0,
        5.0,
        5.0,
        0.0,
        60.0,
        25.0
    ),
    column!(
        "phase",
        "Table 1 phase transition: ordered flight once dense (20–200)",
        1.40,
        0.72,
        0.10,
        5.0,
        0.2,
        7.0,
        9.2,
        10.0,
        2.2,
        0.0,
        0.0
    ),
    column!(
        "phototaxis",
        "Table 1 phototaxis: moths gather at a `light` target (20–80)",
        1.40,
        0.42,
        1.0,
        3.0,
        0.2,
        8.0,
        10.0,
        0.0,
        0.0,
        1.0,
        5.0
    ),
];
