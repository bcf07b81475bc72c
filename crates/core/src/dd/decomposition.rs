//! From a partition to the local objects of the method (D05 §4.1–4.4): the interface Γ (DOFs in
//! two or more subdomains), the non-contact subdomains T^ι as [`LinearBlock`]s, the contact
//! clusters ϑ (subdomains linked by contact pairs, union–find) as [`ContactCluster`]s, and their
//! tied versions for the auxiliary problem. Local factorisations run in parallel.

use rayon::prelude::*;

use super::options::Weights;
use super::pair::{ContactCluster, LocalRow};
use super::partition::Partition;
use std::sync::Arc;

use super::subdomain::{
    assemble, rigid_candidates, BlockOperators, Csr, LinearBlock, OperatorCache,
};
use super::{DdContactRow, DdError, DdProblem};
use crate::contact::pairs::is_normal_row;

const NONE: usize = usize::MAX;

/// Local DOF sets of one subdomain or cluster: interior (global DOFs) and interface (global
/// DOFs, their interface indices).
#[derive(Debug, Clone, Default)]
pub struct LocalDofs {
    pub interior: Vec<usize>,
    pub interface: Vec<usize>,
    pub gamma: Vec<usize>,
}

impl LocalDofs {
    fn all(&self) -> Vec<usize> {
        self.interior
            .iter()
            .chain(&self.interface)
            .copied()
            .collect()
    }

    /// Map global DOF → local index (interior first).
    fn local_map(&self, n: usize) -> Vec<usize> {
        let mut map = vec![NONE; n];
        for (i, &d) in self.all().iter().enumerate() {
            map[d] = i;
        }
        map
    }
}

/// Everything the iterations need.
pub struct Decomposition {
    pub partition: Partition,
    /// Global DOF of each interface index.
    pub interface: Vec<usize>,
    pub blocks: Vec<LinearBlock>,
    pub block_dofs: Vec<LocalDofs>,
    pub clusters: Vec<ContactCluster>,
    pub cluster_dofs: Vec<LocalDofs>,
    /// Pair indices of each cluster (rows 2i normal, 2i + 1 tangent).
    pub cluster_pairs: Vec<Vec<usize>>,
    /// Tied clusters for the auxiliary problem, and whether the tangential rows had to be tied
    /// too (full stick) because the normal tie alone left a rigid motion.
    pub tied: Vec<LinearBlock>,
    pub full_stick: Vec<bool>,
}

impl Decomposition {
    /// The decomposition of `problem`; the subdomain operators come from `operators` when it
    /// holds them for the same stiffness.
    pub fn new(
        problem: &DdProblem,
        partition: Partition,
        operators: Option<&OperatorCache>,
        weights: Weights,
    ) -> Result<Decomposition, DdError> {
        let n = problem.n_dofs();
        let ns = partition.n_subdomains;
        let elements = subdomain_elements(&partition);
        let dof_subs = dof_subdomains(problem, &elements, n);
        let (interface, sub_dofs) = interface_and_local_dofs(&dof_subs, n, ns);
        let rho = match weights {
            Weights::Stiffness => stiffness_weights(problem, &elements),
            Weights::MeanYoung => young_weights(problem, &elements),
        };
        let (blocks, block_dofs) =
            linear_blocks(problem, &partition, &elements, &sub_dofs, &rho, operators)?;
        let (members, cluster_pairs) = cluster_members(problem, &partition);
        let built = build_clusters(
            problem,
            &elements,
            &sub_dofs,
            &rho,
            &members,
            &cluster_pairs,
        )?;
        let mut clusters = Vec::new();
        let mut tied = Vec::new();
        let mut full_stick = Vec::new();
        let mut cluster_dofs = Vec::new();
        for b in built {
            clusters.push(b.cluster);
            tied.push(b.tied);
            full_stick.push(b.full_stick);
            cluster_dofs.push(b.dofs);
        }
        Ok(Decomposition {
            partition,
            interface,
            blocks,
            block_dofs,
            clusters,
            cluster_dofs,
            cluster_pairs,
            tied,
            full_stick,
        })
    }

