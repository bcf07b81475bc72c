//! Reader of Gmsh's MSH files (design §2.4, imported meshes): versions 4.1 and 2.2, each ASCII
//! or binary (little-endian, 8-byte doubles and size_t). It reads `$MeshFormat`,
//! `$PhysicalNames`, `$Entities` (4.1), `$Nodes` and `$Elements` and skips other sections;
//! a partitioned mesh (`$PartitionedEntities`) and element types other than 3-node triangles,
//! 2-node lines and points are refused by name. What it returns is the file's content in the
//! file's own tags; `gmsh` maps it onto the scene.

use std::collections::HashMap;

use super::geom::P;
use crate::scene::SceneError;

const PATH: &str = "mesh.gmsh_file";

/// The parts of an MSH file the import uses.
#[derive(Default)]
pub(crate) struct Msh<'a> {
    bytes: &'a [u8],
    /// A binary file: places are byte offsets, not lines.
    binary: bool,
    /// (dimension, physical tag) → name.
    names: HashMap<(i32, i32), String>,
    /// (dimension, entity tag) → physical tags (MSH 2.2: the element's physical tag → itself).
    physical: HashMap<(i32, i32), Vec<i32>>,
    /// Node coordinates.
    pub nodes: Vec<P>,
    /// The file's tag of every node.
    pub node_tags: Vec<usize>,
    node_index: HashMap<usize, usize>,
    /// 3-node triangles.
    pub triangles: Vec<Element<3>>,
    /// 2-node lines.
    pub lines: Vec<Element<2>>,
}

/// An element of the file.
pub(crate) struct Element<const N: usize> {
    /// The entity (surface or curve) it belongs to; in MSH 2.2 its physical tag.
    pub entity: i32,
    /// The file's node tags of its corners.
    pub nodes: [usize; N],
    /// Its byte offset in the file.
    pub at: usize,
    /// Its element tag.
    pub tag: usize,
}

impl Msh<'_> {
    /// The place of byte offset `at` in words: "line N" in an ASCII file, "byte N" in a binary
    /// one.
    pub fn place(&self, at: usize) -> String {
        if self.binary {
            format!("byte {at}")
        } else {
            let end = at.min(self.bytes.len());
            let line = 1 + self.bytes[..end].iter().filter(|&&b| b == b'\n').count();
            format!("line {line}")
        }
    }

    /// An error at byte offset `at`.
    pub fn err(&self, at: usize, reason: impl std::fmt::Display) -> SceneError {
        SceneError::new(PATH, format!("{}: {reason}", self.place(at)))
    }

    /// The physical names of an entity of dimension `dim`.
    pub fn names_of(&self, dim: i32, entity: i32) -> Vec<&str> {
        self.physical
            .get(&(dim, entity))
            .into_iter()
            .flatten()
            .filter_map(|t| self.names.get(&(dim, *t)).map(String::as_str))
            .collect()
    }

    /// The index of the node with the file's tag `tag` (referred to at byte `at`).
    pub fn node(&self, tag: usize, at: usize) -> Result<usize, SceneError> {
        self.node_index
            .get(&tag)
            .copied()
            .ok_or_else(|| self.err(at, format!("unknown node {tag}")))
    }

    fn add_node(&mut self, tag: usize, p: P, at: usize) -> Result<(), SceneError> {
        if !p[0].is_finite() || !p[1].is_finite() {
            return Err(self.err(at, "non-finite node coordinate"));
        }
        if self.node_index.insert(tag, self.nodes.len()).is_some() {
            return Err(self.err(at, format!("node {tag} is defined twice")));
        }
        self.nodes.push(p);
        self.node_tags.push(tag);
        Ok(())
    }

    /// Stores an element of Gmsh type `kind` (1 line, 2 triangle, 15 point: ignored).
    fn add_element(&mut self, kind: i64, entity: i32, tag: usize, v: &[usize], at: usize) {
        match kind {
            1 => self.lines.push(Element {
                entity,
                nodes: [v[0], v[1]],
                at,
                tag,
            }),
            2 => self.triangles.push(Element {
                entity,
                nodes: [v[0], v[1], v[2]],
                at,
                tag,
            }),
            _ => {}
        }
    }
}

/// Nodes per element of the accepted types, or why a type is refused.
fn nodes_per(kind: i64) -> Result<usize, String> {
    let what = match kind {
        1 => return Ok(2),
        2 => return Ok(3),
        15 => return Ok(1),
        3 => "4-node quadrangles (turn recombination off)",
        8 | 9 | 21 | 23 | 25 => "second-order or higher-order elements (mesh with element order 1)",
        4..=7 | 11..=14 | 17..=19 => "3D elements (wsm is plane: mesh a 2D geometry)",
        _ => "an element type wsm does not use",
    };
    Err(format!(
        "element type {kind} is not supported: {what}; wsm reads 3-node triangles and 2-node lines"
    ))
}

