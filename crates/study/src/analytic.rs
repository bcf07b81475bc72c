//! Analytic reference solutions of the verification cases (design §6) and exact error norms
//! against them: the manufactured elasticity solution, the thick-walled cylinder (Lamé) and
//! 2D Hertz contact (plane strain, frictionless).
//!
//! Errors of a P1 field u_h against an exact field u are integrated with the degree-5 Dunavant
//! rule on every triangle: ‖u − u_h‖_L² and the energy norm ‖u − u_h‖_a,
//! ‖v‖²_a = ∫ λ (div v)² + 2μ e(v):e(v).

use std::f64::consts::PI;

use wsm_core::{
    element_displacements, BoundaryCondition, Contact, InitialGap, Material, Mesh, Scene,
    SceneError, TriangleGradients, WsmError,
};

/// Degree-5 Dunavant rule on a triangle: (barycentric point, weight), weights summing to 1.
pub fn quadrature() -> [([f64; 3], f64); 7] {
    let (a1, b1, w1) = (
        0.059_715_871_789_770,
        0.470_142_064_105_115,
        0.132_394_152_788_506,
    );
    let (a2, b2, w2) = (
        0.797_426_985_353_087,
        0.101_286_507_323_456,
        0.125_939_180_544_827,
    );
    [
        ([1.0 / 3.0; 3], 0.225),
        ([a1, b1, b1], w1),
        ([b1, a1, b1], w1),
        ([b1, b1, a1], w1),
        ([a2, b2, b2], w2),
        ([b2, a2, b2], w2),
        ([b2, b2, a2], w2),
    ]
}

/// Quadrature points of triangle `t`: (x, barycentric coordinates, weight · area).
pub fn points(mesh: &Mesh, t: usize) -> Vec<([f64; 2], [f64; 3], f64)> {
    let tri = mesh.triangles[t];
    let area = mesh.triangle_area(t);
    quadrature()
        .into_iter()
        .map(|(l, w)| {
            let x = (0..3).fold([0.0; 2], |acc, i| {
                [
                    acc[0] + l[i] * mesh.nodes[tri[i]][0],
                    acc[1] + l[i] * mesh.nodes[tri[i]][1],
                ]
            });
            (x, l, w * area)
        })
        .collect()
}

/// An exact displacement field.
pub trait ExactField {
    /// The exact displacement (u1, u2) at the point x.
    fn u(&self, x: [f64; 2]) -> [f64; 2];
    /// [[∂x u1, ∂y u1], [∂x u2, ∂y u2]].
    fn grad(&self, x: [f64; 2]) -> [[f64; 2]; 2];
}

/// Errors of a P1 field against an exact one, with the norms of the exact field.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FieldErrors {
    /// ‖u − u_h‖ in L².
    pub l2: f64,
    /// ‖u − u_h‖ in the energy norm ‖v‖²_a = ∫ λ (div v)² + 2μ e(v):e(v).
    pub energy: f64,
    /// ‖u‖ in L² of the exact field.
    pub l2_norm: f64,
    /// ‖u‖_a, the energy norm of the exact field.
    pub energy_norm: f64,
}

impl FieldErrors {
    /// The relative L² error ‖u − u_h‖ / ‖u‖.
    pub fn relative_l2(&self) -> f64 {
        self.l2 / self.l2_norm
    }
    /// The relative energy-norm error ‖u − u_h‖_a / ‖u‖_a.
    pub fn relative_energy(&self) -> f64 {
        self.energy / self.energy_norm
    }
}

