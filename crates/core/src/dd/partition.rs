//! Partition of the bodies into subdomains (D05 §4.1, FGCS 3.1–3.2).
//!
//! Rules: interfaces lie inside bodies and never cut a contact zone (D05 4.4, Γ ∩ Γc = ∅): every
//! element touching a contact node belongs to that node's contact subdomain. The contact nodes are
//! all nodes of the contact rows — with mortar rows (design §2.4.1) the master nodes of each
//! slave node's combination too, so that every row lies inside one contact cluster. Automatic partitions
//! keep contact subdomains SMALL — the band of elements within `contact_layers` element layers of
//! the contact nodes (FGCS Remark 3.1: the contraction factor 2β² of Thm 7.1 shrinks with the
//! contact subdomains' share of the energy) — except for a floating body in contact, which becomes
//! one contact subdomain as a whole (its local problem is then semi-coercive, D05 Thm 2.1). Bands
//! of one body that touch are merged, so that every interface DOF belongs to a non-contact
//! subdomain (S0 regular). Pockets of the rest without any prescribed DOF (cut off by bands) join
//! their contact subdomain, since they would float in S0. The rest of each body is cut by
//! recursive inertial bisection of the element centroids (balanced, compact), then made
//! edge-connected (a subdomain glued at a vertex would have extra kernel modes). Explicit
//! partitions are split into edge-connected pieces and validated by the same rules.

use std::collections::HashMap;

use super::{DdError, DdProblem};

/// Default width of the contact bands, in element layers.
pub const CONTACT_LAYERS: usize = 2;

/// How to partition.
#[derive(Debug, Clone, PartialEq)]
pub enum PartitionRequest {
    /// About `subdomains` subdomains in total (at least one per body part), contact bands of
    /// `contact_layers` element layers.
    Automatic {
        /// Requested total number of subdomains (approximate, at least one per body part).
        subdomains: usize,
        /// Width of the contact bands in element layers around the contact nodes.
        contact_layers: usize,
    },
    /// About `elements` elements per non-contact subdomain.
    BySize {
        /// Target number of elements per non-contact subdomain.
        elements: usize,
        /// Width of the contact bands in element layers around the contact nodes.
        contact_layers: usize,
    },
    /// Subdomain of every element (edge-disconnected pieces become subdomains of their own).
    Explicit(Vec<usize>),
    /// A partition built before for the same mesh and contact pairs (it depends on nothing
    /// else), reused for every data set of a scene.
    Given(Box<Partition>),
}

/// A validated partition.
#[derive(Debug, Clone, PartialEq)]
pub struct Partition {
    /// Subdomain index of every element, numbered 0..`n_subdomains`.
    pub element_subdomain: Vec<usize>,
    /// Number of subdomains.
    pub n_subdomains: usize,
    /// Whether each subdomain touches a contact zone.
    pub contact: Vec<bool>,
}

impl Partition {
    /// Partition `problem` as requested and validate the result.
    pub fn new(problem: &DdProblem, request: &PartitionRequest) -> Result<Partition, DdError> {
        let element_subdomain = match request {
            PartitionRequest::Automatic {
                subdomains,
                contact_layers,
            } => automatic(problem, Target::Count(*subdomains), *contact_layers),
            PartitionRequest::BySize {
                elements,
                contact_layers,
            } => automatic(problem, Target::Size(*elements), *contact_layers),
            PartitionRequest::Explicit(list) => split_disconnected(problem, list),
            PartitionRequest::Given(partition) => return Ok((**partition).clone()),
        };
        Partition::validate(problem, element_subdomain)
    }

