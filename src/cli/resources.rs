//! What a bake needs — memory and disk — against what the machine has: the
//! estimates `check` prints, and the limits `check` and `bake` refuse a shot over (exit 2,
//! located at the swarm's `count`) unless `--allow-large` is given.

use super::bake::Plan;
use crate::error::{Error, Result};
use crate::export::Format;
use crate::shot::{Region, Shot, Swarm};
use std::path::Path;

/// Bytes per bee and frame of each cache, measured on `examples/grassland.toml` (1,000
/// bees of the bee model, 240 frames): glTF 62 (plus 1.4 kB of JSON per bee), USDA the
/// writer's own estimate, CSV 163. Models without channels write a little less.
const GLTF_BYTES: f64 = 62.0;
const GLTF_JSON_PER_BEE: f64 = 1400.0;
const USDA_BYTES: f64 = crate::export::usda::BYTES_PER_INSTANCE_FRAME as f64;
const CSV_BYTES: f64 = 163.0;

/// What a bake of a plan needs.
pub struct Needs {
    /// Each file it writes (with a description after a space, for clips) and its size, B.
    pub files: Vec<(String, f64)>,
    /// Scratch space beside the outputs at the worst moment of the bake, B.
    pub scratch: f64,
    /// Peak memory, B.
    pub memory: f64,
    /// USDA clip layers, when the USDA cache is split.
    pub usda_clips: Option<usize>,
}

impl Needs {
    pub fn of(plan: &Plan) -> Needs {
        let shot = &plan.shot;
        let (bees, frames) = (shot.bee_count() as f64, shot.frame_count() as f64);
        let bee_frames = bees * frames;
        let mut files: Vec<(String, f64)> = Vec::new();
        let mut scratch = 0.0;
        let mut usda_clips = None;
        for f in &plan.formats {
            let name = f.file_name(&shot.name);
            match f {
                Format::Glb => {
                    files.push((name, bee_frames * GLTF_BYTES + bees * GLTF_JSON_PER_BEE));
                    scratch += bee_frames * 52.0;
                }
                Format::Gltf => {
                    files.push((name, bees * GLTF_JSON_PER_BEE));
                    files.push((format!("{}.bin", shot.name), bee_frames * GLTF_BYTES));
                    scratch += bee_frames * 52.0;
                }
                Format::Usda => {
                    let size = bee_frames * USDA_BYTES;
                    let clip = shot.output.options.usda_clip_frames.unwrap_or_else(|| {
                        crate::export::usda::clip_frames_for(bees as u64, frames as u64)
                    });
                    if clip > 0 {
                        let clips = (frames / clip as f64).ceil();
                        usda_clips = Some(clips as usize);
                        files.push((
                            format!(
                                "{name} + {}.clips/ ({clips} clip layers of {clip} frames)",
                                shot.name
                            ),
                            size,
                        ));
                        scratch += size / clips.max(1.0);
                    } else {
                        files.push((name, size));
                        scratch += size;
                    }
                }
                Format::Csv => files.push((name, bee_frames * CSV_BYTES)),
            }
        }
        if plan.preview {
            files.push((format!("{}.preview.png", shot.name), 200e3));
        }
        // Simulation state (two agent buffers, neighbour records and lists, the frame
        // record), the glTF writer's per-bee state and document, one USDA frame of text.
        let mut memory = 30e6 + bees * 700.0;
        if plan
            .formats
            .iter()
            .any(|f| matches!(f, Format::Glb | Format::Gltf))
        {
            memory += bees * (100.0 + GLTF_JSON_PER_BEE);
        }
        if plan.formats.contains(&Format::Usda) {
            memory += bees * USDA_BYTES * 2.0;
        }
        Needs {
            files,
            scratch,
            memory,
            usda_clips,
        }
    }

    /// The finished caches, B.
    pub fn disk(&self) -> f64 {
        self.files.iter().map(|(_, b)| b).sum()
    }
}

/// A swarm's agents per m³ at spawn and, for models with a neighbour radius, that radius
/// (m) and the neighbours each agent has within it on average.
pub fn density(w: &Swarm) -> (f64, Option<(f64, f64)>) {
    let volume = match w.spawn {
        Region::Box { half, .. } => 8.0 * (half.x * half.y * half.z) as f64,
        Region::Sphere { radius, .. } => 4.0 / 3.0 * std::f64::consts::PI * (radius as f64).powi(3),
    };
    let density = w.count as f64 / volume;
    let near = w
        .params
        .get("neighbour_radius")
        .map(|h| (h, density * 4.0 / 3.0 * std::f64::consts::PI * h.powi(3)));
    (density, near)
}

