//! No body is ever inside an obstacle, for any model and any parameter in its documented
//! range: random scenes of overlapping and thin obstacles, fast flight and fine noise,
//! checked at every frame. The cases are drawn from a fixed seed, so a failure repeats.

use beeswarm::geometry::mesh::MeshMode;
use beeswarm::geometry::{Shape, signed_distance};
use beeswarm::math::Rng;
use beeswarm::sim::Simulation;
use glam::Vec3;

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
    let model = ["bee", "brownian", "boids", "curl", "fastswarm"][(rng.f32() * 5.0) as usize % 5];
    // Cases from 200 on fly paper 001's field model, towards a goal across the scene.
    // Cases from 240 on are paper 004's butterflies (gravity, wind gusts and rain push
    // them at the ground and the obstacles), chasing each other and a target.
    let model = if case >= 240 {
        "butterfly"
    } else if case >= 200 {
        "field"
    } else {
        model
    };
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
        "butterfly" => format!(
            "{{ max_speed = {:.2}, rain_rate = 20, rain_kick = {:.2}, chase = 1, gust_x = {:.2}, gust_end = 0.5 }}",
            speed.min(10.0),
            rng.range(0.1, 3.0),
            rng.range(-5.0, 5.0)
        ),
        // Flies recorded velocities: no speed to set.
        "fastswarm" => format!("{{ noise_cell = {:.4} }}", rng.range(0.001, 0.2)),
        _ => format!("{{ speed = {speed:.2} }}"),
    };
    let mut src = format!(
        "[scene]\nframes = [1, 25]\nseed = {case}\n[[swarm]]\ncount = 30\nmodel = \"{model}\"\nparams = {params}\n\
         spawn = {{ center = [0, 1, 0], size = [0.8, 0.8, 0.8] }}\n"
    );
    for _ in 0..1 + (rng.f32() * 5.0) as usize {
        src += &format!("[[obstacle]]\n{}\n", obstacle(&mut rng));
    }
    if model == "field" || model == "butterfly" {
        src += "[[target]]\nposition = [0.9, 1.2, -0.9]\n";
    }
    src
}

#[test]
fn no_body_is_ever_inside_an_obstacle() {
    let mut checked = 0usize;
    let mut worst = f32::INFINITY;
    for case in 0..270 {
        let src = scene(case);
        // A scene whose spawn box lies wholly inside obstacles is refused, as documented.
        let Ok(shot) = beeswarm::shot::parse(
            &src,
            std::path::Path::new("t.toml"),
            std::path::Path::new("."),
        ) else {
            continue;
        };
        let gaps = every_gap(&shot, &src, case, |k, _, p| {
            signed_distance(&shot.obstacles[k].shape, p)
        });
        checked += gaps.checked;
        worst = worst.min(gaps.smallest);
    }
    println!(
        "{checked} body–obstacle checks, smallest gap {:.4} mm",
        worst * 1e3
    );
    assert!(checked > 100_000, "the cases must run: {checked}");
}

/// What [`every_gap`] saw: body–obstacle pairs checked, the smallest gap (m), and gaps
/// under 1 mm.
struct Gaps {
    checked: usize,
    smallest: f32,
    touching: usize,
}

/// Bakes `shot` frame by frame and asserts that no body is inside any obstacle, with
/// `distance(k, frame, p)` the signed distance from p to obstacle k at that frame
/// (negative inside); `src` and `case` name the scene in a failure.
fn every_gap(
    shot: &beeswarm::shot::Shot,
    src: &str,
    case: u64,
    distance: impl Fn(usize, i32, Vec3) -> f32,
) -> Gaps {
    let radius = shot.swarms[0].bee.radius;
    let mut gaps = Gaps {
        checked: 0,
        smallest: f32::INFINITY,
        touching: 0,
    };
    let mut sim = Simulation::new(shot);
    loop {
        for s in sim.record() {
            for (p, scale) in s.position.iter().zip(&s.scale) {
                let ri = radius * scale;
                for (k, o) in shot.obstacles.iter().enumerate() {
                    let gap = distance(k, sim.frame(), *p) - ri;
                    gaps.smallest = gaps.smallest.min(gap);
                    gaps.touching += usize::from(gap < 1e-3);
                    assert!(
                        gap > -1e-4,
                        "case {case}, frame {}: a body {:.2} mm inside {}\n{src}",
                        sim.frame(),
                        -gap * 1e3,
                        o.name
                    );
                    gaps.checked += 1;
                }
            }
        }
        if sim.done() {
            return gaps;
        }
        sim.advance();
    }
}

