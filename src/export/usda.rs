//! USDA cache: one `PointInstancer` per swarm, written as text without a USD library.
//!
//! Layout of `<name>.usda` (Y-up, metres, time codes = frame numbers):
//!
//! ```text
//! /<Shot>                          Xform, defaultPrim, kind = "component"
//!     /<swarm>                     PointInstancer: ids, protoIndices, prototypes, and
//!                                  static scales, time-sampled positions, orientations (quath),
//!                                  velocities (m/s), angularVelocities (deg/s), extent,
//!                                  and one primvars:<channel> per channel the model
//!                                  records ("vertex": per instance; a honeybee: pitch,
//!                                  roll, sway, state); a swarm that hides agents (bees
//!                                  inside their hive) also time-samples invisibleIds
//!         /Prototypes/<species>    Scope / Xform (e.g. Prototypes/honeybee; a flapping
//!                                  bee: honeybee_0..7 per phase group; a butterfly:
//!                                  butterfly_0..18 with the wings at -90°..90° of flap,
//!                                  chosen per frame by a time-sampled protoIndices)
//!             /<part>              Mesh per part of the species (body, wing_l, wing_r),
//!                                  real size in metres, body along +X
//! ```
//!
//! USDA stores the time samples of one attribute as one block, but frames arrive one at a
//! time with every attribute. To keep memory bounded, each frame's text of each
//! (swarm, attribute) is appended to its own scratch file as the frame arrives, and
//! `finish` concatenates the scratch files into the layer: memory holds one frame's text.
//!
//! With `usda_clip_frames > 0` the samples go to value clips instead: one layer per chunk
//! of frames in `<name>.clips/`, plus a manifest, and the main layer holds only the
//! static data and the clip metadata. Each clip also carries the first frame of the next
//! chunk, so that sub-frame times at a chunk boundary (motion blur) interpolate exactly as
//! they do in a single-file cache.
//!
//! Every file is committed only when the whole bake succeeded: a failed or interrupted
//! bake leaves the previous cache in place and no temporary file behind.

mod text;

use super::CacheWriter;
use super::wings::{self, WingDisplay};
use crate::atomic::{AtomicFile, ScratchFile, SealedFile};
use crate::error::{Error, Result};
use crate::sim::{CacheMeta, Frame, SwarmFrame, SwarmMeta};
use crate::species::{Alpha, Drive, Primitive, Species};
use glam::Vec3;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use text::{HalfFormatter, push_f32};

/// Instances per formatting task. Large enough that a task outweighs its scheduling,
/// small enough that one big swarm still spreads over every core.
const PIECE: usize = 8192;

/// The time-sampled attributes of each instancer, in the order they are written: the
/// fixed ones, then one primvar per channel of the swarm's model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Attr {
    Positions,
    Orientations,
    Scales,
    Velocities,
    AngularVelocities,
    Extent,
    /// `protoIndices` of a swarm drawn by flap bins (`flap_column`): per instance, the
    /// prototype of the bin of its recorded flap angle (channel column `.0`).
    ProtoIndices(usize),
    /// `primvars:<name>` of the swarm's channel with this index.
    Primvar(usize),
    /// `invisibleIds`: the ids of the instances hidden at the frame (`SwarmMeta::hidden`),
    /// for a swarm that hides any.
    InvisibleIds,
}

/// `scales` is not among them: an instance's scale is constant through a shot (the frame
/// contract), so it is written once, with the static data.
const FIXED_ATTRS: [Attr; 5] = [
    Attr::Positions,
    Attr::Orientations,
    Attr::Velocities,
    Attr::AngularVelocities,
    Attr::Extent,
];

/// Every time-sampled attribute of a swarm's instancer, in order.
fn attrs(m: &SwarmMeta) -> impl Iterator<Item = Attr> + '_ {
    FIXED_ATTRS
        .into_iter()
        .chain(flap_column(m).map(Attr::ProtoIndices))
        .chain((0..m.channels.len()).map(Attr::Primvar))
        .chain(m.hidden.map(|_| Attr::InvisibleIds))
}

/// The channel column of a swarm whose wings are drawn by flap bins: its species turns
/// parts by a recorded `flap` channel (the butterfly) and its model records one. USD
/// instances share their prototypes, so per-instance wing motion is drawn by choosing,
/// each frame, the prototype posed nearest the recorded angle (`wings::flap_bin`).
fn flap_column(m: &SwarmMeta) -> Option<usize> {
    let turns_by_flap = m.species.parts.iter().any(|p| {
        matches!(
            p.drive,
            Drive::Channel {
                channel: "flap",
                ..
            }
        )
    });
    if turns_by_flap {
        m.channel("flap")
    } else {
        None
    }
}

impl Attr {
    /// Type and name, as declared in the layer.
    fn decl(self, m: &SwarmMeta) -> String {
        match self {
            Attr::Positions => "point3f[] positions".into(),
            Attr::Orientations => "quath[] orientations".into(),
            Attr::Scales => "float3[] scales".into(),
            Attr::Velocities => "vector3f[] velocities".into(),
            Attr::AngularVelocities => "vector3f[] angularVelocities".into(),
            Attr::Extent => "float3[] extent".into(),
            Attr::ProtoIndices(_) => "int[] protoIndices".into(),
            Attr::Primvar(c) => format!("float[] primvars:{}", m.channels[c].name),
            Attr::InvisibleIds => "int64[] invisibleIds".into(),
        }
    }

    fn name(self, m: &SwarmMeta) -> String {
        let decl = self.decl(m);
        decl.split(' ').nth(1).expect("type then name").to_owned()
    }

    /// Our primvars are per instance. On a PointInstancer, "vertex" (like "varying")
    /// assigns element i to instance i; "vertex" is what DCCs write and read back.
    fn primvar_doc(self, m: &SwarmMeta) -> Option<&'static str> {
        match self {
            Attr::Primvar(c) => Some(m.channels[c].doc),
            _ => None,
        }
    }

    /// A generous text size of one instance, to size buffers once.
    fn bytes_per_instance(self) -> usize {
        match self {
            Attr::Positions | Attr::Scales | Attr::Velocities | Attr::AngularVelocities => {
                3 * 16 + 6
            }
            Attr::Orientations => 4 * 11 + 8,
            Attr::Extent | Attr::InvisibleIds => 0,
            Attr::ProtoIndices(_) => 4,
            Attr::Primvar(_) => 16 + 2,
        }
    }
}

/// One formatting task: the text of instances `start..end` of one attribute of one swarm
/// at the current frame, separators included, so pieces concatenate to the array's text
/// whatever order the threads finish in.
struct Piece {
    swarm: usize,
    attr: Attr,
    start: usize,
    end: usize,
    text: Vec<u8>,
    /// First instance whose value is not finite.
    bad: Option<usize>,
}

impl Piece {
    fn format(
        &mut self,
        s: &SwarmFrame,
        radius: f32,
        half: HalfFormatter,
        hidden: Option<(usize, f32)>,
    ) {
        let out = &mut self.text;
        out.clear();
        self.bad = None;
        let r = self.start..self.end;
        let sep = |out: &mut Vec<u8>, i: usize| {
            if i > 0 {
                out.extend_from_slice(b", ");
            }
        };
        let vec3s = |out: &mut Vec<u8>, vs: &[Vec3]| -> Option<usize> {
            for (i, v) in r.clone().zip(vs) {
                if !v.is_finite() {
                    return Some(i);
                }
                sep(out, i);
                push_vec3(out, *v);
            }
            None
        };
        let floats = |out: &mut Vec<u8>, vs: &[f32]| -> Option<usize> {
            for (i, &v) in r.clone().zip(vs) {
                if !v.is_finite() {
                    return Some(i);
                }
                sep(out, i);
                push_f32(out, v);
            }
            None
        };
        self.bad = match self.attr {
            Attr::Positions => vec3s(out, &s.position[r.clone()]),
            Attr::Velocities => vec3s(out, &s.velocity[r.clone()]),
            Attr::AngularVelocities => vec3s(out, &s.angular_velocity_deg[r.clone()]),
            Attr::Scales => {
                let mut bad = None;
                for (i, &v) in r.clone().zip(&s.scale[r.clone()]) {
                    if !v.is_finite() {
                        bad = Some(i);
                        break;
                    }
                    sep(out, i);
                    // Uniform: format the number once, copy it thrice.
                    out.push(b'(');
                    let at = out.len();
                    push_f32(out, v);
                    let end = out.len();
                    for _ in 0..2 {
                        out.extend_from_slice(b", ");
                        out.extend_from_within(at..end);
                    }
                    out.push(b')');
                }
                bad
            }
            Attr::Orientations => {
                let mut bad = None;
                for (i, q) in r.clone().zip(&s.orientation[r.clone()]) {
                    if !q.is_finite() {
                        bad = Some(i);
                        break;
                    }
                    sep(out, i);
                    // USDA writes quaternions real part first: (w, x, y, z).
                    out.push(b'(');
                    half.push(out, q.w);
                    out.extend_from_slice(b", ");
                    half.push(out, q.x);
                    out.extend_from_slice(b", ");
                    half.push(out, q.y);
                    out.extend_from_slice(b", ");
                    half.push(out, q.z);
                    out.push(b')');
                }
                bad
            }
            Attr::Primvar(c) => floats(out, &s.channels[c][r.clone()]),
            Attr::InvisibleIds => {
                // One piece over the whole swarm (like the extent): the list is sparse.
                let mut ib = itoa::Buffer::new();
                for i in r.clone().filter(|&i| s.is_hidden(hidden, i)) {
                    if !out.is_empty() {
                        out.extend_from_slice(b", ");
                    }
                    // Shot ids fit int64 (see `write_static`).
                    out.extend_from_slice(ib.format(s.ids[i] as i64).as_bytes());
                }
                None
            }
            Attr::ProtoIndices(c) => {
                let mut ib = itoa::Buffer::new();
                let mut bad = None;
                for (i, &v) in r.clone().zip(&s.channels[c][r.clone()]) {
                    if !v.is_finite() {
                        bad = Some(i);
                        break;
                    }
                    sep(out, i);
                    out.extend_from_slice(ib.format(wings::flap_bin(v)).as_bytes());
                }
                bad
            }
            Attr::Extent => {
                // A bound of every instance under any rotation: the prototype's bound
                // radius times the instance's scale around its position. Conservative,
                // cheap, and it contains the box USD computes from the prototypes.
                let mut lo = Vec3::ZERO;
                let mut hi = Vec3::ZERO;
                let mut bad = None;
                for (i, (p, sc)) in s.position.iter().zip(&s.scale).enumerate() {
                    let reach = Vec3::splat(radius * sc.abs());
                    let (a, b) = (*p - reach, *p + reach);
                    if !(a.is_finite() && b.is_finite()) {
                        bad = Some(i);
                        break;
                    }
                    (lo, hi) = if i == 0 {
                        (a, b)
                    } else {
                        (lo.min(a), hi.max(b))
                    };
                }
                push_vec3(out, lo);
                out.extend_from_slice(b", ");
                push_vec3(out, hi);
                bad
            }
        };
    }
}

