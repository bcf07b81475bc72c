//! `GET /v1/jobs/{id}/fields`: the mesh and fields of a job's nominal, worst or best scenario
//! (design §5.6), solved on the job's mesh within the cap on synchronous solves (`solves`), as
//! JSON for the dashboard or as a VTU file for ParaView, PyVista and meshio.

use axum::extract::{Path, State};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Deserialize;
use utoipa::{IntoParams, ToSchema};

use super::error::{ApiError, ErrorBody};
use super::jobs::{attachment, outcome, stored_scene};
use super::query::Query;
use super::{blocking, solves, AppState, CanRead};
use wsm_core::{CriterionSpec, Scenario, ScenarioMissing, SolveOutput, SolveRequest, WorstOutcome};

/// Which data of the job to solve with.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum ScenarioChoice {
    /// The scene's own values of the uncertain data.
    Nominal,
    /// The data maximising the criterion.
    #[default]
    Worst,
    /// The data minimising the criterion.
    Best,
}

/// How the fields are written.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum FieldsFormat {
    /// Mesh, fields and summary as JSON.
    #[default]
    Json,
    /// A binary VTU file for ParaView, PyVista and meshio, naming the scenario and its data in
    /// its field data.
    Vtu,
}

/// Which scenario's fields to compute.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct FieldsQuery {
    /// `worst` (default), `best` or `nominal` (the scene's own data).
    #[param(inline)]
    pub scenario: Option<ScenarioChoice>,
    /// The criterion whose worst or best data to use (default: the first requested; not used
    /// for `nominal`).
    pub criterion: Option<String>,
    /// `json` (default: mesh, fields and summary) or `vtu` (a binary VTU file for ParaView,
    /// PyVista and meshio, naming the scenario and its data in its field data).
    #[param(inline)]
    pub format: Option<FieldsFormat>,
}

impl FieldsQuery {
    /// The scenario asked for, with data in `outcome`: 422 for a criterion the job did not
    /// search, 409 when it found no point for it.
    fn scenario(&self, outcome: &WorstOutcome) -> Result<Scenario, ApiError> {
        let criterion = || -> Result<CriterionSpec, ApiError> {
            match &self.criterion {
                Some(name) => {
                    CriterionSpec::parse(name).map_err(|why| ApiError::invalid("criterion", why))
                }
                None => outcome
                    .criteria
                    .first()
                    .map(|c| c.criterion.clone())
                    .ok_or_else(|| ApiError::conflict("the job has no criteria")),
            }
        };
        let scenario = match self.scenario.unwrap_or_default() {
            ScenarioChoice::Nominal => Scenario::Nominal,
            ScenarioChoice::Worst => Scenario::Worst(criterion()?),
            ScenarioChoice::Best => Scenario::Best(criterion()?),
        };
        scenario.point(outcome).map_err(|missing| match missing {
            ScenarioMissing::NotSearched(_) => ApiError::invalid("criterion", missing.to_string()),
            ScenarioMissing::NoPoint(_) => ApiError::conflict(missing.to_string()),
        })?;
        Ok(scenario)
    }
}

/// The mesh and fields (displacement \[m\], temperature \[K\], stresses \[Pa\], I2² \[Pa²\],
/// contact pressure \[Pa\] and slip \[m\]) of a job's nominal, worst or best scenario, solved on
/// the job's mesh.
#[utoipa::path(get, path = "/v1/jobs/{id}/fields", tag = "jobs",
    params(("id" = String, Path, description = "Job id"), FieldsQuery),
    responses((status = 200, body = SolveOutput),
        (status = 401, description = "Token required", body = ErrorBody), (status = 404, body = ErrorBody),
        (status = 409, body = ErrorBody), (status = 422, body = ErrorBody)))]
pub async fn job_fields(
    _: CanRead,
    State(state): State<AppState>,
    Path(id): Path<String>,
    Query(q): Query<FieldsQuery>,
) -> Result<Response, ApiError> {
    let (job, outcome) = outcome(&state, &id).await?;
    let scenario = q.scenario(&outcome)?;
    let scene = stored_scene(&job)?;
    let file = format!("{id}-{}.vtu", scenario.file_stem());
    let request = SolveRequest {
        solver: None,
        fields: true,
        frames: false,
    };
    let place = state.solves.take()?;
    let output = blocking(move || {
        let _place = place;
        wsm_core::scenario_solve(scene, &outcome, &scenario, &request)
    })
    .await?
    .map_err(|e| ApiError::engine(e, "scene"))?;
    match q.format.unwrap_or_default() {
        FieldsFormat::Vtu => Ok(attachment(
            "application/xml",
            &file,
            output.vtu.unwrap_or_default().into_bytes(),
        )),
        FieldsFormat::Json => {
            solves::check_fields(
                &output,
                state.limits.max_field_triangles,
                "format",
                "download them as format=vtu for ParaView",
            )?;
            Ok(Json(output).into_response())
        }
    }
}
