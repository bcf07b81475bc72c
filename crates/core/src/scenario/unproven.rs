//! Plain-words warnings for the extrema a search did not prove (design §4.3): an objective whose
//! search stopped before optimality — budget exhausted, stagnation, time limit, cancel, failed
//! evaluations next to its best point, or a converged polish that the exact derivatives do not
//! certify, or a kink of Φ next to the best point (where no first-order proof exists) — says
//! that its worst value may be higher (its best value lower), which of its data
//! ended inside their intervals and what to do. A `locally_certified` extremum needs no such
//! warning: the derivatives prove first-order optimality there (see
//! [`wsm_search::Certificate`]). What the local proofs leave open is said from the global
//! evidence ([`wsm_search::GlobalEvidence`]): the global rule not met, a runner-up local optimum
//! within a few percent, or a search that could not look (no derivatives, `first_certificate`).

use crate::scenario::worst::{CriterionOutcome, WorstOutcome};
use crate::scene::{Warning, WarningKind};
use wsm_search::{ActiveBound, ObjectiveResult, Sense, Status, StopRule, Verdict, CLOSE_RUNNER_UP};

/// One warning per extremum the search did not settle, worst before best, in criterion order,
/// then what the global evidence leaves open: a run-level warning when no global rule could
/// apply (no derivatives, or `stop: first_certificate`), else one per extremum whose rule was
/// not met or that has a runner-up local optimum within [`CLOSE_RUNNER_UP`] of it.
pub fn warnings(outcome: &WorstOutcome) -> Vec<Warning> {
    let names: Vec<&str> = outcome.parameters.iter().map(|p| p.name.as_str()).collect();
    let extrema: Vec<(String, &str, &str, &ObjectiveResult)> = outcome
        .criteria
        .iter()
        .flat_map(|c: &CriterionOutcome| {
            let symbol = c.criterion.symbol().to_string();
            [
                (symbol.clone(), "worst", "higher", &c.worst),
                (symbol, "best", "lower", &c.best),
            ]
        })
        .collect();
    let mut warnings: Vec<Warning> = extrema
        .iter()
        .filter_map(|(symbol, which, direction, o)| {
            warning(symbol, which, direction, o, &names, outcome.budget)
        })
        .collect();
    let found: Vec<&(String, &str, &str, &ObjectiveResult)> =
        extrema.iter().filter(|e| e.3.value.is_some()).collect();
    let Some(first) = found.first() else {
        return warnings;
    };
    let unproven_locally = first.3.certificate.is_none()
        || first
            .3
            .certificate
            .as_ref()
            .is_some_and(|c| c.verdict == Verdict::NoDerivatives);
    if unproven_locally {
        warnings.push(Warning::new(
            WarningKind::Unproven,
            "",
            "searched without derivatives: no extremum is proven, locally or globally; each is \
             the most extreme of the points evaluated (search with derivatives for local proofs \
             and the global rule)",
        ));
        return warnings;
    }
    if first.3.global.stop == StopRule::FirstCertificate {
        warnings.push(Warning::new(
            WarningKind::Unproven,
            "search.stop",
            "first_certificate: every extremum stopped at its first local proof, and no search \
             looked for other local optima, so a more extreme value elsewhere in the box is \
             possible; use the default stop (global_rule) to look",
        ));
    } else {
        warnings.extend(
            found
                .iter()
                .filter_map(|(symbol, which, _, o)| global_warning(symbol, which, o, &names)),
        );
    }
    warnings
}

/// The global evidence of one extremum in words, when it leaves something open: its rule not
/// met, or a runner-up local optimum within [`CLOSE_RUNNER_UP`].
fn global_warning(
    symbol: &str,
    which: &str,
    o: &ObjectiveResult,
    names: &[&str],
) -> Option<Warning> {
    let g = &o.global;
    let kind = match o.sense {
        Sense::Max => "maximum",
        Sense::Min => "minimum",
    };
    let close = g
        .runner_up
        .as_ref()
        .filter(|r| r.gap <= CLOSE_RUNNER_UP)
        .map(|r| {
            let at: Vec<String> = names
                .iter()
                .zip(&r.point)
                .map(|(n, v)| format!("{n} = {v:.6e}"))
                .collect();
            format!(
                "another local {kind}, {:.6e} at ({}), is within {} of it: the criterion is not \
             monotone over the box, and a small change of the model could make that one the \
             {which}",
                r.value,
                at.join(", "),
                percent(r.gap)
            )
        });
    let open = (!g.rule_met).then(|| {
        format!(
            "the global rule was not met ({}), so a more extreme local {kind} may exist; raise \
             the budget (settings.budget, --budget) to look further",
            g.summary
                .split_once(": ")
                .map_or(g.summary.as_str(), |(_, evidence)| evidence)
        )
    });
    let parts: Vec<String> = [close, open].into_iter().flatten().collect();
    (!parts.is_empty()).then(|| {
        Warning::new(
            WarningKind::Unproven,
            format!("{symbol} {which}"),
            format!("{}.", parts.join("; ")),
        )
    })
}

