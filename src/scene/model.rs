//! The scene model: what a render sees of a scene once it is built —
//! geometry records with their materials, priority solids, lights, the
//! environment, the camera — and the queries on it that do not need a ray
//! tracer: the surface point of a hit, point-in-solid (light sampling and
//! its density are in `light_sampling`). It knows nothing of nested
//! strategies or warps' solvers.
//!
//! Conventions: world space, scene units (metres in the shipped scenes);
//! geometric normals of closed solids point out of the solid.
use super::emitter::{Emitter, Spot};
use super::shapes::{Analytic, Mesh};
use super::texture::{ImageData, Texture};
use crate::bsdf::{Conductor, MicrofacetDistribution, Plastic, RoughConductor, RoughPlastic};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::ray::{Hit, Ray};
use glam::{DVec3, Vec3A as V3};
use std::sync::Arc;

/// The largest film a scene or a render may ask for (checked before any
/// allocation): 134 M pixels, ~1.6 GB of f32 RGB.
pub const MAX_PIXELS: u64 = 1 << 27;

/// How the microfacet materials are shaded: correctly, or (tests only) in
/// a known-wrong way that the render tests must detect.
#[cfg(test)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) enum BsdfVariant {
    /// The library's f, pdf and sample weights.
    #[default]
    Right,
    /// Next-event estimation weighs itself against twice the BSDF's density.
    WrongMisPdf,
    /// A transmitted connection carries the radiance scale (n1/n2)² twice.
    WrongDoubleScale,
    /// Sampled transmissions are weighed with the reflection's Jacobian of
    /// the half vector, 1 / (4 |wi·m|), in place of refraction's.
    WrongJacobian,
    /// A smooth interface in vector shading reflects with half its
    /// Fresnel reflectance (its lobes still weighed as if drawn right).
    WrongHalfFresnel,
    /// A nested solid's boundary in vector shading takes its index pair
    /// against the ambient medium, not from the interior list.
    WrongNestedPair,
    /// A path transmitted through a nested solid's boundary in vector
    /// shading keeps the interior list it had.
    WrongNestedList,
    /// Next-event estimation in vector shading leaves out the cosine at the
    /// shaded point.
    WrongNeeCosine,
    /// Rough glass in vector shading reflects with half the Fresnel
    /// reflectance at the sampled facet (and evaluates so).
    WrongRoughFresnel,
    /// Metals in vector shading take the Fresnel reflectance of a
    /// dielectric of their index (κ = 0).
    WrongMetalFresnel,
    /// Plastics in vector shading: the coating reflects half its Fresnel
    /// reflectance (and transmits 1 − F/2).
    WrongPlasticFresnel,
}

/// Surface response.
#[derive(Debug, Clone)]
pub enum Material {
    /// Lambertian reflection.
    Diffuse {
        /// Albedo, in [0, 1] per channel.
        reflectance: Texture,
        /// Reflects on both sides (else black from behind the normal).
        two_sided: bool,
    },
    /// A perfect mirror.
    Mirror {
        /// Reflectance per channel.
        reflectance: V3,
    },
    /// A closed solid of the priority scheme (index into `RenderScene::solids`).
    Solid(u32),
    /// An interface: `int_ior` on the side opposite the normal, `ext_ior` on the normal side.
    Interface {
        /// Index on the side opposite the normal.
        int_ior: f32,
        /// Index on the side the normal points to.
        ext_ior: f32,
    },
    /// Absorbs everything (lights' bodies).
    Black,
    /// A priority solid (as [`Material::Solid`]) whose surface is rough: the
    /// nested rule's index pair feeds a microfacet boundary.
    RoughSolid {
        /// Index into `RenderScene::solids`.
        solid: u32,
        /// The surface's microfacet normals.
        distribution: MicrofacetDistribution,
    },
    /// A rough interface: [`Material::Interface`] with microfacet normals.
    RoughInterface {
        /// Index on the side opposite the normal.
        int_ior: f32,
        /// Index on the side the normal points to.
        ext_ior: f32,
        /// The surface's microfacet normals.
        distribution: MicrofacetDistribution,
    },
    /// A smooth metal (a mirror with the conductor's Fresnel reflectance).
    Conductor {
        /// The BSDF, one-sided about the normal.
        bsdf: Conductor,
        /// Reflects on both sides (else black from behind the normal).
        two_sided: bool,
    },
    /// A rough metal.
    RoughConductor {
        /// The BSDF, one-sided about the normal.
        bsdf: RoughConductor,
        /// Reflects on both sides.
        two_sided: bool,
    },
    /// A diffuse base under a smooth dielectric coating.
    Plastic {
        /// The BSDF, one-sided about the normal.
        bsdf: Plastic,
        /// Reflects on both sides.
        two_sided: bool,
    },
    /// A diffuse base under a rough coating (its tables built once, shared).
    RoughPlastic {
        /// The BSDF, one-sided about the normal.
        bsdf: Arc<RoughPlastic>,
        /// Reflects on both sides.
        two_sided: bool,
    },
}

