//! Criteria Φ1–Φ6 of a solution (design §4.2, FGCS 4.29–4.34): exact means over the user's areas
//! G_r and boundary pieces G'_r, maximised over r.
//!
//! Φ1 = max_r mean_{G_r} T,  Φ2 = max_r mean_{G'_r} T,  Φ3 = max_r mean_{G_r} u·n(X_r),
//! Φ4 = max_r mean_{G'_r} u·n(X_r),  Φ5 = max_r mean_{G_r} I2²(τ),  Φ6 = max_r mean_{G_r} (−τ_n)
//! with τ_n = n(X_r)·τ·n(X_r); Φ3 over the regions that have a normal, Φ6 over those of them that
//! touch a contact zone (G_r adjacent to Γc, FGCS 4.34). The region weights are
//! normalised (they sum to one), so a mean is a weighted sum of nodal or element values.

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

fn max_of(values: impl Iterator<Item = f64>) -> Option<f64> {
    values.fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))
}

/// Φ1..Φ6 (None where the field or a suitable region is missing).
pub fn evaluate(geometry: &CriteriaGeometry, fields: &Fields) -> [Option<f64>; 6] {
    let mut out = [None; 6];
    if let Some(t) = fields.temperature {
        out[0] = max_of(
            geometry
                .regions
                .iter()
                .map(|r| mean(&r.node_weights, |i| t[i])),
        );
        out[1] = max_of(
            geometry
                .pieces
                .iter()
                .map(|p| mean(&p.node_weights, |i| t[i])),
        );
    }
    if let Some(u) = fields.displacement {
        let along = |n: [f64; 2]| move |i: usize| u[i][0] * n[0] + u[i][1] * n[1];
        out[2] = max_of(
            geometry
                .regions
                .iter()
                .filter_map(|r| r.normal.map(|n| mean(&r.node_weights, along(n)))),
        );
        out[3] = max_of(
            geometry
                .pieces
                .iter()
                .map(|p| mean(&p.node_weights, along(p.normal))),
        );
    }
    if let Some(s) = fields.stresses {
        out[4] = max_of(
            geometry
                .regions
                .iter()
                .map(|r| mean(&r.element_weights, |e| s[e].i2_squared())),
        );
        out[5] = max_of(geometry.regions.iter().filter_map(|r| {
            r.normal.filter(|_| r.adjacent_to_contact).map(|n| {
                mean(&r.element_weights, |e| {
                    let [s11, s22, s12, _] = s[e].stress;
                    -(n[0] * n[0] * s11 + 2.0 * n[0] * n[1] * s12 + n[1] * n[1] * s22)
                })
            })
        }));
    }
    out
}
