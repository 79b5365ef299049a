//! Raw shot → validated [`Shot`]: fills defaults, checks every value, and locates every
//! error in the text.

use super::defaults as d;
use super::locate::Locator;
use super::schema::*;
use super::*;
use crate::error::ShotError;
use crate::geometry::mesh::{Mesh, MeshError as MeshErr, MeshMode};
use crate::model::ParamValues;
use crate::model::fastswarm::database::Database;
use glam::Quat;
use std::sync::{Arc, Weak};

/// The longest scene or swarm name: names become file, node and prim names, and a file
/// name (with the writers' suffixes) must stay under the 255 bytes file systems allow.
const MAX_NAME: usize = 100;

struct Ctx<'a> {
    file: &'a Path,
    loc: Locator<'a>,
    /// glTF files the shot's mesh obstacles read, each parsed once.
    documents: std::cell::RefCell<mesh_file::Documents>,
}

impl Ctx<'_> {
    /// An error about the value at `path`.
    fn err(&self, path: &str, message: impl Into<String>) -> ShotError {
        self.err_at(self.loc.span_of(path), path, message)
    }

    /// An error about the key at `path` (an unknown name).
    fn key_err(&self, path: &str, message: impl Into<String>) -> ShotError {
        self.err_at(self.loc.key_span_of(path), path, message)
    }

    fn err_at(
        &self,
        span: Option<std::ops::Range<usize>>,
        path: &str,
        message: impl Into<String>,
    ) -> ShotError {
        let (line, column, source_line) = match span {
            Some(span) => {
                let (l, c, s) = self.loc.line_col(span.start);
                (l, c, Some(s))
            }
            None => (0, 0, None),
        };
        ShotError {
            file: self.file.to_path_buf(),
            line,
            column,
            key: path.to_owned(),
            message: message.into(),
            source_line,
            hint: None,
        }
    }

    fn hint(&self, path: &str, message: impl Into<String>, hint: impl Into<String>) -> ShotError {
        let mut e = self.err(path, message);
        e.hint = Some(hint.into());
        e
    }

    /// Deserializes the whole text. A TOML or type error is located (line, column, key)
    /// with a hint for a misspelt key; a `nan` or `inf` anywhere is refused too.
    fn deserialize<T: serde::de::DeserializeOwned>(&self, src: &str) -> Result<T, ShotError> {
        let value: T = toml::from_str(src).map_err(|e| {
            let span = e.span().unwrap_or(0..0);
            let (line, column, source_line) = self.loc.line_col(span.start);
            let message = friendly(e.message());
            let hint = message
                .starts_with("unknown field")
                .then(|| unknown_field_hint(&message));
            ShotError {
                file: self.file.to_path_buf(),
                line,
                column,
                key: self.loc.path_at(span.start).unwrap_or_default(),
                message,
                source_line: Some(source_line),
                hint,
            }
        })?;
        if let Some((p, v)) = self.loc.non_finite.first() {
            return Err(self.err(p, format!("expected a finite number, found {v}")));
        }
        if let Some((p, n, found)) = self.loc.too_long.first() {
            let what = match n {
                2 => "a list of two frame numbers [start, end]",
                _ => "a list of three numbers [x, y, z]",
            };
            return Err(self.err(p, format!("expected {what}, found {found} elements")));
        }
        Ok(value)
    }

    /// A number that must lie in [lo, hi].
    fn range(&self, path: &str, v: f64, lo: f64, hi: f64, what: &str) -> Result<f64, ShotError> {
        if v.is_finite() && v >= lo && v <= hi {
            Ok(v)
        } else {
            Err(self.err(path, format!("expected {what}, found {v}")))
        }
    }

    fn positive(&self, path: &str, v: f64) -> Result<f64, ShotError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(path, format!("expected a number greater than 0, found {v}")))
        }
    }

    /// A range of seconds `[min, max]`, 0 ≤ min ≤ max ≤ 3600 (how long bees stay).
    fn seconds_range(&self, path: &str, v: &[f64]) -> Result<(f64, f64), ShotError> {
        match v {
            [lo, hi]
                if lo.is_finite() && hi.is_finite() && *lo >= 0.0 && lo <= hi && *hi <= 3600.0 =>
            {
                Ok((*lo, *hi))
            }
            _ => Err(self.err(
                path,
                format!("expected [min, max] seconds with 0 <= min <= max <= 3600, found {v:?}"),
            )),
        }
    }

    fn non_negative(&self, path: &str, v: f64) -> Result<f64, ShotError> {
        self.range(path, v, 0.0, f64::MAX, "a number of at least 0")
    }

    /// A position or extent, metres, each component within ±1,000,000.
    fn vec(&self, path: &str, v: V3) -> Result<Vec3, ShotError> {
        self.vec_in(path, v, "m")
    }

    /// Three finite numbers within ±1,000,000 `unit`.
    fn vec_in(&self, path: &str, v: V3, unit: &str) -> Result<Vec3, ShotError> {
        if v.iter().all(|x| x.is_finite() && x.abs() <= 1e6) {
            Ok(Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32))
        } else {
            Err(self.err(
                path,
                format!("expected three finite numbers within ±1000000 {unit}, found {v:?}"),
            ))
        }
    }

    fn size(&self, path: &str, v: V3) -> Result<Vec3, ShotError> {
        let s = self.vec(path, v)?;
        if s.min_element() > 0.0 {
            Ok(s)
        } else {
            Err(self.err(
                path,
                format!("expected three sizes greater than 0, found {v:?}"),
            ))
        }
    }

    fn required<T: Clone>(&self, path: &str, v: &Option<T>, what: &str) -> Result<T, ShotError> {
        v.clone().ok_or_else(|| {
            self.err(
                path,
                format!(
                    "missing key `{}`: expected {what}",
                    path.rsplit('.').next().unwrap_or(path)
                ),
            )
        })
    }

    fn one_of<'s>(&self, path: &str, v: &str, options: &[&'s str]) -> Result<&'s str, ShotError> {
        options.iter().find(|o| **o == v).copied().ok_or_else(|| {
            self.err(
                path,
                format!("expected one of {}, found \"{v}\"", quoted(options)),
            )
        })
    }
}

/// `[output] wings` and `wing_flap_hz`. A shot that gives only `wing_flap_hz > 0` (the
/// older way to ask for a flap) flaps; `wing_flap_hz` with a still or blurred display is
/// refused rather than ignored.
fn resolve_wings(cx: &Ctx, ro: &RawOutput, fps: f64) -> Result<WingDisplay, ShotError> {
    let hz_range = |hz: f64| {
        cx.range(
            "output.wing_flap_hz",
            hz,
            0.0,
            fps / 2.0,
            &format!(
                "a visible flap rate above 0 and up to half the frame rate ({} Hz at {fps} fps)",
                fps / 2.0
            ),
        )
    };
    let name = match ro.wings.as_deref() {
        Some(w) => cx.one_of("output.wings", w, &["still", "blur", "flap"])?,
        None if ro.wing_flap_hz.is_some_and(|hz| hz != 0.0) => "flap",
        None => d::WINGS,
    };
    Ok(match name {
        "flap" => {
            let hz = hz_range(
                ro.wing_flap_hz
                    .unwrap_or_else(|| d::WING_FLAP_HZ.min(fps / 6.0)),
            )?;
            if hz == 0.0 {
                return Err(cx.err(
                    "output.wing_flap_hz",
                    "expected a flap rate above 0 with wings = \"flap\" (use wings = \"still\" or \"blur\" for wings that do not move)",
                ));
            }
            WingDisplay::Flap { hz }
        }
        other => {
            if let Some(hz) = ro.wing_flap_hz {
                hz_range(hz)?;
                if hz != 0.0 {
                    return Err(cx.err(
                        "output.wing_flap_hz",
                        format!(
                            "wing_flap_hz = {hz} only applies to wings = \"flap\", and wings = \"{other}\" here"
                        ),
                    ));
                }
            }
            if other == "still" {
                WingDisplay::Still
            } else {
                WingDisplay::Blur
            }
        }
    })
}

