//! The P1 element's stiffness pieces (design §2.4): per element and independent entry of the
//! plane-strain law, K^k_e = area·Bᵀ E_k B in global xy, and their rotation into the nodes'
//! local bases (rollers). The P1 operator (`elasticity`) and the mixed element (`mixed`) build
//! on them.

use super::geometry::TriangleGradients;
use crate::scene::law::ENTRIES;

/// Per element and independent entry k = (p, q) of D: K^k_e = area Bᵀ E_k B in global xy, E_k
/// the symmetric unit matrix of (p, q): area (s_a[p] s_b[q] + s_a[q] s_b[p]) for p ≠ q and
/// area s_a[p] s_b[p] for p = q, s_a the strain (e11, e22, γ12) of the shape function's unknown.
pub(super) fn element_matrices(g: &TriangleGradients) -> [[[f64; 6]; 6]; 6] {
    // e(φ_a e_x) = (xa, 0, ya), e(φ_a e_y) = (0, ya, xa) as (e11, e22, γ12).
    let strain = |i: usize| {
        let (x, y) = (g.dx[i / 2], g.dy[i / 2]);
        if i.is_multiple_of(2) {
            [x, 0.0, y]
        } else {
            [0.0, y, x]
        }
    };
    let mut k = [[[0.0; 6]; 6]; 6];
    for (i, row) in k.iter_mut().enumerate() {
        let si = strain(i);
        for (j, entry) in row.iter_mut().enumerate() {
            let sj = strain(j);
            *entry = ENTRIES.map(|(p, q)| {
                let v = if p == q {
                    si[p] * sj[p]
                } else {
                    si[p] * sj[q] + si[q] * sj[p]
                };
                g.area * v
            });
        }
    }
    k
}

/// K_loc = Tᵀ K T with T = blockdiag(R_a), R_a = [e0 e1] the local basis of node a:
/// (K_loc)_ij = e_i(a)ᵀ K_ab e_j(b) for local DOF i of node a and j of node b.
pub(super) fn rotate(k: &mut [[[f64; 6]; 6]; 6], bases: [[[f64; 2]; 2]; 3]) {
    let global = *k;
    for (i, row) in k.iter_mut().enumerate() {
        for (j, entry) in row.iter_mut().enumerate() {
            let (a, b) = (i / 2, j / 2);
            let (ea, eb) = (bases[a][i % 2], bases[b][j % 2]);
            *entry = std::array::from_fn(|c| {
                (0..2)
                    .flat_map(|p| (0..2).map(move |q| (p, q)))
                    .map(|(p, q)| ea[p] * global[2 * a + p][2 * b + q][c] * eb[q])
                    .sum()
            });
        }
    }
}