    pub fn n_interface(&self) -> usize {
        self.interface.len()
    }
}

/// The elements of each subdomain, in element order.
fn subdomain_elements(partition: &Partition) -> Vec<Vec<usize>> {
    let mut elements = vec![Vec::new(); partition.n_subdomains];
    for (e, &s) in partition.element_subdomain.iter().enumerate() {
        elements[s].push(e);
    }
    elements
}

/// The subdomains of each of the `n` reduced DOFs, sorted and without repetitions.
fn dof_subdomains(problem: &DdProblem, elements: &[Vec<usize>], n: usize) -> Vec<Vec<usize>> {
    let mut dof_subs: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (s, list) in elements.iter().enumerate() {
        for &e in list {
            for d in problem.elements[e].dofs.into_iter().flatten() {
                if dof_subs[d].last() != Some(&s) {
                    dof_subs[d].push(s);
                }
            }
        }
    }
    for v in &mut dof_subs {
        v.sort_unstable();
        v.dedup();
    }
    dof_subs
}

/// The interface (DOFs in two or more subdomains, in DOF order) and the interior and interface
/// DOFs of each of the `ns` subdomains.
fn interface_and_local_dofs(
    dof_subs: &[Vec<usize>],
    n: usize,
    ns: usize,
) -> (Vec<usize>, Vec<LocalDofs>) {
    let interface: Vec<usize> = (0..n).filter(|&d| dof_subs[d].len() > 1).collect();
    let mut gamma_of = vec![NONE; n];
    for (i, &d) in interface.iter().enumerate() {
        gamma_of[d] = i;
    }
    let mut sub_dofs = vec![LocalDofs::default(); ns];
    for (d, subs) in dof_subs.iter().enumerate() {
        for &s in subs {
            if gamma_of[d] == NONE {
                sub_dofs[s].interior.push(d);
            } else {
                sub_dofs[s].interface.push(d);
                sub_dofs[s].gamma.push(gamma_of[d]);
            }
        }
    }
    (interface, sub_dofs)
}

/// ρ_s: mean diagonal of the local stiffness (a stiffness measure, D05 5.5).
fn stiffness_weights(problem: &DdProblem, elements: &[Vec<usize>]) -> Vec<f64> {
    elements
        .iter()
        .map(|list| {
            let (mut sum, mut count) = (0.0, 0usize);
            for &e in list {
                let el = &problem.elements[e];
                for i in 0..6 {
                    if el.dofs[i].is_some() {
                        sum += el.matrix[i][i];
                        count += 1;
                    }
                }
            }
            sum / count.max(1) as f64
        })
        .collect()
}

/// ρ_s: the area-weighted mean Young's modulus of the subdomain's elements (D05 5.5, the
/// papers' choice).
fn young_weights(problem: &DdProblem, elements: &[Vec<usize>]) -> Vec<f64> {
    elements
        .iter()
        .map(|list| {
            let (mut sum, mut area) = (0.0, 0.0);
            for &e in list {
                let el = &problem.elements[e];
                sum += el.young * el.area;
                area += el.area;
            }
            sum / area
        })
        .collect()
}