fn quoted(options: &[&str]) -> String {
    options
        .iter()
        .map(|o| format!("\"{o}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

fn is_identifier(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(ch) if ch.is_ascii_alphabetic() || ch == '_')
        && c.all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
}

/// Suggests the closest known key for serde's "unknown field `x`, expected one of `a`, `b`".
fn unknown_field_hint(message: &str) -> String {
    let quoted_words: Vec<&str> = message.split('`').skip(1).step_by(2).collect();
    let suggestion = quoted_words.split_first().and_then(|(unknown, known)| {
        let unknown = unknown.to_ascii_lowercase();
        known
            .iter()
            .map(|k| (edit_distance(&unknown, &k.to_ascii_lowercase()), *k))
            .filter(|(d, k)| *d <= 2.max(k.len() / 3))
            .min_by_key(|(d, _)| *d)
            .map(|(_, k)| k)
    });
    match suggestion {
        Some(k) => format!("did you mean `{k}`? docs/shot-format.md lists every key"),
        None => "check the spelling; docs/shot-format.md lists every key".to_owned(),
    }
}

/// Levenshtein distance, counting a swap of two neighbouring letters as one edit.
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut best = (d[i - 1][j] + 1)
                .min(d[i][j - 1] + 1)
                .min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                best = best.min(d[i - 2][j - 2] + 1);
            }
            d[i][j] = best;
        }
    }
    d[a.len()][b.len()]
}

/// Rewrites serde's type names into words an artist reads, on one line.
fn friendly(msg: &str) -> String {
    let mut m = msg.trim().replace('\n', ", ");
    for (from, to) in [
        ("expected i64", "expected a whole number"),
        ("expected f64", "expected a number"),
        ("expected a boolean", "expected true or false"),
        (
            "expected an array of length 3",
            "expected a list of three numbers [x, y, z]",
        ),
        (
            "expected an array of length 2",
            "expected a list of two frame numbers [start, end]",
        ),
        ("expected a sequence", "expected a list"),
        ("expected struct", "expected a table"),
    ] {
        m = m.replace(from, to);
    }
    m
}

pub fn resolve(src: &str, file: &Path, base: &Path) -> Result<Shot, ShotError> {
    let cx = Ctx {
        file,
        loc: Locator::new(src),
        documents: Default::default(),
    };
    let raw: RawShot = cx.deserialize(src).map_err(|mut e| {
        if e.message.contains("number too large") {
            // The text does not parse, so no key is located: name the key on that line.
            let key = e
                .source_line
                .as_deref()
                .and_then(|l| l.split_once('='))
                .map(|(k, _)| k.trim().to_owned())
                .unwrap_or_default();
            e.key = key;
            e.message = "expected a whole number from -9223372036854775808 to 9223372036854775807 (far beyond any valid value here)".to_owned();
            return e;
        }
        // A syntax error has no key: say plainly the text is not TOML.
        if e.hint.is_none() && e.key.is_empty() && !e.message.contains("missing field") {
            e.message = format!("not valid TOML: {}", e.message);
        }
        e
    })?;

    // [scene]
    let scene = raw.scene.clone().unwrap_or_default();
    let default_name = file
        .file_stem()
        .map(|s| s.to_string_lossy().trim_end_matches(".shot").to_owned())
        .filter(|s| !s.is_empty() && !s.starts_with('<'))
        .unwrap_or_else(|| d::SHOT_NAME.to_owned());
    let name = scene.name.clone().unwrap_or(default_name);
    if name.chars().count() > MAX_NAME {
        return Err(cx.hint(
            "scene.name",
            format!(
                "expected a name of at most {MAX_NAME} characters, found {}",
                name.chars().count()
            ),
            "the name becomes the output file names, which file systems limit to 255 bytes",
        ));
    }
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c))
        || name.starts_with('.')
    {
        if scene.name.is_none() {
            // The name came from the file name: say so, and suggest one to write.
            let safe: String = name
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || "_-.".contains(c) {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            let safe = safe.trim_start_matches('.');
            let safe = if safe.is_empty() { d::SHOT_NAME } else { safe };
            return Err(cx.hint(
                "scene.name",
                format!(
                    "the shot is named after its file, \"{name}\", which is not a file-safe name (letters, digits, _ - .)"
                ),
                format!("name it in the shot: [scene] name = \"{safe}\", or rename the file"),
            ));
        }
        return Err(cx.hint(
            "scene.name",
            format!("expected a file-safe name (letters, digits, _ - .), found \"{name}\""),
            "the name becomes the output file names, e.g. <name>.glb",
        ));
    }
    let fps = cx.range(
        "scene.fps",
        scene.fps.unwrap_or(d::FPS),
        1.0,
        1000.0,
        "frames per second between 1 and 1000",
    )?;
    let [f0, f1] = scene.frames.unwrap_or(d::FRAMES);
    if f0 > f1 {
        return Err(cx.hint(
            "scene.frames",
            format!("the frame range is reversed: [{f0}, {f1}]"),
            format!("write frames = [{f1}, {f0}]"),
        ));
    }
    if f0 < -1_000_000 || f1 > 1_000_000 || f1 - f0 > 100_000 {
        return Err(cx.err(
            "scene.frames",
            "expected at most 100000 frames within ±1000000",
        ));
    }
    let substeps = cx.range(
        "scene.substeps",
        scene.substeps.unwrap_or(d::SUBSTEPS) as f64,
        1.0,
        64.0,
        "a whole number of substeps from 1 to 64",
    )? as u32;
    let seed = scene.seed.unwrap_or(d::SEED);
    if seed < 0 {
        return Err(cx.err(
            "scene.seed",
            format!("expected a whole number of at least 0, found {seed}"),
        ));
    }

    // [[swarm]]
    if raw.swarm.is_empty() {
        return Err(ShotError {
            file: file.to_path_buf(),
            line: 0,
            column: 0,
            key: "swarm".to_owned(),
            message: "the shot has no swarm".to_owned(),
            source_line: None,
            hint: Some("add one:\n\n[[swarm]]\ncount = 200".to_owned()),
        });
    }
    let mut swarms = Vec::new();
    for (i, rs) in raw.swarm.iter().enumerate() {
        swarms.push(resolve_swarm(&cx, i, rs, base, &swarms)?);
    }
    if swarms.iter().map(|s| s.count).sum::<usize>() > 10_000_000 {
        return Err(cx.err("swarm", "expected at most 10000000 bees in one shot"));
    }

    let mut obstacles = Vec::new();
    for (i, ro) in raw.obstacle.iter().enumerate() {
        obstacles.push(resolve_obstacle(&cx, i, ro, base, f0 as f64)?);
    }
    check_moving_obstacles(&cx, &swarms, &obstacles)?;
    let mut targets = Vec::new();
    for (i, rt) in raw.target.iter().enumerate() {
        if rt.curve.is_some() || rt.samples.is_some() {
            for point in curve_samples(&cx, i, rt)? {
                targets.push(resolve_target(&cx, i, &point, &swarms)?);
            }
        } else {
            targets.push(resolve_target(&cx, i, rt, &swarms)?);
        }
    }
    resolve_start_inside(&cx, &raw.swarm, &mut swarms, &targets)?;
    let wind = match raw.wind.as_ref().and_then(|w| w.velocity) {
        Some(v) => cx.vec_in("wind.velocity", v, "m/s")?,
        None => Vec3::ZERO,
    };

    let ro = raw.output.clone().unwrap_or_default();
    let dir = ro.dir.clone().unwrap_or_else(|| d::OUTPUT_DIR.to_owned());
    if dir.trim().is_empty() {
        return Err(cx.err(
            "output.dir",
            "expected a folder path, found an empty string",
        ));
    }
    if dir.contains('\0') {
        return Err(cx.err(
            "output.dir",
            "expected a folder path, found one holding a NUL character",
        ));
    }
    let mut formats = Vec::new();
    let names: Vec<String> = ro
        .formats
        .clone()
        .unwrap_or_else(|| d::OUTPUT_FORMATS.iter().map(|s| s.to_string()).collect());
    for (k, f) in names.iter().enumerate() {
        let fmt = Format::parse(f).ok_or_else(|| {
            cx.err(
                &format!("output.formats[{k}]"),
                format!("expected one of \"glb\", \"gltf\", \"usda\", \"csv\", found \"{f}\""),
            )
        })?;
        if !formats.contains(&fmt) {
            formats.push(fmt);
        }
    }
    if formats.is_empty() {
        return Err(cx.err("output.formats", "expected at least one format"));
    }
    let wings = resolve_wings(&cx, &ro, fps)?;
    let gltf_layout = match cx.one_of(
        "output.gltf_layout",
        ro.gltf_layout.as_deref().unwrap_or(d::GLTF_LAYOUT),
        &["parts", "agent"],
    )? {
        "agent" => GltfLayout::Agent,
        _ => GltfLayout::Parts,
    };
    let usda_clip_frames = match ro.usda_clip_frames {
        Some(clip) => Some(cx.range(
            "output.usda_clip_frames",
            clip as f64,
            0.0,
            1e6,
            "a whole number of frames of at least 0 (0 = no clips)",
        )? as u32),
        None => None,
    };

    let shot = Shot {
        name,
        fps,
        frame_start: f0 as i32,
        frame_end: f1 as i32,
        substeps,
        seed: seed as u64,
        swarms,
        obstacles,
        targets,
        wind,
        output: Output {
            dir: base.join(dir),
            formats,
            preview: ro.preview.unwrap_or(false),
            options: OutputOptions {
                wings,
                gltf_layout,
                usda_clip_frames,
            },
        },
    };
    check_spawn_regions(&cx, &shot)?;
    Ok(shot)
}

