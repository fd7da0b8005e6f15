//! The pipeline's warped copies of the meshes, and which copy keys share
//! one.
use crate::embree::DynamicMesh;
use crate::warp::{CopyKey, Family, WarpGlass};

/// A warped copy of the meshes kept across frames: one BVH holding the
/// triangles of one or more copy keys (`groups`).
pub(super) struct MeshCopy {
    /// Its keys, each with a slab of the vertex array (member m's images at
    /// `m·nv..(m+1)·nv`) and a run of its triangles.
    pub(super) members: Vec<CopyKey>,
    /// Per member: its bit in `Pipeline::masks` (index in `Pipeline::keys`).
    pub(super) member_bits: Vec<u8>,
    /// Per member: the end of its triangles in `tri_ids`.
    pub(super) member_ends: Vec<usize>,
    pub(super) mesh: DynamicMesh,
    /// Per triangle of the copy: its index in `Pipeline::tris`.
    pub(super) tri_ids: Vec<u32>,
    /// Next frame's vertex array (swapped with the mesh's).
    pub(super) next: Vec<[f32; 3]>,
    /// The tube's copies: per vertex of `next`, its `Frustum::outcode`.
    pub(super) codes: Vec<u8>,
    /// Built once in `Pipeline::new` and never updated: the tube's direct
    /// copy, every triangle at its unwarped position (see `Pipeline::new`).
    pub(super) fixed: bool,
}

impl MeshCopy {
    /// The key of the copy's triangle `prim`.
    pub(super) fn key_of(&self, prim: usize) -> CopyKey {
        let m = self.member_ends.iter().position(|&end| prim < end).unwrap_or(0);
        self.members[m]
    }
}

/// The copy keys that share one BVH. A ray asks one BVH for the nearest
/// hit among its members, which must be the nearest hit the ray would
/// take from the members queried one by one.
///
/// The plate: its direct triangles (vertices in front of the near face,
/// unmoved) lie wholly in front of the near face's plane, the warped ones
/// wholly behind it (a warped vertex keeps a normal depth `a − L > 0`,
/// since `a ≥ W > L`). Along an eye ray every direct hit comes before the
/// plane (where a direct query alone would stop) and every warped hit
/// after it, and a ray that does not cross the plane reaches no warped
/// triangle. So one query per tile instead of two, and no classification.
///
/// The tube keeps one BVH per key: hollow2 + through4 (asked by the same
/// rays) and tir2 − + (on the two sides of the plane through the eye and
/// the axis, which a ray from the eye does not cross) could share one
/// exactly, but that is no faster (docs/warp.md). The direct copy
/// must stay alone: its query stops at the tube, and a direct triangle
/// across the tube's silhouette would otherwise show through it.
pub(super) fn groups(glass: &WarpGlass, keys: &[CopyKey]) -> Vec<Vec<CopyKey>> {
    let group = |k: &CopyKey| match (glass, k.family) {
        (WarpGlass::Plate(_), _) => 0,
        (_, Family::Direct) => 0,
        (_, Family::Through4) => 1,
        (_, Family::Hollow2) => 2,
        (_, Family::Tir2) => 3 + (k.side > 0) as usize,
        (_, Family::Wall2) => 5 + (k.side > 0) as usize,
    };
    let mut out: Vec<Vec<CopyKey>> = Vec::new();
    for g in 0..7 {
        let members: Vec<CopyKey> = keys.iter().filter(|k| group(k) == g).copied().collect();
        if !members.is_empty() {
            out.push(members);
        }
    }
    out
}
