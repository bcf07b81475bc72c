//! The zoned operator shared by elasticity and heat: K(c) = Σ_z Σ_k c_{z,k} K_{z,k}, a linear
//! combination of per-zone matrices with zone coefficients c (elasticity: (λ_z, μ_z), FGCS 2.13'
//! a(u, v) = Σ_z ∫ λ_z tr e(u) tr e(v) + 2μ_z e(u):e(v); heat: κ_z, ∫ κ_z ∇T·∇w).
//!
//! The reduced system keeps only free unknowns ([`Slot::Free`]); prescribed ones
//! ([`Slot::Fixed`]) are lifted to the right-hand side with the coupling block K_fd. The lower
//! triangle of K_ff has ONE pattern (CSC, usize); each zone stores only its own nonzero positions
//! and values, so assembling K for new coefficients costs O(nnz) and the symbolic Cholesky
//! analysis is done once.

use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::Par;

use super::linear::{Factor, Symbolic};
use super::FemError;

/// Where an unknown of the (rotated, merged) field lives in the reduced system.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Slot {
    /// Index among the free unknowns (rows of K_ff).
    Free(usize),
    /// Index among the prescribed unknowns (columns of K_fd).
    Fixed(usize),
}

/// One merged matrix entry of a zone.
#[derive(Debug, Clone, Copy)]
struct Entry<const NC: usize> {
    col: usize,
    row: usize,
    v: [f64; NC],
}

/// Collects element matrices zone by zone; `finish` builds the pattern and the per-zone blocks.
#[derive(Debug)]
pub struct OperatorBuilder<const NC: usize> {
    n_free: usize,
    n_fixed: usize,
    free_free: Vec<Vec<Entry<NC>>>,
    free_fixed: Vec<Vec<Entry<NC>>>,
}

impl<const NC: usize> OperatorBuilder<NC> {
    pub fn new(n_free: usize, n_fixed: usize, n_zones: usize) -> Self {
        OperatorBuilder {
            n_free,
            n_fixed,
            free_free: vec![Vec::new(); n_zones],
            free_fixed: vec![Vec::new(); n_zones],
        }
    }

    /// Add an element of `zone` whose local unknowns are `slots`; `entry(i, j)` gives the
    /// element matrix entry (i, j) of each coefficient, in the basis of the slots.
    pub fn add_element(
        &mut self,
        zone: usize,
        slots: &[Slot],
        entry: impl Fn(usize, usize) -> [f64; NC],
    ) {
        for (i, &si) in slots.iter().enumerate() {
            let Slot::Free(row) = si else { continue };
            for (j, &sj) in slots.iter().enumerate() {
                match sj {
                    Slot::Free(col) if row >= col => self.free_free[zone].push(Entry {
                        col,
                        row,
                        v: entry(i, j),
                    }),
                    Slot::Fixed(col) => self.free_fixed[zone].push(Entry {
                        col,
                        row,
                        v: entry(i, j),
                    }),
                    Slot::Free(_) => {}
                }
            }
        }
    }

    /// Build the common pattern (every diagonal entry included), the per-zone blocks and the
    /// symbolic factorisation.
    pub fn finish(self) -> Result<ZonedOperator<NC>, FemError> {
        let n = self.n_free;
        let free_free: Vec<Vec<Entry<NC>>> = self.free_free.into_iter().map(merge).collect();
        let mut keys: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
        for zone in &free_free {
            keys.extend(zone.iter().map(|e| (e.col, e.row)));
        }
        keys.sort_unstable();
        keys.dedup();
        let mut col_ptr = vec![0usize; n + 1];
        for &(c, _) in &keys {
            col_ptr[c + 1] += 1;
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        let row_idx: Vec<usize> = keys.iter().map(|&(_, r)| r).collect();
        let position = |e: &Entry<NC>| {
            let (lo, hi) = (col_ptr[e.col], col_ptr[e.col + 1]);
            lo + row_idx[lo..hi].partition_point(|&r| r < e.row)
        };
        let zones = free_free
            .iter()
            .map(|merged| ZoneBlock {
                index: merged.iter().map(position).collect(),
                values: merged.iter().map(|e| e.v).collect(),
            })
            .collect();
        let coupling = self
            .free_fixed
            .into_iter()
            .map(|entries| {
                let merged = merge(entries);
                CouplingBlock {
                    rows: merged.iter().map(|e| e.row).collect(),
                    cols: merged.iter().map(|e| e.col).collect(),
                    values: merged.iter().map(|e| e.v).collect(),
                }
            })
            .collect();
        let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let symbolic = Symbolic::analyse(pattern.as_ref())?;
        Ok(ZonedOperator {
            n_fixed: self.n_fixed,
            pattern,
            zones,
            coupling,
            symbolic,
            quasi_definite: false,
        })
    }
}

/// Sort entries by (col, row) and sum duplicates.
fn merge<const NC: usize>(mut entries: Vec<Entry<NC>>) -> Vec<Entry<NC>> {
    entries.sort_unstable_by_key(|e| (e.col, e.row));
    let mut out: Vec<Entry<NC>> = Vec::with_capacity(entries.len() / 2);
    for e in entries {
        match out.last_mut() {
            Some(last) if last.col == e.col && last.row == e.row => {
                for k in 0..NC {
                    last.v[k] += e.v[k];
                }
            }
            _ => out.push(e),
        }
    }
    out
}

/// Nonzeros of one zone in the common pattern: value positions and per-coefficient values.
#[derive(Debug, Clone)]
struct ZoneBlock<const NC: usize> {
    index: Vec<usize>,
    values: Vec<[f64; NC]>,
}

/// Coupling block K_fd of one zone (free rows, fixed columns) in coordinate form.
#[derive(Debug, Clone)]
struct CouplingBlock<const NC: usize> {
    rows: Vec<usize>,
    cols: Vec<usize>,
    values: Vec<[f64; NC]>,
}

/// K_ff(c) = Σ_z Σ_k c_{z,k} K_{z,k} on one lower-triangular pattern, plus K_fd(c) for lifting.
#[derive(Debug, Clone)]
pub struct ZonedOperator<const NC: usize> {
    n_fixed: usize,
    pattern: SymbolicSparseColMat<usize>,
    zones: Vec<ZoneBlock<NC>>,
    coupling: Vec<CouplingBlock<NC>>,
    symbolic: Symbolic,
    /// Symmetric quasi-definite (the mixed u–p system): factorised as LDLᵀ, not LLᵀ.
    quasi_definite: bool,
}

impl<const NC: usize> ZonedOperator<NC> {
    /// The same operator marked symmetric quasi-definite: [`Self::factor`] then computes an
    /// LDLᵀ factorisation without pivoting ([`Symbolic::factorize_quasi_definite`]).
    pub fn into_quasi_definite(mut self) -> Self {
        self.quasi_definite = true;
        self
    }

