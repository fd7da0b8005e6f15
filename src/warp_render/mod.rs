//! The warp renderer (`snell warp-render`) and the exact trace it is judged
//! against.
//!
//! Warp: every mesh is subdivided to a screen-space tolerance, every vertex
//! is moved to each of its images (`plate`, `cylinder`, `paper`), and the
//! triangles whose three vertices have an image in the same family form that
//! family's warped copy (one Embree scene each). A pixel casts one straight
//! primary ray at its centre into the copies its ray class names (the
//! paper's depth peeling, done analytically by `WarpGlass::classify`) and
//! into the direct copy before the glass; the nearest hit wins.
//!
//! A triangle whose vertices land in different families (or have no image)
//! is in no copy: along the seams between families, and at the tube's
//! silhouette, a strip up to one subdivided triangle wide shows the
//! background. `Comparison::mismatched` counts those pixels.
//!
//! Exact: the same primary ray follows the glass exactly (`exact_path`:
//! refraction, TIR where it happens, no reflection branches), and each straight
//! piece is cast against the unwarped meshes.
//!
//! Both shade the surface point they show with the same unshadowed local
//! model (emission + reflectance × (constant environment + directional and
//! point lights with |cos|)), so their difference is the warp's error alone.
pub mod pipeline;
use crate::embree::{BuildQuality, Ray, Scene, SceneBuilder, SceneFlags};
use crate::error::{Error, Result};
use crate::scene::shapes::Mesh;
use crate::scene::{Environment, Light, Material, RenderScene, Shape};
use crate::warp::approx_tube::approx_tube_image;
use crate::warp::{CopyKey, Family, PlateStatus, WarpGlass, WarpMethod, WarpSpec};
use glam::{DVec3, Vec3A as V3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::time::Instant;

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

pub(crate) fn d3(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
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

/// Most images one vertex can have in distinct copies (direct, through4 or
/// hollow2, tir2±, wall2±).
pub const MAX_IMAGES: usize = 7;

/// The images of one vertex: (copy, warped position), at most one per copy.
/// Inline (no allocation per vertex).
#[derive(Debug, Clone, Copy)]
pub struct VertexImages {
    len: u8,
    items: [(CopyKey, [f32; 3]); MAX_IMAGES],
}

impl Default for VertexImages {
    fn default() -> Self {
        VertexImages {
            len: 0,
            items: [(CopyKey::DIRECT, [0.0; 3]); MAX_IMAGES],
        }
    }
}

impl VertexImages {
    /// Add an image unless its copy already has one (the first wins).
    pub fn push(&mut self, key: CopyKey, p: DVec3) {
        if (self.len as usize) < MAX_IMAGES && self.get(key).is_none() {
            self.items[self.len as usize] = (key, [p.x as f32, p.y as f32, p.z as f32]);
            self.len += 1;
        }
    }
    /// The image of the vertex in copy `key`, if it has one.
    pub fn get(&self, key: CopyKey) -> Option<[f32; 3]> {
        self.items[..self.len as usize]
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, p)| *p)
    }
    /// Number of images.
    pub fn len(&self) -> usize {
        self.len as usize
    }
    /// Has the vertex no image at all?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Per-eye solver state: the fast cylinder tables when they apply.
pub struct VertexSolver {
    glass: WarpGlass,
    method: WarpMethod,
    eye: DVec3,
    fast: Option<crate::warp::CylinderWarper>,
}

impl VertexSolver {
    /// A solver for points whose straight elevation (β along the tube's axis)
    /// lies within those of `points`.
    pub fn new(glass: WarpGlass, method: WarpMethod, eye: DVec3, points: &[DVec3]) -> Self {
        let fast = match (&glass, method) {
            (WarpGlass::Cylinder(c), WarpMethod::Exact) if !points.is_empty() => {
                crate::warp::CylinderWarper::for_targets(*c, eye, points).ok()
            }
            _ => None,
        };
        VertexSolver {
            glass,
            method,
            eye,
            fast,
        }
    }

    /// The images of the point `p`.
    pub fn images(&self, p: DVec3) -> VertexImages {
        vertex_images(&self.glass, self.method, self.eye, p, self.fast.as_ref())
    }

    /// Every image of every point of `pts`, as `each(index in pts, copy,
    /// warped position)`, in the order `images` keeps them (the first per
    /// copy wins there; `each` may see a copy again). The fast cylinder
    /// solver takes the points in batches (as `images_chunk`).
    pub fn each_image<F: FnMut(usize, CopyKey, DVec3)>(&self, pts: &[DVec3], mut each: F) {
        let (WarpMethod::Exact, Some(f)) = (self.method, self.fast.as_ref()) else {
            for (i, p) in pts.iter().enumerate() {
                let vi = self.images(*p);
                for (k, q) in &vi.items[..vi.len()] {
                    each(i, *k, d3(*q));
                }
            }
            return;
        };
        f.images_batch(pts, false, |i, ims| {
            for im in ims.into_iter().flatten() {
                each(i, WarpGlass::key_for(im.family, im.impact), im.position);
            }
        });
    }

    /// The images of every point of `pts` into `out` (as `images`); the
    /// fast cylinder solver takes them in batches (its Newton polishes run
    /// four at a time).
    pub fn images_chunk(&self, pts: &[DVec3], out: &mut [VertexImages]) {
        let (WarpMethod::Exact, Some(f)) = (self.method, self.fast.as_ref()) else {
            for (o, p) in out.iter_mut().zip(pts) {
                *o = self.images(*p);
            }
            return;
        };
        f.images_batch(pts, false, |i, ims| {
            let mut vi = VertexImages::default();
            if let Ok(ims) = ims {
                for im in ims {
                    vi.push(WarpGlass::key_for(im.family, im.impact), im.position);
                }
            }
            out[i] = vi;
        });
    }
}

thread_local! {
    /// The fast cylinder solver's image buffer, reused across vertices.
    static IMAGES: std::cell::RefCell<Vec<crate::warp::CylImage>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Images of one point by `method` (first image per copy key).
pub fn vertex_images(
    glass: &WarpGlass,
    method: WarpMethod,
    eye: DVec3,
    p: DVec3,
    fast: Option<&crate::warp::CylinderWarper>,
) -> VertexImages {
    let mut out = VertexImages::default();
    match glass {
        WarpGlass::Plate(pl) => match pl.warped_position(eye, p) {
            Ok(pos) => out.push(
                CopyKey {
                    family: Family::Wall2,
                    side: 0,
                },
                pos,
            ),
            Err(PlateStatus::InFront) => out.push(CopyKey::DIRECT, p),
            Err(_) => {}
        },
        WarpGlass::Cylinder(c) => {
            if let (WarpMethod::Exact, Some(f)) = (method, fast) {
                // The fast solver writes into the thread's buffer: no
                // allocation per vertex.
                IMAGES.with_borrow_mut(|ims| {
                    if f.images_into(p, false, ims).is_ok() {
                        for im in ims.iter() {
                            out.push(WarpGlass::key_for(im.family, im.impact), im.position);
                        }
                    }
                });
                return out;
            }
            let ims = match method {
                WarpMethod::Exact => c.images(eye, p).unwrap_or_default(),
                WarpMethod::Paper => approx_tube_image(c, eye, p).ok().flatten().into_iter().collect(),
            };
            for im in ims {
                let key = WarpGlass::key_for(im.family, im.impact);
                out.push(key, im.position);
            }
        }
    }
    out
}

/// One warped copy: an Embree scene and, per triangle, its source.
pub struct WarpedCopy {
    /// Which copy.
    pub key: CopyKey,
    /// Its Embree scene.
    pub scene: Scene,
    /// (object index in `Prepared::objects`, triangle index in its mesh).
    pub source: Vec<(u32, u32)>,
}

/// All warped copies of a scene, with timings.
pub struct Warped {
    /// The copies.
    pub copies: Vec<WarpedCopy>,
    /// Seconds spent moving vertices.
    pub warp_s: f64,
    /// Seconds spent building the copies' BVHs.
    pub build_s: f64,
    /// Vertex images found.
    pub images: usize,
    /// Triangles whose vertices have no image copy in common (in different
    /// families, or some without an image); the tube's direct copy holds
    /// every triangle all the same (`pipeline::Pipeline::new`).
    pub dropped_triangles: usize,
}

/// Warp every vertex (in parallel) and build the copies.
pub fn warp_scene(scene: &RenderScene, spec: &WarpSpec, prep: &Prepared) -> Result<Warped> {
    let eye = DVec3::from(scene.camera.position.to_array().map(|x| x as f64));
    let t0 = Instant::now();
    let all: Vec<DVec3> = prep
        .objects
        .iter()
        .flat_map(|o| o.mesh.positions.iter().map(|p| d3(*p)))
        .collect();
    let solver = VertexSolver::new(spec.glass, spec.method, eye, &all);
    let per_object: Vec<Vec<VertexImages>> = prep
        .objects
        .iter()
        .map(|o| {
            o.mesh
                .positions
                .par_iter()
                .with_min_len(256)
                .map(|p| solver.images(d3(*p)))
                .collect()
        })
        .collect();
    let warp_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let images = per_object.iter().flatten().map(|v| v.len()).sum();
    // One copy per key, built in parallel (each is its own Embree scene).
    let built: Vec<Option<Result<WarpedCopy>>> = spec
        .glass
        .copy_keys()
        .into_par_iter()
        .map(|key| {
            let mut positions: Vec<[f32; 3]> = Vec::with_capacity(prep.vertices);
            let mut indices: Vec<[u32; 3]> = Vec::new();
            let mut source = Vec::new();
            // The tube's direct copy is the unwarped scene, every triangle
            // (its query stops at the tube: see `pipeline::Pipeline::new`).
            let unwarped = key == CopyKey::DIRECT && matches!(spec.glass, WarpGlass::Cylinder(_));
            for (oi, o) in prep.objects.iter().enumerate() {
                let base = positions.len() as u32;
                let imgs = &per_object[oi];
                if unwarped {
                    positions.extend_from_slice(&o.mesh.positions);
                } else {
                    positions.extend(imgs.iter().map(|vi| vi.get(key).unwrap_or([0.0; 3])));
                }
                let has = |v: u32| unwarped || imgs[v as usize].get(key).is_some();
                for (ti, tri) in o.mesh.indices.iter().enumerate() {
                    if tri.iter().all(|&v| has(v)) {
                        indices.push(tri.map(|v| v + base));
                        source.push((oi as u32, ti as u32));
                    }
                }
            }
            if indices.is_empty() {
                return None;
            }
            Some((|| {
                // Rebuilt every frame (the eye moves): Embree's fast (Morton) builder.
                let mut b =
                    SceneBuilder::new(scene.embree.device(), SceneFlags::default(), BuildQuality::Low)?;
                b.add_triangles(&positions, &indices)?;
                Ok(WarpedCopy {
                    key,
                    scene: b.commit()?,
                    source,
                })
            })())
        })
        .collect();
    let mut copies = Vec::new();
    for c in built.into_iter().flatten() {
        copies.push(c?);
    }
    // Triangles in no copy: no key common to all three vertices.
    let dropped_triangles = prep
        .objects
        .par_iter()
        .enumerate()
        .map(|(oi, o)| {
            let imgs = &per_object[oi];
            o.mesh
                .indices
                .iter()
                .filter(|tri| {
                    let a = &imgs[tri[0] as usize];
                    !a.items[..a.len()].iter().any(|(k, _)| {
                        imgs[tri[1] as usize].get(*k).is_some() && imgs[tri[2] as usize].get(*k).is_some()
                    })
                })
                .count()
        })
        .sum();
    Ok(Warped {
        copies,
        warp_s,
        build_s: t1.elapsed().as_secs_f64(),
        images,
        dropped_triangles,
    })
}

/// What a pixel shows: the surface point on the unwarped mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shown {
    /// Index into `Prepared::objects`.
    pub object: u32,
    /// The point on the unwarped mesh (world space).
    pub point: DVec3,
    /// Length of the (possibly refracted) path from the eye to the point.
    pub path_length: f64,
}

/// A primary-ray image.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Linear RGB, row-major, row 0 at the top.
    pub pixels: Vec<V3>,
    /// What each pixel shows (`None`: the environment).
    pub shown: Vec<Option<Shown>>,
    /// Seconds spent on the primary rays and shading.
    pub render_s: f64,
}

