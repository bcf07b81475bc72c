//! Uncertain parameters (design §4.1): resolve each `uncertain[i].field` path to the scene number
//! it varies, check its interval, and write a parameter vector θ into the numeric `Data`.
//!
//! Supported paths: `materials.M.{E, nu, lambda, mu, E1, E2, E3, nu12, nu13, nu23, G12, angle,
//! matrix[i][j], out_of_plane[k], specific_weight, body_force[c], conductivity,
//! conductivity[i][j], heat_source, expansion, beta, beta[k]}` (a symmetric matrix entry `[i][j]`
//! varies `[j][i]` with it), `boundary[i].{displacement[c], traction[c],
//! pressure, hydrostatic.level, hydrostatic.unit_weight, temperature, heat_flux}`,
//! `contacts[i].slip_limit` (constant g) and
//! `contacts[i].slip_limit.values[k]` (knot values of a piecewise linear g),
//! `contacts[i].friction_coefficient` (Coulomb's F; it scales the state-dependent slip bound
//! F |λ_n|, so the data map is affine in it like every other datum), and
//! `thermal.reference_temperature`; in a dynamic scene (design §3.5) also
//! `materials.M.{density, viscosity}` (where the material gives them) and
//! `absorbing[k].damping`. A boundary condition or contact zone is picked by its index
//! `[i]` or by its `name` (`boundary[water_up1].pressure`, `contacts[joint].slip_limit`): a name
//! keeps pointing at its entry when entries are inserted, an index does not, so an index whose
//! entry has a name gets a warning ([`index_path_warnings`]).
//!
//! Linked data (design §4.1): `uncertain[i].drives` lists further numbers the same datum θ sets,
//! each to factor × θ ([`Parameter::fields`]); a search sees one dimension, and the derivative
//! along it is Σ factor × the numbers' derivatives (one stencil moves them together).
//!
//! The scene's own value of every uncertain datum (its nominal value, solved by `wsm solve` and
//! by a run's nominal solve) must lie in the datum's interval ([`parameters`] and the scene's
//! validation refuse it otherwise).
//!
//! A piecewise linear slip limit with `max_slope` C \[Pa/m\] lives in the set U = {lo_k ≤ g_k ≤
//! hi_k, g ≥ 0, |dg/ds| ≤ C} (FGCS 4.15), s the arc length along the zone (knots are fractions of
//! the zone length L, so adjacent knots differ by at most C · L · Δfraction); a knot that is not
//! uncertain keeps its value (lo_k = hi_k). The box of knot values is mapped onto U by the
//! Euclidean projection (Dykstra's algorithm over the slope slabs and the box), so every
//! admissible g is reached (it is its own image) and every θ in the box gives an admissible g
//! ([`applied_values`] are the values a solve uses). U is a lattice (pointwise max and min of
//! two members are members) with the least element L_k = max_j (lo_j − C L |s_k − s_j|)
//! ([`least_slip_limit`]): U is empty unless L ≤ hi ([`parameters`] refuses it), and since the
//! balance of a floating body only gets easier as g grows, L is the one slip limit the balance
//! check needs.
//!
//! Uncertain entries of a stiffness matrix or a conductivity matrix make an interval matrix
//! (FGCS 4.5, 4.7); [`check_interval_matrices`] refuses a box whose margin λ_min(½(B̲ + B̄)) −
//! ρ(½(B̄ − B̲)) (FGCS 4.6, 4.8) is not positive, since only then is every member positive definite.
//! Uncertain orthotropic constants are checked the same way on the unit-diagonal normal compliance
//! with interval entries −ν_ij √(E_j/E_i).

use super::data::{BoundaryValue, Data, Elastic, Expansion};
use super::law::interval_margin;
use super::model::{Conductivity, Material, Scene, SlipLimit, ThermalStress, Uncertain};
use super::rules::Constant;
use super::warning::{Warning, WarningKind};
use super::SceneError;

/// The scene number an uncertain parameter varies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamTarget {
    /// `materials.M.E` of material index M (name order).
    Young(usize),
    /// `materials.M.nu`.
    Poisson(usize),
    /// `materials.M.lambda`.
    Lambda(usize),
    /// `materials.M.mu`.
    Mu(usize),
    /// `materials.M.E1`, `E2`, `E3`: (material, axis 0..3).
    OrthotropicYoung(usize, usize),
    /// `materials.M.nu12`, `nu13`, `nu23`: (material, 0..3 in that order).
    OrthotropicPoisson(usize, usize),
    /// `materials.M.G12`.
    OrthotropicShear(usize),
    /// `materials.M.angle` \[deg\].
    Angle(usize),
    /// `materials.M.matrix[i][j]` with i ≤ j (and its mirror `[j][i]`).
    MatrixEntry(usize, usize, usize),
    /// `materials.M.out_of_plane[k]`.
    OutOfPlane(usize, usize),
    /// `materials.M.specific_weight`.
    SpecificWeight(usize),
    /// `materials.M.body_force[c]`: (material, component).
    BodyForce(usize, usize),
    /// `materials.M.conductivity` (a scalar).
    Conductivity(usize),
    /// `materials.M.conductivity[i][j]` with i ≤ j (and its mirror `[j][i]`).
    ConductivityEntry(usize, usize, usize),
    /// `materials.M.heat_source`.
    HeatSource(usize),
    /// `materials.M.expansion` (α).
    Expansion(usize),
    /// `materials.M.beta` (a scalar).
    Beta(usize),
    /// `materials.M.beta[k]` of a Voigt β.
    BetaEntry(usize, usize),
    /// `boundary[b].displacement[c]`: (condition, component).
    Displacement(usize, usize),
    /// `boundary[b].traction[c]`: (condition, component).
    Traction(usize, usize),
    /// `boundary[b].pressure`.
    Pressure(usize),
    /// `boundary[b].hydrostatic.level`: the level y0 of a hydrostatic pressure (not affine: its
    /// derivative is written exactly by [`stencil`]).
    HydrostaticLevel(usize),
    /// `boundary[b].hydrostatic.unit_weight`.
    UnitWeight(usize),
    /// `boundary[b].temperature`.
    Temperature(usize),
    /// `boundary[b].heat_flux`.
    HeatFlux(usize),
    /// `contacts[c].slip_limit`, a constant g.
    SlipConstant(usize),
    /// `contacts[c].slip_limit.values[k]`: (contact, knot).
    SlipKnot(usize, usize),
    /// `contacts[c].friction_coefficient`.
    FrictionCoefficient(usize),
    /// `thermal.reference_temperature`.
    ReferenceTemperature,
    /// `materials.M.density` of a dynamic scene.
    Density(usize),
    /// `materials.M.viscosity` (the retardation time τ_v) of a dynamic scene.
    Viscosity(usize),
    /// `absorbing[k].damping` of a dynamic scene.
    AbsorbingDamping(usize),
}

