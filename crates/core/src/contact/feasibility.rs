//! Primal feasibility of the contact constraints with the prescribed displacements (design
//! §3.1): can the bodies be placed without overlap at all?
//!
//! The discrete constraints are `(B u)_{n,m} ≤ g0_m` on every unilateral node pair and
//! `= g0_m` on every bilateral one, over the displacements with `u = u_D` on Γu. The free DOFs
//! are unrestricted, so a row with a free part can always be met on its own. A row without one
//! — a **pinned pair**, both nodes' normal motion prescribed, like the end of a fault on the
//! two bodies' fixed bottoms — is a condition on the data alone:
//!
//! ```text
//!     r_m = n_m · (u_D^k − u_D^l) − g0_m ≤ 0      (= 0 for a bilateral pair).
//! ```
//!
//! It is decided exactly here, from the DOF map's constraint sources, before any factorisation.
//! (Rows that share free DOFs could still contradict each other in combination, a Farkas vector
//! y with Bᵀy = 0; such a conflict reaches the dual QP as a ray of unboundedness, which the QP
//! solver reports as [`super::qp::QpError::Unbounded`] within one progress window.)
//!
//! `r_m` is affine in the prescribed displacement values, `r_m = Σ_s a_ms v_s − g0_m`, so on a
//! box of uncertain displacements its largest value is taken at the vertex that puts every `v_s`
//! at the end matching the sign of `a_ms`: [`Feasibility::check_box`] decides the whole
//! admissible set without enumerating vertices, and suggests the largest feasible interval.

use super::pairs::{normal_row, ContactGeometry};
use crate::fem::DofMap;
use crate::mesh::Mesh;
use crate::scene::{BoundaryValue, Data, Scene, SceneError};

/// Overlap (relative to the largest prescribed value of the pair) still read as rounding.
const OVERLAP_TOL: f64 = 1e-12;

/// A displacement component `boundary[bc].displacement[comp]`.
type Source = (usize, usize);

/// A contact pair whose normal row has no free DOF, with `∂r/∂v_s` for its sources.
#[derive(Debug, Clone)]
struct PinnedPair {
    /// Index into [`ContactGeometry::pairs`].
    pair: usize,
    /// `(source, a_s)`, sources in first-seen order.
    sources: Vec<(Source, f64)>,
}

impl PinnedPair {
    /// `a_s = ∂r/∂v_s` of a displacement component (0 when it does not fix this pair).
    fn slope(&self, source: Source) -> f64 {
        self.sources
            .iter()
            .find(|(s, _)| *s == source)
            .map_or(0.0, |&(_, a)| a)
    }

    /// The uncertain datum that moves `r` most over its interval, `|a_s| (hi − lo)`.
    fn most_influential<'u, 'a>(
        &self,
        moved: &[&'u UncertainDisplacement<'a>],
    ) -> Option<&'u UncertainDisplacement<'a>> {
        let influence = |u: &UncertainDisplacement<'_>| self.slope(u.source).abs() * (u.hi - u.lo);
        moved
            .iter()
            .copied()
            .max_by(|a, b| influence(a).total_cmp(&influence(b)))
    }
}

/// The pinned pairs of a scene (topology; the values are read from the data on each check).
#[derive(Debug, Clone, Default)]
pub struct Feasibility {
    pinned: Vec<PinnedPair>,
}

/// An interval of one uncertain displacement, for [`Feasibility::check_box`].
#[derive(Debug, Clone, Copy)]
pub struct UncertainDisplacement<'a> {
    /// Index of the entry in the scene's `uncertain` list.
    pub index: usize,
    /// Its display name.
    pub name: &'a str,
    /// The varied component `boundary[bc].displacement[comp]`.
    pub source: (usize, usize),
    /// Interval ends \[m\].
    pub lo: f64,
    /// Interval ends \[m\].
    pub hi: f64,
}

impl Feasibility {
    /// Find the pinned pairs of `geometry` (normal rows whose free coefficients vanish).
    pub fn new(geometry: &ContactGeometry, dofs: &DofMap) -> Feasibility {
        let pinned = geometry
            .pairs
            .iter()
            .enumerate()
            .filter(|&(m, _)| {
                let free: f64 = geometry.rows[normal_row(m)]
                    .free
                    .iter()
                    .map(|(_, c)| c.abs())
                    .sum();
                free <= 1e-12
            })
            .map(|(m, pair)| {
                let mut sources: Vec<(Source, f64)> = Vec::new();
                for (node, sign) in pair.terms() {
                    for (source, du) in dofs.prescribed_sources(node) {
                        let a = sign * (pair.normal[0] * du[0] + pair.normal[1] * du[1]);
                        match sources.iter_mut().find(|(s, _)| *s == source) {
                            Some((_, total)) => *total += a,
                            None => sources.push((source, a)),
                        }
                    }
                }
                PinnedPair { pair: m, sources }
            })
            .collect();
        Feasibility { pinned }
    }

