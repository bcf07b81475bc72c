//! Contact clusters: the nonlinear subdomains Ω^k_i ∪ Ω^l_j of D05 §4.1 (D03's Ω*_j when a
//! subdomain touches several zones).
//!
//! - Frictional local problem (D05 4.27–4.28, FGCS 3.7–3.8, 3.14): with Dirichlet data y on the
//!   cluster's interface, min ½u_IᵀK_IIu_I − u_Iᵀ(f_I − K_IΓ y) + Σ σ_\[l,u\](B u_I − e). Condensed
//!   on the contact multipliers once per factorisation, C = B K_II⁺ Bᵀ, and solved per evaluation
//!   by [`solve_box_qp`] with warm start; the interface reaction K_ΓI u_I + K_ΓΓ y is the cluster's
//!   part of S_CON(y) + (its part of F) (D05 4.27, 4.31, 4.34 written with matrices). A floating
//!   member without interface (a whole floating body) leaves a kernel R in K_II: then
//!   u_I = K_II⁺(…) + Rα and the QP carries the equilibrium rows (BR)ᵀλ = Rᵀ(f_I − K_IΓ y) (D05
//!   Thm 2.1 locally).
//! - Tied auxiliary problem (D05 4.35–4.46, FGCS 3.18–3.24): the normal rows become equalities
//!   B_n u = e_n, eliminated master/slave (one DOF of each row expressed by the others), which
//!   gives an ordinary [`LinearBlock`] with matrix TᵀKT. If the tie leaves the interior floating
//!   (a body that could slide along the tied zone), the tangential rows are tied as well.

use faer::{Mat, MatRef, Side};

use super::dense::{mul, Cholesky};
use super::subdomain::{Csr, KernelFactor, LinearBlock};
use crate::contact::qp::{solve_box_qp, BoxQp, QpOptions, QpSolution, WarmStart};

/// Relative margin (to the largest multiplier) by which a multiplier must lie inside its bounds
/// for its row to count as active in [`ContactCluster::tangent`].
const ACTIVE_TOL: f64 = 1e-9;

/// Relative eigenvalue cut of the pseudo-inverse H⁺ in [`ContactCluster::tangent`].
const PINV_TOL: f64 = 1e-10;

/// A contact row on the cluster's interior DOFs.
#[derive(Debug, Clone)]
pub struct LocalRow {
    pub entries: Vec<(usize, f64)>,
    pub value: f64,
    pub lower: f64,
    pub upper: f64,
}

/// The result of one local frictional solve.
#[derive(Debug, Clone)]
pub struct ClusterState {
    /// Interior displacement (cluster interior order).
    pub interior: Vec<f64>,
    /// Interface reaction K_ΓI u_I + K_ΓΓ y.
    pub reaction: Vec<f64>,
    /// QP solution (multipliers x in row order, rigid amplitudes α).
    pub qp: QpSolution,
}

/// The generalised derivative of the cluster's part of S_CON at one local solution (the
/// semismooth Newton step of [`super::newton`]): rows whose multiplier lies strictly inside its
/// bounds (pressed normals, sticking tangentials) are held as equalities B_A u_I = 0, the others
/// keep their multiplier and drop out. Its action y ↦ K_ΓΓ y + K_ΓI u_I with
/// u_I = argmin{½u_IᵀK_IIu_I + u_IᵀK_IΓ y : B_A u_I = 0} is the Schur complement of the cluster
/// tied on the active rows (D05 4.44–4.46 with Γ_c0 = the active set).
pub struct ClusterTangent {
    rows: Vec<usize>,
    /// Cholesky factor of C_AA = B_A K_II⁺ B_Aᵀ.
    c: Cholesky,
    /// G_A = (B_A R)ᵀ and H⁺ for floating members (r × m, r × r; r = 0 otherwise).
    ga: Mat<f64>,
    h_pinv: Mat<f64>,
}

/// A contact cluster with its condensed contact operator.
#[derive(Debug, Clone)]
pub struct ContactCluster {
    pub n_interior: usize,
    /// Interface index of each local interface DOF.
    pub gamma: Vec<usize>,
    k: Csr,
    interior: KernelFactor,
    rows: Vec<LocalRow>,
    /// K_II⁺ Bᵀ (n_I × m).
    x: Mat<f64>,
    /// B K_II⁺ Bᵀ (m × m).
    c: Mat<f64>,
    /// (B R)ᵀ (r × m).
    g: Mat<f64>,
    f_interior: Vec<f64>,
}

