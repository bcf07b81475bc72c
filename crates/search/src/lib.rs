//! The outer maximiser of the worst-scenario method (design §4.3): a generic, deterministic,
//! budgeted, cancellable and resumable search for the extrema of criteria Φ_i(θ) over a box of
//! parameters θ, where every evaluation is an expensive black box.
//!
//! One search serves several objectives (max or min of one criterion each) with one shared pool
//! of evaluations; every point any phase asks for goes through the [`EvalCache`], which can be
//! pre-loaded from a previous (interrupted) run and persisted afterwards. Phases, one module each:
//!
//! With exact derivatives from the evaluator (design §4.3, "With exact derivatives"):
//!
//! 0. `vertex_walk` — the centre, the vertex its gradient signs point to per objective, then
//!    flips of the bounds the gradient does not prove: a first local certificate, cheaply;
//! 1. `global` — the global question: every vertex of the box when the budget affords it (each
//!    one locally certified or not by its own derivatives), then rounds of local searches
//!    (`ascent`, a projected quasi-Newton ascent) from a space-filling design, from the vertices
//!    the gradient signs at other optima point to, and from the far side of every datum whose
//!    derivative changes sign; it stops by the rule of [`StopRule`] (by default a Bayesian
//!    estimate of the unseen local optima, Boender & Rinnooy Kan) and reports its
//!    [`GlobalEvidence`].
//!
//! Without derivatives:
//!
//! 1. `screening` — all vertices of the box plus its centre when that is cheap, topped up with a
//!    scrambled Latin hypercube (design §4.3 item 1);
//! 2. `pso` — argmin's `ParticleSwarm`, seeded with the best points evaluated so far (item 2);
//! 3. `polish` — a bounded compass search written as an argmin `Solver`, coarse from the basin
//!    tops of the sample, then fine from the best of them and its ties (item 3).
//!
//! Then `sensitivity` — normalised sensitivities (exact from the derivatives, else one-sided
//! finite differences) at each optimum; `certificate` — the local first-order optimality proof of
//! every extremum from the exact derivatives; `optima` — basin tops, the vertex and
//! several-maximiser reports (item 4).
//!
//! `driver` runs them and splits the budget; `session` is the single gate to the evaluator
//! (budget, wall time, cancellation, progress, convergence history); `guard` applies those
//! limits and stagnation to any argmin solver; `cost` is an objective as an argmin cost;
//! `space` maps the unit box onto the physical one; `random` gives the seeded streams.
//!
//! All searching happens in the unit box [0, 1]^k of the k free parameters (those with lo < hi),
//! so parameters of very different units are treated alike. Results are identical for a given
//! seed whatever the thread count: the evaluator returns results in input order and nothing
//! depends on completion order.

mod ascent;
mod cache;
mod certificate;
mod cost;
mod driver;
mod global;
mod guard;
mod optima;
mod polish;
mod pso;
mod random;
mod screening;
mod sensitivity;
mod session;
mod space;
mod vertex_walk;

pub use cache::EvalCache;
pub use certificate::{BoundProof, Certificate, Kink, Verdict, CERTIFY_TOL};
pub use driver::search;
pub use global::{default_budget, GlobalEvidence, RunnerUp, CLOSE_RUNNER_UP};

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// The one-sided derivatives of a criterion along one parameter: `right` = lim (Φ(θ + ε e) −
/// Φ(θ))/ε and `left` = lim (Φ(θ) − Φ(θ − ε e))/ε for ε ↓ 0; equal where Φ is differentiable.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct OneSided {
    /// Derivative as the parameter increases.
    pub right: f64,
    /// Derivative as the parameter decreases (the slope from the left).
    pub left: f64,
}

/// Relative difference of the one-sided derivatives below which a criterion is differentiable.
const SMOOTH_TOL: f64 = 1e-9;

impl OneSided {
    /// The derivative of a differentiable criterion (both sides equal).
    pub fn both(slope: f64) -> OneSided {
        OneSided {
            right: slope,
            left: slope,
        }
    }

    /// Whether both one-sided derivatives agree (to 1e-9 relative).
    pub fn is_differentiable(&self) -> bool {
        let scale = self.right.abs().max(self.left.abs());
        (self.right - self.left).abs() <= SMOOTH_TOL * scale
    }

    /// Both derivatives multiplied by `factor` (a negative factor turns Φ into −Φ).
    pub fn scaled(self, factor: f64) -> OneSided {
        OneSided {
            right: self.right * factor,
            left: self.left * factor,
        }
    }

