//! A condition estimate of the stiffness matrix K_ff of a state problem: κ = λ_max / λ_min+,
//! λ_min+ the smallest eigenvalue above the k zero eigenvalues of the floating bodies' rigid
//! motions (k = the contact kernel dimension, design §2.3). Dense symmetric eigenvalues, so only
//! for small problems; eigenvalues below rounding (≈ 1e-15 λ_max) cannot be resolved, so
//! κ ≳ 1e15 means "singular to working precision".

use faer::{Mat, Side};

use wsm_core::{Data, StateProblem, WsmError};

/// Largest K_ff for which the estimate is computed.
pub const MAX_UNKNOWNS: usize = 1500;

/// κ(K_ff) for the data (`None` above [`MAX_UNKNOWNS`]).
pub fn stiffness_condition(problem: &StateProblem, data: &Data) -> Result<Option<f64>, WsmError> {
    let op = problem.elastic.operator();
    let n = op.n_free();
    if n == 0 || n > MAX_UNKNOWNS {
        return Ok(None);
    }
    let values = op.assemble(&problem.elastic.coefficients(data)?)?;
    let pattern = op.pattern();
    let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
    let mut k = Mat::<f64>::zeros(n, n);
    for c in 0..n {
        for p in col_ptr[c]..col_ptr[c + 1] {
            let r = row_idx[p];
            k[(r, c)] = values[p];
            k[(c, r)] = values[p];
        }
    }
    let eigenvalues = k
        .self_adjoint_eigenvalues(Side::Lower)
        .map_err(|e| WsmError::io("condition estimate", format!("{e:?}")))?;
    let zero = problem.contact.kernel_dim();
    let largest = eigenvalues.last().copied().unwrap_or(0.0);
    let smallest = eigenvalues.get(zero).copied().unwrap_or(0.0);
    Ok(Some(if smallest > 0.0 {
        largest / smallest
    } else {
        f64::INFINITY
    }))
}
