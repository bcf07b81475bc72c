//! Validation of a scene before any work (design §5.2): every error names the JSON path of the
//! offending field and the reason. Geometric checks that need the mesh (segments on the boundary,
//! matching contact nodes, overlapping zones) are done by the mesher with the same error type.

use super::law;
use super::model::*;
use super::params::{check_interval_matrices, resolve_all, unaddressable, ParamTarget, Parameter};
use super::planar::{orient, signed_area2};
use super::rules::Constant;
use super::shape::{array_read_as_object, objects_where_objects, plain_message};
use super::strict::{strict_value, StrictError};
use super::SceneError;
use std::collections::BTreeSet;

/// Parse a scene from JSON text; parse errors carry the JSON path, and an object that repeats a
/// key is refused naming it (as the service refuses it, [`strict_value`]).
pub fn parse(text: &str) -> Result<Scene, SceneError> {
    let located = |e: serde_path_to_error::Error<serde_json::Error>| {
        let path = e.path().to_string();
        let path = if path == "." { String::from("$") } else { path };
        SceneError::new(path, plain_message(&e.into_inner().to_string()))
    };
    let de = &mut serde_json::Deserializer::from_str(text);
    let value = strict_value(de).map_err(|e| match e {
        StrictError::Syntax { path, message } => SceneError::new(path, plain_message(&message)),
        repeated => SceneError::new(repeated.path(), repeated.reason()),
    })?;
    check_sizes(&value, &mut String::new())?;
    let scene: Scene = serde_path_to_error::deserialize(value.clone()).map_err(|e| {
        array_read_as_object::<Scene>(&value, e.path()).unwrap_or_else(|| located(e))
    })?;
    objects_where_objects(&value, &scene)?;
    validate(&scene)?;
    Ok(scene)
}

/// Items accepted in any one list of a scene document (polygons are bounded together by
/// [`MAX_VERTICES`] as well).
pub const MAX_LIST: usize = MAX_VERTICES;

/// Characters accepted in any other string of a scene document (a description, a field path, a
/// reference to a name).
pub const MAX_TEXT: usize = 1000;

/// Characters accepted in any name of a scene document — the scene's `name`, the `name` of an
/// entry, a key (material, segment): names are echoed in results, job listings and messages.
pub const MAX_NAME: usize = 200;

/// Refuse any list longer than [`MAX_LIST`], any name (a `name` member or a key) longer than
/// [`MAX_NAME`] and any other string longer than [`MAX_TEXT`], naming the first (`path` is the
/// JSON path so far, as serde_path_to_error writes it).
fn check_sizes(value: &serde_json::Value, path: &mut String) -> Result<(), SceneError> {
    let here = |path: &str| {
        if path.is_empty() {
            "$".to_string()
        } else {
            path.to_string()
        }
    };
    match value {
        serde_json::Value::Array(items) => {
            if items.len() > MAX_LIST {
                return Err(SceneError::new(
                    here(path),
                    format!("{} items; at most {MAX_LIST} are accepted", items.len()),
                ));
            }
            for (i, item) in items.iter().enumerate() {
                let len = path.len();
                path.push_str(&format!("[{i}]"));
                check_sizes(item, path)?;
                path.truncate(len);
            }
        }
        serde_json::Value::Object(members) => {
            for (key, member) in members {
                let len = path.len();
                if !path.is_empty() {
                    path.push('.');
                }
                if key.chars().count() > MAX_NAME {
                    return Err(SceneError::new(
                        here(path).trim_end_matches('.').to_string(),
                        format!(
                            "a key (a name) of {} characters; a name has at most {MAX_NAME}",
                            key.chars().count()
                        ),
                    ));
                }
                path.push_str(key);
                match member {
                    serde_json::Value::String(name)
                        if key == "name" && name.chars().count() > MAX_NAME =>
                    {
                        return Err(SceneError::new(
                            path.clone(),
                            format!(
                                "{} characters; a name has at most {MAX_NAME} (it is shown in \
                                 results, job listings and messages)",
                                name.chars().count()
                            ),
                        ));
                    }
                    _ => check_sizes(member, path)?,
                }
                path.truncate(len);
            }
        }
        serde_json::Value::String(text) if text.chars().count() > MAX_TEXT => {
            return Err(SceneError::new(
                here(path),
                format!("{} characters; at most {MAX_TEXT}", text.chars().count()),
            ));
        }
        _ => {}
    }
    Ok(())
}

/// Check the meaning of a parsed scene.
pub fn validate(scene: &Scene) -> Result<(), SceneError> {
    if scene.version != 1 {
        return Err(SceneError::new("version", "only version 1 is supported"));
    }
    check_vertex_count(scene)?;
    check_bodies(scene)?;
    check_materials(scene)?;
    check_segments(scene)?;
    check_boundary(scene)?;
    check_contacts(scene)?;
    check_mesh(&scene.mesh, scene)?;
    check_element(scene)?;
    check_criteria(scene)?;
    check_search(scene)?;
    super::dynamics::check_dynamics(scene)?;
    let parameters = resolve_all(scene)?;
    check_interval_matrices(scene, &parameters)?;
    check_stiffness_ratio(scene, &parameters)
}

/// The stiffest modulus (λ + 2μ) of a scene's materials divided by the softest (μ), over the
/// whole box of uncertain data, may not exceed this. Beyond it the round-off of the stiff
/// zones' entries swamps the soft zones' in one system (a 1e18 ratio in one body stops the
/// Cholesky factorisation; 1e16 still solves): refused as bad input rather than failing the
/// solver. It bounds soft inclusions and nearly incompressible materials (ν up to about
/// 0.5 − 1e-12) alike.
pub const MAX_STIFFNESS_RATIO: f64 = 1e12;