/// Applies `params = { … }` (at `prefix`) over `into`: each key must be a parameter of
/// the model, each value within the parameter's range.
fn resolve_params(
    cx: &Ctx,
    prefix: &str,
    p: &RawParams,
    into: &mut ParamValues,
) -> Result<(), ShotError> {
    let info = into.model().info();
    for (key, &v) in p {
        let path = format!("{prefix}.{key}");
        let Some(spec) = info.params.iter().find(|s| s.name == key) else {
            let names: Vec<&str> = info.params.iter().map(|s| s.name).collect();
            let near = names
                .iter()
                .map(|n| (edit_distance(&key.to_ascii_lowercase(), n), *n))
                .filter(|(d, n)| *d <= 2.max(n.len() / 3))
                .min_by_key(|(d, _)| *d)
                .map(|(_, n)| format!("did you mean `{n}`? "))
                .unwrap_or_default();
            let mut e = cx.key_err(
                &path,
                format!("the {} model has no parameter `{key}`", info.name),
            );
            e.hint = Some(format!(
                "{near}its parameters: {} (`beeswarm models` lists them)",
                names.join(", ")
            ));
            return Err(e);
        };
        into.set(key, cx.range(&path, v, spec.min, spec.max, spec.expected)?);
    }
    Ok(())
}

/// Reads a preset file (`[preset]` header and `[params]`) for a swarm of `model`.
pub fn load_preset_file(path: &Path, model: ModelKind) -> Result<ParamValues, ShotError> {
    let builtin = || quoted(&preset_names(model));
    let src = read_bounded(path)
        .and_then(|b| {
            String::from_utf8(b)
                .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidData, "not UTF-8 text"))
        })
        .map_err(|e| ShotError {
            file: path.to_path_buf(),
            line: 0,
            column: 0,
            key: String::new(),
            message: format!("cannot read the preset file {}: {e}", path.display()),
            source_line: None,
            hint: Some(format!(
                "built-in presets of the {} model: {}",
                model.name(),
                builtin()
            )),
        })?;
    let cx = Ctx {
        file: path,
        loc: Locator::new(&src),
        documents: Default::default(),
    };
    let raw: RawPresetFile = cx.deserialize(&src).map_err(|mut e| {
        if e.message == "missing field `preset`" {
            e.key = "preset".to_owned();
            e.message = "missing the [preset] table".to_owned();
            e.hint = Some(
                "a preset file starts with [preset] (name, model, base, description, provenance), then [params]"
                    .to_owned(),
            );
        }
        e
    })?;
    let file_model = raw.preset.model.as_deref().unwrap_or("bee");
    if file_model != model.name() {
        return Err(cx.hint(
            "preset.model",
            format!(
                "this preset is for the {file_model} model, the swarm flies the {} model",
                model.name()
            ),
            "use a preset written for the swarm's model, or change the swarm's `model`",
        ));
    }
    let base = raw
        .preset
        .base
        .clone()
        .unwrap_or_else(|| model.default_preset().to_owned());
    let mut params = ParamValues::preset(model, &base).ok_or_else(|| {
        cx.err(
            "preset.base",
            format!("expected one of {}, found \"{base}\"", builtin()),
        )
    })?;
    if let Some(p) = &raw.params {
        resolve_params(&cx, "params", p, &mut params)?;
    }
    Ok(params)
}

/// The built-in preset names of a model.
fn preset_names(model: ModelKind) -> Vec<&'static str> {
    model.info().presets.iter().map(|p| p.name).collect()
}