/// What the machine offers a bake into `out_dir`; `None` where it cannot be known.
#[derive(Clone, Copy, Debug)]
pub struct Machine {
    /// Memory available to a new process without swapping (Linux `MemAvailable`), B.
    pub memory: Option<f64>,
    /// Free space for an unprivileged user on the output folder's filesystem, B.
    pub disk: Option<f64>,
}

impl Machine {
    pub fn now(out_dir: &Path) -> Machine {
        Machine {
            memory: available_memory(),
            disk: free_disk(out_dir),
        }
    }
}

fn available_memory() -> Option<f64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Free space where `dir` is, or would be created (its nearest existing ancestor).
#[cfg(unix)]
fn free_disk(dir: &Path) -> Option<f64> {
    use std::os::unix::ffi::OsStrExt;
    let existing = dir
        .ancestors()
        .map(|p| {
            if p.as_os_str().is_empty() {
                Path::new(".")
            } else {
                p
            }
        })
        .find(|p| p.is_dir())?;
    let c = std::ffi::CString::new(existing.as_os_str().as_bytes()).ok()?;
    // SAFETY: `c` is a NUL-terminated path and `st` a zeroed statvfs that the call fills.
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    if unsafe { libc::statvfs(c.as_ptr(), &mut st) } != 0 {
        return None;
    }
    Some(st.f_bavail as f64 * st.f_frsize as f64)
}

#[cfg(not(unix))]
fn free_disk(_dir: &Path) -> Option<f64> {
    None
}

/// A limit a shot is over: the key it is about and what to say.
#[derive(Debug, PartialEq)]
pub struct OverLimit {
    pub key: String,
    pub message: String,
}

/// The first limit `shot` is over, given what it needs and what the machine has: memory
/// above what is available, or disk (while baking) above the free space. (A crowded spawn
/// is no longer refused: an agent interacts with at most its 16 nearest neighbours, so a
/// crowd costs a bounded few times a sparse cloud per agent; `check` warns and predicts the
/// time.)
pub fn over_limit(shot: &Shot, needs: &Needs, machine: Machine) -> Option<OverLimit> {
    // Memory and disk grow with the bee count: name the largest swarm's.
    let largest = (0..shot.swarms.len()).max_by_key(|&i| shot.swarms[i].count)?;
    let count_key = format!("swarm[{largest}].count");
    let bees = |s: &Shot| {
        if s.swarms.len() == 1 {
            format!("{} bees", s.bee_count())
        } else {
            format!(
                "{} bees in {} swarms, {} in \"{}\"",
                s.bee_count(),
                s.swarms.len(),
                s.swarms[largest].count,
                s.swarms[largest].name
            )
        }
    };
    if let Some(avail) = machine.memory
        && needs.memory > avail
    {
        return Some(OverLimit {
            key: count_key,
            message: format!(
                "a bake of {} needs about {} of memory, and {} is available",
                bees(shot),
                bytes(needs.memory),
                bytes(avail)
            ),
        });
    }
    let disk = needs.disk() + needs.scratch;
    if let Some(free) = machine.disk
        && disk > free
    {
        return Some(OverLimit {
            key: count_key,
            message: format!(
                "a bake of {} × {} frames needs about {} of disk while it runs ({} of caches), \
                 and the output folder's disk has {} free",
                bees(shot),
                shot.frame_count(),
                bytes(disk),
                bytes(needs.disk()),
                bytes(free)
            ),
        });
    }
    None
}

/// Refuses `plan` when it is over a limit (see [`over_limit`]) unless `allow_large`: a shot
/// error located at the key in `shot_file` (`None`: the built-in demo shot), with the
/// figures and the flag that overrides it.
pub fn refuse_over_limits(plan: &Plan, shot_file: Option<&Path>, allow_large: bool) -> Result<()> {
    if allow_large {
        return Ok(());
    }
    let needs = Needs::of(plan);
    let Some(over) = over_limit(&plan.shot, &needs, Machine::now(&plan.out_dir)) else {
        return Ok(());
    };
    Err(located(
        shot_file,
        &over.key,
        over.message,
        "pass --allow-large to bake it anyway".to_owned(),
    ))
}

