//! The vertex walk (design §4.3, "With exact derivatives"), run first when the evaluator gives
//! exact derivatives. Criteria of contact problems are very often monotone in each datum over
//! the box, and then the extremum is the vertex the gradient's signs point to — and the signs at
//! that vertex prove it locally ([`certificate`](super::certificate)). The walk evaluates the
//! centre, then for every objective the vertex its mean unit slopes point to (all objectives'
//! vertices in one batch), and while an objective's vertex is not certified, flips the bounds
//! the derivative there disproves (a few rounds, each batch shared by the objectives still
//! walking). A certified end is a first local optimum; whether another is better is the global
//! phase's question (`global`).

use super::certificate::{self, scale, CERTIFY_TOL};
use super::session::Session;
use super::{Phase, Verdict};

/// Rounds of bound flips after the first vertex.
const MAX_FLIPS: usize = 4;

/// One objective's walk.
struct Walk {
    /// Current vertex (unit box).
    vertex: Vec<f64>,
    /// Score of the previous point of the walk.
    score: f64,
    /// Still walking.
    active: bool,
}

/// Walk every objective. Never fails: a refused batch (budget or halt) ends the walk with what
/// it has proven so far.
pub(super) fn run(session: &Session) {
    session.set_phase(Phase::VertexWalk);
    let m = session.objectives().len();
    let dim = session.space.dim();
    let Ok(centre) = session.indices(&[vec![0.5; dim]]) else {
        return;
    };
    let mut walks: Vec<Walk> = (0..m)
        .map(|k| {
            let mut walk = Walk {
                vertex: Vec::new(),
                score: f64::NEG_INFINITY,
                active: false,
            };
            let sense = session.objectives()[k].sense;
            if let Some(probe) = session.probe(k, centre[0]) {
                if let Some(slopes) = &probe.slopes {
                    let s = certificate::unit_slopes(session.space, sense, slopes);
                    walk.vertex = s
                        .iter()
                        .map(|s| if s.mean() > 0.0 { 1.0 } else { 0.0 })
                        .collect();
                    walk.score = sense.score(probe.value);
                    walk.active = true;
                }
            }
            walk
        })
        .collect();
    for _ in 0..=MAX_FLIPS {
        let walking: Vec<usize> = (0..m).filter(|&k| walks[k].active).collect();
        if walking.is_empty() {
            break;
        }
        let batch: Vec<Vec<f64>> = walking.iter().map(|&k| walks[k].vertex.clone()).collect();
        let Ok(indices) = session.indices(&batch) else {
            break;
        };
        for (&k, &index) in walking.iter().zip(&indices) {
            step(session, k, index, &mut walks[k]);
        }
    }
}

/// Judge objective `k` at its vertex (trace point `index`): stop it (certified, or no better
/// than the previous point), or flip the bounds its derivative disproves.
fn step(session: &Session, k: usize, index: usize, walk: &mut Walk) {
    walk.active = false;
    let sense = session.objectives()[k].sense;
    let Some(probe) = session.probe(k, index) else {
        return;
    };
    let Some(slopes) = &probe.slopes else {
        return;
    };
    let score = sense.score(probe.value);
    let s = certificate::unit_slopes(session.space, sense, slopes);
    if score < walk.score {
        return;
    }
    walk.score = score;
    let proof = certificate::certify(session.space, sense, &probe.unit, probe.value, Some(slopes));
    if proof.verdict == Verdict::LocallyCertified {
        session.note_end(k, probe.unit.clone());
        return;
    }
    let tol = CERTIFY_TOL * scale(probe.value);
    for (u, d) in walk
        .vertex
        .iter_mut()
        .zip(certificate::ascent_direction(&probe.unit, &s))
    {
        if d.abs() > tol {
            *u = 1.0 - *u;
        }
    }
    walk.active = true;
}