#[inline]
fn push_vec3(out: &mut Vec<u8>, v: Vec3) {
    out.push(b'(');
    push_f32(out, v.x);
    out.extend_from_slice(b", ");
    push_f32(out, v.y);
    out.extend_from_slice(b", ");
    push_f32(out, v.z);
    out.push(b')');
}

/// Scratch files a writer keeps open between frames, at most. A shot of many swarms has
/// more (eight or so per swarm): they are then opened for each frame's append and closed
/// again, so the process stays far below the usual 1,024-file limit whatever the count.
const OPEN_SPILLS: usize = 128;

/// The scratch file collecting one (swarm, attribute)'s sample lines for one chunk.
struct Spill {
    scratch: ScratchFile,
    /// Open while the chunk has few enough spills (see `OPEN_SPILLS`).
    w: Option<BufWriter<File>>,
}

impl Spill {
    /// The writer, opened for appending if it was closed.
    fn writer(&mut self) -> Result<&mut BufWriter<File>> {
        if self.w.is_none() {
            let f = std::fs::OpenOptions::new()
                .append(true)
                .open(&self.scratch.path)
                .map_err(io(&self.scratch.path))?;
            // Smaller than a full piece (8,192 instances of text), which then goes
            // straight to the file instead of being copied through the buffer.
            self.w = Some(BufWriter::with_capacity(64 << 10, f));
        }
        Ok(self.w.as_mut().expect("opened above"))
    }

    /// Flushes and, unless `keep_open`, closes the writer.
    fn settle(&mut self, keep_open: bool) -> Result<()> {
        if let Some(w) = self.w.as_mut() {
            w.flush().map_err(io(&self.scratch.path))?;
        }
        if !keep_open {
            self.w = None;
        }
        Ok(())
    }
}

/// The samples of the frames `start..` not yet written into a layer.
struct Chunk {
    start: i32,
    /// Index `UsdaWriter::first_spill[swarm] + attribute`.
    spills: Vec<Spill>,
}

/// A finished clip layer, complete and closed, waiting for the bake to succeed.
struct PendingClip {
    scratch: ScratchFile,
    dest: PathBuf,
    start: i32,
}

/// About how many bytes of samples one instance adds per frame (positions, orientations,
/// velocities, angular velocities, three bee channels): 180, measured on
/// `examples/grassland.toml` (43.3 MB for 1,000 bees × 240 frames). `beeswarm check`
/// predicts cache sizes from it too.
pub const BYTES_PER_INSTANCE_FRAME: u64 = 180;
/// A cache up to this size is one file by default; a larger one is split into value clips.
const ONE_FILE_MAX_BYTES: u64 = 1 << 30;
/// The size of one default value clip.
const CLIP_BYTES: u64 = 256 << 20;

/// Frames per value clip when the shot does not say: 0 (one file) for a cache up to
/// about 1 GiB of samples, else clips of about 256 MiB. Besides opening faster, clips are
/// written while the bake runs, so a large bake ends without copying gigabytes of samples
/// after its last frame.
pub fn auto_clip_frames(meta: &CacheMeta) -> u32 {
    let instances: u64 = meta.swarms.iter().map(|s| s.count as u64).sum();
    clip_frames_for(instances, meta.frame_count() as u64)
}

/// [`auto_clip_frames`] for `instances` over `frames`.
pub fn clip_frames_for(instances: u64, frames: u64) -> u32 {
    let per_frame = instances.max(1) * BYTES_PER_INSTANCE_FRAME;
    if per_frame * frames <= ONE_FILE_MAX_BYTES {
        0
    } else {
        (CLIP_BYTES / per_frame).clamp(1, frames) as u32
    }
}

pub struct UsdaWriter {
    meta: CacheMeta,
    dest: PathBuf,
    /// Where scratch files go: beside the destination, so nothing crosses filesystems.
    dir: PathBuf,
    root: String,
    /// Frames per value clip, 0 = one file.
    clip_frames: usize,
    clips_dir: PathBuf,
    created_clips_dir: bool,
    /// Per swarm: the ids of the first frame (they must not change) and the bound radius
    /// of one prototype at scale 1.
    ids: Vec<Vec<u64>>,
    /// Per swarm: the scales of the first frame (they must not change either), written
    /// once as a static attribute.
    scales: Vec<Vec<f32>>,
    radius: Vec<f32>,
    /// Per swarm: the prototype geometry of its species, one mesh per part.
    protos: Vec<Vec<ProtoPart>>,
    /// Per swarm: what the flap bins saw, for posing the bins' other parts.
    bins: Vec<BinStats>,
    wings: WingDisplay,
    /// Per swarm: the index of its first attribute's spill in a chunk.
    first_spill: Vec<usize>,
    pieces: Vec<Piece>,
    half: HalfFormatter,
    next_frame: i32,
    chunk: Option<Chunk>,
    clips: Vec<PendingClip>,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |e| Error::io(path, e)
}

impl UsdaWriter {
    pub fn create(
        path: &Path,
        meta: &CacheMeta,
        clip_frames: u32,
        wings: WingDisplay,
    ) -> Result<Self> {
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf();
        let protos: Vec<Vec<ProtoPart>> = meta
            .swarms
            .iter()
            .map(|s| proto_parts(s.species, s.body_length_m, wings))
            .collect();
        let radius = protos.iter().map(|p| bound_radius(p)).collect();
        let bins = meta
            .swarms
            .iter()
            .zip(&protos)
            .map(|(m, parts)| BinStats::new(m, parts))
            .collect();
        let mut first_spill = Vec::new();
        let mut spills = 0;
        for s in &meta.swarms {
            first_spill.push(spills);
            spills += attrs(s).count();
        }
        let clips_dir = dir.join(format!("{}.clips", meta.shot_name));
        let mut created_clips_dir = false;
        // What a bake killed outright left among the clips goes first.
        crate::atomic::remove_stale_temporaries(&clips_dir);
        if clip_frames > 0 && !clips_dir.is_dir() {
            std::fs::create_dir_all(&clips_dir).map_err(io(&clips_dir))?;
            created_clips_dir = true;
        }
        Ok(UsdaWriter {
            meta: meta.clone(),
            dest: path.to_path_buf(),
            dir,
            root: text::prim_name(&meta.shot_name),
            clip_frames: clip_frames as usize,
            clips_dir,
            created_clips_dir,
            ids: Vec::new(),
            scales: Vec::new(),
            radius,
            protos,
            bins,
            wings,
            first_spill,
            pieces: Vec::new(),
            half: HalfFormatter::new(),
            next_frame: meta.frame_start,
            chunk: None,
            clips: Vec::new(),
        })
    }

    /// Checks a frame against the contract: in order, every swarm present with its
    /// constant count and ids, every per-bee vector of that length.
    fn check(&mut self, frame: &Frame) -> Result<()> {
        super::check_frame_order("USDA", &self.meta, self.next_frame, frame)?;
        for (k, (s, m)) in frame.swarms.iter().zip(&self.meta.swarms).enumerate() {
            let n = s.ids.len();
            let lens = [
                s.position.len(),
                s.velocity.len(),
                s.orientation.len(),
                s.angular_velocity_deg.len(),
                s.scale.len(),
            ];
            let channels_ok =
                s.channels.len() == m.channels.len() && s.channels.iter().all(|c| c.len() == n);
            if n != m.count || lens.iter().any(|&l| l != n) || !channels_ok {
                return Err(Error::bake(format!(
                    "USDA writer: swarm \"{}\" at frame {} has {n} ids and per-bee arrays of \
                     {lens:?} and {} channel columns; expected {} bees and {} channels \
                     (instance count is constant through a shot)",
                    m.name,
                    frame.frame,
                    s.channels.len(),
                    m.count,
                    m.channels.len()
                )));
            }
            match self.scales.get(k) {
                None => self.scales.push(s.scale.clone()),
                Some(first) if *first != s.scale => {
                    return Err(Error::bake(format!(
                        "USDA writer: swarm \"{}\" changed an instance's scale at frame {} \
                         (scales are constant through a shot and written once)",
                        m.name, frame.frame
                    )));
                }
                Some(_) => {}
            }
            match self.ids.get(k) {
                None => self.ids.push(s.ids.clone()),
                Some(first) if *first != s.ids => {
                    return Err(Error::bake(format!(
                        "USDA writer: swarm \"{}\" changed its bee ids or their order at frame {}",
                        m.name, frame.frame
                    )));
                }
                Some(_) => {}
            }
        }
        Ok(())
    }

    /// The formatting tasks, fixed for the shot since counts are constant.
    fn plan_pieces(&mut self) {
        for (k, m) in self.meta.swarms.iter().enumerate() {
            for attr in attrs(m) {
                let whole = matches!(attr, Attr::Extent | Attr::InvisibleIds);
                let ranges: Vec<(usize, usize)> = if whole || m.count == 0 {
                    vec![(0, m.count)]
                } else {
                    (0..m.count)
                        .step_by(PIECE)
                        .map(|a| (a, (a + PIECE).min(m.count)))
                        .collect()
                };
                for (start, end) in ranges {
                    self.pieces.push(Piece {
                        swarm: k,
                        attr,
                        start,
                        end,
                        text: Vec::with_capacity((end - start) * attr.bytes_per_instance() + 128),
                        bad: None,
                    });
                }
            }
        }
    }

    fn new_chunk(&self, start: i32) -> Result<Chunk> {
        let mut spills = Vec::new();
        for m in &self.meta.swarms {
            for attr in attrs(m) {
                let scratch = ScratchFile::new(
                    &self.dir,
                    &format!("usda.{}.{}", m.name, attr.name(m).replace(':', "_")),
                );
                File::create(&scratch.path).map_err(io(&scratch.path))?;
                spills.push(Spill { w: None, scratch });
            }
        }
        Ok(Chunk { start, spills })
    }

    /// Appends the formatted frame to a chunk's scratch files.
    fn spill(pieces: &[Piece], frame: i32, chunk: &mut Chunk) -> Result<()> {
        let mut head = Vec::with_capacity(32);
        head.extend_from_slice(b"            ");
        head.extend_from_slice(itoa::Buffer::new().format(frame).as_bytes());
        head.extend_from_slice(b": [");
        // Pieces are ordered by (swarm, attribute) like the spills, one group per spill;
        // each spill is its own file, so they are written in parallel.
        let groups: Vec<&[Piece]> = pieces
            .chunk_by(|a, b| a.swarm == b.swarm && a.attr == b.attr)
            .collect();
        debug_assert_eq!(groups.len(), chunk.spills.len());
        let keep_open = chunk.spills.len() <= OPEN_SPILLS;
        chunk
            .spills
            .par_iter_mut()
            .zip(groups)
            .try_for_each(|(spill, group)| {
                let path = spill.scratch.path.clone();
                let w = spill.writer()?;
                w.write_all(&head).map_err(io(&path))?;
                for p in group {
                    w.write_all(&p.text).map_err(io(&path))?;
                }
                w.write_all(b"],\n").map_err(io(&path))?;
                spill.settle(keep_open)
            })
    }

