//! The mesh of a run with a target error (`--target-error REL`, design §6): the scene on a ladder
//! of meshes — every mesh size multiplied by 4, 2, 1, 1/2, … — solved at the nominal data, the
//! discretisation error of each level's criteria estimated from the next two finer levels
//! exactly as in the accuracy statement (Richardson extrapolation when the three values converge
//! monotonically, else the largest difference; one finer level where the ladder ends), and the
//! run takes the coarsest level whose estimate of every requested criterion is within the
//! target. The ladder stops before a level would exceed [`MAX_CHOICE_UNKNOWNS`], or after a mesh
//! at least as fine as the scene's that cannot be built; when no level meets the target the run
//! takes the finest one that solved and says so.
//!
//! A level whose solve fails (or whose mesh cannot be built) is kept as a candidate with its
//! `failure`, meets no target and helps estimate no other level's error; the run reports it as a
//! warning and goes on with the levels that solved. Only when none solved does the choice fail,
//! with the error of the scene's own mesh.
//!
//! The choice is made at the nominal data, before the search; the accuracy statement of the
//! result then checks it at the worst and best data. The solves are cold sequential direct
//! solves, so the choice is a function of the scene and the target alone (bit-identical on any
//! thread count, machine or resume) and belongs to the run hash.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::ladder::{scaled, DirectLevel};
use super::statement::extremum_accuracy;
use crate::error::WsmError;
use crate::fault::{injected, FaultSite, SolveFault};
use crate::scene::{CriterionSpec, Scene, SceneError};

/// Size factor of the coarsest level tried (relative to the scene's mesh sizes).
pub const COARSEST_FACTOR: f64 = 4.0;
/// No level of the ladder beyond this many unknowns.
pub const MAX_CHOICE_UNKNOWNS: usize = 400_000;

/// One level of the ladder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct CandidateMesh {
    /// Mesh sizes relative to the scene's (4, 2, 1, 1/2, …).
    pub size_factor: f64,
    /// Unknowns (free displacement DOFs) on this level's mesh.
    pub unknowns: usize,
    /// Triangles of this level's mesh.
    pub triangles: usize,
    /// The requested criteria at the nominal data on this mesh (`None`: not defined or the solve
    /// failed).
    pub values: Vec<Option<f64>>,
    /// Estimated relative discretisation error of each value (`None`: no finer level to compare
    /// with, or a failed solve).
    pub relative_errors: Vec<Option<f64>>,
    /// Every estimate is within the target.
    pub meets_target: bool,
    /// Meshing, set-up and the solve \[s\].
    pub seconds: f64,
    /// Why this level could not be meshed or solved.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// How the run's mesh was chosen for a target error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct MeshChoice {
    /// The requested relative error of every criterion.
    pub target_error: f64,
    /// The chosen level's size factor (the run's mesh sizes are the scene's × this).
    pub size_factor: f64,
    /// Whether the chosen level's estimate meets the target; false when no level up to
    /// `MAX_CHOICE_UNKNOWNS` unknowns did (the finest level that solved is used).
    pub met: bool,
    /// The levels built, coarsest first.
    pub candidates: Vec<CandidateMesh>,
    /// Wall time of the choice \[s\].
    pub seconds: f64,
    /// How the level was chosen, in words (ladder factors, error estimate, choice rule).
    pub method: String,
}

/// Check a target error (the request field `target_error`).
pub fn check_target(scene: &Scene, target: f64) -> Result<(), WsmError> {
    if !(target.is_finite() && target > 0.0 && target < 1.0) {
        return Err(SceneError::new(
            "target_error",
            format!("a relative error between 0 and 1, e.g. 0.01 for 1 % (got {target})"),
        )
        .into());
    }
    if let Some(path) = scene.mesh.imported() {
        return Err(SceneError::new(
            "target_error",
            format!(
                "an imported mesh ({path}) cannot be coarsened by wsm, and the ladder starts at \
                 4 × the scene's sizes: leave target_error out (the accuracy statement still \
                 refines the mesh by subdivision)"
            ),
        )
        .into());
    }
    Ok(())
}

/// A level's criteria at the nominal data, or why its mesh could not be built or solved.
struct Level {
    factor: f64,
    /// Whether its mesh was built (unknowns and triangles are 0 otherwise).
    built: bool,
    unknowns: usize,
    triangles: usize,
    values: Result<Vec<Option<f64>>, WsmError>,
    seconds: f64,
}

