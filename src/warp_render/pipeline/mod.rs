//! The warp renderer for many frames (interactive viewing, the paper's use
//! case): the copies live across frames, the vertices are re-solved every
//! frame, and primary rays go out in packets of sixteen (4 × 4 pixel tiles).
//!
//! Per frame:
//! 1. Warp: every vertex gets its images. The plate runs the four-lane
//!    closed form (`Plate::warp_batch`) straight into the copies' vertex
//!    arrays; the tube runs the fast solver per vertex.
//! 2. Copies: one `DynamicMesh` per group of copy keys (`groups`: the
//!    plate's direct and warped copies together; each of the tube's keys
//!    alone, `MeshCopy`), its vertex array one slab per key holding the
//!    images in that copy (a vertex without one keeps its unwarped
//!    position, which no kept triangle uses) and its triangles those whose
//!    three vertices have an image for the same key. When the
//!    triangles are the same as last frame the BVH is refitted
//!    (`RTC_BUILD_QUALITY_REFIT`), otherwise rebuilt with Embree's fast
//!    builder: the arrays are shared with Embree, not copied.
//! 3. Rays: pixels in tiles of 4 × 4, classified analytically; one
//!    `rtcIntersect16` per group that any lane of the tile needs (the
//!    tube's direct copy up to the glass, then the lanes' groups beyond
//!    it, each lane culled at its nearest hit so far); the nearest hit wins
//!    and is shaded as in `render_warped`.
//!
//! The images are the ones `warp_scene` + `render_warped` make (same
//! solvers, same copies, same shading): tested pixel for pixel.
//!
//! Departure from the paper: Mukai et al. draw the warped meshes with a GPU
//! rasteriser. Here the copies are Embree BVHs traced with packets, since a
//! CPU rasteriser (triangles binned into bands of rows, each pixel centre
//! tested exactly along its ray) gave the same pixels no faster: the
//! per-pixel passes (classification, shading, buffers) dominate, not the
//! visibility query (docs/warp.md, "What was tried and did not pay").
//!
//! Files: `mesh_copy` (the copies and which keys share one), `update` (a
//! frame's warp), `cull` (the camera's pyramid), `classify` (a ray's
//! copies), `render` (the rays).
mod classify;
mod cull;
mod mesh_copy;
mod render;
mod update;

use crate::embree::DynamicMesh;
use crate::error::{Error, Result};
use crate::scene::RenderScene;
use crate::warp::{CopyKey, PlateStatus, WarpGlass, WarpSpec};
use crate::warp_render::prepare::Prepared;
use crate::warp_render::rays::d3;
use cull::CULL_MARGIN_PX;
use glam::DVec3;
use mesh_copy::{groups, MeshCopy};

/// Timings and counts of one frame's warp.
#[derive(Debug, Clone, Default)]
pub struct FrameWarp {
    /// Seconds solving vertex images (tables included).
    pub warp_s: f64,
    /// Seconds updating the copies (index lists, refit or rebuild).
    pub build_s: f64,
    /// Vertex images found.
    pub images: usize,
    /// Copies refitted.
    pub refits: usize,
    /// Copies rebuilt.
    pub rebuilds: usize,
    /// Triangles whose vertices have no image copy in common (the tube's
    /// direct copy holds every triangle all the same).
    pub dropped_triangles: usize,
    /// Triangles of the tube's copies left out of their BVH this frame
    /// because no primary ray can meet them (wholly outside the camera's
    /// pyramid of rays, `Frustum`).
    pub culled_triangles: usize,
}

/// The warp renderer's state for one scene.
pub struct Pipeline {
    glass: WarpGlass,
    method: crate::warp::WarpMethod,
    /// All objects' vertices, concatenated.
    positions: Vec<[f32; 3]>,
    /// All triangles, indices into `positions`.
    tris: Vec<[u32; 3]>,
    /// Per triangle: (object, triangle in its mesh).
    tri_src: Vec<(u32, u32)>,
    /// Every copy key of the glass (at most 8).
    keys: Vec<CopyKey>,
    copies: Vec<MeshCopy>,
    /// Per vertex: bit k set when the vertex has an image for `keys[k]`.
    masks: Vec<u8>,
    /// Scratch for the plate's batch.
    plate_class: Vec<std::result::Result<bool, PlateStatus>>,
    /// `positions` in f64 (the tube's solver input), made once.
    positions64: Vec<DVec3>,
    /// The tube's copies leave out triangles outside the camera's pyramid
    /// widened by this many pixels (`Frustum`); `None`: nothing is culled.
    cull_margin_px: Option<f32>,
}

