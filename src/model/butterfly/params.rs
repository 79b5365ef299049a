//! Parameters of the butterfly model (paper 004, Chen et al. 2022) and its two species of
//! Table 2 as presets. SI units throughout; the choices the paper leaves open are marked
//! "not in the paper" and explained in docs/model.md, "Paper 004".

use crate::model::params::Preset;

crate::declare_params! {
    /// Parameters of the butterfly model.
    pub struct ButterflyParams {
        /// Body mass m (Table 2: monarch 0.428 g, read as grams).
        mass: "kg", 0.428e-3, [1e-6, 1.0], "a mass from 0.000001 to 1 kg";
        /// Total area of the four wings (Table 2: monarch 26 cm²), split 55 % fore, 45 % hind.
        wing_area: "m²", 26e-4, [1e-6, 1.0], "an area from 0.000001 to 1 m²";
        /// Wing span tip to tip, giving the blade elements' lever arms (not in the paper: about 6 cm).
        span: "m", 0.06, [1e-3, 2.0], "a span from 0.001 to 2 m";
        /// |u_max| of Eq. 2–3: the speed at which frequency and amplitude reach their ranges (not in the paper).
        max_speed: "m/s", 1.5, [0.05, 50.0], "a speed from 0.05 to 50 m/s";
        /// Lowest flap frequency: a cycle must end for Eq. 2 to be re-evaluated (not in the paper; Eq. 2 tends to 0 at rest).
        min_flap_hz: "Hz", 2.0, [0.1, 100.0], "a frequency from 0.1 to 100 Hz";
        /// k of Eq. 12: how many earlier flapping cycles the sliding window smooths over.
        window: "1", 10.0, [0.0, 10.0], "a whole number of cycles from 0 to 10";
        /// ρ of Eq. 4: air density (not in the paper: sea level, 15 °C).
        air_density: "kg/m³", 1.225, [0.0, 10.0], "a density from 0 to 10 kg/m³";
        /// η of Eq. 7: magnitude of the vortex force, read as an acceleration (m/s² per unit noise slope).
        eta: "m²/s²", 3.66, [0.0, 1000.0], "a gain from 0 to 1000";
        /// gain_x = gain_z of Eq. 7: horizontal size of the vortices (the paper's 22 is in unstated scene units; 22 m leaves butterflies at a flower still).
        gain_xz: "m", 2.0, [1e-3, 1000.0], "a length from 0.001 to 1000 m";
        /// gain_y of Eq. 7: vertical size of the vortices (the paper's 5.5, a quarter of gain_x as in the paper).
        gain_y: "m", 0.5, [1e-3, 1000.0], "a length from 0.001 to 1000 m";
        /// L of Eq. 8: the farthest a butterfly sees an attraction point.
        sense_length: "m", 4.5, [1e-3, 10000.0], "a length from 0.001 to 10000 m";
        /// The force Eq. 8's R(d) stands for at d = 1, divided by m (not in the paper: 16 mN, four times a monarch's weight, so that attraction holds it near its target).
        attraction_force: "N", 16e-3, [0.0, 1.0], "a force from 0 to 1 N";
        /// 1: the nearest other butterfly within L is an attraction point too (chasing, Sec. 7.1); 0: only the targets.
        chase: "1", 0.0, [0.0, 1.0], "0 (off) or 1 (on)";
        /// A gust added to the shot's wind between gust_start and gust_end, x component (not in the paper's equations: its Fig. 10).
        gust_x: "m/s", 0.0, [-100.0, 100.0], "a speed from -100 to 100 m/s";
        /// The gust's y component.
        gust_y: "m/s", 0.0, [-100.0, 100.0], "a speed from -100 to 100 m/s";
        /// The gust's z component.
        gust_z: "m/s", 0.0, [-100.0, 100.0], "a speed from -100 to 100 m/s";
        /// When the gust starts, seconds after the first frame.
        gust_start: "s", 0.0, [0.0, 1e6], "a time from 0 to 1000000 s";
        /// When the gust stops, seconds after the first frame.
        gust_end: "s", 0.0, [0.0, 1e6], "a time from 0 to 1000000 s";
        /// Raindrops hitting one butterfly per second (Fig. 11's rain; 0: dry).
        rain_rate: "1/s", 0.0, [0.0, 1000.0], "a rate from 0 to 1000 per second";
        /// Mean downward velocity one raindrop gives a butterfly (drawn from 0.5 to 1.5 times this).
        rain_kick: "m/s", 0.3, [0.0, 100.0], "a speed from 0 to 100 m/s";
        /// Time constant with which the body's heading follows the direction of travel.
        heading_lag: "s", 0.15, [1e-3, 100.0], "a time constant from 0.001 to 100 s";
    }
}

/// Table 2's species (the first is the default).
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "monarch",
        doc: "Table 2, monarch (Danaus plexippus): wing area 26 cm², mass 0.428 g",
        values: &[],
    },
    Preset {
        name: "swallowtail",
        doc: "Table 2, swallowtail (Pachliopta aristolochiae): wing area 28 cm², mass 0.34 g",
        values: &[("wing_area", 28e-4), ("mass", 0.34e-3)],
    },
];