    fn validate(problem: &DdProblem, element_subdomain: Vec<usize>) -> Result<Partition, DdError> {
        let ne = problem.elements.len();
        if element_subdomain.len() != ne {
            return Err(DdError::Partition(format!(
                "{} subdomain indices for {ne} elements",
                element_subdomain.len()
            )));
        }
        let n_subdomains = element_subdomain.iter().map(|&s| s + 1).max().unwrap_or(0);
        let mut body = vec![usize::MAX; n_subdomains];
        for (e, &s) in element_subdomain.iter().enumerate() {
            let b = problem.element_body(e);
            if body[s] != usize::MAX && body[s] != b {
                return Err(DdError::Partition(format!(
                    "subdomain {s} has elements of two bodies"
                )));
            }
            body[s] = b;
        }
        if let Some(s) = body.iter().position(|&b| b == usize::MAX) {
            return Err(DdError::Partition(format!("subdomain {s} is empty")));
        }
        let node_subdomains = node_subdomains(problem, &element_subdomain);
        let mut contact = vec![false; n_subdomains];
        for pair in &problem.pairs {
            for &node in &pair.nodes {
                match node_subdomains[node].as_slice() {
                    [s] => contact[*s] = true,
                    _ => {
                        let [x, y] = problem.nodes[node];
                        return Err(DdError::Partition(format!(
                            "contact node {node} at ({x:.6}, {y:.6}) lies on a subdomain interface \
                             (interfaces must not cut a contact zone)"
                        )));
                    }
                }
            }
        }
        for (node, subs) in node_subdomains.iter().enumerate() {
            if subs.len() > 1 && subs.iter().all(|&s| contact[s]) {
                return Err(DdError::Partition(format!(
                    "interface node {node} belongs only to contact subdomains {subs:?}; S0 would be singular there"
                )));
            }
        }
        Ok(Partition {
            element_subdomain,
            n_subdomains,
            contact,
        })
    }
}

/// Renumber so that every edge-connected piece of a subdomain is a subdomain of its own (a
/// piece glued to the rest at a vertex or not at all would bring extra kernel modes), numbered
/// in order of first appearance. Lists of the wrong length are left to the validation.
fn split_disconnected(problem: &DdProblem, element_subdomain: &[usize]) -> Vec<usize> {
    if element_subdomain.len() != problem.elements.len() {
        return element_subdomain.to_vec();
    }
    let edges = edge_neighbours(problem);
    let mut out = vec![UNSET; element_subdomain.len()];
    let mut next = 0;
    for start in 0..out.len() {
        if out[start] != UNSET {
            continue;
        }
        let s = element_subdomain[start];
        out[start] = next;
        let mut stack = vec![start];
        while let Some(e) = stack.pop() {
            for &f in &edges[e] {
                if out[f] == UNSET && element_subdomain[f] == s {
                    out[f] = next;
                    stack.push(f);
                }
            }
        }
        next += 1;
    }
    out
}

/// Sorted subdomains of the elements around each node.
pub fn node_subdomains(problem: &DdProblem, element_subdomain: &[usize]) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); problem.nodes.len()];
    for (e, el) in problem.elements.iter().enumerate() {
        for &n in &el.nodes {
            out[n].push(element_subdomain[e]);
        }
    }
    for v in &mut out {
        v.sort_unstable();
        v.dedup();
    }
    out
}

enum Target {
    Count(usize),
    Size(usize),
}

const UNSET: usize = usize::MAX;