/// The non-contact subdomains as linear blocks (factorised in parallel, or taken from
/// `operators`), with their local DOFs.
fn linear_blocks(
    problem: &DdProblem,
    partition: &Partition,
    elements: &[Vec<usize>],
    sub_dofs: &[LocalDofs],
    rho: &[f64],
    operators: Option<&OperatorCache>,
) -> Result<(Vec<LinearBlock>, Vec<LocalDofs>), DdError> {
    let n = problem.n_dofs();
    let ns = partition.n_subdomains;
    let non_contact: Vec<usize> = (0..ns).filter(|&s| !partition.contact[s]).collect();
    let blocks: Vec<LinearBlock> = non_contact
        .par_iter()
        .map(|&s| {
            let dofs = &sub_dofs[s];
            let local = dofs.local_map(n);
            let all = dofs.all();
            let k = Csr::from_triplets(all.len(), assemble(problem, &elements[s], &local));
            let cand = rigid_candidates(problem, &all, &vec![0; all.len()]);
            let ni = dofs.interior.len();
            let ops = match operators {
                Some(cache) => cache.get((s, ns), k, ni, cand.as_ref()),
                None => BlockOperators::new(k, ni, cand.as_ref()).map(Arc::new),
            };
            ops.and_then(|ops| {
                LinearBlock::with_operators(
                    ops,
                    ni,
                    dofs.gamma.clone(),
                    vec![rho[s]; dofs.gamma.len()],
                    dofs.interior.iter().map(|&d| problem.rhs[d]).collect(),
                    vec![0.0; dofs.gamma.len()],
                )
            })
            .map_err(|reason| DdError::Subdomain {
                subdomain: s,
                reason,
            })
        })
        .collect::<Result<_, _>>()?;
    let block_dofs = non_contact.iter().map(|&s| sub_dofs[s].clone()).collect();
    Ok((blocks, block_dofs))
}

/// Root of `i` in the union–find forest `p`, halving the path on the way.
fn find(p: &mut [usize], mut i: usize) -> usize {
    while p[i] != i {
        p[i] = p[p[i]];
        i = p[i];
    }
    i
}

/// Clusters: union–find over the contact pairs (every node of a pair's rows: a mortar row's
/// master nodes join the slave node's cluster). The member subdomains of each cluster and the
/// indices of its pairs, clusters numbered by their first contact subdomain.
fn cluster_members(
    problem: &DdProblem,
    partition: &Partition,
) -> (Vec<Vec<usize>>, Vec<Vec<usize>>) {
    let ns = partition.n_subdomains;
    let node_sub = {
        let mut m = vec![NONE; problem.nodes.len()];
        for (e, el) in problem.elements.iter().enumerate() {
            for &v in &el.nodes {
                m[v] = partition.element_subdomain[e];
            }
        }
        m
    };
    let mut parent: Vec<usize> = (0..ns).collect();
    for pair in &problem.pairs {
        let a = node_sub[pair.nodes[0]];
        for &node in &pair.nodes[1..] {
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, node_sub[node]));
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let mut cluster_of = vec![NONE; ns];
    let mut members: Vec<Vec<usize>> = Vec::new();
    for s in (0..ns).filter(|&s| partition.contact[s]) {
        let r = find(&mut parent, s);
        if cluster_of[r] == NONE {
            cluster_of[r] = members.len();
            members.push(Vec::new());
        }
        members[cluster_of[r]].push(s);
    }
    let mut cluster_pairs = vec![Vec::new(); members.len()];
    for (i, pair) in problem.pairs.iter().enumerate() {
        let r = find(&mut parent, node_sub[pair.nodes[0]]);
        cluster_pairs[cluster_of[r]].push(i);
    }
    (members, cluster_pairs)
}

/// Every cluster's local contact problem and tied block, built in parallel.
fn build_clusters(
    problem: &DdProblem,
    elements: &[Vec<usize>],
    sub_dofs: &[LocalDofs],
    rho: &[f64],
    members: &[Vec<usize>],
    cluster_pairs: &[Vec<usize>],
) -> Result<Vec<BuiltCluster>, DdError> {
    members
        .par_iter()
        .zip(cluster_pairs)
        .enumerate()
        .map(|(c, (mem, pairs))| {
            build_cluster(problem, elements, sub_dofs, rho, mem, pairs)
                .map_err(|reason| DdError::Cluster { cluster: c, reason })
        })
        .collect::<Result<_, _>>()
}