    /// Writes one swarm's time-sample blocks from a chunk's scratch files.
    fn copy_samples(
        &self,
        chunk: &mut Chunk,
        swarm: usize,
        out: &mut impl Write,
        out_path: &Path,
    ) -> Result<()> {
        let m = &self.meta.swarms[swarm];
        for (a, attr) in attrs(m).enumerate() {
            if crate::atomic::interrupted() {
                return Err(Error::bake(
                    "interrupted while writing the USDA layer: no cache was written; the previous cache is untouched",
                ));
            }
            let spill = &mut chunk.spills[self.first_spill[swarm] + a];
            spill.settle(false)?;
            let mut src = File::open(&spill.scratch.path).map_err(io(&spill.scratch.path))?;
            writeln!(out, "        {}.timeSamples = {{", attr.decl(m)).map_err(io(out_path))?;
            std::io::copy(&mut src, out).map_err(io(out_path))?;
            out.write_all(b"        }\n").map_err(io(out_path))?;
        }
        Ok(())
    }

    fn clip_dest(&self, index: usize, count: usize) -> PathBuf {
        self.clips_dir
            .join(clip_file_name(&self.meta.shot_name, index, count))
    }

    /// Writes the current chunk as a complete clip layer, left uncommitted.
    fn close_chunk(&mut self, mut chunk: Chunk) -> Result<()> {
        let index = self.clips.len();
        let count = self.clip_count();
        let dest = self.clip_dest(index, count);
        let scratch = ScratchFile::new(&self.clips_dir, "usda.clip");
        let path = scratch.path.clone();
        // Not hashed as it is written (unlike `AtomicFile`): the samples are copied in by
        // the kernel (`io::copy` between files), and the bake hashes the clips in parallel
        // at its end, which costs less than hashing them here on the writer's thread, the
        // bottleneck of a large USDA bake (100,000 bees: 33 s against 28 s).
        let mut out = BufWriter::with_capacity(1 << 20, File::create(&path).map_err(io(&path))?);
        let last = (chunk.start + self.clip_frames as i32).min(self.meta.frame_end);
        let mut head = String::new();
        let _ = write!(
            head,
            "#usda 1.0\n(\n    doc = {}\n)\n\nover \"{}\"\n{{\n",
            text::quoted(&format!(
                "Value clip {} of {count} of shot \"{}\": frames {}-{last}. Written by beeswarm {}.",
                index + 1,
                self.meta.shot_name,
                chunk.start,
                self.meta.tool_version
            )),
            self.root
        );
        out.write_all(head.as_bytes()).map_err(io(&path))?;
        for (k, m) in self.meta.swarms.iter().enumerate() {
            write!(out, "    over \"{}\"\n    {{\n", m.name).map_err(io(&path))?;
            self.copy_samples(&mut chunk, k, &mut out, &path)?;
            out.write_all(b"    }\n").map_err(io(&path))?;
        }
        out.write_all(b"}\n\n").map_err(io(&path))?;
        let file = out
            .into_inner()
            .map_err(|e| Error::io(&path, e.into_error()))?;
        file.sync_all().map_err(io(&path))?;
        self.clips.push(PendingClip {
            scratch,
            dest,
            start: chunk.start,
        });
        Ok(())
    }

    fn clip_count(&self) -> usize {
        self.meta.frame_count().div_ceil(self.clip_frames.max(1))
    }

    /// The layer header: stage metadata and what made the cache.
    fn header(&self) -> String {
        let m = &self.meta;
        let fps = text::f64_text(m.fps);
        format!(
            "#usda 1.0\n(\n    customLayerData = {{\n        uint64 seed = {}\n        string shotName = {}\n        \
             string toolVersion = {}\n    }}\n    defaultPrim = \"{}\"\n    doc = {}\n    endTimeCode = {}\n    \
             framesPerSecond = {fps}\n    metersPerUnit = 1\n    startTimeCode = {}\n    timeCodesPerSecond = {fps}\n    \
             upAxis = \"Y\"\n)\n\n",
            m.seed,
            text::quoted(&m.shot_name),
            text::quoted(&m.tool_version),
            self.root,
            text::quoted(
                "Honeybee swarm cache: one PointInstancer per swarm. Metres, seconds, Y up."
            ),
            m.frame_end,
            m.frame_start,
        )
    }

    /// Static instancer data: ids, prototype indices, scales, the prototype relationship.
    fn write_static(&self, swarm: usize, out: &mut impl Write, path: &Path) -> Result<()> {
        let m = &self.meta.swarms[swarm];
        let mut t = Vec::with_capacity(m.count * 12 + 256);
        let mut ib = itoa::Buffer::new();
        t.extend_from_slice(b"        int64[] ids = [");
        for (i, id) in self.ids[swarm].iter().enumerate() {
            if i > 0 {
                t.extend_from_slice(b", ");
            }
            // Shot ids fit int64 by construction; a u64 above i64::MAX would be written as
            // its int64 bit pattern, which is what USD would read back from binary.
            t.extend_from_slice(ib.format(*id as i64).as_bytes());
        }
        t.extend_from_slice(b"]\n");
        // Flap bins choose the prototype per frame: protoIndices is time-sampled then.
        if flap_column(m).is_none() {
            t.extend_from_slice(b"        int[] protoIndices = [");
            let phased = self.phased(swarm);
            for (i, &id) in self.ids[swarm].iter().enumerate() {
                if i > 0 {
                    t.extend_from_slice(b", ");
                }
                // Flapping: the prototype of the bee's phase group, as in glTF.
                let index = if phased { wings::group(id) } else { 0 };
                t.extend_from_slice(ib.format(index).as_bytes());
            }
            t.extend_from_slice(b"]\n");
        }
        // Uniform scales, constant through the shot: formatted like a time sample.
        let mut scales = Piece {
            swarm,
            attr: Attr::Scales,
            start: 0,
            end: m.count,
            text: Vec::with_capacity(m.count * Attr::Scales.bytes_per_instance()),
            bad: None,
        };
        let frame = SwarmFrame {
            scale: self.scales[swarm].clone(),
            ..SwarmFrame::default()
        };
        scales.format(&frame, 0.0, self.half, None);
        if scales.bad.is_some() {
            return Err(Error::bake(format!(
                "USDA writer: swarm \"{}\" has a scale that is not finite",
                m.name
            )));
        }
        t.extend_from_slice(b"        float3[] scales = [");
        t.extend_from_slice(&scales.text);
        t.extend_from_slice(b"]\n");
        let targets: Vec<String> = self
            .proto_names(swarm)
            .iter()
            .map(|p| format!("</{}/{}/Prototypes/{p}>", self.root, m.name))
            .collect();
        let _ = writeln!(
            Wrap(&mut t),
            "        rel prototypes = {}",
            if targets.len() == 1 {
                targets[0].clone()
            } else {
                format!("[{}]", targets.join(", "))
            }
        );
        out.write_all(&t).map_err(io(path))
    }

    /// Whether a swarm's wings flap: then it has one prototype per phase group.
    fn phased(&self, swarm: usize) -> bool {
        self.wings.flap_hz() > 0.0 && self.protos[swarm].iter().any(|p| p.flap.is_some())
    }

    /// The prototype names of a swarm: `<species>`, or `<species>_<group>` per phase group,
    /// or `<species>_<bin>` per flap bin.
    fn proto_names(&self, swarm: usize) -> Vec<String> {
        let sp = self.meta.swarms[swarm].species.name;
        if flap_column(&self.meta.swarms[swarm]).is_some() {
            (0..wings::FLAP_BINS).map(|k| format!("{sp}_{k}")).collect()
        } else if self.phased(swarm) {
            (0..wings::PHASES).map(|g| format!("{sp}_{g}")).collect()
        } else {
            vec![sp.to_owned()]
        }
    }

    /// The prototype subtree of one instancer: `Prototypes/<species>[_<group>]/<part>`.
    fn prototypes(&self, swarm: usize) -> String {
        let mut s = String::from("\n        def Scope \"Prototypes\"\n        {\n");
        let names = self.proto_names(swarm);
        for (g, name) in names.iter().enumerate() {
            if g > 0 {
                // The other phase groups (flap bins) reference the first one's geometry and
                // override only their wings' turn samples (turn): the meshes are written once.
                let _ = write!(
                    s,
                    "\n            def Xform \"{name}\" (\n                prepend references = </{}/{}/Prototypes/{}>\n            )\n            {{\n",
                    self.root, self.meta.swarms[swarm].name, names[0]
                );
                let mut first = true;
                for part in &self.protos[swarm] {
                    let turn = self.part_turn(swarm, part, g);
                    if let Turn::None = turn {
                        continue;
                    }
                    if !first {
                        s.push('\n');
                    }
                    first = false;
                    let _ = write!(
                        s,
                        "                over \"{}\"\n                {{\n",
                        part.name
                    );
                    let ind = "                    ";
                    match turn {
                        Turn::Sampled(samples) => turn_samples(&mut s, ind, &samples),
                        Turn::Still(op, deg) => {
                            let _ = writeln!(s, "{ind}float xformOp:{op} = {}", f32_text(deg));
                        }
                        Turn::None => {}
                    }
                    s.push_str("                }\n");
                }
                s.push_str("            }\n");
                continue;
            }
            let _ = write!(s, "            def Xform \"{name}\"\n            {{\n");
            for (k, part) in self.protos[swarm].iter().enumerate() {
                if k > 0 {
                    s.push('\n');
                }
                mesh_text(
                    &mut s,
                    &self.looks_path(),
                    part,
                    self.part_turn(swarm, part, g),
                );
            }
            s.push_str("            }\n");
        }
        s.push_str("        }\n");
        s
    }

    /// `/<root>/Looks`, where every material of the shot is.
    fn looks_path(&self) -> String {
        format!("/{}/Looks", self.root)
    }

    /// A part's turn about its hinge in prototype `g` of a swarm: the bin's flap angle for a
    /// part turned by the `flap` channel of a binned swarm; for another channel-driven part
    /// of it (the abdomen), the mean of its channel over every (instance, frame) of the bin
    /// (0 for an empty bin); else as the wing display says.
    fn part_turn(&self, swarm: usize, part: &ProtoPart, g: usize) -> Turn {
        let binned = flap_column(&self.meta.swarms[swarm]).is_some();
        match (part.channel_flap, part.channel_turn) {
            (Some(sign), _) if binned => Turn::Still("rotateX", sign * wings::flap_bin_deg(g)),
            (_, Some((channel, op, sign))) if binned => {
                let bins = &self.bins[swarm];
                let mean = bins
                    .sums
                    .iter()
                    .find(|(c, _)| self.meta.swarms[swarm].channels[*c].name == channel)
                    .filter(|_| bins.counts[g] > 0)
                    .map_or(0.0, |(_, sums)| sums[g] / bins.counts[g] as f64);
                Turn::Still(op, sign * mean as f32)
            }
            _ => self.wing_turn(part, self.phased(swarm).then_some(g)),
        }
    }