fn resolve_swarm(
    cx: &Ctx,
    i: usize,
    rs: &RawSwarm,
    base: &Path,
    earlier: &[Swarm],
) -> Result<Swarm, ShotError> {
    let k = |key: &str| format!("swarm[{i}].{key}");
    let name = rs.name.clone().unwrap_or_else(|| {
        if i == 0 {
            d::SWARM_NAME.to_owned()
        } else {
            format!("{}_{}", d::SWARM_NAME, i + 1)
        }
    });
    if name.chars().count() > MAX_NAME {
        return Err(cx.err(
            &k("name"),
            format!(
                "expected a name of at most {MAX_NAME} characters, found {}",
                name.chars().count()
            ),
        ));
    }
    if !is_identifier(&name) {
        return Err(cx.hint(&k("name"), format!("expected a name of letters, digits and _ not starting with a digit, found \"{name}\""), "swarm names become node and prim names in the caches"));
    }
    if earlier.iter().any(|s| s.name == name) {
        return Err(cx.err(
            &k("name"),
            format!("a swarm named \"{name}\" already exists"),
        ));
    }
    let count = cx
        .required(
            &k("count"),
            &rs.count,
            "the number of bees, e.g. count = 200",
        )
        .map_err(|mut e| {
            if e.line == 0 || e.key != k("count") {
                e.key = k("count");
            }
            e
        })?;
    if count > 10_000_000 {
        return Err(cx.err(
            &k("count"),
            format!("expected at most 10000000 bees, found {count}"),
        ));
    }
    if count < 1 {
        return Err(cx.hint(
            &k("count"),
            format!("expected at least 1 bee, found {count}"),
            "remove the swarm instead of giving it no bees",
        ));
    }
    let names: Vec<&str> = ModelKind::ALL.iter().map(|m| m.name()).collect();
    let model_name = rs.model.as_deref().unwrap_or(d::MODEL);
    let model = ModelKind::parse(cx.one_of(&k("model"), model_name, &names)?)
        .expect("one of the registered names");
    let preset = rs
        .preset
        .clone()
        .unwrap_or_else(|| model.default_preset().to_owned());
    let mut params = match ParamValues::preset(model, &preset) {
        Some(p) => p,
        None if preset.ends_with(".toml") => {
            load_preset_file(&base.join(&preset), model).map_err(|e| {
                if e.line == 0 {
                    // Unreadable: say so here, where the file is named.
                    let mut outer = cx.err(&k("preset"), e.message);
                    outer.hint = e.hint;
                    outer
                } else {
                    // An error inside the preset file: show it, located in that file.
                    let mut outer = cx.err(
                        &k("preset"),
                        format!("the preset file \"{preset}\" has an error (below)"),
                    );
                    outer.hint = Some(e.to_string());
                    outer
                }
            })?
        }
        None => {
            return Err(cx.hint(
                &k("preset"),
                format!(
                    "the {} model has no preset \"{preset}\": expected one of {} or a preset file ending in .toml",
                    model.name(),
                    quoted(&preset_names(model))
                ),
                "`beeswarm models` lists every model's presets; beeswarm calibrate writes preset files",
            ));
        }
    };
    if let Some(p) = &rs.params {
        resolve_params(cx, &k("params"), p, &mut params)?;
    }

    let rsp = rs.spawn.clone().unwrap_or_default();
    let (auto_center, auto_size) = d::spawn_box(count);
    let center = cx.vec(&k("spawn.center"), rsp.center.unwrap_or(auto_center))?;
    let shape = cx.one_of(
        &k("spawn.shape"),
        rsp.shape.as_deref().unwrap_or("box"),
        &["box", "sphere"],
    )?;
    // A key of the other shape would be silently ignored: say so instead.
    let (stray, hint) = match shape {
        "box" => (
            rsp.radius.map(|_| "radius"),
            "a box takes center and size; for a sphere write shape = \"sphere\"",
        ),
        _ => (
            rsp.size.map(|_| "size"),
            "a sphere takes center and radius; for a box write shape = \"box\"",
        ),
    };
    if let Some(key) = stray {
        return Err(cx.hint(
            &k(&format!("spawn.{key}")),
            format!("a {shape} spawn region has no `{key}`"),
            hint,
        ));
    }
    let spawn = match shape {
        "box" => Region::Box {
            center,
            half: cx.size(&k("spawn.size"), rsp.size.unwrap_or(auto_size))? * 0.5,
        },
        _ => Region::Sphere {
            center,
            radius: cx.positive(
                &k("spawn.radius"),
                cx.required(
                    &k("spawn.radius"),
                    &rsp.radius,
                    "the sphere's radius in metres",
                )?,
            )? as f32,
        },
    };

    let rv = rs.variation.clone().unwrap_or_default();
    let variation = Variation {
        size: cx.range(
            &k("variation.size"),
            rv.size.unwrap_or(d::VARIATION_SIZE),
            0.0,
            0.9,
            "a fraction from 0 to 0.9",
        )? as f32,
        speed: cx.range(
            &k("variation.speed"),
            rv.speed.unwrap_or(d::VARIATION_SPEED),
            0.0,
            0.9,
            "a fraction from 0 to 0.9",
        )? as f32,
        phase: cx.range(
            &k("variation.phase"),
            rv.phase.unwrap_or(d::VARIATION_PHASE),
            0.0,
            1.0,
            "a fraction of a cycle from 0 to 1",
        )? as f32,
    };

    let rb = rs.bee.clone().unwrap_or_default();
    let bee = Body {
        length: cx.range(
            &k("bee.length"),
            rb.length.unwrap_or(d::BEE_LENGTH),
            1e-4,
            1.0,
            "a body length from 0.0001 to 1 m",
        )? as f32,
        radius: cx.range(
            &k("bee.radius"),
            rb.radius.unwrap_or(d::BEE_RADIUS),
            1e-5,
            0.5,
            "a body radius from 0.00001 to 0.5 m",
        )? as f32,
        mass: cx.range(
            &k("bee.mass"),
            rb.mass.unwrap_or(d::BEE_MASS),
            1e-7,
            10.0,
            "a mass from 1e-7 to 10 kg",
        )? as f32,
        wing_area: cx.range(
            &k("bee.wing_area"),
            rb.wing_area.unwrap_or(d::BEE_WING_AREA),
            1e-8,
            1.0,
            "a wing area from 1e-8 to 1 m²",
        )? as f32,
        wing_beat_hz: cx.range(
            &k("bee.wing_beat_hz"),
            rb.wing_beat_hz.unwrap_or(d::BEE_WING_BEAT_HZ),
            0.0,
            2000.0,
            "a frequency from 0 to 2000 Hz",
        )? as f32,
    };

    let bounds = match &rs.bounds {
        Some(b) => {
            let c = cx.vec(
                &k("bounds.center"),
                b.center.unwrap_or(rsp.center.unwrap_or(auto_center)),
            )?;
            let s = cx.size(
                &k("bounds.size"),
                cx.required(
                    &k("bounds.size"),
                    &b.size,
                    "the box size [x, y, z] in metres",
                )?,
            )?;
            Some((c, s * 0.5))
        }
        None => Some((
            spawn.center(),
            spawn.half_extents() + Vec3::splat(d::BOUNDS_MARGIN as f32),
        )),
    };

    let database = match &rs.database {
        None => None,
        Some(file) => Some(resolve_database(cx, i, model, file, base)?),
    };

    Ok(Swarm {
        name,
        count: count as usize,
        model,
        preset,
        params,
        spawn,
        variation,
        bee,
        bounds,
        database,
        start_inside: 0.0,
    })
}

