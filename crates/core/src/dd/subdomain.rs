//! Subdomain linear algebra (D05 §4.3, §5.1; design §3.2, "Local operators").
//!
//! A [`LinearBlock`] is a subdomain (or a tied contact cluster) with its local stiffness ordered
//! interior first, A = [Å B; Bᵀ Ā] = [K_II K_IΓ; K_ΓI K_ΓΓ] (D05 4.24). It provides
//! - the Schur complement S y = K_ΓΓ y − K_ΓI K_II⁻¹ K_IΓ y, matrix-free through a sparse Cholesky
//!   factor of K_II (interior Dirichlet solves, D05 4.24–4.26);
//! - the condensed load g = f_Γ − K_ΓI K_II⁻¹ f_I (its share of F, D05 4.34);
//! - the Neumann solve S⁺ g: the full local problem with interface load g (D05 5.1–5.2), factored
//!   with a minimal set of DOFs pinned when the subdomain is floating and the kernel projected out
//!   (the particular solution φ⁰ ∈ Q, D05 5.10);
//! - the kernel Z = Ker A (rigid motions surviving the subdomain's Dirichlet/roller constraints,
//!   D05 3.29), found as the null space of A on the span of the three plane rigid motions.
//!
//! S and the Neumann trace map are formed once per block as dense n_Γ × n_Γ matrices (S by one
//! multi-column Dirichlet solve; the Neumann map from S when K_II is nonsingular, else by one
//! multi-column solve with the pinned Neumann factor), so the interface iterations — PCG1, PCG2
//! and the outer steps, a few hundred applications per solve — cost small dense products instead
//! of sparse triangular solves.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, PoisonError};

use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, MatMut, MatRef, Par};

use super::dense::{mul, thin_svd, Cholesky, ThinSvd};
use super::DdProblem;
use crate::fem::rigid::{orthonormal_columns, pick_pinned, remove_components};
use crate::fem::{Factor, Symbolic};
use crate::memo::{self, Memo};

/// Relative size ‖A z‖ / max diag(A) below which a unit rigid motion z counts as a kernel vector.
const KERNEL_TOL: f64 = 1e-9;

/// Symmetric sparse matrix in compressed rows (both triangles stored).
#[derive(Debug, Clone)]
pub struct Csr {
    n: usize,
    ptr: Vec<usize>,
    col: Vec<usize>,
    val: Vec<f64>,
}

impl Csr {
    /// Build from (row, col, value) triplets; duplicates are summed.
    pub fn from_triplets(n: usize, mut t: Vec<(usize, usize, f64)>) -> Csr {
        t.sort_unstable_by_key(|&(r, c, _)| (r, c));
        let mut ptr = vec![0; n + 1];
        let mut col = Vec::with_capacity(t.len());
        let mut val: Vec<f64> = Vec::with_capacity(t.len());
        let mut last = (usize::MAX, usize::MAX);
        for (r, c, v) in t {
            if (r, c) == last {
                if let Some(x) = val.last_mut() {
                    *x += v;
                }
            } else {
                ptr[r + 1] += 1;
                col.push(c);
                val.push(v);
                last = (r, c);
            }
        }
        for i in 0..n {
            ptr[i + 1] += ptr[i];
        }
        Csr { n, ptr, col, val }
    }

    pub fn dim(&self) -> usize {
        self.n
    }

    /// Entries (col, value) of row `r`.
    pub fn row(&self, r: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        (self.ptr[r]..self.ptr[r + 1]).map(move |p| (self.col[p], self.val[p]))
    }

    /// y[r − r0] += Σ_{c ∈ [c0, c1)} A_rc x[c − c0] for r ∈ [r0, r1).
    pub fn mul_block(
        &self,
        (r0, r1): (usize, usize),
        (c0, c1): (usize, usize),
        x: &[f64],
        y: &mut [f64],
    ) {
        for r in r0..r1 {
            let mut s = 0.0;
            for (c, v) in self.row(r) {
                if c >= c0 && c < c1 {
                    s += v * x[c - c0];
                }
            }
            y[r - r0] += s;
        }
    }

    /// Largest diagonal entry of the leading `m` × `m` block.
    fn max_diag(&self, m: usize) -> f64 {
        (0..m)
            .flat_map(|r| self.row(r).filter(move |&(c, _)| c == r).map(|(_, v)| v))
            .fold(0.0, f64::max)
    }
}

