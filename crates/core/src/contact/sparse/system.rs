//! One active set of the sparse contact path (design §3.1, "The sparse contact path"): the
//! primal equations of the set solved with one sparse Cholesky factor, no dense matrix of the
//! pairs' size anywhere.
//!
//! Node-to-node pairs touch disjoint DOFs. On the free DOFs S_m of pair m (≤ 4) the rows of B
//! whose multiplier is free in the set (active normals, stuck tangentials, bilateral normals)
//! are B_a = R_aᵀ Q₁ᵀ with Q = [Q₁ Q₂] orthonormal (|S_m| × |S_m|, Gram–Schmidt of B_aᵀ then a
//! completion) and R_a upper triangular. In the coordinates y = Qᵀ u the set's equalities
//! B_a u = t_a prescribe y₁ = R_a⁻ᵀ t_a, so the step solves A = QᵀKQ (Q block diagonal,
//! identity off the pairs) on the remaining coordinates like a Dirichlet problem, with the
//! prescribed coordinates and the DOFs pinned for floating bodies replaced by identity rows. The
//! pattern of A — K's with every pair's DOFs merged into one dense block — is analysed once per
//! scene (AMD), the values re-assembled per set from a precomputed plan. The set's multipliers
//! come from the residual at the prescribed coordinates, Qᵀ(f − K u) restricted to y₁ = R_a λ_a,
//! and the residual at the pinned DOFs measures what a floating body's rigid motion must balance.

use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Mat, Par};

use crate::contact::bodies::pin;
use crate::contact::pairs::{normal_row, pair_of_row, tangential_row, ContactGeometry};
use crate::error::WsmError;
use crate::fem::{symmetric_apply, Factor, Symbolic};

/// No block on this DOF.
const NONE: usize = usize::MAX;
/// Free DOFs of one block at most (pairs sharing nodes chain into one block).
const MAX_BLOCK_DOFS: usize = 16;

/// The orthonormal basis of one block for one set, and the triangular factor of its free rows.
#[derive(Debug, Clone)]
struct Basis {
    /// s × s row-major: q\[i s + j\] is the component on DOF i of basis vector j (the first
    /// `rank` span the free rows' B_aᵀ).
    q: Vec<f64>,
    /// B_aᵀ = Q₁ R on the independent rows, R upper triangular (rank × rank, row-major).
    r: Vec<f64>,
    rank: usize,
    /// Per row given: whether it is independent of the rows before it (a dependent row's
    /// equation is implied — checked after the solve — and its multiplier is 0).
    independent: Vec<bool>,
}

/// The contact pairs that share free DOFs (usually one pair): their free DOFs and their rows
/// there.
#[derive(Debug, Clone)]
struct Block {
    /// The block's free DOFs, increasing.
    dofs: Vec<usize>,
    /// Rows of B with a free part on the block: (row index, coefficients on `dofs`).
    rows: Vec<(usize, Vec<f64>)>,
    /// Offset of the block's basis in the flat basis values.
    offset: usize,
}

/// One term of A = QᵀKQ: value\[target\] += q\[qa\] K\[source\] q\[qb\] × weight.
#[derive(Debug, Clone, Copy)]
struct Term {
    source: u32,
    target: u32,
    qa: u32,
    qb: u32,
    weight: f64,
}

/// The scene's part of the sparse path: blocks, pinned DOFs, the merged pattern and its
/// symbolic analysis, and the assembly plan.
#[derive(Debug, Clone)]
pub struct SparseSystem {
    blocks: Vec<Block>,
    block_of: Vec<usize>,
    /// Per row of B: whether it has a free part.
    variable: Vec<bool>,
    /// DOFs pinned for the floating bodies (none of them on a pair), increasing.
    pinned: Vec<usize>,
    pattern: SymbolicSparseColMat<usize>,
    symbolic: Symbolic,
    plan: Vec<Term>,
    /// Length of the flat basis values (1 + Σ s_b²).
    q_len: usize,
}

