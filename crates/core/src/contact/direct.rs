//! The exact direct contact solver (design §3.1): K factorised once per stiffness, the contact
//! problem condensed on the node-pair multipliers and solved as a box QP to machine precision.
//!
//! Primal (D05 Def. 2.1, discrete): min ½uᵀKu − fᵀu + Σ_m g_m w_m |(B u)_{t,m}| subject to
//! (B u)_{n,m} ≤ g0_m. Dual with multipliers λ (normal force ≥ 0, |tangential| ≤ g w):
//!   min ½ λᵀ C λ − λᵀ d   s.t. box,  G λ = e,
//! with C = B K⁺ Bᵀ, d = B K⁺ f + B_d u_d − g0, and for floating bodies (semi-coercive case, CZ
//! Thm 1.2, D05 Thm 2.1) the kernel R of K on the free DOFs: G = RᵀBᵀ, e = Rᵀ f (the loads left
//! after contact must not excite a rigid motion). Then u = K⁺(f − Bᵀλ) + R α with α the equality
//! multipliers. K⁺ is the generalised inverse obtained by pinning, per floating body, as many
//! DOFs as it has rigid motions (chosen so that the pinned rows of R are well conditioned).
//! Infeasible G λ = e within the box means the loads cannot be balanced by contact and friction:
//! the solve is refused with the body and the unbalanced motion named.
//!
//! Forming C: B only touches the contact DOFs c (free DOFs of contact nodes), so
//! C = B_c (K⁺)_cc B_cᵀ. K is analysed once per scene with c ordered last, grouped body by body
//! ([`Symbolic::analyse_with_trailing`]); with the trailing factor block L₂₂,
//! (K⁻¹)_cc = (L₂₂ L₂₂ᵀ)⁻¹, so C = Wᵀ W with W = L₂₂⁻¹ B_cᵀ: one dense triangular solve and one
//! dense product per diagonal block of L₂₂ (one per body, K being block diagonal over bodies)
//! instead of m sparse solves. A pinned DOF has an identity row and column in the pinned K and a
//! zero entry in K⁺, so its column of B_c is zeroed.
//!
//! K is block diagonal over bodies; each body's block is analysed and factorised on its own
//! ([`super::bodies`]), so that the factor of a body whose zone coefficients did not change can
//! be reused ([`DirectContact::factor_with`]).

mod adjoint;
mod sparse_tangent;
mod tangent;

pub use adjoint::AdjointForms;
pub(crate) use tangent::{classify, tangent_bounds, RowMotion, TangentDisplacement};
pub use tangent::{ContactPoint, DataDerivative};

use std::sync::{Arc, OnceLock};

use faer::linalg::solvers::DenseSolveCore;
use faer::{Mat, Par};
use rayon::prelude::*;

use super::bodies::{body_blocks, BodyBlock, BodyFactor};
use super::condition;
use super::coulomb::{self, CoulombReport};
use super::feasibility::Feasibility;
use super::pairs::{is_normal_row, pair_of_row, ContactGeometry, ContactRow};
use super::qp::{solve_box_qp, BoxQp, QpError, QpOptions, QpSolution, WarmStart};
use super::sparse::system::SparseSystem;
use super::sparse::{self, SparseFailure, TrescaProblem};
use crate::error::WsmError;
use crate::fem::rigid::{orthonormal_columns, pick_pinned, remove_components};
use crate::fem::{ElasticCoefficients, ElasticProblem, RigidModes};
use crate::scene::{ContactMethod, Data, SceneError};

/// Relative size (to the largest displacement) of the gap defect that triggers a refinement.
const REFINE_TOL: f64 = 1e-12;
/// Refinements of the condensed problem at most.
const MAX_REFINEMENTS: usize = 3;

/// Floating-body kernel on the free DOFs and the DOFs pinned to factorise K.
#[derive(Debug, Clone)]
struct Kernel {
    /// n_free × k rigid modes of all floating bodies.
    modes: Mat<f64>,
    /// Per mode: body index and name, and (translation x, translation y, rotation)
    /// coefficients.
    labels: Vec<(usize, String, [f64; 3])>,
    pinned: Vec<usize>,
    /// (RᵀR)⁻¹, for the orthogonal projector P = I − R (RᵀR)⁻¹ Rᵀ onto the loads a floating
    /// body can carry.
    gram_inverse: Mat<f64>,
}

/// Cosine |B_r · R_j| / (‖B_r‖ ‖R_j‖) below which a contact row does not see a rigid mode.
const FREE_MOTION_TOL: f64 = 1e-10;

