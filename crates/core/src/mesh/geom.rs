//! Small planar geometry helpers shared by the mesher, the Gmsh import and the criteria weights:
//! polygon areas and point location, point–segment and segment–segment distances, and arc-length
//! projection onto polylines. The difference, cross product and orientation of points are the
//! scene's (`scene::planar`), shared with its validation.

/// A point `[x, y]`.
pub(crate) type P = [f64; 2];

use crate::scene::signed_area2;
pub(crate) use crate::scene::{cross, orient, sub};

pub(crate) fn dot(a: P, b: P) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

pub(crate) fn dist(a: P, b: P) -> f64 {
    let d = sub(a, b);
    d[0].hypot(d[1])
}

pub(crate) fn lerp(a: P, b: P, t: f64) -> P {
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

/// Signed area of a closed ring (the last point connects to the first); positive when CCW.
pub(crate) fn signed_area(ring: &[P]) -> f64 {
    signed_area2(ring) * 0.5
}

/// Signed area and first moments (∫x, ∫y) of a closed ring by a fan of signed triangles; exact
/// for non-convex and degenerate rings. Positive area when CCW.
pub(crate) fn ring_moments(ring: &[P]) -> (f64, P) {
    let (mut a, mut mx, mut my) = (0.0, 0.0, 0.0);
    for i in 1..ring.len().saturating_sub(1) {
        let t = 0.5 * orient(ring[0], ring[i], ring[i + 1]);
        a += t;
        mx += t * (ring[0][0] + ring[i][0] + ring[i + 1][0]) / 3.0;
        my += t * (ring[0][1] + ring[i][1] + ring[i + 1][1]) / 3.0;
    }
    (a, [mx, my])
}

/// Whether `p` lies inside the closed ring (crossing-number rule; boundary points are undefined).
pub(crate) fn point_in_ring(p: P, ring: &[P]) -> bool {
    let n = ring.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Distance from `p` to segment [a, b] and the parameter t ∈ [0, 1] of the closest point.
pub(crate) fn point_segment(p: P, a: P, b: P) -> (f64, f64) {
    let d = sub(b, a);
    let l2 = dot(d, d);
    let t = if l2 > 0.0 {
        (dot(sub(p, a), d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (dist(p, lerp(a, b, t)), t)
}

/// Whether segments [a, b] and [c, d] cross transversally at a point interior to both, by more
/// than `tol` on each side (touching, collinear overlap and T-junctions do not count).
pub(crate) fn cross_properly(a: P, b: P, c: P, d: P, tol: f64) -> bool {
    let side = |p: P, q: P, r: P| orient(p, q, r) / dist(p, q).max(f64::MIN_POSITIVE);
    let (s1, s2) = (side(a, b, c), side(a, b, d));
    let (s3, s4) = (side(c, d, a), side(c, d, b));
    ((s1 > tol && s2 < -tol) || (s1 < -tol && s2 > tol))
        && ((s3 > tol && s4 < -tol) || (s3 < -tol && s4 > tol))
}

/// Distance between segments [a, b] and [c, d] (0 when they cross).
pub(crate) fn segment_segment(a: P, b: P, c: P, d: P) -> f64 {
    let (o1, o2) = (orient(a, b, c), orient(a, b, d));
    let (o3, o4) = (orient(c, d, a), orient(c, d, b));
    if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
        return 0.0;
    }
    point_segment(a, c, d)
        .0
        .min(point_segment(b, c, d).0)
        .min(point_segment(c, a, b).0)
        .min(point_segment(d, a, b).0)
}

/// Distance from `p` to a closed ring's boundary.
pub(crate) fn ring_distance(p: P, ring: &[P]) -> f64 {
    let n = ring.len();
    (0..n)
        .map(|i| point_segment(p, ring[i], ring[(i + 1) % n]).0)
        .fold(f64::INFINITY, f64::min)
}

/// A polyline with cumulative arc length, for projections.
#[derive(Debug, Clone)]
pub(crate) struct Polyline {
    pub pts: Vec<P>,
    cum: Vec<f64>,
}

impl Polyline {
    pub fn new(pts: Vec<P>) -> Polyline {
        let mut cum = vec![0.0; pts.len()];
        for i in 1..pts.len() {
            cum[i] = cum[i - 1] + dist(pts[i - 1], pts[i]);
        }
        Polyline { pts, cum }
    }

    pub fn length(&self) -> f64 {
        self.cum.last().copied().unwrap_or(0.0)
    }

    /// Distance from `p` to the polyline and the arc length of the closest point (the first
    /// piece wins ties).
    pub fn project(&self, p: P) -> (f64, f64) {
        let mut best = (f64::INFINITY, 0.0);
        for i in 1..self.pts.len() {
            let (d, t) = point_segment(p, self.pts[i - 1], self.pts[i]);
            if d < best.0 {
                best = (d, self.cum[i - 1] + t * (self.cum[i] - self.cum[i - 1]));
            }
        }
        if self.pts.len() == 1 {
            best = (dist(p, self.pts[0]), 0.0);
        }
        best
    }
}

/// Axis-aligned bounding box `[xmin, ymin, xmax, ymax]` of points.
pub(crate) fn bbox(pts: impl IntoIterator<Item = P>) -> [f64; 4] {
    pts.into_iter().fold(
        [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ],
        |b, p| {
            [
                b[0].min(p[0]),
                b[1].min(p[1]),
                b[2].max(p[0]),
                b[3].max(p[1]),
            ]
        },
    )
}

/// Calls `f(i, j)` (i < j in input order) for every pair of boxes that overlap after growing by
/// `tol`, by a sweep over the x axis; stops at the first error.
pub(crate) fn overlapping_pairs<E>(
    boxes: &[[f64; 4]],
    tol: f64,
    mut f: impl FnMut(usize, usize) -> Result<(), E>,
) -> Result<(), E> {
    let mut order: Vec<usize> = (0..boxes.len()).collect();
    order.sort_by(|&i, &j| boxes[i][0].total_cmp(&boxes[j][0]).then(i.cmp(&j)));
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if boxes[j][0] > boxes[i][2] + tol {
                break;
            }
            if boxes[j][1] <= boxes[i][3] + tol && boxes[i][1] <= boxes[j][3] + tol {
                f(i.min(j), i.max(j))?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_area_centroid_and_location() {
        let sq = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]];
        assert_eq!(signed_area(&sq), 2.0);
        assert_eq!(ring_moments(&sq), (2.0, [2.0, 1.0]));
        assert!(point_in_ring([1.0, 0.5], &sq));
        assert!(!point_in_ring([2.5, 0.5], &sq));
        assert_eq!(ring_distance([3.0, 0.5], &sq), 1.0);
    }

    #[test]
    fn segment_predicates() {
        let (a, b, c, d) = ([0.0, 0.0], [2.0, 0.0], [1.0, -1.0], [1.0, 1.0]);
        assert!(cross_properly(a, b, c, d, 1e-12));
        assert!(!cross_properly(a, b, [1.0, 0.0], d, 1e-12));
        assert_eq!(segment_segment(a, b, c, d), 0.0);
        assert_eq!(segment_segment(a, b, [0.0, 1.0], [2.0, 1.0]), 1.0);
        let pl = Polyline::new(vec![a, b, [2.0, 2.0]]);
        assert_eq!(pl.length(), 4.0);
        assert_eq!(pl.project([2.5, 1.0]), (0.5, 3.0));
    }
}
