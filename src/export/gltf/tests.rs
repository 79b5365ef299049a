//! Writer tests on synthetic frames: the simulator is not needed to check the file.

use super::*;
use crate::sim::{SwarmFrame, SwarmMeta};
use json::animation::Property;

const FPS: f64 = 24.0;

fn meta(swarms: &[(&str, usize, f32)], start: i32, end: i32) -> CacheMeta {
    CacheMeta {
        shot_name: "unit_shot".into(),
        fps: FPS,
        frame_start: start,
        frame_end: end,
        seed: 42,
        tool_version: "9.8.7".into(),
        swarms: swarms
            .iter()
            .map(|&(name, count, len)| SwarmMeta {
                name: name.into(),
                count,
                species: &crate::species::HONEYBEE,
                channels: crate::species::BEE_CHANNELS.to_vec(),
                body_length_m: len,
                wing_beat_hz: 230.0,
                hidden: None,
            })
            .collect(),
    }
}

/// Deterministic motion: bees circle fast enough that the yaw passes several full turns
/// (glam then returns quaternions of alternating sign, which the writer must smooth out),
/// with pitch, roll and sway all non-zero.
fn synth(meta: &CacheMeta, frame: i32, varying_scale: bool) -> Vec<SwarmFrame> {
    let t = (frame - meta.frame_start) as f32 / meta.fps as f32;
    let mut first_id = 100;
    meta.swarms
        .iter()
        .map(|sm| {
            let mut s = SwarmFrame {
                channels: vec![Vec::new(); crate::species::BEE_CHANNELS.len()],
                ..Default::default()
            };
            for i in 0..sm.count {
                let id = first_id + 7 * i as u64;
                let phase = i as f32 * 0.37;
                let yaw = 3.0 * t + phase;
                let p = Vec3::new(
                    0.5 * yaw.cos(),
                    1.0 + 0.1 * (2.0 * t + phase).sin(),
                    -0.5 * yaw.sin(),
                );
                let pitch = 12.0 * (1.7 * t + phase).sin();
                let roll = 25.0 * (1.1 * t + 2.0 * phase).cos();
                let heading = Quat::from_rotation_y(yaw + std::f32::consts::FRAC_PI_2);
                let orientation = heading
                    * Quat::from_rotation_z(pitch.to_radians())
                    * Quat::from_rotation_x(roll.to_radians());
                s.ids.push(id);
                s.position.push(p);
                s.velocity.push(Vec3::ZERO);
                s.orientation.push(orientation);
                s.heading.push(heading);
                s.channels[0].push(pitch);
                s.channels[1].push(roll);
                s.channels[2].push(0.01 * (5.0 * t + phase).sin());
                s.channels[3].push(0.0);
                s.angular_velocity_deg.push(Vec3::ZERO);
                let scale = 0.9 + 0.1 * (i % 3) as f32;
                let grow = if varying_scale && i == 0 { t } else { 0.0 };
                s.scale.push(scale + grow);
            }
            first_id += 10_000;
            s
        })
        .collect()
}

/// Options of a bake: wings flapping at `flap_hz`, or blurred for 0.
fn opts(flap_hz: f64) -> OutputOptions {
    layout_opts(flap_hz, GltfLayout::Parts)
}

fn layout_opts(flap_hz: f64, layout: GltfLayout) -> OutputOptions {
    OutputOptions {
        wings: if flap_hz > 0.0 {
            WingDisplay::Flap { hz: flap_hz }
        } else {
            WingDisplay::Blur
        },
        gltf_layout: layout,
        ..Default::default()
    }
}

struct Bake {
    meta: CacheMeta,
    flap_hz: f64,
    layout: GltfLayout,
    varying_scale: bool,
    budget: usize,
}

impl Bake {
    fn new(meta: CacheMeta) -> Bake {
        Bake {
            meta,
            flap_hz: 0.0,
            layout: GltfLayout::Parts,
            varying_scale: false,
            budget: TRANSPOSE_BUDGET_BYTES,
        }
    }
    fn run(&self, container: Container, dir: &Path) -> Vec<PathBuf> {
        let ext = match container {
            Container::Glb => "glb",
            Container::Gltf => "gltf",
        };
        let path = dir.join(format!("{}.{ext}", self.meta.shot_name));
        let mut w = GltfWriter::create(
            container,
            &path,
            &self.meta,
            &layout_opts(self.flap_hz, self.layout),
        )
        .unwrap();
        w.transpose_budget = self.budget;
        let mut w: Box<dyn CacheWriter> = Box::new(w);
        for f in self.meta.frame_start..=self.meta.frame_end {
            let swarms = synth(&self.meta, f, self.varying_scale);
            let time = (f - self.meta.frame_start) as f64 / self.meta.fps;
            w.write_frame(&Frame {
                frame: f,
                time,
                swarms: &swarms,
            })
            .unwrap();
        }
        // Committed .bin first (so a .gltf never points at an old buffer); list the
        // document first.
        let mut paths = crate::atomic::commit_all(w.finish().unwrap()).unwrap();
        paths.sort_by_key(|p| p.extension().is_some_and(|e| e == "bin"));
        paths
    }
}

/// A written cache read back: the document and its binary buffer.
struct Doc {
    root: Root,
    bin: Vec<u8>,
}

fn read(path: &Path) -> Doc {
    let bytes = std::fs::read(path).unwrap();
    if path.extension().unwrap() == "glb" {
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
        assert_eq!(&bytes[0..4], b"glTF");
        assert_eq!(u32_at(4), 2);
        assert_eq!(u32_at(8), bytes.len());
        let json_len = u32_at(12);
        assert_eq!(&bytes[16..20], b"JSON");
        assert_eq!(json_len % 4, 0);
        let bin_at = 20 + json_len;
        assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
        let bin_len = u32_at(bin_at);
        assert_eq!(bin_at + 8 + bin_len, bytes.len());
        let root = Root::from_slice(&bytes[20..bin_at]).unwrap();
        let used = root.buffers[0].byte_length.0 as usize;
        assert!(
            bin_len - used < 4,
            "BIN chunk is only padding beyond the buffer"
        );
        Doc {
            root,
            bin: bytes[bin_at + 8..bin_at + 8 + used].to_vec(),
        }
    } else {
        let root = Root::from_slice(&bytes).unwrap();
        let uri = root.buffers[0].uri.clone().unwrap();
        let bin = std::fs::read(path.with_file_name(uri)).unwrap();
        assert_eq!(bin.len() as u64, root.buffers[0].byte_length.0);
        Doc { root, bin }
    }
}

