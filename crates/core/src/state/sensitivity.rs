//! Exact sensitivities of the criteria (design §4.4): dΦ_i/dθ_j of a solved state, on the
//! converged state with the factors of the solve — by the adjoint where the contact state is
//! differentiable ([`crate::contact::direct::AdjointForms`]: two solves per criterion region,
//! whatever the number of data), by the forward tangent elsewhere (per direction, one-sided where
//! the active set is weakly active) and on request ([`DerivativeRoute::Forward`], the check).
//!
//! Per parameter θ_j, the data derivative comes from a [`Stencil`] of data sets (exact up to
//! rounding for the affine data maps, ≈ 1e-12 relative for ν). Then, reusing the state's factors:
//! 1. heat (FGCS 2.1–2.4): K_h dT = −Σ_k w_k (K_h(D_k) T − q(D_k)) on the free unknowns, dT_d
//!    the derivative of the prescribed temperatures;
//! 2. elasticity with contact (FGCS 2.7–2.11, the discrete contact problem): the residual
//!    derivative b = Σ_k w_k (f(D_k, T + t_k dT) − K(D_k) u) drives the tangent contact problem
//!    ([`crate::contact::direct::DataDerivative`]);
//! 3. stresses: dτ = A e(du) − β dT + Σ_k w_k τ(D_k; u, T);
//! 4. criteria (FGCS 4.29–4.34): the derivative of a region value is a linear form of the
//!    tangent fields (the region value itself for Φ1–Φ4 and Φ6, 2 mean B(τ, dτ) for Φ5); the
//!    adjoint turns it into a form of the data derivative.
//!    Where regions tie in the maximum over r, the right derivative is the largest right
//!    derivative of the tied regions and the left one the smallest left derivative.
//!
//! The DD solver's state is differentiated with the direct solver's factor and C (the same
//! formulas on the DD multipliers), which costs one direct factorisation per stiffness.

use super::criterion_values::{per_region_with, region_forms, Fields, LinearForm, PerCriterion};
use super::{thermal_key, StateProblem};
use crate::contact::direct::{
    AdjointForms, ContactPoint, ContactSolution, DataDerivative, StiffnessFactor,
    TangentDisplacement,
};
use crate::error::WsmError;
use crate::fem::{ElasticCoefficients, ElementStress, HeatCoefficients, MixedThermalRate};
use crate::scene::params::Stencil;
use crate::scene::{Criterion, Data, Element};
pub use wsm_search::OneSided;

/// Relative distance to the maximum within which a region ties with the maximising one.
pub(crate) const TIE_TOL: f64 = 1e-12;

/// Per parameter, the derivatives of Φ1..Φ6 (None where the criterion was not computed; always
/// None for the defined criteria, which have no maximum).
pub type Sensitivities = Vec<PerCriterion<Option<OneSided>>>;

/// Per parameter, per Φ, per region of its family, the one-sided derivative of the region's value
/// — for the regions that tie for the maximum and those read by criteria bound to one region
/// (`None` for the others).
pub type RegionSensitivities = Vec<PerCriterion<Vec<Option<OneSided>>>>;

/// How the derivatives of the criteria are taken (design §4.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DerivativeRoute {
    /// The adjoint where the state is differentiable, the forward tangent elsewhere.
    Adjoint,
    /// The forward tangent along every direction.
    Forward,
}

/// The derivatives of the region values of Φ1..Φ6 along +θ_j (right) and −θ_j, negated (left).
type OneSidedRegions = (PerCriterion<Vec<f64>>, PerCriterion<Vec<f64>>);

/// The state a sensitivity is taken at.
pub(super) struct SolvedState<'a> {
    pub data: &'a Data,
    pub temperature: Option<&'a [f64]>,
    pub elastic: Option<ElasticState<'a>>,
}

/// The elastic part of a solved state.
pub(super) struct ElasticState<'a> {
    pub coefficients: &'a [ElasticCoefficients],
    pub factor: &'a StiffnessFactor,
    pub contact: &'a ContactSolution,
    pub displacement: &'a [[f64; 2]],
    pub stresses: &'a [ElementStress],
}

