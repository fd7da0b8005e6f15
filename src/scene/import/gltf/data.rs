//! A glTF file's bytes: the document (first checked for what the `gltf`
//! crate would index or unwrap unchecked, then validated by the crate, its
//! errors as JSON pointers), its buffers (the GLB's binary chunk, `data:`
//! URIs, or files beside it; each checked to hold its declared length), and
//! accessors read with checked bounds, so a hostile file is refused rather
//! than indexed out of range.
use crate::scene::import::MAX_MESH_ELEMENTS;
use crate::scene::shapes::Mesh;
use gltf::accessor::{DataType, Dimensions};
use std::path::{Path, PathBuf};

/// Largest glTF/GLB file read, and largest external buffer.
const MAX_FILE_BYTES: u64 = 1 << 31;

/// A loaded glTF file: the document and its buffers' bytes.
pub struct GltfData {
    /// The validated document.
    pub doc: gltf::Document,
    /// Each buffer's bytes, at least its declared `byteLength` long.
    pub buffers: Vec<Vec<u8>>,
    /// The file's directory (for URIs).
    pub dir: PathBuf,
}

/// An error at a JSON pointer of the file.
pub type PtrError = (String, String);

/// `a.b[0].c` (the crate's paths) as the JSON pointer `/a/b/0/c`.
pub fn pointer(path: &str) -> String {
    let mut out = String::new();
    for part in path.split('.') {
        let mut rest = part;
        if let Some(b) = rest.find('[') {
            out.push('/');
            out.push_str(&rest[..b]);
            rest = &rest[b..];
            while let Some(s) = rest.strip_prefix('[') {
                let end = s.find(']').unwrap_or(s.len());
                out.push('/');
                out.push_str(&s[..end]);
                rest = s.get(end + 1..).unwrap_or("");
            }
        } else if !rest.is_empty() {
            out.push('/');
            out.push_str(rest);
        }
    }
    if out.is_empty() {
        "/".into()
    } else {
        out
    }
}

/// Read and validate the glTF file at `path` and its buffers.
pub fn load(path: &Path) -> Result<GltfData, PtrError> {
    let len = std::fs::metadata(path)
        .map_err(|e| ("/".to_string(), format!("cannot read: {e}")))?
        .len();
    if len > MAX_FILE_BYTES {
        return Err((
            "/".into(),
            format!("{len} bytes: files over {MAX_FILE_BYTES} bytes are refused"),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| ("/".to_string(), format!("cannot read: {e}")))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    parse(&bytes, &dir)
}

/// Parse glTF or GLB bytes; `dir` resolves external buffers.
pub fn parse(bytes: &[u8], dir: &Path) -> Result<GltfData, PtrError> {
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(crate_error)?;
    let root = document.into_json();
    unchecked_by_the_crate(&root)?;
    let doc = gltf::Document::from_json(root).map_err(crate_error)?;
    let mut buffers = Vec::new();
    for b in doc.buffers() {
        let at = format!("/buffers/{}", b.index());
        let mut data = match b.source() {
            gltf::buffer::Source::Bin => blob.clone().ok_or_else(|| {
                (
                    at.clone(),
                    "refers to the GLB binary chunk, but the file has none".to_string(),
                )
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(uri, dir).map_err(|e| (format!("{at}/uri"), e))?,
        };
        if data.len() < b.length() {
            return Err((
                format!("{at}/byteLength"),
                format!("declares {} bytes, but its data has {}", b.length(), data.len()),
            ));
        }
        data.truncate(b.length());
        buffers.push(data);
    }
    Ok(GltfData {
        doc,
        buffers,
        dir: dir.to_path_buf(),
    })
}

/// The `gltf` crate's error as a JSON pointer and a message.
fn crate_error(e: gltf::Error) -> PtrError {
    match e {
        gltf::Error::Validation(v) => {
            let (p, err) = &v[0];
            (
                pointer(&p.to_string()),
                format!(
                    "{err}{}",
                    if v.len() > 1 {
                        format!(" (and {} more)", v.len() - 1)
                    } else {
                        String::new()
                    }
                ),
            )
        }
        gltf::Error::Deserialize(d) => (
            "/".into(),
            format!(
                "not valid glTF JSON at line {}, column {}: {d}",
                d.line(),
                d.column()
            ),
        ),
        other => ("/".into(), other.to_string()),
    }
}

/// What the `gltf` crate's validation or its accessors index or unwrap
/// without checking, so that a document the crate would panic on is refused
/// at a pointer: a POSITION attribute naming an accessor that does not exist
/// (the validation indexes it), an image with neither a `uri` nor a
/// `bufferView`, or in a view without a `mimeType` (`Image::source`), and a
/// camera without the projection object its `type` names
/// (`Camera::projection`).
fn unchecked_by_the_crate(root: &gltf::json::Root) -> Result<(), PtrError> {
    let n_acc = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (sem, a) in &prim.attributes {
                if a.value() >= n_acc {
                    return Err((
                        format!("/meshes/{m}/primitives/{p}/attributes/{}", sem.to_string()),
                        format!("accessor {} does not exist (the file has {n_acc})", a.value()),
                    ));
                }
            }
        }
    }
    for (i, im) in root.images.iter().enumerate() {
        match (&im.uri, &im.buffer_view, &im.mime_type) {
            (None, None, _) => {
                return Err((
                    format!("/images/{i}"),
                    "an image needs a uri or a bufferView".into(),
                ))
            }
            (None, Some(_), None) => {
                return Err((
                    format!("/images/{i}/mimeType"),
                    "an image in a bufferView needs a mimeType".into(),
                ))
            }
            _ => {}
        }
    }
    for (i, c) in root.cameras.iter().enumerate() {
        use gltf::json::camera::Type;
        use gltf::json::validation::Checked;
        let missing = match c.type_ {
            Checked::Valid(Type::Perspective) if c.perspective.is_none() => "perspective",
            Checked::Valid(Type::Orthographic) if c.orthographic.is_none() => "orthographic",
            _ => continue,
        };
        return Err((
            format!("/cameras/{i}/{missing}"),
            format!("the camera's type is {missing}, but it has no {missing} object"),
        ));
    }
    Ok(())
}

/// A buffer URI's bytes: `data:…;base64,…` or a file relative to `dir`.
fn read_uri(uri: &str, dir: &Path) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, b64) = rest
            .split_once(";base64,")
            .ok_or("only base64 data URIs are read")?;
        return base64(b64);
    }
    if uri.contains("://") {
        return Err(format!(
            "\"{uri}\": only files beside the glTF and data URIs are read"
        ));
    }
    let path = dir.join(percent_decode(uri));
    let len = std::fs::metadata(&path)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .len();
    if len > MAX_FILE_BYTES {
        return Err(format!("{}: over {MAX_FILE_BYTES} bytes", path.display()));
    }
    std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))
}