/// Reads bytes in an ASCII or binary MSH file.
struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
    binary: bool,
}

impl<'a> Cursor<'a> {
    fn err(&self, at: usize, reason: impl std::fmt::Display) -> SceneError {
        Msh {
            bytes: self.b,
            binary: self.binary,
            ..Msh::default()
        }
        .err(at, reason)
    }

    fn skip_space(&mut self) {
        while self.pos < self.b.len() && self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
    }

    /// The next line (trimmed), after skipping blank space.
    fn line(&mut self) -> Option<&'a str> {
        self.skip_space();
        if self.pos >= self.b.len() {
            return None;
        }
        let end = self.b[self.pos..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(self.b.len(), |k| self.pos + k);
        let text = std::str::from_utf8(&self.b[self.pos..end]).unwrap_or("");
        self.pos = (end + 1).min(self.b.len());
        Some(text.trim())
    }

    /// The next whitespace-separated token, parsed.
    fn token<T: std::str::FromStr>(&mut self, what: &str) -> Result<T, SceneError> {
        self.skip_space();
        let start = self.pos;
        while self.pos < self.b.len() && !self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(self.err(start, format!("the file ends early, expected {what}")));
        }
        let tok = String::from_utf8_lossy(&self.b[start..self.pos]);
        tok.parse()
            .map_err(|_| self.err(start, format!("expected {what}, found '{tok}'")))
    }

    fn raw<const N: usize>(&mut self, what: &str) -> Result<[u8; N], SceneError> {
        let bytes = self
            .b
            .get(self.pos..self.pos + N)
            .ok_or_else(|| self.err(self.pos, format!("the file ends early, expected {what}")))?;
        self.pos += N;
        let mut out = [0u8; N];
        out.copy_from_slice(bytes);
        Ok(out)
    }

    /// A C `int` (binary: 4 bytes).
    fn int(&mut self, what: &str) -> Result<i64, SceneError> {
        if self.binary {
            Ok(i32::from_le_bytes(self.raw(what)?) as i64)
        } else {
            self.token(what)
        }
    }

    /// A `size_t` (binary: 8 bytes).
    fn size(&mut self, what: &str) -> Result<usize, SceneError> {
        let at = self.pos;
        let v = if self.binary {
            u64::from_le_bytes(self.raw(what)?)
        } else {
            self.token(what)?
        };
        usize::try_from(v).map_err(|_| self.err(at, format!("{what} {v} is too large")))
    }

    /// A non-negative `int` used as a count or tag.
    fn count(&mut self, what: &str) -> Result<usize, SceneError> {
        let at = self.pos;
        let v = self.int(what)?;
        usize::try_from(v).map_err(|_| self.err(at, format!("{what} must not be negative ({v})")))
    }

    /// A `double` (binary: 8 bytes).
    fn float(&mut self, what: &str) -> Result<f64, SceneError> {
        if self.binary {
            Ok(f64::from_le_bytes(self.raw(what)?))
        } else {
            self.token(what)
        }
    }

    /// A count that the rest of the file must be able to hold (at least `min_bytes` each), so
    /// that a corrupt count cannot make the reader reserve unbounded memory.
    fn checked(
        &self,
        n: usize,
        min_bytes: usize,
        at: usize,
        what: &str,
    ) -> Result<usize, SceneError> {
        if n.saturating_mul(min_bytes) > self.b.len() - self.pos.min(self.b.len()) {
            return Err(self.err(at, format!("{what} {n} is more than the file can hold")));
        }
        Ok(n)
    }
}

/// The MSH version of a file.
#[derive(Clone, Copy, PartialEq)]
enum Version {
    V41,
    V22,
}

