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
//! then u = A⁻¹ (F − Bᵀ Λ) (a second solve with A's factor, only when Λ ≠ 0). C_h is formed
//! once per run (A⁻¹ Bᵀ for it, one solve per multiplier, is dropped then: the dense n × m
//! product W Λ per step would read all of it, far more than the solve). The condensed problem
//! is solved by `dynamics.contact_solver`:
//! - `pdas` (default): the paper's primal–dual active set method (27) (module `pdas`),
//!   warm-started from the previous step's sets; when it does not terminate (a repeated set,
//!   the iteration cap, a singular C_FF), the step is solved by the QP kernel instead and
//!   counted in [`StepStats::fallback`];
//! - `qp`: the dense box QP [`solve_box_qp`] (semismooth Newton with an MPRGP fallback, design
//!   §3.1), warm-started from the previous step's Λ.
//!
//! In the crate's tests every PDAS step is also solved by the QP kernel and the largest
//! difference of the two u_{n+1} is recorded (see `qp_check`): the two agree to 1e-10.

use faer::Mat;

use crate::contact::pairs::{is_normal_row, pair_of_row, ContactGeometry};
use crate::contact::qp::{solve_box_qp, BoxQp, QpOptions, WarmStart};
use crate::error::WsmError;
use crate::fem::Factor;
use crate::scene::ContactSolver;

use super::pdas::{self, Status};

/// The per-step contact solver of a run: A's factor and C_h = B A⁻¹ Bᵀ.
#[derive(Debug)]
pub struct StepContact<'a> {
    geometry: &'a ContactGeometry,
    factor: Factor,
    c: Mat<f64>,
    fixed: Vec<f64>,
    solver: ContactSolver,
    warm: Option<WarmStart>,
    sets: Option<Vec<Status>>,
}

/// What one step's contact solve did.
#[derive(Debug, Clone, Copy, Default)]
pub struct StepStats {
    /// Semismooth Newton (PDAS) steps of the QP.
    pub iterations: usize,
    /// Active-set changes of the QP.
    pub changes: usize,
    /// PDAS did not terminate and the QP kernel solved the step.
    pub fallback: bool,
}

impl<'a> StepContact<'a> {
    /// Form C_h for the factor of A; `fixed` are the prescribed values u_d.
    /// The steps are solved by PDAS (see [`StepContact::with_solver`]).
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
            c,
            fixed,
            solver: ContactSolver::default(),
            warm: None,
            sets: None,
        }
    }

    /// Solve the steps with `solver`.
    pub fn with_solver(mut self, solver: ContactSolver) -> StepContact<'a> {
        self.solver = solver;
        self
    }

    /// Start the first step from the multipliers Λ (e.g. of the static start; the PDAS sets
    /// they stand in, and the QP's warm start).
    pub fn start_from(&mut self, multipliers: &[f64], lower: &[f64], upper: &[f64]) {
        self.sets = Some(pdas::sets_of(multipliers, lower, upper));
        self.warm = Some(WarmStart {
            x: multipliers.to_vec(),
            alpha: Vec::new(),
        });
    }

    /// The factor of A.
    pub fn factor(&self) -> &Factor {
        &self.factor
    }

    /// u = A⁻¹ (F − Bᵀ Λ) for the right-hand side F and multipliers Λ, given A⁻¹ F
    /// (`unconstrained`, returned as it is when Λ = 0).
    pub fn respond(&self, rhs: &[f64], unconstrained: Vec<f64>, multipliers: &[f64]) -> Vec<f64> {
        if multipliers.iter().all(|&l| l == 0.0) {
            return unconstrained;
        }
        let mut f = rhs.to_vec();
        let negated: Vec<f64> = multipliers.iter().map(|l| -l).collect();
        self.geometry.add_transpose(&negated, &mut f);
        self.factor.solve(&f)
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
        let u = self.factor.solve(rhs);
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
        let start = self
            .sets
            .clone()
            .unwrap_or_else(|| pdas::sets_of(&vec![0.0; m], lower, upper));
        let terminated = match self.solver {
            ContactSolver::Pdas => pdas::solve(&self.c, &d, lower, upper, &start),
            ContactSolver::Qp => None,
        };
        let (x, stats) = match terminated {
            Some(s) => {
                #[cfg(test)]
                qp_check::record(self, &d, lower, upper, &s.x);
                self.sets = Some(s.sets);
                let stats = StepStats {
                    iterations: s.iterations,
                    changes: s.changes,
                    fallback: false,
                };
                (s.x, stats)
            }
            None => {
                let (x, iterations, changes) = self.qp(&d, lower, upper)?;
                self.sets = Some(pdas::sets_of(&x, lower, upper));
                let stats = StepStats {
                    iterations,
                    changes,
                    fallback: self.solver == ContactSolver::Pdas,
                };
                (x, stats)
            }
        };
        let u = self.respond(rhs, u, &x);
        self.warm = Some(WarmStart {
            x: x.clone(),
            alpha: Vec::new(),
        });
        Ok((u, x, stats))
    }

    /// The step's condensed problem by the QP kernel, warm-started from the previous step:
    /// (Λ, Newton steps, active-set changes).
    fn qp(
        &self,
        d: &[f64],
        lower: &[f64],
        upper: &[f64],
    ) -> Result<(Vec<f64>, usize, usize), WsmError> {
        let problem = BoxQp::new(self.c.clone(), d.to_vec(), lower.to_vec(), upper.to_vec());
        let solution = solve_box_qp(&problem, self.warm.as_ref(), &QpOptions::default())
            .map_err(|e| WsmError::contact(format!("time step contact problem: {e}")))?;
        Ok((solution.x, solution.iterations, solution.active_set_changes))
    }
}

/// Test builds: every PDAS step is solved by the QP kernel too, and the largest difference of
/// the two u_{n+1} (relative to max |u_{n+1} − A⁻¹F|, the contact's effect, and to the step's
/// displacement) is kept per thread.
#[cfg(test)]
pub(super) mod qp_check {
    use std::cell::Cell;

    use super::StepContact;

    thread_local! {
        static CHECK: Cell<(usize, f64)> = const { Cell::new((0, 0.0)) };
    }

    /// Reset the record; returns (steps checked, largest relative difference) so far.
    pub fn take() -> (usize, f64) {
        CHECK.with(|c| c.replace((0, 0.0)))
    }

    pub(super) fn record(
        contact: &StepContact,
        d: &[f64],
        lower: &[f64],
        upper: &[f64],
        x: &[f64],
    ) {
        let (q, _, _) = contact
            .qp(d, lower, upper)
            .expect("the QP kernel solves the step");
        // A⁻¹ Bᵀ Λ: the multipliers' effect on u_{n+1}.
        let n = contact.factor.dim();
        let effect = |x: &[f64]| -> Vec<f64> {
            let mut f = vec![0.0; n];
            contact.geometry.add_transpose(x, &mut f);
            contact.factor.solve(&f)
        };
        let (a, b) = (effect(x), effect(&q));
        let scale = a.iter().chain(&b).fold(0.0_f64, |m, v| m.max(v.abs()));
        let diff = a
            .iter()
            .zip(&b)
            .fold(0.0_f64, |m, (p, q)| m.max((p - q).abs()));
        let relative = if scale > 0.0 { diff / scale } else { 0.0 };
        CHECK.with(|c| {
            let (steps, worst) = c.get();
            c.set((steps + 1, worst.max(relative)));
        });
    }
}
