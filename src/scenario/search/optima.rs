//! Reports on the extremum (SPEC §4.2 "report when several maximisers are found", §4.3 item 1):
//! distinct near-optimal points (clusters farther apart than 0.1 in the unit box), and whether a
//! vertex attains the optimum. Both work on the run's feasible points ranked best first, with
//! scores oriented so that larger is better.

use super::space::{distance, is_vertex};

/// Relative tolerance for "reaches the optimum".
pub(super) const OPTIMUM_TOL: f64 = 1e-9;
/// Unit-box distance beyond which two points belong to different optima.
const SEPARATION: f64 = 0.1;

fn near(score: f64, best: f64, rel_tol: f64) -> bool {
    best - score <= rel_tol * best.abs()
}

/// Representatives of the distinct clusters of points within `rel_tol` (relative) of the best
/// score, the best point first, at most `max` of them. `ranked` is sorted best first.
pub(super) fn representatives(
    ranked: &[(Vec<f64>, f64)],
    rel_tol: f64,
    max: usize,
) -> Vec<Vec<f64>> {
    let Some((_, best)) = ranked.first() else {
        return Vec::new();
    };
    let mut reps: Vec<Vec<f64>> = Vec::new();
    for (x, _) in ranked.iter().take_while(|(_, s)| near(*s, *best, rel_tol)) {
        if reps.len() == max {
            break;
        }
        if reps.iter().all(|r| distance(r, x) > SEPARATION) {
            reps.push(x.clone());
        }
    }
    reps
}

/// Some evaluated vertex of the box reaches the best score within `OPTIMUM_TOL`.
pub(super) fn vertex_optimal(ranked: &[(Vec<f64>, f64)]) -> bool {
    let Some((_, best)) = ranked.first() else {
        return false;
    };
    ranked
        .iter()
        .take_while(|(_, s)| near(*s, *best, OPTIMUM_TOL))
        .any(|(x, _)| is_vertex(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clusters_and_vertices() {
        let ranked = vec![
            (vec![0.3, 0.5], 2.0),
            (vec![0.7, 0.5], 2.0 - 1e-12),
            (vec![0.31, 0.5], 2.0 - 1e-10),
            (vec![1.0, 0.0], 2.0 - 1e-3),
        ];
        assert_eq!(
            representatives(&ranked, OPTIMUM_TOL, usize::MAX),
            vec![vec![0.3, 0.5], vec![0.7, 0.5]]
        );
        assert_eq!(representatives(&ranked, 1e-2, 2).len(), 2);
        assert_eq!(representatives(&ranked, 1e-2, 3).len(), 3);
        assert!(!vertex_optimal(&ranked));
        assert!(vertex_optimal(&ranked[3..]));
        assert!(representatives(&[], 1.0, 3).is_empty());
        // Negative scores (a minimum of a positive criterion): relative to |best|.
        let neg = vec![(vec![0.0], -1.0), (vec![1.0], -1.0 - 1e-10)];
        assert_eq!(representatives(&neg, OPTIMUM_TOL, 9).len(), 2);
    }
}