    /// The mean of both sides (the derivative where Φ is differentiable).
    pub fn mean(&self) -> f64 {
        0.5 * (self.right + self.left)
    }
}

/// What the black box answers at a feasible point.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Answer {
    /// The criteria vector.
    pub values: Vec<f64>,
    /// `slopes[c][i]`: the one-sided derivatives of criterion `c` along parameter `i` (all
    /// parameters of the box, fixed ones included); empty when the evaluator gives none.
    pub slopes: Vec<Vec<OneSided>>,
}

impl From<Vec<f64>> for Answer {
    /// Criteria values without derivatives.
    fn from(values: Vec<f64>) -> Answer {
        Answer {
            values,
            slopes: Vec::new(),
        }
    }
}

/// The answer of one evaluation, or the reason it failed.
pub type Outcome = Result<Answer, String>;

/// The expensive black box: the criteria vector (Φ1, …, Φ6 or any other) at given parameters,
/// with their derivatives if it can give them.
pub trait Evaluator: Sync {
    /// Evaluate the criteria vector at each point (physical parameter values, inside the box).
    /// Called with a whole generation at once; the implementation may run the batch in parallel
    /// but must return the results in input order. An `Err` marks an infeasible point; a
    /// non-finite criterion value is treated the same way. Derivatives (`Answer::slopes`), when
    /// given, drive the vertex walk and prove the extrema ([`Certificate`]).
    fn evaluate(&self, points: &[Vec<f64>]) -> Vec<Outcome>;

    /// Points passed to [`Evaluator::evaluate`] at once, between two checks of cancellation and
    /// the time limit (a few per thread; more when the batch is spread over other processes).
    /// Chunking never changes results, only how soon a halt is seen.
    fn chunk_size(&self) -> usize {
        CHUNK_PER_THREAD * rayon::current_num_threads().max(1)
    }

    /// Whether the answers carry derivatives (`Answer::slopes`). Only then does the search
    /// start with the vertex walk and take its sensitivities from them instead of extra
    /// finite-difference points.
    fn gives_derivatives(&self) -> bool {
        false
    }
}

/// Points per thread evaluated between two checks of cancellation and the time limit.
pub const CHUNK_PER_THREAD: usize = 2;

/// Whether a criterion is to be maximised (the worst scenario) or minimised (the best one).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum Sense {
    /// Find the largest value (JSON `"max"`).
    Max,
    /// Find the smallest value (JSON `"min"`).
    Min,
}

/// One extremum to find: `sense` of the criterion at index `criterion` of the criteria vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Objective {
    /// Index into the criteria vector that [`Evaluator::evaluate`] returns.
    pub criterion: usize,
    /// Whether that criterion is maximised or minimised.
    pub sense: Sense,
}

/// The search: a box, the objectives, and the limits.
#[derive(Clone, Debug, PartialEq)]
pub struct SearchProblem {
    /// `[lo, hi]` per parameter, finite, `lo <= hi`; `lo == hi` fixes the parameter.
    pub bounds: Vec<[f64; 2]>,
    /// The extrema to find, all served by one shared pool of evaluations; at least one.
    pub objectives: Vec<Objective>,
    /// Total number of distinct points evaluated for everything (all phases, all objectives).
    pub budget: usize,
    /// Wall-time limit in seconds, checked between batches (`None` or ∞: no limit).
    pub max_seconds: Option<f64>,
    /// Seed of every random choice; the result is a function of the problem and the seed.
    pub seed: u64,
    /// Names of the parameters, which key the result's `data` and `gradient` (a parameter
    /// without one is `θ<index>`).
    pub names: Vec<String>,
    /// When the search may stop before its budget is spent.
    pub stop: StopRule,
}

/// When a search with exact derivatives may stop before its budget is spent (`search.stop`).
/// Without derivatives the search always spends its budget.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    utoipa::ToSchema,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum StopRule {
    /// Spend the whole budget looking for other local optima.
    Budget,
    /// Stop an objective once its global rule is met (see [`GlobalEvidence::rule_met`]): every
    /// vertex of the box screened (when there are at most 1024) and the Boender–Rinnooy Kan
    /// estimate of the local optima not yet found below ½. The default.
    #[default]
    GlobalRule,
    /// Stop an objective at its first locally certified extremum: fastest, and says nothing
    /// about other basins.
    FirstCertificate,
}