/// The data derivative of the elastic contact problem along one parameter.
struct ElasticDerivative {
    /// b on the free DOFs.
    residual: Vec<f64>,
    /// du_d.
    fixed: Vec<f64>,
    /// Derivatives of the multiplier bounds (0 for infinite ones).
    lower: Vec<f64>,
    upper: Vec<f64>,
    /// Σ_k w_k τ(D_k; u, T) per element, when the law changes along the parameter (at the
    /// elements the criteria read; 0 elsewhere).
    stress_part: Option<Vec<[f64; 4]>>,
}

impl ElasticDerivative {
    /// The part the contact problem sees.
    fn view(&self) -> DataDerivative<'_> {
        DataDerivative {
            residual: &self.residual,
            fixed: &self.fixed,
            lower: &self.lower,
            upper: &self.upper,
        }
    }
}

/// The adjoint forms of the needed region values (design §4.4): per form, the contact adjoint of
/// its displacement part, its coefficients on du_d and on dT, and its stress part (which also
/// reads the change of the law along the parameter).
struct AdjointCriteria {
    contact: AdjointForms,
    /// Regions per criterion.
    shape: PerCriterion<usize>,
    /// (criterion, region) of each form.
    regions: Vec<(usize, usize)>,
    /// Per form, its index in `contact` when it reads the displacement or the stresses.
    mechanical: Vec<Option<usize>>,
    fixed: Vec<Vec<f64>>,
    temperature: Vec<Vec<f64>>,
    stress_forms: Vec<Vec<(usize, [f64; 4])>>,
}

impl AdjointCriteria {
    /// The derivatives of the region values along the data derivative `part` with the
    /// temperature derivative `dt` (0 for the regions not needed).
    fn along(&self, part: &ElasticDerivative, dt: Option<&[f64]>) -> PerCriterion<Vec<f64>> {
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let mut out: PerCriterion<Vec<f64>> = self.shape.map(|n| vec![0.0; n]);
        for (f, &(i, r)) in self.regions.iter().enumerate() {
            let mut value = dot(&self.fixed[f], &part.fixed);
            if let Some(c) = self.mechanical[f] {
                value += self.contact.apply(c, &part.view());
            }
            if let Some(dt) = dt {
                value += dot(&self.temperature[f], dt);
            }
            if let Some(stress_part) = &part.stress_part {
                value += self.stress_forms[f]
                    .iter()
                    .map(|&(e, g)| dot(&g, &stress_part[e]))
                    .sum::<f64>();
            }
            out[i][r] = value;
        }
        out
    }
}

/// The tangent fields of one direction.
struct Tangent {
    temperature: Option<Vec<f64>>,
    displacement: Option<Vec<[f64; 2]>>,
    stresses: Option<Vec<ElementStress>>,
    multipliers: Option<Vec<f64>>,
}

impl Tangent {
    fn fields(&self) -> Fields<'_> {
        Fields {
            temperature: self.temperature.as_deref(),
            displacement: self.displacement.as_deref(),
            stresses: self.stresses.as_deref(),
            multipliers: self.multipliers.as_deref(),
            velocity: None,
        }
    }
}

impl SolvedState<'_> {
    /// The state's fields as the criteria read them.
    fn fields(&self) -> Fields<'_> {
        Fields {
            temperature: self.temperature,
            displacement: self.elastic.as_ref().map(|e| e.displacement),
            stresses: self.elastic.as_ref().map(|e| e.stresses),
            multipliers: self
                .elastic
                .as_ref()
                .map(|e| e.contact.multipliers.as_slice()),
            velocity: None,
        }
    }
}

/// One direction of differentiation: the data stencil of a parameter and the temperature
/// derivative along it (`None` without heat).
struct Direction<'a> {
    stencil: &'a Stencil,
    d_temperature: Option<&'a [f64]>,
}

/// Which region values are differentiated: per Φ, the regions that tie for its maximum, and
/// those plus the regions a criterion is bound to.
struct RegionSelection {
    tied: PerCriterion<Vec<bool>>,
    needed: PerCriterion<Vec<bool>>,
}

impl RegionSelection {
    /// The selection at the region values `values`, with the bound regions `bound`.
    fn new(values: &PerCriterion<Vec<f64>>, bound: &PerCriterion<Vec<usize>>) -> RegionSelection {
        // The defined criteria have no maximum: only the bound ones are differentiated.
        let tied: PerCriterion<Vec<bool>> = std::array::from_fn(|i| {
            if i == Criterion::Defined as usize {
                vec![false; values[i].len()]
            } else {
                tied_regions(&values[i])
            }
        });
        let needed = std::array::from_fn(|i| {
            let mut needed = tied[i].clone();
            for &r in &bound[i] {
                if let Some(n) = needed.get_mut(r) {
                    *n = true;
                }
            }
            needed
        });
        RegionSelection { tied, needed }
    }

