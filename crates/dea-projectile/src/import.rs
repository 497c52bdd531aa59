//! Projectile meshes from files: Gmsh `.msh` 4.1 (ASCII and binary), ABAQUS `.inp`
//! (`*NODE`, `*ELEMENT` of type C3D8/C3D8R/C3D8I) and STL (ASCII and binary, surfaces for a
//! rigid projectile). Volume meshes keep 8-node hexahedra, and Gmsh's 4-node tetrahedra for
//! a rigid projectile's surface; lower dimensional elements (points, lines, surface facets)
//! are skipped, other volume elements are refused. Every error names the file and the line
//! (the byte, in binary files).

use std::collections::HashMap;
use std::path::Path;

use dea_core::Vec3;

use crate::mesh::{compact, outer_triangles, Hex, HexMesh};

/// Why a mesh file cannot be used.
#[derive(Debug, PartialEq)]
pub struct ImportError {
    /// the mesh file
    pub path: String,
    /// 1-based line (ASCII), or byte offset prefixed in the message (binary); 0: the file
    pub line: usize,
    /// what is wrong there
    pub message: String,
}

impl std::fmt::Display for ImportError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line > 0 {
            write!(f, "{}:{}: {}", self.path, self.line, self.message)
        } else {
            write!(f, "{}: {}", self.path, self.message)
        }
    }
}

impl std::error::Error for ImportError {}

/// Gmsh's element types of the 8-node hexahedron and the 4-node tetrahedron.
const GMSH_HEXAHEDRON: i64 = 5;
const GMSH_TETRAHEDRON: i64 = 4;

/// Nodes of each Gmsh element type that may appear next to hexahedra (skipped unless a
/// hexahedron), and whether the type is a volume element.
fn gmsh_element(kind: i64) -> Option<(usize, bool)> {
    match kind {
        15 => Some((1, false)), // point
        1 => Some((2, false)),  // line
        2 => Some((3, false)),  // triangle
        3 => Some((4, false)),  // quadrangle
        GMSH_TETRAHEDRON => Some((4, true)),
        GMSH_HEXAHEDRON => Some((8, true)),
        6 => Some((6, true)), // prism
        7 => Some((5, true)), // pyramid
        _ => None,
    }
}

/// The largest mesh file read [bytes]: a 2^24-element hexahedral mesh in ASCII is about
/// 1.5 GB, far beyond any projectile a fibre-level shot can afford.
pub const MAX_MESH_BYTES: u64 = 2 << 30;

/// The bytes of a mesh file: a regular file (not a FIFO or a device, which could block or
/// never end) of at most [`MAX_MESH_BYTES`].
fn read_file(path: &Path) -> Result<Vec<u8>, ImportError> {
    let name = path.display().to_string();
    let refuse = |message: String| ImportError { path: name.clone(), line: 0, message };
    let metadata = std::fs::metadata(path).map_err(|e| refuse(format!("cannot read: {e}")))?;
    if !metadata.is_file() {
        return Err(refuse("not a regular file (a FIFO, a device or a directory cannot be a mesh)".into()));
    }
    if metadata.len() > MAX_MESH_BYTES {
        return Err(refuse(format!(
            "{} bytes: larger than the {MAX_MESH_BYTES} bytes a mesh may have",
            metadata.len()
        )));
    }
    std::fs::read(path).map_err(|e| refuse(format!("cannot read: {e}")))
}

/// Reads a mesh, choosing the format by the file's extension.
pub fn read_mesh(path: &Path) -> Result<HexMesh, ImportError> {
    let name = path.display().to_string();
    let bytes = read_file(path)?;
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("msh") => parse_gmsh(&bytes, &name),
        Some("inp") => parse_abaqus(&String::from_utf8_lossy(&bytes), &name),
        _ => Err(ImportError {
            path: name,
            line: 0,
            message: "unknown mesh format: use .msh (Gmsh 4.1) or .inp (ABAQUS)".into(),
        }),
    }
}

/// A closed surface for a rigid projectile, choosing the format by the file's extension:
/// STL as it is, or the outer surface of a Gmsh or ABAQUS volume mesh (hexahedra and, from
/// Gmsh, tetrahedra). Vertices and triangles, normals out; closure is checked by the user.
pub fn read_surface(path: &Path) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), ImportError> {
    let name = path.display().to_string();
    let bytes = read_file(path)?;
    let (nodes, hexes, tetrahedra) =
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("stl") => return parse_stl(&bytes, &name),
            Some("msh") => gmsh_elements(&bytes, &name)?.finish_volume(&name)?,
            Some("inp") => {
                let mesh = parse_abaqus(&String::from_utf8_lossy(&bytes), &name)?;
                (mesh.nodes, mesh.hexes, Vec::new())
            }
            _ => {
                return Err(ImportError {
                    path: name,
                    line: 0,
                    message: "unknown mesh format: use .msh (Gmsh 4.1), .inp (ABAQUS) or .stl".into(),
                })
            }
        };
    let (vertices, _, triangles) = compact(&nodes, &outer_triangles(&hexes, &tetrahedra));
    Ok((vertices, triangles))
}

