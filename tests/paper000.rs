//! Paper 000's comparisons with other models, each measured on its example shot
//! (`examples/paper000_*.toml`) baked in memory: the tests assert the paper's claims on
//! numbers measured from the tracks, and print the numbers (docs/validation.md records
//! them; `cargo test --release --test paper000 -- --nocapture` shows them).

mod common;

use beeswarm::eval::collective::{self, Frames, ShapeOptions};
use common::bake_example as bake;
use std::collections::BTreeMap;

/// The frames from `from_s` seconds on (the swarm has left its spawn box by then).
fn after(f: &Frames, from_s: f64) -> Frames {
    let k = (from_s * f.fps()).round() as usize;
    Frames::new(
        f.fps(),
        f.positions()[k..].to_vec(),
        f.velocities()[k..].to_vec(),
    )
    .unwrap()
}

#[test]
fn fig7_bees_touch_far_less_than_curl_noise_agents_in_a_dense_cloud() {
    let swarms = bake("paper000_fig7_contacts.toml");
    // Bodies closer than two capsule radii (2 mm each, the shot's default body).
    let contact = 2.0 * 0.002;
    let bees = collective::contacts(&swarms["bees"], contact);
    let curl = collective::contacts(&swarms["curl"], contact);
    println!(
        "Fig. 7: contact-frames bees {} curl {}; new contacts per agent per second bees {:.4} curl {:.4}",
        bees.contact_frames,
        curl.contact_frames,
        bees.new_per_agent_second.unwrap(),
        curl.new_per_agent_second.unwrap()
    );
    // Curl agents, blind to bodies, do touch: the comparison is not vacuous.
    assert!(
        curl.contact_frames >= 100,
        "curl contacts {}",
        curl.contact_frames
    );
    assert!(
        bees.contact_frames * 4 < curl.contact_frames,
        "bees {} vs curl {} contact-frames",
        bees.contact_frames,
        curl.contact_frames
    );
    assert!(bees.new_per_agent_second.unwrap() * 4.0 < curl.new_per_agent_second.unwrap());
}

#[test]
fn fig9_bees_are_low_aligned_like_brownian_motion_not_like_boids() {
    let swarms = bake("paper000_fig9_alignment.toml");
    let mut agreement = BTreeMap::new();
    let mut polarisation = BTreeMap::new();
    for (name, f) in &swarms {
        let a = collective::alignment(&after(f, 2.0));
        agreement.insert(name.as_str(), a.neighbour_agreement.unwrap());
        polarisation.insert(name.as_str(), a.polarisation.unwrap());
    }
    println!(
        "Fig. 9: nearest-neighbour heading agreement {agreement:?}; polarisation {polarisation:?}"
    );
    // Boids align with their neighbours: the baseline the bees must differ from.
    assert!(agreement["boids"] > 0.6, "boids {agreement:?}");
    // Bees: far below boids, near Brownian motion.
    assert!(
        agreement["bees"] < 0.5 * agreement["boids"],
        "{agreement:?}"
    );
    assert!(
        (agreement["bees"] - agreement["brownian"]).abs() < 0.3,
        "{agreement:?}"
    );
    // Nor does the swarm as a whole fly one way.
    assert!(polarisation["bees"] < 0.3, "{polarisation:?}");
}

