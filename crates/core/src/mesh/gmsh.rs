//! Import of a Gmsh mesh (MSH 4.1, ASCII) instead of meshing the scene's polygons.
//!
//! The sections `$MeshFormat`, `$PhysicalNames`, `$Entities`, `$Nodes` and `$Elements` are read
//! by a small hand parser (other sections are skipped). Only 3-node triangles (type 2), 2-node
//! lines (type 1) and points (type 15, ignored) are accepted. Physical names of surfaces are
//! zone names of the scene; physical names of curves give the edges of the scene segment of the
//! same name. Node splitting, segments and contacts are shared with the mesher (`assemble`).
//!
//! The imported mesh is checked before the FEM sees it (`check::connectivity`, `hanging_node`):
//! triangles of either orientation are turned counter-clockwise, a triangle with no area, two
//! triangles folded over one edge (or an edge of three triangles), a node lying inside another
//! element's edge of the same body, and a line element of a used physical curve that is no
//! triangle edge are refused with the file's line, element and node tags. Nodes used by no
//! triangle (a circle's centre point, say) are not part of the FE model and are dropped.

use std::collections::{BTreeMap, HashMap};

use super::assemble::{finish, mesh_zones, RawMesh};
use super::check::{self, Defect};
use super::geom::{orient, P};
use super::rows::Rows;
use super::{Mesh, MeshZone};
use crate::scene::{Scene, SceneError};

const PATH: &str = "mesh.gmsh_file";

fn err(line: usize, reason: impl std::fmt::Display) -> SceneError {
    SceneError::new(PATH, format!("line {line}: {reason}"))
}

/// Whitespace-separated tokens of a section, with their line numbers.
struct Tokens<'a> {
    items: Vec<(usize, &'a str)>,
    pos: usize,
    end_line: usize,
}