/// Nodes, hexahedra and tetrahedra with dense indices.
type Volume = (Vec<Vec3>, Vec<Hex>, Vec<[u32; 4]>);

/// Nodes by tag and elements by node tags, turned into a mesh with dense indices.
struct Collected {
    node_index: HashMap<u64, u32>,
    nodes: Vec<Vec3>,
    hexes: Vec<([u64; 8], usize)>,
    tetrahedra: Vec<([u64; 4], usize)>,
}

impl Collected {
    fn new() -> Self {
        Self { node_index: HashMap::new(), nodes: Vec::new(), hexes: Vec::new(), tetrahedra: Vec::new() }
    }

    fn index<const N: usize>(&self, tags: &[u64; N], line: usize, path: &str) -> Result<[u32; N], ImportError> {
        let mut nodes = [0u32; N];
        for (k, tag) in tags.iter().enumerate() {
            nodes[k] = *self.node_index.get(tag).ok_or_else(|| ImportError {
                path: path.into(),
                line,
                message: format!("element refers to node {tag}, which is not defined"),
            })?;
        }
        Ok(nodes)
    }

    /// Nodes, hexahedra and tetrahedra with dense indices; inverted elements refused.
    fn finish_volume(self, path: &str) -> Result<Volume, ImportError> {
        let hexes: Vec<Hex> =
            self.hexes.iter().map(|(tags, line)| self.index(tags, *line, path)).collect::<Result<_, _>>()?;
        let tetrahedra: Vec<[u32; 4]> =
            self.tetrahedra.iter().map(|(tags, line)| self.index(tags, *line, path)).collect::<Result<_, _>>()?;
        if hexes.is_empty() && tetrahedra.is_empty() {
            return Err(ImportError {
                path: path.into(),
                line: 0,
                message: "no 8-node hexahedra or 4-node tetrahedra in the file".into(),
            });
        }
        for (k, t) in tetrahedra.iter().enumerate() {
            let [a, b, c, d] = t.map(|n| self.nodes[n as usize]);
            let volume = (b - a).cross(&(c - a)).dot(&(d - a));
            if volume.is_nan() || volume <= 0.0 {
                return Err(ImportError {
                    path: path.into(),
                    line: self.tetrahedra[k].1,
                    message: format!("tetrahedron {k} (in file order) is inverted or degenerate"),
                });
            }
        }
        let mesh = HexMesh { nodes: self.nodes, hexes };
        if let Some(k) = mesh.volumes().iter().position(|&v| v.is_nan() || v <= 0.0) {
            return Err(ImportError { path: path.into(), line: 0, message: format!("hexahedron {k} (in file order) is inverted or degenerate: its nodes must follow the Gmsh/ABAQUS corner order") });
        }
        Ok((mesh.nodes, mesh.hexes, tetrahedra))
    }

    fn node(&mut self, tag: u64, position: Vec3, path: &str, line: usize) -> Result<(), ImportError> {
        if self.node_index.insert(tag, self.nodes.len() as u32).is_some() {
            return Err(ImportError { path: path.into(), line, message: format!("node {tag} defined twice") });
        }
        self.nodes.push(position);
        Ok(())
    }

    /// Keeps a Gmsh element of type `kind` with node tags `tags` if it is a hexahedron or a
    /// tetrahedron.
    fn element(&mut self, kind: i64, tags: &[u64], line: usize) {
        match kind {
            GMSH_HEXAHEDRON => self.hexes.push((tags[..8].try_into().expect("8 nodes"), line)),
            GMSH_TETRAHEDRON => self.tetrahedra.push((tags[..4].try_into().expect("4 nodes"), line)),
            _ => {}
        }
    }

    /// A hexahedral mesh, for any use (a deformable projectile too).
    fn finish(self, path: &str) -> Result<HexMesh, ImportError> {
        let (nodes, hexes, tetrahedra) = self.finish_volume(path)?;
        if !tetrahedra.is_empty() {
            return Err(ImportError {
                path: path.into(),
                line: 0,
                message:
                    "tetrahedra serve a rigid projectile's surface only: mesh this projectile with 8-node hexahedra"
                        .into(),
            });
        }
        if hexes.is_empty() {
            return Err(ImportError { path: path.into(), line: 0, message: "no 8-node hexahedra in the file".into() });
        }
        Ok(HexMesh { nodes, hexes })
    }
}

