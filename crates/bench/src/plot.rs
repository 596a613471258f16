//! SVG plots (`--plots DIR`): one per scene and pair of measures, time across, error or
//! quality up, every method and setting a labelled point, the Pareto front joined in red.

use crate::json::{Point, Report};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

/// Draws every plot of a report into `dir` (created if needed), one SVG file each, named
/// after the suite, scene and quality measure.
pub fn draw_report(report: &Report, dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
    let mut plots: BTreeMap<(String, String, String), Vec<&Point>> = BTreeMap::new();
    for p in report.points.iter().filter(|p| p.quality.is_some()) {
        plots
            .entry((p.scene.clone(), p.time_name.clone(), p.quality_name.clone()))
            .or_default()
            .push(p);
    }
    for ((scene, time_name, quality_name), points) in &plots {
        let name = format!("{}_{}_{}.svg", report.suite, scene, quality_name);
        let path = dir.join(file_name(&name));
        let root = SVGBackend::new(&path, (900, 640)).into_drawing_area();
        let title = format!("{}: {scene}", report.suite);
        draw(&root, &title, time_name, quality_name, points).map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Letters, digits, `-`, `_` and `.` only.
fn file_name(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// An axis range around `values`, and whether to draw it on a log scale (all positive and
/// spread over more than a factor of 20).
fn axis(values: impl Iterator<Item = f64>) -> (f64, f64, bool) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (0.0, 1.0, false);
    }
    if lo > 0.0 && hi / lo > 20.0 {
        return (lo / 1.5, hi * 1.5, true);
    }
    let pad = ((hi - lo) * 0.08).max(hi.abs() * 0.05).max(1e-12);
    (
        (lo - pad).min(if lo >= 0.0 { 0.0 } else { lo - pad }),
        hi + pad,
        false,
    )
}

fn draw(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    title: &str,
    time_name: &str,
    quality_name: &str,
    points: &[&Point],
) -> Result<(), Box<dyn std::error::Error>> {
    root.fill(&WHITE)?;
    let xy: Vec<(f64, f64)> = points
        .iter()
        .map(|p| (p.time, p.quality.unwrap_or(f64::NAN)))
        .collect();
    let (x0, x1, xlog) = axis(xy.iter().map(|p| p.0));
    let (y0, y1, ylog) = axis(xy.iter().map(|p| p.1));
    let mut front: Vec<(f64, f64)> = points
        .iter()
        .zip(&xy)
        .filter(|(p, _)| p.pareto)
        .map(|(_, &xy)| xy)
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The four axis kinds are four chart types; one macro body draws them all.
    macro_rules! chart {
        ($x:expr, $y:expr) => {{
            let mut chart = ChartBuilder::on(root)
                .caption(title, ("sans-serif", 22))
                .margin(16)
                .x_label_area_size(44)
                .y_label_area_size(70)
                .build_cartesian_2d($x, $y)?;
            chart
                .configure_mesh()
                .x_desc(time_name)
                .y_desc(format!("{quality_name} (lower is better)"))
                // Log axes put labels at values like 0.30000000000000004: three significant
                // digits are all a reader wants, and fewer labels keep them apart.
                .x_labels(8)
                .x_label_formatter(&|v| format!("{:.3}", *v as f64))
                .y_label_formatter(&|v| format!("{:.3}", *v as f64))
                .draw()?;
            chart.draw_series(LineSeries::new(front.iter().copied(), RED.stroke_width(2)))?;
            chart.draw_series(points.iter().zip(&xy).map(|(p, &(x, y))| {
                let style = if p.pareto {
                    RED.filled()
                } else {
                    BLUE.mix(0.7).filled()
                };
                EmptyElement::at((x, y))
                    + Circle::new((0, 0), 4, style)
                    + Text::new(
                        format!("{} {}", p.method, p.setting),
                        (6, -6),
                        ("sans-serif", 11).into_font(),
                    )
            }))?;
        }};
    }
    match (xlog, ylog) {
        (false, false) => chart!(x0..x1, y0..y1),
        (true, false) => chart!((x0..x1).log_scale(), y0..y1),
        (false, true) => chart!(x0..x1, (y0..y1).log_scale()),
        (true, true) => chart!((x0..x1).log_scale(), (y0..y1).log_scale()),
    }
    Ok(())
}