fn automatic(problem: &DdProblem, target: Target, layers: usize) -> Vec<usize> {
    let ne = problem.elements.len();
    let node_elements = node_elements(problem);
    let mut sub = vec![UNSET; ne];
    let mut next = 0;
    // Floating bodies in contact: one subdomain each.
    let contact_bodies: Vec<usize> = problem
        .pairs
        .iter()
        .flat_map(|p| p.nodes.iter().map(|&n| problem.node_body[n]))
        .collect();
    for &b in &problem.floating_bodies {
        if contact_bodies.contains(&b) {
            for (e, s) in sub.iter_mut().enumerate() {
                if problem.element_body(e) == b {
                    *s = next;
                }
            }
            next += 1;
        }
    }
    // Bands of `layers` element layers around the contact nodes.
    let mut band = vec![false; ne];
    let mut front: Vec<usize> = problem
        .pairs
        .iter()
        .flat_map(|p| p.nodes.iter().copied())
        .collect();
    for _ in 0..layers.max(1) {
        let mut nodes = Vec::new();
        for &n in &front {
            for &e in &node_elements[n] {
                if sub[e] == UNSET && !band[e] {
                    band[e] = true;
                    nodes.extend(problem.elements[e].nodes);
                }
            }
        }
        front = nodes;
    }
    // Connected components of the band (sharing a node) → contact subdomains.
    for start in 0..ne {
        if band[start] && sub[start] == UNSET {
            flood(problem, &node_elements, start, next, &mut sub, |e| band[e]);
            next += 1;
        }
    }
    // The rest: edge-connected components, each cut by recursive inertial bisection.
    let edges = edge_neighbours(problem);
    let mut components = Vec::new();
    let mut comp = vec![UNSET; ne];
    for start in 0..ne {
        if sub[start] == UNSET && comp[start] == UNSET {
            let mut list = Vec::new();
            let mut stack = vec![start];
            comp[start] = components.len();
            while let Some(e) = stack.pop() {
                list.push(e);
                for &f in &edges[e] {
                    if sub[f] == UNSET && comp[f] == UNSET {
                        comp[f] = components.len();
                        stack.push(f);
                    }
                }
            }
            list.sort_unstable();
            components.push(list);
        }
    }
    let components = absorb_floating_pockets(problem, &edges, components, &mut sub);
    let rest: usize = components.iter().map(Vec::len).sum();
    let parts = allot(&components, &target, next, rest);
    let first_rest = next;
    for (list, &k) in components.iter().zip(&parts) {
        bisect(problem, list, k, &mut next, &mut sub);
    }
    make_connected(&edges, &mut sub, first_rest);
    renumber(&mut sub);
    sub
}

/// A component of the non-contact rest with no prescribed DOF (a pocket cut off by contact
/// bands, e.g. a few elements between a band and a free boundary) would float in S0, which
/// excludes the contact subdomains: S0 singular, the PCG2 coarse matrix too (D05 Lemma 7.1 needs
/// ⟨S0 u, u⟩ to be a norm). Such pockets join the contact subdomain they share most edges with
/// (or nodes, when they touch it at vertices only); the other components are returned.
fn absorb_floating_pockets(
    problem: &DdProblem,
    edges: &[Vec<usize>],
    components: Vec<Vec<usize>>,
    sub: &mut [usize],
) -> Vec<Vec<usize>> {
    let node_elements = node_elements(problem);
    let mut kept = Vec::with_capacity(components.len());
    for list in components {
        let anchored = list
            .iter()
            .any(|&e| problem.elements[e].dofs.iter().any(Option::is_none));
        let mut count: HashMap<usize, usize> = HashMap::new();
        for &e in &list {
            for &f in &edges[e] {
                if sub[f] != UNSET {
                    *count.entry(sub[f]).or_default() += 2 * problem.elements.len();
                }
            }
            for &n in &problem.elements[e].nodes {
                for &f in &node_elements[n] {
                    if sub[f] != UNSET {
                        *count.entry(sub[f]).or_default() += 1;
                    }
                }
            }
        }
        let best = count
            .into_iter()
            .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)));
        match best {
            Some((s, _)) if !anchored => list.iter().for_each(|&e| sub[e] = s),
            _ => kept.push(list),
        }
    }
    kept
}

/// Number of parts for each component (largest remainder, at least 1 each).
fn allot(components: &[Vec<usize>], target: &Target, used: usize, rest: usize) -> Vec<usize> {
    let total = match *target {
        Target::Count(n) => n.saturating_sub(used),
        Target::Size(size) => rest.div_ceil(size.max(1)),
    }
    .max(components.len());
    let mut parts: Vec<usize> = components
        .iter()
        .map(|c| (total * c.len() / rest.max(1)).max(1))
        .collect();
    let assigned: usize = parts.iter().sum();
    let mut order: Vec<usize> = (0..components.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(components[i].len()));
    for k in 0..total.saturating_sub(assigned) {
        parts[order[k % order.len()]] += 1;
    }
    parts
}

