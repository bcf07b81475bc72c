//! ParaView-readable VTK XML unstructured grid (.vtu, ASCII) of a mesh with point and cell
//! fields.

use crate::mesh::Mesh;
use std::fmt::Write;

/// A named field: one value per point (or cell) with `components` numbers each.
pub struct Field<'a> {
    /// The `Name` of the VTK data array.
    pub name: &'a str,
    /// Numbers per point or cell (1 for a scalar, 3 for a vector).
    pub components: usize,
    /// The values, point- or cell-major: `components` numbers per entry.
    pub values: Vec<f64>,
}

/// Render the mesh and fields as a .vtu document.
pub fn write_vtu(mesh: &Mesh, point_fields: &[Field], cell_fields: &[Field]) -> String {
    let mut s = String::new();
    let (np, nc) = (mesh.nodes.len(), mesh.triangles.len());
    s.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n");
    let _ = writeln!(s, "<Piece NumberOfPoints=\"{np}\" NumberOfCells=\"{nc}\">");
    s.push_str(
        "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
    );
    for p in &mesh.nodes {
        let _ = writeln!(s, "{:e} {:e} 0", p[0], p[1]);
    }
    s.push_str("</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
    for t in &mesh.triangles {
        let _ = writeln!(s, "{} {} {}", t[0], t[1], t[2]);
    }
    s.push_str("</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
    for k in 0..nc {
        let _ = write!(s, "{} ", 3 * (k + 1));
    }
    s.push_str("\n</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
    s.push_str(&"5 ".repeat(nc));
    s.push_str("\n</DataArray>\n</Cells>\n");
    write_fields(&mut s, "PointData", point_fields);
    write_fields(&mut s, "CellData", cell_fields);
    s.push_str("</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    s
}

fn write_fields(s: &mut String, tag: &str, fields: &[Field]) {
    let _ = writeln!(s, "<{tag}>");
    for f in fields {
        let _ = writeln!(
            s,
            "<DataArray type=\"Float64\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"ascii\">",
            f.name, f.components
        );
        for chunk in f.values.chunks(f.components.max(1)) {
            let line: Vec<String> = chunk.iter().map(|v| format!("{v:e}")).collect();
            let _ = writeln!(s, "{}", line.join(" "));
        }
        s.push_str("</DataArray>\n");
    }
    let _ = writeln!(s, "</{tag}>");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vtu_has_counts_and_fields() {
        let mesh = Mesh {
            nodes: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            triangles: vec![[0, 1, 2]],
            triangle_zone: vec![0],
            ..Default::default()
        };
        let u = Field {
            name: "displacement",
            components: 3,
            values: vec![0.0; 9],
        };
        let z = Field {
            name: "zone",
            components: 1,
            values: vec![0.0],
        };
        let text = write_vtu(&mesh, &[u], &[z]);
        assert!(text.contains("NumberOfPoints=\"3\" NumberOfCells=\"1\""));
        assert!(text.contains("Name=\"displacement\" NumberOfComponents=\"3\""));
        assert!(text.contains("<CellData>") && text.contains("Name=\"zone\""));
        assert_eq!(text.matches("<DataArray").count(), 6);
    }
}
