//! The numeric data of a scene in resolved form: everything a solve needs besides the mesh.
//!
//! The worst-scenario engine varies exactly these numbers (design §4.1); the mesh and the
//! topology (which zone uses which material, which condition acts on which segment) never change
//! between evaluations. Indices follow the scene: materials in name order (the `BTreeMap` order),
//! boundary conditions and contacts in list order, segments in name order.

use super::law::{lame_from_young, Orthotropic, PlaneStrainLaw};
use super::model::{BoundaryCondition, Conductivity, Material, Scene, SlipLimit, ThermalStress};

/// Elastic constants as the user gave them; converted to the plane-strain law on use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Elastic {
    /// Young's modulus E \[Pa\] and Poisson's ratio ν.
    Young {
        /// Young's modulus E \[Pa\].
        e: f64,
        /// Poisson's ratio ν [-].
        nu: f64,
    },
    /// Lamé constants λ, μ \[Pa\].
    Lame {
        /// Lamé's first parameter λ \[Pa\].
        lambda: f64,
        /// Shear modulus μ \[Pa\].
        mu: f64,
    },
    /// Orthotropic constants and the angle of material axis 1.
    Orthotropic(Orthotropic),
    /// The plane-strain law itself.
    Matrix(PlaneStrainLaw),
}

impl Elastic {
    /// The plane-strain law (FGCS 2.7′); `None` when orthotropic constants have a singular
    /// compliance. Isotropic: λ, μ by `lame_from_young` when E, ν are given.
    pub fn law(&self) -> Option<PlaneStrainLaw> {
        match self {
            Elastic::Young { .. } | Elastic::Lame { .. } => {
                let (lambda, mu) = self.lame()?;
                Some(PlaneStrainLaw::isotropic(lambda, mu))
            }
            Elastic::Orthotropic(o) => o.law(),
            Elastic::Matrix(law) => Some(*law),
        }
    }

    /// (λ, μ) of an isotropic material, `None` otherwise.
    fn lame(&self) -> Option<(f64, f64)> {
        match *self {
            Elastic::Young { e, nu } => Some(lame_from_young(e, nu)),
            Elastic::Lame { lambda, mu } => Some((lambda, mu)),
            Elastic::Orthotropic(_) | Elastic::Matrix(_) => None,
        }
    }
}

/// Thermal expansion as given: α (β = C α I), β directly, or the Voigt β.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Expansion {
    /// Linear thermal expansion α [1/K]; β = C α I (isotropic: (3λ + 2μ)α).
    Alpha(f64),
    /// Thermal stress coefficient β \[Pa/K\]: β I.
    Beta(f64),
    /// Voigt β = (β11, β22, β12, β33) \[Pa/K\], β12 the tensor shear component.
    Voigt([f64; 4]),
}

/// Numeric data of one material.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialData {
    /// Elastic constants as given.
    pub elastic: Elastic,
    /// Specific weight ρg [N/m³] (acts in −y).
    pub specific_weight: f64,
    /// Additional body force [N/m³].
    pub body_force: [f64; 2],
    /// Conductivity (κ11, κ12, κ22) [W/(m K)] in x, y (a scalar κ is (κ, 0, κ)).
    pub conductivity: [f64; 3],
    /// Heat source W [W/m³].
    pub heat_source: f64,
    /// Thermal expansion, α or β as given (β = 0 when neither is).
    pub expansion: Expansion,
}

impl MaterialData {
    /// Total body force F [N/m³].
    pub fn force(&self) -> [f64; 2] {
        [
            self.body_force[0],
            self.body_force[1] - self.specific_weight,
        ]
    }

    /// The Voigt thermal stress vector (β11, β22, β12, β33) \[Pa/K\] (FGCS 2.7′); `None` for an
    /// expansion α of a material given by its matrix (α needs the out-of-plane stiffness) or of
    /// orthotropic constants with a singular compliance.
    pub fn beta(&self) -> Option<[f64; 4]> {
        match self.expansion {
            Expansion::Voigt(b) => Some(b),
            Expansion::Beta(b) => Some([b, b, 0.0, b]),
            Expansion::Alpha(a) => match &self.elastic {
                Elastic::Orthotropic(o) => o.expansion_beta(a),
                Elastic::Matrix(_) => None,
                iso => {
                    let (l, m) = iso.lame()?;
                    let b = (3.0 * l + 2.0 * m) * a;
                    Some([b, b, 0.0, b])
                }
            },
        }
    }
}