/// The material moduli at the corners of their intervals, the stiffest and the softest against
/// [`MAX_STIFFNESS_RATIO`].
fn check_stiffness_ratio(scene: &Scene, parameters: &[Parameter]) -> Result<(), SceneError> {
    let used = scene.used_materials();
    // (material, constant varied when soft) at the stiffest and softest corner.
    let mut stiffest: Option<(f64, &str)> = None;
    let mut softest: Option<(f64, &str, &str)> = None;
    for (index, (name, m)) in scene.materials.iter().enumerate() {
        if !used.contains(name.as_str()) {
            continue;
        }
        let range = |target: ParamTarget, nominal: f64| {
            parameters
                .iter()
                .flat_map(Parameter::field_intervals)
                .filter(|f| f.0 == target)
                .fold((nominal, nominal), |(lo, hi), f| (lo.min(f.1), hi.max(f.2)))
        };
        let (corners, soft_field) = match (m.young, m.nu, m.lambda, m.mu) {
            (Some(e), Some(nu), _, _) => {
                let (e, nu) = (
                    range(ParamTarget::Young(index), e),
                    range(ParamTarget::Poisson(index), nu),
                );
                let corners = [(e.0, nu.0), (e.0, nu.1), (e.1, nu.0), (e.1, nu.1)];
                (
                    corners.map(|(e, nu)| law::lame_from_young(e, nu)).to_vec(),
                    "E",
                )
            }
            (_, _, Some(l), Some(mu)) => {
                let (l, mu) = (
                    range(ParamTarget::Lambda(index), l),
                    range(ParamTarget::Mu(index), mu),
                );
                (
                    vec![(l.0, mu.0), (l.0, mu.1), (l.1, mu.0), (l.1, mu.1)],
                    "mu",
                )
            }
            // Anisotropic laws at their nominal values: the plane-strain bulk and shear moduli
            // play λ + μ and μ.
            _ => match super::data::Data::material(m).elastic.law() {
                Some(law) => {
                    let (bulk, shear) = law.bulk_and_shear();
                    let field = if m.matrix.is_some() { "matrix" } else { "G12" };
                    (vec![(bulk - shear, shear)], field)
                }
                None => continue, // refused by check_materials
            },
        };
        for (lambda, mu) in corners {
            if stiffest.is_none_or(|(s, _)| lambda + 2.0 * mu > s) {
                stiffest = Some((lambda + 2.0 * mu, name));
            }
            if softest.is_none_or(|(s, _, _)| mu < s) {
                softest = Some((mu, name, soft_field));
            }
        }
    }
    let (Some((stiff, stiff_name)), Some((soft, soft_name, soft_field))) = (stiffest, softest)
    else {
        return Ok(());
    };
    if stiff <= MAX_STIFFNESS_RATIO * soft {
        return Ok(());
    }
    let (path, what) = if stiff_name == soft_name {
        let field = match soft_field {
            "E" => "nu",
            "mu" => "lambda",
            other => other,
        };
        (
            format!("materials.{soft_name}.{field}"),
            format!("material '{soft_name}' is nearly incompressible: its λ + 2μ reaches {stiff:.3e} Pa against μ = {soft:.3e} Pa"),
        )
    } else {
        (
            format!("materials.{soft_name}.{soft_field}"),
            format!("material '{stiff_name}' (λ + 2μ up to {stiff:.3e} Pa) is too stiff next to '{soft_name}' (μ down to {soft:.3e} Pa)"),
        )
    };
    Err(SceneError::new(
        path,
        format!(
            "{what}, a ratio of {:.1e}; at most {MAX_STIFFNESS_RATIO:.0e} can be solved in double precision (over the whole box of uncertain data)",
            stiff / soft
        ),
    ))
}

/// Vertices accepted in all polygons, holes, paths and criteria regions of a scene together. The
/// geometric checks (simple polygons, overlapping bodies) grow faster than linearly with the
/// vertex count: this bound keeps the whole validation under about a second.
pub const MAX_VERTICES: usize = 10_000;

fn check_vertex_count(scene: &Scene) -> Result<(), SceneError> {
    let mut lists: Vec<(String, usize)> = Vec::new();
    for (b, body) in scene.bodies.iter().enumerate() {
        for (z, zone) in body.zones.iter().enumerate() {
            let path = format!("bodies[{b}].zones[{z}]");
            lists.push((format!("{path}.polygon"), zone.polygon.len()));
            for (h, hole) in zone.holes.iter().enumerate() {
                lists.push((format!("{path}.holes[{h}]"), hole.len()));
            }
        }
    }
    for (name, segment) in &scene.segments {
        let n = segment.path.as_ref().map_or(2, Vec::len);
        lists.push((format!("segments.{name}.path"), n));
    }
    for (r, region) in scene.criteria.regions.iter().enumerate() {
        lists.push((
            format!("criteria.regions[{r}].polygon"),
            region.polygon.len(),
        ));
    }
    let mut total = 0;
    for (path, n) in lists {
        total += n;
        if total > MAX_VERTICES {
            return Err(SceneError::new(
                path,
                format!(
                    "the scene's polygons, holes, paths and regions have more than {MAX_VERTICES} vertices together; a finer boundary belongs in a Gmsh mesh (mesh.gmsh_file, command line)"
                ),
            ));
        }
    }
    Ok(())
}

pub(super) fn finite(path: &str, v: f64) -> Result<f64, SceneError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(SceneError::new(path, "must be a finite number"))
    }
}

/// A finite value that obeys the rule of `constant` ([`Constant::check`]).
fn admissible(path: &str, v: f64, constant: Constant) -> Result<(), SceneError> {
    constant
        .check(finite(path, v)?)
        .map_err(|reason| SceneError::new(path, reason))
}

/// The name of an entry that field paths may pick (`boundary[NAME]`, `contacts[NAME]`): unique
/// in its list and usable in a path ([`unaddressable`]); an error at `{path}.name` otherwise.
fn entry_name<'a>(
    names: &mut BTreeSet<&'a str>,
    name: &'a str,
    path: &str,
    what: &str,
) -> Result<(), SceneError> {
    if let Some(why) = unaddressable(name) {
        return Err(SceneError::new(
            format!("{path}.name"),
            format!("{what} name '{name}' {why}"),
        ));
    }
    unique_name(names, name, path, what)
}

/// Record the name of the entry at `path` (a `what`): a name used before is an error at
/// `{path}.name`.
pub(super) fn unique_name<'a>(
    names: &mut BTreeSet<&'a str>,
    name: &'a str,
    path: &str,
    what: &str,
) -> Result<(), SceneError> {
    if names.insert(name) {
        Ok(())
    } else {
        Err(SceneError::new(
            format!("{path}.name"),
            format!("{what} name '{name}' used twice"),
        ))
    }
}

/// Largest coordinate magnitude \[m\] (10,000 km): areas, lengths and orientations of the
/// geometric checks stay far from overflow (a product of two coordinates is at most 1e14).
pub const MAX_COORDINATE: f64 = 1e7;

/// Every point of a list (its path `{path}[k]`) as [`check_point`].
fn check_points(path: &str, pts: &[Point]) -> Result<(), SceneError> {
    for (k, p) in pts.iter().enumerate() {
        check_point(&format!("{path}[{k}]"), *p)?;
    }
    Ok(())
}

/// A point (or direction) with finite components within [`MAX_COORDINATE`].
pub(super) fn check_point(path: &str, p: Point) -> Result<(), SceneError> {
    if p.iter().all(|c| c.abs() <= MAX_COORDINATE) {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!(
                "coordinates must be finite numbers of at most {MAX_COORDINATE:.0e} m in \
                 magnitude (got [{:e}, {:e}])",
                p[0], p[1]
            ),
        ))
    }
}

