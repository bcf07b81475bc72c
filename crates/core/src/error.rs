//! The crate's error type: every failure a user can cause names its cause, and every variant
//! belongs to one [`ErrorKind`] that a caller maps to an HTTP status or an exit code without
//! reading the text.

use crate::fem::FemError;
use crate::scene::SceneError;
use wsm_search::SearchError;

/// Which inner solver failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SolverStage {
    /// The contact problem (direct solver: free motions, dual QP).
    Contact,
    /// The heat problem.
    Heat,
}

impl std::fmt::Display for SolverStage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SolverStage::Contact => "contact solver",
            SolverStage::Heat => "heat solver",
        })
    }
}

/// Errors of meshing, solving, searching and of the run around them.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WsmError {
    /// A bad scene or request: the JSON path of the field and the reason.
    #[error("{0}")]
    Scene(#[from] SceneError),
    /// The finite-element layer refused the data (or, for a matrix that is not positive
    /// definite, failed).
    #[error("{0}")]
    Fem(#[from] FemError),
    /// A body has no support at all.
    #[error("body '{body}' cannot be balanced: {reason}")]
    Unbalanced {
        /// The body's name in the scene.
        body: String,
        /// Its index in the scene's `bodies`.
        index: usize,
        /// Why it is unsupported (e.g. no displacement or roller condition and no contact zone).
        reason: String,
    },
    /// The semi-coercive solvability condition fails (CZ Thm 1.2, D05 Thm 2.1).
    #[error("body '{body}' cannot be balanced by contact and friction: the loads drive a rigid {motion} that the contact zones cannot hold")]
    UnbalancedMode {
        /// The floating body's name in the scene.
        body: String,
        /// Its index in the scene's `bodies`.
        index: usize,
        /// The rigid motion (translation and/or rotation) the loads drive, in words.
        motion: String,
    },
    /// An inner solver failed on admissible data.
    #[error("{stage}: {reason}")]
    Solver {
        /// The inner solver that failed.
        stage: SolverStage,
        /// The solver's account of the failure (e.g. the KKT residuals that missed the tolerance).
        reason: String,
    },
    /// The outer search could not run.
    #[error("search: {0}")]
    Search(#[from] SearchError),
    /// More than half of a run's evaluations have no state solution: the result would say
    /// nothing reliable, so the run ends with this error (every evaluation stays in the log).
    #[error("{failed} of {evaluations} evaluations failed, so the search cannot answer; first error: {first}")]
    EvaluationsFailed {
        /// Failed evaluations.
        failed: usize,
        /// All evaluations of the run.
        evaluations: usize,
        /// The first failure's error.
        first: String,
    },
    /// The work was cancelled before it had anything to report.
    #[error("cancelled")]
    Cancelled,
    /// A named thing (a bundled example, a job) does not exist.
    #[error("no {what} '{name}'")]
    NotFound {
        /// The kind of thing looked up, e.g. `"bundled example"`.
        what: &'static str,
        /// The name that was not found.
        name: String,
    },
    /// An evaluation log belongs to another scene or other settings.
    #[error("the log {path} belongs to another run: its hash is {found}, this run's is {expected} (scene or criteria differ)")]
    LogMismatch {
        /// The log's file path (`job <id>` for a service job's stored evaluations).
        path: String,
        /// This run's hash (64 hex digits, `run::run_hash`).
        expected: String,
        /// The hash recorded in the log.
        found: String,
    },
    /// Reading or writing a file (or another store), or encoding a result.
    #[error("{path}: {reason}")]
    Io {
        /// The file path or store that failed.
        path: String,
        /// The underlying error's message.
        reason: String,
    },
}

/// The class of an error, for status codes and exit codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The input is wrong (the message names the field): HTTP 422, exit code 2.
    BadInput,
    /// The input is well formed but the physics has no solution (a body cannot be balanced).
    Unsolvable,
    /// A solver or the search failed on valid input (a defect or a numerical breakdown).
    Solver,
    /// The work was cancelled before it had a result: HTTP 409, exit code 6.
    Cancelled,
    /// A named example or job does not exist: HTTP 404, exit code 2.
    NotFound,
    /// Files, stores, logs of other runs.
    Io,
}

impl ErrorKind {
    /// The command line's exit status of an error of this kind: 2 bad input or unknown name,
    /// 3 unsolvable, 4 solver failure, 5 files and logs, 6 cancelled (the Python package
    /// carries the same number on its exceptions).
    pub fn exit_code(self) -> u8 {
        match self {
            ErrorKind::BadInput | ErrorKind::NotFound => 2,
            ErrorKind::Unsolvable => 3,
            ErrorKind::Solver => 4,
            ErrorKind::Io => 5,
            ErrorKind::Cancelled => 6,
        }
    }

    /// The kind's name in snake case (`bad_input`, `unsolvable`, …), as job records and the
    /// Python package carry it.
    pub fn name(self) -> &'static str {
        match self {
            ErrorKind::BadInput => "bad_input",
            ErrorKind::Unsolvable => "unsolvable",
            ErrorKind::Solver => "solver",
            ErrorKind::Cancelled => "cancelled",
            ErrorKind::NotFound => "not_found",
            ErrorKind::Io => "io",
        }
    }
}

impl WsmError {
    /// The error's class, from which callers derive the HTTP status and the exit code.
    pub fn kind(&self) -> ErrorKind {
        match self {
            WsmError::Scene(_) => ErrorKind::BadInput,
            WsmError::Fem(e) => match e {
                FemError::FloatingBody { .. } => ErrorKind::Unsolvable,
                FemError::NotPositiveDefinite { .. } | FemError::Solver(_) => ErrorKind::Solver,
                _ => ErrorKind::BadInput,
            },
            WsmError::Unbalanced { .. }
            | WsmError::UnbalancedMode { .. }
            | WsmError::EvaluationsFailed { .. } => ErrorKind::Unsolvable,
            WsmError::Solver { .. } | WsmError::Search(_) => ErrorKind::Solver,
            WsmError::Cancelled => ErrorKind::Cancelled,
            WsmError::NotFound { .. } => ErrorKind::NotFound,
            WsmError::LogMismatch { .. } | WsmError::Io { .. } => ErrorKind::Io,
        }
    }

    /// The JSON path of the offending field, where the error names one: the field of bad
    /// input, the body (`bodies[i]`) an unsolvable scene cannot balance.
    pub fn path(&self) -> Option<String> {
        match self {
            WsmError::Scene(e) => Some(e.path.clone()),
            WsmError::Unbalanced { index, .. } | WsmError::UnbalancedMode { index, .. } => {
                Some(format!("bodies[{index}]"))
            }
            WsmError::Fem(FemError::FloatingBody { body, .. }) => Some(format!("bodies[{body}]")),
            _ => None,
        }
    }

    /// A file or store error.
    pub fn io(path: impl std::fmt::Display, reason: impl std::fmt::Display) -> WsmError {
        WsmError::Io {
            path: path.to_string(),
            reason: reason.to_string(),
        }
    }

    /// A contact-solver failure.
    pub fn contact(reason: impl Into<String>) -> WsmError {
        WsmError::Solver {
            stage: SolverStage::Contact,
            reason: reason.into(),
        }
    }
}
