//! Rigid motions and floating bodies (design §2.3, CZ Thm 1.2, D05 Thm 2.1).
//!
//! The plane rigid motions of a body are w = a (1, 0) + b (0, 1) + c (−(y − y_c), x − x_c) about
//! its centroid. A body is floating when some nonzero rigid motion satisfies all its constraints
//! (every prescribed local DOF of the motion is zero): then K_ff is singular. The kernel of K_ff
//! on that body is exactly those motions, expressed here on the free DOFs.

use faer::{Mat, MatRef, Side};

use super::dofs::DofMap;
use super::operator::Slot;
use super::FemError;
use crate::mesh::Mesh;

/// Relative eigenvalue threshold below which a rigid motion counts as unconstrained.
const KERNEL_TOL: f64 = 1e-10;

/// The rigid motions of a body that its supports leave free.
#[derive(Debug, Clone)]
pub struct RigidModes {
    /// Index of the body in the mesh.
    pub body: usize,
    /// Rotation centre (area centroid of the body).
    pub centroid: [f64; 2],
    /// Each mode as coefficients (translation x, translation y, rotation about the centroid).
    pub coefficients: Vec<[f64; 3]>,
    /// Each mode on the reduced (free, rotated) DOFs: n_free × modes.
    pub modes: Mat<f64>,
}

/// Area centroid of a body and its radius (largest node distance from the centroid, at least
/// the smallest positive float so that it can scale the rotation).
fn centroid_and_radius(mesh: &Mesh, body: usize) -> ([f64; 2], f64) {
    let (mut area, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if mesh.node_body[tri[0]] != body {
            continue;
        }
        let a = mesh.triangle_area(t);
        area += a;
        for &n in tri {
            cx += a * mesh.nodes[n][0] / 3.0;
            cy += a * mesh.nodes[n][1] / 3.0;
        }
    }
    let c = if area > 0.0 {
        [cx / area, cy / area]
    } else {
        [0.0, 0.0]
    };
    let radius = body_nodes(mesh, body)
        .map(|n| (mesh.nodes[n][0] - c[0]).hypot(mesh.nodes[n][1] - c[1]))
        .fold(f64::MIN_POSITIVE, f64::max);
    (c, radius)
}

fn body_nodes(mesh: &Mesh, body: usize) -> impl Iterator<Item = usize> + '_ {
    (0..mesh.nodes.len()).filter(move |&n| mesh.node_body[n] == body)
}

/// The three unit rigid motions at point p: translation x, translation y, rotation (scaled by
/// 1/scale so that the three are comparable).
fn rigid_at(p: [f64; 2], c: [f64; 2], scale: f64) -> [[f64; 2]; 3] {
    [
        [1.0, 0.0],
        [0.0, 1.0],
        [-(p[1] - c[1]) / scale, (p[0] - c[0]) / scale],
    ]
}

/// Coefficient vectors (in the scaled basis) of the rigid motions left free by the constraints.
fn unconstrained_motions(
    mesh: &Mesh,
    dofs: &DofMap,
    body: usize,
    c: [f64; 2],
    scale: f64,
) -> Result<Vec<[f64; 3]>, FemError> {
    let mut gram = Mat::<f64>::zeros(3, 3);
    for node in body_nodes(mesh, body) {
        let w = rigid_at(mesh.nodes[node], c, scale);
        for a in dofs.constraint_directions(node) {
            let row = w.map(|wi| a[0] * wi[0] + a[1] * wi[1]);
            for i in 0..3 {
                for j in 0..3 {
                    gram[(i, j)] += row[i] * row[j];
                }
            }
        }
    }
    let trace = gram[(0, 0)] + gram[(1, 1)] + gram[(2, 2)];
    if trace == 0.0 {
        return Ok(vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    }
    let eig = gram
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| FemError::Solver(format!("rigid-motion eigenproblem: {e:?}")))?;
    let (s, u) = (eig.S(), eig.U());
    Ok((0..3)
        .filter(|&k| s[k] <= KERNEL_TOL * trace)
        .map(|k| [u[(0, k)], u[(1, k)], u[(2, k)]])
        .collect())
}

