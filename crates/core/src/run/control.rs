//! The lifecycle of a run as its caller sees it: the cancel flag, the progress events (one per
//! phase change and per evaluation batch), the evaluation log and where batches are evaluated.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::log::EvaluationLog;
use super::remote::BatchDispatch;
use crate::fault::SolveFault;
use crate::scene::CriterionSpec;
use wsm_search::{Phase, Progress, Sense};

/// The phase a run is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum RunPhase {
    /// A service job waiting for a worker.
    Queued,
    /// The mesh ladder of a run with a target error (`crate::estimate::mesh_choice`).
    MeshChoice,
    /// Meshing the scene and building the state problem.
    Meshing,
    /// The solvability condition at the vertices of the admissible box (design §4.1).
    AdmissibleCheck,
    /// The solve at the nominal data (the warm start of every evaluation).
    NominalSolve,
    /// With exact derivatives: the centre of the box and the vertices the gradients point to
    /// (design §4.3, with the exact derivatives of §4.4).
    VertexWalk,
    /// The screening shared by all objectives: vertices and centre of the box when cheap, then
    /// a Latin hypercube (design §4.3 item 1).
    Screening,
    /// The particle swarm of one objective (design §4.3 item 2).
    Swarm,
    /// The local polish of one objective: compass search, or the projected quasi-Newton ascent
    /// with exact derivatives (design §4.3 item 3).
    Polish,
    /// The finite-difference sensitivities at every optimum, without exact derivatives (design
    /// §4.3 item 4).
    Sensitivities,
    /// With exact derivatives: rounds of local searches from new starts looking for other local
    /// optima (design §4.3, "The global question").
    Multistart,
    /// The accuracy statement: worst and best data re-solved on refined meshes.
    Accuracy,
    /// The time steps of a dynamic solve (design §3.5): `evaluations` counts the steps taken,
    /// `budget` the steps of the run.
    TimeSteps,
    /// The run has ended (the outcome's status says how).
    Finished,
}

/// The best value so far of one objective (max or min of one criterion).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct BestSoFar {
    /// The criterion Φ1–Φ6.
    pub criterion: CriterionSpec,
    /// `max` (the worst scenario) or `min` (the best one).
    pub sense: Sense,
    /// `None` while no feasible point was evaluated (units of the criterion).
    pub value: Option<f64>,
}

/// A progress report: sent at every phase change and after every evaluation batch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct ProgressEvent {
    /// The phase the run is in.
    pub phase: RunPhase,
    /// The criterion the swarm or polish works on (`None` in shared phases).
    pub objective: Option<BestSoFar>,
    /// Distinct points evaluated so far (including replayed ones).
    pub evaluations: usize,
    /// Of `evaluations`, how many failed (the inner solver's error is in the log).
    #[serde(default)]
    pub failures: usize,
    /// The run's total evaluation budget (distinct points, all phases and objectives).
    pub budget: usize,
    /// Best value so far per objective: max, then min, of each criterion in request order
    /// (empty before the search).
    pub best: Vec<BestSoFar>,
    /// Since the run started \[s\].
    pub elapsed_seconds: f64,
}

/// A progress callback.
pub type ProgressFn = dyn Fn(&ProgressEvent) + Send + Sync;

/// What the caller holds on to during a run: a cancel flag (honoured in every phase, within one
/// evaluation batch in the search), progress reports and an evaluation log.
#[derive(Clone, Default)]
pub struct RunControl {
    /// Raise to cancel: the run stops with status `cancelled` and its partial outcome.
    pub cancel: Arc<AtomicBool>,
    /// Called with every [`ProgressEvent`].
    pub progress: Option<Arc<ProgressFn>>,
    /// Where every evaluation goes once its chunk is done, and where a resumed run replays from.
    pub log: Option<Arc<dyn EvaluationLog>>,
    /// Where evaluation batches are computed when not here (other worker processes).
    pub dispatch: Option<Arc<dyn BatchDispatch>>,
    /// For tests of failure handling: the solves made here (search evaluations, the accuracy
    /// statement's refined solves, the mesh choice's solves) fail where it answers.
    pub fault: Option<Arc<SolveFault>>,
    /// Peak memory a single solve may need \[bytes\] (`--max-solve-memory`): a run whose scene
    /// is estimated beyond it is refused before meshing, and a refined level of its accuracy
    /// statement beyond it is not built (a listed failure) — design §3.1, cost estimate.
    pub max_solve_bytes: Option<f64>,
}

impl RunControl {
    /// No cancellation, progress reports, log, dispatch or faults.
    pub fn new() -> RunControl {
        RunControl::default()
    }

    /// Report progress to `progress`.
    pub fn with_progress(
        mut self,
        progress: impl Fn(&ProgressEvent) + Send + Sync + 'static,
    ) -> Self {
        self.progress = Some(Arc::new(progress));
        self
    }

    /// Store (and replay) the evaluations in `log`.
    pub fn with_log(mut self, log: Arc<dyn EvaluationLog>) -> Self {
        self.log = Some(log);
        self
    }

    /// Evaluate batches through `dispatch` (other worker processes).
    pub fn with_dispatch(mut self, dispatch: Arc<dyn BatchDispatch>) -> Self {
        self.dispatch = Some(dispatch);
        self
    }

    /// Fail the solves where `fault` answers (tests of failure handling; see
    /// `crate::fault`).
    pub fn with_fault(mut self, fault: Arc<SolveFault>) -> Self {
        self.fault = Some(fault);
        self
    }

    /// Refuse solves estimated to need more than `bytes` of memory (design §3.1).
    pub fn with_max_solve_memory(mut self, bytes: u64) -> Self {
        self.max_solve_bytes = Some(bytes as f64);
        self
    }

    /// Use `cancel` as the cancel flag (shared with the caller).
    pub fn with_cancel(mut self, cancel: Arc<AtomicBool>) -> Self {
        self.cancel = cancel;
        self
    }

    /// Whether the cancel flag is raised.
    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::SeqCst)
    }

    pub(super) fn report(&self, event: &ProgressEvent) {
        if let Some(progress) = &self.progress {
            progress(event);
        }
    }
}

impl RunPhase {
    pub(super) fn of(phase: Phase) -> RunPhase {
        match phase {
            Phase::VertexWalk => RunPhase::VertexWalk,
            Phase::Screening => RunPhase::Screening,
            Phase::Global { .. } => RunPhase::Swarm,
            Phase::Polish { .. } => RunPhase::Polish,
            Phase::Sensitivity => RunPhase::Sensitivities,
            Phase::Multistart { .. } => RunPhase::Multistart,
        }
    }
}

/// The objective a search phase works on.
pub(super) fn phase_objective(phase: Phase) -> Option<usize> {
    match phase {
        Phase::Global { objective } | Phase::Polish { objective } => Some(objective),
        Phase::VertexWalk | Phase::Screening | Phase::Sensitivity | Phase::Multistart { .. } => {
            None
        }
    }
}

/// Best values per objective (max, min of each criterion in order) from a search report.
pub(super) fn best_so_far(criteria: &[CriterionSpec], progress: &Progress) -> Vec<BestSoFar> {
    criteria
        .iter()
        .flat_map(|c| [(c.clone(), Sense::Max), (c.clone(), Sense::Min)])
        .zip(&progress.best)
        .map(|((criterion, sense), value)| BestSoFar {
            criterion,
            sense,
            value: *value,
        })
        .collect()
}