/// A swarm's `database` key: a FASTSWARM velocity database file (`beeswarm fastswarm-db`
/// writes them), read and checked; errors inside the file point at its line, and back.
fn resolve_database(
    cx: &Ctx,
    i: usize,
    model: ModelKind,
    file: &str,
    base: &Path,
) -> Result<Arc<Database>, ShotError> {
    let key = format!("swarm[{i}].database");
    if model != ModelKind::Fastswarm {
        return Err(cx.hint(
            &key,
            format!("a {} swarm has no velocity database", model.name()),
            "`database` names the recorded velocities of a model = \"fastswarm\" swarm",
        ));
    }
    let path = base.join(file);
    // A database is a few tens of kilobytes; a much larger file is not one.
    const MAX_BYTES: u64 = 64 * 1024 * 1024;
    let text = std::fs::File::open(&path)
        .and_then(|f| {
            let mut s = String::new();
            std::io::Read::read_to_string(&mut std::io::Read::take(f, MAX_BYTES + 1), &mut s)
                .map(|_| s)
        })
        .map_err(|e| cx.err(&key, format!("{}: cannot read it: {e}", path.display())))?;
    if text.len() as u64 > MAX_BYTES {
        return Err(cx.err(
            &key,
            format!(
                "{}: larger than {} MB; not a velocity database",
                path.display(),
                MAX_BYTES >> 20
            ),
        ));
    }
    Database::parse_located(&text)
        .map(Arc::new)
        .map_err(|(line, message)| {
            let mut err = cx.err(&key, message.clone());
            if line > 0 {
                err.hint = Some(format!(
                    "the velocity database of swarm[{i}], `database` at {}:{}",
                    err.file.display(),
                    err.line
                ));
                err.file = path.clone();
                err.line = line;
                err.column = 1;
                err.source_line = text.lines().nth(line - 1).map(str::to_owned);
            } else {
                err.message = format!("{}: {message}", path.display());
            }
            err
        })
}

/// Keys `keys = [{ frame, position, rotation }, ...]` at `prefix` (`target[0]`), in
/// increasing frame order: (frame, position, rotation in degrees if the key has one). Only
/// a moving obstacle's keys may turn (`rotating`).
fn resolve_keys(
    cx: &Ctx,
    prefix: &str,
    raw_keys: &[RawKey],
    rotating: bool,
) -> Result<Vec<(f64, Vec3, Option<Vec3>)>, ShotError> {
    let k = |j: usize, key: &str| format!("{prefix}.keys[{j}].{key}");
    let mut keys: Vec<(f64, Vec3, Option<Vec3>)> = Vec::new();
    for (j, key) in raw_keys.iter().enumerate() {
        let f = cx.required(&k(j, "frame"), &key.frame, "the key's frame number")?;
        if !f.is_finite() {
            return Err(cx.err(
                &k(j, "frame"),
                format!("expected a frame number, found {f}"),
            ));
        }
        let p = cx.vec(
            &k(j, "position"),
            cx.required(
                &k(j, "position"),
                &key.position,
                "the key's position [x, y, z]",
            )?,
        )?;
        let rotation = match key.rotation {
            Some(_) if !rotating => {
                return Err(cx.hint(
                    &k(j, "rotation"),
                    "a target's key has no `rotation`",
                    "a target is a point: its keys move it (frame, position)",
                ));
            }
            Some(r) => Some(cx.vec(&k(j, "rotation"), r)?),
            None => None,
        };
        if let Some(&(prev, ..)) = keys.last()
            && f <= prev
        {
            return Err(cx.err(
                &k(j, "frame"),
                format!("expected key frames in increasing order, found {f} after {prev}"),
            ));
        }
        keys.push((f, p, rotation));
    }
    Ok(keys)
}

fn resolve_obstacle(
    cx: &Ctx,
    i: usize,
    ro: &RawObstacle,
    base: &Path,
    first_frame: f64,
) -> Result<Obstacle, ShotError> {
    let k = |key: &str| format!("obstacle[{i}].{key}");
    let kind = cx.required(
        &k("type"),
        &ro.kind,
        "the obstacle type: \"sphere\", \"box\", \"capsule\", \"cylinder\", \"plane\" or \"mesh\"",
    )?;
    let kind = cx.one_of(
        &k("type"),
        &kind,
        &[
            "sphere", "box", "capsule", "shaft", "cylinder", "plane", "mesh",
        ],
    )?;
    let name = ro
        .name
        .clone()
        .unwrap_or_else(|| format!("{kind}_{}", i + 1));
    let center = || {
        cx.vec(
            &k("center"),
            cx.required(&k("center"), &ro.center, "the centre [x, y, z] in metres")?,
        )
    };
    let radius = || {
        cx.positive(
            &k("radius"),
            cx.required(&k("radius"), &ro.radius, "the radius in metres")?,
        )
        .map(|r| r as f32)
    };
    let rotation = || -> Result<Quat, ShotError> {
        Ok(euler_deg(
            cx.vec(&k("rotation"), ro.rotation.unwrap_or([0.0; 3]))?,
        ))
    };
    // Keys that belong to other shapes are mistakes worth reporting.
    let allowed: &[&str] = match kind {
        "sphere" => &["center", "radius"],
        "box" => &["center", "size", "rotation"],
        "capsule" | "shaft" => &["a", "b", "radius"],
        "cylinder" => &["center", "radius", "height", "rotation"],
        "mesh" => &[
            "file",
            "node",
            "mode",
            "thickness",
            "position",
            "rotation",
            "scale",
            "keys",
        ],
        _ => &["point", "normal"],
    };
    let present = [
        ("center", ro.center.is_some()),
        ("radius", ro.radius.is_some()),
        ("size", ro.size.is_some()),
        ("height", ro.height.is_some()),
        ("rotation", ro.rotation.is_some()),
        ("a", ro.a.is_some()),
        ("b", ro.b.is_some()),
        ("point", ro.point.is_some()),
        ("normal", ro.normal.is_some()),
        ("file", ro.file.is_some()),
        ("mode", ro.mode.is_some()),
        ("thickness", ro.thickness.is_some()),
        ("position", ro.position.is_some()),
        ("scale", ro.scale.is_some()),
        ("node", ro.node.is_some()),
        ("keys", ro.keys.is_some()),
    ];
    if let Some((key, _)) = present.iter().find(|(key, p)| *p && !allowed.contains(key)) {
        return Err(cx.hint(
            &k(key),
            format!("a {kind} has no `{key}`"),
            if *key == "keys" {
                "only mesh obstacles move: type = \"mesh\" with keys = [{ frame, position, rotation }, ...]".to_owned()
            } else {
                format!("a {kind} takes {}", allowed.join(", "))
            },
        ));
    }
    // A moving mesh: its keys, in place of `position` and `rotation`.
    let mut keys = Vec::new();
    if let Some(raw) = &ro.keys {
        for key in ["position", "rotation"] {
            if present.iter().any(|(k2, p)| *p && *k2 == key) {
                return Err(cx.hint(
                    &k(key),
                    format!("a moving mesh has either `{key}` or `keys`, not both"),
                    format!("give each key its {key}: keys = [{{ frame = 1, position = [0, 1, 0], rotation = [0, 0, 0] }}, ...]"),
                ));
            }
        }
        if raw.is_empty() {
            return Err(cx.err(
                &k("keys"),
                "expected at least one key { frame, position, rotation }",
            ));
        }
        keys = resolve_keys(cx, &format!("obstacle[{i}]"), raw, true)?
            .into_iter()
            .map(|(f, position, rotation)| {
                (
                    f,
                    Placement {
                        position,
                        rotation_deg: rotation.unwrap_or(Vec3::ZERO),
                    },
                )
            })
            .collect();
    }
    let shape = match kind {
        "sphere" => Shape::Sphere {
            center: center()?,
            radius: radius()?,
        },
        "box" => Shape::Box {
            center: center()?,
            half: cx.size(
                &k("size"),
                cx.required(&k("size"), &ro.size, "the box size [x, y, z] in metres")?,
            )? * 0.5,
            rotation: rotation()?,
        },
        "capsule" | "shaft" => {
            let a = cx.vec(
                &k("a"),
                cx.required(&k("a"), &ro.a, "the first end point [x, y, z]")?,
            )?;
            let b = cx.vec(
                &k("b"),
                cx.required(&k("b"), &ro.b, "the second end point [x, y, z]")?,
            )?;
            Shape::Capsule {
                a,
                b,
                radius: radius()?,
            }
        }
        "cylinder" => Shape::Cylinder {
            center: center()?,
            radius: radius()?,
            half_height: cx.positive(
                &k("height"),
                cx.required(&k("height"), &ro.height, "the height in metres")?,
            )? as f32
                * 0.5,
            rotation: rotation()?,
        },
        "mesh" => {
            let mut obstacle = Obstacle {
                name: name.clone(),
                shape: Shape::Plane {
                    point: Vec3::ZERO,
                    normal: Vec3::Y,
                },
                keys,
            };
            // A moving mesh is built in its rest frame (scaled only) and placed by its
            // pose; a static one is built where it stands.
            let moving = !obstacle.keys.is_empty();
            let placement = if moving { Quat::IDENTITY } else { rotation()? };
            obstacle.shape = Shape::Mesh {
                mesh: resolve_mesh(cx, i, ro, base, placement, moving)?,
                pose: obstacle.pose_at(first_frame),
            };
            return Ok(obstacle);
        }
        _ => {
            let point = cx.vec(&k("point"), ro.point.unwrap_or([0.0; 3]))?;
            let n = cx.vec(&k("normal"), ro.normal.unwrap_or([0.0, 1.0, 0.0]))?;
            if n.length() < 1e-6 {
                return Err(cx.err(&k("normal"), "expected a non-zero normal vector"));
            }
            Shape::Plane {
                point,
                normal: n.normalize(),
            }
        }
    };
    Ok(Obstacle {
        name,
        shape,
        keys: Vec::new(),
    })
}

