//! No body is ever inside an obstacle, for any model and any parameter in its documented
//! range: random scenes of overlapping and thin obstacles, fast flight and fine noise,
//! checked at every frame. The cases are drawn from a fixed seed, so a failure repeats.

use beeswarm::geometry::signed_distance;
use beeswarm::math::Rng;
use beeswarm::sim::Simulation;

mod common;

/// A random obstacle near the origin, as TOML: thin boards, spheres, shafts, cylinders,
/// and now and then a ground plane.
fn obstacle(rng: &mut Rng) -> String {
    let c = |rng: &mut Rng| {
        format!(
            "[{:.3}, {:.3}, {:.3}]",
            rng.range(-0.4, 0.4),
            rng.range(0.6, 1.4),
            rng.range(-0.4, 0.4)
        )
    };
    match (rng.f32() * 5.0) as u32 {
        0 => format!(
            "type = \"box\"\ncenter = {}\nsize = [{:.3}, {:.3}, {:.3}]\nrotation = [0, {:.1}, {:.1}]",
            c(rng),
            rng.range(0.005, 0.02), // a board 5–20 mm thick
            rng.range(0.3, 1.0),
            rng.range(0.3, 1.0),
            rng.range(0.0, 90.0),
            rng.range(0.0, 30.0)
        ),
        1 => format!(
            "type = \"sphere\"\ncenter = {}\nradius = {:.3}",
            c(rng),
            rng.range(0.02, 0.3)
        ),
        2 => format!(
            "type = \"capsule\"\na = {}\nb = {}\nradius = {:.3}",
            c(rng),
            c(rng),
            rng.range(0.004, 0.05)
        ),
        3 => format!(
            "type = \"cylinder\"\ncenter = {}\nradius = {:.3}\nheight = {:.3}",
            c(rng),
            rng.range(0.01, 0.2),
            rng.range(0.2, 1.5)
        ),
        _ => format!(
            "type = \"plane\"\npoint = [0, {:.3}, 0]\nnormal = [0, 1, 0]",
            rng.range(0.5, 0.8)
        ),
    }
}

fn scene(case: u64) -> String {
    let mut rng = Rng::new(2026, case, 0);
    let model = ["bee", "brownian", "boids", "curl"][(rng.f32() * 4.0) as usize % 4];
    // Cases from 200 on fly paper 001's field model, towards a goal across the scene.
    let model = if case >= 200 { "field" } else { model };
    // Speeds up to the documented 50 m/s, the noise lattice down to its 1 mm minimum.
    let speed = if rng.f32() < 0.5 {
        rng.range(0.5, 3.0)
    } else {
        rng.range(10.0, 50.0)
    };
    let params = match model {
        "bee" => format!(
            "{{ speed = {speed:.2}, noise_cell = {:.4} }}",
            rng.range(0.001, 0.2)
        ),
        "curl" => format!(
            "{{ speed = {speed:.2}, noise_cell = {:.4} }}",
            rng.range(0.001, 0.2)
        ),
        "field" => {
            let scale = rng.range(0.001, 0.2);
            format!(
                "{{ s0 = {speed:.2}, scale = {scale:.4}, gain = {:.4}, goal_radius = 0.2 }}",
                speed * scale
            )
        }
        _ => format!("{{ speed = {speed:.2} }}"),
    };
    let mut src = format!(
        "[scene]\nframes = [1, 25]\nseed = {case}\n[[swarm]]\ncount = 30\nmodel = \"{model}\"\nparams = {params}\n\
         spawn = {{ center = [0, 1, 0], size = [0.8, 0.8, 0.8] }}\n"
    );
    for _ in 0..1 + (rng.f32() * 5.0) as usize {
        src += &format!("[[obstacle]]\n{}\n", obstacle(&mut rng));
    }
    if model == "field" {
        src += "[[target]]\nposition = [0.9, 1.2, -0.9]\n";
    }
    src
}

#[test]
fn no_body_is_ever_inside_an_obstacle() {
    let mut checked = 0usize;
    let mut worst = f32::INFINITY;
    for case in 0..240 {
        let src = scene(case);
        // A scene whose spawn box lies wholly inside obstacles is refused, as documented.
        let Ok(shot) = beeswarm::shot::parse(
            &src,
            std::path::Path::new("t.toml"),
            std::path::Path::new("."),
        ) else {
            continue;
        };
        let radius = shot.swarms[0].bee.radius;
        let mut sim = Simulation::new(&shot);
        loop {
            for s in sim.record() {
                for (p, scale) in s.position.iter().zip(&s.scale) {
                    let ri = radius * scale;
                    for o in &shot.obstacles {
                        let gap = signed_distance(&o.shape, *p) - ri;
                        worst = worst.min(gap);
                        assert!(
                            gap > -1e-4,
                            "case {case}, frame {}: a body {:.2} mm inside {}\n{src}",
                            sim.frame(),
                            -gap * 1e3,
                            o.name
                        );
                        checked += 1;
                    }
                }
            }
            if sim.done() {
                break;
            }
            sim.advance();
        }
    }
    println!(
        "{checked} body–obstacle checks, smallest gap {:.4} mm",
        worst * 1e3
    );
    assert!(checked > 100_000, "the cases must run: {checked}");
}