    /// A part's turn about its hinge (degrees about X): none, a still angle, or one sample
    /// per frame for phase group `flap`.
    fn wing_turn(&self, part: &ProtoPart, flap: Option<usize>) -> Turn {
        let Some(right) = part.flap else {
            return Turn::None;
        };
        match (self.wings, flap) {
            (WingDisplay::Flap { hz }, Some(g)) => {
                let m = &self.meta;
                let samples = (m.frame_start..=m.frame_end)
                    .map(|f| {
                        let t = (f - m.frame_start) as f64 / m.fps;
                        (f, wings::turn_deg(wings::angle(hz, t, g), right))
                    })
                    .collect();
                Turn::Sampled(samples)
            }
            (display, _) => match wings::rest_up_deg(display, 0) {
                0.0 => Turn::None,
                up => Turn::Still("rotateX", wings::turn_deg(up, right)),
            },
        }
    }

    /// The `Looks` scope: one `UsdPreviewSurface` material per material of the species in
    /// the shot (shared by every swarm), bound by the prototype meshes.
    fn looks(&self) -> String {
        let mut done: Vec<&str> = Vec::new();
        let mut s = String::from("    def Scope \"Looks\"\n    {\n");
        for sw in &self.meta.swarms {
            for mat in sw.species.materials {
                if done.contains(&mat.name) {
                    continue;
                }
                if !done.is_empty() {
                    s.push('\n');
                }
                done.push(mat.name);
                let path = format!("{}/{}", self.looks_path(), mat.name);
                let opacity = match mat.alpha {
                    Alpha::Opaque => 1.0,
                    Alpha::Membrane => wings::alpha(self.wings),
                };
                let [r, g, b] = mat.rgb;
                let _ = write!(
                    s,
                    "        def Material \"{name}\"\n        {{\n            \
                     token outputs:surface.connect = <{path}/PreviewSurface.outputs:surface>\n\n            \
                     def Shader \"PreviewSurface\"\n            {{\n                \
                     uniform token info:id = \"UsdPreviewSurface\"\n                \
                     color3f inputs:diffuseColor = ({}, {}, {})\n                \
                     float inputs:metallic = 0\n                \
                     float inputs:opacity = {}\n                \
                     float inputs:roughness = {}\n                \
                     token outputs:surface\n            }}\n        }}\n",
                    f32_text(r),
                    f32_text(g),
                    f32_text(b),
                    f32_text(opacity),
                    f32_text(mat.roughness),
                    name = mat.name,
                );
            }
        }
        s.push_str("    }\n\n");
        s
    }

    /// Instancer opening line with its metadata.
    fn instancer_open(&self, swarm: usize) -> String {
        let m = &self.meta.swarms[swarm];
        format!(
            "    def PointInstancer \"{}\" (\n        customData = {{\n            float beeLength = {}\n            \
             float wingBeatHz = {}\n        }}\n    )\n    {{\n",
            m.name,
            f32_text(m.body_length_m),
            f32_text(m.wing_beat_hz)
        )
    }

    fn finish_single(mut self) -> Result<Vec<SealedFile>> {
        let mut chunk = self.chunk.take().expect("at least one frame was written");
        let mut file = AtomicFile::create(&self.dest)?;
        let path = self.dest.clone();
        let mut head = self.header();
        let _ = write!(
            head,
            "def Xform \"{}\" (\n    kind = \"component\"\n)\n{{\n",
            self.root
        );
        head.push_str(&self.looks());
        file.writer()
            .write_all(head.as_bytes())
            .map_err(io(&path))?;
        for k in 0..self.meta.swarms.len() {
            let out = file.writer();
            out.write_all(self.instancer_open(k).as_bytes())
                .map_err(io(&path))?;
            self.write_static(k, out, &path)?;
            let m = &self.meta.swarms[k];
            for attr in attrs(m) {
                if let Some(doc) = attr.primvar_doc(m) {
                    write!(
                        out,
                        "        {} (\n{}        )\n",
                        attr.decl(m),
                        primvar_meta(doc)
                    )
                    .map_err(io(&path))?;
                }
            }
            self.copy_samples(&mut chunk, k, out, &path)?;
            out.write_all(self.prototypes(k).as_bytes())
                .map_err(io(&path))?;
            out.write_all(b"    }\n").map_err(io(&path))?;
        }
        file.writer().write_all(b"}\n\n").map_err(io(&path))?;
        drop(chunk);
        // A previous bake of this shot in clips mode left clip layers that nothing will
        // reference any more once this layer is in place.
        let stale = stale_clips(&self.clips_dir, &self.meta.shot_name, &[]);
        Ok(vec![file.seal()?.remove_after_commit(stale)])
    }

    fn finish_clips(mut self) -> Result<Vec<SealedFile>> {
        let chunk = self.chunk.take().expect("at least one frame was written");
        self.close_chunk(chunk)?;
        let manifest_dest = self
            .clips_dir
            .join(format!("{}.manifest.usda", self.meta.shot_name));
        let rel = |p: &Path| {
            format!(
                "@./{}.clips/{}@",
                self.meta.shot_name,
                p.file_name().expect("clip file name").to_string_lossy()
            )
        };

        // Manifest: every attribute that has samples in the clips, typed, without values.
        // It spares USD from opening every clip to learn what they contain.
        let mut manifest = AtomicFile::create(&manifest_dest)?;
        let mut t = format!(
            "#usda 1.0\n(\n    doc = {}\n)\n\nover \"{}\"\n{{\n",
            text::quoted("Value clip manifest: the attributes the clips hold samples for."),
            self.root
        );
        for m in &self.meta.swarms {
            let _ = write!(t, "    over \"{}\"\n    {{\n", m.name);
            for attr in attrs(m) {
                let _ = writeln!(t, "        {}", attr.decl(m));
            }
            t.push_str("    }\n");
        }
        t.push_str("}\n\n");
        manifest
            .write_all(t.as_bytes())
            .map_err(io(&manifest_dest))?;

        let mut main = AtomicFile::create(&self.dest)?;
        let path = self.dest.clone();
        let mut t = self.header();
        let _ = write!(
            t,
            "def Xform \"{}\" (\n    clips = {{\n        dictionary default = {{\n",
            self.root
        );
        t.push_str("            double2[] active = [");
        for (i, c) in self.clips.iter().enumerate() {
            let _ = write!(t, "{}({}, {i})", if i > 0 { ", " } else { "" }, c.start);
        }
        t.push_str("]\n            asset[] assetPaths = [");
        for (i, c) in self.clips.iter().enumerate() {
            let _ = write!(t, "{}{}", if i > 0 { ", " } else { "" }, rel(&c.dest));
        }
        let (a, b) = (self.meta.frame_start, self.meta.frame_end);
        // Clip time = stage time: the clips hold samples at the frame numbers themselves.
        let times = if a == b {
            format!("({a}, {a})")
        } else {
            format!("({a}, {a}), ({b}, {b})")
        };
        let _ = write!(
            t,
            "]\n            asset manifestAssetPath = {}\n            string primPath = \"/{}\"\n            \
             double2[] times = [{times}]\n        }}\n    }}\n    kind = \"component\"\n)\n{{\n",
            rel(&manifest_dest),
            self.root
        );
        t.push_str(&self.looks());
        main.write_all(t.as_bytes()).map_err(io(&path))?;
        for k in 0..self.meta.swarms.len() {
            let out = main.writer();
            out.write_all(self.instancer_open(k).as_bytes())
                .map_err(io(&path))?;
            self.write_static(k, out, &path)?;
            // Declared here so the composed stage knows their types; values come from
            // the clips.
            let m = &self.meta.swarms[k];
            for attr in attrs(m) {
                match attr.primvar_doc(m) {
                    Some(doc) => write!(
                        out,
                        "        {} (\n{}        )\n",
                        attr.decl(m),
                        primvar_meta(doc)
                    ),
                    None => writeln!(out, "        {}", attr.decl(m)),
                }
                .map_err(io(&path))?;
            }
            out.write_all(self.prototypes(k).as_bytes())
                .map_err(io(&path))?;
            out.write_all(b"    }\n").map_err(io(&path))?;
        }
        main.writer().write_all(b"}\n\n").map_err(io(&path))?;

        // The layers the main one depends on are committed first, so that the main layer
        // never names a clip that is not in place.
        let mut sealed = Vec::new();
        let mut written = Vec::new();
        for c in std::mem::take(&mut self.clips) {
            written.push(c.dest.clone());
            sealed.push(c.scratch.seal_as(c.dest)?);
        }
        sealed.push(manifest.seal()?);
        let stale = stale_clips(&self.clips_dir, &self.meta.shot_name, &written);
        sealed.push(main.seal()?.remove_after_commit(stale));
        Ok(sealed)
    }
}

/// `std::fmt::Write` over a byte buffer.
struct Wrap<'a>(&'a mut Vec<u8>);

impl std::fmt::Write for Wrap<'_> {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.0.extend_from_slice(s.as_bytes());
        Ok(())
    }
}

fn f32_text(v: f32) -> String {
    let mut out = Vec::new();
    push_f32(&mut out, v);
    String::from_utf8(out).expect("ryu writes ASCII")
}

fn primvar_meta(doc: &str) -> String {
    format!(
        "            doc = {}\n            interpolation = \"vertex\"\n",
        text::quoted(doc)
    )
}

fn clip_file_name(shot: &str, index: usize, count: usize) -> String {
    let width = count.to_string().len().max(4);
    format!("{shot}.{:0width$}.usda", index + 1)
}

/// Clip layers of an earlier bake of this shot that the new cache does not use: only
/// files named exactly as this writer names them. They are removed (and their folder, if
/// then empty) once the new main layer is in place.
fn stale_clips(clips_dir: &Path, shot: &str, keep: &[PathBuf]) -> Vec<PathBuf> {
    let mut stale_files = Vec::new();
    let Ok(entries) = std::fs::read_dir(clips_dir) else {
        return stale_files;
    };
    let prefix = format!("{shot}.");
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(middle) = name
            .strip_prefix(&prefix)
            .and_then(|r| r.strip_suffix(".usda"))
        else {
            continue;
        };
        let path = e.path();
        // The manifest goes with clips mode as a whole; clip layers one by one.
        let stale = if middle == "manifest" {
            keep.is_empty()
        } else {
            !middle.is_empty()
                && middle.bytes().all(|b| b.is_ascii_digit())
                && !keep.contains(&path)
        };
        if stale {
            stale_files.push(path);
        }
    }
    stale_files
}

