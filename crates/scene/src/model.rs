//! Serde model of the scene document (design §5.2, format version 1).
//!
//! A scene is one JSON document: bodies made of material zones (polygons with holes), named
//! boundary segments, boundary conditions by segment name, materials, contact zones between two
//! bodies' segments, an optional thermal part, mesh controls, criteria regions, the admissible set
//! of uncertain data and the search settings. All quantities are SI (m, Pa, N/m³, K, W/m³, W/m²).
//! This module only describes the shape of the document; `validate` checks its meaning.

use super::dynamics::{AbsorbingLayer, Dynamics, PointLoad, Receiver, TimeFunction};
use super::rules::{
    MAX_ANGLE, MAX_CONDUCTIVITY, MAX_FRICTION, MAX_LEVEL, MAX_STRESS, MAX_UNIT_WEIGHT,
    MIN_CONDUCTIVITY, MIN_MODULUS,
};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
pub use wsm_search::StopRule;

/// A point `[x, y]` in metres.
pub type Point = [f64; 2];

/// The whole scene document: format version 1, all quantities SI (m, Pa, N/m³, K, W/(m K),
/// W/m³, W/m²).
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// The JSON Schema the document declares for editors (`"$schema"`, e.g. the path of
    /// `openapi/scene.schema.json`); wsm reads and ignores it (design §5.2).
    #[serde(rename = "$schema", default, skip_serializing)]
    pub schema: Option<String>,
    /// Format version; only `1` exists.
    #[schemars(range(equal = 1))]
    pub version: u32,
    /// Human-readable name.
    #[serde(default)]
    pub name: String,
    /// Free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Elastic bodies Ω^ι, each the union of its zones.
    pub bodies: Vec<Body>,
    /// Named boundary segments (polylines on a body's boundary).
    #[serde(default)]
    pub segments: BTreeMap<String, Segment>,
    /// Materials by name.
    pub materials: BTreeMap<String, Material>,
    /// Boundary conditions by segment name; each entry sets exactly one condition.
    #[serde(default)]
    pub boundary: Vec<BoundaryCondition>,
    /// Contact zones Γ^kl between two bodies.
    #[serde(default)]
    pub contacts: Vec<Contact>,
    /// Stationary heat problem (FGCS P1); absent means no thermal part.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thermal: Option<Thermal>,
    /// Mesh controls.
    pub mesh: MeshControls,
    /// Criteria regions G_r and boundary pieces G'_r.
    #[serde(default)]
    pub criteria: CriteriaRegions,
    /// Uncertain data: each entry points at a scene number and gives its interval.
    #[serde(default)]
    pub uncertain: Vec<Uncertain>,
    /// Worst-scenario search settings.
    #[serde(default)]
    pub search: SearchSettings,
    /// Inner solver settings.
    #[serde(default)]
    pub solver: SolverSettings,
    /// Time grid and integrator: present, the scene is a dynamic problem (design §3.6).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dynamics: Option<Dynamics>,
    /// Absorbing layers (dynamic scenes only).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub absorbing: Vec<AbsorbingLayer>,
    /// Points whose displacement, velocity and acceleration the history records (dynamic
    /// scenes only).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub receivers: Vec<Receiver>,
    /// Point forces with time functions, e.g. seismic sources (dynamic scenes only; PDAS paper
    /// §2: a volume force at the source point).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub point_loads: Vec<PointLoad>,
}

/// One elastic body.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Body {
    /// Body name, unique in the scene; segments refer to the body by it.
    pub name: String,
    /// Material zones Ω^ι_j; they must not overlap and together form the body.
    pub zones: Vec<Zone>,
    /// Initial velocity `[vx, vy]` \[m/s\] of every node of the body (dynamic scenes only),
    /// added on top of the `dynamics.initial` state (design §3.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_velocity: Option<[f64; 2]>,
}

/// A material zone: a simple polygon (either orientation) with optional holes.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Zone {
    /// Zone name, unique in the scene (with `gmsh_file`: the physical name of the 2D entities).
    pub name: String,
    /// Name of an entry of `materials`.
    pub material: String,
    /// Outer boundary: at least three vertices `[x, y]` \[m\], not self-intersecting; the first
    /// point need not be repeated at the end.
    pub polygon: Vec<Point>,
    /// Holes cut out of the zone, each a polygon like `polygon`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub holes: Vec<Vec<Point>>,
}

/// A boundary segment: the part of a body's boundary lying on a polyline.
///
/// Either `from`/`to` (a straight piece) or `path` (a polyline, `closed` for a whole loop such as
/// the rim of a hole) must be given.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Segment {
    /// Name of the body on whose boundary the segment lies.
    pub body: String,
    /// Start point \[m\] of a straight segment (with `to`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<Point>,
    /// End point \[m\] of a straight segment (with `from`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<Point>,
    /// Vertices \[m\] of a polyline segment, instead of `from`/`to`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<Vec<Point>>,
    /// Whether `path` is a closed loop (its last point joins the first); default false.
    #[serde(default)]
    pub closed: bool,
}

impl Segment {
    /// The polyline of the segment (closed loops repeat their first point at the end).
    pub fn polyline(&self) -> Vec<Point> {
        let mut pts = match (&self.path, self.from, self.to) {
            (Some(p), _, _) => p.clone(),
            (None, Some(a), Some(b)) => vec![a, b],
            _ => Vec::new(),
        };
        if self.closed && pts.len() > 2 && pts.first() != pts.last() {
            pts.push(pts[0]);
        }
        pts
    }
}