impl Material {
    /// A dielectric boundary (smooth or rough): the nested rule applies to it.
    pub fn is_dielectric(&self) -> bool {
        matches!(
            self,
            Material::Interface { .. }
                | Material::Solid(_)
                | Material::RoughSolid { .. }
                | Material::RoughInterface { .. }
        )
    }
}

/// Geometry shape as the integrator sees it.
#[derive(Debug, Clone)]
pub enum Shape {
    /// A triangle mesh (closed when it bounds a solid).
    Mesh(Arc<Mesh>),
    /// An analytic shape on Embree user geometry.
    Analytic(Analytic),
}

/// One Embree geometry (indexed by geomID).
#[derive(Debug, Clone)]
pub struct GeomRecord {
    /// The object's name (unique in the scene).
    pub name: String,
    /// Its shape, in world space.
    pub shape: Shape,
    /// Its material (`Material::Solid` for priority solids).
    pub material: Material,
    /// Emitted radiance, if it is a light source.
    pub emission: Option<Texture>,
    /// The emission leaves both sides (else only the side the geometric
    /// normal points to).
    pub emission_two_sided: bool,
    /// Index into `RenderScene::lights` when this surface is also an NEE light.
    pub light: Option<u32>,
}

impl GeomRecord {
    /// Does shading read texture coordinates here? (Analytic shapes' uv costs
    /// atan2/acos, so it is computed only when read.)
    pub fn needs_uv(&self) -> bool {
        let m = matches!(&self.material, Material::Diffuse { reflectance, .. } if reflectance.needs_uv());
        m || self.emission.as_ref().is_some_and(Texture::needs_uv)
    }
}

/// A priority solid (Schmidt & Budge).
#[derive(Debug, Clone)]
pub struct Solid {
    /// The object's name.
    pub name: String,
    /// Its geometry id.
    pub geom: u32,
    /// Its declared priority (higher wins).
    pub priority: i64,
    /// Dense total order: priority first, then declaration order (the later
    /// declared object wins a tie, as if its priority were higher by an infinitesimal).
    pub rank: u32,
    /// Its index of refraction.
    pub ior: f32,
    /// Beer–Lambert absorption coefficient per metre, per channel.
    pub sigma_a: V3,
    /// Its world-space bounds (min, max).
    pub aabb: (DVec3, DVec3),
}

/// Light sources for next-event estimation.
#[derive(Debug, Clone)]
pub enum Light {
    /// A point light.
    Point {
        /// Position.
        position: V3,
        /// Radiant intensity per channel (W/sr in scene units).
        intensity: V3,
    },
    /// A directional light (the sun).
    Directional {
        /// Unit direction the light travels in.
        direction: V3,
        /// Irradiance on a surface facing the light.
        irradiance: V3,
    },
    /// A rectangular area light, emitting on the side of `normal`.
    Rect {
        /// One corner.
        corner: V3,
        /// The edge from `corner` along u.
        edge_u: V3,
        /// The edge from `corner` along v.
        edge_v: V3,
        /// Unit normal, the emitting side.
        normal: V3,
        /// Area.
        area: f32,
        /// Emitted radiance.
        radiance: V3,
    },
    /// A spherical area light.
    Sphere {
        /// Centre.
        center: V3,
        /// Radius.
        radius: f32,
        /// Emitted radiance.
        radiance: V3,
    },
    /// A spot light (a point whose intensity falls off away from its axis).
    Spot(Spot),
    /// An emitting object.
    Emitter(Emitter),
}