/// Whether closed segments [a, b] and [c, d] intersect (touching counts).
fn segments_intersect(a: Point, b: Point, c: Point, d: Point) -> bool {
    let (d1, d2) = (orient(c, d, a), orient(c, d, b));
    let (d3, d4) = (orient(a, b, c), orient(a, b, d));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    let on = |p: Point, q: Point, r: Point, o: f64| {
        o == 0.0
            && r[0] >= p[0].min(q[0])
            && r[0] <= p[0].max(q[0])
            && r[1] >= p[1].min(q[1])
            && r[1] <= p[1].max(q[1])
    };
    on(c, d, a, d1) || on(c, d, b, d2) || on(a, b, c, d3) || on(a, b, d, d4)
}

/// A simple polygon: at least 3 points, non-zero area, no two non-adjacent edges meeting.
fn check_polygon(path: &str, pts: &[Point]) -> Result<(), SceneError> {
    check_points(path, pts)?;
    let mut pts = pts.to_vec();
    if pts.len() > 3 && pts.first() == pts.last() {
        pts.pop();
    }
    let n = pts.len();
    if n < 3 {
        return Err(SceneError::new(path, "a polygon needs at least 3 points"));
    }
    let scale = pts
        .iter()
        .flat_map(|p| [p[0].abs(), p[1].abs()])
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    if signed_area2(&pts).abs() <= 1e-14 * scale * scale {
        return Err(SceneError::new(path, "the polygon has zero area"));
    }
    for i in 0..n {
        for j in i + 1..n {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            if adjacent {
                continue;
            }
            if segments_intersect(pts[i], pts[(i + 1) % n], pts[j], pts[(j + 1) % n]) {
                return Err(SceneError::new(
                    path,
                    format!("the polygon intersects itself (edges {i} and {j})"),
                ));
            }
        }
    }
    Ok(())
}

fn check_bodies(scene: &Scene) -> Result<(), SceneError> {
    if scene.bodies.is_empty() {
        return Err(SceneError::new("bodies", "at least one body is required"));
    }
    let mut names = BTreeSet::new();
    let mut zone_names = BTreeSet::new();
    for (b, body) in scene.bodies.iter().enumerate() {
        if body.name.trim().is_empty() || !names.insert(body.name.as_str()) {
            return Err(SceneError::new(
                format!("bodies[{b}].name"),
                format!("body name '{}' is empty or used twice", body.name),
            ));
        }
        if body.zones.is_empty() {
            return Err(SceneError::new(
                format!("bodies[{b}].zones"),
                "a body needs at least one zone",
            ));
        }
        for (z, zone) in body.zones.iter().enumerate() {
            let path = format!("bodies[{b}].zones[{z}]");
            if zone.name.trim().is_empty() || !zone_names.insert(zone.name.as_str()) {
                return Err(SceneError::new(
                    format!("{path}.name"),
                    format!("zone name '{}' is empty or used twice", zone.name),
                ));
            }
            if !scene.materials.contains_key(&zone.material) {
                return Err(SceneError::new(
                    format!("{path}.material"),
                    format!("unknown material '{}'", zone.material),
                ));
            }
            check_polygon(&format!("{path}.polygon"), &zone.polygon)?;
            for (h, hole) in zone.holes.iter().enumerate() {
                check_polygon(&format!("{path}.holes[{h}]"), hole)?;
            }
        }
    }
    Ok(())
}

fn check_materials(scene: &Scene) -> Result<(), SceneError> {
    if scene.materials.is_empty() {
        return Err(SceneError::new(
            "materials",
            "at least one material is required",
        ));
    }
    for (name, m) in &scene.materials {
        let path = format!("materials.{name}");
        check_elastic(&path, m)?;
        if let Some(w) = m.specific_weight {
            admissible(&format!("{path}.specific_weight"), w, Constant::Load)?;
        }
        if let Some(f) = m.body_force {
            for (c, v) in f.iter().enumerate() {
                admissible(&format!("{path}.body_force[{c}]"), *v, Constant::Load)?;
            }
        }
        if m.expansion.is_some() && m.beta.is_some() {
            return Err(SceneError::new(
                path,
                "give either expansion (alpha) or beta, not both",
            ));
        }
        match m.conductivity {
            Some(Conductivity::Scalar(k)) => {
                admissible(&format!("{path}.conductivity"), k, Constant::Conductivity)?;
            }
            Some(Conductivity::Matrix(k)) => check_conductivity_matrix(&path, &k)?,
            None => {}
        }
        for (field, v) in [("heat_source", m.heat_source), ("expansion", m.expansion)] {
            if let Some(v) = v {
                finite(&format!("{path}.{field}"), v)?;
            }
        }
        match m.beta {
            Some(ThermalStress::Scalar(b)) => {
                finite(&format!("{path}.beta"), b)?;
            }
            Some(ThermalStress::Voigt(b)) => {
                for (k, v) in b.iter().enumerate() {
                    finite(&format!("{path}.beta[{k}]"), *v)?;
                }
            }
            None => {}
        }
        if m.matrix.is_some() && m.expansion.is_some() {
            return Err(SceneError::new(
                format!("{path}.expansion"),
                "an expansion α needs the material's full 3D stiffness; with `matrix` give `beta` \
                 (a scalar or [β11, β22, β12, β33])",
            ));
        }
        if scene.thermal.is_some() && m.conductivity.is_none() {
            let used = scene
                .bodies
                .iter()
                .flat_map(|b| &b.zones)
                .any(|z| &z.material == name);
            if used {
                return Err(SceneError::new(
                    format!("{path}.conductivity"),
                    "the scene has a thermal part, so every used material needs a conductivity",
                ));
            }
        }
    }
    Ok(())
}

