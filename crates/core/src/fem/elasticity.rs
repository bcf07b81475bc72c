//! Plane-strain P1 elasticity: the reduced operator, unit loads and the linear solve.
//!
//! Bilinear form (FGCS 2.13' with the Voigt law 2.7′, D05 Def. 2.1):
//! a(u, v) = Σ_z ∫_{Ω_z} e(v)ᵀ D_z e(u) with e = (e11, e22, γ12) and D_z the zone's symmetric
//! plane-strain stiffness ([`crate::scene::law`]), so K = Σ_z Σ_k d_{z,k} K^k_z over the six
//! independent entries d_k = D_ij (i ≤ j) with, per element, K^k_e = area·Bᵀ E_k B, E_k the
//! symmetric unit matrix of entry (i, j) (design §2.4). Isotropic zones have D = λ m mᵀ +
//! μ diag(2, 2, 1) (m = (1, 1, 0)).
//! Load functional (FGCS 2.16, D05 §3): S(v, T) = Σ_z ∫ F_z·v + ∫_{Γτ} P·v + Σ_z ∫ (T − T0) β_z·e(v),
//! β·e = β11 e11 + β22 e22 + β12 γ12, with the pressure form P = −p n. Loads are linear in F, P, p
//! and T − T0: unit load vectors (nodal weights) are precomputed and scaled by the data. The
//! thermal term uses the element mean of the P1 temperature, exact because e(v) is constant per
//! element.

use faer::Par;

use crate::mesh::Mesh;
use crate::scene::law::symmetric_eigenvalues;
use crate::scene::{BoundaryValue, Data, Element, Scene};

use super::dofs::DofMap;
use super::element_matrices::{element_matrices, rotate};
use super::geometry::{check_mesh, element_gradients, TriangleGradients, UnitLoads};
use super::hydrostatic::add_hydrostatic;
use super::mixed::{deviatoric_beta, mean_excess, mixed_system, MixedOperator};
use super::operator::{OperatorBuilder, OperatorFactor, Slot, ZonedOperator};
use super::rigid::{floating_bodies, rigid_modes, RigidModes};
use super::stress::{
    element_displacements, element_stress, element_stresses, internal_forces, plane_strain_stress,
    ElementStress, ZoneMaterial,
};
use super::{expect_len, material_of, ElasticCoefficients, FemError};

/// The elasticity problem of a mesh and scene topology: DOFs, operator, unit loads.
#[derive(Debug, Clone)]
pub struct ElasticProblem {
    mesh: Mesh,
    dofs: DofMap,
    operator: ZonedOperator<6>,
    gradients: Vec<TriangleGradients>,
    /// Load weights per zone and per boundary condition.
    unit_loads: UnitLoads,
    floating: Vec<usize>,
    /// The pressure side of the MINI element when `mesh.element` is `mixed` (design §2.7).
    mixed: Option<MixedOperator>,
}

impl ElasticProblem {
    /// Build DOFs, the operator on its pattern, unit loads and the symbolic factorisation. The
    /// topology (condition kinds, prescribed components) is read from `data`; values are not.
    pub fn new(mesh: &Mesh, data: &Data) -> Result<ElasticProblem, FemError> {
        ElasticProblem::with_element(mesh, data, Element::P1)
    }

    /// [`ElasticProblem::new`] with the finite element `element` (P1 or the MINI mixed element,
    /// whose factor and solve work on the u–p system; the DOFs and loads are the same).
    pub fn with_element(
        mesh: &Mesh,
        data: &Data,
        element: Element,
    ) -> Result<ElasticProblem, FemError> {
        check_mesh(mesh)?;
        let dofs = DofMap::new(mesh, &data.boundary)?;
        let gradients = element_gradients(mesh);
        let (operator, mixed) = match element {
            Element::P1 => (build_operator(mesh, &dofs, &gradients)?, None),
            Element::Mixed => {
                let (system, mixed) = mixed_system(mesh, &dofs, &gradients)?;
                (system, Some(mixed))
            }
        };
        let floating = floating_bodies(mesh, &dofs)?;
        Ok(ElasticProblem {
            unit_loads: UnitLoads::new(mesh, &data.boundary, &gradients),
            mesh: mesh.clone(),
            dofs,
            operator,
            gradients,
            floating,
            mixed,
        })
    }

    /// [`ElasticProblem::with_element`] with the data and `mesh.element` of a validated scene.
    pub fn from_scene(mesh: &Mesh, scene: &Scene) -> Result<ElasticProblem, FemError> {
        ElasticProblem::with_element(mesh, &Data::from_scene(scene), scene.mesh.element)
    }