/// A random closed blob as OBJ text: a sphere whose radius varies smoothly with direction
/// (star-shaped, so never self-intersecting), `rings` × `segments` cells, about a metre
/// across at most.
fn blob_obj(rng: &mut Rng, rings: u32, segments: u32) -> String {
    let r0 = rng.range(0.05, 0.35);
    let (a, b, c) = (
        rng.range(0.0, 0.5),
        rng.range(1.0, 4.0),
        rng.range(0.0, 6.3),
    );
    common::star_shaped_obj(rings, segments, |th, ph| {
        r0 * (1.0 + a * (b * th).sin() * (2.0 * ph + c).cos())
    })
}

/// A random open sheet as OBJ text: a wavy square, 1 m a side, avoided as a shell.
fn sheet_obj(rng: &mut Rng) -> String {
    let n = 12;
    let (amp, k) = (rng.range(0.0, 0.15), rng.range(2.0, 9.0));
    let mut s = String::new();
    for i in 0..=n {
        for j in 0..=n {
            let (x, z) = (i as f32 / n as f32 - 0.5, j as f32 / n as f32 - 0.5);
            s += &format!("v {x} {} {z}\n", amp * (k * x).sin() * (k * z).cos());
        }
    }
    let at = |i: u32, j: u32| 1 + i * (n + 1) + j;
    for i in 0..n {
        for j in 0..n {
            s += &format!(
                "f {} {} {}\nf {} {} {}\n",
                at(i, j),
                at(i, j + 1),
                at(i + 1, j + 1),
                at(i, j),
                at(i + 1, j + 1),
                at(i + 1, j)
            );
        }
    }
    s
}

/// The vertices and triangles of OBJ text (`v` lines, `f` lines of 3 or 4 corners).
fn obj_parts(obj: &str) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (mut v, mut t) = (Vec::new(), Vec::new());
    for line in obj.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.first() {
            Some(&"v") => v.push([1, 2, 3].map(|k| w[k].parse::<f32>().unwrap())),
            Some(&"f") => {
                let c: Vec<u32> = w[1..]
                    .iter()
                    .map(|x| x.parse::<u32>().unwrap() - 1)
                    .collect();
                for k in 1..c.len() - 1 {
                    t.push([c[0], c[k], c[k + 1]]);
                }
            }
            _ => {}
        }
    }
    (v, t)
}

/// The same mesh as binary little-endian PLY.
fn obj_to_ply(obj: &str) -> Vec<u8> {
    let (v, t) = obj_parts(obj);
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        v.len(),
        t.len()
    )
    .into_bytes();
    for p in &v {
        p.iter().for_each(|c| b.extend(c.to_le_bytes()));
    }
    for f in &t {
        b.push(3);
        f.iter().for_each(|i| b.extend(i.to_le_bytes()));
    }
    b
}

