//! The evaluation log (design §5.4): every evaluation of a run goes to an [`EvaluationLog`] as soon
//! as its chunk of a batch is done (a few points per thread), and a restarted run replays what its
//! log holds, so nothing stored is recomputed.
//! A log belongs to one run hash (see `hash`); a log of another scene or other criteria is
//! refused.
//!
//! Implementations here: [`JsonLinesLog`] (a file: one header line, then one JSON line per
//! evaluation; a truncated last line from a crash while writing is dropped and that evaluation
//! redone) and [`MemoryLog`]. The service stores evaluations in its database instead.

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, SeekFrom, Write};
use std::path::PathBuf;
use std::sync::{Mutex, PoisonError};

use serde::{Deserialize, Serialize};

use crate::error::WsmError;
use crate::scenario::evaluator::Evaluation;
use crate::scene::CriterionSpec;

/// What identifies a run's evaluations: the first line of a log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogHeader {
    /// Always `wsm-evaluations`.
    pub format: String,
    /// Version of the log format, currently 1.
    pub version: u32,
    /// Hash of the scene and the criteria (`run::hash::run_hash`).
    pub run_hash: String,
    /// The scene's `name`, for people reading the log (the hash decides whether it matches).
    pub scene: String,
    /// The requested criteria, in the order of each evaluation's criteria values.
    pub criteria: Vec<CriterionSpec>,
    /// The field path of every parameter, in the order of each evaluation's `point`.
    pub parameters: Vec<String>,
}

impl LogHeader {
    /// The value of [`LogHeader::format`].
    pub const FORMAT: &'static str = "wsm-evaluations";

    /// The header of a version-1 log for the run with hash `run_hash`.
    pub fn new(
        run_hash: String,
        scene: String,
        criteria: Vec<CriterionSpec>,
        parameters: Vec<String>,
    ) -> LogHeader {
        LogHeader {
            format: Self::FORMAT.into(),
            version: 1,
            run_hash,
            scene,
            criteria,
            parameters,
        }
    }
}

/// Where a run's evaluations are stored.
pub trait EvaluationLog: Send + Sync {
    /// Start or continue the run described by `header`: the evaluations stored so far, oldest
    /// first (none for a new log). Refuses ([`WsmError::LogMismatch`]) a log of another run.
    fn open(&self, header: &LogHeader) -> Result<Vec<Evaluation>, WsmError>;

    /// Store the evaluations of one chunk of a batch, in input order, as soon as the chunk is
    /// done (a few points per thread: a crash loses at most the chunk in flight).
    fn append(&self, evaluations: &[Evaluation]) -> Result<(), WsmError>;
}

/// Evaluations kept in memory (tests, and the table of a run without a log file).
#[derive(Debug, Default)]
pub struct MemoryLog {
    evaluations: Mutex<Vec<Evaluation>>,
}

impl MemoryLog {
    /// An empty log.
    pub fn new() -> MemoryLog {
        MemoryLog::default()
    }

    /// Everything appended so far, in order.
    pub fn evaluations(&self) -> Vec<Evaluation> {
        self.evaluations
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }
}

impl EvaluationLog for MemoryLog {
    fn open(&self, _header: &LogHeader) -> Result<Vec<Evaluation>, WsmError> {
        Ok(Vec::new())
    }

    fn append(&self, evaluations: &[Evaluation]) -> Result<(), WsmError> {
        self.evaluations
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .extend_from_slice(evaluations);
        Ok(())
    }
}

/// Whether a log file is started afresh or continued.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogMode {
    /// A new log: refused when the file exists and is not empty (nothing is overwritten).
    Create,
    /// Replay the file, then append to it (a missing or empty file starts a new log).
    Resume,
}

/// A JSON-lines evaluation log file.
pub struct JsonLinesLog {
    path: PathBuf,
    mode: LogMode,
    state: Mutex<FileState>,
}

#[derive(Default)]
struct FileState {
    file: Option<File>,
    /// Every evaluation of the run: replayed, then appended.
    evaluations: Vec<Evaluation>,
}

impl JsonLinesLog {
    /// The log at `path`; the file is opened (and, for [`LogMode::Resume`], replayed) by
    /// [`EvaluationLog::open`].
    pub fn new(path: impl Into<PathBuf>, mode: LogMode) -> JsonLinesLog {
        JsonLinesLog {
            path: path.into(),
            mode,
            state: Mutex::new(FileState::default()),
        }
    }