/// Parses an MSH 4.1 or 2.2 file, ASCII or binary.
pub(crate) fn parse(bytes: &[u8]) -> Result<Msh<'_>, SceneError> {
    let mut c = Cursor {
        b: bytes,
        pos: 0,
        binary: false,
    };
    let mut msh = Msh {
        bytes,
        ..Msh::default()
    };
    let mut version = None;
    loop {
        let at = {
            c.skip_space();
            c.pos
        };
        let Some(head) = c.line() else { break };
        let Some(name) = head.strip_prefix('$') else {
            return Err(c.err(at, format!("expected a section start, found '{head}'")));
        };
        let name = name.to_string();
        match (name.as_str(), version) {
            ("MeshFormat", _) => version = Some(format(&mut c)?),
            (_, None) => {
                return Err(SceneError::new(
                    PATH,
                    "not a Gmsh .msh file (no $MeshFormat section first)",
                ))
            }
            ("PhysicalNames", _) => physical_names(&mut c, &mut msh)?,
            ("Entities", Some(Version::V41)) => entities(&mut c, &mut msh)?,
            ("Nodes", Some(v)) => nodes(&mut c, &mut msh, v)?,
            ("Elements", Some(v)) => elements(&mut c, &mut msh, v)?,
            ("PartitionedEntities", _) => {
                return Err(c.err(
                    at,
                    "a partitioned mesh is not supported (save it unpartitioned: \
                     Mesh.PartitionOldStyleMsh2 off, or no partitioning)",
                ))
            }
            _ => {
                skip_section(&mut c, &name, at)?;
                continue;
            }
        }
        let end_at = {
            c.skip_space();
            c.pos
        };
        let end = format!("$End{name}");
        if c.line() != Some(end.as_str()) {
            return Err(c.err(end_at, format!("expected {end}")));
        }
    }
    if version.is_none() {
        return Err(SceneError::new(
            PATH,
            "not a Gmsh .msh file (no $MeshFormat section)",
        ));
    }
    msh.binary = c.binary;
    if msh.triangles.is_empty() {
        return Err(SceneError::new(PATH, "the file has no 3-node triangles"));
    }
    Ok(msh)
}

/// Skips an unknown section up to its `$End` line.
fn skip_section(c: &mut Cursor, name: &str, at: usize) -> Result<(), SceneError> {
    let end = format!("\n$End{name}");
    let k = c.b[c.pos..]
        .windows(end.len())
        .position(|w| w == end.as_bytes())
        .ok_or_else(|| c.err(at, format!("section ${name} has no $End{name}")))?;
    c.pos += k + end.len();
    Ok(())
}

fn format(c: &mut Cursor) -> Result<Version, SceneError> {
    c.skip_space();
    let at = c.pos;
    let version: String = c.token("the format version")?;
    let file_type: u32 = c.token("the file type")?;
    let data_size: u32 = c.token("the data size")?;
    let version = match version.as_str() {
        "4.1" => Version::V41,
        "2.2" => Version::V22,
        _ => {
            return Err(c.err(
                at,
                format!("MSH version {version} is not supported (only 4.1 and 2.2)"),
            ))
        }
    };
    if data_size != 8 {
        return Err(c.err(
            at,
            format!("data size {data_size} is not supported (only 8)"),
        ));
    }
    if file_type == 1 {
        // A binary file: one int 1 on its own line tells the byte order.
        c.pos += 1;
        let one = i32::from_le_bytes(c.raw("the byte-order mark")?);
        if one != 1 {
            return Err(c.err(
                at,
                "a big-endian binary file is not supported (write it on a little-endian machine, \
                 or as ASCII)",
            ));
        }
        c.binary = true;
    } else if file_type != 0 {
        return Err(c.err(
            at,
            format!("file type {file_type} is neither ASCII (0) nor binary (1)"),
        ));
    }
    Ok(version)
}

fn physical_names(c: &mut Cursor, msh: &mut Msh) -> Result<(), SceneError> {
    let count: usize = c.token("the number of physical names")?;
    for _ in 0..count {
        c.skip_space();
        let at = c.pos;
        let l = c
            .line()
            .ok_or_else(|| c.err(at, "fewer physical names than announced"))?;
        let mut parts = l.splitn(3, char::is_whitespace);
        let dim = parts.next().and_then(|x| x.parse::<i32>().ok());
        let tag = parts.next().and_then(|x| x.parse::<i32>().ok());
        let name = parts.next().map(|x| x.trim().trim_matches('"').to_string());
        match (dim, tag, name) {
            (Some(d), Some(t), Some(name)) if !l.starts_with('$') => {
                msh.names.insert((d, t), name);
            }
            _ => return Err(c.err(at, "expected `dimension tag \"name\"`")),
        }
    }
    Ok(())
}

fn entities(c: &mut Cursor, msh: &mut Msh) -> Result<(), SceneError> {
    let counts = [
        c.size("the number of points")?,
        c.size("the number of curves")?,
        c.size("the number of surfaces")?,
        c.size("the number of volumes")?,
    ];
    for (dim, &count) in counts.iter().enumerate() {
        for _ in 0..count {
            let tag = c.int("an entity tag")? as i32;
            // Points have one coordinate triple, other entities a bounding box.
            for _ in 0..if dim == 0 { 3 } else { 6 } {
                c.float("a coordinate")?;
            }
            let at = c.pos;
            let np = c.size("the number of physical tags")?;
            let np = c.checked(np, 1, at, "the number of physical tags")?;
            let tags = (0..np)
                .map(|_| c.int("a physical tag").map(|t| t.abs() as i32))
                .collect::<Result<Vec<_>, _>>()?;
            msh.physical.insert((dim as i32, tag), tags);
            if dim > 0 {
                let nb = c.size("the number of bounding entities")?;
                for _ in 0..nb {
                    c.int("a bounding entity")?;
                }
            }
        }
    }
    Ok(())
}

