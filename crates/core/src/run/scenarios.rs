//! The fields of a finished worst-scenario run's scenarios (design §5.6): the nominal data and
//! the worst and best data of every criterion, solved again on the run's mesh (its mesh choice
//! applied) — the search keeps criteria, not fields — each as a VTU labelled with its scenario
//! and data, and a PVD index of the series. One mesh and operator set-up serves the whole
//! series, and data shared by several scenarios are solved once.

use std::collections::HashSet;
use std::fmt;

use super::{check_point, scenario_label, solve_output, solve_point, with_solver};
use super::{SolveOutput, SolveRequest};
use crate::error::WsmError;
use crate::estimate::ladder::scaled;
use crate::output::pvd::{write_pvd, SeriesEntry};
use crate::scenario::worst::WorstOutcome;
use crate::scene::params::parameters;
use crate::scene::{Criterion, CriterionSpec, Scene, SceneError};
use crate::state::StateProblem;
use wsm_search::ObjectiveResult;

/// A scenario of a run: its nominal data, or the worst or best data of one of its criteria.
#[derive(Debug, Clone, PartialEq)]
pub enum Scenario {
    /// The scene's own values of the uncertain data.
    Nominal,
    /// The data maximising the criterion.
    Worst(CriterionSpec),
    /// The data minimising the criterion.
    Best(CriterionSpec),
}

/// Why a run has no data for a scenario.
#[derive(Debug, Clone, PartialEq)]
pub enum ScenarioMissing {
    /// The run did not search this criterion (its name).
    NotSearched(String),
    /// The search found no feasible point for it (the scenario's title).
    NoPoint(String),
}

impl fmt::Display for ScenarioMissing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScenarioMissing::NotSearched(c) => write!(f, "the run did not search {c}"),
            ScenarioMissing::NoPoint(s) => write!(f, "no feasible point was found for the {s}"),
        }
    }
}

impl From<ScenarioMissing> for WsmError {
    fn from(missing: ScenarioMissing) -> WsmError {
        SceneError::new("criterion", missing.to_string()).into()
    }
}

impl Scenario {
    /// `nominal`, `worst` or `best`.
    pub fn kind(&self) -> &'static str {
        match self {
            Scenario::Nominal => "nominal",
            Scenario::Worst(_) => "worst",
            Scenario::Best(_) => "best",
        }
    }

    /// The criterion of a worst or best scenario.
    pub fn criterion(&self) -> Option<&CriterionSpec> {
        match self {
            Scenario::Nominal => None,
            Scenario::Worst(c) | Scenario::Best(c) => Some(c),
        }
    }

    /// In words: `nominal`, `worst phi3`, `best phi3@crest`.
    pub fn title(&self) -> String {
        match self.criterion() {
            Some(c) => format!("{} {}", self.kind(), c.name()),
            None => self.kind().to_string(),
        }
    }

    /// A file name stem: `nominal`, `worst-phi3`, `best-phi3-at-crest` (characters other than
    /// ASCII letters, digits, `_` and `.` become `_`).
    pub fn file_stem(&self) -> String {
        let Some(c) = self.criterion() else {
            return self.kind().to_string();
        };
        if c.criterion == Criterion::Defined {
            return format!("{}-{}", self.kind(), c.name());
        }
        let mut stem = format!("{}-{}", self.kind(), c.criterion.name());
        if let Some(region) = &c.region {
            stem.push_str("-at-");
            stem.extend(region.chars().map(|ch| {
                if ch.is_ascii_alphanumeric() || ch == '_' || ch == '.' {
                    ch
                } else {
                    '_'
                }
            }));
        }
        stem
    }

    /// The search's extremum of this scenario in `outcome` (`None` for the nominal data).
    fn extremum<'a>(
        &self,
        outcome: &'a WorstOutcome,
    ) -> Result<Option<&'a ObjectiveResult>, ScenarioMissing> {
        let Some(criterion) = self.criterion() else {
            return Ok(None);
        };
        let found = outcome
            .criteria
            .iter()
            .find(|c| &c.criterion == criterion)
            .ok_or_else(|| ScenarioMissing::NotSearched(criterion.name()))?;
        Ok(Some(match self {
            Scenario::Worst(_) => &found.worst,
            _ => &found.best,
        }))
    }

    /// The data of this scenario in `outcome`: `None` for the nominal data.
    pub fn point(&self, outcome: &WorstOutcome) -> Result<Option<Vec<f64>>, ScenarioMissing> {
        match self.extremum(outcome)? {
            None => Ok(None),
            Some(extremum) => extremum
                .point
                .clone()
                .map(Some)
                .ok_or_else(|| ScenarioMissing::NoPoint(self.title())),
        }
    }
}

/// One solved scenario of a series.
#[derive(Debug, Clone)]
pub struct ScenarioFields {
    /// Which scenario.
    pub scenario: Scenario,
    /// Its file name in the series (`worst-phi3.vtu`), unique within it.
    pub file: String,
    /// The solve, with its fields and VTU.
    pub output: SolveOutput,
}

