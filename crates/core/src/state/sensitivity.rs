//! Exact sensitivities of the criteria (design §4.3): dΦ_i/dθ_j of a solved state, by the
//! tangent (forward) method on the converged state with the factors of the solve.
//!
//! Per parameter θ_j, the data derivative comes from a [`Stencil`] of data sets (exact up to
//! rounding for the affine data maps, ≈ 1e-12 relative for ν). Then, reusing the state's factors:
//! 1. heat (FGCS 2.1–2.4): K_h dT = −Σ_k w_k (K_h(D_k) T − q(D_k)) on the free unknowns, dT_d
//!    the derivative of the prescribed temperatures;
//! 2. elasticity with contact (FGCS 2.7–2.11, the discrete contact problem): the residual
//!    derivative b = Σ_k w_k (f(D_k, T + t_k dT) − K(D_k) u) drives the tangent contact problem
//!    ([`crate::contact::direct::DataDerivative`]), one-sided where the active set is weakly
//!    active;
//! 3. stresses: dτ = A e(du) − β dT + Σ_k w_k τ(D_k; u, T);
//! 4. criteria (FGCS 4.29–4.34): Φ1–Φ4 and Φ6 are linear in the fields, so the derivative of a
//!    region value is the region value of the tangent field; Φ5 = mean I2² has 2 mean B(τ, dτ).
//!    Where regions tie in the maximum over r, the right derivative is the largest right
//!    derivative of the tied regions and the left one the smallest left derivative.
//!
//! The DD solver's state is differentiated with the direct solver's factor and C (the same
//! formulas on the DD multipliers), which costs one direct factorisation per stiffness.

use super::criterion_values::{per_region, region_derivatives, Fields};
use super::{thermal_key, StateProblem};
use crate::contact::direct::{ContactPoint, ContactSolution, DataDerivative, StiffnessFactor};
use crate::error::WsmError;
use crate::fem::ElementStress;
use crate::scene::params::Stencil;
use crate::scene::Data;
pub use wsm_search::OneSided;

/// Relative distance to the maximum within which a region ties with the maximising one.
const TIE_TOL: f64 = 1e-12;

/// Per parameter, the derivatives of Φ1..Φ6 (None where the criterion was not computed).
pub type Sensitivities = Vec<[Option<OneSided>; 6]>;

/// The state a sensitivity is taken at.
pub(super) struct SolvedState<'a> {
    pub data: &'a Data,
    pub temperature: Option<&'a [f64]>,
    pub elastic: Option<ElasticState<'a>>,
}

/// The elastic part of a solved state.
pub(super) struct ElasticState<'a> {
    pub coefficients: &'a [[f64; 2]],
    pub factor: &'a StiffnessFactor,
    pub contact: &'a ContactSolution,
    pub displacement: &'a [[f64; 2]],
    pub stresses: &'a [ElementStress],
}

/// The tangent fields of one direction.
/// The data derivative of the elastic contact problem along one parameter.
struct ElasticDerivative {
    /// b on the free DOFs.
    residual: Vec<f64>,
    /// du_d.
    fixed: Vec<f64>,
    /// Derivatives of the multiplier bounds (0 for infinite ones).
    lower: Vec<f64>,
    upper: Vec<f64>,
    /// Σ_k w_k τ(D_k; u, T) per element, when the law changes along the parameter.
    stress_part: Option<Vec<[f64; 4]>>,
}

struct Tangent {
    temperature: Option<Vec<f64>>,
    displacement: Option<Vec<[f64; 2]>>,
    stresses: Option<Vec<ElementStress>>,
}

impl Tangent {
    fn fields(&self) -> Fields<'_> {
        Fields {
            temperature: self.temperature.as_deref(),
            displacement: self.displacement.as_deref(),
            stresses: self.stresses.as_deref(),
        }
    }
}

impl StateProblem {
    /// dΦ/dθ_j for every stencil of `stencils`, at the solved state.
    pub(super) fn sensitivities(
        &self,
        state: &SolvedState,
        stencils: &[Stencil],
    ) -> Result<Sensitivities, WsmError> {
        let fields = Fields {
            temperature: state.temperature,
            displacement: state.elastic.as_ref().map(|e| e.displacement),
            stresses: state.elastic.as_ref().map(|e| e.stresses),
        };
        let values = per_region(&self.criteria, &fields);
        Ok(self
            .tangents(state, stencils)?
            .iter()
            .map(|(plus, minus)| {
                let right = region_derivatives(&self.criteria, &fields, &plus.fields());
                let left = match minus {
                    Some(m) => region_derivatives(&self.criteria, &fields, &m.fields())
                        .map(|d| d.iter().map(|v| -v).collect()),
                    None => right.clone(),
                };
                std::array::from_fn(|i| one_sided(&values[i], &right[i], &left[i]))
            })
            .collect())
    }

