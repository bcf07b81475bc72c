//! Criteria Φ1–Φ6 of a solution (design §4.2, FGCS 4.29–4.34): exact means over the user's areas
//! G_r and boundary pieces G'_r, maximised over r.
//!
//! Φ1 = max_r mean_{G_r} T,  Φ2 = max_r mean_{G'_r} T,  Φ3 = max_r mean_{G_r} u·n(X_r),
//! Φ4 = max_r mean_{G'_r} u·n(X_r),  Φ5 = max_r mean_{G_r} I2²(τ),  Φ6 = max_r mean_{G_r} (−τ_n)
//! with τ_n = n(X_r)·τ·n(X_r); Φ3 over the regions that have a normal, Φ6 over those of them that
//! touch a contact zone (G_r adjacent to Γc, FGCS 4.34). The region weights are
//! normalised (they sum to one), so a mean is a weighted sum of nodal or element values.
//!
//! Each region value has a derivative that is a [`LinearForm`] of the tangent fields (dT, du, dτ):
//! the region value itself for the linear criteria, 2 mean B(τ, dτ) for Φ5 (B the bilinear form
//! of I2²). The sensitivities apply the forms to tangent fields (forward) or hand them to the
//! adjoint (design §4.3).
//!
//! The defined criteria (`criteria.defined`, [`Criterion::Defined`]) are the family after Φ6: the
//! k-th member is the mean of a stress quantity q over its area, Σ_e w_e q(τ_e), with the form
//! Σ_e w_e ∇q(τ_e)·dτ_e (q linear for a component; σ1, σ2 and von Mises linearised at τ_e,
//! `fem::stress_measures::stress_quantity_gradient`), or the mean of a contact traction over a
//! boundary piece, Σ_i w_i λ_{r(i)} / w_{pair(i)}, a linear form on the multipliers whose
//! derivative reads dλ; in a dynamic scene, a receiver's speed |v(x_r)| (v interpolated in
//! P1 at the receiver), with the form (v/|v|)·dv(x_r) where v(x_r) ≠ 0. The family has no maximum: each member is
//! requested by its name, as a criterion bound to it.

use super::solution::{pair_of_node, piece_traction_rows};
use crate::contact::pairs::ContactGeometry;
use crate::fem::stress::i2_bilinear;
use crate::fem::stress_measures::{stress_quantity, stress_quantity_gradient};
use crate::fem::ElementStress;
use crate::regions::{AreaRegion, CriteriaGeometry};
use crate::scene::{Criterion, DefinedQuantity, SceneError};

/// One entry per kind of criterion (Φ1..Φ6, the defined ones), indexed by `criterion as usize`.
pub type PerCriterion<T> = [T; Criterion::COUNT];

/// The fields a criterion evaluation can use.
pub struct Fields<'a> {
    /// Nodal temperature \[K\], for Φ1 and Φ2 (`None`: not solved).
    pub temperature: Option<&'a [f64]>,
    /// Nodal displacement (x, y) \[m\], for Φ3 and Φ4 (`None`: not solved).
    pub displacement: Option<&'a [[f64; 2]]>,
    /// Element stresses, for Φ5 and Φ6 (`None`: not solved).
    pub stresses: Option<&'a [ElementStress]>,
    /// Contact multipliers by row of B, for the defined contact tractions (`None`: not solved).
    pub multipliers: Option<&'a [f64]>,
    /// Nodal velocity (x, y) \[m/s\], for a receiver's peak velocity (`None`: a static state,
    /// at rest).
    pub velocity: Option<&'a [[f64; 2]]>,
}

/// A linear form on (temperature, displacement, stresses, multipliers): Σ t_n T_n + Σ a_n·u_n +
/// Σ g_e·τ_e + Σ c_r λ_r, with τ_e = (τ11, τ22, τ12, τ33) and λ_r the contact multiplier of row r.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinearForm {
    /// (node, coefficient of T_node).
    pub temperature: Vec<(usize, f64)>,
    /// (node, coefficients of u_node in global x, y).
    pub displacement: Vec<(usize, [f64; 2])>,
    /// (element, coefficients of its stress components).
    pub stresses: Vec<(usize, [f64; 4])>,
    /// (row of B, coefficient of its contact multiplier).
    pub multipliers: Vec<(usize, f64)>,
    /// (node, coefficients of v_node in global x, y).
    pub velocity: Vec<(usize, [f64; 2])>,
}