/// Exactly one elastic law per material, each number admissible and the law positive definite
/// (FGCS 2.7′ needs a symmetric positive definite A); errors name the field and the value.
fn check_elastic(path: &str, m: &Material) -> Result<(), SceneError> {
    let orthotropic = [m.e1, m.e2, m.e3, m.nu12, m.nu13, m.nu23, m.g12, m.angle];
    let kinds = [
        m.young.is_some() || m.nu.is_some(),
        m.lambda.is_some() || m.mu.is_some(),
        orthotropic.iter().any(Option::is_some),
        m.matrix.is_some() || m.out_of_plane.is_some(),
    ];
    if kinds.iter().filter(|k| **k).count() != 1 {
        return Err(SceneError::new(
            path,
            "give exactly one elastic law: (E, nu), (lambda, mu), orthotropic (E1, E2, E3, nu12, \
             nu13, nu23, G12, optional angle) or (matrix, optional out_of_plane)",
        ));
    }
    let missing = |field: &str| {
        SceneError::new(
            format!("{path}.{field}"),
            "missing: the material's other constants need it",
        )
    };
    match (m.young, m.nu, m.lambda, m.mu) {
        (Some(e), Some(nu), None, None) => {
            admissible(&format!("{path}.E"), e, Constant::Young)?;
            return admissible(&format!("{path}.nu"), nu, Constant::Poisson);
        }
        (None, None, Some(l), Some(mu)) => {
            admissible(&format!("{path}.mu"), mu, Constant::Mu)?;
            return admissible(&format!("{path}.lambda"), l, Constant::Lambda);
        }
        (Some(_), None, ..) => return Err(missing("nu")),
        (None, Some(_), ..) => return Err(missing("E")),
        (.., Some(_), None) => return Err(missing("mu")),
        (.., None, Some(_)) => return Err(missing("lambda")),
        _ => {}
    }
    if let Some(d) = m.matrix {
        return check_matrix(path, &d, m.out_of_plane.unwrap_or([0.0; 3]));
    }
    if m.out_of_plane.is_some() {
        return Err(missing("matrix"));
    }
    let get = |field: &str, v: Option<f64>, rule: Constant| {
        let v = v.ok_or_else(|| missing(field))?;
        admissible(&format!("{path}.{field}"), v, rule).map(|()| v)
    };
    let young = [
        get("E1", m.e1, Constant::Young)?,
        get("E2", m.e2, Constant::Young)?,
        get("E3", m.e3, Constant::Young)?,
    ];
    let poisson = [
        get("nu12", m.nu12, Constant::OrthotropicPoisson)?,
        get("nu13", m.nu13, Constant::OrthotropicPoisson)?,
        get("nu23", m.nu23, Constant::OrthotropicPoisson)?,
    ];
    get("G12", m.g12, Constant::Mu)?;
    if let Some(angle) = m.angle {
        admissible(&format!("{path}.angle"), angle, Constant::Angle)?;
    }
    check_orthotropic_compliance(path, young, poisson)
}

/// The orthotropic compliance must be positive definite: its normal block scaled to a unit
/// diagonal, I − N with N_ij = ν_ij √(E_j/E_i), has a positive smallest eigenvalue. The error
/// names the Poisson ratio of the largest coupling |N_ij|.
fn check_orthotropic_compliance(
    path: &str,
    young: [f64; 3],
    poisson: [f64; 3],
) -> Result<(), SceneError> {
    let scaled = scaled_compliance(young, poisson);
    let least = law::symmetric_eigenvalues(&scaled)[0];
    if least > 1e-12 {
        return Ok(());
    }
    let couplings = [(0, 1, "nu12"), (0, 2, "nu13"), (1, 2, "nu23")];
    let (k, &(_, _, field)) = couplings
        .iter()
        .enumerate()
        .max_by(|a, b| {
            scaled[a.1 .0][a.1 .1]
                .abs()
                .total_cmp(&scaled[b.1 .0][b.1 .1].abs())
        })
        .unwrap_or((0, &couplings[0]));
    Err(SceneError::new(
        format!("{path}.{field}"),
        format!(
            "{field} = {} makes the orthotropic compliance not positive definite (smallest \
             eigenvalue {least:.3e} of the unit-diagonal normal compliance; need \
             1 − ν12ν21 − ν13ν31 − ν23ν32 − 2ν21ν32ν13 > 0 and |ν_ij| < √(E_i/E_j))",
            poisson[k]
        ),
    ))
}

/// The normal compliance scaled to a unit diagonal: 1 on the diagonal, −ν_ij √(E_j/E_i) off it.
fn scaled_compliance(young: [f64; 3], poisson: [f64; 3]) -> [[f64; 3]; 3] {
    let n = |i: usize, j: usize, nu: f64| -nu * (young[j] / young[i]).sqrt();
    let (a, b, c) = (
        n(0, 1, poisson[0]),
        n(0, 2, poisson[1]),
        n(1, 2, poisson[2]),
    );
    [[1.0, a, b], [a, 1.0, c], [b, c, 1.0]]
}

/// A plane-strain matrix: finite entries within the stiffness range, symmetric, positive
/// definite.
fn check_matrix(path: &str, d: &[[f64; 3]; 3], out: [f64; 3]) -> Result<(), SceneError> {
    for (i, row) in d.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            admissible(
                &format!("{path}.matrix[{i}][{j}]"),
                *v,
                Constant::MatrixEntry,
            )?;
            if (v - d[j][i]).abs() > 1e-12 * v.abs().max(d[j][i].abs()) {
                return Err(SceneError::new(
                    format!("{path}.matrix[{i}][{j}]"),
                    format!(
                        "the matrix must be symmetric: [{i}][{j}] = {v} but [{j}][{i}] = {}",
                        d[j][i]
                    ),
                ));
            }
        }
    }
    for (k, v) in out.iter().enumerate() {
        admissible(
            &format!("{path}.out_of_plane[{k}]"),
            *v,
            Constant::MatrixEntry,
        )?;
    }
    let least = law::symmetric_eigenvalues(d)[0];
    if least > 0.0 {
        Ok(())
    } else {
        Err(SceneError::new(
            format!("{path}.matrix"),
            format!(
                "the matrix is not positive definite: its smallest eigenvalue is {least:.6e} Pa"
            ),
        ))
    }
}

/// A conductivity matrix: finite, symmetric, with eigenvalues in the conductivity range.
fn check_conductivity_matrix(path: &str, k: &[[f64; 2]; 2]) -> Result<(), SceneError> {
    let field = format!("{path}.conductivity");
    for (i, row) in k.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            finite(&format!("{field}[{i}][{j}]"), *v)?;
        }
    }
    if (k[0][1] - k[1][0]).abs() > 1e-12 * k[0][1].abs().max(k[1][0].abs()) {
        return Err(SceneError::new(
            format!("{field}[0][1]"),
            format!(
                "the conductivity matrix must be symmetric: [0][1] = {} but [1][0] = {}",
                k[0][1], k[1][0]
            ),
        ));
    }
    let [least, largest] = law::symmetric_eigenvalues(k);
    if Constant::Conductivity.admits(least) && Constant::Conductivity.admits(largest) {
        Ok(())
    } else {
        Err(SceneError::new(
            field,
            format!(
                "the conductivity matrix has the eigenvalues {least:.6e} and {largest:.6e}; {} \
                 (positive definite)",
                Constant::Conductivity.rule()
            ),
        ))
    }
}

fn check_segments(scene: &Scene) -> Result<(), SceneError> {
    for (name, s) in &scene.segments {
        let path = format!("segments.{name}");
        if !scene.bodies.iter().any(|b| b.name == s.body) {
            return Err(SceneError::new(
                format!("{path}.body"),
                format!("unknown body '{}'", s.body),
            ));
        }
        let geometry = s.path.is_some() || (s.from.is_some() && s.to.is_some());
        if !geometry && scene.mesh.imported().is_none() {
            return Err(SceneError::new(
                path,
                "give `from` and `to`, or a `path` polyline",
            ));
        }
        if s.path.is_some() && (s.from.is_some() || s.to.is_some()) {
            return Err(SceneError::new(
                path,
                "give either `from`/`to` or `path`, not both",
            ));
        }
        let pts = s.polyline();
        check_points(&format!("{path}.path"), &pts)?;
        if geometry && pts.windows(2).any(|w| w[0] == w[1]) {
            return Err(SceneError::new(
                path,
                "the polyline has a zero-length piece",
            ));
        }
    }
    Ok(())
}

