//! Paper 001's scenes (Wang et al. 2014, Table 1), each baked in memory from its example
//! shot (`examples/paper001_*.toml`): the tests assert the paper's claims on numbers
//! measured from the tracks and print them (`cargo test --release --test paper001 --
//! --nocapture`). The ignored test `benchmark` times every scene and the path field's
//! build for the README's performance table (`-- --ignored --nocapture`; never asserted).

use beeswarm::geometry::{self, Shape};
use beeswarm::model::field::path_field::{CostMap, Lattice, PathField};
use beeswarm::shot::Shot;
use beeswarm::sim::Simulation;
use glam::Vec3;
use std::path::Path;
use std::time::Instant;

fn load(example: &str) -> Shot {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(example);
    beeswarm::shot::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// One swarm's track: positions and the `mde` channel per frame.
struct Track {
    pos: Vec<Vec<Vec3>>,
    mde: Vec<Vec<f32>>,
}

impl Track {
    /// Mean share of agents minimum distance enforcement moved per frame (Table 1's last row).
    fn mde_share(&self) -> f64 {
        let frames = &self.mde[1..];
        frames
            .iter()
            .map(|f| f.iter().filter(|&&x| x > 0.5).count() as f64 / f.len() as f64)
            .sum::<f64>()
            / frames.len() as f64
    }
}

/// Bakes the first swarm of a shot in memory, checking every value is finite.
fn bake(shot: &Shot) -> Track {
    let mut sim = Simulation::new(shot);
    let mut track = Track {
        pos: Vec::new(),
        mde: Vec::new(),
    };
    loop {
        let s = &sim.record()[0];
        assert!(s.position.iter().all(|p| p.is_finite()));
        assert!(s.channels.iter().flatten().all(|x| x.is_finite()));
        track.pos.push(s.position.clone());
        let c = sim.meta().swarms[0].channel("mde").expect("mde channel");
        track.mde.push(s.channels[c].clone());
        if sim.done() {
            break;
        }
        sim.advance();
    }
    track
}

/// The smallest signed distance from any agent centre to any of `shapes` over all frames.
fn deepest(track: &Track, shapes: &[Shape]) -> f32 {
    track
        .pos
        .iter()
        .flatten()
        .map(|p| {
            shapes
                .iter()
                .map(|s| geometry::signed_distance(s, *p))
                .fold(f32::INFINITY, f32::min)
        })
        .fold(f32::INFINITY, f32::min)
}

fn obstacles(shot: &Shot) -> Vec<Shape> {
    shot.obstacles.iter().map(|o| o.shape.clone()).collect()
}

fn share(ps: &[Vec3], f: impl Fn(Vec3) -> bool) -> f64 {
    ps.iter().filter(|p| f(**p)).count() as f64 / ps.len() as f64
}

#[test]
fn two_blocks_the_swarm_passes_the_blocks_and_never_enters_them() {
    let shot = load("paper001_two_blocks.toml");
    let t = bake(&shot);
    let deepest = deepest(&t, &obstacles(&shot));
    let last = t.pos.last().unwrap();
    // The goal side: beyond the blocks' far faces (z = 1).
    let crossed = share(last, |p| p.z > 1.0);
    let in_goal = share(last, |p| p.distance(Vec3::new(0.0, 2.0, 4.5)) < 1.5);
    println!(
        "two blocks: {} agents, {:.1} % past the blocks after {:.0} s, {:.1} % within 1.5 m of the goal; nearest approach to a block {deepest:.4} m; MDE {:.3} % of agents per frame (paper 0.36 %)",
        last.len(),
        100.0 * crossed,
        (t.pos.len() - 1) as f64 / shot.fps,
        100.0 * in_goal,
        100.0 * t.mde_share()
    );
    assert_eq!(last.len(), 300);
    assert!(deepest >= 0.0, "an agent centre {deepest} m inside a block");
    assert!(crossed >= 0.95, "{crossed}");
    // They start 4 m before the blocks: none is past them at first.
    assert_eq!(share(&t.pos[0], |p| p.z > 1.0), 0.0);
}

#[test]
fn chasing_the_swarm_follows_the_moving_ball_and_never_enters_it() {
    let shot = load("paper001_chasing.toml");
    let t = bake(&shot);
    let ball = &shot.targets[0];
    let radius = ball.radius;
    let frame = |k: usize| shot.frame_start as f64 + k as f64;
    // The ball is a boundary: no agent centre ever inside it where the world had it when
    // the agents last moved (at the start of a frame's last substep; during a drag the
    // ball moves 0.12 m per substep).
    let mut nearest = f32::INFINITY;
    let last_substep = 1.0 - 1.0 / shot.substeps as f64;
    for (k, ps) in t.pos.iter().enumerate().skip(1) {
        let c = ball.position_at(frame(k - 1) + last_substep);
        for p in ps {
            nearest = nearest.min(p.distance(c) - radius);
        }
    }
    let median_distance = |k: usize| {
        let c = ball.position_at(frame(k));
        let mut d: Vec<f32> = t.pos[k].iter().map(|p| p.distance(c)).collect();
        d.sort_by(f32::total_cmp);
        d[d.len() / 2]
    };
    // Just after each drag ends the swarm is still where the ball was; 2 s later it is
    // around the ball again.
    let mut followed = Vec::new();
    for end in [108usize, 204] {
        let (at_drop, later) = (median_distance(end - 1), median_distance(end - 1 + 48));
        followed.push((at_drop, later));
    }
    let (start, before) = (median_distance(0), median_distance(83));
    println!(
        "chasing: median distance to the ball {start:.2} m at start, {before:.2} m before the first drag; after each drag {} ; nearest approach to the ball's surface {nearest:.4} m; obstacles {:.4} m; MDE {:.3} % per frame (paper 0.54 %)",
        followed
            .iter()
            .map(|(a, b)| format!("{a:.2} m → {b:.2} m 2 s later"))
            .collect::<Vec<_>>()
            .join(", "),
        deepest(&t, &obstacles(&shot)),
        100.0 * t.mde_share()
    );
    assert!(nearest >= 0.0, "{nearest}");
    assert!(deepest(&t, &obstacles(&shot)) >= 0.0);
    assert!(before < 0.4 * start, "{before} vs {start}");
    for (at_drop, later) in followed {
        assert!(at_drop > 2.5, "the ball moved away: {at_drop}");
        assert!(later < 1.2, "the swarm caught up: {later}");
    }
}

#[test]
fn aggregation_the_cloud_holds_around_the_goal_without_collapsing() {
    let shot = load("paper001_aggregation.toml");
    let t = bake(&shot);
    let goal = Vec3::new(0.0, 2.5, 0.0);
    let (mut worst_held, mut smallest_rms, mut largest_rms) = (1.0f64, f32::INFINITY, 0.0f32);
    for ps in &t.pos[24..] {
        worst_held = worst_held.min(share(ps, |p| p.distance(goal) < 2.0));
        let rms =
            (ps.iter().map(|p| p.distance_squared(goal)).sum::<f32>() / ps.len() as f32).sqrt();
        smallest_rms = smallest_rms.min(rms);
        largest_rms = largest_rms.max(rms);
    }
    let rms0 = (t.pos[0]
        .iter()
        .map(|p| p.distance_squared(goal))
        .sum::<f32>()
        / t.pos[0].len() as f32)
        .sqrt();
    // Agents that moved: the cloud churns, it does not freeze.
    let moved = t.pos[0]
        .iter()
        .zip(t.pos.last().unwrap())
        .map(|(a, b)| a.distance(*b))
        .sum::<f32>()
        / t.pos[0].len() as f32;
    println!(
        "aggregation: {} agents; from 1 s on at least {:.1} % within 2 m of the goal; RMS radius {rms0:.2} m at start, {smallest_rms:.2}–{largest_rms:.2} m after; mean displacement over the shot {moved:.2} m; MDE {:.3} % per frame (paper 0.03 %)",
        t.pos[0].len(),
        100.0 * worst_held,
        100.0 * t.mde_share()
    );
    assert_eq!(t.pos[0].len(), 1000);
    assert!(worst_held >= 0.95, "{worst_held}");
    assert!(
        smallest_rms > 0.6 * rms0,
        "collapsed: {smallest_rms} vs {rms0}"
    );
    assert!(moved > 0.5, "{moved}");
}

#[test]
fn phototaxis_moths_gather_at_the_light_and_never_enter_the_lamp() {
    let shot = load("paper001_phototaxis.toml");
    let t = bake(&shot);
    let light = Vec3::new(0.0, 2.6, 0.0);
    let near = |ps: &Vec<Vec3>| share(ps, |p| p.distance(light) < 1.0);
    let (first, last) = (near(&t.pos[0]), near(t.pos.last().unwrap()));
    let deepest = deepest(&t, &obstacles(&shot));
    println!(
        "phototaxis: within 1 m of the light {:.1} % at start, {:.1} % after {:.0} s; nearest approach to the lamp {deepest:.4} m; MDE {:.3} % per frame (paper 0.01 %)",
        100.0 * first,
        100.0 * last,
        (t.pos.len() - 1) as f64 / shot.fps,
        100.0 * t.mde_share()
    );
    assert!(first < 0.2, "{first}");
    assert!(last >= 0.8, "{last}");
    assert!(deepest >= 0.0, "{deepest}");
}

#[test]
fn locusts_cross_the_landscape_and_never_enter_an_obstacle() {
    let shot = load("paper001_locusts.toml");
    let t = bake(&shot);
    let deepest = deepest(&t, &obstacles(&shot));
    let crossed = share(t.pos.last().unwrap(), |p| p.x > 100.0);
    println!(
        "locusts: {} agents, {:.1} % beyond x = 100 m after {:.0} s; nearest approach to an obstacle {deepest:.4} m; MDE {:.3} % per frame (paper 0.68 %)",
        t.pos[0].len(),
        100.0 * crossed,
        (t.pos.len() - 1) as f64 / shot.fps,
        100.0 * t.mde_share()
    );
    assert_eq!(t.pos[0].len(), 5000);
    assert!(crossed >= 0.9, "{crossed}");
    assert!(deepest >= 0.0, "{deepest}");
}

/// Times each scene (setup with the first fast-marching solve, then frames) and the path
/// field's build alone, for the README. Wall-clock figures: printed, never asserted.
#[test]
#[ignore]
fn benchmark() {
    let threads: usize = std::env::var("BENCH_THREADS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2);
    for (file, paper_fps) in [
        ("paper001_two_blocks.toml", 219.4),
        ("paper001_chasing.toml", 587.9),
        ("paper001_aggregation.toml", 66.2),
        ("paper001_phototaxis.toml", 1988.1),
        ("paper001_locusts.toml", 12.2),
    ] {
        let shot = load(file);
        let s = &shot.swarms[0];
        let p = |k: &str| s.params.get(k).unwrap() as f32;
        let (c, h) = s.bounds.unwrap();
        let lattice = Lattice::over(c, h, p("cell"), beeswarm::model::field::MAX_CELLS);
        let t0 = Instant::now();
        let map = CostMap::new(
            lattice.clone(),
            &obstacles(&shot),
            p("cost_length"),
            p("cost_repulsion"),
        );
        let t_map = t0.elapsed().as_secs_f64();
        let goals: Vec<Vec3> = shot.targets.iter().map(|t| t.position_at(1.0)).collect();
        let t1 = Instant::now();
        let field = PathField::solve(&map, &goals, p("goal_radius"));
        let t_fmm = t1.elapsed().as_secs_f64();
        assert!(field.lattice.len() == lattice.len());
        let mb = (lattice.len() * CostMap::BYTES_PER_CELL) as f64 / 1e6;
        let (setup, per_frame, steps) = beeswarm::bake::with_threads(threads, || {
            let t = Instant::now();
            let mut sim = Simulation::new(&shot);
            sim.advance();
            let setup = t.elapsed().as_secs_f64();
            let frames = 48;
            let t = Instant::now();
            for _ in 0..frames {
                sim.advance();
            }
            (
                setup,
                t.elapsed().as_secs_f64() / frames as f64,
                shot.substeps as f64,
            )
        })
        .unwrap();
        println!(
            "{file}: {} agents, grid {}×{}×{} ({:.0} MB): cost map {:.3} s, fast marching {:.3} s; setup + first frame {setup:.3} s; {:.2} ms/frame = {:.0} steps/s ({:.1}× the paper's {paper_fps} CPU fps) on {threads} threads",
            s.count,
            lattice.dims[0],
            lattice.dims[1],
            lattice.dims[2],
            mb,
            t_map,
            t_fmm,
            per_frame * 1e3,
            steps / per_frame,
            steps / per_frame / paper_fps,
        );
    }
    // Phototaxis at Table 1's own count (the example has Fig. 1(b)'s 300).
    let mut shot = load("paper001_phototaxis.toml");
    shot.swarms[0].count = 30;
    let ms = beeswarm::bake::with_threads(threads, || {
        let mut sim = Simulation::new(&shot);
        sim.advance();
        let t = Instant::now();
        for _ in 0..96 {
            sim.advance();
        }
        t.elapsed().as_secs_f64() / 96.0 * 1e3
    })
    .unwrap();
    println!(
        "phototaxis at 30 agents: {ms:.3} ms/frame = {:.0} steps/s ({:.1}× the paper's 1988.1)",
        2e3 / ms,
        2e3 / ms / 1988.1
    );
    // Time per frame against the number of agents, at the locusts' fixed field.
    let base = load("paper001_locusts.toml");
    for n in [2500usize, 5000, 10_000, 20_000] {
        let mut shot = base.clone();
        shot.swarms[0].count = n;
        let ms = beeswarm::bake::with_threads(threads, || {
            let mut sim = Simulation::new(&shot);
            sim.advance();
            let t = Instant::now();
            for _ in 0..24 {
                sim.advance();
            }
            t.elapsed().as_secs_f64() / 24.0 * 1e3
        })
        .unwrap();
        println!(
            "locusts at {n} agents: {ms:.2} ms/frame ({:.0} ns per agent-step)",
            ms * 1e6 / (n as f64 * 2.0)
        );
    }
}
