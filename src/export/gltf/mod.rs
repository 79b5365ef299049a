//! glTF 2.0 cache: `.glb`, or `.gltf` with its `.bin` beside it.
//!
//! Scene: one root node per swarm (named after it), one node per agent under it. Two
//! layouts (`[output] gltf_layout`). **parts** (the default): under each agent node one node
//! per part of the swarm's species (`species::Species`), named `<agent>_<part>`. For the
//! honeybee:
//!
//! ```text
//! bee_000123            translation = position − heading·(0,0,sway), rotation = heading
//! └─ bee_000123_body    translation = (0,0,sway), rotation = Rz(pitch)·Rx(roll), scale,
//!    │                  mesh = the striped body                          (Drive::Attitude)
//!    ├─ bee_000123_wing_l   hinge on the thorax: still, blur fan or flapping (Drive::Flap)
//!    └─ bee_000123_wing_r
//! ```
//!
//! so an animator reads the path on the agent node and the body motion on its child, and
//! the body node's world transform is exactly the simulated pose (its world position is
//! the tracks CSV position). The lateral offset (sway) is the channel the species names in
//! `lateral_offset`; a part with `Drive::Channel` gets a rotation track turning it about
//! its axis by the channel's value in degrees.
//!
//! **agent**: the agent node holds the simulated pose itself (translation = position,
//! rotation = orientation, scale) and one mesh of every part that does not move on its
//! own, posed at rest; only moving parts (flapping wings, channel-driven parts) get child
//! nodes. One animated node per bee unless the wings flap: what DCC importers, whose time
//! grows with animated nodes, load fastest.
//!
//! Every track is LINEAR and keyed once per frame on one shared time accessor,
//! `(frame − start) / fps` seconds, but one: an agent that is hidden at some frames (a
//! bee inside its hive, `SwarmMeta::hidden`) gets a STEP scale track on its agent node,
//! 0 while hidden, so that it vanishes and reappears between two frames without
//! shrinking. In the agent layout that track also carries the agent's own scale. Wings
//! are drawn as `export::wings` says, like USD.
//!
//! Memory: the buffer wants each bee's history contiguous (node-major) but frames arrive
//! one at a time (frame-major). Each frame's keys are appended to a scratch file as they
//! come and transposed in blocks of bees at `finish`, so memory is about 100 bytes per bee
//! plus one bounded block buffer, whatever the shot length. The JSON (about 1.5 kB per
//! bee) is the part that grows with the bee count.

use super::wings::{self, WingDisplay};
use super::{CacheWriter, GltfLayout, OutputOptions};
use crate::atomic::{AtomicFile, ScratchFile, SealedFile};
use crate::error::{Error, Result};
use crate::sim::{CacheMeta, Frame};
use crate::species::{Alpha, Drive, Primitive, Species};
use glam::{Quat, Vec3};
use gltf_json as json;
use json::validation::{Checked::Valid, USize64};
use json::{Index, Root};
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Which container to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    /// One binary `.glb` file.
    Glb,
    /// `<shot>.gltf` JSON plus `<shot>.bin` beside it.
    Gltf,
}

/// Floats spilled per agent per frame: agent translation (3), agent rotation (4), lateral
/// offset (1), body rotation (4), scale (1), shown (1: visible, 0: hidden). Stored
/// little-endian, exactly the bytes the
/// buffer holds. Then one channel value per channel-driven part (as many as the species
/// of the shot with the most), turned into rotations at `finish`.
const RECORD_FLOATS: usize = 14;
const RECORD_BYTES: usize = RECORD_FLOATS * 4;
/// Upper bound of the transpose block at `finish`.
const TRANSPOSE_BUDGET_BYTES: usize = 16 << 20;

const F32: json::accessor::ComponentType = json::accessor::ComponentType::F32;

/// Splits a simulated pose into the bee node (path) and body node (body motion) transforms.
///
/// Returns `(bee translation, bee rotation = heading, body rotation = heading⁻¹·orientation)`;
/// the body translation is `(0, 0, sway)`. Then
/// `bee_t + bee_r·(0,0,sway) = position` and `bee_r·body_r = orientation`.
pub fn split_pose(
    position: Vec3,
    heading: Quat,
    orientation: Quat,
    sway: f32,
) -> (Vec3, Quat, Quat) {
    let heading = heading.normalize();
    let body = (heading.conjugate() * orientation.normalize()).normalize();
    (
        position - heading * Vec3::new(0.0, 0.0, sway),
        heading,
        body,
    )
}

/// `q` or `-q` (the same rotation), whichever is nearer `prev`, so that LINEAR (slerp)
/// interpolation between consecutive keys takes the short way round.
pub fn same_hemisphere(prev: Quat, q: Quat) -> Quat {
    if prev.dot(q) < 0.0 { -q } else { q }
}

/// The first key of a track: `w ≥ 0`, purely for tidy, predictable files.
fn canonical(q: Quat) -> Quat {
    if q.w < 0.0 { -q } else { q }
}

/// Rotation of a part driven by a channel: `deg` degrees about `axis`.
pub fn channel_rotation(axis: Vec3, deg: f32) -> Quat {
    Quat::from_axis_angle(axis.normalize(), deg.to_radians())
}

/// Key times: exactly `(frame − start) / fps`, rounded once to f32.
fn key_times(meta: &CacheMeta) -> Vec<f32> {
    (0..meta.frame_count())
        .map(|k| (k as f64 / meta.fps) as f32)
        .collect()
}

/// The node name of a honeybee (`bee_000123`).
pub fn bee_name(id: u64) -> String {
    agent_name(&crate::species::HONEYBEE, id)
}

/// The node name of an agent: `<species.agent>_<id, 6 digits or more>`.
pub fn agent_name(species: &Species, id: u64) -> String {
    format!("{}_{id:06}", species.agent)
}