/// Material of a zone: an elastic law, loads and thermal constants.
///
/// The elastic law is exactly one of: isotropic (`E`, `nu`) or (`lambda`, `mu`); orthotropic
/// (`E1`, `E2`, `E3`, `nu12`, `nu13`, `nu23`, `G12`, optional `angle`); or the plane-strain
/// matrix itself (`matrix`, `out_of_plane`). Voigt order (e11, e22, γ12) with engineering shear
/// γ12 = 2 e12 (design §2.1).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Isotropic: Young's modulus E \[Pa\] (with `nu`).
    #[serde(rename = "E", default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = MIN_MODULUS, max = MAX_STRESS))]
    pub young: Option<f64>,
    /// Isotropic: Poisson's ratio ν [-] (with `E`), in (−1, ½).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = -1.0, "exclusiveMaximum" = 0.5))]
    pub nu: Option<f64>,
    /// Isotropic: Lamé's first parameter λ \[Pa\] (with `mu`): 0 or in \[1e-3, 1e15\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0.0, max = MAX_STRESS))]
    pub lambda: Option<f64>,
    /// Isotropic: shear modulus μ \[Pa\] (with `lambda`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = MIN_MODULUS, max = MAX_STRESS))]
    pub mu: Option<f64>,
    /// Orthotropic: Young's modulus E1 \[Pa\] along material axis 1 (in the plane, at `angle`).
    #[serde(rename = "E1", default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = MIN_MODULUS, max = MAX_STRESS))]
    pub e1: Option<f64>,
    /// Orthotropic: Young's modulus E2 \[Pa\] along material axis 2 (in the plane).
    #[serde(rename = "E2", default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = MIN_MODULUS, max = MAX_STRESS))]
    pub e2: Option<f64>,
    /// Orthotropic: Young's modulus E3 \[Pa\] out of the plane.
    #[serde(rename = "E3", default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = MIN_MODULUS, max = MAX_STRESS))]
    pub e3: Option<f64>,
    /// Orthotropic: Poisson's ratio ν12 [-] (−ε2/ε1 under stress along axis 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nu12: Option<f64>,
    /// Orthotropic: Poisson's ratio ν13 [-].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nu13: Option<f64>,
    /// Orthotropic: Poisson's ratio ν23 [-].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nu23: Option<f64>,
    /// Orthotropic: in-plane shear modulus G12 \[Pa\].
    #[serde(rename = "G12", default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = MIN_MODULUS, max = MAX_STRESS))]
    pub g12: Option<f64>,
    /// Orthotropic: angle of material axis 1 from the x axis, counter-clockwise \[deg\]
    /// (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = -MAX_ANGLE, max = MAX_ANGLE))]
    pub angle: Option<f64>,
    /// The plane-strain in-plane stiffness D \[Pa\]: a symmetric positive definite 3×3 matrix
    /// acting on (e11, e22, γ12) and giving (τ11, τ22, τ12).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub matrix: Option<[[f64; 3]; 3]>,
    /// With `matrix`: the out-of-plane row (c31, c32, c36) \[Pa\] of τ33 = c31 e11 + c32 e22 +
    /// c36 γ12 − β33 (T − T0) (default zeros).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub out_of_plane: Option<[f64; 3]>,
    /// Specific weight ρg [N/m³]: body force (0, −specific_weight).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = -MAX_STRESS, max = MAX_STRESS))]
    pub specific_weight: Option<f64>,
    /// Body force `[fx, fy]` [N/m³], added to the specific weight.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body_force: Option<[f64; 2]>,
    /// Thermal conductivity κ [W/(m K)]: a scalar, or a symmetric positive definite 2×2 matrix
    /// `[[κ11, κ12], [κ21, κ22]]` in x, y.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub conductivity: Option<Conductivity>,
    /// Heat source W [W/m³].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heat_source: Option<f64>,
    /// Linear thermal expansion α [1/K], the same in every direction; β = C α I (isotropic:
    /// (3λ + 2μ) α). Not with `matrix`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expansion: Option<f64>,
    /// Thermal stress coefficient \[Pa/K\], instead of `expansion`: a scalar β (β I), or the
    /// Voigt vector `[β11, β22, β12, β33]` (β12 the tensor shear component).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beta: Option<ThermalStress>,
    /// Density ρ \[kg/m³\] (> 0); required with `dynamics`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub density: Option<f64>,
    /// Kelvin–Voigt viscosity as a retardation time τ_v \[s\] (≥ 0): c⁽¹⁾ = τ_v c⁽⁰⁾, so
    /// τ = c⁽⁰⁾ (e(u) + τ_v e(u′)) (PDAS paper (1)); absent: elastic.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0.0))]
    pub viscosity: Option<f64>,
}

/// A conductivity: a scalar or a symmetric 2×2 matrix.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(
    untagged,
    expecting = "a conductivity: a number, or a 2×2 matrix [[k11, k12], [k21, k22]]"
)]
pub enum Conductivity {
    /// Isotropic κ [W/(m K)].
    Scalar(#[schemars(range(min = MIN_CONDUCTIVITY, max = MAX_CONDUCTIVITY))] f64),
    /// `[[κ11, κ12], [κ21, κ22]]` [W/(m K)], symmetric positive definite.
    Matrix([[f64; 2]; 2]),
}

/// A thermal stress coefficient: a scalar β or the Voigt vector.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(
    untagged,
    expecting = "a thermal stress coefficient: a number, or [beta11, beta22, beta12, beta33]"
)]
pub enum ThermalStress {
    /// β \[Pa/K\]: the thermal stress β (T − T0) I.
    Scalar(f64),
    /// `[β11, β22, β12, β33]` \[Pa/K\].
    Voigt([f64; 4]),
}

/// One boundary condition on a named segment. Exactly one of the condition fields is set.
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BoundaryCondition {
    /// Optional name, unique among the boundary conditions: uncertain data refer to the
    /// condition's numbers by it (`boundary[NAME].pressure`), which keeps pointing at this entry
    /// when entries are inserted before it (an index does not).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Name of the segment the condition acts on (a key of `segments`).
    pub segment: String,
    /// Prescribed displacement \[m\] per component; `null` leaves the component free.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub displacement: Option<[Option<f64>; 2]>,
    /// Surface traction \[Pa\] (force per area, global x/y components).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub traction: Option<[f64; 2]>,
    /// Normal pressure \[Pa\]: traction −p·n with n the outward normal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = -MAX_STRESS, max = MAX_STRESS))]
    pub pressure: Option<f64>,
    /// Hydrostatic pressure p(y) = γ · max(y0 − y, 0) of a liquid whose free surface is at the
    /// level y0, acting like `pressure` (traction −p·n); the segment may also be a contact
    /// zone's, which makes it the uplift in the joint (design §2.6).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hydrostatic: Option<Hydrostatic>,
    /// Bilateral contact with a rigid foundation (Γo): u·d = 0, zero tangential traction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roller: Option<Roller>,
    /// Prescribed temperature T1 \[K\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature: Option<f64>,
    /// Prescribed inward heat flux [W/m²] (0 is the default insulated boundary).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heat_flux: Option<f64>,
    /// Dynamic scenes: the traction or pressure is multiplied by this function of time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_function: Option<TimeFunction>,
}

