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
//!    alone), its vertex array one slab per
//!    key holding the images in that copy (a vertex without one keeps its
//!    unwarped position, which no kept triangle uses) and its triangles
//!    those whose three vertices have an image for the same key. When the
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
//! visibility query (docs/warp.md, "What did not pay").
use super::{d3, f3, pixel_ray, shade, Frame, Originals, Prepared, Shown, VertexSolver};
use crate::embree::{Committed, DynamicMesh, Packet16};
use crate::error::{Error, Result};
use crate::scene::RenderScene;
use crate::warp::{CopyKey, Family, PlateStatus, WarpGlass, WarpSpec};
use glam::{DVec3, Vec3A as V3};
use rayon::prelude::*;
use std::time::Instant;

/// One BVH across frames, holding one or more copy keys (`groups`).
struct Copy {
    /// Its keys, each with a slab of the vertex array (member m's images at
    /// `m·nv..(m+1)·nv`) and a run of its triangles.
    members: Vec<CopyKey>,
    /// Per member: its bit in `Pipeline::masks` (index in `Pipeline::keys`).
    member_bits: Vec<u8>,
    /// Per member: the end of its triangles in `tri_ids`.
    member_ends: Vec<usize>,
    mesh: DynamicMesh,
    /// Per triangle of the copy: its index in `Pipeline::tris`.
    tri_ids: Vec<u32>,
    /// Next frame's vertex array (swapped with the mesh's).
    next: Vec<[f32; 3]>,
    /// The tube's copies: per vertex of `next`, its [`Frustum::outcode`].
    codes: Vec<u8>,
    /// Built once in `Pipeline::new` and never updated: the tube's direct
    /// copy, every triangle at its unwarped position (see `Pipeline::new`).
    fixed: bool,
}

impl Copy {
    /// The key of the copy's triangle `prim`.
    fn key_of(&self, prim: usize) -> CopyKey {
        let m = self.member_ends.iter().position(|&end| prim < end).unwrap_or(0);
        self.members[m]
    }
}

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

/// `slabs` (each split into `chunks` runs of `chunk` elements) regrouped by
/// run: row r holds every slab's run r, so one job writes one run of every
/// slab.
fn chunk_rows<T>(slabs: Vec<&mut [T]>, chunks: usize, chunk: usize) -> Vec<Vec<&mut [T]>> {
    let mut rows: Vec<Vec<&mut [T]>> = (0..chunks).map(|_| Vec::with_capacity(slabs.len())).collect();
    for slab in slabs {
        for (row, part) in rows.iter_mut().zip(slab.chunks_mut(chunk)) {
            row.push(part);
        }
    }
    rows
}

/// The four side planes of the camera's pyramid of primary rays (planes
/// through the eye), widened to a pixel and a half beyond the outermost
/// pixel centres. A triangle whose three vertices lie strictly outside one
/// of them lies wholly outside it (it is their convex hull), and every
/// primary ray `eye + t·d`, t > 0, lies inside it, so no primary ray meets
/// the triangle: leaving it out of a copy's BVH changes no pixel. The margin
/// (~1e-3 rad at 1600×1200) dwarfs the f32 rounding of the copies' vertices
/// and of Embree's rays (~1e-7 relative).
///
/// Issue 16, eleventh round: the tube's plane is 9 m tall where the view
/// spans ~5 m, and a vertical tube keeps a ray's vertical slope, so ~40 %
/// of each copy's triangles are never seen; building their BVHs was most of
/// the copies phase. Only the tube's copies are culled: the plate's triangle
/// sets do not depend on the camera, which is what lets a moving camera
/// refit them.
struct Frustum {
    eye: DVec3,
    /// Inward normals (not unit).
    normals: [DVec3; 4],
}

/// How far beyond the outermost pixel centres the culling pyramid's planes
/// lie, in pixels.
const CULL_MARGIN_PX: f32 = 1.5;

impl Frustum {
    /// The pyramid of `scene`'s camera over its film (the warp renderer's
    /// rays: `pixel_ray`), its planes `margin` pixels beyond the outermost
    /// pixel centres (`CULL_MARGIN_PX`), or `None` when they are degenerate.
    fn of(scene: &RenderScene, margin: f32) -> Option<Frustum> {
        let (w, h) = (scene.width as f32, scene.height as f32);
        let (lo, wx, hy) = (0.5 - margin, w - 0.5 + margin, h - 0.5 + margin);
        // Lens sample (0, 0): the ray from the eye, as `pixel_ray`.
        let ray = |x: f32, y: f32| {
            let (o, d) = scene.camera.ray(x, y, (0.0, 0.0));
            (d3(o.to_array()), d3(d.to_array()))
        };
        let (eye, tl) = ray(lo, lo);
        let (tr, bl, br) = (ray(wx, lo).1, ray(lo, hy).1, ray(wx, hy).1);
        let centre = ray(0.5 * w, 0.5 * h).1;
        let mut normals = [tl.cross(bl), bl.cross(br), br.cross(tr), tr.cross(tl)];
        for n in &mut normals {
            if n.dot(centre) < 0.0 {
                *n = -*n;
            }
        }
        // Every corner inside the other planes, or the pyramid is not one
        // (a fov near 180°, a degenerate film): then nothing is culled.
        let ok = normals.iter().all(|n| {
            n.is_finite()
                && n.dot(centre) > 0.0
                && [tl, tr, bl, br].iter().all(|c| n.dot(*c) > -1e-9 * n.length())
        });
        ok.then_some(Frustum { eye, normals })
    }

