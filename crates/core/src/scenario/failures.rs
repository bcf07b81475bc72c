//! Failed evaluations as part of a run's answer (design §4.3): which points of the box have no
//! state solution, the part of the box they cover, the plain warning of the result, and the
//! objectives they keep from being settled.
//!
//! A failed point is infeasible for the search (it is never optimal), so an extremum next to
//! failures may be an artefact of where the solver could not answer: an objective whose best point
//! has a failed evaluation within the search's resolution — the spacing `B^(−1/n)` that a budget of
//! `B` evaluations resolves in `n` parameters, in the unit box's ∞-norm — is reported
//! [`Status::Unsettled`]. A run in which more than half of the evaluations failed answers nothing
//! useful; it ends with [`WsmError::EvaluationsFailed`] (the log keeps every evaluation).

use serde::{Deserialize, Serialize};

use crate::error::WsmError;
use crate::scene::{Warning, WarningKind};
use wsm_search::{EvalCache, ObjectiveResult, Status};

/// How many failed evaluations a result lists (the count and the region cover all of them).
const LISTED: usize = 50;

/// One evaluation without a state solution.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct FailedEvaluation {
    /// Physical parameter values, aligned with the result's `parameters`.
    pub point: Vec<f64>,
    /// The inner solver's error.
    pub error: String,
}

/// The failed evaluations of a run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct FailureSummary {
    /// How many of the run's evaluations failed.
    pub count: usize,
    /// Per parameter, `[smallest, largest]` value among the failed points: the part of the box
    /// they cover (empty when none failed).
    pub region: Vec<[f64; 2]>,
    /// The first failed evaluations (at most 50), in evaluation order.
    pub listed: Vec<FailedEvaluation>,
}

impl FailureSummary {
    /// The failures among the cached outcomes (replayed and new alike).
    pub fn from_cache(cache: &EvalCache) -> FailureSummary {
        let mut summary = FailureSummary::default();
        for (point, outcome) in cache.iter() {
            let Err(error) = outcome else { continue };
            summary.count += 1;
            if summary.region.is_empty() {
                summary.region = point.iter().map(|&x| [x, x]).collect();
            }
            for (r, &x) in summary.region.iter_mut().zip(point) {
                *r = [r[0].min(x), r[1].max(x)];
            }
            if summary.listed.len() < LISTED {
                summary.listed.push(FailedEvaluation {
                    point: point.to_vec(),
                    error: error.clone(),
                });
            }
        }
        summary
    }

    /// Mark the objectives (each criterion's worst and best) whose best point has a failure
    /// within the search's resolution: every failed point of `cache` counts, not only the
    /// listed ones.
    pub fn unsettle<'a>(
        cache: &EvalCache,
        objectives: impl IntoIterator<Item = &'a mut ObjectiveResult>,
        bounds: &[[f64; 2]],
        budget: usize,
    ) {
        if bounds.is_empty() {
            return;
        }
        let failed: Vec<&[f64]> = cache
            .iter()
            .filter(|(_, outcome)| outcome.is_err())
            .map(|(point, _)| point)
            .collect();
        if failed.is_empty() {
            return;
        }
        let resolution = (budget.max(1) as f64).powf(-1.0 / bounds.len() as f64);
        for objective in objectives {
            if near(&failed, objective, bounds, resolution) {
                objective.status = Status::Unsettled;
            }
        }
    }

    /// The plain warning of a result with failures (none without).
    pub fn warning(&self, evaluations: usize, names: &[String]) -> Option<Warning> {
        let first = self.listed.first()?;
        let region: Vec<String> = names
            .iter()
            .zip(&self.region)
            .filter(|(_, r)| r[0] < r[1])
            .map(|(name, r)| format!("{name} in [{}, {}]", r[0], r[1]))
            .collect();
        let region = if region.is_empty() {
            "a single point".to_string()
        } else {
            region.join(", ")
        };
        Some(Warning::new(
            WarningKind::FailedEvaluations,
            "",
            format!(
                "{} of {evaluations} evaluations failed, covering {region}; the worst or best may lie where the solver gave no answer (objectives with a failure next to their best point are marked unsettled). First error: {}",
                self.count, first.error
            ),
        ))
    }

    /// [`WsmError::EvaluationsFailed`] when more than half of the evaluations failed.
    pub fn check_majority(&self, evaluations: usize) -> Result<(), WsmError> {
        match self.listed.first() {
            Some(first) if 2 * self.count > evaluations => Err(WsmError::EvaluationsFailed {
                failed: self.count,
                evaluations,
                first: first.error.clone(),
            }),
            _ => Ok(()),
        }
    }
}

/// Whether a failed point lies within `resolution` (unit box, ∞-norm) of the objective's best
/// point.
fn near(
    failed: &[&[f64]],
    objective: &ObjectiveResult,
    bounds: &[[f64; 2]],
    resolution: f64,
) -> bool {
    let Some(best) = &objective.point else {
        return false;
    };
    failed.iter().any(|point| {
        point
            .iter()
            .zip(best)
            .zip(bounds)
            .all(|((&x, &y), &[lo, hi])| {
                let width = hi - lo;
                width <= 0.0 || ((x - y) / width).abs() <= resolution
            })
    })
}
