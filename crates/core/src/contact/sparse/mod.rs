//! The sparse contact path (design §3.1, "The sparse contact path"): a primal–dual active set
//! method (Hintermüller–Ito–Kunisch; Kunisch–Stadler for Tresca friction) on the primal
//! problem, every step one sparse factorisation ([`system`]), so memory is O(nnz of a factor)
//! instead of the dense path's O(pairs²). Chosen above [`AUTO_PAIRS`] pairs (or by
//! `solver.contact`).
//!
//! A set marks every row either free (its multiplier unknown, its gap or slip w_i = 0: an active
//! normal, a stuck tangential, a bilateral normal) or at a bound (λ_i = l_i or u_i, w_i
//! unknown). The step solves the set's linear problem exactly; the next set frees a bound row
//! whose w has the wrong sign (at the lower bound w ≤ 0 is required, at the upper w ≥ 0) and
//! bounds a free row whose multiplier left [l_i, u_i]. A set that repeats is a cycle and an
//! error, never a result. The start is the bonded, closed set (every row free) or the set of
//! a warm start.
//!
//! Floating bodies keep the dense path's formulation: u = ũ + R α with ũ solved on K pinned at
//! one DOF per rigid mode (off the pairs) and α from the balance of the pinned DOFs: the step
//! solves k + 1 right-hand sides with one factor, and the k × k matrix of their pinned
//! residuals gives α (pseudo-inverse for the motions no free row sees; the displacement is then
//! put into the dense path's normal form by the caller).

pub(crate) mod system;

use faer::{MatRef, Par};

use super::pairs::{pair_of_row, ContactGeometry};
use super::qp::WarmStart;
use crate::error::WsmError;
use system::{SetLoad, SparseSystem};

/// Contact pairs from which `solver.contact: auto` takes the sparse path.
pub const AUTO_PAIRS: usize = 1500;
/// Active-set steps at most.
const MAX_STEPS: usize = 200;
/// Relative tolerance of the sign tests of the set update (rounding of one exact solve).
const SIGN_TOL: f64 = 1e-12;
/// Relative residual of the pinned DOFs above which a set cannot balance a floating body.
const BALANCE_TOL: f64 = 1e-8;

/// Where a row's multiplier is in the set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Row {
    Free,
    Lower,
    Upper,
    /// No free part and no bound to meet: λ = 0.
    Zero,
}

/// The result of the active-set iteration.
#[derive(Debug, Clone)]
pub struct SparseOutcome {
    /// Displacement on the free DOFs.
    pub u: Vec<f64>,
    /// Per pair (normal, tangential) multipliers.
    pub multipliers: Vec<f64>,
    /// Rigid-body amplitudes of the floating bodies.
    pub rigid: Vec<f64>,
    /// Active-set steps (each one sparse factorisation).
    pub steps: usize,
    /// Rows that changed status over the steps.
    pub changes: usize,
    /// Relative accuracy of the last step's solve (its iterative-refinement correction).
    pub accuracy: f64,
}

/// Why the iteration returned no state.
#[derive(Debug, Clone)]
pub enum SparseFailure {
    /// The final set leaves a floating body's rigid mode `mode` unbalanced.
    Unbalanced {
        /// Index of the rigid mode.
        mode: usize,
        /// Its residual relative to the loads.
        residual: f64,
    },
    /// No set satisfies the sign conditions within the steps, or a set repeated.
    NotConverged(String),
    /// The factorisation failed.
    Solver(WsmError),
}

impl From<WsmError> for SparseFailure {
    fn from(e: WsmError) -> Self {
        SparseFailure::Solver(e)
    }
}

/// The data of one Tresca problem on the sparse path.
pub struct TrescaProblem<'a> {
    /// Pairs and rows of B.
    pub geometry: &'a ContactGeometry,
    /// Rigid modes of the floating bodies on the free DOFs (n × k).
    pub modes: MatRef<'a, f64>,
    /// K's lower-triangular values (unpinned).
    pub k_values: &'a [f64],
    /// Loads on the free DOFs.
    pub rhs: &'a [f64],
    /// Per row: B_d u_d − g0, so that w = B u + offsets.
    pub offsets: &'a [f64],
    /// Lower bounds of the multipliers.
    pub lower: &'a [f64],
    /// Upper bounds of the multipliers.
    pub upper: &'a [f64],
}