fn segment_known(scene: &Scene, path: String, name: &str) -> Result<(), SceneError> {
    if scene.segments.contains_key(name) {
        Ok(())
    } else {
        Err(SceneError::new(path, format!("unknown segment '{name}'")))
    }
}

fn check_boundary(scene: &Scene) -> Result<(), SceneError> {
    let mut names = BTreeSet::new();
    for (i, bc) in scene.boundary.iter().enumerate() {
        let path = format!("boundary[{i}]");
        if let Some(name) = &bc.name {
            entry_name(&mut names, name, &path, "boundary condition")?;
        }
        segment_known(scene, format!("{path}.segment"), &bc.segment)?;
        let set = [
            bc.displacement.is_some(),
            bc.traction.is_some(),
            bc.pressure.is_some(),
            bc.hydrostatic.is_some(),
            bc.roller.is_some(),
            bc.temperature.is_some(),
            bc.heat_flux.is_some(),
        ]
        .iter()
        .filter(|&&x| x)
        .count();
        if set != 1 {
            return Err(SceneError::new(
                path,
                "set exactly one of displacement, traction, pressure, hydrostatic, roller, temperature, \
                 heat_flux",
            ));
        }
        if let Some(d) = bc.displacement {
            if d.iter().all(Option::is_none) {
                return Err(SceneError::new(
                    format!("{path}.displacement"),
                    "both components are free",
                ));
            }
            prescribed_once(scene, i, d)?;
            for (c, v) in d.iter().enumerate() {
                if let Some(v) = v {
                    admissible(
                        &format!("{path}.displacement[{c}]"),
                        *v,
                        Constant::Displacement,
                    )?;
                }
            }
        }
        if let Some(t) = bc.traction {
            for (c, v) in t.iter().enumerate() {
                admissible(&format!("{path}.traction[{c}]"), *v, Constant::Load)?;
            }
        }
        if let Some(p) = bc.pressure {
            admissible(&format!("{path}.pressure"), p, Constant::Load)?;
        }
        if let Some(h) = bc.hydrostatic {
            admissible(
                &format!("{path}.hydrostatic.level"),
                h.level,
                Constant::Level,
            )?;
            admissible(
                &format!("{path}.hydrostatic.unit_weight"),
                h.unit_weight,
                Constant::UnitWeight,
            )?;
        }
        if let Some(Roller { direction: Some(d) }) = bc.roller {
            check_point(&format!("{path}.roller.direction"), d)?;
            if d[0].hypot(d[1]) == 0.0 {
                return Err(SceneError::new(
                    format!("{path}.roller.direction"),
                    "the direction is zero",
                ));
            }
        }
        for (field, v) in [("temperature", bc.temperature), ("heat_flux", bc.heat_flux)] {
            if let Some(v) = v {
                finite(&format!("{path}.{field}"), v)?;
                if scene.thermal.is_none() {
                    return Err(SceneError::new(
                        format!("{path}.{field}"),
                        "a thermal condition needs the scene's `thermal` section",
                    ));
                }
            }
        }
    }
    Ok(())
}

/// A displacement component of a segment is prescribed by one condition: a second one on the
/// same segment and component (equal or not — with uncertain data they part) is refused at
/// `boundary[i].displacement[c]`, naming the first.
fn prescribed_once(scene: &Scene, i: usize, d: [Option<f64>; 2]) -> Result<(), SceneError> {
    let segment = &scene.boundary[i].segment;
    for (j, earlier) in scene.boundary[..i].iter().enumerate() {
        let Some(e) = earlier.displacement.filter(|_| &earlier.segment == segment) else {
            continue;
        };
        if let Some(c) = (0..2).find(|&c| d[c].is_some() && e[c].is_some()) {
            return Err(SceneError::new(
                format!("boundary[{i}].displacement[{c}]"),
                format!(
                    "segment '{segment}' already has its {} displacement prescribed by \
                     boundary[{j}]; give each component of a segment once",
                    ["x", "y"][c]
                ),
            ));
        }
    }
    Ok(())
}

fn check_contacts(scene: &Scene) -> Result<(), SceneError> {
    let mut names = BTreeSet::new();
    let mut used = BTreeSet::new();
    for (i, c) in scene.contacts.iter().enumerate() {
        let path = format!("contacts[{i}]");
        entry_name(&mut names, &c.name, &path, "contact")?;
        for (k, seg) in c.between.iter().enumerate() {
            segment_known(scene, format!("{path}.between[{k}]"), seg)?;
            if !used.insert(seg.as_str()) {
                return Err(SceneError::new(
                    format!("{path}.between[{k}]"),
                    format!("segment '{seg}' is already used by another contact zone"),
                ));
            }
        }
        let body = |k: usize| scene.segments.get(&c.between[k]).map(|s| s.body.as_str());
        if body(0) == body(1) {
            return Err(SceneError::new(
                format!("{path}.between"),
                "a contact zone joins segments of two different bodies",
            ));
        }
        if let Some(slave) = &c.slave {
            if c.coupling != Coupling::Mortar {
                return Err(SceneError::new(
                    format!("{path}.slave"),
                    "a slave side is chosen only with \"coupling\": \"mortar\"",
                ));
            }
            if !c.between.contains(slave) {
                return Err(SceneError::new(
                    format!("{path}.slave"),
                    format!("'{slave}' is not one of the zone's two segments (`between`)"),
                ));
            }
        }
        let slip_path = format!("{path}.slip_limit");
        match &c.slip_limit {
            SlipLimit::Constant(g) => admissible(&slip_path, *g, Constant::SlipLimit)?,
            SlipLimit::PiecewiseLinear {
                knots,
                values,
                max_slope,
            } => {
                check_knots(&slip_path, knots, values)?;
                if let Some(c) = max_slope {
                    if finite(&format!("{slip_path}.max_slope"), *c)? < 0.0 {
                        return Err(SceneError::new(
                            format!("{slip_path}.max_slope"),
                            "must be >= 0",
                        ));
                    }
                }
            }
        }
        match &c.initial_gap {
            Some(InitialGap::Parabola { radius, touch_at }) => {
                if finite(&format!("{path}.initial_gap.parabola.radius"), *radius)? <= 0.0 {
                    return Err(SceneError::new(
                        format!("{path}.initial_gap.parabola.radius"),
                        "must be > 0",
                    ));
                }
                check_point(&format!("{path}.initial_gap.parabola.touch_at"), *touch_at)?;
            }
            Some(InitialGap::PiecewiseLinear { knots, values }) => {
                check_knots(
                    &format!("{path}.initial_gap.piecewise_linear"),
                    knots,
                    values,
                )?;
            }
            None => {}
        }
        if c.kind == ContactKind::Bilateral
            && !matches!(c.slip_limit, SlipLimit::Constant(g) if g == 0.0)
        {
            return Err(SceneError::new(
                slip_path,
                "a bilateral contact zone is frictionless: omit slip_limit",
            ));
        }
        if let Some(f) = c.friction_coefficient {
            let friction_path = format!("{path}.friction_coefficient");
            admissible(&friction_path, f, Constant::FrictionCoefficient)?;
            if c.kind == ContactKind::Bilateral {
                return Err(SceneError::new(
                    friction_path,
                    "a bilateral contact zone is frictionless: omit friction_coefficient",
                ));
            }
            if !matches!(c.slip_limit, SlipLimit::Constant(g) if g == 0.0) {
                return Err(SceneError::new(
                    slip_path,
                    "give either a Tresca slip_limit or a Coulomb friction_coefficient, not both",
                ));
            }
        }
    }
    Ok(())
}