/// Per-bee state kept in memory between frames (everything else is in the scratch file).
#[derive(Clone, Debug)]
struct BeeState {
    /// First-frame record: the nodes' rest TRS, so a viewer without animation shows frame 1.
    first: [f32; RECORD_FLOATS],
    /// First-frame values of the channels driving parts (`SwarmPlan::driven` order).
    first_driven: Box<[f32]>,
    prev_bee_r: Quat,
    prev_body_r: Quat,
    /// Scale is nominally constant per bee; a scale track is written only if it is not.
    scale_varies: bool,
    /// Hidden at some frame: the agent node gets a STEP scale track (see the module notes).
    hides: bool,
    swarm: usize,
}

/// What one swarm's species takes from its channels.
#[derive(Clone, Debug)]
struct SwarmPlan {
    /// Column of the lateral offset channel (`None`: 0).
    lateral: Option<usize>,
    /// Parts driven by a channel, in part order: (part, channel column, axis).
    driven: Vec<(usize, usize, Vec3)>,
}

pub struct GltfWriter {
    container: Container,
    /// `.glb` or `.gltf` destination.
    dest: PathBuf,
    meta: CacheMeta,
    wings: WingDisplay,
    layout: GltfLayout,
    spill: Option<BufWriter<File>>,
    scratch: ScratchFile,
    /// Bee ids per swarm, from the first frame; every later frame must match.
    ids: Vec<Vec<u64>>,
    plans: Vec<SwarmPlan>,
    /// Bytes spilled per agent per frame (`RECORD_BYTES` + 4 per driven part, padded to the
    /// species with the most).
    record_bytes: usize,
    bees: Vec<BeeState>,
    next_frame: i32,
    record: Vec<u8>,
    /// Size of the transpose block at `finish` (a field so tests can force many blocks).
    transpose_budget: usize,
}

impl GltfWriter {
    pub fn create(
        container: Container,
        path: &Path,
        meta: &CacheMeta,
        opts: &OutputOptions,
    ) -> Result<Self> {
        let flap_hz = opts.wings.flap_hz();
        if !(meta.fps.is_finite() && meta.fps > 0.0) {
            return Err(Error::input(format!(
                "fps must be positive, got {}",
                meta.fps
            )));
        }
        if !(flap_hz.is_finite() && (0.0..=meta.fps / 2.0).contains(&flap_hz)) {
            return Err(Error::input(format!(
                "output.wing_flap_hz = {flap_hz}: must be above 0 and at most half \
                 the frame rate ({}), or the flap aliases",
                meta.fps / 2.0
            )));
        }
        if meta.frame_end < meta.frame_start {
            return Err(Error::input("the frame range is empty"));
        }
        // Keys are f32 seconds; a very long shot at a high rate could round two frames to
        // the same time, which glTF forbids (times must strictly increase).
        if key_times(meta).windows(2).any(|t| t[1] <= t[0]) {
            return Err(Error::input(format!(
                "frames {}..={} at {} fps are too many for glTF's f32 key times; \
                 split the shot or use usda",
                meta.frame_start, meta.frame_end, meta.fps
            )));
        }
        let mut plans = Vec::new();
        for s in &meta.swarms {
            if !(s.body_length_m.is_finite() && s.body_length_m > 0.0) {
                return Err(Error::input(format!(
                    "swarm {}: body length must be positive, got {}",
                    s.name, s.body_length_m
                )));
            }
            s.species
                .check(&s.channels)
                .map_err(|e| Error::input(format!("swarm {}: {e}", s.name)))?;
            let driven = s
                .species
                .parts
                .iter()
                .enumerate()
                .filter_map(|(k, p)| match p.drive {
                    Drive::Channel { channel, axis } => {
                        Some((k, s.channel(channel).expect("checked above"), axis))
                    }
                    _ => None,
                })
                .collect();
            if opts.gltf_layout == GltfLayout::Agent {
                let offsets: Vec<Vec3> = (s.species.meshes)(s.body_length_m)
                    .iter()
                    .map(|pm| pm.offset)
                    .collect();
                agent_parts(s.species, opts.wings, &offsets).map_err(|part| {
                    Error::input(format!(
                        "swarm {}: species {} animates part {part} under a part posed at \
                         rest, which output.gltf_layout = \"agent\" cannot draw; use \"parts\"",
                        s.name, s.species.name
                    ))
                })?;
            }
            plans.push(SwarmPlan {
                lateral: s.lateral_offset(),
                driven,
            });
        }
        let most_driven = plans.iter().map(|p| p.driven.len()).max().unwrap_or(0);
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let scratch = ScratchFile::new(dir, "gltf");
        let file = File::create(&scratch.path).map_err(|e| Error::io(&scratch.path, e))?;
        Ok(GltfWriter {
            container,
            dest: path.to_path_buf(),
            meta: meta.clone(),
            wings: opts.wings,
            layout: opts.gltf_layout,
            spill: Some(BufWriter::with_capacity(1 << 20, file)),
            scratch,
            ids: Vec::new(),
            plans,
            record_bytes: RECORD_BYTES + 4 * most_driven,
            bees: Vec::new(),
            next_frame: meta.frame_start,
            record: Vec::new(),
            transpose_budget: TRANSPOSE_BUDGET_BYTES,
        })
    }

    fn bee_count(&self) -> usize {
        self.bees.len()
    }
}