impl Kernel {
    /// Orthonormal basis (n_free × z) of the free motions {R α : B_A R α = 0} over the rows A
    /// whose multiplier is not fixed by its bounds (a zero slip limit fixes the tangential one):
    /// rigid motions that no contact row sees, e.g. frictionless sliding along a straight zone.
    /// Energy, gaps and forces do not depend on them. Computed from the right singular vectors
    /// of the row- and column-normalised B_A R with singular values ≤ [`FREE_MOTION_TOL`].
    fn free_motions(
        &self,
        geometry: &ContactGeometry,
        lower: &[f64],
        upper: &[f64],
    ) -> Result<Mat<f64>, WsmError> {
        let modes = &self.modes;
        let (n, k) = (modes.nrows(), modes.ncols());
        if k == 0 {
            return Ok(Mat::zeros(n, 0));
        }
        let rows: Vec<&ContactRow> = geometry
            .rows
            .iter()
            .zip(lower.iter().zip(upper))
            .filter(|(_, (l, u))| l < u)
            .map(|(row, _)| row)
            .collect();
        let col_norm: Vec<f64> = (0..k)
            .map(|j| (0..n).map(|i| modes[(i, j)].powi(2)).sum::<f64>().sqrt())
            .collect();
        // At least k rows (zero padding) so that the thin SVD has all k right singular vectors.
        let br = Mat::<f64>::from_fn(rows.len().max(k), k, |r, j| {
            let Some(row) = rows.get(r) else {
                return 0.0;
            };
            let norm = row.free.iter().map(|&(_, c)| c * c).sum::<f64>().sqrt();
            if norm == 0.0 {
                return 0.0;
            }
            let dot: f64 = row.free.iter().map(|&(i, c)| c * modes[(i, j)]).sum();
            dot / (norm * col_norm[j])
        });
        let svd = br
            .thin_svd()
            .map_err(|e| WsmError::contact(format!("free-motion SVD: {e:?}")))?;
        let (s, v) = (svd.S().column_vector(), svd.V());
        let free: Vec<usize> = (0..k).filter(|&c| s[c] <= FREE_MOTION_TOL).collect();
        let mut z = Mat::<f64>::zeros(n, free.len());
        for (col, &c) in free.iter().enumerate() {
            for j in 0..k {
                let w = v[(j, c)] / col_norm[j];
                for i in 0..n {
                    z[(i, col)] += w * modes[(i, j)];
                }
            }
        }
        Ok(orthonormal_columns(z.as_ref()))
    }

    /// v ← P v: remove the rigid-mode components (least squares).
    fn project(&self, v: &mut [f64]) {
        let k = self.modes.ncols();
        if k == 0 {
            return;
        }
        let c: Vec<f64> = (0..k)
            .map(|j| {
                v.iter()
                    .enumerate()
                    .map(|(i, x)| self.modes[(i, j)] * x)
                    .sum()
            })
            .collect();
        for j in 0..k {
            let t: f64 = (0..k).map(|l| self.gram_inverse[(j, l)] * c[l]).sum();
            for (i, x) in v.iter_mut().enumerate() {
                *x -= self.modes[(i, j)] * t;
            }
        }
    }
}

/// The contact problem of a scene: geometry, floating-body kernel and G = RᵀBᵀ, and the
/// body blocks of K, each analysed with its contact DOFs last.
#[derive(Debug, Clone)]
pub struct DirectContact {
    pub geometry: ContactGeometry,
    /// Anderson depth of the Coulomb fixed point (`solver.coulomb_acceleration`; 0 = plain).
    pub coulomb_anderson_depth: usize,
    /// The pairs whose normal rows the prescribed displacements alone decide.
    pub feasibility: Feasibility,
    kernel: Kernel,
    g: Mat<f64>,
    bodies: Vec<BodyBlock>,
    /// The sparse contact path ([`super::sparse`]) when the scene takes it; then `bodies` is
    /// empty and no C is formed.
    sparse: Option<SparseSystem>,
}

/// K (with pinned DOFs) factorised for one stiffness data set, body by body, with
/// C = B K⁺ Bᵀ.
#[derive(Debug, Clone)]
pub struct StiffnessFactor {
    /// Zone coefficients [λ_z, μ_z] the factor was built from.
    pub coefficients: Vec<ElasticCoefficients>,
    /// Values of the unpinned K (for residual checks).
    values: Vec<f64>,
    parts: Vec<Arc<BodyFactor>>,
    c: Mat<f64>,
    /// κ∞ of the Jacobi-scaled C, computed on first use ([`StiffnessFactor::scaled_condition`]).
    c_condition: OnceLock<Option<f64>>,
    /// How many body factors were reused from a cache.
    pub reused_bodies: usize,
    /// Time of the numeric factorisations with their shares of C, and of the assembly of C
    /// with the floating-body projection \[s\].
    pub seconds: [f64; 2],
}

impl StiffnessFactor {
    /// κ∞ of C in the QP's Jacobi scaling ([`condition::scaled_condition`]; `None` when C is
    /// not numerically positive definite), estimated once per factor.
    fn scaled_condition(&self) -> Option<f64> {
        *self
            .c_condition
            .get_or_init(|| condition::scaled_condition(self.c.as_ref()))
    }
}

/// A cache of body factors: given the body index, its block and the global values of K, the
/// body's factor and whether it came from the cache.
pub type BodyCache<'a> =
    &'a (dyn Fn(usize, &BodyBlock, &[f64]) -> Result<(Arc<BodyFactor>, bool), WsmError> + Sync);