/// The numbers of one boundary condition.
#[derive(Debug, Clone, PartialEq)]
pub enum BoundaryValue {
    /// Prescribed displacement \[m\] per global component; `None` leaves the component free.
    Displacement([Option<f64>; 2]),
    /// Surface traction P \[Pa\] in global x/y components.
    Traction([f64; 2]),
    /// Normal pressure p \[Pa\]: traction −p n with n the outward normal.
    Pressure(f64),
    /// Hydrostatic pressure p(y) = γ max(y0 − y, 0), traction −p n (design §2.6).
    Hydrostatic(HydrostaticData),
    /// Roller with a given direction, or the segment normal when `None`.
    Roller(Option<[f64; 2]>),
    /// Prescribed temperature T1 \[K\].
    Temperature(f64),
    /// Prescribed inward heat flux q [W/m²].
    HeatFlux(f64),
}

impl BoundaryValue {
    /// Whether the condition belongs to the heat problem.
    pub fn is_thermal(&self) -> bool {
        matches!(
            self,
            BoundaryValue::Temperature(_) | BoundaryValue::HeatFlux(_)
        )
    }
}

/// The numbers of a hydrostatic pressure (design §2.6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HydrostaticData {
    /// Level y0 \[m\] of the free surface.
    pub level: f64,
    /// Unit weight γ \[N/m³\].
    pub unit_weight: f64,
    /// A uniform pressure \[Pa\] added where the segment lies below the level: 0 in a scene's
    /// data. It is ∂p/∂y0 = γ H(y0 − y) when set to γ, which is how the level's derivative
    /// stencil writes the exact load derivative ([`super::params::stencil`]).
    pub wet_pressure: f64,
}

impl HydrostaticData {
    /// The pressure \[Pa\] at height y.
    pub fn pressure(&self, y: f64) -> f64 {
        if y < self.level {
            self.unit_weight * (self.level - y) + self.wet_pressure
        } else {
            0.0
        }
    }
}

/// A boundary condition resolved to its segment index.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryData {
    /// Index of the segment (scene segments in name order).
    pub segment: usize,
    /// The kind of condition and its numbers.
    pub value: BoundaryValue,
}

/// Slip limit g of a contact zone: piecewise linear in the fraction s ∈ [0, 1] of the zone.
#[derive(Debug, Clone, PartialEq)]
pub struct SlipData {
    /// Knot positions, fractions 0..1 of the zone's arc length, increasing; `[0]` for a constant g.
    pub knots: Vec<f64>,
    /// g at the knots \[Pa\].
    pub values: Vec<f64>,
}

/// Linear interpolation of `values` at increasing `knots`, constant outside; 0 without knots.
pub fn piecewise_linear(knots: &[f64], values: &[f64], s: f64) -> f64 {
    let n = knots.len().min(values.len());
    if n == 0 {
        return 0.0;
    }
    if s <= knots[0] {
        return values[0];
    }
    for i in 1..n {
        if s <= knots[i] {
            let w = (s - knots[i - 1]) / (knots[i] - knots[i - 1]);
            return values[i - 1] * (1.0 - w) + values[i] * w;
        }
    }
    values[n - 1]
}

/// All numbers a solve depends on.
#[derive(Debug, Clone, PartialEq)]
pub struct Data {
    /// Numbers of each material, in name order.
    pub materials: Vec<MaterialData>,
    /// Each boundary condition with its segment index, in list order.
    pub boundary: Vec<BoundaryData>,
    /// Slip limit per contact zone, in list order (zero on a Coulomb zone).
    pub slip: Vec<SlipData>,
    /// Coulomb friction coefficient F [-] per contact zone, in list order; `None` on a zone with
    /// a given (Tresca) slip limit.
    pub friction: Vec<Option<f64>>,
    /// Reference temperature T0 \[K\] of the stress-free state (0 without a thermal part).
    pub reference_temperature: f64,
    /// The numbers of a dynamic scene (empty without `dynamics`' entries).
    pub dynamic: DynamicData,
}

/// The numbers only a dynamic run reads (design §3.5): densities and Kelvin–Voigt retardation
/// times per material (name order, 0 where not given), and the damping α of each absorbing
/// layer (list order).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DynamicData {
    /// Density ρ \[kg/m³\] per material.
    pub density: Vec<f64>,
    /// Retardation time τ_v \[s\] per material.
    pub viscosity: Vec<f64>,
    /// Damping α \[kg/(m³ s)\] per absorbing layer.
    pub absorbing: Vec<f64>,
}

