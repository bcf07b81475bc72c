//! The target element size h(x) of the mesher: the global `mesh.max_size`, lowered near the
//! `mesh.refine` entries (along named segments, inside polygons) and growing linearly with the
//! distance from them, so that the mesh grades smoothly from fine to coarse.

use super::geom::{dist, lerp, point_in_ring, point_segment, ring_distance, signed_area, P};
use crate::scene::{Scene, SceneError};

/// Growth of h per unit distance away from a refinement source.
const GRADING: f64 = 0.3;

/// Refuse meshes estimated to exceed this many triangles.
pub(crate) const MAX_TRIANGLES: f64 = 5.0e6;

/// Mean triangle area of a Delaunay-refined mesh of edge bound h, as a multiple of h².
const AREA_PER_H2: f64 = 0.25;

enum Shape {
    Lines(Vec<Vec<P>>),
    Area(Vec<P>),
}

struct Source {
    size: f64,
    shape: Shape,
    /// JSON path of the source's `max_size`.
    path: String,
}

/// The size field.
pub(crate) struct SizeField {
    global: f64,
    sources: Vec<Source>,
}

fn positive(x: f64, path: &str) -> Result<f64, SceneError> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(SceneError::new(path, "must be a positive number of metres"))
    }
}

impl SizeField {
    /// Reads and checks `mesh.max_size` and `mesh.refine`.
    pub fn from_scene(scene: &Scene) -> Result<SizeField, SceneError> {
        let global = positive(scene.mesh.built_in_max_size()?, "mesh.max_size")?;
        let mut sources = Vec::new();
        for (i, r) in scene.mesh.refine.iter().enumerate() {
            let path = format!("mesh.refine[{i}]");
            let size = positive(r.max_size, &format!("{path}.max_size"))?;
            if r.segments.is_empty() && r.polygon.is_none() {
                return Err(SceneError::new(path, "give `segments` or `polygon`"));
            }
            let mut lines = Vec::new();
            for (j, name) in r.segments.iter().enumerate() {
                let line = scene
                    .segments
                    .get(name)
                    .map(|s| s.polyline())
                    .ok_or_else(|| {
                        SceneError::new(
                            format!("{path}.segments[{j}]"),
                            format!("unknown segment '{name}'"),
                        )
                    })?;
                if line.is_empty() {
                    return Err(SceneError::new(
                        format!("{path}.segments[{j}]"),
                        format!("segment '{name}' has no geometry (from/to or path)"),
                    ));
                }
                lines.push(line);
            }
            if !lines.is_empty() {
                sources.push(Source {
                    size,
                    shape: Shape::Lines(lines),
                    path: format!("{path}.max_size"),
                });
            }
            if let Some(poly) = &r.polygon {
                let ppath = format!("{path}.polygon");
                if poly.len() < 3 || poly.iter().flatten().any(|c| !c.is_finite()) {
                    return Err(SceneError::new(ppath, "needs at least 3 finite points"));
                }
                if signed_area(poly) == 0.0 {
                    return Err(SceneError::new(ppath, "has zero area"));
                }
                sources.push(Source {
                    size,
                    shape: Shape::Area(poly.clone()),
                    path: format!("{path}.max_size"),
                });
            }
        }
        Ok(SizeField { global, sources })
    }

    /// A uniform field (tests, Gmsh-free helpers).
    #[cfg(test)]
    pub fn uniform(h: f64) -> SizeField {
        SizeField {
            global: h,
            sources: Vec::new(),
        }
    }

    /// h(p).
    pub fn at(&self, p: P) -> f64 {
        self.at_with_source(p).0
    }

    /// h(p) and the source that sets it (index in [`Self::source_paths`]; None: the global
    /// size).
    pub fn at_with_source(&self, p: P) -> (f64, Option<usize>) {
        self.sources
            .iter()
            .enumerate()
            .fold((self.global, None), |(h, which), (i, s)| {
                let d = match &s.shape {
                    Shape::Area(ring) if point_in_ring(p, ring) => 0.0,
                    Shape::Area(ring) => ring_distance(p, ring),
                    Shape::Lines(lines) => lines
                        .iter()
                        .flat_map(|l| l.windows(2).map(|w| point_segment(p, w[0], w[1]).0))
                        .chain(lines.iter().filter(|l| l.len() == 1).map(|l| dist(p, l[0])))
                        .fold(f64::INFINITY, f64::min),
                };
                let local = s.size + GRADING * d;
                if local < h {
                    (local, Some(i))
                } else {
                    (h, which)
                }
            })
    }

    /// JSON paths of the refinement sources' `max_size`, in source order.
    pub fn source_paths(&self) -> impl Iterator<Item = &str> {
        self.sources.iter().map(|s| s.path.as_str())
    }