impl CacheWriter for GltfWriter {
    fn write_frame(&mut self, frame: &Frame) -> Result<()> {
        super::check_frame_order("glTF", &self.meta, self.next_frame, frame)?;
        let first = frame.frame == self.meta.frame_start;
        if first {
            self.ids = frame.swarms.iter().map(|s| s.ids.clone()).collect();
        }
        self.record.clear();
        let mut bee = 0;
        for (si, s) in frame.swarms.iter().enumerate() {
            let n = s.len();
            let lengths = [
                s.position.len(),
                s.heading.len(),
                s.orientation.len(),
                s.scale.len(),
            ];
            let channels_ok = s.channels.len() == self.meta.swarms[si].channels.len()
                && s.channels.iter().all(|c| c.len() == n);
            if lengths.iter().any(|&l| l != n) || !channels_ok || s.ids != self.ids[si] {
                return Err(Error::bake(format!(
                    "glTF writer: swarm {} at frame {} does not have the bees of the first frame",
                    self.meta.swarms[si].name, frame.frame
                )));
            }
            let plan = &self.plans[si];
            for i in 0..n {
                let lateral = s.channel_or_zero(plan.lateral, i);
                // The agent layout's one node holds the simulated pose itself (in the slots
                // of the path node's translation and rotation).
                let (bee_t, bee_r, body_r) = match self.layout {
                    GltfLayout::Parts => {
                        split_pose(s.position[i], s.heading[i], s.orientation[i], lateral)
                    }
                    GltfLayout::Agent => {
                        (s.position[i], s.orientation[i].normalize(), Quat::IDENTITY)
                    }
                };
                let scale = s.scale[i];
                let driven = plan.driven.iter().map(|&(_, c, _)| s.channels[c][i]);
                let finite = bee_t.is_finite()
                    && bee_r.is_finite()
                    && body_r.is_finite()
                    && lateral.is_finite()
                    && driven.clone().all(f32::is_finite)
                    && scale.is_finite()
                    && scale > 0.0;
                if !finite {
                    return Err(Error::bake(format!(
                        "glTF writer: bee {} at frame {} has a non-finite pose or a \
                         non-positive scale",
                        s.ids[i], frame.frame
                    )));
                }
                let (bee_r, body_r) = if first {
                    (canonical(bee_r), canonical(body_r))
                } else {
                    let st = &self.bees[bee];
                    (
                        same_hemisphere(st.prev_bee_r, bee_r),
                        same_hemisphere(st.prev_body_r, body_r),
                    )
                };
                let hidden = s.is_hidden(self.meta.swarms[si].hidden, i);
                let shown = if hidden { 0.0 } else { 1.0 };
                let rec: [f32; RECORD_FLOATS] = [
                    bee_t.x, bee_t.y, bee_t.z, bee_r.x, bee_r.y, bee_r.z, bee_r.w, lateral,
                    body_r.x, body_r.y, body_r.z, body_r.w, scale, shown,
                ];
                // The record's bytes written in place (zero past its floats).
                let at = self.record.len();
                self.record.resize(at + self.record_bytes, 0);
                let bytes = self.record[at..].chunks_exact_mut(4);
                for (b, v) in bytes.zip(rec.into_iter().chain(driven.clone())) {
                    b.copy_from_slice(&v.to_le_bytes());
                }
                if first {
                    self.bees.push(BeeState {
                        first: rec,
                        first_driven: driven.collect(),
                        prev_bee_r: bee_r,
                        prev_body_r: body_r,
                        scale_varies: false,
                        hides: hidden,
                        swarm: si,
                    });
                } else {
                    let st = &mut self.bees[bee];
                    st.prev_bee_r = bee_r;
                    st.prev_body_r = body_r;
                    st.scale_varies |= scale != st.first[12];
                    st.hides |= hidden;
                }
                bee += 1;
            }
        }
        let spill = self.spill.as_mut().expect("spill open until finish");
        spill
            .write_all(&self.record)
            .map_err(|e| Error::io(&self.scratch.path, e))?;
        self.next_frame += 1;
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<Vec<SealedFile>> {
        super::check_all_frames_written("glTF", &self.meta, self.next_frame)?;
        let spill = self.spill.take().expect("spill open until finish");
        spill
            .into_inner()
            .map_err(|e| Error::io(&self.scratch.path, e.into_error()))?;
        let bin_name = bin_file_name(&self.dest);
        let layout = Layout::build(&self, &bin_name);
        match self.container {
            Container::Glb => {
                let mut out = AtomicFile::create(&self.dest)?;
                write_glb(&self, &layout, &mut out)?;
                Ok(vec![out.seal()?])
            }
            Container::Gltf => {
                let bin_path = self.dest.with_file_name(&bin_name);
                let mut bin = AtomicFile::create(&bin_path)?;
                write_bin(&self, &layout, &mut bin)?;
                let mut gltf = AtomicFile::create(&self.dest)?;
                layout
                    .root
                    .to_writer(&mut gltf)
                    .map_err(|e| Error::bake(format!("glTF JSON: {e}")))?;
                // Both files are complete before either is renamed; the .bin goes first so
                // a new .gltf never points at an old buffer.
                Ok(vec![bin.seal()?, gltf.seal()?])
            }
        }
    }
}

/// `<stem>.bin` beside `dest`.
fn bin_file_name(dest: &Path) -> String {
    let stem = dest
        .file_stem()
        .map(|s| s.to_string_lossy())
        .unwrap_or_default();
    format!("{stem}.bin")
}

/// Percent-encodes a file name for use as a relative URI.
fn uri_encode(name: &str) -> String {
    let mut out = String::new();
    for b in name.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// The JSON document plus what is needed to stream the binary buffer that matches it.
struct Layout {
    root: Root,
    /// Meshes, key times and wing tracks: small, built in memory, at the buffer's start.
    head: Vec<u8>,
    /// Byte length of the buffer (head + every bee's tracks).
    total: u64,
}

/// Bytes of one agent's tracks: agent T, agent R, then (parts layout) body T and body R,
/// then S if it varies (body S, or the agent's in the agent layout), then one rotation per
/// channel-driven part, then the agent node's STEP scale if it hides.
fn bee_bytes(st: &BeeState, layout: GltfLayout, frames: usize, driven: usize) -> usize {
    let body = if layout == GltfLayout::Parts {
        12 + 16
    } else {
        0
    };
    let scale = if st.scale_varies { 12 } else { 0 };
    let shown = if st.hides { 12 } else { 0 };
    frames * (12 + 16 + body + scale + 16 * driven + shown)
}

/// The agent node's scale at a frame of its record while it hides: 0 hidden, else 1 (parts
/// layout, whose body node holds the scale) or its scale (agent layout).
fn shown_scale(layout: GltfLayout, rec: &[f32; RECORD_FLOATS]) -> f32 {
    match layout {
        GltfLayout::Parts => rec[13],
        GltfLayout::Agent => rec[12] * rec[13],
    }
}

/// Byte offsets (per frame) in an agent's tracks: (scale, first driven rotation).
fn bee_offsets(layout: GltfLayout, scale_varies: bool) -> (usize, usize) {
    let scale = if layout == GltfLayout::Parts { 56 } else { 28 };
    (scale, scale + if scale_varies { 12 } else { 0 })
}

/// Whether a part moves on its own under a wing display (gets its own animated node).
fn moves(drive: Drive, display: WingDisplay) -> bool {
    match drive {
        Drive::Attitude | Drive::Static => false,
        Drive::Flap { .. } => matches!(display, WingDisplay::Flap { .. }),
        Drive::Channel { .. } => true,
    }
}

/// How the agent layout draws one part.
#[derive(Clone, Copy, Debug)]
struct AgentPart {
    /// In the agent node's one mesh, posed at rest; else a node of its own.
    merged: bool,
    /// Merged: the part's rest transform in the agent frame. A node of its own under a
    /// merged parent: its translation in the agent frame. Else: its offset.
    rotation: Quat,
    translation: Vec3,
}

/// The agent layout of a species for a wing display; `Err(part)` names a moving part whose
/// merged parent is turned at rest (a rotation track would replace that turn), or an
/// attitude part under a moving one.
fn agent_parts(
    sp: &Species,
    display: WingDisplay,
    offsets: &[Vec3],
) -> std::result::Result<Vec<AgentPart>, &'static str> {
    let mut out: Vec<AgentPart> = Vec::with_capacity(sp.parts.len());
    for (k, part) in sp.parts.iter().enumerate() {
        let parent = part.parent.map(|p| out[p]);
        let (pr, pt) = match parent {
            None => (Quat::IDENTITY, Vec3::ZERO),
            Some(p) if p.merged => (p.rotation, p.translation),
            // The attitude part holds the agent's pose: it cannot hang off a moving part.
            Some(_) if part.drive == Drive::Attitude => return Err(part.name),
            Some(_) => {
                out.push(AgentPart {
                    merged: false,
                    rotation: Quat::IDENTITY,
                    translation: offsets[k],
                });
                continue;
            }
        };
        let (own_r, own_t) = match part.drive {
            // The attitude part sits at the agent's centre, whatever its offset.
            Drive::Attitude => (Quat::IDENTITY, Vec3::ZERO),
            Drive::Flap { right } => (
                wings::rotation(wings::rest_up_deg(display, 0), right),
                offsets[k],
            ),
            Drive::Static | Drive::Channel { .. } => (Quat::IDENTITY, offsets[k]),
        };
        let merged = !moves(part.drive, display);
        if !merged && !pr.abs_diff_eq(Quat::IDENTITY, 1e-7) {
            return Err(part.name);
        }
        out.push(AgentPart {
            merged,
            rotation: if merged { pr * own_r } else { Quat::IDENTITY },
            translation: pr * own_t + pt,
        });
    }
    Ok(out)
}

fn pad4(v: &mut Vec<u8>, fill: u8) {
    while !v.len().is_multiple_of(4) {
        v.push(fill);
    }
}

fn f32_bytes(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// A JSON number holding exactly the f32 value (the validator compares bounds exactly).
fn exact(v: f32) -> json::Value {
    json::Value::from(f64::from(v))
}

fn accessor(
    view: Index<json::buffer::View>,
    offset: usize,
    count: usize,
    component: json::accessor::ComponentType,
    type_: json::accessor::Type,
) -> json::Accessor {
    json::Accessor {
        buffer_view: Some(view),
        byte_offset: (offset > 0).then_some(USize64(offset as u64)),
        count: USize64(count as u64),
        component_type: Valid(json::accessor::GenericComponentType(component)),
        extensions: None,
        extras: None,
        type_: Valid(type_),
        min: None,
        max: None,
        name: None,
        normalized: false,
        sparse: None,
    }
}

fn node(name: String) -> json::Node {
    json::Node {
        name: Some(name),
        ..Default::default()
    }
}

fn material(name: &str, rgba: [f32; 4], roughness: f32, blend: bool) -> json::Material {
    json::Material {
        name: Some(name.into()),
        alpha_mode: Valid(if blend {
            json::material::AlphaMode::Blend
        } else {
            json::material::AlphaMode::Opaque
        }),
        double_sided: blend,
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor(rgba),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(roughness),
            ..Default::default()
        },
        ..Default::default()
    }
}

fn raw_extras(v: &serde_json::Value) -> json::Extras {
    serde_json::value::RawValue::from_string(v.to_string()).ok()
}

impl Layout {
    fn build(w: &GltfWriter, bin_name: &str) -> Layout {
        use json::accessor::Type;
        let meta = &w.meta;
        let frames = meta.frame_count();
        let mut root = Root::default();
        let mut head: Vec<u8> = Vec::new();

        let info = serde_json::json!({
            "shot_name": meta.shot_name,
            "fps": meta.fps,
            "frame_start": meta.frame_start,
            "frame_end": meta.frame_end,
            "seed": meta.seed,
            "tool_version": meta.tool_version,
            "wings": w.wings.name(),
            "wing_flap_hz": w.wings.flap_hz(),
            "gltf_layout": w.layout.name(),
            "units": "metres",
            "up_axis": "Y",
        });
        root.asset = json::Asset {
            generator: Some(format!("beeswarm {}", meta.tool_version)),
            version: "2.0".into(),
            extras: raw_extras(&info),
            ..Default::default()
        };
        let buffer = root.push(json::Buffer {
            byte_length: USize64(0), // set below, once every region is placed
            name: None,
            uri: match w.container {
                Container::Glb => None,
                Container::Gltf => Some(uri_encode(bin_name)),
            },
            extensions: None,
            extras: None,
        });
        let view = |root: &mut Root,
                    head: &mut Vec<u8>,
                    bytes: &[u8],
                    target: Option<json::buffer::Target>| {
            let offset = head.len();
            head.extend_from_slice(bytes);
            pad4(head, 0);
            root.push(json::buffer::View {
                buffer,
                byte_length: USize64(bytes.len() as u64),
                byte_offset: (offset > 0).then_some(USize64(offset as u64)),
                byte_stride: None,
                name: None,
                target: target.map(Valid),
                extensions: None,
                extras: None,
            })
        };

        // Materials of every species in the shot, in order of first appearance, shared by
        // every mesh (a material name already pushed is reused).
        let wing_alpha = wings::alpha(w.wings);
        let mut material_names: Vec<&str> = Vec::new();
        let mut species_materials: Vec<(&str, Vec<Index<json::Material>>)> = Vec::new();
        for s in &meta.swarms {
            let sp = s.species;
            if species_materials.iter().any(|(n, _)| *n == sp.name) {
                continue;
            }
            let mut indices = Vec::new();
            for m in sp.materials {
                if let Some(k) = material_names.iter().position(|n| *n == m.name) {
                    indices.push(Index::new(k as u32));
                    continue;
                }
                let [r, g, b] = m.rgb;
                let (alpha, blend) = match m.alpha {
                    Alpha::Opaque => (1.0, false),
                    Alpha::Membrane => (wing_alpha, true),
                };
                material_names.push(m.name);
                indices.push(root.push(material(m.name, [r, g, b, alpha], m.roughness, blend)));
            }
            species_materials.push((sp.name, indices));
        }

        // One mesh set per distinct (species, body length): usually one for the shot.
        struct MeshSet {
            species: &'static str,
            length_bits: u32,
            /// Per part: its mesh, if it has one (and, in the agent layout, a node).
            meshes: Vec<Option<Index<json::Mesh>>>,
            /// Per part: its rest translation in its parent's frame.
            offsets: Vec<Vec3>,
            /// Agent layout: how each part is drawn, and the agent node's mesh.
            agent: Vec<AgentPart>,
            agent_mesh: Option<Index<json::Mesh>>,
        }
        let mut sets: Vec<MeshSet> = Vec::new();
        let mut swarm_set = Vec::new();
        for s in &meta.swarms {
            let sp = s.species;
            let bits = s.body_length_m.to_bits();
            if let Some(k) = sets
                .iter()
                .position(|m| m.species == sp.name && m.length_bits == bits)
            {
                swarm_set.push(k);
                continue;
            }
            let mats = &species_materials
                .iter()
                .find(|(n, _)| *n == sp.name)
                .expect("materials of every species")
                .1;
            let mut part_meshes = (sp.meshes)(s.body_length_m);
            // The wings a display draws: the blur bakes its fan into the wing mesh.
            for (part, pm) in sp.parts.iter().zip(&mut part_meshes) {
                if let Drive::Flap { right } = part.drive {
                    for (p, _) in &mut pm.primitives {
                        *p = wings::mesh(p, w.wings, right);
                    }
                }
            }
            assert_eq!(
                part_meshes.len(),
                sp.parts.len(),
                "species {}: one mesh entry per part",
                sp.name
            );
            let prim =
                |root: &mut Root, head: &mut Vec<u8>, p: &Primitive, mat: Index<json::Material>| {
                    let (lo, hi) = p.bounds();
                    let pos_bytes = f32_bytes(p.positions.iter().flatten().copied());
                    let nrm_bytes = f32_bytes(p.normals.iter().flatten().copied());
                    let idx_bytes: Vec<u8> =
                        p.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
                    let tv = Some(json::buffer::Target::ArrayBuffer);
                    let pv = view(root, head, &pos_bytes, tv);
                    let nv = view(root, head, &nrm_bytes, tv);
                    let iv = view(
                        root,
                        head,
                        &idx_bytes,
                        Some(json::buffer::Target::ElementArrayBuffer),
                    );
                    let n = p.positions.len();
                    let mut pa = accessor(pv, 0, n, F32, Type::Vec3);
                    pa.min = Some(json::Value::Array(lo.into_iter().map(exact).collect()));
                    pa.max = Some(json::Value::Array(hi.into_iter().map(exact).collect()));
                    let pa = root.push(pa);
                    let na = root.push(accessor(nv, 0, n, F32, Type::Vec3));
                    let ia = root.push(accessor(
                        iv,
                        0,
                        p.indices.len(),
                        json::accessor::ComponentType::U16,
                        Type::Scalar,
                    ));
                    json::mesh::Primitive {
                        attributes: [
                            (Valid(json::mesh::Semantic::Positions), pa),
                            (Valid(json::mesh::Semantic::Normals), na),
                        ]
                        .into(),
                        extensions: None,
                        extras: None,
                        indices: Some(ia),
                        material: Some(mat),
                        mode: Valid(json::mesh::Mode::Triangles),
                        targets: None,
                    }
                };
            let tag = format!("{}_{}mm", sp.agent, fmt_mm(s.body_length_m));
            let offsets: Vec<Vec3> = part_meshes.iter().map(|pm| pm.offset).collect();
            let agent = match w.layout {
                GltfLayout::Agent => {
                    agent_parts(sp, w.wings, &offsets).expect("checked when the writer was made")
                }
                GltfLayout::Parts => Vec::new(),
            };
            let mesh = |root: &mut Root,
                        head: &mut Vec<u8>,
                        name: String,
                        prims: &[(Primitive, usize)]| {
                let primitives = prims
                    .iter()
                    .map(|(p, m)| prim(root, head, p, mats[*m]))
                    .collect();
                root.push(json::Mesh {
                    name: Some(name),
                    primitives,
                    extensions: None,
                    extras: None,
                    weights: None,
                })
            };
            let mut meshes = Vec::new();
            for (k, (part, pm)) in sp.parts.iter().zip(&part_meshes).enumerate() {
                let in_agent_mesh = agent.get(k).is_some_and(|a| a.merged);
                meshes.push((!pm.primitives.is_empty() && !in_agent_mesh).then(|| {
                    mesh(
                        &mut root,
                        &mut head,
                        format!("{tag}_{}", part.name),
                        &pm.primitives,
                    )
                }));
            }
            // The agent layout's one mesh: every merged part posed in the agent frame, one
            // primitive per material (fewer primitives import faster).
            let mut merged: Vec<(Primitive, usize)> = Vec::new();
            for (a, pm) in agent.iter().zip(&part_meshes) {
                if !a.merged {
                    continue;
                }
                for (p, m) in &pm.primitives {
                    let posed = p.transformed(a.rotation, a.translation);
                    match merged.iter_mut().find(|(_, mm)| mm == m) {
                        Some((acc, _)) => acc.extend(&posed),
                        None => merged.push((posed, *m)),
                    }
                }
            }
            let agent_mesh =
                (!merged.is_empty()).then(|| mesh(&mut root, &mut head, tag.clone(), &merged));
            swarm_set.push(sets.len());
            sets.push(MeshSet {
                species: sp.name,
                length_bits: bits,
                meshes,
                offsets,
                agent,
                agent_mesh,
            });
        }

        // The one time accessor every sampler shares.
        let bees = w.bee_count();
        let animated = bees > 0;
        let times = key_times(meta);
        let time_acc = animated.then(|| {
            let tv = view(
                &mut root,
                &mut head,
                &f32_bytes(times.iter().copied()),
                None,
            );
            let mut a = accessor(tv, 0, frames, F32, Type::Scalar);
            a.min = Some(json::Value::Array(vec![exact(times[0])]));
            a.max = Some(json::Value::Array(vec![exact(times[frames - 1])]));
            a.name = Some("time".into());
            root.push(a)
        });

        // Wing tracks, one (left, right) pair per phase group in use, shared by many bees.
        let flaps = |s: &crate::sim::SwarmMeta| {
            s.species
                .parts
                .iter()
                .any(|p| matches!(p.drive, Drive::Flap { .. }))
        };
        let flap_hz = w.wings.flap_hz();
        let flapping = animated && flap_hz > 0.0 && meta.swarms.iter().any(flaps);
        let mut wing_tracks: Vec<Option<(Index<json::Accessor>, Index<json::Accessor>)>> =
            vec![None; wings::PHASES as usize];
        if flapping {
            let mut used = [false; wings::PHASES as usize];
            // Only the groups of agents with flapping parts: no unused accessor.
            for (ids, s) in w.ids.iter().zip(&meta.swarms) {
                if flaps(s) {
                    for &id in ids {
                        used[wings::group(id)] = true;
                    }
                }
            }
            let groups: Vec<usize> = (0..wings::PHASES as usize).filter(|&g| used[g]).collect();
            let mut bytes = Vec::new();
            for &g in &groups {
                for right in [false, true] {
                    for k in 0..frames {
                        let t = k as f64 / meta.fps;
                        let q = wings::rotation(wings::angle(flap_hz, t, g), right);
                        bytes.extend(f32_bytes(q.to_array()));
                    }
                }
            }
            let wv = view(&mut root, &mut head, &bytes, None);
            for (slot, &g) in groups.iter().enumerate() {
                let track = |side: usize| (slot * 2 + side) * frames * 16;
                let l = root.push(accessor(wv, track(0), frames, F32, Type::Vec4));
                let r = root.push(accessor(wv, track(1), frames, F32, Type::Vec4));
                wing_tracks[g] = Some((l, r));
            }
        }
        let agent_layout = w.layout == GltfLayout::Agent;

        // Bees: one buffer view per bee holding its tracks back to back.
        let mut offset = head.len() as u64;
        let mut channels = Vec::new();
        let mut samplers = Vec::new();
        let track_as = |samplers: &mut Vec<json::animation::Sampler>,
                        channels: &mut Vec<json::animation::Channel>,
                        node: Index<json::Node>,
                        output: Index<json::Accessor>,
                        path: json::animation::Property,
                        interpolation: json::animation::Interpolation| {
            let sampler = Index::push(
                samplers,
                json::animation::Sampler {
                    extensions: None,
                    extras: None,
                    input: time_acc.expect("tracks only when animated"),
                    interpolation: Valid(interpolation),
                    output,
                },
            );
            channels.push(json::animation::Channel {
                sampler,
                target: json::animation::Target {
                    extensions: None,
                    extras: None,
                    node,
                    path: Valid(path),
                },
                extensions: None,
                extras: None,
            });
        };
        let track = |samplers: &mut Vec<json::animation::Sampler>,
                     channels: &mut Vec<json::animation::Channel>,
                     node: Index<json::Node>,
                     output: Index<json::Accessor>,
                     path: json::animation::Property| {
            let linear = json::animation::Interpolation::Linear;
            track_as(samplers, channels, node, output, path, linear);
        };
        use json::animation::Property::{Rotation, Scale, Translation};
        let mut scene_nodes = Vec::new();
        let mut g = 0;
        for (si, s) in meta.swarms.iter().enumerate() {
            let set = &sets[swarm_set[si]];
            let sp = s.species;
            let plan = &w.plans[si];
            let swarm_root = root.push(node(s.name.clone()));
            scene_nodes.push(swarm_root);
            let mut children = Vec::new();
            // Each part's node, counted from the agent node (None: in the agent mesh).
            let mut slots: Vec<Option<usize>> = Vec::new();
            for k in 0..sp.parts.len() {
                let merged = agent_layout && set.agent[k].merged;
                let next = 1 + slots.iter().flatten().count();
                slots.push((!merged).then_some(next));
            }
            for &id in &w.ids[si] {
                let st = &w.bees[g];
                let f = &st.first;
                g += 1;
                let size = bee_bytes(st, w.layout, frames, plan.driven.len());
                let bv = root.push(json::buffer::View {
                    buffer,
                    byte_length: USize64(size as u64),
                    byte_offset: Some(USize64(offset)),
                    byte_stride: None,
                    name: None,
                    target: None,
                    extensions: None,
                    extras: None,
                });
                offset += size as u64;
                let bee_t = root.push(accessor(bv, 0, frames, F32, Type::Vec3));
                let bee_r = root.push(accessor(bv, frames * 12, frames, F32, Type::Vec4));
                let body_tr = (!agent_layout).then(|| {
                    (
                        root.push(accessor(bv, frames * 28, frames, F32, Type::Vec3)),
                        root.push(accessor(bv, frames * 40, frames, F32, Type::Vec4)),
                    )
                });
                let (scale_at, driven_at) = bee_offsets(w.layout, st.scale_varies);
                let body_s = st
                    .scale_varies
                    .then(|| root.push(accessor(bv, frames * scale_at, frames, F32, Type::Vec3)));
                let driven_at = frames * driven_at;
                let driven_r: Vec<Index<json::Accessor>> = (0..plan.driven.len())
                    .map(|j| {
                        let at = driven_at + j * frames * 16;
                        root.push(accessor(bv, at, frames, F32, Type::Vec4))
                    })
                    .collect();
                let shown_s = st.hides.then(|| {
                    let at = driven_at + plan.driven.len() * frames * 16;
                    root.push(accessor(bv, at, frames, F32, Type::Vec3))
                });

                let name = agent_name(sp, id);
                let group = wings::group(id);
                let wing_pose = |right: bool| {
                    let up = wings::rest_up_deg(w.wings, group);
                    json::scene::UnitQuaternion(wings::rotation(up, right).to_array())
                };
                // Parents before children in the node list, so the document reads top-down:
                // the agent node, then one node per part (that has one) in part order.
                let base = root.nodes.len();
                let at = |k: usize| Index::<json::Node>::new((base + k) as u32);
                let part_node = |k: usize| at(slots[k].expect("a part with a node"));
                // The agent node's children: parts with a node under no part with one.
                let kids = |parent: Option<usize>| {
                    let v: Vec<_> = (0..sp.parts.len())
                        .filter(|&k| {
                            slots[k].is_some()
                                && match parent {
                                    None => sp.parts[k].parent.is_none_or(|p| slots[p].is_none()),
                                    Some(p) => sp.parts[k].parent == Some(p),
                                }
                        })
                        .map(part_node)
                        .collect();
                    (!v.is_empty()).then_some(v)
                };
                let bee = at(0);
                let rest_scale = if st.hides {
                    shown_scale(w.layout, f)
                } else if agent_layout {
                    f[12]
                } else {
                    1.0
                };
                root.push(json::Node {
                    children: kids(None),
                    translation: Some([f[0], f[1], f[2]]),
                    rotation: Some(json::scene::UnitQuaternion([f[3], f[4], f[5], f[6]])),
                    scale: (rest_scale != 1.0).then_some([rest_scale; 3]),
                    mesh: if agent_layout { set.agent_mesh } else { None },
                    ..node(name.clone())
                });
                for (k, part) in sp.parts.iter().enumerate() {
                    if slots[k].is_none() {
                        continue;
                    }
                    let o = if agent_layout {
                        set.agent[k].translation
                    } else {
                        set.offsets[k]
                    };
                    let base = json::Node {
                        mesh: set.meshes[k],
                        children: kids(Some(k)),
                        ..node(format!("{name}_{}", part.name))
                    };
                    let n = match part.drive {
                        Drive::Attitude => json::Node {
                            translation: Some([0.0, 0.0, f[7]]),
                            rotation: Some(json::scene::UnitQuaternion([f[8], f[9], f[10], f[11]])),
                            scale: (f[12] != 1.0).then_some([f[12]; 3]),
                            ..base
                        },
                        Drive::Flap { right } => json::Node {
                            translation: Some(o.to_array()),
                            rotation: Some(wing_pose(right)),
                            ..base
                        },
                        Drive::Channel { axis, .. } => {
                            let j = plan
                                .driven
                                .iter()
                                .position(|d| d.0 == k)
                                .expect("every channel-driven part is planned");
                            let q = canonical(channel_rotation(axis, st.first_driven[j]));
                            json::Node {
                                translation: Some(o.to_array()),
                                rotation: Some(json::scene::UnitQuaternion(q.to_array())),
                                ..base
                            }
                        }
                        Drive::Static => json::Node {
                            translation: Some(o.to_array()),
                            ..base
                        },
                    };
                    root.push(n);
                }
                children.push(bee);
                track(&mut samplers, &mut channels, bee, bee_t, Translation);
                track(&mut samplers, &mut channels, bee, bee_r, Rotation);
                if let Some(s) = shown_s {
                    let step = json::animation::Interpolation::Step;
                    track_as(&mut samplers, &mut channels, bee, s, Scale, step);
                } else if let (true, Some(s)) = (agent_layout, body_s) {
                    track(&mut samplers, &mut channels, bee, s, Scale);
                }
                for (k, part) in sp.parts.iter().enumerate() {
                    if slots[k].is_none() {
                        continue;
                    }
                    let pn = part_node(k);
                    match part.drive {
                        Drive::Attitude => {
                            let (body_t, body_r) = body_tr.expect("parts layout");
                            track(&mut samplers, &mut channels, pn, body_t, Translation);
                            track(&mut samplers, &mut channels, pn, body_r, Rotation);
                            if let Some(body_s) = body_s {
                                track(&mut samplers, &mut channels, pn, body_s, Scale);
                            }
                        }
                        Drive::Flap { right } if flapping => {
                            let (l, r) =
                                wing_tracks[group].expect("a track for every group in use");
                            let out = if right { r } else { l };
                            track(&mut samplers, &mut channels, pn, out, Rotation);
                        }
                        Drive::Channel { .. } => {
                            let j = plan.driven.iter().position(|d| d.0 == k).expect("planned");
                            track(&mut samplers, &mut channels, pn, driven_r[j], Rotation);
                        }
                        Drive::Flap { .. } | Drive::Static => {}
                    }
                }
            }
            if !children.is_empty() {
                root.nodes[swarm_root.value()].children = Some(children);
            }
        }
        if !channels.is_empty() {
            root.push(json::Animation {
                name: Some(meta.shot_name.clone()),
                channels,
                samplers,
                extensions: None,
                extras: None,
            });
        }
        let scene = root.push(json::Scene {
            name: Some(meta.shot_name.clone()),
            nodes: scene_nodes,
            extensions: None,
            extras: raw_extras(&info),
        });
        root.scene = Some(scene);
        root.buffers[buffer.value()].byte_length = USize64(offset);
        Layout {
            root,
            head,
            total: offset,
        }
    }
}

/// Millimetres for a mesh name: `12` for 0.012 m, `11.5` for 0.0115 m.
fn fmt_mm(m: f32) -> String {
    let mm = (f64::from(m) * 1e4).round() / 10.0;
    let s = format!("{mm}");
    s.replace('.', "p")
}

/// Streams the binary buffer: the head, then every bee's tracks, transposed from the
/// frame-major scratch file in blocks of bees so memory stays bounded.
fn write_bin(w: &GltfWriter, layout: &Layout, out: &mut AtomicFile) -> Result<()> {
    let dest = out.dest().to_path_buf();
    let io = |e| Error::io(&dest, e);
    let sio = |e| Error::io(&w.scratch.path, e);
    out.write_all(&layout.head).map_err(io)?;
    let mut written = layout.head.len() as u64;
    let frames = w.meta.frame_count();
    let bees = w.bee_count();
    let mut scratch = File::open(&w.scratch.path).map_err(sio)?;
    let rb = w.record_bytes;
    let block = (w.transpose_budget / (frames * rb)).clamp(1, bees.max(1));
    let mut buf = vec![0u8; block.min(bees) * frames * rb];
    let mut track = Vec::new();
    let mut b0 = 0;
    while b0 < bees {
        let nb = block.min(bees - b0);
        // buf[(f * nb + b) * RECORD_BYTES..] = record of bee b0 + b at frame f
        for f in 0..frames {
            let at = ((f * bees + b0) * rb) as u64;
            scratch.seek(SeekFrom::Start(at)).map_err(sio)?;
            let dst = &mut buf[f * nb * rb..(f + 1) * nb * rb];
            scratch.read_exact(dst).map_err(sio)?;
        }
        for b in 0..nb {
            let rec = |f: usize| &buf[(f * nb + b) * rb..(f * nb + b + 1) * rb];
            track.clear();
            for f in 0..frames {
                track.extend_from_slice(&rec(f)[0..12]); // bee translation
            }
            for f in 0..frames {
                track.extend_from_slice(&rec(f)[12..28]); // bee rotation
            }
            if w.layout == GltfLayout::Parts {
                for f in 0..frames {
                    track.extend_from_slice(&[0; 8]); // body translation (0, 0, sway)
                    track.extend_from_slice(&rec(f)[28..32]);
                }
                for f in 0..frames {
                    track.extend_from_slice(&rec(f)[32..48]); // body rotation
                }
            }
            let st = &w.bees[b0 + b];
            if st.scale_varies {
                for f in 0..frames {
                    let s = &rec(f)[48..52];
                    track.extend_from_slice(&[s, s, s].concat());
                }
            }
            for (j, &(_, _, axis)) in w.plans[st.swarm].driven.iter().enumerate() {
                let mut prev = None;
                for f in 0..frames {
                    let at = RECORD_BYTES + 4 * j;
                    let deg = f32::from_le_bytes(rec(f)[at..at + 4].try_into().expect("4 bytes"));
                    let q = channel_rotation(axis, deg);
                    let q = match prev {
                        None => canonical(q),
                        Some(p) => same_hemisphere(p, q),
                    };
                    prev = Some(q);
                    track.extend_from_slice(&f32_bytes(q.to_array()));
                }
            }
            if st.hides {
                for f in 0..frames {
                    let floats: [f32; RECORD_FLOATS] = std::array::from_fn(|k| {
                        f32::from_le_bytes(rec(f)[4 * k..4 * k + 4].try_into().expect("4 bytes"))
                    });
                    let v = shown_scale(w.layout, &floats);
                    track.extend_from_slice(&f32_bytes([v; 3]));
                }
            }
            out.write_all(&track).map_err(io)?;
            written += track.len() as u64;
        }
        b0 += nb;
    }
    if written != layout.total {
        return Err(Error::bake(format!(
            "glTF writer: wrote {written} buffer bytes, the layout has {}",
            layout.total
        )));
    }
    Ok(())
}

fn write_glb(w: &GltfWriter, layout: &Layout, out: &mut AtomicFile) -> Result<()> {
    let dest = out.dest().to_path_buf();
    let io = |e| Error::io(&dest, e);
    let json_err = |e: serde_json::Error| Error::bake(format!("glTF JSON: {e}"));
    // Serialised into memory first, as the header needs its length (13.7 MB for 10,000
    // bees). Serialised once to count its bytes and again straight into the file, in
    // serde's many small writes, it took 95–110 ms instead of 45–60.
    let json = serde_json::to_vec(&layout.root).map_err(json_err)?;
    let json_len = json.len() as u64;
    let json_pad = (4 - json_len % 4) % 4;
    let bin_pad = (4 - layout.total % 4) % 4;
    let total = 12 + 8 + json_len + json_pad + 8 + layout.total + bin_pad;
    let total = u32::try_from(total).map_err(|_| {
        Error::bake(format!(
            "the glTF cache would be {:.1} GiB, over the 4 GiB limit of a .glb: write \
             `gltf` (separate .bin) or, better for this many bees, `usda`",
            total as f64 / (1u64 << 30) as f64
        ))
    })?;
    let mut header = Vec::with_capacity(20);
    header.extend_from_slice(b"glTF");
    header.extend_from_slice(&2u32.to_le_bytes());
    header.extend_from_slice(&total.to_le_bytes());
    header.extend_from_slice(&((json_len + json_pad) as u32).to_le_bytes());
    header.extend_from_slice(b"JSON");
    out.write_all(&header).map_err(io)?;
    out.write_all(&json).map_err(io)?;
    drop(json);
    // JSON chunks pad with spaces, binary chunks with zeros (GLB spec).
    out.write_all(&b"   "[..json_pad as usize]).map_err(io)?;
    out.write_all(&((layout.total + bin_pad) as u32).to_le_bytes())
        .map_err(io)?;
    out.write_all(b"BIN\0").map_err(io)?;
    write_bin(w, layout, out)?;
    out.write_all(&[0u8; 3][..bin_pad as usize]).map_err(io)?;
    Ok(())
}

#[cfg(test)]
mod tests;