/// ‖u − u_h‖ in L² and in energy, (λ, μ) given per triangle.
pub fn field_errors(
    mesh: &Mesh,
    uh: &[[f64; 2]],
    exact: &dyn ExactField,
    lame: &dyn Fn(usize) -> (f64, f64),
) -> FieldErrors {
    let mut sums = [0.0; 4];
    for t in 0..mesh.triangles.len() {
        let tri = mesh.triangles[t];
        let (lambda, mu) = lame(t);
        let [e11, e22, gamma] =
            TriangleGradients::of(mesh, t).strain(&element_displacements(uh, tri));
        let eh = [e11, e22, 0.5 * gamma];
        let energy = |e: [f64; 3]| {
            let tr = e[0] + e[1];
            lambda * tr * tr + 2.0 * mu * (e[0] * e[0] + e[1] * e[1] + 2.0 * e[2] * e[2])
        };
        for (x, l, w) in points(mesh, t) {
            let ue = exact.u(x);
            let uhx = (0..3).fold([0.0; 2], |a, i| {
                [a[0] + l[i] * uh[tri[i]][0], a[1] + l[i] * uh[tri[i]][1]]
            });
            let g = exact.grad(x);
            let ee = [g[0][0], g[1][1], 0.5 * (g[0][1] + g[1][0])];
            sums[0] += w * ((ue[0] - uhx[0]).powi(2) + (ue[1] - uhx[1]).powi(2));
            sums[1] += w * energy([ee[0] - eh[0], ee[1] - eh[1], ee[2] - eh[2]]);
            sums[2] += w * (ue[0] * ue[0] + ue[1] * ue[1]);
            sums[3] += w * energy(ee);
        }
    }
    let [l2, energy, l2_norm, energy_norm] = sums.map(f64::sqrt);
    FieldErrors {
        l2,
        energy,
        l2_norm,
        energy_norm,
    }
}

/// u = (sin πx cos πy, cos 2πx sin πy) on the unit square with the body force
/// f = −(λ + μ) ∇div u − μ Δu and u prescribed on the whole boundary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Manufactured {
    /// Lamé's first parameter λ of the (homogeneous, isotropic) material.
    pub lambda: f64,
    /// The shear modulus μ of the material.
    pub mu: f64,
}

impl ExactField for Manufactured {
    fn u(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        [
            (PI * x).sin() * (PI * y).cos(),
            (2.0 * PI * x).cos() * (PI * y).sin(),
        ]
    }

    fn grad(&self, [x, y]: [f64; 2]) -> [[f64; 2]; 2] {
        [
            [
                PI * (PI * x).cos() * (PI * y).cos(),
                -PI * (PI * x).sin() * (PI * y).sin(),
            ],
            [
                -2.0 * PI * (2.0 * PI * x).sin() * (PI * y).sin(),
                PI * (2.0 * PI * x).cos() * (PI * y).cos(),
            ],
        ]
    }
}

impl Manufactured {
    /// The body force f = −(λ + μ) ∇div u − μ Δu at (x, y) that makes u the exact solution.
    pub fn force(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let (l, m) = (self.lambda, self.mu);
        let s = (PI * x).cos() + (2.0 * PI * x).cos();
        let ddx_div =
            PI * (PI * y).cos() * (-PI * (PI * x).sin() - 2.0 * PI * (2.0 * PI * x).sin());
        let ddy_div = -PI * PI * (PI * y).sin() * s;
        let u = self.u([x, y]);
        [
            -(l + m) * ddx_div + 2.0 * PI * PI * m * u[0],
            -(l + m) * ddy_div + 5.0 * PI * PI * m * u[1],
        ]
    }

    /// The consistent nodal load vector ∫ f φ_i (quadrature of degree 5).
    pub fn loads(&self, mesh: &Mesh) -> Vec<[f64; 2]> {
        let mut loads = vec![[0.0; 2]; mesh.nodes.len()];
        for t in 0..mesh.triangles.len() {
            for (x, l, w) in points(mesh, t) {
                let f = self.force(x);
                for (i, &node) in mesh.triangles[t].iter().enumerate() {
                    loads[node][0] += w * f[0] * l[i];
                    loads[node][1] += w * f[1] * l[i];
                }
            }
        }
        loads
    }
}

/// A thick-walled cylinder a ≤ r ≤ b under internal pressure p, plane strain (Lamé):
/// u_r = (1 + ν)/E · c ((1 − 2ν) r + b²/r), σ_θθ = c (1 + b²/r²), c = a² p / (b² − a²).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LameCylinder {
    /// The inner radius a.
    pub a: f64,
    /// The outer radius b.
    pub b: f64,
    /// The internal pressure p on the inner rim.
    pub p: f64,
    /// Young's modulus E.
    pub e: f64,
    /// Poisson's ratio ν.
    pub nu: f64,
}

