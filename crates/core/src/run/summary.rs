//! The human summary of a worst-scenario outcome (design §5.1): per criterion what it measures,
//! its worst and best value, the data that make each, and the two levels of proof — the local
//! certificate and the global evidence — in plain words, then the warnings. `wsm worst` prints it
//! on stderr beside the JSON on stdout.

use std::fmt::Write;

use crate::scenario::worst::WorstOutcome;
use crate::scene::{Criterion, DefinedCriterion};
use wsm_search::{ActiveBound, ObjectiveResult, Sense, Verdict};

/// The summary as lines of text; `defined` are the scene's defined criteria (their units and
/// what they measure).
pub fn summary(outcome: &WorstOutcome, defined: &[DefinedCriterion]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: {} of {} solves, status {}",
        outcome.scene,
        outcome.evaluations,
        outcome.budget,
        serde_json::to_value(outcome.status)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default()
    );
    let names: Vec<&str> = outcome.parameters.iter().map(|p| p.name.as_str()).collect();
    for c in &outcome.criteria {
        let kind = c.criterion.criterion;
        let quantity = (kind == Criterion::Defined)
            .then(|| {
                defined
                    .iter()
                    .find(|d| Some(&d.name) == c.criterion.region.as_ref())
            })
            .flatten()
            .map(|d| d.quantity);
        let (unit, definition) = quantity.map_or((kind.unit(), kind.definition()), |q| {
            (q.unit(), q.definition())
        });
        let over = match (&c.criterion.region, kind) {
            (Some(_), Criterion::Defined) => format!("'{}'", c.criterion.name()),
            (Some(region), _) => format!("bound to '{region}'"),
            (None, _) => "the largest over its regions".to_string(),
        };
        let _ = writeln!(
            out,
            "{} [{unit}]: {definition}, {over}",
            c.criterion.symbol()
        );
        for (which, o) in [("worst", &c.worst), ("best", &c.best)] {
            extremum(&mut out, kind, unit, which, o, &names);
        }
    }
    for w in &outcome.warnings {
        let _ = writeln!(out, "warning: {w}");
    }
    out
}

fn extremum(
    out: &mut String,
    criterion: Criterion,
    unit: &str,
    which: &str,
    o: &ObjectiveResult,
    names: &[&str],
) {
    let Some(value) = o.value else {
        let _ = writeln!(out, "  {which}: no value (no evaluation gave one)");
        return;
    };
    let equivalent = match criterion {
        Criterion::Phi5 if value >= 0.0 => format!(" (√Φ5 = {:.4e} Pa)", value.sqrt()),
        _ => String::new(),
    };
    let region = o
        .region
        .as_ref()
        .map_or(String::new(), |r| format!(" in '{r}'"));
    let _ = writeln!(out, "  {which} {value:.6e} {unit}{equivalent}{region}");
    let data: Vec<String> = names
        .iter()
        .zip(o.point.iter().flatten())
        .zip(&o.active_bounds)
        .map(|((n, v), bound)| {
            let place = match bound {
                ActiveBound::Lower => " (lower end)",
                ActiveBound::Upper => " (upper end)",
                ActiveBound::None => " (inside)",
                ActiveBound::Fixed => "",
            };
            format!("{n} = {v:.6e}{place}")
        })
        .collect();
    if !data.is_empty() {
        let _ = writeln!(out, "    data: {}", data.join(", "));
    }
    let local = match o.certificate.as_ref().map(|c| c.verdict) {
        Some(Verdict::LocallyCertified) => {
            "locally certified (the exact derivatives prove first-order optimality here)"
        }
        Some(Verdict::NotOptimal) => "not proven: the derivatives show a direction to improve",
        Some(Verdict::NoDerivatives) | None => "none (no derivatives)",
    };
    let _ = writeln!(out, "    local proof: {local}");
    let _ = writeln!(out, "    {}", o.global.summary);
    if let Some(r) = &o.global.runner_up {
        let kind = match o.sense {
            Sense::Max => "maximum",
            Sense::Min => "minimum",
        };
        let _ = writeln!(
            out,
            "    runner-up local {kind}: {:.6e} {unit} ({:.2e} relative, less extreme)",
            r.value, r.gap
        );
    }
}
