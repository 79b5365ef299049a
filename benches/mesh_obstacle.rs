//! Cost of a mesh obstacle (issue 22): bee-steps per second of a swarm around a closed
//! triangle mesh against the same shot around the analytic sphere it approximates and
//! with no obstacle; the mesh's build time and memory; and the cost of one query.
//!
//! `cargo bench --bench mesh_obstacle -- BEES FRAMES TRIANGLES [none|sphere|mesh]`
//! (e.g. `10000 24 100000`; set RAYON_NUM_THREADS for a fixed thread count). Prints one
//! JSON line. Timings are wall-clock and vary with the machine and its load. With a last
//! argument only that shot is simulated (no query timings): for counting instructions,
//! which a loaded machine does not disturb, e.g.
//! `RAYON_NUM_THREADS=1 valgrind --tool=callgrind target/release/deps/mesh_obstacle-* 10000 8 100000 mesh`
//! less the same run with 2 frames (loading left out; a `--toggle-collect` on the
//! simulation's functions counts only the calling thread's share, as the steps run on
//! rayon's worker thread), and
//! the same with `none`: the ratio of the differences is the mesh's cost.
//! `turning` is the same ball on keys turning it 90° about its centre over the shot (the
//! same obstacle to the bees, so the difference to `mesh` is the cost of a moving mesh's
//! pose), `moving` the ball also travelling 0.5 m along +X.

use beeswarm::geometry::{self, Shape};
use beeswarm::sim::Simulation;
use glam::Vec3;
use std::fmt::Write as _;
use std::time::Instant;

/// A UV sphere of radius 1 about the origin as OBJ text, about `triangles` triangles.
fn sphere_obj(triangles: usize) -> String {
    let rings = ((triangles as f64 / 4.0).sqrt().round() as u32).max(3);
    let segments = 2 * rings;
    let mut s = String::from("v 0 1 0\n");
    for i in 1..rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let ph = std::f64::consts::TAU * j as f64 / segments as f64;
            let _ = writeln!(
                s,
                "v {} {} {}",
                th.sin() * ph.cos(),
                th.cos(),
                th.sin() * ph.sin()
            );
        }
    }
    s += "v 0 -1 0\n";
    let bottom = 2 + (rings - 1) * segments;
    let at = |i: u32, j: u32| 2 + (i - 1) * segments + j % segments;
    for j in 0..segments {
        let _ = writeln!(s, "f 1 {} {}", at(1, j + 1), at(1, j));
        let _ = writeln!(
            s,
            "f {bottom} {} {}",
            at(rings - 1, j),
            at(rings - 1, j + 1)
        );
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            let _ = writeln!(
                s,
                "f {} {} {} {}",
                at(i, j),
                at(i, j + 1),
                at(i + 1, j + 1),
                at(i + 1, j)
            );
        }
    }
    s
}