/// Why a scene cannot use the sparse path.
pub type Ineligible = String;

/// The set's right-hand side: loads on the free DOFs (with the bound multipliers' forces taken
/// off) and the values the free rows must take.
pub struct SetLoad {
    /// Loads on the free DOFs.
    pub loads: Vec<f64>,
    /// Per row: B_i u for the rows whose multiplier is free (ignored for the others).
    pub targets: Vec<f64>,
}

/// The solution of one set for one right-hand side.
pub struct SetSolution {
    /// Displacement on the free DOFs (pinned DOFs zero).
    pub u: Vec<f64>,
    /// Multipliers of the free rows (zero elsewhere).
    pub multipliers: Vec<f64>,
    /// Residual f − K u − Bᵀλ at the pinned DOFs (what a rigid motion must balance).
    pub pinned_residual: Vec<f64>,
}

impl SparseSystem {
    /// Blocks, pattern and plan; the inner `Err` when a block grows beyond [`MAX_BLOCK_DOFS`]
    /// (the dense path handles those).
    pub fn new(
        geometry: &ContactGeometry,
        pattern: SymbolicSparseColMatRef<'_, usize>,
        pinned: Vec<usize>,
    ) -> Result<Result<SparseSystem, Ineligible>, WsmError> {
        let n = pattern.ncols();
        let (blocks, block_of) = match blocks_of_pairs(geometry, n) {
            Ok(b) => b,
            Err(reason) => return Ok(Err(reason)),
        };
        for block in &blocks {
            if block.dofs.iter().any(|d| pinned.binary_search(d).is_ok()) {
                return Ok(Err("a pinned DOF lies on a contact pair".into()));
            }
        }
        let variable = geometry.rows.iter().map(|r| !r.free.is_empty()).collect();
        let q_len = blocks
            .last()
            .map_or(1, |b| b.offset + b.dofs.len() * b.dofs.len());
        let (pattern, plan) = merged_pattern(pattern, &blocks, &block_of);
        let symbolic = Symbolic::analyse(pattern.as_ref())?;
        Ok(Ok(SparseSystem {
            blocks,
            block_of,
            variable,
            pinned,
            pattern,
            symbolic,
            plan,
            q_len,
        }))
    }

    /// Whether row `i` of B has a free part (a row without one is decided by the prescribed
    /// values alone and is never free).
    pub fn variable(&self, i: usize) -> bool {
        self.variable[i]
    }

    /// Nonzeros of the factor of A (8 bytes each).
    pub fn factor_nnz(&self) -> usize {
        self.symbolic.factor_nnz()
    }