    /// Per direction, the one-sided derivative of each Φ's maximum over its tied regions, and
    /// those of the needed regions.
    fn one_sided(
        &self,
        values: &PerCriterion<Vec<f64>>,
        derivatives: &[OneSidedRegions],
    ) -> (Sensitivities, RegionSensitivities) {
        let sensitivities = derivatives
            .iter()
            .map(|(right, left)| {
                std::array::from_fn(|i| {
                    (i != Criterion::Defined as usize)
                        .then(|| one_sided(&values[i], &self.tied[i], &right[i], &left[i]))
                        .flatten()
                })
            })
            .collect();
        let regions = derivatives
            .iter()
            .map(|(right, left)| {
                std::array::from_fn(|i| {
                    (0..values[i].len())
                        .map(|r| {
                            self.needed[i][r].then(|| OneSided {
                                right: right[i][r],
                                left: left[i][r],
                            })
                        })
                        .collect()
                })
            })
            .collect();
        (sensitivities, regions)
    }
}

/// The region derivatives of a state without elasticity: linear in the temperature derivative,
/// the same from both sides.
fn thermal_region_derivatives(
    forms: &PerCriterion<Vec<LinearForm>>,
    d_temperatures: &[Option<Vec<f64>>],
) -> Vec<OneSidedRegions> {
    d_temperatures
        .iter()
        .map(|dt| {
            let tangent = Fields {
                temperature: dt.as_deref(),
                displacement: None,
                stresses: None,
                multipliers: None,
                velocity: None,
            };
            let right = apply_forms(forms, &tangent);
            (right.clone(), right)
        })
        .collect()
}

impl StateProblem {
    /// dΦ/dθ_j for every stencil of `stencils`, at the solved state, by `route`; the derivatives
    /// of the region values that tie for each maximum or that `bound` lists (per Φ, indices in
    /// its family); and how many directions the adjoint gave.
    ///
    /// Steps: the criteria's linear forms and region values at the state; the regions whose
    /// derivatives are needed; the temperature derivative per direction; the region derivatives
    /// per direction (heat alone, or elasticity by the adjoint and the forward tangents); the
    /// one-sided derivatives of each maximum and of the needed regions.
    pub(super) fn sensitivities(
        &self,
        state: &SolvedState,
        stencils: &[Stencil],
        route: DerivativeRoute,
        bound: &PerCriterion<Vec<usize>>,
    ) -> Result<(Sensitivities, RegionSensitivities, usize), WsmError> {
        let fields = state.fields();
        let forms = region_forms(&self.criteria, &fields);
        let values = per_region_with(&self.criteria, &fields, &forms);
        let selection = RegionSelection::new(&values, bound);
        let d_temperatures: Vec<Option<Vec<f64>>> = stencils
            .iter()
            .map(|stencil| {
                state
                    .temperature
                    .map(|t| self.temperature_derivative(state.data, t, stencil))
                    .transpose()
            })
            .collect::<Result<_, _>>()?;
        let (derivatives, adjoint_directions) = match &state.elastic {
            None => (thermal_region_derivatives(&forms, &d_temperatures), 0),
            Some(el) => {
                let directions: Vec<Direction> = stencils
                    .iter()
                    .zip(&d_temperatures)
                    .map(|(stencil, dt)| Direction {
                        stencil,
                        d_temperature: dt.as_deref(),
                    })
                    .collect();
                self.elastic_region_derivatives(
                    state,
                    el,
                    &directions,
                    &forms,
                    &selection.needed,
                    route,
                )?
            }
        };
        let (sensitivities, regions) = selection.one_sided(&values, &derivatives);
        Ok((sensitivities, regions, adjoint_directions))
    }