fn centroid(problem: &DdProblem, e: usize) -> [f64; 2] {
    let [a, b, c] = problem.elements[e].nodes;
    let (pa, pb, pc) = (problem.nodes[a], problem.nodes[b], problem.nodes[c]);
    [(pa[0] + pb[0] + pc[0]) / 3.0, (pa[1] + pb[1] + pc[1]) / 3.0]
}

/// Recursive inertial bisection of `list` into `k` parts numbered from `*next`.
fn bisect(problem: &DdProblem, list: &[usize], k: usize, next: &mut usize, sub: &mut [usize]) {
    if k <= 1 || list.len() < 2 {
        for &e in list {
            sub[e] = *next;
        }
        *next += 1;
        return;
    }
    let pts: Vec<[f64; 2]> = list.iter().map(|&e| centroid(problem, e)).collect();
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p[0]).sum::<f64>() / n;
    let my = pts.iter().map(|p| p[1]).sum::<f64>() / n;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in &pts {
        let (dx, dy) = (p[0] - mx, p[1] - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    // Principal axis of the 2×2 covariance.
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let axis = [angle.cos(), angle.sin()];
    let mut order: Vec<(f64, usize)> = pts
        .iter()
        .zip(list)
        .map(|(p, &e)| (p[0] * axis[0] + p[1] * axis[1], e))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let k1 = k / 2;
    let cut = list.len() * k1 / k;
    let left: Vec<usize> = order[..cut].iter().map(|x| x.1).collect();
    let right: Vec<usize> = order[cut..].iter().map(|x| x.1).collect();
    bisect(problem, &left, k1, next, sub);
    bisect(problem, &right, k - k1, next, sub);
}

/// Give every edge-disconnected piece of a subdomain numbered ≥ `first` (except its largest) to
/// the neighbouring subdomain (≥ `first`) it shares most edges with.
fn make_connected(edges: &[Vec<usize>], sub: &mut [usize], first: usize) {
    for _ in 0..8 {
        let mut changed = false;
        let mut seen = vec![false; sub.len()];
        let mut pieces: HashMap<usize, Vec<Vec<usize>>> = HashMap::new();
        for start in 0..sub.len() {
            if sub[start] < first || seen[start] {
                continue;
            }
            let s = sub[start];
            let mut piece = vec![start];
            seen[start] = true;
            let mut i = 0;
            while i < piece.len() {
                for &f in &edges[piece[i]] {
                    if sub[f] == s && !seen[f] {
                        seen[f] = true;
                        piece.push(f);
                    }
                }
                i += 1;
            }
            pieces.entry(s).or_default().push(piece);
        }
        let mut keys: Vec<usize> = pieces.keys().copied().collect();
        keys.sort_unstable();
        for s in keys {
            let mut list = pieces.remove(&s).unwrap_or_default();
            if list.len() < 2 {
                continue;
            }
            list.sort_by_key(|p| std::cmp::Reverse(p.len()));
            for piece in &list[1..] {
                let mut count: HashMap<usize, usize> = HashMap::new();
                for &e in piece {
                    for &f in &edges[e] {
                        if sub[f] != s && sub[f] >= first {
                            *count.entry(sub[f]).or_default() += 1;
                        }
                    }
                }
                let best = count
                    .into_iter()
                    .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)));
                if let Some((t, _)) = best {
                    for &e in piece {
                        sub[e] = t;
                    }
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
}

/// Number subdomains 0.. in order of first appearance of their number (removes gaps).
fn renumber(sub: &mut [usize]) {
    let mut ids: Vec<usize> = sub.to_vec();
    ids.sort_unstable();
    ids.dedup();
    let map: HashMap<usize, usize> = ids.iter().enumerate().map(|(i, &s)| (s, i)).collect();
    for s in sub.iter_mut() {
        *s = map[s];
    }
}

fn node_elements(problem: &DdProblem) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); problem.nodes.len()];
    for (e, el) in problem.elements.iter().enumerate() {
        for &n in &el.nodes {
            out[n].push(e);
        }
    }
    out
}

