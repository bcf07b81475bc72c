//! The exact direct contact solver (SPEC §3.1): K factorised once per stiffness, the contact
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

use faer::linalg::matmul::triangular::{matmul, BlockStructure};
use faer::linalg::solvers::DenseSolveCore;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Accum, Mat, Par};

use super::pairs::{ContactGeometry, ContactRow};
use super::qp::{solve_box_qp, BoxQp, QpError, QpOptions, QpSolution, WarmStart};
use crate::error::WsmError;
use crate::fem::rigid::{orthonormal_columns, pick_pinned, remove_components};
use crate::fem::{ElasticProblem, Factor, RigidModes, Symbolic};
use crate::scene::Data;

/// Relative size (to the largest displacement) of the gap defect that triggers a refinement.
const REFINE_TOL: f64 = 1e-12;
/// Refinements of the condensed problem at most.
const MAX_REFINEMENTS: usize = 3;

/// Floating-body kernel on the free DOFs and the DOFs pinned to factorise K.
#[derive(Debug, Clone)]
struct Kernel {
    /// n_free × k rigid modes of all floating bodies.
    modes: Mat<f64>,
    /// Per mode: body name and (translation x, translation y, rotation) coefficients.
    labels: Vec<(String, [f64; 3])>,
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

/// One diagonal block of L₂₂ (module doc): its trailing DOFs `range`, the contact rows that
/// touch them and the dense B_cᵀ restricted to both (pinned DOFs zeroed).
#[derive(Debug, Clone)]
struct SchurBlock {
    range: std::ops::Range<usize>,
    rows: Vec<usize>,
    bt: Mat<f64>,
}

/// The contact problem of a scene: geometry, floating-body kernel and G = RᵀBᵀ, and the
/// symbolic analysis of K with the contact DOFs last.
#[derive(Debug, Clone)]
pub struct DirectContact {
    pub geometry: ContactGeometry,
    kernel: Kernel,
    g: Mat<f64>,
    symbolic: Symbolic,
    blocks: Vec<SchurBlock>,
}

/// K (with pinned DOFs) factorised for one stiffness data set, with C = B K⁺ Bᵀ.
#[derive(Debug, Clone)]
pub struct StiffnessFactor {
    /// Zone coefficients [λ_z, μ_z] the factor was built from.
    pub coefficients: Vec<[f64; 2]>,
    /// Values of the unpinned K (for residual checks).
    values: Vec<f64>,
    factor: Factor,
    c: Mat<f64>,
}

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
                    reason: "it is not held by displacement or roller conditions and touches no contact zone".into(),
                });
            }
            modes.push(elastic.rigid_modes(body)?);
        }
        let n = elastic.dofs().n_free();
        let k: usize = modes.iter().map(|m| m.modes.ncols()).sum();
        let mut all = Mat::<f64>::zeros(n, k);
        let mut labels = Vec::with_capacity(k);
        let mut pinned = Vec::new();
        let mut col = 0;
        for rm in &modes {
            for j in 0..rm.modes.ncols() {
                for i in 0..n {
                    all[(i, col)] = rm.modes[(i, j)];
                }
                labels.push((elastic.mesh().bodies[rm.body].clone(), rm.coefficients[j]));
                col += 1;
            }
            pinned.extend(pick_pinned(rm.modes.as_ref()));
        }
        pinned.sort_unstable();
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
        let (symbolic, blocks) = schur_structure(elastic, &geometry, &pinned)?;
        Ok(DirectContact {
            geometry,
            kernel: Kernel {
                modes: all,
                labels,
                pinned,
                gram_inverse,
            },
            g,
            symbolic,
            blocks,
        })
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
    ) -> Result<usize, WsmError> {
        let (lower, upper) = self.geometry.bounds(data);
        let z = self.kernel.free_motions(&self.geometry, &lower, &upper)?;
        remove_components(z.as_ref(), u_free);
        Ok(z.ncols())
    }

    /// Assemble K for the coefficients, pin the floating DOFs, factorise, and form C.
    pub fn factor(
        &self,
        elastic: &ElasticProblem,
        coefficients: &[[f64; 2]],
        par: Par,
    ) -> Result<StiffnessFactor, WsmError> {
        let op = elastic.operator();
        let values = op.assemble(coefficients)?;
        let mut pinned_values = values.clone();
        pin(op.pattern(), &mut pinned_values, &self.kernel.pinned);
        let factor = self.symbolic.factorize(op.matrix(&pinned_values), par)?;
        let c = self.schur(&factor, par)?;
        let c = self.project_hessian(&factor, c);
        Ok(StiffnessFactor {
            coefficients: coefficients.to_vec(),
            values,
            factor,
            c,
        })
    }

    /// x = K⁺ b (pinned entries zero on input and output).
    fn pseudo_solve(&self, factor: &Factor, b: &mut [f64]) {
        for &p in &self.kernel.pinned {
            b[p] = 0.0;
        }
        let mut x = faer::MatMut::from_column_major_slice_mut(b, b.len(), 1);
        factor.solve_in_place(x.as_mut());
        for &p in &self.kernel.pinned {
            b[p] = 0.0;
        }
    }

    /// x = P K⁺ P b: the symmetric generalised inverse of the TFETI-style projected formulation.
    /// For loads a floating body can carry (Rᵀb = 0) it gives a solution of K x = b like K⁺, but
    /// the unbalanced part of b no longer produces the huge deformation of a pinned body, which
    /// keeps d and C on the scale of the true displacements (relative QP tolerances stay
    /// meaningful for slender floating bodies).
    fn projected_solve(&self, factor: &Factor, b: &mut [f64]) {
        self.kernel.project(b);
        self.pseudo_solve(factor, b);
        self.kernel.project(b);
    }

    /// C' = B P K⁺ P Bᵀ from C = B K⁺ Bᵀ: with Z = K⁺R, X = B Z, Q = Rᵀ Z, M = (RᵀR)⁻¹ and
    /// P Bᵀ = Bᵀ − R M G: C' = C − X M G − Gᵀ M Xᵀ + Gᵀ M Q M G.
    fn project_hessian(&self, factor: &Factor, mut c: Mat<f64>) -> Mat<f64> {
        let k = self.kernel_dim();
        if k == 0 {
            return c;
        }
        let (n, m) = (self.kernel.modes.nrows(), self.geometry.dim());
        let mut z = Mat::<f64>::zeros(n, k);
        for j in 0..k {
            let mut col: Vec<f64> = (0..n).map(|i| self.kernel.modes[(i, j)]).collect();
            self.pseudo_solve(factor, &mut col);
            for (i, v) in col.into_iter().enumerate() {
                z[(i, j)] = v;
            }
        }
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

    /// C = Σ_blocks Wᵀ W with W = L₂₂⁻¹ B_cᵀ on each diagonal block of L₂₂ (module doc);
    /// only the lower triangle of each Wᵀ W is computed and mirrored, so C is exactly symmetric.
    fn schur(&self, factor: &Factor, par: Par) -> Result<Mat<f64>, WsmError> {
        let m = self.geometry.dim();
        let mut c = Mat::<f64>::zeros(m, m);
        for block in &self.blocks {
            let l = factor.trailing_block(block.range.clone())?;
            let mut w = block.bt.clone();
            solve_lower_triangular_in_place(l.as_ref(), w.as_mut(), par);
            let k = block.rows.len();
            let mut wtw = Mat::<f64>::zeros(k, k);
            matmul(
                wtw.as_mut(),
                BlockStructure::TriangularLower,
                Accum::Replace,
                w.transpose(),
                BlockStructure::Rectangular,
                w.as_ref(),
                BlockStructure::Rectangular,
                1.0,
                par,
            );
            for (j, &rj) in block.rows.iter().enumerate() {
                for (i, &ri) in block.rows.iter().enumerate().skip(j) {
                    let v = wtw[(i, j)];
                    c[(ri, rj)] += v;
                    if ri != rj {
                        c[(rj, ri)] += v;
                    }
                }
            }
        }
        Ok(c)
    }

    /// Solve the contact problem for the reduced right-hand side `rhs` (loads and lifting) and
    /// prescribed values `fixed`.
    pub fn solve(
        &self,
        factor: &StiffnessFactor,
        elastic: &ElasticProblem,
        rhs: &[f64],
        fixed: &[f64],
        data: &Data,
        warm: Option<&WarmStart>,
    ) -> Result<ContactSolution, WsmError> {
        let geometry = &self.geometry;
        let m = geometry.dim();
        let mut x0 = rhs.to_vec();
        self.projected_solve(&factor.factor, &mut x0);
        let mut d: Vec<f64> = (0..m).map(|r| geometry.rows[r].dot(&x0)).collect();
        self.add_offsets(fixed, &mut d);
        let mut start = warm.cloned();
        let mut refinements = 0;
        let (lower, upper) = geometry.bounds(data);
        let free_motions = self.kernel.free_motions(geometry, &lower, &upper)?;
        let (qp, multipliers, rigid, u_free, gaps) = loop {
            let (qp, multipliers, rigid) = if m == 0 && self.kernel_dim() == 0 {
                (None, Vec::new(), Vec::new())
            } else {
                let (g, e) = self.equilibrium(rhs);
                let problem = BoxQp::new(factor.c.clone(), d.clone(), lower.clone(), upper.clone())
                    .with_equalities(g, e);
                let options = QpOptions {
                    parallel: false,
                    ..QpOptions::default()
                };
                let sol = solve_box_qp(&problem, start.as_ref(), &options)
                    .map_err(|err| self.explain(err))?;
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
            let gap = if r % 2 == 0 {
                self.geometry.pairs[r / 2].gap
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
        let mut u_free = rhs.to_vec();
        for (row, l) in self.geometry.rows.iter().zip(multipliers) {
            for &(i, c) in &row.free {
                u_free[i] -= c * l;
            }
        }
        self.projected_solve(&factor.factor, &mut u_free);
        for (j, a) in rigid.iter().enumerate() {
            for (i, ui) in u_free.iter_mut().enumerate() {
                *ui += self.kernel.modes[(i, j)] * a;
            }
        }
        u_free
    }

    /// Turn an infeasible equilibrium into a message naming the body and the motion.
    pub fn explain(&self, err: QpError) -> WsmError {
        match err {
            QpError::Infeasible {
                equality_rows,
                residuals,
            } => {
                let row = equality_rows.first().copied().unwrap_or(0);
                let (body, [tx, ty, rot]) =
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
                    motion: describe_motion(tx, ty, rot),
                }
            }
            other => WsmError::contact(other.to_string()),
        }
    }
}

/// The contact DOFs (free DOFs with a nonzero in a row of B) grouped body by body, the symbolic
/// analysis of K with them ordered last, and the diagonal blocks of L₂₂ with their dense B_cᵀ.
/// Without contact the plain AMD analysis of the operator is shared.
fn schur_structure(
    elastic: &ElasticProblem,
    geometry: &ContactGeometry,
    pinned: &[usize],
) -> Result<(Symbolic, Vec<SchurBlock>), WsmError> {
    let op = elastic.operator();
    let (mesh, dofs) = (elastic.mesh(), elastic.dofs());
    let mut body_of = vec![usize::MAX; op.n_free()];
    for pair in &geometry.pairs {
        for &node in &pair.nodes {
            for slot in dofs.slots(node) {
                if let crate::fem::Slot::Free(i) = slot {
                    body_of[i] = mesh.node_body[node];
                }
            }
        }
    }
    let mut contact: Vec<usize> = geometry
        .rows
        .iter()
        .flat_map(|row| row.free.iter().map(|&(i, _)| i))
        .collect();
    contact.sort_unstable_by_key(|&i| (body_of[i], i));
    contact.dedup();
    if contact.is_empty() {
        return Ok((op.symbolic().clone(), Vec::new()));
    }
    let symbolic = Symbolic::analyse_with_trailing(op.pattern(), &contact)?;
    let mut position = vec![usize::MAX; op.n_free()];
    for (k, &i) in contact.iter().enumerate() {
        position[i] = k;
    }
    let bounds = symbolic.trailing_blocks();
    let blocks = bounds
        .windows(2)
        .map(|w| {
            let range = w[0]..w[1];
            let inside =
                |i: usize| range.contains(&position[i]) && pinned.binary_search(&i).is_err();
            let rows: Vec<usize> = (0..geometry.dim())
                .filter(|&r| {
                    geometry.rows[r]
                        .free
                        .iter()
                        .any(|&(i, c)| c != 0.0 && inside(i))
                })
                .collect();
            let mut bt = Mat::<f64>::zeros(range.len(), rows.len());
            for (j, &r) in rows.iter().enumerate() {
                for &(i, c) in &geometry.rows[r].free {
                    if inside(i) {
                        bt[(position[i] - range.start, j)] += c;
                    }
                }
            }
            SchurBlock { range, rows, bt }
        })
        .filter(|b| !b.rows.is_empty())
        .collect();
    Ok((symbolic, blocks))
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

/// Replace the rows and columns of `pinned` DOFs by the identity scaled to the mean diagonal.
fn pin(
    pattern: faer::sparse::SymbolicSparseColMatRef<'_, usize>,
    values: &mut [f64],
    pinned: &[usize],
) {
    if pinned.is_empty() {
        return;
    }
    let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
    let n = pattern.ncols();
    let mut diag_sum = 0.0;
    for c in 0..n {
        for p in col_ptr[c]..col_ptr[c + 1] {
            if row_idx[p] == c {
                diag_sum += values[p].abs();
            }
        }
    }
    let diag = (diag_sum / n.max(1) as f64).max(f64::MIN_POSITIVE);
    for c in 0..n {
        let col_pinned = pinned.binary_search(&c).is_ok();
        for p in col_ptr[c]..col_ptr[c + 1] {
            let r = row_idx[p];
            if col_pinned || pinned.binary_search(&r).is_ok() {
                values[p] = if r == c { diag } else { 0.0 };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::StateProblem;

    /// C' = B P K⁺ P Bᵀ the direct way: one projected solve per column of Bᵀ.
    fn schur_by_solves(contact: &DirectContact, factor: &Factor) -> Mat<f64> {
        let rows = &contact.geometry.rows;
        let n = factor.dim();
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
        let text = crate::examples::example("block-on-base").expect("example exists");
        let scene = crate::scene::parse(text).expect("example parses");
        StateProblem::new(scene).expect("example builds")
    }

    #[test]
    fn schur_from_trailing_factor_matches_solves() {
        let problem = block_on_base();
        let contact = &problem.contact;
        assert!(contact.kernel_dim() > 0, "the block floats");
        assert!(
            contact.blocks.len() >= 2,
            "one block of L22 per body: {}",
            contact.blocks.len()
        );
        let coefficients = problem.elastic.coefficients(&problem.nominal).unwrap();
        for par in [Par::Seq, Par::rayon(2)] {
            let f = contact
                .factor(&problem.elastic, &coefficients, par)
                .unwrap();
            let diff = relative_difference(&f.c, &schur_by_solves(contact, &f.factor));
            assert!(diff < 1e-12, "relative difference {diff:e}");
            assert_eq!(f.c, f.c.transpose().to_owned(), "C exactly symmetric");
        }
    }

    #[test]
    fn pinned_contact_dof_contributes_nothing() {
        let problem = block_on_base();
        let mut contact = problem.contact.clone();
        // Pin also a contact DOF of the floating block (K⁺ then has a zero row and column there).
        let block = contact.blocks.last().unwrap();
        let row = &contact.geometry.rows[block.rows[0]];
        let extra = row.free.iter().map(|&(i, _)| i).max().unwrap();
        contact.kernel.pinned.push(extra);
        contact.kernel.pinned.sort_unstable();
        contact.kernel.pinned.dedup();
        let (symbolic, blocks) =
            schur_structure(&problem.elastic, &contact.geometry, &contact.kernel.pinned).unwrap();
        (contact.symbolic, contact.blocks) = (symbolic, blocks);
        let coefficients = problem.elastic.coefficients(&problem.nominal).unwrap();
        let f = contact
            .factor(&problem.elastic, &coefficients, Par::Seq)
            .unwrap();
        let diff = relative_difference(&f.c, &schur_by_solves(&contact, &f.factor));
        assert!(diff < 1e-12, "relative difference {diff:e}");
    }
}