impl Data {
    /// Whether some contact zone has Coulomb friction (its slip bound depends on the state).
    pub fn has_coulomb(&self) -> bool {
        self.friction.iter().any(Option::is_some)
    }

    /// Resolve the numbers of a scene that `validate` accepted (missing values read as zero).
    pub fn from_scene(scene: &Scene) -> Data {
        let segment_index = |name: &str| scene.segments.keys().position(|k| k == name).unwrap_or(0);
        Data {
            materials: scene.materials.values().map(material_data).collect(),
            boundary: scene
                .boundary
                .iter()
                .map(|bc| BoundaryData {
                    segment: segment_index(&bc.segment),
                    value: boundary_value(bc),
                })
                .collect(),
            slip: scene
                .contacts
                .iter()
                .map(|c| match &c.slip_limit {
                    SlipLimit::Constant(g) => SlipData {
                        knots: vec![0.0],
                        values: vec![*g],
                    },
                    SlipLimit::PiecewiseLinear { knots, values, .. } => SlipData {
                        knots: knots.clone(),
                        values: values.clone(),
                    },
                })
                .collect(),
            friction: scene
                .contacts
                .iter()
                .map(|c| c.friction_coefficient)
                .collect(),
            reference_temperature: scene
                .thermal
                .as_ref()
                .map_or(0.0, |t| t.reference_temperature),
            dynamic: DynamicData {
                density: scene
                    .materials
                    .values()
                    .map(|m| m.density.unwrap_or(0.0))
                    .collect(),
                viscosity: scene
                    .materials
                    .values()
                    .map(|m| m.viscosity.unwrap_or(0.0))
                    .collect(),
                absorbing: scene.absorbing.iter().map(|a| a.damping).collect(),
            },
        }
    }
}

impl Data {
    /// The numbers of one material of a validated scene.
    pub(crate) fn material(m: &Material) -> MaterialData {
        material_data(m)
    }
}

fn material_data(m: &Material) -> MaterialData {
    let elastic = match (m.young, m.nu, m.lambda, m.mu) {
        (Some(e), Some(nu), _, _) => Elastic::Young { e, nu },
        (_, _, Some(lambda), Some(mu)) => Elastic::Lame { lambda, mu },
        _ => match m.matrix {
            Some(d) => Elastic::Matrix(PlaneStrainLaw {
                d,
                out_of_plane: m.out_of_plane.unwrap_or([0.0; 3]),
            }),
            None => Elastic::Orthotropic(Orthotropic {
                young: [m.e1, m.e2, m.e3].map(|v| v.unwrap_or(0.0)),
                poisson: [m.nu12, m.nu13, m.nu23].map(|v| v.unwrap_or(0.0)),
                shear: m.g12.unwrap_or(0.0),
                angle: m.angle.unwrap_or(0.0),
            }),
        },
    };
    MaterialData {
        elastic,
        specific_weight: m.specific_weight.unwrap_or(0.0),
        body_force: m.body_force.unwrap_or([0.0, 0.0]),
        conductivity: match m.conductivity {
            Some(Conductivity::Scalar(k)) => [k, 0.0, k],
            Some(Conductivity::Matrix(k)) => [k[0][0], k[0][1], k[1][1]],
            None => [0.0; 3],
        },
        heat_source: m.heat_source.unwrap_or(0.0),
        expansion: match (m.expansion, m.beta) {
            (_, Some(ThermalStress::Scalar(b))) => Expansion::Beta(b),
            (_, Some(ThermalStress::Voigt(b))) => Expansion::Voigt(b),
            (Some(a), None) => Expansion::Alpha(a),
            (None, None) => Expansion::Beta(0.0),
        },
    }
}

fn boundary_value(bc: &BoundaryCondition) -> BoundaryValue {
    if let Some(d) = bc.displacement {
        BoundaryValue::Displacement(d)
    } else if let Some(t) = bc.traction {
        BoundaryValue::Traction(t)
    } else if let Some(p) = bc.pressure {
        BoundaryValue::Pressure(p)
    } else if let Some(h) = bc.hydrostatic {
        BoundaryValue::Hydrostatic(HydrostaticData {
            level: h.level,
            unit_weight: h.unit_weight,
            wet_pressure: 0.0,
        })
    } else if let Some(r) = &bc.roller {
        BoundaryValue::Roller(r.direction)
    } else if let Some(t) = bc.temperature {
        BoundaryValue::Temperature(t)
    } else {
        BoundaryValue::HeatFlux(bc.heat_flux.unwrap_or(0.0))
    }
}