impl Doc {
    fn floats(&self, acc: Index<json::Accessor>) -> Vec<f32> {
        let a = &self.root.accessors[acc.value()];
        let v = &self.root.buffer_views[a.buffer_view.unwrap().value()];
        let start = v.byte_offset.map_or(0, |o| o.0) + a.byte_offset.map_or(0, |o| o.0);
        let n = a.count.0 as usize * a.type_.as_ref().unwrap().multiplicity();
        let start = start as usize;
        assert!(start + 4 * n <= (v.byte_offset.map_or(0, |o| o.0) + v.byte_length.0) as usize);
        self.bin[start..start + 4 * n]
            .chunks(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    fn node(&self, name: &str) -> Index<json::Node> {
        let i = self
            .root
            .nodes
            .iter()
            .position(|n| n.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no node {name}"));
        Index::new(i as u32)
    }

    /// The sampler (input, output) animating `node`'s `path`, if any.
    fn track(
        &self,
        node: Index<json::Node>,
        path: Property,
    ) -> Option<(Index<json::Accessor>, Index<json::Accessor>)> {
        let anim = self.root.animations.first()?;
        anim.channels
            .iter()
            .find(|c| c.target.node == node && c.target.path == Valid(path))
            .map(|c| {
                let s = &anim.samplers[c.sampler.value()];
                (s.input, s.output)
            })
    }

    fn vec3s(&self, acc: Index<json::Accessor>) -> Vec<Vec3> {
        self.floats(acc).chunks(3).map(Vec3::from_slice).collect()
    }

    fn quats(&self, acc: Index<json::Accessor>) -> Vec<Quat> {
        self.floats(acc).chunks(4).map(Quat::from_slice).collect()
    }

    fn extras(&self) -> serde_json::Value {
        serde_json::from_str(self.root.asset.extras.as_ref().unwrap().get()).unwrap()
    }
}

fn names_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn agent_layout_is_one_animated_node_per_bee_holding_the_simulated_pose() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 5, 0.012), ("drones", 3, 0.015)], 10, 33);
    let mut b = Bake::new(m.clone());
    b.layout = GltfLayout::Agent;
    b.varying_scale = true;
    let doc = read(&b.run(Container::Glb, dir.path())[0]);
    let r = &doc.root;
    // Swarm roots, then one node per bee: no part nodes while the wings do not flap.
    assert_eq!(r.nodes.len(), 2 + 8);
    // One mesh per bee length, one primitive per material (yellow, black, wing fan).
    assert_eq!(r.meshes.len(), 2);
    assert_eq!(r.meshes[0].name.as_deref(), Some("bee_12mm"));
    assert_eq!(r.meshes[0].primitives.len(), 3);
    let anim = &r.animations[0];
    let animated: std::collections::BTreeSet<_> =
        anim.channels.iter().map(|c| c.target.node).collect();
    assert_eq!(animated.len(), 8);
    // T and R for every bee, S for the one whose scale changes (bee 0 of each swarm).
    assert_eq!(anim.channels.len(), 8 * 2 + 2);
    for f in m.frame_start..=m.frame_end {
        let k = (f - m.frame_start) as usize;
        for s in synth(&m, f, true) {
            for i in 0..s.len() {
                let bee = doc.node(&bee_name(s.ids[i]));
                let t = doc.vec3s(doc.track(bee, Property::Translation).unwrap().1)[k];
                let q = doc.quats(doc.track(bee, Property::Rotation).unwrap().1)[k];
                assert_eq!(t, s.position[i], "the tracks CSV position, exactly");
                assert!(q.dot(s.orientation[i]).abs() > 1.0 - 1e-6);
                let node = &r.nodes[bee.value()];
                assert!(node.children.is_none() && node.mesh.is_some());
            }
        }
    }
}

#[test]
fn agent_layout_with_flapping_wings_animates_only_the_wings_besides_the_bee() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 4, 0.012)], 1, 12);
    let mut b = Bake::new(m);
    b.layout = GltfLayout::Agent;
    b.flap_hz = 4.0;
    let parts = read(&b.run(Container::Glb, dir.path())[0]);
    let r = &parts.root;
    let bee = &r.nodes[parts.node(&bee_name(100)).value()];
    let kids: Vec<_> = bee
        .children
        .clone()
        .unwrap()
        .iter()
        .map(|k| r.nodes[k.value()].name.clone().unwrap())
        .collect();
    assert_eq!(
        kids,
        [
            format!("{}_wing_l", bee_name(100)),
            format!("{}_wing_r", bee_name(100))
        ]
    );
    // The body alone in the bee's mesh (yellow and black bands).
    assert_eq!(r.meshes[bee.mesh.unwrap().value()].primitives.len(), 2);
    let wing = parts.node(&format!("{}_wing_r", bee_name(100)));
    // Hinged where the parts layout hinges it on the body (the body sits at the centre).
    let hinge = crate::species::honeybee::BeeMesh::new(0.012).wing_hinge_right;
    assert_eq!(r.nodes[wing.value()].translation, Some(hinge.to_array()));
    let q = parts.quats(parts.track(wing, Property::Rotation).unwrap().1);
    let up: Vec<f32> = q
        .iter()
        .map(|q| -2.0 * q.x.atan2(q.w).to_degrees())
        .collect();
    for (k, u) in up.iter().enumerate() {
        let want = wings::angle(4.0, k as f64 / FPS, wings::group(100));
        assert!((u - want).abs() < 1e-3, "{u} vs {want}");
    }
    // Bee, wing_l, wing_r animated per bee.
    let animated: std::collections::BTreeSet<_> = r.animations[0]
        .channels
        .iter()
        .map(|c| c.target.node)
        .collect();
    assert_eq!(animated.len(), 4 * 3);
}

