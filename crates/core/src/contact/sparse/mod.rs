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

use super::pairs::ContactGeometry;
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
    let (m, k) = (p.geometry.dim(), p.modes.ncols());
    let variable = |i: usize| system.variable(i);
    let mut rows: Vec<Row> = (0..m)
        .map(|i| initial_row(variable(i), p, i, warm))
        .collect();
    let mode_rows: Vec<Vec<f64>> = (0..k)
        .map(|j| {
            p.geometry
                .rows
                .iter()
                .map(|row| row.free.iter().map(|&(i, c)| c * p.modes[(i, j)]).sum())
                .collect()
        })
        .collect();
    let f_scale = p.rhs.iter().fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()));
    let mut seen = std::collections::HashSet::new();
    let mut changes = 0;
    for step in 1..=MAX_STEPS {
        let free: Vec<bool> = rows.iter().map(|r| *r == Row::Free).collect();
        let bound = |i: usize| match rows[i] {
            Row::Lower => p.lower[i],
            Row::Upper => p.upper[i],
            Row::Free | Row::Zero => 0.0,
        };
        let mut loads = p.rhs.to_vec();
        for (i, row) in p.geometry.rows.iter().enumerate() {
            let l = bound(i);
            if l != 0.0 {
                row.free.iter().for_each(|&(d, c)| loads[d] -= c * l);
            }
        }
        let mut set_loads = vec![SetLoad {
            loads,
            targets: p.offsets.iter().map(|o| -o).collect(),
        }];
        set_loads.extend(mode_rows.iter().map(|br| SetLoad {
            loads: vec![0.0; p.rhs.len()],
            targets: br.iter().map(|v| -v).collect(),
        }));
        let (solutions, accuracy) = system.solve_set(p.k_values, &free, &set_loads, par)?;
        let (alpha, unbalance) = rigid_amplitudes(&solutions);
        let mut u = solutions[0].u.clone();
        let mut multipliers = solutions[0].multipliers.clone();
        for (j, a) in alpha.iter().enumerate() {
            let sol = &solutions[j + 1];
            u.iter_mut()
                .enumerate()
                .for_each(|(i, ui)| *ui += a * (sol.u[i] + p.modes[(i, j)]));
            multipliers
                .iter_mut()
                .zip(&sol.multipliers)
                .for_each(|(l, s)| *l += a * s);
        }
        for (i, l) in multipliers.iter_mut().enumerate() {
            if rows[i] != Row::Free {
                *l = bound(i);
            }
        }
        let w: Vec<f64> = p
            .geometry
            .rows
            .iter()
            .zip(p.offsets)
            .map(|(row, o)| row.dot(&u) + o)
            .collect();
        let lambda_tol = SIGN_TOL
            * multipliers
                .iter()
                .fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()));
        let u_scale = u
            .iter()
            .chain(p.offsets)
            .fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()));
        let w_tol = SIGN_TOL * u_scale;
        let mut changed = 0;
        for i in 0..m {
            let next = match rows[i] {
                Row::Free if multipliers[i] < p.lower[i] - lambda_tol => Row::Lower,
                Row::Free if multipliers[i] > p.upper[i] + lambda_tol => Row::Upper,
                Row::Lower if variable(i) && p.lower[i] < p.upper[i] && w[i] > w_tol => Row::Free,
                Row::Upper if variable(i) && p.lower[i] < p.upper[i] && w[i] < -w_tol => Row::Free,
                same => same,
            };
            if next != rows[i] {
                rows[i] = next;
                changed += 1;
            }
        }
        changes += changed;
        if changed == 0 {
            // A free row dependent on others at a shared node was not imposed: it must hold.
            if let Some(i) = (0..m).find(|&i| rows[i] == Row::Free && w[i].abs() > 1e3 * w_tol) {
                return Err(SparseFailure::NotConverged(format!(
                    "the contact conditions of zone {} at a node shared with another pair are inconsistent (residual {:.1e} m)",
                    p.geometry.pairs[i / 2].zone,
                    w[i].abs()
                )));
            }
            if let Some((mode, residual)) = unbalance
                .iter()
                .enumerate()
                .map(|(j, r)| (j, r.abs() / f_scale.max(lambda_tol / SIGN_TOL)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .filter(|(_, r)| *r > BALANCE_TOL)
            {
                return Err(SparseFailure::Unbalanced { mode, residual });
            }
            return Ok(SparseOutcome {
                u,
                multipliers,
                rigid: alpha,
                steps: step,
                changes,
                accuracy,
            });
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