impl ParamTarget {
    /// The sign or range rule of the varied number, if it has one.
    fn constant(self) -> Option<Constant> {
        match self {
            ParamTarget::Young(_) | ParamTarget::OrthotropicYoung(..) => Some(Constant::Young),
            ParamTarget::OrthotropicShear(_) => Some(Constant::Mu),
            ParamTarget::OrthotropicPoisson(..) => Some(Constant::OrthotropicPoisson),
            ParamTarget::MatrixEntry(..) | ParamTarget::OutOfPlane(..) => {
                Some(Constant::MatrixEntry)
            }
            ParamTarget::Poisson(_) => Some(Constant::Poisson),
            ParamTarget::Lambda(_) => Some(Constant::Lambda),
            ParamTarget::Mu(_) => Some(Constant::Mu),
            ParamTarget::Conductivity(_) => Some(Constant::Conductivity),
            ParamTarget::SlipConstant(_) | ParamTarget::SlipKnot(..) => Some(Constant::SlipLimit),
            ParamTarget::FrictionCoefficient(_) => Some(Constant::FrictionCoefficient),
            ParamTarget::SpecificWeight(_)
            | ParamTarget::BodyForce(..)
            | ParamTarget::Traction(..)
            | ParamTarget::Pressure(_) => Some(Constant::Load),
            ParamTarget::Displacement(..) => Some(Constant::Displacement),
            ParamTarget::Angle(_) => Some(Constant::Angle),
            ParamTarget::HydrostaticLevel(_) => Some(Constant::Level),
            ParamTarget::UnitWeight(_) => Some(Constant::UnitWeight),
            ParamTarget::Density(_) => Some(Constant::Density),
            ParamTarget::Viscosity(_) => Some(Constant::Retardation),
            ParamTarget::AbsorbingDamping(_) => Some(Constant::Damping),
            _ => None,
        }
    }
}

/// One resolved uncertain parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// Display name: the entry's `name`, or its `field` path.
    pub name: String,
    /// The scene number the parameter varies.
    pub target: ParamTarget,
    /// Lower end of the interval, in the number's unit.
    pub lo: f64,
    /// Upper end of the interval (≥ `lo`; equal when the number is fixed).
    pub hi: f64,
    /// The further numbers the datum drives (`uncertain[i].drives`), each with its factor: the
    /// number is factor × θ.
    pub drives: Vec<(ParamTarget, f64)>,
}

impl Parameter {
    /// Every number the datum sets, with its factor: `target` (factor 1), then `drives`.
    pub fn fields(&self) -> impl Iterator<Item = (ParamTarget, f64)> + '_ {
        std::iter::once((self.target, 1.0)).chain(self.drives.iter().copied())
    }

    /// Every number the datum sets with the interval it sweeps, factor × [lo, hi] in order.
    pub fn field_intervals(&self) -> impl Iterator<Item = (ParamTarget, f64, f64)> + '_ {
        self.fields().map(|(target, factor)| {
            let (a, b) = (factor * self.lo, factor * self.hi);
            (target, a.min(b), a.max(b))
        })
    }
}