/// The result of one contact solve.
#[derive(Debug, Clone)]
pub struct ContactSolution {
    /// Displacement on the free DOFs.
    pub u_free: Vec<f64>,
    /// Multipliers: per pair (normal force, tangential force) [N/m].
    pub multipliers: Vec<f64>,
    /// Rigid-body amplitudes of the floating bodies.
    pub rigid: Vec<f64>,
    /// Relative gap and slip: B u + B_d u_d − g0 (normal rows ≤ 0 when closed).
    pub gaps: Vec<f64>,
    /// QP statistics (None when there is no contact).
    pub qp: Option<QpSolution>,
    /// ‖K u − f + Bᵀλ‖ / ‖f‖ on the free DOFs.
    pub equilibrium_residual: f64,
    /// Rigid motions no contact row determines; `u_free` has no component along them
    /// ([`DirectContact::normalise_free_motions`]).
    pub free_motions: usize,
    /// Time in the QP \[s\] (the rest of the solve: solves with K, gaps, residual).
    pub qp_seconds: f64,
    /// Refinements of the condensed problem (each one more QP and one more solve with K).
    pub refinements: usize,
    /// The Coulomb fixed point (None without a Coulomb zone).
    pub coulomb: Option<CoulombReport>,
    /// The sparse path's active-set iteration (None on the dense path).
    pub sparse: Option<SparseReport>,
}

/// The sparse contact path's iteration, summed over the Tresca problems of a solve.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SparseReport {
    /// Active-set steps, each one sparse factorisation.
    pub steps: usize,
    /// Rows that changed status.
    pub changes: usize,
    /// Relative accuracy of the last solve (its iterative-refinement correction).
    pub accuracy: f64,
    /// Nonzeros of the factor of one step.
    pub factor_nnz: usize,
}

/// What every Tresca problem of one contact solve shares (a Coulomb solve makes several, with
/// other multiplier bounds): the factor of K, the elastic problem, the reduced right-hand side
/// (loads and lifting) and the prescribed values.
#[derive(Clone, Copy)]
struct TrescaInputs<'a> {
    factor: &'a StiffnessFactor,
    elastic: &'a ElasticProblem,
    rhs: &'a [f64],
    fixed: &'a [f64],
}

impl DirectContact {
    /// Pairs, B rows and the floating-body kernel. Refuses a floating body without contact.
    pub fn new(
        scene: &crate::scene::Scene,
        elastic: &ElasticProblem,
    ) -> Result<DirectContact, WsmError> {
        let geometry = ContactGeometry::new(scene, elastic.mesh(), elastic.dofs());
        let mut modes: Vec<RigidModes> = Vec::new();
        for &body in elastic.floating_bodies() {
            let touches = geometry
                .pairs
                .iter()
                .any(|p| p.nodes.iter().any(|&n| elastic.mesh().node_body[n] == body));
            if !touches {
                return Err(WsmError::Unbalanced {
                    body: elastic.mesh().bodies[body].clone(),
                    index: body,
                    reason: "it is not held by displacement or roller conditions and touches no contact zone".into(),
                });
            }
            modes.push(elastic.rigid_modes(body)?);
        }
        // The operator's unknowns: the free DOFs (and, for the mixed element, the pressures,
        // on which a rigid motion is zero: its divergence vanishes).
        let n = elastic.operator().n_free();
        let k: usize = modes.iter().map(|m| m.modes.ncols()).sum();
        let mut all = Mat::<f64>::zeros(n, k);
        let mut labels = Vec::with_capacity(k);
        let mut pinned = Vec::new();
        let mut col = 0;
        for rm in &modes {
            for j in 0..rm.modes.ncols() {
                for i in 0..rm.modes.nrows() {
                    all[(i, col)] = rm.modes[(i, j)];
                }
                labels.push((
                    rm.body,
                    elastic.mesh().bodies[rm.body].clone(),
                    rm.coefficients[j],
                ));
                col += 1;
            }
            pinned.extend(pick_pinned(rm.modes.as_ref()));
        }
        pinned.sort_unstable();
        // The sparse path factorises K augmented by contact rows as SPD-like LDLᵀ: P1 only (the
        // scene's validation refuses `solver.contact: "sparse"` with the mixed element).
        let wants_sparse = elastic.pressure_offset().is_none()
            && match scene.solver.contact {
                ContactMethod::Dense => false,
                ContactMethod::Sparse => true,
                ContactMethod::Auto => geometry.pairs.len() >= sparse::AUTO_PAIRS,
            };
        let mut sparse_system = None;
        if wants_sparse {
            let off_pairs = pinned_off_pairs(&all, &geometry, &modes);
            match SparseSystem::new(&geometry, elastic.operator().pattern(), off_pairs.clone())? {
                Ok(system) => {
                    pinned = off_pairs;
                    sparse_system = Some(system);
                }
                Err(reason) if scene.solver.contact == ContactMethod::Sparse => {
                    return Err(SceneError::new(
                        "solver.contact",
                        format!("the sparse contact path cannot take this scene: {reason}; use \"dense\" or \"auto\""),
                    )
                    .into());
                }
                Err(_) => {}
            }
        }
        let mut g = Mat::<f64>::zeros(k, geometry.dim());
        for (r, row) in geometry.rows.iter().enumerate() {
            for j in 0..k {
                g[(j, r)] = row.free.iter().map(|&(i, c)| c * all[(i, j)]).sum();
            }
        }
        let gram = all.transpose() * &all;
        let gram_inverse = if k == 0 {
            Mat::zeros(0, 0)
        } else {
            gram.llt(faer::Side::Lower)
                .map_err(|_| WsmError::contact("rigid modes of the floating bodies are dependent"))?
                .inverse()
        };
        let bodies = match sparse_system {
            Some(_) => Vec::new(),
            None => body_blocks(elastic, &geometry, &pinned)?,
        };
        Ok(DirectContact {
            feasibility: Feasibility::new(&geometry, elastic.dofs()),
            geometry,
            coulomb_anderson_depth: scene.solver.coulomb_acceleration.depth(),
            kernel: Kernel {
                modes: all,
                labels,
                pinned,
                gram_inverse,
            },
            g,
            bodies,
            sparse: sparse_system,
        })
    }

