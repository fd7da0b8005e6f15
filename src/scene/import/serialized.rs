//! Mitsuba's `.serialized` meshes (format versions 3 and 4): shapes one after
//! another, each a little-endian header (`0x041C`, version) and a zlib
//! stream (flags, name in version 4, vertex and face counts, positions,
//! normals, texture coordinates, colours, `u32` face indices); the file ends
//! with a table of each shape's offset and the shape count.
use super::MAX_MESH_ELEMENTS;
use crate::scene::shapes::Mesh;
use flate2::read::ZlibDecoder;
use std::io::Read;
use std::path::Path;

const FORMAT_ID: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const DOUBLE_PRECISION: u32 = 0x2000;

/// Which part of the request an error is about, for the scene key it names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// The file itself.
    File,
    /// The shape index.
    Index,
}

/// Mesh `shape_index` of the `.serialized` file at `path`; `smooth` keeps its
/// vertex normals for shading (unless the shape asks for face normals).
pub fn load(path: &Path, shape_index: u64, smooth: bool) -> Result<Mesh, (Fault, String)> {
    let bytes = std::fs::read(path).map_err(|e| (Fault::File, format!("cannot read: {e}")))?;
    parse(&bytes, shape_index, smooth)
}

/// Parse `.serialized` bytes (see [`load`]).
pub fn parse(bytes: &[u8], shape_index: u64, smooth: bool) -> Result<Mesh, (Fault, String)> {
    let file = |m: String| (Fault::File, m);
    let (format, version) = header(bytes, 0).map_err(file)?;
    if format != FORMAT_ID {
        return Err(file(format!(
            "not a Mitsuba .serialized file (format id {format:#06x}, expected 0x041c)"
        )));
    }
    if version != 3 && version != 4 {
        return Err(file(format!(
            "format version {version}: only versions 3 and 4 are read"
        )));
    }
    let start = if shape_index == 0 {
        0
    } else {
        let n = bytes.len();
        if n < 4 {
            return Err(file("the file is too short for its table of shapes".into()));
        }
        let count = u32::from_le_bytes(bytes[n - 4..].try_into().unwrap_or([0; 4])) as u64;
        if shape_index >= count {
            return Err((
                Fault::Index,
                format!("shape index {shape_index} is out of range: the file holds {count} shapes"),
            ));
        }
        let width = if version == 4 { 8 } else { 4 };
        let at = (count - shape_index)
            .checked_mul(width)
            .and_then(|b| (n as u64).checked_sub(4 + b))
            .ok_or_else(|| file("the table of shapes lies outside the file".into()))?
            as usize;
        let mut b = [0u8; 8];
        b[..width as usize].copy_from_slice(&bytes[at..at + width as usize]);
        let off = u64::from_le_bytes(b);
        if off >= n as u64 {
            return Err(file(format!(
                "shape {shape_index} starts at byte {off}, outside the file"
            )));
        }
        let (f, v) = header(bytes, off as usize).map_err(file)?;
        if f != FORMAT_ID || v != version {
            return Err(file(format!(
                "no shape header at byte {off} (shape {shape_index})"
            )));
        }
        off as usize
    };
    let mut z = ZlibDecoder::new(&bytes[start + 4..]);
    read_shape(&mut z, version, smooth).map_err(file)
}

fn header(bytes: &[u8], at: usize) -> Result<(u16, u16), String> {
    let h = bytes
        .get(at..at + 4)
        .ok_or("the file is too short for a shape header")?;
    Ok((u16::from_le_bytes([h[0], h[1]]), u16::from_le_bytes([h[2], h[3]])))
}

