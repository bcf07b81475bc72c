//! End-to-end tests of the search (design §4.3) on analytic criteria.

use super::*;
use rayon::prelude::*;
use std::collections::HashSet;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Duration;

type Criteria = Result<Vec<f64>, String>;

/// An analytic evaluator that runs each batch in parallel and counts what it is asked.
struct Analytic<F> {
    f: F,
    calls: AtomicUsize,
    batches: AtomicUsize,
    seen: Mutex<HashSet<Vec<u64>>>,
    repeats: AtomicUsize,
    delay: Duration,
}

impl<F: Fn(&[f64]) -> Criteria + Sync> Analytic<F> {
    fn new(f: F) -> Self {
        Analytic {
            f,
            calls: AtomicUsize::new(0),
            batches: AtomicUsize::new(0),
            seen: Mutex::new(HashSet::new()),
            repeats: AtomicUsize::new(0),
            delay: Duration::ZERO,
        }
    }

    fn calls(&self) -> usize {
        self.calls.load(Ordering::SeqCst)
    }
}

impl<F: Fn(&[f64]) -> Criteria + Sync> Evaluator for Analytic<F> {
    fn evaluate(&self, points: &[Vec<f64>]) -> Vec<Outcome> {
        self.calls.fetch_add(points.len(), Ordering::SeqCst);
        self.batches.fetch_add(1, Ordering::SeqCst);
        {
            let mut seen = self.seen.lock().unwrap();
            for p in points {
                if !seen.insert(p.iter().map(|x| x.to_bits()).collect()) {
                    self.repeats.fetch_add(1, Ordering::SeqCst);
                }
            }
        }
        std::thread::sleep(self.delay);
        points
            .par_iter()
            .map(|p| (self.f)(p).map(Answer::from))
            .collect()
    }
}

fn problem(bounds: Vec<[f64; 2]>, objectives: &[(usize, Sense)], budget: usize) -> SearchProblem {
    SearchProblem {
        bounds,
        objectives: objectives
            .iter()
            .map(|&(criterion, sense)| Objective { criterion, sense })
            .collect(),
        budget,
        max_seconds: None,
        seed: 2024,
        names: Vec::new(),
        stop: StopRule::GlobalRule,
    }
}

fn run(p: &SearchProblem, e: &dyn Evaluator) -> SearchResult {
    search(p, e, &mut EvalCache::new(), SearchControl::default()).unwrap()
}

/// Everything but the wall time and the count of fresh evaluations, bit for bit.
fn fingerprint(r: &SearchResult) -> String {
    format!("{:?} {:?} {}", r.status, r.objectives, r.evaluations)
}

fn cache_fingerprint(c: &EvalCache) -> String {
    format!("{:?}", c.iter().collect::<Vec<_>>())
}

// ---- (a) monotone criterion: the extrema are vertices, found exactly ----

fn monotone(p: &[f64]) -> Criteria {
    Ok(vec![p[0] / p[1] + p[2]])
}

fn monotone_problem() -> SearchProblem {
    problem(
        vec![[1.0, 3.0], [0.5, 2.0], [-1.0, 4.0]],
        &[(0, Sense::Max), (0, Sense::Min)],
        400,
    )
}

#[test]
fn monotone_criterion_is_extremal_at_exact_vertices() {
    let e = Analytic::new(monotone);
    let r = run(&monotone_problem(), &e);
    let (max, min) = (&r.objectives[0], &r.objectives[1]);
    assert_eq!(max.point, Some(vec![3.0, 0.5, 4.0]));
    assert_eq!(max.value, Some(10.0));
    assert_eq!(min.point, Some(vec![1.0, 2.0, -1.0]));
    assert_eq!(min.value, Some(-0.5));
    for o in [max, min] {
        assert!(o.at_vertex && o.vertex_optimal && !o.several_optima);
        assert_eq!(o.optima.len(), 1);
    }
    use ActiveBound::{Lower, Upper};
    assert_eq!(max.active_bounds, vec![Upper, Lower, Upper]);
    assert_eq!(min.active_bounds, vec![Lower, Upper, Lower]);
    // S_i ≈ ∂Φ/∂p_i (hi − lo) / |Φ| at the maximiser (3, 0.5, 4), Φ = 10.
    let s: Vec<f64> = max.sensitivities.iter().map(|s| s.unwrap()).collect();
    assert!((s[0] - 2.0 * 2.0 / 10.0).abs() < 1e-2, "{s:?}");
    assert!((s[1] + 12.0 * 1.5 / 10.0).abs() < 0.1, "{s:?}");
    assert!((s[2] - 5.0 / 10.0).abs() < 1e-9, "{s:?}");
    // The history starts with the first evaluation and ends at the optimum.
    assert_eq!(max.history.first().unwrap().0, 1);
    assert_eq!(max.history.last().unwrap().1, 10.0);
    assert!(max
        .history
        .windows(2)
        .all(|w| w[0].0 < w[1].0 && w[0].1 < w[1].1));
    assert!(r.evaluations <= 400 && e.calls() == r.evaluations);
    assert_eq!(r.status, Status::Completed);
    println!(
        "(a) monotone: {} evaluations, status {:?}",
        r.evaluations, r.status
    );
}