#[derive(Debug, Clone)]
/// Radiance arriving from infinitely far away.
pub enum Environment {
    /// No light.
    Black,
    /// The same radiance from every direction.
    Constant(V3),
    /// An equirectangular (latitude-longitude) map.
    Map {
        /// The image, linear RGB.
        image: Arc<ImageData>,
        /// Multiplier of the image's values.
        scale: f32,
        /// World to map directions (the inverse of the map's `to_world`
        /// rotation); `None`: the map's frame is the world's.
        to_local: Option<glam::Mat3A>,
        /// Where the image's rows sit between the poles.
        rows: super::texture::Rows,
        /// Next-event estimation's distribution over the map (`None`: a
        /// black map, which nothing samples).
        sampler: Option<Arc<super::envmap::EnvSampler>>,
    },
    /// A sun of finite angular size in an analytic sky; the path tracer
    /// samples its disk by next-event estimation.
    Sky(super::sun::Sky),
}

impl Environment {
    /// Radiance arriving along −`dir` (seen looking along `dir`).
    #[inline]
    pub fn eval(&self, dir: V3) -> V3 {
        match self {
            Environment::Black => V3::ZERO,
            Environment::Constant(c) => *c,
            Environment::Map {
                image,
                scale,
                to_local,
                rows,
                ..
            } => {
                let d = match to_local {
                    Some(m) => *m * dir,
                    None => dir,
                };
                let u = 0.5 + d.x.atan2(-d.z) / std::f32::consts::TAU;
                let v = d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
                image.lookup_rows(u, v, *rows) * *scale
            }
            Environment::Sky(sky) => sky.eval(dir),
        }
    }

    /// Does next-event estimation sample this environment (a map's texels
    /// or a sky's sun)? Constant and black environments are not sampled.
    #[inline]
    pub fn is_sampled(&self) -> bool {
        self.sun_nee().is_some() || self.map_sampler().is_some()
    }

    /// A map's sampling distribution and world-to-map rotation, if next-event
    /// estimation samples it.
    #[inline]
    pub fn map_sampler(&self) -> Option<(&super::envmap::EnvSampler, Option<&glam::Mat3A>)> {
        match self {
            Environment::Map {
                sampler: Some(s),
                to_local,
                ..
            } => Some((s, to_local.as_ref())),
            _ => None,
        }
    }