/// The scene a run solved: `scene` at the mesh sizes of the run's mesh choice, if it made one.
fn run_scene(scene: Scene, outcome: &WorstOutcome) -> Result<Scene, WsmError> {
    match &outcome.mesh_choice {
        Some(choice) => scaled(&scene, choice.size_factor),
        None => Ok(scene),
    }
}

/// The solve of one scenario of the run `outcome` of `scene` (the scene the run was given), with
/// fields and a VTU naming the scenario, its criterion, the criterion's value and its data.
pub fn scenario_solve(
    scene: Scene,
    outcome: &WorstOutcome,
    scenario: &Scenario,
    request: &SolveRequest,
) -> Result<SolveOutput, WsmError> {
    let point = scenario.point(outcome)?;
    let scene = with_solver(run_scene(scene, outcome)?, request);
    let params = parameters(&scene)?;
    if let Some(p) = &point {
        check_point(p, &params)?;
    }
    let problem = StateProblem::new(scene)?;
    let (data, solution) = solve_point(&problem, &params, point.as_deref())?;
    let label = labelled(&problem, &params, point.as_deref(), scenario, outcome);
    Ok(solve_output(&problem, &data, &solution, &label, request))
}

fn labelled(
    problem: &StateProblem,
    params: &[crate::scene::params::Parameter],
    point: Option<&[f64]>,
    scenario: &Scenario,
    outcome: &WorstOutcome,
) -> crate::output::solution_grid::ScenarioLabel {
    let mut label = scenario_label(problem, params, point, scenario.kind());
    label.criterion = scenario.criterion().map(CriterionSpec::name);
    label.criterion_value = scenario
        .extremum(outcome)
        .ok()
        .flatten()
        .and_then(|e| e.value);
    label
}

/// The series of a run: the nominal scenario, then the worst and best of every criterion in the
/// run's order, each with fields and a VTU, on one set-up of the run's mesh. Scenarios without a
/// feasible point are left out and listed, with the reason, in the second value.
pub fn scenario_series(
    scene: Scene,
    outcome: &WorstOutcome,
    request: &SolveRequest,
) -> Result<(Vec<ScenarioFields>, Vec<String>), WsmError> {
    let request = SolveRequest {
        fields: true,
        ..request.clone()
    };
    let scene = with_solver(run_scene(scene, outcome)?, &request);
    let params = parameters(&scene)?;
    let problem = StateProblem::new(scene)?;
    let mut scenarios = vec![Scenario::Nominal];
    for c in &outcome.criteria {
        scenarios.push(Scenario::Worst(c.criterion.clone()));
        scenarios.push(Scenario::Best(c.criterion.clone()));
    }
    let mut solved: Vec<(Option<Vec<f64>>, _)> = Vec::new();
    let mut series = Vec::new();
    let mut skipped = Vec::new();
    let mut files = HashSet::new();
    for scenario in scenarios {
        let point = match scenario.point(outcome) {
            Ok(point) => point,
            Err(missing) => {
                skipped.push(missing.to_string());
                continue;
            }
        };
        if let Some(p) = &point {
            check_point(p, &params)?;
        }
        let index = match solved.iter().position(|(p, _)| p == &point) {
            Some(index) => index,
            None => {
                solved.push((
                    point.clone(),
                    solve_point(&problem, &params, point.as_deref())?,
                ));
                solved.len() - 1
            }
        };
        let (data, solution) = &solved[index].1;
        let label = labelled(&problem, &params, point.as_deref(), &scenario, outcome);
        let output = solve_output(&problem, data, solution, &label, &request);
        let stem = scenario.file_stem();
        let mut file = format!("{stem}.vtu");
        let mut n = 2;
        while !files.insert(file.clone()) {
            file = format!("{stem}-{n}.vtu");
            n += 1;
        }
        series.push(ScenarioFields {
            scenario,
            file,
            output,
        });
    }
    Ok((series, skipped))
}

/// The PVD index of a series: ParaView opens it as one data set whose time steps are the
/// scenarios in order.
pub fn series_index(series: &[ScenarioFields]) -> String {
    let entries: Vec<SeriesEntry> = series
        .iter()
        .map(|s| SeriesEntry {
            file: s.file.clone(),
            title: s.scenario.title(),
            time: None,
        })
        .collect();
    write_pvd(&entries)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Criterion;

    #[test]
    fn titles_and_file_stems() {
        let bound = CriterionSpec {
            criterion: Criterion::Phi3,
            region: Some("crest/left side".into()),
        };
        let free = CriterionSpec {
            criterion: Criterion::Phi5,
            region: None,
        };
        assert_eq!(Scenario::Nominal.title(), "nominal");
        assert_eq!(Scenario::Nominal.file_stem(), "nominal");
        assert_eq!(Scenario::Best(free).file_stem(), "best-phi5");
        let worst = Scenario::Worst(bound);
        assert_eq!(worst.title(), "worst phi3@crest/left side");
        assert_eq!(worst.file_stem(), "worst-phi3-at-crest_left_side");
    }
}
