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

#[test]
fn models_json_lists_every_model_with_its_parameters_and_presets() {
    let doc: serde_json::Value = serde_json::from_str(&beeswarm::cli::models::json()).unwrap();
    let models = doc["models"].as_array().unwrap();
    let names: Vec<&str> = models.iter().map(|m| m["name"].as_str().unwrap()).collect();
    for want in ["bee", "curl", "brownian", "boids"] {
        assert!(names.contains(&want), "{want} missing from {names:?}");
    }
    let bee = &models[names.iter().position(|n| *n == "bee").unwrap()];
    let params: Vec<&str> = bee["params"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert!(
        params.contains(&"kappa1") && params.contains(&"neighbour_radius"),
        "{params:?}"
    );
    let presets: Vec<&str> = bee["presets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert_eq!(presets, ["nest", "grassland", "optimized"]);
    // A preset's values are every parameter's value under it.
    assert_eq!(bee["presets"][1]["values"]["kappa2"], 5.0);
    let channels: Vec<&str> = bee["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    assert_eq!(channels, ["pitch", "roll", "sway"]);
    let curl = &models[names.iter().position(|n| *n == "curl").unwrap()];
    let curl_params: Vec<&str> = curl["params"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert!(
        curl_params.contains(&"speed") && !curl_params.contains(&"kappa1"),
        "{curl_params:?}"
    );
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