// ---- (b) smooth multimodal criterion with an interior maximum ----

const PEAK: [f64; 2] = [0.3137, 0.6421];

fn gaussians(u: [f64; 2]) -> f64 {
    let g = |c: [f64; 2], s: f64, h: f64| {
        h * (-((u[0] - c[0]).powi(2) + (u[1] - c[1]).powi(2)) / (2.0 * s * s)).exp()
    };
    g(PEAK, 0.08, 1.0) + g([0.75, 0.25], 0.1, 0.8) + g([0.2, 0.15], 0.05, 0.5)
}

/// The criterion in physical units of very different sizes: x in [0, 1e5] Pa, y in
/// [-1e-3, 1e-3] m.
const MULTIMODAL_BOX: [[f64; 2]; 2] = [[0.0, 1e5], [-1e-3, 1e-3]];

fn multimodal(p: &[f64]) -> Criteria {
    Ok(vec![gaussians([p[0] / 1e5, (p[1] + 1e-3) / 2e-3])])
}

#[test]
fn interior_maximum_beats_the_grid_with_a_fifth_of_its_evaluations() {
    let e = Analytic::new(multimodal);
    let r = run(
        &problem(MULTIMODAL_BOX.to_vec(), &[(0, Sense::Max)], 336),
        &e,
    );
    let o = &r.objectives[0];
    let best = o.value.unwrap();
    // The other peaks lift the top by ~3e-8 only; the top is attained within ~1e-7 of PEAK.
    let truth = gaussians(PEAK);
    let grid = (0..41)
        .flat_map(|i| (0..41).map(move |j| gaussians([i as f64 / 40.0, j as f64 / 40.0])))
        .fold(f64::MIN, f64::max);
    println!(
        "(b) {} evaluations, best {best:.12} (truth {truth:.12}, rel err {:.1e}), grid {grid:.12}, \
         status {:?}",
        r.evaluations,
        (best - truth).abs() / truth,
        r.status
    );
    assert!(e.calls() <= 336 && r.evaluations <= 336);
    assert!((best - truth).abs() <= 1e-6 * truth);
    assert!(best >= grid);
    assert!(
        best >= truth * (1.0 - 1e-9),
        "the polish stops at a 1e-9 flat poll"
    );
    let x = o.point.as_ref().unwrap();
    assert!((x[0] / 1e5 - PEAK[0]).abs() < 1e-4 && ((x[1] + 1e-3) / 2e-3 - PEAK[1]).abs() < 1e-4);
    assert!(!o.at_vertex && !o.vertex_optimal && !o.several_optima);
    assert_eq!(o.active_bounds, vec![ActiveBound::None; 2]);
    // At an interior maximum both one-sided slopes point down, by O(h / σ²) ≈ 0.08.
    assert!(o
        .sensitivities
        .iter()
        .all(|s| (-0.1..0.0).contains(&s.unwrap())));
}

#[test]
fn interior_maximum_is_found_for_many_seeds() {
    let mut worst: f64 = 0.0;
    for seed in 0..40 {
        let e = Analytic::new(multimodal);
        let mut p = problem(MULTIMODAL_BOX.to_vec(), &[(0, Sense::Max)], 336);
        p.seed = seed;
        let best = run(&p, &e).objectives[0].value.unwrap();
        worst = worst.max((gaussians(PEAK) - best) / gaussians(PEAK));
    }
    println!("(b) worst relative error over 40 seeds: {worst:.1e}");
    assert!(worst <= 1e-6);
}

// ---- (c) budget, cache, resumption ----

#[test]
fn budget_is_never_exceeded_and_repeats_are_free() {
    for budget in [0, 1, 2, 7, 50, 97, 336, 1000] {
        let e = Analytic::new(multimodal);
        let p = problem(
            MULTIMODAL_BOX.to_vec(),
            &[(0, Sense::Max), (0, Sense::Min)],
            budget,
        );
        let r = run(&p, &e);
        assert!(e.calls() <= budget, "budget {budget}: {} calls", e.calls());
        assert_eq!(e.calls(), r.evaluations);
        assert_eq!(e.calls(), r.new_evaluations);
        assert_eq!(e.repeats.load(Ordering::SeqCst), 0);
        if budget == 0 {
            assert_eq!(r.status, Status::BudgetExhausted);
            assert_eq!(r.objectives[0].value, None);
        }
    }
}

