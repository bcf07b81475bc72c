//! Scene: the JSON document a user submits (SPEC §5.2), its validation, and its numeric data.
//!
//! `model` is the serde shape, `validate` checks meaning and names the JSON path of any bad
//! field, `data` resolves the numbers that the worst-scenario engine may vary.

mod data;
mod model;

pub use data::*;
pub use model::*;

use std::fmt;

/// A scene error: the JSON path of the offending field and the reason.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    pub path: String,
    pub reason: String,
}

impl SceneError {
    pub fn new(path: impl Into<String>, reason: impl Into<String>) -> SceneError {
        SceneError {
            path: path.into(),
            reason: reason.into(),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path, self.reason)
    }
}

impl std::error::Error for SceneError {}