#[test]
fn fig5_bees_fly_smooth_zigzags_where_curl_noise_turns_abruptly() {
    let swarms = bake("paper000_fig5_trajectories.toml");
    let opts = ShapeOptions::default();
    let bees = collective::trajectory_shape(&after(&swarms["bees"], 1.0), &opts);
    let curl = collective::trajectory_shape(&after(&swarms["curl"], 1.0), &opts);
    let (bw, cw) = (
        bees.median_turn_rate.unwrap(),
        curl.median_turn_rate.unwrap(),
    );
    let (ba, ca) = (
        bees.median_angular_acceleration.unwrap(),
        curl.median_angular_acceleration.unwrap(),
    );
    let peak = bees.median_peak_frequency.unwrap();
    println!(
        "Fig. 5: median turn rate bees {bw:.3} curl {cw:.3} rad/s; median angular acceleration \
         bees {ba:.2} curl {ca:.2} rad/s²; bees' yaw-rate peak {peak:.3} Hz (curl {:?}); \
         zigzags per second bees {:.2} curl {:.2}",
        curl.median_peak_frequency,
        bees.zigzags_per_second.unwrap(),
        curl.zigzags_per_second.unwrap()
    );
    // Smooth against abrupt: the bees' flight direction turns and changes its turning far
    // more gently than the curl agents'.
    assert!(bw * 3.0 < cw, "turn rate bees {bw} curl {cw}");
    assert!(ba * 3.0 < ca, "angular acceleration bees {ba} curl {ca}");
    // The zigzag: the bees' heading swings with the body's roll oscillation (Eq. 4, period
    // 2 × 91.775 time units of the preset's `oscillation_time_unit`).
    let unit = beeswarm::model::BeeParams::nest().oscillation_time_unit;
    let roll_hz = 1.0 / (beeswarm::model::bee::oscillation::ROLL_PERIOD * unit);
    assert!(
        (peak - roll_hz).abs() < 0.25 * roll_hz,
        "yaw-rate peak {peak} Hz, roll {roll_hz} Hz"
    );
}

#[test]
fn fig1a_a_lone_bee_bobs_and_sways_visibly_at_the_paper_s_frequencies() {
    let example = "paper000_fig1a_oscillation.toml";
    let swarms = bake(example);
    let f = &swarms["bee"];
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(example);
    let length = beeswarm::shot::load(&path).unwrap().swarms[0].bee.length as f64;
    let p: Vec<_> = f.positions().iter().map(|fr| fr[0]).collect();
    let (bob, sway) = common::bob_and_sway_series(&p, f.fps());
    let peak = |x: &[f64]| collective::peak_frequency(&collective::power_spectrum(x, f.fps()));
    let (bob_hz, sway_hz) = (peak(&bob).unwrap(), peak(&sway).unwrap());
    let (bob_bl, sway_bl) = (common::rms(&bob) / length, common::rms(&sway) / length);
    let unit = beeswarm::model::BeeParams::nest().oscillation_time_unit;
    let pitch_hz = 1.0 / (beeswarm::model::bee::oscillation::PITCH_PERIOD * unit);
    let roll_hz = 1.0 / (beeswarm::model::bee::oscillation::ROLL_PERIOD * unit);
    println!(
        "Fig. 1a: bob {bob_bl:.3} body lengths rms at {bob_hz:.2} Hz (Eq. 3: {pitch_hz:.2} Hz), \
         sway {sway_bl:.3} body lengths rms at {sway_hz:.2} Hz (Eq. 4: {roll_hz:.2} Hz), at {} fps",
        f.fps()
    );
    // The bob follows the pitch of Eq. 3 and the sway the roll of Eq. 4, each sampled at
    // four or more frames per cycle at the shot's 24 fps, so both read on screen.
    let bin = f.fps() / bob.len().next_power_of_two() as f64;
    assert!((bob_hz - pitch_hz).abs() <= 1.5 * bin, "bob at {bob_hz} Hz");
    assert!(
        (sway_hz - roll_hz).abs() <= 1.5 * bin,
        "sway at {sway_hz} Hz"
    );
    assert!(pitch_hz * 4.0 <= f.fps() && roll_hz * 4.0 <= f.fps());
    // Visible, not wild: about a tenth of a body length of bob, under one and a half body
    // lengths of sway (docs/model.md, Eqs. 3–4).
    assert!((0.07..0.2).contains(&bob_bl), "bob {bob_bl} body lengths");
    assert!((0.4..1.5).contains(&sway_bl), "sway {sway_bl} body lengths");
}