/// `%20` and friends in a relative URI.
pub fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let Some(v) = std::str::from_utf8(&b[i + 1..i + 3])
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok())
            {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn base64(s: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0);
    for c in s.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' | b'\n' | b'\r' | b' ' => continue,
            _ => return Err("invalid base64 in a data URI".into()),
        };
        acc = (acc << 6) | v as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

impl GltfData {
    /// Accessor `a` as rows of `N` floats (normalised integers scaled to
    /// [0, 1] or [-1, 1]), every byte checked to lie in its buffer.
    pub fn floats<const N: usize>(&self, a: &gltf::Accessor<'_>) -> Result<Vec<[f32; N]>, PtrError> {
        let at = format!("/accessors/{}", a.index());
        let dims = match a.dimensions() {
            Dimensions::Scalar => 1,
            Dimensions::Vec2 => 2,
            Dimensions::Vec3 => 3,
            Dimensions::Vec4 => 4,
            _ => 0,
        };
        if dims != N {
            return Err((
                format!("{at}/type"),
                format!("expected {N} components per element"),
            ));
        }
        let ty = a.data_type();
        if ty != DataType::F32 && !a.normalized() {
            return Err((
                format!("{at}/componentType"),
                "expected floats or normalised integers".into(),
            ));
        }
        let raw = self.raw(a, N)?;
        let size = comp_size(ty);
        Ok(raw
            .iter()
            .map(|e| {
                let mut r = [0f32; N];
                for (k, v) in r.iter_mut().enumerate() {
                    *v = component(ty, &e[k * size..(k + 1) * size]);
                }
                r
            })
            .collect())
    }

    /// Accessor `a` as vertex indices (unsigned integers).
    pub fn indices(&self, a: &gltf::Accessor<'_>) -> Result<Vec<u32>, PtrError> {
        let at = format!("/accessors/{}", a.index());
        let ty = a.data_type();
        if !matches!(ty, DataType::U8 | DataType::U16 | DataType::U32) || a.dimensions() != Dimensions::Scalar
        {
            return Err((
                format!("{at}/componentType"),
                "expected unsigned integer scalars for indices".into(),
            ));
        }
        let size = comp_size(ty);
        Ok(self
            .raw(a, 1)?
            .iter()
            .map(|e| index_component(ty, &e[..size]))
            .collect())
    }