/// Bee-steps per second over the whole shot.
fn steps_per_second(shot: &beeswarm::shot::Shot) -> f64 {
    let mut sim = Simulation::new(shot);
    let t = Instant::now();
    while !sim.done() {
        sim.advance();
    }
    let steps = shot.bee_count() * (shot.frame_count() - 1) * shot.substeps as usize;
    steps as f64 / t.elapsed().as_secs_f64()
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.is_empty() {
        // `cargo test --all-targets` / `cargo bench` without arguments: nothing to measure.
        eprintln!("mesh_obstacle: give BEES FRAMES TRIANGLES, e.g. 10000 24 100000");
        return;
    }
    let (bees, frames, triangles, only) = match &args[..] {
        [b, f, t] => (b, f, t, None),
        [b, f, t, o] if ["none", "sphere", "mesh", "turning", "moving"].contains(&o.as_str()) => {
            (b, f, t, Some(o.as_str()))
        }
        _ => {
            eprintln!(
                "usage: mesh_obstacle BEES FRAMES TRIANGLES [none|sphere|mesh|turning|moving]"
            );
            std::process::exit(2);
        }
    };
    let (bees, frames, triangles): (usize, usize, usize) = (
        bees.parse().unwrap(),
        frames.parse().unwrap(),
        triangles.parse().unwrap(),
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ball.obj"), sphere_obj(triangles)).unwrap();
    // Bees fill a 4 m box around a 1 m-radius ball (those spawned inside start on it).
    let shot_src = |obstacle: &str| {
        format!(
            "[scene]\nframes = [1, {}]\n[[swarm]]\ncount = {bees}\n\
             spawn = {{ center = [0, 1, 0], size = [4, 4, 4] }}\n{obstacle}",
            frames + 1
        )
    };
    let parse = |src: &str| {
        beeswarm::shot::parse(src, &dir.path().join("b.toml"), dir.path()).expect("shot")
    };
    let t = Instant::now();
    let with_mesh = parse(&shot_src(
        "[[obstacle]]\ntype = \"mesh\"\nfile = \"ball.obj\"\nposition = [0, 1, 0]\n",
    ));
    let load_s = t.elapsed().as_secs_f64();
    let Shape::Mesh { mesh, .. } = &with_mesh.obstacles[0].shape else {
        unreachable!()
    };
    let with_sphere = parse(&shot_src(
        "[[obstacle]]\ntype = \"sphere\"\ncenter = [0, 1, 0]\nradius = 1\n",
    ));
    let without = parse(&shot_src(""));
    if let Some(only) = only {
        let keyed = |to: &str| {
            parse(&shot_src(&format!(
                "[[obstacle]]\ntype = \"mesh\"\nfile = \"ball.obj\"\nkeys = [{{ frame = 1, position = [0, 1, 0] }}, \
                 {{ frame = {}, position = {to}, rotation = [0, 90, 0] }}]\n",
                frames + 1
            )))
        };
        let turning = keyed("[0, 1, 0]");
        let moving = keyed("[0.5, 1, 0]");
        let shot = match only {
            "none" => &without,
            "sphere" => &with_sphere,
            "turning" => &turning,
            "moving" => &moving,
            _ => &with_mesh,
        };
        println!(
            "{{\"only\": \"{only}\", \"bees\": {bees}, \"frames\": {frames}, \"steps_per_s\": {:.0}}}",
            steps_per_second(shot)
        );
        return;
    }

    // One query: points spread through the bees' box, deterministic.
    let n = 1_000_000;
    let pts: Vec<Vec3> = geometry::fibonacci_sphere(n)
        .enumerate()
        .map(|(k, d)| Vec3::new(0.0, 1.0, 0.0) + d * (0.5 + 2.5 * (k % 97) as f32 / 97.0))
        .collect();
    let t = Instant::now();
    let mut sum = 0.0f64;
    for p in &pts {
        sum += mesh.query(*p).distance as f64;
    }
    let query_ns = t.elapsed().as_secs_f64() * 1e9 / n as f64;
    let sphere = with_sphere.obstacles[0].shape.clone();
    let t = Instant::now();
    for p in &pts {
        sum += geometry::query(&sphere, *p).distance as f64;
    }
    let sphere_query_ns = t.elapsed().as_secs_f64() * 1e9 / n as f64;

    // By distance from the ball's centre (its surface at 1 m).
    let mut bands = String::new();
    for r in [0.05f32, 0.5, 0.9, 0.99, 1.01, 1.1, 1.5, 3.0] {
        let ps: Vec<Vec3> = geometry::fibonacci_sphere(10_000)
            .map(|d| Vec3::new(0.0, 1.0, 0.0) + d * r)
            .collect();
        let t = Instant::now();
        for p in &ps {
            sum += mesh.query(*p).distance as f64;
        }
        let _ = write!(
            bands,
            "{}\"{r}\": {:.0}",
            if bands.is_empty() { "" } else { ", " },
            t.elapsed().as_secs_f64() * 1e9 / ps.len() as f64
        );
    }
    let none = steps_per_second(&without);
    let ball = steps_per_second(&with_sphere);
    let meshed = steps_per_second(&with_mesh);
    println!(
        "{{\"bees\": {bees}, \"frames\": {frames}, \"substeps\": {}, \"triangles\": {}, \
         \"threads\": {}, \"mesh_load_s\": {load_s:.3}, \"mesh_memory_mb\": {:.1}, \
         \"mesh_query_ns\": {query_ns:.0}, \"sphere_query_ns\": {sphere_query_ns:.1}, \"mesh_query_ns_at_radius\": {{{bands}}}, \
         \"steps_per_s_no_obstacle\": {none:.0}, \"steps_per_s_sphere\": {ball:.0}, \
         \"steps_per_s_mesh\": {meshed:.0}, \"mesh_vs_none\": {:.3}, \"mesh_vs_sphere\": {:.3}, \
         \"checksum\": {sum:.3}}}",
        with_mesh.substeps,
        mesh.triangle_count(),
        rayon::current_num_threads(),
        mesh.memory_bytes() as f64 / 1e6,
        meshed / none,
        meshed / ball
    );
}