    /// The sky whose sun next-event estimation samples, if any.
    #[inline]
    pub fn sun_nee(&self) -> Option<&super::sun::Sky> {
        match self {
            Environment::Sky(sky) if sky.sun_nee() => Some(sky),
            _ => None,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
/// Which integrator a scene renders with (`[integrator] type`).
pub enum IntegratorKind {
    /// The unbiased path tracer.
    Path,
    /// The Whitted preview.
    Whitted,
}

/// Everything a render needs.
pub struct RenderScene {
    /// The Embree scene of every geometry.
    pub embree: crate::embree::Scene,
    /// Known-wrong variants of the microfacet materials' shading, for the
    /// render tests' power.
    #[cfg(test)]
    pub(crate) bsdf_variant: BsdfVariant,
    /// The analytic shapes, when the path tracer's packets intersect them
    /// itself (`embree` then has a twin of its meshes alone).
    pub analytic_set: Option<crate::scene::shapes::AnalyticSet>,
    /// Geometry records, indexed by Embree geometry id.
    pub geoms: Vec<GeomRecord>,
    /// Priority solids, indexed by solid index.
    pub solids: Vec<Solid>,
    /// Rank per geomID: the solid's rank, or `u32::MAX` for non-solids (never false).
    pub rank_by_geom: Vec<u32>,
    /// Solid index per geomID.
    pub solid_by_geom: Vec<Option<u32>>,
    /// Light sources for next-event estimation.
    pub lights: Vec<Light>,
    /// Radiance from infinity.
    pub environment: Environment,
    /// The camera at the film resolution the scene file declares (a render
    /// at another resolution uses `Camera::with_resolution`).
    pub camera: Camera,
    /// Film width the scene file declares (pixels); renders take theirs
    /// from `render::RenderSettings`, which starts from these four.
    pub width: u32,
    /// Film height the scene file declares (pixels).
    pub height: u32,
    /// Samples per pixel the scene file declares.
    pub spp: u32,
    /// Seed the scene file declares.
    pub seed: u64,
    /// The integrator.
    pub integrator: IntegratorKind,
    /// Path segments including the camera ray (1: emitters only).
    pub max_depth: u32,
    /// Segment index from which Russian roulette starts.
    pub rr_depth: u32,
    /// Index of the medium outside every solid.
    pub ambient_ior: f32,
    /// Solids that contain the camera (found by point-in-solid tests or given).
    pub camera_interior: Vec<u32>,
    /// True when some solids may overlap (bounds intersect): only then can a
    /// false hit happen and only then is a filter installed.
    pub has_overlap: bool,
    /// Analytic solids left out of filtered queries below their rank by
    /// Embree ray masks (geometry mask bit = rank), sorted by rank: a ray
    /// with top rank P0 settles those ranked below P0 by point-in-solid.
    pub(crate) masked_solids: Vec<u32>,
    /// The lowest rank of a solid not in `masked_solids` (`u32::MAX` when
    /// there is none): a ray whose top rank is at most this can see no solid
    /// ranked below it once the masked ones are left out, so no hit of its
    /// query can be false.
    pub(crate) lowest_unmasked_rank: u32,
    /// Indices of the solids that are closed meshes, with their bounds: the
    /// only solids whose entry Embree can leak (a ray through a vertex) and
    /// whose hits near an edge may be touches (`dielectric::trace`).
    pub(crate) mesh_solids: Vec<(u32, (DVec3, DVec3))>,
    /// The solids' bounds, for finding the solids near a point
    /// (`dielectric::settle`).
    pub(crate) solid_boxes: SolidBoxes,
    /// Per geometry, the solids whose surfaces may come near its own, and
    /// how near (`dielectric::settle`, computed on first use).
    pub(crate) neighbours: std::sync::OnceLock<Neighbours>,
    /// The gradient-index medium, if any: rays inside its bounds are cast as chords.
    pub medium: Option<crate::media::Medium>,
    /// The analytic warp glass (`[warp]`), if any; its geometry is also in
    /// `geoms` (as `glass_geoms`) so that `snell render` traces it exactly.
    pub warp: Option<crate::warp::WarpSpec>,
    /// Warnings produced while loading (e.g. flipped meshes).
    pub warnings: Vec<String>,
    pub(crate) containment: Vec<Containment>,
}

/// Axis-aligned boxes in f32, padded and rounded outward: which boxes meet
/// a small cube around a point, at a compare or two per box that does not
/// (f32 boxes halve the loads of the same test on the f64 bounds).
#[derive(Debug, Clone, Default)]
pub(crate) struct SolidBoxes {
    /// Per box: lower x, y, z, upper x, y, z.
    boxes: Vec<[f32; 6]>,
}

impl SolidBoxes {
    /// The boxes, in order (box `i` is reported as `i`).
    pub(crate) fn new(boxes: impl Iterator<Item = (DVec3, DVec3)>) -> Self {
        // Far more than f32 rounding: no box that meets the cube in f64 is missed.
        let pad = |v: f64| 1e-6 * (1.0 + v.abs());
        let boxes = boxes
            .map(|(a, b)| {
                let lo = [0, 1, 2].map(|k| (a[k] - pad(a[k])) as f32);
                let hi = [0, 1, 2].map(|k| (b[k] + pad(b[k])) as f32);
                [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]]
            })
            .collect();
        Self { boxes }
    }

    /// Call `f(i)` for every box `i`, in order, that meets the cube of
    /// half-side `tol` around `p` (and perhaps a few that come within a
    /// millionth of it); stops at the first `false`.
    #[inline]
    pub(crate) fn meeting(&self, p: DVec3, tol: f64, mut f: impl FnMut(u32) -> bool) {
        let q = |k: usize, s: f64| (p[k] + s * (tol + 1e-6 * (1.0 + p[k].abs()))) as f32;
        let (lo, hi) = ([0, 1, 2].map(|k| q(k, -1.0)), [0, 1, 2].map(|k| q(k, 1.0)));
        for (i, b) in self.boxes.iter().enumerate() {
            if hi[0] < b[0] || lo[0] > b[3] || hi[1] < b[1] || lo[1] > b[4] || hi[2] < b[2] || lo[2] > b[5] {
                continue;
            }
            if !f(i as u32) {
                return;
            }
        }
    }
}

/// Per geometry (geomID), the solids other than its own whose surfaces may
/// pass within `tol` of its surface, each with the box on the geometry's
/// surface where it may (`of[g]`, in solid order). A geometry that is
/// no solid (a ground, a backdrop) has its neighbours too: most hits are on
/// those, and most have none.
#[derive(Debug, Clone, Default)]
pub(crate) struct Neighbours {
    pub(crate) tol: f64,
    pub(crate) of: Vec<Vec<Zone>>,
    /// Per mesh geometry with neighbours, per triangle: the box holding the
    /// parts of that triangle a neighbour's surface may come within `tol`
    /// of ([`Box32::EMPTY`] when none), padded as a [`Zone`] is. (`None`:
    /// not known per primitive, as for analytic shapes.)
    pub(crate) near_prims: Vec<Option<Vec<Box32>>>,
}

/// An axis-aligned box in f32 (bounds rounded outward by whoever makes it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Box32 {
    pub(crate) lo: [f32; 3],
    pub(crate) hi: [f32; 3],
}

impl Box32 {
    /// The box that holds nothing.
    pub(crate) const EMPTY: Box32 = Box32 {
        lo: [f32::INFINITY; 3],
        hi: [f32::NEG_INFINITY; 3],
    };