/// The same mesh as glTF with its buffer in a data URI, placed by a node's translation
/// (undone by the vertices, so the obstacle is where the OBJ's would be).
fn obj_to_gltf(obj: &str) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let (v, t) = obj_parts(obj);
    let mut buf = Vec::new();
    for p in &v {
        [p[0] - 0.25, p[1], p[2]]
            .iter()
            .for_each(|c| buf.extend(c.to_le_bytes()));
    }
    for f in &t {
        f.iter().for_each(|i| buf.extend(i.to_le_bytes()));
    }
    let mut b64 = String::new();
    for c in buf.chunks(3) {
        let n = c
            .iter()
            .enumerate()
            .fold(0u32, |a, (k, &x)| a | (x as u32) << (16 - 8 * k));
        for k in 0..4 {
            b64.push(if k <= c.len() {
                A[(n >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    let pos_len = 12 * v.len();
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
 "nodes": [{{"name": "blob", "translation": [0.25, 0, 0], "mesh": 0}}],
 "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
 "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{b64}"}}],
 "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {pos_len}}}, {{"buffer": 0, "byteOffset": {pos_len}, "byteLength": {idx_len}}}],
 "accessors": [{{"bufferView": 0, "componentType": 5126, "count": {nv}, "type": "VEC3", "min": [-9, -9, -9], "max": [9, 9, 9]}},
  {{"bufferView": 1, "componentType": 5125, "count": {ni}, "type": "SCALAR"}}]}}"#,
        len = buf.len(),
        idx_len = 12 * t.len(),
        nv = v.len(),
        ni = 3 * t.len()
    )
}

/// A scene of 1–3 mesh obstacles (closed blobs, some thin and flattened by the scale, and
/// open sheets), randomly placed, written beside the shot in `dir` as OBJ, binary PLY or
/// glTF in turn (the same meshes whatever the file).
fn mesh_scene(case: u64, dir: &std::path::Path) -> String {
    let mut rng = Rng::new(2026, case, 22);
    let model = ["bee", "brownian", "boids", "curl"][case as usize % 4];
    let speed = if rng.f32() < 0.5 {
        rng.range(0.5, 3.0)
    } else {
        rng.range(10.0, 50.0)
    };
    let mut src = format!(
        "[scene]\nframes = [1, 25]\nseed = {case}\n[[swarm]]\ncount = 30\nmodel = \"{model}\"\n\
         params = {{ speed = {speed:.2} }}\nspawn = {{ center = [0, 1, 0], size = [0.8, 0.8, 0.8] }}\n"
    );
    for k in 0..1 + (rng.f32() * 3.0) as usize {
        let shell = rng.f32() < 0.3;
        let text = if shell {
            sheet_obj(&mut rng)
        } else {
            blob_obj(&mut rng, 10, 20)
        };
        let file = match (case as usize + k) % 3 {
            0 => {
                let f = format!("m{case}_{k}.obj");
                std::fs::write(dir.join(&f), text).unwrap();
                f
            }
            1 => {
                let f = format!("m{case}_{k}.ply");
                std::fs::write(dir.join(&f), obj_to_ply(&text)).unwrap();
                f
            }
            _ => {
                let f = format!("m{case}_{k}.gltf");
                std::fs::write(dir.join(&f), obj_to_gltf(&text)).unwrap();
                f
            }
        };
        // Non-uniform scale: now and then a blob squashed into a 5–20 mm board.
        let squash = if rng.f32() < 0.3 {
            rng.range(0.02, 0.08)
        } else {
            rng.range(0.5, 2.0)
        };
        src += &format!(
            "[[obstacle]]\ntype = \"mesh\"\nfile = \"{file}\"\nposition = [{:.3}, {:.3}, {:.3}]\n\
             rotation = [{:.1}, {:.1}, {:.1}]\nscale = [{:.3}, {squash:.3}, {:.3}]\n",
            rng.range(-0.4, 0.4),
            rng.range(0.6, 1.4),
            rng.range(-0.4, 0.4),
            rng.range(0.0, 180.0),
            rng.range(0.0, 180.0),
            rng.range(0.0, 180.0),
            rng.range(0.5, 2.0),
            rng.range(0.5, 2.0),
        );
        if shell {
            src += &format!(
                "mode = \"shell\"\nthickness = {:.3}\n",
                rng.range(0.0, 0.02)
            );
        }
    }
    src
}