/// A Cholesky factor of the leading block of a [`Csr`] with its kernel pinned: solves A x = b for
/// b ∈ Range(A) with x = 0 on the pinned DOFs (a generalised inverse A⁺, A A⁺ A = A).
#[derive(Debug, Clone)]
pub struct KernelFactor {
    n: usize,
    /// New index of each kept DOF (pinned → None).
    keep: Vec<Option<usize>>,
    factor: Option<Factor>,
    /// Orthonormal kernel basis, n × r.
    kernel: Mat<f64>,
}

impl KernelFactor {
    /// Factor the leading `m` × `m` block of `a`; its kernel is searched in the span of the
    /// columns of `candidates` (m × c; c = 0 means the block must be positive definite).
    pub fn new(a: &Csr, m: usize, candidates: MatRef<'_, f64>) -> Result<KernelFactor, String> {
        let kernel = kernel(a, m, candidates)?;
        let pinned = pick_pinned(kernel.as_ref());
        let mut keep = vec![None; m];
        let mut next = 0;
        for (i, k) in keep.iter_mut().enumerate() {
            if !pinned.contains(&i) {
                *k = Some(next);
                next += 1;
            }
        }
        let factor = if next == 0 {
            None
        } else {
            let mut trips = Vec::new();
            for r in 0..m {
                let Some(nr) = keep[r] else { continue };
                for (c, v) in a.row(r) {
                    if c < m {
                        if let Some(nc) = keep[c] {
                            if nr >= nc {
                                trips.push(Triplet::new(nr, nc, v));
                            }
                        }
                    }
                }
            }
            let mat = SparseColMat::<usize, f64>::try_new_from_triplets(next, next, &trips)
                .map_err(|e| format!("sparse matrix: {e:?}"))?;
            let symbolic = Symbolic::analyse(mat.symbolic()).map_err(|e| e.to_string())?;
            Some(
                symbolic
                    .factorize(mat.as_ref(), Par::Seq)
                    .map_err(|e| e.to_string())?,
            )
        };
        Ok(KernelFactor {
            n: m,
            keep,
            factor,
            kernel,
        })
    }

    pub fn kernel(&self) -> MatRef<'_, f64> {
        self.kernel.as_ref()
    }

    /// x = A⁺ b for every column b of `rhs` (n × k).
    pub fn solve_mat(&self, rhs: MatRef<'_, f64>) -> Mat<f64> {
        let mut out = Mat::<f64>::zeros(self.n, rhs.ncols());
        let Some(factor) = &self.factor else {
            return out;
        };
        let mut x = Mat::<f64>::zeros(factor.dim(), rhs.ncols());
        for (i, k) in self.keep.iter().enumerate() {
            if let Some(k) = *k {
                for j in 0..rhs.ncols() {
                    x[(k, j)] = rhs[(i, j)];
                }
            }
        }
        factor.solve_in_place(x.as_mut());
        for (i, k) in self.keep.iter().enumerate() {
            if let Some(k) = *k {
                for j in 0..rhs.ncols() {
                    out[(i, j)] = x[(k, j)];
                }
            }
        }
        out
    }

    /// x = A⁺ b.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let Some(factor) = &self.factor else {
            return vec![0.0; self.n];
        };
        let mut x = vec![0.0; factor.dim()];
        for (i, k) in self.keep.iter().enumerate() {
            if let Some(k) = *k {
                x[k] = b[i];
            }
        }
        let x = factor.solve(&x);
        self.keep.iter().map(|k| k.map_or(0.0, |k| x[k])).collect()
    }

    /// x ← x − Z Zᵀ x (projection onto the complement Q of the kernel).
    pub fn project(&self, x: &mut [f64]) {
        remove_components(self.kernel.as_ref(), x);
    }
}

