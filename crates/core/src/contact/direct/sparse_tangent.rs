//! Directional derivatives of the contact state on the sparse contact path (design §4.4 with
//! §3.1's sparse path): the tangent problem of [`super::tangent`] — the same box of multiplier
//! derivatives (free rows unconstrained, strictly active rows following their bound, weakly
//! active rows one-sided) — solved in its primal form by the active-set iteration of
//! [`crate::contact::sparse`]: loads b = df − dK u, row offsets B_d du_d, no gap. Its solution is
//! du itself (and dλ, dα), put into the state's normal form along free rigid motions. On a
//! strict active set every direction has the same set, so all are solved with one factor
//! ([`sparse::solve_fixed`]); with weakly active rows each direction and sign runs the iteration. Coulomb states (whose
//! tangent couples dλ_t to F dλ_n, not a box) have no derivative on this path.

use super::tangent::{
    classify, tangent_bounds, ContactPoint, DataDerivative, RowMotion, TangentDisplacement,
};
use super::{DirectContact, StiffnessFactor};
use crate::contact::sparse::system::SparseSystem;
use crate::contact::sparse::{self, SparseFailure, TrescaProblem};
use crate::error::WsmError;
use crate::fem::rigid::remove_components;
use faer::Par;

impl DirectContact {
    /// [`DirectContact::tangents`] on the sparse path.
    pub(super) fn sparse_tangents(
        &self,
        system: &SparseSystem,
        factor: &StiffnessFactor,
        state: &ContactPoint,
        directions: &[DataDerivative],
    ) -> Result<Vec<TangentDisplacement>, WsmError> {
        if state.friction.iter().any(Option::is_some) {
            return Err(WsmError::contact(
                "exact derivatives of a Coulomb contact state are not available on the sparse \
                 contact path (solver.contact: \"dense\" gives them, at a memory cost that grows \
                 with the square of the pairs)",
            ));
        }
        let motions = classify(state);
        let free_motions = self
            .kernel
            .free_motions(&self.geometry, state.lower, state.upper)?;
        // The signed problem of one direction: loads, row offsets and bounds.
        let data = |dd: &DataDerivative, sign: f64| {
            let b: Vec<f64> = dd.residual.iter().map(|x| sign * x).collect();
            let fixed: Vec<f64> = dd.fixed.iter().map(|x| sign * x).collect();
            let offsets: Vec<f64> = self
                .geometry
                .rows
                .iter()
                .map(|row| row.dot_fixed(&fixed))
                .collect();
            let (lower, upper) = tangent_bounds(&motions, dd, sign);
            SignedDirection {
                loads: b,
                offsets,
                lower,
                upper,
            }
        };
        let explain = |e: SparseFailure| {
            let reason = match e {
                SparseFailure::Unbalanced { mode, residual } => format!(
                    "the load derivative leaves rigid mode {mode} unbalanced ({residual:.1e})"
                ),
                SparseFailure::NotConverged(reason) => reason,
                SparseFailure::Solver(e) => e.to_string(),
            };
            WsmError::contact(format!("sensitivity of the contact state: {reason}"))
        };
        let normal_form = |mut du: Vec<f64>| {
            remove_components(free_motions.as_ref(), &mut du);
            du
        };
        let weak = |dd: &DataDerivative| {
            motions.iter().enumerate().any(|(r, m)| match m {
                RowMotion::WeakLower | RowMotion::WeakUpper => true,
                RowMotion::Pinched => dd.lower[r] != dd.upper[r],
                _ => false,
            })
        };
        if !directions.iter().any(weak) {
            // A strict active set: every direction on the same set, one factor for all.
            let all: Vec<_> = directions.iter().map(|dd| data(dd, 1.0)).collect();
            let problems: Vec<TrescaProblem> = all
                .iter()
                .map(|d| self.tangent_problem(factor, d))
                .collect();
            let outcomes = sparse::solve_fixed(system, &problems, Par::Seq).map_err(explain)?;
            return Ok(outcomes
                .into_iter()
                .map(|o| TangentDisplacement {
                    plus: normal_form(o.u),
                    minus: None,
                    plus_multipliers: o.multipliers,
                    minus_multipliers: None,
                })
                .collect());
        }
        let tangent = |dd: &DataDerivative, sign: f64| -> Result<(Vec<f64>, Vec<f64>), WsmError> {
            let d = data(dd, sign);
            let outcome = sparse::solve(system, &self.tangent_problem(factor, &d), None, Par::Seq)
                .map_err(explain)?;
            Ok((normal_form(outcome.u), outcome.multipliers))
        };
        directions
            .iter()
            .map(|dd| {
                let (plus, plus_multipliers) = tangent(dd, 1.0)?;
                let (minus, minus_multipliers) = if weak(dd) {
                    let (u, l) = tangent(dd, -1.0)?;
                    (Some(u), Some(l))
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
}

/// The tangent problem of one direction and sign: loads b, row offsets B_d du_d and the
/// bounds of the multiplier derivatives.
struct SignedDirection {
    loads: Vec<f64>,
    offsets: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl DirectContact {
    fn tangent_problem<'a>(
        &'a self,
        factor: &'a StiffnessFactor,
        d: &'a SignedDirection,
    ) -> TrescaProblem<'a> {
        TrescaProblem {
            geometry: &self.geometry,
            modes: self.kernel.modes.as_ref(),
            k_values: &factor.values,
            rhs: &d.loads,
            offsets: &d.offsets,
            lower: &d.lower,
            upper: &d.upper,
        }
    }
}
