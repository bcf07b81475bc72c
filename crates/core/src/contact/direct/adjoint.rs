//! The adjoint of the tangent contact problem (design §4.4): linear forms of the displacement
//! derivative du turned into linear forms of the data derivative, so that the derivatives of a
//! few criteria along many data directions cost two solves with K per criterion instead of two
//! per direction and no tangent QP at all.
//!
//! Where no row is weakly active, the tangent problem of [`super::tangent`] is linear: the free
//! rows F solve their stationarity and the floating bodies' equilibrium,
//!
//! ```text
//!   M [dλ_F; dα] = [d'_F − C_FA dλ_A;  Rᵀb − G_A dλ_A],   M = [C_FF  −G_Fᵀ; G_F  0],
//!   d' = B P K⁺ P b + B_d du_d,
//! ```
//!
//! the other rows A follow their bounds (dλ_A = the bound derivative), and
//! du = (I − Z Zᵀ)(P K⁺ P (b − Bᵀ dλ) + R dα) with Z the free motions. For a form ℓ(du) = aᵀdu,
//! with a' = (I − Z Zᵀ) a, z = P K⁺ P a', s = [−(B z)_F; Rᵀa'], Mᵀ y = s and
//! w = P K⁺ P B_Fᵀ y₁:
//!
//! ```text
//!   ℓ(du) = (z + w + R y₂)ᵀ b + y₁ᵀ (B_d du_d)_F − (B z + C y₁ + Gᵀ y₂)_Aᵀ dλ_A.
//! ```
//!
//! A form that also reads the multipliers, ℓ = aᵀdu + cᵀdλ (the defined contact-traction
//! criteria, design §4.2), has s = [c_F − (B z)_F; Rᵀa'] and adds c_A to the coefficients of dλ_A.
//!
//! z and w of all forms are one multi-right-hand-side solve each. Where the state is only
//! one-sided differentiable (weakly active rows, or pinched rows whose bounds move apart along a
//! direction), and on Coulomb zones (slip rows coupled to the normal ones), the forward tangent
//! is used instead; M is solved with full pivoting after a
//! diagonal scaling and refused when numerically singular (then the forward tangent, with its
//! QP, decides).

use faer::linalg::solvers::Solve;
use faer::Mat;

use super::tangent::{classify, RowMotion};
use super::{ContactPoint, DataDerivative, DirectContact, StiffnessFactor};
use crate::error::WsmError;
use crate::fem::rigid::remove_components;

/// Smallest ratio of the smallest to the largest pivot of the scaled M that is accepted.
const PIVOT_RATIO: f64 = 1e-12;
/// Relative size below which the free rows do not see a rigid motion (or a form does not read it).
const UNSEEN_TOL: f64 = 1e-10;

/// A form ℓ = aᵀ du_free + cᵀ dλ: a over the free DOFs, c as (row of B, coefficient).
pub type CriterionForm = (Vec<f64>, Vec<(usize, f64)>);

/// Forms of the data derivative equal to given forms of du (see the module doc).
pub struct AdjointForms {
    motions: Vec<RowMotion>,
    /// Per form: the coefficients of b (free DOFs).
    residual: Vec<Vec<f64>>,
    /// Per form: the coefficients of du_d (fixed DOFs).
    fixed: Vec<Vec<f64>>,
    /// Per form: the coefficients of the bound derivative each row follows (0 on free rows).
    bound: Vec<Vec<f64>>,
}

impl AdjointForms {
    /// Whether the derivative along `dd` is linear (no pinched row whose bounds move apart), so
    /// that [`Self::apply`] gives it.
    pub fn is_linear_along(&self, dd: &DataDerivative) -> bool {
        self.motions
            .iter()
            .enumerate()
            .all(|(r, m)| *m != RowMotion::Pinched || dd.lower[r] == dd.upper[r])
    }

    /// The value of form `form` at the derivative du along `dd`.
    pub fn apply(&self, form: usize, dd: &DataDerivative) -> f64 {
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let bounds: f64 = self
            .motions
            .iter()
            .enumerate()
            .map(|(r, m)| match m {
                RowMotion::Upper => self.bound[form][r] * dd.upper[r],
                RowMotion::Free => 0.0,
                _ => self.bound[form][r] * dd.lower[r],
            })
            .sum();
        dot(&self.residual[form], dd.residual) + dot(&self.fixed[form], dd.fixed) + bounds
    }
}

