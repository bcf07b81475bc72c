//! `wsm._native`: the engine's front door (wsm-core's re-exports of its `run`, `scene` and `error`)
//! for the Python package (README "Python", design §5.7). Scenes, requests and results cross as
//! JSON text through the same serde types the command line and the service use, so a result's JSON
//! here is the CLI's, bit for bit; the pure-Python layer (`crates/python/python/wsm/`) turns it
//! into dicts, NumPy arrays and DataFrames.
//!
//! The GIL is released while the engine works. A worst-scenario run goes on in its own thread
//! while the calling thread waits without the GIL, hands progress events to a Python callback
//! and checks for signals: a Ctrl-C raises the run's cancel flag, the run stops within one
//! evaluation batch, and the `KeyboardInterrupt` is raised once it has. Point evaluations stop
//! between chunks the same way.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use wsm_core::{
    parse_scene, EvaluationLog, JsonLinesLog, LogMode, MemoryLog, PointEvaluator, ProgressEvent,
    RunControl, SceneError, SolveRequest, WorstRequest, WsmError,
};

pyo3::create_exception!(
    _native,
    NativeError,
    PyException,
    "An engine error: args are (message, kind, field path or None, exit code)."
);

/// How often the waiting thread looks at the run: progress, signals, the end.
const POLL: Duration = Duration::from_millis(100);

/// The engine's error as a Python exception carrying its kind, the field it names and the
/// command line's exit code (`wsm.WsmError` is built from these in Python).
fn raise(error: WsmError) -> PyErr {
    let kind = error.kind();
    NativeError::new_err((
        error.to_string(),
        kind.name(),
        error.path(),
        kind.exit_code(),
    ))
}

/// A JSON argument from the Python layer that does not read as `what`.
fn bad_json(what: &str, e: serde_json::Error) -> PyErr {
    raise(SceneError::new(what, e.to_string()).into())
}

fn to_json(value: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| raise(WsmError::io("JSON output", e)))
}

/// The names of the bundled examples.
#[pyfunction]
fn example_names() -> Vec<String> {
    wsm_core::example_names().map(String::from).collect()
}

/// The scene text of a bundled example.
#[pyfunction]
fn example(name: &str) -> PyResult<String> {
    wsm_core::find_example(name)
        .map(String::from)
        .map_err(raise)
}

/// Check a scene's text as every command does (repeated keys, fields, physics); the error
/// names the field.
#[pyfunction]
fn check_scene(scene: &str) -> PyResult<()> {
    parse_scene(scene).map(drop).map_err(|e| raise(e.into()))
}

/// One state solve: the JSON of the summary and, with `fields`, the fields; and with fields
/// the VTU document `wsm solve --vtu` writes.
#[pyfunction]
#[pyo3(signature = (scene, request))]
fn solve(py: Python<'_>, scene: &str, request: &str) -> PyResult<(String, Option<String>)> {
    let scene = parse_scene(scene).map_err(|e| raise(e.into()))?;
    let request: SolveRequest = serde_json::from_str(request).map_err(|e| bad_json("solver", e))?;
    let output = py
        .detach(|| wsm_core::solve(scene, &request))
        .map_err(raise)?;
    Ok((to_json(&output)?, output.vtu))
}