/// One part of a prototype: its mesh (the wing a display draws), where it sits in the body
/// frame, and whether it is a wing (`Some(right)`) that turns about its hinge.
#[derive(Clone, Debug)]
struct ProtoPart {
    name: &'static str,
    /// Primitives with their material (`Species::materials` index), in the part frame.
    prims: Vec<(Primitive, usize)>,
    materials: Vec<(&'static str, Alpha, [f32; 3])>,
    /// Opacity of the membrane materials under the wing display.
    membrane_opacity: f32,
    /// The part frame's origin in the body frame (a wing: its hinge).
    translate: Vec3,
    flap: Option<bool>,
    /// A part turned by the `flap` channel (itself or a parent, `Drive::Channel` about
    /// ±X): the sign of that axis, so the prototype's turn about X is `sign × flap`.
    channel_flap: Option<f32>,
    /// A part with a mesh turned by another channel (`Drive::Channel`, no channel-driven
    /// parent: the butterfly's abdomen): (channel, `rotateX|Y|Z`, sign of the axis).
    channel_turn: Option<(&'static str, &'static str, f32)>,
}

/// The prototype of a species: its meshes (`Species::meshes`, as glTF draws them) flattened
/// into the body frame, one Mesh prim per part with a mesh. A part's parents only move it
/// (the honeybee's and every species' parts hang off an unturned body); a channel-driven
/// part rests at 0 (USD instances share their prototypes, so per-agent part motion is not
/// drawn), except that a swarm with flap bins poses the parts the `flap` channel turns at
/// each bin's angle, one prototype per bin (`flap_column`).
fn proto_parts(sp: &Species, length: f32, display: WingDisplay) -> Vec<ProtoPart> {
    let meshes = (sp.meshes)(length);
    assert_eq!(
        meshes.len(),
        sp.parts.len(),
        "species {}: one mesh entry per part",
        sp.name
    );
    let mut at: Vec<Vec3> = Vec::new();
    let mut flap_sign: Vec<Option<f32>> = Vec::new();
    let mut turned: Vec<bool> = Vec::new();
    let mut out = Vec::new();
    for (part, pm) in sp.parts.iter().zip(meshes) {
        let parent = part.parent.map_or(Vec3::ZERO, |p| at[p]);
        // The flap turns its part and every part below it; the parts between a flap and
        // its mesh (the butterfly's feather) rest at 0, so one turn about X poses the mesh.
        let channel_flap = match part.drive {
            Drive::Channel {
                channel: "flap",
                axis,
            } => {
                assert!(
                    axis.y == 0.0 && axis.z == 0.0 && axis.x.abs() == 1.0,
                    "species {}: part {} flaps about ±X",
                    sp.name,
                    part.name
                );
                Some(axis.x)
            }
            _ => part.parent.and_then(|p| flap_sign[p]),
        };
        flap_sign.push(channel_flap);
        // Only a part hanging from unturned parents: one turn at its own joint poses it.
        let under_channel = part.parent.is_some_and(|p| turned[p]);
        turned.push(under_channel || matches!(part.drive, Drive::Channel { .. }));
        let channel_turn = match part.drive {
            Drive::Channel { channel, axis } if channel != "flap" && !under_channel => {
                Some(axis_op(sp, part.name, channel, axis))
            }
            _ => None,
        };
        let translate = match part.drive {
            // The attitude part sits at the agent's centre.
            Drive::Attitude => parent,
            _ => parent + pm.offset,
        };
        at.push(translate);
        if pm.primitives.is_empty() {
            continue;
        }
        let flap = match part.drive {
            Drive::Flap { right } => Some(right),
            _ => None,
        };
        let prims = pm
            .primitives
            .into_iter()
            .map(|(p, m)| match flap {
                Some(right) => (wings::mesh(&p, display, right), m),
                None => (p, m),
            })
            .collect();
        out.push(ProtoPart {
            name: part.name,
            prims,
            materials: sp
                .materials
                .iter()
                .map(|m| (m.name, m.alpha, m.rgb))
                .collect(),
            membrane_opacity: wings::alpha(display),
            translate,
            flap,
            channel_flap,
            channel_turn,
        });
    }
    out
}

/// The `rotateX|Y|Z` op and sign of a turn about a signed unit axis of the part frame.
fn axis_op(
    sp: &Species,
    part: &str,
    channel: &'static str,
    axis: Vec3,
) -> (&'static str, &'static str, f32) {
    let ops = ["rotateX", "rotateY", "rotateZ"];
    let k = (0..3)
        .find(|&k| axis[k].abs() == 1.0 && axis.length_squared() == 1.0)
        .unwrap_or_else(|| panic!("species {}: part {part} turns about a unit axis", sp.name));
    (channel, ops[k], axis[k])
}

/// The radius of a sphere at the origin holding the corners of the prototype's bounding
/// box at any time (a wing swept through every turn about its hinge line). USD bounds an
/// instancer by each instance's transformed prototype box, so a sphere around the box,
/// not around the points, is what contains `ComputeExtentAtTime` under every rotation.
fn bound_radius(parts: &[ProtoPart]) -> f32 {
    let (mut lo, mut hi) = (Vec3::MAX, Vec3::MIN);
    for part in parts {
        for (prim, _) in &part.prims {
            for p in &prim.positions {
                let p = Vec3::from(*p);
                let turns_x = part.flap.is_some() || part.channel_flap.is_some();
                let (a, b) = match (turns_x, part.channel_turn) {
                    // Turning about X keeps x and the distance from the hinge line.
                    (true, _) | (_, Some((_, "rotateX", _))) => {
                        let r = p.y.hypot(p.z);
                        (Vec3::new(p.x, -r, -r), Vec3::new(p.x, r, r))
                    }
                    (_, Some((_, "rotateY", _))) => {
                        let r = p.x.hypot(p.z);
                        (Vec3::new(-r, p.y, -r), Vec3::new(r, p.y, r))
                    }
                    (_, Some(_)) => {
                        let r = p.x.hypot(p.y);
                        (Vec3::new(-r, -r, p.z), Vec3::new(r, r, p.z))
                    }
                    (false, None) => (p, p),
                };
                lo = lo.min(a + part.translate);
                hi = hi.max(b + part.translate);
            }
        }
    }
    lo.abs().max(hi.abs()).length()
}

/// Per flap bin of a swarm: how many (instance, frame) pairs fell in it, and the sum of
/// each posed channel (the abdomen's) over them, summed in frame and instance order so the
/// means are the same with any thread count. The abdomen moves against the flap (paper 004
/// Table 3: same frequency, opposite phase): within a 10° bin of the aggregation example
/// its angle spreads ±0.7° (standard deviation), so the bin's mean poses it closely.
struct BinStats {
    /// The flap channel's column; `None` for a swarm without flap bins (nothing kept).
    flap: Option<usize>,
    counts: Vec<u64>,
    /// (channel column, sum per bin).
    sums: Vec<(usize, Vec<f64>)>,
}

impl BinStats {
    fn new(m: &SwarmMeta, parts: &[ProtoPart]) -> Self {
        let flap = flap_column(m);
        let mut sums: Vec<(usize, Vec<f64>)> = Vec::new();
        if flap.is_some() {
            for (channel, _, _) in parts.iter().filter_map(|p| p.channel_turn) {
                if let Some(c) = m.channel(channel)
                    && !sums.iter().any(|(k, _)| *k == c)
                {
                    sums.push((c, vec![0.0; wings::FLAP_BINS]));
                }
            }
        }
        BinStats {
            flap,
            counts: vec![0; wings::FLAP_BINS],
            sums,
        }
    }

    /// Counts one frame of the swarm (its values already checked finite).
    fn add(&mut self, s: &SwarmFrame) {
        let Some(fc) = self.flap else {
            return;
        };
        for (i, &a) in s.channels[fc].iter().enumerate() {
            let b = wings::flap_bin(a);
            self.counts[b] += 1;
            for (c, sums) in &mut self.sums {
                sums[b] += s.channels[*c][i] as f64;
            }
        }
    }
}

/// A part's turn about its hinge, degrees: a wing's about its hinge line (part X), a
/// butterfly's abdomen about its joint's axis.
enum Turn {
    None,
    /// A still turn, degrees, by the op `rotateX`, `rotateY` or `rotateZ`.
    Still(&'static str, f32),
    /// (frame, degrees), one per frame.
    Sampled(Vec<(i32, f32)>),
}

/// A wing's time-sampled turn about its hinge line.
fn turn_samples(s: &mut String, ind: &str, samples: &[(i32, f32)]) {
    let _ = writeln!(s, "{ind}float xformOp:rotateX.timeSamples = {{");
    for (f, deg) in samples {
        let _ = writeln!(s, "{ind}    {f}: {},", f32_text(*deg));
    }
    let _ = writeln!(s, "{ind}}}");
}

/// Merges the `seam` vertices equal in position and normal (where a part's material prims
/// meet), remapping `indices`: the surface and its shading are unchanged, and readers that
/// check for weldable points (Omniverse's asset validator) have none to report. Other
/// vertices stay apart: two closed shells touching at a pole would otherwise become one
/// non-manifold vertex. Vertices keep the order of their first use (deterministic).
fn weld(
    points: &[Vec3],
    normals: &[Vec3],
    seam: &[bool],
    indices: &mut [i32],
) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut first = std::collections::HashMap::new();
    let mut remap = Vec::with_capacity(points.len());
    let (mut out_p, mut out_n) = (Vec::new(), Vec::new());
    for i in 0..points.len() {
        let next = out_p.len() as i32;
        let j = if seam[i] {
            // +0.0 and -0.0 are one position; bits make the key exact and hashable.
            let (p, n) = (points[i], normals[i]);
            let key = [p.x, p.y, p.z, n.x, n.y, n.z].map(|v| (v + 0.0).to_bits());
            *first.entry(key).or_insert(next)
        } else {
            next
        };
        if j == next {
            out_p.push(points[i]);
            out_n.push(normals[i]);
        }
        remap.push(j);
    }
    for i in indices.iter_mut() {
        *i = remap[*i as usize];
    }
    (out_p, out_n)
}

/// Which of a triangle list's `n` vertices lie on an edge of only one triangle.
fn open_edge_vertices(indices: &[u16], n: usize) -> Vec<bool> {
    let tris = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]].map(u32::from));
    let mut open = vec![false; n];
    for (&(a, b), &(uses, _)) in &crate::geometry::mesh::edge_uses(tris) {
        if uses == 1 {
            open[a as usize] = true;
            open[b as usize] = true;
        }
    }
    open
}

