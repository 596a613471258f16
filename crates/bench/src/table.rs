//! Plain-text tables of a report on stdout.

use crate::json::Report;
use comfy_table::{ContentArrangement, ContentLineStyle, LineStyle, Table, TableStyle};

/// No borders: a space of padding after each cell and a blank junction put the columns two
/// spaces apart; dashes under the headers.
const PLAIN: TableStyle = TableStyle::new()
    .header_lines(ContentLineStyle::none().junction(' '))
    .header_separator(LineStyle::none().fill('-').junction(' '))
    .content_lines(ContentLineStyle::none().junction(' '));

/// Prints rows under headers, each column as wide as its widest cell.
pub fn print_table(headers: &[&str], rows: &[Vec<String>]) {
    let mut table = Table::new();
    table
        .load_style(PLAIN)
        .set_content_arrangement(ContentArrangement::Disabled)
        .set_header(headers.to_vec())
        .add_rows(rows.iter().cloned());
    for column in table.column_iter_mut() {
        column.set_padding((0, 1));
    }
    println!("{}", table.trim_fmt());
}

/// A number in a few significant digits.
pub fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        format!("{x}")
    } else if x.abs() >= 1e5 || x.abs() < 1e-3 {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}

/// Prints a suite's points (grouped by plot), its Markdown table, notes and stress rows.
pub fn print_report(report: &Report) {
    println!("\n== {} ({:.1} s)", report.suite, report.seconds);
    if !report.points.is_empty() {
        let rows: Vec<Vec<String>> = report
            .points
            .iter()
            .map(|p| {
                vec![
                    p.scene.clone(),
                    p.method.clone(),
                    p.setting.clone(),
                    format!("{} {}", num(p.time), p.time_name),
                    match p.quality {
                        Some(q) => format!("{} {}", num(q), p.quality_name),
                        None => format!("- {}", p.quality_name),
                    },
                    if p.pareto { "*".into() } else { String::new() },
                ]
            })
            .collect();
        print_table(
            &[
                "scene",
                "method",
                "setting",
                "time",
                "error/quality",
                "front",
            ],
            &rows,
        );
    }
    if !report.markdown.is_empty() {
        println!();
        for line in &report.markdown {
            println!("{line}");
        }
        println!();
    }
    for note in &report.notes {
        println!("  {note}");
    }
    if !report.stress.is_empty() {
        let rows: Vec<Vec<String>> = report
            .stress
            .iter()
            .map(|r| {
                vec![
                    r.structure.clone(),
                    r.query.clone(),
                    r.cases.to_string(),
                    r.misses.to_string(),
                    r.leaks.to_string(),
                    r.panics.to_string(),
                    r.nans.to_string(),
                ]
            })
            .collect();
        print_table(
            &[
                "structure",
                "query",
                "cases",
                "misses",
                "leaks",
                "panics",
                "nans",
            ],
            &rows,
        );
        let cases: u64 = report.stress.iter().map(|r| r.cases).sum();
        println!("total: {cases} cases, {} failures", report.failures());
        for s in &report.failure_samples {
            println!("  failure: {s}");
        }
    }
}