impl<'a> Tokens<'a> {
    fn new(lines: &[(usize, &'a str)], end_line: usize) -> Tokens<'a> {
        let items = lines
            .iter()
            .flat_map(|&(n, l)| l.split_whitespace().map(move |t| (n, t)))
            .collect();
        Tokens {
            items,
            pos: 0,
            end_line,
        }
    }

    fn next<T: std::str::FromStr>(&mut self, what: &str) -> Result<T, SceneError> {
        let Some(&(line, tok)) = self.items.get(self.pos) else {
            return Err(err(
                self.end_line,
                format!("section ends early, expected {what}"),
            ));
        };
        self.pos += 1;
        tok.parse()
            .map_err(|_| err(line, format!("expected {what}, found '{tok}'")))
    }

    fn line(&self) -> usize {
        self.items.get(self.pos).map_or(self.end_line, |t| t.0)
    }

    fn skip(&mut self, n: usize) {
        self.pos += n;
    }
}

/// The parts of an MSH file the import uses.
#[derive(Default)]
struct Msh {
    /// (dimension, physical tag) → name.
    names: HashMap<(i32, i32), String>,
    /// (dimension, entity tag) → physical tags.
    physical: HashMap<(i32, i32), Vec<i32>>,
    nodes: Vec<P>,
    /// The file's tag of every node.
    node_tags: Vec<usize>,
    node_index: HashMap<usize, usize>,
    triangles: Vec<Element<3>>,
    lines: Vec<Element<2>>,
}

/// An element of the file.
struct Element<const N: usize> {
    /// The entity (surface or curve) it belongs to.
    entity: i32,
    nodes: [usize; N],
    /// Its line in the file and its element tag.
    line: usize,
    tag: usize,
}

/// Reads an MSH 4.1 ASCII mesh whose physical names match the scene's zones and segments.
pub fn import_gmsh(text: &str, scene: &Scene) -> Result<Mesh, SceneError> {
    let msh = parse(text)?;
    let zones = mesh_zones(scene)?;
    let raw = msh.zoned_triangles(&zone_numbers(scene)?)?;
    check_zones_present(scene, &raw)?;
    let edges = check::connectivity(&raw.nodes, &raw.triangles).map_err(|d| defect(&msh, d))?;
    check_hanging_nodes(&msh, scene, &zones, &raw)?;
    let curves = msh.curves(scene, &edges)?;
    finish(scene, raw, zones, &curves)
}

/// The mesh zone number of every zone name (zones numbered body by body); the names must be
/// unique, since the file's physical names refer to them.
fn zone_numbers(scene: &Scene) -> Result<HashMap<&str, usize>, SceneError> {
    let mut zone_of_name: HashMap<&str, usize> = HashMap::new();
    let mut z = 0;
    for (b, body) in scene.bodies.iter().enumerate() {
        for (k, zone) in body.zones.iter().enumerate() {
            if zone_of_name.insert(zone.name.as_str(), z).is_some() {
                return Err(SceneError::new(
                    format!("bodies[{b}].zones[{k}].name"),
                    "zone names must be unique when the mesh comes from a Gmsh file",
                ));
            }
            z += 1;
        }
    }
    Ok(zone_of_name)
}

/// No hanging node inside any one body (bodies in contact may have non-matching meshes).
fn check_hanging_nodes(
    msh: &Msh,
    scene: &Scene,
    zones: &[MeshZone],
    raw: &RawMesh,
) -> Result<(), SceneError> {
    for b in 0..scene.bodies.len() {
        let tris: Vec<[usize; 3]> = (0..raw.triangles.len())
            .filter(|&t| zones[raw.zone[t]].body == b)
            .map(|t| raw.triangles[t])
            .collect();
        if let Some(Defect::Hanging(n, t, e)) = check::hanging_node(&raw.nodes, &tris) {
            let t = raw
                .triangles
                .iter()
                .position(|x| *x == tris[t])
                .unwrap_or(0);
            return Err(defect(msh, Defect::Hanging(n, t, e)));
        }
    }
    Ok(())
}

impl Msh {
    /// The physical names of an entity of dimension `dim`.
    fn names_of(&self, dim: i32, entity: i32) -> Vec<&str> {
        self.physical
            .get(&(dim, entity))
            .into_iter()
            .flatten()
            .filter_map(|t| self.names.get(&(dim, *t)).map(String::as_str))
            .collect()
    }

    /// The index of the node with the file's tag `tag` (referred to on `line`).
    fn node(&self, tag: usize, line: usize) -> Result<usize, SceneError> {
        self.node_index
            .get(&tag)
            .copied()
            .ok_or_else(|| err(line, format!("unknown node {tag}")))
    }

    /// The triangles, counter-clockwise, each in the zone its surface's physical name names.
    fn zoned_triangles(&self, zone_of_name: &HashMap<&str, usize>) -> Result<RawMesh, SceneError> {
        let mut raw = RawMesh {
            nodes: self.nodes.clone(),
            ..RawMesh::default()
        };
        for &Element {
            entity,
            nodes: tags,
            line,
            ..
        } in &self.triangles
        {
            let names = self.names_of(2, entity);
            let zone = names
                .iter()
                .find_map(|n| zone_of_name.get(n).copied())
                .ok_or_else(|| {
                    err(
                        line,
                        format!(
                            "surface {entity} (physical names {names:?}) matches no zone of the scene"
                        ),
                    )
                })?;
            let [a, b, c] = [
                self.node(tags[0], line)?,
                self.node(tags[1], line)?,
                self.node(tags[2], line)?,
            ];
            // Either orientation is accepted; the mesh is kept counter-clockwise.
            let ccw = orient(raw.nodes[a], raw.nodes[b], raw.nodes[c]) >= 0.0;
            raw.triangles.push(if ccw { [a, b, c] } else { [a, c, b] });
            raw.zone.push(zone);
        }
        Ok(raw)
    }

    /// The line elements of every physical curve; those of the scene's segments must be
    /// triangle edges (`edges`: the mesh's node adjacency).
    fn curves(
        &self,
        scene: &Scene,
        edges: &Rows,
    ) -> Result<BTreeMap<String, Vec<[usize; 2]>>, SceneError> {
        let mut curves: BTreeMap<String, Vec<[usize; 2]>> = BTreeMap::new();
        for el in &self.lines {
            let [a, b] = [
                self.node(el.nodes[0], el.line)?,
                self.node(el.nodes[1], el.line)?,
            ];
            for name in self.names_of(1, el.entity) {
                let is_edge = edges.row(a).contains(&b) || edges.row(b).contains(&a);
                if !is_edge && scene.segments.contains_key(name) {
                    return Err(err(
                        el.line,
                        format!(
                            "line element {} of the physical curve '{name}' joins nodes {} and {}, \
                             which are not two corners of one triangle: the curve does not conform \
                             to the surface mesh",
                            el.tag, el.nodes[0], el.nodes[1]
                        ),
                    ));
                }
                curves.entry(name.to_string()).or_default().push([a, b]);
            }
        }
        Ok(curves)
    }
}

/// The error for a connectivity defect, naming the file's element and node tags.
fn defect(msh: &Msh, d: Defect) -> SceneError {
    let el = |t: usize| &msh.triangles[t];
    let tag = |n: usize| msh.node_tags[n];
    match d {
        Defect::Degenerate(t) => err(
            el(t).line,
            format!(
                "triangle element {} (nodes {:?}) is degenerate: its corners are repeated or \
                 collinear, so it has no area",
                el(t).tag,
                el(t).nodes
            ),
        ),
        Defect::Overlap([s, t], [a, b]) => err(
            el(t).line,
            format!(
                "triangle elements {} (line {}) and {} lie on the same side of the edge between \
                 nodes {} and {}: they overlap (a folded or duplicated element), or the edge \
                 belongs to more than two triangles",
                el(s).tag,
                el(s).line,
                el(t).tag,
                tag(a),
                tag(b)
            ),
        ),
        Defect::Hanging(n, t, [a, b]) => err(
            el(t).line,
            format!(
                "node {} lies on the edge between nodes {} and {} of triangle element {} \
                 without being one of its corners (a hanging node): neighbouring elements must \
                 share their nodes along every edge",
                tag(n),
                tag(a),
                tag(b),
                el(t).tag
            ),
        ),
    }
}

/// Every scene zone must have triangles.
fn check_zones_present(scene: &Scene, raw: &RawMesh) -> Result<(), SceneError> {
    let mut present = vec![false; scene.bodies.iter().map(|b| b.zones.len()).sum()];
    for &z in &raw.zone {
        present[z] = true;
    }
    let mut z = 0;
    for (b, body) in scene.bodies.iter().enumerate() {
        for (k, zone) in body.zones.iter().enumerate() {
            if !present[z] {
                return Err(SceneError::new(
                    format!("bodies[{b}].zones[{k}]"),
                    format!(
                        "the Gmsh file has no triangles in a physical surface named '{}'",
                        zone.name
                    ),
                ));
            }
            z += 1;
        }
    }
    Ok(())
}

/// Splits the text into sections and parses the known ones.
fn parse(text: &str) -> Result<Msh, SceneError> {
    let lines: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .collect();
    let mut msh = Msh::default();
    let mut seen_format = false;
    let mut i = 0;
    while i < lines.len() {
        let (n, l) = lines[i];
        if l.is_empty() {
            i += 1;
            continue;
        }
        let Some(name) = l.strip_prefix('$') else {
            return Err(err(n, format!("expected a section start, found '{l}'")));
        };
        let end = format!("$End{name}");
        let close = lines[i + 1..]
            .iter()
            .position(|&(_, x)| x == end)
            .map(|k| i + 1 + k)
            .ok_or_else(|| err(n, format!("section ${name} has no {end}")))?;
        let body = &lines[i + 1..close];
        let end_line = lines[close].0;
        match name {
            "MeshFormat" => {
                format(Tokens::new(body, end_line))?;
                seen_format = true;
            }
            "PhysicalNames" => physical_names(body, end_line, &mut msh)?,
            "Entities" => entities(Tokens::new(body, end_line), &mut msh)?,
            "Nodes" => nodes(Tokens::new(body, end_line), &mut msh)?,
            "Elements" => elements(Tokens::new(body, end_line), &mut msh)?,
            _ => {}
        }
        i = close + 1;
    }
    if !seen_format {
        return Err(SceneError::new(
            PATH,
            "not a Gmsh .msh file (no $MeshFormat section)",
        ));
    }
    if msh.triangles.is_empty() {
        return Err(SceneError::new(PATH, "the file has no 3-node triangles"));
    }
    Ok(msh)
}

fn format(mut t: Tokens) -> Result<(), SceneError> {
    let line = t.line();
    let version: String = t.next("the format version")?;
    let file_type: u32 = t.next("the file type")?;
    if version != "4.1" {
        return Err(err(
            line,
            format!("MSH version {version} is not supported (only 4.1)"),
        ));
    }
    if file_type != 0 {
        return Err(err(
            line,
            "binary MSH files are not supported (save as ASCII)",
        ));
    }
    Ok(())
}

fn physical_names(
    body: &[(usize, &str)],
    end_line: usize,
    msh: &mut Msh,
) -> Result<(), SceneError> {
    let mut rows = body.iter().filter(|(_, l)| !l.is_empty());
    let count: usize = match rows.next() {
        Some(&(n, l)) => l
            .parse()
            .map_err(|_| err(n, "expected the number of physical names"))?,
        None => return Err(err(end_line, "empty $PhysicalNames section")),
    };
    for _ in 0..count {
        let &(n, l) = rows
            .next()
            .ok_or_else(|| err(end_line, "fewer physical names than announced"))?;
        let mut parts = l.splitn(3, char::is_whitespace);
        let dim = parts.next().and_then(|x| x.parse::<i32>().ok());
        let tag = parts.next().and_then(|x| x.parse::<i32>().ok());
        let name = parts.next().map(|x| x.trim().trim_matches('"').to_string());
        match (dim, tag, name) {
            (Some(d), Some(t), Some(name)) => {
                msh.names.insert((d, t), name);
            }
            _ => return Err(err(n, "expected `dimension tag \"name\"`")),
        }
    }
    Ok(())
}

fn entities(mut t: Tokens, msh: &mut Msh) -> Result<(), SceneError> {
    let counts: [usize; 4] = [
        t.next("the number of points")?,
        t.next("the number of curves")?,
        t.next("the number of surfaces")?,
        t.next("the number of volumes")?,
    ];
    for (dim, &count) in counts.iter().enumerate() {
        for _ in 0..count {
            let tag: i32 = t.next("an entity tag")?;
            // Points have one coordinate triple, other entities a bounding box.
            t.skip(if dim == 0 { 3 } else { 6 });
            let np: usize = t.next("the number of physical tags")?;
            let tags = (0..np)
                .map(|_| t.next::<i32>("a physical tag"))
                .collect::<Result<Vec<_>, _>>()?;
            msh.physical
                .insert((dim as i32, tag), tags.iter().map(|x| x.abs()).collect());
            if dim > 0 {
                let nb: usize = t.next("the number of bounding entities")?;
                t.skip(nb);
            }
        }
    }
    Ok(())
}

fn nodes(mut t: Tokens, msh: &mut Msh) -> Result<(), SceneError> {
    let blocks: usize = t.next("the number of node blocks")?;
    t.skip(3);
    for _ in 0..blocks {
        let dim: usize = t.next("the entity dimension")?;
        t.skip(1);
        let parametric: usize = t.next("the parametric flag")?;
        let n: usize = t.next("the number of nodes")?;
        let tags = (0..n)
            .map(|_| t.next::<usize>("a node tag"))
            .collect::<Result<Vec<_>, _>>()?;
        for tag in tags {
            let line = t.line();
            let x: f64 = t.next("x")?;
            let y: f64 = t.next("y")?;
            t.skip(1 + if parametric == 1 { dim } else { 0 });
            if !x.is_finite() || !y.is_finite() {
                return Err(err(line, "non-finite node coordinate"));
            }
            if msh.node_index.insert(tag, msh.nodes.len()).is_some() {
                return Err(err(line, format!("node {tag} is defined twice")));
            }
            msh.nodes.push([x, y]);
            msh.node_tags.push(tag);
        }
    }
    Ok(())
}

fn elements(mut t: Tokens, msh: &mut Msh) -> Result<(), SceneError> {
    let blocks: usize = t.next("the number of element blocks")?;
    t.skip(3);
    for _ in 0..blocks {
        let line = t.line();
        t.skip(1);
        let entity: i32 = t.next("the entity tag")?;
        let kind: u32 = t.next("the element type")?;
        let n: usize = t.next("the number of elements")?;
        let per = match kind {
            1 => 2,
            2 => 3,
            15 => 1,
            _ => {
                return Err(err(
                    line,
                    format!(
                    "element type {kind} is not supported (only 3-node triangles, 2-node lines)"
                ),
                ))
            }
        };
        for _ in 0..n {
            let line = t.line();
            let tag: usize = t.next("an element tag")?;
            let v = (0..per)
                .map(|_| t.next::<usize>("a node tag"))
                .collect::<Result<Vec<_>, _>>()?;
            match kind {
                1 => msh.lines.push(Element {
                    entity,
                    nodes: [v[0], v[1]],
                    line,
                    tag,
                }),
                2 => msh.triangles.push(Element {
                    entity,
                    nodes: [v[0], v[1], v[2]],
                    line,
                    tag,
                }),
                _ => {}
            }
        }
    }
    Ok(())
}