impl LinearForm {
    /// The form's value on `fields` (a missing field contributes nothing).
    pub fn apply(&self, fields: &Fields) -> f64 {
        let temperature = fields.temperature.map_or(0.0, |t| {
            self.temperature.iter().map(|&(i, w)| w * t[i]).sum()
        });
        let displacement = fields.displacement.map_or(0.0, |u| {
            self.displacement
                .iter()
                .map(|&(i, a)| a[0] * u[i][0] + a[1] * u[i][1])
                .sum()
        });
        let stresses = fields.stresses.map_or(0.0, |s| {
            self.stresses
                .iter()
                .map(|&(e, g)| (0..4).map(|k| g[k] * s[e].stress[k]).sum::<f64>())
                .sum()
        });
        let multipliers = fields.multipliers.map_or(0.0, |l| {
            self.multipliers.iter().map(|&(r, c)| c * l[r]).sum()
        });
        let velocity = fields.velocity.map_or(0.0, |v| {
            self.velocity
                .iter()
                .map(|&(i, a)| a[0] * v[i][0] + a[1] * v[i][1])
                .sum()
        });
        temperature + displacement + stresses + multipliers + velocity
    }

    /// Whether the form reads the displacement, the stresses, the contact multipliers or the
    /// velocity.
    pub fn is_mechanical(&self) -> bool {
        !self.displacement.is_empty()
            || !self.stresses.is_empty()
            || !self.multipliers.is_empty()
            || !self.velocity.is_empty()
    }
}

/// −n·τ·n as a form on (τ11, τ22, τ12, τ33), scaled by `w`.
fn normal_pressure([n0, n1]: [f64; 2], w: f64) -> [f64; 4] {
    [-w * n0 * n0, -w * n1 * n1, -2.0 * w * n0 * n1, 0.0]
}

/// The regions behind each Φ: indices into `geometry.regions` (Φ1, Φ3, Φ5, Φ6) or
/// `geometry.pieces` (Φ2, Φ4), in the order of the region values and forms below — all areas for
/// Φ1 and Φ5, the areas with a normal for Φ3, those of them next to a contact zone for Φ6, all
/// pieces for Φ2 and Φ4 (FGCS 4.29–4.34).
pub fn family(geometry: &CriteriaGeometry, criterion: Criterion) -> Vec<usize> {
    let areas = |keep: &dyn Fn(&AreaRegion) -> bool| -> Vec<usize> {
        (0..geometry.regions.len())
            .filter(|&r| keep(&geometry.regions[r]))
            .collect()
    };
    match criterion {
        Criterion::Phi1 | Criterion::Phi5 => areas(&|_| true),
        Criterion::Phi3 => areas(&|r| r.normal.is_some()),
        Criterion::Phi6 => areas(&|r| r.normal.is_some() && r.adjacent_to_contact),
        Criterion::Phi2 | Criterion::Phi4 => (0..geometry.pieces.len()).collect(),
        Criterion::Defined => (0..geometry.defined.len()).collect(),
    }
}

/// The name of the `index`-th region of Φ's family.
pub fn region_name(geometry: &CriteriaGeometry, criterion: Criterion, index: usize) -> &str {
    let member = family(geometry, criterion)[index];
    match criterion {
        Criterion::Phi2 | Criterion::Phi4 => &geometry.pieces[member].name,
        Criterion::Defined => &geometry.defined[member].name,
        _ => &geometry.regions[member].name,
    }
}