fn warning(
    symbol: &str,
    which: &str,
    direction: &str,
    o: &ObjectiveResult,
    names: &[&str],
    budget: usize,
) -> Option<Warning> {
    let kink = o.certificate.as_ref().and_then(|c| c.kink).filter(|_| {
        matches!(
            o.status,
            Status::BudgetExhausted | Status::Stagnated | Status::Completed
        )
    });
    let (reason, advice) = match (o.status, kink) {
        (Status::LocallyCertified, _) => return None,
        (_, Some(k)) => (
            format!(
                "{symbol} has a kink next to it: its derivative along {} changes sign between the reported point and an evaluated point {:.1e} of that interval away (relative rates {:+.1e} and {:+.1e}; e.g. a contact pair switching between stick and slip), so no first-order proof exists there",
                names.get(k.parameter).copied().unwrap_or("a datum"),
                k.distance,
                k.rates[0],
                k.rates[1]
            ),
            "a local extremum along that datum lies between the two points, which a larger budget cannot prove (it may still find a better basin elsewhere)",
        ),
        (Status::Completed, _) => match &o.certificate {
            Some(c) if c.verdict == Verdict::NotOptimal => (
                format!(
                    "its polish converged but the exact derivatives do not prove optimality (relative residual {:.1e})",
                    c.residual.unwrap_or(f64::NAN)
                ),
                "the criterion may have a kink there; raise the budget or try another seed",
            ),
            _ => return None,
        },
        (Status::BudgetExhausted, _) => (
            format!("the budget of {budget} solves ran out before its polish converged"),
            "raise the budget (settings.budget, --budget) or narrow the intervals",
        ),
        (Status::Stagnated, _) => (
            "its polish stopped improving without converging".to_string(),
            "raise the budget or try another seed",
        ),
        (Status::TimeLimit, _) => (
            "the time limit stopped it".to_string(),
            "raise the time limit (settings.max_seconds, --max-seconds)",
        ),
        (Status::Cancelled, _) => ("the run was cancelled".to_string(), "run it to its end"),
        (Status::Unsettled, _) => (
            "failed evaluations lie next to its best point".to_string(),
            "see the failures: the extremum may be where the solver gave no answer",
        ),
    };
    let Some(value) = o.value else {
        return Some(Warning::new(
            WarningKind::Unproven,
            format!("{symbol} {which}"),
            format!("no value — no evaluation gave one ({reason}); {advice}."),
        ));
    };
    let inside: Vec<&str> = names
        .iter()
        .zip(&o.active_bounds)
        .filter(|(_, bound)| **bound == ActiveBound::None)
        .map(|(name, _)| *name)
        .collect();
    let place = if inside.is_empty() {
        "its data at a vertex of the box".to_string()
    } else {
        format!(
            "{} of {} uncertain data inside their intervals ({})",
            inside.len(),
            names.len(),
            inside.join(", ")
        )
    };
    Some(Warning::new(
        WarningKind::Unproven,
        format!("{symbol} {which}"),
        format!(
            "may be {direction} than the reported {value:.6e}: the search stopped before optimality — {reason}, with {place}; {advice}."
        ),
    ))
}

/// A small relative gap in percent, readable at any size: `2.5 %`, `3.2e-3 %`.
fn percent(gap: f64) -> String {
    let p = 100.0 * gap;
    if p >= 0.1 {
        format!("{p:.1} %")
    } else {
        format!("{p:.1e} %")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn objective(status: Status, bounds: Vec<ActiveBound>) -> ObjectiveResult {
        ObjectiveResult {
            value: Some(2.5e-3),
            point: Some(vec![0.0; bounds.len()]),
            active_bounds: bounds,
            ..ObjectiveResult::empty(0, wsm_search::Sense::Max, status, 2)
        }
    }

    #[test]
    fn a_kink_next_to_the_best_point_is_named_with_the_datum() {
        let mut o = objective(
            Status::BudgetExhausted,
            vec![ActiveBound::None, ActiveBound::Lower],
        );
        o.certificate = Some(wsm_search::Certificate {
            verdict: Verdict::NotOptimal,
            residual: Some(3e-3),
            active: Vec::new(),
            starts: 1,
            kink: Some(wsm_search::Kink {
                parameter: 0,
                distance: 0.04,
                rates: [3e-3, -2e-2],
            }),
        });
        let w = warning("Φ5", "best", "lower", &o, &["F", "E"], 150)
            .unwrap()
            .to_string();
        assert!(w.starts_with("Φ5 best: may be lower"), "{w}");
        assert!(
            w.contains("Φ5 has a kink next to it: its derivative along F changes sign")
                && w.contains("4.0e-2 of that interval")
                && w.contains("which a larger budget cannot prove"),
            "{w}"
        );
    }

    #[test]
    fn an_unconverged_extremum_says_so_and_names_its_interior_data() {
        let o = objective(
            Status::BudgetExhausted,
            vec![ActiveBound::Upper, ActiveBound::None],
        );
        let w = warning("Φ5", "worst", "higher", &o, &["E", "g"], 400)
            .unwrap()
            .to_string();
        assert!(
            w.starts_with("Φ5 worst: may be higher than the reported 2.500000e-3"),
            "{w}"
        );
        assert!(
            w.contains("budget of 400 solves")
                && w.contains("1 of 2 uncertain data inside their intervals (g)"),
            "{w}"
        );
        assert!(w.contains("raise the budget"), "{w}");
    }

    #[test]
    fn a_converged_extremum_has_no_warning() {
        let o = objective(
            Status::Completed,
            vec![ActiveBound::Upper, ActiveBound::Lower],
        );
        assert_eq!(warning("Φ3", "best", "lower", &o, &["E", "g"], 400), None);
    }
}