impl ContactCluster {
    /// `k`: local matrix ordered [interior; interface]; `rows` on interior DOFs; `candidates`:
    /// rigid motions of the members on the interior rows (kernel search for floating members).
    pub fn new(
        k: Csr,
        n_interior: usize,
        gamma: Vec<usize>,
        rows: Vec<LocalRow>,
        f_interior: Vec<f64>,
        candidates: MatRef<'_, f64>,
    ) -> Result<ContactCluster, String> {
        let interior = KernelFactor::new(&k, n_interior, candidates)?;
        let m = rows.len();
        let mut bt = Mat::<f64>::zeros(n_interior, m);
        for (j, row) in rows.iter().enumerate() {
            for &(i, a) in &row.entries {
                bt[(i, j)] += a;
            }
        }
        let x = interior.solve_mat(bt.as_ref());
        let mut c = Mat::<f64>::zeros(m, m);
        for (i, row) in rows.iter().enumerate() {
            for j in 0..m {
                c[(i, j)] = row.entries.iter().map(|&(p, a)| a * x[(p, j)]).sum();
            }
        }
        let c = Mat::from_fn(m, m, |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
        let r = interior.kernel();
        let g = Mat::from_fn(r.ncols(), m, |a, j| {
            rows[j].entries.iter().map(|&(p, v)| v * r[(p, a)]).sum()
        });
        Ok(ContactCluster {
            n_interior,
            gamma,
            k,
            interior,
            rows,
            x,
            c,
            g,
            f_interior,
        })
    }

    /// Number of rigid modes of the interior problem (floating members).
    pub fn n_floating_modes(&self) -> usize {
        self.g.nrows()
    }

    fn ranges(&self) -> ((usize, usize), (usize, usize)) {
        ((0, self.n_interior), (self.n_interior, self.k.dim()))
    }

    /// Solve the local frictional contact problem with interface values `y`.
    pub fn evaluate(
        &self,
        y: &[f64],
        warm: Option<&WarmStart>,
        opts: &QpOptions,
    ) -> Result<ClusterState, String> {
        let (ri, rg) = self.ranges();
        let mut rhs = self.f_interior.clone();
        let my: Vec<f64> = y.iter().map(|v| -v).collect();
        self.k.mul_block(ri, rg, &my, &mut rhs);
        let w = self.interior.solve(&rhs);
        let d: Vec<f64> = self
            .rows
            .iter()
            .map(|row| row.entries.iter().map(|&(p, a)| a * w[p]).sum::<f64>() - row.value)
            .collect();
        let mut qp = BoxQp::new(
            self.c.clone(),
            d,
            self.rows.iter().map(|r| r.lower).collect(),
            self.rows.iter().map(|r| r.upper).collect(),
        );
        let kernel = self.interior.kernel();
        if kernel.ncols() > 0 {
            let e = (0..kernel.ncols())
                .map(|a| (0..self.n_interior).map(|i| kernel[(i, a)] * rhs[i]).sum())
                .collect();
            qp = qp.with_equalities(self.g.clone(), e);
        }
        let sol = solve_box_qp(&qp, warm, opts).map_err(|e| e.to_string())?;
        let mut u = w;
        for (j, &lam) in sol.x.iter().enumerate() {
            if lam != 0.0 {
                for (i, ui) in u.iter_mut().enumerate() {
                    *ui -= self.x[(i, j)] * lam;
                }
            }
        }
        for (a, &alpha) in sol.alpha.iter().enumerate() {
            for (i, ui) in u.iter_mut().enumerate() {
                *ui += kernel[(i, a)] * alpha;
            }
        }
        let mut reaction = vec![0.0; self.gamma.len()];
        self.k.mul_block(rg, rg, y, &mut reaction);
        self.k.mul_block(rg, ri, &u, &mut reaction);
        Ok(ClusterState {
            interior: u,
            reaction,
            qp: sol,
        })
    }

    /// The tangent at the multipliers `x` of a local solution (row order); `None` when the active
    /// rows are dependent (C_AA singular).
    pub fn tangent(&self, x: &[f64]) -> Option<ClusterTangent> {
        let scale = x.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
        let eps = ACTIVE_TOL * scale.max(f64::MIN_POSITIVE);
        let rows: Vec<usize> = (0..self.rows.len())
            .filter(|&r| {
                let row = &self.rows[r];
                x[r] > row.lower + eps
                    && x[r] < row.upper - eps
                    && row.entries.iter().any(|e| e.1 != 0.0)
            })
            .collect();
        let (m, r) = (rows.len(), self.n_floating_modes());
        let c = Cholesky::new(Mat::from_fn(m, m, |i, j| self.c[(rows[i], rows[j])]).as_ref())?;
        // Floating members: H = G_A C_AA⁻¹ G_Aᵀ on the rigid amplitudes, pseudo-inverted (modes
        // the active rows do not hold stay free and do not reach the interface).
        let ga = Mat::from_fn(r, m, |a, j| self.g[(a, rows[j])]);
        let cg = c.solve(ga.transpose());
        let h = mul(ga.as_ref(), cg.as_ref());
        let h = Mat::from_fn(r, r, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
        let mut h_pinv = Mat::<f64>::zeros(r, r);
        if r > 0 {
            let eig = h.self_adjoint_eigen(Side::Lower).ok()?;
            let (vals, vecs) = (eig.S(), eig.U());
            let top = (0..r).map(|k| vals[k].abs()).fold(0.0, f64::max);
            for k in 0..r {
                if vals[k] > PINV_TOL * top {
                    for i in 0..r {
                        for j in 0..r {
                            h_pinv[(i, j)] += vecs[(i, k)] * vecs[(j, k)] / vals[k];
                        }
                    }
                }
            }
        }
        Some(ClusterTangent {
            rows,
            c,
            ga,
            h_pinv,
        })
    }

    /// The tangent's action on interface values `y`: with w = K_II⁺(−K_IΓ y), d = B_A w and
    /// e = Rᵀ(−K_IΓ y), the amplitudes α = H⁺(e − G_A C_AA⁻¹ d), multipliers
    /// λ = C_AA⁻¹(d + G_Aᵀ α), u_I = w − K_II⁺B_Aᵀ λ + R α.
    pub fn tangent_apply(&self, t: &ClusterTangent, y: &[f64]) -> Vec<f64> {
        let (ri, rg) = self.ranges();
        let my: Vec<f64> = y.iter().map(|v| -v).collect();
        let mut rhs = vec![0.0; self.n_interior];
        self.k.mul_block(ri, rg, &my, &mut rhs);
        let mut u = self.interior.solve(&rhs);
        let m = t.rows.len();
        let d = Mat::from_fn(m, 1, |i, _| {
            self.rows[t.rows[i]]
                .entries
                .iter()
                .map(|&(p, a)| a * u[p])
                .sum::<f64>()
        });
        let kernel = self.interior.kernel();
        let e = Mat::from_fn(kernel.ncols(), 1, |a, _| {
            (0..self.n_interior)
                .map(|i| kernel[(i, a)] * rhs[i])
                .sum::<f64>()
        });
        let cd = t.c.solve(d.as_ref());
        let alpha = mul(
            t.h_pinv.as_ref(),
            (e - mul(t.ga.as_ref(), cd.as_ref())).as_ref(),
        );
        let lam =
            t.c.solve((d + mul(t.ga.transpose(), alpha.as_ref())).as_ref());
        for (i, &r) in t.rows.iter().enumerate() {
            let l = lam[(i, 0)];
            for (p, up) in u.iter_mut().enumerate() {
                *up -= self.x[(p, r)] * l;
            }
        }
        for a in 0..kernel.ncols() {
            for (i, up) in u.iter_mut().enumerate() {
                *up += kernel[(i, a)] * alpha[(a, 0)];
            }
        }
        let mut reaction = vec![0.0; self.gamma.len()];
        self.k.mul_block(rg, rg, y, &mut reaction);
        self.k.mul_block(rg, ri, &u, &mut reaction);
        reaction
    }

    /// The tied auxiliary block: rows with `tie(row)` become equalities (eliminated), except rows
    /// without free DOFs. `rho` and
    /// `candidates` (rows: all local DOFs) as for [`LinearBlock::new`].
    pub fn tied(
        &self,
        tie: impl Fn(usize) -> bool,
        rho: Vec<f64>,
        candidates: MatRef<'_, f64>,
    ) -> Result<LinearBlock, String> {
        self.tied_with_load(tie, &self.f_interior, rho, candidates)
    }

    /// Master/slave elimination of the tied rows B_r u = e_r, in row order: each row, with the
    /// slaves chosen so far substituted, gets as slave its interior DOF of largest coefficient,
    /// u_p = t0_p + Σ a_j u_j over master DOFs, and that expression is substituted into the
    /// earlier slaves' ones. A DOF shared by several rows (a node where two contact zones meet,
    /// with one pair per zone) is thus handled like any other. A row implied by the earlier ones
    /// is skipped; one that contradicts them (or leaves no interior DOF) is refused.
    #[allow(clippy::type_complexity)]
    fn eliminate(
        &self,
        tied: &[usize],
    ) -> Result<(Vec<Option<Vec<(usize, f64)>>>, Vec<f64>), String> {
        let n = self.k.dim();
        let mut slave: Vec<Option<Vec<(usize, f64)>>> = vec![None; n];
        let mut t0 = vec![0.0; n];
        let mut slaves: Vec<usize> = Vec::new();
        for &r in tied {
            let row = &self.rows[r];
            let scale = row.entries.iter().fold(0.0f64, |m, e| m.max(e.1.abs()));
            let mut coefficients: std::collections::BTreeMap<usize, f64> = Default::default();
            let mut value = row.value;
            let mut magnitude = row.value.abs();
            for &(p, a) in &row.entries {
                match &slave[p] {
                    None => *coefficients.entry(p).or_default() += a,
                    Some(expr) => {
                        value -= a * t0[p];
                        magnitude += (a * t0[p]).abs();
                        for &(j, b) in expr {
                            *coefficients.entry(j).or_default() += a * b;
                        }
                    }
                }
            }
            coefficients.retain(|_, c| c.abs() > 1e-12 * scale);
            if coefficients.is_empty() && value.abs() <= 1e-10 * magnitude {
                // Implied by the earlier rows (e.g. both tangential rows at a node shared by
                // two tied zones whose normal rows already fix the relative displacement).
                continue;
            }
            let pivot = coefficients
                .iter()
                .filter(|(&p, _)| p < self.n_interior)
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()).then(b.0.cmp(a.0)))
                .map(|(&p, &c)| (p, c));
            let Some((p, c_p)) = pivot else {
                return Err(format!(
                    "tied row {r} contradicts the other tied rows; cannot eliminate"
                ));
            };
            let expr: Vec<(usize, f64)> = coefficients
                .iter()
                .filter(|(&j, _)| j != p)
                .map(|(&j, &c)| (j, -c / c_p))
                .collect();
            let constant = value / c_p;
            for &q in &slaves {
                let Some(old) = slave[q].take() else {
                    continue;
                };
                let w: f64 = old.iter().filter(|e| e.0 == p).map(|e| e.1).sum();
                if w == 0.0 {
                    slave[q] = Some(old);
                    continue;
                }
                let mut merged: std::collections::BTreeMap<usize, f64> =
                    old.into_iter().filter(|e| e.0 != p).collect();
                for &(j, a) in &expr {
                    *merged.entry(j).or_default() += w * a;
                }
                t0[q] += w * constant;
                slave[q] = Some(merged.into_iter().filter(|e| e.1 != 0.0).collect());
            }
            slave[p] = Some(expr);
            t0[p] = constant;
            slaves.push(p);
        }
        Ok((slave, t0))
    }