/// Orthonormal basis of {z ∈ span(candidates) : A_mm z = 0}.
fn kernel(a: &Csr, m: usize, candidates: MatRef<'_, f64>) -> Result<Mat<f64>, String> {
    let q = orthonormal_columns(candidates);
    if q.ncols() == 0 {
        return Ok(q);
    }
    let mut aq = Mat::<f64>::zeros(m, q.ncols());
    for j in 0..q.ncols() {
        let x: Vec<f64> = (0..m).map(|i| q[(i, j)]).collect();
        let mut y = vec![0.0; m];
        a.mul_block((0, m), (0, m), &x, &mut y);
        for i in 0..m {
            aq[(i, j)] = y[i];
        }
    }
    // SVD of A Q itself (not of the Gram matrix, which would square the rounding level).
    let ThinSvd { s, v: u, .. } = thin_svd(aq.as_ref())?;
    let tol = KERNEL_TOL * a.max_diag(m);
    let cols: Vec<usize> = (0..q.ncols()).filter(|&k| s[k] <= tol).collect();
    let mut z = Mat::<f64>::zeros(m, cols.len());
    for (jn, &k) in cols.iter().enumerate() {
        for c in 0..q.ncols() {
            let w = u[(c, k)];
            for i in 0..m {
                z[(i, jn)] += w * q[(i, c)];
            }
        }
    }
    Ok(orthonormal_columns(z.as_ref()))
}

/// The three plane rigid motions (translations, rotation about the group centroid scaled by the
/// group radius) on the DOFs `dofs`, one set per group (`group[i]` of local DOF i): n × 3·groups.
pub fn rigid_candidates(problem: &DdProblem, dofs: &[usize], group: &[usize]) -> Mat<f64> {
    let n_groups = group.iter().map(|g| g + 1).max().unwrap_or(0);
    let mut centre = vec![[0.0; 3]; n_groups];
    for (&d, &g) in dofs.iter().zip(group) {
        let p = problem.nodes[problem.dof_node[d]];
        centre[g][0] += p[0];
        centre[g][1] += p[1];
        centre[g][2] += 1.0;
    }
    let centre: Vec<[f64; 2]> = centre.iter().map(|c| [c[0] / c[2], c[1] / c[2]]).collect();
    let mut radius = vec![f64::MIN_POSITIVE; n_groups];
    for (&d, &g) in dofs.iter().zip(group) {
        let p = problem.nodes[problem.dof_node[d]];
        radius[g] = radius[g].max((p[0] - centre[g][0]).hypot(p[1] - centre[g][1]));
    }
    Mat::from_fn(dofs.len(), 3 * n_groups, |i, j| {
        let g = group[i];
        if j / 3 != g {
            return 0.0;
        }
        let p = problem.nodes[problem.dof_node[dofs[i]]];
        let e = problem.dof_direction[dofs[i]];
        let w = match j % 3 {
            0 => [1.0, 0.0],
            1 => [0.0, 1.0],
            _ => [
                -(p[1] - centre[g][1]) / radius[g],
                (p[0] - centre[g][0]) / radius[g],
            ],
        };
        w[0] * e[0] + w[1] * e[1]
    })
}

/// Assemble the local stiffness of `elements` on local DOFs `local[global]` (usize::MAX = not
/// local) into triplets.
pub fn assemble(
    problem: &DdProblem,
    elements: &[usize],
    local: &[usize],
) -> Vec<(usize, usize, f64)> {
    let mut t = Vec::with_capacity(elements.len() * 36);
    for &e in elements {
        let el = &problem.elements[e];
        for (i, di) in el.dofs.iter().enumerate() {
            let Some(di) = *di else { continue };
            for (j, dj) in el.dofs.iter().enumerate() {
                let Some(dj) = *dj else { continue };
                t.push((local[di], local[dj], el.matrix[i][j]));
            }
        }
    }
    t
}

/// Relative size of K_ΓI z (to the largest diagonal entry) and of zᵀ f_I (to ‖f_I‖) below which
/// an interior kernel vector z counts as decoupled from the interface and balanced.
const DECOUPLED_TOL: f64 = 1e-9;