/// The derivative forms of the region values of Φ1..Φ6 and the defined criteria (empty where the
/// field or a suitable region is missing), per kind in the order of its [`family`]. The forms of
/// Φ5 and of the nonlinear defined quantities linearise them at `fields.stresses`.
pub fn region_forms(geometry: &CriteriaGeometry, fields: &Fields) -> PerCriterion<Vec<LinearForm>> {
    let mut out: PerCriterion<Vec<LinearForm>> = Default::default();
    let areas = |c: Criterion| -> Vec<&AreaRegion> {
        family(geometry, c)
            .into_iter()
            .map(|r| &geometry.regions[r])
            .collect()
    };
    if fields.temperature.is_some() {
        let of = |weights: &[(usize, f64)]| LinearForm {
            temperature: weights.to_vec(),
            ..LinearForm::default()
        };
        out[0] = areas(Criterion::Phi1)
            .into_iter()
            .map(|r| of(&r.node_weights))
            .collect();
        out[1] = geometry
            .pieces
            .iter()
            .map(|p| of(&p.node_weights))
            .collect();
    }
    if fields.displacement.is_some() {
        let along = |weights: &[(usize, f64)], n: [f64; 2]| LinearForm {
            displacement: weights
                .iter()
                .map(|&(i, w)| (i, [w * n[0], w * n[1]]))
                .collect(),
            ..LinearForm::default()
        };
        out[2] = areas(Criterion::Phi3)
            .into_iter()
            .filter_map(|r| r.normal.map(|n| along(&r.node_weights, n)))
            .collect();
        out[3] = geometry
            .pieces
            .iter()
            .map(|p| along(&p.node_weights, p.normal))
            .collect();
    }
    if let Some(s) = fields.stresses {
        let unit = |k: usize| std::array::from_fn::<f64, 4, _>(|j| f64::from(u8::from(j == k)));
        out[4] = areas(Criterion::Phi5)
            .into_iter()
            .map(|r| LinearForm {
                stresses: r
                    .element_weights
                    .iter()
                    .map(|&(e, w)| {
                        (
                            e,
                            std::array::from_fn(|k| 2.0 * w * i2_bilinear(s[e].stress, unit(k))),
                        )
                    })
                    .collect(),
                ..LinearForm::default()
            })
            .collect();
        out[5] = areas(Criterion::Phi6)
            .into_iter()
            .filter_map(|r| {
                r.normal.map(|n| LinearForm {
                    stresses: r
                        .element_weights
                        .iter()
                        .map(|&(e, w)| (e, normal_pressure(n, w)))
                        .collect(),
                    ..LinearForm::default()
                })
            })
            .collect();
        out[Criterion::Defined as usize] = geometry
            .defined
            .iter()
            .map(|d| {
                if d.quantity.is_contact() {
                    return LinearForm {
                        multipliers: d.multipliers.clone(),
                        ..LinearForm::default()
                    };
                }
                if d.quantity.is_receiver() {
                    return speed_form(&d.receiver, fields.velocity);
                }
                LinearForm {
                    stresses: geometry.regions[d.region]
                        .element_weights
                        .iter()
                        .filter_map(|&(e, w)| {
                            let g = stress_quantity_gradient(d.quantity, s[e].stress)?;
                            Some((e, g.map(|g| w * g)))
                        })
                        .collect(),
                    ..LinearForm::default()
                }
            })
            .collect();
    }
    out
}

/// The velocity at a receiver, Σ_i φ_i v_i over its P1 `weights` (zero without a velocity
/// field: a static state is at rest).
pub fn receiver_velocity(weights: &[(usize, f64)], velocity: Option<&[[f64; 2]]>) -> [f64; 2] {
    velocity.map_or([0.0; 2], |v| {
        weights.iter().fold([0.0; 2], |acc, &(i, w)| {
            [acc[0] + w * v[i][0], acc[1] + w * v[i][1]]
        })
    })
}

/// The derivative form of the speed |v(x_r)| at a receiver: (v/|v|)·dv(x_r), on the velocity
/// field; empty where v(x_r) = 0 (|v| has no derivative there, only one-sided ones, |dv(x_r)|
/// along any direction, which the caller takes).
fn speed_form(weights: &[(usize, f64)], velocity: Option<&[[f64; 2]]>) -> LinearForm {
    let v = receiver_velocity(weights, velocity);
    let speed = v[0].hypot(v[1]);
    if speed == 0.0 {
        return LinearForm::default();
    }
    LinearForm {
        velocity: weights
            .iter()
            .map(|&(i, w)| (i, [w * v[0] / speed, w * v[1] / speed]))
            .collect(),
        ..LinearForm::default()
    }
}

