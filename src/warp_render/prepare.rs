//! The meshes ready to warp: every mesh of the scene but the glass,
//! subdivided until its longest projected edge is within the tolerance
//! (or, for the bench and the report, replaced by a grid).
use super::rays::d3;
use crate::error::{Error, Result};
use crate::scene::shapes::Mesh;
use crate::scene::{RenderScene, Shape};
use crate::warp::WarpSpec;
use glam::{DVec3, Vec3A as V3};
use std::collections::HashMap;

/// Triangle budget over all subdivided meshes (each copy adds as much again).
pub const MAX_WARP_TRIANGLES: u64 = 1 << 23;

/// A mesh of the scene, subdivided, in world space.
#[derive(Debug, Clone)]
pub struct WarpObject {
    /// Its geometry index in the render scene (material, emission).
    pub geom: u32,
    /// The mesh, subdivided, in world space.
    pub mesh: Mesh,
    /// Subdivision levels applied.
    pub levels: u32,
}

/// The meshes ready to warp.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The meshes.
    pub objects: Vec<WarpObject>,
    /// Longest projected edge after subdivision (pixels, unwarped view).
    pub max_edge_px: f64,
    /// Vertices over all objects.
    pub vertices: usize,
    /// Triangles over all objects.
    pub triangles: usize,
}