/// An interior kernel Z of K_II (a floating part that touches no interface, e.g. a body held
/// only by a frictionless tie) is admissible when K_ΓI Z = 0: then K_II x = b − K_IΓ y is solvable
/// for every y as soon as Zᵀ f_I = 0, the Schur complement does not depend on the chosen
/// particular solution, and the part's motion along Z is left to the global normal form
/// ([`crate::contact::direct::DirectContact::normalise_free_motions`]).
fn check_interior_kernel(
    k: &Csr,
    n_interior: usize,
    z: MatRef<'_, f64>,
    f_interior: &[f64],
) -> Result<(), String> {
    let n = k.dim();
    let scale = k.max_diag(n);
    let f_norm = f_interior.iter().map(|v| v * v).sum::<f64>().sqrt();
    for j in 0..z.ncols() {
        let col: Vec<f64> = (0..n_interior).map(|i| z[(i, j)]).collect();
        let mut coupling = vec![0.0; n - n_interior];
        k.mul_block((n_interior, n), (0, n_interior), &col, &mut coupling);
        if coupling.iter().any(|c| c.abs() > DECOUPLED_TOL * scale) {
            return Err(
                "the interior problem has a rigid motion that moves interface DOFs (a floating \
                 part glued to the interface at a vertex)"
                    .into(),
            );
        }
        let work: f64 = col.iter().zip(f_interior).map(|(a, b)| a * b).sum();
        if work.abs() > DECOUPLED_TOL * f_norm {
            return Err(format!(
                "a floating part without interface is loaded along one of its free rigid motions \
                 (work {work:.3e} of a load of norm {f_norm:.3e}); nothing can balance it"
            ));
        }
    }
    Ok(())
}

/// What a block's stiffness alone determines: the local matrix, the Dirichlet factor, S, the
/// Neumann trace map and the kernel. Built once per distinct stiffness (see [`OperatorCache`]).
#[derive(Debug)]
pub struct BlockOperators {
    k: Csr,
    dirichlet: KernelFactor,
    /// S = K_ΓΓ − K_ΓI K_II⁻¹ K_IΓ, dense (n_Γ × n_Γ).
    schur: Mat<f64>,
    /// The Neumann trace map g ↦ (P A⁺ [0; g])_Γ, dense (n_Γ × n_Γ).
    neumann_trace: Mat<f64>,
    /// Kernel of the local Neumann matrix (rows: local DOFs).
    kernel: Mat<f64>,
}

impl BlockOperators {
    /// `k`: local matrix (interior first); `candidates`: rigid motions (rows = local DOFs)
    /// spanning the kernel of k.
    pub fn new(
        k: Csr,
        n_interior: usize,
        candidates: MatRef<'_, f64>,
    ) -> Result<BlockOperators, String> {
        let dirichlet = KernelFactor::new(&k, n_interior, candidates.subrows(0, n_interior))?;
        let ng = k.dim() - n_interior;
        let schur = symmetrised(schur_dense(&k, n_interior, &dirichlet));
        let (neumann_trace, kernel) = if dirichlet.kernel().ncols() == 0 {
            // K_II is nonsingular: the Neumann map follows from S (no second factorisation).
            let kernel = kernel(&k, k.dim(), candidates)?;
            let map = neumann_from_schur(&k, n_interior, &dirichlet, &schur, kernel.as_ref())?;
            (map, kernel)
        } else {
            let neumann = KernelFactor::new(&k, k.dim(), candidates)?;
            let map = neumann_columns(&neumann, n_interior, ng);
            (map, neumann.kernel().to_owned())
        };
        Ok(BlockOperators {
            k,
            dirichlet,
            schur,
            neumann_trace,
            kernel,
        })
    }
}

/// Memory the operators of a block with local matrix `k` hold \[bytes\]: S and the Neumann map
/// (n_Γ × n_Γ each), the kernel (≤ 3 columns) and the local matrix with its factor (about as
/// much again as the matrix).
fn operator_bytes(k: &Csr, n_interior: usize) -> usize {
    let ng = k.dim() - n_interior;
    8 * (2 * ng * ng + 3 * k.dim() + 2 * k.val.len())
}

/// The operators of one subdomain by stiffness.
type SubdomainMemo = Memo<Arc<BlockOperators>>;

/// Memory for cached subdomain operators of a scene \[bytes\] (shared by its subdomains).
const OPERATOR_CACHE_BYTES: usize = 1 << 28;

/// The operators of each subdomain for the stiffness values seen last (keyed by their exact
/// bits, so a cached operator equals a fresh one): an evaluation whose λ, μ leave a subdomain's
/// stiffness unchanged — only loads or slip limits changed, or only other zones' materials —
/// builds nothing for it. One per scene, shared by the evaluations.
#[derive(Default)]
pub struct OperatorCache {
    /// Per subdomain, once it has been built.
    subdomains: std::sync::Mutex<Vec<Option<Arc<SubdomainMemo>>>>,
    built: AtomicUsize,
    reused: AtomicUsize,
}