#[test]
fn resumed_run_reuses_the_cache_and_reaches_the_same_result() {
    let p = problem(
        MULTIMODAL_BOX.to_vec(),
        &[(0, Sense::Max), (0, Sense::Min)],
        400,
    );
    let full_eval = Analytic::new(multimodal);
    let mut full_cache = EvalCache::new();
    let full = search(&p, &full_eval, &mut full_cache, SearchControl::default()).unwrap();

    // Same job again from its own persisted evaluations: nothing new is evaluated.
    let mut restored = EvalCache::new();
    for (x, o) in full_cache.iter() {
        restored.insert(x.to_vec(), o.clone());
    }
    let again_eval = Analytic::new(multimodal);
    let again = search(&p, &again_eval, &mut restored, SearchControl::default()).unwrap();
    assert_eq!(again_eval.calls(), 0);
    assert_eq!(again.new_evaluations, 0);
    assert_eq!(fingerprint(&again), fingerprint(&full));

    // Interrupted after ~150 evaluations, then resumed from what it had persisted.
    let cancel = AtomicBool::new(false);
    let stop_at_150 = |pr: &Progress| {
        if pr.evaluations >= 150 {
            cancel.store(true, Ordering::SeqCst);
        }
    };
    let control = SearchControl {
        cancel: &cancel,
        on_progress: &stop_at_150,
    };
    let mut partial_cache = EvalCache::new();
    let first = Analytic::new(multimodal);
    let partial = search(&p, &first, &mut partial_cache, control).unwrap();
    assert_eq!(partial.status, Status::Cancelled);
    let second = Analytic::new(multimodal);
    let resumed = search(&p, &second, &mut partial_cache, SearchControl::default()).unwrap();
    println!(
        "(c) full run {} evaluations; interrupted at {}, resumed with {} new",
        full.evaluations,
        partial.evaluations,
        second.calls()
    );
    assert!(partial.evaluations >= 150 && partial.evaluations < full.evaluations);
    assert_eq!(second.calls(), full.evaluations - partial.evaluations);
    assert_eq!(fingerprint(&resumed), fingerprint(&full));
    assert_eq!(
        cache_fingerprint(&partial_cache),
        cache_fingerprint(&full_cache)
    );
}

// ---- (d) cancellation and time limit ----

#[test]
fn cancellation_stops_before_the_next_batch() {
    let cancel = AtomicBool::new(false);
    let at_cancel = AtomicUsize::new(0);
    let e = Analytic::new(|p: &[f64]| monotone(p));
    let on_progress = |pr: &Progress| {
        if pr.evaluations >= 60 && !cancel.load(Ordering::SeqCst) {
            at_cancel.store(e.batches.load(Ordering::SeqCst), Ordering::SeqCst);
            cancel.store(true, Ordering::SeqCst);
        }
    };
    let control = SearchControl {
        cancel: &cancel,
        on_progress: &on_progress,
    };
    let r = search(&monotone_problem(), &e, &mut EvalCache::new(), control).unwrap();
    assert_eq!(r.status, Status::Cancelled);
    assert_eq!(
        e.batches.load(Ordering::SeqCst),
        at_cancel.load(Ordering::SeqCst)
    );
    assert!(r.evaluations < 400);
    // The partial result still holds the best found so far.
    assert!(r.objectives[0].value.is_some());
    assert!(r.objectives.iter().all(|o| o.status == Status::Cancelled));

    // Raised before the start: nothing is evaluated.
    let e = Analytic::new(monotone);
    let control = SearchControl {
        cancel: &AtomicBool::new(true),
        on_progress: &|_| {},
    };
    let r = search(&monotone_problem(), &e, &mut EvalCache::new(), control).unwrap();
    assert_eq!((r.status, e.calls()), (Status::Cancelled, 0));
}

#[test]
fn time_limit_is_respected() {
    let mut e = Analytic::new(multimodal);
    e.delay = Duration::from_millis(20);
    let mut p = problem(MULTIMODAL_BOX.to_vec(), &[(0, Sense::Max)], 5000);
    p.max_seconds = Some(0.2);
    let r = run(&p, &e);
    println!(
        "(d) time limit 0.2 s: stopped after {:?}, {} evaluations",
        r.elapsed, r.evaluations
    );
    assert_eq!(r.status, Status::TimeLimit);
    assert!(r.elapsed >= Duration::from_millis(200));
    // Stopped at the limit, not after the budget (5000 × 20 ms = 100 s): the limit, one
    // evaluation in flight and room for a loaded 2-core machine.
    assert!(r.elapsed < Duration::from_millis(200 + 20 + 1000));
    assert!(r.objectives[0].value.is_some());
    // An infinite limit is no limit.
    p.max_seconds = Some(f64::INFINITY);
    p.budget = 50;
    e.delay = Duration::ZERO;
    assert_ne!(run(&p, &e).status, Status::TimeLimit);
}