/// A hydrostatic pressure: p(y) = γ · max(y0 − y, 0) on the segment (design §2.6).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Hydrostatic {
    /// The level y0 \[m\] of the free surface (the y coordinate where the pressure is zero);
    /// the segment is loaded below it. `boundary[NAME].hydrostatic.level` may be uncertain.
    #[schemars(range(min = -MAX_LEVEL, max = MAX_LEVEL))]
    pub level: f64,
    /// The unit weight γ = ρg \[N/m³\] of the liquid (water: 9810), ≥ 0.
    #[schemars(range(min = 0.0, max = MAX_UNIT_WEIGHT))]
    pub unit_weight: f64,
}

/// Roller direction: `{}` uses the segment's outward normal, `{"direction": [dx, dy]}` a given one.
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Roller {
    /// Constrained direction d of u·d = 0 (any nonzero length); absent: the segment's averaged
    /// outward normal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<[f64; 2]>,
}

/// Contact kind on Γ^kl.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ContactKind {
    /// Signorini contact with Tresca friction.
    #[default]
    Unilateral,
    /// Tied normal displacement, frictionless.
    Bilateral,
}

/// A contact zone between a segment of body k and a segment of body l (zero initial gap).
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Contact {
    /// Name of the contact zone, unique among the contact zones; used in results and reports, and
    /// by uncertain data (`contacts[NAME].slip_limit`).
    pub name: String,
    /// `[segment of body k, segment of body l]`; the normal is the outward normal of body k.
    pub between: [String; 2],
    /// `unilateral` (default) or `bilateral`.
    #[serde(default)]
    pub kind: ContactKind,
    /// Tresca slip limit g \[Pa\]; 0 means frictionless. Left at 0 when the zone has a
    /// `friction_coefficient`.
    #[serde(default)]
    pub slip_limit: SlipLimit,
    /// Coulomb friction coefficient F [-] (≥ 0): |τ_t| ≤ F |τ_n| on the zone instead of a
    /// given slip limit (design §3.4). Exclusive with a non-zero `slip_limit`; unilateral only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0.0, max = MAX_FRICTION))]
    pub friction_coefficient: Option<f64>,
    /// Initial normal gap g0 ≥ 0 between the two segments (default 0, as in the papers). Lets a
    /// flat contact line model curved surfaces, e.g. the 2D Hertz setting. With mortar coupling
    /// it is added to the gap the geometry gives.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_gap: Option<InitialGap>,
    /// How the two sides are coupled: `nodes` (default; matching node pairs) or `mortar` (dual
    /// mortar on non-matching meshes, design §2.4.1).
    #[serde(default, skip_serializing_if = "Coupling::is_nodes")]
    pub coupling: Coupling,
    /// With mortar coupling, the segment (one of `between`) that carries the multipliers and
    /// whose outward normal is the contact normal; default the finer side (body k on a tie).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slave: Option<String>,
    /// Kinetic Coulomb coefficient F_k [-] of a slip-rate-dependent friction law (dynamic scenes
    /// with `friction_coefficient`, the static coefficient F_s; PDAS paper (6)):
    /// F(v) = F_k + (F_s − F_k) exp(−|v| / v_c), v the pair's slip rate of the previous step and
    /// v_c = `slip_rate_scale` (design §3.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0.0, max = MAX_FRICTION))]
    pub friction_kinetic: Option<f64>,
    /// Characteristic slip rate v_c \[m/s\] (> 0) of `friction_kinetic`: below it the static
    /// coefficient holds, far above it the kinetic one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub slip_rate_scale: Option<f64>,
}

/// Coupling of the two sides of a contact zone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Coupling {
    /// Node pairs at identical positions: both segments must have matching nodes (the papers').
    #[default]
    Nodes,
    /// Dual mortar (Wohlmuth; PDAS paper (15)–(25)): the segments need only overlap; each body is
    /// meshed on its own.
    Mortar,
}

impl Coupling {
    /// Whether this is the default node-pair coupling (for `skip_serializing_if`).
    pub fn is_nodes(&self) -> bool {
        *self == Coupling::Nodes
    }
}

/// Initial normal gap of a contact zone.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum InitialGap {
    /// g0 = d²/(2R), d the distance from the touching point (a cylinder of radius R on a flat,
    /// or two cylinders with 1/R = 1/R1 + 1/R2).
    Parabola {
        /// Radius R \[m\] (> 0).
        #[schemars(extend("exclusiveMinimum" = 0.0))]
        radius: f64,
        /// The touching point `[x, y]` \[m\] on the contact line, where g0 = 0.
        touch_at: Point,
    },
    /// Piecewise linear in the arc-length fraction s ∈ [0, 1] along body k's segment.
    PiecewiseLinear {
        /// Knot positions, fractions 0..1 of the arc length along body k's segment, strictly
        /// increasing.
        knots: Vec<f64>,
        /// g0 at the knots \[m\].
        values: Vec<f64>,
    },
}

/// Slip limit: a constant, or piecewise linear on knots given as fractions of the zone length.
// Read by hand (below) rather than as a serde untagged enum, which would silently drop an
// unknown member of the object form (a misspelt `max_slope`); the schema says the same
// (`deny_unknown_fields` for schemars only).
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[serde(untagged)]
#[schemars(deny_unknown_fields)]
pub enum SlipLimit {
    /// One slip limit g \[Pa\] along the whole zone (≥ 0).
    Constant(#[schemars(range(min = 0.0, max = MAX_STRESS))] f64),
    /// g piecewise linear in the arc-length fraction along the zone, optionally with a slope bound.
    PiecewiseLinear {
        /// Knot positions, fractions 0..1 of the arc length along body k's segment, increasing.
        knots: Vec<f64>,
        /// g at the knots \[Pa\].
        values: Vec<f64>,
        /// Optional bound C on |dg/ds| [Pa/m] (FGCS 4.15).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_slope: Option<f64>,
    },
}

impl<'de> Deserialize<'de> for SlipLimit {
    /// A number, or the object form with no member but `knots`, `values` and `max_slope`.
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        /// The object form.
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Piecewise {
            knots: Vec<f64>,
            values: Vec<f64>,
            #[serde(default)]
            max_slope: Option<f64>,
        }
        let expected = || {
            serde::de::Error::custom(
                "a slip limit: a number, or an object {\"knots\": [...], \"values\": [...], \
                 \"max_slope\": optional number}",
            )
        };
        match serde_json::Value::deserialize(deserializer)? {
            serde_json::Value::Number(g) => {
                g.as_f64().map(SlipLimit::Constant).ok_or_else(expected)
            }
            object @ serde_json::Value::Object(_) => {
                let p = Piecewise::deserialize(object).map_err(serde::de::Error::custom)?;
                Ok(SlipLimit::PiecewiseLinear {
                    knots: p.knots,
                    values: p.values,
                    max_slope: p.max_slope,
                })
            }
            _ => Err(expected()),
        }
    }
}