/// Solve the Tresca problem by the primal–dual active set method (module doc).
pub fn solve(
    system: &SparseSystem,
    p: &TrescaProblem,
    warm: Option<&WarmStart>,
    par: Par,
) -> Result<SparseOutcome, SparseFailure> {
    let m = p.geometry.dim();
    let mut rows: Vec<Row> = (0..m)
        .map(|i| initial_row(system.variable(i), p, i, warm))
        .collect();
    let mut seen = std::collections::HashSet::new();
    let mut changes = 0;
    for step in 1..=MAX_STEPS {
        let (mut states, accuracy) = solve_sets(system, &[p], &rows, par)?;
        let state = states
            .pop()
            .ok_or_else(|| SparseFailure::NotConverged("the step gave no solution".into()))?;
        let changed = update(system, p, &mut rows, &state);
        changes += changed;
        if changed == 0 {
            return finish(p, &rows, state, step, changes, accuracy);
        }
        if !seen.insert(rows.clone()) {
            return Err(SparseFailure::NotConverged(format!(
                "the active set cycles (step {step}, {changed} rows changing)"
            )));
        }
    }
    Err(SparseFailure::NotConverged(format!(
        "no active set satisfied the contact conditions within {MAX_STEPS} steps"
    )))
}

/// Solve problems whose sets are known — every row with a free part either unbounded (free)
/// or with equal bounds, the same rows free in all — with one factor for all of them (e.g. the
/// tangents of a strict active set along every data direction). A problem whose set would
/// change is an error.
pub fn solve_fixed(
    system: &SparseSystem,
    problems: &[TrescaProblem],
    par: Par,
) -> Result<Vec<SparseOutcome>, SparseFailure> {
    let Some(first) = problems.first() else {
        return Ok(Vec::new());
    };
    let m = first.geometry.dim();
    // Per row, whether it is free; None when a row could change its status.
    let set_of = |p: &TrescaProblem| -> Option<Vec<bool>> {
        (0..m)
            .map(|i| {
                let unbounded = p.lower[i] == f64::NEG_INFINITY && p.upper[i] == f64::INFINITY;
                let movable = system.variable(i) && !unbounded && p.lower[i] != p.upper[i];
                (!movable).then(|| initial_row(system.variable(i), p, i, None) == Row::Free)
            })
            .collect()
    };
    let first_set = set_of(first);
    if first_set.is_none() || problems.iter().any(|p| set_of(p) != first_set) {
        return Err(SparseFailure::NotConverged(
            "the problems of a fixed set differ in their sets, or a row could move".into(),
        ));
    }
    let rows: Vec<Row> = (0..m)
        .map(|i| initial_row(system.variable(i), first, i, None))
        .collect();
    let refs: Vec<&TrescaProblem> = problems.iter().collect();
    let (states, accuracy) = solve_sets(system, &refs, &rows, par)?;
    problems
        .iter()
        .zip(states)
        .map(|(p, state)| {
            let mut own = rows.clone();
            if update(system, p, &mut own, &state) != 0 {
                return Err(SparseFailure::NotConverged(
                    "a row of a fixed set left it".into(),
                ));
            }
            finish(p, &own, state, 1, 0, accuracy)
        })
        .collect()
}

/// One problem's state after a step: displacement, multipliers, rigid amplitudes, the
/// pinned DOFs' residual per rigid mode, and the gaps and slips.
struct StepState {
    u: Vec<f64>,
    multipliers: Vec<f64>,
    alpha: Vec<f64>,
    unbalance: Vec<f64>,
    w: Vec<f64>,
}

/// The multiplier of a row at a bound (0 for free and zero rows).
fn bound_value(p: &TrescaProblem, row: Row, i: usize) -> f64 {
    match row {
        Row::Lower => p.lower[i],
        Row::Upper => p.upper[i],
        Row::Free | Row::Zero => 0.0,
    }
}