    /// Every evaluation of the run so far (replayed and new), in log order.
    pub fn evaluations(&self) -> Vec<Evaluation> {
        self.lock().evaluations.clone()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, FileState> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn io(&self, reason: impl std::fmt::Display) -> WsmError {
        WsmError::io(self.path.display(), reason)
    }

    /// Read the header and the complete records; the byte length of the valid prefix.
    fn replay(&self, header: &LogHeader) -> Result<(Vec<Evaluation>, u64), WsmError> {
        let file = File::open(&self.path).map_err(|e| self.io(e))?;
        let mut reader = BufReader::new(file);
        let mut line = String::new();
        let mut valid = 0u64;
        let mut evaluations = Vec::new();
        let mut number = 0usize;
        loop {
            line.clear();
            let read = reader.read_line(&mut line).map_err(|e| self.io(e))?;
            if read == 0 {
                break;
            }
            number += 1;
            let complete = line.ends_with('\n');
            if number == 1 {
                if !complete {
                    // A crash while writing the header: nothing was logged yet.
                    return Ok((Vec::new(), 0));
                }
                let found: LogHeader = serde_json::from_str(line.trim_end()).map_err(|e| {
                    self.io(format!("line 1 is not a wsm evaluation log header: {e}"))
                })?;
                if found.format != LogHeader::FORMAT {
                    return Err(self.io(format!(
                        "line 1: format '{}' is not '{}'",
                        found.format,
                        LogHeader::FORMAT
                    )));
                }
                if found.run_hash != header.run_hash {
                    return Err(WsmError::LogMismatch {
                        path: self.path.display().to_string(),
                        expected: header.run_hash.clone(),
                        found: found.run_hash,
                    });
                }
            } else {
                match serde_json::from_str::<Evaluation>(line.trim_end()) {
                    Ok(e) if complete && e.point.len() == header.parameters.len() => {
                        evaluations.push(e)
                    }
                    // The last line of a log cut by a crash: that evaluation is redone.
                    _ if !complete => break,
                    Ok(_) => {
                        return Err(self.io(format!(
                            "line {number}: the point does not have {} parameters",
                            header.parameters.len()
                        )))
                    }
                    Err(e) => return Err(self.io(format!("line {number}: {e}"))),
                }
            }
            valid += read as u64;
        }
        Ok((evaluations, valid))
    }

    fn write_line(file: &mut File, value: &impl Serialize) -> Result<(), String> {
        let mut line = serde_json::to_string(value).map_err(|e| e.to_string())?;
        line.push('\n');
        // One write per line: a crash leaves at most the last line incomplete.
        file.write_all(line.as_bytes()).map_err(|e| e.to_string())
    }
}

impl EvaluationLog for JsonLinesLog {
    fn open(&self, header: &LogHeader) -> Result<Vec<Evaluation>, WsmError> {
        let existing = std::fs::metadata(&self.path).map(|m| m.len()).unwrap_or(0);
        let (evaluations, valid) = match self.mode {
            LogMode::Create if existing > 0 => {
                return Err(self.io(
                    "the log file exists and is not empty (resume it with --resume, or choose another file)",
                ))
            }
            LogMode::Resume if existing > 0 => self.replay(header)?,
            _ => (Vec::new(), 0),
        };
        let mut file = OpenOptions::new()
            .create(true)
            .write(true)
            .truncate(false)
            .open(&self.path)
            .map_err(|e| self.io(e))?;
        // Drop a cut last line before appending.
        file.set_len(valid).map_err(|e| self.io(e))?;
        file.seek(SeekFrom::End(0)).map_err(|e| self.io(e))?;
        if valid == 0 {
            Self::write_line(&mut file, header).map_err(|e| self.io(e))?;
        }
        let mut state = self.lock();
        state.file = Some(file);
        state.evaluations = evaluations.clone();
        Ok(evaluations)
    }

    fn append(&self, evaluations: &[Evaluation]) -> Result<(), WsmError> {
        let mut state = self.lock();
        let file = state
            .file
            .as_mut()
            .ok_or_else(|| self.io("the log was not opened"))?;
        for evaluation in evaluations {
            Self::write_line(file, evaluation).map_err(|e| self.io(e))?;
        }
        state.evaluations.extend_from_slice(evaluations);
        Ok(())
    }
}
