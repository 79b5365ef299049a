//! The distribution figure (like Fig. 18 of paper 000): one panel per metric, the
//! reference as grey bars, each candidate as a coloured step outline, ΔE per candidate in
//! the panel, one legend for the figure.

use super::report::Report;
use crate::plot::{Canvas, Chart, Legend, LegendMark, palette};

const PANEL_W: i64 = 400;
const PANEL_H: i64 = 290;
const HEADER_H: i64 = 30;

/// Short label for a candidate in panels: its name, shortened to fit.
fn short(name: &str, max: usize) -> String {
    let n: Vec<char> = name.chars().collect();
    if n.len() <= max {
        name.to_owned()
    } else {
        n[..max - 1].iter().collect::<String>() + "~"
    }
}

/// Renders the report's distributions. Metrics the reference lacks get no panel.
pub fn draw(report: &Report) -> Canvas {
    let panels: Vec<_> = report.metrics.iter().filter(|m| m.applicable).collect();
    let cols = panels.len().clamp(1, 3) as i64;
    let rows = (panels.len() as i64 + cols - 1) / cols;
    let mut legend = Legend::default();
    legend.add(
        format!("real: {}", report.reference.name),
        palette::LIGHT_GREY,
        LegendMark::Box,
    );
    for (i, c) in report.candidates.iter().enumerate() {
        legend.add(c.name.clone(), palette::series(i), LegendMark::Line);
    }
    let (lw, lh) = legend.size();
    let width = (cols * PANEL_W).max(lw + 40);
    let height = HEADER_H + lh + 10 + rows.max(1) * PANEL_H;
    let mut c = Canvas::new(width as u32, height as u32, palette::WHITE);

    let title = format!(
        "flight metrics: real vs simulated (dt = {} s, {} shared bins; end bins hold the tails; spikes over 2.5x the real peak are cut)",
        report.settings.dt, report.settings.bins
    );
    c.text(12, 10, &title, palette::BLACK, 1);
    legend.draw(&mut c, 12, HEADER_H);

    for (n, m) in panels.iter().enumerate() {
        let ox = (n as i64 % cols) * PANEL_W;
        let oy = HEADER_H + lh + 10 + (n as i64 / cols) * PANEL_H;
        let Some(bins) = m.bins else { continue };
        let edges = bins.edges();
        // The axis fits the reference and candidates, but a candidate's spike (often all
        // its mass in an end bin) may not squash the reference flat: bars taller than 2.5
        // times the reference's highest are cut at the top of the panel.
        let rmax = m.reference_masses.iter().fold(0.0f64, |a, &b| a.max(b));
        let ymax = m
            .candidates
            .iter()
            .flat_map(|c| c.masses.iter())
            .fold(rmax, |a, &b| a.max(b))
            .min(2.5 * rmax.max(1e-3));
        let chart = Chart::new(
            ox + 62,
            oy + 28,
            ox + PANEL_W - 14,
            oy + PANEL_H - 44,
            (bins.lo, bins.hi),
            (0.0, (ymax * 1.08).max(1e-3)),
        );
        chart.bars(&mut c, &edges, &m.reference_masses, palette::LIGHT_GREY);
        for (i, cand) in m.candidates.iter().enumerate() {
            if cand.l1.is_some() {
                chart.steps(&mut c, &edges, &cand.masses, palette::series(i), 2);
            }
        }
        chart.frame(&mut c, m.metric.label(), "", "probability");
        // ΔE per candidate, top right inside the plot area.
        for (i, cand) in m.candidates.iter().enumerate() {
            let s = match cand.l1 {
                Some(d) => format!("{} ΔE={d:.3}", short(&cand.name, 12)),
                None => format!("{} n/a", short(&cand.name, 12)),
            };
            let w = Canvas::text_width(&s, 1);
            let y = chart.top + 6 + i as i64 * 11;
            c.fill_rect(
                chart.right - w - 8,
                y - 1,
                chart.right - 2,
                y + 8,
                palette::WHITE,
            );
            c.text(
                chart.right - w - 4,
                y,
                &s,
                palette::darken(palette::series(i), 0.15),
                1,
            );
        }
    }
    c
}