/// Lines with their 1-based numbers, blank ones skipped.
struct Lines<'a> {
    inner: std::iter::Peekable<std::iter::Enumerate<std::str::Lines<'a>>>,
    path: &'a str,
    last: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str, path: &'a str) -> Self {
        Self { inner: text.lines().enumerate().peekable(), path, last: 0 }
    }

    fn error(&self, line: usize, message: impl Into<String>) -> ImportError {
        ImportError { path: self.path.into(), line, message: message.into() }
    }

    fn next(&mut self) -> Result<(usize, &'a str), ImportError> {
        for (k, line) in self.inner.by_ref() {
            if !line.trim().is_empty() {
                self.last = k + 1;
                return Ok((k + 1, line.trim()));
            }
        }
        Err(ImportError { path: self.path.into(), line: self.last, message: "unexpected end of file".into() })
    }

    /// The next line as numbers.
    /// The line that must close a section whose blocks were just read: a block that listed
    /// more lines than it claimed, or a header whose total disagrees with its blocks', is an
    /// error rather than a silently shorter mesh.
    fn end(&mut self, marker: &str, head_line: usize, total: u64, claimed: u64, what: &str) -> Result<(), ImportError> {
        let (line, text) = self.next()?;
        if text != marker {
            return Err(self.error(line, format!("expected {marker}: a block lists more {what} than its count says")));
        }
        if total != claimed {
            return Err(self.error(head_line, format!("the header claims {claimed} {what}, its blocks hold {total}")));
        }
        Ok(())
    }

    fn numbers<T: std::str::FromStr>(&mut self, expected: usize) -> Result<(usize, Vec<T>), ImportError> {
        let (line, text) = self.next()?;
        let values: Result<Vec<T>, _> = text.split_whitespace().map(str::parse).collect();
        match values {
            Ok(values) if values.len() >= expected => Ok((line, values)),
            Ok(values) => Err(self.error(line, format!("expected {expected} numbers, found {}", values.len()))),
            Err(_) => Err(self.error(line, format!("not a number in {text:?}"))),
        }
    }
}

/// Parses a Gmsh 4.1 hexahedral mesh, ASCII or binary.
pub fn parse_gmsh(bytes: &[u8], path: &str) -> Result<HexMesh, ImportError> {
    gmsh_elements(bytes, path)?.finish(path)
}

/// The nodes and volume elements of a Gmsh 4.1 file, ASCII or binary.
fn gmsh_elements(bytes: &[u8], path: &str) -> Result<Collected, ImportError> {
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(64)]).into_owned();
    let mut header = head.lines();
    let (first, format) = (header.next().unwrap_or("").trim(), header.next().unwrap_or("").trim().to_string());
    if first != "$MeshFormat" {
        return Err(ImportError {
            path: path.into(),
            line: 1,
            message: "not a Gmsh mesh: expected $MeshFormat".into(),
        });
    }
    let fields: Vec<&str> = format.split_whitespace().collect();
    if fields.first() != Some(&"4.1") {
        return Err(ImportError {
            path: path.into(),
            line: 2,
            message: format!(
                "MSH version {:?}: only 4.1 is read (save as Version 4 ASCII or binary)",
                fields.first().unwrap_or(&"")
            ),
        });
    }
    match fields.get(1) {
        Some(&"0") => parse_gmsh_ascii(&String::from_utf8_lossy(bytes), path),
        Some(&"1") => parse_gmsh_binary(bytes, path),
        _ => {
            Err(ImportError { path: path.into(), line: 2, message: "file type must be 0 (ASCII) or 1 (binary)".into() })
        }
    }
}

fn parse_gmsh_ascii(text: &str, path: &str) -> Result<Collected, ImportError> {
    let mut lines = Lines::new(text, path);
    let mut collected = Collected::new();
    while let Ok((_, line)) = lines.next() {
        match line {
            "$Nodes" => {
                let (head_line, head) = lines.numbers::<u64>(4)?;
                let mut total = 0u64;
                for _ in 0..head[0] {
                    let (line, block) = lines.numbers::<u64>(4)?;
                    let (parametric, count) = (block[2] != 0, block[3]);
                    if parametric {
                        return Err(lines.error(line, "parametric node coordinates are not supported"));
                    }
                    // no capacity from a count the file claims: a wrong one ends at the file's end
                    let mut tags = Vec::new();
                    for _ in 0..count {
                        tags.push(lines.numbers::<u64>(1)?.1[0]);
                    }
                    for tag in tags {
                        let (line, x) = lines.numbers::<f64>(3)?;
                        collected.node(tag, Vec3::new(x[0], x[1], x[2]), path, line)?;
                    }
                    total += count;
                }
                lines.end("$EndNodes", head_line, total, head[1], "nodes")?;
            }
            "$Elements" => {
                let (head_line, head) = lines.numbers::<u64>(4)?;
                let mut total = 0u64;
                for _ in 0..head[0] {
                    let (line, block) = lines.numbers::<i64>(4)?;
                    let (kind, count) = (block[2], block[3].max(0) as u64);
                    total += count;
                    let Some((nodes, volume)) = gmsh_element(kind) else {
                        return Err(lines.error(line, format!("unknown element type {kind}")));
                    };
                    if volume && kind != GMSH_HEXAHEDRON && kind != GMSH_TETRAHEDRON {
                        return Err(lines.error(
                            line,
                            format!("element type {kind} is neither an 8-node hexahedron nor a 4-node tetrahedron"),
                        ));
                    }
                    for _ in 0..count {
                        let (line, values) = lines.numbers::<u64>(1 + nodes)?;
                        collected.element(kind, &values[1..], line);
                    }
                }
                lines.end("$EndElements", head_line, total, head[1], "elements")?;
            }
            _ => {}
        }
    }
    Ok(collected)
}