impl DirectContact {
    /// The adjoint forms of `forms` (each a vector over the free DOFs and a sparse vector over
    /// the rows of B: ℓ = aᵀ du_free + cᵀ dλ) at the converged contact state (`n_fixed`
    /// prescribed DOFs), or `None` where the state has weakly active rows or M is numerically
    /// singular. The multiplier part adds c_F to the free rows' adjoint load s and c_A to the
    /// coefficients of the bound derivatives the other rows follow (module doc).
    pub fn adjoint(
        &self,
        factor: &StiffnessFactor,
        state: &ContactPoint,
        forms: &[CriterionForm],
        n_fixed: usize,
    ) -> Result<Option<AdjointForms>, WsmError> {
        // A row that touches no free DOF (both nodes prescribed) moves nothing: its multiplier
        // is a reaction, whatever its state, and follows its lower bound with no effect.
        let motions: Vec<RowMotion> = classify(state)
            .into_iter()
            .zip(&self.geometry.rows)
            .map(|(m, row)| {
                if row.free.iter().all(|&(_, c)| c == 0.0) {
                    RowMotion::Lower
                } else {
                    m
                }
            })
            .collect();
        // Coulomb's slip rows follow ±F λ_n, a coupling to the normal rows this adjoint does not
        // carry (design §3.4): the forward tangent takes them.
        let coulomb = state.friction.iter().any(Option::is_some);
        if coulomb
            || motions
                .iter()
                .any(|m| matches!(m, RowMotion::WeakLower | RowMotion::WeakUpper))
        {
            return Ok(None);
        }
        if forms.is_empty() {
            return Ok(Some(AdjointForms {
                motions,
                residual: Vec::new(),
                fixed: Vec::new(),
                bound: Vec::new(),
            }));
        }
        let n = self.kernel.modes.nrows();
        let k = self.kernel_dim();
        let rows = &self.geometry.rows;
        let free_rows: Vec<usize> = (0..motions.len())
            .filter(|&r| motions[r] == RowMotion::Free)
            .collect();
        let free_motions = self
            .kernel
            .free_motions(&self.geometry, state.lower, state.upper)?;
        // The multiplier parts c, dense over the rows.
        let c: Vec<Vec<f64>> = forms
            .iter()
            .map(|(_, part)| {
                let mut c = vec![0.0; motions.len()];
                for &(r, v) in part {
                    c[r] += v;
                }
                c
            })
            .collect();
        // z = P K⁺ P a' for all forms.
        let mut a_projected: Vec<Vec<f64>> = forms.iter().map(|(a, _)| a.clone()).collect();
        for a in &mut a_projected {
            remove_components(free_motions.as_ref(), a);
        }
        let mut z: Vec<f64> = a_projected.iter().flatten().copied().collect();
        self.projected_solve_columns(factor, &mut z, forms.len());
        let z: Vec<&[f64]> = z.chunks_exact(n.max(1)).collect();
        let bz: Vec<Vec<f64>> = z
            .iter()
            .map(|z| rows.iter().map(|row| row.dot(z)).collect())
            .collect();
        // s₁ = −(B z)_F + c_F: the load of the free rows' adjoint, with the form's own dλ_F.
        let load: Vec<Vec<f64>> = bz
            .iter()
            .zip(&c)
            .map(|(bz, c)| bz.iter().zip(c).map(|(b, c)| b - c).collect())
            .collect();
        let Some(y) = self.solve_reduced_transpose(factor, &free_rows, &load, &a_projected)? else {
            return Ok(None);
        };
        // w = P K⁺ P B_Fᵀ y₁ for all forms.
        let mut w = vec![0.0; n * forms.len()];
        for (column, y) in w.chunks_exact_mut(n.max(1)).zip(&y) {
            for (&r, yr) in free_rows.iter().zip(y) {
                for &(i, c) in &rows[r].free {
                    column[i] += c * yr;
                }
            }
        }
        self.projected_solve_columns(factor, &mut w, forms.len());
        let mut residual = Vec::with_capacity(forms.len());
        let mut fixed = Vec::with_capacity(forms.len());
        let mut bound = Vec::with_capacity(forms.len());
        for (f, y) in y.iter().enumerate() {
            let (y1, y2) = y.split_at(free_rows.len());
            let mut v: Vec<f64> = z[f]
                .iter()
                .zip(&w[f * n..(f + 1) * n])
                .map(|(a, b)| a + b)
                .collect();
            for (j, yj) in y2.iter().enumerate() {
                for (i, vi) in v.iter_mut().enumerate() {
                    *vi += self.kernel.modes[(i, j)] * yj;
                }
            }
            let mut fixed_f = vec![0.0; n_fixed];
            for (&r, yr) in free_rows.iter().zip(y1) {
                for &(i, c) in &rows[r].fixed {
                    fixed_f[i] += c * yr;
                }
            }
            let bound_f: Vec<f64> = (0..motions.len())
                .map(|r| {
                    if motions[r] == RowMotion::Free {
                        return 0.0;
                    }
                    let cy: f64 = free_rows
                        .iter()
                        .zip(y1)
                        .map(|(&q, yq)| factor.c[(q, r)] * yq)
                        .sum();
                    let gy: f64 = (0..k).map(|j| self.g[(j, r)] * y2[j]).sum();
                    // Without a multiplier part the coefficient is as before, bit for bit.
                    if c[f][r] == 0.0 {
                        -(bz[f][r] + cy + gy)
                    } else {
                        c[f][r] - (bz[f][r] + cy + gy)
                    }
                })
                .collect();
            residual.push(v);
            fixed.push(fixed_f);
            bound.push(bound_f);
        }
        Ok(Some(AdjointForms {
            motions,
            residual,
            fixed,
            bound,
        }))
    }