/// Solve the set `rows` for every problem with one factor: per problem its loads (the bound
/// multipliers' forces taken off) and one right-hand side per rigid mode, then α from the
/// pinned DOFs' balance.
fn solve_sets(
    system: &SparseSystem,
    problems: &[&TrescaProblem],
    rows: &[Row],
    par: Par,
) -> Result<(Vec<StepState>, f64), SparseFailure> {
    let Some(first) = problems.first() else {
        return Ok((Vec::new(), 0.0));
    };
    let (geometry, modes) = (first.geometry, first.modes);
    let k = modes.ncols();
    let free: Vec<bool> = rows.iter().map(|r| *r == Row::Free).collect();
    let mode_rows: Vec<Vec<f64>> = (0..k)
        .map(|j| {
            geometry
                .rows
                .iter()
                .map(|row| row.free.iter().map(|&(i, c)| c * modes[(i, j)]).sum())
                .collect()
        })
        .collect();
    let mut set_loads = Vec::with_capacity(problems.len() * (k + 1));
    for p in problems {
        let mut loads = p.rhs.to_vec();
        for (i, row) in geometry.rows.iter().enumerate() {
            let l = bound_value(p, rows[i], i);
            if l != 0.0 {
                row.free.iter().for_each(|&(d, c)| loads[d] -= c * l);
            }
        }
        set_loads.push(SetLoad {
            loads,
            targets: p.offsets.iter().map(|o| -o).collect(),
        });
        set_loads.extend(mode_rows.iter().map(|br| SetLoad {
            loads: vec![0.0; p.rhs.len()],
            targets: br.iter().map(|v| -v).collect(),
        }));
    }
    let (solutions, accuracy) = system.solve_set(first.k_values, &free, &set_loads, par)?;
    let states = problems
        .iter()
        .zip(solutions.chunks(k + 1))
        .map(|(p, solutions)| {
            let (alpha, unbalance) = rigid_amplitudes(solutions);
            let mut u = solutions[0].u.clone();
            let mut multipliers = solutions[0].multipliers.clone();
            for (j, a) in alpha.iter().enumerate() {
                let sol = &solutions[j + 1];
                u.iter_mut()
                    .enumerate()
                    .for_each(|(i, ui)| *ui += a * (sol.u[i] + modes[(i, j)]));
                multipliers
                    .iter_mut()
                    .zip(&sol.multipliers)
                    .for_each(|(l, s)| *l += a * s);
            }
            for (i, l) in multipliers.iter_mut().enumerate() {
                if rows[i] != Row::Free {
                    *l = bound_value(p, rows[i], i);
                }
            }
            let w = geometry
                .rows
                .iter()
                .zip(p.offsets)
                .map(|(row, o)| row.dot(&u) + o)
                .collect();
            StepState {
                u,
                multipliers,
                alpha,
                unbalance,
                w,
            }
        })
        .collect();
    Ok((states, accuracy))
}

/// Tolerances of the sign tests: (multipliers, gaps and slips).
fn tolerances(p: &TrescaProblem, state: &StepState) -> (f64, f64) {
    let lambda = state
        .multipliers
        .iter()
        .fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()));
    let u_scale = state
        .u
        .iter()
        .chain(p.offsets)
        .fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()));
    (SIGN_TOL * lambda, SIGN_TOL * u_scale)
}

/// The next set from a step's state (module doc); returns how many rows changed.
fn update(system: &SparseSystem, p: &TrescaProblem, rows: &mut [Row], state: &StepState) -> usize {
    let (lambda_tol, w_tol) = tolerances(p, state);
    let (lambda, w) = (&state.multipliers, &state.w);
    let mut changed = 0;
    for (i, row) in rows.iter_mut().enumerate() {
        let movable = system.variable(i) && p.lower[i] < p.upper[i];
        let next = match *row {
            Row::Free if lambda[i] < p.lower[i] - lambda_tol => Row::Lower,
            Row::Free if lambda[i] > p.upper[i] + lambda_tol => Row::Upper,
            Row::Lower if movable && w[i] > w_tol => Row::Free,
            Row::Upper if movable && w[i] < -w_tol => Row::Free,
            same => same,
        };
        if next != *row {
            *row = next;
            changed += 1;
        }
    }
    changed
}

