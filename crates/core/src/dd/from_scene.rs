//! DD for a scene's elastic contact problem (design §3.2 wired into the state layer): the scene's
//! solver settings become [`DdOptions`], the contact rows come from the direct solver's
//! [`crate::contact::pairs::ContactGeometry`] (same discrete problem), and the answer is returned
//! in the direct solver's [`ContactSolution`] form, with gaps and equilibrium residual from the
//! same [`DirectContact`] functions, so that contact results, stresses and criteria stay shared
//! between the two solvers.
//!
//! Depends on [`super::options`], [`super::successive`] (the solve), [`super::partition`] and
//! the input types of [`super`], and on [`crate::contact`], [`crate::fem`], [`crate::mesh`] and
//! [`crate::scene`]; only the state layer depends on it.

use std::collections::HashMap;

use super::options::{
    CoarseKind, DdOptions, OuterIteration, Pcg1Preconditioner, Weights, PCG1_TOL,
};
use super::partition::CONTACT_LAYERS;
use super::successive::{solve, DdSolution, Fallback};
use super::{DdContactPair, DdContactRow, DdError, DdProblem, Partition, PartitionRequest};
use crate::contact::coulomb;
use crate::contact::direct::{ContactSolution, DirectContact};
use crate::contact::pairs::{normal_row, tangential_row, ContactGeometry};
use crate::contact::LoadCase;
use crate::fem::ElasticProblem;
use crate::mesh::geom::point_in_ring;
use crate::mesh::Mesh;
use crate::scene::{Data, DdCoarse, DdIteration, DdPcg1, DdWeights, Scene};

/// Elements per subdomain when the scene asks for an automatic count (`subdomains: 0`): about
/// the paper's tunnel (9676 elements on 12 subdomains).
const AUTO_ELEMENTS: usize = 800;

/// Fewest elements per requested subdomain: a larger `subdomains` count is capped (subdomains of
/// a few elements make nearly dependent coarse directions and gain nothing).
const MIN_ELEMENTS: usize = 16;

/// Tightest relative PCG residual asked for: below it rounding stalls PCG on the bundled scenes
/// (hertz: 4.6e-10 after 500 iterations).
const PCG_FLOOR: f64 = 1e-9;

/// DD options of a scene: `partition` polygons fix the subdomains (`explicit_partition`),
/// otherwise `subdomains` is the total count (0: about `AUTO_ELEMENTS` elements per
/// subdomain; at most one per `MIN_ELEMENTS` elements); `dd` selects the variants (the papers'
/// printed PCG1, kernel coarse space, plain iteration, mean-Young weights, the tied set Γc0 by
/// zone names, validated by the scene); `tolerance` is the relative stopping tolerance of the successive approximations
/// (the PCG2 tolerance is kept tighter so that it does not limit it; PCG1 only gives the start
/// U⁰).
pub fn options(scene: &Scene, mesh: &Mesh) -> DdOptions {
    let settings = &scene.solver;
    let layers = CONTACT_LAYERS;
    let partition = match settings.subdomains {
        _ if !settings.partition.is_empty() => {
            PartitionRequest::Explicit(explicit_partition(&settings.partition, mesh))
        }
        0 => PartitionRequest::BySize {
            elements: AUTO_ELEMENTS,
            contact_layers: layers,
        },
        n => PartitionRequest::Automatic {
            subdomains: n.min(mesh.triangles.len() / MIN_ELEMENTS).max(1),
            contact_layers: layers,
        },
    };
    let tol = settings.tolerance;
    let dd = &settings.dd;
    DdOptions {
        partition,
        pcg1_preconditioner: match dd.pcg1 {
            DdPcg1::Reduced => Pcg1Preconditioner::Reduced,
            DdPcg1::Printed => Pcg1Preconditioner::Full,
        },
        coarse: match dd.coarse {
            DdCoarse::Rigid => CoarseKind::Rigid,
            DdCoarse::Kernels => CoarseKind::Kernels,
        },
        iteration: match dd.iteration {
            DdIteration::Safeguarded => OuterIteration::Safeguarded,
            DdIteration::Plain => OuterIteration::Plain,
        },
        weights: match dd.weights {
            DdWeights::Stiffness => Weights::Stiffness,
            DdWeights::MeanYoung => Weights::MeanYoung,
        },
        tied_zones: dd.tied_zones.as_ref().map(|names| {
            names
                .iter()
                .filter_map(|n| scene.contacts.iter().position(|c| c.name == *n))
                .collect()
        }),
        outer_tol: tol,
        pcg1_tol: PCG1_TOL.max(tol * 1e-1),
        pcg2_tol: (tol * 1e-1).max(PCG_FLOOR),
        ..DdOptions::default()
    }
}

/// The subdomain of every triangle for the scene's partition polygons: the first polygon that
/// contains the centroid, per body; triangles in no polygon form one subdomain per body.
/// Subdomains are numbered in order of first appearance.
pub fn explicit_partition(polygons: &[Vec<[f64; 2]>], mesh: &Mesh) -> Vec<usize> {
    let mut ids: HashMap<(usize, usize), usize> = HashMap::new();
    mesh.triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            let body = mesh.zones[mesh.triangle_zone[t]].body;
            let c = tri.iter().fold([0.0, 0.0], |c, &n| {
                [c[0] + mesh.nodes[n][0] / 3.0, c[1] + mesh.nodes[n][1] / 3.0]
            });
            let region = polygons
                .iter()
                .position(|p| point_in_ring(c, p))
                .unwrap_or(polygons.len());
            let next = ids.len();
            *ids.entry((region, body)).or_insert(next)
        })
        .collect()
}