    /// Per stencil, the region derivatives along +θ_j and −θ_j of a state with elasticity: by
    /// the adjoint where `route` asks for it, the contact path allows it and the contact state is
    /// differentiable along the direction, by the forward tangents for the rest; and how many
    /// directions the adjoint gave.
    fn elastic_region_derivatives(
        &self,
        state: &SolvedState,
        el: &ElasticState,
        directions: &[Direction],
        forms: &PerCriterion<Vec<LinearForm>>,
        needed: &PerCriterion<Vec<bool>>,
        route: DerivativeRoute,
    ) -> Result<(Vec<OneSidedRegions>, usize), WsmError> {
        let mut elements: Vec<usize> = forms
            .iter()
            .flatten()
            .flat_map(|f| f.stresses.iter().map(|&(e, _)| e))
            .collect();
        elements.sort_unstable();
        elements.dedup();
        let parts: Vec<ElasticDerivative> = directions
            .iter()
            .map(|d| self.elastic_derivative(state, el, d.stencil, d.d_temperature, &elements))
            .collect::<Result<_, _>>()?;
        let (lo, hi, friction) = self.bounds_at(state.data, el);
        let point = contact_point(el, &lo, &hi, &friction);
        let mut derivatives: Vec<Option<OneSidedRegions>> = vec![None; directions.len()];
        // The adjoint is built on the dense path's C; the sparse path takes the forward
        // tangents (design §3.1).
        if route == DerivativeRoute::Adjoint && !self.contact.is_sparse() {
            if let Some(adjoint) = self.adjoint_criteria(state, el, &point, forms, needed)? {
                for (j, part) in parts.iter().enumerate() {
                    if adjoint.contact.is_linear_along(&part.view()) {
                        let right = adjoint.along(part, directions[j].d_temperature);
                        derivatives[j] = Some((right.clone(), right));
                    }
                }
            }
        }
        let adjoint_directions = derivatives.iter().filter(|d| d.is_some()).count();
        let rest: Vec<usize> = (0..directions.len())
            .filter(|&j| derivatives[j].is_none())
            .collect();
        let rest_parts: Vec<&ElasticDerivative> = rest.iter().map(|&j| &parts[j]).collect();
        let rest_dt: Vec<Option<&[f64]>> =
            rest.iter().map(|&j| directions[j].d_temperature).collect();
        let tangents = self.tangents(state, el, &point, &rest_parts, &rest_dt)?;
        for (j, (plus, minus)) in rest.into_iter().zip(tangents) {
            let right = apply_forms(forms, &plus.fields());
            let left = match minus {
                Some(m) => apply_forms(forms, &m.fields()).map(|d| d.iter().map(|v| -v).collect()),
                None => right.clone(),
            };
            derivatives[j] = Some((right, left));
        }
        let derivatives = derivatives
            .into_iter()
            .map(|d| d.ok_or_else(|| WsmError::contact("a direction was not differentiated")))
            .collect::<Result<_, WsmError>>()?;
        Ok((derivatives, adjoint_directions))
    }

    /// The multiplier bounds at the state (Coulomb ones at its normal forces) and each pair's
    /// Coulomb coefficient (`None`: Tresca or bilateral).
    #[allow(clippy::type_complexity)]
    fn bounds_at(&self, data: &Data, el: &ElasticState) -> (Vec<f64>, Vec<f64>, Vec<Option<f64>>) {
        let geometry = &self.contact.geometry;
        let (lo, hi) = geometry.bounds(data, Some(&el.contact.multipliers));
        let friction = geometry
            .pairs
            .iter()
            .map(|p| data.friction[p.zone].filter(|_| !p.bilateral))
            .collect();
        (lo, hi, friction)
    }

    /// The state's own derivative along every stencil (du on the free DOFs and dλ per row,
    /// along +θ_j and, where one-sided, −θ_j): the contact tangents of §4.4 on the data
    /// derivatives of [`Self::elastic_derivative`].
    pub(super) fn state_tangents(
        &self,
        state: &SolvedState,
        stencils: &[Stencil],
    ) -> Result<Vec<TangentDisplacement>, WsmError> {
        let el = state
            .elastic
            .as_ref()
            .ok_or_else(|| WsmError::contact("the elastic state was not solved"))?;
        let parts: Vec<ElasticDerivative> = stencils
            .iter()
            .map(|stencil| {
                let dt = state
                    .temperature
                    .map(|t| self.temperature_derivative(state.data, t, stencil))
                    .transpose()?;
                self.elastic_derivative(state, el, stencil, dt.as_deref(), &[])
            })
            .collect::<Result<_, WsmError>>()?;
        let (lo, hi, friction) = self.bounds_at(state.data, el);
        let point = contact_point(el, &lo, &hi, &friction);
        let derivatives: Vec<DataDerivative> = parts.iter().map(|p| p.view()).collect();
        self.contact.tangents(el.factor, &point, &derivatives)
    }