    /// Whether the operator is quasi-definite (LDLᵀ) rather than positive definite (LLᵀ).
    pub fn is_quasi_definite(&self) -> bool {
        self.quasi_definite
    }

    /// Numeric factorisation of a matrix on this operator's pattern (or a sub-pattern analysed
    /// by `symbolic`): LLᵀ, or LDLᵀ for a quasi-definite operator.
    pub fn factorize_with(
        &self,
        symbolic: &Symbolic,
        matrix: SparseColMatRef<'_, usize, f64>,
        par: Par,
    ) -> Result<Factor, FemError> {
        if self.quasi_definite {
            symbolic.factorize_quasi_definite(matrix, par)
        } else {
            symbolic.factorize(matrix, par)
        }
    }

    /// Number of free unknowns (dimension of K_ff).
    pub fn n_free(&self) -> usize {
        self.pattern.nrows()
    }

    /// Number of prescribed unknowns.
    pub fn n_fixed(&self) -> usize {
        self.n_fixed
    }

    /// Number of zones.
    pub fn n_zones(&self) -> usize {
        self.zones.len()
    }

    /// Lower-triangular CSC pattern of K_ff.
    pub fn pattern(&self) -> SymbolicSparseColMatRef<'_, usize> {
        self.pattern.as_ref()
    }

    /// The shared symbolic Cholesky analysis of the pattern.
    pub fn symbolic(&self) -> &Symbolic {
        &self.symbolic
    }

    fn check_coefficients(&self, coefs: &[[f64; NC]]) -> Result<(), FemError> {
        if coefs.len() == self.zones.len() {
            Ok(())
        } else {
            Err(FemError::Input(format!(
                "{} zone coefficient sets given, the operator has {} zones",
                coefs.len(),
                self.zones.len()
            )))
        }
    }

    /// Values of K_ff(c) (lower triangle) in the order of `pattern()`.
    pub fn assemble(&self, coefs: &[[f64; NC]]) -> Result<Vec<f64>, FemError> {
        self.check_coefficients(coefs)?;
        let mut values = vec![0.0; self.pattern.compute_nnz()];
        for (zone, c) in self.zones.iter().zip(coefs) {
            for (&p, v) in zone.index.iter().zip(&zone.values) {
                values[p] += (0..NC).map(|k| c[k] * v[k]).sum::<f64>();
            }
        }
        Ok(values)
    }

    /// K_ff as a faer matrix view (lower triangle) over `values` from [`Self::assemble`].
    pub fn matrix<'a>(&'a self, values: &'a [f64]) -> SparseColMatRef<'a, usize, f64> {
        SparseColMatRef::new(self.pattern.as_ref(), values)
    }

    /// y = K_ff x with K_ff given by its lower-triangular `values`.
    pub fn apply(&self, values: &[f64], x: &[f64]) -> Vec<f64> {
        super::linear::symmetric_apply(self.pattern.as_ref(), values, x)
    }

