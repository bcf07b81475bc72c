//! Warnings about a valid scene's data (design §5.2): things that are allowed but probably not
//! meant, each with the JSON path and the value. The front door puts them first among the
//! warnings of `wsm solve` (the solver report) and of a run (its result).
//!
//! - An uncertain datum addressed by the index of a boundary condition or contact zone that has
//!   a name ([`super::params::index_path_warnings`]): inserting an entry would move it.
//! - Magnitudes no solid or load has, usually a unit slip (MPa or GPa typed as Pa, mm as m):
//!   a Young's modulus (given, derived from λ and μ, or an orthotropic E_i) below
//!   [`MIN_SOLID_MODULUS`], a prescribed displacement longer than the model's extent (the
//!   diagonal of the bodies' bounding box), a specific weight above [`MAX_SPECIFIC_WEIGHT`] and a
//!   pressure or traction above [`MAX_SURFACE_LOAD`] — nominal values and interval ends alike.

use std::collections::BTreeSet;

use super::model::{Material, Scene};
use super::params::{index_path_warnings, parameters, ParamTarget};
use super::warning::{Warning, WarningKind};

/// Young's moduli below this \[Pa\] are softer than any solid (soft rubber is about 1e6 Pa).
pub const MIN_SOLID_MODULUS: f64 = 1e5;
/// Specific weights above this \[N/m³\] are heavier than any material (osmium: 2.2e5 N/m³).
pub const MAX_SPECIFIC_WEIGHT: f64 = 1e6;
/// Pressures and tractions above this \[Pa\] are far beyond what structures carry
/// (high-strength steel yields near 2e9 Pa).
pub const MAX_SURFACE_LOAD: f64 = 1e10;

/// The warnings about `scene`'s data (empty for a plausible scene).
pub fn warnings(scene: &Scene) -> Vec<Warning> {
    let mut out = index_path_warnings(scene);
    let extent = extent(scene);
    let used = scene.used_materials();
    for (name, m) in &scene.materials {
        if used.contains(name.as_str()) {
            out.extend(material_warnings(&format!("materials.{name}"), m));
        }
    }
    for (i, bc) in scene.boundary.iter().enumerate() {
        let path = format!("boundary[{i}]");
        for (c, d) in bc.displacement.iter().flatten().enumerate() {
            out.extend(d.and_then(|d| far(&format!("{path}.displacement[{c}]"), d, extent)));
        }
        for (c, t) in bc.traction.iter().flatten().enumerate() {
            out.extend(huge_load(&format!("{path}.traction[{c}]"), *t));
        }
        out.extend(
            bc.pressure
                .and_then(|p| huge_load(&format!("{path}.pressure"), p)),
        );
    }
    out.extend(interval_warnings(scene, &used, extent));
    out
}

/// Moduli and the specific weight of one used material.
fn material_warnings(path: &str, m: &Material) -> Vec<Warning> {
    let mut out = Vec::new();
    if let Some(e) = m.young {
        out.extend(soft(&format!("{path}.E"), e, ""));
    }
    if let (Some(lambda), Some(mu)) = (m.lambda, m.mu) {
        let e = mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu);
        out.extend(soft(
            &format!("{path}.mu"),
            e,
            " (E = μ(3λ + 2μ)/(λ + μ) of its lambda and mu)",
        ));
    }
    for (field, e) in [("E1", m.e1), ("E2", m.e2), ("E3", m.e3)] {
        out.extend(e.and_then(|e| soft(&format!("{path}.{field}"), e, "")));
    }
    out.extend(
        m.specific_weight
            .and_then(|w| heavy(&format!("{path}.specific_weight"), w)),
    );
    out
}

/// The interval ends of uncertain moduli, displacements, specific weights and surface loads.
fn interval_warnings(scene: &Scene, used: &BTreeSet<&str>, extent: f64) -> Vec<Warning> {
    let Ok(parameters) = parameters(scene) else {
        return Vec::new();
    };
    let material_used = |m: usize| {
        scene
            .materials
            .keys()
            .nth(m)
            .is_some_and(|name| used.contains(name.as_str()))
    };
    let mut out = Vec::new();
    for (i, p) in parameters.iter().enumerate() {
        let path = format!("uncertain[{i}].interval");
        for (target, lo, hi) in p.field_intervals() {
            let largest = lo.abs().max(hi.abs());
            out.extend(match target {
                ParamTarget::Young(m) | ParamTarget::OrthotropicYoung(m, _) if material_used(m) => {
                    soft(&path, lo, "")
                }
                ParamTarget::SpecificWeight(m) if material_used(m) => heavy(&path, hi),
                ParamTarget::Displacement(..) => far(&path, largest, extent),
                ParamTarget::Pressure(_) | ParamTarget::Traction(..) => huge_load(&path, largest),
                _ => None,
            });
        }
    }
    out
}

fn soft(path: &str, e: f64, how: &str) -> Option<Warning> {
    (e < MIN_SOLID_MODULUS).then(|| {
        units(
            path,
            format!(
                "a Young's modulus of {e:e} Pa{how} is below {MIN_SOLID_MODULUS:e} Pa, softer \
             than any solid (soft rubber is about 1e6 Pa, concrete 3e10 Pa); moduli are in Pa, \
             not MPa or GPa"
            ),
        )
    })
}

fn far(path: &str, d: f64, extent: f64) -> Option<Warning> {
    (d.abs() > extent).then(|| {
        units(
            path,
            format!(
                "a prescribed displacement of {d:e} m is larger than the whole model (the \
             diagonal of its bounding box is {extent:e} m); displacements are in m, not mm"
            ),
        )
    })
}

fn heavy(path: &str, w: f64) -> Option<Warning> {
    (w > MAX_SPECIFIC_WEIGHT).then(|| {
        units(
            path,
            format!("a specific weight of {w:e} N/m³ is above {MAX_SPECIFIC_WEIGHT:e} N/m³, \
             heavier than any material (steel is about 7.7e4 N/m³); it is ρg in N/m³, e.g. 2.4e4 for \
             concrete"),
        )
    })
}

fn huge_load(path: &str, p: f64) -> Option<Warning> {
    (p.abs() > MAX_SURFACE_LOAD).then(|| {
        units(
            path,
            format!(
                "a surface load of {p:e} Pa is above {MAX_SURFACE_LOAD:e} Pa, far beyond \
             what structures carry (high-strength steel yields near 2e9 Pa); loads are in Pa"
            ),
        )
    })
}

/// A [`WarningKind::Units`] warning about the number at `path`.
fn units(path: &str, message: String) -> Warning {
    Warning::new(WarningKind::Units, path, message)
}

/// The diagonal of the bounding box of the bodies' zones \[m\].
fn extent(scene: &Scene) -> f64 {
    let points = scene
        .bodies
        .iter()
        .flat_map(|b| &b.zones)
        .flat_map(|z| &z.polygon);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (hi[0] - lo[0]).hypot(hi[1] - lo[1])
}