    /// The adjoint of every `needed` region form of the criteria (design §4.4): the contact
    /// adjoint of their displacement parts and the coefficients of du_d and dT; `None` where the
    /// contact state is only one-sided differentiable.
    fn adjoint_criteria(
        &self,
        state: &SolvedState,
        el: &ElasticState,
        point: &ContactPoint,
        forms: &PerCriterion<Vec<LinearForm>>,
        needed: &PerCriterion<Vec<bool>>,
    ) -> Result<Option<AdjointCriteria>, WsmError> {
        let elastic = &self.elastic;
        let nodes = elastic.mesh().nodes.len();
        let mut regions = Vec::new();
        let mut mechanical = Vec::new();
        let mut free_forms = Vec::new();
        let mut fixed = Vec::new();
        let mut temperature = Vec::new();
        let mut stress_forms = Vec::new();
        for (i, criterion) in forms.iter().enumerate() {
            for (r, form) in criterion.iter().enumerate() {
                if !needed[i][r] {
                    continue;
                }
                let mut a_u = vec![[0.0; 2]; nodes];
                let mut a_t = vec![0.0; nodes];
                for &(n, a) in &form.displacement {
                    a_u[n][0] += a[0];
                    a_u[n][1] += a[1];
                }
                for &(n, t) in &form.temperature {
                    a_t[n] += t;
                }
                elastic.add_stress_form_transpose(
                    state.data,
                    &form.stresses,
                    &mut a_u,
                    &mut a_t,
                )?;
                let (mut a_free, a_fixed) = elastic.dofs().restrict(&a_u);
                // Zero on the mixed element's pressure unknowns (no form reads them).
                a_free.resize(elastic.operator().n_free(), 0.0);
                regions.push((i, r));
                mechanical.push(form.is_mechanical().then_some(free_forms.len()));
                if form.is_mechanical() {
                    free_forms.push((a_free, form.multipliers.clone()));
                }
                fixed.push(a_fixed);
                temperature.push(a_t);
                stress_forms.push(form.stresses.clone());
            }
        }
        let n_fixed = elastic.dofs().n_fixed();
        Ok(self
            .contact
            .adjoint(el.factor, point, &free_forms, n_fixed)?
            .map(|contact| AdjointCriteria {
                contact,
                shape: forms.each_ref().map(Vec::len),
                regions,
                mechanical,
                fixed,
                temperature,
                stress_forms,
            }))
    }

    /// Per direction, the tangent fields along +θ_j and, where the state is only one-sided
    /// differentiable, along −θ_j (`None`: minus the first). The contact tangents of all
    /// directions share their solves with K (one multi-right-hand-side solve for all).
    fn tangents(
        &self,
        state: &SolvedState,
        el: &ElasticState,
        point: &ContactPoint,
        parts: &[&ElasticDerivative],
        d_temperatures: &[Option<&[f64]>],
    ) -> Result<Vec<(Tangent, Option<Tangent>)>, WsmError> {
        let derivatives: Vec<DataDerivative> = parts.iter().map(|p| p.view()).collect();
        let tangents = self.contact.tangents(el.factor, point, &derivatives)?;
        let elastic = &self.elastic;
        parts
            .iter()
            .zip(d_temperatures)
            .zip(tangents)
            .map(|((part, d_temperature), tangent)| {
                let fields =
                    |du_free: &[f64], dlambda: &[f64], sign: f64| -> Result<Tangent, WsmError> {
                        let signed = |v: &[f64]| v.iter().map(|x| sign * x).collect::<Vec<f64>>();
                        let du = elastic.dofs().expand(du_free, &signed(&part.fixed));
                        let dt = d_temperature.map(signed);
                        let mut stresses =
                            elastic.stress_increments(state.data, &du, dt.as_deref())?;
                        if let Some(stress_part) = &part.stress_part {
                            for (s, p) in stresses.iter_mut().zip(stress_part) {
                                for (sc, pc) in s.stress.iter_mut().zip(p) {
                                    *sc += sign * pc;
                                }
                            }
                        }
                        Ok(Tangent {
                            temperature: dt,
                            displacement: Some(du),
                            stresses: Some(stresses),
                            multipliers: Some(dlambda.to_vec()),
                        })
                    };
                let plus = fields(&tangent.plus, &tangent.plus_multipliers, 1.0)?;
                let minus = match (&tangent.minus, &tangent.minus_multipliers) {
                    (Some(du), Some(dlambda)) => Some(fields(du, dlambda, -1.0)?),
                    (Some(du), None) => Some(fields(du, &[], -1.0)?),
                    (None, _) => None,
                };
                Ok((plus, minus))
            })
            .collect()
    }