    /// Whether the scene takes the sparse contact path (no C, no dense derivatives).
    pub fn is_sparse(&self) -> bool {
        self.sparse.is_some()
    }

    /// Nonzeros of one step's factor on the sparse path (None on the dense path).
    pub fn sparse_factor_nnz(&self) -> Option<usize> {
        self.sparse.as_ref().map(SparseSystem::factor_nnz)
    }

    /// G = RᵀBᵀ and e = Rᵀ f: the equilibrium rows of the floating bodies for free-DOF loads f.
    pub fn equilibrium(&self, f: &[f64]) -> (Mat<f64>, Vec<f64>) {
        let e = (0..self.kernel_dim())
            .map(|j| (0..f.len()).map(|i| self.kernel.modes[(i, j)] * f[i]).sum())
            .collect();
        (self.g.clone(), e)
    }

    /// Number of rigid motions left to the contact (sum over floating bodies).
    pub fn kernel_dim(&self) -> usize {
        self.kernel.labels.len()
    }

    /// Put a displacement on the free DOFs into the solver-independent normal form: no
    /// (Euclidean) component along any rigid motion that neither the energy nor a contact row
    /// with free multiplier determines (see `Kernel::free_motions`). Returns how many there are.
    pub fn normalise_free_motions(
        &self,
        u_free: &mut [f64],
        data: &Data,
        multipliers: &[f64],
    ) -> Result<usize, WsmError> {
        let (lower, upper) = self.geometry.bounds(data, Some(multipliers));
        let z = self.kernel.free_motions(&self.geometry, &lower, &upper)?;
        remove_components(z.as_ref(), u_free);
        Ok(z.ncols())
    }

    /// The body blocks of K.
    pub fn bodies(&self) -> &[BodyBlock] {
        &self.bodies
    }

    /// Assemble K for the coefficients, pin the floating DOFs, factorise, and form C (every body
    /// factorised afresh).
    pub fn factor(
        &self,
        elastic: &ElasticProblem,
        coefficients: &[ElasticCoefficients],
        par: Par,
    ) -> Result<StiffnessFactor, WsmError> {
        let fresh = |_: usize, body: &BodyBlock, values: &[f64]| {
            body.factor(values).map(|f| (Arc::new(f), false))
        };
        self.factor_with(elastic, coefficients, par, &fresh)
    }

    /// As [`Self::factor`], with the body factors taken from `cache` (bodies in parallel unless
    /// `par` is sequential; each body factor is sequential, so the result does not depend on
    /// `par`). C is summed body by body in body order.
    pub fn factor_with(
        &self,
        elastic: &ElasticProblem,
        coefficients: &[ElasticCoefficients],
        par: Par,
        cache: BodyCache,
    ) -> Result<StiffnessFactor, WsmError> {
        let start = std::time::Instant::now();
        let values = elastic.operator().assemble(coefficients)?;
        if self.sparse.is_some() {
            // The sparse path factorises per active set; K's values are all it needs.
            return Ok(StiffnessFactor {
                coefficients: coefficients.to_vec(),
                values,
                parts: Vec::new(),
                c: Mat::zeros(0, 0),
                c_condition: OnceLock::new(),
                reused_bodies: 0,
                seconds: [start.elapsed().as_secs_f64(), 0.0],
            });
        }
        let body = |(b, block): (usize, &BodyBlock)| cache(b, block, &values);
        let parts: Vec<(Arc<BodyFactor>, bool)> = match par {
            Par::Seq => self
                .bodies
                .iter()
                .enumerate()
                .map(body)
                .collect::<Result<_, _>>(),
            _ => self
                .bodies
                .par_iter()
                .enumerate()
                .map(body)
                .collect::<Result<_, _>>(),
        }?;
        let numeric = start.elapsed().as_secs_f64();
        let start = std::time::Instant::now();
        let m = self.geometry.dim();
        let mut c = Mat::<f64>::zeros(m, m);
        for (block, (part, _)) in self.bodies.iter().zip(&parts) {
            block.add_schur(part, &mut c);
        }
        let reused_bodies = parts.iter().filter(|p| p.1).count();
        let mut factor = StiffnessFactor {
            coefficients: coefficients.to_vec(),
            values,
            parts: parts.into_iter().map(|p| p.0).collect(),
            c: Mat::zeros(0, 0),
            c_condition: OnceLock::new(),
            reused_bodies,
            seconds: [numeric, 0.0],
        };
        factor.c = self.project_hessian(&factor, c);
        factor.seconds[1] = start.elapsed().as_secs_f64();
        Ok(factor)
    }