#[test]
fn split_pose_recomposes_exactly() {
    let heading = Quat::from_rotation_y(2.0);
    let orientation = heading * Quat::from_rotation_z(0.3_f32) * Quat::from_rotation_x(-0.4_f32);
    let p = Vec3::new(1.0, 2.0, 3.0);
    let (bee_t, bee_r, body_r) = split_pose(p, heading, orientation, 0.02);
    assert!((bee_t + bee_r * Vec3::new(0.0, 0.0, 0.02) - p).length() < 1e-6);
    assert!((bee_r * body_r).dot(orientation).abs() > 1.0 - 1e-6);
    let expect = Quat::from_rotation_z(0.3) * Quat::from_rotation_x(-0.4);
    assert!(body_r.dot(expect).abs() > 1.0 - 1e-6);
}

#[test]
fn body_world_pose_reconstructs_the_simulated_pose() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 5, 0.012), ("drones", 3, 0.015)], 10, 57);
    let paths = Bake::new(m.clone()).run(Container::Gltf, dir.path());
    let doc = read(&paths[0]);
    for f in m.frame_start..=m.frame_end {
        let k = (f - m.frame_start) as usize;
        for s in synth(&m, f, false) {
            for i in 0..s.len() {
                let name = bee_name(s.ids[i]);
                let bee = doc.node(&name);
                let body = doc.node(&format!("{name}_body"));
                let bt = doc.vec3s(doc.track(bee, Property::Translation).unwrap().1)[k];
                let br = doc.quats(doc.track(bee, Property::Rotation).unwrap().1)[k];
                let dt = doc.vec3s(doc.track(body, Property::Translation).unwrap().1)[k];
                let dr = doc.quats(doc.track(body, Property::Rotation).unwrap().1)[k];
                assert_eq!((dt.x, dt.y), (0.0, 0.0));
                assert_eq!(dt.z, s.channels[2][i]);
                let world_p = bt + br * dt;
                let world_q = br * dr;
                assert!(
                    (world_p - s.position[i]).length() < 1e-6,
                    "{name} frame {f}"
                );
                assert!(world_q.dot(s.orientation[i]).abs() > 1.0 - 1e-6);
                // The bee node carries yaw only; pitch and roll live on the body.
                assert!(br.dot(s.heading[i]).abs() > 1.0 - 1e-6);
                let pr = Quat::from_rotation_z(s.channels[0][i].to_radians())
                    * Quat::from_rotation_x(s.channels[1][i].to_radians());
                assert!(dr.dot(pr).abs() > 1.0 - 1e-5);
            }
        }
    }
}

#[test]
fn quaternions_are_unit_and_keys_stay_in_one_hemisphere() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Bake::new(meta(&[("bees", 6, 0.012)], 1, 120));
    b.flap_hz = 6.0;
    let paths = b.run(Container::Glb, dir.path());
    let doc = read(&paths[0]);
    let anim = &doc.root.animations[0];
    let mut rotation_tracks = 0;
    for c in &anim.channels {
        if c.target.path != Valid(Property::Rotation) {
            continue;
        }
        rotation_tracks += 1;
        let q = doc.quats(anim.samplers[c.sampler.value()].output);
        assert_eq!(q.len(), 120);
        for k in 0..q.len() {
            assert!((q[k].length() - 1.0).abs() < 1e-6);
            if k > 0 {
                assert!(q[k - 1].dot(q[k]) >= 0.0, "sign flip at key {k}");
            }
        }
    }
    // bee + body + two wings per bee
    assert_eq!(rotation_tracks, 6 * 4);
    // The synthetic yaw passes 15 full turns, so raw quaternions do flip sign: the writer
    // must have undone it. Check the bee's heading track really did cross w < 0.
    let bee = doc.node(&bee_name(100));
    let q = doc.quats(doc.track(bee, Property::Rotation).unwrap().1);
    assert!(q.iter().any(|q| q.w < -0.5) && q.iter().any(|q| q.w > 0.5));
}

#[test]
fn one_shared_time_accessor_with_exact_times_and_bounds() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 3, 0.012)], -5, 234);
    let mut b = Bake::new(m.clone());
    b.flap_hz = 12.0; // Nyquist: allowed
    let doc = read(&b.run(Container::Glb, dir.path())[0]);
    let anim = &doc.root.animations[0];
    let inputs: std::collections::BTreeSet<_> = anim.samplers.iter().map(|s| s.input).collect();
    assert_eq!(inputs.len(), 1);
    let input = *inputs.first().unwrap();
    let t = doc.floats(input);
    assert_eq!(t.len(), m.frame_count());
    for (k, &tk) in t.iter().enumerate() {
        assert_eq!(tk, (k as f64 / FPS) as f32);
        if k > 0 {
            assert!(tk > t[k - 1]);
        }
    }
    let a = &doc.root.accessors[input.value()];
    // (serde_json without `float_roundtrip` may misread the last digit of an f64, so compare
    // as f32; the JSON text itself is the exact f64 value of the f32 key.)
    assert_eq!(a.min.as_ref().unwrap()[0].as_f64().unwrap() as f32, t[0]);
    assert_eq!(
        a.max.as_ref().unwrap()[0].as_f64().unwrap() as f32,
        t[t.len() - 1]
    );
    for s in &anim.samplers {
        assert_eq!(
            s.interpolation,
            Valid(json::animation::Interpolation::Linear)
        );
        assert_eq!(
            doc.root.accessors[s.output.value()].count.0 as usize,
            t.len()
        );
    }
    for v in doc.floats(anim.samplers[0].output) {
        assert!(v.is_finite());
    }
}