impl Frame {
    /// The frame of `scene`'s film rendered into `pixels` and `shown`, timed
    /// from `t0`.
    pub(crate) fn finished(
        scene: &RenderScene,
        pixels: Vec<V3>,
        shown: Vec<Option<Shown>>,
        t0: Instant,
    ) -> Frame {
        Frame {
            width: scene.width,
            height: scene.height,
            pixels,
            shown,
            render_s: t0.elapsed().as_secs_f64(),
        }
    }
}

pub(crate) fn shade(
    scene: &RenderScene,
    prep: &Prepared,
    object: u32,
    tri: u32,
    u: f32,
    v: f32,
    weight: f64,
) -> (V3, DVec3) {
    let o = &prep.objects[object as usize];
    let g = &scene.geoms[o.geom as usize];
    let [a, b, c] = o.mesh.indices[tri as usize].map(|i| d3(o.mesh.positions[i as usize]));
    let (u64_, v64) = (u.clamp(0.0, 1.0) as f64, v.clamp(0.0, 1.0) as f64);
    let p = a * (1.0 - u64_ - v64).max(0.0) + b * u64_ + c * v64;
    // Texture coordinates always; the normal only for the lights, the one
    // thing that reads it (its normalisation was ~20 % of `shade` in the
    // tube's ray pass, perf, issue 16 eleventh round; the tube's scene is
    // lit by its emitting plane alone, the plate's by a light).
    let uv = o.mesh.shading_uv(tri, u, v);
    let pf = V3::new(p.x as f32, p.y as f32, p.z as f32);
    let mut col = g.emission.as_ref().map(|e| e.eval(pf, uv)).unwrap_or(V3::ZERO);
    if let Material::Diffuse { reflectance, .. } = &g.material {
        let rho = reflectance.eval(pf, uv);
        let mut e = match &scene.environment {
            Environment::Constant(c) => *c,
            _ => V3::ZERO,
        };
        let n = if scene.lights.is_empty() {
            V3::ZERO
        } else {
            o.mesh.shading_normal(tri, u, v).unwrap_or_else(|| {
                let ng = (b - a).cross(c - a).normalize_or_zero();
                V3::new(ng.x as f32, ng.y as f32, ng.z as f32)
            })
        };
        for l in &scene.lights {
            match l {
                Light::Directional {
                    direction,
                    irradiance,
                } => e += *irradiance * n.dot(*direction).abs() / std::f32::consts::PI,
                Light::Point { position, intensity } => {
                    let d = *position - pf;
                    let r2 = d.length_squared().max(1e-12);
                    e += *intensity * (n.dot(d).abs() / r2.sqrt()) / (r2 * std::f32::consts::PI);
                }
                _ => {}
            }
        }
        col += rho * e;
    }
    (col * weight as f32, p)
}

