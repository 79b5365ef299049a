//! A variant's shot file: the wedged shot's own text with the variant's keys set (so its
//! comments and layout survive), checked as a shot, then made to stand alone in the wedge
//! folder: its own scene name and output folder, a preview for the contact sheet, and
//! preset files copied beside it.

use super::vary::Variant;
use crate::error::{Error, Result, ShotError};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toml_edit::{DocumentMut, Item, TableLike, Value};

/// The shot's top-level tables; any other first segment is a `[scene]` key (`seed`).
const TABLES: [&str; 6] = ["scene", "swarm", "obstacle", "target", "wind", "output"];
/// Arrays of tables, addressed by an element's `name` or index.
const ARRAYS: [&str; 3] = ["swarm", "obstacle", "target"];

/// A value as written on the command line: TOML (`1.2`, `"a"`, `[0, 1, 0]`), else a bare
/// word taken as a string (`nest`).
fn parse_value(text: &str) -> Value {
    match format!("v = {text}").parse::<DocumentMut>() {
        Ok(doc) => match doc.get("v").and_then(Item::as_value) {
            Some(v) => {
                let mut v = v.clone();
                v.decor_mut().clear();
                v
            }
            None => Value::from(text),
        },
        Err(_) => Value::from(text),
    }
}

/// Sets `key` (see [`super::vary`]) to `value` in `doc`, creating missing tables (inline
/// below the top level, so a new sub-table never lands under the wrong `[[swarm]]`).
pub fn set(doc: &mut DocumentMut, key: &str, value: Value) -> std::result::Result<(), String> {
    let mut segs: Vec<&str> = key.split('.').collect();
    if !TABLES.contains(&segs[0]) {
        segs.insert(0, "scene");
    }
    let (last, path) = segs.split_last().expect("a key has a segment");
    let mut table: &mut dyn TableLike = doc.as_table_mut();
    let mut i = 0;
    while i < path.len() {
        let seg = path[i];
        if i == 0 && ARRAYS.contains(&seg) {
            let Some(&element) = path.get(1) else {
                return Err(format!(
                    "expected {seg}.NAME.KEY: which [[{seg}]] (its name or index), then the key"
                ));
            };
            let Some(array) = table.get_mut(seg).and_then(Item::as_array_of_tables_mut) else {
                return Err(format!("the shot has no [[{seg}]]"));
            };
            let names: Vec<String> = array
                .iter()
                .enumerate()
                .map(|(k, t)| {
                    t.get("name")
                        .and_then(Item::as_str)
                        .map_or_else(|| k.to_string(), str::to_owned)
                })
                .collect();
            let Some(idx) = names
                .iter()
                .position(|n| n == element)
                .or_else(|| element.parse::<usize>().ok().filter(|&k| k < names.len()))
            else {
                return Err(format!(
                    "no {seg} named \"{element}\"; the shot has {}",
                    names
                        .iter()
                        .map(|n| format!("\"{n}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            };
            table = array.get_mut(idx).expect("index checked");
            i += 2;
            continue;
        }
        if !table.contains_key(seg) {
            let new = if i == 0 {
                Item::Table(toml_edit::Table::new())
            } else {
                Item::Value(Value::InlineTable(toml_edit::InlineTable::new()))
            };
            table.insert(seg, new);
        }
        let here = path[..=i].join(".");
        table = table
            .get_mut(seg)
            .and_then(Item::as_table_like_mut)
            .ok_or_else(|| format!("{here} is a value, not a table"))?;
        i += 1;
    }
    match table.get_mut(last).and_then(Item::as_value_mut) {
        Some(old) => {
            // Keep the comment and spacing around the old value.
            let decor = old.decor().clone();
            *old = value;
            *old.decor_mut() = decor;
        }
        None => {
            if table.get(last).is_some_and(|i| !i.is_none()) {
                return Err(format!("{key} is a table; set one of its keys"));
            }
            table.insert(last, Item::Value(value));
        }
    }
    Ok(())
}

/// Makes the text of variant `index` (1-based) of the shot at `shot_path` (text `src`),
/// checked: an error is located in the wedged shot's lines (the variant's values are
/// written in place) and names the variant.
pub fn varied_text(src: &str, shot_path: &Path, index: usize, variant: &Variant) -> Result<String> {
    let mut doc: DocumentMut = src.parse().map_err(|e: toml_edit::TomlError| {
        Error::input(format!("{}: not valid TOML: {e}", shot_path.display()))
    })?;
    for (key, value) in &variant.assignments {
        set(&mut doc, key, parse_value(value)).map_err(|e| {
            Error::input(format!(
                "wedge variant {index} ({}): {key}: {e}",
                variant.label()
            ))
        })?;
    }
    let text = doc.to_string();
    let base = shot_path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    crate::shot::parse(&text, shot_path, &base).map_err(|mut e: ShotError| {
        e.message = format!(
            "{} (in wedge variant {index}: {})",
            e.message,
            variant.label()
        );
        // A line the wedge added (a key the shot did not have) is not a line of the shot
        // file: say whose text the location is in.
        let key_of = |line: &str| line.split('=').next().unwrap_or("").trim().to_owned();
        let (ours, theirs) = (
            src.lines().nth(e.line.wrapping_sub(1)),
            text.lines().nth(e.line.wrapping_sub(1)),
        );
        if e.line > 0 && ours.map(key_of) != theirs.map(key_of) {
            e.file = PathBuf::from(format!(
                "{} as wedge variant {index} writes it",
                shot_path.display()
            ));
        }
        Error::Shot(Box::new(e))
    })?;
    Ok(text)
}

/// Preset files copied into a wedge's `presets/` folder: source → file name there.
#[derive(Default)]
pub struct CopiedPresets {
    pub files: BTreeMap<PathBuf, String>,
}

impl CopiedPresets {
    /// The name in `presets/` for the preset file at `source`, unique per source.
    fn name_for(&mut self, source: &Path) -> String {
        if let Some(n) = self.files.get(source) {
            return n.clone();
        }
        let stem = source
            .file_stem()
            .map_or_else(|| "preset".to_owned(), |s| s.to_string_lossy().into_owned());
        let mut name = format!("{stem}.toml");
        let mut k = 2;
        while self.files.values().any(|n| *n == name) {
            name = format!("{stem}_{k}.toml");
            k += 1;
        }
        self.files.insert(source.to_path_buf(), name.clone());
        name
    }
}

/// Rewrites a checked variant so it stands alone as `variants/<variant_name>.toml` of the
/// wedge: its scene name, its output folder `../caches/<variant_name>`, `formats`, a
/// preview, and preset files as `../presets/<file>` (recorded in `presets` for copying).
pub fn standalone_text(
    text: &str,
    shot_dir: &Path,
    variant_name: &str,
    formats: &[crate::shot::Format],
    presets: &mut CopiedPresets,
) -> Result<String> {
    let mut doc: DocumentMut = text.parse().map_err(|e| Error::bake(format!("{e}")))?;
    let internal = |e: String| Error::bake(format!("cannot write the variant shot: {e}"));
    set(&mut doc, "scene.name", Value::from(variant_name)).map_err(internal)?;
    set(
        &mut doc,
        "output.dir",
        Value::from(format!("../caches/{variant_name}")),
    )
    .map_err(internal)?;
    set(&mut doc, "output.preview", Value::from(true)).map_err(internal)?;
    let names: toml_edit::Array = formats.iter().map(|f| f.name()).collect();
    set(&mut doc, "output.formats", Value::Array(names)).map_err(internal)?;
    if let Some(swarms) = doc.get_mut("swarm").and_then(Item::as_array_of_tables_mut) {
        for t in swarms.iter_mut() {
            let Some(preset) = t.get("preset").and_then(Item::as_str) else {
                continue;
            };
            if !preset.ends_with(".toml") {
                continue; // a built-in preset
            }
            let source = shot_dir.join(preset);
            let source = source.canonicalize().unwrap_or(source);
            let name = presets.name_for(&source);
            t["preset"] = toml_edit::value(format!("../presets/{name}"));
        }
    }
    Ok(doc.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set_str(src: &str, key: &str, value: &str) -> std::result::Result<String, String> {
        let mut doc: DocumentMut = src.parse().unwrap();
        set(&mut doc, key, parse_value(value))?;
        Ok(doc.to_string())
    }

    const SHOT: &str = "[scene]\nseed = 1 # the seed\n\n[[swarm]]\nname = \"a\"\ncount = 3\n\n[[swarm]]\nname = \"b\"\ncount = 4\n";

    #[test]
    fn sets_keys_in_place() {
        let out = set_str(SHOT, "seed", "7").unwrap();
        assert!(out.contains("seed = 7 # the seed\n"), "{out}");
        let out = set_str(SHOT, "swarm.b.count", "9").unwrap();
        assert!(out.contains("name = \"b\"\ncount = 9\n"), "{out}");
        let out = set_str(SHOT, "swarm.0.params.speed", "1.5").unwrap();
        assert!(
            out.contains("name = \"a\"\ncount = 3\nparams = { speed = 1.5 }\n"),
            "{out}"
        );
        let out = set_str(SHOT, "swarm.a.preset", "nest").unwrap();
        assert!(out.contains("preset = \"nest\""), "{out}");
        let out = set_str(SHOT, "wind.velocity", "[1, 0, 0]").unwrap();
        assert!(out.contains("[wind]\nvelocity = [1, 0, 0]"), "{out}");
    }

    #[test]
    fn refuses_what_it_cannot_address() {
        let e = set_str(SHOT, "swarm.c.count", "1").unwrap_err();
        assert!(
            e.contains("no swarm named \"c\"; the shot has \"a\", \"b\""),
            "{e}"
        );
        let e = set_str(SHOT, "seed.x", "1").unwrap_err();
        assert!(e.contains("scene.seed is a value"), "{e}");
        let e = set_str(SHOT, "obstacle.x.radius", "1").unwrap_err();
        assert!(e.contains("no [[obstacle]]"), "{e}");
        let e = set_str(SHOT, "swarm.count", "1").unwrap_err();
        assert!(e.contains("expected swarm.NAME.KEY"), "{e}");
    }
}