#[test]
fn node_hierarchy_swarm_bee_body_wings() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 4, 0.012), ("scouts", 2, 0.012)], 1, 3);
    let doc = read(&Bake::new(m).run(Container::Glb, dir.path())[0]);
    let r = &doc.root;
    let scene = &r.scenes[r.scene.unwrap().value()];
    let roots: Vec<_> = scene
        .nodes
        .iter()
        .map(|n| r.nodes[n.value()].name.clone().unwrap())
        .collect();
    assert_eq!(roots, ["bees", "scouts"]);
    let mut body_meshes = std::collections::BTreeSet::new();
    let mut wing_meshes = std::collections::BTreeSet::new();
    for (si, root_node) in scene.nodes.iter().enumerate() {
        let bees = r.nodes[root_node.value()].children.clone().unwrap();
        assert_eq!(bees.len(), [4, 2][si]);
        for (i, bee) in bees.iter().enumerate() {
            let bee = &r.nodes[bee.value()];
            let name = bee.name.clone().unwrap();
            assert_eq!(name, bee_name(100 + 10_000 * si as u64 + 7 * i as u64));
            assert!(bee.mesh.is_none());
            let kids = bee.children.clone().unwrap();
            assert_eq!(kids.len(), 1);
            let body = &r.nodes[kids[0].value()];
            assert_eq!(body.name.clone().unwrap(), format!("{name}_body"));
            body_meshes.insert(body.mesh.unwrap());
            let scale = [0.9, 1.0, 1.1][i % 3];
            let expect = (scale != 1.0).then_some([scale as f32; 3]);
            assert_eq!(body.scale, expect);
            let wings = body.children.clone().unwrap();
            let wing_names: Vec<_> = wings
                .iter()
                .map(|w| r.nodes[w.value()].name.clone().unwrap())
                .collect();
            assert_eq!(
                wing_names,
                [format!("{name}_wing_l"), format!("{name}_wing_r")]
            );
            for w in wings {
                wing_meshes.insert(r.nodes[w.value()].mesh.unwrap());
            }
        }
    }
    // Same bee length: one body mesh and one mesh per wing side for every bee.
    assert_eq!(body_meshes.len(), 1);
    assert_eq!(wing_meshes.len(), 2);
    assert_eq!(r.meshes.len(), 3);
    let body = &r.meshes[body_meshes.first().unwrap().value()];
    assert_eq!(body.primitives.len(), 2, "yellow and black bands");
    let wing_mat = &r.materials[r.meshes[wing_meshes.first().unwrap().value()].primitives[0]
        .material
        .unwrap()
        .value()];
    assert_eq!(wing_mat.alpha_mode, Valid(json::material::AlphaMode::Blend));
    assert!(wing_mat.double_sided);
    // Blurred by default: no wing tracks, a very transparent membrane, wings at mid-stroke.
    assert_eq!(
        wing_mat.pbr_metallic_roughness.base_color_factor.0[3],
        wings::ALPHA_BLUR
    );
    let anim = &r.animations[0];
    assert_eq!(anim.channels.len(), 6 * 4);
    let wing = &r.nodes[doc.node(&format!("{}_wing_r", bee_name(100))).value()];
    let q = Quat::from_array(wing.rotation.as_ref().unwrap().0);
    // The blur's fan spans the stroke in the mesh: the wing node itself is not turned.
    assert!(q.dot(Quat::IDENTITY) > 1.0 - 1e-6);
    let fan = &r.accessors[r.meshes[wing.mesh.unwrap().value()].primitives[0].attributes
        [&Valid(json::mesh::Semantic::Positions)]
        .value()];
    let one_wing = crate::species::honeybee::BeeMesh::new(0.012)
        .wing_right
        .positions
        .len();
    assert_eq!(fan.count.0 as usize, wings::BLUR_COPIES * one_wing);
}

#[test]
fn wing_flap_tracks_beat_at_the_requested_rate_in_phase_groups() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 10, 0.012)], 1, 48);
    let mut b = Bake::new(m);
    b.flap_hz = 4.0;
    let doc = read(&b.run(Container::Glb, dir.path())[0]);
    let r = &doc.root;
    let wing = doc.node(&format!("{}_wing_r", bee_name(100)));
    let out = doc.track(wing, Property::Rotation).unwrap().1;
    let q = doc.quats(out);
    // Up angle from the rotation about X (the right wing raises with a negative angle).
    let up: Vec<f32> = q
        .iter()
        .map(|q| -2.0 * q.x.atan2(q.w).to_degrees())
        .collect();
    let lo = up.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = up.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    // Six samples per stroke catch at least cos(30°) of the amplitude whatever the phase.
    let reach = wings::AMPLITUDE_DEG * 0.86;
    assert!(
        hi <= wings::MID_DEG + wings::AMPLITUDE_DEG + 1e-3 && hi >= wings::MID_DEG + reach,
        "{hi}"
    );
    assert!(
        lo >= wings::MID_DEG - wings::AMPLITUDE_DEG - 1e-3 && lo <= wings::MID_DEG - reach,
        "{lo}"
    );
    // 4 Hz at 24 fps: the pose repeats every 6 frames.
    for k in 6..up.len() {
        assert!((up[k] - up[k - 6]).abs() < 1e-3);
    }
    // Ids 100 and 156 share a phase group (8 groups by id), 100 and 107 do not.
    let track_of = |id: u64| {
        doc.track(
            doc.node(&format!("{}_wing_r", bee_name(id))),
            Property::Rotation,
        )
        .unwrap()
        .1
    };
    assert_eq!(track_of(100), track_of(156));
    assert_ne!(track_of(100), track_of(107));
    let mat = &r.materials[r.meshes[r.nodes[wing.value()].mesh.unwrap().value()].primitives[0]
        .material
        .unwrap()
        .value()];
    assert_eq!(
        mat.pbr_metallic_roughness.base_color_factor.0[3],
        wings::ALPHA_CLEAR
    );
}