    /// The box from `lo` to `hi` (f64) widened by `pad` and by a millionth
    /// of each coordinate's size, then rounded outward to f32: a point
    /// within `pad` of the f64 box, computed in f32, lies in it.
    pub(crate) fn padded(lo: glam::DVec3, hi: glam::DVec3, pad: f64) -> Box32 {
        Box32 {
            lo: (lo - pad - 1e-6 * (1.0 + lo.abs())).to_array().map(|v| v as f32),
            hi: (hi + pad + 1e-6 * (1.0 + hi.abs())).to_array().map(|v| v as f32),
        }
    }

    /// Does the box hold `p`?
    #[inline]
    pub(crate) fn holds(&self, p: [f32; 3]) -> bool {
        p[0] >= self.lo[0]
            && p[0] <= self.hi[0]
            && p[1] >= self.lo[1]
            && p[1] <= self.hi[1]
            && p[2] >= self.lo[2]
            && p[2] <= self.hi[2]
    }
}

/// Where on a geometry's surface the surface of `solid` may come within the
/// neighbour table's tolerance: a box, padded by that tolerance again (for
/// the rounding of a hit point computed in f32) and rounded outward to f32.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Zone {
    pub(crate) solid: u32,
    pub(crate) bx: Box32,
}

impl Zone {
    /// Does the box hold `p`?
    #[inline]
    pub(crate) fn holds(&self, p: [f32; 3]) -> bool {
        self.bx.holds(p)
    }
}

/// Point-in-solid classification of each solid (independent of Embree).
#[derive(Debug, Clone)]
pub(crate) enum Containment {
    Mesh(Arc<crate::scene::shapes::ContainsGrid>),
    Analytic(Analytic),
}

impl RenderScene {
    /// Is `p` inside solid `s` (point-in-solid, independent of Embree)?
    pub fn solid_contains(&self, s: u32, p: DVec3) -> bool {
        match &self.containment[s as usize] {
            Containment::Mesh(m) => m.contains(p),
            Containment::Analytic(a) => a.contains(p).unwrap_or(false),
        }
    }