    /// y = M⁻ᵀ s per form, s = [−bz_F; Rᵀa'] (`bz` = B z − c, c the form's multiplier part), with M = [C_FF −G_Fᵀ; G_F 0] scaled by
    /// D = diag(C_ii^(−1/2) on F, 1/‖row of G_F D‖ on the equalities); `None` when numerically
    /// singular. An equality that no free row sees (a rigid motion held by rows at their bounds
    /// only, or by none) constrains the data, not the multipliers: it is dropped with y₂ = 0,
    /// which needs its s = Rᵀa' to vanish (the form does not read that motion).
    fn solve_reduced_transpose(
        &self,
        factor: &StiffnessFactor,
        free_rows: &[usize],
        bz: &[Vec<f64>],
        a_projected: &[Vec<f64>],
    ) -> Result<Option<Vec<Vec<f64>>>, WsmError> {
        let (nf, k) = (free_rows.len(), self.kernel_dim());
        let mut scale = vec![1.0; nf];
        for (i, &r) in free_rows.iter().enumerate() {
            let c = factor.c[(r, r)];
            if !(c > 0.0 && c.is_finite()) {
                return Ok(None);
            }
            scale[i] = 1.0 / c.sqrt();
        }
        let mode_load = |f: usize, j: usize| -> f64 {
            (0..a_projected[f].len())
                .map(|p| self.kernel.modes[(p, j)] * a_projected[f][p])
                .sum()
        };
        let norms: Vec<f64> = (0..k)
            .map(|j| {
                free_rows.iter().enumerate().fold(0.0_f64, |m, (i, &r)| {
                    m.max((self.g[(j, r)] * scale[i]).abs())
                })
            })
            .collect();
        let largest_norm = norms.iter().copied().fold(0.0_f64, f64::max);
        let mut kept = Vec::new();
        for (j, &norm) in norms.iter().enumerate() {
            if norm > UNSEEN_TOL * largest_norm {
                kept.push(j);
                scale.push(1.0 / norm);
                continue;
            }
            let mode_norm = (0..self.kernel.modes.nrows())
                .map(|p| self.kernel.modes[(p, j)].powi(2))
                .sum::<f64>()
                .sqrt();
            for (f, a) in a_projected.iter().enumerate() {
                let a_norm = a.iter().map(|x| x * x).sum::<f64>().sqrt();
                if mode_load(f, j).abs() > UNSEEN_TOL * mode_norm * a_norm {
                    return Ok(None);
                }
            }
        }
        let size = nf + kept.len();
        let mut y: Vec<Vec<f64>> = vec![vec![0.0; nf + k]; bz.len()];
        if size == 0 {
            return Ok(Some(y));
        }
        let entry = |i: usize, j: usize| -> f64 {
            let value = match (i < nf, j < nf) {
                (true, true) => factor.c[(free_rows[i], free_rows[j])],
                (true, false) => -self.g[(kept[j - nf], free_rows[i])],
                (false, true) => self.g[(kept[i - nf], free_rows[j])],
                (false, false) => 0.0,
            };
            scale[i] * value * scale[j]
        };
        let m = Mat::<f64>::from_fn(size, size, entry);
        // Mᵀ y = s  ⇔  M̃ᵀ (D⁻¹ y) = D s with M̃ = D M D.
        let mut rhs = Mat::<f64>::from_fn(size, bz.len(), |i, f| {
            let s = if i < nf {
                -bz[f][free_rows[i]]
            } else {
                mode_load(f, kept[i - nf])
            };
            scale[i] * s
        });
        // Without equalities M = C_FF is symmetric positive definite (Cholesky refuses it
        // otherwise); with them, LU with partial pivoting. Either way the pivots are checked.
        if kept.is_empty() {
            let Ok(factor) = m.llt(faer::Side::Lower) else {
                return Ok(None);
            };
            if !pivots_ok((0..size).map(|i| factor.L()[(i, i)].powi(2))) {
                return Ok(None);
            }
            factor.solve_transpose_in_place(rhs.as_mut());
        } else {
            let factor = m.partial_piv_lu();
            if !pivots_ok((0..size).map(|i| factor.U()[(i, i)].abs())) {
                return Ok(None);
            }
            factor.solve_transpose_in_place(rhs.as_mut());
        }
        for (f, y) in y.iter_mut().enumerate() {
            for i in 0..size {
                let at = if i < nf { i } else { nf + kept[i - nf] };
                y[at] = scale[i] * rhs[(i, f)];
            }
        }
        if y.iter().flatten().any(|v| !v.is_finite()) {
            return Ok(None);
        }
        Ok(Some(y))
    }
}

/// Whether the pivots of a factorisation are far enough from singular: the smallest at least
/// [`PIVOT_RATIO`] of the largest.
fn pivots_ok(pivots: impl Iterator<Item = f64> + Clone) -> bool {
    let largest = pivots.clone().fold(0.0_f64, f64::max);
    let smallest = pivots.fold(f64::INFINITY, f64::min);
    smallest > PIVOT_RATIO * largest
}
