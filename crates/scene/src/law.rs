//! The plane-strain stress–strain law of a zone in Voigt form (FGCS 2.7′, design §2.1):
//! τ = D e − β (T − T0) in the plane and τ33 = c · e − β33 (T − T0), with
//! e = (e11, e22, γ12) (engineering shear γ12 = 2 e12), τ = (τ11, τ22, τ12), D the symmetric
//! in-plane 3×3 stiffness and c = (c31, c32, c36) the out-of-plane row (ε33 = 0, τ13 = τ23 = 0).
//! The thermal vector is β = (β11, β22, β12, β33): β12 is the tensor shear component, so the
//! thermal work is β11 e11 + β22 e22 + β12 γ12 (FGCS's factor 2 on shear components).
//!
//! Sources of D: isotropic λ, μ; an orthotropic material (E1, E2, E3, ν12, ν13, ν23, G12 and the
//! angle of axis 1 in the plane, axis 3 out of plane), whose 3D compliance is inverted, restricted
//! to ε33 = 0 and rotated; or the matrix itself. Also here: the symmetric eigenvalues of small
//! matrices and the interval-matrix margin of FGCS (4.6)/(4.8),
//! λ_min(½(B̲ + B̄)) − ρ(½(B̄ − B̲)), whose positivity guarantees that every symmetric member of
//! the box is positive definite.

/// The plane-strain law of a zone without its thermal part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneStrainLaw {
    /// In-plane stiffness D \[Pa\] acting on (e11, e22, γ12), symmetric.
    pub d: [[f64; 3]; 3],
    /// Out-of-plane row (c31, c32, c36) \[Pa\]: τ33 = c · (e11, e22, γ12) − β33 (T − T0).
    pub out_of_plane: [f64; 3],
}

/// Indices (i, j), i ≤ j, of the six independent entries of D in the order of
/// [`PlaneStrainLaw::coefficients`]: d11, d12, d13, d22, d23, d33.
pub const ENTRIES: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// The Lamé coefficients (λ, μ) \[Pa\] of an isotropic material of Young's modulus E \[Pa\] and
/// Poisson's ratio ν: λ = Eν/((1+ν)(1−2ν)), μ = E/(2(1+ν)). The one place this conversion is
/// written (the resolved data, the validation's stiffness corners and the tests use it).
pub fn lame_from_young(e: f64, nu: f64) -> (f64, f64) {
    (
        e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        e / (2.0 * (1.0 + nu)),
    )
}

impl PlaneStrainLaw {
    /// Isotropic plane strain: D = λ m mᵀ + μ diag(2, 2, 1), c = (λ, λ, 0).
    pub fn isotropic(lambda: f64, mu: f64) -> PlaneStrainLaw {
        let a = lambda + 2.0 * mu;
        PlaneStrainLaw {
            d: [[a, lambda, 0.0], [lambda, a, 0.0], [0.0, 0.0, mu]],
            out_of_plane: [lambda, lambda, 0.0],
        }
    }

    /// The six independent entries of D (the zone coefficients of the elastic operator).
    pub fn coefficients(&self) -> [f64; 6] {
        ENTRIES.map(|(i, j)| self.d[i][j])
    }

    /// (τ11, τ22, τ12, τ33) of the strain (e11, e22, e12) (tensor shear) and ΔT = T − T0.
    pub fn stress(&self, beta: &[f64; 4], strain: [f64; 3], delta_t: f64) -> [f64; 4] {
        let e = [strain[0], strain[1], 2.0 * strain[2]];
        let row = |r: &[f64; 3]| r[0] * e[0] + r[1] * e[1] + r[2] * e[2];
        [
            row(&self.d[0]) - beta[0] * delta_t,
            row(&self.d[1]) - beta[1] * delta_t,
            row(&self.d[2]) - beta[2] * delta_t,
            row(&self.out_of_plane) - beta[3] * delta_t,
        ]
    }

    /// `bulk_and_shear` of D.
    pub fn bulk_and_shear(&self) -> (f64, f64) {
        bulk_and_shear(&self.coefficients())
    }
}

/// A plane-strain bulk modulus and a shear modulus of D given by its entries
/// [`PlaneStrainLaw::coefficients`]: K = mᵀ D m / 4 (m = (1, 1, 0)) and
/// G = min(d33, (d11 − 2 d12 + d22)/4); for isotropic D exactly λ + μ and μ.
pub fn bulk_and_shear(&[d11, d12, _, d22, _, d33]: &[f64; 6]) -> (f64, f64) {
    let bulk = (d11 + 2.0 * d12 + d22) / 4.0;
    let shear = d33.min((d11 - 2.0 * d12 + d22) / 4.0);
    (bulk, shear)
}