    /// Might a surface of solid `s` pass within `tol` of `p`? Exact for
    /// spheres, closed cylinders, tubes and closed meshes (point–triangle
    /// distance on the triangles of `p`'s point-in-solid cells); `true`
    /// (unknown) for the rest.
    pub(crate) fn surface_may_be_near(&self, s: u32, p: DVec3, tol: f64) -> bool {
        match &self.containment[s as usize] {
            Containment::Analytic(a) => a.surface_near(p, tol).unwrap_or(true),
            Containment::Mesh(m) => m.surface_near(p, tol),
        }
    }

    /// Solids containing `p` (independent point-in-solid tests: for a mesh
    /// the parity test itself, not the cell cache the tracer reads, so that
    /// the audit and the tests that judge the tracer by it do not share it).
    pub fn solids_containing(&self, p: DVec3) -> Vec<u32> {
        self.containment
            .iter()
            .enumerate()
            .filter(|(_, c)| match c {
                Containment::Mesh(m) => m.parity_contains(p),
                Containment::Analytic(a) => a.contains(p).unwrap_or(false),
            })
            .map(|(i, _)| i as u32)
            .collect()
    }
}

impl RenderScene {
    /// Change the declared film resolution (the camera keeps its vertical
    /// field of view, or an orthographic view its height). Only the warp renderer uses this; path-traced renders
    /// leave the scene alone and take a `render::RenderSettings`.
    ///
    /// # Errors
    /// A zero or too large resolution.
    pub fn set_resolution(&mut self, width: u32, height: u32) -> Result<()> {
        if width == 0 || height == 0 || (width as u64) * (height as u64) > MAX_PIXELS {
            return Err(Error::Invalid(format!(
                "resolution {width}x{height} is out of range"
            )));
        }
        self.camera = self.camera.with_resolution(width, height);
        self.width = width;
        self.height = height;
        Ok(())
    }
}

/// Geometry at a hit, in world space.
#[derive(Debug, Clone, Copy)]
pub struct SurfacePoint {
    /// The point on the surface (reconstructed, not org + t·dir).
    pub p: V3,
    /// Unit geometric normal with the shape's convention (see `scene::shapes`).
    pub ng: V3,
    /// Unit shading normal on the same side as `ng`.
    pub ns: V3,
    /// Texture coordinates in [0, 1]² (zero unless a texture needs them).
    pub uv: [f32; 2],
}

/// A light sample seen from `p`: direction, distance, radiance and solid-angle pdf
/// (0 for delta lights), including the 1/num_lights choice.
pub struct LightSample {
    /// Unit direction from the point to the light.
    pub wi: V3,
    /// Distance to the light sample (infinite for a directional light).
    pub dist: f32,
    /// Radiance (or, for delta lights, intensity over distance squared) arriving, times the number of lights.
    pub li: V3,
    /// Solid-angle density of the sample including the 1/num_lights choice (1 for delta lights).
    pub pdf: f32,
    /// A point or directional light (no MIS).
    pub delta: bool,
}

impl LightSample {
    /// Is it a sample of the environment (a light at infinity that is not a
    /// delta: the sun's disk or a map)?
    #[inline]
    pub fn is_environment(&self) -> bool {
        self.dist == f32::INFINITY && !self.delta
    }
}

impl RenderScene {
    /// Hit point and normals for `hit` along `ray` (unit direction).
    ///
    /// The point is reconstructed on the surface rather than taken as org + t·dir
    /// (pbrt's approach): from the barycentrics in f64 for triangles, by exact
    /// projection for analytic shapes. Its error is then a few ulps of its own
    /// coordinates, whatever the ray's length, which bounds `offset_origin`.
    /// (Forced inline: once per hit, into the lane loop.)
    #[inline(always)]
    pub fn surface_point(&self, ray: &Ray, hit: &Hit) -> SurfacePoint {
        let scene = self;
        let rec = &scene.geoms[hit.geom_id as usize];
        match &rec.shape {
            Shape::Mesh(m) => {
                let p = m.point(hit.prim_id, hit.u, hit.v);
                let ng = super::shapes::normalize_or(hit.ng, V3::Y);
                // Texture coordinates only where a texture reads them (the
                // glass meshes' hits never do).
                let ns = m.shading_normal(hit.prim_id, hit.u, hit.v);
                let uv = if rec.needs_uv() {
                    m.shading(hit.prim_id, hit.u, hit.v).1
                } else {
                    [0.0, 0.0]
                };
                let ns = match ns {
                    Some(n) if n.dot(ng) > 0.0 => n,
                    Some(n) => -n,
                    None => ng,
                };
                SurfacePoint { p, ng, ns, uv }
            }
            Shape::Analytic(a) => {
                let p = ray.org + ray.dir * hit.t;
                let pd = a.project(hit.prim_id, p.as_dvec3());
                let n = a.normal(hit.prim_id, pd);
                analytic_point(rec, a, pd, pd.as_vec3a(), n.as_vec3a())
            }
        }
    }