    /// Rough number of triangles for a domain of the given area; errors when it is too many,
    /// naming the size that causes it.
    pub fn check_budget(&self, domain_area: f64) -> Result<f64, SceneError> {
        let global = domain_area / (AREA_PER_H2 * self.global * self.global);
        let mut total = global;
        let mut worst = (global, "mesh.max_size");
        for s in &self.sources {
            let band = |len: f64| 2.0 * len / (AREA_PER_H2 * GRADING * s.size);
            let n = match &s.shape {
                Shape::Lines(lines) => lines
                    .iter()
                    .map(|l| band(l.windows(2).map(|w| dist(w[0], w[1])).sum()))
                    .sum(),
                Shape::Area(ring) => {
                    let n = ring.len();
                    let perimeter: f64 = (0..n).map(|i| dist(ring[i], ring[(i + 1) % n])).sum();
                    signed_area(ring).abs() / (AREA_PER_H2 * s.size * s.size) + band(perimeter)
                }
            };
            total += n;
            if n > worst.0 {
                worst = (n, s.path.as_str());
            }
        }
        if total > MAX_TRIANGLES {
            return Err(SceneError::new(
                worst.1,
                format!(
                    "too small for the domain: about {total:.2e} triangles estimated \
                     (limit {MAX_TRIANGLES:.0e})"
                ),
            ));
        }
        Ok(total)
    }

    /// Interior points splitting segment [a, b] into pieces no longer than h at either end,
    /// spaced evenly in the metric ds / h(s) (with more pieces where h grows fast).
    pub fn subdivide(&self, a: P, b: P) -> Vec<P> {
        let len = dist(a, b);
        if len == 0.0 {
            return Vec::new();
        }
        // Sample the metric m(s) = ∫ ds / h at steps of a quarter of the local size.
        let mut samples = vec![(0.0, 0.0)];
        let (mut s, mut m) = (0.0_f64, 0.0_f64);
        while s < len {
            let ds = (0.25 * self.at(lerp(a, b, s / len))).min(len - s);
            m += ds / self.at(lerp(a, b, (s + 0.5 * ds) / len));
            s += ds;
            samples.push((s, m));
        }
        let mut pieces = (m - 1e-9).ceil().max(1.0) as usize;
        loop {
            let pts = Self::split_metric(&samples, pieces, a, b, len);
            let fits = std::iter::once(a)
                .chain(pts.iter().copied())
                .zip(pts.iter().copied().chain(std::iter::once(b)))
                .all(|(p, q)| dist(p, q) <= self.at(p).min(self.at(q)) * (1.0 + 1e-9));
            if fits {
                return pts;
            }
            pieces += 1 + pieces / 8;
        }
    }

    /// Points at equal metric spacing for the sampled metric.
    fn split_metric(samples: &[(f64, f64)], pieces: usize, a: P, b: P, len: f64) -> Vec<P> {
        let m = samples.last().map_or(0.0, |s| s.1);
        let mut out = Vec::with_capacity(pieces.saturating_sub(1));
        let mut k = 1;
        for w in samples.windows(2) {
            let ((s0, m0), (s1, m1)) = (w[0], w[1]);
            while k < pieces && (k as f64) * m / (pieces as f64) <= m1 {
                let target = (k as f64) * m / (pieces as f64);
                let sk = s0 + (s1 - s0) * (target - m0) / (m1 - m0);
                out.push(lerp(a, b, sk / len));
                k += 1;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_subdivision_is_even() {
        let f = SizeField::uniform(0.25);
        let pts = f.subdivide([0.0, 0.0], [1.0, 0.0]);
        assert_eq!(pts.len(), 3);
        for (i, p) in pts.iter().enumerate() {
            assert!((p[0] - 0.25 * (i + 1) as f64).abs() < 1e-12);
        }
        assert!(f.subdivide([0.0, 0.0], [0.2, 0.0]).is_empty());
    }

    #[test]
    fn graded_subdivision_respects_local_size() {
        let f = SizeField {
            global: 0.2,
            sources: vec![Source {
                size: 0.01,
                shape: Shape::Lines(vec![vec![[0.0, 0.0], [0.0, 1.0]]]),
                path: String::new(),
            }],
        };
        let mut pts = vec![[0.0, 0.0]];
        pts.extend(f.subdivide([0.0, 0.0], [2.0, 0.0]));
        pts.push([2.0, 0.0]);
        for w in pts.windows(2) {
            let h = f.at(w[0]).min(f.at(w[1]));
            assert!(dist(w[0], w[1]) <= h, "{w:?} {h}");
        }
        assert!(dist(pts[0], pts[1]) < 0.0105);
        assert!(dist(pts[pts.len() - 2], pts[pts.len() - 1]) > 0.15);
    }
}
