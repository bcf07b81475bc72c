//! Plain-words warnings for the extrema a search did not prove (issue #24): an objective whose
//! search stopped before optimality — budget exhausted, stagnation, time limit, cancel, failed
//! evaluations next to its best point, or a converged polish that the exact derivatives do not
//! certify, or a kink of Φ next to the best point (where no first-order proof exists) — says
//! that its worst value may be higher (its best value lower), which of its data
//! ended inside their intervals and what to do. A `certified` extremum needs no warning: the
//! derivatives prove first-order optimality there (a local statement, like any converged
//! search; see [`wsm_search::Certificate`]). Without derivatives (turned off), a converged
//! polish is not warned about either: nothing could prove it.

use crate::scenario::worst::{CriterionOutcome, WorstOutcome};
use wsm_search::{ActiveBound, ObjectiveResult, Status, Verdict};

/// One warning per extremum the search did not settle, worst before best, in criterion order.
pub fn warnings(outcome: &WorstOutcome) -> Vec<String> {
    let names: Vec<&str> = outcome.parameters.iter().map(|p| p.name.as_str()).collect();
    outcome
        .criteria
        .iter()
        .flat_map(|c: &CriterionOutcome| {
            [("worst", "higher", &c.worst), ("best", "lower", &c.best)]
                .map(|(which, direction, o)| (c, which, direction, o))
        })
        .filter_map(|(c, which, direction, o)| {
            warning(
                &c.criterion.symbol(),
                which,
                direction,
                o,
                &names,
                outcome.budget,
            )
        })
        .collect()
}

fn warning(
    symbol: &str,
    which: &str,
    direction: &str,
    o: &ObjectiveResult,
    names: &[&str],
    budget: usize,
) -> Option<String> {
    let kink = o.certificate.as_ref().and_then(|c| c.kink).filter(|_| {
        matches!(
            o.status,
            Status::BudgetExhausted | Status::Stagnated | Status::Completed
        )
    });
    let (reason, advice) = match (o.status, kink) {
        (Status::Certified, _) => return None,
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
    let Some(value) = o.best_value else {
        return Some(format!(
            "{symbol} {which}: no value — no evaluation gave one ({reason}); {advice}."
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
    Some(format!(
        "{symbol} {which} may be {direction} than the reported {value:.6e}: the search stopped before optimality — {reason}, with {place}; {advice}."
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn objective(status: Status, bounds: Vec<ActiveBound>) -> ObjectiveResult {
        ObjectiveResult {
            best_value: Some(2.5e-3),
            best_point: Some(vec![0.0; bounds.len()]),
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
        let w = warning("Φ5", "best", "lower", &o, &["F", "E"], 150).unwrap();
        assert!(w.starts_with("Φ5 best may be lower"), "{w}");
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
        let w = warning("Φ5", "worst", "higher", &o, &["E", "g"], 400).unwrap();
        assert!(
            w.starts_with("Φ5 worst may be higher than the reported 2.500000e-3"),
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
