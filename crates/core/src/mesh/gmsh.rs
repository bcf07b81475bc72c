//! Import of a Gmsh mesh (`mesh.gmsh_file`, design §2.5) instead of meshing the scene's
//! polygons: the file is read by `msh` (MSH 4.1 or 2.2, ASCII or binary); physical names of
//! surfaces are zone names of the scene, physical names of curves give the edges of the scene
//! segment of the same name. The mesh is then checked and built by `import`, whose errors name
//! the file's line (or byte offset) and its element and node tags.

use std::collections::BTreeMap;

use super::geom::orient;
use super::import::{import, zone_numbers, Imported, Places};
use super::msh::{self, Msh};
use super::Mesh;
use crate::scene::{InlineMesh, Scene, SceneError};

/// Reads an MSH file (4.1 or 2.2, ASCII or binary) whose physical names match the scene's zones
/// and segments.
pub fn import_gmsh(file: impl AsRef<[u8]>, scene: &Scene) -> Result<Mesh, SceneError> {
    let msh = msh::parse(file.as_ref())?;
    import(imported(&msh, scene)?, scene, &msh)
}

/// The scene with its Gmsh mesh (`mesh.gmsh_file`, read and checked) given inline instead
/// (`mesh.inline`): the file's nodes in file order, its triangles counter-clockwise with their
/// zones, and the line elements of the physical curves named like scene segments. The inline
/// scene meshes to the same mesh, so it gives the same results.
pub fn with_inline_mesh(scene: &Scene) -> Result<Scene, SceneError> {
    let file = scene.mesh.gmsh_file.as_ref().ok_or_else(|| {
        SceneError::new(
            "mesh.gmsh_file",
            "the scene has no Gmsh mesh to give inline",
        )
    })?;
    let bytes = std::fs::read(file)
        .map_err(|e| SceneError::new("mesh.gmsh_file", format!("cannot read '{file}': {e}")))?;
    let msh = msh::parse(&bytes)?;
    let mut m = imported(&msh, scene)?;
    // The same checks as an import (errors name the file's lines and tags).
    import(m.clone(), scene, &msh)?;
    for tri in &mut m.triangles {
        if orient(m.nodes[tri[0]], m.nodes[tri[1]], m.nodes[tri[2]]) < 0.0 {
            tri.swap(1, 2);
        }
    }
    let zones: Vec<String> = scene
        .bodies
        .iter()
        .flat_map(|b| b.zones.iter().map(|z| z.name.clone()))
        .collect();
    let segments = m
        .curves
        .iter()
        .filter(|(name, _)| scene.segments.contains_key(*name))
        .map(|(name, lines)| (name.clone(), lines.iter().map(|&l| m.lines[l]).collect()))
        .collect();
    let mut out = scene.clone();
    out.mesh.gmsh_file = None;
    out.mesh.inline = Some(InlineMesh {
        nodes: m.nodes,
        triangles: m.triangles,
        zones,
        triangle_zones: m.zone,
        segments,
    });
    Ok(out)
}

/// The file's mesh mapped onto the scene: triangles in the zone their surface's physical name
/// names, lines grouped by their curve's physical names.
fn imported(msh: &Msh, scene: &Scene) -> Result<Imported, SceneError> {
    let zone_of_name = zone_numbers(scene)?;
    let node = |tag: usize, at: usize| msh.node(tag, at);
    let mut m = Imported {
        nodes: msh.nodes.clone(),
        ..Imported::default()
    };
    for el in &msh.triangles {
        let names = msh.names_of(2, el.entity);
        let zone = names
            .iter()
            .find_map(|n| zone_of_name.get(n).copied())
            .ok_or_else(|| {
                msh.err(
                    el.at,
                    format!(
                        "surface {} (physical names {names:?}) matches no zone of the scene",
                        el.entity
                    ),
                )
            })?;
        let [a, b, c] = el.nodes;
        m.triangles
            .push([node(a, el.at)?, node(b, el.at)?, node(c, el.at)?]);
        m.zone.push(zone);
    }
    let mut curves: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (l, el) in msh.lines.iter().enumerate() {
        let [a, b] = el.nodes;
        m.lines.push([node(a, el.at)?, node(b, el.at)?]);
        for name in msh.names_of(1, el.entity) {
            curves.entry(name.to_string()).or_default().push(l);
        }
    }
    m.curves = curves;
    Ok(m)
}

impl Places for Msh<'_> {
    fn source(&self) -> &'static str {
        "the Gmsh file"
    }

    fn triangle_kind(&self) -> &'static str {
        "triangle element"
    }

    fn triangle_id(&self, t: usize) -> String {
        self.triangles[t].tag.to_string()
    }

    fn node_id(&self, n: usize) -> String {
        self.node_tags[n].to_string()
    }

    fn line(&self, l: usize) -> String {
        format!("line element {}", self.lines[l].tag)
    }

    fn at_triangle(&self, t: usize, reason: String) -> SceneError {
        self.err(self.triangles[t].at, reason)
    }

    fn at_line(&self, l: usize, reason: String) -> SceneError {
        self.err(self.lines[l].at, reason)
    }
}
