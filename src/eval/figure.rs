//! The distribution figure (like Fig. 18 of paper 000): one panel per metric, the
//! reference as grey bars, each candidate as a coloured step outline, ΔE per candidate in
//! the panel, one legend for the figure.

use super::report::Report;
use crate::error::Result;
use crate::plot::{Figure, Legend, Mark, bold, house_axes, palette, px, text};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Output pixels: a panel, the figure's side margin and the title lines.
const PANEL_W: f64 = 420.0;
const PANEL_H: f64 = 300.0;
const MARGIN: f64 = 14.0;
const TITLE_H: f64 = 50.0;

/// Short label for a candidate in panels: its name, shortened to fit.
fn short(name: &str, max: usize) -> String {
    let n: Vec<char> = name.chars().collect();
    if n.len() <= max {
        name.to_owned()
    } else {
        n[..max - 1].iter().collect::<String>() + "…"
    }
}

/// Renders the report's distributions. Metrics the reference lacks get no panel.
pub fn draw(report: &Report) -> Result<Figure> {
    let panels: Vec<_> = report.metrics.iter().filter(|m| m.applicable).collect();
    let cols = panels.len().clamp(1, 3);
    let rows = panels.len().div_ceil(cols).max(1);
    let mut legend = Legend::default();
    legend.add(
        format!("real: {}", report.reference.name),
        Mark::Area {
            fill: palette::LIGHT_GREY.to_rgba(),
            edge: palette::LIGHT_GREY,
        },
    );
    for (i, c) in report.candidates.iter().enumerate() {
        legend.add(c.name.clone(), Mark::Line(palette::series(i).to_rgba()));
    }
    let width = (cols as f64 * PANEL_W).max(900.0);
    let mut legend_h = 0.0;
    Figure::draw(8, 8, |a| {
        legend_h = legend.height(a, width - 2.0 * MARGIN)?;
        Ok(())
    })?;
    let top = TITLE_H + legend_h + 8.0;
    let height = top + rows as f64 * PANEL_H;
    let subtitle = format!(
        "dt = {} s, {} shared bins; end bins hold the tails; spikes over 2.5× the real peak are cut",
        report.settings.dt, report.settings.bins
    );

    Figure::draw(width as u32, height.ceil() as u32, |root| {
        root.draw_text(
            "Flight metrics: real vs simulated",
            &bold(18.0, palette::TEXT),
            (px(MARGIN), px(10.0)),
        )?;
        root.draw_text(
            &subtitle,
            &text(13.0, palette::GREY),
            (px(MARGIN), px(33.0)),
        )?;
        legend.draw(root, MARGIN, TITLE_H, width - 2.0 * MARGIN)?;

        for (n, m) in panels.iter().enumerate() {
            let Some(bins) = m.bins else { continue };
            let (ox, oy) = (
                (n % cols) as f64 * PANEL_W,
                top + (n / cols) as f64 * PANEL_H,
            );
            let area = root
                .margin(px(oy), 0, px(ox), 0)
                .shrink((0, 0), (px(PANEL_W), px(PANEL_H)));
            let edges = bins.edges();
            // The axis fits the reference and candidates, but a candidate's spike (often
            // all its mass in an end bin) may not squash the reference flat: bars taller
            // than 2.5 times the reference's highest are cut at the top of the panel.
            let rmax = m.reference_masses.iter().fold(0.0f64, |a, &b| a.max(b));
            let ymax = m
                .candidates
                .iter()
                .flat_map(|c| c.masses.iter())
                .fold(rmax, |a, &b| a.max(b))
                .min(2.5 * rmax.max(1e-3));
            let ytop = (ymax * 1.08).max(1e-3);
            let mut chart = ChartBuilder::on(&area)
                .caption(m.metric.label(), bold(15.0, palette::TEXT))
                .margin(px(10.0))
                .margin_top(px(4.0))
                .x_label_area_size(px(24.0))
                .y_label_area_size(px(58.0))
                .build_cartesian_2d(bins.lo..bins.hi, 0.0..ytop)?;
            house_axes(&mut chart.configure_mesh(), 12.0)
                .y_desc("probability")
                .x_labels(6)
                .y_labels(5)
                .draw()?;
            chart.draw_series(m.reference_masses.iter().enumerate().map(|(i, &h)| {
                Rectangle::new(
                    [(edges[i], 0.0), (edges[i + 1], h.min(ytop))],
                    palette::LIGHT_GREY.filled(),
                )
            }))?;
            for (i, cand) in m.candidates.iter().enumerate() {
                if cand.l1.is_none() {
                    continue;
                }
                let mut pts = vec![(edges[0], 0.0)];
                for (k, &h) in cand.masses.iter().enumerate() {
                    pts.push((edges[k], h.min(ytop)));
                    pts.push((edges[k + 1], h.min(ytop)));
                }
                pts.push((edges[cand.masses.len()], 0.0));
                chart.draw_series([PathElement::new(
                    pts,
                    palette::series(i).stroke_width(px(1.8) as u32),
                )])?;
            }
            // ΔE per candidate, top right inside the plot area, on a veil so curves
            // under it do not garble the text.
            let plot = chart.plotting_area().strip_coord_spec();
            let (w, _) = plot.dim_in_pixel();
            for (i, cand) in m.candidates.iter().enumerate() {
                let s = match cand.l1 {
                    Some(d) => format!("{} ΔE = {d:.3}", short(&cand.name, 14)),
                    None => format!("{} n/a", short(&cand.name, 14)),
                };
                let style = text(12.5, palette::darken(palette::series(i), 0.15))
                    .pos(Pos::new(HPos::Right, VPos::Top));
                let (tw, _) = plot.estimate_text_size(&s, &style)?;
                let y = px(4.0 + i as f64 * 16.0);
                let right = w as i32 - px(5.0);
                plot.draw(&Rectangle::new(
                    [
                        (right - tw as i32 - px(4.0), y),
                        (right + px(3.0), y + px(16.0)),
                    ],
                    palette::WHITE.mix(0.85).filled(),
                ))?;
                plot.draw_text(&s, &style, (right, y + px(1.5)))?;
            }
        }
        Ok(())
    })
}