#[test]
fn flap_rate_above_half_the_frame_rate_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 1, 0.012)], 1, 2);
    let err = GltfWriter::create(Container::Glb, &dir.path().join("a.glb"), &m, &opts(12.5));
    assert!(matches!(err, Err(Error::Input(_))));
    assert!(names_in(dir.path()).is_empty());
}

#[test]
fn metadata_in_asset_and_scene_extras() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 2, 0.012)], 3, 9);
    let doc = read(&Bake::new(m).run(Container::Gltf, dir.path())[0]);
    assert_eq!(doc.root.asset.generator.as_deref(), Some("beeswarm 9.8.7"));
    assert_eq!(doc.root.asset.version, "2.0");
    let x = doc.extras();
    assert_eq!(x["fps"], 24.0);
    assert_eq!(x["frame_start"], 3);
    assert_eq!(x["frame_end"], 9);
    assert_eq!(x["shot_name"], "unit_shot");
    assert_eq!(x["seed"], 42);
    assert_eq!(x["tool_version"], "9.8.7");
    let scene = &doc.root.scenes[0];
    assert_eq!(
        scene.extras.as_ref().unwrap().get(),
        doc.root.asset.extras.as_ref().unwrap().get()
    );
}

#[test]
fn glb_and_gltf_carry_the_same_document_and_buffer() {
    let dir = tempfile::tempdir().unwrap();
    let b = Bake::new(meta(&[("bees", 7, 0.012)], 1, 30));
    let glb = read(&b.run(Container::Glb, dir.path())[0]);
    let gltf_paths = b.run(Container::Gltf, dir.path());
    assert_eq!(gltf_paths.len(), 2);
    assert!(gltf_paths[1].ends_with("unit_shot.bin"));
    let mut gltf = read(&gltf_paths[0]);
    assert_eq!(gltf.root.buffers[0].uri.as_deref(), Some("unit_shot.bin"));
    gltf.root.buffers[0].uri = None;
    assert_eq!(
        glb.root.to_string().unwrap(),
        gltf.root.to_string().unwrap()
    );
    assert_eq!(glb.bin, gltf.bin);
    assert_eq!(
        names_in(dir.path()),
        ["unit_shot.bin", "unit_shot.glb", "unit_shot.gltf"]
    );
}

#[test]
fn blocked_transpose_matches_a_single_block_and_output_is_deterministic() {
    let one = tempfile::tempdir().unwrap();
    let many = tempfile::tempdir().unwrap();
    let mut b = Bake::new(meta(&[("bees", 9, 0.012), ("b", 4, 0.01)], 1, 25));
    let a = std::fs::read(&b.run(Container::Glb, one.path())[0]).unwrap();
    let again = std::fs::read(&b.run(Container::Glb, one.path())[0]).unwrap();
    assert_eq!(a, again, "identical input, identical bytes");
    b.budget = 2 * 25 * RECORD_BYTES + 1; // two bees per block, 13 bees: a ragged last block
    let c = std::fs::read(&b.run(Container::Glb, many.path())[0]).unwrap();
    assert_eq!(a, c);
}

#[test]
fn scale_track_only_for_bees_whose_scale_changes() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Bake::new(meta(&[("bees", 3, 0.012)], 1, 24));
    b.varying_scale = true;
    let doc = read(&b.run(Container::Glb, dir.path())[0]);
    let body0 = doc.node(&format!("{}_body", bee_name(100)));
    let body1 = doc.node(&format!("{}_body", bee_name(107)));
    let s = doc.vec3s(doc.track(body0, Property::Scale).unwrap().1);
    assert_eq!(s[0], Vec3::splat(0.9));
    assert_eq!(s[23], Vec3::splat(0.9 + 23.0 / 24.0));
    assert!(doc.track(body1, Property::Scale).is_none());
}

#[test]
fn interrupted_or_failed_bake_leaves_the_previous_cache_and_no_temp_files() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 4, 0.012)], 1, 10);
    let glb = dir.path().join("unit_shot.glb");
    std::fs::write(&glb, "previous").unwrap();
    // Interrupted: frames written, writer dropped without finish.
    {
        let mut w = GltfWriter::create(Container::Glb, &glb, &m, &opts(0.0)).unwrap();
        for f in 1..=5 {
            let s = synth(&m, f, false);
            w.write_frame(&Frame {
                frame: f,
                time: 0.0,
                swarms: &s,
            })
            .unwrap();
        }
        assert_eq!(
            names_in(dir.path()).len(),
            2,
            "the scratch file exists during the bake"
        );
    }
    assert_eq!(names_in(dir.path()), ["unit_shot.glb"]);
    assert_eq!(std::fs::read_to_string(&glb).unwrap(), "previous");
    // Failed: the frames stop early, then finish reports it.
    let mut w: Box<dyn CacheWriter> = Box::new(
        GltfWriter::create(
            Container::Gltf,
            &dir.path().join("unit_shot.gltf"),
            &m,
            &opts(0.0),
        )
        .unwrap(),
    );
    for f in 1..=3 {
        let s = synth(&m, f, false);
        w.write_frame(&Frame {
            frame: f,
            time: 0.0,
            swarms: &s,
        })
        .unwrap();
    }
    assert!(w.finish().is_err());
    assert_eq!(names_in(dir.path()), ["unit_shot.glb"]);
    // Failed: a NaN pose.
    let mut w = GltfWriter::create(Container::Glb, &glb, &m, &opts(0.0)).unwrap();
    let mut s = synth(&m, 1, false);
    s[0].position[2].y = f32::NAN;
    assert!(
        w.write_frame(&Frame {
            frame: 1,
            time: 0.0,
            swarms: &s
        })
        .is_err()
    );
    drop(w);
    assert_eq!(names_in(dir.path()), ["unit_shot.glb"]);
    assert_eq!(std::fs::read_to_string(&glb).unwrap(), "previous");
}

