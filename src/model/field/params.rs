//! Parameters of paper 001's field model, named as its Table 1 names them, with the
//! table's values as presets. Lengths in metres (the paper states no unit; docs/model.md,
//! "Paper 001", says why metres fit its values), speeds in m/s.

use crate::model::Preset;

crate::declare_params! {
    /// Parameters of the field model (paper 001).
    pub struct FieldParams {
        /// Table 1 `scale`: size of the noise lattice, P(x / scale). Larger: wider eddies.
        scale: "m", 0.4, [1e-3, 1000.0], "a noise scale from 0.001 to 1000 m";
        /// Table 1 `gain`: magnitude of the noise potentials P. Larger: more intense random flight (about gain / scale m/s).
        gain: "m²/s", 0.25, [0.0, 1000.0], "a gain from 0 to 1000";
        /// Table 1 `s0`: the inherent speed along the path field (Eq. 8).
        s0: "m/s", 1.5, [0.0, 100.0], "a speed from 0 to 100 m/s";
        /// Side l of the path field's cells (Table 1 gives grid dimensions: the domain is the swarm's bounds box).
        cell: "m", 0.1, [1e-3, 100.0], "a cell size from 0.001 to 100 m";
        /// d0 of Eq. 2: width of the boundary ramp (the paper: one cell).
        d0: "m", 0.1, [1e-4, 100.0], "a distance from 0.0001 to 100 m";
        /// Minimum distance enforcement: agents closer than this are pushed apart (0: off).
        d_min: "m", 0.02, [0.0, 10.0], "a distance from 0 to 10 m";
        /// Radius of the goal area around each target: inside it the path field is zero and the noise alone moves agents.
        goal_radius: "m", 1.0, [1e-3, 1000.0], "a radius from 0.001 to 1000 m";
        /// The path field is solved again once a goal has moved this far since the last solve (the paper: per user manipulation).
        resolve_distance: "m", 0.5, [1e-3, 1000.0], "a distance from 0.001 to 1000 m";
        /// A of Eq. 4: cost weight of path length.
        cost_length: "1", 0.6, [1e-3, 100.0], "a weight from 0.001 to 100";
        /// B of Eq. 4: cost weight of the repulsion near obstacles.
        cost_repulsion: "1", 0.4, [0.0, 100.0], "a weight from 0 to 100";
        /// Largest extra speed towards the nearest target (phototaxis); each agent draws its own in [0, taxis_speed].
        taxis_speed: "m/s", 0.0, [0.0, 100.0], "a speed from 0 to 100 m/s";
        /// Time constant of the smoothed velocity the body heads along.
        heading_lag: "s", 0.15, [1e-3, 100.0], "a time constant from 0.001 to 100 s";
        /// Largest bank into a turn.
        bank_max_deg: "deg", 45.0, [0.0, 80.0], "an angle from 0 to 80 degrees";
    }
}

/// Table 1's five scenes. Cell sizes make the examples' domains (their swarms' bounds)
/// the table's grids; d0 is one cell, as the paper sets it.
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "two_blocks",
        doc: "Table 1 two blocks: scale 0.4, gain 0.25, s0 1.5; 60×40×112 cells of 0.1 m",
        values: &[],
    },
    Preset {
        name: "chasing",
        doc: "Table 1 chasing: scale 0.4, gain 0.25, s0 1.5; 80×40×120 cells of 0.1 m",
        values: &[("goal_radius", 0.8)],
    },
    Preset {
        name: "aggregation",
        doc: "Table 1 aggregation: scale 2.0, gain 0.5, s0 2.5; 20×20×20 cells of 0.25 m",
        values: &[
            ("scale", 2.0),
            ("gain", 0.5),
            ("s0", 2.5),
            ("cell", 0.25),
            ("d0", 0.25),
            ("goal_radius", 1.5),
        ],
    },
    Preset {
        name: "phototaxis",
        doc: "Table 1 phototaxis: scale 0.2, gain 0.7, s0 2.5; 100×100×100 cells of 0.05 m; a pull towards the light",
        values: &[
            ("scale", 0.2),
            ("gain", 0.7),
            ("s0", 2.5),
            ("cell", 0.05),
            ("d0", 0.05),
            ("goal_radius", 0.6),
            ("taxis_speed", 0.6),
        ],
    },
    Preset {
        name: "locusts",
        doc: "Table 1 locusts: scale 0.6, gain 1.0, s0 8.0; 120×50×55 cells of 1 m",
        values: &[
            ("scale", 0.6),
            ("gain", 1.0),
            ("s0", 8.0),
            ("cell", 1.0),
            ("d0", 1.0),
            ("d_min", 0.1),
            ("goal_radius", 8.0),
        ],
    },
];