/// A little-endian reader of Gmsh binary blocks (data-size 8: size_t is 8 bytes).
struct Binary<'a> {
    bytes: &'a [u8],
    at: usize,
    path: &'a str,
}

impl Binary<'_> {
    fn error(&self, message: impl std::fmt::Display) -> ImportError {
        ImportError { path: self.path.into(), line: 0, message: format!("byte {}: {message}", self.at) }
    }

    fn take(&mut self, n: usize) -> Result<&[u8], ImportError> {
        if n > self.bytes.len() - self.at {
            return Err(self.error("unexpected end of file"));
        }
        self.at += n;
        Ok(&self.bytes[self.at - n..self.at])
    }

    fn size(&mut self) -> Result<u64, ImportError> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }

    fn int(&mut self) -> Result<i32, ImportError> {
        Ok(i32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }

    fn double(&mut self) -> Result<f64, ImportError> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }

    /// Moves past the next line that reads `marker`.
    fn seek(&mut self, marker: &str) -> bool {
        let needle = format!("{marker}\n");
        match self.bytes[self.at..].windows(needle.len()).position(|w| w == needle.as_bytes()) {
            Some(k) => {
                self.at += k + needle.len();
                true
            }
            None => false,
        }
    }
}

fn parse_gmsh_binary(bytes: &[u8], path: &str) -> Result<Collected, ImportError> {
    let mut reader = Binary { bytes, at: 0, path };
    let mut collected = Collected::new();
    reader.seek("$MeshFormat");
    reader.seek("4.1 1 8");
    if reader.int()? != 1 {
        return Err(reader.error("the file was written on a big-endian machine, or is damaged"));
    }
    if !reader.seek("$Nodes") {
        return Err(reader.error("no $Nodes section"));
    }
    let blocks = reader.size()?;
    let _ = (reader.size()?, reader.size()?, reader.size()?);
    for _ in 0..blocks {
        let (_, _, parametric) = (reader.int()?, reader.int()?, reader.int()?);
        let count = reader.size()? as usize;
        if parametric != 0 {
            return Err(reader.error("parametric node coordinates are not supported"));
        }
        let tags: Vec<u64> = (0..count).map(|_| reader.size()).collect::<Result<_, _>>()?;
        for tag in tags {
            let x = Vec3::new(reader.double()?, reader.double()?, reader.double()?);
            collected.node(tag, x, path, 0).map_err(|e| reader.error(e.message))?;
        }
    }
    if !reader.seek("$Elements") {
        return Err(reader.error("no $Elements section"));
    }
    let blocks = reader.size()?;
    let _ = (reader.size()?, reader.size()?, reader.size()?);
    for _ in 0..blocks {
        let (_, _, kind) = (reader.int()?, reader.int()?, reader.int()? as i64);
        let count = reader.size()? as usize;
        let Some((nodes, volume)) = gmsh_element(kind) else {
            return Err(reader.error(format!("unknown element type {kind}")));
        };
        if volume && kind != GMSH_HEXAHEDRON && kind != GMSH_TETRAHEDRON {
            return Err(
                reader.error(format!("element type {kind} is neither an 8-node hexahedron nor a 4-node tetrahedron"))
            );
        }
        for _ in 0..count {
            let _tag = reader.size()?;
            let element: Vec<u64> = (0..nodes).map(|_| reader.size()).collect::<Result<_, _>>()?;
            collected.element(kind, &element, 0);
        }
    }
    Ok(collected)
}

