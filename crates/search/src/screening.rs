//! Phase 1, screening (design §4.3 item 1), shared by all objectives: all 2^k vertices of the unit
//! box plus its centre when 2^k + 1 ≤ budget / 3 (the extremum of a monotone criterion is a
//! vertex), topped up (or, without vertices, made) by a scrambled Latin hypercube to about
//! budget / 5 points in all, so that the swarm is seeded from a space-filling sample.

use super::random::{uniform, Rng};

/// The screening design in the unit box of dimension `dim`, at most `cap` points.
pub(super) fn design(dim: usize, budget: usize, cap: usize, rng: &mut Rng) -> Vec<Vec<f64>> {
    if dim == 0 {
        return vec![Vec::new()];
    }
    let vertex_count = u32::try_from(dim).ok().and_then(|d| 1usize.checked_shl(d));
    let mut points = match vertex_count {
        // 2^k + 1 <= budget / 3, and the design fits under the cap.
        Some(v) if v < budget / 3 && v < cap => vertices_and_centre(dim, v),
        _ => Vec::new(),
    };
    let fill = (budget / 5)
        .clamp(1, cap.max(1))
        .saturating_sub(points.len());
    points.extend(latin_hypercube(dim, fill, rng));
    points
}

fn vertices_and_centre(dim: usize, count: usize) -> Vec<Vec<f64>> {
    let mut points: Vec<Vec<f64>> = (0..count)
        .map(|mask| (0..dim).map(|j| ((mask >> j) & 1) as f64).collect())
        .collect();
    points.push(vec![0.5; dim]);
    points
}

/// `size` points, one in each of `size` equal slabs along every axis, at a random place in its
/// cell; the slabs are matched across axes by independent random permutations.
pub(super) fn latin_hypercube(dim: usize, size: usize, rng: &mut Rng) -> Vec<Vec<f64>> {
    let mut points = vec![vec![0.0; dim]; size];
    for j in 0..dim {
        let mut slabs: Vec<usize> = (0..size).collect();
        for i in (1..size).rev() {
            let r = ((uniform(rng) * (i + 1) as f64) as usize).min(i);
            slabs.swap(i, r);
        }
        for (point, slab) in points.iter_mut().zip(slabs) {
            point[j] = (slab as f64 + uniform(rng)) / size as f64;
        }
    }
    points
}

#[cfg(test)]
mod tests {
    use super::super::random::stream;
    use super::*;

    #[test]
    fn vertices_when_cheap() {
        let d = design(3, 27, 27, &mut stream(0, 0));
        assert_eq!(d.len(), 9);
        // Topped up to 100 / 5 = 20 points.
        let d20 = design(3, 100, 100, &mut stream(0, 0));
        assert_eq!((d20.len(), &d20[..9]), (20, &d[..]));
        assert!(d.contains(&vec![1.0, 0.0, 1.0]));
        assert_eq!(d[8], vec![0.5; 3]);
        // 2^3 + 1 = 9 > 26 / 3: a Latin hypercube of 26 / 5 = 5 points instead.
        assert_eq!(design(3, 26, 26, &mut stream(0, 0)).len(), 5);
        assert_eq!(
            design(0, 100, 100, &mut stream(0, 0)),
            vec![Vec::<f64>::new()]
        );
        // Huge dimension: no overflow.
        assert_eq!(design(200, 1000, 1000, &mut stream(0, 0)).len(), 200);
    }

    #[test]
    fn latin_hypercube_fills_every_slab() {
        let d = design(4, 50, 50, &mut stream(3, 0));
        assert_eq!(d.len(), 10);
        for j in 0..4 {
            let mut slabs: Vec<usize> = d.iter().map(|p| (p[j] * 10.0) as usize).collect();
            slabs.sort();
            assert_eq!(slabs, (0..10).collect::<Vec<_>>());
        }
    }
}