// Inlined: returned through memory from a call, the ray's 48 bytes were
// read back right after being written (a store-forwarding stall, perf).
#[inline]
pub(crate) fn pixel_ray(scene: &RenderScene, x: u32, y: u32) -> (DVec3, DVec3) {
    let (o, d) = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5, (0.0, 0.0));
    let o = DVec3::new(o.x as f64, o.y as f64, o.z as f64);
    let d = DVec3::new(d.x as f64, d.y as f64, d.z as f64).normalize();
    (o, d)
}

pub(crate) fn f3(v: DVec3) -> V3 {
    V3::new(v.x as f32, v.y as f32, v.z as f32)
}

fn cast(s: &Scene, o: DVec3, d: DVec3, tfar: f64) -> Option<crate::embree::Hit> {
    let ray = Ray {
        org: f3(o),
        dir: f3(d),
        tnear: 0.0,
        tfar: tfar.min(f32::MAX as f64) as f32,
    };
    s.intersect(&ray)
}

fn run_rows<F>(width: u32, height: u32, f: F) -> (Vec<V3>, Vec<Option<Shown>>)
where
    F: Fn(u32, u32) -> (V3, Option<Shown>) + Sync,
{
    let rows: Vec<Vec<(V3, Option<Shown>)>> = (0..height)
        .into_par_iter()
        .map(|y| (0..width).map(|x| f(x, y)).collect())
        .collect();
    rows.into_iter().flatten().unzip()
}

