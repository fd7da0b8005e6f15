//! Mesh files by extension, for the `mesh` shape: OBJ, PLY, Mitsuba
//! `.serialized` and glTF primitives, each checked the same way (indices in
//! range, finite positions, attribute arrays as long as the positions).
use super::{gltf, ply, serialized};
use crate::scene::desc::MeshDesc;
use crate::scene::meshgen;
use crate::scene::shapes::Mesh;
use std::path::Path;

/// The triangles of mesh shape `m` read from `path` (its `file`, resolved).
/// On failure: the key of `m` at fault (`file`, `shape_index`, `mesh`,
/// `primitive`) and what is wrong.
pub fn load_mesh(path: &Path, m: &MeshDesc) -> Result<Mesh, (&'static str, String)> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let only = |key: &'static str, v: Option<u64>, kind: &str| match v {
        Some(_) => Err((key, format!("{key} applies only to {kind} files"))),
        None => Ok(()),
    };
    let mesh = match ext.as_str() {
        "serialized" => {
            only("mesh", m.mesh, "glTF")?;
            only("primitive", m.primitive, "glTF")?;
            serialized::load(path, m.shape_index.unwrap_or(0), m.smooth).map_err(|(f, e)| match f {
                serialized::Fault::Index => ("shape_index", e),
                serialized::Fault::File => ("file", e),
            })?
        }
        "gltf" | "glb" => {
            only("shape_index", m.shape_index, ".serialized")?;
            gltf::load_primitive(path, m.mesh.unwrap_or(0), m.primitive.unwrap_or(0), m.smooth)?
        }
        _ => {
            only("shape_index", m.shape_index, ".serialized")?;
            only("mesh", m.mesh, "glTF")?;
            only("primitive", m.primitive, "glTF")?;
            if ext == "ply" {
                ply::load(path, m.smooth).map_err(|e| ("file", e))?
            } else {
                meshgen::load_obj(path, m.smooth).map_err(|e| ("file", e))?
            }
        }
    };
    check(&mesh).map_err(|e| ("file", e))?;
    Ok(mesh)
}

/// What every mesh must satisfy before it is built.
pub(crate) fn check(m: &Mesh) -> Result<(), String> {
    if m.indices.is_empty() {
        return Err("the mesh has no triangles".into());
    }
    let n = m.positions.len();
    if let Some((k, t)) = m
        .indices
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&i| i as usize >= n))
    {
        return Err(format!(
            "triangle {} uses vertex {:?}, but there are {n} vertices",
            k + 1,
            t
        ));
    }
    if let Some(k) = m.positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("vertex {} has a non-finite coordinate", k + 1));
    }
    if m.normals.as_ref().is_some_and(|v| v.len() != n) {
        return Err("the normals are not one per vertex".into());
    }
    if m.uvs.as_ref().is_some_and(|v| v.len() != n) {
        return Err("the texture coordinates are not one per vertex".into());
    }
    Ok(())
}