/// One mesh prim of the prototype: triangles with vertex normals, bound to the shot's
/// `Looks` materials (one `GeomSubset` per material when it has several, as the body's
/// bands), with `displayColor`/`displayOpacity` for viewers that draw no materials.
fn mesh_text(s: &mut String, looks: &str, part: &ProtoPart, turn: Turn) {
    let ind = "                    ";
    let mut points: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut indices: Vec<i32> = Vec::new();
    // Vertices on an open edge of their prim: where two material prims meet.
    let mut seam: Vec<bool> = Vec::new();
    // Faces per material, in order of first use.
    let mut subsets: Vec<(usize, Vec<usize>)> = Vec::new();
    let mut face_material = Vec::new();
    for (prim, m) in &part.prims {
        let base = points.len() as i32;
        let first_face = indices.len() / 3;
        seam.extend(open_edge_vertices(&prim.indices, prim.positions.len()));
        points.extend(prim.positions.iter().map(|p| Vec3::from(*p)));
        normals.extend(prim.normals.iter().map(|n| Vec3::from(*n)));
        indices.extend(prim.indices.iter().map(|&i| base + i as i32));
        let faces = first_face..indices.len() / 3;
        face_material.extend(faces.clone().map(|_| *m));
        match subsets.iter_mut().find(|(mm, _)| mm == m) {
            Some((_, f)) => f.extend(faces),
            None => subsets.push((*m, faces.collect())),
        }
    }
    let (points, normals) = weld(&points, &normals, &seam, &mut indices);
    let vec3_list = |vs: &[Vec3]| {
        let mut t = Vec::new();
        for (i, v) in vs.iter().enumerate() {
            if i > 0 {
                t.extend_from_slice(b", ");
            }
            push_vec3(&mut t, *v);
        }
        String::from_utf8(t).expect("ASCII")
    };
    let ints = |vs: &mut dyn Iterator<Item = i64>| {
        vs.map(|v| v.to_string()).collect::<Vec<_>>().join(", ")
    };
    let material = |m: usize| part.materials[m];
    let binding = |m: usize| format!("rel material:binding = <{looks}/{}>", material(m).0);
    let membrane = subsets
        .iter()
        .any(|&(m, _)| material(m).1 == Alpha::Membrane);
    let _ = writeln!(
        s,
        "{}def Mesh \"{}\" (\n{ind}prepend apiSchemas = [\"MaterialBindingAPI\"]\n{}){}{{",
        &ind[4..],
        part.name,
        &ind[4..],
        format_args!("\n{}", &ind[4..])
    );
    if membrane {
        // Wings are single sheets, seen from both sides.
        let _ = writeln!(s, "{ind}uniform bool doubleSided = 1");
    }
    let (mut lo, mut hi) = (Vec3::MAX, Vec3::MIN);
    for p in &points {
        (lo, hi) = (lo.min(*p), hi.max(*p));
    }
    let _ = writeln!(s, "{ind}float3[] extent = [{}]", vec3_list(&[lo, hi]));
    let _ = writeln!(
        s,
        "{ind}int[] faceVertexCounts = [{}]",
        ints(&mut (0..indices.len() / 3).map(|_| 3))
    );
    let _ = writeln!(
        s,
        "{ind}int[] faceVertexIndices = [{}]",
        ints(&mut indices.iter().map(|&i| i as i64))
    );
    if subsets.len() == 1 {
        let _ = writeln!(s, "{ind}{}", binding(subsets[0].0));
    }
    let _ = writeln!(
        s,
        "{ind}normal3f[] normals = [{}] (\n{ind}    interpolation = \"vertex\"\n{ind})",
        vec3_list(&normals)
    );
    let _ = writeln!(s, "{ind}point3f[] points = [{}]", vec3_list(&points));
    // One colour per material, indexed per face (an indexed primvar: the colours repeat).
    let palette: Vec<Vec3> = subsets
        .iter()
        .map(|&(m, _)| Vec3::from(material(m).2))
        .collect();
    let interpolation = if subsets.len() == 1 {
        "constant"
    } else {
        "uniform"
    };
    let _ = writeln!(
        s,
        "{ind}color3f[] primvars:displayColor = [{}] (\n{ind}    interpolation = \"{interpolation}\"\n{ind})",
        vec3_list(&palette)
    );
    if subsets.len() > 1 {
        let slot = |m: usize| subsets.iter().position(|&(mm, _)| mm == m).unwrap_or(0) as i64;
        let _ = writeln!(
            s,
            "{ind}int[] primvars:displayColor:indices = [{}]",
            ints(&mut face_material.iter().map(|&m| slot(m)))
        );
    }
    if membrane {
        let _ = writeln!(
            s,
            "{ind}float[] primvars:displayOpacity = [{}] (\n{ind}    interpolation = \"constant\"\n{ind})",
            f32_text(part.membrane_opacity)
        );
    }
    // Rendered as is, not subdivided.
    let _ = writeln!(s, "{ind}uniform token subdivisionScheme = \"none\"");
    if subsets.len() > 1 {
        let _ = writeln!(
            s,
            "{ind}uniform token subsetFamily:materialBind:familyType = \"partition\""
        );
    }
    let mut ops = Vec::new();
    if part.translate != Vec3::ZERO {
        let mut t = Vec::new();
        push_vec3(&mut t, part.translate);
        let _ = writeln!(
            s,
            "{ind}double3 xformOp:translate = {}",
            String::from_utf8(t).expect("ASCII")
        );
        ops.push("\"xformOp:translate\"");
    }
    match turn {
        Turn::None => {}
        Turn::Still(op, deg) => {
            let _ = writeln!(s, "{ind}float xformOp:{op} = {}", f32_text(deg));
            ops.push(match op {
                "rotateX" => "\"xformOp:rotateX\"",
                "rotateY" => "\"xformOp:rotateY\"",
                _ => "\"xformOp:rotateZ\"",
            });
        }
        Turn::Sampled(samples) => {
            turn_samples(s, ind, &samples);
            ops.push("\"xformOp:rotateX\"");
        }
    }
    if !ops.is_empty() {
        let _ = writeln!(
            s,
            "{ind}uniform token[] xformOpOrder = [{}]",
            ops.join(", ")
        );
    }
    if subsets.len() > 1 {
        for (m, faces) in &subsets {
            let _ = write!(
                s,
                "\n{ind}def GeomSubset \"{}\" (\n{ind}    prepend apiSchemas = [\"MaterialBindingAPI\"]\n{ind})\n{ind}{{\n\
                 {ind}    uniform token elementType = \"face\"\n{ind}    uniform token familyName = \"materialBind\"\n\
                 {ind}    int[] indices = [{}]\n{ind}    {}\n{ind}}}\n",
                material(*m).0,
                ints(&mut faces.iter().map(|&f| f as i64)),
                binding(*m)
            );
        }
    }
    let _ = writeln!(s, "{}}}", &ind[4..]);
}

impl CacheWriter for UsdaWriter {
    fn write_frame(&mut self, frame: &Frame) -> Result<()> {
        self.check(frame)?;
        if self.pieces.is_empty() {
            self.plan_pieces();
        }
        let (radius, half, swarms) = (&self.radius, self.half, &self.meta.swarms);
        self.pieces.par_iter_mut().for_each(|p| {
            p.format(
                &frame.swarms[p.swarm],
                radius[p.swarm],
                half,
                swarms[p.swarm].hidden,
            )
        });
        if let Some(p) = self.pieces.iter().find(|p| p.bad.is_some()) {
            let i = p.bad.expect("found a bad piece");
            return Err(Error::bake(format!(
                "USDA writer: swarm \"{}\", bee {}: {} is not finite at frame {}",
                self.meta.swarms[p.swarm].name,
                frame.swarms[p.swarm].ids[i],
                match p.attr {
                    Attr::Extent => "position".to_owned(),
                    // The bin comes from the flap channel: name the channel.
                    Attr::ProtoIndices(c) => Attr::Primvar(c).name(&self.meta.swarms[p.swarm]),
                    a => a.name(&self.meta.swarms[p.swarm]),
                },
                frame.frame
            )));
        }

        for (bins, s) in self.bins.iter_mut().zip(frame.swarms) {
            bins.add(s);
        }
        let f = frame.frame;
        match self.chunk.take() {
            None => self.chunk = Some(self.new_chunk(f)?),
            Some(mut c) if self.clip_frames > 0 && f == c.start + self.clip_frames as i32 => {
                // The first frame of the next clip ends the previous one too (see the
                // module comment on sub-frame interpolation at a boundary).
                Self::spill(&self.pieces, f, &mut c)?;
                self.close_chunk(c)?;
                self.chunk = Some(self.new_chunk(f)?);
            }
            Some(c) => self.chunk = Some(c),
        }
        Self::spill(&self.pieces, f, self.chunk.as_mut().expect("chunk open"))?;
        self.next_frame += 1;
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<Vec<SealedFile>> {
        super::check_all_frames_written("USDA", &self.meta, self.next_frame)?;
        if self.clip_frames > 0 {
            self.finish_clips()
        } else {
            self.finish_single()
        }
    }
}

impl Drop for UsdaWriter {
    fn drop(&mut self) {
        // Scratch files and uncommitted clips delete themselves; remove the clip folder
        // too if this writer made it and nothing was committed into it.
        self.chunk = None;
        self.clips.clear();
        if self.created_clips_dir {
            let _ = std::fs::remove_dir(&self.clips_dir);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::SwarmMeta;
    use glam::Quat;

    fn meta(counts: &[usize], frames: (i32, i32)) -> CacheMeta {
        CacheMeta {
            shot_name: "test-shot".into(),
            fps: 24.0,
            frame_start: frames.0,
            frame_end: frames.1,
            seed: 7,
            tool_version: "0.1.0".into(),
            swarms: counts
                .iter()
                .enumerate()
                .map(|(k, &count)| SwarmMeta {
                    name: format!("swarm{k}"),
                    count,
                    species: &crate::species::HONEYBEE,
                    channels: crate::species::BEE_CHANNELS.to_vec(),
                    body_length_m: 0.012,
                    wing_beat_hz: 230.0,
                    hidden: None,
                })
                .collect(),
        }
    }

    #[test]
    fn large_caches_default_to_value_clips_of_about_256_mib() {
        // 10,000 bees × 240 frames ≈ 0.43 GB: one file.
        assert_eq!(auto_clip_frames(&meta(&[6000, 4000], (1, 240))), 0);
        // 100,000 × 240 ≈ 4.3 GB: clips of 14 frames (100,000 × 180 B × 14 ≈ 252 MB).
        let clip = auto_clip_frames(&meta(&[100_000], (1, 240)));
        assert_eq!(clip, 14);
        // A huge swarm gets one frame per clip, never 0.
        assert_eq!(auto_clip_frames(&meta(&[10_000_000], (1, 3))), 1);
    }

    /// Deterministic, varied values: negative, tiny, integral, zero.
    fn swarm_frame(count: usize, frame: i32, first_id: u64) -> SwarmFrame {
        let t = frame as f32 * 0.1;
        let mut s = SwarmFrame {
            channels: vec![Vec::new(); crate::species::BEE_CHANNELS.len()],
            ..Default::default()
        };
        for i in 0..count {
            let a = i as f32 * 0.37 + t;
            s.ids.push(first_id + i as u64);
            s.position
                .push(Vec3::new(a.sin(), 1.0 + 0.25 * i as f32, -a.cos() * 1e-3));
            s.velocity.push(Vec3::new(a.cos(), 0.0, -2.5));
            let q = Quat::from_rotation_y(a) * Quat::from_rotation_z(0.3 * a.sin());
            s.orientation.push(q);
            s.heading.push(Quat::from_rotation_y(a));
            s.channels[0].push(17.19 * a.sin());
            s.channels[1].push(-3.0);
            s.channels[2].push(1e-7 * i as f32);
            s.channels[3].push((i % 3) as f32);
            s.angular_velocity_deg.push(Vec3::new(0.0, 57.3, 1.5));
            s.scale.push(1.0 + 0.01 * i as f32);
        }
        s
    }

    fn bake(dir: &Path, m: &CacheMeta, clip_frames: u32) -> Result<Vec<PathBuf>> {
        let path = dir.join(format!("{}.usda", m.shot_name));
        let mut w: Box<dyn CacheWriter> = Box::new(UsdaWriter::create(
            &path,
            m,
            clip_frames,
            WingDisplay::Blur,
        )?);
        for f in m.frame_start..=m.frame_end {
            let mut first = 100;
            let swarms: Vec<SwarmFrame> = m
                .swarms
                .iter()
                .map(|s| {
                    first += 1000;
                    swarm_frame(s.count, f, first)
                })
                .collect();
            w.write_frame(&Frame {
                frame: f,
                time: (f - m.frame_start) as f64 / m.fps,
                swarms: &swarms,
            })?;
        }
        crate::atomic::commit_all(w.finish()?)
    }

    fn files(dir: &Path) -> Vec<String> {
        let mut out = Vec::new();
        for e in walk(dir) {
            out.push(e.strip_prefix(dir).unwrap().to_string_lossy().into_owned());
        }
        out.sort();
        out
    }

    fn walk(dir: &Path) -> Vec<PathBuf> {
        let mut out = Vec::new();
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                out.push(p.clone());
                out.extend(walk(&p));
            } else {
                out.push(p);
            }
        }
        out
    }

