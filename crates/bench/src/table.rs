//! Plain-text tables of a report on stdout.

use crate::json::Report;

/// Prints rows under headers, each column as wide as its widest cell.
pub fn print_table(headers: &[&str], rows: &[Vec<String>]) {
    let mut widths: Vec<usize> = headers.iter().map(|h| h.len()).collect();
    for row in rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.len());
        }
    }
    let line = |cells: Vec<&str>| {
        let padded: Vec<String> = cells
            .iter()
            .zip(&widths)
            .map(|(c, w)| format!("{c:<w$}"))
            .collect();
        println!("{}", padded.join("  ").trim_end());
    };
    line(headers.to_vec());
    line(
        widths
            .iter()
            .map(|&w| &"--------------------------------"[..w.min(32)])
            .collect(),
    );
    for row in rows {
        line(row.iter().map(String::as_str).collect());
    }
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