/// The outcome of a set that no longer changes, after the checks no sign test makes: a free row
/// dependent on others must hold, and floating bodies must be balanced.
fn finish(
    p: &TrescaProblem,
    rows: &[Row],
    state: StepState,
    steps: usize,
    changes: usize,
    accuracy: f64,
) -> Result<SparseOutcome, SparseFailure> {
    let (lambda_tol, w_tol) = tolerances(p, &state);
    let w = &state.w;
    // A free row dependent on others at a shared node was not imposed: it must hold.
    if let Some(i) = (0..w.len()).find(|&i| rows[i] == Row::Free && w[i].abs() > 1e3 * w_tol) {
        return Err(SparseFailure::NotConverged(format!(
            "the contact conditions of zone {} at a node shared with another pair are inconsistent (residual {:.1e} m)",
            p.geometry.pairs[pair_of_row(i)].zone,
            w[i].abs()
        )));
    }
    let f_scale = p.rhs.iter().fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()));
    if let Some((mode, residual)) = state
        .unbalance
        .iter()
        .enumerate()
        .map(|(j, r)| (j, r.abs() / f_scale.max(lambda_tol / SIGN_TOL)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .filter(|(_, r)| *r > BALANCE_TOL)
    {
        return Err(SparseFailure::Unbalanced { mode, residual });
    }
    Ok(SparseOutcome {
        u: state.u,
        multipliers: state.multipliers,
        rigid: state.alpha,
        steps,
        changes,
        accuracy,
    })
}

/// The first set: a warm start's, else every row with a free part free (bonded and closed).
fn initial_row(variable: bool, p: &TrescaProblem, i: usize, warm: Option<&WarmStart>) -> Row {
    let (l, u) = (p.lower[i], p.upper[i]);
    if !variable {
        // w = offsets: a multiplier at the bound its sign pushes to, 0 without one.
        let w = p.offsets[i];
        return match () {
            _ if w > 0.0 && u.is_finite() => Row::Upper,
            _ if w < 0.0 && l.is_finite() => Row::Lower,
            _ if l == 0.0 => Row::Lower,
            _ if u == 0.0 => Row::Upper,
            _ => Row::Zero,
        };
    }
    if l == u {
        return Row::Lower;
    }
    match warm.and_then(|w| w.x.get(i)) {
        Some(&x) if x <= l => Row::Lower,
        Some(&x) if x >= u => Row::Upper,
        _ => Row::Free,
    }
}

/// α with Σ α_j ρ_j = −ρ₀ (least squares, minimum norm), and the residual ρ₀ + P α per mode.
fn rigid_amplitudes(solutions: &[system::SetSolution]) -> (Vec<f64>, Vec<f64>) {
    let k = solutions.len() - 1;
    if k == 0 {
        return (Vec::new(), Vec::new());
    }
    let rho0 = &solutions[0].pinned_residual;
    let p = faer::Mat::<f64>::from_fn(k, k, |i, j| solutions[j + 1].pinned_residual[i]);
    let alpha = match p.thin_svd() {
        Ok(svd) => {
            let (s, u, v) = (svd.S().column_vector(), svd.U(), svd.V());
            let cut = 1e-10 * (0..k).fold(0.0_f64, |a, i| a.max(s[i]));
            let mut alpha = vec![0.0; k];
            for c in 0..k {
                if s[c] <= cut {
                    continue;
                }
                let coef = -(0..k).map(|i| u[(i, c)] * rho0[i]).sum::<f64>() / s[c];
                alpha
                    .iter_mut()
                    .enumerate()
                    .for_each(|(j, a)| *a += coef * v[(j, c)]);
            }
            alpha
        }
        Err(_) => vec![0.0; k],
    };
    let residual = (0..k)
        .map(|i| rho0[i] + (0..k).map(|j| p[(i, j)] * alpha[j]).sum::<f64>())
        .collect();
    (alpha, residual)
}
