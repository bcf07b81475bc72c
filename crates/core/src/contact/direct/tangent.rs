//! Directional derivatives of the contact state (design §4.4): the derivative of the solution of
//! the condensed contact problem along a data direction, on the converged active set.
//!
//! At the solution λ of min ½λᵀCλ − λᵀd over the box l ≤ λ ≤ u with Gλ = e, and with
//! w = d − Cλ + Gᵀα the gaps and slips, a change of the data by ε changes K u = f − Bᵀλ (+ R α)
//! to first order by K du = b − Bᵀ dλ with b = df − dK u (the derivative of the equilibrium
//! residual at fixed u, λ). The one-sided derivative (dλ, dα) along +ε solves the tangent QP
//! (the directional derivative of a parametric QP, e.g. Bonnans–Shapiro, *Perturbation Analysis
//! of Optimization Problems*, §5.2):
//!
//! ```text
//!   min ½ dλᵀ C dλ − dλᵀ d'   d' = B P K⁺ P b + B_d du_d,   G dλ = Rᵀ b,
//!   free rows (l < λ < u): dλ unconstrained;   strictly active rows (λ at a bound, w ≠ 0):
//!   dλ = d(bound);   weakly active rows (λ at a bound, w = 0): dλ ≥ dl (or ≤ du);
//!   rows with l = u: dl ≤ dλ ≤ du.
//! ```
//!
//! Then du = P K⁺ P (b − Bᵀ dλ) + R dα, with the same normal form along undetermined rigid
//! motions as the state itself. Without weakly active rows the derivative is linear in the
//! direction (the state is differentiable) and the derivative along −ε is minus that along +ε;
//! with them it is computed separately and the state is only one-sided differentiable.
//! C and the factors of K are those of the state solve: a derivative costs one projected solve
//! with K, one with K for the recovery, and one QP on the (mostly fixed) active set; the solves
//! of all directions are made together, as one multi-right-hand-side solve each.
//!
//! Coulomb zones (design §3.4): the converged state is the fixed point λ = S(D, F λ_n) of the
//! Tresca solution map, so the bound of a slipping pair moves with the state, dλ_t = ±(dF λ_n +
//! F dλ_n). The tangent problem is then no longer a box QP but, on a strict active set, the
//! linear system of its optimality conditions: (C dλ − Gᵀ dα)_r = d'_r on free rows, dλ_r =
//! d(bound) on strictly active Tresca rows, dλ_t ∓ F dλ_n = ±dF λ_n on slipping Coulomb rows
//! (dF λ_n is the bound derivative the data give at fixed λ), dλ_t = 0 on open pairs, and
//! G dλ = Rᵀ b; solved by a pseudo-inverse (rigid motions no row sees are undetermined and
//! removed afterwards, as for the state). A Coulomb state with a weakly active row (a grazing
//! pair, or a pair at the stick/slip transition) is not differentiable and no derivative is
//! given for it.

use super::{DirectContact, StiffnessFactor};
use crate::contact::pairs::{is_tangential_row, normal_row, pair_of_row, ContactRow};
use crate::contact::qp::{solve_box_qp, BoxQp, QpOptions, WarmStart};
use crate::error::WsmError;
use crate::fem::rigid::remove_components;
use faer::Mat;

/// Relative distance of a multiplier to its bound below which it is on the bound.
const AT_BOUND_TOL: f64 = 1e-10;
/// Relative size of a gap or slip below which an active row is weakly active.
const WEAK_TOL: f64 = 1e-9;
/// Relative size of the load on a rigid mode below which it is rounding.
const ROUNDING_TOL: f64 = 1e-12;

/// How a multiplier may move in the tangent problem.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum RowMotion {
    /// Strictly inside its bounds: free.
    Free,
    /// Strictly active at the lower bound: follows it.
    Lower,
    /// Strictly active at the upper bound: follows it.
    Upper,
    /// Weakly active at the lower bound: may leave it upwards.
    WeakLower,
    /// Weakly active at the upper bound: may leave it downwards.
    WeakUpper,
    /// Both bounds coincide: stays between their derivatives.
    Pinched,
}

