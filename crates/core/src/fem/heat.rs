//! Stationary heat (FGCS problem P1, design §2.1 thermal, §3.3): −div(κ_z ∇T) = W_z in each zone
//! with κ_z a symmetric positive definite 2×2 conductivity (FGCS 4.7), T = T1 on `Temperature`
//! segments, inward flux κ∇T·n = q on `HeatFlux` segments, zero flux elsewhere, perfect thermal
//! contact across every contact zone (T continuous). Weak form: Σ_z ∫ ∇wᵀ κ_z ∇T = Σ_z ∫ W_z w +
//! ∫ q w ds, P1, with the zoned operator of `operator` and the three coefficients (κ11, κ12, κ22)
//! per zone.
//!
//! Perfect contact: the two nodes of each node-coupled contact pair are ONE thermal unknown
//! (union-find). Across a mortar-coupled zone (design §2.4.1, §3.3) continuity is the Matlab
//! mortar paper's weak continuity (7) with the dual basis: each slave node's temperature is tied,
//! T_p = Σ_q M̂_pq T_q, so the slave unknowns are eliminated, T = Q T_primary, and the operator and
//! loads are Qᵀ K Q and Qᵀ f. A slave node with a prescribed temperature keeps it (its tie is
//! dropped, as the paper's nonmortar end points on ∂Ω_D are Dirichlet nodes). Every connected
//! thermal component needs a prescribed temperature, otherwise the problem is singular and is
//! refused at construction.

use faer::Par;

use crate::mesh::Mesh;
use crate::scene::{BoundaryValue, Data, Scene};

use super::geometry::{check_mesh, element_gradients, TriangleGradients, UnitLoads};
use super::operator::{OperatorBuilder, OperatorFactor, Slot, ZonedOperator};
use super::{boundary_segment, expect_len, material_of, FemError, HeatCoefficients};
use crate::scene::law::symmetric_eigenvalues;

/// Union-find with path halving.
#[derive(Debug, Clone)]
struct UnionFind {
    parent: Vec<usize>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n).collect(),
        }
    }

    fn find(&mut self, mut i: usize) -> usize {
        while self.parent[i] != i {
            self.parent[i] = self.parent[self.parent[i]];
            i = self.parent[i];
        }
        i
    }

    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.parent[ra.max(rb)] = ra.min(rb);
        }
    }
}

/// Per fixed unknown: a node of it and the indices of the `Temperature` conditions on it.
type FixedSources = Vec<(usize, Vec<usize>)>;

/// Where a node's temperature lives in the reduced system.
#[derive(Debug, Clone, PartialEq)]
pub enum Thermal {
    /// A primary unknown: free or prescribed.
    Own(Slot),
    /// A mortar slave node: T_p = Σ (weight · value of slot), the slave's dual-mortar row M̂_p·
    /// expressed in primary unknowns.
    Tied(Vec<(Slot, f64)>),
}

/// The heat problem of a mesh and scene topology.
#[derive(Debug, Clone)]
pub struct HeatProblem {
    mesh: Mesh,
    /// Thermal unknown of each node (merged across node-coupled contact pairs).
    unknown_of: Vec<usize>,
    /// Each thermal unknown's place in the reduced system (a row of Q).
    terms: Vec<Thermal>,
    /// Per fixed unknown: a node of it and the `Temperature` conditions prescribing it.
    fixed_sources: FixedSources,
    operator: ZonedOperator<3>,
    /// Load weights per zone and per boundary condition.
    unit_loads: UnitLoads,
}