    /// The element byte slices of accessor `a` (`n` components each).
    fn raw<'s>(&'s self, a: &gltf::Accessor<'_>, n: usize) -> Result<Vec<&'s [u8]>, PtrError> {
        let at = format!("/accessors/{}", a.index());
        if a.sparse().is_some() {
            return Err((format!("{at}/sparse"), "sparse accessors are not read".into()));
        }
        let count = a.count();
        if count as u64 > MAX_MESH_ELEMENTS {
            return Err((
                format!("{at}/count"),
                format!("{count} elements: more than {MAX_MESH_ELEMENTS}"),
            ));
        }
        let view = a.view().ok_or_else(|| {
            (
                format!("{at}/bufferView"),
                "an accessor without a buffer view is not read".to_string(),
            )
        })?;
        let elem = comp_size(a.data_type()) * n;
        let stride = view.stride().unwrap_or(elem).max(elem);
        let data = self.buffers.get(view.buffer().index()).ok_or_else(|| {
            (
                format!("/bufferViews/{}/buffer", view.index()),
                "no such buffer".to_string(),
            )
        })?;
        let bad = || {
            (
                format!("{at}/count"),
                format!("{count} elements do not fit in buffer view {}", view.index()),
            )
        };
        let view_end = view.offset().checked_add(view.length()).ok_or_else(bad)?;
        if view_end > data.len() {
            return Err((
                format!("/bufferViews/{}/byteLength", view.index()),
                "the view runs past the end of its buffer".into(),
            ));
        }
        let start = view.offset().checked_add(a.offset()).ok_or_else(bad)?;
        if count == 0 {
            return Ok(Vec::new());
        }
        let last = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(start))
            .and_then(|x| x.checked_add(elem))
            .ok_or_else(bad)?;
        if last > view_end {
            return Err(bad());
        }
        Ok((0..count)
            .map(|i| &data[start + i * stride..start + i * stride + elem])
            .collect())
    }

    /// Primitive `p` of mesh `m` as triangles (glTF's texture v runs down
    /// the image, snell's up: v is flipped).
    pub fn primitive(&self, m: usize, p: usize, smooth: bool) -> Result<Mesh, PtrError> {
        let mesh = self.doc.meshes().nth(m).ok_or_else(|| {
            (
                "/meshes".to_string(),
                format!("no mesh {m} (the file has {})", self.doc.meshes().len()),
            )
        })?;
        let prim = mesh.primitives().nth(p).ok_or_else(|| {
            (
                format!("/meshes/{m}/primitives"),
                format!("no primitive {p} (the mesh has {})", mesh.primitives().len()),
            )
        })?;
        let at = format!("/meshes/{m}/primitives/{p}");
        if prim.mode() != gltf::mesh::Mode::Triangles {
            return Err((
                format!("{at}/mode"),
                "only triangle primitives (mode 4) are read".into(),
            ));
        }
        let pos = prim.get(&gltf::Semantic::Positions).ok_or_else(|| {
            (
                format!("{at}/attributes"),
                "expected a POSITION attribute".to_string(),
            )
        })?;
        let positions = self.floats::<3>(&pos)?;
        let n = positions.len();
        let normals = match prim.get(&gltf::Semantic::Normals) {
            Some(a) if smooth => Some(self.floats::<3>(&a)?),
            _ => None,
        };
        let uvs = match prim.get(&gltf::Semantic::TexCoords(0)) {
            Some(a) => Some(
                self.floats::<2>(&a)?
                    .into_iter()
                    .map(|[u, v]| [u, 1.0 - v])
                    .collect::<Vec<_>>(),
            ),
            None => None,
        };
        for (what, len) in [
            ("NORMAL", normals.as_ref().map(Vec::len)),
            ("TEXCOORD_0", uvs.as_ref().map(Vec::len)),
        ] {
            if len.is_some_and(|l| l != n) {
                return Err((
                    format!("{at}/attributes/{what}"),
                    format!("expected {n} elements, as POSITION"),
                ));
            }
        }
        let flat: Vec<u32> = match prim.indices() {
            Some(a) => self.indices(&a)?,
            None => (0..n as u32).collect(),
        };
        if !flat.len().is_multiple_of(3) {
            return Err((
                format!("{at}/indices"),
                "the index count is not a multiple of 3".into(),
            ));
        }
        let indices: Vec<[u32; 3]> = flat.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        if let Some(t) = indices.iter().find(|t| t.iter().any(|&i| i as usize >= n)) {
            return Err((
                format!("{at}/indices"),
                format!("triangle {t:?} uses a vertex beyond the {n} vertices"),
            ));
        }
        Ok(Mesh {
            positions,
            indices,
            normals,
            uvs,
        })
    }
}

fn comp_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// One little-endian float component (normalised integers scaled to
/// [0, 1] or [-1, 1]).
fn component(t: DataType, b: &[u8]) -> f32 {
    match t {
        DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        DataType::U8 => b[0] as f32 / 255.0,
        DataType::I8 => (b[0] as i8 as f32 / 127.0).max(-1.0),
        DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
        DataType::I16 => (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0),
        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32 / u32::MAX as f32,
    }
}

/// The exact u32 of an index component (f32 would round large indices).
pub fn index_component(t: DataType, b: &[u8]) -> u32 {
    match t {
        DataType::U8 => b[0] as u32,
        DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
        _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pointers_and_base64() {
        assert_eq!(
            pointer("meshes[0].primitives[1].indices"),
            "/meshes/0/primitives/1/indices"
        );
        assert_eq!(base64("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
    }
}
