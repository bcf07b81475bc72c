//! Planar primitives shared by the scene's validation and the mesher (`mesh::geom` re-exports
//! them): difference and cross product of points, the orientation of three points and twice the
//! signed area of a ring. Floating-point, not exact: the mesher's triangulation uses its own exact
//! predicate (`mesh::tri::orient`).

use super::model::Point;

/// a − b.
pub fn sub(a: Point, b: Point) -> Point {
    [a[0] - b[0], a[1] - b[1]]
}

/// The cross product a × b = a_x b_y − a_y b_x.
pub fn cross(a: Point, b: Point) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Twice the signed area of triangle (a, b, c): positive when counter-clockwise.
pub fn orient(a: Point, b: Point, c: Point) -> f64 {
    cross(sub(b, a), sub(c, a))
}

/// Twice the signed area of a closed ring (the last point connects to the first): positive when
/// counter-clockwise.
pub fn signed_area2(ring: &[Point]) -> f64 {
    let n = ring.len();
    (0..n).map(|i| cross(ring[i], ring[(i + 1) % n])).sum()
}