/// Render the warped copies with straight primary rays.
pub fn render_warped(scene: &RenderScene, spec: &WarpSpec, prep: &Prepared, warped: &Warped) -> Frame {
    let t0 = Instant::now();
    let direct = warped.copies.iter().find(|c| c.key == CopyKey::DIRECT);
    let (pixels, shown) = run_rows(scene.width, scene.height, |x, y| {
        let (o, d) = pixel_ray(scene, x, y);
        let class = spec.glass.classify(o, d);
        let mut best: Option<(f32, &WarpedCopy, crate::embree::Hit)> = None;
        if let Some(dc) = direct {
            if let Some(h) = cast(&dc.scene, o, d, class.t_enter) {
                best = Some((h.t, dc, h));
            }
        }
        for key in &class.copies {
            if let Some(c) = warped.copies.iter().find(|c| c.key == *key) {
                if let Some(h) = cast(&c.scene, o, d, f64::INFINITY) {
                    if best.as_ref().is_none_or(|b| h.t < b.0) {
                        best = Some((h.t, c, h));
                    }
                }
            }
        }
        match best {
            None => (V3::ZERO, None),
            Some((_, c, h)) => {
                let (obj, tri) = c.source[h.prim_id as usize];
                let weight = if spec.fresnel && c.key != CopyKey::DIRECT {
                    spec.glass.exact_path(o, d).transmittance
                } else {
                    1.0
                };
                let (col, p) = shade(scene, prep, obj, tri, h.u, h.v, weight);
                (
                    col,
                    Some(Shown {
                        object: obj,
                        point: p,
                        path_length: (p - o).length(),
                    }),
                )
            }
        }
    });
    Frame::finished(scene, pixels, shown, t0)
}