    #[test]
    fn single_file_layout_and_metadata() {
        let dir = tempfile::tempdir().unwrap();
        let m = meta(&[3, 2], (1, 4));
        let out = bake(dir.path(), &m, 0).unwrap();
        assert_eq!(out, vec![dir.path().join("test-shot.usda")]);
        assert_eq!(
            files(dir.path()),
            vec!["test-shot.usda"],
            "no scratch file left"
        );
        let t = std::fs::read_to_string(&out[0]).unwrap();
        for needle in [
            "#usda 1.0\n(\n",
            "defaultPrim = \"test_shot\"",
            "upAxis = \"Y\"",
            "metersPerUnit = 1\n",
            "startTimeCode = 1\n",
            "endTimeCode = 4\n",
            "timeCodesPerSecond = 24\n",
            "framesPerSecond = 24\n",
            "uint64 seed = 7",
            "string shotName = \"test-shot\"",
            "string toolVersion = \"0.1.0\"",
            "def Xform \"test_shot\"",
            "def PointInstancer \"swarm0\"",
            "def PointInstancer \"swarm1\"",
            "int64[] ids = [1100, 1101, 1102]\n",
            "int64[] ids = [2100, 2101]\n",
            "int[] protoIndices = [0, 0, 0]\n",
            "rel prototypes = </test_shot/swarm0/Prototypes/honeybee>",
            "float[] primvars:pitch (\n",
            "float[] primvars:roll (\n",
            "float[] primvars:sway (\n",
            "doc = \"Body pitch, degrees, nose up positive (about body +Z).\"",
            "interpolation = \"vertex\"",
            "def Xform \"honeybee\"",
            "def Mesh \"body\"",
            "def Mesh \"wing_l\"",
            "def Mesh \"wing_r\"",
            "def Scope \"Looks\"",
            "def Material \"bee_yellow\"",
            "uniform token info:id = \"UsdPreviewSurface\"",
            "color3f inputs:diffuseColor = (0.85, 0.55, 0.05)",
            "float inputs:opacity = 0.16",
            "prepend apiSchemas = [\"MaterialBindingAPI\"]",
            "uniform token subsetFamily:materialBind:familyType = \"partition\"",
            "def GeomSubset \"bee_black\"",
            "rel material:binding = </test_shot/Looks/bee_wing>",
            "normal3f[] normals = [",
            "float[] primvars:displayOpacity = [0.16]",
        ] {
            assert!(t.contains(needle), "missing {needle:?}");
        }
        for attr in attrs(&m.swarms[0]) {
            let block = format!(
                "        {}.timeSamples = {{\n            1: [",
                attr.decl(&m.swarms[0])
            );
            assert_eq!(
                t.matches(&block).count(),
                2,
                "{attr:?}: one block per swarm"
            );
        }
        // Frame 1 of swarm 0, bee 0: a = 0.1, exact shortest text of each value.
        let s = swarm_frame(3, 1, 1100);
        let mut expect = b"            1: [".to_vec();
        push_vec3(&mut expect, s.position[0]);
        assert!(t.contains(std::str::from_utf8(&expect).unwrap()));
        assert!(t.contains("            4: [(0, 57.3, 1.5), (0, 57.3, 1.5), (0, 57.3, 1.5)],\n"));
        assert!(
            t.contains("            2: [-3, -3, -3],\n"),
            "integral floats have no .0"
        );
        assert!(
            t.contains("            1: [0, 1e-7, 2e-7],\n"),
            "sway: shortest, exponent form"
        );
        // Scales are constant per instance: written once, not sampled.
        assert!(t.contains(
            "        float3[] scales = [(1, 1, 1), (1.01, 1.01, 1.01), (1.02, 1.02, 1.02)]\n"
        ));
        assert!(!t.contains("scales.timeSamples"));
        // (`inf` alone would match the shaders' `info:id`.)
        assert!(
            !t.contains("NaN")
                && ["inf,", "inf)", "inf]"].iter().all(|n| !t.contains(n))
                && !t.contains("-0,")
                && !t.contains(".0,")
        );
        // Four samples per block, in frame order.
        let pos = t.find("point3f[] positions.timeSamples").unwrap();
        let block = &t[pos..pos + t[pos..].find("        }\n").unwrap()];
        let frames: Vec<&str> = block
            .lines()
            .skip(1)
            .map(|l| l.trim().split(':').next().unwrap())
            .collect();
        assert_eq!(frames, ["1", "2", "3", "4"]);
    }

    #[test]
    fn flapping_wings_get_one_prototype_per_phase_group() {
        let dir = tempfile::tempdir().unwrap();
        let m = meta(&[10], (1, 6));
        let path = dir.path().join("test-shot.usda");
        let mut w = UsdaWriter::create(&path, &m, 0, WingDisplay::Flap { hz: 4.0 }).unwrap();
        for f in 1..=6 {
            let s = swarm_frame(10, f, 100);
            w.write_frame(&Frame {
                frame: f,
                time: 0.0,
                swarms: std::slice::from_ref(&s),
            })
            .unwrap();
        }
        crate::atomic::commit_all(Box::new(w).finish().unwrap()).unwrap();
        let t = std::fs::read_to_string(&path).unwrap();
        // Ids 100..110: groups 4, 5, 6, 7, 0, 1, ...
        assert!(t.contains("int[] protoIndices = [4, 5, 6, 7, 0, 1, 2, 3, 4, 5]\n"));
        assert!(t.contains("rel prototypes = [</test_shot/swarm0/Prototypes/honeybee_0>, "));
        assert!(t.contains("def Xform \"honeybee_7\" (\n                prepend references = </test_shot/swarm0/Prototypes/honeybee_0>"));
        // One set of meshes; each group's wings turn once per frame, shifted by 1/8 beat.
        assert_eq!(t.matches("def Mesh \"body\"").count(), 1);
        assert_eq!(t.matches("float xformOp:rotateX.timeSamples").count(), 16);
        let turn =
            |g: usize, f: i32| wings::turn_deg(wings::angle(4.0, (f - 1) as f64 / 24.0, g), true);
        assert!(t.contains(&format!("    2: {},\n", f32_text(turn(0, 2)))));
        assert_ne!(turn(0, 2), turn(1, 2));
        assert!(t.contains("float inputs:opacity = 0.45"));
    }

    #[test]
    fn butterfly_wings_take_the_prototype_of_their_flap_bin_each_frame() {
        use crate::model::butterfly::BUTTERFLY_CHANNELS;
        let dir = tempfile::tempdir().unwrap();
        let mut m = meta(&[3], (1, 4));
        m.swarms[0].species = &crate::species::BUTTERFLY;
        m.swarms[0].channels = BUTTERFLY_CHANNELS.to_vec();
        m.swarms[0].body_length_m = 0.025;
        let flap = m.swarms[0].channel("flap").unwrap();
        let abdomen = m.swarms[0].channel("abdomen").unwrap();
        let path = dir.path().join("test-shot.usda");
        let mut w = UsdaWriter::create(&path, &m, 0, WingDisplay::Blur).unwrap();
        // Recorded flap angles per frame for the three butterflies: a stroke, a glide, a
        // value beyond the bins (clamped to the last).
        let angles = [
            [85.0, 10.0, -120.0],
            [40.2, 10.0, 3.0],
            [-4.9, 10.0, 95.0],
            [-64.0, 10.0, 44.9],
        ];
        for f in 1..=4 {
            let mut s = swarm_frame(3, f, 100);
            s.channels = vec![vec![0.0; 3]; BUTTERFLY_CHANNELS.len()];
            s.channels[flap] = angles[(f - 1) as usize].to_vec();
            // The gliding butterfly (always bin 10) moves its abdomen: mean -10°.
            s.channels[abdomen] = vec![0.0, [-8.0, -10.0, -12.5, -9.5][(f - 1) as usize], 0.0];
            w.write_frame(&Frame {
                frame: f,
                time: 0.0,
                swarms: std::slice::from_ref(&s),
            })
            .unwrap();
        }
        crate::atomic::commit_all(Box::new(w).finish().unwrap()).unwrap();
        let t = std::fs::read_to_string(&path).unwrap();
        // Bins of 10° from -90°: 85° → 18 (90°), 10° → 10, -120° → 0, 40.2° → 13, ...
        assert!(t.contains(
            "        int[] protoIndices.timeSamples = {\n            1: [18, 10, 0],\n            \
             2: [13, 10, 9],\n            3: [9, 10, 18],\n            4: [3, 10, 13],\n        }\n"
        ));
        assert!(
            !t.contains("int[] protoIndices = ["),
            "no static indices besides the samples"
        );
        // One prototype per bin; the meshes once, in the first, posed at -90°.
        assert_eq!(
            t.matches("def Xform \"butterfly_").count(),
            wings::FLAP_BINS
        );
        assert!(t.contains("</test_shot/swarm0/Prototypes/butterfly_18>]"));
        assert_eq!(t.matches("def Mesh \"forewing_r\"").count(), 1);
        assert!(t.contains("def Xform \"butterfly_13\" (\n                prepend references = </test_shot/swarm0/Prototypes/butterfly_0>"));
        // Left wings turn +flap about X (tip up), right wings −flap; the body never turns.
        let bin13 = &t[t.find("def Xform \"butterfly_13\"").unwrap()..];
        let bin13 = &bin13[..bin13.find("def Xform \"butterfly_14\"").unwrap()];
        for (part, deg) in [
            ("forewing_l", "40"),
            ("forewing_r", "-40"),
            ("hindwing_l", "40"),
            ("hindwing_r", "-40"),
        ] {
            let over = &bin13[bin13.find(&format!("over \"{part}\"")).unwrap()..];
            assert!(
                over.contains(&format!("float xformOp:rotateX = {deg}\n")),
                "{part}"
            );
        }
        assert!(!bin13.contains("over \"body\""));
        // The abdomen (about -Z) at the mean its channel had in the bin: 0 in bin 13, 10° of
        // rotateZ (tip up by -10°) in bin 10, 0 in an empty bin.
        let abdomen_in = |k: usize| {
            let from = t.find(&format!("def Xform \"butterfly_{k}\"")).unwrap();
            let bin = &t[from..];
            let over = &bin[bin.find("over \"abdomen\"").unwrap()..];
            let line = over
                .lines()
                .find(|l| l.contains("xformOp:rotateZ"))
                .unwrap();
            line.trim().to_owned()
        };
        assert_eq!(abdomen_in(13), "float xformOp:rotateZ = 0");
        assert_eq!(abdomen_in(10), "float xformOp:rotateZ = 10");
        assert_eq!(abdomen_in(5), "float xformOp:rotateZ = 0");
        // The flap channel is still a primvar, as recorded.
        assert!(t.contains("float[] primvars:flap.timeSamples"));
    }