    /// X = K⁺ B for the `columns` right-hand sides stored one after the other in `b`, in one
    /// multi-right-hand-side solve per body (pinned entries zero on input and output).
    fn pseudo_solve(&self, factor: &StiffnessFactor, b: &mut [f64], columns: usize) {
        if columns == 0 {
            return;
        }
        let n = b.len() / columns;
        let zero_pinned = |b: &mut [f64]| {
            for column in b.chunks_exact_mut(n) {
                for &p in &self.kernel.pinned {
                    column[p] = 0.0;
                }
            }
        };
        zero_pinned(b);
        let mut x = faer::MatMut::from_column_major_slice_mut(b, n, columns);
        for (block, part) in self.bodies.iter().zip(&factor.parts) {
            block.solve_in_place(part, x.as_mut());
        }
        zero_pinned(b);
    }

    /// x = P K⁺ P b: the symmetric generalised inverse of the TFETI-style projected formulation.
    /// For loads a floating body can carry (Rᵀb = 0) it gives a solution of K x = b like K⁺, but
    /// the unbalanced part of b no longer produces the huge deformation of a pinned body, which
    /// keeps d and C on the scale of the true displacements (relative QP tolerances stay
    /// meaningful for slender floating bodies).
    fn projected_solve(&self, factor: &StiffnessFactor, b: &mut [f64]) {
        self.projected_solve_columns(factor, b, 1);
    }

    /// [`Self::projected_solve`] of `columns` right-hand sides stored one after the other.
    fn projected_solve_columns(&self, factor: &StiffnessFactor, b: &mut [f64], columns: usize) {
        if columns == 0 {
            return;
        }
        let n = b.len() / columns;
        b.chunks_exact_mut(n).for_each(|c| self.kernel.project(c));
        self.pseudo_solve(factor, b, columns);
        b.chunks_exact_mut(n).for_each(|c| self.kernel.project(c));
    }

    /// C' = B P K⁺ P Bᵀ from C = B K⁺ Bᵀ: with Z = K⁺R, X = B Z, Q = Rᵀ Z, M = (RᵀR)⁻¹ and
    /// P Bᵀ = Bᵀ − R M G: C' = C − X M G − Gᵀ M Xᵀ + Gᵀ M Q M G.
    fn project_hessian(&self, factor: &StiffnessFactor, mut c: Mat<f64>) -> Mat<f64> {
        let k = self.kernel_dim();
        if k == 0 {
            return c;
        }
        let (n, m) = (self.kernel.modes.nrows(), self.geometry.dim());
        let mut columns: Vec<f64> = (0..k)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .map(|(i, j)| self.kernel.modes[(i, j)])
            .collect();
        self.pseudo_solve(factor, &mut columns, k);
        let z = Mat::<f64>::from_fn(n, k, |i, j| columns[j * n + i]);
        let x = Mat::<f64>::from_fn(m, k, |r, j| {
            self.geometry.rows[r]
                .free
                .iter()
                .map(|&(i, cf)| cf * z[(i, j)])
                .sum()
        });
        let q = self.kernel.modes.transpose() * &z;
        let mg = &self.kernel.gram_inverse * &self.g; // k × m
        let xmg = &x * &mg; // m × m
        let correction = mg.transpose() * (&q * &mg);
        for j in 0..m {
            for r in 0..m {
                c[(r, j)] += correction[(r, j)] - xmg[(r, j)] - xmg[(j, r)];
            }
        }
        // Exact symmetry (the QP checks it): average the rounding of the two triangles.
        for j in 0..m {
            for r in 0..j {
                let v = 0.5 * (c[(r, j)] + c[(j, r)]);
                c[(r, j)] = v;
                c[(j, r)] = v;
            }
        }
        c
    }

    /// Solve the contact problem for the reduced right-hand side `rhs` (loads and lifting) and
    /// prescribed values `fixed`: one Tresca problem, or on Coulomb zones the fixed point of
    /// Tresca problems ([`coulomb::solve`]) on the same factor and C, each step warm-started from
    /// the previous one.
    pub fn solve(
        &self,
        factor: &StiffnessFactor,
        elastic: &ElasticProblem,
        rhs: &[f64],
        fixed: &[f64],
        data: &Data,
        warm: Option<&WarmStart>,
    ) -> Result<ContactSolution, WsmError> {
        let inputs = TrescaInputs {
            factor,
            elastic,
            rhs,
            fixed,
        };
        let mut qp_seconds = 0.0;
        let mut sparse_steps = (0, 0);
        let tresca = |lower: &[f64], upper: &[f64], previous: Option<&ContactSolution>| {
            let start = previous.map(|p| WarmStart {
                x: p.multipliers.clone(),
                alpha: p.rigid.clone(),
            });
            let start = start.as_ref().or(warm);
            let sol = match &self.sparse {
                Some(system) => self.solve_tresca_sparse(system, &inputs, lower, upper, start)?,
                None => self.solve_tresca(&inputs, lower, upper, start)?,
            };
            qp_seconds += sol.qp_seconds;
            if let Some(r) = &sol.sparse {
                sparse_steps.0 += r.steps;
                sparse_steps.1 += r.changes;
            }
            Ok(sol)
        };
        // A step's multipliers are exact to the QP's relative KKT residual amplified by the
        // condition of C (unknown, so no rounding level beyond the tolerance, when C is not
        // numerically positive definite).
        let rounding_level = |s: &ContactSolution| match (&s.qp, &s.sparse) {
            (_, Some(report)) => report.accuracy,
            (Some(qp), None) => factor
                .scaled_condition()
                .map_or(0.0, |kappa| kappa * qp.kkt.max()),
            (None, None) => 0.0,
        };
        let (mut sol, report) = coulomb::solve(
            &self.geometry,
            data,
            self.coulomb_anderson_depth,
            tresca,
            |s| s.multipliers.as_slice(),
            rounding_level,
            WsmError::contact,
        )?;
        sol.coulomb = report;
        sol.qp_seconds = qp_seconds;
        if let Some(total) = sol.sparse.as_mut() {
            // Steps and changes summed over the Tresca problems of a Coulomb solve.
            total.steps = sparse_steps.0;
            total.changes = sparse_steps.1;
        }
        Ok(sol)
    }