impl std::fmt::Debug for OperatorCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (built, reused) = self.counts();
        write!(f, "OperatorCache {{ built: {built}, reused: {reused} }}")
    }
}

impl OperatorCache {
    /// The operators of subdomain `s` of `count` for its local matrix `k`, from the cache or
    /// built.
    pub fn get(
        &self,
        (s, count): (usize, usize),
        k: Csr,
        n_interior: usize,
        candidates: MatRef<'_, f64>,
    ) -> Result<Arc<BlockOperators>, String> {
        let key = memo::key(k.val.iter().copied());
        let memo = {
            let mut subdomains = self
                .subdomains
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            if subdomains.len() < count {
                subdomains.resize(count, None);
            }
            subdomains[s]
                .get_or_insert_with(|| {
                    let budget = OPERATOR_CACHE_BYTES / count.max(1);
                    Arc::new(Memo::new(memo::capacity(
                        budget,
                        operator_bytes(&k, n_interior),
                    )))
                })
                .clone()
        };
        let (ops, cached) = memo.get_or_try(key, || {
            BlockOperators::new(k, n_interior, candidates).map(Arc::new)
        })?;
        let counter = if cached { &self.reused } else { &self.built };
        counter.fetch_add(1, Ordering::Relaxed);
        Ok(ops)
    }

    /// Subdomain operators (built, reused) so far.
    pub fn counts(&self) -> (usize, usize) {
        (
            self.built.load(Ordering::Relaxed),
            self.reused.load(Ordering::Relaxed),
        )
    }
}

/// A linear subdomain (or tied cluster): local matrix ordered [interior; interface].
#[derive(Debug, Clone)]
pub struct LinearBlock {
    /// Number of interior DOFs; local DOF n_interior + j is interface DOF `gamma[j]`.
    pub n_interior: usize,
    /// Interface index of each local interface DOF.
    pub gamma: Vec<usize>,
    /// Stiffness measure ρ of the subdomain owning each local interface DOF (D05 5.5).
    pub rho: Vec<f64>,
    ops: Arc<BlockOperators>,
    f_interior: Vec<f64>,
    gamma_load: Vec<f64>,
}

impl LinearBlock {
    /// `k`: local matrix (interior first); `f_interior`: interior load; `gamma_load`: interface
    /// load carried by this block beyond the global f_Γ; `candidates`: rigid motions (rows = local
    /// DOFs) spanning the kernel of k.
    pub fn new(
        k: Csr,
        n_interior: usize,
        gamma: Vec<usize>,
        rho: Vec<f64>,
        f_interior: Vec<f64>,
        gamma_load: Vec<f64>,
        candidates: MatRef<'_, f64>,
    ) -> Result<LinearBlock, String> {
        let ops = Arc::new(BlockOperators::new(k, n_interior, candidates)?);
        LinearBlock::with_operators(ops, n_interior, gamma, rho, f_interior, gamma_load)
    }

    /// As [`Self::new`], with the operators built already.
    pub fn with_operators(
        ops: Arc<BlockOperators>,
        n_interior: usize,
        gamma: Vec<usize>,
        rho: Vec<f64>,
        f_interior: Vec<f64>,
        gamma_load: Vec<f64>,
    ) -> Result<LinearBlock, String> {
        check_interior_kernel(&ops.k, n_interior, ops.dirichlet.kernel(), &f_interior)?;
        Ok(LinearBlock {
            n_interior,
            gamma,
            rho,
            ops,
            f_interior,
            gamma_load,
        })
    }

