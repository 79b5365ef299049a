//! Throughput of the USDA writer on recorded arrays (driven by `scripts/bench_usda.py`,
//! which times usd-core on the same arrays).
//!
//! `cargo bench --bench usda_writer -- INPUT OUT_DIR BEES FRAMES`
//!
//! INPUT is raw little-endian f32, frame after frame; each frame is, for all bees in
//! turn per block: positions (3), velocities (3), orientations (x, y, z, w), angular
//! velocities (3), scale, pitch, roll, sway. Prints one JSON line.

use beeswarm::export::{Format, OutputOptions, open_writer};
use beeswarm::sim::{CacheMeta, Frame, SwarmFrame, SwarmMeta};
use glam::{Quat, Vec3};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.is_empty() {
        // `cargo test --all-targets` / `cargo bench` without arguments: nothing to measure.
        eprintln!("usda_writer: run through scripts/bench_usda.py (INPUT OUT_DIR BEES FRAMES)");
        return;
    }
    let [input, out, bees, frames] = &args[..] else {
        eprintln!("usage: usda_writer INPUT OUT_DIR BEES FRAMES");
        std::process::exit(2);
    };
    let (n, f): (usize, usize) = (bees.parse().unwrap(), frames.parse().unwrap());
    let raw = std::fs::read(input).expect("input");
    let floats: Vec<f32> = raw
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    assert_eq!(floats.len(), n * f * 17, "input size");
    let v3 = |s: &[f32]| s.chunks_exact(3).map(Vec3::from_slice).collect::<Vec<_>>();
    let frames: Vec<SwarmFrame> = floats
        .chunks_exact(n * 17)
        .map(|fr| {
            let mut at = 0;
            let mut take = |k: usize| {
                at += k * n;
                &fr[at - k * n..at]
            };
            let position = v3(take(3));
            let velocity = v3(take(3));
            let orientation: Vec<Quat> = take(4).chunks_exact(4).map(Quat::from_slice).collect();
            let angular_velocity_deg = v3(take(3));
            SwarmFrame {
                ids: (0..n as u64).collect(),
                heading: orientation.clone(),
                position,
                velocity,
                orientation,
                angular_velocity_deg,
                scale: take(1).to_vec(),
                // pitch, roll, sway
                channels: (0..3).map(|_| take(1).to_vec()).collect(),
            }
        })
        .collect();
    let meta = CacheMeta {
        shot_name: "bench".into(),
        fps: 24.0,
        frame_start: 1,
        frame_end: f as i32,
        seed: 0,
        tool_version: env!("CARGO_PKG_VERSION").into(),
        swarms: vec![SwarmMeta {
            name: "bees".into(),
            count: n,
            species: &beeswarm::species::HONEYBEE,
            channels: beeswarm::species::BEE_CHANNELS.to_vec(),
            body_length_m: 0.012,
            wing_beat_hz: 230.0,
            hidden: None,
        }],
    };
    let dir = std::path::Path::new(out);
    std::fs::create_dir_all(dir).unwrap();

    let t0 = Instant::now();
    let mut w = open_writer(Format::Usda, &meta, dir, &OutputOptions::default()).unwrap();
    for (i, s) in frames.iter().enumerate() {
        w.write_frame(&Frame {
            frame: i as i32 + 1,
            time: i as f64 / 24.0,
            swarms: std::slice::from_ref(s),
        })
        .unwrap();
    }
    let t1 = Instant::now();
    let paths = beeswarm::atomic::commit_all(w.finish().unwrap()).unwrap();
    let t2 = Instant::now();
    let bytes = std::fs::metadata(&paths[0]).unwrap().len();
    println!(
        "{{\"seconds\":{:.4},\"frames_seconds\":{:.4},\"finish_seconds\":{:.4},\"bytes\":{bytes},\"threads\":{},\"path\":\"{}\"}}",
        (t2 - t0).as_secs_f64(),
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        rayon::current_num_threads(),
        paths[0].display()
    );
}