    /// Refuse `data` when the prescribed displacements make two bodies overlap at a pinned pair
    /// (or pull a bilateral one apart), naming the zone, the node, the overlap and the field.
    pub fn check(
        &self,
        scene: &Scene,
        mesh: &Mesh,
        geometry: &ContactGeometry,
        data: &Data,
    ) -> Result<(), SceneError> {
        match self.violations(geometry, data).first() {
            None => Ok(()),
            Some(&(p, r)) => Err(self.explain(scene, mesh, geometry, data, p, r)),
        }
    }

    /// Refuse an admissible set in which some vertex of the uncertain displacements overlaps a
    /// pinned pair: the worst vertex of each pair in closed form (`r` is affine in the values).
    pub fn check_box(
        &self,
        scene: &Scene,
        mesh: &Mesh,
        geometry: &ContactGeometry,
        nominal: &Data,
        uncertain: &[UncertainDisplacement<'_>],
    ) -> Result<(), SceneError> {
        for (p, pinned) in self.pinned.iter().enumerate() {
            let slope = |u: &UncertainDisplacement<'_>| pinned.slope(u.source);
            // The vertex that maximises r (and, for a bilateral pair, the one that minimises it).
            let mut worst = nominal.clone();
            let mut best = nominal.clone();
            for u in uncertain {
                let a = slope(u);
                let (up, down) = if a >= 0.0 { (u.hi, u.lo) } else { (u.lo, u.hi) };
                set_value(&mut worst, u.source, up);
                set_value(&mut best, u.source, down);
            }
            let bilateral = geometry.pairs[pinned.pair].bilateral;
            for vertex in [&worst, &best] {
                let r = self.residual(pinned, geometry, vertex);
                if !self.violated(pinned, geometry, vertex, r) {
                    continue;
                }
                let moved: Vec<&UncertainDisplacement<'_>> =
                    uncertain.iter().filter(|u| slope(u) != 0.0).collect();
                let at: Vec<String> = moved
                    .iter()
                    .map(|u| format!("{} = {}", u.name, value(vertex, u.source)))
                    .collect();
                let cause = self.explain(scene, mesh, geometry, vertex, p, r);
                let culprit = pinned.most_influential(&moved);
                let path =
                    culprit.map_or(cause.path.clone(), |u| format!("uncertain[{}]", u.index));
                let suggestion = match culprit {
                    Some(u) if !bilateral => self.suggest(pinned, geometry, vertex, u),
                    _ => String::new(),
                };
                let vertex_text = if at.is_empty() {
                    String::new()
                } else {
                    format!("at the vertex ({}) ", at.join(", "))
                };
                return Err(SceneError::new(
                    path,
                    format!(
                        "the admissible set contains data without any admissible displacement: {vertex_text}{}{suggestion}",
                        cause.reason
                    ),
                ));
            }
        }
        Ok(())
    }

    /// `(pinned index, r)` of every violated pinned pair, largest violation first.
    fn violations(&self, geometry: &ContactGeometry, data: &Data) -> Vec<(usize, f64)> {
        let mut out: Vec<(usize, f64)> = self
            .pinned
            .iter()
            .enumerate()
            .map(|(p, pinned)| (p, self.residual(pinned, geometry, data)))
            .filter(|&(p, r)| self.violated(&self.pinned[p], geometry, data, r))
            .collect();
        out.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        out
    }

    /// `r = Σ a_s v_s − g0` of a pinned pair for the data.
    fn residual(&self, pinned: &PinnedPair, geometry: &ContactGeometry, data: &Data) -> f64 {
        let pushed: f64 = pinned
            .sources
            .iter()
            .map(|&(s, a)| a * value(data, s))
            .sum();
        pushed - geometry.pairs[pinned.pair].gap
    }

    /// Whether `r` exceeds rounding: any sign for a bilateral pair, overlap for a unilateral one.
    fn violated(
        &self,
        pinned: &PinnedPair,
        geometry: &ContactGeometry,
        data: &Data,
        r: f64,
    ) -> bool {
        let pair = &geometry.pairs[pinned.pair];
        let scale = pinned
            .sources
            .iter()
            .map(|&(s, _)| value(data, s).abs())
            .fold(pair.gap.abs(), f64::max);
        let tol = OVERLAP_TOL * scale;
        if pair.bilateral {
            r.abs() > tol
        } else {
            r > tol
        }
    }

    /// The message of a violated pinned pair: zone, node, overlap, the fields that fix the two
    /// nodes, and the value of the most contributing field that would close it.
    fn explain(
        &self,
        scene: &Scene,
        mesh: &Mesh,
        geometry: &ContactGeometry,
        data: &Data,
        p: usize,
        r: f64,
    ) -> SceneError {
        let pinned = &self.pinned[p];
        let pair = &geometry.pairs[pinned.pair];
        let contact = &scene.contacts[pair.zone];
        let [x, y] = mesh.nodes[pair.nodes[0]];
        let [nx, ny] = pair.normal;
        let what = if pair.bilateral && r < 0.0 {
            format!("pull the tied bodies apart by {:.3e} m", -r)
        } else {
            format!("make the bodies overlap by {r:.3e} m")
        };
        let fields: Vec<String> = distinct_conditions(&pinned.sources)
            .into_iter()
            .map(|bc| {
                let body = scene
                    .boundary
                    .get(bc)
                    .and_then(|b| scene.segments.get(&b.segment))
                    .map_or(String::new(), |s| format!(" ({})", s.body));
                format!("boundary[{bc}].displacement{body}")
            })
            .collect();
        // The field whose term pushes r furthest in its sign, and the value that makes r = 0.
        let culprit = pinned
            .sources
            .iter()
            .filter(|&&(_, a)| a != 0.0)
            .max_by(|a, b| {
                (r.signum() * a.1 * value(data, a.0))
                    .total_cmp(&(r.signum() * b.1 * value(data, b.0)))
            });
        let (path, fix) = match culprit {
            Some(&((bc, comp), a)) => {
                let v = value(data, (bc, comp));
                let closing = six_digits(v - r / a);
                let relation = if pair.bilateral {
                    "="
                } else if a > 0.0 {
                    "≤"
                } else {
                    "≥"
                };
                (
                    format!("boundary[{bc}].displacement[{comp}]"),
                    format!(
                        "; with the other values kept, boundary[{bc}].displacement[{comp}] {relation} {closing} closes it"
                    ),
                )
            }
            None => (format!("contacts[{}]", pair.zone), String::new()),
        };
        SceneError::new(
            path,
            format!(
                "contact zone '{}' (contacts[{}]): at the node ({x}, {y}) the prescribed displacements alone {what} along the normal ({nx:.4}, {ny:.4}), so no admissible displacement exists; both nodes of the pair are fixed by {}{fix}",
                contact.name,
                pair.zone,
                fields.join(" and "),
            ),
        )
    }

    /// The largest interval of the uncertain datum `u` that is feasible with the others at the
    /// worst vertex.
    fn suggest(
        &self,
        pinned: &PinnedPair,
        geometry: &ContactGeometry,
        vertex: &Data,
        u: &UncertainDisplacement<'_>,
    ) -> String {
        let a = pinned.slope(u.source);
        let r = self.residual(pinned, geometry, vertex);
        let limit = six_digits(value(vertex, u.source) - r / a);
        let (lo, hi) = if a > 0.0 {
            (u.lo, limit.min(u.hi))
        } else {
            (limit.max(u.lo), u.hi)
        };
        if lo <= hi {
            format!(
                "; the largest feasible interval of {} with the other data at this vertex is [{lo}, {hi}]",
                u.name
            )
        } else {
            format!(
                "; no value of {} in its interval is feasible with the other data at this vertex",
                u.name
            )
        }
    }
}

/// `v` rounded to six significant digits, for messages.
fn six_digits(v: f64) -> f64 {
    format!("{v:.5e}").parse().unwrap_or(v)
}

/// The boundary conditions among the sources, in first-seen order.
fn distinct_conditions(sources: &[(Source, f64)]) -> Vec<usize> {
    let mut out = Vec::new();
    for &((bc, _), _) in sources {
        if !out.contains(&bc) {
            out.push(bc);
        }
    }
    out
}

/// The value of `boundary[bc].displacement[comp]` in the data (0 when not prescribed).
fn value(data: &Data, (bc, comp): Source) -> f64 {
    match data.boundary.get(bc).map(|b| &b.value) {
        Some(BoundaryValue::Displacement(components)) => components[comp].unwrap_or(0.0),
        _ => 0.0,
    }
}

fn set_value(data: &mut Data, (bc, comp): Source, v: f64) {
    if let Some(BoundaryValue::Displacement(components)) =
        data.boundary.get_mut(bc).map(|b| &mut b.value)
    {
        components[comp] = Some(v);
    }
}