#[test]
fn frames_out_of_order_or_with_other_bees_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", 2, 0.012)], 1, 4);
    let mut w =
        GltfWriter::create(Container::Glb, &dir.path().join("a.glb"), &m, &opts(0.0)).unwrap();
    let s = synth(&m, 2, false);
    assert!(
        w.write_frame(&Frame {
            frame: 2,
            time: 0.0,
            swarms: &s
        })
        .is_err()
    );
    let s = synth(&m, 1, false);
    w.write_frame(&Frame {
        frame: 1,
        time: 0.0,
        swarms: &s,
    })
    .unwrap();
    let mut s = synth(&m, 2, false);
    s[0].ids[1] = 5;
    assert!(
        w.write_frame(&Frame {
            frame: 2,
            time: 0.0,
            swarms: &s
        })
        .is_err()
    );
}

#[test]
fn a_swarm_without_bees_still_makes_a_valid_file() {
    let dir = tempfile::tempdir().unwrap();
    let doc =
        read(&Bake::new(meta(&[("empty", 0, 0.012)], 1, 5)).run(Container::Glb, dir.path())[0]);
    assert!(doc.root.animations.is_empty());
    assert_eq!(doc.root.nodes.len(), 1);
}

/// Runs the Khronos validator (tests/node/validate_gltf.mjs) when node and the validator
/// package are available (`BEESWARM_NODE_MODULES`); the pytest suite runs it on real bakes.
fn validator_report(path: &Path) -> Option<serde_json::Value> {
    let modules = std::env::var("BEESWARM_NODE_MODULES").ok()?;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/node/validate_gltf.mjs");
    let out = std::process::Command::new("node")
        .arg(script)
        .arg(path)
        .env("BEESWARM_NODE_MODULES", modules)
        .output()
        .ok()?;
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(serde_json::from_slice(&out.stdout).unwrap())
}

#[test]
fn khronos_validator_reports_no_errors_or_warnings() {
    let dir = tempfile::tempdir().unwrap();
    for (flap_hz, layout) in [
        (0.0, GltfLayout::Parts),
        (6.0, GltfLayout::Parts),
        (0.0, GltfLayout::Agent),
        (6.0, GltfLayout::Agent),
    ] {
        let mut b = Bake::new(meta(&[("bees", 5, 0.012), ("big", 2, 0.02)], 1, 30));
        b.flap_hz = flap_hz;
        b.layout = layout;
        b.varying_scale = true;
        for container in [Container::Glb, Container::Gltf] {
            let path = &b.run(container, dir.path())[0];
            let Some(report) = validator_report(path) else {
                eprintln!("skipped: set BEESWARM_NODE_MODULES to run the glTF validator");
                return;
            };
            let issues = &report["issues"];
            assert_eq!(issues["numErrors"], 0, "{report:#}");
            assert_eq!(issues["numWarnings"], 0, "{report:#}");
            assert_eq!(issues["numInfos"], 0, "{report:#}");
        }
    }
}

/// Writer-only timing and memory on synthetic frames (the simulation excluded):
/// `BEESWARM_PERF_BEES=10000 cargo test --release --lib gltf_writer_throughput -- --ignored
/// --nocapture`, under `/usr/bin/time -v` for the peak memory.
#[test]
#[ignore]
fn gltf_writer_throughput() {
    let bees: usize = std::env::var("BEESWARM_PERF_BEES").map_or(1000, |v| v.parse().unwrap());
    let frames = 240;
    let dir = tempfile::tempdir().unwrap();
    let m = meta(&[("bees", bees, 0.012)], 1, frames);
    for container in [Container::Glb, Container::Gltf] {
        let ext = if container == Container::Glb {
            "glb"
        } else {
            "gltf"
        };
        let path = dir.path().join(format!("perf.{ext}"));
        let mut w: Box<dyn CacheWriter> =
            Box::new(GltfWriter::create(container, &path, &m, &opts(0.0)).unwrap());
        let mut in_frames = std::time::Duration::ZERO;
        for f in 1..=frames {
            let s = synth(&m, f, false);
            let t = std::time::Instant::now();
            w.write_frame(&Frame {
                frame: f,
                time: 0.0,
                swarms: &s,
            })
            .unwrap();
            in_frames += t.elapsed();
        }
        let t = std::time::Instant::now();
        let paths = crate::atomic::commit_all(w.finish().unwrap()).unwrap();
        let finish = t.elapsed();
        let size: u64 = paths
            .iter()
            .map(|p| std::fs::metadata(p).unwrap().len())
            .sum();
        eprintln!(
            "{bees} bees x {frames} frames .{ext}: {:.1} MB, write_frame total {:.2} s, \
             finish {:.2} s",
            size as f64 / 1e6,
            in_frames.as_secs_f64(),
            finish.as_secs_f64()
        );
        for p in paths {
            std::fs::remove_file(p).unwrap();
        }
    }
}

#[test]
fn a_range_too_long_for_f32_key_times_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    // Past 2 s the f32 spacing (0.24 µs) exceeds a frame at 5 MHz (0.2 µs): keys collide.
    let mut m = meta(&[("bees", 1, 0.012)], 0, 10_500_000);
    m.fps = 5e6;
    let err = GltfWriter::create(Container::Glb, &dir.path().join("a.glb"), &m, &opts(0.0));
    assert!(matches!(err, Err(Error::Input(_))));
    m.frame_end = 1_000;
    assert!(GltfWriter::create(Container::Glb, &dir.path().join("a.glb"), &m, &opts(0.0)).is_ok());
}

/// A test-only articulated insect: a thorax (the attitude) with two wings driven by the
/// channel "stroke" about X and an abdomen driven by "abdomen" about Z, no lateral offset.
mod articulated {
    use crate::species::{Alpha, Channel, Drive, Material, Part, PartMesh, Primitive, Species};
    use glam::Vec3;