/// A `type = "mesh"` obstacle: the file read, placed in the world (scale, then
/// `rotation`, then position), checked and turned into a query structure. The same file
/// with the same placement and mode is built once per process and shared.
fn resolve_mesh(
    cx: &Ctx,
    i: usize,
    ro: &RawObstacle,
    base: &Path,
    rotation: Quat,
    moving: bool,
) -> Result<Arc<Mesh>, ShotError> {
    let k = |key: &str| format!("obstacle[{i}].{key}");
    let file = cx.required(
        &k("file"),
        &ro.file,
        "the mesh file (.obj, .stl, .ply, .gltf or .glb), relative to the shot",
    )?;
    let mode_name = ro.mode.clone().unwrap_or_else(|| "solid".to_owned());
    let mode = match cx.one_of(&k("mode"), &mode_name, &["solid", "shell"])? {
        "solid" => {
            if ro.thickness.is_some() {
                return Err(cx.hint(
                    &k("thickness"),
                    "a solid mesh has no `thickness`",
                    "`thickness` thickens an open mesh: add mode = \"shell\"",
                ));
            }
            MeshMode::Solid
        }
        _ => MeshMode::Shell {
            thickness: cx.range(
                &k("thickness"),
                ro.thickness.unwrap_or(d::MESH_SHELL_THICKNESS),
                0.0,
                1000.0,
                "a thickness from 0 to 1000 m",
            )? as f32,
        },
    };
    // A moving mesh's keys place it.
    let position = if moving {
        Vec3::ZERO
    } else {
        cx.vec(&k("position"), ro.position.unwrap_or([0.0; 3]))?
    };
    let scale = cx.size(&k("scale"), ro.scale.unwrap_or([1.0; 3]))?;
    let path = base.join(&file);
    let located = |e: mesh_file::FileError| -> ShotError {
        if ro.node.is_some() && e.message.starts_with(mesh_file::NODE_ERROR) {
            return cx.err(&k("node"), format!("{}: {}", path.display(), e.message));
        }
        let mut err = cx.err(&k("file"), e.message.clone());
        if e.line > 0 {
            // The problem is inside the mesh file: point there, and back to the shot.
            err.hint = Some(format!(
                "the mesh of obstacle[{i}], `file` at {}:{}",
                err.file.display(),
                err.line
            ));
            err.file = path.clone();
            err.line = e.line;
            err.column = 1;
            err.source_line = e.source_line;
        } else {
            err.message = format!("{}: {}", path.display(), e.message);
        }
        err
    };
    let data = mesh_file::read(&path, ro.node.as_deref(), &mut cx.documents.borrow_mut())
        .map_err(located)?;
    let vertices: Vec<Vec3> = data
        .vertices
        .iter()
        .map(|v| position + rotation * (scale * *v))
        .collect();
    let key = mesh_key(&vertices, &data.triangles, mode);
    let mut loaded = LOADED_MESHES.lock().unwrap_or_else(|e| e.into_inner());
    // Meshes no shot holds any more are gone; forget them.
    loaded.retain(|(_, m)| m.strong_count() > 0);
    if let Some(m) = loaded
        .iter()
        .find(|(k, _)| *k == key)
        .and_then(|(_, m)| m.upgrade())
    {
        return Ok(m);
    }
    let mesh = Mesh::new(&vertices, &data.triangles, mode).map_err(|e| {
        let hint = match e {
            MeshErr::NotClosed { .. } | MeshErr::Inconsistent { .. } => Some(
                "close the mesh (in Blender: Select All by Trait > Non Manifold, then fill), \
                 or avoid it as a surface with mode = \"shell\""
                    .to_owned(),
            ),
            _ => None,
        };
        let mut err = cx.err(&k("file"), format!("{}: {e}", path.display()));
        err.hint = hint;
        err
    })?;
    // Shared by the shot, its copies and the simulation; freed with the last of them.
    let mesh = Arc::new(mesh);
    loaded.push((key, Arc::downgrade(&mesh)));
    Ok(mesh)
}

/// Meshes alive in this process, by [`mesh_key`]: resolving the same shot again while a
/// copy is held (a check, then a bake; a wedge's variants) shares the mesh instead of
/// building it again. Weak, so this list never keeps a mesh alive.
static LOADED_MESHES: std::sync::Mutex<Vec<(u64, Weak<Mesh>)>> = std::sync::Mutex::new(Vec::new());

/// A digest of the placed vertices, the triangles and the mode.
fn mesh_key(vertices: &[Vec3], triangles: &[[u32; 3]], mode: MeshMode) -> u64 {
    use std::hash::{Hash, Hasher};
    // SipHash with fixed keys: the same digest in every run.
    #[allow(deprecated)]
    let mut h = std::hash::SipHasher::new();
    for v in vertices {
        v.to_array().map(f32::to_bits).hash(&mut h);
    }
    triangles.hash(&mut h);
    match mode {
        MeshMode::Solid => 0u32.hash(&mut h),
        MeshMode::Shell { thickness } => thickness.to_bits().hash(&mut h),
    }
    h.finish()
}

/// The most targets one `curve` expands into.
const MAX_CURVE_SAMPLES: i64 = 1000;