impl Default for SlipLimit {
    fn default() -> Self {
        SlipLimit::Constant(0.0)
    }
}

/// Stationary heat problem settings.
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Thermal {
    /// Reference temperature T0 \[K\] of the stress-free state.
    #[serde(default)]
    pub reference_temperature: f64,
}

/// Mesh controls.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MeshControls {
    /// Maximal element edge length \[m\] of the built-in mesher: required unless `gmsh_file` is
    /// given (an imported mesh has its own sizes, and `max_size` is then not used).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_size: Option<f64>,
    /// Local refinement near segments or inside polygons.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub refine: Vec<Refinement>,
    /// Minimal angle of the quality refinement \[deg\] (≤ 30).
    #[serde(default = "default_min_angle")]
    #[schemars(extend("exclusiveMinimum" = 0.0), range(max = 30.0))]
    pub min_angle: f64,
    /// Import a Gmsh .msh file (MSH 4.1 or 2.2, ASCII or binary) instead of meshing the
    /// polygons. Physical names of 2D entities map to zone names, of 1D entities to segment
    /// names. The command line reads a relative path from the scene file's directory (`wsm`
    /// resolves it when it reads the file); the library opens the path as it stands.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gmsh_file: Option<String>,
    /// A mesh given in the scene instead of meshing the polygons (not with `gmsh_file`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inline: Option<InlineMesh>,
    /// Uniform subdivisions of an imported mesh (`gmsh_file` or `inline`), each splitting every
    /// triangle into four by its edge midpoints (halving every edge); 0 by default, at most
    /// [`MAX_SUBDIVIDE`]. The accuracy statement refines an imported mesh this way.
    #[serde(default, skip_serializing_if = "is_zero")]
    #[schemars(range(max = MAX_SUBDIVIDE))]
    pub subdivide: u32,
    /// The finite element (design §2.7): `p1` linear triangles (default), or `mixed`, the MINI
    /// u–p element (P1 + bubble displacement, P1 pressure) that does not lock as ν → ½, for
    /// isotropic materials, on the same nodes.
    #[serde(default, skip_serializing_if = "Element::is_p1")]
    pub element: Element,
}

/// The finite element of the elastic problem (`mesh.element`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Element {
    /// Linear triangles (displacement only).
    #[default]
    P1,
    /// MINI: P1 + cubic bubble displacement, continuous P1 pressure (locking-free).
    Mixed,
}

impl Element {
    /// Whether this is the default P1 element.
    pub fn is_p1(&self) -> bool {
        *self == Element::P1
    }
}

/// Most uniform subdivisions of an imported mesh (each multiplies its triangles by 4).
pub const MAX_SUBDIVIDE: u32 = 8;

fn is_zero(n: &u32) -> bool {
    *n == 0
}

impl MeshControls {
    /// The JSON path of the imported mesh (`mesh.gmsh_file` or `mesh.inline`), or `None` when
    /// the built-in mesher meshes the polygons.
    pub fn imported(&self) -> Option<&'static str> {
        if self.gmsh_file.is_some() {
            Some("mesh.gmsh_file")
        } else if self.inline.is_some() {
            Some("mesh.inline")
        } else {
            None
        }
    }
}

/// A triangle mesh given in the scene (`mesh.inline`), checked like an imported Gmsh mesh.
/// Nodes are numbered from 0 in the order of `nodes`; every index below is such a number.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InlineMesh {
    /// Node coordinates `[x, y]` \[m\].
    pub nodes: Vec<Point>,
    /// Triangles: three node indices each, in either orientation (3-node, linear).
    pub triangles: Vec<[usize; 3]>,
    /// Zone names used by `triangle_zones`: each must be a zone name of the scene, and every
    /// zone of the scene must have triangles.
    pub zones: Vec<String>,
    /// The zone of each triangle, an index into `zones` (as many as `triangles`).
    pub triangle_zones: Vec<usize>,
    /// Boundary edges by segment name: each a pair of node indices that is an edge of a
    /// triangle. A scene segment named here takes these edges (it then needs no `from`/`to`
    /// or `path`); names that are no scene segment are ignored.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub segments: BTreeMap<String, Vec<[usize; 2]>>,
}

fn default_min_angle() -> f64 {
    28.0
}

/// A local refinement: along the given segments and/or inside a polygon.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Refinement {
    /// Names of segments along which the size is lowered.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub segments: Vec<String>,
    /// A polygon of vertices `[x, y]` \[m\] inside which the size is lowered.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polygon: Option<Vec<Point>>,
    /// Local maximal element edge length \[m\] (> 0); away from the refined places the size grows
    /// linearly back to `mesh.max_size`.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_size: f64,
}

/// Criteria regions (FGCS 4.29–4.34).
#[derive(Debug, Clone, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CriteriaRegions {
    /// Small areas G_r.
    #[serde(default)]
    pub regions: Vec<CriterionRegion>,
    /// Boundary pieces G'_r.
    #[serde(default)]
    pub boundary_pieces: Vec<BoundaryPiece>,
    /// Criteria the user defines (design §4.2): the mean of a stress quantity over one area or
    /// of a contact traction over one boundary piece, named so that `search.criteria` lists them beside `phi1` … `phi6`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub defined: Vec<DefinedCriterion>,
}

/// A criterion defined in the scene (design §4.2): the mean of a stress quantity over an area
/// G_r, or of a contact traction over a boundary piece G'_r on a contact zone, or (dynamic scenes,
/// design §3.5) the peak velocity of a receiver; searched like Φ1–Φ6 under its own name.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DefinedCriterion {
    /// The name `search.criteria` uses: letters, digits and `_`, starting with a letter, not
    /// `phi` followed by a digit, unique among the defined criteria.
    #[schemars(regex(pattern = r"^(?![pP][hH][iI][0-9])[A-Za-z][A-Za-z0-9_]*$"))]
    pub name: String,
    /// Where the mean is taken: an area (`criteria.regions[].name`) for a stress quantity, a
    /// boundary piece (`criteria.boundary_pieces[].name`) on a contact zone's segment for a
    /// contact traction; absent for `peak_velocity`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<String>,
    /// The receiver (`receivers[].name`) whose velocity `peak_velocity` reads; absent for the
    /// other quantities.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub receiver: Option<String>,
    /// The quantity averaged (or, for `peak_velocity`, followed over time).
    pub quantity: DefinedQuantity,
}