    /// The finite element the problem was built with.
    pub fn element(&self) -> Element {
        if self.mixed.is_some() {
            Element::Mixed
        } else {
            Element::P1
        }
    }

    /// Ok for P1; for the mixed element the error that `what` is not available with it.
    fn p1_only(&self, what: &str) -> Result<(), FemError> {
        match self.mixed {
            None => Ok(()),
            Some(_) => Err(FemError::Input(format!(
                "{what} is not available with mesh.element \"mixed\" (design §2.7)"
            ))),
        }
    }

    /// (λ, μ) per zone for the mixed element (isotropic zones only).
    pub(crate) fn lame(&self, data: &Data) -> Result<Vec<(f64, f64)>, FemError> {
        let names: Vec<String> = self.mesh.zones.iter().map(|z| z.name.clone()).collect();
        let entries: Vec<ElasticCoefficients> = self
            .zone_materials(data)?
            .iter()
            .map(|m| m.law.coefficients())
            .collect();
        MixedOperator::lame(&entries, &names)
    }

    /// The first pressure unknown of the operator (the number of free displacement DOFs) when
    /// the element is mixed: unknown `offset + n` is the pressure of node n.
    pub fn pressure_offset(&self) -> Option<usize> {
        self.mixed.as_ref().map(MixedOperator::n_displacement)
    }

    /// The mesh the problem was built on.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// The DOF map: rotated nodal bases, free and prescribed DOFs.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// The reduced operator K_ff(D) with the six entries of D_z per zone as coefficients; for
    /// the mixed element the quasi-definite (u, p̂) system (pressure unknowns after the free
    /// displacement DOFs, [`Self::pressure_offset`]) with the coefficients of
    /// `MixedOperator::coefficients` (design §2.7).
    pub fn operator(&self) -> &ZonedOperator<6> {
        &self.operator
    }

    /// Bodies not held against all rigid motions by Dirichlet and roller conditions.
    pub fn floating_bodies(&self) -> &[usize] {
        &self.floating
    }

    /// Rigid motions of `body` left free by its supports, on the reduced DOFs.
    pub fn rigid_modes(&self, body: usize) -> Result<RigidModes, FemError> {
        rigid_modes(&self.mesh, &self.dofs, body)
    }

