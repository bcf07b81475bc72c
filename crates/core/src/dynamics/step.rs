//! The contact problem of one time step (design §3.5; PDAS paper Problem 4–5 (11)–(12)):
//! min ½ uᵀ A u − Fᵀ u + Σ_m G_m |(B u − B u_n)_{t,m}| subject to (B u)_{n,m} + (B_d u_d)_{n,m} ≤ g0_m,
//! with A = M + a C + c K0 factorised once for the run. The friction term acts on the slip of
//! the step (the paper's (10) writes |v_t| with v standing for the increment, §3 of the paper:
//! "v stands for v + u′ − u"), with the bound G = s × (Tresca g w, or Coulomb F |λ_n| of the
//! previous step — the paper's given friction of the previous time level).
//!
//! It is solved as the existing contact solver solves a static problem (design §3.1): condensed
//! on the multipliers, C_h = B A⁻¹ Bᵀ (A is positive definite through M: no floating-body
//! kernel), d = B A⁻¹ F + B_d u_d − g0 on normal rows and B A⁻¹ F − B u_n on tangential rows,
//! the dense box QP [`solve_box_qp`] warm-started from the previous step, then
//! u = A⁻¹ F − (A⁻¹ Bᵀ) Λ. A⁻¹ Bᵀ is formed once per run.

use faer::Mat;

use crate::contact::pairs::{is_normal_row, pair_of_row, ContactGeometry};
use crate::contact::qp::{solve_box_qp, BoxQp, QpOptions, QpSolution, WarmStart};
use crate::error::WsmError;
use crate::fem::Factor;

/// The per-step contact solver of a run: A's factor, W = A⁻¹ Bᵀ and C_h = B W.
#[derive(Debug)]
pub struct StepContact<'a> {
    geometry: &'a ContactGeometry,
    factor: Factor,
    w: Mat<f64>,
    c: Mat<f64>,
    fixed: Vec<f64>,
    warm: Option<WarmStart>,
}

/// What one step's contact solve did.
#[derive(Debug, Clone, Copy, Default)]
pub struct StepStats {
    /// Semismooth Newton (PDAS) steps of the QP.
    pub iterations: usize,
    /// Active-set changes of the QP.
    pub changes: usize,
}

impl<'a> StepContact<'a> {
    /// Form W = A⁻¹ Bᵀ and C_h for the factor of A; `fixed` are the prescribed values u_d.
    pub fn new(geometry: &'a ContactGeometry, factor: Factor, fixed: Vec<f64>) -> StepContact<'a> {
        let (n, m) = (factor.dim(), geometry.dim());
        let mut w = Mat::<f64>::zeros(n, m);
        for (r, row) in geometry.rows.iter().enumerate() {
            for &(i, c) in &row.free {
                w[(i, r)] += c;
            }
        }
        if m > 0 {
            factor.solve_in_place(w.as_mut());
        }
        let bw = Mat::<f64>::from_fn(m, m, |r, s| {
            geometry.rows[r]
                .free
                .iter()
                .map(|&(i, c)| c * w[(i, s)])
                .sum()
        });
        // Symmetric to rounding; symmetrised so that the QP's symmetry check sees the exact
        // structure.
        let c = Mat::<f64>::from_fn(m, m, |r, s| 0.5 * (bw[(r, s)] + bw[(s, r)]));
        StepContact {
            geometry,
            factor,
            w,
            c,
            fixed,
            warm: None,
        }
    }

    /// The factor of A.
    pub fn factor(&self) -> &Factor {
        &self.factor
    }

    /// W = A⁻¹ Bᵀ.
    pub fn w(&self) -> &Mat<f64> {
        &self.w
    }

    /// C_h = B A⁻¹ Bᵀ (symmetrised).
    pub fn condensed(&self) -> &Mat<f64> {
        &self.c
    }

    /// The contact geometry.
    pub fn geometry(&self) -> &ContactGeometry {
        self.geometry
    }

    /// Solve A u = F − BᵀΛ with the step's contact conditions; `u_now` is u_n (the friction
    /// acts on B_t (u − u_n)); `lower`, `upper` the bounds of Λ. Returns u_{n+1} and Λ.
    pub fn solve(
        &mut self,
        rhs: &[f64],
        u_now: &[f64],
        lower: &[f64],
        upper: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>, StepStats), WsmError> {
        let mut u = self.factor.solve(rhs);
        let m = self.geometry.dim();
        if m == 0 {
            return Ok((u, Vec::new(), StepStats::default()));
        }
        let d: Vec<f64> = self
            .geometry
            .rows
            .iter()
            .enumerate()
            .map(|(r, row)| {
                if is_normal_row(r) {
                    row.dot(&u) + row.dot_fixed(&self.fixed)
                        - self.geometry.pairs[pair_of_row(r)].gap
                } else {
                    row.dot(&u) - row.dot(u_now)
                }
            })
            .collect();
        let problem = BoxQp::new(self.c.clone(), d, lower.to_vec(), upper.to_vec());
        let solution: QpSolution =
            solve_box_qp(&problem, self.warm.as_ref(), &QpOptions::default())
                .map_err(|e| WsmError::contact(format!("time step contact problem: {e}")))?;
        for (s, &lambda) in solution.x.iter().enumerate() {
            if lambda != 0.0 {
                for (i, ui) in u.iter_mut().enumerate() {
                    *ui -= self.w[(i, s)] * lambda;
                }
            }
        }
        let stats = StepStats {
            iterations: solution.iterations,
            changes: solution.active_set_changes,
        };
        self.warm = Some(WarmStart::from(&solution));
        Ok((u, solution.x, stats))
    }
}