// ---- (e) determinism ----

#[test]
fn results_are_identical_whatever_the_thread_count() {
    let p = problem(
        vec![[0.0, 1e5], [-1e-3, 1e-3], [3.0, 3.0]],
        &[(0, Sense::Max), (0, Sense::Min), (1, Sense::Max)],
        500,
    );
    let f = |x: &[f64]| -> Criteria {
        let g = multimodal(x)?[0];
        Ok(vec![
            g,
            (x[0] / 1e5 - 0.4).sin() * (x[1] * 3e3).cos() * x[2],
        ])
    };
    let once = || {
        let e = Analytic::new(f);
        let mut cache = EvalCache::new();
        let r = search(&p, &e, &mut cache, SearchControl::default()).unwrap();
        (fingerprint(&r), cache_fingerprint(&cache))
    };
    let reference = once();
    assert_eq!(once(), reference);
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        assert_eq!(pool.install(once), reference, "{threads} threads");
    }
    // Another seed explores differently.
    let mut q = p.clone();
    q.seed += 1;
    let other = search(
        &q,
        &Analytic::new(f),
        &mut EvalCache::new(),
        SearchControl::default(),
    )
    .unwrap();
    assert_ne!(fingerprint(&other), reference.0);
}

// ---- (f) failed evaluations ----

#[test]
fn failures_and_nan_are_infeasible_and_never_optimal() {
    // Φ = x + y on [0, 1]²: fails where x + y > 1.5, NaN near (1, 0) and (0, 1).
    let f = |p: &[f64]| -> Criteria {
        let (x, y) = (p[0], p[1]);
        if x + y > 1.5 {
            Err(format!("no convergence at {p:?}"))
        } else if (x - y).abs() > 0.8 {
            Ok(vec![f64::NAN])
        } else {
            Ok(vec![x + y])
        }
    };
    let e = Analytic::new(f);
    let mut cache = EvalCache::new();
    let r = search(
        &problem(vec![[0.0, 1.0]; 2], &[(0, Sense::Max)], 300),
        &e,
        &mut cache,
        SearchControl::default(),
    )
    .unwrap();
    let o = &r.objectives[0];
    let (best, x) = (o.value.unwrap(), o.point.clone().unwrap());
    // The compass crawls along the oblique edge of the feasible set.
    assert!(best <= 1.5 && best > 1.5 - 1e-4, "{best}");
    assert_eq!(f(&x), Ok(vec![best]));
    let failed = cache.iter().filter(|(_, o)| o.is_err()).count();
    assert!(
        failed > 0
            && cache
                .iter()
                .any(|(_, o)| o.as_ref().is_err_and(|m| m.contains("non-finite")))
    );

    // Nothing feasible at all, and a criteria vector too short for the objective.
    let e = Analytic::new(|_: &[f64]| -> Criteria { Err("always".into()) });
    let r = run(&problem(vec![[0.0, 1.0]; 2], &[(0, Sense::Max)], 50), &e);
    assert_eq!(r.objectives[0].value, None);
    assert_eq!(r.objectives[0].point, None);
    let e = Analytic::new(|p: &[f64]| -> Criteria { Ok(vec![p[0]]) });
    let r = run(
        &problem(vec![[0.0, 1.0]], &[(0, Sense::Max), (3, Sense::Max)], 60),
        &e,
    );
    assert_eq!(r.objectives[0].value, Some(1.0));
    assert_eq!(r.objectives[1].value, None);
    // Invalid problems are refused before any evaluation.
    let bad = problem(vec![[0.0, 1.0], [2.0, 1.0]], &[(0, Sense::Max)], 60);
    assert!(matches!(
        search(&bad, &e, &mut EvalCache::new(), SearchControl::default()),
        Err(SearchError::InvalidBounds { index: 1, .. })
    ));
    let none = problem(vec![[0.0, 1.0]], &[], 60);
    assert_eq!(
        search(&none, &e, &mut EvalCache::new(), SearchControl::default()),
        Err(SearchError::NoObjectives)
    );
}

// ---- (g) fixed parameters, one and zero dimensions ----

