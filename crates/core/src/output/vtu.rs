//! VTK XML unstructured grid (.vtu) writer (design §5.6): points, mixed linear cells
//! (triangles and lines), point, cell and field data. Every array is inline binary
//! (`format="binary"`): the base64 encoding of one stream made of a `UInt64` byte count followed
//! by the values in little-endian order (`header_type="UInt64"`, no compression), which
//! ParaView, PyVista (VTK) and meshio all read.

use std::fmt::Write;

use base64::Engine;

/// The VTK cell types wsm writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellKind {
    /// `VTK_TRIANGLE` (5): three nodes, counter-clockwise.
    Triangle,
    /// `VTK_LINE` (3): two nodes.
    Line,
}

impl CellKind {
    /// The VTK cell type code.
    pub fn vtk_type(self) -> u8 {
        match self {
            CellKind::Triangle => 5,
            CellKind::Line => 3,
        }
    }

    /// Nodes per cell.
    pub fn nodes(self) -> usize {
        match self {
            CellKind::Triangle => 3,
            CellKind::Line => 2,
        }
    }
}

/// The numbers of a data array, with their VTK type.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// `Float64`.
    Float64(Vec<f64>),
    /// `Int32`.
    Int32(Vec<i32>),
    /// `Int64`.
    Int64(Vec<i64>),
    /// `UInt8` (also text: its UTF-8 bytes).
    UInt8(Vec<u8>),
}

impl Values {
    fn len(&self) -> usize {
        match self {
            Values::Float64(v) => v.len(),
            Values::Int32(v) => v.len(),
            Values::Int64(v) => v.len(),
            Values::UInt8(v) => v.len(),
        }
    }

    fn vtk_type(&self) -> &'static str {
        match self {
            Values::Float64(_) => "Float64",
            Values::Int32(_) => "Int32",
            Values::Int64(_) => "Int64",
            Values::UInt8(_) => "UInt8",
        }
    }

    /// The little-endian bytes of the values.
    fn bytes(&self) -> Vec<u8> {
        match self {
            Values::Float64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::Int32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::Int64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::UInt8(v) => v.clone(),
        }
    }
}

/// A named data array: `components` numbers per tuple.
#[derive(Debug, Clone, PartialEq)]
pub struct DataArray {
    /// The array's `Name`.
    pub name: String,
    /// Numbers per tuple: 1 for a scalar, 3 for a vector, 6 for a symmetric tensor.
    pub components: usize,
    /// The values, tuple-major.
    pub values: Values,
}

impl DataArray {
    /// A `Float64` array of `components` numbers per tuple.
    pub fn float(name: &str, components: usize, values: Vec<f64>) -> DataArray {
        DataArray {
            name: name.to_string(),
            components,
            values: Values::Float64(values),
        }
    }

    /// An `Int32` scalar array.
    pub fn int(name: &str, values: Vec<i32>) -> DataArray {
        DataArray {
            name: name.to_string(),
            components: 1,
            values: Values::Int32(values),
        }
    }

    /// A text as a `UInt8` array of its UTF-8 bytes (meshio 5 reads no VTK `String` arrays).
    pub fn text(name: &str, text: &str) -> DataArray {
        DataArray {
            name: name.to_string(),
            components: 1,
            values: Values::UInt8(text.as_bytes().to_vec()),
        }
    }

    /// Number of tuples.
    pub fn tuples(&self) -> usize {
        self.values.len() / self.components.max(1)
    }
}

/// An unstructured grid: points in 3D, cells of [`CellKind`]s, and data arrays.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Grid {
    /// Point coordinates \[m\].
    pub points: Vec<[f64; 3]>,
    /// The kind of each cell.
    pub cell_kinds: Vec<CellKind>,
    /// The cells' point indices, cell after cell (`kind.nodes()` each).
    pub connectivity: Vec<usize>,
    /// One tuple per point.
    pub point_data: Vec<DataArray>,
    /// One tuple per cell.
    pub cell_data: Vec<DataArray>,
    /// Arrays describing the whole grid (any number of tuples).
    pub field_data: Vec<DataArray>,
}

impl Grid {
    /// Append a cell.
    pub fn push_cell(&mut self, kind: CellKind, nodes: &[usize]) {
        debug_assert_eq!(nodes.len(), kind.nodes());
        self.cell_kinds.push(kind);
        self.connectivity.extend_from_slice(nodes);
    }
}