fn local_row(row: &DdContactRow, local: &[usize], n_interior: usize) -> Result<LocalRow, String> {
    let entries = row
        .entries
        .iter()
        .map(|&(d, a)| match local[d] {
            i if i < n_interior => Ok((i, a)),
            _ => Err(format!("contact DOF {d} is not interior to its cluster")),
        })
        .collect::<Result<_, _>>()?;
    Ok(LocalRow {
        entries,
        value: row.value,
        lower: row.lower,
        upper: row.upper,
    })
}

struct BuiltCluster {
    cluster: ContactCluster,
    tied: LinearBlock,
    full_stick: bool,
    dofs: LocalDofs,
}

fn build_cluster(
    problem: &DdProblem,
    elements: &[Vec<usize>],
    sub_dofs: &[LocalDofs],
    rho: &[f64],
    members: &[usize],
    pairs: &[usize],
) -> Result<BuiltCluster, String> {
    let n = problem.n_dofs();
    // (global, member) for interior and interface DOFs.
    let mut interior: Vec<(usize, usize)> = Vec::new();
    let mut iface: Vec<(usize, usize, usize)> = Vec::new();
    for (m, &s) in members.iter().enumerate() {
        interior.extend(sub_dofs[s].interior.iter().map(|&d| (d, m)));
        iface.extend(
            sub_dofs[s]
                .interface
                .iter()
                .zip(&sub_dofs[s].gamma)
                .map(|(&d, &g)| (g, d, m)),
        );
    }
    interior.sort_unstable();
    iface.sort_unstable();
    let dofs = LocalDofs {
        interior: interior.iter().map(|x| x.0).collect(),
        interface: iface.iter().map(|x| x.1).collect(),
        gamma: iface.iter().map(|x| x.0).collect(),
    };
    let group: Vec<usize> = interior
        .iter()
        .map(|x| x.1)
        .chain(iface.iter().map(|x| x.2))
        .collect();
    let local = dofs.local_map(n);
    let all = dofs.all();
    let els: Vec<usize> = members
        .iter()
        .flat_map(|&s| elements[s].iter().copied())
        .collect();
    let k = Csr::from_triplets(all.len(), assemble(problem, &els, &local));
    let ni = dofs.interior.len();
    let mut rows = Vec::with_capacity(2 * pairs.len());
    for &p in pairs {
        rows.push(local_row(&problem.pairs[p].normal, &local, ni)?);
        rows.push(local_row(&problem.pairs[p].tangent, &local, ni)?);
    }
    let cand = rigid_candidates(problem, &all, &group);
    let f_interior: Vec<f64> = dofs.interior.iter().map(|&d| problem.rhs[d]).collect();
    let cluster = ContactCluster::new(
        k,
        ni,
        dofs.gamma.clone(),
        rows,
        f_interior,
        cand.subrows(0, ni),
    )?;
    let rho_gamma: Vec<f64> = iface.iter().map(|x| rho[members[x.2]]).collect();
    // Rows 2i, 2i + 1 belong to the cluster's pair i; only the pairs on Γc0 are tied (D05 4.35).
    let on_tied_set = |row: usize| problem.pairs[pairs[row / 2]].tied;
    let normal = |row: usize| on_tied_set(row) && is_normal_row(row);
    let (tied, full_stick) = match cluster.tied(normal, rho_gamma.clone(), cand.as_ref()) {
        Ok(t) => (t, false),
        Err(first) => match cluster.tied(on_tied_set, rho_gamma, cand.as_ref()) {
            Ok(t) => (t, true),
            Err(_) if !pairs.iter().all(|&p| problem.pairs[p].tied) => {
                return Err(format!(
                    "{first}; the tied set Γc0 (solver.dd.tied_zones) leaves a body of this \
                     cluster free in the auxiliary problem: tie one of its zones"
                ))
            }
            Err(_) => return Err(first),
        },
    };
    Ok(BuiltCluster {
        cluster,
        tied,
        full_stick,
        dofs,
    })
}