/// The unwarped meshes as one Embree scene (for the exact trace).
pub struct Originals {
    /// Their Embree scene.
    pub scene: Scene,
    /// Per triangle: (object index, triangle index).
    pub source: Vec<(u32, u32)>,
    /// Seconds building it.
    pub build_s: f64,
}

/// The unwarped meshes of `prep` as one Embree scene, for the exact trace.
///
/// # Errors
/// An Embree error while building.
pub fn build_originals(scene: &RenderScene, prep: &Prepared) -> Result<Originals> {
    let t0 = Instant::now();
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let mut source = Vec::new();
    for (oi, o) in prep.objects.iter().enumerate() {
        let base = positions.len() as u32;
        positions.extend_from_slice(&o.mesh.positions);
        for (ti, t) in o.mesh.indices.iter().enumerate() {
            indices.push(t.map(|v| v + base));
            source.push((oi as u32, ti as u32));
        }
    }
    let mut b = SceneBuilder::new(scene.embree.device(), SceneFlags::default(), BuildQuality::Medium)?;
    if !indices.is_empty() {
        b.add_triangles(&positions, &indices)?;
    }
    Ok(Originals {
        scene: b.commit()?,
        source,
        build_s: t0.elapsed().as_secs_f64(),
    })
}

/// The exact trace: each primary ray follows the glass exactly.
pub fn render_exact(scene: &RenderScene, spec: &WarpSpec, prep: &Prepared, orig: &Originals) -> Frame {
    let t0 = Instant::now();
    let (pixels, shown) = run_rows(scene.width, scene.height, |x, y| {
        let (o, d) = pixel_ray(scene, x, y);
        let path = spec.glass.exact_path(o, d);
        let mut travelled = 0.0;
        for (i, s) in path.segments.iter().enumerate() {
            if let Some(h) = cast(&orig.scene, s.origin, s.dir, s.t_end) {
                let (obj, tri) = orig.source[h.prim_id as usize];
                let weight = if spec.fresnel && i > 0 {
                    path.transmittance
                } else {
                    1.0
                };
                let (col, p) = shade(scene, prep, obj, tri, h.u, h.v, weight);
                return (
                    col,
                    Some(Shown {
                        object: obj,
                        point: p,
                        path_length: travelled + (p - s.origin).length(),
                    }),
                );
            }
            travelled += s.t_end;
        }
        (V3::ZERO, None)
    });
    Frame::finished(scene, pixels, shown, t0)
}