fn solve_level(
    scene: &Scene,
    criteria: &[CriterionSpec],
    factor: f64,
    fault: Option<&SolveFault>,
) -> Level {
    let start = Instant::now();
    match DirectLevel::new(scene, factor, criteria) {
        Ok(level) => Level {
            factor,
            built: true,
            unknowns: level.unknowns(),
            triangles: level.triangles(),
            values: match injected(
                fault,
                FaultSite::MeshChoice {
                    size_factor: factor,
                },
            ) {
                Some(reason) => Err(WsmError::contact(reason)),
                None => level.criteria_at(&level.problem.nominal),
            },
            seconds: start.elapsed().as_secs_f64(),
        },
        Err(e) => Level {
            factor,
            built: false,
            unknowns: 0,
            triangles: 0,
            values: Err(e),
            seconds: start.elapsed().as_secs_f64(),
        },
    }
}

/// The relative error estimates of `level`'s values from the finer levels after it (one or
/// two), relative to the largest magnitude on those levels; a criterion that is zero on all of
/// them has error 0.
fn relative_errors(level: &Level, finer: &[&Level], criteria: usize) -> Vec<Option<f64>> {
    let h: Vec<f64> = std::iter::once(level)
        .chain(finer.iter().copied())
        .map(|l| (l.unknowns.max(1) as f64).powf(-0.5))
        .collect();
    (0..criteria)
        .map(|k| {
            let value = level.values.as_ref().ok()?[k]?;
            let refined: Vec<Option<f64>> = finer
                .iter()
                .map(|l| l.values.as_ref().ok().and_then(|v| v[k]))
                .collect();
            if refined.iter().any(Option::is_none) {
                return None;
            }
            let estimate = extremum_accuracy(value, refined.clone(), &h, None).estimate?;
            let scale = refined
                .iter()
                .flatten()
                .fold(value.abs(), |m, r| m.max(r.abs()));
            Some(if scale > 0.0 { estimate / scale } else { 0.0 })
        })
        .collect()
}

/// The scene on the coarsest mesh whose estimated error of every criterion at the nominal data
/// is within `target` (relative), and how it was chosen. `stop` is polled between levels
/// (cancel: `WsmError::Cancelled`); `fault` fails the solves where it answers (tests).
pub fn choose_mesh(
    scene: &Scene,
    criteria: &[CriterionSpec],
    target: f64,
    stop: &dyn Fn() -> bool,
    fault: Option<&SolveFault>,
    refuse: Option<&Refusal<'_>>,
) -> Result<(Scene, MeshChoice), WsmError> {
    choose_mesh_within(
        scene,
        criteria,
        target,
        MAX_CHOICE_UNKNOWNS,
        stop,
        fault,
        refuse,
    )
}

/// Why the level with mesh sizes × factor must not be built (its solve would need more memory
/// than the run may use; answered by the caller from the cost estimate, design §3.1).
pub type Refusal<'a> = dyn Fn(f64) -> Option<WsmError> + 'a;

/// [`choose_mesh`] with a ladder of at most `max_unknowns` unknowns.
fn choose_mesh_within(
    scene: &Scene,
    criteria: &[CriterionSpec],
    target: f64,
    max_unknowns: usize,
    stop: &dyn Fn() -> bool,
    fault: Option<&SolveFault>,
    refuse: Option<&Refusal<'_>>,
) -> Result<(Scene, MeshChoice), WsmError> {
    check_target(scene, target)?;
    let start = Instant::now();
    let mut levels: Vec<Level> = Vec::new();
    let mut chosen: Option<usize> = None;
    loop {
        if stop() {
            return Err(WsmError::Cancelled);
        }
        if levels.last().is_some_and(|l| 4 * l.unknowns > max_unknowns) {
            break;
        }
        let factor = COARSEST_FACTOR * 0.5_f64.powi(levels.len() as i32);
        if let Some(error) = refuse.and_then(|refuse| refuse(factor)) {
            // Beyond the memory limit: not built, and every finer level is larger still.
            levels.push(Level {
                factor,
                built: false,
                unknowns: 0,
                triangles: 0,
                values: Err(error),
                seconds: 0.0,
            });
            break;
        }
        let level = solve_level(scene, criteria, factor, fault);
        // A mesh as fine as the scene's that cannot be built: a finer one is larger still.
        let last = !level.built && factor <= 1.0;
        levels.push(level);
        if last {
            break;
        }
        let n = levels.len();
        if n >= 3
            && meets(
                &levels[n - 3],
                &[&levels[n - 2], &levels[n - 1]],
                target,
                criteria,
            )
        {
            chosen = Some(n - 3);
            break;
        }
    }
    let n = levels.len();
    // The ladder ended at the cap: the second finest level with one refinement.
    if chosen.is_none() && n >= 2 && meets(&levels[n - 2], &[&levels[n - 1]], target, criteria) {
        chosen = Some(n - 2);
    }
    let met = chosen.is_some();
    let Some(index) = chosen.or_else(|| levels.iter().rposition(|l| l.values.is_ok())) else {
        return Err(none_solved(levels));
    };
    let candidates = levels
        .iter()
        .enumerate()
        .map(|(i, level)| {
            let finer: Vec<&Level> = levels[i + 1..].iter().take(2).collect();
            let relative = if finer.is_empty() {
                vec![None; criteria.len()]
            } else {
                relative_errors(level, &finer, criteria.len())
            };
            CandidateMesh {
                size_factor: level.factor,
                unknowns: level.unknowns,
                triangles: level.triangles,
                values: level
                    .values
                    .clone()
                    .unwrap_or_else(|_| vec![None; criteria.len()]),
                meets_target: within(&relative, target),
                relative_errors: relative,
                seconds: level.seconds,
                failure: level.values.as_ref().err().map(WsmError::to_string),
            }
        })
        .collect();
    let size_factor = levels[index].factor;
    let choice = MeshChoice {
        target_error: target,
        size_factor,
        met,
        candidates,
        seconds: start.elapsed().as_secs_f64(),
        method: format!(
            "the scene's mesh sizes × {COARSEST_FACTOR}, × {}, … solved at the nominal data \
             (direct solver, cold); a level's error is estimated from the next two finer levels \
             (Richardson extrapolation when monotone, else the largest difference), relative to \
             the largest magnitude; the coarsest level meeting the target for every criterion is \
             used, or the finest that solved (at most {max_unknowns} unknowns) when none does",
            COARSEST_FACTOR / 2.0
        ),
    };
    Ok((scaled(scene, size_factor)?, choice))
}