/// The converged contact state a derivative is taken at.
pub struct ContactPoint<'a> {
    /// Multipliers λ.
    pub multipliers: &'a [f64],
    /// Gaps and slips w = B u + B_d u_d − g0.
    pub gaps: &'a [f64],
    /// Lower multiplier bounds of the data.
    pub lower: &'a [f64],
    /// Upper multiplier bounds of the data (on Coulomb pairs ±F λ_n at the state).
    pub upper: &'a [f64],
    /// Per pair, the Coulomb friction coefficient F of its zone (`None`: Tresca or bilateral).
    pub friction: &'a [Option<f64>],
    /// Largest displacement component (the scale of gaps and slips).
    pub displacement_scale: f64,
}

/// The data derivative of one direction, as seen by the contact problem.
pub struct DataDerivative<'a> {
    /// b = df − dK u on the free DOFs.
    pub residual: &'a [f64],
    /// Derivative of the prescribed values u_d.
    pub fixed: &'a [f64],
    /// Derivatives of the lower and upper multiplier bounds (0 for infinite bounds).
    pub lower: &'a [f64],
    /// See `lower`.
    pub upper: &'a [f64],
}

/// One data derivative taken along +ε (`sign` 1) or −ε (`sign` −1), with its right-hand
/// sides signed: what a tangent problem of one direction is solved for.
struct SignedDirection<'a> {
    /// The derivative of the data.
    derivative: &'a DataDerivative<'a>,
    /// +1 or −1.
    sign: f64,
    /// sign · P K⁺ P b.
    x0: Vec<f64>,
    /// sign · b.
    b: Vec<f64>,
    /// sign · du_d.
    fixed: Vec<f64>,
}

impl SignedDirection<'_> {
    /// d_r = B_r x0 + B_r^d du_d: the rate of `row`'s gap at fixed multipliers.
    fn gap_rate(&self, row: &ContactRow) -> f64 {
        row.dot(&self.x0) + row.dot_fixed(&self.fixed)
    }

    /// The signed derivatives of row `r`'s lower and upper multiplier bounds.
    fn bound_rates(&self, r: usize) -> (f64, f64) {
        (
            self.sign * self.derivative.lower[r],
            self.sign * self.derivative.upper[r],
        )
    }
}

/// The derivative of the displacement on the free DOFs along +ε and, when the state is only
/// one-sided differentiable, along −ε.
pub struct TangentDisplacement {
    /// du along +ε.
    pub plus: Vec<f64>,
    /// du along −ε (the change per unit decrease of the parameter); `None` when it is −`plus`.
    pub minus: Option<Vec<f64>>,
    /// dλ along +ε, by row of B.
    pub plus_multipliers: Vec<f64>,
    /// dλ along −ε, with `minus`.
    pub minus_multipliers: Option<Vec<f64>>,
}

