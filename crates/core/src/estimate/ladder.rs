//! Mesh levels of a scene: the same geometry with every mesh size (`mesh.max_size` and each
//! local `mesh.refine[].max_size`) multiplied by one factor. Level k of a ladder has the factor
//! `coarsest · ratio^(−k)`, so each level refines the previous one by `ratio` in h (about
//! `ratio²` in unknowns). The meshes are not nested: the Delaunay mesher meshes each level anew.
//! An imported mesh has no sizes to scale: its levels are uniform subdivisions (factor 1/2 each,
//! nested), so only factors 1/2^k exist for it.
//! [`DirectLevel`] is one level set up for cold, thread-count-independent direct solves of
//! chosen criteria (the accuracy statement's refined meshes, the target-error ladder).

use crate::error::WsmError;
use crate::fem::Par;
use crate::scene::{CriterionSpec, Data, Scene, SceneError, SolverKind, MAX_SUBDIVIDE};
use crate::state::{Needs, SolveOptions, StateProblem, Target};

/// The scene with all mesh sizes multiplied by `factor` (> 0). An imported mesh (design §2.5) is
/// refined by uniform subdivision, which halves h: its factor must be 1/2^k (k more
/// subdivisions); it cannot be coarsened.
pub fn scaled(scene: &Scene, factor: f64) -> Result<Scene, WsmError> {
    if let Some(path) = scene.mesh.imported() {
        let halvings = -factor.log2();
        let k = halvings.round();
        if !(factor.is_finite() && factor > 0.0 && k >= 0.0 && halvings == k) {
            return Err(SceneError::new(
                path,
                format!(
                    "an imported mesh is only refined by uniform subdivision, which halves the \
                     element size: no mesh with sizes × {factor}"
                ),
            )
            .into());
        }
        let mut out = scene.clone();
        out.mesh.subdivide += k as u32;
        if out.mesh.subdivide > MAX_SUBDIVIDE {
            return Err(SceneError::new(
                "mesh.subdivide",
                format!("more than {MAX_SUBDIVIDE} subdivisions of the imported mesh"),
            )
            .into());
        }
        return Ok(out);
    }
    if !(factor.is_finite() && factor > 0.0) {
        return Err(SceneError::new(
            "mesh.max_size",
            format!("mesh size factor must be positive (got {factor})"),
        )
        .into());
    }
    let mut out = scene.clone();
    if let Some(h) = &mut out.mesh.max_size {
        *h *= factor;
    }
    for r in &mut out.mesh.refine {
        r.max_size *= factor;
    }
    Ok(out)
}

/// A scene on one mesh level, solved cold by the direct solver with sequential factorisations
/// (results independent of the thread count): what the accuracy statement and the mesh choice
/// re-solve.
pub struct DirectLevel {
    /// The scene on this level's mesh, set up for direct solves.
    pub problem: StateProblem,
    options: SolveOptions,
    targets: Vec<Target>,
}

impl DirectLevel {
    /// Mesh and set up `scene` with its mesh sizes × `factor`, for `criteria`.
    pub fn new(
        scene: &Scene,
        factor: f64,
        criteria: &[CriterionSpec],
    ) -> Result<DirectLevel, WsmError> {
        let mut scene = scaled(scene, factor)?;
        scene.solver.kind = SolverKind::Direct;
        let problem = StateProblem::new(scene)?;
        let targets = problem.targets(criteria)?;
        let options = SolveOptions {
            needs: Needs::for_targets(&problem.scene, &targets),
            par: Par::Seq,
            warm: None,
        };
        Ok(DirectLevel {
            problem,
            options,
            targets,
        })
    }

    /// The criteria at `data` (`None` where one is not defined), or why the solve failed.
    pub fn criteria_at(&self, data: &Data) -> Result<Vec<Option<f64>>, WsmError> {
        self.problem
            .solve(data, &self.options)
            .map(|s| self.targets.iter().map(|&t| s.value(t)).collect())
    }

    /// Unknowns (free displacement DOFs) on this level's mesh.
    pub fn unknowns(&self) -> usize {
        self.problem.elastic.dofs().n_free()
    }

    /// Triangles of this level's mesh.
    pub fn triangles(&self) -> usize {
        self.problem.mesh().triangles.len()
    }
}

/// A sequence of mesh size factors, coarsest first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ladder {
    /// Size factor of level 0.
    pub coarsest: f64,
    /// Refinement in h from one level to the next (> 1).
    pub ratio: f64,
    /// Number of levels (≥ 3, enough for a Richardson extrapolation).
    pub levels: usize,
}

impl Ladder {
    /// Check the numbers; errors name the command-line option.
    pub fn new(coarsest: f64, ratio: f64, levels: usize) -> Result<Ladder, WsmError> {
        if !(coarsest.is_finite() && coarsest > 0.0) {
            return Err(SceneError::new("--coarsest", "must be a positive factor").into());
        }
        if !(ratio.is_finite() && ratio > 1.0) {
            return Err(SceneError::new("--ratio", "must be greater than 1").into());
        }
        if levels < 3 {
            return Err(SceneError::new(
                "--levels",
                "at least 3 levels are needed for an extrapolation",
            )
            .into());
        }
        Ok(Ladder {
            coarsest,
            ratio,
            levels,
        })
    }