    /// Solve the set `free` (per row of B: its multiplier is free) for the right-hand sides
    /// `loads`, with K given by its lower-triangular values. Returns the solutions and the
    /// relative size of the iterative-refinement correction (an estimate of their accuracy).
    pub fn solve_set(
        &self,
        k_values: &[f64],
        free: &[bool],
        loads: &[SetLoad],
        par: Par,
    ) -> Result<(Vec<SetSolution>, f64), WsmError> {
        let n = self.block_of.len();
        let mut q = vec![1.0; self.q_len];
        let mut bases = Vec::with_capacity(self.blocks.len());
        // Per block, the rows whose multiplier is free, in the basis' order.
        let mut free_rows: Vec<Vec<usize>> = Vec::with_capacity(self.blocks.len());
        for block in &self.blocks {
            let rows: Vec<&(usize, Vec<f64>)> =
                block.rows.iter().filter(|(i, _)| free[*i]).collect();
            let coefficients: Vec<&[f64]> = rows.iter().map(|(_, c)| c.as_slice()).collect();
            let basis = basis(&coefficients, block.dofs.len());
            q[block.offset..block.offset + basis.q.len()].copy_from_slice(&basis.q);
            free_rows.push(
                rows.iter()
                    .zip(&basis.independent)
                    .filter(|(_, &independent)| independent)
                    .map(|((i, _), _)| *i)
                    .collect(),
            );
            bases.push(basis);
        }
        let full = self.assemble(k_values, &q);
        let mut fixed: Vec<usize> = self.pinned.clone();
        for (block, b) in self.blocks.iter().zip(&bases) {
            fixed.extend(&block.dofs[..b.rank]);
        }
        fixed.sort_unstable();
        let mut system = full.clone();
        let scale = pin(self.pattern.as_ref(), &mut system, &fixed);
        let factor = self
            .symbolic
            .factorize(SparseColMatRef::new(self.pattern.as_ref(), &system), par)
            .map_err(|e| WsmError::contact(format!("sparse contact factorisation: {e}")))?;
        let columns = loads.len();
        let mut prescribed = Mat::<f64>::zeros(n, columns);
        let mut transformed = Mat::<f64>::zeros(n, columns);
        for (j, load) in loads.iter().enumerate() {
            let mut b = load.loads.clone();
            let mut y = vec![0.0; n];
            for ((block, basis), rows) in self.blocks.iter().zip(&bases).zip(&free_rows) {
                transform_block(&block.dofs, &basis.q, &mut b, true);
                // R_aᵀ y₁ = t (lower triangular).
                let rank = basis.rank;
                for (i, &row) in rows.iter().enumerate() {
                    let s: f64 = (0..i)
                        .map(|l| basis.r[l * rank + i] * y[block.dofs[l]])
                        .sum();
                    y[block.dofs[i]] = (load.targets[row] - s) / basis.r[i * rank + i];
                }
            }
            for i in 0..n {
                transformed[(i, j)] = b[i];
                prescribed[(i, j)] = y[i];
            }
        }
        // rhs = b − A y_P off the fixed coordinates, scale · y_P on them (zero when pinned).
        let mut rhs = Mat::<f64>::zeros(n, columns);
        for j in 0..columns {
            let y: Vec<f64> = (0..n).map(|i| prescribed[(i, j)]).collect();
            let ay = symmetric_apply(self.pattern.as_ref(), &full, &y);
            for i in 0..n {
                rhs[(i, j)] = transformed[(i, j)] - ay[i];
            }
            for &i in &fixed {
                rhs[(i, j)] = scale * y[i];
            }
        }
        let mut y = rhs.clone();
        factor.solve_in_place(y.as_mut());
        let correction = refine(&factor, self.pattern.as_ref(), &system, &rhs, &mut y);
        let m = self.variable.len();
        let solutions = (0..columns)
            .map(|j| {
                let yj: Vec<f64> = (0..n).map(|i| y[(i, j)]).collect();
                let ay = symmetric_apply(self.pattern.as_ref(), &full, &yj);
                let residual: Vec<f64> = (0..n).map(|i| transformed[(i, j)] - ay[i]).collect();
                let mut multipliers = vec![0.0; m];
                for ((block, basis), rows) in self.blocks.iter().zip(&bases).zip(&free_rows) {
                    // R_a λ_a = residual at y₁ (upper triangular).
                    let rank = basis.rank;
                    let mut lambda = vec![0.0; rank];
                    for i in (0..rank).rev() {
                        let s: f64 = (i + 1..rank)
                            .map(|l| basis.r[i * rank + l] * lambda[l])
                            .sum();
                        lambda[i] = (residual[block.dofs[i]] - s) / basis.r[i * rank + i];
                    }
                    for (&row, l) in rows.iter().zip(lambda) {
                        multipliers[row] = l;
                    }
                }
                let pinned_residual = self.pinned.iter().map(|&p| residual[p]).collect();
                let mut u = yj;
                for (block, basis) in self.blocks.iter().zip(&bases) {
                    transform_block(&block.dofs, &basis.q, &mut u, false);
                }
                SetSolution {
                    u,
                    multipliers,
                    pinned_residual,
                }
            })
            .collect();
        Ok((solutions, correction))
    }