impl HeatProblem {
    /// Build the thermal numbering, the operator (symbolic factorisation included) and unit loads.
    pub fn new(mesh: &Mesh, data: &Data) -> Result<HeatProblem, FemError> {
        check_mesh(mesh)?;
        let unknown_of = merge_contact_nodes(mesh);
        let n_unknowns = unknown_of.iter().max().map_or(0, |m| m + 1);
        let sources = temperature_sources(mesh, data, &unknown_of, n_unknowns)?;
        let ties = mortar_ties(mesh, &unknown_of, &sources)?;
        check_components(mesh, &unknown_of, &sources, &ties)?;
        let (slots, fixed_sources) = number_unknowns(&unknown_of, sources, &ties);
        let terms = resolve_ties(mesh, &unknown_of, &slots, &ties)?;
        let gradients = element_gradients(mesh);
        let n_fixed = fixed_sources.len();
        let n_free = slots.iter().flatten().count() - n_fixed;
        let operator = build_operator(mesh, &unknown_of, &terms, n_free, n_fixed, &gradients)?;
        Ok(HeatProblem {
            unit_loads: UnitLoads::new(mesh, &data.boundary, &gradients),
            mesh: mesh.clone(),
            unknown_of,
            terms,
            fixed_sources,
            operator,
        })
    }

    /// [`HeatProblem::new`] with the data of a validated scene.
    pub fn from_scene(mesh: &Mesh, scene: &Scene) -> Result<HeatProblem, FemError> {
        HeatProblem::new(mesh, &Data::from_scene(scene))
    }

    /// The mesh the problem was built on.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// The reduced operator K_ff(κ) with coefficients (κ11, κ12, κ22)_z per zone.
    pub fn operator(&self) -> &ZonedOperator<3> {
        &self.operator
    }

    /// The temperature of `node` in the reduced system: its own slot, or the mortar combination
    /// of a tied slave node.
    pub fn thermal(&self, node: usize) -> &Thermal {
        &self.terms[self.unknown_of[node]]
    }

    /// Conductivity (κ11, κ12, κ22)_z per zone, validated positive definite.
    pub fn coefficients(&self, data: &Data) -> Result<Vec<HeatCoefficients>, FemError> {
        self.mesh
            .zones
            .iter()
            .map(|zone| {
                let kappa = material_of(data, zone)?.conductivity;
                let [k11, k12, k22] = kappa;
                let least = symmetric_eigenvalues(&[[k11, k12], [k12, k22]])[0];
                if least > 0.0 && kappa.iter().all(|k| k.is_finite()) {
                    Ok(kappa)
                } else {
                    Err(FemError::InvalidMaterial {
                        material: zone.material,
                        reason: format!(
                            "conductivity (κ11, κ12, κ22) = {kappa:?} must be positive definite"
                        ),
                    })
                }
            })
            .collect()
    }

    /// Assemble and factorise K_ff(κ) on the shared symbolic factorisation.
    pub fn factor(&self, data: &Data, par: Par) -> Result<OperatorFactor<3>, FemError> {
        self.operator.factor(&self.coefficients(data)?, par)
    }

    /// Nodal heat loads ∫ W φ_i + ∫ q φ_i ds, before merging and constraints.
    pub fn loads(&self, data: &Data) -> Result<Vec<f64>, FemError> {
        expect_len(
            "boundary conditions",
            data.boundary.len(),
            self.unit_loads.segments.len(),
        )?;
        let mut f = vec![0.0; self.mesh.nodes.len()];
        for (zone, weights) in self.mesh.zones.iter().zip(&self.unit_loads.zones) {
            let w = material_of(data, zone)?.heat_source;
            for &(node, weight) in weights {
                f[node] += w * weight;
            }
        }
        for (bc, load) in data.boundary.iter().zip(&self.unit_loads.segments) {
            if let BoundaryValue::HeatFlux(q) = bc.value {
                for &(node, weight) in &load.weights {
                    f[node] += q * weight;
                }
            }
        }
        Ok(f)
    }

    /// Prescribed temperatures of the fixed unknowns; conditions meeting at a node must agree.
    pub fn fixed_values(&self, data: &Data) -> Result<Vec<f64>, FemError> {
        self.fixed_sources
            .iter()
            .map(|(node, bcs)| {
                let values = bcs
                    .iter()
                    .map(|&bc| match data.boundary.get(bc).map(|b| &b.value) {
                        Some(BoundaryValue::Temperature(t)) => Ok(*t),
                        _ => Err(FemError::InvalidBoundary {
                            index: bc,
                            reason:
                                "no longer a temperature condition (the problem was built with one)"
                                    .into(),
                        }),
                    })
                    .collect::<Result<Vec<f64>, FemError>>()?;
                agreed_value(&self.mesh, *node, &values)
            })
            .collect()
    }