/// Knots strictly increasing in [0, 1], one non-negative finite value per knot.
fn check_knots(path: &str, knots: &[f64], values: &[f64]) -> Result<(), SceneError> {
    if knots.len() != values.len() || knots.is_empty() {
        return Err(SceneError::new(
            format!("{path}.knots"),
            "knots and values must be non-empty and of equal length",
        ));
    }
    if knots.iter().any(|k| !(0.0..=1.0).contains(k)) || knots.windows(2).any(|w| w[1] <= w[0]) {
        return Err(SceneError::new(
            format!("{path}.knots"),
            "knots must increase strictly within [0, 1]",
        ));
    }
    for (k, v) in values.iter().enumerate() {
        if finite(&format!("{path}.values[{k}]"), *v)? < 0.0 {
            return Err(SceneError::new(
                format!("{path}.values[{k}]"),
                "must be >= 0",
            ));
        }
    }
    Ok(())
}

impl MeshControls {
    /// `max_size` for the built-in mesher, or the error that it is missing (naming
    /// `mesh.max_size`).
    pub fn built_in_max_size(&self) -> Result<f64, SceneError> {
        self.max_size.ok_or_else(|| {
            SceneError::new(
                "mesh.max_size",
                "missing: the built-in mesher needs the maximal element edge length in metres \
                 (or import a mesh with mesh.gmsh_file or mesh.inline)",
            )
        })
    }
}

/// `mesh.element: "mixed"` (design §2.7) with what it supports: isotropic materials (a thermal
/// part included), no dynamics, the direct solver on its dense contact path.
fn check_element(scene: &Scene) -> Result<(), SceneError> {
    if scene.mesh.element.is_p1() {
        return Ok(());
    }
    let refuse = |what: &str| {
        Err(SceneError::new(
            "mesh.element",
            format!("\"mixed\" {what} (design §2.7); use \"p1\""),
        ))
    };
    if scene.solver.contact == ContactMethod::Sparse {
        return refuse("takes the dense contact path only: solver.contact \"sparse\" is refused");
    }
    if scene.dynamics.is_some() {
        return refuse("is static only: no dynamics");
    }
    if scene.solver.kind == SolverKind::Dd {
        return refuse("is solved by the direct solver only: solver.kind \"dd\" is refused");
    }
    for body in &scene.bodies {
        for zone in &body.zones {
            if let Some(m) = scene.materials.get(&zone.material) {
                let isotropic =
                    (m.young.is_some() && m.nu.is_some()) || (m.lambda.is_some() && m.mu.is_some());
                if !isotropic {
                    return Err(SceneError::new(
                        format!("materials.{}", zone.material),
                        "mesh.element \"mixed\" needs an isotropic material (young and nu, or \
                         lambda and mu)",
                    ));
                }
            }
        }
    }
    Ok(())
}

fn check_mesh(mesh: &MeshControls, scene: &Scene) -> Result<(), SceneError> {
    // An imported mesh needs no max_size (a given one is checked all the same).
    if (mesh.max_size.is_some() || mesh.imported().is_none())
        && finite("mesh.max_size", mesh.built_in_max_size()?)? <= 0.0
    {
        return Err(SceneError::new("mesh.max_size", "must be > 0"));
    }
    if mesh.gmsh_file.is_some() && mesh.inline.is_some() {
        return Err(SceneError::new(
            "mesh.inline",
            "give either mesh.gmsh_file or mesh.inline, not both",
        ));
    }
    if mesh.subdivide > 0 && mesh.imported().is_none() {
        return Err(SceneError::new(
            "mesh.subdivide",
            "subdivides an imported mesh (mesh.gmsh_file or mesh.inline); the built-in mesher \
             is refined with mesh.max_size",
        ));
    }
    if mesh.subdivide > MAX_SUBDIVIDE {
        return Err(SceneError::new(
            "mesh.subdivide",
            format!(
                "at most {MAX_SUBDIVIDE} (each subdivision multiplies the triangles by 4; got {})",
                mesh.subdivide
            ),
        ));
    }
    if !(finite("mesh.min_angle", mesh.min_angle)? > 0.0 && mesh.min_angle <= 30.0) {
        return Err(SceneError::new(
            "mesh.min_angle",
            "must lie in (0, 30] degrees",
        ));
    }
    for (i, r) in mesh.refine.iter().enumerate() {
        let path = format!("mesh.refine[{i}]");
        if finite(&format!("{path}.max_size"), r.max_size)? <= 0.0 {
            return Err(SceneError::new(format!("{path}.max_size"), "must be > 0"));
        }
        for (j, s) in r.segments.iter().enumerate() {
            segment_known(scene, format!("{path}.segments[{j}]"), s)?;
        }
        if let Some(p) = &r.polygon {
            check_polygon(&format!("{path}.polygon"), p)?;
        }
        if r.segments.is_empty() && r.polygon.is_none() {
            return Err(SceneError::new(
                path,
                "give `segments` or a `polygon` to refine",
            ));
        }
    }
    Ok(())
}