    /// Solve the contact problem with the multiplier bounds `lower`, `upper` (a Tresca problem).
    fn solve_tresca(
        &self,
        inputs: &TrescaInputs,
        lower: &[f64],
        upper: &[f64],
        warm: Option<&WarmStart>,
    ) -> Result<ContactSolution, WsmError> {
        let TrescaInputs {
            factor,
            elastic,
            rhs,
            fixed,
        } = *inputs;
        let geometry = &self.geometry;
        let m = geometry.dim();
        let mut x0 = rhs.to_vec();
        self.projected_solve(factor, &mut x0);
        let mut d: Vec<f64> = (0..m).map(|r| geometry.rows[r].dot(&x0)).collect();
        self.add_offsets(fixed, &mut d);
        let mut start = warm.cloned();
        let mut refinements = 0;
        let mut qp_seconds = 0.0;
        let free_motions = self.kernel.free_motions(geometry, lower, upper)?;
        let (qp, multipliers, rigid, u_free, gaps) = loop {
            let (qp, multipliers, rigid) = if m == 0 && self.kernel_dim() == 0 {
                (None, Vec::new(), Vec::new())
            } else {
                let (g, e) = self.equilibrium(rhs);
                let problem =
                    BoxQp::new(factor.c.clone(), d.clone(), lower.to_vec(), upper.to_vec())
                        .with_equalities(g, e);
                let options = QpOptions {
                    parallel: false,
                    ..QpOptions::default()
                };
                let t = std::time::Instant::now();
                let sol = solve_box_qp(&problem, start.as_ref(), &options)
                    .map_err(|err| self.explain(err))?;
                qp_seconds += t.elapsed().as_secs_f64();
                let (x, alpha) = (sol.x.clone(), sol.alpha.clone());
                (Some(sol), x, alpha)
            };
            let mut u_free = self.recover(factor, rhs, &multipliers, &rigid);
            remove_components(free_motions.as_ref(), &mut u_free);
            let gaps = self.gaps(&u_free, fixed);
            // Iterative refinement of the condensed problem: the QP saw w = d − Cλ + Gᵀα with C
            // and d from solves with K; for an ill-conditioned K they differ from the true gaps
            // B u − g0 by rounding. Shift d by the defect and re-solve from the same active set.
            let Some(sol) = qp.as_ref() else {
                break (qp, multipliers, rigid, u_free, gaps);
            };
            let u_scale = u_free.iter().fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()));
            let defect: Vec<f64> = gaps.iter().zip(&sol.w).map(|(t, w)| t - w).collect();
            let worst = defect.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            if worst <= REFINE_TOL * u_scale || refinements == MAX_REFINEMENTS {
                break (qp, multipliers, rigid, u_free, gaps);
            }
            for (di, delta) in d.iter_mut().zip(&defect) {
                *di += delta;
            }
            start = Some(WarmStart::from(sol));
            refinements += 1;
        };
        Ok(ContactSolution {
            equilibrium_residual: self.equilibrium_residual(
                elastic,
                &factor.values,
                &u_free,
                &multipliers,
                rhs,
            ),
            u_free,
            multipliers,
            rigid,
            gaps,
            qp,
            free_motions: free_motions.ncols(),
            qp_seconds,
            refinements,
            coulomb: None,
            sparse: None,
        })
    }

    /// [`Self::solve_tresca`] on the sparse path ([`super::sparse`]): the active-set iteration
    /// on the primal, then the dense path's normal form (no component along free motions).
    fn solve_tresca_sparse(
        &self,
        system: &SparseSystem,
        inputs: &TrescaInputs,
        lower: &[f64],
        upper: &[f64],
        warm: Option<&WarmStart>,
    ) -> Result<ContactSolution, WsmError> {
        let (factor, rhs, fixed) = (inputs.factor, inputs.rhs, inputs.fixed);
        let start = std::time::Instant::now();
        let mut offsets = vec![0.0; self.geometry.dim()];
        self.add_offsets(fixed, &mut offsets);
        let problem = TrescaProblem {
            geometry: &self.geometry,
            modes: self.kernel.modes.as_ref(),
            k_values: &factor.values,
            rhs,
            offsets: &offsets,
            lower,
            upper,
        };
        // A warm start from other data may lead the iteration into a cycle that the bonded,
        // closed start avoids: try that before giving up.
        let outcome = match sparse::solve(system, &problem, warm, Par::Seq) {
            Err(SparseFailure::NotConverged(_)) if warm.is_some() => {
                sparse::solve(system, &problem, None, Par::Seq)
            }
            other => other,
        };
        let outcome = outcome.map_err(|e| match e {
            SparseFailure::Unbalanced { mode, residual } => self.explain(QpError::Infeasible {
                equality_rows: vec![mode],
                residuals: vec![residual],
            }),
            SparseFailure::NotConverged(reason) => {
                WsmError::contact(format!("sparse contact solver: {reason}"))
            }
            SparseFailure::Solver(e) => e,
        })?;
        let free_motions = self.kernel.free_motions(&self.geometry, lower, upper)?;
        let mut u_free = outcome.u;
        remove_components(free_motions.as_ref(), &mut u_free);
        let gaps = self.gaps(&u_free, fixed);
        Ok(ContactSolution {
            equilibrium_residual: self.equilibrium_residual(
                inputs.elastic,
                &factor.values,
                &u_free,
                &outcome.multipliers,
                rhs,
            ),
            u_free,
            multipliers: outcome.multipliers,
            rigid: outcome.rigid,
            gaps,
            qp: None,
            free_motions: free_motions.ncols(),
            qp_seconds: start.elapsed().as_secs_f64(),
            refinements: 0,
            coulomb: None,
            sparse: Some(SparseReport {
                steps: outcome.steps,
                changes: outcome.changes,
                accuracy: outcome.accuracy,
                factor_nnz: system.factor_nnz(),
            }),
        })
    }

    /// Relative gap and slip B u + B_d u_d − g0 of a free-DOF displacement.
    pub fn gaps(&self, u_free: &[f64], fixed: &[f64]) -> Vec<f64> {
        let mut gaps = self.geometry.apply(u_free);
        self.add_offsets(fixed, &mut gaps);
        gaps
    }

    /// ‖K u − f + Bᵀλ‖ / ‖f‖ on the free DOFs, with K assembled from `values`.
    pub fn equilibrium_residual(
        &self,
        elastic: &ElasticProblem,
        values: &[f64],
        u_free: &[f64],
        multipliers: &[f64],
        rhs: &[f64],
    ) -> f64 {
        let mut residual = elastic.operator().apply(values, u_free);
        self.geometry.add_transpose(multipliers, &mut residual);
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        for (r, b) in residual.iter_mut().zip(rhs) {
            *r -= b;
        }
        norm(&residual) / norm(rhs).max(f64::MIN_POSITIVE)
    }

    /// Add B_d u_d − g0 (prescribed values on contact nodes, initial gaps on normal rows).
    fn add_offsets(&self, fixed: &[f64], v: &mut [f64]) {
        for (r, (row, vr)) in self.geometry.rows.iter().zip(v.iter_mut()).enumerate() {
            let gap = if is_normal_row(r) {
                self.geometry.pairs[pair_of_row(r)].gap
            } else {
                0.0
            };
            *vr += row.dot_fixed(fixed) - gap;
        }
    }

    /// u = P K⁺ P (f − Bᵀλ) + R α on the free DOFs.
    fn recover(
        &self,
        factor: &StiffnessFactor,
        rhs: &[f64],
        multipliers: &[f64],
        rigid: &[f64],
    ) -> Vec<f64> {
        self.recover_all(factor, &[(rhs, multipliers, rigid)])
            .pop()
            .unwrap_or_default()
    }

    /// [`Self::recover`] for several (f, λ, α), in one multi-right-hand-side solve.
    fn recover_all(
        &self,
        factor: &StiffnessFactor,
        states: &[(&[f64], &[f64], &[f64])],
    ) -> Vec<Vec<f64>> {
        let n = states.first().map_or(0, |(rhs, _, _)| rhs.len());
        let mut buffer: Vec<f64> = Vec::with_capacity(n * states.len());
        for (rhs, multipliers, _) in states {
            let start = buffer.len();
            buffer.extend_from_slice(rhs);
            let u_free = &mut buffer[start..];
            for (row, l) in self.geometry.rows.iter().zip(multipliers.iter()) {
                for &(i, c) in &row.free {
                    u_free[i] -= c * l;
                }
            }
        }
        self.projected_solve_columns(factor, &mut buffer, states.len());
        buffer
            .chunks_exact(n.max(1))
            .zip(states)
            .map(|(u, (_, _, rigid))| {
                let mut u_free = u.to_vec();
                for (j, a) in rigid.iter().enumerate() {
                    for (i, ui) in u_free.iter_mut().enumerate() {
                        *ui += self.kernel.modes[(i, j)] * a;
                    }
                }
                u_free
            })
            .collect()
    }

    /// Turn an infeasible equilibrium into a message naming the body and the motion.
    pub fn explain(&self, err: QpError) -> WsmError {
        match err {
            QpError::Infeasible {
                equality_rows,
                residuals,
            } => {
                let row = equality_rows.first().copied().unwrap_or(0);
                let (index, body, [tx, ty, rot]) =
                    self.kernel.labels.get(row).cloned().unwrap_or_default();
                // Residual G x − e < 0: the load's work on the mode exceeds what contact can
                // resist, so the body would move along +mode (and along −mode otherwise).
                let sign = if residuals.first().copied().unwrap_or(0.0) < 0.0 {
                    1.0
                } else {
                    -1.0
                };
                // (+ 0.0 turns −0.0 into 0.0 for printing.)
                let (tx, ty, rot) = (sign * tx + 0.0, sign * ty + 0.0, sign * rot + 0.0);
                WsmError::UnbalancedMode {
                    body,
                    index,
                    motion: describe_motion(tx, ty, rot),
                }
            }
            other => WsmError::contact(other.to_string()),
        }
    }
}