#[test]
fn fixed_parameters_and_low_dimensions() {
    let f = |p: &[f64]| -> Criteria { Ok(vec![p[0] * p[2] - (p[1] - 0.3).powi(2)]) };
    let e = Analytic::new(f);
    let r = run(
        &problem(
            vec![[2.0, 2.0], [0.0, 1.0], [5.0, 5.0]],
            &[(0, Sense::Max)],
            200,
        ),
        &e,
    );
    let o = &r.objectives[0];
    let x = o.point.clone().unwrap();
    assert_eq!((x[0], x[2]), (2.0, 5.0));
    // Φ is flat to 1e-9 relative within ~1e-4 of the maximiser.
    assert!((x[1] - 0.3).abs() < 1e-3, "{x:?}");
    assert!(o.value.unwrap() > 10.0 - 1e-8);
    use ActiveBound::{Fixed, None as Free};
    assert_eq!(o.active_bounds, vec![Fixed, Free, Fixed]);
    assert_eq!(o.sensitivities[0], None);
    assert_eq!(o.sensitivities[2], None);
    assert!(o.sensitivities[1].unwrap().abs() < 1e-3);

    let e = Analytic::new(|p: &[f64]| -> Criteria { Ok(vec![(3.0 * p[0]).sin()]) });
    let r = run(&problem(vec![[0.0, 1.0]], &[(0, Sense::Max)], 100), &e);
    let x = r.objectives[0].point.clone().unwrap()[0];
    assert!((x - std::f64::consts::PI / 6.0).abs() < 1e-3, "{x}");
    assert!(r.objectives[0].value.unwrap() > 1.0 - 1e-9, "{r:?}");

    for bounds in [vec![], vec![[1.0, 1.0], [2.0, 2.0]]] {
        let e = Analytic::new(|p: &[f64]| -> Criteria { Ok(vec![p.iter().sum::<f64>() + 1.0]) });
        let n = bounds.len();
        let r = run(
            &problem(bounds, &[(0, Sense::Max), (0, Sense::Min)], 10),
            &e,
        );
        assert_eq!(e.calls(), 1);
        assert_eq!(r.status, Status::Completed);
        for o in &r.objectives {
            assert_eq!(o.value, Some(if n == 0 { 1.0 } else { 4.0 }));
            assert!(o.at_vertex && o.vertex_optimal && !o.several_optima);
            assert_eq!(o.sensitivities, vec![None; n]);
        }
    }
}

// ---- (h) several maximisers ----

#[test]
fn two_equal_peaks_are_both_reported() {
    // Φ = 10 − (x² − 1)² − y² on [−2, 2] × [−1, 1]: maxima 10 at (±1, 0).
    let f = |p: &[f64]| -> Criteria { Ok(vec![10.0 - (p[0] * p[0] - 1.0).powi(2) - p[1] * p[1]]) };
    let e = Analytic::new(f);
    let r = run(
        &problem(vec![[-2.0, 2.0], [-1.0, 1.0]], &[(0, Sense::Max)], 600),
        &e,
    );
    let o = &r.objectives[0];
    println!(
        "(h) {} evaluations, optima {:?}, best {:?}",
        r.evaluations, o.optima, o.value
    );
    assert!(o.several_optima);
    assert_eq!(o.optima.len(), 2);
    let mut xs: Vec<f64> = o.optima.iter().map(|x| x[0]).collect();
    xs.sort_by(f64::total_cmp);
    assert!(
        (xs[0] + 1.0).abs() < 1e-3 && (xs[1] - 1.0).abs() < 1e-3,
        "{xs:?}"
    );
    assert!(o.optima.iter().all(|x| x[1].abs() < 1e-3));
}

// ---- progress reports ----

#[test]
fn progress_is_reported_after_every_batch() {
    let reports = Mutex::new(Vec::<Progress>::new());
    let record = |p: &Progress| reports.lock().unwrap().push(p.clone());
    let control = SearchControl {
        cancel: &AtomicBool::new(false),
        on_progress: &record,
    };
    let e = Analytic::new(monotone);
    let r = search(&monotone_problem(), &e, &mut EvalCache::new(), control).unwrap();
    let reports = reports.into_inner().unwrap();
    assert!(reports.len() >= e.batches.load(Ordering::SeqCst));
    assert_eq!(reports[0].phase, Phase::Screening);
    // 2^3 vertices, the centre, and a Latin hypercube up to 400 / 5 points, in one batch
    // (reported chunk by chunk while it is evaluated).
    let mut screening = reports.iter().filter(|p| p.phase == Phase::Screening);
    assert_eq!(screening.next_back().map(|p| p.evaluations), Some(80));
    assert!(reports
        .windows(2)
        .all(|w| w[0].evaluations <= w[1].evaluations));
    let phases: Vec<Phase> = reports.iter().map(|p| p.phase).collect();
    for phase in [
        Phase::Global { objective: 0 },
        Phase::Polish { objective: 1 },
        Phase::Sensitivity,
    ] {
        assert!(phases.contains(&phase), "{phase:?}");
    }
    let last = reports.last().unwrap();
    assert_eq!((last.evaluations, last.budget), (r.evaluations, 400));
    assert_eq!(last.best, vec![Some(10.0), Some(-0.5)]);
}

