//! The single gate between the phases and the evaluator (design §4.3 items 4 and "Evaluations of
//! one generation run in parallel, are cached … and persisted"): every batch of unit-box points
//! is mapped to physical points, looked up in the [`EvalCache`], and only the points this run has
//! not seen are counted against the budget; only those missing from the cache are passed to the
//! evaluator, as one batch. The session also keeps the run's trace of distinct points, the best
//! value and the convergence history of every objective, checks wall time and cancellation
//! before each batch, and reports progress after it.
//!
//! A point restored from a pre-loaded cache counts against the budget like a fresh one (it was
//! paid for by the interrupted run), so a resumed run with the same seed makes exactly the same
//! decisions and reaches the same result without re-evaluating anything.

use super::cache::EvalCache;
use super::space::Space;
use super::{
    Answer, Evaluator, Objective, OneSided, Outcome, Phase, Progress, SearchControl, Sense, Status,
};
use std::collections::{HashMap, HashSet};
use std::sync::atomic::Ordering;
use std::sync::{Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

/// A batch was refused: the budget cannot take it, or the run is halted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("search stopped: {0:?}")]
pub(super) struct Stop(pub(super) Status);

impl Sense {
    /// The value turned so that larger is better.
    pub(super) fn score(self, value: f64) -> f64 {
        match self {
            Sense::Max => value,
            Sense::Min => -value,
        }
    }
}

/// One distinct point of this run: its unit coordinates and answer (`None` if infeasible).
struct Visit {
    unit: Vec<f64>,
    answer: Option<Answer>,
}

/// What the run knows at one evaluated point about one objective.
pub(super) struct Probe {
    /// Unit-box coordinates.
    pub(super) unit: Vec<f64>,
    /// The objective's criterion value.
    pub(super) value: f64,
    /// Its physical derivatives along every parameter, if the evaluator gave them.
    pub(super) slopes: Option<Vec<OneSided>>,
}

struct Ledger<'a> {
    cache: &'a mut EvalCache,
    /// Physical-point bits → index into `trace`.
    seen: HashMap<Vec<u64>, usize>,
    trace: Vec<Visit>,
    /// Visits without a criteria vector.
    failed: usize,
    fresh: usize,
    phase: Phase,
    /// Per objective: trace index of the best point.
    best: Vec<Option<usize>>,
    history: Vec<Vec<(usize, f64)>>,
    /// Per objective: where its local searches (vertex walk, ascents) ended (unit box).
    ends: Vec<Vec<Vec<f64>>>,
    halt: Option<Status>,
}

pub(super) struct Session<'a> {
    pub(super) space: &'a Space,
    objectives: &'a [Objective],
    evaluator: &'a dyn Evaluator,
    control: SearchControl<'a>,
    budget: usize,
    start: Instant,
    max_time: Option<Duration>,
    ledger: Mutex<Ledger<'a>>,
}

/// An evaluator answer holding a non-finite value (NaN, ±∞) is an error; derivatives that do
/// not give every criterion a finite slope along each of the `n` parameters are dropped (the
/// point then proves nothing, but its values stand).
fn sanitize(outcome: Outcome, n: usize) -> Outcome {
    outcome.and_then(|mut answer| {
        if !answer.values.iter().all(|v| v.is_finite()) {
            return Err(format!("non-finite criterion value in {:?}", answer.values));
        }
        let complete = answer.slopes.len() == answer.values.len()
            && answer.slopes.iter().all(|row| {
                row.len() == n
                    && row
                        .iter()
                        .all(|s| s.right.is_finite() && s.left.is_finite())
            });
        if !complete {
            answer.slopes.clear();
        }
        Ok(answer)
    })
}

impl<'a> Session<'a> {
    pub(super) fn new(
        space: &'a Space,
        objectives: &'a [Objective],
        evaluator: &'a dyn Evaluator,
        control: SearchControl<'a>,
        budget: usize,
        max_seconds: Option<f64>,
        cache: &'a mut EvalCache,
    ) -> Self {
        Session {
            space,
            objectives,
            evaluator,
            control,
            budget,
            start: Instant::now(),
            // An infinite (or unrepresentable) limit is no limit.
            max_time: max_seconds.and_then(|s| Duration::try_from_secs_f64(s.max(0.0)).ok()),
            ledger: Mutex::new(Ledger {
                cache,
                seen: HashMap::new(),
                trace: Vec::new(),
                failed: 0,
                fresh: 0,
                phase: Phase::Screening,
                best: vec![None; objectives.len()],
                history: vec![Vec::new(); objectives.len()],
                ends: vec![Vec::new(); objectives.len()],
                halt: None,
            }),
        }
    }