/// Warp against exact, pixel by pixel.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Comparison {
    /// Root-mean-square difference of linear RGB over all pixels and channels.
    pub rmse: f64,
    /// Pixels where both show the same object (position errors are over these).
    pub matched: u64,
    /// Pixels where one shows something and the other nothing or another object.
    pub mismatched: u64,
    /// Pixels compared.
    pub pixels: u64,
    /// Distance between the shown surface points (scene units).
    pub pos_mean: f64,
    /// Median distance.
    pub pos_median: f64,
    /// 95th percentile.
    pub pos_p95: f64,
    /// Largest.
    pub pos_max: f64,
    /// The same in pixel footprints (distance / size of a pixel at the exact
    /// point: the spacing of the exact points of neighbouring pixels).
    pub px_mean: f64,
    /// Median, in pixel footprints.
    pub px_median: f64,
    /// 95th percentile, in pixel footprints.
    pub px_p95: f64,
    /// Largest, in pixel footprints.
    pub px_max: f64,
}

fn quantiles(mut v: Vec<f64>) -> (f64, f64, f64, f64) {
    if v.is_empty() {
        return (0.0, 0.0, 0.0, 0.0);
    }
    v.sort_by(f64::total_cmp);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
    (mean, q(0.5), q(0.95), *v.last().unwrap_or(&0.0))
}