    /// The size factor of level k.
    pub fn factor(&self, level: usize) -> f64 {
        self.coarsest * self.ratio.powi(-(level as i32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{InlineMesh, Scene};

    #[test]
    fn an_imported_mesh_is_scaled_by_subdivision_only() {
        let mut scene = crate::mesh::tests::scene(serde_json::json!({
            "version": 1,
            "bodies": [{ "name": "b", "zones": [{ "name": "z", "material": "m", "polygon": [] }] }],
            "materials": { "m": { "E": 1.0, "nu": 0.3 } },
            "mesh": {}
        }));
        scene.mesh.inline = Some(InlineMesh {
            nodes: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            triangles: vec![[0, 1, 2]],
            zones: vec!["z".into()],
            triangle_zones: vec![0],
            segments: Default::default(),
        });
        assert_eq!(scaled(&scene, 0.25).unwrap().mesh.subdivide, 2);
        assert_eq!(scaled(&scene, 1.0).unwrap().mesh.subdivide, 0);
        for factor in [2.0, 0.3, 0.0, f64::NAN] {
            let e = scaled(&scene, factor).err().unwrap().to_string();
            assert!(
                e.starts_with("mesh.inline: an imported mesh is only refined"),
                "{e}"
            );
        }
        scene.mesh.subdivide = MAX_SUBDIVIDE;
        let e = scaled(&scene, 0.5).err().unwrap().to_string();
        assert!(e.starts_with("mesh.subdivide: more than"), "{e}");
    }

    /// Design §2.5: on a mesh that wsm also generates (block on base, two bodies in contact),
    /// the ladder of uniform subdivisions of the imported coarse mesh and the generated ladder
    /// (sizes halved, meshed anew) extrapolate to the same values, and the mean displacement
    /// converges under subdivision at a steady P1 rate (differences between levels falling by
    /// 2^p, 1 ≤ p ≤ 2).
    #[test]
    fn subdivision_and_generated_ladders_converge_to_the_same_value() {
        let mut scene =
            crate::scene::parse(crate::bundled::find("block-on-base").unwrap()).unwrap();
        scene.mesh.max_size = Some(0.2);
        scene.mesh.refine.clear();
        let mesh = crate::mesh::generate(&scene).unwrap();
        let mut imported = scene.clone();
        imported.mesh.inline = Some(mesh.to_inline());
        let criteria: Vec<CriterionSpec> = scene.search.criteria.clone();
        let ladder = |scene: &Scene| -> Vec<(f64, Vec<f64>)> {
            (0..4)
                .map(|k| {
                    let level = DirectLevel::new(scene, 0.5f64.powi(k), &criteria).unwrap();
                    let values = level.criteria_at(&level.problem.nominal).unwrap();
                    let h = (level.unknowns() as f64).powf(-0.5);
                    (h, values.into_iter().map(Option::unwrap).collect())
                })
                .collect()
        };
        let (generated, subdivided) = (ladder(&scene), ladder(&imported));
        for (c, criterion) in criteria.iter().enumerate() {
            let values = |l: &[(f64, Vec<f64>)]| l.iter().map(|x| x.1[c]).collect::<Vec<_>>();
            let hs = |l: &[(f64, Vec<f64>)]| l.iter().map(|x| x.0).collect::<Vec<_>>();
            let (g, s) = (values(&generated), values(&subdivided));
            assert!(
                (g[0] - s[0]).abs() <= 1e-12 * g[0].abs(),
                "the same coarse mesh"
            );
            let fit = |l: &[(f64, Vec<f64>)]| {
                super::super::richardson::extrapolate(&hs(l)[1..], &values(l)[1..]).unwrap()
            };
            let (fg, fs) = (fit(&generated), fit(&subdivided));
            // Differences between successive subdivisions: each about 2^p times the next.
            let d: Vec<f64> = s.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
            let rates: Vec<f64> = d.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
            println!(
                "{criterion:?}: generated {g:?} → {:.6e} (order {:?}); subdivided {s:?} → \
                 {:.6e} (order {:?}); subdivision rates {rates:?}",
                fg.value, fg.order, fs.value, fs.order
            );
            let spread = (g[0] - g[3]).abs().max((s[0] - s[3]).abs());
            assert!(
                (fg.value - fs.value).abs() <= 0.1 * spread,
                "{criterion:?}: extrapolations {} and {} differ by more than 10 % of the \
                 coarse-to-fine change {spread}",
                fg.value,
                fs.value
            );
            // The mean displacement Φ3 converges steadily at a P1 rate: between the energy
            // norm's 1 and the smooth solution's 2 (the block's corners on the contact limit
            // it). Stress means near the corners (Φ5, Φ6) are not yet monotone at these sizes,
            // on either ladder.
            if criterion.criterion == crate::scene::Criterion::Phi3 {
                assert!(
                    rates.iter().all(|&p| (1.0..=2.2).contains(&p))
                        && (rates[0] - rates[1]).abs() < 0.2,
                    "{criterion:?}: rates {rates:?}"
                );
            }
        }
    }
}