/// Split `a.b[2].c[name]` into tokens: names between dots, and in brackets indices (digits) or
/// entry names (anything else but `]`).
fn tokens(path: &str) -> Option<Vec<Token<'_>>> {
    let mut out = Vec::new();
    let mut rest = path;
    loop {
        let end = rest.find(['.', '[']).unwrap_or(rest.len());
        if end > 0 {
            out.push(Token::Name(&rest[..end]));
        }
        rest = &rest[end..];
        while let Some(inner) = rest.strip_prefix('[') {
            let close = inner.find(']')?;
            let key = &inner[..close];
            out.push(match key.trim().parse() {
                Ok(index) => Token::Index(index),
                Err(_) if !key.trim().is_empty() => Token::Key(key),
                Err(_) => return None,
            });
            rest = &inner[close + 1..];
        }
        match rest.strip_prefix('.') {
            Some(after) => rest = after,
            None if rest.is_empty() => return Some(out),
            None => return None,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Token<'a> {
    Name(&'a str),
    Index(usize),
    /// An entry picked by its name: `boundary[water_up1]`.
    Key(&'a str),
}

/// Whether `name` can pick its entry in a field path: not blank, no brackets (they end the
/// selector) and not all digits (that is an index). `None` when it can, else why not.
pub(crate) fn unaddressable(name: &str) -> Option<&'static str> {
    if name.trim().is_empty() {
        Some("is empty")
    } else if name.contains(['[', ']']) {
        Some("contains a bracket, which ends the name in a field path such as boundary[NAME]")
    } else if name.trim().bytes().all(|b| b.is_ascii_digit()) {
        Some("is all digits, which a field path reads as an index")
    } else {
        None
    }
}

/// The index of the entry of `list` (`boundary` or `contacts`, with its entries' names) that
/// the selector picks: `[i]` as it is (the target checks it exists), `[name]` by its name.
fn entry_index<'a>(
    list: &str,
    names: impl Iterator<Item = Option<&'a str>>,
    selector: Token<'_>,
    unknown: Unknown<'_>,
) -> Result<usize, SceneError> {
    let wanted = match selector {
        Token::Index(i) => return Ok(i),
        Token::Key(name) => name,
        Token::Name(_) => return Err(unknown("unknown field")),
    };
    let names: Vec<Option<&str>> = names.collect();
    if let Some(i) = names.iter().position(|n| *n == Some(wanted)) {
        return Ok(i);
    }
    let known: Vec<String> = names.iter().flatten().map(|n| format!("'{n}'")).collect();
    Err(unknown(&if known.is_empty() {
        format!("no {list} entry is named '{wanted}': none has a name (give the entry a `name`, or use its index)")
    } else {
        format!(
            "no {list} entry is named '{wanted}'; the names are {}",
            known.join(", ")
        )
    }))
}

fn boundary_names(scene: &Scene) -> impl Iterator<Item = Option<&str>> {
    scene.boundary.iter().map(|b| b.name.as_deref())
}

fn contact_names(scene: &Scene) -> impl Iterator<Item = Option<&str>> {
    scene.contacts.iter().map(|c| Some(c.name.as_str()))
}

/// Warnings for the uncertain data addressed by the index of an entry that has a name
/// (`uncertain[2].field: boundary[4] is the entry named 'up1'; …`): inserting an entry before
/// it would move the datum onto another entry without any error.
pub fn index_path_warnings(scene: &Scene) -> Vec<Warning> {
    let mut warnings = Vec::new();
    for (i, u) in scene.uncertain.iter().enumerate() {
        let named = match tokens(&u.field).as_deref() {
            Some([Token::Name("boundary"), Token::Index(b), ..]) => scene
                .boundary
                .get(*b)
                .and_then(|bc| bc.name.as_deref())
                .map(|name| ("boundary", *b, name)),
            Some([Token::Name("contacts"), Token::Index(c), ..]) => scene
                .contacts
                .get(*c)
                .map(|contact| ("contacts", *c, contact.name.as_str())),
            _ => None,
        };
        if let Some((list, index, name)) = named {
            warnings.push(Warning::new(
                WarningKind::DataPath,
                format!("uncertain[{i}].field"),
                format!(
                    "{list}[{index}] is the entry named '{name}'; refer to it as {list}[{name}] \
                     so that inserting entries cannot move the datum"
                ),
            ));
        }
    }
    warnings
}

/// The error of an unknown or unsuitable field path, with the reason.
type Unknown<'a> = &'a dyn Fn(&str) -> SceneError;

/// Resolve `uncertain[i]` against the scene and check its interval, then its driven fields
/// (`uncertain[i].drives[k]`: a known number, a finite non-zero factor — positive on a contact
/// force bound, whose least value the balance check takes at θ = lo — and factor × interval within
/// the number's rule). A knot of a slope-limited slip limit is projected with its own interval
/// and can neither drive nor be driven.
fn resolve_uncertain(scene: &Scene, i: usize, u: &Uncertain) -> Result<Parameter, SceneError> {
    let target = resolve_field(scene, &format!("uncertain[{i}].field"), &u.field)?;
    let [lo, hi] = u.interval;
    check_interval(&target, lo, hi, &format!("uncertain[{i}].interval"))?;
    let mut drives = Vec::new();
    for (k, d) in u.drives.iter().enumerate() {
        let path = format!("uncertain[{i}].drives[{k}]");
        let driven = resolve_field(scene, &format!("{path}.field"), &d.field)?;
        for (t, which) in [(target, &u.field), (driven, &d.field)] {
            if is_sloped_knot(scene, t) {
                return Err(SceneError::new(
                    format!("{path}.field"),
                    format!(
                        "'{which}' is a knot of a slip limit with max_slope, projected onto its \
                         slope set with its own interval: it cannot be linked to other data"
                    ),
                ));
            }
        }
        let factor_path = format!("{path}.factor");
        if !d.factor.is_finite() || d.factor == 0.0 {
            return Err(SceneError::new(
                factor_path,
                "the factor must be a finite number other than 0",
            ));
        }
        let bound = matches!(
            driven,
            ParamTarget::SlipConstant(_)
                | ParamTarget::SlipKnot(..)
                | ParamTarget::FrictionCoefficient(_)
        );
        if bound && d.factor < 0.0 {
            return Err(SceneError::new(
                factor_path,
                "a slip limit or friction coefficient must grow with its datum: the factor must be > 0",
            ));
        }
        let (a, b) = (d.factor * lo, d.factor * hi);
        check_interval(&driven, a.min(b), a.max(b), &factor_path)?;
        drives.push((driven, d.factor));
    }
    Ok(Parameter {
        name: u.name.clone().unwrap_or_else(|| u.field.clone()),
        target,
        lo,
        hi,
        drives,
    })
}

/// Whether `target` is a knot of a slip limit with a slope bound.
fn is_sloped_knot(scene: &Scene, target: ParamTarget) -> bool {
    matches!(target, ParamTarget::SlipKnot(c, _)
        if matches!(scene.contacts[c].slip_limit, SlipLimit::PiecewiseLinear { max_slope: Some(_), .. }))
}

/// Resolve the field path `field` (given at `field_path` of the document) to its number.
fn resolve_field(scene: &Scene, field_path: &str, field: &str) -> Result<ParamTarget, SceneError> {
    let unknown = |why: &str| SceneError::new(field_path, format!("'{field}': {why}"));
    let toks = tokens(field).ok_or_else(|| unknown("not a valid field path"))?;
    use Token::Name as N;
    let target =
        match toks.as_slice() {
            [N("materials"), N(m), rest @ ..] => material_target(scene, m, rest, &unknown)?,
            [N("boundary"), entry, rest @ ..] => {
                let b = entry_index("boundary", boundary_names(scene), *entry, &unknown)?;
                boundary_target(scene, b, rest, &unknown)?
            }
            [N("contacts"), entry, rest @ ..] => {
                let c = entry_index("contacts", contact_names(scene), *entry, &unknown)?;
                contact_target(scene, c, rest, &unknown)?
            }
            [N("thermal"), N("reference_temperature")] if scene.thermal.is_some() => {
                ParamTarget::ReferenceTemperature
            }
            [N("absorbing"), Token::Index(k), N("damping")] if *k < scene.absorbing.len() => {
                ParamTarget::AbsorbingDamping(*k)
            }
            [N("absorbing"), ..] => return Err(unknown(
                "an absorbing layer's number is `absorbing[k].damping` with k an existing layer",
            )),
            _ => return Err(unknown("unknown field")),
        };
    Ok(target)
}

/// `materials.NAME.…`: an elastic constant, a load density or a thermal constant of a zone.
fn material_target(
    scene: &Scene,
    m: &str,
    rest: &[Token<'_>],
    unknown: Unknown<'_>,
) -> Result<ParamTarget, SceneError> {
    use Token::{Index as I, Name as N};
    let idx = scene
        .materials
        .keys()
        .position(|k| k == m)
        .ok_or_else(|| unknown("unknown material"))?;
    let mat = &scene.materials[m];
    match rest {
        [N("E")] if mat.young.is_some() => Ok(ParamTarget::Young(idx)),
        [N("nu")] if mat.nu.is_some() => Ok(ParamTarget::Poisson(idx)),
        [N("lambda")] if mat.lambda.is_some() => Ok(ParamTarget::Lambda(idx)),
        [N("mu")] if mat.mu.is_some() => Ok(ParamTarget::Mu(idx)),
        [N("E" | "nu" | "lambda" | "mu")] => Err(unknown(
            "the material is given by the other pair of elastic constants",
        )),
        [N(field @ ("E1" | "E2" | "E3"))] if mat.e1.is_some() => {
            let axis = ["E1", "E2", "E3"].iter().position(|f| f == field);
            Ok(ParamTarget::OrthotropicYoung(idx, axis.unwrap_or(0)))
        }
        [N(field @ ("nu12" | "nu13" | "nu23"))] if mat.e1.is_some() => {
            let k = ["nu12", "nu13", "nu23"].iter().position(|f| f == field);
            Ok(ParamTarget::OrthotropicPoisson(idx, k.unwrap_or(0)))
        }
        [N("G12")] if mat.e1.is_some() => Ok(ParamTarget::OrthotropicShear(idx)),
        [N("angle")] if mat.e1.is_some() => Ok(ParamTarget::Angle(idx)),
        [N("matrix"), I(i), I(j)] if mat.matrix.is_some() && *i < 3 && *j < 3 => {
            Ok(ParamTarget::MatrixEntry(idx, *i.min(j), *i.max(j)))
        }
        [N("out_of_plane"), I(k)] if mat.matrix.is_some() && *k < 3 => {
            Ok(ParamTarget::OutOfPlane(idx, *k))
        }
        [N("specific_weight")] => Ok(ParamTarget::SpecificWeight(idx)),
        [N("body_force"), I(c)] if *c < 2 => Ok(ParamTarget::BodyForce(idx, *c)),
        [N("conductivity")] if !matches!(mat.conductivity, Some(Conductivity::Matrix(_))) => {
            Ok(ParamTarget::Conductivity(idx))
        }
        [N("conductivity"), I(i), I(j)]
            if matches!(mat.conductivity, Some(Conductivity::Matrix(_))) && *i < 2 && *j < 2 =>
        {
            Ok(ParamTarget::ConductivityEntry(idx, *i.min(j), *i.max(j)))
        }
        [N("heat_source")] => Ok(ParamTarget::HeatSource(idx)),
        [N("density" | "viscosity")] if scene.dynamics.is_none() => Err(unknown(
            "a density or viscosity varies only a scene with `dynamics`",
        )),
        [N("density")] if mat.density.is_some() => Ok(ParamTarget::Density(idx)),
        [N("viscosity")] if mat.viscosity.is_some() => Ok(ParamTarget::Viscosity(idx)),
        [N("expansion")] if mat.beta.is_none() => Ok(ParamTarget::Expansion(idx)),
        [N("beta")]
            if mat.expansion.is_none() && !matches!(mat.beta, Some(ThermalStress::Voigt(_))) =>
        {
            Ok(ParamTarget::Beta(idx))
        }
        [N("beta"), I(k)] if matches!(mat.beta, Some(ThermalStress::Voigt(_))) && *k < 4 => {
            Ok(ParamTarget::BetaEntry(idx, *k))
        }
        _ => Err(unknown("not an uncertain-capable material field")),
    }
}

/// `boundary[b].…`: a number of a boundary condition that the condition gives.
fn boundary_target(
    scene: &Scene,
    b: usize,
    rest: &[Token<'_>],
    unknown: Unknown<'_>,
) -> Result<ParamTarget, SceneError> {
    use Token::{Index as I, Name as N};
    let bc = scene
        .boundary
        .get(b)
        .ok_or_else(|| unknown("no such boundary condition"))?;
    match rest {
        [N("displacement"), I(c)]
            if bc
                .displacement
                .is_some_and(|d| d.get(*c).is_some_and(Option::is_some)) =>
        {
            Ok(ParamTarget::Displacement(b, *c))
        }
        [N("traction"), I(c)] if bc.traction.is_some() && *c < 2 => {
            Ok(ParamTarget::Traction(b, *c))
        }
        [N("pressure")] if bc.pressure.is_some() => Ok(ParamTarget::Pressure(b)),
        [N("hydrostatic"), N("level")] if bc.hydrostatic.is_some() => {
            Ok(ParamTarget::HydrostaticLevel(b))
        }
        [N("hydrostatic"), N("unit_weight")] if bc.hydrostatic.is_some() => {
            Ok(ParamTarget::UnitWeight(b))
        }
        [N("temperature")] if bc.temperature.is_some() => Ok(ParamTarget::Temperature(b)),
        [N("heat_flux")] if bc.heat_flux.is_some() => Ok(ParamTarget::HeatFlux(b)),
        _ => Err(unknown("the boundary condition has no such number")),
    }
}

/// `contacts[c].…`: its slip limit or its friction coefficient.
fn contact_target(
    scene: &Scene,
    c: usize,
    rest: &[Token<'_>],
    unknown: Unknown<'_>,
) -> Result<ParamTarget, SceneError> {
    use Token::Name as N;
    match rest {
        [N("slip_limit"), rest @ ..] => slip_limit_target(scene, c, rest, unknown),
        [N("friction_coefficient")] => match scene.contacts.get(c) {
            None => Err(unknown("no such contact zone")),
            Some(contact) if contact.friction_coefficient.is_none() => Err(unknown(
                "the contact zone has a Tresca slip limit, not a friction coefficient",
            )),
            Some(_) => Ok(ParamTarget::FrictionCoefficient(c)),
        },
        _ => Err(unknown("unknown field")),
    }
}

/// `contacts[c].slip_limit` (a constant g) or `contacts[c].slip_limit.values[k]` (a knot).
fn slip_limit_target(
    scene: &Scene,
    c: usize,
    rest: &[Token<'_>],
    unknown: Unknown<'_>,
) -> Result<ParamTarget, SceneError> {
    use Token::{Index as I, Name as N};
    let contact = scene
        .contacts
        .get(c)
        .ok_or_else(|| unknown("no such contact zone"))?;
    if contact.friction_coefficient.is_some() {
        return Err(unknown(
            "the contact zone has Coulomb friction: make friction_coefficient uncertain",
        ));
    }
    match (rest, &contact.slip_limit) {
        ([], SlipLimit::Constant(_)) => Ok(ParamTarget::SlipConstant(c)),
        ([N("values"), I(k)], SlipLimit::PiecewiseLinear { values, .. }) if *k < values.len() => {
            Ok(ParamTarget::SlipKnot(c, *k))
        }
        _ => Err(unknown(
            "use slip_limit for a constant g, slip_limit.values[k] for knots",
        )),
    }
}

/// The interval of a parameter: finite, not inverted, and within the rule of its constant.
fn check_interval(target: &ParamTarget, lo: f64, hi: f64, ipath: &str) -> Result<(), SceneError> {
    if !lo.is_finite() || !hi.is_finite() {
        return Err(SceneError::new(ipath, "bounds must be finite"));
    }
    if lo > hi {
        return Err(SceneError::new(
            ipath,
            format!("inverted interval [{lo}, {hi}]"),
        ));
    }
    if let Some(constant) = target.constant() {
        constant
            .check_interval(lo, hi)
            .map_err(|reason| SceneError::new(ipath, reason))?;
    }
    Ok(())
}

/// Resolve every `uncertain[i]`, check its interval and that the scene's own value of the
/// datum (its nominal value) lies in it: the one rule `wsm solve`, `wsm worst` and the service
/// share through the scene's validation and [`parameters`].
pub(crate) fn resolve_all(scene: &Scene) -> Result<Vec<Parameter>, SceneError> {
    let nominal = Data::from_scene(scene);
    scene
        .uncertain
        .iter()
        .enumerate()
        .map(|(i, u)| {
            let parameter = resolve_uncertain(scene, i, u)?;
            let value = value(&nominal, parameter.target);
            for (k, &(target, factor)) in parameter.drives.iter().enumerate() {
                let own = self::value(&nominal, target);
                let linked = factor * value;
                if (own - linked).abs() > 1e-12 * own.abs().max(linked.abs()) {
                    return Err(SceneError::new(
                        format!("uncertain[{i}].drives[{k}].factor"),
                        format!(
                            "the scene's value {own} of {} is not factor × the nominal value of \
                             {} ({factor} × {value} = {linked}); the datum sets it to factor × θ, \
                             so make the scene's value agree",
                            u.drives[k].field, u.field
                        ),
                    ));
                }
            }
            if parameter.lo <= value && value <= parameter.hi {
                Ok(parameter)
            } else {
                Err(SceneError::new(
                    format!("uncertain[{i}]"),
                    format!(
                        "the nominal value {value} of {} lies outside its interval [{}, {}]; \
                         the scene's own value is the nominal data (solved by `wsm solve` and \
                         first in every run), so set it inside the interval or widen the interval",
                        u.field, parameter.lo, parameter.hi
                    ),
                ))
            }
        })
        .collect()
}

/// Resolve all uncertain parameters of a scene.
pub fn parameters(scene: &Scene) -> Result<Vec<Parameter>, SceneError> {
    let params = resolve_all(scene)?;
    for (i, p) in params.iter().enumerate() {
        // Each number of entry i, with its path, against the numbers set before it.
        let earlier: Vec<ParamTarget> = params[..i]
            .iter()
            .flat_map(|q| q.fields().map(|(t, _)| t))
            .collect();
        let paths = std::iter::once((format!("uncertain[{i}].field"), &scene.uncertain[i].field))
            .chain(
                scene.uncertain[i]
                    .drives
                    .iter()
                    .enumerate()
                    .map(|(k, d)| (format!("uncertain[{i}].drives[{k}].field"), &d.field)),
            );
        for (n, ((target, _), (path, field))) in p.fields().zip(paths).enumerate() {
            let seen = earlier.contains(&target) || p.fields().take(n).any(|(t, _)| t == target);
            if seen {
                return Err(SceneError::new(
                    path,
                    format!("'{field}' is already set by an uncertain datum before it"),
                ));
            }
        }
    }
    check_interval_matrices(scene, &params)?;
    for set in slope_sets(scene, &params) {
        let least = least_slip_limit(&set.knots, set.slope, &set.bounds);
        if let Some(k) = (0..least.len()).find(|&k| least[k] > set.bounds[k].1) {
            return Err(SceneError::new(
                format!("contacts[{}].slip_limit.max_slope", set.contact),
                format!(
                    "no slip limit satisfies the slope bound and the knot intervals: the other \
                     knots' lower bounds force knot {k} to at least {} Pa, above its upper bound \
                     {} Pa (raise max_slope or widen the intervals)",
                    least[k], set.bounds[k].1
                ),
            ));
        }
    }
    Ok(params)
}

/// FGCS (4.6) and (4.8) on the box: per material with uncertain stiffness-matrix entries,
/// conductivity-matrix entries or orthotropic E/ν, the margin λ_min(½(B̲ + B̄)) − ρ(½(B̄ − B̲))
/// of its interval matrix must be positive; the error names the material, its zones and the
/// margin.
pub fn check_interval_matrices(scene: &Scene, params: &[Parameter]) -> Result<(), SceneError> {
    let bounds = FieldBounds(params);
    for (idx, (name, m)) in scene.materials.iter().enumerate() {
        let refuse = |field: &str, what: &str, equation: &str, margin: f64| {
            let zones: Vec<&str> = scene
                .bodies
                .iter()
                .flat_map(|b| &b.zones)
                .filter(|z| &z.material == name)
                .map(|z| z.name.as_str())
                .collect();
            SceneError::new(
                format!("materials.{name}{field}"),
                format!(
                    "the uncertain {what} of material '{name}' (zones {}) fail FGCS ({equation}): \
                     λ_min(½(B̲ + B̄)) − ρ(½(B̄ − B̲)) = {margin:.6e} ≤ 0, so the box may hold \
                     matrices that are not positive definite (narrow the intervals)",
                    zones.join(", ")
                ),
            )
        };
        if let Some(d) = m.matrix {
            if bounds.any(|t| matches!(t, ParamTarget::MatrixEntry(k, ..) if k == idx)) {
                let (lo, hi) = bounds.symmetric_box(&d, |i, j| ParamTarget::MatrixEntry(idx, i, j));
                let margin = interval_margin::<3>(&lo, &hi);
                if margin <= 0.0 {
                    return Err(refuse(".matrix", "stiffness-matrix entries", "4.6", margin));
                }
            }
        }
        if let Some(Conductivity::Matrix(k)) = m.conductivity {
            if bounds.any(|t| matches!(t, ParamTarget::ConductivityEntry(c, ..) if c == idx)) {
                let (lo, hi) =
                    bounds.symmetric_box(&k, |i, j| ParamTarget::ConductivityEntry(idx, i, j));
                let margin = interval_margin::<2>(&lo, &hi);
                if margin <= 0.0 {
                    let what = "conductivity-matrix entries";
                    return Err(refuse(".conductivity", what, "4.8", margin));
                }
            }
        }
        if let Some((lo, hi)) = orthotropic_compliance_box(&bounds, idx, m) {
            let margin = interval_margin::<3>(&lo, &hi);
            if margin <= 0.0 {
                let what = "orthotropic constants (their unit-diagonal normal compliance)";
                return Err(refuse("", what, "4.6", margin));
            }
        }
    }
    Ok(())
}

/// The entrywise lower and upper bounds of an interval matrix.
type MatrixBox<const N: usize> = ([[f64; N]; N], [[f64; N]; N]);

/// The intervals of the uncertain fields, as the parameters give them.
struct FieldBounds<'a>(&'a [Parameter]);

impl FieldBounds<'_> {
    /// The interval of `target`, or the point `nominal` when no parameter drives it.
    fn of(&self, target: ParamTarget, nominal: f64) -> (f64, f64) {
        self.0
            .iter()
            .flat_map(Parameter::field_intervals)
            .find(|f| f.0 == target)
            .map_or((nominal, nominal), |(_, lo, hi)| (lo, hi))
    }

    /// Whether a parameter drives a field matching `target`.
    fn any(&self, target: impl Fn(ParamTarget) -> bool) -> bool {
        self.0
            .iter()
            .flat_map(Parameter::fields)
            .any(|(t, _)| target(t))
    }

    /// The entrywise lower and upper bounds of a symmetric matrix whose entry (i, j), i ≤ j, is
    /// the field `entry(i, j)`.
    fn symmetric_box<const N: usize>(
        &self,
        nominal: &[[f64; N]; N],
        entry: impl Fn(usize, usize) -> ParamTarget,
    ) -> MatrixBox<N> {
        let bound = |i: usize, j: usize| self.of(entry(i.min(j), i.max(j)), nominal[i][j]);
        (
            std::array::from_fn(|i| std::array::from_fn(|j| bound(i, j).0)),
            std::array::from_fn(|i| std::array::from_fn(|j| bound(i, j).1)),
        )
    }
}

/// The interval box of an orthotropic material's unit-diagonal normal compliance, entries
/// −ν_ij √(E_j/E_i) by interval arithmetic, when material `idx` is orthotropic with uncertain
/// constants.
fn orthotropic_compliance_box(
    bounds: &FieldBounds,
    idx: usize,
    m: &Material,
) -> Option<MatrixBox<3>> {
    let varies = bounds.any(|t| {
        matches!(t, ParamTarget::OrthotropicYoung(k, _) | ParamTarget::OrthotropicPoisson(k, _)
            if k == idx)
    });
    let (true, Some(e1), Some(e2), Some(e3), Some(n12), Some(n13), Some(n23)) =
        (varies, m.e1, m.e2, m.e3, m.nu12, m.nu13, m.nu23)
    else {
        return None;
    };
    let young: [(f64, f64); 3] =
        std::array::from_fn(|k| bounds.of(ParamTarget::OrthotropicYoung(idx, k), [e1, e2, e3][k]));
    let poisson: [(f64, f64); 3] = std::array::from_fn(|k| {
        bounds.of(ParamTarget::OrthotropicPoisson(idx, k), [n12, n13, n23][k])
    });
    let coupling = |i: usize, j: usize, (nlo, nhi): (f64, f64)| {
        let (rlo, rhi) = (
            (young[j].0 / young[i].1).sqrt(),
            (young[j].1 / young[i].0).sqrt(),
        );
        let corners = [-nlo * rlo, -nlo * rhi, -nhi * rlo, -nhi * rhi];
        (
            corners.iter().copied().fold(f64::INFINITY, f64::min),
            corners.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    };
    let off = [
        coupling(0, 1, poisson[0]),
        coupling(0, 2, poisson[1]),
        coupling(1, 2, poisson[2]),
    ];
    let box_of = |pick: fn((f64, f64)) -> f64| {
        [
            [1.0, pick(off[0]), pick(off[1])],
            [pick(off[0]), 1.0, pick(off[2])],
            [pick(off[1]), pick(off[2]), 1.0],
        ]
    };
    Some((box_of(|b| b.0), box_of(|b| b.1)))
}

/// Write θ into a copy of the nominal data, then map slope-limited slip limits onto their sets.
pub fn apply(scene: &Scene, nominal: &Data, params: &[Parameter], theta: &[f64]) -> Data {
    let mut data = nominal.clone();
    for (p, &v) in params.iter().zip(theta) {
        for (target, factor) in p.fields() {
            set(&mut data, target, factor * v);
        }
    }
    for set in slope_sets(scene, params) {
        let slip = &mut data.slip[set.contact];
        slip.values = project_slope(&slip.values, &slip.knots, set.slope, &set.bounds);
    }
    data
}

/// The value each parameter's datum takes in the data of θ: θ itself, except for the knots of
/// slope-limited slip limits, which take their projected values.
pub fn applied_values(
    scene: &Scene,
    nominal: &Data,
    params: &[Parameter],
    theta: &[f64],
) -> Vec<f64> {
    let data = apply(scene, nominal, params, theta);
    params
        .iter()
        .zip(theta)
        .map(|(p, &v)| match p.target {
            ParamTarget::SlipKnot(c, k) => data.slip[c].values[k],
            _ => v,
        })
        .collect()
}

/// The value each parameter's datum takes in `data` (e.g. the nominal data).
pub fn values(data: &Data, params: &[Parameter]) -> Vec<f64> {
    params.iter().map(|p| value(data, p.target)).collect()
}

/// Set the slope-limited slip limits of `data` to the least elements of their sets.
pub fn least_slip_limits(scene: &Scene, params: &[Parameter], data: &mut Data) {
    for set in slope_sets(scene, params) {
        data.slip[set.contact].values = least_slip_limit(&set.knots, set.slope, &set.bounds);
    }
}

/// The admissible set of one slope-limited slip limit: its knots (fractions), the slope bound
/// per fraction (C × zone length) and the bounds of each knot value.
struct SlopeSet {
    contact: usize,
    knots: Vec<f64>,
    slope: f64,
    bounds: Vec<(f64, f64)>,
}

/// The slope-limited slip limits of the scene, with the scene's value as both bounds of a knot
/// that is not uncertain.
fn slope_sets(scene: &Scene, params: &[Parameter]) -> Vec<SlopeSet> {
    scene
        .contacts
        .iter()
        .enumerate()
        .filter_map(|(c, contact)| {
            let SlipLimit::PiecewiseLinear {
                knots,
                values,
                max_slope: Some(slope),
            } = &contact.slip_limit
            else {
                return None;
            };
            let bounds = (0..values.len())
                .map(|k| {
                    params
                        .iter()
                        .find(|p| p.target == ParamTarget::SlipKnot(c, k))
                        .map_or((values[k], values[k]), |p| (p.lo, p.hi))
                })
                .collect();
            Some(SlopeSet {
                contact: c,
                knots: knots.clone(),
                slope: slope * zone_length(scene, c),
                bounds,
            })
        })
        .collect()
}

/// Arc length \[m\] of contact zone `c` along body k's segment (its knots' reference).
fn zone_length(scene: &Scene, c: usize) -> f64 {
    scene
        .segments
        .get(&scene.contacts[c].between[0])
        .map_or(0.0, |segment| {
            segment
                .polyline()
                .windows(2)
                .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
                .sum()
        })
}

/// The least element of {lo ≤ g ≤ hi, g ≥ 0, |g_j − g_k| ≤ slope |s_j − s_k|}: L_k = max_j
/// (max(lo_j, 0) − slope |s_k − s_j|); a member of the set exactly when the set is not empty
/// (L ≤ hi).
pub fn least_slip_limit(knots: &[f64], slope: f64, bounds: &[(f64, f64)]) -> Vec<f64> {
    knots
        .iter()
        .map(|&s| {
            knots
                .iter()
                .zip(bounds)
                .map(|(&t, &(lo, _))| lo.max(0.0) - slope * (s - t).abs())
                .fold(0.0_f64, f64::max)
        })
        .collect()
}

/// Data at the points θ + t_k e_i with weights w_k such that Σ_k w_k F(D_k) is the derivative
/// of F(D(θ)) along θ_i (design §4.3); the sensitivities of the state problem are built on it.
///
/// Along one parameter every map from θ to `Data` is affine (E, λ, μ, G12, matrix entries, α, β
/// and conductivities enter the coefficients linearly), and the quantities the sensitivities
/// combine are at most quadratic (β (T + t dT − T0)), except Poisson's ratio, the orthotropic
/// E1, E2, E3, ν12, ν13, ν23 and angle (D is rational in the former, trigonometric in the angle)
/// and the knots of a slope-limited slip limit. For
/// the former the stencil is exact for degree ≤ 2 with a long step (0.1 × width: rounding only,
/// ≈ 1e-15 relative); for ν it is of order 4 with a step well inside the poles at ν = 0.5 and
/// ν = −1 (≈ 1e-12 relative), and for the orthotropic constants of order 4 with the step 1e-3 ×
/// max(|θ_i|, width); for slope-limited knots, whose projection is piecewise linear, it
/// is exact on each piece with a short step.
#[derive(Debug, Clone)]
pub struct Stencil {
    /// (t_k, w_k, D_k).
    pub points: Vec<(f64, f64, Data)>,
}

/// Step of the affine parameters, relative to the interval width.
const AFFINE_STEP: f64 = 0.1;
/// Step of the non-affine parameters, relative to max(|θ_i|, width) (and for ν to the distance
/// to its poles).
const SHORT_STEP: f64 = 1e-6;
/// Step of ν relative to its scale (order 4: truncation ≈ (step / distance to a pole)⁴).
const POISSON_STEP: f64 = 1e-3;

/// Derivative formulas as (offset in steps, weight × step) per point.
const CENTRAL_2: &[(f64, f64)] = &[(-1.0, -0.5), (1.0, 0.5)];
const FORWARD_2: &[(f64, f64)] = &[(0.0, -1.5), (1.0, 2.0), (2.0, -0.5)];
const CENTRAL_4: &[(f64, f64)] = &[
    (-2.0, 1.0 / 12.0),
    (-1.0, -8.0 / 12.0),
    (1.0, 8.0 / 12.0),
    (2.0, -1.0 / 12.0),
];
const FORWARD_4: &[(f64, f64)] = &[
    (0.0, -25.0 / 12.0),
    (1.0, 4.0),
    (2.0, -3.0),
    (3.0, 4.0 / 3.0),
    (4.0, -0.25),
];

/// The derivative stencil of parameter `i` at θ: central when its points lie in the box,
/// otherwise one-sided pointing into it (see [`Stencil`] for the formulas and steps). A datum
/// that drives several numbers takes the shortest of their steps (in units of θ) and the higher
/// order of their formulas; its derivative is then Σ factor × the numbers' derivatives.
///
/// A hydrostatic level y0 is not differenced: its numbers stay at factor × θ_i in those points,
/// and two more points at t = 0, the data with `wet_pressure` = factor × γ (weight 1) and without
/// (weight −1), add the exact load derivative factor × γ H(y0 − y) (design §2.6).
pub fn stencil(
    scene: &Scene,
    nominal: &Data,
    params: &[Parameter],
    theta: &[f64],
    i: usize,
) -> Stencil {
    let p = &params[i];
    let x = theta[i];
    let width = p.hi - p.lo;
    let differenced: Vec<(ParamTarget, f64)> = p
        .fields()
        .filter(|(t, _)| !matches!(t, ParamTarget::HydrostaticLevel(_)))
        .collect();
    let levels: Vec<(usize, f64)> = p
        .fields()
        .filter_map(|(t, factor)| match t {
            ParamTarget::HydrostaticLevel(b) => Some((b, factor)),
            _ => None,
        })
        .collect();
    let mut points = Vec::new();
    let rules: Vec<StepRule> = differenced
        .iter()
        .map(|&(target, factor)| {
            let (h, central, forward) = step_rule(scene, target, factor * x, factor.abs() * width);
            (h / factor.abs(), central, forward)
        })
        .collect();
    if let Some(&(mut h, _, _)) = rules.first() {
        let (mut central, mut forward) = (CENTRAL_2, FORWARD_2);
        for &(h_k, central_k, forward_k) in &rules {
            h = h.min(h_k);
            if central_k.len() > central.len() {
                (central, forward) = (central_k, forward_k);
            }
        }
        let reach = |taps: &[(f64, f64)]| taps.iter().fold(0.0_f64, |m, (t, _)| m.max(t.abs())) * h;
        let taps: Vec<(f64, f64)> = if x - reach(central) >= p.lo && x + reach(central) <= p.hi
            || width < 2.0 * reach(central)
        {
            central.to_vec()
        } else if x + reach(forward) <= p.hi {
            forward.to_vec()
        } else {
            forward.iter().map(|&(t, w)| (-t, -w)).collect()
        };
        points = taps
            .iter()
            .map(|&(steps, weight)| {
                let mut at = theta.to_vec();
                at[i] = x + steps * h;
                let mut data = apply(scene, nominal, params, &at);
                for &(b, factor) in &levels {
                    set(&mut data, ParamTarget::HydrostaticLevel(b), factor * x);
                }
                (steps * h, weight / h, data)
            })
            .collect();
    }
    if !levels.is_empty() {
        let at = apply(scene, nominal, params, theta);
        let mut wet = at.clone();
        for &(b, factor) in &levels {
            if let BoundaryValue::Hydrostatic(h) = &mut wet.boundary[b].value {
                h.wet_pressure = factor * h.unit_weight;
            }
        }
        points.push((0.0, 1.0, wet));
        points.push((0.0, -1.0, at));
    }
    Stencil { points }
}

/// A step and the central and one-sided formulas of one number.
type StepRule = (f64, &'static [(f64, f64)], &'static [(f64, f64)]);

/// The step and formulas of a number at the value `x` swept over an interval of `width`.
fn step_rule(scene: &Scene, target: ParamTarget, x: f64, width: f64) -> StepRule {
    let scale = x.abs().max(width).max(f64::MIN_POSITIVE);
    match target {
        ParamTarget::Poisson(_) => (
            POISSON_STEP * scale.min(0.5 - x).min(1.0 + x),
            CENTRAL_4,
            FORWARD_4,
        ),
        ParamTarget::OrthotropicYoung(..)
        | ParamTarget::OrthotropicPoisson(..)
        | ParamTarget::Angle(_)
            if width > 0.0 =>
        {
            (POISSON_STEP * scale, CENTRAL_4, FORWARD_4)
        }
        _ if is_sloped_knot(scene, target) || width == 0.0 => {
            (SHORT_STEP * scale, CENTRAL_2, FORWARD_2)
        }
        _ => (AFFINE_STEP * width, CENTRAL_2, FORWARD_2),
    }
}

/// The value of the datum `target` in `data` (what [`set`] writes; 0 where the scene leaves the
/// number out and the data read it as zero).
fn value(data: &Data, target: ParamTarget) -> f64 {
    use ParamTarget as T;
    let material = |m: usize| &data.materials[m];
    match target {
        T::Young(m) | T::Poisson(m) | T::Lambda(m) | T::Mu(m) => {
            match (target, material(m).elastic) {
                (T::Young(_), Elastic::Young { e, .. }) => e,
                (T::Poisson(_), Elastic::Young { nu, .. }) => nu,
                (T::Lambda(_), Elastic::Lame { lambda, .. }) => lambda,
                (T::Mu(_), Elastic::Lame { mu, .. }) => mu,
                _ => 0.0,
            }
        }
        T::OrthotropicYoung(m, _)
        | T::OrthotropicPoisson(m, _)
        | T::OrthotropicShear(m)
        | T::Angle(m) => match (target, material(m).elastic) {
            (T::OrthotropicYoung(_, k), Elastic::Orthotropic(o)) => o.young[k],
            (T::OrthotropicPoisson(_, k), Elastic::Orthotropic(o)) => o.poisson[k],
            (T::OrthotropicShear(_), Elastic::Orthotropic(o)) => o.shear,
            (_, Elastic::Orthotropic(o)) => o.angle,
            _ => 0.0,
        },
        T::MatrixEntry(m, i, j) => match material(m).elastic {
            Elastic::Matrix(law) => law.d[i][j],
            _ => 0.0,
        },
        T::OutOfPlane(m, k) => match material(m).elastic {
            Elastic::Matrix(law) => law.out_of_plane[k],
            _ => 0.0,
        },
        T::SpecificWeight(m) => material(m).specific_weight,
        T::BodyForce(m, c) => material(m).body_force[c],
        T::Conductivity(m) => material(m).conductivity[0],
        T::ConductivityEntry(m, i, j) => material(m).conductivity[i + j],
        T::HeatSource(m) => material(m).heat_source,
        T::Expansion(m) | T::Beta(m) | T::BetaEntry(m, _) => {
            match (target, material(m).expansion) {
                (T::Expansion(_), Expansion::Alpha(a)) => a,
                (T::Beta(_), Expansion::Beta(b)) => b,
                (T::BetaEntry(_, k), Expansion::Voigt(b)) => b[k],
                _ => 0.0,
            }
        }
        T::Displacement(b, c) => match data.boundary[b].value {
            BoundaryValue::Displacement(d) => d[c].unwrap_or(0.0),
            _ => 0.0,
        },
        T::Traction(b, c) => match data.boundary[b].value {
            BoundaryValue::Traction(t) => t[c],
            _ => 0.0,
        },
        T::HydrostaticLevel(b) | T::UnitWeight(b) => match data.boundary[b].value {
            BoundaryValue::Hydrostatic(h) if matches!(target, T::HydrostaticLevel(_)) => h.level,
            BoundaryValue::Hydrostatic(h) => h.unit_weight,
            _ => 0.0,
        },
        T::Pressure(b) | T::Temperature(b) | T::HeatFlux(b) => match data.boundary[b].value {
            BoundaryValue::Pressure(v)
            | BoundaryValue::Temperature(v)
            | BoundaryValue::HeatFlux(v) => v,
            _ => 0.0,
        },
        T::SlipConstant(c) => data.slip[c].values[0],
        T::SlipKnot(c, k) => data.slip[c].values[k],
        T::FrictionCoefficient(c) => data.friction[c].unwrap_or(0.0),
        T::ReferenceTemperature => data.reference_temperature,
        T::Density(m) => data.dynamic.density[m],
        T::Viscosity(m) => data.dynamic.viscosity[m],
        T::AbsorbingDamping(k) => data.dynamic.absorbing[k],
    }
}

fn set(data: &mut Data, target: ParamTarget, v: f64) {
    use ParamTarget as T;
    match target {
        T::Young(m) | T::Poisson(m) | T::Lambda(m) | T::Mu(m) => {
            let el = &mut data.materials[m].elastic;
            match (target, el) {
                (T::Young(_), Elastic::Young { e, .. }) => *e = v,
                (T::Poisson(_), Elastic::Young { nu, .. }) => *nu = v,
                (T::Lambda(_), Elastic::Lame { lambda, .. }) => *lambda = v,
                (T::Mu(_), Elastic::Lame { mu, .. }) => *mu = v,
                _ => {}
            }
        }
        T::OrthotropicYoung(m, _)
        | T::OrthotropicPoisson(m, _)
        | T::OrthotropicShear(m)
        | T::Angle(m) => {
            if let Elastic::Orthotropic(o) = &mut data.materials[m].elastic {
                match target {
                    T::OrthotropicYoung(_, k) => o.young[k] = v,
                    T::OrthotropicPoisson(_, k) => o.poisson[k] = v,
                    T::OrthotropicShear(_) => o.shear = v,
                    _ => o.angle = v,
                }
            }
        }
        T::MatrixEntry(m, i, j) => {
            if let Elastic::Matrix(law) = &mut data.materials[m].elastic {
                law.d[i][j] = v;
                law.d[j][i] = v;
            }
        }
        T::OutOfPlane(m, k) => {
            if let Elastic::Matrix(law) = &mut data.materials[m].elastic {
                law.out_of_plane[k] = v;
            }
        }
        T::SpecificWeight(m) => data.materials[m].specific_weight = v,
        T::BodyForce(m, c) => data.materials[m].body_force[c] = v,
        T::Conductivity(m) => data.materials[m].conductivity = [v, 0.0, v],
        T::ConductivityEntry(m, i, j) => data.materials[m].conductivity[i + j] = v,
        T::BetaEntry(m, k) => {
            if let Expansion::Voigt(b) = &mut data.materials[m].expansion {
                b[k] = v;
            }
        }
        T::HeatSource(m) => data.materials[m].heat_source = v,
        T::Expansion(m) => data.materials[m].expansion = Expansion::Alpha(v),
        T::Beta(m) => data.materials[m].expansion = Expansion::Beta(v),
        T::Displacement(b, c) => {
            if let BoundaryValue::Displacement(d) = &mut data.boundary[b].value {
                d[c] = Some(v);
            }
        }
        T::Traction(b, c) => {
            if let BoundaryValue::Traction(t) = &mut data.boundary[b].value {
                t[c] = v;
            }
        }
        T::Pressure(b) => data.boundary[b].value = BoundaryValue::Pressure(v),
        T::HydrostaticLevel(b) | T::UnitWeight(b) => {
            if let BoundaryValue::Hydrostatic(h) = &mut data.boundary[b].value {
                match target {
                    T::HydrostaticLevel(_) => h.level = v,
                    _ => h.unit_weight = v,
                }
            }
        }
        T::Temperature(b) => data.boundary[b].value = BoundaryValue::Temperature(v),
        T::HeatFlux(b) => data.boundary[b].value = BoundaryValue::HeatFlux(v),
        T::SlipConstant(c) => data.slip[c].values = vec![v],
        T::SlipKnot(c, k) => data.slip[c].values[k] = v,
        T::FrictionCoefficient(c) => data.friction[c] = Some(v),
        T::ReferenceTemperature => data.reference_temperature = v,
        T::Density(m) => data.dynamic.density[m] = v,
        T::Viscosity(m) => data.dynamic.viscosity[m] = v,
        T::AbsorbingDamping(k) => data.dynamic.absorbing[k] = v,
    }
}

/// Euclidean projection of knot values onto {lo ≤ g ≤ hi, g ≥ 0, |g_{k+1} − g_k| ≤ C (s_{k+1} − s_k)}
/// by Dykstra's alternating projections (exact limit; iterated to 1e-13 relative).
/// `knots` are fractions of the zone and `slope` the bound per fraction (C × zone length).
pub fn project_slope(values: &[f64], knots: &[f64], slope: f64, bounds: &[(f64, f64)]) -> Vec<f64> {
    let n = values.len();
    let mut x = values.to_vec();
    // One correction vector per constraint set: the box and each slab.
    let mut p_box = vec![0.0; n];
    let mut p_slab = vec![[0.0; 2]; n.saturating_sub(1)];
    let scale = values.iter().fold(1e-300_f64, |m, v| m.max(v.abs()));
    for _ in 0..10_000 {
        let before = x.clone();
        for k in 0..n {
            let y = x[k] + p_box[k];
            let (lo, hi) = bounds.get(k).copied().unwrap_or((0.0, f64::INFINITY));
            x[k] = y.clamp(lo.max(0.0), hi.max(lo.max(0.0)));
            p_box[k] = y - x[k];
        }
        for k in 0..n.saturating_sub(1) {
            let limit = slope * (knots[k + 1] - knots[k]);
            let (a, b) = (x[k] + p_slab[k][0], x[k + 1] + p_slab[k][1]);
            let diff = b - a;
            let excess = diff.abs() - limit;
            let (na, nb) = if excess > 0.0 {
                let shift = 0.5 * excess * diff.signum();
                (a + shift, b - shift)
            } else {
                (a, b)
            };
            p_slab[k] = [a - na, b - nb];
            x[k] = na;
            x[k + 1] = nb;
        }
        let change = x
            .iter()
            .zip(&before)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        if change <= 1e-13 * scale {
            break;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_parse_names_and_indices() {
        assert_eq!(
            tokens("boundary[2].traction[0]").unwrap(),
            vec![
                Token::Name("boundary"),
                Token::Index(2),
                Token::Name("traction"),
                Token::Index(0)
            ]
        );
        assert_eq!(
            tokens("contacts[dam foundation.joint].friction_coefficient").unwrap(),
            vec![
                Token::Name("contacts"),
                Token::Key("dam foundation.joint"),
                Token::Name("friction_coefficient")
            ]
        );
        assert!(tokens("boundary[]").is_none());
        assert!(tokens("boundary[2]traction").is_none());
        assert!(tokens("boundary[up1").is_none());
    }

    #[test]
    fn slope_projection_is_identity_inside_and_feasible_outside() {
        let knots = [0.0, 0.5, 1.0];
        let b = [(0.0, 10.0); 3];
        let inside = project_slope(&[1.0, 1.2, 1.4], &knots, 1.0, &b);
        assert!(inside
            .iter()
            .zip([1.0, 1.2, 1.4])
            .all(|(a, b)| (a - b).abs() < 1e-12));
        let out = project_slope(&[0.0, 5.0, 0.0], &knots, 1.0, &b);
        for k in 0..2 {
            assert!((out[k + 1] - out[k]).abs() <= 0.5 + 1e-9, "{out:?}");
        }
        // Symmetric input, symmetric projection; the middle is pulled down by the same amount the
        // ends are pulled up: (0+a, 5-2a, 0+a) with 5-3a = 0.5 → a = 1.5.
        assert!(
            (out[0] - 1.5).abs() < 1e-6 && (out[1] - 2.0).abs() < 1e-6,
            "{out:?}"
        );
    }

    /// The least element is a member of the set and below each of its members (a lattice).
    #[test]
    fn least_slip_limit_is_the_least_member() {
        let knots = [0.0, 0.25, 1.0];
        let bounds = [(5.0, 6.0), (0.0, 6.0), (1.0, 6.0)];
        let slope = 8.0;
        let least = least_slip_limit(&knots, slope, &bounds);
        assert_eq!(least, vec![5.0, 3.0, 1.0]);
        for values in [[6.0, 6.0, 6.0], [5.0, 0.0, 0.0], [6.0, 2.0, 5.0]] {
            let member = project_slope(&values, &knots, slope, &bounds);
            assert!(
                member.iter().zip(&least).all(|(m, l)| m >= &(l - 1e-9)),
                "{member:?}"
            );
        }
        assert_eq!(project_slope(&least, &knots, slope, &bounds), least);
    }

    /// `max_slope` is in Pa per metre of the zone; a set the slope bound empties is refused
    /// naming the field.
    #[test]
    fn max_slope_is_per_metre_and_an_empty_set_is_refused() {
        let text = include_str!("../../../scenes/tunnel-fault-slip-profile.json");
        let scene = crate::parse(text).unwrap();
        assert!((zone_length(&scene, 0) - 22.0).abs() < 1e-9);
        let params = parameters(&scene).unwrap();
        let problem_data = crate::data::Data::from_scene(&scene);
        let mut theta: Vec<f64> = params.iter().map(|p| p.lo).collect();
        theta[1] = 1.5e6;
        let g = &apply(&scene, &problem_data, &params, &theta).slip[0].values;
        // 4e4 Pa/m over 11 m between adjacent knots: 0.44 MPa, not 4e4 × 0.5.
        assert!(((g[1] - g[0]) - 4.4e5).abs() < 1.0, "{g:?}");
        assert!(((g[1] - g[2]) - 4.4e5).abs() < 1.0, "{g:?}");

        let mut value: serde_json::Value = serde_json::from_str(text).unwrap();
        value["uncertain"][0]["interval"] = serde_json::json!([1.4e6, 1.5e6]);
        value["uncertain"][1]["interval"] = serde_json::json!([3e5, 4e5]);
        value["contacts"][0]["slip_limit"]["values"] = serde_json::json!([1.45e6, 3.5e5, 1.1e6]);
        let scene = crate::parse(&value.to_string()).unwrap();
        let error = parameters(&scene).unwrap_err();
        assert_eq!(error.path, "contacts[0].slip_limit.max_slope");
        assert!(error.reason.contains("knot 1"), "{}", error.reason);
    }
}