impl DefinedCriterion {
    /// The region or receiver the criterion reads, by name (empty if the scene gives neither).
    pub fn place(&self) -> &str {
        self.region
            .as_deref()
            .or(self.receiver.as_deref())
            .unwrap_or_default()
    }
}

/// The quantity of a defined criterion \[Pa\] (design §4.2, §5.8): a component, principal
/// stress or the von Mises stress of the plane-strain stress (τ11, τ22, τ12, τ33), averaged over
/// an area; or a contact traction, averaged over a boundary piece on a contact zone; or, in a
/// dynamic scene, a receiver's speed \[m/s\] (design §3.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum DefinedQuantity {
    /// σxx.
    SigmaXx,
    /// σyy.
    SigmaYy,
    /// τxy.
    TauXy,
    /// σzz = τ33, the out-of-plane stress.
    SigmaZz,
    /// The larger in-plane principal stress σ1.
    Sigma1,
    /// The smaller in-plane principal stress σ2.
    Sigma2,
    /// The von Mises stress √(3/2 τᴰ:τᴰ).
    VonMises,
    /// The contact pressure (the normal multiplier per unit length, > 0 in compression), as
    /// `piece_contact_pressure` reports it.
    ContactPressure,
    /// The tangential traction (the tangential multiplier per unit length), as the contact
    /// profiles report it.
    ContactShear,
    /// The speed |v| \[m/s\] at a receiver (`receiver`), its largest value over the time
    /// steps (dynamic scenes only).
    PeakVelocity,
}

impl DefinedQuantity {
    /// Whether the quantity is a contact traction (averaged over a boundary piece).
    pub fn is_contact(self) -> bool {
        matches!(
            self,
            DefinedQuantity::ContactPressure | DefinedQuantity::ContactShear
        )
    }

    /// Whether the quantity is a receiver's peak velocity (read at a receiver, not over a
    /// region).
    pub fn is_receiver(self) -> bool {
        self == DefinedQuantity::PeakVelocity
    }

    /// The SI unit of the criterion's value.
    pub fn unit(self) -> &'static str {
        if self.is_receiver() {
            "m/s"
        } else {
            "Pa"
        }
    }

    /// What a criterion of this quantity measures, in words.
    pub fn definition(self) -> &'static str {
        if self.is_receiver() {
            "largest speed |v| at a receiver over the time steps, defined in the scene"
        } else if self.is_contact() {
            "mean of a contact traction over a boundary piece G'_r, defined in the scene"
        } else {
            "mean of a stress quantity over an area G_r, defined in the scene"
        }
    }
}

/// An area G_r with the point X_r whose outward normal is used by Φ3 and Φ6.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CriterionRegion {
    /// Region name, unique among the regions and boundary pieces.
    pub name: String,
    /// The area G_r: a simple polygon of vertices `[x, y]` \[m\].
    pub polygon: Vec<Point>,
    /// X_r: a boundary point; the outward normal of the region's body there is n(X_r).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal_at: Option<Point>,
    /// An explicit unit direction instead of `normal_at`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<[f64; 2]>,
}

/// A boundary piece G'_r: the part of a segment between two points.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BoundaryPiece {
    /// Piece name, unique among the regions and boundary pieces.
    pub name: String,
    /// Name of the segment the piece lies on.
    pub segment: String,
    /// Start point \[m\], projected onto the segment; default the segment's start.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<Point>,
    /// End point \[m\], projected onto the segment; default the segment's end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<Point>,
    /// X_r; defaults to the piece's midpoint.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal_at: Option<Point>,
}

/// One uncertain datum: the scene field it varies and its interval.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Uncertain {
    /// Path of a scene number, e.g. `materials.rock.E`, `boundary[2].traction[0]`,
    /// `contacts[0].slip_limit`, `contacts[0].slip_limit.values[1]`,
    /// `contacts[0].friction_coefficient`; a boundary condition or contact zone may be picked by
    /// its name instead of its index: `boundary[water_up1].pressure`,
    /// `contacts[joint].friction_coefficient`. Results and tables name the datum by this path as
    /// written.
    pub field: String,
    /// `[lo, hi]` in the field's unit: finite, lo ≤ hi and within the field's sign and range rules;
    /// lo = hi keeps the number fixed. The scene's own value of the field (its nominal value)
    /// must lie in it.
    pub interval: [f64; 2],
    /// Display name of the parameter (e.g. `"friction of the dam joint"`); defaults to `field`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Further scene numbers the same datum θ drives (linked data, design §4.1): each takes the
    /// value `factor` × θ, e.g. one water level on every face of a dam or one pressure per body
    /// (CZ 3.8). Each field's own scene value must be `factor` × the nominal value of `field`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub drives: Vec<Driven>,
}

/// A scene number driven by an uncertain datum θ: it takes the value `factor` × θ.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Driven {
    /// Path of the scene number, as in `uncertain[i].field`.
    pub field: String,
    /// The factor [field unit per datum unit]: finite and not zero (> 0 for a slip limit or a
    /// friction coefficient).
    pub factor: f64,
}

/// The criteria Φ1–Φ6 (FGCS numbering) and the family of the scene's defined criteria.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    Serialize,
    Deserialize,
    utoipa::ToSchema,
    JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// Φ1: the largest mean temperature over the areas G_r \[K\] (needs `thermal`).
    Phi1,
    /// Φ2: the largest mean temperature over the boundary pieces G'_r \[K\] (needs `thermal`).
    Phi2,
    /// Φ3: the largest mean displacement along n(X_r) over the areas G_r that have a normal \[m\].
    Phi3,
    /// Φ4: the largest mean displacement along n(X_r) over the boundary pieces G'_r \[m\].
    Phi4,
    /// Φ5: the largest mean shear-stress intensity I2² over the areas G_r \[Pa²\].
    Phi5,
    /// Φ6: the largest mean normal compression −n·τ·n over the areas G_r that have a normal \[Pa\].
    Phi6,
    /// A criterion of `criteria.defined`, always bound to one of them by name (design §4.2);
    /// written as the user's name, never as this variant.
    #[serde(skip)]
    Defined,
}

