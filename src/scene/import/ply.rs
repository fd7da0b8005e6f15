//! A PLY reader (ASCII and binary, either byte order) for triangle meshes:
//! `vertex` positions with optional normals (`nx ny nz`) and texture
//! coordinates (`u v`, `s t` or `texture_u texture_v`), `face` polygons
//! (fan-triangulated); other elements and properties are read past. Counts
//! are checked against the bytes left before anything is allocated.
use super::MAX_MESH_ELEMENTS;
use crate::scene::shapes::Mesh;
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

struct Property {
    name: String,
    /// For a list: the type of its length.
    count: Option<Scalar>,
    value: Scalar,
}

struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// Values of one element, read in order from the body.
struct Body<'a> {
    bytes: &'a [u8],
    pos: usize,
    enc: Encoding,
}

impl Body<'_> {
    fn left(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn next(&mut self, t: Scalar) -> Result<f64, String> {
        if self.enc == Encoding::Ascii {
            while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            let start = self.pos;
            while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            let tok = std::str::from_utf8(&self.bytes[start..self.pos]).unwrap_or("");
            if tok.is_empty() {
                return Err("the file ends before its elements do".into());
            }
            return tok.parse::<f64>().map_err(|_| {
                format!(
                    "expected a number, got \"{}\"",
                    tok.chars().take(40).collect::<String>()
                )
            });
        }
        let n = t.size();
        if self.left() < n {
            return Err("the file ends before its elements do".into());
        }
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(&self.bytes[self.pos..self.pos + n]);
        self.pos += n;
        if self.enc == Encoding::Big {
            b[..n].reverse();
        }
        Ok(match t {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }
}

/// Read a PLY file's triangles; `smooth` keeps its vertex normals for shading.
pub fn load(path: &Path, smooth: bool) -> Result<Mesh, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    parse(&bytes, smooth)
}

/// Parse PLY bytes (see [`load`]).
pub fn parse(bytes: &[u8], smooth: bool) -> Result<Mesh, String> {
    let end = find(bytes, b"end_header").ok_or("not a PLY file: no end_header line")?;
    let mut body_start = end + b"end_header".len();
    if bytes.get(body_start) == Some(&b'\r') {
        body_start += 1;
    }
    if bytes.get(body_start) == Some(&b'\n') {
        body_start += 1;
    }
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| "the PLY header is not text")?;
    let mut lines = header.lines().map(str::trim);
    if lines.next() != Some("ply") {
        return Err("not a PLY file: the first line must be \"ply\"".into());
    }
    let mut enc = None;
    let mut elements: Vec<Element> = Vec::new();
    for (n, line) in lines.enumerate() {
        let line_no = n + 2;
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                enc = Some(match *f {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Little,
                    "binary_big_endian" => Encoding::Big,
                    o => return Err(format!("header line {line_no}: unknown format \"{o}\"")),
                })
            }
            ["element", name, count] => {
                let count: u64 = count.parse().map_err(|_| {
                    format!("header line {line_no}: expected an element count, got \"{count}\"")
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            ["property", "list", ct, vt, name] => {
                let e = elements
                    .last_mut()
                    .ok_or(format!("header line {line_no}: a property before any element"))?;
                let (Some(c), Some(v)) = (Scalar::parse(ct), Scalar::parse(vt)) else {
                    return Err(format!("header line {line_no}: unknown list types \"{ct} {vt}\""));
                };
                if matches!(c, Scalar::F32 | Scalar::F64) {
                    return Err(format!(
                        "header line {line_no}: a list length must be an integer type"
                    ));
                }
                e.props.push(Property {
                    name: name.to_string(),
                    count: Some(c),
                    value: v,
                });
            }
            ["property", t, name] => {
                let e = elements
                    .last_mut()
                    .ok_or(format!("header line {line_no}: a property before any element"))?;
                let v = Scalar::parse(t).ok_or(format!("header line {line_no}: unknown type \"{t}\""))?;
                e.props.push(Property {
                    name: name.to_string(),
                    count: None,
                    value: v,
                });
            }
            _ => {
                return Err(format!(
                    "header line {line_no}: expected format, element, property or comment, got \"{}\"",
                    line.chars().take(60).collect::<String>()
                ))
            }
        }
    }
    let enc = enc.ok_or("the PLY header has no format line")?;
    let mut body = Body {
        bytes,
        pos: body_start.min(bytes.len()),
        enc,
    };
    let mut mesh = Mesh::default();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut seen_vertex = false;
    for e in &elements {
        // Every element takes at least a byte: a count beyond the bytes left is a lie.
        if e.count > MAX_MESH_ELEMENTS || e.count > body.left() as u64 {
            return Err(format!(
                "element \"{}\" claims {} entries, more than the file holds (or than {MAX_MESH_ELEMENTS})",
                e.name, e.count
            ));
        }
        let idx = |n: &str| e.props.iter().position(|p| p.name == n && p.count.is_none());
        match e.name.as_str() {
            "vertex" => {
                seen_vertex = true;
                let (Some(x), Some(y), Some(z)) = (idx("x"), idx("y"), idx("z")) else {
                    return Err("element \"vertex\" needs properties x, y, z".into());
                };
                let n = match (idx("nx"), idx("ny"), idx("nz")) {
                    (Some(a), Some(b), Some(c)) if smooth => Some([a, b, c]),
                    _ => None,
                };
                let uv = match (idx("u"), idx("v")) {
                    (Some(a), Some(b)) => Some([a, b]),
                    _ => match (idx("s"), idx("t")) {
                        (Some(a), Some(b)) => Some([a, b]),
                        _ => match (idx("texture_u"), idx("texture_v")) {
                            (Some(a), Some(b)) => Some([a, b]),
                            _ => None,
                        },
                    },
                };
                let mut vals = vec![0.0; e.props.len()];
                for _ in 0..e.count {
                    read_element(&mut body, e, &mut vals)?;
                    mesh.positions
                        .push([vals[x] as f32, vals[y] as f32, vals[z] as f32]);
                    if let Some([a, b, c]) = n {
                        normals.push([vals[a] as f32, vals[b] as f32, vals[c] as f32]);
                    }
                    if let Some([a, b]) = uv {
                        uvs.push([vals[a] as f32, vals[b] as f32]);
                    }
                }
            }
            "face" => {
                let li = e
                    .props
                    .iter()
                    .position(|p| {
                        p.count.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index")
                    })
                    .ok_or("element \"face\" needs a list property vertex_indices")?;
                for _ in 0..e.count {
                    let mut poly = Vec::new();
                    for (k, p) in e.props.iter().enumerate() {
                        match p.count {
                            None => {
                                body.next(p.value)?;
                            }
                            Some(ct) => {
                                let len = list_len(&mut body, ct)?;
                                for _ in 0..len {
                                    let v = body.next(p.value)?;
                                    if k == li {
                                        if !(v >= 0.0 && v <= u32::MAX as f64 && v.fract() == 0.0) {
                                            return Err(format!("face index {v} is not a vertex index"));
                                        }
                                        poly.push(v as u32);
                                    }
                                }
                            }
                        }
                    }
                    for j in 1..poly.len().saturating_sub(1) {
                        mesh.indices.push([poly[0], poly[j], poly[j + 1]]);
                    }
                    if mesh.indices.len() as u64 > MAX_MESH_ELEMENTS {
                        return Err(format!("more than {MAX_MESH_ELEMENTS} triangles"));
                    }
                }
            }
            _ => {
                let mut vals = vec![0.0; e.props.len()];
                for _ in 0..e.count {
                    read_element(&mut body, e, &mut vals)?;
                }
            }
        }
    }
    if !seen_vertex {
        return Err("the PLY file has no vertex element".into());
    }
    if !normals.is_empty() {
        mesh.normals = Some(normals);
    }
    if !uvs.is_empty() {
        mesh.uvs = Some(uvs);
    }
    Ok(mesh)
}

/// One element's scalar properties into `vals` (lists are read past).
fn read_element(body: &mut Body<'_>, e: &Element, vals: &mut [f64]) -> Result<(), String> {
    for (k, p) in e.props.iter().enumerate() {
        match p.count {
            None => vals[k] = body.next(p.value)?,
            Some(ct) => {
                let len = list_len(body, ct)?;
                for _ in 0..len {
                    body.next(p.value)?;
                }
            }
        }
    }
    Ok(())
}

/// A list's length, checked against the bytes left.
fn list_len(body: &mut Body<'_>, ct: Scalar) -> Result<u64, String> {
    let len = body.next(ct)?;
    if !(len >= 0.0 && len.fract() == 0.0 && len <= body.left() as f64) {
        return Err(format!("a list claims {len} entries, more than the file holds"));
    }
    Ok(len as u64)
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_and_binary_give_the_same_quad() {
        let ascii = b"ply\nformat ascii 1.0\ncomment x\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
        let a = parse(ascii, true).unwrap();
        assert_eq!(a.indices, vec![[0, 1, 2], [0, 2, 3]]);
        let mut bin = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
        for p in &a.positions {
            for c in p {
                bin.extend(c.to_be_bytes());
            }
        }
        bin.push(4);
        for i in [0i32, 1, 2, 3] {
            bin.extend(i.to_be_bytes());
        }
        let b = parse(&bin, true).unwrap();
        assert_eq!(a.positions, b.positions);
        assert_eq!(a.indices, b.indices);
    }

    #[test]
    fn lying_counts_are_refused_before_allocating() {
        let t = b"ply\nformat binary_little_endian 1.0\nelement vertex 99999999999\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
        let e = parse(t, true).unwrap_err();
        assert!(e.contains("claims"), "{e}");
    }
}