/// Elements sharing an edge with each element.
fn edge_neighbours(problem: &DdProblem) -> Vec<Vec<usize>> {
    let mut by_edge: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for (e, el) in problem.elements.iter().enumerate() {
        let [a, b, c] = el.nodes;
        for (p, q) in [(a, b), (b, c), (c, a)] {
            by_edge.entry((p.min(q), p.max(q))).or_default().push(e);
        }
    }
    let mut out = vec![Vec::new(); problem.elements.len()];
    for list in by_edge.values() {
        for &e in list {
            out[e].extend(list.iter().copied().filter(|&f| f != e));
        }
    }
    for v in &mut out {
        v.sort_unstable();
    }
    out
}

/// Assign `id` to the elements reachable from `start` through shared nodes (nodes belong to one
/// body) among those with `member(e)`.
fn flood(
    problem: &DdProblem,
    node_elements: &[Vec<usize>],
    start: usize,
    id: usize,
    sub: &mut [usize],
    member: impl Fn(usize) -> bool,
) {
    let mut stack = vec![start];
    sub[start] = id;
    while let Some(e) = stack.pop() {
        for &n in &problem.elements[e].nodes {
            for &f in &node_elements[n] {
                if sub[f] == UNSET && member(f) {
                    sub[f] = id;
                    stack.push(f);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dd::bench::two_blocks;

    #[test]
    fn floating_pockets_join_the_contact_subdomain_they_touch() {
        // Two blocks, lower clamped at its bottom, upper pushed at its top; the bands of the
        // contact zone are subdomains 0 (lower body) and 1 (upper body).
        let problem = two_blocks(16, 0.0, 0.0).expect("problem");
        let ne = problem.elements.len();
        let node_elements = node_elements(&problem);
        let edges = edge_neighbours(&problem);
        let mut sub = vec![UNSET; ne];
        let mut front: Vec<usize> = problem
            .pairs
            .iter()
            .flat_map(|p| p.nodes.iter().copied())
            .collect();
        let mut band = vec![false; ne];
        for _ in 0..2 {
            let mut nodes = Vec::new();
            for &n in &front {
                for &e in &node_elements[n] {
                    if !band[e] {
                        band[e] = true;
                        nodes.extend(problem.elements[e].nodes);
                    }
                }
            }
            front = nodes;
        }
        for e in 0..ne {
            if band[e] {
                sub[e] = problem.element_body(e);
            }
        }
        // A pocket: the free-standing rest elements of the upper body right above its band
        // (no prescribed DOF); an anchored component: everything else.
        let anchored = |e: usize| problem.elements[e].dofs.iter().any(Option::is_none);
        let pocket: Vec<usize> = (0..ne)
            .filter(|&e| {
                sub[e] == UNSET
                    && problem.element_body(e) == 1
                    && !anchored(e)
                    && edges[e].iter().any(|&f| band[f])
            })
            .take(5)
            .collect();
        assert!(!pocket.is_empty());
        let rest: Vec<usize> = (0..ne)
            .filter(|&e| sub[e] == UNSET && !pocket.contains(&e))
            .collect();
        assert!(rest.iter().any(|&e| anchored(e)));
        let kept = absorb_floating_pockets(
            &problem,
            &edges,
            vec![pocket.clone(), rest.clone()],
            &mut sub,
        );
        assert_eq!(kept, vec![rest]);
        assert!(pocket.iter().all(|&e| sub[e] == 1));
    }
}