/// Compare and produce a heatmap (position error in pixels: black 0, red 1,
/// yellow ≥ 2; magenta where the two show different things).
pub fn compare(scene: &RenderScene, warp: &Frame, exact: &Frame) -> (Comparison, Vec<V3>) {
    let (w, h) = (warp.width as usize, warp.height as usize);
    let mut se = 0.0;
    for (a, b) in warp.pixels.iter().zip(&exact.pixels) {
        let d = *a - *b;
        se += (d * d).element_sum() as f64;
    }
    let rmse = (se / (3 * w * h).max(1) as f64).sqrt();
    let pixel_angle = scene.camera.pixel_angle() as f64;
    let footprint = |i: usize| -> f64 {
        let Some(s) = exact.shown[i] else { return 0.0 };
        let (x, y) = (i % w, i / w);
        let mut spacing: Vec<f64> = Vec::new();
        for (nx, ny) in [
            (x + 1, y),
            (x.wrapping_sub(1), y),
            (x, y + 1),
            (x, y.wrapping_sub(1)),
        ] {
            if nx < w && ny < h {
                if let Some(n) = exact.shown[ny * w + nx] {
                    if n.object == s.object {
                        spacing.push((n.point - s.point).length());
                    }
                }
            }
        }
        if spacing.is_empty() {
            s.path_length * pixel_angle
        } else {
            spacing.sort_by(f64::total_cmp);
            spacing[0]
        }
    };
    let mut pos = Vec::new();
    let mut px = Vec::new();
    let mut heat = vec![V3::ZERO; w * h];
    let mut mismatched = 0;
    for (i, cell) in heat.iter_mut().enumerate() {
        match (warp.shown[i], exact.shown[i]) {
            (Some(a), Some(b)) if a.object == b.object => {
                let e = (a.point - b.point).length();
                let fp = footprint(i);
                let epx = if fp > 0.0 { e / fp } else { 0.0 };
                pos.push(e);
                px.push(epx);
                let t = (epx as f32).min(2.0);
                *cell = if t <= 1.0 {
                    V3::new(t, 0.0, 0.0)
                } else {
                    V3::new(1.0, t - 1.0, 0.0)
                };
            }
            (None, None) => {}
            _ => {
                mismatched += 1;
                *cell = V3::new(1.0, 0.0, 1.0);
            }
        }
    }
    let matched = pos.len() as u64;
    let (pos_mean, pos_median, pos_p95, pos_max) = quantiles(pos);
    let (px_mean, px_median, px_p95, px_max) = quantiles(px);
    (
        Comparison {
            rmse,
            matched,
            mismatched,
            pixels: (w * h) as u64,
            pos_mean,
            pos_median,
            pos_p95,
            pos_max,
            px_mean,
            px_median,
            px_p95,
            px_max,
        },
        heat,
    )
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

/// What `snell warp-render` does, as a library call (the bench and tests use it).
#[derive(Debug, Clone, Default)]
pub struct WarpRunOptions {
    /// Render threads (`None`: one per core).
    pub threads: Option<usize>,
    /// Override of `[warp].subdivide` (pixels).
    pub subdivide: Option<f64>,
    /// Override of `[warp].method`.
    pub method: Option<WarpMethod>,
    /// Override of `[warp].fresnel`.
    pub fresnel: Option<bool>,
    /// Also run the exact trace and compare.
    pub compare: bool,
}

/// Everything one warp render measured.
pub struct WarpReport {
    /// The warped frame.
    pub frame: Frame,
    /// The exact trace, its comparison with the frame and the error heat map (with `compare`).
    pub exact: Option<(Frame, Comparison, Vec<V3>)>,
    /// Vertices after subdivision.
    pub vertices: usize,
    /// Triangles after subdivision.
    pub triangles: usize,
    /// Longest projected edge after subdivision (pixels).
    pub max_edge_px: f64,
    /// Seconds subdividing.
    pub subdivide_s: f64,
    /// Seconds moving vertices.
    pub warp_s: f64,
    /// Seconds building the copies' BVHs.
    pub build_s: f64,
    /// Vertex images found.
    pub images: usize,
    /// Triangles whose vertices have no image copy in common (`Warped`'s).
    pub dropped_triangles: usize,
    /// Triangles left out of the tube's copies as no primary ray can meet
    /// them (outside the camera's pyramid of rays; not in `copies`).
    pub culled_triangles: usize,
    /// Triangles per copy, by copy name.
    pub copies: Vec<(String, usize)>,
    /// Exact trace: BVH build of the unwarped meshes and the trace itself.
    pub exact_build_s: f64,
}

impl WarpReport {
    /// Seconds for one warped frame: warp + copy BVHs + primary rays.
    pub fn frame_s(&self) -> f64 {
        self.warp_s + self.build_s + self.frame.render_s
    }

    /// The report as JSON (timings, sizes, speed-up, the comparison).
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::json!({
            "width": self.frame.width,
            "height": self.frame.height,
            "vertices": self.vertices,
            "triangles": self.triangles,
            "max_projected_edge_px": self.max_edge_px,
            "subdivide_s": self.subdivide_s,
            "warp_s": self.warp_s,
            "copy_build_s": self.build_s,
            "render_s": self.frame.render_s,
            "frame_s": self.frame_s(),
            "frames_per_s": 1.0 / self.frame_s().max(1e-12),
            "vertices_per_s": self.vertices as f64 / self.warp_s.max(1e-12),
            "images": self.images,
            "dropped_triangles": self.dropped_triangles,
            "culled_triangles": self.culled_triangles,
            "copies": self.copies.iter().map(|(k, n)| serde_json::json!({"copy": k, "triangles": n})).collect::<Vec<_>>(),
            "provenance": crate::provenance::json(),
        });
        if let Some((ex, cmp, _)) = &self.exact {
            v["exact_trace_s"] = serde_json::json!(ex.render_s);
            v["exact_build_s"] = serde_json::json!(self.exact_build_s);
            v["speedup_render"] = serde_json::json!(ex.render_s / self.frame.render_s.max(1e-12));
            v["speedup_frame"] = serde_json::json!(ex.render_s / self.frame_s().max(1e-12));
            v["comparison"] = serde_json::to_value(cmp).unwrap_or_default();
        }
        v
    }
}