    /// Kernel of the local Neumann matrix (rows: local DOFs).
    pub fn kernel(&self) -> MatRef<'_, f64> {
        self.ops.kernel.as_ref()
    }

    fn ranges(&self) -> ((usize, usize), (usize, usize)) {
        ((0, self.n_interior), (self.n_interior, self.ops.k.dim()))
    }

    /// S Y for the columns Y of local interface values (n_Γ × k).
    pub fn schur_mat(&self, y: MatRef<'_, f64>) -> Mat<f64> {
        mul(self.ops.schur.as_ref(), y)
    }

    /// S y.
    pub fn schur(&self, y: &[f64]) -> Vec<f64> {
        dense_apply(self.ops.schur.as_ref(), y)
    }

    /// The block's share of F: gamma_load − K_ΓI K_II⁻¹ f_I.
    pub fn condensed_load(&self) -> Vec<f64> {
        let (ri, rg) = self.ranges();
        let x: Vec<f64> = self
            .ops
            .dirichlet
            .solve(&self.f_interior)
            .iter()
            .map(|v| -v)
            .collect();
        let mut s = self.gamma_load.clone();
        self.ops.k.mul_block(rg, ri, &x, &mut s);
        s
    }

    /// Interior displacement for interface values y: K_II⁺ (f_I − K_IΓ y), with no component
    /// along an interior kernel (a floating part without interface, see
    /// `check_interior_kernel`).
    pub fn interior(&self, y: &[f64]) -> Vec<f64> {
        let (ri, rg) = self.ranges();
        let mut b = self.f_interior.clone();
        let my: Vec<f64> = y.iter().map(|v| -v).collect();
        self.ops.k.mul_block(ri, rg, &my, &mut b);
        let mut x = self.ops.dirichlet.solve(&b);
        self.ops.dirichlet.project(&mut x);
        x
    }

    /// Interface trace of the Neumann solution φ⁰ ∈ Q of A φ = [0; g] (g must annihilate the
    /// kernel's trace).
    pub fn neumann(&self, g: &[f64]) -> Vec<f64> {
        dense_apply(self.ops.neumann_trace.as_ref(), g)
    }
}

/// S = K_ΓΓ − K_ΓI K_II⁻¹ K_IΓ, dense: the blocks read off the rows once, one multi-column
/// Dirichlet solve X = K_II⁻¹ K_IΓ, then K_ΓI X row by row (K_ΓI is sparse).
fn schur_dense(k: &Csr, n_interior: usize, dirichlet: &KernelFactor) -> Mat<f64> {
    let (ni, ng) = (n_interior, k.dim() - n_interior);
    let mut kig = Mat::<f64>::zeros(ni, ng);
    let mut out = Mat::<f64>::zeros(ng, ng);
    for r in 0..k.dim() {
        for (c, v) in k.row(r).filter(|&(c, _)| c >= ni) {
            if r < ni {
                kig[(r, c - ni)] = v;
            } else {
                out[(r - ni, c - ni)] = v;
            }
        }
    }
    let x = dirichlet.solve_mat(kig.as_ref());
    for j in 0..ng {
        let xj = x.col(j);
        for r in 0..ng {
            let s: f64 = k
                .row(ni + r)
                .filter(|&(c, _)| c < ni)
                .map(|(c, v)| v * xj[c])
                .sum();
            out[(r, j)] -= s;
        }
    }
    out
}

/// The Neumann trace map as columns: (P A⁺ [0; e_j])_Γ for every interface DOF j, by one
/// multi-column solve with the pinned factor and the kernel projected out.
fn neumann_columns(neumann: &KernelFactor, n_interior: usize, ng: usize) -> Mat<f64> {
    let n = n_interior + ng;
    let mut rhs = Mat::<f64>::zeros(n, ng);
    for j in 0..ng {
        rhs[(n_interior + j, j)] = 1.0;
    }
    let x = neumann.solve_mat(rhs.as_ref());
    let mut out = Mat::<f64>::zeros(ng, ng);
    let mut col = vec![0.0; n];
    for j in 0..ng {
        for (i, c) in col.iter_mut().enumerate() {
            *c = x[(i, j)];
        }
        neumann.project(&mut col);
        for i in 0..ng {
            out[(i, j)] = col[n_interior + i];
        }
    }
    out
}