impl Pipeline {
    /// Copies for `prep`'s meshes; `refit` lets unchanged triangle sets refit.
    pub fn new(scene: &RenderScene, spec: &WarpSpec, prep: &Prepared, refit: bool) -> Result<Pipeline> {
        let mut positions = Vec::with_capacity(prep.vertices);
        let mut tris = Vec::with_capacity(prep.triangles);
        let mut tri_src = Vec::with_capacity(prep.triangles);
        for (oi, o) in prep.objects.iter().enumerate() {
            let base = positions.len() as u32;
            positions.extend_from_slice(&o.mesh.positions);
            for (ti, t) in o.mesh.indices.iter().enumerate() {
                tris.push(t.map(|v| v + base));
                tri_src.push((oi as u32, ti as u32));
            }
        }
        let keys = spec.glass.copy_keys();
        if keys.len() > 8 {
            return Err(Error::Invalid(format!("{} warp copies: at most 8", keys.len())));
        }
        let mut copies = Vec::new();
        for members in groups(&spec.glass, &keys) {
            copies.push(MeshCopy {
                member_bits: members
                    .iter()
                    .map(|m| keys.iter().position(|k| k == m).unwrap_or(0) as u8)
                    .collect(),
                member_ends: vec![0; members.len()],
                members,
                mesh: DynamicMesh::new(scene.embree.device(), refit)?,
                tri_ids: Vec::new(),
                next: Vec::new(),
                codes: Vec::new(),
                fixed: false,
            });
        }
        if let WarpGlass::Cylinder(_) = spec.glass {
            // The tube's direct copy is the unwarped scene itself: every
            // triangle at its own position, built once here and never
            // updated. Its query stops where the ray enters the tube
            // (`Classifier::classify`), so along every ray it answers the
            // exact trace's first straight piece: what lies in front of the
            // tube, and everything a ray that misses the tube hits (a
            // triangle across the silhouette included, which the per-frame
            // direct copy of vertices with a direct image had dropped).
            // Nothing in it depends on the eye, so a frame neither filters
            // nor rebuilds it (as the exact trace's BVH of the unwarped
            // meshes is built once, `build_originals`).
            if let Some(c) = copies.iter_mut().find(|c| c.members[..] == [CopyKey::DIRECT]) {
                let n = tris.len();
                c.mesh.update(|vs, is| {
                    vs.clone_from(&positions);
                    is.clone_from(&tris);
                    true
                })?;
                c.tri_ids = (0..n as u32).collect();
                c.member_ends = vec![n];
                c.fixed = true;
            }
        }
        Ok(Pipeline {
            glass: spec.glass,
            method: spec.method,
            masks: vec![0; positions.len()],
            plate_class: Vec::new(),
            positions64: positions.iter().map(|p| d3(*p)).collect(),
            positions,
            cull_margin_px: Some(CULL_MARGIN_PX),
            tris,
            tri_src,
            keys,
            copies,
        })
    }

    /// The copy holding `key`.
    fn key_index(&self, key: CopyKey) -> Option<usize> {
        self.copies.iter().position(|c| c.members.contains(&key))
    }

    /// The bit of `key` in `masks`.
    fn key_bit(&self, key: CopyKey) -> u8 {
        self.keys.iter().position(|k| *k == key).map_or(0, |i| 1 << i)
    }

    /// Copies and their triangle counts (labels as in reports).
    pub fn copy_sizes(&self) -> Vec<(String, usize)> {
        let mut out = Vec::new();
        for c in &self.copies {
            let mut start = 0;
            for (key, &end) in c.members.iter().zip(&c.member_ends) {
                if end > start {
                    out.push((key.label(), end - start));
                }
                start = end;
            }
        }
        out
    }
}