fn nodes(c: &mut Cursor, msh: &mut Msh, version: Version) -> Result<(), SceneError> {
    if version == Version::V22 {
        let at = c.pos;
        let n: usize = c.token("the number of nodes")?;
        c.checked(n, 28, at, "the number of nodes")?;
        if c.binary {
            c.pos += 1;
        }
        for _ in 0..n {
            let at = c.pos;
            let tag = c.count("a node tag")?;
            let p = [c.float("x")?, c.float("y")?];
            c.float("z")?;
            msh.add_node(tag, p, at)?;
        }
        return Ok(());
    }
    let blocks = c.size("the number of node blocks")?;
    for _ in 0..3 {
        c.size("the node counts")?;
    }
    for _ in 0..blocks {
        let dim = c.count("the entity dimension")?;
        c.int("the entity tag")?;
        let parametric = c.int("the parametric flag")?;
        let at = c.pos;
        let n = c.size("the number of nodes")?;
        c.checked(n, 2, at, "the number of nodes")?;
        let tags = (0..n)
            .map(|_| c.size("a node tag"))
            .collect::<Result<Vec<_>, _>>()?;
        for tag in tags {
            let at = c.pos;
            let p = [c.float("x")?, c.float("y")?];
            for _ in 0..1 + if parametric == 1 { dim } else { 0 } {
                c.float("a coordinate")?;
            }
            msh.add_node(tag, p, at)?;
        }
    }
    Ok(())
}

fn elements(c: &mut Cursor, msh: &mut Msh, version: Version) -> Result<(), SceneError> {
    if version == Version::V22 {
        return elements_22(c, msh);
    }
    let blocks = c.size("the number of element blocks")?;
    for _ in 0..3 {
        c.size("the element counts")?;
    }
    for _ in 0..blocks {
        let at = c.pos;
        c.int("the entity dimension")?;
        let entity = c.int("the entity tag")? as i32;
        let kind = c.int("the element type")?;
        let n = c.size("the number of elements")?;
        let per = nodes_per(kind).map_err(|e| c.err(at, e))?;
        c.checked(n, 2 * (per + 1), at, "the number of elements")?;
        let mut v = vec![0; per];
        for _ in 0..n {
            let at = c.pos;
            let tag = c.size("an element tag")?;
            for x in v.iter_mut() {
                *x = c.size("a node tag")?;
            }
            msh.add_element(kind, entity, tag, &v, at);
        }
    }
    Ok(())
}

/// MSH 2.2 elements: each carries its physical tag (the first of its tags), which stands for
/// the entity.
fn elements_22(c: &mut Cursor, msh: &mut Msh) -> Result<(), SceneError> {
    let at = c.pos;
    let total: usize = c.token("the number of elements")?;
    c.checked(total, 8, at, "the number of elements")?;
    if c.binary {
        c.pos += 1;
    }
    let mut read = 0;
    while read < total {
        // Binary: one header (type, count, number of tags) per block; ASCII: one per element.
        let (header, block) = if c.binary {
            let at = c.pos;
            let kind = c.int("the element type")?;
            let block = c.count("the number of elements in the block")?;
            let ntags = c.count("the number of tags")?;
            if block == 0 {
                return Err(c.err(at, "an element block of 0 elements"));
            }
            (Some((kind, ntags)), block.min(total - read))
        } else {
            (None, 1)
        };
        for _ in 0..block {
            let at = c.pos;
            let tag = c.count("an element tag")?;
            let (kind, ntags) = match header {
                Some(h) => h,
                None => (c.int("the element type")?, c.count("the number of tags")?),
            };
            let per = nodes_per(kind).map_err(|e| c.err(at, e))?;
            let ntags = c.checked(ntags, 1, at, "the number of tags")?;
            let tags = (0..ntags)
                .map(|_| c.int("a tag"))
                .collect::<Result<Vec<_>, _>>()?;
            let physical = tags.first().copied().unwrap_or(0) as i32;
            let v = (0..per)
                .map(|_| c.count("a node tag"))
                .collect::<Result<Vec<_>, _>>()?;
            let dim = match kind {
                2 => 2,
                1 => 1,
                _ => 0,
            };
            msh.physical.insert((dim, physical), vec![physical]);
            msh.add_element(kind, physical, tag, &v, at);
            read += 1;
        }
    }
    Ok(())
}