impl DirectContact {
    /// The derivatives of the contact solution (`multipliers`, `gaps` of the state with bounds
    /// `lower`, `upper`) along each data derivative of `directions`, with the state's factor:
    /// the solves with K of all directions are made together (one multi-right-hand-side solve
    /// for d', one for the recovery), the tangent QPs one by one.
    pub fn tangents(
        &self,
        factor: &StiffnessFactor,
        state: &ContactPoint,
        directions: &[DataDerivative],
    ) -> Result<Vec<TangentDisplacement>, WsmError> {
        let Some(first) = directions.first() else {
            return Ok(Vec::new());
        };
        if let Some(system) = &self.sparse {
            return self.sparse_tangents(system, factor, state, directions);
        }
        let n = first.residual.len();
        let motions = classify(state);
        let coulomb = state.friction.iter().any(Option::is_some);
        if coulomb {
            check_differentiable(&motions, directions)?;
        }
        let free_motions = self
            .kernel
            .free_motions(&self.geometry, state.lower, state.upper)?;
        // x0 = P K⁺ P b of every direction; along −ε it is −x0.
        let mut x0: Vec<f64> = directions
            .iter()
            .flat_map(|dd| dd.residual.iter().copied())
            .collect();
        if self.geometry.dim() > 0 || self.kernel_dim() > 0 {
            self.projected_solve_columns(factor, &mut x0, directions.len());
        }
        let x0: Vec<&[f64]> = x0.chunks_exact(n.max(1)).collect();
        let signed = |v: &[f64], sign: f64| v.iter().map(|x| sign * x).collect::<Vec<f64>>();
        // (b, dλ, dα) of one direction and sign.
        let multipliers = |j: usize, sign: f64| -> Result<[Vec<f64>; 3], WsmError> {
            let derivative = &directions[j];
            let direction = SignedDirection {
                derivative,
                sign,
                x0: signed(x0.get(j).copied().unwrap_or(&[]), sign),
                b: signed(derivative.residual, sign),
                fixed: signed(derivative.fixed, sign),
            };
            let (dlambda, dalpha) = if coulomb {
                self.coulomb_tangent(factor, &motions, state, &direction)?
            } else {
                self.tangent_multipliers(factor, &motions, &direction)?
            };
            Ok([direction.b, dlambda, dalpha])
        };
        let recover = |states: &[[Vec<f64>; 3]]| -> Vec<Vec<f64>> {
            let views: Vec<(&[f64], &[f64], &[f64])> = states
                .iter()
                .map(|[b, l, a]| (b.as_slice(), l.as_slice(), a.as_slice()))
                .collect();
            let mut du = self.recover_all(factor, &views);
            for u in &mut du {
                remove_components(free_motions.as_ref(), u);
            }
            du
        };
        let plus_states: Vec<[Vec<f64>; 3]> = (0..directions.len())
            .map(|j| multipliers(j, 1.0))
            .collect::<Result<_, _>>()?;
        let plus = recover(&plus_states);
        plus.into_iter()
            .zip(plus_states)
            .enumerate()
            .map(|(j, (plus, [_, plus_multipliers, _]))| {
                let dd = &directions[j];
                let weak = motions.iter().enumerate().any(|(r, m)| match m {
                    RowMotion::WeakLower | RowMotion::WeakUpper => true,
                    RowMotion::Pinched => dd.lower[r] != dd.upper[r],
                    _ => false,
                });
                let (minus, minus_multipliers) = if weak {
                    let state = multipliers(j, -1.0)?;
                    let minus = recover(std::slice::from_ref(&state)).pop();
                    let [_, dlambda, _] = state;
                    (minus, Some(dlambda))
                } else {
                    (None, None)
                };
                Ok(TangentDisplacement {
                    plus,
                    minus,
                    plus_multipliers,
                    minus_multipliers,
                })
            })
            .collect()
    }

    /// (dλ, dα) of the tangent QP for the signed data derivative (`x0` = P K⁺ P b).
    fn tangent_multipliers(
        &self,
        factor: &StiffnessFactor,
        motions: &[RowMotion],
        direction: &SignedDirection,
    ) -> Result<(Vec<f64>, Vec<f64>), WsmError> {
        let m = self.geometry.dim();
        if m == 0 && self.kernel_dim() == 0 {
            return Ok((Vec::new(), Vec::new()));
        }
        let d: Vec<f64> = self
            .geometry
            .rows
            .iter()
            .map(|row| direction.gap_rate(row))
            .collect();
        let (lo, hi) = tangent_bounds(motions, direction.derivative, direction.sign);
        let (g, e) = self.tangent_equilibrium(&direction.b);
        let start = WarmStart {
            x: lo
                .iter()
                .zip(&hi)
                .map(|(l, h)| 0.0_f64.clamp(*l, *h))
                .collect(),
            alpha: Vec::new(),
        };
        let problem = BoxQp::new(factor.c.clone(), d, lo, hi).with_equalities(g, e);
        let sol = solve_box_qp(&problem, Some(&start), &QpOptions::default())
            .map_err(|err| WsmError::contact(format!("sensitivity of the contact state: {err}")))?;
        Ok((sol.x, sol.alpha))
    }
}