    /// The data derivative of the elastic contact problem along the stencil's parameter (with
    /// the temperature derivative `d_temperature`): b = Σ_k w_k (f(D_k, T + t_k dT) − K(D_k) u),
    /// the derivatives of u_d and of the multiplier bounds, and the part of dτ from the law's
    /// change, Σ_k w_k τ(D_k; u, T), when the law changes, at the `elements` the criteria read
    /// (0 elsewhere).
    fn elastic_derivative(
        &self,
        state: &SolvedState,
        el: &ElasticState,
        stencil: &Stencil,
        d_temperature: Option<&[f64]>,
        elements: &[usize],
    ) -> Result<ElasticDerivative, WsmError> {
        let elastic = &self.elastic;
        let geometry = &self.contact.geometry;
        let m = geometry.dim();
        let mut part = ElasticDerivative {
            // The operator's unknowns: the free DOFs (and the mixed element's pressures).
            residual: vec![0.0; elastic.operator().n_free()],
            fixed: vec![0.0; elastic.dofs().n_fixed()],
            lower: vec![0.0; m],
            upper: vec![0.0; m],
            stress_part: None,
        };
        let materials = elastic.zone_materials(state.data)?;
        let d_lame = self.mixed_lame_derivative(stencil)?;
        let coefficients: Vec<Vec<ElasticCoefficients>> = match &d_lame {
            None => stencil
                .points
                .iter()
                .map(|(_, _, d)| elastic.coefficients(d))
                .collect::<Result<_, _>>()?,
            Some(d_lame) => {
                // The mixed element's coefficients are rational in the data: the stencil sees
                // them linearised, c + t_k dc, with dc exact (design §2.7).
                let dc = elastic.mixed_coefficient_derivatives(state.data, d_lame)?;
                linearised(el.coefficients, &dc, stencil)
            }
        };
        let stiffness_varies = coefficients.iter().any(|c| c != el.coefficients);
        // Whether the law τ(D; u, T) changes along the stencil: then every point's stresses
        // enter, the unchanged one (t = 0 of a one-sided stencil) included.
        let mut law_varies = false;
        for (_, _, d) in &stencil.points {
            law_varies |= elastic.zone_materials(d)? != materials
                || d.reference_temperature != state.data.reference_temperature;
        }
        for ((t, w, d), coefficients) in stencil.points.iter().zip(&coefficients) {
            let temperature: Option<Vec<f64>> = state.temperature.map(|temp| match d_temperature {
                Some(dt) => temp.iter().zip(dt).map(|(a, b)| a + t * b).collect(),
                None => temp.to_vec(),
            });
            let fixed_k = elastic.fixed_values(d)?;
            let loads = elastic.loads(d, temperature.as_deref())?;
            let rhs = elastic.rhs_with(coefficients, &loads, &fixed_k)?;
            add_scaled(&mut part.residual, *w, &rhs);
            add_scaled(&mut part.fixed, *w, &fixed_k);
            // On Coulomb zones F_k λ_n at the state's normal forces: the part dF λ_n of the
            // bound's derivative (the part F dλ_n is the tangent problem's coupling).
            let (lo, hi) = geometry.bounds(d, Some(&el.contact.multipliers));
            add_scaled(&mut part.lower, *w, &finite_or_zero(&lo));
            add_scaled(&mut part.upper, *w, &finite_or_zero(&hi));
            if law_varies && d_lame.is_none() {
                let stresses =
                    elastic.stresses_at(d, el.displacement, state.temperature, elements)?;
                let sum = part
                    .stress_part
                    .get_or_insert_with(|| vec![[0.0; 4]; el.stresses.len()]);
                for (&e, s) in elements.iter().zip(&stresses) {
                    for (pc, sc) in sum[e].iter_mut().zip(&s.stress) {
                        *pc += w * sc;
                    }
                }
            }
        }
        let thermal = match (&d_lame, state.temperature) {
            (Some(_), Some(t)) => Some(self.mixed_thermal_rate(t, stencil)?),
            _ => None,
        };
        if let (Some(d_lame), Some(rate)) = (&d_lame, &thermal) {
            // The temperature enters the mixed element's pressure rows (design §2.7).
            elastic.add_mixed_thermal_rows_rate(
                state.data,
                d_lame,
                rate,
                d_temperature,
                &mut part.residual,
            )?;
        }
        if let Some(d_lame) = d_lame.filter(|_| law_varies) {
            // The mixed element's law is rational in λ, μ: its exact derivative at fixed u.
            let rates = elastic.mixed_stress_rates(
                state.data,
                &d_lame,
                el.displacement,
                thermal.as_ref(),
                elements,
            )?;
            let mut sum = vec![[0.0; 4]; el.stresses.len()];
            for (&e, rate) in elements.iter().zip(rates) {
                sum[e] = rate;
            }
            part.stress_part = Some(sum);
        }
        if stiffness_varies {
            // K is linear in the zone coefficients: Σ w_k K(c_k) u = K(Σ w_k c_k) u.
            let values = elastic
                .operator()
                .assemble(&weighted_sum(stencil, &coefficients))?;
            let ku = elastic.operator().apply(&values, &el.contact.u_free);
            add_scaled(&mut part.residual, -1.0, &ku);
        }
        Ok(part)
    }