/// Render the grid as a .vtu document.
pub fn write_vtu(grid: &Grid) -> String {
    let mut s = String::new();
    s.push_str(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<UnstructuredGrid>\n",
    );
    if !grid.field_data.is_empty() {
        s.push_str("<FieldData>\n");
        for array in &grid.field_data {
            write_array(&mut s, array, true);
        }
        s.push_str("</FieldData>\n");
    }
    let _ = writeln!(
        s,
        "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
        grid.points.len(),
        grid.cell_kinds.len()
    );
    s.push_str("<Points>\n");
    let coordinates = grid.points.iter().flatten().copied().collect();
    write_array(&mut s, &DataArray::float("Points", 3, coordinates), false);
    s.push_str("</Points>\n<Cells>\n");
    let offsets = grid
        .cell_kinds
        .iter()
        .scan(0, |end, kind| {
            *end += kind.nodes() as i64;
            Some(*end)
        })
        .collect();
    let cells = [
        ("connectivity", Values::Int64(to_i64(&grid.connectivity))),
        ("offsets", Values::Int64(offsets)),
        (
            "types",
            Values::UInt8(grid.cell_kinds.iter().map(|k| k.vtk_type()).collect()),
        ),
    ];
    for (name, values) in cells {
        let array = DataArray {
            name: name.to_string(),
            components: 1,
            values,
        };
        write_array(&mut s, &array, false);
    }
    s.push_str("</Cells>\n");
    for (tag, arrays) in [
        ("PointData", &grid.point_data),
        ("CellData", &grid.cell_data),
    ] {
        let _ = writeln!(s, "<{tag}>");
        for array in arrays {
            write_array(&mut s, array, false);
        }
        let _ = writeln!(s, "</{tag}>");
    }
    s.push_str("</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    s
}

fn to_i64(values: &[usize]) -> Vec<i64> {
    values
        .iter()
        .map(|&v| i64::try_from(v).unwrap_or(i64::MAX))
        .collect()
}

/// One `<DataArray>` (`NumberOfComponents` for more than one); field data carries its
/// `NumberOfTuples`.
fn write_array(s: &mut String, array: &DataArray, field: bool) {
    let _ = write!(
        s,
        "<DataArray type=\"{}\" Name=\"{}\"",
        array.values.vtk_type(),
        xml_escape(&array.name),
    );
    // One component is VTK's default; left out, meshio reads a scalar as a 1-D array.
    if array.components != 1 {
        let _ = write!(s, " NumberOfComponents=\"{}\"", array.components);
    }
    if field {
        let _ = write!(s, " NumberOfTuples=\"{}\"", array.tuples());
    }
    let _ = writeln!(
        s,
        " format=\"binary\">\n{}\n</DataArray>",
        encode(&array.values)
    );
}

/// The base64 of the byte count (`UInt64`) followed by the values' bytes.
pub fn encode(values: &Values) -> String {
    let data = values.bytes();
    let mut stream = (data.len() as u64).to_le_bytes().to_vec();
    stream.extend_from_slice(&data);
    base64::engine::general_purpose::STANDARD.encode(stream)
}

/// `text` with the five XML special characters escaped, for an attribute value.
fn xml_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The payload of the array named `name` in `text`, decoded: (byte count, bytes).
    pub(crate) fn decoded(text: &str, name: &str) -> (u64, Vec<u8>) {
        let start = text
            .find(&format!("Name=\"{name}\""))
            .expect("array present");
        let body = &text[start..];
        let body = &body[body.find('\n').unwrap() + 1..];
        let body = &body[..body.find('\n').unwrap()];
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(body)
            .expect("valid base64");
        let count = u64::from_le_bytes(bytes[..8].try_into().unwrap());
        (count, bytes[8..].to_vec())
    }

    fn one_triangle_and_a_line() -> Grid {
        let mut grid = Grid {
            points: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            ..Grid::default()
        };
        grid.push_cell(CellKind::Triangle, &[0, 1, 2]);
        grid.push_cell(CellKind::Line, &[0, 1]);
        grid
    }

    #[test]
    fn arrays_round_trip_through_base64() {
        let mut grid = one_triangle_and_a_line();
        let u = vec![1.5, -2.25e-7, 0.0, 3.0, f64::NAN, 0.0, -0.0, 1e300, 0.0];
        grid.point_data
            .push(DataArray::float("displacement", 3, u.clone()));
        grid.cell_data.push(DataArray::int("zone_id", vec![4, -1]));
        grid.field_data
            .push(DataArray::text("scene", "a <b> & \"c\""));
        let text = write_vtu(&grid);

        let (count, bytes) = decoded(&text, "displacement");
        assert_eq!(count, 72);
        let back: Vec<f64> = bytes
            .chunks(8)
            .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(back.len(), u.len());
        for (a, b) in back.iter().zip(&u) {
            assert!(a.to_bits() == b.to_bits(), "{a} != {b}");
        }
        let (count, bytes) = decoded(&text, "zone_id");
        assert_eq!(
            (count, bytes),
            (8, [4i32.to_le_bytes(), (-1i32).to_le_bytes()].concat())
        );
        let (count, bytes) = decoded(&text, "types");
        assert_eq!((count, bytes), (2, vec![5, 3]));
        let (_, bytes) = decoded(&text, "offsets");
        assert_eq!(bytes, [3i64.to_le_bytes(), 5i64.to_le_bytes()].concat());
        let (_, bytes) = decoded(&text, "connectivity");
        let nodes: Vec<i64> = bytes
            .chunks(8)
            .map(|b| i64::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(nodes, [0, 1, 2, 0, 1]);
        assert!(text.contains("NumberOfPoints=\"3\" NumberOfCells=\"2\""));
    }

    #[test]
    fn field_data_is_text_bytes_with_tuples_and_escaped_names() {
        let mut grid = one_triangle_and_a_line();
        grid.field_data
            .push(DataArray::text("scenario", "worst phi3"));
        grid.field_data
            .push(DataArray::float("data:E<rock>", 1, vec![2.0e9]));
        let text = write_vtu(&grid);
        assert!(text.contains(
            "<DataArray type=\"UInt8\" Name=\"scenario\" NumberOfTuples=\"10\" \
             format=\"binary\">"
        ));
        assert!(text.contains("Name=\"data:E&lt;rock&gt;\""));
        let (_, bytes) = decoded(&text, "scenario");
        assert_eq!(String::from_utf8(bytes).unwrap(), "worst phi3");
        let field = text.find("<FieldData>").unwrap();
        assert!(field < text.find("<Piece").unwrap());
    }
}