/// The bounds of the multiplier derivatives along the signed direction (module doc): free rows
/// unconstrained, strictly active ones following their bound, weakly active ones one-sided.
pub(crate) fn tangent_bounds(
    motions: &[RowMotion],
    dd: &DataDerivative,
    sign: f64,
) -> (Vec<f64>, Vec<f64>) {
    let (inf, ninf) = (f64::INFINITY, f64::NEG_INFINITY);
    motions
        .iter()
        .enumerate()
        .map(|(r, motion)| {
            let (dl, du) = (sign * dd.lower[r], sign * dd.upper[r]);
            match motion {
                RowMotion::Free => (ninf, inf),
                RowMotion::Lower => (dl, dl),
                RowMotion::Upper => (du, du),
                RowMotion::WeakLower => (dl, inf),
                RowMotion::WeakUpper => (ninf, du),
                RowMotion::Pinched => (dl.min(du), du.max(dl)),
            }
        })
        .unzip()
}

/// A Coulomb state is differentiable only on a strict active set: no weakly active row, no
/// pinched row whose bounds move apart.
fn check_differentiable(
    motions: &[RowMotion],
    directions: &[DataDerivative],
) -> Result<(), WsmError> {
    for (r, motion) in motions.iter().enumerate() {
        let weak = match motion {
            RowMotion::WeakLower | RowMotion::WeakUpper => true,
            RowMotion::Pinched => directions.iter().any(|dd| dd.lower[r] != dd.upper[r]),
            _ => false,
        };
        if weak {
            return Err(WsmError::contact(format!(
                "the Coulomb contact state is not differentiable: contact pair {} is at a \
                 transition (grazing, or between stick and slip), so no derivative is given",
                pair_of_row(r)
            )));
        }
    }
    Ok(())
}

impl DirectContact {
    /// G and e = Rᵀb of the tangent problem. Rᵀb of a balanced load derivative is zero up to
    /// rounding: it is measured against ‖R_j‖ ‖b‖, not against itself (the box QP's feasibility
    /// test is relative to e).
    fn tangent_equilibrium(&self, b: &[f64]) -> (faer::Mat<f64>, Vec<f64>) {
        let (g, mut e) = self.equilibrium(b);
        let b_norm = b.iter().map(|x| x * x).sum::<f64>().sqrt();
        for (j, ej) in e.iter_mut().enumerate() {
            let mode_norm = (0..b.len())
                .map(|i| self.kernel.modes[(i, j)].powi(2))
                .sum::<f64>()
                .sqrt();
            if ej.abs() <= ROUNDING_TOL * mode_norm * b_norm {
                *ej = 0.0;
            }
        }
        (g, e)
    }

