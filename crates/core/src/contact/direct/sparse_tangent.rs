//! Directional derivatives of the contact state on the sparse contact path (design §4.4 with
//! §3.1's sparse path): the tangent problem of [`super::tangent`] — the same box of multiplier
//! derivatives (free rows unconstrained, strictly active rows following their bound, weakly
//! active rows one-sided) — solved in its primal form by the active-set iteration of
//! [`crate::contact::sparse`]: loads b = df − dK u, row offsets B_d du_d, no gap. Its solution is
//! du itself (and dλ, dα), put into the state's normal form along free rigid motions. A strict
//! active set needs one or two steps, each one sparse factorisation. Coulomb states (whose
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
        let tangent = |dd: &DataDerivative, sign: f64| -> Result<Vec<f64>, WsmError> {
            let b: Vec<f64> = dd.residual.iter().map(|x| sign * x).collect();
            let fixed: Vec<f64> = dd.fixed.iter().map(|x| sign * x).collect();
            let offsets: Vec<f64> = self
                .geometry
                .rows
                .iter()
                .map(|row| row.dot_fixed(&fixed))
                .collect();
            let (lower, upper) = tangent_bounds(&motions, dd, sign);
            let problem = TrescaProblem {
                geometry: &self.geometry,
                modes: self.kernel.modes.as_ref(),
                k_values: &factor.values,
                rhs: &b,
                offsets: &offsets,
                lower: &lower,
                upper: &upper,
            };
            let outcome = sparse::solve(system, &problem, None, Par::Seq).map_err(|e| {
                let reason = match e {
                    SparseFailure::Unbalanced { mode, residual } => format!(
                        "the load derivative leaves rigid mode {mode} unbalanced ({residual:.1e})"
                    ),
                    SparseFailure::NotConverged(reason) => reason,
                    SparseFailure::Solver(e) => e.to_string(),
                };
                WsmError::contact(format!("sensitivity of the contact state: {reason}"))
            })?;
            let mut du = outcome.u;
            remove_components(free_motions.as_ref(), &mut du);
            Ok(du)
        };
        directions
            .iter()
            .map(|dd| {
                let plus = tangent(dd, 1.0)?;
                let weak = motions.iter().enumerate().any(|(r, m)| match m {
                    RowMotion::WeakLower | RowMotion::WeakUpper => true,
                    RowMotion::Pinched => dd.lower[r] != dd.upper[r],
                    _ => false,
                });
                let minus = if weak { Some(tangent(dd, -1.0)?) } else { None };
                Ok(TangentDisplacement { plus, minus })
            })
            .collect()
    }
}