    #[test]
    fn orientations_are_real_first_halves() {
        let dir = tempfile::tempdir().unwrap();
        let m = meta(&[2], (0, 0));
        let path = dir.path().join("q.usda");
        let mut w = UsdaWriter::create(&path, &m, 0, WingDisplay::Blur).unwrap();
        let mut s = swarm_frame(2, 0, 1);
        s.orientation = vec![
            Quat::IDENTITY,
            Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
        ];
        w.write_frame(&Frame {
            frame: 0,
            time: 0.0,
            swarms: std::slice::from_ref(&s),
        })
        .unwrap();
        crate::atomic::commit_all(Box::new(w).finish().unwrap()).unwrap();
        let t = std::fs::read_to_string(&path).unwrap();
        // (w, x, y, z): identity, then 90° about +Y = (0.7071, 0, 0.7071, 0) in half.
        assert!(t.contains("quath[] orientations.timeSamples = {\n            0: [(1, 0, 0, 0), (0.707, 0, 0.707, 0)],\n"));
    }

    #[test]
    fn non_finite_values_are_refused_with_the_bee_named() {
        let dir = tempfile::tempdir().unwrap();
        let m = meta(&[3], (1, 1));
        let path = dir.path().join("n.usda");
        let mut w = UsdaWriter::create(&path, &m, 0, WingDisplay::Blur).unwrap();
        let mut s = swarm_frame(3, 1, 40);
        s.velocity[2].y = f32::NAN;
        let e = w
            .write_frame(&Frame {
                frame: 1,
                time: 0.0,
                swarms: std::slice::from_ref(&s),
            })
            .unwrap_err()
            .to_string();
        assert!(e.contains("bee 42") && e.contains("velocities"), "{e}");
        drop(w);
        assert!(files(dir.path()).is_empty());
    }

    #[test]
    fn contract_violations_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let m = meta(&[2], (1, 3));
        let path = dir.path().join("c.usda");
        let mut w = UsdaWriter::create(&path, &m, 0, WingDisplay::Blur).unwrap();
        let s = swarm_frame(2, 1, 0);
        let frame = |f, s: &SwarmFrame| -> Result<()> {
            let swarms = [s.clone()];
            let fr = Frame {
                frame: f,
                time: 0.0,
                swarms: &swarms,
            };
            w.write_frame(&fr)
        };
        let mut frame = frame;
        assert!(frame(2, &s).is_err(), "out of order");
        frame(1, &s).unwrap();
        let mut swapped = swarm_frame(2, 2, 0);
        swapped.ids.swap(0, 1);
        assert!(frame(2, &swapped).is_err(), "ids reordered");
        assert!(frame(2, &swarm_frame(3, 2, 0)).is_err(), "count changed");
        let mut grown = swarm_frame(2, 2, 0);
        grown.scale[1] *= 1.5;
        assert!(frame(2, &grown).is_err(), "a scale changed");
        frame(2, &swarm_frame(2, 2, 0)).unwrap();
        assert!(Box::new(w).finish().is_err(), "frame 3 never came");
        assert!(files(dir.path()).is_empty());
    }

    #[test]
    fn dropped_writer_keeps_the_previous_cache_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let m = meta(&[4], (1, 6));
        bake(dir.path(), &m, 2).unwrap();
        bake(dir.path(), &m, 0).unwrap();
        let before: Vec<(String, Vec<u8>)> = files(dir.path())
            .into_iter()
            .map(|f| {
                (
                    f.clone(),
                    std::fs::read(dir.path().join(&f)).unwrap_or_default(),
                )
            })
            .collect();
        for clip_frames in [0, 2] {
            let path = dir.path().join("test-shot.usda");
            let mut w = UsdaWriter::create(&path, &m, clip_frames, WingDisplay::Blur).unwrap();
            for f in 1..=5 {
                let s = swarm_frame(4, f, 1);
                w.write_frame(&Frame {
                    frame: f,
                    time: 0.0,
                    swarms: std::slice::from_ref(&s),
                })
                .unwrap();
            }
            drop(w); // interrupted before the last frame
            let after: Vec<(String, Vec<u8>)> = files(dir.path())
                .into_iter()
                .map(|f| {
                    (
                        f.clone(),
                        std::fs::read(dir.path().join(&f)).unwrap_or_default(),
                    )
                })
                .collect();
            assert_eq!(before, after);
        }
    }

    #[test]
    fn clips_split_samples_and_overlap_by_one_frame() {
        let dir = tempfile::tempdir().unwrap();
        let m = meta(&[3, 1], (1, 10));
        let out = bake(dir.path(), &m, 4).unwrap();
        assert_eq!(
            files(dir.path()),
            vec![
                "test-shot.clips",
                "test-shot.clips/test-shot.0001.usda",
                "test-shot.clips/test-shot.0002.usda",
                "test-shot.clips/test-shot.0003.usda",
                "test-shot.clips/test-shot.manifest.usda",
                "test-shot.usda",
            ]
        );
        assert_eq!(out.len(), 5);
        let main = std::fs::read_to_string(dir.path().join("test-shot.usda")).unwrap();
        assert!(
            !main.contains("timeSamples"),
            "the main layer holds no samples"
        );
        assert!(main.contains("double2[] active = [(1, 0), (5, 1), (9, 2)]"));
        assert!(main.contains(
            "asset[] assetPaths = [@./test-shot.clips/test-shot.0001.usda@, \
             @./test-shot.clips/test-shot.0002.usda@, @./test-shot.clips/test-shot.0003.usda@]"
        ));
        assert!(
            main.contains("asset manifestAssetPath = @./test-shot.clips/test-shot.manifest.usda@")
        );
        assert!(main.contains("double2[] times = [(1, 1), (10, 10)]"));
        assert!(main.contains("string primPath = \"/test_shot\""));

        let single = tempfile::tempdir().unwrap();
        bake(single.path(), &m, 0).unwrap();
        let whole = std::fs::read_to_string(single.path().join("test-shot.usda")).unwrap();
        let sample = |t: &str, attr: Attr, nth: usize, f: i32| -> String {
            let head = format!("{}.timeSamples = {{\n", attr.decl(&m.swarms[0]));
            let at = t.match_indices(&head).nth(nth).unwrap().0;
            let line = format!("            {f}: [");
            let from = at + t[at..].find(&line).unwrap();
            t[from..from + t[from..].find('\n').unwrap()].to_owned()
        };
        let clip = |n| {
            std::fs::read_to_string(
                dir.path()
                    .join(format!("test-shot.clips/test-shot.000{n}.usda")),
            )
            .unwrap()
        };
        for attr in attrs(&m.swarms[0]) {
            for (n, frames) in [(1, 1..=5), (2, 5..=9), (3, 9..=10)] {
                let c = clip(n);
                for f in frames {
                    for swarm in 0..2 {
                        assert_eq!(sample(&c, attr, swarm, f), sample(&whole, attr, swarm, f));
                    }
                }
            }
        }
        // Shrinking the clip count removes the clips no longer referenced.
        bake(dir.path(), &m, 5).unwrap();
        assert_eq!(files(dir.path()).len(), 5);
        bake(dir.path(), &m, 0).unwrap();
        assert_eq!(files(dir.path()), vec!["test-shot.usda"]);
    }

    #[test]
    fn an_empty_swarm_is_an_empty_instancer() {
        let dir = tempfile::tempdir().unwrap();
        let m = meta(&[0, 2], (1, 2));
        bake(dir.path(), &m, 0).unwrap();
        let t = std::fs::read_to_string(dir.path().join("test-shot.usda")).unwrap();
        assert!(t.contains("int64[] ids = []\n        int[] protoIndices = []\n"));
        assert!(t.contains("point3f[] positions.timeSamples = {\n            1: [],\n"));
        assert!(
            t.contains("float3[] extent.timeSamples = {\n            1: [(0, 0, 0), (0, 0, 0)],\n")
        );
    }

    #[test]
    fn one_frame_shot_in_clips_mode() {
        let dir = tempfile::tempdir().unwrap();
        let m = meta(&[2], (5, 5));
        assert_eq!(bake(dir.path(), &m, 24).unwrap().len(), 3);
        let main = std::fs::read_to_string(dir.path().join("test-shot.usda")).unwrap();
        assert!(main.contains("double2[] active = [(5, 0)]"));
        assert!(main.contains("double2[] times = [(5, 5)]"));
    }

    #[test]
    fn output_is_deterministic_and_independent_of_threads() {
        let m = meta(&[PIECE * 2 + 17, 5], (3, 5));
        let a = tempfile::tempdir().unwrap();
        let b = tempfile::tempdir().unwrap();
        bake(a.path(), &m, 0).unwrap();
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| bake(b.path(), &m, 0))
            .unwrap();
        let read = |d: &Path| std::fs::read(d.join("test-shot.usda")).unwrap();
        assert!(read(a.path()) == read(b.path()));
    }

    /// Writes sample caches for manual inspection with usd-core:
    /// `BEESWARM_USDA_SAMPLE=/tmp/x cargo test --release usda::tests::write_sample -- --ignored`
    #[test]
    #[ignore]
    fn write_sample() {
        let dir = PathBuf::from(std::env::var("BEESWARM_USDA_SAMPLE").unwrap());
        let m = meta(&[5, 3], (-3, 8));
        std::fs::create_dir_all(dir.join("single")).unwrap();
        std::fs::create_dir_all(dir.join("clips")).unwrap();
        bake(&dir.join("single"), &m, 0).unwrap();
        bake(&dir.join("clips"), &m, 5).unwrap();
    }
}