    fn ledger(&self) -> MutexGuard<'_, Ledger<'a>> {
        self.ledger.lock().unwrap_or_else(PoisonError::into_inner)
    }

    pub(super) fn budget(&self) -> usize {
        self.budget
    }

    pub(super) fn objectives(&self) -> &'a [Objective] {
        self.objectives
    }

    pub(super) fn elapsed(&self) -> Duration {
        self.start.elapsed()
    }

    /// Distinct points used by this run so far.
    pub(super) fn evaluations(&self) -> usize {
        self.ledger().trace.len()
    }

    /// Points passed to the evaluator by this run.
    pub(super) fn fresh_evaluations(&self) -> usize {
        self.ledger().fresh
    }

    pub(super) fn set_phase(&self, phase: Phase) {
        self.ledger().phase = phase;
    }

    /// Check cancellation and wall time now; the halt is sticky.
    pub(super) fn check_halt(&self) -> Option<Status> {
        let mut ledger = self.ledger();
        Self::update_halt(&mut ledger, self);
        ledger.halt
    }

    /// The halt recorded so far, without checking again.
    pub(super) fn halt(&self) -> Option<Status> {
        self.ledger().halt
    }

    fn update_halt(ledger: &mut Ledger<'a>, session: &Session<'a>) {
        if ledger.halt.is_none() {
            if session.control.cancel.load(Ordering::SeqCst) {
                ledger.halt = Some(Status::Cancelled);
            } else if session
                .max_time
                .is_some_and(|t| session.start.elapsed() >= t)
            {
                ledger.halt = Some(Status::TimeLimit);
            }
        }
    }

    /// Evaluate a batch of unit-box points, then report progress; returns their trace indices
    /// in input order.
    fn run_batch<U: AsRef<[f64]>>(&self, units: &[U]) -> Result<Vec<usize>, Stop> {
        let (indices, progress) = self.admit(units)?;
        (self.control.on_progress)(&progress);
        Ok(indices)
    }

    /// Under the lock: check halts and budget, evaluate what the cache lacks, record the points
    /// new to this run.
    fn admit<U: AsRef<[f64]>>(&self, units: &[U]) -> Result<(Vec<usize>, Progress), Stop> {
        let mut ledger = self.ledger();
        Self::update_halt(&mut ledger, self);
        if let Some(halt) = ledger.halt {
            return Err(Stop(halt));
        }
        let physical: Vec<Vec<f64>> = units
            .iter()
            .map(|u| self.space.to_physical(u.as_ref()))
            .collect();
        let keys: Vec<Vec<u64>> = physical
            .iter()
            .map(|p| p.iter().map(|x| x.to_bits()).collect())
            .collect();
        // The distinct points new to this run, in order of first appearance.
        let mut batch_keys = HashSet::new();
        let new: Vec<usize> = (0..keys.len())
            .filter(|&j| !ledger.seen.contains_key(&keys[j]) && batch_keys.insert(&keys[j]))
            .collect();
        if ledger.trace.len() + new.len() > self.budget {
            return Err(Stop(Status::BudgetExhausted));
        }
        let missing: Vec<Vec<f64>> = new
            .iter()
            .filter(|&&j| ledger.cache.get(&physical[j]).is_none())
            .map(|&j| physical[j].clone())
            .collect();
        // A batch halted part-way still records the points it evaluated (a partial result).
        let filled = self.fill_cache(&mut ledger, missing);
        for &j in &new {
            let Some(outcome) = ledger.cache.get(&physical[j]).cloned() else {
                continue;
            };
            let answer = sanitize(outcome, self.space.len()).ok();
            self.record(&mut ledger, units[j].as_ref().to_vec(), answer);
            let index = ledger.trace.len() - 1;
            ledger.seen.insert(keys[j].clone(), index);
        }
        filled?;
        let indices = keys
            .iter()
            .filter_map(|k| ledger.seen.get(k).copied())
            .collect();
        let progress = self.progress(&ledger, 0);
        Ok((indices, progress))
    }

    /// A progress report: the run's distinct points so far plus `pending` points of the batch
    /// under evaluation.
    fn progress(&self, ledger: &Ledger<'a>, pending: usize) -> Progress {
        Progress {
            evaluations: ledger.trace.len() + pending,
            budget: self.budget,
            phase: ledger.phase,
            best: (0..self.objectives.len())
                .map(|k| self.best_in(ledger, k).map(|(_, v)| v))
                .collect(),
            failures: ledger.failed,
        }
    }

    /// Evaluate `points` (distinct, not in the cache) and cache the answers, in chunks of a few
    /// points per thread so that cancellation and the time limit are honoured within a large
    /// batch, with a progress report after each chunk but the last (the batch reports that). The
    /// chunk size is asked again before each chunk: a dispatch sizes it by the solve times seen.
    fn fill_cache(&self, ledger: &mut Ledger<'a>, points: Vec<Vec<f64>>) -> Result<(), Stop> {
        let mut done = 0;
        while done < points.len() {
            if done > 0 {
                (self.control.on_progress)(&self.progress(ledger, done));
                Self::update_halt(ledger, self);
                if let Some(halt) = ledger.halt {
                    return Err(Stop(halt));
                }
            }
            let chunk = self.evaluator.chunk_size().max(1);
            let part = &points[done..(done + chunk).min(points.len())];
            let mut answers = self.evaluator.evaluate(part).into_iter();
            ledger.fresh += part.len();
            for point in part {
                let answer = answers.next().unwrap_or_else(|| {
                    Err("the evaluator returned fewer results than points".to_string())
                });
                ledger
                    .cache
                    .insert(point.clone(), sanitize(answer, self.space.len()));
            }
            done += part.len();
        }
        Ok(())
    }

    /// Append a visit to the trace and update every objective's best and history.
    fn record(&self, ledger: &mut Ledger<'a>, unit: Vec<f64>, answer: Option<Answer>) {
        let index = ledger.trace.len();
        for (k, objective) in self.objectives.iter().enumerate() {
            let Some(value) = answer.as_ref().and_then(|a| objective.value(&a.values)) else {
                continue;
            };
            let improves = self
                .best_in(ledger, k)
                .is_none_or(|(_, best)| objective.sense.score(value) > objective.sense.score(best));
            if improves {
                ledger.best[k] = Some(index);
                ledger.history[k].push((index + 1, value));
            }
        }
        ledger.failed += usize::from(answer.is_none());
        ledger.trace.push(Visit { unit, answer });
    }

    fn value_at(&self, ledger: &Ledger<'a>, k: usize, index: usize) -> Option<f64> {
        let answer = ledger.trace[index].answer.as_ref()?;
        self.objectives[k].value(&answer.values)
    }

    fn best_in(&self, ledger: &Ledger<'a>, k: usize) -> Option<(usize, f64)> {
        let index = ledger.best[k]?;
        Some((index, self.value_at(ledger, k, index)?))
    }

    /// Evaluate a batch (screening).
    pub(super) fn evaluate<U: AsRef<[f64]>>(&self, units: &[U]) -> Result<(), Stop> {
        self.run_batch(units).map(|_| ())
    }

    /// Evaluate a batch and return the trace indices of its points, in input order.
    pub(super) fn indices<U: AsRef<[f64]>>(&self, units: &[U]) -> Result<Vec<usize>, Stop> {
        self.run_batch(units)
    }

    /// Objective `k` at the trace point `index` (`None` where infeasible).
    pub(super) fn probe(&self, k: usize, index: usize) -> Option<Probe> {
        let ledger = self.ledger();
        let visit = &ledger.trace[index];
        let answer = visit.answer.as_ref()?;
        let criterion = self.objectives[k].criterion;
        Some(Probe {
            unit: visit.unit.clone(),
            value: self.objectives[k].value(&answer.values)?,
            slopes: answer.slopes.get(criterion).cloned(),
        })
    }

    /// Objective `k` at the evaluated points within `radius` (unit box) of `unit` that have
    /// derivatives, as (unit point, value, physical slopes).
    pub(super) fn neighbours(
        &self,
        k: usize,
        unit: &[f64],
        radius: f64,
    ) -> Vec<(Vec<f64>, f64, Vec<OneSided>)> {
        let ledger = self.ledger();
        let criterion = self.objectives[k].criterion;
        ledger
            .trace
            .iter()
            .filter(|visit| super::space::distance(&visit.unit, unit) <= radius)
            .filter_map(|visit| {
                let answer = visit.answer.as_ref()?;
                let value = self.objectives[k].value(&answer.values)?;
                let slopes = answer.slopes.get(criterion)?.clone();
                Some((visit.unit.clone(), value, slopes))
            })
            .collect()
    }

    /// Objective `k` at the evaluated unit point `unit` (`None` if not evaluated or infeasible).
    pub(super) fn probe_at(&self, k: usize, unit: &[f64]) -> Option<Probe> {
        let index = *self.ledger().seen.get(&self.key(unit))?;
        self.probe(k, index)
    }

    /// Whether this run has evaluated the unit point `unit` already.
    pub(super) fn has_seen(&self, unit: &[f64]) -> bool {
        self.ledger().seen.contains_key(&self.key(unit))
    }

    /// The key of a unit point in `seen`: the bits of its physical point.
    fn key(&self, unit: &[f64]) -> Vec<u64> {
        self.space
            .to_physical(unit)
            .iter()
            .map(|x| x.to_bits())
            .collect()
    }

    /// Objective `k` at every feasible point of this run, in order of evaluation.
    pub(super) fn feasible(&self, k: usize) -> Vec<Probe> {
        let count = self.evaluations();
        (0..count).filter_map(|i| self.probe(k, i)).collect()
    }

    /// Distinct vertices of the box evaluated by this run (feasible or not).
    pub(super) fn vertices_evaluated(&self) -> usize {
        self.ledger()
            .trace
            .iter()
            .filter(|visit| super::space::is_vertex(&visit.unit))
            .count()
    }

    /// Objective `k` at its best point so far.
    pub(super) fn best_probe(&self, k: usize) -> Option<Probe> {
        let index = self.ledger().best[k]?;
        self.probe(k, index)
    }

    /// Evaluate a batch and return the values of objective `k` (`None` where infeasible).
    pub(super) fn values<U: AsRef<[f64]>>(
        &self,
        units: &[U],
        k: usize,
    ) -> Result<Vec<Option<f64>>, Stop> {
        let indices = self.run_batch(units)?;
        let ledger = self.ledger();
        Ok(indices
            .into_iter()
            .map(|i| self.value_at(&ledger, k, i))
            .collect())
    }

    /// Best point (unit box) and value of objective `k` so far.
    pub(super) fn best(&self, k: usize) -> Option<(Vec<f64>, f64)> {
        let ledger = self.ledger();
        let (index, value) = self.best_in(&ledger, k)?;
        Some((ledger.trace[index].unit.clone(), value))
    }

    /// Feasible points of this run for objective `k` with their scores (larger is better),
    /// best first; ties keep the order of evaluation.
    pub(super) fn ranked(&self, k: usize) -> Vec<(Vec<f64>, f64)> {
        let ledger = self.ledger();
        let sense = self.objectives[k].sense;
        let mut points: Vec<(Vec<f64>, f64)> = (0..ledger.trace.len())
            .filter_map(|i| {
                let value = self.value_at(&ledger, k, i)?;
                Some((ledger.trace[i].unit.clone(), sense.score(value)))
            })
            .collect();
        points.sort_by(|a, b| b.1.total_cmp(&a.1));
        points
    }

    /// Note that a local search of objective `k` ended at the unit point `unit`.
    pub(super) fn note_end(&self, k: usize, unit: Vec<f64>) {
        self.ledger().ends[k].push(unit);
    }

    /// How many local searches of objective `k` have ended.
    pub(super) fn ends(&self, k: usize) -> usize {
        self.ledger().ends[k].len()
    }

    /// How many local searches of objective `k` ended within `tol` (unit box) of `unit`.
    pub(super) fn ends_near(&self, k: usize, unit: &[f64], tol: f64) -> usize {
        self.ledger().ends[k]
            .iter()
            .filter(|end| super::space::distance(end, unit) <= tol)
            .count()
    }

    pub(super) fn history(&self, k: usize) -> Vec<(usize, f64)> {
        self.ledger().history[k].clone()
    }
}

impl Objective {
    /// This objective's criterion in a feasible criteria vector (`None` if the vector is short).
    fn value(&self, criteria: &[f64]) -> Option<f64> {
        criteria.get(self.criterion).copied()
    }
}