    /// (dλ, dα) of a Coulomb state on its strict active set: the linear system of the module
    /// doc, solved by a pseudo-inverse of the row-equilibrated matrix.
    fn coulomb_tangent(
        &self,
        factor: &StiffnessFactor,
        motions: &[RowMotion],
        state: &ContactPoint,
        direction: &SignedDirection,
    ) -> Result<(Vec<f64>, Vec<f64>), WsmError> {
        let m = self.geometry.dim();
        let (g, e) = self.tangent_equilibrium(&direction.b);
        let k = e.len();
        let n = m + k;
        let mut a = Mat::<f64>::zeros(n, n);
        let mut rhs = vec![0.0; n];
        for (r, motion) in motions.iter().enumerate() {
            let (dl, du) = direction.bound_rates(r);
            let bound = match motion {
                RowMotion::Free => {
                    for j in 0..m {
                        a[(r, j)] = factor.c[(r, j)];
                    }
                    for i in 0..k {
                        a[(r, m + i)] = -g[(i, r)];
                    }
                    let row = &self.geometry.rows[r];
                    rhs[r] = direction.gap_rate(row);
                    continue;
                }
                RowMotion::Lower | RowMotion::Pinched => (dl, -1.0),
                RowMotion::Upper => (du, 1.0),
                // Refused by `check_differentiable`.
                RowMotion::WeakLower | RowMotion::WeakUpper => (0.0, 0.0),
            };
            a[(r, r)] = 1.0;
            rhs[r] = bound.0;
            // A slipping Coulomb row follows F λ_n: dλ_t − (±F) dλ_n = ±dF λ_n.
            let tangential = is_tangential_row(r);
            if let (true, Some(f), RowMotion::Lower | RowMotion::Upper) =
                (tangential, state.friction[pair_of_row(r)], motion)
            {
                a[(r, normal_row(pair_of_row(r)))] = -bound.1 * f;
            }
        }
        for i in 0..k {
            for j in 0..m {
                a[(m + i, j)] = g[(i, j)];
            }
            rhs[m + i] = e[i];
        }
        // Row equilibration, then x = A⁺ rhs with singular values below 1e-12 σ_max dropped.
        for r in 0..n {
            let scale = (0..n).fold(0.0_f64, |s, j| s.max(a[(r, j)].abs()));
            if scale > 0.0 {
                for j in 0..n {
                    a[(r, j)] /= scale;
                }
                rhs[r] /= scale;
            }
        }
        let svd = a
            .thin_svd()
            .map_err(|e| WsmError::contact(format!("sensitivity of the Coulomb state: {e:?}")))?;
        let (u, sigma, v) = (svd.U(), svd.S().column_vector(), svd.V());
        let cutoff = 1e-12 * (0..n).fold(0.0_f64, |s, i| s.max(sigma[i]));
        let mut x = vec![0.0; n];
        for c in 0..n {
            if sigma[c] <= cutoff {
                continue;
            }
            let coefficient = (0..n).map(|r| u[(r, c)] * rhs[r]).sum::<f64>() / sigma[c];
            for (j, xj) in x.iter_mut().enumerate() {
                *xj += v[(j, c)] * coefficient;
            }
        }
        let alpha = x.split_off(m);
        Ok((x, alpha))
    }
}

/// The tangent motion of every multiplier from the converged state.
pub(crate) fn classify(state: &ContactPoint) -> Vec<RowMotion> {
    let finite_max = |v: &[f64]| {
        v.iter()
            .filter(|x| x.is_finite())
            .fold(0.0_f64, |m, x| m.max(x.abs()))
    };
    let force_scale = finite_max(state.multipliers)
        .max(finite_max(state.lower))
        .max(finite_max(state.upper))
        .max(f64::MIN_POSITIVE);
    let gap_scale = finite_max(state.gaps)
        .max(state.displacement_scale)
        .max(f64::MIN_POSITIVE);
    let (bound_tol, weak_tol) = (AT_BOUND_TOL * force_scale, WEAK_TOL * gap_scale);
    state
        .multipliers
        .iter()
        .zip(state.gaps)
        .zip(state.lower.iter().zip(state.upper))
        .map(|((&x, &w), (&l, &u))| {
            let at_lower = x - l <= bound_tol;
            let at_upper = u - x <= bound_tol;
            match (at_lower, at_upper) {
                (true, true) => RowMotion::Pinched,
                (true, false) if w < -weak_tol => RowMotion::Lower,
                (true, false) => RowMotion::WeakLower,
                (false, true) if w > weak_tol => RowMotion::Upper,
                (false, true) => RowMotion::WeakUpper,
                (false, false) => RowMotion::Free,
            }
        })
        .collect()
}