/// The rigid motions of `body` that its supports leave free (empty when the body is held).
pub fn rigid_modes(mesh: &Mesh, dofs: &DofMap, body: usize) -> Result<RigidModes, FemError> {
    let (centroid, scale) = centroid_and_radius(mesh, body);
    let scaled = unconstrained_motions(mesh, dofs, body, centroid, scale)?;
    // Unscaled rotation: the coefficient multiplies (−(y − yc), x − xc) directly; a fully free
    // body gets the plain basis (translation x, translation y, unit rotation).
    let coefficients: Vec<[f64; 3]> = if scaled.len() == 3 {
        vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    } else {
        scaled.iter().map(|m| [m[0], m[1], m[2] / scale]).collect()
    };
    let mut modes = Mat::<f64>::zeros(dofs.n_free(), coefficients.len());
    for node in body_nodes(mesh, body) {
        let w = rigid_at(mesh.nodes[node], centroid, 1.0);
        for (k, m) in coefficients.iter().enumerate() {
            let v = [
                m[0] * w[0][0] + m[1] * w[1][0] + m[2] * w[2][0],
                m[0] * w[0][1] + m[1] * w[1][1] + m[2] * w[2][1],
            ];
            let local = dofs.to_local(node, v);
            for (slot, value) in dofs.slots(node).into_iter().zip(local) {
                if let Slot::Free(i) = slot {
                    modes[(i, k)] = value;
                }
            }
        }
    }
    Ok(RigidModes {
        body,
        centroid,
        coefficients,
        modes,
    })
}

/// Bodies whose supports leave some rigid motion free (K_ff singular on them).
pub fn floating_bodies(mesh: &Mesh, dofs: &DofMap) -> Result<Vec<usize>, FemError> {
    let mut floating = Vec::new();
    for body in 0..mesh.bodies.len() {
        let (centroid, scale) = centroid_and_radius(mesh, body);
        if !unconstrained_motions(mesh, dofs, body, centroid, scale)?.is_empty() {
            floating.push(body);
        }
    }
    Ok(floating)
}

/// x ← x − Z Zᵀ x for orthonormal columns Z (remove the components along a kernel basis).
pub fn remove_components(z: MatRef<'_, f64>, x: &mut [f64]) {
    for j in 0..z.ncols() {
        let d: f64 = x.iter().enumerate().map(|(i, v)| z[(i, j)] * v).sum();
        for (i, v) in x.iter_mut().enumerate() {
            *v -= d * z[(i, j)];
        }
    }
}

/// Modified Gram–Schmidt (twice), dropping columns that are numerically dependent.
pub fn orthonormal_columns(a: MatRef<'_, f64>) -> Mat<f64> {
    let n = a.nrows();
    let mut cols: Vec<Vec<f64>> = Vec::new();
    for j in 0..a.ncols() {
        let mut v: Vec<f64> = (0..n).map(|i| a[(i, j)]).collect();
        let norm0 = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm0 == 0.0 {
            continue;
        }
        for _ in 0..2 {
            for c in &cols {
                let s: f64 = c.iter().zip(&v).map(|(a, b)| a * b).sum();
                v.iter_mut().zip(c).for_each(|(x, y)| *x -= s * y);
            }
        }
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 1e-8 * norm0 {
            v.iter_mut().for_each(|x| *x /= norm);
            cols.push(v);
        }
    }
    Mat::from_fn(n, cols.len(), |i, j| cols[j][i])
}

/// Rows (DOFs) to pin for a generalised inverse: as many as Z has columns, on which Z restricted
/// is nonsingular and as well conditioned as greedy pivoting on the rows of Z makes it.
pub fn pick_pinned(z: MatRef<'_, f64>) -> Vec<usize> {
    let (n, r) = (z.nrows(), z.ncols());
    let mut rows: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..r).map(|j| z[(i, j)]).collect())
        .collect();
    let mut pinned = Vec::with_capacity(r);
    for _ in 0..r {
        let best = (0..n).filter(|i| !pinned.contains(i)).max_by(|&a, &b| {
            let na: f64 = rows[a].iter().map(|x| x * x).sum();
            let nb: f64 = rows[b].iter().map(|x| x * x).sum();
            na.total_cmp(&nb).then(b.cmp(&a))
        });
        let Some(p) = best else { break };
        let norm = rows[p].iter().map(|x| x * x).sum::<f64>().sqrt();
        let dir: Vec<f64> = rows[p].iter().map(|x| x / norm).collect();
        for row in rows.iter_mut() {
            let s: f64 = row.iter().zip(&dir).map(|(a, b)| a * b).sum();
            row.iter_mut().zip(&dir).for_each(|(x, d)| *x -= s * d);
        }
        pinned.push(p);
    }
    pinned
}