/// Orthotropic constants: axes 1 and 2 in the plane (axis 1 at `angle` from x), axis 3 out of
/// plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orthotropic {
    /// Young's moduli E1, E2, E3 \[Pa\].
    pub young: [f64; 3],
    /// Poisson's ratios ν12, ν13, ν23 (ν_ij = −ε_j/ε_i under stress along i).
    pub poisson: [f64; 3],
    /// In-plane shear modulus G12 \[Pa\].
    pub shear: f64,
    /// Angle of axis 1 from the x axis, counter-clockwise \[deg\].
    pub angle: f64,
}

impl Orthotropic {
    /// The 3×3 normal block of the 3D compliance in material axes \[1/Pa\]:
    /// S_ii = 1/E_i, S_12 = −ν12/E1, S_13 = −ν13/E1, S_23 = −ν23/E2.
    pub fn normal_compliance(&self) -> [[f64; 3]; 3] {
        let [e1, e2, e3] = self.young;
        let [n12, n13, n23] = self.poisson;
        [
            [1.0 / e1, -n12 / e1, -n13 / e1],
            [-n12 / e1, 1.0 / e2, -n23 / e2],
            [-n13 / e1, -n23 / e2, 1.0 / e3],
        ]
    }

    /// The normal block C of the 3D stiffness in material axes (the inverse of
    /// [`Self::normal_compliance`]); `None` when the compliance is singular.
    pub fn normal_stiffness(&self) -> Option<[[f64; 3]; 3]> {
        invert3(&self.normal_compliance())
    }

    /// The plane-strain law in the x, y frame: in material axes D' = [[C11, C12, 0], [C12, C22,
    /// 0], [0, 0, G12]] and c' = (C13, C23, 0); rotated by D = Tᵀ D' T, c = Tᵀ c' with T the
    /// engineering-strain rotation e' = T e.
    pub fn law(&self) -> Option<PlaneStrainLaw> {
        let c = self.normal_stiffness()?;
        let local = [
            [c[0][0], c[0][1], 0.0],
            [c[0][1], c[1][1], 0.0],
            [0.0, 0.0, self.shear],
        ];
        let t = strain_rotation(self.angle);
        let mut d = [[0.0; 3]; 3];
        for (i, row) in d.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3)
                    .flat_map(|p| (0..3).map(move |q| (p, q)))
                    .map(|(p, q)| t[p][i] * local[p][q] * t[q][j])
                    .sum();
            }
        }
        Some(PlaneStrainLaw {
            d,
            out_of_plane: transpose_times(&t, [c[0][2], c[1][2], 0.0]),
        })
    }

    /// β of an isotropic expansion α \[1/K\]: the stress of ε = α I, C (α, α, α) in material
    /// axes, rotated like a stress: (β11, β22, β12) = Tᵀ (b1, b2, 0), β33 = b3.
    pub fn expansion_beta(&self, alpha: f64) -> Option<[f64; 4]> {
        let c = self.normal_stiffness()?;
        let b = c.map(|row| alpha * (row[0] + row[1] + row[2]));
        let [b11, b22, b12] = transpose_times(&strain_rotation(self.angle), [b[0], b[1], 0.0]);
        Some([b11, b22, b12, b[2]])
    }
}

/// T with e' = T e for engineering strains (e11, e22, γ12) and material axis 1 at `angle` \[deg\].
fn strain_rotation(angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.to_radians().sin_cos();
    [
        [c * c, s * s, c * s],
        [s * s, c * c, -c * s],
        [-2.0 * c * s, 2.0 * c * s, c * c - s * s],
    ]
}

/// Tᵀ v.
fn transpose_times(t: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|p| t[p][i] * v[p]).sum())
}

/// The inverse of a 3×3 matrix by cofactors; `None` when it is singular or not finite.
fn invert3(a: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let cof = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0]
    };
    let det: f64 = (0..3).map(|j| a[0][j] * cof(0, j)).sum();
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| cof(j, i) / det));
    inv.iter().flatten().all(|v| v.is_finite()).then_some(inv)
}