    /// Prescribed temperatures taken from a nodal field (e.g. an exact solution).
    pub fn fixed_values_from(&self, field: &[f64]) -> Result<Vec<f64>, FemError> {
        expect_len("nodal temperatures", field.len(), self.mesh.nodes.len())?;
        Ok(self
            .fixed_sources
            .iter()
            .map(|&(node, _)| field[node])
            .collect())
    }

    /// Reduced right-hand side b = f|_free − K_fd(κ) T_d for the data.
    pub fn rhs(&self, data: &Data) -> Result<Vec<f64>, FemError> {
        self.rhs_with(
            &self.coefficients(data)?,
            &self.loads(data)?,
            &self.fixed_values(data)?,
        )
    }

    /// Reduced right-hand side from explicit coefficients, nodal loads and prescribed values.
    pub fn rhs_with(
        &self,
        coefficients: &[HeatCoefficients],
        loads: &[f64],
        fixed: &[f64],
    ) -> Result<Vec<f64>, FemError> {
        expect_len("nodal heat loads", loads.len(), self.mesh.nodes.len())?;
        let mut b = vec![0.0; self.operator.n_free()];
        for (node, &f) in loads.iter().enumerate() {
            match self.thermal(node) {
                Thermal::Own(Slot::Free(i)) => b[*i] += f,
                Thermal::Own(Slot::Fixed(_)) => {}
                Thermal::Tied(tied) => {
                    for &(slot, w) in tied {
                        if let Slot::Free(i) = slot {
                            b[i] += w * f;
                        }
                    }
                }
            }
        }
        self.operator.lift(coefficients, fixed, &mut b)?;
        Ok(b)
    }

    /// Solve for the nodal temperature with a factor of the same data.
    pub fn solve(&self, factor: &OperatorFactor<3>, data: &Data) -> Result<Vec<f64>, FemError> {
        if factor.coefficients != self.coefficients(data)? {
            return Err(FemError::Input(
                "the factor was computed for other conductivities".into(),
            ));
        }
        self.solve_with(factor, &self.loads(data)?, &self.fixed_values(data)?)
    }

    /// Solve with explicit nodal loads and prescribed values.
    pub fn solve_with(
        &self,
        factor: &OperatorFactor<3>,
        loads: &[f64],
        fixed: &[f64],
    ) -> Result<Vec<f64>, FemError> {
        let b = self.rhs_with(&factor.coefficients, loads, fixed)?;
        Ok(self.expand(&factor.factor.solve(&b), fixed))
    }

    /// The nodal field of free and fixed unknown values (tied slave nodes by their mortar
    /// combination).
    pub fn expand(&self, free: &[f64], fixed: &[f64]) -> Vec<f64> {
        let value = |slot: Slot| match slot {
            Slot::Free(i) => free[i],
            Slot::Fixed(i) => fixed[i],
        };
        (0..self.mesh.nodes.len())
            .map(|node| match self.thermal(node) {
                Thermal::Own(slot) => value(*slot),
                Thermal::Tied(tied) => tied
                    .iter()
                    .fold(0.0, |sum, &(slot, w)| sum + w * value(slot)),
            })
            .collect()
    }

    /// The free unknown values of a nodal field (tied slave nodes are not unknowns).
    pub fn free_values(&self, field: &[f64]) -> Vec<f64> {
        let mut free = vec![0.0; self.operator.n_free()];
        for (node, &v) in field.iter().enumerate() {
            if let Thermal::Own(Slot::Free(i)) = self.thermal(node) {
                free[*i] = v;
            }
        }
        free
    }
}