    /// Matrix of triangle `t` in the rotated nodal basis for zone coefficients `coefs` (the entries of D_z
    /// per zone, as from [`Self::coefficients`]), with the slots of its six local DOFs (node-major,
    /// in the order of the triangle's nodes): the element contribution to K_ff and K_fd. Used by
    /// the domain decomposition to assemble subdomain matrices.
    pub fn element_matrix(
        &self,
        t: usize,
        coefs: &[ElasticCoefficients],
    ) -> Result<([Slot; 6], [[f64; 6]; 6]), FemError> {
        self.p1_only("the element matrix (domain decomposition)")?;
        let tri = *self
            .mesh
            .triangles
            .get(t)
            .ok_or_else(|| FemError::Input(format!("triangle {t} out of range")))?;
        let c = *coefs.get(self.mesh.triangle_zone[t]).ok_or_else(|| {
            FemError::Input(format!(
                "{} zone coefficient sets given, triangle {t} is in zone {}",
                coefs.len(),
                self.mesh.triangle_zone[t]
            ))
        })?;
        let mut k = element_matrices(&self.gradients[t]);
        rotate(&mut k, tri.map(|n| self.dofs.basis(n)));
        let [a, b, d] = tri.map(|n| self.dofs.slots(n));
        let slots = [a[0], a[1], b[0], b[1], d[0], d[1]];
        let mut m = [[0.0; 6]; 6];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..6).map(|q| c[q] * k[i][j][q]).sum();
            }
        }
        Ok((slots, m))
    }

    /// Validated plane-strain law and β of every zone: D positive definite, all finite.
    pub fn zone_materials(&self, data: &Data) -> Result<Vec<ZoneMaterial>, FemError> {
        self.mesh
            .zones
            .iter()
            .map(|zone| {
                let m = material_of(data, zone)?;
                let invalid = |reason: String| FemError::InvalidMaterial {
                    material: zone.material,
                    reason,
                };
                let law = m.elastic.law().ok_or_else(|| {
                    invalid("the orthotropic compliance is singular".to_string())
                })?;
                let beta = m.beta().ok_or_else(|| {
                    invalid("an expansion α needs the full 3D stiffness; give β".to_string())
                })?;
                let least = symmetric_eigenvalues(&law.d)[0];
                let finite = law.d.iter().flatten().chain(&law.out_of_plane).chain(&beta);
                if !(least > 0.0 && finite.into_iter().all(|v| v.is_finite())) {
                    return Err(invalid(format!(
                        "plane-strain stiffness {:?} (smallest eigenvalue {least:e}), β = {beta:?}: \
                         need a finite positive definite stiffness",
                        law.d
                    )));
                }
                Ok(ZoneMaterial { law, beta })
            })
            .collect()
    }

    /// Operator coefficients per zone: the six independent entries of D_z
    /// (`crate::scene::law::ENTRIES`); for the mixed element (μ, s, s²/μ, s²/λ, 0, 0).
    pub fn coefficients(&self, data: &Data) -> Result<Vec<ElasticCoefficients>, FemError> {
        if let Some(mixed) = &self.mixed {
            return Ok(mixed.coefficients(&self.lame(data)?));
        }
        Ok(self
            .zone_materials(data)?
            .iter()
            .map(|m| m.law.coefficients())
            .collect())
    }

    /// Assemble and factorise K_ff for the data (numeric factorisation only; the symbolic one
    /// is shared). Errors naming the body when a body is floating.
    pub fn factor(&self, data: &Data, par: Par) -> Result<OperatorFactor<6>, FemError> {
        if let Some(&body) = self.floating.first() {
            return Err(FemError::FloatingBody {
                body,
                name: self.mesh.bodies[body].clone(),
            });
        }
        self.operator.factor(&self.coefficients(data)?, par)
    }

    /// Global nodal load vector f (S(v, T) tested with the nodal basis), before constraints.
    pub fn loads(
        &self,
        data: &Data,
        temperature: Option<&[f64]>,
    ) -> Result<Vec<[f64; 2]>, FemError> {
        let mut f = vec![[0.0; 2]; self.mesh.nodes.len()];
        self.add_body_forces(data, &mut f)?;
        self.add_boundary_loads(data, &mut f)?;
        if let Some(t) = temperature {
            self.add_thermal_load(data, t, &mut f)?;
        }
        Ok(f)
    }

    fn add_body_forces(&self, data: &Data, f: &mut [[f64; 2]]) -> Result<(), FemError> {
        for (zone, weights) in self.mesh.zones.iter().zip(&self.unit_loads.zones) {
            let force = material_of(data, zone)?.force();
            for &(node, w) in weights {
                f[node][0] += w * force[0];
                f[node][1] += w * force[1];
            }
        }
        Ok(())
    }

    fn add_boundary_loads(&self, data: &Data, f: &mut [[f64; 2]]) -> Result<(), FemError> {
        expect_len(
            "boundary conditions",
            data.boundary.len(),
            self.unit_loads.segments.len(),
        )?;
        for (bc, load) in data.boundary.iter().zip(&self.unit_loads.segments) {
            match bc.value {
                BoundaryValue::Traction(p) => {
                    for &(node, w) in &load.weights {
                        f[node][0] += w * p[0];
                        f[node][1] += w * p[1];
                    }
                }
                BoundaryValue::Pressure(p) => {
                    for &(node, n) in &load.normals {
                        f[node][0] -= p * n[0];
                        f[node][1] -= p * n[1];
                    }
                }
                BoundaryValue::Hydrostatic(h) => add_hydrostatic(&self.mesh, bc.segment, &h, f),
                _ => {}
            }
        }
        Ok(())
    }

    /// f += Σ_e (T̄_e − T0) area_e Bᵀ(β11, β22, β12)_z (the Duhamel–Neumann term of S); for the
    /// mixed element only the part of β that the pressure does not carry
    /// ([`deviatoric_beta`], design §2.7).
    fn add_thermal_load(
        &self,
        data: &Data,
        temperature: &[f64],
        f: &mut [[f64; 2]],
    ) -> Result<(), FemError> {
        self.check_temperature(temperature)?;
        let materials = self.zone_materials(data)?;
        for (t, tri) in self.mesh.triangles.iter().enumerate() {
            let zone_beta = &materials[self.mesh.triangle_zone[t]].beta;
            let beta = match self.mixed {
                None => [zone_beta[0], zone_beta[1], zone_beta[2]],
                Some(_) => deviatoric_beta(zone_beta),
            };
            let dt = mean_excess(*tri, temperature, data.reference_temperature);
            let fe = self.gradients[t].nodal_forces([beta[0] * dt, beta[1] * dt, beta[2] * dt]);
            for (i, &node) in tri.iter().enumerate() {
                f[node][0] += fe[2 * i];
                f[node][1] += fe[2 * i + 1];
            }
        }
        Ok(())
    }

    fn check_temperature(&self, temperature: &[f64]) -> Result<(), FemError> {
        expect_len(
            "nodal temperatures",
            temperature.len(),
            self.mesh.nodes.len(),
        )
    }

    /// Prescribed local DOF values u_d of the data.
    pub fn fixed_values(&self, data: &Data) -> Result<Vec<f64>, FemError> {
        self.dofs.fixed_values(&self.mesh, &data.boundary)
    }

    /// Reduced right-hand side b = Rᵀf|_free − K_fd(D) u_d for the data.
    pub fn rhs(&self, data: &Data, temperature: Option<&[f64]>) -> Result<Vec<f64>, FemError> {
        self.load_rhs(
            data,
            temperature,
            &self.coefficients(data)?,
            &self.fixed_values(data)?,
        )
    }

    /// The reduced right-hand side of the data's loads ([`Self::loads`]) with explicit
    /// coefficients and prescribed values ([`Self::rhs_with`]); for the mixed element with a
    /// temperature field also the thermal rows of the pressure equation (design §2.7).
    pub fn load_rhs(
        &self,
        data: &Data,
        temperature: Option<&[f64]>,
        coefficients: &[ElasticCoefficients],
        fixed: &[f64],
    ) -> Result<Vec<f64>, FemError> {
        let mut b = self.rhs_with(coefficients, &self.loads(data, temperature)?, fixed)?;
        if let (Some(mixed), Some(t)) = (&self.mixed, temperature) {
            let lame = self.lame(data)?;
            let rows =
                self.pressure_thermal_rows(mixed, data, &lame, t, data.reference_temperature)?;
            mixed.add_thermal_rows(&lame, &rows, &mut b);
        }
        Ok(b)
    }

    /// The mixed element's thermal rows of the pressure equation for the temperature's excess
    /// over `reference` ([`MixedOperator::thermal_rows`]).
    fn pressure_thermal_rows(
        &self,
        mixed: &MixedOperator,
        data: &Data,
        lame: &[(f64, f64)],
        temperature: &[f64],
        reference: f64,
    ) -> Result<Vec<f64>, FemError> {
        let expansion = self.pressure_expansion(data, lame)?;
        Ok(mixed.thermal_rows(&self.mesh, &expansion, temperature, reference))
    }

    /// γ = β33/λ per zone: the thermal rows' coefficient of the mixed element (design §2.7).
    fn pressure_expansion(&self, data: &Data, lame: &[(f64, f64)]) -> Result<Vec<f64>, FemError> {
        Ok(self
            .zone_materials(data)?
            .iter()
            .zip(lame)
            .map(|(m, &(l, _))| m.beta[3] / l)
            .collect())
    }

    /// Reduced right-hand side from explicit coefficients, nodal loads and prescribed values
    /// (for the mixed element extended by the pressure rows, zero before the lifting).
    pub fn rhs_with(
        &self,
        coefficients: &[ElasticCoefficients],
        loads: &[[f64; 2]],
        fixed: &[f64],
    ) -> Result<Vec<f64>, FemError> {
        expect_len("nodal loads", loads.len(), self.mesh.nodes.len())?;
        let (mut b, _) = self.dofs.restrict(loads);
        b.resize(self.operator.n_free(), 0.0);
        self.operator.lift(coefficients, fixed, &mut b)?;
        Ok(b)
    }

    /// Solve K u = f for the data with a factor of the same data: the global nodal displacement.
    pub fn solve(
        &self,
        factor: &OperatorFactor<6>,
        data: &Data,
        temperature: Option<&[f64]>,
    ) -> Result<Vec<[f64; 2]>, FemError> {
        if factor.coefficients != self.coefficients(data)? {
            return Err(FemError::Input(
                "the factor was computed for other material data".into(),
            ));
        }
        let fixed = self.fixed_values(data)?;
        let b = self.load_rhs(data, temperature, &factor.coefficients, &fixed)?;
        Ok(self.solve_rhs(factor, &b, &fixed))
    }

    /// Solve with explicit nodal loads and prescribed local values.
    pub fn solve_with(
        &self,
        factor: &OperatorFactor<6>,
        loads: &[[f64; 2]],
        fixed: &[f64],
    ) -> Result<Vec<[f64; 2]>, FemError> {
        let b = self.rhs_with(&factor.coefficients, loads, fixed)?;
        Ok(self.solve_rhs(factor, &b, fixed))
    }

    /// The global nodal displacement of the reduced system with right-hand side `b`.
    fn solve_rhs(&self, factor: &OperatorFactor<6>, b: &[f64], fixed: &[f64]) -> Vec<[f64; 2]> {
        let x = factor.factor.solve(b);
        self.dofs.expand(&x[..self.dofs.n_free()], fixed)
    }

    /// Element strains and stresses (τ11, τ22, τ12, τ33) of a displacement field.
    pub fn stresses(
        &self,
        data: &Data,
        u: &[[f64; 2]],
        temperature: Option<&[f64]>,
    ) -> Result<Vec<ElementStress>, FemError> {
        self.stresses_relative_to(data, u, temperature, data.reference_temperature)
    }

    /// Element stresses of `u` (with the temperature field's excess over T0) at `elements` only,
    /// in their order.
    pub fn stresses_at(
        &self,
        data: &Data,
        u: &[[f64; 2]],
        temperature: Option<&[f64]>,
        elements: &[usize],
    ) -> Result<Vec<ElementStress>, FemError> {
        expect_len("nodal displacements", u.len(), self.mesh.nodes.len())?;
        if let Some(t) = temperature {
            self.check_temperature(t)?;
        }
        if let Some(e) = elements.iter().find(|&&e| e >= self.mesh.triangles.len()) {
            return Err(FemError::Input(format!("triangle {e} out of range")));
        }
        if let Some(mixed) = &self.mixed {
            let thermal = temperature.map(|t| (t, data.reference_temperature));
            return self.mixed_stresses(mixed, data, u, thermal, elements);
        }
        let materials = self.zone_materials(data)?;
        let thermal = temperature.map(|t| (t, data.reference_temperature));
        elements
            .iter()
            .map(|&e| {
                Ok(element_stress(
                    &self.mesh,
                    &self.gradients,
                    &materials,
                    u,
                    thermal,
                    e,
                ))
            })
            .collect()
    }

    /// The stresses of a displacement increment `du` with the temperature increment `dt`
    /// (τ = A e(du) − β dT: the linear part of the law, no reference temperature).
    pub fn stress_increments(
        &self,
        data: &Data,
        du: &[[f64; 2]],
        dt: Option<&[f64]>,
    ) -> Result<Vec<ElementStress>, FemError> {
        self.stresses_relative_to(data, du, dt, 0.0)
    }

    /// The transpose of [`Self::stress_increments`] for a linear form Σ_e g_e·dτ_e of the element
    /// stresses: adds to `displacement` (global x, y per node) and `temperature` (per node) the
    /// coefficients a, t with Σ_e g_e·dτ_e(du, dT) = Σ_n a_n·du_n + Σ_n t_n dT_n. The law is
    /// linear in (e(du), dT), so its columns are its values at unit strains and a unit ΔT.
    pub fn add_stress_form_transpose(
        &self,
        data: &Data,
        form: &[(usize, [f64; 4])],
        displacement: &mut [[f64; 2]],
        temperature: &mut [f64],
    ) -> Result<(), FemError> {
        expect_len(
            "nodal coefficients",
            displacement.len(),
            self.mesh.nodes.len(),
        )?;
        self.check_temperature(temperature)?;
        if let Some(mixed) = &self.mixed {
            return self.add_mixed_stress_form_transpose(
                mixed,
                data,
                form,
                displacement,
                temperature,
            );
        }
        let materials = self.zone_materials(data)?;
        let dot = |g: &[f64; 4], s: [f64; 4]| (0..4).map(|k| g[k] * s[k]).sum::<f64>();
        for &(e, g) in form {
            let tri = *self
                .mesh
                .triangles
                .get(e)
                .ok_or_else(|| FemError::Input(format!("triangle {e} out of range")))?;
            let m = &materials[self.mesh.triangle_zone[e]];
            // g·τ(strain) = h·(e11, e22, e12); the element strain is (s0, s1, s2/2) of B v.
            let h: [f64; 3] = std::array::from_fn(|k| {
                let unit = std::array::from_fn(|j| f64::from(u8::from(j == k)));
                dot(&g, plane_strain_stress(m, unit, 0.0))
            });
            let grads = &self.gradients[e];
            let per_area = grads.nodal_forces([h[0], h[1], 0.5 * h[2]]);
            let thermal = dot(&g, plane_strain_stress(m, [0.0; 3], 1.0)) / 3.0;
            for (i, &node) in tri.iter().enumerate() {
                displacement[node][0] += per_area[2 * i] / grads.area;
                displacement[node][1] += per_area[2 * i + 1] / grads.area;
                temperature[node] += thermal;
            }
        }
        Ok(())
    }

    /// Element stresses of `u` with the temperature field's excess over `reference`.
    fn stresses_relative_to(
        &self,
        data: &Data,
        u: &[[f64; 2]],
        temperature: Option<&[f64]>,
        reference: f64,
    ) -> Result<Vec<ElementStress>, FemError> {
        expect_len("nodal displacements", u.len(), self.mesh.nodes.len())?;
        if let Some(t) = temperature {
            self.check_temperature(t)?;
        }
        if let Some(mixed) = &self.mixed {
            let all: Vec<usize> = (0..self.mesh.triangles.len()).collect();
            let thermal = temperature.map(|t| (t, reference));
            return self.mixed_stresses(mixed, data, u, thermal, &all);
        }
        let materials = self.zone_materials(data)?;
        Ok(element_stresses(
            &self.mesh,
            &self.gradients,
            &materials,
            u,
            temperature.map(|t| (t, reference)),
        ))
    }

    /// Element stresses of the mixed element at `elements` (in range), with the temperature
    /// field's excess over a reference in `thermal`: τ = 2μ e(u) + p̄ I − (β11 − β33, β22 − β33,
    /// β12) ΔT̄ and τ33 = p̄, with the nodal pressure p = λ div u − β33 ΔT recovered from u
    /// (design §2.7).
    fn mixed_stresses(
        &self,
        mixed: &MixedOperator,
        data: &Data,
        u: &[[f64; 2]],
        thermal: Option<(&[f64], f64)>,
        elements: &[usize],
    ) -> Result<Vec<ElementStress>, FemError> {
        let lame = self.lame(data)?;
        let p = match thermal {
            None => mixed.pressure(&self.mesh, &self.gradients, &lame, u)?,
            Some((t, reference)) => {
                let rows = self.pressure_thermal_rows(mixed, data, &lame, t, reference)?;
                mixed.thermo_pressure(&self.mesh, &self.gradients, &lame, u, &rows)?
            }
        };
        let materials = self.zone_materials(data)?;
        Ok(elements
            .iter()
            .map(|&e| {
                let tri = self.mesh.triangles[e];
                let [e11, e22, gamma] = self.gradients[e].strain(&element_displacements(u, tri));
                let zone = self.mesh.triangle_zone[e];
                let mu = lame[zone].1;
                let mean = tri.iter().map(|&n| p[n]).sum::<f64>() / 3.0;
                let [d11, d22, d12] = match thermal {
                    None => [0.0; 3],
                    Some((t, reference)) => {
                        let dt = mean_excess(tri, t, reference);
                        deviatoric_beta(&materials[zone].beta).map(|b| b * dt)
                    }
                };
                ElementStress {
                    strain: [e11, e22, gamma / 2.0],
                    stress: [
                        2.0 * mu * e11 + mean - d11,
                        2.0 * mu * e22 + mean - d22,
                        mu * gamma - d12,
                        mean,
                    ],
                }
            })
            .collect())
    }

    /// Nodal residual K u − f in global components (thermal part included through the stress):
    /// the reaction forces at constrained nodes, ≈ 0 elsewhere.
    pub fn reactions(
        &self,
        data: &Data,
        u: &[[f64; 2]],
        temperature: Option<&[f64]>,
    ) -> Result<Vec<[f64; 2]>, FemError> {
        let stresses = self.stresses(data, u, temperature)?;
        let mut r = internal_forces(&self.mesh, &self.gradients, &stresses);
        let mut mechanical = vec![[0.0; 2]; self.mesh.nodes.len()];
        self.add_body_forces(data, &mut mechanical)?;
        self.add_boundary_loads(data, &mut mechanical)?;
        for (ri, fi) in r.iter_mut().zip(&mechanical) {
            ri[0] -= fi[0];
            ri[1] -= fi[1];
        }
        Ok(r)
    }
}