/// Reserves the memory a bake of `plan` needs before any of it is spent, so that a shot
/// the system can never hold is an error (exit 2, located at the largest swarm's count)
/// instead of an abort part-way. The reservation is address space only: no page is touched
/// and it is released at once (Linux refuses, by default, a single allocation larger than
/// its memory and swap together).
pub fn reserve_memory(plan: &Plan, shot_file: Option<&Path>) -> Result<()> {
    let needs = Needs::of(plan);
    let Err(e) = try_reserve(needs.memory) else {
        return Ok(());
    };
    let shot = &plan.shot;
    let largest = (0..shot.swarms.len())
        .max_by_key(|&i| shot.swarms[i].count)
        .unwrap_or(0);
    Err(located(
        shot_file,
        &format!("swarm[{largest}].count"),
        format!(
            "a bake of {} bees needs about {} of memory, and the system refused to allocate it ({e})",
            shot.bee_count(),
            bytes(needs.memory)
        ),
        "bake fewer bees, or on a machine with more memory".to_owned(),
    ))
}

/// Asks the allocator for `bytes` and gives them back.
pub fn try_reserve(bytes: f64) -> std::result::Result<(), std::collections::TryReserveError> {
    let mut probe: Vec<u8> = Vec::new();
    probe.try_reserve_exact(bytes.min(usize::MAX as f64) as usize)
}

fn located(shot_file: Option<&Path>, key: &str, message: String, hint: String) -> Error {
    let (file, src) = match shot_file {
        Some(p) => (
            p.to_path_buf(),
            crate::shot::read_bounded(p)
                .map(|b| String::from_utf8_lossy(&b).into_owned())
                .unwrap_or_default(),
        ),
        None => (
            "<embedded default shot>".into(),
            crate::shot::EMBEDDED_DEFAULT.to_owned(),
        ),
    };
    Error::Shot(Box::new(crate::shot::error_at(
        &file,
        &src,
        key,
        message,
        Some(hint),
    )))
}

pub fn bytes(b: f64) -> String {
    match b {
        b if b >= 1e12 => format!("{:.1} TB", b / 1e12),
        b if b >= 1e9 => format!("{:.1} GB", b / 1e9),
        b if b >= 1e6 => format!("{:.0} MB", b / 1e6),
        b => format!("{:.0} kB", (b / 1e3).max(1.0)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(src: &str, formats: &[Format]) -> Plan {
        let shot = crate::shot::parse(src, Path::new("t.toml"), Path::new(".")).unwrap();
        Plan {
            shot,
            out_dir: "out".into(),
            formats: formats.to_vec(),
            preview: false,
        }
    }

    #[test]
    fn memory_and_disk_limits_name_the_count_and_the_figures() {
        let p = plan(
            "[[swarm]]\nname = \"a\"\ncount = 10\n[[swarm]]\nname = \"b\"\ncount = 100000\n",
            &[Format::Glb, Format::Usda],
        );
        let needs = Needs::of(&p);
        let roomy = Machine {
            memory: Some(1e12),
            disk: Some(1e15),
        };
        assert_eq!(over_limit(&p.shot, &needs, roomy), None);
        let small_memory = Machine {
            memory: Some(needs.memory - 1.0),
            ..roomy
        };
        let over = over_limit(&p.shot, &needs, small_memory).unwrap();
        assert_eq!(over.key, "swarm[1].count");
        assert!(
            over.message
                .contains("100010 bees in 2 swarms, 100000 in \"b\"")
                && over.message.contains("of memory"),
            "{}",
            over.message
        );
        let small_disk = Machine {
            disk: Some(needs.disk()),
            ..roomy
        };
        let over = over_limit(&p.shot, &needs, small_disk).unwrap();
        assert!(
            over.message.contains("of disk while it runs"),
            "{}",
            over.message
        );
        // Unknown figures refuse nothing.
        let unknown = Machine {
            memory: None,
            disk: None,
        };
        assert_eq!(over_limit(&p.shot, &needs, unknown), None);
    }

    #[test]
    fn an_impossible_allocation_is_an_error_not_an_abort() {
        // 1 EiB: beyond any machine's address space, refused whatever the overcommit policy.
        assert!(try_reserve(2f64.powi(60)).is_err());
        assert!(try_reserve(1e6).is_ok());
    }
}