/// Thermal unknown per node: node-coupled contact pairs merged, numbered compactly in node order.
fn merge_contact_nodes(mesh: &Mesh) -> Vec<usize> {
    let mut uf = UnionFind::new(mesh.nodes.len());
    for contact in mesh.contacts.iter().filter(|c| c.mortar.is_none()) {
        for &[a, b] in &contact.pairs {
            uf.union(a, b);
        }
    }
    let mut id = vec![usize::MAX; mesh.nodes.len()];
    let mut next = 0;
    (0..mesh.nodes.len())
        .map(|node| {
            let root = uf.find(node);
            if id[root] == usize::MAX {
                id[root] = next;
                next += 1;
            }
            id[root]
        })
        .collect()
}

/// The `Temperature` conditions acting on each thermal unknown.
fn temperature_sources(
    mesh: &Mesh,
    data: &Data,
    unknown_of: &[usize],
    n_unknowns: usize,
) -> Result<Vec<Vec<usize>>, FemError> {
    let mut sources = vec![Vec::new(); n_unknowns];
    for (bc, b) in data.boundary.iter().enumerate() {
        if !matches!(b.value, BoundaryValue::Temperature(_)) {
            continue;
        }
        let segment = boundary_segment(mesh, bc, b.segment)?;
        for &node in &segment.nodes {
            let s: &mut Vec<usize> = &mut sources[unknown_of[node]];
            if !s.contains(&bc) {
                s.push(bc);
            }
        }
    }
    Ok(sources)
}

/// A mortar slave unknown's tie: (master thermal unknown, M̂_pq).
type Tie = Vec<(usize, f64)>;

/// Per thermal unknown, the mortar tie of a slave node without a prescribed temperature: its
/// row M̂_p· (design §2.4.1) over thermal unknowns. A slave node that is prescribed keeps its
/// value and gets no tie.
fn mortar_ties(
    mesh: &Mesh,
    unknown_of: &[usize],
    sources: &[Vec<usize>],
) -> Result<Vec<Option<Tie>>, FemError> {
    let mut ties: Vec<Option<Tie>> = vec![None; sources.len()];
    for contact in &mesh.contacts {
        let Some(rows) = &contact.mortar else {
            continue;
        };
        for (&[slave, _], row) in contact.pairs.iter().zip(rows) {
            let u = unknown_of[slave];
            if !sources[u].is_empty() {
                continue;
            }
            let conflict = |reason: String| FemError::ConflictingConstraints {
                node: slave,
                x: mesh.nodes[slave][0],
                y: mesh.nodes[slave][1],
                reason,
            };
            if ties[u].is_some() {
                return Err(conflict(format!(
                    "the node is a mortar slave twice (again in contact zone '{}'): its \
                     temperature would be tied to two different combinations",
                    contact.name
                )));
            }
            let mut combination: Tie = Vec::with_capacity(row.master.len());
            for &(q, w) in &row.master {
                add_term(&mut combination, unknown_of[q], w);
            }
            if combination.iter().any(|&(v, _)| v == u) {
                return Err(conflict(format!(
                    "in contact zone '{}' the slave node is merged with one of its own mortar \
                     master nodes",
                    contact.name
                )));
            }
            ties[u] = Some(combination);
        }
    }
    Ok(ties)
}

/// Add w · `key` to a short combination, merging a repeated key.
fn add_term<K: PartialEq>(combination: &mut Vec<(K, f64)>, key: K, w: f64) {
    match combination.iter_mut().find(|(k, _)| *k == key) {
        Some((_, sum)) => *sum += w,
        None => combination.push((key, w)),
    }
}