/// The thermal side of the mixed element's derivative along a parameter (design §2.7,
/// "Derivatives"): the state's temperature and the derivatives of the zones' β and of the
/// reference temperature.
pub(crate) struct MixedThermalRate<'a> {
    /// The state's nodal temperature T.
    pub temperature: &'a [f64],
    /// dβ = (dβ11, dβ22, dβ12, dβ33) per zone.
    pub d_beta: Vec<[f64; 4]>,
    /// dT0.
    pub d_reference: f64,
}

/// The derivatives of the mixed element's operator and stresses along the data (design §2.7,
/// "Derivatives"), in the Lamé derivatives (dλ, dμ) per zone.
impl ElasticProblem {
    /// The derivative of the operator's zone coefficients along the Lamé derivatives `d_lame`
    /// at `data` ([`MixedOperator::coefficient_derivatives`]); an error for P1, whose
    /// coefficients are the entries of D themselves.
    pub(crate) fn mixed_coefficient_derivatives(
        &self,
        data: &Data,
        d_lame: &[(f64, f64)],
    ) -> Result<Vec<ElasticCoefficients>, FemError> {
        let mixed = self.mixed_operator()?;
        Ok(mixed.coefficient_derivatives(&self.lame(data)?, d_lame))
    }

    /// The derivative of the thermal rows r = R(γ, T − T0) of the pressure equation
    /// ([`MixedOperator::thermal_rows`], γ = β33/λ) along `d_lame` and the thermal data's
    /// derivatives `rate`, with the temperature derivative `d_temperature` (None: at fixed T):
    /// dr = R(dγ, T − T0) + R(γ, dT − dT0), dγ = dβ33/λ − β33 dλ/λ².
    fn thermal_rows_rate(
        &self,
        mixed: &MixedOperator,
        data: &Data,
        d_lame: &[(f64, f64)],
        rate: &MixedThermalRate,
        d_temperature: Option<&[f64]>,
    ) -> Result<Vec<f64>, FemError> {
        let lame = self.lame(data)?;
        let materials = self.zone_materials(data)?;
        let expansion = self.pressure_expansion(data, &lame)?;
        let d_expansion: Vec<f64> = materials
            .iter()
            .zip(&lame)
            .zip(d_lame)
            .zip(&rate.d_beta)
            .map(|(((m, &(l, _)), &(dl, _)), db)| db[3] / l - m.beta[3] * dl / (l * l))
            .collect();
        let mut dr = mixed.thermal_rows(
            &self.mesh,
            &d_expansion,
            rate.temperature,
            data.reference_temperature,
        );
        let zero;
        let dt = match d_temperature {
            Some(dt) => dt,
            None => {
                zero = vec![0.0; self.mesh.nodes.len()];
                &zero
            }
        };
        let from_temperature = mixed.thermal_rows(&self.mesh, &expansion, dt, rate.d_reference);
        for (a, b) in dr.iter_mut().zip(from_temperature) {
            *a += b;
        }
        Ok(dr)
    }

