//! wsm-scene — the scene: the JSON document a user submits (design §5.2), its validation, its
//! numeric data and its uncertain parameters. The first stage of the engine's pipeline, a crate
//! of its own because it needs no numerics library: it compiles beside faer, and the engine
//! (`wsm-core`) names it `scene` and re-exports the document at its front door; other crates use
//! it through wsm-core. The planar primitives, `piecewise_linear` and `touching_tolerance` are
//! public for the engine's mesher and loads, which share them.
//!
//! `model` is the serde shape, `validate` checks meaning and names the JSON path of any bad
//! field, `data` resolves the numbers a solve needs, `params` maps uncertain parameters onto them,
//! `law` builds the plane-strain law of a material (FGCS 2.7′) and checks interval
//! matrices (FGCS 4.6, 4.8), `planar` holds the orientation and signed-area primitives the
//! validation and the mesher share, `rules` holds the sign and range rules (materials, slip limit) both of them check,
//! `strict` reads JSON refusing repeated keys (the scene files and the service's bodies),
//! `warnings` lists what a valid scene holds that is probably not meant (implausible
//! magnitudes, uncertain data addressed by the index of a named entry), and `schema` derives
//! the JSON Schema of the document from `model`.

mod data;
pub mod dynamics;
pub mod law;
mod model;
pub mod params;
mod planar;
mod rules;
mod schema;
mod shape;
mod strict;
mod validate;
mod warning;
mod warnings;

pub use data::piecewise_linear;
pub use data::{
    BoundaryData, BoundaryValue, Data, DynamicData, Elastic, Expansion, HydrostaticData,
    MaterialData, SlipData,
};
pub use dynamics::{
    AbsorbingLayer, ContactSolver, Dynamics, InitialState, PointLoad, Receiver, TimeFunction,
    TimeScheme,
};
pub use law::{Orthotropic, PlaneStrainLaw};
pub use model::{
    is_defined_name, Body, BoundaryCondition, BoundaryPiece, Conductivity, Contact, ContactKind,
    ContactMethod, CoulombAcceleration, Coupling, CriteriaRegions, Criterion, CriterionRegion,
    CriterionSpec, DdCoarse, DdIteration, DdPcg1, DdSettings, DdWeights, DefinedCriterion,
    DefinedQuantity, Driven, Element, Hydrostatic, InitialGap, InlineMesh, Material, MeshControls,
    Point, Refinement, Roller, Scene, SearchSettings, Segment, SlipLimit, SolverKind,
    SolverSettings, StopRule, Thermal, ThermalStress, Uncertain, Zone, MAX_SUBDIVIDE,
};
pub use planar::{cross, orient, signed_area2, sub};
pub use schema::{scene_schema, scene_schema_json, SCENE_SCHEMA_DIALECT};
pub use shape::{objects_where_objects, plain_message};
pub use strict::{strict_value, StrictError};
pub use validate::touching_tolerance;
pub use validate::{check_criteria_list, parse, validate, MAX_COORDINATE, MAX_NAME, MAX_TEXT};
pub use warning::{Warning, WarningKind};
pub use warnings::{warnings, MAX_SPECIFIC_WEIGHT, MAX_SURFACE_LOAD, MIN_SOLID_MODULUS};

use std::fmt;

/// A scene error: the JSON path of the offending field and the reason.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// JSON path of the offending field, e.g. `bodies[0].zones[1].material` (`$` for the whole
    /// document); for run settings the request field or command-line option.
    pub path: String,
    /// Why the field was refused.
    pub reason: String,
}

impl SceneError {
    /// An error at `path` with `reason`.
    pub fn new(path: impl Into<String>, reason: impl Into<String>) -> SceneError {
        SceneError {
            path: path.into(),
            reason: reason.into(),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path, self.reason)
    }
}

impl std::error::Error for SceneError {}