/// The contact rows of the direct solver's geometry (same normals, tangents, weights, gaps and
/// multiplier bounds `lower`, `upper`, so that DD and direct solve the same discrete problem):
/// normal rows B_n u ≤ g0 − B_{n,d} u_d, tangential rows g w |B_t u + B_{t,d} u_d|. A pair is
/// tied in the auxiliary problem when its zone is in `tied_zones` (`None`: every zone) or it is
/// bilateral.
pub fn contact_pairs(
    geometry: &ContactGeometry,
    lower: &[f64],
    upper: &[f64],
    fixed: &[f64],
    tied_zones: Option<&[usize]>,
) -> Vec<DdContactPair> {
    geometry
        .pairs
        .iter()
        .enumerate()
        .map(|(m, p)| {
            let row = |r: usize, gap: f64| DdContactRow {
                entries: geometry.rows[r].free.clone(),
                value: gap - geometry.rows[r].dot_fixed(fixed),
                lower: lower[r],
                upper: upper[r],
            };
            DdContactPair {
                nodes: p.terms().map(|(node, _)| node).collect(),
                normal: row(normal_row(m), p.gap),
                tangent: row(tangential_row(m), 0.0),
                tied: tied_zones.is_none_or(|z| z.contains(&p.zone))
                    || lower[normal_row(m)] == f64::NEG_INFINITY,
            }
        })
        .collect()
}

/// The partition of `options` for the scene's mesh and contact pairs (it does not depend on the
/// data; built once per scene and passed on as [`PartitionRequest::Given`]).
pub fn partition(
    elastic: &ElasticProblem,
    direct: &DirectContact,
    data: &Data,
    options: &DdOptions,
) -> Result<Partition, DdError> {
    let coefficients = elastic.coefficients(data)?;
    let fixed = elastic.fixed_values(data)?;
    let (lower, upper) = direct.geometry.bounds(data, None);
    let pairs = contact_pairs(
        &direct.geometry,
        &lower,
        &upper,
        &fixed,
        options.tied_zones.as_deref(),
    );
    let rhs = vec![0.0; elastic.dofs().n_free()];
    let problem = DdProblem::from_elastic(elastic, &coefficients, rhs, pairs)?;
    Partition::new(&problem, &options.partition)
}

/// The relative accuracy of a DD step's contact multipliers, as a multiple of its outer
/// tolerance: the multipliers are reactions of stiff subdomains, so the interface error is
/// amplified by the stiffness contrast (measured on the MCS 2007 knee, contrast 600: the
/// successive Coulomb steps agree to 1e-8–5e-8 at a tolerance of 1e-10 and stop changing there).
/// This is the rounding level of the Coulomb fixed point over DD steps (design §3.4).
const MULTIPLIER_NOISE: f64 = 1e4;

/// Solve the elastic contact problem (zone coefficients, reduced right-hand side, prescribed
/// values) by DD on the contact rows of `direct`; `fallback` is the direct solver, used only when
/// DD fails (and reported). Undetermined rigid motions get the direct solver's normal form.
/// On Coulomb zones the DD solves the successive Tresca problems of `coulomb::solve`, each
/// from the subdomain operators of the first; there the fallback (a whole Coulomb solve) is not
/// a Tresca step, so a failing step ends the DD solve and the caller answers directly.
pub fn solve_elastic(
    elastic: &ElasticProblem,
    direct: &DirectContact,
    case: LoadCase,
    options: &DdOptions,
    fallback: Option<Fallback>,
) -> Result<(ContactSolution, DdSolution), DdError> {
    let LoadCase {
        data,
        coefficients,
        rhs,
        fixed,
    } = case;
    let geometry = &direct.geometry;
    let fallback = if data.has_coulomb() { None } else { fallback };
    // Each step's solution with its multipliers flattened as the direct solver's.
    let tresca = |lower: &[f64], upper: &[f64], _: Option<&(DdSolution, Vec<f64>)>| {
        let pairs = contact_pairs(geometry, lower, upper, fixed, options.tied_zones.as_deref());
        let problem = DdProblem::from_elastic(elastic, coefficients, rhs.to_vec(), pairs)?;
        let sol = solve(&problem, options, fallback)?;
        let flat = sol.multipliers.iter().flatten().copied().collect();
        Ok((sol, flat))
    };
    let ((mut sol, multipliers), coulomb_report) = coulomb::solve(
        geometry,
        data,
        direct.coulomb_anderson_depth,
        tresca,
        |s| s.1.as_slice(),
        |_| coulomb::TOLERANCE.max(MULTIPLIER_NOISE * options.outer_tol),
        |reason| DdError::Diverged { reason },
    )?;
    let free_motions = direct
        .normalise_free_motions(&mut sol.u, data, &multipliers)
        .map_err(|e| DdError::Input(e.to_string()))?;
    let values = elastic.operator().assemble(coefficients)?;
    let equilibrium_residual =
        direct.equilibrium_residual(elastic, &values, &sol.u, &multipliers, rhs);
    let contact = ContactSolution {
        equilibrium_residual,
        gaps: direct.gaps(&sol.u, fixed),
        u_free: sol.u.clone(),
        multipliers,
        rigid: Vec::new(),
        qp: None,
        free_motions,
        qp_seconds: 0.0,
        refinements: 0,
        coulomb: coulomb_report,
        sparse: None,
    };
    Ok((contact, sol))
}