#[cfg(test)]
mod test_support {
    use super::*;
    use crate::warp_render::prepare::prepare;
    use glam::Vec3A as V3;

    /// A pinhole camera at `pos` looking at the origin (y up, 40° field of
    /// view), as the tests move the scenes' eyes.
    pub(super) fn looking_at_origin(pos: V3, w: u32, h: u32) -> crate::camera::Camera {
        crate::camera::Camera::try_new(pos, V3::ZERO, V3::Y, 40.0, w, h, 0.0, 1.0).unwrap()
    }

    /// scenes/warp_cylinder.toml at 160 × 120, subdivided as its `[warp]`
    /// says.
    pub(super) fn tube_at_160x120() -> (RenderScene, WarpSpec, Prepared) {
        let mut s = crate::scene::load_scene(
            std::path::Path::new("scenes/warp_cylinder.toml"),
            &crate::scene::BuildOptions::default(),
        )
        .unwrap();
        s.set_resolution(160, 120).unwrap();
        let spec = s.warp.clone().unwrap();
        let prep = prepare(&s, &spec, spec.subdivide).unwrap();
        (s, spec, prep)
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::{looking_at_origin, tube_at_160x120};
    use super::*;
    use crate::warp_render::exact::{build_originals, render_exact};
    use crate::warp_render::rays::pixel_ray;
    use glam::Vec3A as V3;

    /// The tube's direct copy is the unwarped scene (`Pipeline::new`): every
    /// pixel whose ray misses the tube shows what the exact trace shows,
    /// the pixels along the silhouette included, where a triangle across it
    /// has a vertex hidden behind the tube (the per-frame direct copy of
    /// vertices with a direct image dropped those: 240 of 19,200 pixels
    /// showed nothing there at 160 × 120). Also after a moved camera (the
    /// copy is not rebuilt).
    #[test]
    fn beside_the_tube_the_warp_is_the_exact_trace() {
        let (mut s, spec, prep) = tube_at_160x120();
        let orig = build_originals(&s, &prep).unwrap();
        let mut pipe = Pipeline::new(&s, &spec, &prep, false).unwrap();
        let pos = s.camera.position;
        for dx in [0.0f32, 0.07] {
            s.camera = looking_at_origin(pos + V3::new(dx, 0.03, 0.0), 160, 120);
            let fw = pipe.warp(&s).unwrap();
            assert!(fw.rebuilds >= 1, "{fw:?}");
            let a = pipe.render(&s, &spec, &prep);
            let e = render_exact(&s, &spec, &prep, &orig);
            // Pixels beside the tube, and those within two pixels of its
            // silhouette (|b| up to R + 2 pixel footprints at the axis).
            let (mut beside, mut near_edge) = (0, 0);
            let foot = 2.0 * 20f64.to_radians().tan() / 120.0 * 4.0;
            for y in 0..120u32 {
                for x in 0..160u32 {
                    let (o, d) = pixel_ray(&s, x, y);
                    let (t_enter, _) = spec.glass.classify_keys(o, d);
                    if t_enter.is_finite() {
                        continue;
                    }
                    beside += 1;
                    let WarpGlass::Cylinder(c) = spec.glass else {
                        unreachable!()
                    };
                    if c.impact_of(o, d).0.abs() < c.outer_radius + 2.0 * foot {
                        near_edge += 1;
                    }
                    let i = (y * 160 + x) as usize;
                    match (a.shown[i], e.shown[i]) {
                        (Some(p), Some(q)) => assert!(
                            p.object == q.object && (p.point - q.point).length() < 1e-5,
                            "pixel ({x}, {y}): {p:?} {q:?}"
                        ),
                        (None, None) => {}
                        (p, q) => panic!("pixel ({x}, {y}): warp {p:?} exact {q:?}"),
                    }
                }
            }
            assert!(beside > 5_000 && near_edge > 200, "{beside} {near_edge}");
        }
    }
}