/// One 1→4 subdivision; shared edges get one midpoint (watertight).
pub fn subdivide_once(m: &Mesh) -> Mesh {
    let mut positions = m.positions.clone();
    let mut normals = m.normals.clone();
    let mut uvs = m.uvs.clone();
    let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(m.indices.len() * 2);
    let mut indices = Vec::with_capacity(m.indices.len() * 4);
    let mut midpoint = |a: u32, b: u32| -> u32 {
        let key = (a.min(b), a.max(b));
        *mid.entry(key).or_insert_with(|| {
            let (pa, pb) = (d3(positions[a as usize]), d3(positions[b as usize]));
            let p = (pa + pb) * 0.5;
            positions.push([p.x as f32, p.y as f32, p.z as f32]);
            if let Some(ns) = normals.as_mut() {
                let (na, nb) = (V3::from(ns[a as usize]), V3::from(ns[b as usize]));
                ns.push((na + nb).normalize_or_zero().to_array());
            }
            if let Some(ts) = uvs.as_mut() {
                let (ta, tb) = (ts[a as usize], ts[b as usize]);
                ts.push([(ta[0] + tb[0]) * 0.5, (ta[1] + tb[1]) * 0.5]);
            }
            (positions.len() - 1) as u32
        })
    };
    for &[a, b, c] in &m.indices {
        let (ab, bc, ca) = (midpoint(a, b), midpoint(b, c), midpoint(c, a));
        indices.extend_from_slice(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    Mesh {
        positions,
        indices,
        normals,
        uvs,
    }
}

/// Longest projected edge (pixels) among edges with both ends in front of
/// the eye and at least one end within the image widened by half its size.
fn max_edge_px(scene: &RenderScene, m: &Mesh) -> f64 {
    let (w, h) = (scene.width as f32, scene.height as f32);
    let near = |x: f32, y: f32| x > -0.5 * w && x < 1.5 * w && y > -0.5 * h && y < 1.5 * h;
    let proj: Vec<Option<(f32, f32)>> = m
        .positions
        .iter()
        .map(|p| scene.camera.project(V3::from(*p)))
        .collect();
    let mut worst = 0.0f64;
    for tri in &m.indices {
        for k in 0..3 {
            let (a, b) = (tri[k] as usize, tri[(k + 1) % 3] as usize);
            if let (Some(pa), Some(pb)) = (proj[a], proj[b]) {
                if near(pa.0, pa.1) || near(pb.0, pb.1) {
                    let l = ((pa.0 - pb.0).powi(2) + (pa.1 - pb.1).powi(2)).sqrt() as f64;
                    worst = worst.max(l);
                }
            }
        }
    }
    worst
}

/// Collect the scene's meshes (everything but the glass) and subdivide each
/// until its longest projected edge is at most `tol_px` pixels.
pub fn prepare(scene: &RenderScene, spec: &WarpSpec, tol_px: f64) -> Result<Prepared> {
    // The warp solves for where a vertex must move so that the straight ray
    // from the eye sees it where refraction would: it needs one eye, which
    // an orthographic camera (parallel rays from a rectangle) does not have.
    if scene.camera.orthographic_view().is_some() {
        return Err(Error::Invalid(
            "the warp renderer needs a perspective camera (it warps vertices toward one eye); \
             an orthographic scene renders with `snell render`, which traces the glass"
                .into(),
        ));
    }
    let mut objects = Vec::new();
    let mut total: u64 = 0;
    let mut max_edge: f64 = 0.0;
    for (gi, g) in scene.geoms.iter().enumerate() {
        if spec.glass_geoms.contains(&(gi as u32)) {
            continue;
        }
        let mesh = match &g.shape {
            Shape::Mesh(m) => m.as_ref().clone(),
            Shape::Analytic(_) => {
                return Err(Error::Invalid(format!(
                    "object \"{}\": the warp renderer moves mesh vertices, so it needs triangle meshes \
                     (rect, box, lathe, heightfield, mesh); analytic shapes (sphere, disk, cylinder, tube) \
                     are not supported",
                    g.name
                )))
            }
        };
        let edge = max_edge_px(scene, &mesh);
        let mut levels = 0u32;
        let mut e = edge;
        while e > tol_px && levels < 16 {
            e *= 0.5;
            levels += 1;
        }
        let tris = mesh.indices.len() as u64 * 4u64.saturating_pow(levels);
        total = total.saturating_add(tris);
        if total > MAX_WARP_TRIANGLES {
            return Err(Error::Invalid(format!(
                "warp.subdivide: subdividing \"{}\" to {tol_px} px would need {tris} triangles \
                 (~{:.1} GB with its warped copies; limit {MAX_WARP_TRIANGLES} in all): raise warp.subdivide",
                g.name,
                tris as f64 * 80.0 / 1e9
            )));
        }
        let mut m = mesh;
        for _ in 0..levels {
            m = subdivide_once(&m);
        }
        max_edge = max_edge.max(e);
        objects.push(WarpObject {
            geom: gi as u32,
            mesh: m,
            levels,
        });
    }
    let vertices = objects.iter().map(|o| o.mesh.positions.len()).sum();
    let triangles = objects.iter().map(|o| o.mesh.indices.len()).sum();
    Ok(Prepared {
        objects,
        max_edge_px: max_edge,
        vertices,
        triangles,
    })
}

/// Replace the scene's largest object (a rect) by a grid of about `vertices`
/// vertices: the vertex sweeps of the warp bench and `snell report`.
pub fn with_grid(prep: &mut Prepared, vertices: usize) -> Result<()> {
    let area = |o: &WarpObject| {
        let (lo, hi) = o.mesh.aabb();
        let d = hi - lo;
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    let k = (0..prep.objects.len())
        .max_by(|&a, &b| area(&prep.objects[a]).total_cmp(&area(&prep.objects[b])))
        .ok_or_else(|| Error::Invalid("warp grid: the scene has no warp objects".into()))?;
    let m = &prep.objects[k].mesh;
    if m.positions.len() != 4 {
        return Err(Error::Invalid(
            "warp grid: the scene's main surface must be a rect (4 vertices)".into(),
        ));
    }
    let c: Vec<DVec3> = m
        .positions
        .iter()
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect();
    let (su, sv) = ((c[1] - c[0]).length(), (c[3] - c[0]).length());
    let nx = ((vertices as f64 * su / sv).sqrt().round() as u32).max(2);
    let ny = ((vertices as f64 / nx as f64).round() as u32).max(2);
    let normal = (c[1] - c[0]).cross(c[3] - c[0]).normalize();
    prep.objects[k].mesh = crate::scene::meshgen::grid([c[0], c[1], c[2], c[3]], normal, nx, ny);
    prep.objects[k].levels = 0;
    prep.vertices = prep.objects.iter().map(|o| o.mesh.positions.len()).sum();
    prep.triangles = prep.objects.iter().map(|o| o.mesh.indices.len()).sum();
    Ok(())
}

/// Load a `[warp]` scene at `w`×`h` and replace its main surface by a grid of
/// about `vertices` vertices (no subdivision).
pub fn grid_scene(path: &str, w: u32, h: u32, vertices: usize) -> Result<(RenderScene, Prepared)> {
    let mut scene =
        crate::scene::load_scene(std::path::Path::new(path), &crate::scene::BuildOptions::default())?;
    scene.set_resolution(w, h)?;
    let spec = scene
        .warp
        .clone()
        .ok_or_else(|| Error::Invalid(format!("{path}: not a [warp] scene")))?;
    let mut prep = prepare(&scene, &spec, 1e9)?;
    with_grid(&mut prep, vertices)?;
    Ok((scene, prep))
}
