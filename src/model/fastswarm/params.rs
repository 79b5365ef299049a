//! Parameters of the FASTSWARM model (paper 003): the energy weights of Table 1, ρ, and
//! the zone radii the paper does not give (our choices, docs/model.md "Paper 003").

use crate::model::params::Preset;

crate::declare_params! {
    /// Parameters of the FASTSWARM model.
    pub struct FastswarmParams {
        /// w_rep (Eq. 4): weight of repulsion from neighbours closer than d_rep.
        w_rep: "1", 1.0, [0.0, 100.0], "a weight from 0 to 100";
        /// w_oa (Eq. 6): weight of attraction to neighbours between d_att1 and d_att2.
        w_oa: "1", 1.0, [0.0, 100.0], "a weight from 0 to 100";
        /// w_cos (Eq. 7): weight of heading towards the swarm centre (the centre of the swarm's bounds).
        w_cos: "1", 0.05, [0.0, 100.0], "a weight from 0 to 100";
        /// w_dir (Eq. 9): weight of keeping the current direction.
        w_dir: "1", 1.0, [0.0, 100.0], "a weight from 0 to 100";
        /// w_acc (Eq. 10): weight of acceleration continuity with the recorded sample.
        w_acc: "1", 1.0, [0.0, 100.0], "a weight from 0 to 100";
        /// w_env (Eq. 11–12): weight of the response to the swarm's targets (attraction, or startle when danger_distance > 0).
        w_env: "1", 0.0, [0.0, 100.0], "a weight from 0 to 100";
        /// w_n (Eq. 13): weight of following the curl-noise direction.
        w_n: "1", 0.2, [0.0, 100.0], "a weight from 0 to 100";
        /// w_user (Eq. 14–15): weight of heading to the next key point; above 0 the swarm's targets are key points.
        w_user: "1", 0.0, [0.0, 100.0], "a weight from 0 to 100";
        /// ρ: scale of every exponential energy (Sec. 5: 2.5).
        rho: "1", 2.5, [0.0, 20.0], "a scale from 0 to 20";
        /// d_rep (Eq. 4): radius of the repulsion zone.
        d_rep: "m", 0.03, [1e-4, 10.0], "a distance from 0.0001 to 10 m";
        /// d_att1 (Eq. 6): inner radius of the attraction zone.
        d_att1: "m", 0.08, [1e-4, 10.0], "a distance from 0.0001 to 10 m";
        /// d_att2 (Eq. 6): outer radius of the attraction zone (how far an agent looks).
        d_att2: "m", 0.3, [1e-4, 10.0], "a distance from 0.0001 to 10 m";
        /// d_danger (Eq. 12): a target this close startles (0: targets attract instead).
        danger_distance: "m", 0.0, [0.0, 100.0], "a distance from 0 to 100 m";
        /// A key point counts as reached within this distance (Eq. 15).
        arrival_radius: "m", 0.1, [1e-3, 100.0], "a distance from 0.001 to 100 m";
        /// Edge of the curl-noise lattice giving the noise direction (Eq. 13).
        noise_cell: "m", 0.3, [1e-3, 100.0], "a noise cell size from 0.001 to 100 m";
    }
}

/// Table 1 of paper 003, one preset per scenario (the first is the default).
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "aggregation",
        doc: "Table 1, aggregation (37 / 300 agents): w = 1, 1, 0.05, 1, 1, 0, 0.2, 0",
        values: &[],
    },
    Preset {
        name: "mating",
        doc: "Table 1, mating: attracted to the swarm's targets (a female), w_env = 1, w_n = 0.5",
        values: &[("w_env", 1.0), ("w_n", 0.5)],
    },
    Preset {
        name: "escaping",
        doc: "Table 1, escaping: startled by targets within 0.3 m (w_env = 2, w_cos = 0.2, w_n = 0.3); in danger w_oa = w_cos = 0",
        values: &[
            ("w_cos", 0.2),
            ("w_env", 2.0),
            ("w_n", 0.3),
            ("danger_distance", 0.3),
        ],
    },
    Preset {
        name: "shape",
        doc: "Table 1, shape constraint (heart / star): the swarm's targets are key points, w = 1, 0.5, 0, 1, 1, 0, 1, 1",
        values: &[("w_oa", 0.5), ("w_cos", 0.0), ("w_n", 1.0), ("w_user", 1.0)],
    },
];