fn check_criteria(scene: &Scene) -> Result<(), SceneError> {
    let mut names = BTreeSet::new();
    for (r, g) in scene.criteria.regions.iter().enumerate() {
        let path = format!("criteria.regions[{r}]");
        unique_name(&mut names, &g.name, &path, "region")?;
        check_polygon(&format!("{path}.polygon"), &g.polygon)?;
        if let Some(n) = g.normal {
            check_point(&format!("{path}.normal"), n)?;
            if n[0].hypot(n[1]) == 0.0 {
                return Err(SceneError::new(
                    format!("{path}.normal"),
                    "the normal is zero",
                ));
            }
        }
        if let Some(x) = g.normal_at {
            check_point(&format!("{path}.normal_at"), x)?;
        }
    }
    for (r, piece) in scene.criteria.boundary_pieces.iter().enumerate() {
        let path = format!("criteria.boundary_pieces[{r}]");
        unique_name(&mut names, &piece.name, &path, "boundary piece")?;
        segment_known(scene, format!("{path}.segment"), &piece.segment)?;
        for (field, p) in [
            ("from", piece.from),
            ("to", piece.to),
            ("normal_at", piece.normal_at),
        ] {
            if let Some(p) = p {
                check_point(&format!("{path}.{field}"), p)?;
            }
        }
    }
    let mut defined = BTreeSet::new();
    for (k, d) in scene.criteria.defined.iter().enumerate() {
        let path = format!("criteria.defined[{k}]");
        if !crate::is_defined_name(&d.name) {
            return Err(SceneError::new(
                format!("{path}.name"),
                format!(
                    "'{}' is not a criterion name: letters, digits and '_', starting with a letter, and not phi followed by a digit",
                    d.name
                ),
            ));
        }
        if !defined.insert(d.name.as_str()) {
            return Err(SceneError::new(
                format!("{path}.name"),
                format!("the criterion name '{}' is defined twice", d.name),
            ));
        }
        let region = defined_place(scene, d, &path)?;
        if d.quantity.is_receiver() {
            continue;
        }
        if d.quantity.is_contact() {
            let piece = scene
                .criteria
                .boundary_pieces
                .iter()
                .find(|p| p.name == region)
                .ok_or_else(|| {
                    SceneError::new(
                        format!("{path}.region"),
                        format!(
                            "'{region}' is not a boundary piece of criteria.boundary_pieces (a contact traction is averaged over one)"
                        ),
                    )
                })?;
            let on_contact = scene
                .contacts
                .iter()
                .any(|c| c.between.contains(&piece.segment));
            if !on_contact {
                return Err(SceneError::new(
                    format!("{path}.region"),
                    format!(
                        "boundary piece '{region}' lies on segment '{}', which is no contact zone's segment",
                        piece.segment
                    ),
                ));
            }
        } else if !scene.criteria.regions.iter().any(|g| g.name == region) {
            return Err(SceneError::new(
                format!("{path}.region"),
                format!(
                    "'{region}' is not an area of criteria.regions (a stress quantity is averaged over one)"
                ),
            ));
        }
    }
    Ok(())
}

/// What a defined criterion reads (at `path`): a receiver of a dynamic scene for `peak_velocity`
/// (checked here; `Ok` gives its name), otherwise a region by name (checked by the caller), and
/// never both.
fn defined_place<'s>(
    scene: &'s Scene,
    d: &'s DefinedCriterion,
    path: &str,
) -> Result<&'s str, SceneError> {
    match (d.quantity.is_receiver(), &d.region, &d.receiver) {
        (true, Some(_), _) => Err(SceneError::new(
            format!("{path}.region"),
            "peak_velocity is read at a receiver: give `receiver` (a name of `receivers`), not `region`",
        )),
        (true, None, None) => Err(SceneError::new(
            format!("{path}.receiver"),
            "peak_velocity needs `receiver`, the name of one of the scene's `receivers`",
        )),
        (true, None, Some(name)) => {
            if scene.dynamics.is_none() {
                return Err(SceneError::new(
                    format!("{path}.quantity"),
                    "peak_velocity is a maximum over the time steps: only in a scene with `dynamics`",
                ));
            }
            if !scene.receivers.iter().any(|r| &r.name == name) {
                return Err(SceneError::new(
                    format!("{path}.receiver"),
                    format!("'{name}' is not the name of one of the scene's `receivers`"),
                ));
            }
            Ok(name)
        }
        (false, _, Some(_)) => Err(SceneError::new(
            format!("{path}.receiver"),
            "only peak_velocity is read at a receiver; this quantity is a mean over `region`",
        )),
        (false, None, None) => Err(SceneError::new(
            format!("{path}.region"),
            "this quantity is a mean over a region: give `region`",
        )),
        (false, Some(region), None) => Ok(region),
    }
}

/// Φ6 is the mean normal stress over the areas adjacent to Γc (FGCS 4.34): at least one region
/// with a normal must touch a contact zone's segment (within [`touching_tolerance`]); the
/// criterion ranges over those.
fn a_region_touches_a_contact(scene: &Scene, path: &str) -> Result<(), SceneError> {
    let touches = |polygon: &[Point]| touches_a_contact(scene, polygon);
    let candidates: Vec<&str> = scene
        .criteria
        .regions
        .iter()
        .filter(|g| g.normal.is_some() || g.normal_at.is_some())
        .map(|g| g.name.as_str())
        .collect();
    if scene
        .criteria
        .regions
        .iter()
        .any(|g| (g.normal.is_some() || g.normal_at.is_some()) && touches(&g.polygon))
    {
        return Ok(());
    }
    Err(SceneError::new(
        path,
        format!(
            "phi6 is the mean normal stress over regions adjacent to a contact zone (FGCS 4.34), but no region with a normal touches one (regions with a normal: {})",
            candidates.join(", ")
        ),
    ))
}

/// Whether an edge of `polygon` lies within the touching tolerance of a contact zone's segment.
fn touches_a_contact(scene: &Scene, polygon: &[Point]) -> bool {
    let n = polygon.len();
    scene
        .contacts
        .iter()
        .flat_map(|c| c.between.iter())
        .filter_map(|name| scene.segments.get(name))
        .any(|segment| {
            segment.polyline().windows(2).any(|e| {
                (0..n).any(|i| {
                    segment_distance(e[0], e[1], polygon[i], polygon[(i + 1) % n])
                        <= touching_tolerance(polygon)
                })
            })
        })
}

/// The distance below which a region touches a line: 1e-6 of the polygon's diameter (rounding
/// of coordinates given in decimal, far below any mesh size).
pub fn touching_tolerance(polygon: &[Point]) -> f64 {
    let diameter = polygon
        .iter()
        .flat_map(|p| {
            polygon
                .iter()
                .map(move |q| (p[0] - q[0]).hypot(p[1] - q[1]))
        })
        .fold(0.0, f64::max);
    1e-6 * diameter
}