impl Criterion {
    /// The six criteria in FGCS order (`criterion as usize` is the index).
    pub const ALL: [Criterion; 6] = [
        Criterion::Phi1,
        Criterion::Phi2,
        Criterion::Phi3,
        Criterion::Phi4,
        Criterion::Phi5,
        Criterion::Phi6,
    ];

    /// How many kinds there are: Φ1–Φ6 and [`Criterion::Defined`] (`criterion as usize` indexes
    /// the per-kind arrays of a solution).
    pub const COUNT: usize = 7;

    /// The JSON name: `phi1` … `phi6` (`defined` for the family of defined criteria).
    pub fn name(self) -> &'static str {
        match self {
            Criterion::Phi1 => "phi1",
            Criterion::Phi2 => "phi2",
            Criterion::Phi3 => "phi3",
            Criterion::Phi4 => "phi4",
            Criterion::Phi5 => "phi5",
            Criterion::Phi6 => "phi6",
            Criterion::Defined => "defined",
        }
    }

    /// The symbol a user reads: `Φ1` … `Φ6`.
    pub fn symbol(self) -> &'static str {
        ["Φ1", "Φ2", "Φ3", "Φ4", "Φ5", "Φ6", "defined"][self as usize]
    }

    /// The SI unit of the criterion's value.
    pub fn unit(self) -> &'static str {
        ["K", "K", "m", "m", "Pa²", "Pa", "Pa"][self as usize]
    }

    /// What the criterion measures, in words (design §4.2, FGCS 4.29–4.34).
    pub fn definition(self) -> &'static str {
        [
            "mean temperature over an area G_r",
            "mean temperature over a boundary piece G'_r",
            "mean displacement along the area's normal n(X_r) over an area G_r",
            "mean displacement along the piece's outward normal over a boundary piece G'_r",
            "mean squared deviatoric stress intensity I2² = τᴰ:τᴰ (plane-strain τ33 included) \
             over an area G_r",
            "mean normal compression −n·τ·n over an area G_r next to a contact zone",
            "mean of a stress quantity over an area G_r or of a contact traction over a boundary piece G'_r, defined in the scene",
        ][self as usize]
    }

    /// Whether the criterion needs the temperature field only (Φ1, Φ2).
    pub fn is_thermal(self) -> bool {
        matches!(self, Criterion::Phi1 | Criterion::Phi2)
    }

    /// The criterion named `s` (`phi1` … `phi6`, case and surrounding blanks ignored), or `None`.
    pub fn parse(s: &str) -> Option<Criterion> {
        Criterion::ALL
            .into_iter()
            .find(|c| c.name() == s.trim().to_ascii_lowercase())
    }
}

/// A requested criterion: Φi as the largest mean over its regions (FGCS 4.29–4.34), or *bound* to
/// one area or boundary piece — then its mean there (design §4.2). JSON: `"phi3"`, `"phi3@crest"`
/// or `{"criterion": "phi3", "region": "crest"}`; written as the string form, so a criterion
/// without a region reads and hashes as before.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CriterionSpec {
    /// Which Φ.
    pub criterion: Criterion,
    /// The one area (Φ1, Φ3, Φ5, Φ6) or boundary piece (Φ2, Φ4) it is bound to, by name; `None`:
    /// the largest over all that qualify.
    pub region: Option<String>,
}

impl CriterionSpec {
    /// The name a user writes: `phi3`, `phi3@crest` when bound, a defined criterion's own name.
    pub fn name(&self) -> String {
        match (&self.region, self.criterion) {
            (Some(r), Criterion::Defined) => r.clone(),
            (Some(r), c) => format!("{}@{r}", c.name()),
            (None, c) => c.name().to_string(),
        }
    }

    /// What a user reads: `Φ3`, `Φ3@crest` when bound, a defined criterion's own name.
    pub fn symbol(&self) -> String {
        match (&self.region, self.criterion) {
            (Some(r), Criterion::Defined) => r.clone(),
            (Some(r), c) => format!("{}@{r}", c.symbol()),
            (None, c) => c.symbol().to_string(),
        }
    }

    /// A criterion of `criteria.defined`, by its name.
    pub fn defined(name: &str) -> CriterionSpec {
        CriterionSpec {
            criterion: Criterion::Defined,
            region: Some(name.to_string()),
        }
    }

    /// The criterion named `s`: `phi1` … `phi6` (case and surrounding blanks ignored),
    /// optionally `@region`, or the name of a defined criterion (letters, digits and `_`,
    /// starting with a letter; whether the scene defines it is checked with the scene); the
    /// reason when it is not one.
    pub fn parse(s: &str) -> Result<CriterionSpec, String> {
        let (kind, region) = match s.split_once('@') {
            Some((kind, region)) => (kind, Some(region.trim())),
            None => (s, None),
        };
        if region.is_none() && Criterion::parse(kind).is_none() && is_defined_name(s.trim()) {
            return Ok(CriterionSpec::defined(s.trim()));
        }
        let criterion = Criterion::parse(kind).ok_or_else(|| {
            format!("unknown criterion '{s}': expected phi1 … phi6, optionally bound to a region as phi3@NAME, or the name of a criterion in criteria.defined")
        })?;
        match region {
            Some("") => Err(format!("'{s}': the region after '@' is empty")),
            region => Ok(CriterionSpec {
                criterion,
                region: region.map(str::to_string),
            }),
        }
    }
}

/// Whether `name` may name a defined criterion: letters, digits and `_`, starting with a letter,
/// and not `phi` followed by a digit (those are Φ1–Φ6 and their misspellings).
pub fn is_defined_name(name: &str) -> bool {
    let mut chars = name.chars();
    let lower = name.to_ascii_lowercase();
    let phi_like = lower
        .strip_prefix("phi")
        .is_some_and(|rest| rest.starts_with(|c: char| c.is_ascii_digit()));
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !phi_like
}

impl From<Criterion> for CriterionSpec {
    /// The criterion over all its regions.
    fn from(criterion: Criterion) -> CriterionSpec {
        CriterionSpec {
            criterion,
            region: None,
        }
    }
}

impl std::fmt::Display for CriterionSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

impl Serialize for CriterionSpec {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.name())
    }
}