    /// Bit k set when `q` lies strictly outside plane k.
    #[inline]
    fn outcode(&self, q: DVec3) -> u8 {
        let d = q - self.eye;
        let mut code = 0;
        for (k, n) in self.normals.iter().enumerate() {
            code |= u8::from(n.dot(d) < 0.0) << k;
        }
        code
    }
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
    copies: Vec<Copy>,
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

/// The packets of both packet renderers: tiles of `TILE_W` × `TILE_H`
/// pixels, one `rtcIntersect16` per query. Issue 16, fourth round: against
/// spans of eight along a row (`rtcIntersect8`), the tube's warp ray pass
/// took 12–15 % less CPU (single thread, interleaved `rays:` runs; 8 × 2
/// tiles about the same, 4 × 4 also best on the plate; the machine has
/// AVX-512, where Embree's packets of sixteen are its native width).
const TILE_W: usize = 4;
const TILE_H: usize = 4;
const LANES: usize = TILE_W * TILE_H;

/// One tile of the packet renders, in a band of `rows` (≤ `TILE_H`) rows of
/// a film `w` pixels wide: lane `l` is pixel (x0 + l % TILE_W, band row
/// l / TILE_W), when that pixel is on the film.
struct Tile {
    x0: usize,
    y0: usize,
    nx: usize,
    rows: usize,
    w: usize,
}

impl Tile {
    /// The tile at column `x0` of band `band` (of `TILE_H` rows).
    fn new(x0: usize, band: usize, rows: usize, w: usize) -> Tile {
        Tile {
            x0,
            y0: band * TILE_H,
            nx: TILE_W.min(w - x0),
            rows,
            w,
        }
    }

