//! Criteria Φ1–Φ6 of a solution (design §4.2, FGCS 4.29–4.34): exact means over the user's areas
//! G_r and boundary pieces G'_r, maximised over r.
//!
//! Φ1 = max_r mean_{G_r} T,  Φ2 = max_r mean_{G'_r} T,  Φ3 = max_r mean_{G_r} u·n(X_r),
//! Φ4 = max_r mean_{G'_r} u·n(X_r),  Φ5 = max_r mean_{G_r} I2²(τ),  Φ6 = max_r mean_{G_r} (−τ_n)
//! with τ_n = n(X_r)·τ·n(X_r); Φ3 over the regions that have a normal, Φ6 over those of them that
//! touch a contact zone (G_r adjacent to Γc, FGCS 4.34). The region weights are
//! normalised (they sum to one), so a mean is a weighted sum of nodal or element values.

use crate::fem::stress::i2_bilinear;
use crate::fem::ElementStress;
use crate::regions::CriteriaGeometry;

/// The fields a criterion evaluation can use.
pub struct Fields<'a> {
    /// Nodal temperature \[K\], for Φ1 and Φ2 (`None`: not solved).
    pub temperature: Option<&'a [f64]>,
    /// Nodal displacement (x, y) \[m\], for Φ3 and Φ4 (`None`: not solved).
    pub displacement: Option<&'a [[f64; 2]]>,
    /// Element stresses, for Φ5 and Φ6 (`None`: not solved).
    pub stresses: Option<&'a [ElementStress]>,
}

fn mean(weights: &[(usize, f64)], f: impl Fn(usize) -> f64) -> f64 {
    weights.iter().map(|&(i, w)| w * f(i)).sum()
}

fn max_of(values: &[f64]) -> Option<f64> {
    values
        .iter()
        .fold(None, |m: Option<f64>, &v| Some(m.map_or(v, |m| m.max(v))))
}

/// The region values of Φ1..Φ6 (empty where the field or a suitable region is missing), with
/// `i2_of(e)` the element value used for Φ5 (I2² for the criteria, its derivative for the
/// sensitivities); the other criteria are linear in the fields.
fn region_values(
    geometry: &CriteriaGeometry,
    fields: &Fields,
    i2_of: &dyn Fn(usize) -> f64,
) -> [Vec<f64>; 6] {
    let mut out: [Vec<f64>; 6] = Default::default();
    if let Some(t) = fields.temperature {
        out[0] = geometry
            .regions
            .iter()
            .map(|r| mean(&r.node_weights, |i| t[i]))
            .collect();
        out[1] = geometry
            .pieces
            .iter()
            .map(|p| mean(&p.node_weights, |i| t[i]))
            .collect();
    }
    if let Some(u) = fields.displacement {
        let along = |n: [f64; 2]| move |i: usize| u[i][0] * n[0] + u[i][1] * n[1];
        out[2] = geometry
            .regions
            .iter()
            .filter_map(|r| r.normal.map(|n| mean(&r.node_weights, along(n))))
            .collect();
        out[3] = geometry
            .pieces
            .iter()
            .map(|p| mean(&p.node_weights, along(p.normal)))
            .collect();
    }
    if let Some(s) = fields.stresses {
        out[4] = geometry
            .regions
            .iter()
            .map(|r| mean(&r.element_weights, i2_of))
            .collect();
        out[5] = geometry
            .regions
            .iter()
            .filter_map(|r| {
                r.normal.filter(|_| r.adjacent_to_contact).map(|n| {
                    mean(&r.element_weights, |e| {
                        let [s11, s22, s12, _] = s[e].stress;
                        -(n[0] * n[0] * s11 + 2.0 * n[0] * n[1] * s12 + n[1] * n[1] * s22)
                    })
                })
            })
            .collect();
    }
    out
}

/// Φ1..Φ6 (None where the field or a suitable region is missing).
pub fn evaluate(geometry: &CriteriaGeometry, fields: &Fields) -> [Option<f64>; 6] {
    per_region(geometry, fields).map(|values| max_of(&values))
}

/// The region values behind each Φ_i (the maximum over them is Φ_i).
pub fn per_region(geometry: &CriteriaGeometry, fields: &Fields) -> [Vec<f64>; 6] {
    let i2 = |e: usize| fields.stresses.map_or(0.0, |s| s[e].i2_squared());
    region_values(geometry, fields, &i2)
}

/// The derivatives of the region values along the tangent fields `tangent` (the derivatives of
/// temperature, displacement and stresses): the region values of the tangent fields for the
/// linear criteria, 2 mean B(τ, dτ) for Φ5 (B the bilinear form of I2²).
pub fn region_derivatives(
    geometry: &CriteriaGeometry,
    fields: &Fields,
    tangent: &Fields,
) -> [Vec<f64>; 6] {
    let i2 = |e: usize| match (fields.stresses, tangent.stresses) {
        (Some(s), Some(ds)) => 2.0 * i2_bilinear(s[e].stress, ds[e].stress),
        _ => 0.0,
    };
    region_values(geometry, tangent, &i2)
}