/// The Neumann trace map from S when K_II is nonsingular. The solutions of A x = [0; g] are the
/// harmonic extensions x = H y = [−K_II⁻¹ K_IΓ y; y] of the solutions y of S y = g; they differ by
/// kernel vectors Z c (whose traces Z_Γ span Ker S), so the projected solution is
/// (P H y)_Γ = y − Z_Γ (Zᵀ H y) for any of them, y = S⁺ g:
/// T = (I − Z_Γ R) S⁺ with R = Z_Γᵀ − (K_II⁻¹ Z_I)ᵀ K_IΓ, and
/// S⁺ = (S + α Q Qᵀ)⁻¹ − Q Qᵀ / α for an orthonormal basis Q of span(Z_Γ) and α the largest
/// diagonal entry of S.
fn neumann_from_schur(
    k: &Csr,
    n_interior: usize,
    dirichlet: &KernelFactor,
    schur: &Mat<f64>,
    z: MatRef<'_, f64>,
) -> Result<Mat<f64>, String> {
    let (ni, ng, r) = (n_interior, schur.nrows(), z.ncols());
    let zg = z.subrows(ni, ng);
    let q = orthonormal_columns(zg);
    let alpha = (0..ng)
        .map(|i| schur[(i, i)])
        .fold(f64::MIN_POSITIVE, f64::max);
    let qqt = mul(q.as_ref(), q.transpose());
    let shifted = Mat::from_fn(ng, ng, |i, j| schur[(i, j)] + alpha * qqt[(i, j)]);
    let cholesky = Cholesky::new(shifted.as_ref())
        .ok_or("the Schur complement with its kernel shifted is not positive definite")?;
    let inverse = cholesky.solve(Mat::<f64>::identity(ng, ng).as_ref());
    // S⁺ is symmetric; the kernel correction below is not (it acts along Z_Γ only).
    let mut pinv = symmetrised(Mat::from_fn(ng, ng, |i, j| {
        inverse[(i, j)] - qqt[(i, j)] / alpha
    }));
    if r == 0 {
        return Ok(pinv);
    }
    // R = Z_Γᵀ − (K_II⁻¹ Z_I)ᵀ K_IΓ, row c from K_ΓI (K_II⁻¹ Z_I)_c.
    let x = dirichlet.solve_mat(z.subrows(0, ni));
    let mut rr = Mat::<f64>::zeros(r, ng);
    let mut t = vec![0.0; ng];
    for c in 0..r {
        let xc: Vec<f64> = (0..ni).map(|i| x[(i, c)]).collect();
        t.fill(0.0);
        k.mul_block((ni, ni + ng), (0, ni), &xc, &mut t);
        for j in 0..ng {
            rr[(c, j)] = zg[(j, c)] - t[j];
        }
    }
    // T = S⁺ − Z_Γ (R S⁺).
    let rs = mul(rr.as_ref(), pinv.as_ref());
    let correction = mul(zg, rs.as_ref());
    for j in 0..ng {
        for i in 0..ng {
            pinv[(i, j)] -= correction[(i, j)];
        }
    }
    Ok(pinv)
}

/// (M + Mᵀ) / 2 for a symmetric operator whose computed columns are symmetric to rounding only.
fn symmetrised(mut m: Mat<f64>) -> Mat<f64> {
    for j in 0..m.ncols() {
        for i in 0..j {
            let v = 0.5 * (m[(i, j)] + m[(j, i)]);
            m[(i, j)] = v;
            m[(j, i)] = v;
        }
    }
    m
}

