//! K body by body for the direct contact solver (design §3.1): bodies share no node, so the
//! stiffness on the free DOFs is block diagonal, K = diag(K_1, …, K_b), and so are its factor and
//! its generalised inverse. Each body's block is analysed once per scene (its own sub-pattern, an
//! AMD ordering with its contact DOFs last, [`Symbolic::analyse_with_trailing`]) and factorised
//! on its own, so that a data set that changes only the Lamé coefficients of one body's zones
//! refactorises only that body. The body's share of the dual Hessian C = B K⁺ Bᵀ is
//! Σ_blocks Wᵀ W with W = L₂₂⁻¹ B_cᵀ on the diagonal blocks of its trailing factor block
//! (module doc of [`super::direct`]).
//!
//! A body factor is a deterministic function of the body's zone coefficients alone (sequential
//! factorisation, its own pinning scale), so a cached one has the same bits as a fresh one.

use faer::linalg::matmul::triangular::{matmul, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Accum, Mat, MatMut, Par};

use super::pairs::ContactGeometry;
use crate::error::WsmError;
use crate::fem::{ElasticProblem, Factor, Slot, Symbolic};

/// One diagonal block of a body's L₂₂: its trailing DOFs `range` (body trailing numbering), the
/// contact rows that touch them and the dense B_cᵀ restricted to both (pinned DOFs zeroed).
#[derive(Debug, Clone)]
pub struct SchurBlock {
    range: std::ops::Range<usize>,
    rows: Vec<usize>,
    bt: Mat<f64>,
}

/// The diagonal block of K of one body (or of all DOFs when K is not block diagonal over
/// bodies), analysed once per scene.
#[derive(Debug, Clone)]
pub struct BodyBlock {
    /// Free DOFs of the body, increasing (local DOF i is global `dofs[i]`).
    pub dofs: Vec<usize>,
    /// Zones whose coefficients enter the block.
    pub zones: Vec<usize>,
    /// Lower-triangular pattern in local numbering and, per local entry, its position in the
    /// global pattern.
    pattern: SymbolicSparseColMat<usize>,
    source: Vec<usize>,
    /// Local DOFs pinned (floating-body kernel).
    pinned: Vec<usize>,
    symbolic: Symbolic,
    blocks: Vec<SchurBlock>,
    /// The block is quasi-definite (mixed u–p element, design §2.7): LDLᵀ instead of LLᵀ.
    quasi_definite: bool,
}

/// A body's block factorised, with its share of C: per Schur block the lower triangle of WᵀW.
#[derive(Debug, Clone)]
pub struct BodyFactor {
    factor: Factor,
    wtw: Vec<Mat<f64>>,
}

impl BodyFactor {
    /// Number of nonzeros of the factor.
    pub fn nnz(&self) -> usize {
        self.factor.nnz()
    }
}

/// The body blocks of K: one per body when no entry of K couples two bodies, else one for all.
pub fn body_blocks(
    elastic: &ElasticProblem,
    geometry: &ContactGeometry,
    pinned: &[usize],
) -> Result<Vec<BodyBlock>, WsmError> {
    let (mesh, dofs, op) = (elastic.mesh(), elastic.dofs(), elastic.operator());
    let n = op.n_free();
    let mut body_of = vec![0usize; n];
    for node in 0..mesh.nodes.len() {
        for slot in dofs.slots(node) {
            if let Slot::Free(i) = slot {
                body_of[i] = mesh.node_body[node];
            }
        }
        if let Some(offset) = elastic.pressure_offset() {
            body_of[offset + node] = mesh.node_body[node];
        }
    }
    let pattern = op.pattern();
    let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
    let coupled = (0..n).any(|c| {
        row_idx[col_ptr[c]..col_ptr[c + 1]]
            .iter()
            .any(|&r| body_of[r] != body_of[c])
    });
    if coupled {
        body_of.fill(0);
    }
    let n_groups = body_of.iter().map(|b| b + 1).max().unwrap_or(0);
    (0..n_groups)
        .filter_map(|g| {
            let members: Vec<usize> = (0..n).filter(|&i| body_of[i] == g).collect();
            (!members.is_empty()).then_some(members)
        })
        .map(|members| {
            let body = body_of[members[0]];
            let zones = (0..mesh.zones.len())
                .filter(|&z| coupled || mesh.zones[z].body == body)
                .collect();
            BodyBlock::new(elastic, geometry, pinned, members, zones)
        })
        .collect()
}