/// The closest point to `p` on triangle abc (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Whether the ray from `p` along `dir` crosses triangle abc (Möller–Trumbore).
fn ray_crosses(p: Vec3, dir: Vec3, [a, b, c]: [Vec3; 3]) -> bool {
    let (e1, e2) = (b - a, c - a);
    let h = dir.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-12 {
        return false;
    }
    let s = p - a;
    let u = s.dot(h) / det;
    let q = s.cross(e1);
    let v = dir.dot(q) / det;
    u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(q) / det > 0.0
}

/// The signed distance to a mesh obstacle by brute force, independent of the query
/// structure under test: the nearest of all triangles, and for a solid the parity of
/// three rays' crossings (the majority, so a ray through an edge does not decide).
fn brute_signed_distance(tris: &[[Vec3; 3]], mode: MeshMode, p: Vec3) -> f32 {
    let d = tris
        .iter()
        .map(|t| (p - closest_on_triangle(p, t[0], t[1], t[2])).length())
        .fold(f32::INFINITY, f32::min);
    match mode {
        MeshMode::Shell { thickness } => d - 0.5 * thickness,
        MeshMode::Solid => {
            let dirs = [
                Vec3::new(0.5377, 0.7093, 0.4559),
                Vec3::new(-0.6131, 0.2207, 0.7586),
                Vec3::new(0.3119, -0.8834, 0.3497),
            ];
            let inside = dirs
                .iter()
                .filter(|dir| tris.iter().filter(|t| ray_crosses(p, **dir, **t)).count() % 2 == 1)
                .count()
                >= 2;
            if inside { -d } else { d }
        }
    }
}

#[test]
fn no_body_is_ever_inside_a_mesh_obstacle() {
    let dir = tempfile::tempdir().unwrap();
    let mut checked = 0usize;
    let mut worst = f32::INFINITY;
    let mut touching = 0usize;
    for case in 0..60 {
        let src = mesh_scene(case, dir.path());
        let Ok(shot) = beeswarm::shot::parse(&src, &dir.path().join("t.toml"), dir.path()) else {
            continue;
        };
        let meshes: Vec<(Vec<[Vec3; 3]>, MeshMode)> = shot
            .obstacles
            .iter()
            .map(|o| match &o.shape {
                Shape::Mesh { mesh, .. } => (mesh.triangles().collect(), mesh.mode()),
                _ => unreachable!("mesh scenes hold meshes only"),
            })
            .collect();
        let gaps = every_gap(&shot, &src, case, |k, _, p| {
            let (tris, mode) = &meshes[k];
            brute_signed_distance(tris, *mode, p)
        });
        checked += gaps.checked;
        worst = worst.min(gaps.smallest);
        touching += gaps.touching;
    }
    println!(
        "{checked} body–mesh checks, {touching} within 1 mm of a surface, smallest gap {:.4} mm",
        worst * 1e3
    );
    assert!(checked > 50_000, "the cases must run: {checked}");
    // The bodies must actually meet the meshes for the check to mean anything.
    assert!(touching > 1_000, "too few contacts: {touching}");
}