/// Parses the nodes and C3D8 elements of an ABAQUS input file.
pub fn parse_abaqus(text: &str, path: &str) -> Result<HexMesh, ImportError> {
    #[derive(PartialEq)]
    enum Section {
        Other,
        Nodes,
        Hexahedra,
    }
    let mut collected = Collected::new();
    let mut section = Section::Other;
    let mut pending: Vec<u64> = Vec::new();
    let mut pending_line = 0;
    for (k, raw) in text.lines().enumerate() {
        let (line, text) = (k + 1, raw.trim());
        if text.is_empty() || text.starts_with("**") {
            continue;
        }
        let error = |message: String| ImportError { path: path.into(), line, message };
        if let Some(keyword) = text.strip_prefix('*') {
            let upper = keyword.to_ascii_uppercase();
            let name = upper.split(',').next().unwrap_or("").trim().to_string();
            section = match name.as_str() {
                "NODE" => Section::Nodes,
                "ELEMENT" => {
                    let kind = upper
                        .split(',')
                        .find_map(|p| {
                            p.trim().strip_prefix("TYPE").map(|t| t.trim_start_matches([' ', '=']).trim().to_string())
                        })
                        .unwrap_or_default();
                    match kind.as_str() {
                        "C3D8" | "C3D8R" | "C3D8I" => Section::Hexahedra,
                        other if other.starts_with("C3D") => {
                            return Err(error(format!(
                                "element type {other} is not an 8-node hexahedron (C3D8, C3D8R or C3D8I)"
                            )))
                        }
                        _ => Section::Other,
                    }
                }
                _ => Section::Other,
            };
            continue;
        }
        let fields: Vec<&str> = text.split(',').map(str::trim).filter(|f| !f.is_empty()).collect();
        match section {
            Section::Nodes => {
                let values: Result<Vec<f64>, _> = fields.iter().map(|f| f.parse::<f64>()).collect();
                let values = values.map_err(|_| error(format!("not a number in {text:?}")))?;
                if values.len() < 4 || values[0].fract() != 0.0 || values[0] < 0.0 {
                    return Err(error(format!("a node line is `tag, x, y, z`, got {text:?}")));
                }
                collected.node(values[0] as u64, Vec3::new(values[1], values[2], values[3]), path, line)?;
            }
            Section::Hexahedra => {
                // an element may continue on the next line after a trailing comma
                if pending.is_empty() {
                    pending_line = line;
                }
                for f in fields {
                    pending.push(f.parse::<u64>().map_err(|_| error(format!("not an integer: {f:?}")))?);
                }
                if pending.len() >= 9 {
                    if pending.len() > 9 {
                        return Err(ImportError {
                            path: path.into(),
                            line: pending_line,
                            message: format!("a C3D8 element has a tag and 8 nodes, got {} numbers", pending.len()),
                        });
                    }
                    let mut tags = [0u64; 8];
                    tags.copy_from_slice(&pending[1..9]);
                    collected.hexes.push((tags, pending_line));
                    pending.clear();
                }
            }
            Section::Other => {}
        }
    }
    if !pending.is_empty() {
        return Err(ImportError {
            path: path.into(),
            line: pending_line,
            message: "incomplete element at the end of the file".into(),
        });
    }
    collected.finish(path)
}

/// Parses an STL surface, ASCII or binary (told apart by the binary size rule: 84 bytes
/// plus 50 per facet). Vertices repeated bit for bit are merged; the facets' vertex order
/// gives their orientation (their normal records are ignored, as STL readers commonly do).
pub fn parse_stl(bytes: &[u8], path: &str) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), ImportError> {
    let mut merged: HashMap<[u64; 3], u32> = HashMap::new();
    let mut vertices = Vec::new();
    let mut vertex = |p: Vec3| {
        *merged.entry([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]).or_insert_with(|| {
            vertices.push(p);
            (vertices.len() - 1) as u32
        })
    };
    let mut triangles = Vec::new();
    let binary_count =
        (bytes.len() >= 84).then(|| u32::from_le_bytes(bytes[80..84].try_into().expect("4 bytes")) as usize);
    if binary_count.is_some_and(|n| 84 + 50 * n == bytes.len()) {
        let mut reader = Binary { bytes, at: 84, path };
        for _ in 0..binary_count.unwrap_or(0) {
            let mut facet = [0.0f32; 12];
            for value in &mut facet {
                *value = f32::from_le_bytes(reader.take(4)?.try_into().expect("4 bytes"));
            }
            reader.take(2)?;
            if facet.iter().any(|v| !v.is_finite()) {
                return Err(reader.error("a facet has a coordinate that is not a finite number"));
            }
            let corner =
                |k: usize| Vec3::new(facet[3 + 3 * k] as f64, facet[4 + 3 * k] as f64, facet[5 + 3 * k] as f64);
            triangles.push([vertex(corner(0)), vertex(corner(1)), vertex(corner(2))]);
        }
    } else {
        let text = String::from_utf8_lossy(bytes);
        let mut lines = Lines::new(&text, path);
        let (line, first) = lines.next()?;
        if !first.starts_with("solid") {
            return Err(lines
                .error(line, "neither ASCII STL (starts with \"solid\") nor binary STL (84 bytes plus 50 per facet)"));
        }
        loop {
            let (line, text) = lines.next()?;
            let mut words = text.split_whitespace();
            match words.next() {
                Some("endsolid") => break,
                Some("facet") => {}
                _ => return Err(lines.error(line, format!("expected \"facet\" or \"endsolid\", found {text:?}"))),
            }
            let expect = |lines: &mut Lines, word: &str| -> Result<(), ImportError> {
                let (line, text) = lines.next()?;
                if text.split_whitespace().collect::<Vec<_>>().join(" ") == word {
                    Ok(())
                } else {
                    Err(lines.error(line, format!("expected {word:?}, found {text:?}")))
                }
            };
            expect(&mut lines, "outer loop")?;
            let mut corners = [0u32; 3];
            for corner in &mut corners {
                let (line, text) = lines.next()?;
                let values: Vec<&str> = text.split_whitespace().collect();
                let numbers: Option<Vec<f64>> =
                    values.get(1..).and_then(|v| v.iter().map(|x| x.parse().ok()).collect());
                match (values.first(), numbers) {
                    (Some(&"vertex"), Some(x)) if x.len() == 3 && x.iter().all(|v| v.is_finite()) => {
                        *corner = vertex(Vec3::new(x[0], x[1], x[2]))
                    }
                    _ => return Err(lines.error(line, format!("expected \"vertex x y z\", found {text:?}"))),
                }
            }
            expect(&mut lines, "endloop")?;
            expect(&mut lines, "endfacet")?;
            triangles.push(corners);
        }
    }
    if triangles.is_empty() {
        return Err(ImportError { path: path.into(), line: 0, message: "no facets".into() });
    }
    Ok((vertices, triangles))
}