    /// Adds to the pressure rows of the reduced residual `b` the derivative s dr of the mixed
    /// element's thermal rows ([`Self::thermal_rows_rate`] with the temperature derivative
    /// `d_temperature`), the pressure scale s held at its value for `data` (as in
    /// [`MixedOperator::coefficient_derivatives`]).
    pub(crate) fn add_mixed_thermal_rows_rate(
        &self,
        data: &Data,
        d_lame: &[(f64, f64)],
        rate: &MixedThermalRate,
        d_temperature: Option<&[f64]>,
        b: &mut [f64],
    ) -> Result<(), FemError> {
        let mixed = self.mixed_operator()?;
        let dr = self.thermal_rows_rate(mixed, data, d_lame, rate, d_temperature)?;
        mixed.add_thermal_rows(&self.lame(data)?, &dr, b);
        Ok(())
    }

    /// The derivative of the mixed element's stresses τ = 2μ e(u) + p̄ (1, 1, 0, 1) − (β11 − β33,
    /// β22 − β33, β12, 0) ΔT̄ at fixed u and T along `d_lame` and, for a thermo-elastic state,
    /// the thermal data's derivatives `thermal`, at `elements` (in range): 2 dμ e(u) + dp̄ −
    /// d((β11 − β33, β22 − β33, β12) ΔT̄) with dp = −P⁻¹ (dP p + dr) the pressure recovery's
    /// derivative ([`MixedOperator::pressure_rate_at_fixed_displacement`]).
    pub(crate) fn mixed_stress_rates(
        &self,
        data: &Data,
        d_lame: &[(f64, f64)],
        u: &[[f64; 2]],
        thermal: Option<&MixedThermalRate>,
        elements: &[usize],
    ) -> Result<Vec<[f64; 4]>, FemError> {
        let mixed = self.mixed_operator()?;
        let lame = self.lame(data)?;
        let (p, d_rows) = match thermal {
            None => (mixed.pressure(&self.mesh, &self.gradients, &lame, u)?, None),
            Some(rate) => {
                let reference = data.reference_temperature;
                let rows =
                    self.pressure_thermal_rows(mixed, data, &lame, rate.temperature, reference)?;
                let p = mixed.thermo_pressure(&self.mesh, &self.gradients, &lame, u, &rows)?;
                let dr = self.thermal_rows_rate(mixed, data, d_lame, rate, None)?;
                (p, Some(dr))
            }
        };
        let dp = mixed.pressure_rate_at_fixed_displacement(&lame, d_lame, &p, d_rows.as_deref())?;
        let materials = self.zone_materials(data)?;
        elements
            .iter()
            .map(|&e| {
                let tri = self.mesh.triangles[e];
                let [e11, e22, gamma] = self.gradients[e].strain(&element_displacements(u, tri));
                let zone = self.mesh.triangle_zone[e];
                let dmu = d_lame[zone].1;
                let mean = tri.iter().map(|&n| dp[n]).sum::<f64>() / 3.0;
                let [d11, d22, d12] = match thermal {
                    None => [0.0; 3],
                    Some(rate) => {
                        let dt = mean_excess(tri, rate.temperature, data.reference_temperature);
                        let beta = deviatoric_beta(&materials[zone].beta);
                        let d_beta = deviatoric_beta(&rate.d_beta[zone]);
                        std::array::from_fn(|k| d_beta[k] * dt - beta[k] * rate.d_reference)
                    }
                };
                Ok([
                    2.0 * dmu * e11 + mean - d11,
                    2.0 * dmu * e22 + mean - d22,
                    dmu * gamma - d12,
                    mean,
                ])
            })
            .collect()
    }