/// A target with `curve` and `samples`: one static target per sample, spread evenly by arc
/// length along the polyline through the curve's points, in order (a closed curve, whose
/// last point repeats its first, does not repeat it), named `<name>_00`, `<name>_01`, ….
/// The key points of a FASTSWARM shape (paper 003 Sec. 5.1.2) drawn as a curve.
fn curve_samples(cx: &Ctx, i: usize, rt: &RawTarget) -> Result<Vec<RawTarget>, ShotError> {
    let k = |key: &str| format!("target[{i}].{key}");
    let raw = cx.required(
        &k("curve"),
        &rt.curve,
        "the curve's points [[x, y, z], ...] that `samples` spreads targets along",
    )?;
    if rt.position.is_some() || rt.keys.is_some() {
        return Err(cx.hint(
            &k("curve"),
            "a target along a curve has no `position` or `keys`",
            "each sample of the curve is a target at its own place",
        ));
    }
    let pts: Vec<Vec3> = raw
        .iter()
        .map(|p| cx.vec(&k("curve"), *p))
        .collect::<Result<_, _>>()?;
    let samples = cx.required(&k("samples"), &rt.samples, "how many targets, 2 to 1000")?;
    if !(2..=MAX_CURVE_SAMPLES).contains(&samples) {
        return Err(cx.err(
            &k("samples"),
            format!("expected 2 to {MAX_CURVE_SAMPLES} samples, found {samples}"),
        ));
    }
    let lengths: Vec<f32> = pts.windows(2).map(|w| w[0].distance(w[1])).collect();
    let total: f32 = lengths.iter().sum();
    if pts.len() < 2 || total <= 0.0 {
        return Err(cx.err(
            &k("curve"),
            "expected at least two distinct points [[x, y, z], [x, y, z], ...]",
        ));
    }
    let closed = pts[0] == pts[pts.len() - 1];
    let n = samples as usize;
    let step = total / if closed { n } else { n - 1 } as f32;
    let name = rt
        .name
        .clone()
        .unwrap_or_else(|| format!("curve_{}", i + 1));
    let mut out = Vec::with_capacity(n);
    let (mut seg, mut start) = (0usize, 0.0f32);
    for s in 0..n {
        let at = (step * s as f32).min(total);
        while seg + 1 < lengths.len() && start + lengths[seg] < at {
            start += lengths[seg];
            seg += 1;
        }
        let t = if lengths[seg] > 0.0 {
            ((at - start) / lengths[seg]).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let p = pts[seg].lerp(pts[seg + 1], t);
        out.push(RawTarget {
            name: Some(format!("{name}_{s:02}")),
            position: Some([p.x as f64, p.y as f64, p.z as f64]),
            curve: None,
            samples: None,
            ..rt.clone()
        });
    }
    Ok(out)
}

fn resolve_target(
    cx: &Ctx,
    i: usize,
    rt: &RawTarget,
    swarms: &[Swarm],
) -> Result<Target, ShotError> {
    let k = |key: &str| format!("target[{i}].{key}");
    let kind_name = rt.kind.clone().unwrap_or_else(|| "attractor".to_owned());
    let (kind, (radius, strength)) = match cx.one_of(
        &k("type"),
        &kind_name,
        &[
            "nest",
            "flower",
            "attractor",
            "surface",
            "predator",
            "food",
            "light",
        ],
    )? {
        "nest" => (TargetKind::Nest, d::NEST),
        "flower" => (TargetKind::Flower, d::FLOWER),
        "surface" => (TargetKind::Surface, d::SURFACE),
        "predator" => (TargetKind::Predator, d::STIMULUS),
        "food" => (TargetKind::Food, d::STIMULUS),
        "light" => (TargetKind::Light, d::STIMULUS),
        _ => (TargetKind::Attractor, d::ATTRACTOR),
    };
    let normal = match (kind, rt.normal) {
        (TargetKind::Surface, n) => {
            let n = cx.vec(&k("normal"), n.unwrap_or([0.0, 1.0, 0.0]))?;
            if n.length() < 1e-9 {
                return Err(cx.err(&k("normal"), "expected a non-zero normal [x, y, z]"));
            }
            n.normalize()
        }
        (_, None) => Vec3::ZERO,
        (_, Some(_)) => {
            return Err(cx.hint(
                &k("normal"),
                format!("{} target has no `normal`", with_article(&kind_name)),
                "type = \"surface\" pulls towards a plane with this normal",
            ));
        }
    };
    let name = rt
        .name
        .clone()
        .unwrap_or_else(|| format!("{kind_name}_{}", i + 1));
    let mut keys: Vec<(f64, Vec3)> = match &rt.keys {
        Some(raw) => resolve_keys(cx, &format!("target[{i}]"), raw, false)?
            .into_iter()
            .map(|(f, p, _)| (f, p))
            .collect(),
        None => Vec::new(),
    };
    match (rt.position, keys.is_empty()) {
        (Some(p), true) => keys.push((0.0, cx.vec(&k("position"), p)?)),
        (Some(_), false) => {
            return Err(cx.hint(
                &k("position"),
                "a target has either `position` or `keys`, not both",
                "keys = [{ frame = 1, position = [0, 1, 0] }, ...] moves it",
            ));
        }
        (None, true) => {
            return Err(cx.err(
                &k("position"),
                "missing key `position`: expected the target's position [x, y, z] (or `keys`)",
            ));
        }
        (None, false) => {}
    }
    let radius = cx.positive(&k("radius"), rt.radius.unwrap_or(radius))? as f32;
    let strength = cx.non_negative(&k("strength"), rt.strength.unwrap_or(strength))? as f32;
    let reach = match rt.reach {
        Some(r) => cx.positive(&k("reach"), r)? as f32,
        None => f32::INFINITY,
    };
    let swarm_ids = match &rt.swarms {
        None => (0..swarms.len()).collect(),
        Some(names) => names
            .iter()
            .enumerate()
            .map(|(j, n)| {
                swarms.iter().position(|s| &s.name == n).ok_or_else(|| {
                    let known: Vec<&str> = swarms.iter().map(|s| s.name.as_str()).collect();
                    cx.err(
                        &k(&format!("swarms[{j}]")),
                        format!("no swarm named \"{n}\"; the shot has {}", quoted(&known)),
                    )
                })
            })
            .collect::<Result<_, _>>()?,
    };
    let land = rt.land.unwrap_or(false);
    if land && !kind.has_body() {
        return Err(cx.hint(
            &k("land"),
            format!("bees cannot land on {}", with_article(&kind_name)),
            "`land = true` is for a nest or a flower, which have a body to land on",
        ));
    }
    let stay = match &rt.stay {
        None => d::STAY_S,
        Some(_) if !land => {
            return Err(cx.hint(
                &k("stay"),
                "`stay` is how long bees stay after landing, and this target has no `land = true`",
                "add `land = true` to let bees land on it",
            ));
        }
        Some(v) => cx.seconds_range(&k("stay"), v)?,
    };
    let inside = match &rt.inside {
        None => None,
        Some(_) if kind != TargetKind::Nest => {
            return Err(cx.hint(
                &k("inside"),
                format!("bees cannot go inside {}", with_article(&kind_name)),
                "`inside` is for a nest (a hive entrance) with `land = true`",
            ));
        }
        Some(_) if !land => {
            return Err(cx.hint(
                &k("inside"),
                "`inside` is how long bees stay in the hive after landing at its entrance, and this nest has no `land = true`",
                "add `land = true` to let bees land on it and go in",
            ));
        }
        Some(v) => Some(cx.seconds_range(&k("inside"), v)?),
    };
    Ok(Target {
        name,
        kind,
        keys,
        radius,
        strength,
        reach,
        normal,
        swarms: swarm_ids,
        land,
        stay: (stay.0 as f32, stay.1 as f32),
        inside: inside.map(|(a, b)| (a as f32, b as f32)),
    })
}

/// Each swarm's `start_inside`: a fraction from 0 to 1, for a `bee` swarm that a hive (a
/// nest with `inside`) attracts. Read once the targets are known.
fn resolve_start_inside(
    cx: &Ctx,
    raw: &[RawSwarm],
    swarms: &mut [Swarm],
    targets: &[Target],
) -> Result<(), ShotError> {
    for (i, (rs, s)) in raw.iter().zip(swarms.iter_mut()).enumerate() {
        let Some(v) = rs.start_inside else { continue };
        let key = format!("swarm[{i}].start_inside");
        let f = cx.range(&key, v, 0.0, 1.0, "a fraction of the swarm from 0 to 1")?;
        if f > 0.0 && s.model != ModelKind::Bee {
            return Err(cx.hint(
                &key,
                format!(
                    "only bees go inside a hive, and this swarm flies with the `{}` model",
                    s.model.name()
                ),
                "remove `start_inside`, or use model = \"bee\"",
            ));
        }
        let hive = targets
            .iter()
            .any(|t| t.inside.is_some() && t.swarms.contains(&i));
        if f > 0.0 && !hive {
            return Err(cx.hint(
                &key,
                "no hive to start inside: no nest with `inside` attracts this swarm",
                "give a nest `land = true` and `inside = [min, max]` seconds",
            ));
        }
        s.start_inside = f as f32;
    }
    Ok(())
}

/// "an attractor", "a nest".
fn with_article(word: &str) -> String {
    let vowel = word.starts_with(['a', 'e', 'i', 'o', 'u']);
    format!("{} {word}", if vowel { "an" } else { "a" })
}

/// A model that builds a field from the obstacles once per shot (the `field` model's
/// path cost, paper 001 Eq. 4) would steer by a stale field if one moved: refused, at the
/// first moving obstacle's `keys`.
fn check_moving_obstacles(
    cx: &Ctx,
    swarms: &[Swarm],
    obstacles: &[Obstacle],
) -> Result<(), ShotError> {
    let Some(i) = obstacles.iter().position(|o| !o.keys.is_empty()) else {
        return Ok(());
    };
    for (si, s) in swarms.iter().enumerate() {
        let static_only = crate::model::with_model!(s.model, M => {
            <M as crate::model::Model>::STATIC_OBSTACLES
        });
        if static_only {
            return Err(cx.hint(
                &format!("obstacle[{i}].keys"),
                format!(
                    "swarm[{si}] (\"{}\") flies the `{}` model, which builds its path cost field \
                     from the obstacles once per shot, so an obstacle cannot move in its shot",
                    s.name,
                    s.model.name()
                ),
                "remove `keys` (place the mesh with `position` and `rotation`), or give the \
                 swarm a model that sees obstacles move (bee, zonal, boids, ...)",
            ));
        }
    }
    Ok(())
}

/// A spawn region that lies wholly inside obstacles would trap every bee.
fn check_spawn_regions(cx: &Ctx, shot: &Shot) -> Result<(), ShotError> {
    for (i, s) in shot.swarms.iter().enumerate() {
        let c = s.spawn.center();
        let h = s.spawn.half_extents();
        let n = 4;
        let mut all_inside = true;
        'grid: for a in 0..=n {
            for b in 0..=n {
                for e in 0..=n {
                    let f = Vec3::new(a as f32, b as f32, e as f32) / n as f32 * 2.0 - Vec3::ONE;
                    if matches!(s.spawn, Region::Sphere { .. }) && f.length() > 1.0 {
                        continue;
                    }
                    let p = c + f * h;
                    if !shot
                        .obstacles
                        .iter()
                        .any(|o| crate::geometry::signed_distance(&o.shape, p) < 0.0)
                    {
                        all_inside = false;
                        break 'grid;
                    }
                }
            }
        }
        if all_inside && !shot.obstacles.is_empty() {
            return Err(cx.hint(
                &format!("swarm[{i}].spawn"),
                "the spawn region lies entirely inside obstacles",
                "move the spawn centre out of the obstacle or make the region larger",
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::geometry::Shape;

    /// A target with `curve` and `samples` becomes that many targets, evenly spaced along
    /// the polyline in order; a closed curve does not repeat its start; errors are located.
    #[test]
    fn a_curve_is_sampled_into_key_points() {
        let dir = std::path::Path::new(".");
        let parse = |t: &str| {
            super::super::parse(
                &format!(
                    "[[swarm]]\ncount = 2\nmodel = \"fastswarm\"\npreset = \"shape\"\n[[target]]\n{t}"
                ),
                &dir.join("s.toml"),
                dir,
            )
        };
        // A closed unit square, 8 samples: its corners and the middles of its sides.
        let shot = parse("name = \"sq\"\ncurve = [[0, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0], [0, 1, 0]]\nsamples = 8\n").unwrap();
        let got: Vec<glam::Vec3> = shot.targets.iter().map(|t| t.position_at(1.0)).collect();
        let want = [
            [0.0, 1.0],
            [0.5, 1.0],
            [1.0, 1.0],
            [1.0, 1.5],
            [1.0, 2.0],
            [0.5, 2.0],
            [0.0, 2.0],
            [0.0, 1.5],
        ];
        assert_eq!(got.len(), 8);
        for (g, w) in got.iter().zip(want) {
            assert!(
                (*g - glam::Vec3::new(w[0], w[1], 0.0)).length() < 1e-5,
                "{got:?}"
            );
        }
        assert_eq!(shot.targets[3].name, "sq_03");
        // Open: both ends are samples.
        let shot = parse("curve = [[0, 1, 0], [2, 1, 0]]\nsamples = 3\n").unwrap();
        assert_eq!(
            shot.targets[2].position_at(1.0),
            glam::Vec3::new(2.0, 1.0, 0.0)
        );
        let e = parse("curve = [[0, 1, 0], [2, 1, 0]]\nsamples = 1\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("expected 2 to 1000 samples, found 1"),
            "{e}"
        );
        let e = parse("curve = [[0, 1, 0]]\nsamples = 4\n").unwrap_err();
        assert!(
            e.to_string().contains("at least two distinct points"),
            "{e}"
        );
        let e = parse("curve = [[0, 1, 0], [1, 1, 0]]\n").unwrap_err();
        assert!(e.to_string().contains("target[0].samples"), "{e}");
        let e = parse("curve = [[0, 1, 0], [1, 1, 0]]\nsamples = 3\nposition = [0, 0, 0]\n")
            .unwrap_err();
        assert!(e.to_string().contains("has no `position` or `keys`"), "{e}");
    }

    /// A mesh lives as long as a shot (or a simulation's copy) holds it, is shared while
    /// it does, and is freed with the last holder.
    #[test]
    fn meshes_are_shared_while_held_and_freed_after() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("t.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
        )
        .unwrap();
        let src = "[[swarm]]\ncount = 2\n[[obstacle]]\ntype = \"mesh\"\nfile = \"t.obj\"\n";
        let load = || super::super::parse(src, &dir.path().join("s.toml"), dir.path()).unwrap();
        let mesh_of = |s: &crate::shot::Shot| match &s.obstacles[0].shape {
            Shape::Mesh { mesh, .. } => mesh.clone(),
            other => panic!("{other:?}"),
        };
        let a = load();
        let b = load();
        let m = mesh_of(&a);
        assert!(
            std::sync::Arc::ptr_eq(&m, &mesh_of(&b)),
            "built once, shared"
        );
        let weak = std::sync::Arc::downgrade(&m);
        drop((a, b, m));
        assert!(weak.upgrade().is_none(), "freed with its last holder");
        // Built again when asked again.
        assert_eq!(mesh_of(&load()).triangle_count(), 4);
    }
}