/// One DOF per rigid mode of the floating bodies, none on a contact pair (the sparse path
/// prescribes the pairs' coordinates), chosen as [`pick_pinned`] does on the other DOFs.
fn pinned_off_pairs(
    all: &Mat<f64>,
    geometry: &ContactGeometry,
    modes: &[RigidModes],
) -> Vec<usize> {
    let mut on_pairs = vec![false; all.nrows()];
    for row in &geometry.rows {
        row.free.iter().for_each(|&(i, _)| on_pairs[i] = true);
    }
    let mut pinned = Vec::new();
    for rm in modes {
        let off = Mat::<f64>::from_fn(rm.modes.nrows(), rm.modes.ncols(), |i, j| {
            if on_pairs[i] {
                0.0
            } else {
                rm.modes[(i, j)]
            }
        });
        pinned.extend(pick_pinned(off.as_ref()));
    }
    pinned.sort_unstable();
    pinned
}

/// A human description of a rigid motion a (1,0) + b (0,1) + c rotation.
fn describe_motion(tx: f64, ty: f64, rot: f64) -> String {
    let scale = tx.abs().max(ty.abs()).max(rot.abs()).max(f64::MIN_POSITIVE);
    let mut parts = Vec::new();
    if tx.abs().max(ty.abs()) > 1e-6 * scale {
        let n = tx.hypot(ty);
        parts.push(format!("translation along ({:.3}, {:.3})", tx / n, ty / n));
    }
    if rot.abs() > 1e-6 * scale {
        parts.push(
            if rot > 0.0 {
                "counter-clockwise rotation"
            } else {
                "clockwise rotation"
            }
            .to_string(),
        );
    }
    parts.join(" with ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::StateProblem;

    /// C' = B P K⁺ P Bᵀ the direct way: one projected solve per column of Bᵀ.
    fn schur_by_solves(contact: &DirectContact, factor: &StiffnessFactor) -> Mat<f64> {
        let rows = &contact.geometry.rows;
        let n = factor.values.len().min(contact.kernel.modes.nrows());
        let mut c = Mat::<f64>::zeros(rows.len(), rows.len());
        for (j, row) in rows.iter().enumerate() {
            let mut y = vec![0.0; n];
            for &(i, v) in &row.free {
                y[i] += v;
            }
            contact.projected_solve(factor, &mut y);
            for (r, other) in rows.iter().enumerate() {
                c[(r, j)] = other.dot(&y);
            }
        }
        c
    }

    fn relative_difference(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
        let scale = b.norm_max().max(f64::MIN_POSITIVE);
        (a - b).norm_max() / scale
    }

    fn block_on_base() -> StateProblem {
        let text = crate::bundled::example("block-on-base").expect("example exists");
        let scene = crate::scene::parse(text).expect("example parses");
        StateProblem::new(scene).expect("example builds")
    }

    #[test]
    fn schur_from_trailing_factor_matches_solves() {
        let problem = block_on_base();
        let contact = &problem.contact;
        assert!(contact.kernel_dim() > 0, "the block floats");
        assert_eq!(contact.bodies.len(), 2, "one block of K per body");
        let coefficients = problem.elastic.coefficients(&problem.nominal).unwrap();
        let mut first: Option<Mat<f64>> = None;
        for par in [Par::Seq, Par::rayon(2)] {
            let f = contact
                .factor(&problem.elastic, &coefficients, par)
                .unwrap();
            let diff = relative_difference(&f.c, &schur_by_solves(contact, &f));
            assert!(diff < 1e-12, "relative difference {diff:e}");
            assert_eq!(f.c, f.c.transpose().to_owned(), "C exactly symmetric");
            match &first {
                Some(c) => assert_eq!(&f.c, c, "C does not depend on the parallelism"),
                None => first = Some(f.c.clone()),
            }
        }
    }

    #[test]
    fn pinned_contact_dof_contributes_nothing() {
        let problem = block_on_base();
        let mut contact = problem.contact.clone();
        // Pin also a contact DOF of the floating block (K⁺ then has a zero row and column there).
        let body = contact.bodies.last().unwrap();
        let row = &contact.geometry.rows[body.contact_rows()[0]];
        let extra = row.free.iter().map(|&(i, _)| i).max().unwrap();
        contact.kernel.pinned.push(extra);
        contact.kernel.pinned.sort_unstable();
        contact.kernel.pinned.dedup();
        contact.bodies =
            body_blocks(&problem.elastic, &contact.geometry, &contact.kernel.pinned).unwrap();
        let coefficients = problem.elastic.coefficients(&problem.nominal).unwrap();
        let f = contact
            .factor(&problem.elastic, &coefficients, Par::Seq)
            .unwrap();
        let diff = relative_difference(&f.c, &schur_by_solves(&contact, &f));
        assert!(diff < 1e-12, "relative difference {diff:e}");
    }
}
