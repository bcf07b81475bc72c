//! The mesh given in the scene (`mesh.inline`, design §2.5): its indices and names are checked
//! against its own arrays and the scene (errors name `mesh.inline.triangles[17]` and the like),
//! then it goes the way of an imported Gmsh mesh (`import`).

use super::import::{import, zone_numbers, Imported, Places};
use super::Mesh;
use crate::scene::{InlineMesh, Scene, SceneError};

const PATH: &str = "mesh.inline";

/// The scene's mesh from `mesh.inline`.
pub(crate) fn import_inline(inline: &InlineMesh, scene: &Scene) -> Result<Mesh, SceneError> {
    let n = inline.nodes.len();
    if let Some(i) = inline
        .nodes
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(SceneError::new(
            format!("{PATH}.nodes[{i}]"),
            "coordinates must be finite numbers",
        ));
    }
    if inline.triangles.is_empty() {
        return Err(SceneError::new(
            format!("{PATH}.triangles"),
            "the mesh has no triangles",
        ));
    }
    if inline.triangle_zones.len() != inline.triangles.len() {
        return Err(SceneError::new(
            format!("{PATH}.triangle_zones"),
            format!(
                "one zone index per triangle: {} given for {} triangles",
                inline.triangle_zones.len(),
                inline.triangles.len()
            ),
        ));
    }
    let out_of_range = |path: String, index: usize| {
        SceneError::new(
            path,
            format!(
                "node index {index} is out of range (the mesh has {n} nodes, 0 to {})",
                n.saturating_sub(1)
            ),
        )
    };
    for (t, tri) in inline.triangles.iter().enumerate() {
        if let Some(&i) = tri.iter().find(|&&i| i >= n) {
            return Err(out_of_range(format!("{PATH}.triangles[{t}]"), i));
        }
    }
    let zone_of_name = zone_numbers(scene)?;
    let zone_of_index = inline
        .zones
        .iter()
        .enumerate()
        .map(|(k, name)| {
            zone_of_name.get(name.as_str()).copied().ok_or_else(|| {
                SceneError::new(
                    format!("{PATH}.zones[{k}]"),
                    format!("no zone of the scene is named '{name}'"),
                )
            })
        })
        .collect::<Result<Vec<usize>, _>>()?;
    let zone = inline
        .triangle_zones
        .iter()
        .enumerate()
        .map(|(t, &k)| {
            zone_of_index.get(k).copied().ok_or_else(|| {
                SceneError::new(
                    format!("{PATH}.triangle_zones[{t}]"),
                    format!(
                        "zone index {k} is out of range ({} zone names given)",
                        inline.zones.len()
                    ),
                )
            })
        })
        .collect::<Result<Vec<usize>, _>>()?;
    let mut m = Imported {
        nodes: inline.nodes.clone(),
        triangles: inline.triangles.clone(),
        zone,
        ..Imported::default()
    };
    let mut places = InlinePlaces::default();
    for (name, edges) in &inline.segments {
        let mut lines = Vec::with_capacity(edges.len());
        for (k, &[a, b]) in edges.iter().enumerate() {
            let path = format!("{PATH}.segments.{name}[{k}]");
            if let Some(&i) = [a, b].iter().find(|&&i| i >= n) {
                return Err(out_of_range(path, i));
            }
            lines.push(m.lines.len());
            m.lines.push([a, b]);
            places.lines.push(path);
        }
        m.curves.insert(name.clone(), lines);
    }
    import(m, scene, &places)
}

/// JSON paths of the inline mesh's parts.
#[derive(Default)]
struct InlinePlaces {
    /// The path of every line, `mesh.inline.segments.NAME[k]`.
    lines: Vec<String>,
}

impl Places for InlinePlaces {
    fn source(&self) -> &'static str {
        "the inline mesh"
    }

    fn triangle_kind(&self) -> &'static str {
        "triangle"
    }

    fn triangle_id(&self, t: usize) -> String {
        t.to_string()
    }

    fn node_id(&self, n: usize) -> String {
        n.to_string()
    }

    fn line(&self, l: usize) -> String {
        format!("the edge {}", self.lines[l])
    }

    fn at_triangle(&self, t: usize, reason: String) -> SceneError {
        SceneError::new(format!("{PATH}.triangles[{t}]"), reason)
    }

    fn at_line(&self, l: usize, reason: String) -> SceneError {
        SceneError::new(self.lines[l].clone(), reason)
    }
}
