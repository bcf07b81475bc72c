//! The outputs of `wsm study accuracy`: a Markdown report (references with observed orders, the
//! error table, time to 1 % and 0.1 %), a CSV table with every measured value and error, and
//! the log-log plot of error against solve time.

use std::fmt::Write;

use super::accuracy::{AccuracyStudy, Reference, Row, TARGETS};
use super::plot::{svg, Panel, Series};
use wsm_core::WsmError;

/// The quantities shown in tables and plots (the potential and strain energy feed `energy`).
fn shown(study: &AccuracyStudy) -> Vec<usize> {
    (0..study.quantities.len())
        .filter(|&k| !matches!(study.quantities[k].name.as_str(), "J" | "a(u,u)"))
        .collect()
}

/// `1.23e-4`, or `—` for a missing value.
fn sci(v: Option<f64>) -> String {
    v.map_or("—".into(), |x| format!("{x:.2e}"))
}

/// The column heading of a quantity.
fn heading(name: &str) -> String {
    match name {
        "phi1" | "phi2" | "phi3" | "phi4" | "phi5" | "phi6" => format!("Φ{}", &name[3..]),
        "L2" => "L²".into(),
        "half_width" => "a (half-width)".into(),
        "peak_pressure" => "p0 (peak pressure)".into(),
        other => other.into(),
    }
}

fn iterations(row: &Row) -> String {
    match &row.dd {
        Some(d) => format!(
            "{} / {} / {}{}",
            d.pcg1,
            d.outer,
            d.pcg2,
            if row.fallback { " (fallback)" } else { "" }
        ),
        None => format!("QP {}", row.qp_iterations),
    }
}

fn describe(reference: &Reference) -> (String, String, String) {
    match reference {
        Reference::Analytic { value } => ("analytic".into(), format!("{value:.6e}"), String::new()),
        Reference::Richardson(e) => (
            "Richardson".into(),
            format!("{:.6e}", e.value),
            format!(
                "fitted order {}, scatter {:.1e}, uncertainty {}{}",
                e.order.map_or("—".into(), |p| format!("{p:.2}")),
                e.scatter,
                sci(e.uncertainty),
                if e.monotone { "" } else { ", not monotone" }
            ) + if e.at_bound {
                ", order at the end of the fitted range: unreliable"
            } else {
                ""
            },
        ),
        Reference::ExactField => ("exact field".into(), "—".into(), String::new()),
        Reference::PotentialEnergy { j_star, .. } => (
            "extrapolated J".into(),
            format!("J* = {:.6e}", j_star.value),
            format!(
                "fitted order of J {}, scatter {:.1e}, uncertainty of J {}",
                j_star.order.map_or("—".into(), |p| format!("{p:.2}")),
                j_star.scatter,
                sci(j_star.uncertainty)
            ),
        ),
        Reference::None => ("none".into(), "—".into(), "too few levels".into()),
    }
}

/// The Markdown report; `command` is the command line that made it.
pub fn markdown(study: &AccuracyStudy, command: &str) -> String {
    let cols = shown(study);
    let mut out = String::new();
    let _ = writeln!(out, "### Accuracy against run time: {}\n", study.case);
    let _ = writeln!(out, "Made by `{command}`.\n");
    let _ = writeln!(
        out,
        "Mesh sizes × {:.3} · {:.4}^−k (level k); {} thread(s); solve time = median of {} cold solves (no warm start), meshing and set-up apart.\n",
        study.ladder_coarsest, study.ladder_ratio, study.threads, study.repeats
    );
    out.push_str("| quantity | reference | value | observed order of the error | note |\n|---|---|---|---|---|\n");
    for &k in &cols {
        let q = &study.quantities[k];
        let (kind, value, note) = describe(&q.reference);
        let _ = writeln!(
            out,
            "| {} | {kind} | {value} | {} | {note} |",
            heading(&q.name),
            q.observed_order.map_or("—".into(), |p| format!("{p:.2}"))
        );
    }
    out.push_str(
        "\nRelative errors:\n\n| level | unknowns | solver | setup [s] | solve [s] | iterations |",
    );
    for &k in &cols {
        let _ = write!(out, " {} |", heading(&study.quantities[k].name));
    }
    out.push_str("\n|---|---|---|---|---|---|");
    out.push_str(&"---|".repeat(cols.len()));
    out.push('\n');
    for row in &study.rows {
        let _ = write!(
            out,
            "| {} | {} | {} | {:.3} | {:.4} | {} |",
            row.level,
            row.unknowns,
            row.solver,
            row.setup_seconds,
            row.solve_seconds,
            iterations(row)
        );
        for &k in &cols {
            let cell = match &row.failure {
                Some(_) => "failed".into(),
                None => sci(row.errors[k]),
            };
            let _ = write!(out, " {cell} |");
        }
        out.push('\n');
    }
    let failures: Vec<String> = study
        .rows
        .iter()
        .filter_map(|r| {
            r.failure
                .as_ref()
                .map(|f| format!("level {} {}: {f}", r.level, r.solver))
        })
        .collect();
    if !failures.is_empty() {
        let _ = writeln!(out, "\nFailed solves: {}", failures.join("; "));
    }
    out.push_str("\nSolve time to reach an accuracy (the coarsest level from which on every level meets it; a target below the reference's uncertainty cannot be confirmed by the sequence):\n\n| quantity | solver |");
    for t in TARGETS {
        let _ = write!(out, " {} % |", t * 100.0);
    }
    out.push_str("\n|---|---|");
    out.push_str(&"---|".repeat(TARGETS.len()));
    out.push('\n');
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for t in &study.time_to_accuracy {
        if !keys.contains(&(t.quantity.as_str(), t.solver.as_str())) {
            keys.push((t.quantity.as_str(), t.solver.as_str()));
        }
    }
    for (quantity, solver) in keys {
        let _ = write!(out, "| {} | {solver} |", heading(quantity));
        for target in TARGETS {
            let cell = study
                .time_to_accuracy
                .iter()
                .find(|t| t.quantity == quantity && t.solver == solver && t.target == target)
                .map_or("—".into(), |t| {
                    let cell = match (t.solve_seconds, t.unknowns) {
                        (Some(s), Some(n)) => format!("{s:.4} s ({n} unknowns)"),
                        _ => format!("not reached (best {})", sci(t.error)),
                    };
                    if t.resolved {
                        cell
                    } else {
                        format!("{cell}, below the reference uncertainty")
                    }
                });
            let _ = write!(out, " {cell} |");
        }
        out.push('\n');
    }
    out
}