/// A worst-scenario run: `(outcome, printed, table, summary)` — the full outcome's JSON, the
/// JSON `wsm worst` prints (without histories), the CSV `wsm worst --table` writes and the
/// summary it prints on stderr. `log` starts
/// a JSON-lines evaluation log, `resume` continues one; `progress` is called with each progress
/// event's JSON.
#[pyfunction]
#[pyo3(signature = (scene, request, log=None, resume=None, progress=None))]
fn worst(
    py: Python<'_>,
    scene: &str,
    request: &str,
    log: Option<PathBuf>,
    resume: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, String, String, String)> {
    let scene = parse_scene(scene).map_err(|e| raise(e.into()))?;
    let request: WorstRequest =
        serde_json::from_str(request).map_err(|e| bad_json("request", e))?;
    let settings = request.settings(&scene).map_err(raise)?;
    let defined = scene.criteria.defined.clone();
    let (file_log, memory_log) = match (log, resume) {
        (Some(_), Some(_)) => {
            return Err(raise(
                SceneError::new("log", "give log for a new log or resume to continue one").into(),
            ))
        }
        (Some(p), None) => (Some(Arc::new(JsonLinesLog::new(&p, LogMode::Create))), None),
        (None, Some(p)) => (Some(Arc::new(JsonLinesLog::new(&p, LogMode::Resume))), None),
        (None, None) => (None, Some(Arc::new(MemoryLog::new()))),
    };
    let cancel = Arc::new(AtomicBool::new(false));
    let latest: Arc<Mutex<Option<ProgressEvent>>> = Arc::default();
    let sink = latest.clone();
    let mut control = RunControl::new().with_cancel(cancel.clone()).with_progress(
        move |event: &ProgressEvent| {
            *sink.lock().unwrap_or_else(PoisonError::into_inner) = Some(event.clone());
        },
    );
    control = match (&file_log, &memory_log) {
        (Some(log), _) => control.with_log(log.clone() as Arc<dyn EvaluationLog>),
        (None, Some(log)) => control.with_log(log.clone() as Arc<dyn EvaluationLog>),
        (None, None) => control,
    };
    let mut interrupted = None;
    let mut callback_error = None;
    let outcome = std::thread::scope(|s| {
        let (done, mut finished) = mpsc::channel();
        let (request, control) = (&request, &control);
        s.spawn(move || {
            // The receiver lives until the result arrives: the send cannot fail.
            let _ = done.send(wsm_core::worst(scene, request, control));
        });
        loop {
            // The receiver goes into the GIL-free wait and comes back (it is Send, not Sync).
            let waited;
            (waited, finished) = py.detach(move || (finished.recv_timeout(POLL), finished));
            let event = latest.lock().unwrap_or_else(PoisonError::into_inner).take();
            if let (Some(event), Some(callback), None) = (event, &progress, &callback_error) {
                let reported = to_json(&event).and_then(|json| callback.call1(py, (json,)));
                if let Err(e) = reported {
                    cancel.store(true, Ordering::SeqCst);
                    callback_error = Some(e);
                }
            }
            if interrupted.is_none() {
                if let Err(e) = py.check_signals() {
                    cancel.store(true, Ordering::SeqCst);
                    interrupted = Some(e);
                }
            }
            match waited {
                Ok(outcome) => break outcome,
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => {
                    break Err(WsmError::contact("the run's thread ended without a result"))
                }
            }
        }
    });
    if let Some(e) = interrupted.or(callback_error) {
        return Err(e);
    }
    let outcome = outcome.map_err(raise)?;
    let evaluations = match (&file_log, &memory_log) {
        (Some(log), _) => log.evaluations(),
        (None, Some(log)) => log.evaluations(),
        (None, None) => Vec::new(),
    };
    let mut table = Vec::new();
    wsm_core::write_csv(
        &mut table,
        "evaluations table",
        &outcome.parameters,
        &settings.criteria,
        &evaluations,
    )
    .map_err(raise)?;
    let table =
        String::from_utf8(table).map_err(|e| raise(WsmError::io("evaluations table", e)))?;
    let full = to_json(&outcome)?;
    let summary = wsm_core::summary(&outcome, &defined);
    let printed = serde_json::to_string_pretty(&outcome.without_histories())
        .map_err(|e| raise(WsmError::io("JSON output", e)))?;
    Ok((full, printed, table, summary))
}

/// A scene prepared for evaluations at the caller's points (`wsm.Evaluator`).
#[pyclass(frozen, module = "wsm._native")]
struct Evaluator {
    inner: PointEvaluator,
}

#[pymethods]
impl Evaluator {
    /// Mesh, assemble and solve `scene` at its nominal data for the criteria and derivatives
    /// of `request` (JSON of a worst request).
    #[new]
    fn new(py: Python<'_>, scene: &str, request: &str) -> PyResult<Evaluator> {
        let scene = parse_scene(scene).map_err(|e| raise(e.into()))?;
        let request: WorstRequest =
            serde_json::from_str(request).map_err(|e| bad_json("request", e))?;
        let inner = py
            .detach(|| PointEvaluator::new(scene, &request))
            .map_err(raise)?;
        Ok(Evaluator { inner })
    }

    /// JSON of `{parameters, criteria, derivatives}`: what a point is made of and what an
    /// answer holds.
    fn header(&self) -> PyResult<String> {
        to_json(&serde_json::json!({
            "parameters": self.inner.parameters(),
            "criteria": self.inner.criteria(),
            "derivatives": self.inner.derivatives(),
        }))
    }

    /// JSON of the answers at `points` (rows of physical values), in order, solved in
    /// parallel; `chunk` points at a time between checks for Ctrl-C.
    #[pyo3(signature = (points, chunk=64))]
    fn answer(&self, py: Python<'_>, points: Vec<Vec<f64>>, chunk: usize) -> PyResult<String> {
        let mut answers = Vec::with_capacity(points.len());
        for part in points.chunks(chunk.max(1)) {
            answers.extend(py.detach(|| self.inner.answer(part)).map_err(raise)?);
            py.check_signals()?;
        }
        to_json(&answers)
    }
}

/// The module `wsm._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("NativeError", m.py().get_type::<NativeError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(example_names, m)?)?;
    m.add_function(wrap_pyfunction!(example, m)?)?;
    m.add_function(wrap_pyfunction!(check_scene, m)?)?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(worst, m)?)?;
    m.add_class::<Evaluator>()?;
    Ok(())
}