/// The phase a progress report comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Phase {
    /// The centre and the vertices the exact gradients point to (with derivatives only).
    VertexWalk,
    /// The screening shared by all objectives: box vertices and centre when cheap, then a Latin
    /// hypercube.
    Screening,
    /// Particle swarm for objective `objective` (index into `SearchProblem::objectives`).
    Global {
        /// Index into `SearchProblem::objectives`.
        objective: usize,
    },
    /// Compass-search polish for objective `objective`.
    Polish {
        /// Index into `SearchProblem::objectives`.
        objective: usize,
    },
    /// The finite-difference steps for the sensitivities at every optimum (without derivatives).
    Sensitivity,
    /// With derivatives: a round of local searches from new starts (numbered from 0).
    Multistart {
        /// The round.
        round: usize,
    },
}

/// Reported after every batch of evaluations.
#[derive(Clone, Debug, PartialEq)]
pub struct Progress {
    /// Distinct points evaluated by this run so far (including those restored from the cache).
    pub evaluations: usize,
    /// The run's total evaluation budget (`SearchProblem::budget`).
    pub budget: usize,
    /// The phase that evaluated the batch.
    pub phase: Phase,
    /// Best criterion value so far per objective (`None` while nothing feasible was found).
    pub best: Vec<Option<f64>>,
    /// Of `evaluations`, how many failed (no criteria vector).
    pub failures: usize,
}

/// Cancellation flag and progress callback. Cancellation is honoured between batches.
#[derive(Clone, Copy)]
pub struct SearchControl<'a> {
    /// Raised by the caller to stop the search before its next batch (status `Cancelled`).
    pub cancel: &'a AtomicBool,
    /// Called with a [`Progress`] report after every batch of evaluations.
    pub on_progress: &'a (dyn Fn(&Progress) + Sync),
}

static NEVER_CANCELLED: AtomicBool = AtomicBool::new(false);

impl Default for SearchControl<'static> {
    /// Never cancelled, no progress reports.
    fn default() -> Self {
        SearchControl {
            cancel: &NEVER_CANCELLED,
            on_progress: &|_| {},
        }
    }
}

/// Why a search (or one objective of it) ended. Ordered by precedence: the status of a whole
/// search is the greatest of its objectives' statuses.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    Serialize,
    Deserialize,
    utoipa::ToSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// The exact derivatives prove first-order optimality at the reported point: every bound it
    /// sits on is held by the sign of ∂Φ/∂θ, and the gradient along the other data is below
    /// [`CERTIFY_TOL`] relative (see [`Certificate`]). A local statement only: another point of
    /// the box may be better where the criterion is not monotone; what the search knows about
    /// that is the extremum's [`GlobalEvidence`]. (JSON `"locally_certified"`; results stored as
    /// `"certified"` before the rename read as this.)
    #[serde(alias = "certified")]
    LocallyCertified,
    /// The fine polish of the best point converged: its step fell below 1e-8 of the unit box,
    /// or a poll around it was flat within 1e-9 relative.
    Completed,
    /// The polish made no relative improvement above 1e-9 for many iterations.
    Stagnated,
    /// The evaluation budget ran out before the polish converged (or no feasible point was
    /// found to polish).
    BudgetExhausted,
    /// `max_seconds` elapsed.
    TimeLimit,
    /// Failed evaluations lie closer to the best point than the search resolves (set by the
    /// caller that knows the failures): the extremum may be among them, so the value is not
    /// settled.
    Unsettled,
    /// The cancel flag was raised.
    Cancelled,
}

/// Which bound a parameter sits on at an optimum.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum ActiveBound {
    /// Strictly inside its interval (farther than 1e-9 of the range from both ends).
    #[serde(rename = "interior")]
    None,
    /// At its lower end `lo` (within 1e-9 of the range).
    Lower,
    /// At its upper end `hi` (within 1e-9 of the range).
    Upper,
    /// `lo == hi`.
    Fixed,
}