    pub const CHANNELS: [Channel; 2] = [
        Channel {
            name: "stroke",
            unit: "deg",
            doc: "Wing stroke, degrees, tip up positive.",
        },
        Channel {
            name: "abdomen",
            unit: "deg",
            doc: "Abdomen angle, degrees, tip up positive.",
        },
    ];

    pub static MOTH: Species = Species {
        name: "moth",
        agent: "moth",
        parts: &[
            Part {
                name: "thorax",
                parent: None,
                drive: Drive::Attitude,
            },
            Part {
                name: "wing_l",
                parent: Some(0),
                drive: Drive::Channel {
                    channel: "stroke",
                    axis: Vec3::X,
                },
            },
            Part {
                name: "wing_r",
                parent: Some(0),
                drive: Drive::Channel {
                    channel: "stroke",
                    axis: Vec3::NEG_X,
                },
            },
            Part {
                name: "abdomen",
                parent: Some(0),
                drive: Drive::Channel {
                    channel: "abdomen",
                    axis: Vec3::Z,
                },
            },
        ],
        lateral_offset: None,
        materials: &[
            Material {
                name: "moth_body",
                rgb: [0.3, 0.25, 0.2],
                roughness: 0.7,
                alpha: Alpha::Opaque,
            },
            Material {
                name: "moth_wing",
                rgb: [0.9, 0.85, 0.7],
                roughness: 0.5,
                alpha: Alpha::Membrane,
            },
        ],
        meshes,
    };

    /// A triangle in the XZ plane (normal +Y) spanning `a`, `b`, `c` (body lengths).
    fn tri(length: f32, pts: [Vec3; 3]) -> Primitive {
        let mut p = Primitive::default();
        let v: Vec<u16> = pts.iter().map(|q| p.vertex(*q * length, Vec3::Y)).collect();
        p.triangle(v[0], v[1], v[2]);
        p
    }

    fn meshes(length: f32) -> Vec<PartMesh> {
        let thorax = tri(
            length,
            [
                Vec3::new(0.2, 0.0, 0.0),
                Vec3::new(-0.1, 0.0, -0.1),
                Vec3::new(-0.1, 0.0, 0.1),
            ],
        );
        let wing = |side: f32| {
            tri(
                length,
                [
                    Vec3::ZERO,
                    Vec3::new(0.1, 0.0, 0.6 * side),
                    Vec3::new(-0.2, 0.0, 0.5 * side),
                ],
            )
        };
        let abdomen = tri(
            length,
            [
                Vec3::ZERO,
                Vec3::new(-0.5, 0.0, -0.05),
                Vec3::new(-0.5, 0.0, 0.05),
            ],
        );
        vec![
            PartMesh {
                primitives: vec![(thorax, 0)],
                offset: Vec3::ZERO,
            },
            PartMesh {
                primitives: vec![(wing(-1.0), 1)],
                offset: Vec3::new(0.0, 0.05, -0.05) * length,
            },
            PartMesh {
                primitives: vec![(wing(1.0), 1)],
                offset: Vec3::new(0.0, 0.05, 0.05) * length,
            },
            PartMesh {
                primitives: vec![(abdomen, 0)],
                offset: Vec3::new(-0.1, 0.0, 0.0) * length,
            },
        ]
    }
}

/// Synthetic frames of the moth swarm: stroke and abdomen angles that swing through zero.
fn moth_frames(m: &CacheMeta, f: i32) -> Vec<SwarmFrame> {
    let t = (f - m.frame_start) as f32 / m.fps as f32;
    let mut bees = synth(m, f, false);
    for (s, sm) in bees.iter_mut().zip(&m.swarms) {
        if sm.species.name == "moth" {
            let n = s.len();
            s.channels = vec![
                (0..n).map(|i| 60.0 * (9.0 * t + i as f32).sin()).collect(),
                (0..n)
                    .map(|i| -20.0 + 25.0 * (2.0 * t + i as f32).cos())
                    .collect(),
            ];
        }
    }
    bees
}