/// Every connected thermal component must have a prescribed temperature (mortar ties connect a
/// slave to its masters).
fn check_components(
    mesh: &Mesh,
    unknown_of: &[usize],
    sources: &[Vec<usize>],
    ties: &[Option<Tie>],
) -> Result<(), FemError> {
    let mut uf = UnionFind::new(sources.len());
    for tri in &mesh.triangles {
        uf.union(unknown_of[tri[0]], unknown_of[tri[1]]);
        uf.union(unknown_of[tri[0]], unknown_of[tri[2]]);
    }
    for (u, tie) in ties.iter().enumerate() {
        for &(v, _) in tie.iter().flatten() {
            uf.union(u, v);
        }
    }
    let mut held = vec![false; sources.len()];
    for (u, s) in sources.iter().enumerate() {
        if !s.is_empty() {
            let root = uf.find(u);
            held[root] = true;
        }
    }
    for (node, &u) in unknown_of.iter().enumerate() {
        if !held[uf.find(u)] {
            return Err(FemError::NoTemperature {
                node,
                body: mesh
                    .bodies
                    .get(mesh.node_body[node])
                    .cloned()
                    .unwrap_or_default(),
            });
        }
    }
    Ok(())
}

/// Free/fixed slot of each untied unknown (none for a tied one), and per fixed unknown a
/// representative node and its sources.
fn number_unknowns(
    unknown_of: &[usize],
    sources: Vec<Vec<usize>>,
    ties: &[Option<Tie>],
) -> (Vec<Option<Slot>>, FixedSources) {
    let mut node_of = vec![0; sources.len()];
    for (node, &u) in unknown_of.iter().enumerate().rev() {
        node_of[u] = node;
    }
    let mut n_free = 0;
    let mut fixed = Vec::new();
    let slots = sources
        .into_iter()
        .enumerate()
        .map(|(u, s)| {
            if ties[u].is_some() {
                None
            } else if s.is_empty() {
                n_free += 1;
                Some(Slot::Free(n_free - 1))
            } else {
                fixed.push((node_of[u], s));
                Some(Slot::Fixed(fixed.len() - 1))
            }
        })
        .collect();
    (slots, fixed)
}

/// Each unknown's place in the reduced system: its slot, or its tie with master unknowns that are
/// themselves tied (a crosspoint) substituted. A cycle of ties is refused.
fn resolve_ties(
    mesh: &Mesh,
    unknown_of: &[usize],
    slots: &[Option<Slot>],
    ties: &[Option<Tie>],
) -> Result<Vec<Thermal>, FemError> {
    /// Not yet resolved, being resolved (on the stack), or resolved.
    #[derive(Clone)]
    enum State {
        New,
        Open,
        Done(Vec<(Slot, f64)>),
    }
    fn resolve(
        u: usize,
        slots: &[Option<Slot>],
        ties: &[Option<Tie>],
        state: &mut [State],
    ) -> Result<Vec<(Slot, f64)>, usize> {
        if let Some(slot) = slots[u] {
            return Ok(vec![(slot, 1.0)]);
        }
        match &state[u] {
            State::Done(terms) => return Ok(terms.clone()),
            State::Open => return Err(u),
            State::New => {}
        }
        state[u] = State::Open;
        let mut terms = Vec::new();
        for &(v, w) in ties[u].iter().flatten() {
            for (slot, wv) in resolve(v, slots, ties, state)? {
                add_term(&mut terms, slot, w * wv);
            }
        }
        state[u] = State::Done(terms.clone());
        Ok(terms)
    }
    let mut state = vec![State::New; slots.len()];
    (0..slots.len())
        .map(|u| match slots[u] {
            Some(slot) => Ok(Thermal::Own(slot)),
            None => resolve(u, slots, ties, &mut state)
                .map(Thermal::Tied)
                .map_err(|v| {
                    let node = unknown_of.iter().position(|&x| x == v).unwrap_or(0);
                    FemError::ConflictingConstraints {
                        node,
                        x: mesh.nodes[node][0],
                        y: mesh.nodes[node][1],
                        reason: "the mortar ties of crossing zones form a cycle (this slave \
                                 node is, through other zones, its own master)"
                            .into(),
                    }
                }),
        })
        .collect()
}