/// The CSV table: one row per level and solver, every value and error.
pub fn csv(study: &AccuracyStudy) -> Result<String, WsmError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header: Vec<String> = [
        "level",
        "size_factor",
        "unknowns",
        "triangles",
        "solver",
        "tolerance",
        "setup_seconds",
        "solve_seconds",
        "qp_iterations",
        "pcg1",
        "outer",
        "pcg2",
        "fallback",
    ]
    .map(String::from)
    .to_vec();
    for q in &study.quantities {
        header.push(format!("value_{}", q.name));
    }
    for q in &study.quantities {
        header.push(format!("error_{}", q.name));
    }
    header.push("failure".into());
    let io = |e: csv::Error| WsmError::io("CSV table", e);
    w.write_record(&header).map_err(io)?;
    let num = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:e}"));
    for r in &study.rows {
        let mut cells = vec![
            r.level.to_string(),
            r.size_factor.to_string(),
            r.unknowns.to_string(),
            r.triangles.to_string(),
            r.solver.clone(),
            num(r.tolerance),
            r.setup_seconds.to_string(),
            r.solve_seconds.to_string(),
            r.qp_iterations.to_string(),
        ];
        cells.extend(match &r.dd {
            Some(d) => [d.pcg1, d.outer, d.pcg2].map(|n| n.to_string()),
            None => [String::new(), String::new(), String::new()],
        });
        cells.push(r.fallback.to_string());
        cells.extend(r.values.iter().map(|v| num(*v)));
        cells.extend(r.errors.iter().map(|v| num(*v)));
        cells.push(r.failure.clone().unwrap_or_default());
        w.write_record(&cells).map_err(io)?;
    }
    let bytes = w.into_inner().map_err(|e| WsmError::io("CSV table", e))?;
    String::from_utf8(bytes).map_err(|e| WsmError::io("CSV table", e))
}

/// The log-log plot of relative error against solve time, one panel per quantity, one line per
/// solver (points = mesh levels).
pub fn plot(study: &AccuracyStudy) -> String {
    let mut solvers: Vec<&str> = Vec::new();
    for r in &study.rows {
        if !solvers.contains(&r.solver.as_str()) {
            solvers.push(&r.solver);
        }
    }
    let panels: Vec<Panel> = shown(study)
        .into_iter()
        .map(|k| Panel {
            title: heading(&study.quantities[k].name),
            x_label: "solve time [s]".into(),
            y_label: "relative error".into(),
            series: solvers
                .iter()
                .map(|s| Series {
                    label: s.to_string(),
                    points: study
                        .rows
                        .iter()
                        .filter(|r| r.solver == *s)
                        .filter_map(|r| r.errors[k].map(|e| (r.solve_seconds, e)))
                        .collect(),
                })
                .collect(),
            lines: vec![(1e-2, "1 %".into()), (1e-3, "0.1 %".into())],
        })
        .collect();
    svg(
        &format!("{}: error against solve time", study.case),
        &panels,
        3,
    )
}
