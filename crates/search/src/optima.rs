//! Reports on the extremum (design §4.2 "report when several maximisers are found", §4.3 item 1):
//! distinct near-optimal points (clusters farther apart than 0.1 in the unit box), whether a
//! vertex attains the optimum, and the basin tops of the sample (nearest-better clustering) that
//! the driver polishes so that a second maximiser, or a better basin, is not missed. All work on the run's feasible points ranked best first, with
//! scores oriented so that larger is better.

use super::space::{distance, is_vertex};

/// Relative tolerance for "reaches the optimum".
pub(super) const OPTIMUM_TOL: f64 = 1e-9;
/// Unit-box distance beyond which two points belong to different optima.
pub(super) const SEPARATION: f64 = 0.1;
/// Nearest-better clustering: a basin top is this many times farther from its nearest better
/// point than the average point.
const NEAREST_BETTER_FACTOR: f64 = 2.0;
/// Nearest-better clustering looks at this many of the best points (it costs the square).
const NBC_POOL: usize = 200;

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

/// Basin tops of the sample by nearest-better clustering among the `NBC_POOL` best points: the
/// best point, then every point whose nearest better point is farther than
/// `NEAREST_BETTER_FACTOR` times the mean such distance and farther than its k + 1 nearest
/// neighbours (k = dimension, so the sample shows it surrounded by worse points), if its score
/// is at least `min_score`; best first, at most `max`.
pub(super) fn basin_tops(ranked: &[(Vec<f64>, f64)], min_score: f64, max: usize) -> Vec<Vec<f64>> {
    let pool = &ranked[..ranked.len().min(NBC_POOL)];
    let distances: Vec<Vec<f64>> = pool
        .iter()
        .map(|(x, _)| pool.iter().map(|(y, _)| distance(x, y)).collect())
        .collect();
    let nearest_better: Vec<f64> = distances
        .iter()
        .enumerate()
        .map(|(i, d)| d[..i].iter().copied().fold(f64::INFINITY, f64::min))
        .collect();
    let finite = &nearest_better[pool.len().min(1)..];
    let mean = finite.iter().sum::<f64>() / finite.len().max(1) as f64;
    let neighbours = pool.first().map_or(0, |(x, _)| x.len()) + 1;
    let surrounded = |i: usize| {
        let mut d = distances[i].clone();
        d.sort_by(f64::total_cmp);
        // d[0] = 0 is the point itself.
        nearest_better[i] > d.get(neighbours).copied().unwrap_or(0.0)
    };
    pool.iter()
        .enumerate()
        .take_while(|(_, (_, score))| *score >= min_score)
        .filter(|&(i, _)| nearest_better[i] > NEAREST_BETTER_FACTOR * mean && surrounded(i))
        .map(|(_, (x, _))| x.clone())
        .take(max)
        .collect()
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
        // Nearest-better distances: ∞, 0.4, 0.01, ≈0.76 (mean of the finite ones ≈ 0.39).
        assert_eq!(basin_tops(&ranked, f64::MIN, 9), vec![vec![0.3, 0.5]]);
        assert!(basin_tops(&[], f64::MIN, 9).is_empty());
        assert!(vertex_optimal(&ranked[3..]));
        assert!(representatives(&[], 1.0, 3).is_empty());
        // Two hills sampled on a grid: their tops, best first; a lone low point is no top.
        let hill = |x: f64, y: f64| {
            (-((x - 0.2f64).powi(2) + y * y) * 20.0).exp()
                + 0.9 * (-((x - 0.8f64).powi(2) + y * y) * 20.0).exp()
        };
        let mut grid: Vec<(Vec<f64>, f64)> = (0..=10)
            .flat_map(|i| (0..=4).map(move |j| (i as f64 / 10.0, j as f64 / 10.0)))
            .map(|(x, y)| (vec![x, y], hill(x, y)))
            .collect();
        grid.sort_by(|a, b| b.1.total_cmp(&a.1));
        let tops = basin_tops(&grid, f64::MIN, 9);
        assert_eq!(tops, vec![vec![0.2, 0.0], vec![0.8, 0.0]]);
        assert_eq!(basin_tops(&grid, 0.95, 9), vec![vec![0.2, 0.0]]);
        assert_eq!(basin_tops(&grid, f64::MIN, 1), vec![vec![0.2, 0.0]]);
        // Negative scores (a minimum of a positive criterion): relative to |best|.
        let neg = vec![(vec![0.0], -1.0), (vec![1.0], -1.0 - 1e-10)];
        assert_eq!(representatives(&neg, OPTIMUM_TOL, 9).len(), 2);
    }
}