// ---- exact derivatives: vertex walk and certificates ----

/// Values and exact gradients (one row per criterion, one entry per parameter).
type Smooth = (Vec<f64>, Vec<Vec<f64>>);

/// An evaluator that gives exact derivatives with its values.
struct WithSlopes<F> {
    f: F,
    calls: AtomicUsize,
}

impl<F: Fn(&[f64]) -> Smooth + Sync> WithSlopes<F> {
    fn new(f: F) -> Self {
        WithSlopes {
            f,
            calls: AtomicUsize::new(0),
        }
    }
}

impl<F: Fn(&[f64]) -> Smooth + Sync> Evaluator for WithSlopes<F> {
    fn evaluate(&self, points: &[Vec<f64>]) -> Vec<Outcome> {
        self.calls.fetch_add(points.len(), Ordering::SeqCst);
        points
            .iter()
            .map(|p| {
                let (values, gradients) = (self.f)(p);
                let slopes = gradients
                    .into_iter()
                    .map(|g| g.into_iter().map(OneSided::both).collect())
                    .collect();
                Ok(Answer { values, slopes })
            })
            .collect()
    }

    fn gives_derivatives(&self) -> bool {
        true
    }
}

#[test]
fn monotone_criteria_are_certified_at_their_vertices_by_the_walk() {
    // Φ0 = p0 + 2 p1 − p2 (linear), Φ1 = e^{p0} p1 / p2 (monotone, nonlinear) on a box with a
    // fixed datum p3: every extremum at a vertex, found by the centre and one vertex each.
    let f = |p: &[f64]| -> Smooth {
        let e = p[0].exp() * p[1] / p[2];
        (
            vec![p[0] + 2.0 * p[1] - p[2], e],
            vec![vec![1.0, 2.0, -1.0, 0.0], vec![e, e / p[1], -e / p[2], 0.0]],
        )
    };
    let bounds = vec![[0.0, 1.0], [1.0, 3.0], [2.0, 4.0], [7.0, 7.0]];
    let objectives = [
        (0, Sense::Max),
        (0, Sense::Min),
        (1, Sense::Max),
        (1, Sense::Min),
    ];
    let e = WithSlopes::new(f);
    let first = SearchProblem {
        stop: StopRule::FirstCertificate,
        ..problem(bounds.clone(), &objectives, 200)
    };
    let r = run(&first, &e);
    // The centre, then two distinct vertices (each criterion's max and min share them).
    assert_eq!(r.evaluations, 3);
    assert_eq!(e.calls.load(Ordering::SeqCst), 3);
    assert_eq!(r.status, Status::LocallyCertified);
    for o in &r.objectives {
        assert!(!o.global.rule_met, "{:?}", o.global);
        assert!(
            o.global.summary.contains("first local certificate"),
            "{}",
            o.global.summary
        );
    }
    // With the global rule the same extrema, now with evidence: the 8 vertices of the 3 free
    // data (each locally optimal vertex found at no extra cost) and two rounds of four random
    // starts, each of whose ascents climbs to the one optimum in a single step onto a cached
    // vertex — N = 8 starts, W = 1 optimum, 1·7/5 − 1 = 0.4 < ½ optima estimated unseen.
    let global = run(&problem(bounds, &objectives, 200), &e);
    assert_eq!(global.evaluations, 3 + 6 + 8);
    for (o, f) in global.objectives.iter().zip(&r.objectives) {
        assert_eq!((o.point.as_ref(), o.value), (f.point.as_ref(), f.value));
        assert_eq!(o.status, Status::LocallyCertified);
        let g = &o.global;
        assert!(g.rule_met, "{g:?}");
        assert_eq!((g.vertices_screened, g.vertices_total), (8, Some(8)));
        assert_eq!(
            (g.random_starts, g.random_optima, g.local_optima),
            (8, 1, 1)
        );
        assert!((g.unseen_estimate.unwrap() - 0.4).abs() < 1e-12);
        assert_eq!(g.runner_up, None);
        assert!(
            g.summary.starts_with("global rule met: 8 of 8 vertices"),
            "{}",
            g.summary
        );
    }
    let max = vec![1.0, 3.0, 2.0, 7.0];
    let min = vec![0.0, 1.0, 4.0, 7.0];
    for (o, vertex) in r.objectives.iter().zip([&max, &min, &max, &min]) {
        assert_eq!(o.status, Status::LocallyCertified);
        assert_eq!(o.point.as_ref(), Some(vertex));
        let value = f(vertex).0[o.criterion];
        assert_eq!(o.value, Some(value));
        let c = o.certificate.as_ref().unwrap();
        assert_eq!(
            (c.verdict, c.residual),
            (Verdict::LocallyCertified, Some(0.0))
        );
        assert_eq!(c.starts, 1, "the vertex walk ended there");
        // Every free datum is on a bound, each held by the slope's sign (≤ 0 proves a max).
        assert_eq!(c.active.len(), 3);
        let sign = if o.sense == Sense::Max { 1.0 } else { -1.0 };
        assert!(c.active.iter().all(|b| sign * b.rate < 0.0), "{c:?}");
        // Gradient and normalised sensitivities are the exact ones at the vertex, keyed by
        // parameter (unnamed here: θ<index>), and so is the point.
        let g = &f(vertex).1[o.criterion];
        let keyed = |v: Vec<(usize, f64)>| -> Vec<(String, f64)> {
            v.into_iter().map(|(i, x)| (format!("θ{i}"), x)).collect()
        };
        let gradient: Vec<(String, f64)> = o
            .gradient
            .iter()
            .map(|(n, s)| (n.clone(), s.right))
            .collect();
        assert_eq!(gradient, keyed(g.iter().copied().enumerate().collect()));
        assert!(o.gradient.values().all(OneSided::is_differentiable));
        let data: Vec<(String, f64)> = o.data.iter().map(|(n, x)| (n.clone(), *x)).collect();
        assert_eq!(data, keyed(vertex.iter().copied().enumerate().collect()));
        let s0 = g[0] * 1.0 / value.abs();
        assert!((o.sensitivities[0].unwrap() - s0).abs() <= 1e-15 * s0.abs());
        assert_eq!(o.sensitivities[3], None);
    }
}