impl LameCylinder {
    fn c(&self) -> f64 {
        self.a * self.a * self.p / (self.b * self.b - self.a * self.a)
    }

    /// The radial displacement u_r at radius r.
    pub fn radial_displacement(&self, r: f64) -> f64 {
        (1.0 + self.nu) / self.e * self.c() * ((1.0 - 2.0 * self.nu) * r + self.b * self.b / r)
    }

    /// The hoop stress σ_θθ at radius r.
    pub fn hoop_stress(&self, r: f64) -> f64 {
        self.c() * (1.0 + self.b * self.b / (r * r))
    }

    /// u = (A + B/r²) x with u_r = A r + B / r.
    fn coefficients(&self) -> (f64, f64) {
        let k = (1.0 + self.nu) / self.e * self.c();
        (k * (1.0 - 2.0 * self.nu), k * self.b * self.b)
    }

    /// The cylinder of a scene like the `thick-cylinder` example: one zone whose polygon's
    /// vertices lie on the radii a and b about the origin, one material, and one pressure
    /// condition (on the inner rim).
    pub fn from_scene(scene: &Scene) -> Result<LameCylinder, WsmError> {
        let zone = match scene.bodies.as_slice() {
            [body] if body.zones.len() == 1 => &body.zones[0],
            _ => {
                return Err(not_like(
                    "bodies",
                    "one body with one zone",
                    "thick-cylinder",
                ))
            }
        };
        let radii: Vec<f64> = zone.polygon.iter().map(|p| p[0].hypot(p[1])).collect();
        let a = radii.iter().copied().fold(f64::INFINITY, f64::min);
        let b = radii.iter().copied().fold(0.0, f64::max);
        let p = single_pressure(&scene.boundary, "thick-cylinder")?;
        let (e, nu) = young(&scene.materials[&zone.material], &zone.material)?;
        Ok(LameCylinder { a, b, p, e, nu })
    }
}

impl ExactField for LameCylinder {
    fn u(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let (ca, cb) = self.coefficients();
        let s = ca + cb / (x * x + y * y);
        [s * x, s * y]
    }

    fn grad(&self, [x, y]: [f64; 2]) -> [[f64; 2]; 2] {
        let (ca, cb) = self.coefficients();
        let r2 = x * x + y * y;
        let s = ca + cb / r2;
        let q = 2.0 * cb / (r2 * r2);
        [[s - q * x * x, -q * x * y], [-q * x * y, s - q * y * y]]
    }
}

/// 2D Hertz contact of a cylinder (radius R) on a flat, plane strain, load P per unit length:
/// a = 2 √(P R / (π E*)), p0 = 2P / (π a), 1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Hertz {
    /// The cylinder's radius R (of the parabolic initial gap).
    pub radius: f64,
    /// The combined modulus E* of the two bodies, 1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2.
    pub e_star: f64,
    /// The load P per unit length pressing the bodies together.
    pub load: f64,
    /// The touching point of the parabolic gap.
    pub touch_at: [f64; 2],
}

impl Hertz {
    /// The contact half-width a = 2 √(P R / (π E*)).
    pub fn half_width(&self) -> f64 {
        2.0 * (self.load * self.radius / (PI * self.e_star)).sqrt()
    }

    /// The peak contact pressure p0 = 2P / (π a).
    pub fn peak_pressure(&self) -> f64 {
        2.0 * self.load / (PI * self.half_width())
    }