/// Eigenvalues of a symmetric N×N matrix (the upper triangle is read), ascending, by cyclic
/// Jacobi rotations (to rounding).
pub fn symmetric_eigenvalues<const N: usize>(a: &[[f64; N]; N]) -> [f64; N] {
    let mut m: [[f64; N]; N] =
        std::array::from_fn(|i| std::array::from_fn(|j| if i <= j { a[i][j] } else { a[j][i] }));
    for _ in 0..64 {
        let off: f64 = (0..N)
            .flat_map(|i| (i + 1..N).map(move |j| (i, j)))
            .map(|(i, j)| m[i][j] * m[i][j])
            .sum();
        let scale: f64 = (0..N).map(|i| m[i][i] * m[i][i]).sum::<f64>() + off;
        if off <= 1e-32 * scale {
            break;
        }
        for p in 0..N {
            for q in p + 1..N {
                if m[p][q] == 0.0 {
                    continue;
                }
                let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for row in m.iter_mut() {
                    let (mkp, mkq) = (row[p], row[q]);
                    row[p] = c * mkp - s * mkq;
                    row[q] = s * mkp + c * mkq;
                }
                let (row_p, row_q) = (m[p], m[q]);
                for (k, (mpk, mqk)) in row_p.into_iter().zip(row_q).enumerate() {
                    m[p][k] = c * mpk - s * mqk;
                    m[q][k] = s * mpk + c * mqk;
                }
            }
        }
    }
    let mut eig: [f64; N] = std::array::from_fn(|i| m[i][i]);
    eig.sort_by(f64::total_cmp);
    eig
}

/// The margin c_B of FGCS (4.6)/(4.8) of the symmetric interval matrix [lo, hi] (entrywise,
/// lo ≤ hi): λ_min(½(lo + hi)) − ρ(½(hi − lo)). Positive: every symmetric matrix of the box is
/// positive definite (its smallest eigenvalue is at least the margin).
pub fn interval_margin<const N: usize>(lo: &[[f64; N]; N], hi: &[[f64; N]; N]) -> f64 {
    let mid: [[f64; N]; N] =
        std::array::from_fn(|i| std::array::from_fn(|j| 0.5 * (lo[i][j] + hi[i][j])));
    let radius: [[f64; N]; N] =
        std::array::from_fn(|i| std::array::from_fn(|j| 0.5 * (hi[i][j] - lo[i][j])));
    let r = symmetric_eigenvalues(&radius);
    symmetric_eigenvalues(&mid)[0] - r[0].abs().max(r[N - 1].abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_eigenvalues_of_a_known_matrix() {
        // [[2, 1, 0], [1, 2, 0], [0, 0, 5]]: 1, 3, 5.
        let e = symmetric_eigenvalues(&[[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 5.0]]);
        for (a, b) in e.iter().zip([1.0, 3.0, 5.0]) {
            assert!((a - b).abs() < 1e-14, "{e:?}");
        }
        let e = symmetric_eigenvalues(&[[4.0, -2.0], [-2.0, 1.0]]);
        assert!(e[0].abs() < 1e-14 && (e[1] - 5.0).abs() < 1e-14, "{e:?}");
    }

    #[test]
    fn orthotropic_with_isotropic_constants_is_isotropic() {
        let (e, nu) = (2e9, 0.3);
        let (lambda, mu) = lame_from_young(e, nu);
        let iso = PlaneStrainLaw::isotropic(lambda, mu);
        for angle in [0.0, 37.0, 90.0] {
            let o = Orthotropic {
                young: [e; 3],
                poisson: [nu; 3],
                shear: mu,
                angle,
            };
            let law = o.law().unwrap();
            for i in 0..3 {
                for j in 0..3 {
                    assert!((law.d[i][j] - iso.d[i][j]).abs() < 1e-6 * e, "{law:?}");
                }
                assert!((law.out_of_plane[i] - iso.out_of_plane[i]).abs() < 1e-6 * e);
            }
            let beta = o.expansion_beta(1e-5).unwrap();
            let b = (3.0 * iso.d[0][1] + 2.0 * iso.d[2][2]) * 1e-5;
            let expected = [b, b, 0.0, b];
            assert!(
                beta.iter()
                    .zip(expected)
                    .all(|(x, y)| (x - y).abs() < 1e-9 * b),
                "{beta:?}"
            );
        }
    }

    #[test]
    fn interval_margin_bounds_the_box() {
        let lo = [[2.0, -0.5], [-0.5, 2.0]];
        let hi = [[3.0, 0.5], [0.5, 3.0]];
        // Mid diag(2.5, 2.5); radius [[0.5, 0.5], [0.5, 0.5]] with ρ = 1.
        assert!((interval_margin(&lo, &hi) - 1.5).abs() < 1e-14);
        let hi = [[3.0, 2.5], [2.5, 3.0]];
        assert!(interval_margin(&lo, &hi) < 0.0);
    }
}