impl<'de> Deserialize<'de> for CriterionSpec {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        /// The object form.
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Bound {
            criterion: Criterion,
            #[serde(default)]
            region: Option<String>,
        }
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Form {
            Text(String),
            Object(Bound),
        }
        match Form::deserialize(deserializer).map_err(|_| {
            serde::de::Error::custom(
                "expected a criterion: \"phi1\" … \"phi6\", \"phi3@REGION\" or \
                 {\"criterion\": \"phi3\", \"region\": \"REGION\"}",
            )
        })? {
            Form::Text(s) => CriterionSpec::parse(&s).map_err(serde::de::Error::custom),
            Form::Object(b) => match b.region.as_deref().map(str::trim) {
                Some("") => Err(serde::de::Error::custom(
                    "the region of a criterion is empty",
                )),
                region => Ok(CriterionSpec {
                    criterion: b.criterion,
                    region: region.map(str::to_string),
                }),
            },
        }
    }
}

impl utoipa::PartialSchema for CriterionSpec {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        utoipa::openapi::ObjectBuilder::new()
            .schema_type(utoipa::openapi::schema::Type::String)
            .pattern(Some(
                "^(phi[1-6](@.+)?|(?![pP][hH][iI][0-9])[A-Za-z][A-Za-z0-9_]*)$",
            ))
            .description(Some(
                "A criterion: `phi1` … `phi6` (the largest mean over its regions), bound to one \
                 area or boundary piece as `phi3@NAME` (its mean there), or the name of a \
                 criterion in the scene's `criteria.defined`. Requests also accept \
                 `{\"criterion\": \"phi3\", \"region\": \"NAME\"}`.",
            ))
            .examples(["phi5", "phi3@crest"])
            .into()
    }
}

impl utoipa::ToSchema for CriterionSpec {}

impl JsonSchema for CriterionSpec {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "CriterionSpec".into()
    }

    /// What [`CriterionSpec`]'s reader accepts: the text form — `phi1` … `phi6` in any case,
    /// blanks around it ignored, optionally `@` and a region that is not blank — or the object
    /// form with the criterion's exact name.
    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "description": "A criterion: `phi1` … `phi6` (the largest mean over its regions), \
                bound to one area or boundary piece as `phi3@NAME` or \
                `{\"criterion\": \"phi3\", \"region\": \"NAME\"}` (its mean there), or the \
                name of a criterion in `criteria.defined`.",
            "anyOf": [
                {
                    "type": "string",
                    "pattern": "^\\s*[pP][hH][iI][1-6]\\s*(@[\\s\\S]*\\S[\\s\\S]*)?$",
                    "examples": ["phi5", "phi3@crest"]
                },
                {
                    "type": "string",
                    "pattern": "^\\s*(?![pP][hH][iI][0-9])[A-Za-z][A-Za-z0-9_]*\\s*$",
                    "examples": ["heel_pressure"]
                },
                {
                    "type": "object",
                    "properties": {
                        "criterion": generator.subschema_for::<Criterion>(),
                        "region": {
                            "description": "The area or boundary piece, by name (not blank).",
                            "type": ["string", "null"],
                            "pattern": "\\S"
                        }
                    },
                    "required": ["criterion"],
                    "additionalProperties": false
                }
            ]
        })
    }
}

/// Worst-scenario search settings (design §4.3).
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SearchSettings {
    /// The criteria to search, e.g. `["phi3", "phi5@heel"]`; each gets a maximum and a minimum. A
    /// run needs at least one, here or in its request. They are checked when a search uses them:
    /// `wsm solve` ignores them.
    #[serde(default)]
    pub criteria: Vec<CriterionSpec>,
    /// Maximal number of inner solves (shared by all criteria). Default: 300, plus 2^k for k ≤ 10
    /// free uncertain data, so that every vertex of the box can be screened.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub budget: Option<usize>,
    /// Seed of the search's random streams (default 1): the same seed gives the same result on any
    /// thread count.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Wall-time limit \[s\] (> 0); absent: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_seconds: Option<f64>,
    /// Exact derivatives on every evaluation (default true): they drive the search and certify
    /// its extrema; `false` searches without them.
    #[serde(default = "default_derivatives")]
    pub derivatives: bool,
    /// When the search may stop before its budget is spent (with derivatives): `global_rule`
    /// (default) when every vertex is screened and few local optima are estimated unseen,
    /// `first_certificate` at the first locally certified extremum, `budget` never.
    #[serde(default)]
    pub stop: StopRule,
}

fn default_derivatives() -> bool {
    true
}

fn default_seed() -> u64 {
    1
}

impl Scene {
    /// Names of the defined materials some zone uses (a zone naming an undefined one is refused
    /// by validation, not listed here).
    pub fn used_materials(&self) -> BTreeSet<&str> {
        self.bodies
            .iter()
            .flat_map(|b| &b.zones)
            .map(|z| z.material.as_str())
            .filter(|name| self.materials.contains_key(*name))
            .collect()
    }

    /// The search budget: `search.budget`, else the default for the scene's free uncertain data
    /// (those with lo < hi; see [`wsm_search::default_budget`]).
    pub fn search_budget(&self) -> usize {
        self.search.budget.unwrap_or_else(|| {
            let free = self
                .uncertain
                .iter()
                .filter(|u| u.interval[0] < u.interval[1])
                .count();
            wsm_search::default_budget(free)
        })
    }
}

impl Default for SearchSettings {
    fn default() -> Self {
        SearchSettings {
            criteria: Vec::new(),
            budget: None,
            seed: default_seed(),
            max_seconds: None,
            derivatives: default_derivatives(),
            stop: StopRule::default(),
        }
    }
}

/// Which inner solver runs the state problem.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, utoipa::ToSchema, JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum SolverKind {
    /// The direct reference solver: a Cholesky factor per body and the condensed contact QP (design
    /// §3.1).
    #[default]
    Direct,
    /// The domain-decomposition solver of the papers (design §3.2).
    Dd,
}

