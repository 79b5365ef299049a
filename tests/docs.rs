//! Reference pages generated from the code stay in step with it.

use std::path::Path;

#[test]
fn docs_models_md_matches_beeswarm_models_markdown() {
    let page =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/models.md"))
            .expect("docs/models.md");
    let generated = beeswarm::cli::models::markdown();
    assert!(
        page == generated,
        "docs/models.md is out of date: regenerate it with `beeswarm models --markdown > docs/models.md`"
    );
}

/// The `name` of every entry of the list `v[key]`.
fn names<'a>(v: &'a serde_json::Value, key: &str) -> Vec<&'a str> {
    v[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect()
}

#[test]
fn models_json_lists_every_model_with_its_parameters_and_presets() {
    let doc: serde_json::Value = serde_json::from_str(&beeswarm::cli::models::json()).unwrap();
    let models = doc["models"].as_array().unwrap();
    let model = |name: &str| models.iter().find(|m| m["name"] == name).unwrap();
    assert_eq!(
        names(&doc, "models"),
        [
            "bee",
            "curl",
            "brownian",
            "boids",
            "field",
            "fastswarm",
            "zonal",
            "butterfly"
        ]
    );
    assert_eq!(names(model("field"), "channels"), ["speed", "cost", "mde"]);
    assert_eq!(
        names(model("field"), "presets"),
        [
            "two_blocks",
            "chasing",
            "aggregation",
            "phototaxis",
            "locusts"
        ]
    );
    // Paper 003: Table 1's scenarios as presets, and its two channels.
    let fast = model("fastswarm");
    assert_eq!(
        names(fast, "presets"),
        ["aggregation", "mating", "escaping", "shape"]
    );
    assert_eq!(names(fast, "channels"), ["speed", "startled"]);
    let bee = model("bee");
    let params = names(bee, "params");
    assert!(
        params.contains(&"kappa1") && params.contains(&"neighbour_radius"),
        "{params:?}"
    );
    assert_eq!(names(bee, "presets"), ["nest", "grassland", "optimized"]);
    // A preset's values are every parameter's value under it.
    assert_eq!(bee["presets"][1]["values"]["kappa2"], 5.0);
    assert_eq!(names(bee, "channels"), ["pitch", "roll", "sway", "state"]);
    let curl = names(model("curl"), "params");
    assert!(
        curl.contains(&"speed") && !curl.contains(&"kappa1"),
        "{curl:?}"
    );
    // Models flying with the shared force-based flight declare its parameters.
    for m in ["bee", "brownian", "boids"] {
        let p = names(model(m), "params");
        for shared in [
            "speed",
            "avoid_distance",
            "heading_lag",
            "collision_stiffness",
            "attraction",
            "containment",
        ] {
            assert!(p.contains(&shared), "{m} lacks {shared}");
        }
    }
    for m in models {
        for p in m["params"].as_array().unwrap() {
            let (lo, hi, d) = (
                p["min"].as_f64().unwrap(),
                p["max"].as_f64().unwrap(),
                p["default"].as_f64().unwrap(),
            );
            assert!(
                lo <= d && d <= hi,
                "{}.{}: default {d} outside [{lo}, {hi}]",
                m["name"],
                p["name"]
            );
            assert!(!p["doc"].as_str().unwrap().is_empty());
        }
    }
}