    /// Values of A = QᵀKQ (lower triangle, merged pattern) for the flat basis values `q`.
    fn assemble(&self, k_values: &[f64], q: &[f64]) -> Vec<f64> {
        let mut a = vec![0.0; self.pattern.compute_nnz()];
        for t in &self.plan {
            a[t.target as usize] +=
                q[t.qa as usize] * k_values[t.source as usize] * q[t.qb as usize] * t.weight;
        }
        a
    }
}

/// The blocks: pairs joined when they share a free DOF (union of their DOFs), each with the
/// rows that have a free part; and the block of every free DOF.
fn blocks_of_pairs(
    geometry: &ContactGeometry,
    n: usize,
) -> Result<(Vec<Block>, Vec<usize>), Ineligible> {
    let pairs = geometry.pairs.len();
    // Union–find over pairs, joined through shared DOFs.
    let mut parent: Vec<usize> = (0..pairs).collect();
    fn root(parent: &mut [usize], mut a: usize) -> usize {
        while parent[a] != a {
            parent[a] = parent[parent[a]];
            a = parent[a];
        }
        a
    }
    let mut owner = vec![NONE; n];
    for (i, row) in geometry.rows.iter().enumerate() {
        for &(d, _) in &row.free {
            let m = pair_of_row(i);
            if owner[d] == NONE {
                owner[d] = m;
            } else {
                let (a, b) = (root(&mut parent, owner[d]), root(&mut parent, m));
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut index_of_root = vec![NONE; pairs];
    let mut members: Vec<Vec<usize>> = Vec::new();
    for m in 0..pairs {
        let r = root(&mut parent, m);
        if index_of_root[r] == NONE {
            index_of_root[r] = members.len();
            members.push(Vec::new());
        }
        members[index_of_root[r]].push(m);
    }
    let mut block_of = vec![NONE; n];
    let mut blocks = Vec::new();
    let mut offset = 1;
    for pairs_in in members {
        let mut dofs: Vec<usize> = pairs_in
            .iter()
            .flat_map(|&m| [normal_row(m), tangential_row(m)])
            .flat_map(|i| geometry.rows[i].free.iter().map(|&(d, _)| d))
            .collect();
        dofs.sort_unstable();
        dofs.dedup();
        if dofs.is_empty() {
            continue;
        }
        if dofs.len() > MAX_BLOCK_DOFS {
            let zone = geometry.pairs[pairs_in[0]].zone;
            return Err(format!(
                "{} contact pairs of zone {zone} and others share nodes in one chain",
                pairs_in.len()
            ));
        }
        let rows = pairs_in
            .iter()
            .flat_map(|&m| [normal_row(m), tangential_row(m)])
            .filter(|&i| !geometry.rows[i].free.is_empty())
            .map(|i| {
                let mut c = vec![0.0; dofs.len()];
                for &(d, v) in &geometry.rows[i].free {
                    c[dofs.binary_search(&d).unwrap_or(0)] += v;
                }
                (i, c)
            })
            .collect();
        for &d in &dofs {
            block_of[d] = blocks.len();
        }
        let s = dofs.len();
        blocks.push(Block { dofs, rows, offset });
        offset += s * s;
    }
    Ok((blocks, block_of))
}

/// Relative remainder below which a row counts as dependent on the rows before it.
const DEPENDENT: f64 = 1e-10;

/// Orthonormal basis of R^s whose first columns span `rows` (modified Gram–Schmidt, twice;
/// a row dependent on the ones before it is skipped), completed by the unit vectors with the
/// largest remainders.
fn basis(rows: &[&[f64]], s: usize) -> Basis {
    let mut q: Vec<Vec<f64>> = Vec::with_capacity(s);
    // Columns of R (one per independent row), each of length `q.len()` at its time.
    let mut columns: Vec<Vec<f64>> = Vec::new();
    let mut independent = Vec::with_capacity(rows.len());
    for row in rows {
        let mut v = row.to_vec();
        let norm0 = norm(&v);
        let mut column = vec![0.0; q.len() + 1];
        for _ in 0..2 {
            for (l, ql) in q.iter().enumerate() {
                let d = dot(ql, &v);
                column[l] += d;
                axpy(-d, ql, &mut v);
            }
        }
        let nv = norm(&v);
        if norm0 == 0.0 || nv <= DEPENDENT * norm0 || q.len() == s {
            independent.push(false);
            continue;
        }
        independent.push(true);
        column[q.len()] = nv;
        columns.push(column);
        q.push(v.iter().map(|x| x / nv).collect());
    }
    let rank = q.len();
    let mut r = vec![0.0; rank * rank];
    for (i, column) in columns.iter().enumerate() {
        for (l, &v) in column.iter().enumerate() {
            r[l * rank + i] = v;
        }
    }
    while q.len() < s {
        let best = (0..s)
            .map(|j| {
                let mut e = vec![0.0; s];
                e[j] = 1.0;
                for _ in 0..2 {
                    for ql in &q {
                        let d = dot(ql, &e);
                        axpy(-d, ql, &mut e);
                    }
                }
                e
            })
            .max_by(|a, b| norm(a).total_cmp(&norm(b)))
            .unwrap_or_default();
        let nb = norm(&best);
        q.push(best.iter().map(|x| x / nb).collect());
    }
    let mut flat = vec![0.0; s * s];
    for (j, col) in q.iter().enumerate() {
        for i in 0..s {
            flat[i * s + j] = col[i];
        }
    }
    Basis {
        q: flat,
        r,
        rank,
        independent,
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    y.iter_mut().zip(x).for_each(|(yi, xi)| *yi += alpha * xi);
}

/// v ← Qᵀ v (`transpose`) or Q v on the DOFs of one block (q row-major s × s).
fn transform_block(dofs: &[usize], q: &[f64], v: &mut [f64], transpose: bool) {
    let s = dofs.len();
    let old: Vec<f64> = dofs.iter().map(|&i| v[i]).collect();
    for a in 0..s {
        v[dofs[a]] = (0..s)
            .map(|b| {
                let qab = if transpose {
                    q[b * s + a]
                } else {
                    q[a * s + b]
                };
                qab * old[b]
            })
            .sum();
    }
}

/// One step of iterative refinement of A y = rhs; returns the relative size of the correction.
fn refine(
    factor: &Factor,
    pattern: SymbolicSparseColMatRef<'_, usize>,
    a: &[f64],
    rhs: &Mat<f64>,
    y: &mut Mat<f64>,
) -> f64 {
    let (n, columns) = (y.nrows(), y.ncols());
    let mut delta = Mat::<f64>::zeros(n, columns);
    for j in 0..columns {
        let yj: Vec<f64> = (0..n).map(|i| y[(i, j)]).collect();
        let ay = symmetric_apply(pattern, a, &yj);
        for i in 0..n {
            delta[(i, j)] = rhs[(i, j)] - ay[i];
        }
    }
    factor.solve_in_place(delta.as_mut());
    let mut worst = 0.0_f64;
    for j in 0..columns {
        let size = (0..n).fold(0.0_f64, |m, i| m.max(y[(i, j)].abs()));
        let change = (0..n).fold(0.0_f64, |m, i| m.max(delta[(i, j)].abs()));
        if size > 0.0 {
            worst = worst.max(change / size);
        }
        for i in 0..n {
            y[(i, j)] += delta[(i, j)];
        }
    }
    worst
}

/// The pattern of A (K's with every block's DOFs merged into one dense block) and the plan
/// that assembles its values from K's and the blocks' bases.
fn merged_pattern(
    k: SymbolicSparseColMatRef<'_, usize>,
    blocks: &[Block],
    block_of: &[usize],
) -> (SymbolicSparseColMat<usize>, Vec<Term>) {
    let n = k.ncols();
    // Coordinates a DOF's value reaches, with the index of the basis entry q[dof][coordinate].
    let coordinates = |i: usize| -> Vec<(usize, u32)> {
        match block_of[i] {
            NONE => vec![(i, 0)],
            b => {
                let (dofs, s) = (&blocks[b].dofs, blocks[b].dofs.len());
                let local = dofs.binary_search(&i).unwrap_or(0);
                dofs.iter()
                    .enumerate()
                    .map(|(j, &x)| (x, (blocks[b].offset + s * local + j) as u32))
                    .collect()
            }
        }
    };
    let (col_ptr, row_idx) = (k.col_ptr(), k.row_idx());
    // (source, lower target (row, col), qa, qb, weight)
    let mut raw: Vec<(u32, usize, usize, u32, u32, f64)> = Vec::new();
    for c in 0..n {
        let cc = coordinates(c);
        let range = col_ptr[c]..col_ptr[c + 1];
        for (p, &r) in range.clone().zip(&row_idx[range]) {
            if r == c {
                for &(x, qx) in &cc {
                    for &(y, qy) in &cc {
                        if x >= y {
                            raw.push((p as u32, x, y, qx, qy, 1.0));
                        }
                    }
                }
            } else {
                for &(x, qx) in &coordinates(r) {
                    for &(y, qy) in &cc {
                        let weight = if x == y { 2.0 } else { 1.0 };
                        raw.push((p as u32, x.max(y), x.min(y), qx, qy, weight));
                    }
                }
            }
        }
    }
    let mut columns: Vec<Vec<usize>> = vec![Vec::new(); n];
    for &(_, row, col, ..) in &raw {
        columns[col].push(row);
    }
    for (c, rows) in columns.iter_mut().enumerate() {
        rows.push(c);
        rows.sort_unstable();
        rows.dedup();
    }
    let mut ptr = Vec::with_capacity(n + 1);
    ptr.push(0);
    for rows in &columns {
        ptr.push(ptr.last().copied().unwrap_or(0) + rows.len());
    }
    let plan = raw
        .iter()
        .map(|&(source, row, col, qa, qb, weight)| {
            let offset = columns[col].binary_search(&row).unwrap_or(0);
            Term {
                source,
                target: (ptr[col] + offset) as u32,
                qa,
                qb,
                weight,
            }
        })
        .collect();
    let rows: Vec<usize> = columns.into_iter().flatten().collect();
    (
        SymbolicSparseColMat::new_checked(n, n, ptr, None, rows),
        plan,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_spans_the_free_rows_and_is_orthonormal() {
        let rows: [&[f64]; 2] = [&[0.6, 0.8, -0.6, -0.8], &[-0.8, 0.6, 0.8, -0.6]];
        for used in [&rows[..0], &rows[..1], &rows[1..], &rows[..]] {
            let b = basis(used, 4);
            assert!(b.independent.iter().all(|&i| i));
            for i in 0..4 {
                for j in 0..4 {
                    let d: f64 = (0..4).map(|l| b.q[l * 4 + i] * b.q[l * 4 + j]).sum();
                    let expected = if i == j { 1.0 } else { 0.0 };
                    assert!((d - expected).abs() < 1e-14, "QᵀQ ≠ I at {i},{j}");
                }
            }
            // B_aᵀ = Q₁ R.
            for (slot, row) in used.iter().enumerate() {
                for i in 0..4 {
                    let v: f64 = (0..b.rank)
                        .map(|l| b.q[i * 4 + l] * b.r[l * b.rank + slot])
                        .sum();
                    assert!((v - row[i]).abs() < 1e-14);
                }
            }
        }
    }

    #[test]
    fn dependent_rows_are_skipped() {
        let rows: [&[f64]; 3] = [&[1.0, 0.0], &[2.0, 0.0], &[1.0, 1.0]];
        let b = basis(&rows, 2);
        assert_eq!(b.independent, [true, false, true]);
        assert_eq!(b.rank, 2);
        // R = [[1, 1], [0, 1]]: the third row is q₀ + q₁ with q = I.
        assert!((b.r[1] - 1.0).abs() < 1e-15 && (b.r[3] - 1.0).abs() < 1e-15);
    }
}
