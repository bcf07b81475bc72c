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

use crate::fem::stress::i2_bilinear;
use crate::fem::ElementStress;
use crate::regions::{AreaRegion, CriteriaGeometry};
use crate::scene::Criterion;

/// The fields a criterion evaluation can use.
pub struct Fields<'a> {
    /// Nodal temperature \[K\], for Φ1 and Φ2 (`None`: not solved).
    pub temperature: Option<&'a [f64]>,
    /// Nodal displacement (x, y) \[m\], for Φ3 and Φ4 (`None`: not solved).
    pub displacement: Option<&'a [[f64; 2]]>,
    /// Element stresses, for Φ5 and Φ6 (`None`: not solved).
    pub stresses: Option<&'a [ElementStress]>,
}

/// A linear form on (temperature, displacement, stresses): Σ t_n T_n + Σ a_n·u_n + Σ g_e·τ_e,
/// with τ_e = (τ11, τ22, τ12, τ33).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinearForm {
    /// (node, coefficient of T_node).
    pub temperature: Vec<(usize, f64)>,
    /// (node, coefficients of u_node in global x, y).
    pub displacement: Vec<(usize, [f64; 2])>,
    /// (element, coefficients of its stress components).
    pub stresses: Vec<(usize, [f64; 4])>,
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
        temperature + displacement + stresses
    }

    /// Whether the form reads the displacement or the stresses.
    pub fn is_mechanical(&self) -> bool {
        !self.displacement.is_empty() || !self.stresses.is_empty()
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
    }
}

/// The name of the `index`-th region of Φ's family.
pub fn region_name(geometry: &CriteriaGeometry, criterion: Criterion, index: usize) -> &str {
    let member = family(geometry, criterion)[index];
    match criterion {
        Criterion::Phi2 | Criterion::Phi4 => &geometry.pieces[member].name,
        _ => &geometry.regions[member].name,
    }
}

/// The derivative forms of the region values of Φ1..Φ6 (empty where the field or a suitable
/// region is missing), per Φ in the order of its [`family`]. The forms of Φ5 linearise I2² at
/// `fields.stresses`.
pub fn region_forms(geometry: &CriteriaGeometry, fields: &Fields) -> [Vec<LinearForm>; 6] {
    let mut out: [Vec<LinearForm>; 6] = Default::default();
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
    }
    out
}

fn max_of(values: &[f64]) -> Option<f64> {
    values
        .iter()
        .fold(None, |m: Option<f64>, &v| Some(m.map_or(v, |m| m.max(v))))
}

/// Φ1..Φ6 (None where the field or a suitable region is missing) from the region values of
/// [`per_region`]: the largest of each.
pub fn maxima(region_values: &[Vec<f64>; 6]) -> [Option<f64>; 6] {
    region_values.each_ref().map(|values| max_of(values))
}

/// The index (in its [`family`]) of the region whose value is the largest, the first of ties.
pub fn attaining(values: &[f64]) -> Option<usize> {
    let max = max_of(values)?;
    values.iter().position(|&v| v == max)
}

/// The region values behind each Φ_i (the maximum over them is Φ_i): the linear criteria are
/// their forms applied to the fields, Φ5 the mean of I2².
pub fn per_region(geometry: &CriteriaGeometry, fields: &Fields) -> [Vec<f64>; 6] {
    per_region_with(geometry, fields, &region_forms(geometry, fields))
}

/// [`per_region`] with the forms of `region_forms(geometry, fields)` already at hand.
pub fn per_region_with(
    geometry: &CriteriaGeometry,
    fields: &Fields,
    forms: &[Vec<LinearForm>; 6],
) -> [Vec<f64>; 6] {
    std::array::from_fn(|i| match (i, fields.stresses) {
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