    /// Lane `l`'s pixel: its index in the band's slice of the frame and its
    /// film coordinates; `None` past the film's right or bottom edge.
    fn lane(&self, l: usize) -> Option<(usize, u32, u32)> {
        let (dx, dy) = (l % TILE_W, l / TILE_W);
        (dx < self.nx && dy < self.rows).then(|| {
            (
                dy * self.w + self.x0 + dx,
                (self.x0 + dx) as u32,
                (self.y0 + dy) as u32,
            )
        })
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
/// plane (where the direct query stopped) and every warped hit after it,
/// and a ray that does not cross the plane reaches no warped triangle. So
/// one query per span instead of two, and no classification (−16 % CPU in
/// the plate's ray pass).
///
/// The tube keeps one BVH per key: hollow2 + through4 (asked by the same
/// rays) and tir2 − + (on the two sides of the plane through the eye and
/// the axis, which a ray from the eye does not cross) could share one
/// exactly, but that measured no faster (docs/warp.md). The direct copy
/// must stay alone: its query stops at the tube, and a direct triangle
/// across the tube's silhouette would otherwise show through it.
fn groups(glass: &WarpGlass, keys: &[CopyKey]) -> Vec<Vec<CopyKey>> {
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

/// `WarpGlass::classify_keys` for one frame's eye, answering copy bit masks
/// (bit k: copy k) instead of keys. What depends on the eye alone is
/// computed once per frame, and the family tests compare squares
/// (|b| < r ⇔ (e × h)² < r²·|h|², and the TIR test |b|·m_a < r·m_g
/// likewise), so a tube ray costs one square root (its entry into the
/// tube, as `classify_keys` computes it) instead of five, and no key
/// look-ups. Same classes up to rounding at the family edges (tested
/// through the same pixels as `render_warped`).
// One value per frame, on the stack: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
enum Classifier {
    /// The plate's one copy (direct and warped, see `groups`): every ray
    /// looks at it.
    Plate { bit: u8 },
    Tube {
        c: crate::warp::HollowCylinder,
        /// The frame's axes across (u, w) and along (a) the tube.
        u: DVec3,
        w: DVec3,
        a: DVec3,
        /// The eye across the axis: 2-D and as a 3-D offset (for `cyl_roots`).
        e: glam::DVec2,
        qp: DVec3,
        /// hollow2 + through4, tir2 −/+, wall2 −/+.
        bits: [u8; 5],
    },
}

impl Classifier {
    fn new(pipe: &Pipeline, eye: DVec3) -> Classifier {
        let bit = |k: CopyKey| pipe.key_index(k).map_or(0u8, |i| 1 << i);
        let key = |family, side| CopyKey { family, side };
        match pipe.glass {
            WarpGlass::Plate(_) => Classifier::Plate {
                bit: bit(CopyKey::DIRECT),
            },
            WarpGlass::Cylinder(c) => {
                let (u, w, a) = c.frame_axes();
                let q = eye - c.axis_point;
                Classifier::Tube {
                    c,
                    u,
                    w,
                    a,
                    e: c.to2(eye).0,
                    qp: q - a * q.dot(a),
                    bits: [
                        bit(key(Family::Hollow2, 0)) | bit(key(Family::Through4, 0)),
                        bit(key(Family::Tir2, -1)),
                        bit(key(Family::Tir2, 1)),
                        bit(key(Family::Wall2, -1)),
                        bit(key(Family::Wall2, 1)),
                    ],
                }
            }
        }
    }

    /// `classify` for a tile's rays (a zero direction: no copy), written
    /// over arrays without branches so that the compiler can pair the
    /// lanes' square roots and divisions (the per-lane `classify` was a
    /// latency-bound chain of three square roots and four divisions per
    /// ray with the normalisation, ~20 % of the tube's ray pass in perf).
    /// The same arithmetic as `classify`, so the same classes (tested).
    #[inline]
    fn classify16(&self, rays: &[(DVec3, DVec3); LANES]) -> [(f64, u8); LANES] {
        let mut out = [(f64::INFINITY, 0u8); LANES];
        match self {
            Classifier::Plate { bit } => {
                for (o, (_, d)) in out.iter_mut().zip(rays) {
                    if *d != DVec3::ZERO {
                        o.1 = *bit;
                    }
                }
            }
            Classifier::Tube {
                c,
                u,
                w,
                a,
                e,
                qp,
                bits,
            } => {
                let (mut t, mut beta, mut cross, mut hh) =
                    ([0.0f64; LANES], [0.0f64; LANES], [0.0f64; LANES], [0.0f64; LANES]);
                let cc = qp.length_squared() - c.outer_radius * c.outer_radius;
                for l in 0..LANES {
                    let d = rays[l].1;
                    let b = d.dot(*a);
                    // `cyl_roots(qp, d − a·β, R)`'s nearer root, if ahead.
                    let dp = d - *a * b;
                    let aa = dp.length_squared();
                    let bb = qp.dot(dp);
                    let disc = bb * bb - aa * cc;
                    let s = disc.max(0.0).sqrt();
                    let k = if bb > 0.0 { -(bb + s) } else { -bb + s };
                    let t0 = (k / aa).min(cc / k);
                    let ok = aa >= 1e-300 && disc >= 0.0 && k != 0.0 && t0 > 0.0;
                    t[l] = if ok { t0 } else { f64::INFINITY };
                    beta[l] = b;
                    let h = glam::DVec2::new(d.dot(*u), d.dot(*w));
                    hh[l] = h.length_squared();
                    cross[l] = e.perp_dot(h);
                }
                let r2 = c.inner_radius * c.inner_radius;
                for l in 0..LANES {
                    if t[l] == f64::INFINITY {
                        continue;
                    }
                    let (b2h, be) = (cross[l] * cross[l], beta[l]);
                    let side = if cross[l] < 0.0 { 0 } else { 1 };
                    let m = if b2h < r2 * hh[l] {
                        bits[0]
                    } else if b2h * (1.0 - be * be).max(0.0) < r2 * hh[l] * (c.ior * c.ior - be * be).max(0.0)
                    {
                        bits[1 + side]
                    } else {
                        bits[3 + side]
                    };
                    out[l] = (t[l], m);
                }
            }
        }
        out
    }

    /// (distance to the glass, copies to look at beyond it) for unit `d`.
    #[cfg(test)]
    fn classify(&self, d: DVec3) -> (f64, u8) {
        match self {
            Classifier::Plate { bit } => (f64::INFINITY, *bit),
            Classifier::Tube {
                c,
                u,
                w,
                a,
                e,
                qp,
                bits,
            } => {
                let beta = d.dot(*a);
                let t_enter = match crate::warp::glass::cyl_roots(*qp, d - *a * beta, c.outer_radius) {
                    Some((t0, _)) if t0 > 0.0 => t0,
                    _ => return (f64::INFINITY, 0),
                };
                let h = glam::DVec2::new(d.dot(*u), d.dot(*w));
                let hh = h.length_squared();
                // b·|h| = e × h.
                let cross = e.perp_dot(h);
                let r2 = c.inner_radius * c.inner_radius;
                let b2h = cross * cross;
                let side = if cross < 0.0 { 0 } else { 1 };
                let m = if b2h < r2 * hh {
                    bits[0]
                } else if b2h * (1.0 - beta * beta).max(0.0)
                    < r2 * hh * (c.ior * c.ior - beta * beta).max(0.0)
                {
                    bits[1 + side]
                } else {
                    bits[3 + side]
                };
                (t_enter, m)
            }
        }
    }
}

/// The tile's eye rays, as `pixel_ray` makes them (bit for bit: the same
/// f32 camera ray, then the same f64 normalisation, done here lane-wise over
/// arrays so that the compiler can pair the square roots and divisions);
/// lanes off the film get a zero ray, which `classify16` gives no copy.
#[inline]
fn tile_rays(scene: &RenderScene, tile: &Tile) -> [(DVec3, DVec3); LANES] {
    let mut org = [DVec3::ZERO; LANES];
    let (mut x, mut y, mut z) = ([0.0f64; LANES], [0.0f64; LANES], [0.0f64; LANES]);
    let mut live = [false; LANES];
    for l in 0..LANES {
        if let Some((_, px, py)) = tile.lane(l) {
            let (o, d) = scene.camera.ray(px as f32 + 0.5, py as f32 + 0.5, (0.0, 0.0));
            org[l] = DVec3::new(o.x as f64, o.y as f64, o.z as f64);
            (x[l], y[l], z[l]) = (d.x as f64, d.y as f64, d.z as f64);
            live[l] = true;
        } else {
            (x[l], y[l], z[l]) = (0.0, 0.0, 1.0);
        }
    }
    // `DVec3::normalize`: self · (1 / √(x² + y² + z²)), in that order.
    let mut r = [0.0f64; LANES];
    for l in 0..LANES {
        r[l] = 1.0 / (x[l] * x[l] + y[l] * y[l] + z[l] * z[l]).sqrt();
    }
    let mut out = [(DVec3::ZERO, DVec3::ZERO); LANES];
    for l in 0..LANES {
        if live[l] {
            out[l] = (org[l], DVec3::new(x[l] * r[l], y[l] * r[l], z[l] * r[l]));
        }
    }
    out
}

/// A lane's nearest hit so far: (t, copy, primitive, u, v).
type LaneHit = (f32, usize, u32, f32, f32);

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
            copies.push(Copy {
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

    /// Warp every vertex for the scene's current camera and update the
    /// copies. The copies then hold what that camera (its eye, view and
    /// film) can see: render the same camera (`render`, `render_into`)
    /// before the next `warp`. The tube's copies leave out what lies
    /// outside its pyramid of rays (`Frustum`).
    pub fn warp(&mut self, scene: &RenderScene) -> Result<FrameWarp> {
        let eye = DVec3::from(scene.camera.position.to_array().map(|x| x as f64));
        let nv = self.positions.len();
        let t0 = Instant::now();
        let tube = matches!(self.glass, WarpGlass::Cylinder(_));
        let frustum = self
            .cull_margin_px
            .filter(|_| tube)
            .and_then(|m| Frustum::of(scene, m));
        for c in self.copies.iter_mut().filter(|c| !c.fixed) {
            // One slab of nv vertices per member key.
            c.next.resize(c.members.len() * nv, [0.0; 3]);
            c.codes
                .resize(if frustum.is_some() { c.next.len() } else { 0 }, 0);
        }
        let images;
        match (&self.glass, self.method) {
            (WarpGlass::Plate(plate), _) => {
                // One copy (see `groups`): its vertex array holds the
                // unwarped positions (direct), then the warped ones, which the
                // batch writes in place.
                let (dbit, wbit) = (
                    self.key_bit(CopyKey::DIRECT),
                    self.key_bit(CopyKey {
                        family: Family::Wall2,
                        side: 0,
                    }),
                );
                self.plate_class.resize(nv, Ok(false));
                let c = &mut self.copies[0];
                let mut next = std::mem::take(&mut c.next);
                let (mut direct, mut warped) = next.split_at_mut(nv);
                if c.members.first() != Some(&CopyKey::DIRECT) {
                    std::mem::swap(&mut direct, &mut warped);
                }
                direct.copy_from_slice(&self.positions);
                const CHUNK: usize = 4096;
                warped
                    .par_chunks_mut(CHUNK)
                    .zip(self.plate_class.par_chunks_mut(CHUNK))
                    .zip(self.positions.par_chunks(CHUNK))
                    .zip(self.masks.par_chunks_mut(CHUNK))
                    .for_each(|(((out, class), pts), masks)| {
                        plate.warp_batch(eye, pts, out, class);
                        for (m, c) in masks.iter_mut().zip(class.iter()) {
                            *m = match c {
                                Ok(true) => wbit,
                                Ok(false) => dbit,
                                Err(_) => 0,
                            };
                        }
                    });
                self.copies[0].next = next;
                images = self.masks.iter().filter(|&&m| m != 0).count();
            }
            (glass, method) => {
                let all = &self.positions64;
                let solver = VertexSolver::new(*glass, method, eye, all);
                // One pass per chunk of vertices writes their masks and
                // their rows of every slab, straight from the solver's
                // images (before: a `VertexImages` per vertex, then a pass
                // for the masks and one per slab).
                let keys = &self.keys;
                let mut slab_of = [usize::MAX; 8];
                let mut slabs: Vec<&mut [[f32; 3]]> = Vec::new();
                let mut code_slabs: Vec<&mut [u8]> = Vec::new();
                for c in self.copies.iter_mut().filter(|c| !c.fixed) {
                    for (slab, key) in c.next.chunks_mut(nv.max(1)).zip(&c.members) {
                        if let Some(k) = keys.iter().position(|k| k == key) {
                            slab_of[k] = slabs.len();
                        }
                        slabs.push(slab);
                    }
                    code_slabs.extend(c.codes.chunks_mut(nv.max(1)));
                }
                const CHUNK: usize = 256;
                let chunks = nv.div_ceil(CHUNK);
                let rows = chunk_rows(slabs, chunks, CHUNK);
                // Empty rows when nothing is culled.
                let code_rows = chunk_rows(code_slabs, chunks, CHUNK);
                let frustum = &frustum;
                rows.into_par_iter()
                    .zip(code_rows.into_par_iter())
                    .zip(self.masks.par_chunks_mut(CHUNK))
                    .zip(all.par_chunks(CHUNK))
                    .zip(self.positions.par_chunks(CHUNK))
                    .for_each(|((((mut outs, mut codes), masks), pts), unwarped)| {
                        // A vertex without an image in a copy keeps its
                        // unwarped position there (no kept triangle uses it).
                        for o in outs.iter_mut() {
                            o.copy_from_slice(unwarped);
                        }
                        masks.fill(0);
                        solver.each_image(pts, |i, key, q| {
                            let Some(k) = keys.iter().position(|k| *k == key) else {
                                return;
                            };
                            // The first image per copy wins (`VertexImages::push`).
                            if masks[i] & (1 << k) == 0 {
                                masks[i] |= 1 << k;
                                if let Some(o) = outs.get_mut(slab_of[k]) {
                                    o[i] = [q.x as f32, q.y as f32, q.z as f32];
                                }
                                if let (Some(f), Some(code)) = (frustum, codes.get_mut(slab_of[k])) {
                                    code[i] = f.outcode(q);
                                }
                            }
                        });
                    });
                images = self.masks.par_iter().map(|m| m.count_ones() as usize).sum();
            }
        }
        // The keys some vertex has an image for: a copy of none has no
        // triangle (three of the tube's six copies on the bench's view),
        // and its scan of every triangle is skipped.
        let present = self.masks.par_iter().copied().reduce(|| 0, |a, b| a | b);
        let warp_s = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let tris = &self.tris;
        let masks = &self.masks;
        let results: Vec<Result<(Committed, usize)>> = self
            .copies
            .par_iter_mut()
            .filter(|c| !c.fixed)
            .map(|c| {
                let mut culled = 0;
                // Member m's triangles, in order; their vertices index its
                // slab (offset m·nv).
                let mut ids: Vec<u32> = Vec::with_capacity(c.tri_ids.len().max(1024));
                let mut ends = Vec::with_capacity(c.members.len());
                for (m, &b) in c.member_bits.iter().enumerate() {
                    let bit = 1u8 << b;
                    if present & bit != 0 {
                        // The member's outcodes, when the copy is culled.
                        let codes = c.codes.get(m * nv..(m + 1) * nv).filter(|cs| !cs.is_empty());
                        for (i, t) in tris.iter().enumerate() {
                            if !t.iter().all(|&v| masks[v as usize] & bit != 0) {
                                continue;
                            }
                            if codes
                                .is_some_and(|cs| t.iter().fold(!0u8, |all, &v| all & cs[v as usize]) != 0)
                            {
                                culled += 1;
                            } else {
                                ids.push(i as u32);
                            }
                        }
                    }
                    ends.push(ids.len());
                }
                let same = ids == c.tri_ids && ends == c.member_ends;
                c.tri_ids = ids;
                c.member_ends = ends;
                let next = &mut c.next;
                let (ids, ends) = (&c.tri_ids, &c.member_ends);
                let committed = c.mesh.update(|vs, is| {
                    std::mem::swap(vs, next);
                    if same {
                        return false;
                    }
                    is.clear();
                    let mut start = 0;
                    for (m, &end) in ends.iter().enumerate() {
                        let offset = (m * nv) as u32;
                        is.extend(
                            ids[start..end]
                                .iter()
                                .map(|&i| tris[i as usize].map(|v| v + offset)),
                        );
                        start = end;
                    }
                    true
                })?;
                Ok((committed, culled))
            })
            .collect();
        let (mut refits, mut rebuilds, mut culled_triangles) = (0, 0, 0);
        for r in results {
            let (committed, culled) = r?;
            culled_triangles += culled;
            match committed {
                Committed::Refit => refits += 1,
                Committed::Rebuilt => rebuilds += 1,
                Committed::Empty => {}
            }
        }
        let dropped_triangles = self
            .tris
            .par_iter()
            .filter(|t| masks[t[0] as usize] & masks[t[1] as usize] & masks[t[2] as usize] == 0)
            .count();
        Ok(FrameWarp {
            warp_s,
            build_s: t1.elapsed().as_secs_f64(),
            images,
            refits,
            rebuilds,
            dropped_triangles,
            culled_triangles,
        })
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

    /// Render the current copies with straight primary rays in packets of sixteen.
    pub fn render(&self, scene: &RenderScene, spec: &WarpSpec, prep: &Prepared) -> Frame {
        let mut frame = Frame {
            width: 0,
            height: 0,
            pixels: Vec::new(),
            shown: Vec::new(),
            render_s: 0.0,
        };
        self.render_into(scene, spec, prep, &mut frame);
        frame
    }

    /// `render` into a frame kept across frames (an interactive viewer's
    /// frame buffer): every pixel is written, hit or not, so the buffers are
    /// reused without clearing, and a frame does not page in ~120 MB of
    /// fresh memory at 1600×1200 (the kernel's page faults were ~10 % of the
    /// tube's frame in perf). `render_s` includes resizing on the first use.
    pub fn render_into(&self, scene: &RenderScene, spec: &WarpSpec, prep: &Prepared, frame: &mut Frame) {
        let t0 = Instant::now();
        let (w, h) = (scene.width as usize, scene.height as usize);
        frame.width = scene.width;
        frame.height = scene.height;
        frame.pixels.resize(w * h, V3::ZERO);
        frame.shown.resize(w * h, None);
        let (pixels, shown) = (&mut frame.pixels, &mut frame.shown);
        // The direct copy queried up to the glass (the plate's direct
        // triangles share the one copy every ray asks).
        let direct = self
            .copies
            .iter()
            .position(|c| c.members[..] == [CopyKey::DIRECT]);
        let eye = DVec3::from(scene.camera.position.to_array().map(|x| x as f64));
        let classifier = Classifier::new(self, eye);
        pixels
            .par_chunks_mut(w * TILE_H)
            .zip(shown.par_chunks_mut(w * TILE_H))
            .enumerate()
            .for_each(|(ty, (prow, srow))| {
                let rows = prow.len() / w;
                let mut packet = Packet16::new();
                for x0 in (0..w).step_by(TILE_W) {
                    let tile = Tile::new(x0, ty, rows, w);
                    let lane_px = |l: usize| tile.lane(l).map(|(i, _, _)| i);
                    let rays = tile_rays(scene, &tile);
                    let class = classifier.classify16(&rays);
                    let want = class.iter().fold(0u8, |w, c| w | c.1);
                    // Nearest hit per lane: (t, copy, prim, u, v).
                    let mut best: [Option<LaneHit>; LANES] = [None; LANES];
                    if let Some(di) = direct.filter(|&di| !self.copies[di].tri_ids.is_empty()) {
                        packet.clear();
                        for l in 0..LANES {
                            if lane_px(l).is_some() {
                                let tfar = class[l].0.min(f32::MAX as f64) as f32;
                                packet.set(l, f3(rays[l].0), f3(rays[l].1), tfar);
                            }
                        }
                        self.copies[di].mesh.intersect16(&mut packet);
                        for (l, b) in best.iter_mut().enumerate() {
                            if let Some(hh) = packet.hit(l) {
                                *b = Some((hh.t, di, hh.prim_id, hh.u, hh.v));
                            }
                        }
                    }
                    for (ci, c) in self.copies.iter().enumerate() {
                        if want & (1 << ci) == 0 || c.tri_ids.is_empty() {
                            continue;
                        }
                        packet.clear();
                        for l in 0..LANES {
                            if class[l].1 & (1 << ci) != 0 {
                                // Only a nearer hit can change the lane's
                                // answer: Embree culls beyond the best so far.
                                let tfar = best[l].map_or(f32::INFINITY, |b| b.0);
                                packet.set(l, f3(rays[l].0), f3(rays[l].1), tfar);
                            }
                        }
                        c.mesh.intersect16(&mut packet);
                        for (l, b) in best.iter_mut().enumerate() {
                            if let Some(hh) = packet.hit(l) {
                                if b.is_none_or(|b| hh.t < b.0) {
                                    *b = Some((hh.t, ci, hh.prim_id, hh.u, hh.v));
                                }
                            }
                        }
                    }
                    for l in 0..LANES {
                        let Some(i) = lane_px(l) else {
                            continue;
                        };
                        let Some((_, ci, prim, u, v)) = best[l] else {
                            prow[i] = V3::ZERO;
                            srow[i] = None;
                            continue;
                        };
                        let c = &self.copies[ci];
                        let (obj, tri) = self.tri_src[c.tri_ids[prim as usize] as usize];
                        let weight = if spec.fresnel && c.key_of(prim as usize) != CopyKey::DIRECT {
                            spec.glass.exact_path(rays[l].0, rays[l].1).transmittance
                        } else {
                            1.0
                        };
                        let (col, p) = shade(scene, prep, obj, tri, u, v, weight);
                        prow[i] = col;
                        srow[i] = Some(Shown {
                            object: obj,
                            point: p,
                            path_length: (p - rays[l].0).length(),
                        });
                    }
                }
            });
        frame.render_s = t0.elapsed().as_secs_f64();
    }
}

/// The exact trace with the same packets: each pixel's exact path through
/// the glass (analytic, per lane), its straight pieces cast sixteen at a time
/// against the unwarped meshes (piece k of every lane still looking). The
/// same image as `render_exact` (tested); the fair reference for the
/// packet renderer's speed.
pub fn render_exact_packets(
    scene: &RenderScene,
    spec: &WarpSpec,
    prep: &Prepared,
    orig: &Originals,
) -> Frame {
    let t0 = Instant::now();
    let (w, h) = (scene.width as usize, scene.height as usize);
    let mut pixels = vec![V3::ZERO; w * h];
    let mut shown: Vec<Option<Shown>> = vec![None; w * h];
    pixels
        .par_chunks_mut(w * TILE_H)
        .zip(shown.par_chunks_mut(w * TILE_H))
        .enumerate()
        .for_each(|(ty, (prow, srow))| {
            let rows = prow.len() / w;
            let mut packet = Packet16::new();
            for x0 in (0..w).step_by(TILE_W) {
                let tile = Tile::new(x0, ty, rows, w);
                let lane_px = |l: usize| tile.lane(l).map(|(i, _, _)| i);
                let paths: Vec<Option<crate::warp::ExactPath>> = (0..LANES)
                    .map(|l| {
                        tile.lane(l).map(|(_, x, y)| {
                            let (o, d) = pixel_ray(scene, x, y);
                            spec.glass.exact_path(o, d)
                        })
                    })
                    .collect();
                let mut done = [false; LANES];
                let mut travelled = [0.0f64; LANES];
                let most = paths
                    .iter()
                    .flatten()
                    .map(|p| p.segments.len())
                    .max()
                    .unwrap_or(0);
                for k in 0..most {
                    packet.clear();
                    let mut any = false;
                    for l in 0..LANES {
                        if !done[l] {
                            if let Some(s) = paths[l].as_ref().and_then(|p| p.segments.get(k)) {
                                packet.set(l, f3(s.origin), f3(s.dir), s.t_end.min(f32::MAX as f64) as f32);
                                any = true;
                            }
                        }
                    }
                    if !any {
                        break;
                    }
                    orig.scene.intersect16(&mut packet);
                    for l in 0..LANES {
                        if done[l] {
                            continue;
                        }
                        let (Some(i), Some(path)) = (lane_px(l), paths[l].as_ref()) else {
                            continue;
                        };
                        let Some(s) = path.segments.get(k) else {
                            continue;
                        };
                        if let Some(hh) = packet.hit(l) {
                            let (obj, tri) = orig.source[hh.prim_id as usize];
                            let weight = if spec.fresnel && k > 0 {
                                path.transmittance
                            } else {
                                1.0
                            };
                            let (col, p) = shade(scene, prep, obj, tri, hh.u, hh.v, weight);
                            prow[i] = col;
                            srow[i] = Some(Shown {
                                object: obj,
                                point: p,
                                path_length: travelled[l] + (p - s.origin).length(),
                            });
                            done[l] = true;
                        } else {
                            travelled[l] += s.t_end;
                        }
                    }
                }
            }
        });
    Frame::finished(scene, pixels, shown, t0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::warp_render::{build_originals, prepare, render_exact};

    /// A pinhole camera at `pos` looking at the origin (y up, 40° field of
    /// view), as the tests move the scenes' eyes.
    fn looking_at_origin(pos: V3, w: u32, h: u32) -> crate::camera::Camera {
        crate::camera::Camera::try_new(pos, V3::ZERO, V3::Y, 40.0, w, h, 0.0, 1.0).unwrap()
    }

    /// `tile_rays` + `classify16` give every pixel of a frame (the film's
    /// ragged right and bottom edges included) `pixel_ray`'s ray and
    /// `classify`'s class, bit for bit, on both scenes, from two eyes.
    #[test]
    fn tile_rays_and_classes_are_the_per_pixel_ones() {
        for scene in ["scenes/warp_cylinder.toml", "scenes/warp_plate.toml"] {
            let mut s = crate::scene::load_scene(
                std::path::Path::new(scene),
                &crate::scene::BuildOptions::default(),
            )
            .unwrap();
            let (w, h) = (163u32, 122u32);
            s.set_resolution(w, h).unwrap();
            let spec = s.warp.clone().unwrap();
            let prep = prepare(&s, &spec, 1e9).unwrap();
            let pipe = Pipeline::new(&s, &spec, &prep, false).unwrap();
            let pos = s.camera.position;
            let mut classes = [0usize; 8];
            for dx in [0.0f32, 0.31] {
                s.camera = looking_at_origin(pos + V3::new(dx, 0.2, 0.0), w, h);
                let eye = d3(s.camera.position.to_array());
                let cl = Classifier::new(&pipe, eye);
                for band in 0..(h as usize).div_ceil(TILE_H) {
                    let rows = TILE_H.min(h as usize - band * TILE_H);
                    for x0 in (0..w as usize).step_by(TILE_W) {
                        let tile = Tile::new(x0, band, rows, w as usize);
                        let rays = tile_rays(&s, &tile);
                        let class = cl.classify16(&rays);
                        for l in 0..LANES {
                            match tile.lane(l) {
                                Some((_, x, y)) => {
                                    let r = pixel_ray(&s, x, y);
                                    assert_eq!(rays[l], r, "{scene} ({x}, {y})");
                                    let c = cl.classify(r.1);
                                    assert!(
                                        c.1 == class[l].1 && c.0.to_bits() == class[l].0.to_bits(),
                                        "{scene} ({x}, {y}): {c:?} {:?}",
                                        class[l]
                                    );
                                    classes[c.1.trailing_zeros().min(7) as usize] += 1;
                                }
                                None => assert_eq!(class[l].1, 0),
                            }
                        }
                    }
                }
            }
            // The tube's eyes see every class: direct only, hollow2 +
            // through4, tir2 on both sides.
            if scene.ends_with("cylinder.toml") {
                assert!(classes.iter().filter(|&&n| n > 100).count() >= 4, "{classes:?}");
            }
        }
    }

    /// scenes/warp_cylinder.toml at 160 × 120, subdivided as its `[warp]`
    /// says.
    fn tube_at_160x120() -> (RenderScene, WarpSpec, Prepared) {
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

    /// Culling the tube's copies to the camera's pyramid changes no pixel
    /// (the same frame as with nothing culled, from three eyes, one looking
    /// off the tube's centre and one at an odd film size) while it leaves
    /// out a sixth or more of the copies' triangles (22–27k of 96k here).
    /// Its power: the same culling with the pyramid narrowed to 3 pixels
    /// inside the film's edge (a wrong margin) changes the frame.
    #[test]
    fn culling_to_the_camera_changes_no_pixel() {
        let (mut s, spec, prep) = tube_at_160x120();
        let mut culled = Pipeline::new(&s, &spec, &prep, false).unwrap();
        let mut all = Pipeline::new(&s, &spec, &prep, false).unwrap();
        all.cull_margin_px = None;
        let mut narrow = Pipeline::new(&s, &spec, &prep, false).unwrap();
        narrow.cull_margin_px = Some(-3.0);
        let pos = s.camera.position;
        for (dx, target, (w, h)) in [
            (0.0f32, V3::ZERO, (160, 120)),
            (0.4, V3::new(0.9, 0.5, 0.0), (160, 120)),
            (-0.2, V3::ZERO, (131, 97)),
        ] {
            s.set_resolution(w, h).unwrap();
            s.camera = crate::camera::Camera::try_new(
                pos + V3::new(dx, 0.1, 0.0),
                target,
                V3::Y,
                40.0,
                w,
                h,
                0.0,
                1.0,
            )
            .unwrap();
            let fc = culled.warp(&s).unwrap();
            let fa = all.warp(&s).unwrap();
            narrow.warp(&s).unwrap();
            let kept = |p: &Pipeline| p.copy_sizes().iter().map(|c| c.1).sum::<usize>();
            let (kc, ka) = (kept(&culled), kept(&all));
            assert_eq!(fa.culled_triangles, 0);
            assert_eq!(kc + fc.culled_triangles, ka, "{fc:?}");
            assert!(6 * fc.culled_triangles >= ka, "{fc:?} of {ka}");
            let (a, b) = (culled.render(&s, &spec, &prep), all.render(&s, &spec, &prep));
            assert!(a.pixels == b.pixels && a.shown == b.shown, "eye offset {dx}");
            let c = narrow.render(&s, &spec, &prep);
            let differ = c.shown.iter().zip(&b.shown).filter(|(x, y)| x != y).count();
            assert!(differ > 100, "a narrowed pyramid changed only {differ} pixels");
        }
    }
}