/// M y, sequential (results independent of the thread count).
fn dense_apply(m: MatRef<'_, f64>, y: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; m.nrows()];
    faer::linalg::matmul::matmul(
        MatMut::from_column_major_slice_mut(&mut out, m.nrows(), 1),
        faer::Accum::Replace,
        m,
        MatRef::from_column_major_slice(y, y.len(), 1),
        1.0,
        Par::Seq,
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Triplets of a 1D chain of unit springs (Laplacian), free at both ends.
    fn chain_triplets(n: usize) -> Vec<(usize, usize, f64)> {
        (0..n - 1)
            .flat_map(|i| {
                [
                    (i, i, 1.0),
                    (i + 1, i + 1, 1.0),
                    (i, i + 1, -1.0),
                    (i + 1, i, -1.0),
                ]
            })
            .collect()
    }

    /// 1D chain of springs free at both ends: kernel = constants.
    fn chain(n: usize) -> Csr {
        Csr::from_triplets(n, chain_triplets(n))
    }

    #[test]
    fn pinned_factor_solves_compatible_systems_and_finds_the_kernel() {
        let a = chain(6);
        let cand = Mat::from_fn(6, 2, |i, j| if j == 0 { 1.0 } else { i as f64 });
        let f = KernelFactor::new(&a, 6, cand.as_ref()).unwrap();
        assert_eq!(f.kernel().ncols(), 1);
        let b = [1.0, -2.0, 0.5, 0.0, 0.25, 0.25];
        let mut x = f.solve(&b);
        f.project(&mut x);
        let mut ax = vec![0.0; 6];
        a.mul_block((0, 6), (0, 6), &x, &mut ax);
        for (u, v) in ax.iter().zip(b) {
            assert!((u - v).abs() < 1e-12);
        }
        assert!(x.iter().sum::<f64>().abs() < 1e-12);
    }

    #[test]
    fn schur_of_a_chain_is_the_series_spring() {
        // Interior 0..4, interface {4, 5}: springs 0–1–2–3 dangling, 3–4 and 4–5 present.
        let n = 6;
        let mut t = vec![(0, 0, 1.0)];
        t.extend(chain_triplets(n));
        let k = Csr::from_triplets(n, t);
        let none = Mat::<f64>::zeros(n, 0);
        let block = LinearBlock::new(
            k,
            4,
            vec![0, 1],
            vec![1.0; 2],
            vec![0.0; 4],
            vec![0.0; 2],
            none.as_ref(),
        )
        .unwrap();
        // Grounded chain of 5 unit springs in series before DOF 4: stiffness 1/5, plus 4–5.
        let s = block.schur(&[1.0, 0.0]);
        assert!((s[0] - (0.2 + 1.0)).abs() < 1e-12 && (s[1] + 1.0).abs() < 1e-12);
        let sm = block.schur_mat(Mat::from_fn(2, 1, |i, _| [1.0, 0.0][i]).as_ref());
        assert!((sm[(0, 0)] - s[0]).abs() < 1e-14);
    }

    #[test]
    fn neumann_map_from_the_schur_complement_equals_the_pinned_solve_of_a_floating_block() {
        // A floating chain of 7 springs with nonuniform stiffness, interface = both ends and the
        // middle: kernel = constants, K_II nonsingular.
        let n = 8;
        let stiffness = [1.0, 3.0, 0.5, 2.0, 4.0, 1.5, 0.7];
        let mut t = Vec::new();
        for (i, c) in stiffness.iter().enumerate() {
            t.extend([
                (i, i, *c),
                (i + 1, i + 1, *c),
                (i, i + 1, -c),
                (i + 1, i, -c),
            ]);
        }
        // Local order [interior; interface]: interior DOFs 1, 2, 4, 5, 6; interface 0, 3, 7.
        let order = [1, 2, 4, 5, 6, 0, 3, 7];
        let mut new_index = [0; 8];
        for (new, &old) in order.iter().enumerate() {
            new_index[old] = new;
        }
        let t: Vec<(usize, usize, f64)> = t
            .into_iter()
            .map(|(i, j, v)| (new_index[i], new_index[j], v))
            .collect();
        let k = Csr::from_triplets(n, t);
        let candidates = Mat::from_fn(n, 1, |_, _| 1.0);
        let block = LinearBlock::new(
            k.clone(),
            5,
            vec![0, 1, 2],
            vec![1.0; 3],
            vec![0.0; 5],
            vec![0.0; 3],
            candidates.as_ref(),
        )
        .unwrap();
        assert_eq!(block.kernel().ncols(), 1);
        let pinned = KernelFactor::new(&k, n, candidates.as_ref()).unwrap();
        let reference = neumann_columns(&pinned, 5, 3);
        // Compatible loads (sum zero): the same projected solution's trace.
        for g in [[1.0, -0.25, -0.75], [0.0, 2.0, -2.0], [-3.0, 1.0, 2.0]] {
            let new = block.neumann(&g);
            let old = dense_apply(reference.as_ref(), &g);
            for (a, b) in new.iter().zip(&old) {
                assert!(
                    (a - b).abs() < 1e-12 * (1.0 + b.abs()),
                    "{new:?} vs {old:?}"
                );
            }
            // It solves S y = g.
            let sy = block.schur(&new);
            for (a, b) in sy.iter().zip(&g) {
                assert!((a - b).abs() < 1e-12, "{sy:?} vs {g:?}");
            }
        }
    }
}