fn read_shape(z: &mut impl Read, version: u16, smooth: bool) -> Result<Mesh, String> {
    let flags = u32::from_le_bytes(read_n(z, 4)?.try_into().unwrap_or([0; 4]));
    if version == 4 {
        // The shape's name, null-terminated.
        let mut byte = [0u8; 1];
        for k in 0.. {
            z.read_exact(&mut byte)
                .map_err(|e| format!("in the shape's name: {e}"))?;
            if byte[0] == 0 {
                break;
            }
            if k > 1 << 16 {
                return Err("the shape's name is not terminated".into());
            }
        }
    }
    let nv = u64::from_le_bytes(read_n(z, 8)?.try_into().unwrap_or([0; 8]));
    let nf = u64::from_le_bytes(read_n(z, 8)?.try_into().unwrap_or([0; 8]));
    if nv > MAX_MESH_ELEMENTS || nf > MAX_MESH_ELEMENTS {
        return Err(format!(
            "{nv} vertices and {nf} triangles: more than {MAX_MESH_ELEMENTS} are refused"
        ));
    }
    let fsize = if flags & DOUBLE_PRECISION != 0 { 8 } else { 4 };
    let floats = |z: &mut dyn Read, dim: u64| -> Result<Vec<f32>, String> {
        let raw = read_n(z, (nv * dim * fsize) as usize)?;
        Ok(if fsize == 8 {
            raw.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f32)
                .collect()
        } else {
            raw.chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap_or([0; 4])))
                .collect()
        })
    };
    let pos = floats(z, 3)?;
    let mut mesh = Mesh {
        positions: pos.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        ..Mesh::default()
    };
    if flags & HAS_NORMALS != 0 {
        let n = floats(z, 3)?;
        if smooth && flags & FACE_NORMALS == 0 {
            mesh.normals = Some(n.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect());
        }
    }
    if flags & HAS_TEXCOORDS != 0 {
        let t = floats(z, 2)?;
        mesh.uvs = Some(t.chunks_exact(2).map(|c| [c[0], c[1]]).collect());
    }
    if flags & HAS_COLORS != 0 {
        floats(z, 3)?;
    }
    let raw = read_n(z, (nf * 12) as usize)?;
    mesh.indices = raw
        .chunks_exact(12)
        .map(|c| {
            let w = |k: usize| u32::from_le_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
            [w(0), w(4), w(8)]
        })
        .collect();
    Ok(mesh)
}

/// Exactly `n` bytes of the stream, grown as they arrive (a lying count
/// fails at the stream's end, not at the allocation).
fn read_n(z: &mut (impl Read + ?Sized), n: usize) -> Result<Vec<u8>, String> {
    let mut v = Vec::with_capacity(n.min(1 << 24));
    z.take(n as u64)
        .read_to_end(&mut v)
        .map_err(|e| format!("the compressed mesh data is corrupt: {e}"))?;
    if v.len() != n {
        return Err(format!("the mesh data ends early ({} of {n} bytes)", v.len()));
    }
    Ok(v)
}

/// One shape as a version 4 `.serialized` file (for tests and the fuzzer's seeds).
pub fn write_v4(mesh: &Mesh, name: &str) -> Vec<u8> {
    use flate2::write::ZlibEncoder;
    use std::io::Write;
    let mut raw = Vec::new();
    let mut flags = 0u32;
    if mesh.normals.is_some() {
        flags |= HAS_NORMALS;
    }
    if mesh.uvs.is_some() {
        flags |= HAS_TEXCOORDS;
    }
    raw.extend(flags.to_le_bytes());
    raw.extend(name.as_bytes());
    raw.push(0);
    raw.extend((mesh.positions.len() as u64).to_le_bytes());
    raw.extend((mesh.indices.len() as u64).to_le_bytes());
    for p in &mesh.positions {
        p.iter().for_each(|c| raw.extend(c.to_le_bytes()));
    }
    for n in mesh.normals.iter().flatten() {
        n.iter().for_each(|c| raw.extend(c.to_le_bytes()));
    }
    for t in mesh.uvs.iter().flatten() {
        t.iter().for_each(|c| raw.extend(c.to_le_bytes()));
    }
    for t in &mesh.indices {
        t.iter().for_each(|i| raw.extend(i.to_le_bytes()));
    }
    let mut out = Vec::new();
    out.extend(FORMAT_ID.to_le_bytes());
    out.extend(4u16.to_le_bytes());
    let mut enc = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    let _ = enc.write_all(&raw);
    out.extend(enc.finish().unwrap_or_default());
    out.extend(0u64.to_le_bytes());
    out.extend(1u32.to_le_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_hostile_counts() {
        let m = Mesh {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            indices: vec![[0, 1, 2]],
            normals: Some(vec![[0.0, 0.0, 1.0]; 3]),
            uvs: None,
        };
        let bytes = write_v4(&m, "tri");
        let r = parse(&bytes, 0, true).unwrap();
        assert_eq!(r.positions, m.positions);
        assert_eq!(r.indices, m.indices);
        assert_eq!(r.normals, m.normals);
        assert_eq!(parse(&bytes, 1, true).unwrap_err().0, Fault::Index);
        // A stream cut short: its counts promise more than it holds.
        let mut b = bytes.clone();
        b.truncate(b.len() - 20);
        assert!(parse(&b, 0, true).is_err());
    }
}