/// A scene of one random closed blob that sweeps through the swarm on keys, turning as it
/// goes (up to about 11 m/s and 2,900°/s about an axis), among insects of every model that
/// sees obstacles move (all but `field`, which refuses it).
fn moving_mesh_scene(case: u64, dir: &std::path::Path) -> String {
    let mut rng = Rng::new(2026, case, 23);
    let model = [
        "bee",
        "zonal",
        "brownian",
        "boids",
        "curl",
        "fastswarm",
        "butterfly",
    ][case as usize % 7];
    let speed = if rng.f32() < 0.5 {
        rng.range(0.5, 3.0)
    } else {
        rng.range(10.0, 50.0)
    };
    let params = match model {
        "fastswarm" => String::new(),
        "butterfly" => format!("params = {{ max_speed = {:.2} }}\n", speed.min(10.0)),
        "zonal" => format!("params = {{ max_speed = {speed:.2} }}\n"),
        _ => format!("params = {{ speed = {speed:.2} }}\n"),
    };
    let file = format!("moving{case}.obj");
    std::fs::write(dir.join(&file), blob_obj(&mut rng, 10, 20)).unwrap();
    let mut src = format!(
        "[scene]\nframes = [1, 25]\nseed = {case}\n[[swarm]]\ncount = 60\nmodel = \"{model}\"\n\
         {params}spawn = {{ center = [0, 1, 0], size = [0.8, 0.8, 0.8] }}\n\
         [[obstacle]]\ntype = \"mesh\"\nfile = \"{file}\"\nscale = [{:.3}, {:.3}, {:.3}]\nkeys = [\n",
        rng.range(0.8, 2.5),
        rng.range(0.8, 2.5),
        rng.range(0.8, 2.5),
    );
    // Back and forth through the spawn box: 3 to 5 keys, 0.25 to 0.5 s apart.
    let mut frame = 1.0;
    for _ in 0..3 + (rng.f32() * 3.0) as usize {
        src += &format!(
            "  {{ frame = {frame:.1}, position = [{:.3}, {:.3}, {:.3}], rotation = [{:.1}, {:.1}, {:.1}] }},\n",
            rng.range(-1.2, 1.2),
            rng.range(0.6, 1.4),
            rng.range(-0.5, 0.5),
            rng.range(-360.0, 360.0),
            rng.range(-360.0, 360.0),
            rng.range(-360.0, 360.0),
        );
        frame += rng.range(6.0, 12.0);
    }
    src + "]\n"
}

#[test]
fn no_body_is_ever_inside_a_moving_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let (mut checked, mut touching, mut runs) = (0usize, 0usize, 0usize);
    let mut zonal_touching = 0;
    let mut worst = f32::INFINITY;
    for case in 0..42 {
        let src = moving_mesh_scene(case, dir.path());
        // A spawn box wholly inside the blob's first pose is refused, as documented.
        let Ok(shot) = beeswarm::shot::parse(&src, &dir.path().join("t.toml"), dir.path()) else {
            continue;
        };
        runs += 1;
        let o = &shot.obstacles[0];
        let Shape::Mesh {
            mesh,
            pose: Some(_),
        } = &o.shape
        else {
            unreachable!("a keyed mesh has a pose")
        };
        // The blob in its rest frame; a body is carried into it by the pose at its frame.
        let rest: Vec<[Vec3; 3]> = mesh.triangles().collect();
        let gaps = every_gap(&shot, &src, case, |_, frame, p| {
            let pose = o.pose_at(frame as f64).expect("keyed");
            brute_signed_distance(&rest, MeshMode::Solid, pose.to_rest(p))
        });
        checked += gaps.checked;
        worst = worst.min(gaps.smallest);
        touching += gaps.touching;
        if shot.swarms[0].model.name() == "zonal" {
            zonal_touching += gaps.touching;
        }
        if case % 6 == 0 {
            // Started later (as `--frames 13:25` does): the mesh starts where it is then.
            let mut later = shot.clone();
            later.frame_start = 13;
            let gaps = every_gap(&later, &src, case, |_, frame, p| {
                let pose = o.pose_at(frame as f64).expect("keyed");
                brute_signed_distance(&rest, MeshMode::Solid, pose.to_rest(p))
            });
            checked += gaps.checked;
        }
    }
    println!(
        "{runs} scenes, {checked} body–mesh checks, {touching} within 1 mm of the moving surface, smallest gap {:.4} mm",
        worst * 1e3
    );
    assert!(runs >= 30, "the cases must run: {runs}");
    // The mesh must actually come onto bodies for the check to mean anything.
    assert!(touching > 800, "too few contacts: {touching}");
    // The zonal model's velocity obstacles take the surface's own velocity: its insects
    // get out of the mesh's way (20 body-frames at the surface over its 6 scenes; 299 when
    // the plane ignores the motion and the guard has to push them).
    println!("zonal: {zonal_touching} body-frames within 1 mm of the moving surface");
    assert!(
        zonal_touching < 100,
        "zonal insects do not dodge: {zonal_touching}"
    );
}