/// Sets the multiplier forms of the defined contact tractions (`super::solution::piece_traction_rows`)
/// once the contact pairs are known; an error naming the criterion when a node of its piece is
/// in no contact pair (e.g. a piece on a mortar master segment).
pub(crate) fn attach_contact_rows(
    geometry: &mut CriteriaGeometry,
    contact: &ContactGeometry,
    n_nodes: usize,
) -> Result<(), SceneError> {
    let pair = pair_of_node(contact, n_nodes);
    for (k, d) in geometry.defined.iter_mut().enumerate() {
        if !d.quantity.is_contact() {
            continue;
        }
        let piece = &geometry.pieces[d.region];
        let pressure = d.quantity == DefinedQuantity::ContactPressure;
        d.multipliers = piece_traction_rows(piece, contact, &pair, pressure).ok_or_else(|| {
            SceneError::new(
                format!("criteria.defined[{k}].region"),
                format!(
                    "boundary piece '{}' has nodes in no contact pair (a piece on a mortar zone's master side has no multipliers)",
                    piece.name
                ),
            )
        })?;
    }
    Ok(())
}

fn max_of(values: &[f64]) -> Option<f64> {
    values
        .iter()
        .fold(None, |m: Option<f64>, &v| Some(m.map_or(v, |m| m.max(v))))
}

/// Φ1..Φ6 (None where the field or a suitable region is missing) from the region values of
/// [`per_region`]: the largest of each; `None` for the defined criteria, which have no maximum.
pub fn maxima(region_values: &PerCriterion<Vec<f64>>) -> PerCriterion<Option<f64>> {
    std::array::from_fn(|i| {
        (i != Criterion::Defined as usize)
            .then(|| max_of(&region_values[i]))
            .flatten()
    })
}

/// The index (in its [`family`]) of the region whose value is the largest, the first of ties.
pub fn attaining(values: &[f64]) -> Option<usize> {
    let max = max_of(values)?;
    values.iter().position(|&v| v == max)
}

/// The region values behind each Φ_i (the maximum over them is Φ_i): the linear criteria are
/// their forms applied to the fields, Φ5 the mean of I2², a defined criterion the mean of its
/// stress quantity.
pub fn per_region(geometry: &CriteriaGeometry, fields: &Fields) -> PerCriterion<Vec<f64>> {
    per_region_with(geometry, fields, &region_forms(geometry, fields))
}

/// [`per_region`] with the forms of `region_forms(geometry, fields)` already at hand.
pub fn per_region_with(
    geometry: &CriteriaGeometry,
    fields: &Fields,
    forms: &PerCriterion<Vec<LinearForm>>,
) -> PerCriterion<Vec<f64>> {
    const DEFINED: usize = Criterion::Defined as usize;
    std::array::from_fn(|i| match (i, fields.stresses) {
        (DEFINED, Some(s)) => geometry
            .defined
            .iter()
            .zip(&forms[DEFINED])
            .map(|(d, form)| {
                if d.quantity.is_contact() {
                    return form.apply(fields);
                }
                if d.quantity.is_receiver() {
                    let v = receiver_velocity(&d.receiver, fields.velocity);
                    return v[0].hypot(v[1]);
                }
                geometry.regions[d.region]
                    .element_weights
                    .iter()
                    .filter_map(|&(e, w)| Some(w * stress_quantity(d.quantity, s[e].stress)?))
                    .sum()
            })
            .collect(),
        (4, Some(s)) => geometry
            .regions
            .iter()
            .map(|r| {
                r.element_weights
                    .iter()
                    .map(|&(e, w)| w * s[e].i2_squared())
                    .sum()
            })
            .collect(),
        _ => forms[i].iter().map(|f| f.apply(fields)).collect(),
    })
}