    /// Per stencil, the tangent fields along +θ_j and, where the state is only one-sided
    /// differentiable, along −θ_j (`None`: minus the first). The contact tangents of all
    /// stencils share their solves with K (one multi-right-hand-side solve for all).
    fn tangents(
        &self,
        state: &SolvedState,
        stencils: &[Stencil],
    ) -> Result<Vec<(Tangent, Option<Tangent>)>, WsmError> {
        let d_temperatures: Vec<Option<Vec<f64>>> = stencils
            .iter()
            .map(|stencil| {
                state
                    .temperature
                    .map(|t| self.temperature_derivative(state.data, t, stencil))
                    .transpose()
            })
            .collect::<Result<_, _>>()?;
        let Some(el) = &state.elastic else {
            return Ok(d_temperatures
                .into_iter()
                .map(|temperature| {
                    let plus = Tangent {
                        temperature,
                        displacement: None,
                        stresses: None,
                    };
                    (plus, None)
                })
                .collect());
        };
        let parts: Vec<ElasticDerivative> = stencils
            .iter()
            .zip(&d_temperatures)
            .map(|(stencil, dt)| self.elastic_derivative(state, el, stencil, dt.as_deref()))
            .collect::<Result<_, _>>()?;
        let (lo, hi) = self
            .contact
            .geometry
            .bounds(state.data, Some(&el.contact.multipliers));
        let displacement_scale = el
            .displacement
            .iter()
            .fold(0.0_f64, |a, v| a.max(v[0].abs()).max(v[1].abs()));
        let friction: Vec<Option<f64>> = self
            .contact
            .geometry
            .pairs
            .iter()
            .map(|p| state.data.friction[p.zone].filter(|_| !p.bilateral))
            .collect();
        let point = ContactPoint {
            multipliers: &el.contact.multipliers,
            gaps: &el.contact.gaps,
            lower: &lo,
            upper: &hi,
            friction: &friction,
            displacement_scale,
        };
        let derivatives: Vec<DataDerivative> = parts
            .iter()
            .map(|p| DataDerivative {
                residual: &p.residual,
                fixed: &p.fixed,
                lower: &p.lower,
                upper: &p.upper,
            })
            .collect();
        let tangents = self.contact.tangents(el.factor, &point, &derivatives)?;
        let elastic = &self.elastic;
        parts
            .iter()
            .zip(&d_temperatures)
            .zip(tangents)
            .map(|((part, d_temperature), tangent)| {
                let fields = |du_free: &[f64], sign: f64| -> Result<Tangent, WsmError> {
                    let signed = |v: &[f64]| v.iter().map(|x| sign * x).collect::<Vec<f64>>();
                    let du = elastic.dofs().expand(du_free, &signed(&part.fixed));
                    let dt = d_temperature.as_deref().map(signed);
                    let mut stresses = elastic.stress_increments(state.data, &du, dt.as_deref())?;
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
                    })
                };
                let plus = fields(&tangent.plus, 1.0)?;
                let minus = match &tangent.minus {
                    Some(du) => Some(fields(du, -1.0)?),
                    None => None,
                };
                Ok((plus, minus))
            })
            .collect()
    }

    /// The data derivative of the elastic contact problem along the stencil's parameter (with
    /// the temperature derivative `d_temperature`): b = Σ_k w_k (f(D_k, T + t_k dT) − K(D_k) u),
    /// the derivatives of u_d and of the multiplier bounds, and the part of dτ from the law's
    /// change, Σ_k w_k τ(D_k; u, T), when the law changes.
    fn elastic_derivative(
        &self,
        state: &SolvedState,
        el: &ElasticState,
        stencil: &Stencil,
        d_temperature: Option<&[f64]>,
    ) -> Result<ElasticDerivative, WsmError> {
        let elastic = &self.elastic;
        let geometry = &self.contact.geometry;
        let m = geometry.dim();
        let mut part = ElasticDerivative {
            residual: vec![0.0; elastic.dofs().n_free()],
            fixed: vec![0.0; elastic.dofs().n_fixed()],
            lower: vec![0.0; m],
            upper: vec![0.0; m],
            stress_part: None,
        };
        let materials = elastic.zone_materials(state.data)?;
        let coefficients: Vec<Vec<[f64; 2]>> = stencil
            .points
            .iter()
            .map(|(_, _, d)| elastic.coefficients(d))
            .collect::<Result<_, _>>()?;
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
            if law_varies {
                let stresses = elastic.stresses(d, el.displacement, state.temperature)?;
                let sum = part
                    .stress_part
                    .get_or_insert_with(|| vec![[0.0; 4]; stresses.len()]);
                for (p, s) in sum.iter_mut().zip(&stresses) {
                    for (pc, sc) in p.iter_mut().zip(&s.stress) {
                        *pc += w * sc;
                    }
                }
            }
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
        let coefficients: Vec<Vec<[f64; 1]>> = stencil
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
fn add_scaled(y: &mut [f64], a: f64, x: &[f64]) {
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

/// The bounds with infinite entries replaced by 0 (an infinite bound does not move).
fn finite_or_zero(v: &[f64]) -> Vec<f64> {
    v.iter()
        .map(|x| if x.is_finite() { *x } else { 0.0 })
        .collect()
}

/// The one-sided derivatives of max_r V_r from the region values and their right and left
/// derivatives.
fn one_sided(values: &[f64], right: &[f64], left: &[f64]) -> Option<OneSided> {
    let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if values.is_empty() {
        return None;
    }
    let scale = values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let tied = |r: &usize| values[*r] >= max - TIE_TOL * scale;
    let regions = 0..values.len();
    Some(OneSided {
        right: regions
            .clone()
            .filter(tied)
            .map(|r| right[r])
            .fold(f64::NEG_INFINITY, f64::max),
        left: regions
            .filter(tied)
            .map(|r| left[r])
            .fold(f64::INFINITY, f64::min),
    })
}
