//! A warning for the user as data (design §5.2): what it is about (`kind`), the thing it names
//! (`subject`: a JSON path, a zone, a criterion's extremum) and the words (`message`). Every
//! layer that warns — the scene's checks, the state solve, the search's proofs, the accuracy
//! statement, the mesh choice — builds one; the JSON keeps the three fields, so a client picks
//! warnings by kind without parsing text, and [`fmt::Display`] prints the readable
//! `subject: message` that the command line shows.

use std::fmt;

use serde::{Deserialize, Serialize};

/// What a warning is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum WarningKind {
    /// An uncertain datum addressed by the index of an entry that has a name.
    DataPath,
    /// A magnitude no solid or load has (usually a unit slip: MPa as Pa, mm as m).
    Units,
    /// P1 triangles lock: Poisson's ratio close to 0.5.
    Locking,
    /// Rigid motions of floating bodies that contact does not determine.
    RigidMotion,
    /// The state's sensitivities could not be computed.
    Sensitivities,
    /// The solver asked for could not answer; another one did.
    SolverFallback,
    /// The search ran without exact derivatives where it would have had them.
    Derivatives,
    /// Evaluations of the search failed.
    FailedEvaluations,
    /// An extremum the search did not prove, or that the global evidence leaves open.
    Unproven,
    /// The accuracy statement is incomplete (a mesh not built, refined solves failed, cut short).
    Accuracy,
    /// The mesh chosen for a target error does not meet it, or a mesh of its ladder failed.
    TargetError,
    /// A warning stored by an earlier version as plain text.
    Legacy,
}

/// A warning: kind, subject and message.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct Warning {
    /// What the warning is about.
    pub kind: WarningKind,
    /// The thing it names: a JSON path (`materials.rock.E`, `uncertain[2].field`), a zone
    /// (`zone 'marrow'`), a criterion's extremum (`Φ3 worst`), a setting; empty when the
    /// warning is about the whole run.
    pub subject: String,
    /// What is wrong and what to do, in plain words.
    pub message: String,
}

impl Warning {
    /// A warning of `kind` about `subject`.
    pub fn new(kind: WarningKind, subject: impl Into<String>, message: impl Into<String>) -> Self {
        Warning {
            kind,
            subject: subject.into(),
            message: message.into(),
        }
    }

    /// Whether the readable text (`subject: message`) contains `needle`.
    pub fn contains(&self, needle: &str) -> bool {
        self.to_string().contains(needle)
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.subject.is_empty() {
            f.write_str(&self.message)
        } else {
            write!(f, "{}: {}", self.subject, self.message)
        }
    }
}

/// Results stored before warnings were typed hold plain strings: they read back as
/// [`WarningKind::Legacy`] with the whole text as the message.
impl<'de> Deserialize<'de> for Warning {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        struct Fields {
            kind: WarningKind,
            #[serde(default)]
            subject: String,
            message: String,
        }
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Stored {
            Typed(Fields),
            Text(String),
        }
        Ok(match Stored::deserialize(deserializer)? {
            Stored::Typed(f) => Warning::new(f.kind, f.subject, f.message),
            Stored::Text(text) => Warning::new(WarningKind::Legacy, "", text),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_keeps_the_fields_and_reads_old_plain_text() {
        let w = Warning::new(WarningKind::Units, "materials.rock.E", "below 1e5 Pa");
        let json = serde_json::to_value(&w).unwrap();
        assert_eq!(
            json,
            serde_json::json!({"kind": "units", "subject": "materials.rock.E", "message": "below 1e5 Pa"})
        );
        assert_eq!(serde_json::from_value::<Warning>(json).unwrap(), w);
        assert_eq!(w.to_string(), "materials.rock.E: below 1e5 Pa");
        let old: Warning = serde_json::from_str("\"3 of 40 evaluations failed\"").unwrap();
        assert_eq!(old.kind, WarningKind::Legacy);
        assert_eq!(old.to_string(), "3 of 40 evaluations failed");
    }
}