    /// For the mixed element, the derivative of the Lamé constants (λ, μ) per zone along the
    /// stencil's parameter, Σ_k w_k (λ, μ)(D_k) (exact for E, λ and μ, which they are linear
    /// in; order 4 for ν); `None` for P1.
    fn mixed_lame_derivative(
        &self,
        stencil: &Stencil,
    ) -> Result<Option<Vec<(f64, f64)>>, WsmError> {
        if self.elastic.element() != Element::Mixed {
            return Ok(None);
        }
        let mut sum = vec![(0.0, 0.0); self.mesh().zones.len()];
        for (_, w, d) in &stencil.points {
            for (s, (l, m)) in sum.iter_mut().zip(self.elastic.lame(d)?) {
                s.0 += w * l;
                s.1 += w * m;
            }
        }
        Ok(Some(sum))
    }

    /// For the mixed element at the temperature `temperature`, the derivatives of the zones' β
    /// and of the reference temperature along the stencil's parameter (Σ_k w_k of them: exact
    /// for the data β is affine in, order 4 for ν).
    fn mixed_thermal_rate<'a>(
        &self,
        temperature: &'a [f64],
        stencil: &Stencil,
    ) -> Result<MixedThermalRate<'a>, WsmError> {
        let mut rate = MixedThermalRate {
            temperature,
            d_beta: vec![[0.0; 4]; self.mesh().zones.len()],
            d_reference: 0.0,
        };
        for (_, w, d) in &stencil.points {
            for (s, m) in rate.d_beta.iter_mut().zip(self.elastic.zone_materials(d)?) {
                add_scaled(s, *w, &m.beta);
            }
            rate.d_reference += w * d.reference_temperature;
        }
        Ok(rate)
    }

    /// dT along the stencil's parameter: K_h dT_f = Σ_k w_k (q(D_k) − K_h(D_k) T_f) on the free
    /// unknowns, dT_d = Σ_k w_k T_d(D_k); zero when the thermal data do not change.
    fn temperature_derivative(
        &self,
        data: &Data,
        temperature: &[f64],
        stencil: &Stencil,
    ) -> Result<Vec<f64>, WsmError> {
        let heat = self.heat_problem()?;
        let key = thermal_key(data);
        if stencil.points.iter().all(|(_, _, d)| thermal_key(d) == key) {
            return Ok(vec![0.0; temperature.len()]);
        }
        let factor = self.heat_factor(data, crate::fem::Par::Seq)?;
        let t_free = heat.free_values(temperature);
        let mut residual = vec![0.0; t_free.len()];
        let mut fixed = vec![0.0; heat.operator().n_fixed()];
        let coefficients: Vec<Vec<HeatCoefficients>> = stencil
            .points
            .iter()
            .map(|(_, _, d)| heat.coefficients(d))
            .collect::<Result<_, _>>()?;
        let conductivity_varies = coefficients.iter().any(|c| *c != factor.coefficients);
        for ((_, w, d), coefficients) in stencil.points.iter().zip(&coefficients) {
            let fixed_k = heat.fixed_values(d)?;
            let rhs = heat.rhs_with(coefficients, &heat.loads(d)?, &fixed_k)?;
            add_scaled(&mut residual, *w, &rhs);
            add_scaled(&mut fixed, *w, &fixed_k);
        }
        if conductivity_varies {
            let values = heat
                .operator()
                .assemble(&weighted_sum(stencil, &coefficients))?;
            add_scaled(
                &mut residual,
                -1.0,
                &heat.operator().apply(&values, &t_free),
            );
        }
        Ok(heat.expand(&factor.factor.solve(&residual), &fixed))
    }
}

