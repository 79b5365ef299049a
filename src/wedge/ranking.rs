//! The gather step's ranking: every variant's tracks compared with a recording by
//! `beeswarm eval` (docs/validation.md) in one report, and the variants ranked by its
//! fitness q (the mean similarity over the single-insect metrics, 1 = the recording's
//! distributions; what `calibrate` maximises).

use super::Manifest;
use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use crate::eval::EvalArgs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `DIR/<name>.eval.json` (eval's report) and `DIR/<name>.eval.md` (the ranking,
/// then eval's table); returns their paths.
pub fn write(dir: &Path, manifest: &Manifest, reference: &Path) -> Result<Vec<PathBuf>> {
    let tracks = |k: usize| {
        let v = &manifest.variants[k];
        let csv = dir.join(v.caches()).join(format!("{}.tracks.csv", v.name));
        format!("{}={}", v.index, csv.display())
    };
    let json = dir.join(format!("{}.eval.json", manifest.name));
    let table = dir.join(format!("{}.eval.table.md", manifest.name));
    let args = EvalArgs {
        tracks: tracks(0),
        reference: reference.to_path_buf(),
        reference_part: None,
        candidates: (1..manifest.variants.len()).map(tracks).collect(),
        out: Some(json.clone()),
        figure: None,
        markdown: Some(table.clone()),
        dt: None,
        bins: 40,
        density_radius: 0.15,
        min_speed: 1e-3,
    };
    crate::eval::run_eval(&args)?;
    let eval_table = std::fs::read_to_string(&table).map_err(|e| Error::io(&table, e))?;
    let _ = std::fs::remove_file(&table);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).map_err(|e| Error::io(&json, e))?)
            .map_err(|e| Error::bake(format!("{}: {e}", json.display())))?;
    let mut rows: Vec<(usize, f64, f64, f64)> = report["scores"]
        .as_array()
        .map(|scores| {
            scores
                .iter()
                .filter_map(|s| {
                    Some((
                        s["name"].as_str()?.parse().ok()?,
                        s["fitness"].as_f64()?,
                        s["q_all"].as_f64()?,
                        s["entropy_score"].as_f64()?,
                    ))
                })
                .collect()
        })
        .unwrap_or_default();
    if rows.len() != manifest.variants.len() {
        return Err(Error::bake(format!(
            "{}: expected a score per variant",
            json.display()
        )));
    }
    // Best first; ties keep the variants' order.
    rows.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    let mut md = format!(
        "# Wedge {}: {} variants ranked against {}\n\n\
         Ranked by fitness q (mean similarity of the single-insect metrics to the recording, \
         1 = the same distributions; docs/validation.md).\n\n\
         | rank | variant | values | fitness q | q (all applicable) | entropy score E |\n\
         |---:|---:|---|---:|---:|---:|\n",
        manifest.name,
        manifest.variants.len(),
        manifest.reference.as_deref().unwrap_or("the reference"),
    );
    for (rank, (index, fitness, q_all, e)) in rows.iter().enumerate() {
        let label = &manifest.variants[index - 1].label;
        md += &format!(
            "| {} | {index} | {label} | {fitness:.4} | {q_all:.4} | {e:.4} |\n",
            rank + 1
        );
    }
    md += "\n## Per metric (eval)\n\n";
    md += &eval_table;
    let path = dir.join(format!("{}.eval.md", manifest.name));
    let mut f = AtomicFile::create(&path)?;
    f.write_all(md.as_bytes())
        .map_err(|e| Error::io(&path, e))?;
    Ok(vec![json, f.commit()?])
}
