//! The crate's error type: every failure a user can cause names its cause.

use crate::fem::FemError;
use crate::scene::SceneError;

/// Errors of meshing, solving and searching.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WsmError {
    /// A bad scene: the JSON path of the field and the reason.
    #[error("{0}")]
    Scene(#[from] SceneError),
    /// The finite-element layer refused the data.
    #[error("{0}")]
    Fem(#[from] FemError),
    /// A body has no support at all.
    #[error("body '{body}' cannot be balanced: {reason}")]
    Unbalanced { body: String, reason: String },
    /// The semi-coercive solvability condition fails (CZ Thm 1.2, D05 Thm 2.1).
    #[error("body '{body}' cannot be balanced by contact and friction: the loads drive a rigid {motion} that the contact zones cannot hold")]
    UnbalancedMode { body: String, motion: String },
    /// The contact solver failed (with its residuals).
    #[error("contact solver: {0}")]
    Contact(String),
    /// The work was cancelled.
    #[error("cancelled")]
    Cancelled,
    /// Reading or writing a file.
    #[error("{0}")]
    Io(String),
}