    /// [`Self::surface_point`] of `hit` on an analytic shape whose point
    /// `pd` (f64; `p` in f32) and unit geometric normal `ng` are known
    /// ([`AnalyticSet::surface_points`](super::shapes::AnalyticSet::surface_points));
    /// `None` for a mesh hit.
    #[inline]
    pub fn analytic_surface_point(&self, hit: &Hit, pd: DVec3, p: V3, ng: V3) -> Option<SurfacePoint> {
        let rec = &self.geoms[hit.geom_id as usize];
        match &rec.shape {
            Shape::Analytic(a) => Some(analytic_point(rec, a, pd, p, ng)),
            Shape::Mesh(_) => None,
        }
    }
}

/// The surface point on `rec`'s analytic shape `a` at `pd` (`p` in f32) with
/// unit geometric normal `ng`, texture coordinates only where read.
#[inline(always)]
fn analytic_point(rec: &GeomRecord, a: &Analytic, pd: DVec3, p: V3, ng: V3) -> SurfacePoint {
    SurfacePoint {
        p,
        ng,
        ns: ng,
        uv: if rec.needs_uv() { a.uv(pd) } else { [0.0, 0.0] },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_boxes_report_every_box_that_meets_the_cube_and_nothing_far() {
        let mut rng = crate::sampling::Rng::new(3);
        let mut u = |a: f64, b: f64| a + (b - a) * rng.uniform_f64();
        let boxes: Vec<(DVec3, DVec3)> = (0..21)
            .map(|_| {
                let c = DVec3::new(u(-5.0, 5.0), u(-5.0, 5.0), u(-5.0, 5.0));
                let h = DVec3::new(u(0.0, 2.0), u(0.0, 2.0), u(0.0, 2.0));
                (c - h, c + h)
            })
            .collect();
        let sb = SolidBoxes::new(boxes.iter().copied());
        let (mut met, mut near) = (0, 0);
        for _ in 0..20000 {
            let p = DVec3::new(u(-8.0, 8.0), u(-8.0, 8.0), u(-8.0, 8.0));
            let tol = u(0.0, 1e-3);
            let mut got = Vec::new();
            sb.meeting(p, tol, |i| {
                got.push(i);
                true
            });
            for (i, (a, b)) in boxes.iter().enumerate() {
                let meets = (p + tol).cmpge(*a).all() && (p - tol).cmple(*b).all();
                // Within a millionth (the padding) either answer is allowed.
                let gap = (*a - p - tol).max(p - tol - *b).max_element();
                if meets {
                    met += 1;
                    assert!(got.contains(&(i as u32)), "box {i} missed at {p} tol {tol}");
                } else if gap > 1e-5 {
                    assert!(!got.contains(&(i as u32)), "box {i} far ({gap}) but reported");
                } else {
                    near += 1;
                }
            }
            assert!(got.windows(2).all(|w| w[0] < w[1]), "in order");
        }
        assert!(met > 500, "the cubes meet boxes: {met}");
        assert!(near < met, "borderline cases are rare: {near}");
        // Stops at the first `false`.
        let mut calls = 0;
        sb.meeting(DVec3::ZERO, 100.0, |_| {
            calls += 1;
            false
        });
        assert_eq!(calls, 1);
    }
}