#[test]
fn an_interior_maximum_is_found_by_the_safeguard_and_certified() {
    // Φ = 2 − (p0 − 0.3)² − (p1 − 0.7)²: the slope of p0 changes sign between the centre and
    // the vertex it points to, so the walk settles nothing and the global phases run.
    let f = |p: &[f64]| -> Smooth {
        let (a, b) = (p[0] - 0.3, p[1] - 0.7);
        (vec![2.0 - a * a - b * b], vec![vec![-2.0 * a, -2.0 * b]])
    };
    let e = WithSlopes::new(f);
    let r = run(
        &problem(vec![[0.0, 1.0], [0.0, 1.0]], &[(0, Sense::Max)], 300),
        &e,
    );
    let o = &r.objectives[0];
    println!(
        "interior: {} evaluations, {:?}",
        r.evaluations, o.certificate
    );
    assert!(r.evaluations > 3, "the global phases ran");
    let x = o.point.as_ref().unwrap();
    assert!(
        (x[0] - 0.3).abs() < 1e-6 && (x[1] - 0.7).abs() < 1e-6,
        "{x:?}"
    );
    assert_eq!(o.status, Status::LocallyCertified);
    assert!(o.active_bounds.iter().all(|b| *b == ActiveBound::None));
    let proof = o.certificate.as_ref().unwrap();
    assert!(proof.active.is_empty());
    assert!(
        proof.starts >= 1,
        "an ascent ended at the maximum: {proof:?}"
    );
}

#[test]
fn a_walk_that_fails_proves_nothing() {
    // Monotone Φ = p0 + p1, but the vertex the centre points to is infeasible: the walk cannot
    // settle, the other phases run, and the best feasible point is what they find.
    let f = |p: &[f64]| -> Smooth { (vec![p[0] + p[1]], vec![vec![1.0, 1.0]]) };
    struct Holed<E>(E);
    impl<E: Evaluator> Evaluator for Holed<E> {
        fn evaluate(&self, points: &[Vec<f64>]) -> Vec<Outcome> {
            let mut out = self.0.evaluate(points);
            for (p, o) in points.iter().zip(out.iter_mut()) {
                if p[0] == 1.0 && p[1] == 1.0 {
                    *o = Err("diverged".into());
                }
            }
            out
        }
        fn gives_derivatives(&self) -> bool {
            true
        }
    }
    let e = Holed(WithSlopes::new(f));
    let r = run(
        &problem(vec![[0.0, 1.0], [0.0, 1.0]], &[(0, Sense::Max)], 200),
        &e,
    );
    let o = &r.objectives[0];
    assert!(r.evaluations > 2);
    assert!(o.value.unwrap() < 2.0);
    assert_ne!(o.status, Status::LocallyCertified, "{:?}", o.certificate);
    assert_eq!(o.certificate.as_ref().unwrap().verdict, Verdict::NotOptimal);
}