    /// The Hertz data of a scene like the `hertz` example: the first contact has a parabolic
    /// initial gap (R, touching point), the two bodies one material each, and the load is the
    /// resultant of the pressure condition (pressure × segment length).
    pub fn from_scene(scene: &Scene) -> Result<Hertz, WsmError> {
        let contact: &Contact = scene
            .contacts
            .first()
            .ok_or_else(|| not_like("contacts", "a contact zone", "hertz"))?;
        let Some(InitialGap::Parabola { radius, touch_at }) = &contact.initial_gap else {
            return Err(not_like(
                "contacts[0].initial_gap",
                "a parabolic initial gap",
                "hertz",
            ));
        };
        let mut compliance = 0.0;
        for side in &contact.between {
            let body = &scene.segments[side].body;
            let zone = scene
                .bodies
                .iter()
                .find(|b| &b.name == body)
                .and_then(|b| b.zones.first())
                .ok_or_else(|| not_like("bodies", "a zone in each contact body", "hertz"))?;
            let (e, nu) = young(&scene.materials[&zone.material], &zone.material)?;
            compliance += (1.0 - nu * nu) / e;
        }
        let p = single_pressure(&scene.boundary, "hertz")?;
        let entry = scene
            .boundary
            .iter()
            .find(|b| b.pressure.is_some())
            .map(|b| &scene.segments[&b.segment])
            .ok_or_else(|| not_like("boundary", "one pressure condition", "hertz"))?;
        let length: f64 = entry
            .polyline()
            .windows(2)
            .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
            .sum();
        Ok(Hertz {
            radius: *radius,
            e_star: 1.0 / compliance,
            load: p * length,
            touch_at: *touch_at,
        })
    }

    /// The discrete half-width and peak pressure of contact nodes (position, pressure, nodal
    /// length). The half-width comes from the second moment of the pressure about the touching
    /// point (∫ d² p = p0 π a³ / 8 and ∫ p = π a p0 / 2 give a² = 4 ∫ d² p / ∫ p). The peak
    /// pressure is the amplitude of the Hertz profile p0 √(1 − d²/a²) fitted to the nodal forces
    /// of the central half of the contact (|d| < a/2 with the analytic a):
    /// p0_h = Σ p_m w_m / Σ √(1 − d_m²/a²) w_m. The largest nodal pressure itself is no
    /// estimate: on unstructured meshes the nodal pressures of node-to-node contact alternate by
    /// ±2 % from node to node.
    pub fn measure(&self, nodes: impl Iterator<Item = ([f64; 2], f64, f64)>) -> (f64, f64) {
        let a = self.half_width();
        let (mut total, mut moment, mut central, mut profile) = (0.0, 0.0, 0.0, 0.0);
        for (x, pressure, length) in nodes {
            let d2 = (x[0] - self.touch_at[0]).powi(2) + (x[1] - self.touch_at[1]).powi(2);
            total += pressure * length;
            moment += d2 * pressure * length;
            if d2 < 0.25 * a * a {
                central += pressure * length;
                profile += (1.0 - d2 / (a * a)).sqrt() * length;
            }
        }
        ((4.0 * moment / total).sqrt(), central / profile)
    }
}

fn not_like(path: &str, what: &str, example: &str) -> WsmError {
    SceneError::new(
        path,
        format!("the analytic reference needs {what} (a scene like the '{example}' example)"),
    )
    .into()
}

fn single_pressure(boundary: &[BoundaryCondition], example: &str) -> Result<f64, WsmError> {
    let mut pressures = boundary.iter().filter_map(|b| b.pressure);
    match (pressures.next(), pressures.next()) {
        (Some(p), None) => Ok(p),
        _ => Err(not_like(
            "boundary",
            "exactly one pressure condition",
            example,
        )),
    }
}

/// (E, ν) of a material given either way.
fn young(m: &Material, name: &str) -> Result<(f64, f64), WsmError> {
    match (m.young, m.nu, m.lambda, m.mu) {
        (Some(e), Some(nu), _, _) => Ok((e, nu)),
        (_, _, Some(l), Some(mu)) => {
            Ok((mu * (3.0 * l + 2.0 * mu) / (l + mu), l / (2.0 * (l + mu))))
        }
        _ => Err(SceneError::new(
            format!("materials.{name}"),
            "needs E and nu or lambda and mu",
        )
        .into()),
    }
}
