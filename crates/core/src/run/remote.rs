//! Evaluation batches computed elsewhere: a [`BatchDispatch`] (the service's job store, with
//! worker processes behind it) takes the points of a batch and returns their evaluations in input
//! order — computing its own share with the run's evaluator — while the search itself stays in
//! this process. [`Dispatched`] puts a dispatch in front of the run's own evaluator, falling back
//! to it when the dispatch declines a batch (no other worker is there), and keeps the
//! inner-solver statistics of the remote evaluations.
//!
//! The evaluation of a point is a function of (scene, θ) alone, so whoever computes it, the
//! search sees the same values in the same order and ends with the same result, bit for bit.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

use crate::error::WsmError;
use crate::estimate::statement::RefinedDispatch;
use crate::scenario::evaluator::{Evaluation, InnerSummary, ScenarioEvaluator};
use crate::scene::Scene;
use wsm_search::{Evaluator, Outcome};

/// Evaluates points in this process without logging them (the dispatch stores them itself).
pub type LocalEvaluate<'a> = dyn Fn(&[Vec<f64>]) -> Vec<Evaluation> + Sync + 'a;

/// A dispatched batch: its evaluations in input order, and which came from other processes.
pub struct DispatchedBatch {
    /// One evaluation per point of the batch, in input order.
    pub evaluations: Vec<Evaluation>,
    /// Per point: `true` when another process computed it (its statistics are counted as
    /// remote), `false` when this process's share computed it with `local`.
    pub remote: Vec<bool>,
}

/// Evaluates batches of points in other processes (and, as a [`RefinedDispatch`], the accuracy
/// statement's refined solves).
pub trait BatchDispatch: RefinedDispatch {
    /// Points handed out at once (one fan-out batch; cancellation is seen between batches),
    /// given the mean solve time of a point so far (`None` before the first).
    fn chunk_size(&self, seconds_per_point: Option<f64>) -> usize;
    /// The evaluations of `points` in input order, stored by whoever computed them — this
    /// process's share computed with `local`; `None`: not dispatched (evaluate and log here).
    fn evaluate(
        &self,
        points: &[Vec<f64>],
        local: &LocalEvaluate<'_>,
    ) -> Result<Option<DispatchedBatch>, WsmError>;
    /// The scene this run chose for its target error, before any batch: the other processes
    /// evaluate on it instead of choosing again.
    fn share_scene(&self, scene: &Scene) -> Result<(), WsmError>;
    /// Wait until everything evaluated so far is stored (a dispatch may store its own share
    /// while the search goes on); called when the search ends.
    fn flush(&self) -> Result<(), WsmError>;
}

/// Statistics of the evaluations computed elsewhere.
#[derive(Default)]
struct RemoteStats {
    solves: AtomicUsize,
    failures: AtomicUsize,
    seconds: Mutex<f64>,
    max_kkt: Mutex<f64>,
}

/// The run's evaluator with a dispatch in front of it.
pub(super) struct Dispatched<'a> {
    pub(super) local: &'a ScenarioEvaluator<'a>,
    pub(super) dispatch: &'a dyn BatchDispatch,
    /// Where a dispatch failure goes (the run then stops with it).
    pub(super) failure: &'a Mutex<Option<WsmError>>,
    pub(super) halt: &'a AtomicBool,
    remote: RemoteStats,
}

impl<'a> Dispatched<'a> {
    pub(super) fn new(
        local: &'a ScenarioEvaluator<'a>,
        dispatch: &'a dyn BatchDispatch,
        failure: &'a Mutex<Option<WsmError>>,
        halt: &'a AtomicBool,
    ) -> Dispatched<'a> {
        Dispatched {
            local,
            dispatch,
            failure,
            halt,
            remote: RemoteStats::default(),
        }
    }

    fn account(&self, evaluation: &Evaluation) {
        let stats = &self.remote;
        stats.solves.fetch_add(1, Ordering::Relaxed);
        if evaluation.values.is_none() {
            stats.failures.fetch_add(1, Ordering::Relaxed);
        }
        *stats.seconds.lock().unwrap_or_else(PoisonError::into_inner) += evaluation.solve_seconds;
        if let Some(kkt) = evaluation.max_kkt_residual {
            let mut max = stats.max_kkt.lock().unwrap_or_else(PoisonError::into_inner);
            *max = max.max(kkt);
        }
    }

    /// The statistics of the whole run: local and remote evaluations.
    pub(super) fn summary(&self) -> InnerSummary {
        let mut summary = self.local.summary();
        let stats = &self.remote;
        let remote = stats.solves.load(Ordering::Relaxed);
        let qp_total = summary.mean_qp_iterations * summary.solves as f64;
        summary.solves += remote;
        summary.failures += stats.failures.load(Ordering::Relaxed);
        summary.solver_seconds += *stats.seconds.lock().unwrap_or_else(PoisonError::into_inner);
        summary.max_kkt_residual = summary
            .max_kkt_residual
            .max(*stats.max_kkt.lock().unwrap_or_else(PoisonError::into_inner));
        // QP iterations are known for local solves only.
        summary.mean_qp_iterations = qp_total / (summary.solves - remote).max(1) as f64;
        summary
    }
}

impl Evaluator for Dispatched<'_> {
    fn evaluate(&self, points: &[Vec<f64>]) -> Vec<Outcome> {
        let local = |points: &[Vec<f64>]| self.local.evaluate_batch(points);
        match self.dispatch.evaluate(points, &local) {
            Ok(Some(DispatchedBatch {
                evaluations,
                remote,
            })) if evaluations.len() == points.len() => evaluations
                .iter()
                .zip(remote)
                .map(|(e, remote)| {
                    if remote {
                        self.account(e);
                    }
                    e.outcome()
                })
                .collect(),
            Ok(Some(DispatchedBatch { evaluations, .. })) => {
                self.fail(WsmError::io(
                    "evaluation batch",
                    format!(
                        "{} evaluations returned for {} points",
                        evaluations.len(),
                        points.len()
                    ),
                ));
                points.iter().map(|_| Err("not evaluated".into())).collect()
            }
            Ok(None) => self.local.evaluate(points),
            Err(e) => {
                let reason = e.to_string();
                self.fail(e);
                points.iter().map(|_| Err(reason.clone())).collect()
            }
        }
    }

    fn chunk_size(&self) -> usize {
        let summary = self.summary();
        let seconds_per_point =
            (summary.solves > 0).then(|| summary.solver_seconds / summary.solves as f64);
        self.dispatch
            .chunk_size(seconds_per_point)
            .max(self.local.chunk_size())
    }

    fn gives_derivatives(&self) -> bool {
        self.local.gives_derivatives()
    }
}

impl Dispatched<'_> {
    fn fail(&self, error: WsmError) {
        self.failure
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .get_or_insert(error);
        self.halt.store(true, Ordering::SeqCst);
    }
}