#[test]
fn an_articulated_species_animates_its_channel_driven_parts() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = meta(&[("bees", 2, 0.012), ("moths", 3, 0.03)], 1, 40);
    m.swarms[1].species = &articulated::MOTH;
    m.swarms[1].channels = articulated::CHANNELS.to_vec();
    let mut paths = Vec::new();
    for container in [Container::Glb, Container::Gltf] {
        let ext = if container == Container::Glb {
            "glb"
        } else {
            "gltf"
        };
        let path = dir.path().join(format!("moths.{ext}"));
        let mut w: Box<dyn CacheWriter> =
            Box::new(GltfWriter::create(container, &path, &m, &opts(6.0)).unwrap());
        for f in m.frame_start..=m.frame_end {
            let swarms = moth_frames(&m, f);
            w.write_frame(&Frame {
                frame: f,
                time: (f - m.frame_start) as f64 / m.fps,
                swarms: &swarms,
            })
            .unwrap();
        }
        crate::atomic::commit_all(w.finish().unwrap()).unwrap();
        paths.push(path);
    }
    let doc = read(&paths[0]);
    let moth_ids: Vec<u64> = moth_frames(&m, 1)[1].ids.clone();
    for (i, &id) in moth_ids.iter().enumerate() {
        let name = agent_name(&articulated::MOTH, id);
        let agent = doc.node(&name);
        let kids: Vec<String> = doc.root.nodes[agent.value()]
            .children
            .clone()
            .unwrap()
            .iter()
            .map(|k| doc.root.nodes[k.value()].name.clone().unwrap())
            .collect();
        assert_eq!(kids, [format!("{name}_thorax")]);
        let thorax = doc.node(&format!("{name}_thorax"));
        let parts: Vec<String> = doc.root.nodes[thorax.value()]
            .children
            .clone()
            .unwrap()
            .iter()
            .map(|k| doc.root.nodes[k.value()].name.clone().unwrap())
            .collect();
        assert_eq!(
            parts,
            ["wing_l", "wing_r", "abdomen"].map(|p| format!("{name}_{p}"))
        );
        // No lateral offset: the thorax sits on the path node.
        let dt = doc.vec3s(doc.track(thorax, Property::Translation).unwrap().1);
        assert!(dt.iter().all(|t| *t == Vec3::ZERO));
        for (part, channel, axis) in [
            ("wing_l", 0, Vec3::X),
            ("wing_r", 0, Vec3::NEG_X),
            ("abdomen", 1, Vec3::Z),
        ] {
            let node = doc.node(&format!("{name}_{part}"));
            let q = doc.quats(doc.track(node, Property::Rotation).unwrap().1);
            assert_eq!(q.len(), m.frame_count());
            for (k, f) in (m.frame_start..=m.frame_end).enumerate() {
                let deg = moth_frames(&m, f)[1].channels[channel][i];
                // The key is the channel's rotation (up to sign), about the part's axis.
                let expect = channel_rotation(axis, deg);
                assert!(q[k].dot(expect).abs() > 1.0 - 1e-6, "{part} frame {f}");
                let (got_axis, got_angle) = q[k].to_axis_angle();
                let signed = got_angle.to_degrees() * got_axis.dot(axis).signum();
                let wrapped = (signed - deg + 540.0).rem_euclid(360.0) - 180.0;
                assert!(wrapped.abs() < 1e-3, "{part} frame {f}: {signed} vs {deg}");
                if k > 0 {
                    assert!(q[k - 1].dot(q[k]) >= 0.0);
                }
            }
            // Rest pose: the first key; rest translation: the part's offset.
            let n = &doc.root.nodes[node.value()];
            assert_eq!(n.rotation.as_ref().unwrap().0, q[0].to_array());
            assert!(n.translation.is_some());
        }
    }
    // The bees of the same shot keep their flapping wings.
    let bee = bee_name(100);
    let wing = doc.node(&format!("{bee}_wing_r"));
    assert!(doc.track(wing, Property::Rotation).is_some());
    let mesh_names: Vec<String> = doc
        .root
        .meshes
        .iter()
        .map(|m| m.name.clone().unwrap())
        .collect();
    assert_eq!(
        mesh_names,
        [
            "bee_12mm_body",
            "bee_12mm_wing_l",
            "bee_12mm_wing_r",
            "moth_30mm_thorax",
            "moth_30mm_wing_l",
            "moth_30mm_wing_r",
            "moth_30mm_abdomen"
        ]
    );
    for path in &paths {
        let Some(report) = validator_report(path) else {
            eprintln!("skipped: set BEESWARM_NODE_MODULES to run the glTF validator");
            return;
        };
        let issues = &report["issues"];
        assert_eq!(issues["numErrors"], 0, "{report:#}");
        assert_eq!(issues["numWarnings"], 0, "{report:#}");
        assert_eq!(issues["numInfos"], 0, "{report:#}");
    }
}

#[test]
fn agent_layout_gives_channel_driven_parts_their_own_animated_nodes() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = meta(&[("moths", 2, 0.03)], 1, 10);
    m.swarms[0].species = &articulated::MOTH;
    m.swarms[0].channels = articulated::CHANNELS.to_vec();
    let path = dir.path().join("moths.glb");
    let mut w: Box<dyn CacheWriter> = Box::new(
        GltfWriter::create(
            Container::Glb,
            &path,
            &m,
            &layout_opts(0.0, GltfLayout::Agent),
        )
        .unwrap(),
    );
    for f in m.frame_start..=m.frame_end {
        let swarms = moth_frames(&m, f);
        w.write_frame(&Frame {
            frame: f,
            time: 0.0,
            swarms: &swarms,
        })
        .unwrap();
    }
    crate::atomic::commit_all(w.finish().unwrap()).unwrap();
    let doc = read(&path);
    let ids = moth_frames(&m, 1)[0].ids.clone();
    let name = agent_name(&articulated::MOTH, ids[0]);
    let agent = &doc.root.nodes[doc.node(&name).value()];
    // The thorax (the attitude) is the agent node's mesh; the moving parts hang off it at
    // their offsets.
    assert_eq!(
        doc.root.meshes[agent.mesh.unwrap().value()].name.as_deref(),
        Some("moth_30mm")
    );
    let kids: Vec<String> = agent
        .children
        .clone()
        .unwrap()
        .iter()
        .map(|k| doc.root.nodes[k.value()].name.clone().unwrap())
        .collect();
    assert_eq!(
        kids,
        ["wing_l", "wing_r", "abdomen"].map(|p| format!("{name}_{p}"))
    );
    let abdomen = doc.node(&format!("{name}_abdomen"));
    let q = doc.quats(doc.track(abdomen, Property::Rotation).unwrap().1);
    for (k, f) in (m.frame_start..=m.frame_end).enumerate() {
        let deg = moth_frames(&m, f)[0].channels[1][0];
        assert!(q[k].dot(channel_rotation(Vec3::Z, deg)).abs() > 1.0 - 1e-6);
    }
    if let Some(report) = validator_report(&path) {
        assert_eq!(report["issues"]["numErrors"], 0, "{report:#}");
        assert_eq!(report["issues"]["numWarnings"], 0, "{report:#}");
        assert_eq!(report["issues"]["numInfos"], 0, "{report:#}");
    }
}

#[test]
fn a_part_driven_by_a_channel_the_model_does_not_record_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = meta(&[("moths", 1, 0.03)], 1, 2);
    m.swarms[0].species = &articulated::MOTH;
    m.swarms[0].channels = articulated::CHANNELS[..1].to_vec();
    let err = GltfWriter::create(Container::Glb, &dir.path().join("a.glb"), &m, &opts(0.0));
    assert!(matches!(err, Err(Error::Input(_))));
}