#[test]
fn the_global_rule_finds_the_better_of_two_separated_maxima_and_reports_the_runner_up() {
    // Φ = p0 + p1 + 2 exp(−(p1 / 0.15)²) on [0, 1]²: along p1 a narrow peak near 0 and a ramp
    // to 1. The centre's slope along p1 points to 1, where the vertex (1, 1) is a local maximum
    // (Φ = 2, certified by its signs); the global maximum Φ ≈ 3 sits just inside p1 = 0.
    let bump = |t: f64| 2.0 * (-(t / 0.15).powi(2)).exp();
    let f = move |p: &[f64]| -> Smooth {
        let slope = 1.0 - 2.0 * p[1] / 0.0225 * bump(p[1]);
        (vec![p[0] + p[1] + bump(p[1])], vec![vec![1.0, slope]])
    };
    // The maximiser along p1 solves 1 = (2 t / 0.0225) · bump(t) (Newton from 0).
    let mut t = 0.0_f64;
    for _ in 0..50 {
        let g = 1.0 - 2.0 * t / 0.0225 * bump(t);
        let dg = -(2.0 / 0.0225) * bump(t) * (1.0 - 2.0 * t * t / 0.0225);
        t -= g / dg;
    }
    let peak = 1.0 + t + bump(t);
    let bounds = vec![[0.0, 1.0], [0.0, 1.0]];
    let e = WithSlopes::new(f);
    let first = run(
        &SearchProblem {
            stop: StopRule::FirstCertificate,
            ..problem(bounds.clone(), &[(0, Sense::Max)], 200)
        },
        &e,
    );
    let o = &first.objectives[0];
    assert_eq!(o.point, Some(vec![1.0, 1.0]), "the walk's local maximum");
    assert_eq!(o.status, Status::LocallyCertified);
    assert!(!o.global.rule_met);

    let r = run(&problem(bounds, &[(0, Sense::Max)], 200), &e);
    let o = &r.objectives[0];
    let x = o.point.as_ref().unwrap();
    assert!((o.value.unwrap() - peak).abs() <= 1e-9 * peak, "{o:?}");
    assert!(x[0] == 1.0 && (x[1] - t).abs() < 1e-4, "{x:?} vs p1 = {t}");
    assert_eq!(o.status, Status::LocallyCertified);
    let g = &o.global;
    assert!(g.rule_met, "{g:?}");
    assert_eq!(g.local_optima, 2, "{g:?}");
    let runner = g
        .runner_up
        .as_ref()
        .expect("the vertex maximum is the runner-up");
    assert_eq!((runner.point.clone(), runner.value), (vec![1.0, 1.0], 2.0));
    assert!(runner.locally_certified);
    assert!((runner.gap - (peak - 2.0) / peak).abs() < 1e-12);
    println!("{} evaluations: {}", r.evaluations, g.summary);
}

#[test]
fn an_ascent_closes_in_on_a_failure_region_and_ends_unsettled_next_to_it() {
    // Φ = p0 + p1 rises towards (1, 1), but the solver fails for p1 > 0.75: the maximum borders
    // the failure region, where no derivative can certify it.
    let f = |p: &[f64]| -> Smooth { (vec![p[0] + p[1]], vec![vec![1.0, 1.0]]) };
    struct Walled<E>(E);
    impl<E: Evaluator> Evaluator for Walled<E> {
        fn evaluate(&self, points: &[Vec<f64>]) -> Vec<Outcome> {
            let mut out = self.0.evaluate(points);
            for (p, o) in points.iter().zip(out.iter_mut()) {
                if p[1] > 0.75 {
                    *o = Err("no answer".into());
                }
            }
            out
        }
        fn gives_derivatives(&self) -> bool {
            true
        }
    }
    let e = Walled(WithSlopes::new(f));
    let r = run(
        &SearchProblem {
            stop: StopRule::FirstCertificate,
            ..problem(vec![[0.0, 1.0], [0.0, 1.0]], &[(0, Sense::Max)], 60)
        },
        &e,
    );
    let o = &r.objectives[0];
    let x = o.point.as_ref().unwrap();
    println!("{} evaluations, {x:?}, {:?}", r.evaluations, o.status);
    assert_eq!(x[0], 1.0);
    assert!(x[1] <= 0.75 && x[1] > 0.75 - 1e-3, "{x:?}");
    // Never certified, so the search looks on until its budget is spent.
    assert_eq!(o.status, Status::BudgetExhausted);
    assert_eq!(r.evaluations, 60);
}