impl BodyBlock {
    fn new(
        elastic: &ElasticProblem,
        geometry: &ContactGeometry,
        pinned: &[usize],
        dofs: Vec<usize>,
        zones: Vec<usize>,
    ) -> Result<BodyBlock, WsmError> {
        let op = elastic.operator();
        let n = op.n_free();
        let mut local = vec![usize::MAX; n];
        for (k, &i) in dofs.iter().enumerate() {
            local[i] = k;
        }
        let pattern = op.pattern();
        let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
        let mut ptr = Vec::with_capacity(dofs.len() + 1);
        let (mut rows, mut source) = (Vec::new(), Vec::new());
        ptr.push(0);
        for &c in &dofs {
            for p in col_ptr[c]..col_ptr[c + 1] {
                rows.push(local[row_idx[p]]);
                source.push(p);
            }
            ptr.push(rows.len());
        }
        let nl = dofs.len();
        let pattern = SymbolicSparseColMat::new_checked(nl, nl, ptr, None, rows);
        let pinned: Vec<usize> = pinned
            .iter()
            .filter(|&&i| local[i] != usize::MAX)
            .map(|&i| local[i])
            .collect();
        let mut contact: Vec<usize> = geometry
            .rows
            .iter()
            .flat_map(|row| row.free.iter().map(|&(i, _)| local[i]))
            .filter(|&i| i != usize::MAX)
            .collect();
        contact.sort_unstable();
        contact.dedup();
        let (symbolic, blocks) = if contact.is_empty() {
            (Symbolic::analyse(pattern.as_ref())?, Vec::new())
        } else {
            let symbolic = Symbolic::analyse_with_trailing(pattern.as_ref(), &contact)?;
            let blocks = schur_blocks(&symbolic, geometry, &local, &contact, &pinned);
            (symbolic, blocks)
        };
        Ok(BodyBlock {
            dofs,
            zones,
            pattern,
            source,
            pinned,
            symbolic,
            blocks,
            quasi_definite: op.is_quasi_definite(),
        })
    }

    /// The contact rows that touch the body's unpinned DOFs.
    pub fn contact_rows(&self) -> Vec<usize> {
        self.blocks
            .iter()
            .flat_map(|b| b.rows.iter().copied())
            .collect()
    }

    /// The lower-triangular pattern of the block (local numbering).
    pub fn pattern(&self) -> SymbolicSparseColMatRef<'_, usize> {
        self.pattern.as_ref()
    }

    /// Nonzeros of the factor (the size of a [`BodyFactor`] is about 8 bytes × this).
    pub fn factor_nnz(&self) -> usize {
        self.symbolic.factor_nnz()
    }

    /// The body's block of K from the global values of K (lower triangle, global pattern
    /// order), with its pinned DOFs replaced by the identity scaled to the block's mean diagonal,
    /// factorised sequentially, with its share of C.
    pub fn factor(&self, values: &[f64]) -> Result<BodyFactor, WsmError> {
        let mut local: Vec<f64> = self.source.iter().map(|&p| values[p]).collect();
        pin(self.pattern.as_ref(), &mut local, &self.pinned);
        let matrix = SparseColMatRef::new(self.pattern.as_ref(), &local);
        let factor = if self.quasi_definite {
            self.symbolic.factorize_quasi_definite(matrix, Par::Seq)?
        } else {
            self.symbolic.factorize(matrix, Par::Seq)?
        };
        let wtw = self
            .blocks
            .iter()
            .map(|block| {
                let l = factor.trailing_block(block.range.clone())?;
                let mut w = block.bt.clone();
                solve_lower_triangular_in_place(l.as_ref(), w.as_mut(), Par::Seq);
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
                    Par::Seq,
                );
                Ok(wtw)
            })
            .collect::<Result<_, WsmError>>()?;
        Ok(BodyFactor { factor, wtw })
    }

    /// c += the body's share of C (both triangles, so C stays exactly symmetric).
    pub fn add_schur(&self, factor: &BodyFactor, c: &mut Mat<f64>) {
        for (block, wtw) in self.blocks.iter().zip(&factor.wtw) {
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
    }

    /// b ← K_body⁻¹ b on the body's DOFs of the global vectors (columns of `b`).
    pub fn solve_in_place(&self, factor: &BodyFactor, mut b: MatMut<'_, f64>) {
        let mut x = Mat::<f64>::from_fn(self.dofs.len(), b.ncols(), |i, j| b[(self.dofs[i], j)]);
        factor.factor.solve_in_place(x.as_mut());
        for (i, &d) in self.dofs.iter().enumerate() {
            for j in 0..b.ncols() {
                b[(d, j)] = x[(i, j)];
            }
        }
    }
}

/// The diagonal blocks of L₂₂ of a body analysed with its (local) `contact` DOFs last, with the
/// contact rows that touch each block's unpinned DOFs and the dense B_cᵀ on them; `local` maps
/// global free DOFs to the body's (usize::MAX outside it).
fn schur_blocks(
    symbolic: &Symbolic,
    geometry: &ContactGeometry,
    local: &[usize],
    contact: &[usize],
    pinned: &[usize],
) -> Vec<SchurBlock> {
    let mut position = vec![usize::MAX; local.len()];
    for (k, &i) in contact.iter().enumerate() {
        position[i] = k;
    }
    symbolic
        .trailing_blocks()
        .windows(2)
        .map(|w| {
            let range = w[0]..w[1];
            let inside = |i: usize| {
                let l = local[i];
                l != usize::MAX && range.contains(&position[l]) && pinned.binary_search(&l).is_err()
            };
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
                        bt[(position[local[i]] - range.start, j)] += c;
                    }
                }
            }
            SchurBlock { range, rows, bt }
        })
        .filter(|b| !b.rows.is_empty())
        .collect()
}

/// Replace the rows and columns of `pinned` DOFs (increasing) by the identity scaled to the mean
/// diagonal; returns that scale (1 when nothing is pinned).
pub fn pin(
    pattern: SymbolicSparseColMatRef<'_, usize>,
    values: &mut [f64],
    pinned: &[usize],
) -> f64 {
    if pinned.is_empty() {
        return 1.0;
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
    diag
}