/// Distance between the closed segments [a, b] and [c, d].
fn segment_distance(a: Point, b: Point, c: Point, d: Point) -> f64 {
    if segments_intersect(a, b, c, d) {
        return 0.0;
    }
    let to_segment = |p: Point, q: Point, r: Point| {
        let (dx, dy) = (r[0] - q[0], r[1] - q[1]);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 {
            (((p[0] - q[0]) * dx + (p[1] - q[1]) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p[0] - q[0] - t * dx).hypot(p[1] - q[1] - t * dy)
    };
    to_segment(a, c, d)
        .min(to_segment(b, c, d))
        .min(to_segment(c, a, b))
        .min(to_segment(d, a, b))
}

/// Φ4 is the mean normal displacement over boundary pieces off Γu (FGCS 4.32): on a segment with
/// a prescribed displacement or a roller it would only echo the data.
fn piece_off_dirichlet(scene: &Scene, r: usize) -> Result<(), SceneError> {
    let piece = &scene.criteria.boundary_pieces[r];
    let prescribing = scene.boundary.iter().position(|b| {
        b.segment == piece.segment && (b.displacement.is_some() || b.roller.is_some())
    });
    match prescribing {
        Some(i) => Err(SceneError::new(
            format!("criteria.boundary_pieces[{r}].segment"),
            format!(
                "phi4 needs boundary pieces off the Dirichlet boundary Γu (FGCS 4.32), but segment '{}' carries boundary[{i}], which prescribes its displacement",
                piece.segment
            ),
        )),
        None => Ok(()),
    }
}

/// The criteria a search asks for (`criteria`, the JSON path of the list: `search.criteria` or a
/// request's `criteria`): each needs its field, a region of its kind, and a bound region must
/// exist and qualify (design §4.2). Checked when a search uses them, not by every solve.
pub fn check_criteria_list(
    scene: &Scene,
    criteria: &[CriterionSpec],
    list: &str,
) -> Result<(), SceneError> {
    for (k, spec) in criteria.iter().enumerate() {
        let path = format!("{list}[{k}]");
        if criteria[..k].contains(spec) {
            return Err(SceneError::new(
                path,
                format!("{} is listed twice", spec.name()),
            ));
        }
        let c = spec.criterion;
        if c.is_thermal() && scene.thermal.is_none() {
            return Err(SceneError::new(
                path,
                format!("{} needs the scene's `thermal` section", c.name()),
            ));
        }
        match &spec.region {
            Some(name) if c == Criterion::Defined => {
                if !scene.criteria.defined.iter().any(|d| &d.name == name) {
                    return Err(SceneError::new(
                        path,
                        format!("unknown criterion '{name}': not phi1 … phi6 and not a name in criteria.defined"),
                    ));
                }
            }
            Some(region) => check_bound_region(scene, c, region, &path)?,
            None if c == Criterion::Defined => {
                return Err(SceneError::new(
                    path,
                    "a defined criterion is named by its own name",
                ))
            }
            None => check_region_family(scene, c, &path)?,
        }
    }
    Ok(())
}

/// An unbound criterion needs at least one region of its kind.
fn check_region_family(scene: &Scene, c: Criterion, path: &str) -> Result<(), SceneError> {
    let has_areas = !scene.criteria.regions.is_empty();
    let has_pieces = !scene.criteria.boundary_pieces.is_empty();
    let needs_pieces = matches!(c, Criterion::Phi2 | Criterion::Phi4);
    if (needs_pieces && !has_pieces) || (!needs_pieces && !has_areas) {
        let what = if needs_pieces {
            "criteria.boundary_pieces"
        } else {
            "criteria.regions"
        };
        return Err(SceneError::new(
            path,
            format!("{} needs at least one entry in {what}", c.name()),
        ));
    }
    if matches!(c, Criterion::Phi3 | Criterion::Phi6)
        && scene
            .criteria
            .regions
            .iter()
            .all(|g| g.normal.is_none() && g.normal_at.is_none())
    {
        return Err(SceneError::new(
            path,
            format!("{} needs a region with `normal_at` or `normal`", c.name()),
        ));
    }
    if c == Criterion::Phi6 && scene.contacts.is_empty() {
        return Err(SceneError::new(path, "phi6 needs a contact zone"));
    }
    if c == Criterion::Phi4 {
        for r in 0..scene.criteria.boundary_pieces.len() {
            piece_off_dirichlet(scene, r)?;
        }
    }
    if c == Criterion::Phi6 {
        a_region_touches_a_contact(scene, path)?;
    }
    Ok(())
}

/// A criterion bound to `region`: an area of that name for Φ1, Φ3, Φ5, Φ6 (with a normal for Φ3
/// and Φ6, touching a contact zone for Φ6), a boundary piece for Φ2, Φ4 (off Γu for Φ4).
fn check_bound_region(
    scene: &Scene,
    c: Criterion,
    region: &str,
    path: &str,
) -> Result<(), SceneError> {
    let pieces = matches!(c, Criterion::Phi2 | Criterion::Phi4);
    let names: Vec<&str> = if pieces {
        scene
            .criteria
            .boundary_pieces
            .iter()
            .map(|p| p.name.as_str())
            .collect()
    } else {
        scene
            .criteria
            .regions
            .iter()
            .map(|g| g.name.as_str())
            .collect()
    };
    let Some(index) = names.iter().position(|n| *n == region) else {
        let kind = if pieces {
            "boundary piece (criteria.boundary_pieces)"
        } else {
            "area (criteria.regions)"
        };
        return Err(SceneError::new(
            path,
            format!(
                "{} is bound to '{region}', but no {kind} has that name (there are: {})",
                c.name(),
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            ),
        ));
    };
    if pieces {
        if c == Criterion::Phi4 {
            piece_off_dirichlet(scene, index)?;
        }
        return Ok(());
    }
    let g = &scene.criteria.regions[index];
    if matches!(c, Criterion::Phi3 | Criterion::Phi6) && g.normal.is_none() && g.normal_at.is_none()
    {
        return Err(SceneError::new(
            path,
            format!(
                "{} needs a normal, but region '{region}' has neither `normal` nor `normal_at` (criteria.regions[{index}])",
                c.name()
            ),
        ));
    }
    if c == Criterion::Phi6 && !touches_a_contact(scene, &g.polygon) {
        return Err(SceneError::new(
            path,
            format!(
                "phi6 is the mean normal stress over a region adjacent to a contact zone (FGCS 4.34), but region '{region}' touches none"
            ),
        ));
    }
    Ok(())
}

fn check_search(scene: &Scene) -> Result<(), SceneError> {
    if scene.search.budget == Some(0) {
        return Err(SceneError::new("search.budget", "must be at least 1"));
    }
    if let Some(t) = scene.search.max_seconds {
        if finite("search.max_seconds", t)? <= 0.0 {
            return Err(SceneError::new("search.max_seconds", "must be > 0"));
        }
    }
    if !(scene.solver.tolerance > 0.0 && scene.solver.tolerance < 1.0) {
        return Err(SceneError::new("solver.tolerance", "must lie in (0, 1)"));
    }
    for (k, polygon) in scene.solver.partition.iter().enumerate() {
        check_polygon(&format!("solver.partition[{k}]"), polygon)?;
    }
    if let Some(names) = &scene.solver.dd.tied_zones {
        if names.is_empty() {
            return Err(SceneError::new(
                "solver.dd.tied_zones",
                "must name at least one contact zone (D05 4.35: Γc0 of positive measure); \
                 leave it out to tie every zone",
            ));
        }
        for (k, name) in names.iter().enumerate() {
            if !scene.contacts.iter().any(|c| c.name == *name) {
                return Err(SceneError::new(
                    format!("solver.dd.tied_zones[{k}]"),
                    format!("no contact zone is named '{name}'"),
                ));
            }
        }
    }
    Ok(())
}
