//! The import direction between top-level modules: no cycles, and the lower layers (shot,
//! model, species, geometry, field, math) never import the simulation or the writers.
//! Read from the sources, so a new `use crate::…` that breaks the layering fails here.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Top-level module → the top-level modules its files name as `crate::<module>`.
fn imports() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for entry in std::fs::read_dir(&src).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        if name == "main" || name == "lib" {
            continue;
        }
        let mut files = Vec::new();
        collect(&path, &mut files);
        let deps = out.entry(name.clone()).or_default();
        for f in files {
            let source = std::fs::read_to_string(&f).unwrap();
            // Code only: a doc comment may name a module it does not import.
            let text: String = source
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .collect::<Vec<_>>()
                .join("\n");
            for (k, _) in text.match_indices("crate::") {
                let rest = &text[k + "crate::".len()..];
                let m: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                // `crate::{a, b}` groups are not used in this code base; a module name is
                // lower case.
                if !m.is_empty() && m != name && m.chars().all(|c| !c.is_ascii_uppercase()) {
                    deps.insert(m);
                }
            }
        }
    }
    // Only names of top-level modules count (`crate::declare_params!` is a macro).
    let modules: BTreeSet<String> = out.keys().cloned().collect();
    for deps in out.values_mut() {
        deps.retain(|d| modules.contains(d));
    }
    out
}

fn collect(path: &Path, files: &mut Vec<std::path::PathBuf>) {
    if path.is_dir() {
        for e in std::fs::read_dir(path).unwrap() {
            collect(&e.unwrap().path(), files);
        }
    } else if path.extension().is_some_and(|e| e == "rs") {
        files.push(path.to_path_buf());
    }
}

#[test]
fn top_level_modules_import_each_other_without_cycles() {
    let graph = imports();
    // Depth-first search for a back edge; report the cycle's path.
    fn visit(
        m: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        stack: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(at) = stack.iter().position(|s| s == m) {
            let mut cycle = stack[at..].to_vec();
            cycle.push(m.to_owned());
            return Some(cycle);
        }
        if done.contains(m) {
            return None;
        }
        stack.push(m.to_owned());
        for d in graph.get(m).into_iter().flatten() {
            if let Some(c) = visit(d, graph, stack, done) {
                return Some(c);
            }
        }
        stack.pop();
        done.insert(m.to_owned());
        None
    }
    let mut done = BTreeSet::new();
    for m in graph.keys() {
        if let Some(cycle) = visit(m, &graph, &mut Vec::new(), &mut done) {
            panic!("import cycle: {}", cycle.join(" → "));
        }
    }
}

#[test]
fn lower_layers_import_neither_the_simulation_nor_the_writers() {
    let graph = imports();
    for lower in [
        "math", "simd", "geometry", "field", "species", "model", "shot",
    ] {
        let deps = graph.get(lower).cloned().unwrap_or_default();
        for upper in ["sim", "export", "bake", "cli", "eval", "plot"] {
            assert!(
                !deps.contains(upper),
                "`{lower}` imports `{upper}`: it must stay below it ({deps:?})"
            );
        }
    }
    // The shot describes models' parameters but never runs one.
    let model = graph.get("model").cloned().unwrap_or_default();
    assert!(!model.contains("shot"), "`model` imports `shot`: {model:?}");
}

#[test]
fn the_check_sees_the_modules_it_guards() {
    // Guards the test itself: if the source layout changed so that nothing is read, the
    // two tests above would pass vacuously.
    let graph = imports();
    for m in ["sim", "shot", "model", "export", "geometry"] {
        assert!(graph.contains_key(m), "no module `{m}` found in src/");
    }
    assert!(graph["sim"].contains("geometry") && graph["sim"].contains("model"));
}