/// Prepare, warp and render a `[warp]` scene (and the exact trace if asked).
pub fn run(scene: &RenderScene, opts: &WarpRunOptions) -> Result<WarpReport> {
    let Some(spec0) = &scene.warp else {
        return Err(Error::Invalid(
            "the scene has no [warp] table: warp-render needs one warp glass (docs/warp.md)".into(),
        ));
    };
    let mut spec = spec0.clone();
    if let Some(s) = opts.subdivide {
        if !(s.is_finite() && s >= 0.05) {
            return Err(Error::Invalid(format!(
                "--subdivide: expected a projected edge length >= 0.05 pixels, got {s}"
            )));
        }
        spec.subdivide = s;
    }
    if let Some(m) = opts.method {
        spec.method = m;
    }
    if let Some(f) = opts.fresnel {
        spec.fresnel = f;
    }
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = opts.threads {
        pool = pool.num_threads(t.max(1));
    }
    let pool = pool
        .build()
        .map_err(|e| Error::Invalid(format!("cannot start worker threads: {e}")))?;
    pool.install(|| {
        let t0 = Instant::now();
        let prep = prepare(scene, &spec, spec.subdivide)?;
        let subdivide_s = t0.elapsed().as_secs_f64();
        let mut pipe = pipeline::Pipeline::new(scene, &spec, &prep, false)?;
        let warped = pipe.warp(scene)?;
        let frame = pipe.render(scene, &spec, &prep);
        let mut exact_build_s = 0.0;
        let exact = if opts.compare {
            let orig = build_originals(scene, &prep)?;
            exact_build_s = orig.build_s;
            let ex = pipeline::render_exact_packets(scene, &spec, &prep, &orig);
            let (cmp, heat) = compare(scene, &frame, &ex);
            Some((ex, cmp, heat))
        } else {
            None
        };
        Ok(WarpReport {
            vertices: prep.vertices,
            triangles: prep.triangles,
            max_edge_px: prep.max_edge_px,
            subdivide_s,
            warp_s: warped.warp_s,
            build_s: warped.build_s,
            images: warped.images,
            dropped_triangles: warped.dropped_triangles,
            culled_triangles: warped.culled_triangles,
            copies: pipe.copy_sizes(),
            frame,
            exact,
            exact_build_s,
        })
    })
}