    /// rhs −= K_fd(c) u_d: lift the prescribed values `fixed` to the right-hand side.
    pub fn lift(
        &self,
        coefs: &[[f64; NC]],
        fixed: &[f64],
        rhs: &mut [f64],
    ) -> Result<(), FemError> {
        self.check_coefficients(coefs)?;
        if fixed.len() != self.n_fixed || rhs.len() != self.n_free() {
            return Err(FemError::Input(format!(
                "lift: {} fixed values and {} right-hand-side entries given, expected {} and {}",
                fixed.len(),
                rhs.len(),
                self.n_fixed,
                self.n_free()
            )));
        }
        for (block, c) in self.coupling.iter().zip(coefs) {
            for ((&r, &d), v) in block.rows.iter().zip(&block.cols).zip(&block.values) {
                rhs[r] -= (0..NC).map(|k| c[k] * v[k]).sum::<f64>() * fixed[d];
            }
        }
        Ok(())
    }

    /// Assemble K_ff(c) and factorise it numerically on the shared symbolic analysis.
    pub fn factor(&self, coefs: &[[f64; NC]], par: Par) -> Result<OperatorFactor<NC>, FemError> {
        let values = self.assemble(coefs)?;
        let factor = self.factorize_with(&self.symbolic, self.matrix(&values), par)?;
        Ok(OperatorFactor {
            coefficients: coefs.to_vec(),
            factor,
        })
    }
}

/// A factorised K_ff(c) together with the coefficients it was built from (the lifting of
/// prescribed values must use the same coefficients).
#[derive(Debug, Clone)]
pub struct OperatorFactor<const NC: usize> {
    /// Zone coefficients the factor was built from (one `[f64; NC]` per zone: [λ_z, μ_z] for
    /// elasticity, \[κ_z\] for heat).
    pub coefficients: Vec<[f64; NC]>,
    /// The numeric Cholesky factor of K_ff(c).
    pub factor: Factor,
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// Two zones of 1D bar elements on unknowns 0..4 (unknown 4 fixed), coefficients [a, b].
    fn bar() -> ZonedOperator<2> {
        let slot = |u: usize| {
            if u == 4 {
                Slot::Fixed(0)
            } else {
                Slot::Free(u)
            }
        };
        let mut b = OperatorBuilder::<2>::new(4, 1, 2);
        for e in 0..4 {
            let sign = |i: usize, j: usize| if i == j { 1.0 } else { -1.0 };
            b.add_element(e % 2, &[slot(e), slot(e + 1)], |i, j| {
                [sign(i, j), (e + 1) as f64 * sign(i, j)]
            });
        }
        b.finish().unwrap()
    }

    fn dense(op: &ZonedOperator<2>, values: &[f64]) -> Mat<f64> {
        let n = op.n_free();
        let mut k = Mat::<f64>::zeros(n, n);
        for i in 0..n {
            let mut e = vec![0.0; n];
            e[i] = 1.0;
            for (r, v) in op.apply(values, &e).into_iter().enumerate() {
                k[(r, i)] = v;
            }
        }
        k
    }

    #[test]
    fn assembly_is_the_linear_combination_of_zone_matrices() {
        let op = bar();
        let coefs = [[2.0, 0.5], [1.0, 3.0]];
        let k = dense(&op, &op.assemble(&coefs).unwrap());
        // Element e (zone e % 2) has stiffness c0 + (e + 1) c1 between unknowns e and e + 1.
        let s: Vec<f64> = (0..4)
            .map(|e| coefs[e % 2][0] + (e + 1) as f64 * coefs[e % 2][1])
            .collect();
        let expected = [
            [s[0], -s[0], 0.0, 0.0],
            [-s[0], s[0] + s[1], -s[1], 0.0],
            [0.0, -s[1], s[1] + s[2], -s[2]],
            [0.0, 0.0, -s[2], s[2] + s[3]],
        ];
        for i in 0..4 {
            for j in 0..4 {
                assert!((k[(i, j)] - expected[i][j]).abs() < 1e-14, "({i},{j})");
            }
        }
        let mut rhs = vec![0.0; 4];
        op.lift(&coefs, &[2.0], &mut rhs).unwrap();
        assert_eq!(rhs, vec![0.0, 0.0, 0.0, 2.0 * s[3]]);
        assert!(op.assemble(&coefs[..1]).is_err());
    }

    #[test]
    fn factor_solves_many_right_hand_sides_and_rejects_indefinite() {
        let op = bar();
        let coefs = [[2.0, 0.5], [1.0, 3.0]];
        let values = op.assemble(&coefs).unwrap();
        let f = op.factor(&coefs, Par::Seq).unwrap();
        let mut b = Mat::<f64>::from_fn(4, 3, |i, j| (i + 2 * j) as f64 - 1.5);
        let original = b.clone();
        f.factor.solve_in_place(b.as_mut());
        for j in 0..3 {
            let x: Vec<f64> = b.col(j).iter().copied().collect();
            let kx = op.apply(&values, &x);
            for i in 0..4 {
                assert!((kx[i] - original[(i, j)]).abs() < 1e-12);
            }
        }
        let err = op
            .factor(&[[-1.0, -1.0], [1.0, 3.0]], Par::Seq)
            .unwrap_err();
        assert!(matches!(err, FemError::NotPositiveDefinite { .. }));
    }
}