/// Inner solver settings.
#[derive(Debug, Clone, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SolverSettings {
    /// Which inner solver runs the state problem (default `direct`).
    #[serde(default)]
    pub kind: SolverKind,
    /// Requested total number of subdomains for the DD solver (0 = automatic, about 800
    /// elements each).
    #[serde(default)]
    pub subdomains: usize,
    /// Relative tolerance [-] of the DD iterations, in (0, 1) (default 1e-10).
    #[serde(default = "default_tolerance")]
    #[schemars(extend("exclusiveMinimum" = 0.0, "exclusiveMaximum" = 1.0))]
    pub tolerance: f64,
    /// An explicit DD partition instead of the automatic one: every element goes to the first
    /// polygon that contains its centroid (one subdomain per polygon and body), the elements in
    /// no polygon to one subdomain per body. No interface may cut a contact zone.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub partition: Vec<Vec<Point>>,
    /// How the Coulomb fixed point g = F |λ_n| is run: `anderson` (default; Anderson mixing of
    /// the normal forces) or `none` (the papers' plain successive approximations).
    #[serde(default)]
    pub coulomb_acceleration: CoulombAcceleration,
    /// How the direct solver treats the contact (design §3.1): `auto` (default; the sparse path
    /// from 1,500 pairs), `dense` (the condensed QP on C = B K⁺ Bᵀ, exact derivatives) or
    /// `sparse` (primal–dual active set on sparse factors, memory O(nnz of a factor)).
    #[serde(default, skip_serializing_if = "ContactMethod::is_auto")]
    pub contact: ContactMethod,
    /// Variants of the DD solver (design §3.2, "The papers' method as printed"): each member
    /// selects the papers' printed choice instead of wsm's default. Ignored by the direct solver.
    #[serde(default, skip_serializing_if = "DdSettings::is_default")]
    pub dd: DdSettings,
}

/// Variants of the DD solver (design §3.2): wsm's defaults, or the papers' method as printed.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DdSettings {
    /// The PCG1 preconditioner of the auxiliary problem: `reduced` (default; D05 §6 on the
    /// tied operator) or `printed` (D05 §5 / D03 Def. 3.4: Neumann solves on the tied contact
    /// clusters too).
    #[serde(default)]
    pub pcg1: DdPcg1,
    /// The coarse space of the balancing preconditioners: `rigid` (default; rigid motions of
    /// every non-contact subdomain) or `kernels` (as printed, D05 5.11 / 6.7: the floating
    /// subdomains' kernels only).
    #[serde(default)]
    pub coarse: DdCoarse,
    /// The outer iteration: `safeguarded` (default; Anderson mixing, Newton steps and the direct
    /// solver when the successive approximations do not contract) or `plain` (the papers'
    /// successive approximations; a solve whose contraction factor is ≥ 1 on two consecutive
    /// steps stops as "not contracting" and the direct solver answers with that warning).
    #[serde(default)]
    pub iteration: DdIteration,
    /// The stiffness measure ρ of the injection weights (D05 5.5): `stiffness` (default; mean
    /// diagonal of the subdomain's stiffness) or `mean_young` (the papers' choice: mean Young's
    /// modulus of the subdomain).
    #[serde(default)]
    pub weights: DdWeights,
    /// The tied set Γc0 ⊂ Γc of the auxiliary problem (D05 4.35, chosen a priori): the names of
    /// the contact zones whose normal rows are tied (u^k_n − u^l_n = 0, τ_t = 0) in the linear
    /// problem that starts the successive approximations; the other unilateral zones carry no
    /// traction there. Default (absent): every zone, Γc0 = Γc. Bilateral zones are always tied.
    /// The answer does not depend on it, only the start U⁰ and the iteration counts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tied_zones: Option<Vec<String>>,
}

impl DdSettings {
    /// Whether every member is wsm's default.
    pub fn is_default(&self) -> bool {
        *self == DdSettings::default()
    }
}

/// The PCG1 preconditioner (design §3.2).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum DdPcg1 {
    /// The reduced balancing preconditioner of D05 §6 on the tied operator.
    #[default]
    Reduced,
    /// D05 §5 / D03 Def. 3.4 as printed.
    Printed,
}

/// The coarse space of the DD's balancing preconditioners (design §3.2).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum DdCoarse {
    /// Rigid motions of every non-contact subdomain.
    #[default]
    Rigid,
    /// The floating subdomains' kernels only, as printed (D05 5.11 / 6.7).
    Kernels,
}

/// The DD's outer iteration (design §3.2).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum DdIteration {
    /// Successive approximations with Anderson mixing, Newton steps and a direct fallback.
    #[default]
    Safeguarded,
    /// The papers' plain successive approximations (D05 4.37, D03 (52)).
    Plain,
}

/// The stiffness measure ρ of the DD's injection weights (D05 5.5).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum DdWeights {
    /// Mean diagonal of the subdomain's stiffness matrix.
    #[default]
    Stiffness,
    /// Area-weighted mean Young's modulus of the subdomain (the papers' choice).
    MeanYoung,
}

/// How the direct solver treats the contact (design §3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ContactMethod {
    /// The sparse path from 1,500 pairs on, else the dense one.
    #[default]
    Auto,
    /// The condensed dense QP (memory grows with the square of the pairs).
    Dense,
    /// The primal–dual active set on sparse factors.
    Sparse,
}

impl ContactMethod {
    /// The default.
    pub fn is_auto(&self) -> bool {
        *self == ContactMethod::Auto
    }
}

/// Acceleration of the Coulomb fixed point (design §3.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum CoulombAcceleration {
    /// Anderson mixing of depth 3 on the normal forces of the Coulomb pairs.
    #[default]
    Anderson,
    /// Plain successive approximations.
    None,
}

impl CoulombAcceleration {
    /// The Anderson depth (0 = plain).
    pub fn depth(self) -> usize {
        match self {
            CoulombAcceleration::Anderson => 3,
            CoulombAcceleration::None => 0,
        }
    }
}

fn default_tolerance() -> f64 {
    1e-10
}

impl Default for SolverSettings {
    fn default() -> Self {
        SolverSettings {
            kind: SolverKind::Direct,
            subdomains: 0,
            tolerance: default_tolerance(),
            partition: Vec::new(),
            coulomb_acceleration: CoulombAcceleration::default(),
            contact: ContactMethod::default(),
            dd: DdSettings::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slip_limit_is_a_number_or_an_object_with_known_members() {
        let read = |text: &str| serde_json::from_str::<SlipLimit>(text);
        assert!(matches!(read("3e5").unwrap(), SlipLimit::Constant(g) if g == 3e5));
        let SlipLimit::PiecewiseLinear {
            knots,
            values,
            max_slope,
        } = read(r#"{"knots": [0, 1], "values": [1, 2], "max_slope": 5}"#).unwrap()
        else {
            panic!("the object form")
        };
        assert_eq!(
            (knots, values, max_slope),
            (vec![0.0, 1.0], vec![1.0, 2.0], Some(5.0))
        );
        let e = read(r#"{"knots": [0, 1], "values": [1, 2], "max_slop": 5}"#).unwrap_err();
        assert!(e.to_string().contains("unknown field `max_slop`"), "{e}");
        let e = read(r#""abc""#).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("a slip limit: a number, or an object"),
            "{e}"
        );
    }
}