    /// The mixed element's side of [`Self::add_stress_form_transpose`]: with dτ = 2μ e(du) +
    /// p̄(du, dT) (1, 1, 0, 1) − (β11 − β33, β22 − β33, β12, 0) dT̄, the strain part as for P1
    /// with D = μ diag(2, 2, 1), the pressure part Σ_e (g0 + g1 + g3) p̄_e = qᵀ p = yᵀ (G du −
    /// R(γ, dT)), y = P⁻¹ q, and the deviatoric thermal part on the temperature.
    fn add_mixed_stress_form_transpose(
        &self,
        mixed: &MixedOperator,
        data: &Data,
        form: &[(usize, [f64; 4])],
        displacement: &mut [[f64; 2]],
        temperature: &mut [f64],
    ) -> Result<(), FemError> {
        let lame = self.lame(data)?;
        let materials = self.zone_materials(data)?;
        let mut q = vec![0.0; self.mesh.nodes.len()];
        for &(e, g) in form {
            let tri = *self
                .mesh
                .triangles
                .get(e)
                .ok_or_else(|| FemError::Input(format!("triangle {e} out of range")))?;
            let zone = self.mesh.triangle_zone[e];
            let mu = lame[zone].1;
            let grads = &self.gradients[e];
            let per_area = grads.nodal_forces([2.0 * mu * g[0], 2.0 * mu * g[1], mu * g[2]]);
            let pressure = (g[0] + g[1] + g[3]) / 3.0;
            let beta = deviatoric_beta(&materials[zone].beta);
            let thermal = -(g[0] * beta[0] + g[1] * beta[1] + g[2] * beta[2]) / 3.0;
            for (i, &node) in tri.iter().enumerate() {
                displacement[node][0] += per_area[2 * i] / grads.area;
                displacement[node][1] += per_area[2 * i + 1] / grads.area;
                q[node] += pressure;
                temperature[node] += thermal;
            }
        }
        let y = mixed.pressure_weights(&lame, &q)?;
        let from_pressure = mixed.divergence_transpose(&self.mesh, &self.gradients, &y);
        for (a, b) in displacement.iter_mut().zip(from_pressure) {
            a[0] += b[0];
            a[1] += b[1];
        }
        let expansion = self.pressure_expansion(data, &lame)?;
        let from_rows = mixed.thermal_rows_transpose(&self.mesh, &expansion, &y);
        for (t, c) in temperature.iter_mut().zip(from_rows) {
            *t -= c;
        }
        Ok(())
    }

    /// The mixed element's pressure side, or the error that the element is P1.
    fn mixed_operator(&self) -> Result<&MixedOperator, FemError> {
        self.mixed.as_ref().ok_or_else(|| {
            FemError::Input("the mixed element's derivatives need mesh.element \"mixed\"".into())
        })
    }
}

fn build_operator(
    mesh: &Mesh,
    dofs: &DofMap,
    gradients: &[TriangleGradients],
) -> Result<ZonedOperator<6>, FemError> {
    let identity = [[1.0, 0.0], [0.0, 1.0]];
    let mut builder = OperatorBuilder::<6>::new(dofs.n_free(), dofs.n_fixed(), mesh.zones.len());
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let mut k = element_matrices(&gradients[t]);
        let bases = tri.map(|n| dofs.basis(n));
        if bases.iter().any(|b| *b != identity) {
            rotate(&mut k, bases);
        }
        let slots: Vec<Slot> = tri.iter().flat_map(|&n| dofs.slots(n)).collect();
        builder.add_element(mesh.triangle_zone[t], &slots, |i, j| k[i][j]);
    }
    builder.finish()
}