/// y += a x.
pub(crate) fn add_scaled(y: &mut [f64], a: f64, x: &[f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// Σ_k w_k c_k of per-point zone coefficients, with the stencil's weights.
fn weighted_sum<const NC: usize>(
    stencil: &Stencil,
    coefficients: &[Vec<[f64; NC]>],
) -> Vec<[f64; NC]> {
    let mut sum = vec![[0.0; NC]; coefficients.first().map_or(0, Vec::len)];
    for ((_, w, _), point) in stencil.points.iter().zip(coefficients) {
        for (s, c) in sum.iter_mut().zip(point) {
            for (s, c) in s.iter_mut().zip(c) {
                *s += w * c;
            }
        }
    }
    sum
}

/// Per stencil point, the coefficients c + t_k dc (Σ_k w_k of them is dc; the stencil combines
/// them with the loads and prescribed values exactly, as it does P1's affine coefficients).
fn linearised(
    c: &[ElasticCoefficients],
    dc: &[ElasticCoefficients],
    stencil: &Stencil,
) -> Vec<Vec<ElasticCoefficients>> {
    stencil
        .points
        .iter()
        .map(|(t, _, _)| {
            c.iter()
                .zip(dc)
                .map(|(c, dc)| std::array::from_fn(|k| c[k] + t * dc[k]))
                .collect()
        })
        .collect()
}

/// The bounds with infinite entries replaced by 0 (an infinite bound does not move).
fn finite_or_zero(v: &[f64]) -> Vec<f64> {
    v.iter()
        .map(|x| if x.is_finite() { *x } else { 0.0 })
        .collect()
}

/// The contact state of an elastic state with its multiplier bounds and the friction
/// coefficients of its pairs.
fn contact_point<'a>(
    el: &'a ElasticState,
    lower: &'a [f64],
    upper: &'a [f64],
    friction: &'a [Option<f64>],
) -> ContactPoint<'a> {
    ContactPoint {
        multipliers: &el.contact.multipliers,
        gaps: &el.contact.gaps,
        lower,
        upper,
        friction,
        displacement_scale: el
            .displacement
            .iter()
            .fold(0.0_f64, |a, v| a.max(v[0].abs()).max(v[1].abs())),
    }
}

/// The region derivatives of Φ1..Φ6: the forms applied to the tangent fields.
fn apply_forms(forms: &PerCriterion<Vec<LinearForm>>, tangent: &Fields) -> PerCriterion<Vec<f64>> {
    forms
        .each_ref()
        .map(|f| f.iter().map(|form| form.apply(tangent)).collect())
}

/// Which regions tie for the maximum of the region values (within [`TIE_TOL`]).
pub(crate) fn tied_regions(values: &[f64]) -> Vec<bool> {
    let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let scale = values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    values.iter().map(|v| *v >= max - TIE_TOL * scale).collect()
}

/// The one-sided derivatives of max_r V_r from the region values, the regions that tie for the
/// maximum and their right and left derivatives.
pub(crate) fn one_sided(
    values: &[f64],
    tied: &[bool],
    right: &[f64],
    left: &[f64],
) -> Option<OneSided> {
    if values.is_empty() {
        return None;
    }
    let regions = || (0..values.len()).filter(|&r| tied[r]);
    Some(OneSided {
        right: regions()
            .map(|r| right[r])
            .fold(f64::NEG_INFINITY, f64::max),
        left: regions().map(|r| left[r]).fold(f64::INFINITY, f64::min),
    })
}