/// The extremum found for one objective.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct ObjectiveResult {
    /// Index of the criterion in the criteria vector.
    pub criterion: usize,
    /// Whether the criterion was maximised (worst scenario) or minimised (best one).
    pub sense: Sense,
    /// The extremum's value: the largest (worst) or smallest (best) criterion value found
    /// (`None` if no feasible point was evaluated), in the criterion's unit (K for Φ1–Φ2, m for
    /// Φ3–Φ4, Pa² for Φ5, Pa for Φ6). Stored results name it `best_value`.
    #[serde(alias = "best_value")]
    pub value: Option<f64>,
    /// The data of the extremum in the order of the parameters (units of each parameter's
    /// field); `data` gives the same numbers by name. Stored results name it `best_point`.
    #[serde(alias = "best_point")]
    pub point: Option<Vec<f64>>,
    /// Where the criterion takes `value`, filled in by the caller that knows (for a worst-scenario
    /// criterion: the area or boundary piece whose mean it is).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<String>,
    /// When the criterion takes `value` \[s\], filled in by the caller that knows (for a
    /// criterion of a dynamic scene, the maximum over time: the first time it is reached).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time: Option<f64>,
    /// Why the search for this objective ended.
    pub status: Status,
    /// The best point is a vertex of the box (every free coordinate within 1e-9 of a bound).
    pub at_vertex: bool,
    /// Some evaluated vertex (normally from the screening) reaches the best value within 1e-9
    /// relative: the extremum is attained at a vertex, as for a monotone criterion.
    pub vertex_optimal: bool,
    /// Evaluated points farther apart than 0.1 (unit-box distance) reach the best value within
    /// 1e-9 relative: the extremum is probably not unique.
    pub several_optima: bool,
    /// One representative point (physical) per distinct optimum, the best point first.
    pub optima: Vec<Vec<f64>>,
    /// Per parameter, at the best point.
    pub active_bounds: Vec<ActiveBound>,
    /// Per parameter: S_i = ∂Φ/∂θ_i · (hi − lo) / |Φ|, exact where the evaluator gives
    /// derivatives (the mean of both sides at a kink), otherwise by a one-sided difference
    /// pointing into the box. `None` for fixed parameters, when Φ = 0, or when the step was not
    /// evaluated.
    pub sensitivities: Vec<Option<f64>>,
    /// The best point by parameter name (the same numbers as `best_point`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub data: BTreeMap<String, f64>,
    /// By parameter name, ∂Φ/∂θ at the best point in the criterion's unit per the parameter's
    /// unit (both one-sided values); empty without derivatives.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub gradient: BTreeMap<String, OneSided>,
    /// The local proof: what the exact derivatives prove about the best point (absent when
    /// nothing was found).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub certificate: Option<Certificate>,
    /// The global evidence: what the search knows about other local optima of the box.
    #[serde(default)]
    pub global: GlobalEvidence,
    /// (number of evaluations so far, best value so far) at every improvement.
    #[schema(value_type = Vec<Vec<f64>>)]
    pub history: Vec<(usize, f64)>,
}

impl ObjectiveResult {
    /// Nothing found yet (a run stopped before its search), for `n` parameters.
    pub fn empty(criterion: usize, sense: Sense, status: Status, n: usize) -> ObjectiveResult {
        ObjectiveResult {
            criterion,
            sense,
            value: None,
            point: None,
            region: None,
            time: None,
            status,
            at_vertex: false,
            vertex_optimal: false,
            several_optima: false,
            optima: Vec::new(),
            active_bounds: Vec::new(),
            sensitivities: vec![None; n],
            data: BTreeMap::new(),
            gradient: BTreeMap::new(),
            certificate: None,
            global: GlobalEvidence::default(),
            history: Vec::new(),
        }
    }
}

/// The outcome of [`search`].
#[derive(Clone, Debug, PartialEq)]
pub struct SearchResult {
    /// The greatest of the objectives' statuses (and of a halt by time limit or cancellation).
    pub status: Status,
    /// One result per objective, in the order of `SearchProblem::objectives`.
    pub objectives: Vec<ObjectiveResult>,
    /// Distinct points used by this run, including those restored from the cache.
    pub evaluations: usize,
    /// Points actually passed to the evaluator by this run.
    pub new_evaluations: usize,
    /// Wall time of the search.
    pub elapsed: Duration,
}

/// Why a search could not start.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SearchError {
    /// A parameter's interval is not finite or has `lo > hi`.
    #[error("parameter {index}: invalid interval [{lo}, {hi}] (need finite lo <= hi)")]
    InvalidBounds {
        /// Index of the parameter in `SearchProblem::bounds`.
        index: usize,
        /// The interval's lower end.
        lo: f64,
        /// The interval's upper end.
        hi: f64,
    },
    /// `SearchProblem::objectives` is empty.
    #[error("no objectives to search for")]
    NoObjectives,
    /// An argmin solver failed for a reason other than the search's own stop conditions; the
    /// text is argmin's error.
    #[error("optimiser failure: {0}")]
    Solver(String),
}

#[cfg(test)]
mod tests;