    fn tied_with_load(
        &self,
        tie: impl Fn(usize) -> bool,
        f_interior: &[f64],
        rho: Vec<f64>,
        candidates: MatRef<'_, f64>,
    ) -> Result<LinearBlock, String> {
        let n = self.k.dim();
        // Rows on prescribed DOFs only (a pair on a clamped boundary) tie nothing.
        let tied: Vec<usize> = (0..self.rows.len())
            .filter(|&r| tie(r) && self.rows[r].entries.iter().any(|e| e.1 != 0.0))
            .collect();
        let (slave, t0) = self.eliminate(&tied)?;
        let mut new = vec![usize::MAX; n];
        let mut next = 0;
        for (p, s) in slave.iter().enumerate() {
            if s.is_none() {
                new[p] = next;
                next += 1;
            }
        }
        let n_interior = (0..self.n_interior).filter(|&p| slave[p].is_none()).count();
        // u = T ũ + t0.
        let expand = |p: usize| -> Vec<(usize, f64)> {
            match &slave[p] {
                None => vec![(new[p], 1.0)],
                Some(expr) => expr.iter().map(|&(j, a)| (new[j], a)).collect(),
            }
        };
        let mut h = vec![0.0; n];
        h[..self.n_interior].copy_from_slice(f_interior);
        let mt0: Vec<f64> = t0.iter().map(|v| -v).collect();
        self.k.mul_block((0, n), (0, n), &mt0, &mut h);
        let mut trips = Vec::new();
        let mut f = vec![0.0; next];
        let expanded: Vec<Vec<(usize, f64)>> = (0..n).map(expand).collect();
        for p in 0..n {
            for &(pn, wp) in &expanded[p] {
                f[pn] += wp * h[p];
                for (q, v) in self.k.row(p) {
                    for &(qn, wq) in &expanded[q] {
                        trips.push((pn, qn, wp * wq * v));
                    }
                }
            }
        }
        let keep: Vec<usize> = (0..n).filter(|&p| slave[p].is_none()).collect();
        let cand = Mat::from_fn(next, candidates.ncols(), |i, j| candidates[(keep[i], j)]);
        LinearBlock::new(
            Csr::from_triplets(next, trips),
            n_interior,
            self.gamma.clone(),
            rho,
            f[..n_interior].to_vec(),
            f[n_interior..].to_vec(),
            cand.as_ref(),
        )
    }
}