/// The common value of temperature conditions meeting at a node, or a conflict error.
fn agreed_value(mesh: &Mesh, node: usize, values: &[f64]) -> Result<f64, FemError> {
    let first = values.first().copied().unwrap_or(0.0);
    let scale = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    match values.iter().find(|v| (**v - first).abs() > 1e-12 * scale) {
        None => Ok(first),
        Some(other) => Err(FemError::ConflictingConstraints {
            node,
            x: mesh.nodes[node][0],
            y: mesh.nodes[node][1],
            reason: format!("temperature conditions prescribe both {first} and {other}"),
        }),
    }
}

/// Per element K_e = κ area (∇φ_i·∇φ_j) on the merged unknowns; an element with a tied slave
/// node adds Qᵀ K_e Q (each node's local row spread over its tie's slots with their weights).
fn build_operator(
    mesh: &Mesh,
    unknown_of: &[usize],
    terms: &[Thermal],
    n_free: usize,
    n_fixed: usize,
    gradients: &[TriangleGradients],
) -> Result<ZonedOperator<3>, FemError> {
    let mut builder = OperatorBuilder::<3>::new(n_free, n_fixed, mesh.zones.len());
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let g = &gradients[t];
        let k = |i: usize, j: usize| {
            [
                g.area * g.dx[i] * g.dx[j],
                g.area * (g.dx[i] * g.dy[j] + g.dy[i] * g.dx[j]),
                g.area * g.dy[i] * g.dy[j],
            ]
        };
        let node_terms = tri.map(|n| &terms[unknown_of[n]]);
        if let [Thermal::Own(a), Thermal::Own(b), Thermal::Own(c)] = node_terms {
            builder.add_element(mesh.triangle_zone[t], &[*a, *b, *c], k);
            continue;
        }
        // (slot, local node, weight) of the element's expanded unknowns.
        let mut local: Vec<(Slot, usize, f64)> = Vec::new();
        for (i, thermal) in node_terms.iter().enumerate() {
            match thermal {
                Thermal::Own(slot) => local.push((*slot, i, 1.0)),
                Thermal::Tied(tied) => local.extend(tied.iter().map(|&(s, w)| (s, i, w))),
            }
        }
        let slots: Vec<Slot> = local.iter().map(|l| l.0).collect();
        builder.add_element(mesh.triangle_zone[t], &slots, |a, b| {
            let ((_, i, wa), (_, j, wb)) = (local[a], local[b]);
            k(i, j).map(|v| wa * wb * v)
        });
    }
    builder.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::stacked_blocks;
    use crate::scene::{BoundaryData, Elastic, Expansion, MaterialData};

    #[test]
    fn contact_pairs_become_one_unknown() {
        let mesh = stacked_blocks(1.0, 1.0, 1.0, 4, 2, 2);
        let material = MaterialData {
            elastic: Elastic::Lame {
                lambda: 1.0,
                mu: 1.0,
            },
            specific_weight: 0.0,
            body_force: [0.0; 2],
            conductivity: [1.0, 0.0, 1.0],
            heat_source: 0.0,
            expansion: Expansion::Beta(0.0),
        };
        let data = Data {
            materials: vec![material.clone(), material],
            boundary: vec![BoundaryData {
                segment: mesh.segment_index("lower_bottom").unwrap(),
                value: BoundaryValue::Temperature(1.0),
            }],
            slip: Vec::new(),
            friction: Vec::new(),
            reference_temperature: 0.0,
            dynamic: Default::default(),
        };
        let problem = HeatProblem::new(&mesh, &data).unwrap();
        let unknowns = problem.operator().n_free() + problem.operator().n_fixed();
        assert_eq!(unknowns, mesh.nodes.len() - mesh.contacts[0].pairs.len());
        assert_eq!(problem.operator().n_fixed(), 5);
        for &[a, b] in &mesh.contacts[0].pairs {
            assert_eq!(problem.thermal(a), problem.thermal(b));
        }
        // No source, no flux: uniform T = 1 everywhere, through the contact.
        let t = problem
            .solve(&problem.factor(&data, Par::Seq).unwrap(), &data)
            .unwrap();
        assert!(t.iter().all(|&v| (v - 1.0).abs() < 1e-13));
    }
}