#[cfg(test)]
mod tests {
    use super::*;
    use dea_core::surface::{check_closed, MassProperties};

    /// A mesh's outer surface as ASCII STL.
    fn stl_ascii(mesh: &HexMesh) -> String {
        let (vertices, triangles) = mesh.boundary();
        let mut text = String::from("solid body\n");
        for t in &triangles {
            text += "  facet normal 0 0 0\n    outer loop\n";
            for &v in t {
                let x = vertices[v as usize];
                text += &format!("      vertex {:?} {:?} {:?}\n", x.x, x.y, x.z);
            }
            text += "    endloop\n  endfacet\n";
        }
        text + "endsolid body\n"
    }

    /// The same as binary STL (single precision).
    fn stl_binary(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Vec<u8> {
        let mut bytes = vec![b' '; 80];
        bytes.extend((triangles.len() as u32).to_le_bytes());
        for t in triangles {
            bytes.extend([0.0f32; 3].iter().flat_map(|v| v.to_le_bytes()));
            for &v in t {
                bytes.extend(vertices[v as usize].iter().flat_map(|c| (*c as f32).to_le_bytes()));
            }
            bytes.extend([0u8; 2]);
        }
        bytes
    }

    #[test]
    fn stl_ascii_and_binary_read_back_and_name_bad_lines() {
        let mesh = HexMesh::cylinder(1.0, 2.0, 2, 1, 2);
        let (vertices, triangles) = parse_stl(stl_ascii(&mesh).as_bytes(), "a.stl").unwrap();
        assert_eq!((vertices, triangles.clone()), mesh.boundary());
        // binary: single precision, merged all the same
        let (vertices, binary_triangles) = parse_stl(&stl_binary(&mesh.boundary().0, &triangles), "b.stl").unwrap();
        assert_eq!(binary_triangles, triangles);
        assert_eq!(vertices.len(), mesh.boundary().0.len());
        // malformed: a bad vertex line, a missing keyword, a truncated binary file
        let bad = stl_ascii(&mesh).replacen("vertex", "vertex 1.0 two", 1);
        let e = parse_stl(bad.as_bytes(), "bad.stl").unwrap_err();
        assert_eq!((e.line, e.path.as_str()), (4, "bad.stl"), "{e}");
        let e = parse_stl(stl_ascii(&mesh).replacen("endloop", "end", 1).as_bytes(), "bad.stl").unwrap_err();
        assert!(e.message.contains("expected \"endloop\"") && e.line == 7, "{e}");
        let e = parse_stl(b"not a mesh", "x.stl").unwrap_err();
        assert!(e.message.contains("neither ASCII STL"), "{e}");
        let e = parse_stl(stl_ascii(&mesh).lines().take(9).collect::<Vec<_>>().join("\n").as_bytes(), "cut.stl")
            .unwrap_err();
        assert!(e.message.contains("end of file"), "{e}");
    }

    #[test]
    fn tetrahedra_give_a_rigid_surface_but_not_a_hexahedral_mesh() {
        // a unit cube of five tetrahedra, as Gmsh 4.1 ASCII
        let corners: Vec<Vec3> =
            (0..8).map(|k| Vec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64)).collect();
        // corners in binary order 0..7 = (x, y, z) bits; positive tetrahedra
        let tetrahedra = [[0, 1, 2, 4], [1, 3, 2, 7], [1, 2, 4, 7], [1, 7, 4, 5], [2, 4, 7, 6]];
        let mut text = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 8 1 8\n3 1 0 8\n");
        text += &(1..=8).map(|k| format!("{k}\n")).collect::<String>();
        text += &corners.iter().map(|x| format!("{} {} {}\n", x.x, x.y, x.z)).collect::<String>();
        text += "$EndNodes\n$Elements\n1 5 1 5\n3 1 4 5\n";
        text += &tetrahedra
            .iter()
            .enumerate()
            .map(|(k, t)| format!("{} {} {} {} {}\n", k + 1, t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1))
            .collect::<String>();
        text += "$EndElements\n";
        let dir = std::env::temp_dir().join(format!("dea-tet-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("cube.msh"), &text).unwrap();
        let (vertices, triangles) = read_surface(&dir.join("cube.msh")).unwrap();
        assert_eq!(check_closed(&triangles), Ok(()));
        assert!((MassProperties::of_surface(&vertices, &triangles).volume - 1.0).abs() < 1e-15);
        let e = read_mesh(&dir.join("cube.msh")).unwrap_err();
        assert!(e.message.contains("rigid projectile's surface only"), "{e}");
        // an inverted tetrahedron is refused with its line
        std::fs::write(dir.join("bad.msh"), text.replace("\n1 1 2 3 5\n", "\n1 1 3 2 5\n")).unwrap();
        let e = read_surface(&dir.join("bad.msh")).unwrap_err();
        assert!(e.message.contains("inverted") && e.line > 0, "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The generator's cylinder written as Gmsh 4.1 ASCII, with a few boundary lines mixed in.
    fn gmsh_ascii(mesh: &HexMesh) -> String {
        let mut text = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n");
        let n = mesh.nodes.len();
        text += &format!("1 {n} 1 {n}\n3 1 0 {n}\n");
        for k in 0..n {
            text += &format!("{}\n", k + 1);
        }
        for x in &mesh.nodes {
            text += &format!("{:?} {:?} {:?}\n", x.x, x.y, x.z);
        }
        text += "$EndNodes\n$Elements\n";
        let m = mesh.hexes.len();
        text += &format!("2 {} 1 {}\n1 1 1 1\n{} 1 2\n3 1 5 {m}\n", m + 1, m + 1, m + 1);
        for (k, h) in mesh.hexes.iter().enumerate() {
            text += &format!("{}", k + 1);
            for v in h {
                text += &format!(" {}", v + 1);
            }
            text += "\n";
        }
        text + "$EndElements\n"
    }

    fn gmsh_binary(mesh: &HexMesh) -> Vec<u8> {
        let mut b = b"$MeshFormat\n4.1 1 8\n".to_vec();
        b.extend(1i32.to_le_bytes());
        b.extend(b"\n$EndMeshFormat\n$Nodes\n");
        let n = mesh.nodes.len() as u64;
        for v in [1, n, 1, n] {
            b.extend(v.to_le_bytes());
        }
        for v in [3i32, 1, 0] {
            b.extend(v.to_le_bytes());
        }
        b.extend(n.to_le_bytes());
        for k in 1..=n {
            b.extend(k.to_le_bytes());
        }
        for x in &mesh.nodes {
            for c in x.iter() {
                b.extend(c.to_le_bytes());
            }
        }
        b.extend(b"\n$EndNodes\n$Elements\n");
        let m = mesh.hexes.len() as u64;
        for v in [1, m, 1, m] {
            b.extend(v.to_le_bytes());
        }
        for v in [3i32, 1, 5] {
            b.extend(v.to_le_bytes());
        }
        b.extend(m.to_le_bytes());
        for (k, h) in mesh.hexes.iter().enumerate() {
            b.extend((k as u64 + 1).to_le_bytes());
            for v in h {
                b.extend((*v as u64 + 1).to_le_bytes());
            }
        }
        b.extend(b"\n$EndElements\n");
        b
    }

    fn abaqus(mesh: &HexMesh) -> String {
        let mut text = String::from("** a cylinder\n*HEADING\ntest\n*NODE\n");
        for (k, x) in mesh.nodes.iter().enumerate() {
            text += &format!("{}, {:?}, {:?}, {:?}\n", k + 10, x.x, x.y, x.z);
        }
        text += "*Element, type=C3D8, elset=body\n";
        for (k, h) in mesh.hexes.iter().enumerate() {
            // every other element split over two lines
            let nodes: Vec<String> = h.iter().map(|v| (v + 10).to_string()).collect();
            if k % 2 == 0 {
                text += &format!("{}, {}\n", k + 1, nodes.join(", "));
            } else {
                text += &format!("{}, {},\n{}\n", k + 1, nodes[..5].join(", "), nodes[5..].join(", "));
            }
        }
        text
    }

    #[test]
    fn all_three_formats_give_back_the_generated_mesh() {
        let mesh = HexMesh::cylinder(1.7e-3, 3.7e-3, 3, 2, 3);
        for (name, imported) in [
            ("ascii.msh", parse_gmsh(gmsh_ascii(&mesh).as_bytes(), "ascii.msh")),
            ("binary.msh", parse_gmsh(&gmsh_binary(&mesh), "binary.msh")),
            ("mesh.inp", parse_abaqus(&abaqus(&mesh), "mesh.inp")),
        ] {
            let imported = imported.unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(imported, mesh, "{name}");
        }
    }

    #[test]
    fn malformed_files_name_the_line() {
        let mesh = HexMesh::cylinder(1.0, 1.0, 2, 1, 1);
        let good = gmsh_ascii(&mesh);
        // a letter in a coordinate (line of the first node's coordinates)
        let first_coordinates = 4 + 2 + mesh.nodes.len() + 1;
        let mut lines: Vec<String> = good.lines().map(String::from).collect();
        lines[first_coordinates - 1] = "0.0 x 1.0".into();
        let e = parse_gmsh(lines.join("\n").as_bytes(), "bad.msh").unwrap_err();
        assert_eq!((e.path.as_str(), e.line), ("bad.msh", first_coordinates), "{e}");
        assert_eq!(e.to_string(), format!("bad.msh:{first_coordinates}: not a number in \"0.0 x 1.0\""));
        // an element that names a missing node
        let broken = good.replacen("\n1 1 2 ", "\n1 9999 2 ", 1);
        let e = parse_gmsh(broken.as_bytes(), "bad.msh").unwrap_err();
        assert!(e.message.contains("node 9999") && e.line > 0, "{e}");
        // a prism block is refused where it starts
        let prisms = good.replace("\n3 1 5 ", "\n3 1 6 ");
        let e = parse_gmsh(prisms.as_bytes(), "prisms.msh").unwrap_err();
        assert!(e.message.contains("neither an 8-node hexahedron") && e.line > 0, "{e}");
        // counts a file claims: no allocation from them, and every listed line is read
        let n = mesh.nodes.len();
        for claimed in ["1000000000000000000", "18446744073709551615"] {
            let huge = good.replacen(&format!("\n3 1 0 {n}\n"), &format!("\n3 1 0 {claimed}\n"), 1);
            assert_ne!(huge, good);
            let e = parse_gmsh(huge.as_bytes(), "huge.msh").unwrap_err();
            assert!(e.line > 0, "{e}");
        }
        let m = mesh.hexes.len();
        let fewer = good.replacen(&format!("\n3 1 5 {m}\n"), &format!("\n3 1 5 {}\n", m - 1), 1);
        let e = parse_gmsh(fewer.as_bytes(), "fewer.msh").unwrap_err();
        assert!(e.message.contains("expected $EndElements"), "{e}");
        let header = good.replacen(&format!("\n2 {} 1 {}\n", m + 1, m + 1), &format!("\n2 {} 1 {}\n", m + 5, m + 1), 1);
        let e = parse_gmsh(header.as_bytes(), "header.msh").unwrap_err();
        assert!(e.message.contains(&format!("claims {} elements, its blocks hold {}", m + 5, m + 1)), "{e}");
        // an old format version, a truncated binary file
        assert!(parse_gmsh(b"$MeshFormat\n2.2 0 8\n", "old.msh").unwrap_err().message.contains("only 4.1"));
        let binary = gmsh_binary(&mesh);
        let e = parse_gmsh(&binary[..binary.len() - 40], "cut.msh").unwrap_err();
        assert!(e.message.contains("byte") && e.message.contains("end of file"), "{e}");
        // ABAQUS: a short node line and a wrong element type
        let e = parse_abaqus("*NODE\n1, 0.0, 0.0\n", "m.inp").unwrap_err();
        assert_eq!(e.line, 2, "{e}");
        let e = parse_abaqus("*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=C3D4\n1, 1, 1, 1, 1\n", "m.inp").unwrap_err();
        assert_eq!(e.line, 3, "{e}");
        // an inverted element
        let mut inverted = mesh.clone();
        inverted.hexes[0].swap(1, 3);
        inverted.hexes[0].swap(5, 7);
        let e = parse_abaqus(&abaqus(&inverted), "inv.inp").unwrap_err();
        assert!(e.message.contains("inverted"), "{e}");
    }

    #[test]
    fn files_are_read_by_their_extension() {
        let dir = std::env::temp_dir().join(format!("dea-import-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mesh = HexMesh::cylinder(1.0, 2.0, 2, 1, 2);
        std::fs::write(dir.join("p.msh"), gmsh_binary(&mesh)).unwrap();
        std::fs::write(dir.join("p.INP"), abaqus(&mesh)).unwrap();
        std::fs::write(dir.join("p.stl"), stl_ascii(&mesh)).unwrap();
        assert_eq!(read_mesh(&dir.join("p.msh")).unwrap(), mesh);
        assert_eq!(read_mesh(&dir.join("p.INP")).unwrap(), mesh);
        assert!(read_mesh(&dir.join("p.stl")).unwrap_err().to_string().contains("unknown mesh format"));
        // every format gives the same closed surface for a rigid projectile
        let expected = mesh.boundary();
        for name in ["p.msh", "p.INP"] {
            assert_eq!(read_surface(&dir.join(name)).unwrap(), expected, "{name}");
        }
        let (vertices, triangles) = read_surface(&dir.join("p.stl")).unwrap();
        assert_eq!(triangles.len(), expected.1.len());
        assert_eq!(check_closed(&triangles), Ok(()));
        assert!(
            (MassProperties::of_surface(&vertices, &triangles).volume
                - MassProperties::of_surface(&expected.0, &expected.1).volume)
                .abs()
                < 1e-12
        );
        assert!(read_mesh(&dir.join("none.msh")).unwrap_err().to_string().contains("cannot read"));
        // a device or a FIFO would block or never end: refused before a byte is read
        std::os::unix::fs::symlink("/dev/urandom", dir.join("random.msh")).unwrap();
        assert!(read_mesh(&dir.join("random.msh")).unwrap_err().message.contains("not a regular file"));
        assert!(std::process::Command::new("mkfifo").arg(dir.join("fifo.stl")).status().unwrap().success());
        assert!(read_surface(&dir.join("fifo.stl")).unwrap_err().message.contains("not a regular file"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