/// The error when no level of the ladder solved: the scene's own mesh's (size factor 1: the
/// error of the run without a target), or the finest level's when the ladder ended before it.
fn none_solved(levels: Vec<Level>) -> WsmError {
    let factors: Vec<String> = levels.iter().map(|l| l.factor.to_string()).collect();
    let what = format!(
        "target_error: no mesh of the ladder (sizes × {}) could be solved at the nominal data",
        factors.join(", ")
    );
    let own = levels.iter().rposition(|l| l.factor >= 1.0).unwrap_or(0);
    match levels.into_iter().nth(own).map(|l| l.values) {
        Some(Err(WsmError::Solver { stage, reason })) => WsmError::Solver {
            stage,
            reason: format!("{reason} ({what})"),
        },
        Some(Err(e)) => e,
        _ => SceneError::new("target_error", what).into(),
    }
}

fn meets(level: &Level, finer: &[&Level], target: f64, criteria: &[CriterionSpec]) -> bool {
    within(&relative_errors(level, finer, criteria.len()), target)
}

/// Every estimate is known and within the target.
fn within(relative: &[Option<f64>], target: f64) -> bool {
    relative.iter().all(|r| r.is_some_and(|r| r <= target))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Criterion;

    fn scene() -> Scene {
        crate::scene::parse(crate::bundled::find("block-on-base").unwrap()).unwrap()
    }

    #[test]
    fn picks_the_coarsest_level_meeting_the_target() {
        let scene = scene();
        let criteria = [CriterionSpec::from(Criterion::Phi3)];
        let (loose_scene, loose) =
            choose_mesh(&scene, &criteria, 0.05, &|| false, None, None).unwrap();
        let (_, tight) = choose_mesh(&scene, &criteria, 0.002, &|| false, None, None).unwrap();
        for choice in [&loose, &tight] {
            let i = choice
                .candidates
                .iter()
                .position(|c| c.size_factor == choice.size_factor)
                .unwrap();
            if choice.met {
                assert!(choice.candidates[i].meets_target, "{choice:#?}");
                assert!(choice.candidates[i].relative_errors[0].unwrap() <= choice.target_error);
            }
            // Coarsest: no coarser level meets the target.
            assert!(choice.candidates[..i].iter().all(|c| !c.meets_target));
        }
        assert!(
            tight.size_factor < loose.size_factor,
            "{loose:#?}\n{tight:#?}"
        );
        assert_eq!(
            loose_scene.mesh.max_size,
            scene.mesh.max_size.map(|h| h * loose.size_factor)
        );
        // Deterministic: the same choice, bit for bit.
        assert_eq!(
            choose_mesh(&scene, &criteria, 0.05, &|| false, None, None)
                .unwrap()
                .1
                .candidates
                .iter()
                .map(|c| c.values.clone())
                .collect::<Vec<_>>(),
            loose
                .candidates
                .iter()
                .map(|c| c.values.clone())
                .collect::<Vec<_>>()
        );
    }

    #[test]
    fn an_unreachable_target_takes_the_finest_level_within_the_cap_and_says_so() {
        let cap = 20_000;
        let (_, choice) = choose_mesh_within(
            &scene(),
            &[Criterion::Phi3.into()],
            1e-12,
            cap,
            &|| false,
            None,
            None,
        )
        .unwrap();
        assert!(!choice.met);
        let last = choice.candidates.last().unwrap();
        assert_eq!(choice.size_factor, last.size_factor);
        assert!(4 * last.unknowns > cap);
        let before = &choice.candidates[choice.candidates.len() - 2];
        assert!(4 * before.unknowns <= cap);
    }

    /// Fails the mesh choice's solves on meshes finer than `coarsest_failing` × the scene's.
    fn fail_finer_than(coarsest_failing: f64) -> impl Fn(&FaultSite<'_>) -> Option<String> {
        move |site| match site {
            FaultSite::MeshChoice { size_factor } if *size_factor <= coarsest_failing => {
                Some(format!("injected failure at sizes × {size_factor}"))
            }
            _ => None,
        }
    }

    #[test]
    fn a_level_beyond_the_memory_limit_ends_the_ladder_unbuilt() {
        let refuse = |factor: f64| {
            (factor < 1.0).then(|| crate::scene::SceneError::new("mesh.max_size", "too big").into())
        };
        let (_, choice) = choose_mesh_within(
            &scene(),
            &[Criterion::Phi3.into()],
            1e-12,
            MAX_CHOICE_UNKNOWNS,
            &|| false,
            None,
            Some(&refuse),
        )
        .unwrap();
        let last = choice.candidates.last().unwrap();
        assert_eq!(last.size_factor, 0.5, "{choice:#?}");
        assert_eq!(last.unknowns, 0, "not built");
        assert!(last.failure.as_ref().unwrap().contains("too big"));
        assert!(!choice.met);
        assert_eq!(choice.size_factor, 1.0, "the finest level built");
    }

    #[test]
    fn failed_levels_are_kept_with_their_error_and_the_finest_level_that_solved_is_used() {
        let cap = 20_000;
        let fault = fail_finer_than(0.5);
        let (chosen, choice) = choose_mesh_within(
            &scene(),
            &[Criterion::Phi3.into()],
            1e-12,
            cap,
            &|| false,
            Some(&fault),
            None,
        )
        .unwrap();
        assert!(!choice.met);
        // The ladder went on to its cap through the failed levels …
        let failed: Vec<&CandidateMesh> = choice
            .candidates
            .iter()
            .filter(|c| c.size_factor <= 0.5)
            .collect();
        assert!(!failed.is_empty(), "{choice:#?}");
        for c in &failed {
            assert!(c.failure.as_ref().unwrap().contains("injected failure"));
            assert!(c.values.iter().all(Option::is_none) && !c.meets_target);
            assert!(c.unknowns > 0, "built, then failed to solve");
        }
        // … and the run takes the finest level that solved: the scene's own mesh.
        assert_eq!(choice.size_factor, 1.0);
        assert_eq!(chosen.mesh.max_size, scene().mesh.max_size);
        let own = &choice.candidates[2];
        assert_eq!(own.size_factor, 1.0);
        assert!(own.failure.is_none() && own.values[0].is_some());
        // Its error estimate needed the failed finer levels: unknown.
        assert_eq!(own.relative_errors, vec![None]);
    }

    #[test]
    fn a_ladder_where_no_level_solves_fails_with_the_scene_meshs_error() {
        let fault = fail_finer_than(f64::INFINITY);
        let e = choose_mesh_within(
            &scene(),
            &[Criterion::Phi3.into()],
            0.01,
            20_000,
            &|| false,
            Some(&fault),
            None,
        )
        .unwrap_err();
        assert_eq!(e.kind(), crate::error::ErrorKind::Solver, "{e}");
        let text = e.to_string();
        assert!(text.contains("injected failure at sizes × 1 "), "{text}");
        assert!(
            text.contains("target_error: no mesh of the ladder"),
            "{text}"
        );
    }

    #[test]
    fn bad_targets_and_cancels_are_refused() {
        for bad in [0.0, -0.1, 1.0, f64::NAN, f64::INFINITY] {
            let e = choose_mesh(
                &scene(),
                &[Criterion::Phi3.into()],
                bad,
                &|| false,
                None,
                None,
            )
            .unwrap_err();
            assert!(e.to_string().contains("target_error"), "{e}");
        }
        let e = choose_mesh(
            &scene(),
            &[Criterion::Phi3.into()],
            0.01,
            &|| true,
            None,
            None,
        )
        .unwrap_err();
        assert!(matches!(e, WsmError::Cancelled));
    }
}
