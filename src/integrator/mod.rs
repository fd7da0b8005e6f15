//! Integrators: an unbiased path tracer (next-event estimation with MIS for
//! area lights, Russian roulette, smooth dielectrics with exact Fresnel and
//! TIR, nested priorities) and a Whitted tracer for quick previews.
//!
//! Depth follows Mitsuba: `max_depth` counts path segments including the
//! camera ray (1 = directly visible emitters only, 2 = direct lighting).
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList, NestedStrategy};
use crate::embree::RayPacket;
use crate::error::Result;
use crate::optics;
use crate::ray::{front_facing, offset_origin, offset_size, spawn_transmitted, Ray};
use crate::sampling::{cosine_hemisphere, power_heuristic, Rng};
use crate::scene::IntegratorKind;
use crate::scene::{Material, RenderScene, SurfacePoint};
use glam::{DVec3, Vec3A as V3};
use std::f32::consts::FRAC_1_PI;

mod observer;
pub use observer::{RayObserver, RayQuery, RayRecorder};

/// What every path of a render shares: the scene, how nested dielectrics
/// are resolved (a render setting, not part of the scene), and who is told
/// of the queries.
#[derive(Clone, Copy)]
pub struct Tracer<'a> {
    /// The scene.
    pub scene: &'a RenderScene,
    /// How false hits are found and skipped.
    pub strategy: NestedStrategy,
    /// Told of every nearest-hit query and shadow ray (none: no cost but a branch).
    pub observer: Option<&'a dyn RayObserver>,
}

impl<'a> Tracer<'a> {
    /// A tracer of `scene` with the default strategy (the filter) and no observer.
    pub fn new(scene: &'a RenderScene) -> Self {
        Tracer {
            scene,
            strategy: NestedStrategy::Filter,
            observer: None,
        }
    }

    /// This tracer with another nested-dielectric strategy.
    pub fn with_strategy(self, strategy: NestedStrategy) -> Self {
        Tracer { strategy, ..self }
    }

    /// Tell the observer, if any, of the query `q` makes.
    #[inline(always)]
    fn observe(self, q: impl FnOnce() -> RayQuery) {
        if let Some(o) = self.observer {
            o.query(q());
        }
    }

    /// The boundary event at a true hit (`dielectric::boundary` with this
    /// tracer's scene and strategy).
    fn boundary(
        self,
        material: &Material,
        front: bool,
        coincident: &dielectric::Coincident,
        list: &mut InteriorList,
    ) -> Option<dielectric::Boundary> {
        let nesting = dielectric::Nesting::of(self.scene);
        dielectric::boundary(nesting, self.strategy, material, front, coincident, list)
    }

    /// The list of `child`, spawned at a true hit with `coincident`, settled
    /// where another solid's surface passes near the hit
    /// (`dielectric::settle_child`).
    #[inline]
    fn settle(
        self,
        coincident: &dielectric::Coincident,
        child: &Ray,
        list: &mut InteriorList,
        st: &mut Counters,
    ) {
        dielectric::settle_child(self.scene, coincident, child, list, st);
    }

    /// Absorption of the medium a ray inside `list` travels through.
    fn medium(self, list: &InteriorList) -> Option<V3> {
        dielectric::medium_of(dielectric::Nesting::of(self.scene), list)
    }
}

/// The mirror direction of unit-ish `d` about the shading normal `n`; when
/// the shading normal pushes it below the surface (`incident_side` is the
/// geometric normal on the side `d` came from), about the geometric normal.
#[inline]
fn reflected(d: DVec3, n: DVec3, incident_side: V3) -> V3 {
    let wi = optics::reflect(d, n).normalize().as_vec3a();
    if wi.dot(incident_side) > 0.0 {
        wi
    } else {
        optics::reflect(d, incident_side.as_dvec3())
            .normalize()
            .as_vec3a()
    }
}

/// The refracted direction of `d` through the shading normal `n` from index
/// `n1` to `n2` (`None`: total internal reflection); when the shading
/// normal leaves it on the incident side, through the geometric normal.
#[inline]
fn refracted(d: DVec3, n: DVec3, incident_side: V3, n1: f32, n2: f32) -> Option<V3> {
    let t = optics::refract(d, n, n1 as f64, n2 as f64)?
        .normalize()
        .as_vec3a();
    if t.dot(incident_side) < 0.0 {
        return Some(t);
    }
    Some(
        optics::refract(d, incident_side.as_dvec3(), n1 as f64, n2 as f64)
            .unwrap_or(d)
            .normalize()
            .as_vec3a(),
    )
}

/// The shadow ray from `from` (offset to the side `side`) along `wi` for
/// `dist`, counted and observed; `None` when the connection is too short to
/// hold anything (then it is unoccluded without a query).
#[inline]
fn shadow_ray(tr: Tracer<'_>, from: V3, side: V3, wi: V3, dist: f32, st: &mut Counters) -> Option<Ray> {
    st.shadow_rays += 1;
    let o = offset_origin(from, side);
    let mut r = Ray::new(o, wi);
    if dist.is_finite() {
        r.tfar = dist * (1.0 - 1e-4) - 2.0 * offset_size(from);
        if r.tfar <= 0.0 {
            return None;
        }
    }
    tr.observe(|| RayQuery::Shadow(r));
    Some(r)
}

fn unoccluded(tr: Tracer<'_>, from: V3, side: V3, wi: V3, dist: f32, st: &mut Counters) -> bool {
    shadow_ray(tr, from, side, wi, dist, st).is_none_or(|r| !tr.scene.embree.occluded(&r))
}

/// A light sample from the diffuse point `p` before its shadow ray: `None`
/// unless the light is above both normals (`n` shading, `ng` geometric, both
/// on the light's side; a shading normal can lean past the surface) and its
/// straight connection avoids the gradient-index medium. With its cosine at `p`.
#[inline(always)]
fn light_candidate(
    scene: &RenderScene,
    p: V3,
    n: V3,
    ng: V3,
    rng: &mut Rng,
) -> Option<(crate::scene::LightSample, f32)> {
    let ls = scene.sample_light(p, rng)?;
    let cos = n.dot(ls.wi);
    (cos > 0.0 && ng.dot(ls.wi) > 0.0 && !meets_medium(scene, p, ls.wi, ls.dist)).then_some((ls, cos))
}

/// A light sample seen from the diffuse point `p` ([`light_candidate`]) and
/// not occluded. The one light-sampling test of both integrators: Whitted's
/// copy had lost the `ng` check.
fn light_seen(
    tr: Tracer<'_>,
    p: V3,
    n: V3,
    ng: V3,
    rng: &mut Rng,
    st: &mut Counters,
) -> Option<(crate::scene::LightSample, f32)> {
    light_candidate(tr.scene, p, n, ng, rng).filter(|(ls, _)| unoccluded(tr, p, ng, ls.wi, ls.dist, st))
}

/// One path segment: the first true hit (if any) and the straight chord it
/// lies on, the direction the ray arrives with and the distance travelled.
/// The solid surfaces coincident with the hit travel beside it (a
/// [`dielectric::Coincident`] from [`cast`], or [`NO_COINCIDENT`] for a
/// plain query): a segment is built per path and per bounce, and carrying
/// the 112-byte record in it would cost a copy of it per segment.
struct Segment {
    /// The first true hit.
    hit: Option<crate::ray::Hit>,
    /// The straight ray (a chord inside a medium) the hit was found on.
    chord: Ray,
    /// Unit direction at the end (the tangent of the curved path at the hit,
    /// or the direction the ray leaves to infinity with).
    dir: V3,
    /// Path length to the hit (sum of chords).
    length: f32,
    /// The curved-ray integrator failed (e.g. the paper's Euler at a turning
    /// point): the path ends black.
    failed: bool,
    /// The ray reached the medium's bounds before its hit (or escape), so it
    /// may have curved: no straight next-event connection can produce it.
    entered_medium: bool,
}

/// The coincident surfaces of a plain query's hit (none).
static NO_COINCIDENT: dielectric::Coincident = dielectric::Coincident::NONE;

impl Segment {
    /// The curved-ray integrator failed after `travelled` along the path
    /// that started as `ray`: no hit, the path ends black.
    fn failed(ray: &Ray, travelled: f64, entered_medium: bool) -> Segment {
        Segment {
            hit: None,
            chord: *ray,
            dir: ray.dir,
            length: travelled as f32,
            failed: true,
            entered_medium,
        }
    }

    /// A straight segment (no medium) along `ray` ending at `hit`.
    #[inline]
    fn straight(ray: &Ray, hit: Option<crate::ray::Hit>) -> Segment {
        Segment {
            // From where the ray starts (tnear: a ray continued on its line).
            length: hit.map(|h| h.t - ray.tnear).unwrap_or(f32::INFINITY),
            hit,
            chord: *ray,
            dir: ray.dir,
            failed: false,
            entered_medium: false,
        }
    }
}

/// Can [`path_lanes`] trace the paths of a render of `tr`? The path tracer
/// without a gradient-index medium (whose curved segments are chains of
/// queries). Segments that a plain query answers go to Embree in packets
/// (every segment without overlapping solids; outside every solid with them),
/// the others through [`dielectric::trace`] one by one.
pub fn path_lanes_apply(tr: Tracer<'_>) -> bool {
    tr.scene.integrator == IntegratorKind::Path && tr.scene.medium.is_none()
}

/// Chords one curved segment may take before the path is ended (and counted
/// as an integrator failure).
pub const MAX_CHORDS_PER_SEGMENT: u32 = 200_000;

/// Does the straight segment from `p` along unit `wi` for `dist` meet the
/// gradient-index medium's bounds? Next-event estimation is only used for
/// connections that do not (light travels straight outside the bounds); a
/// connection that does would need the curved path between two points.
fn meets_medium(scene: &RenderScene, p: V3, wi: V3, dist: f32) -> bool {
    scene.medium.as_ref().is_some_and(|m| {
        m.bounds()
            .clip(p.as_dvec3(), wi.as_dvec3())
            .is_some_and(|(t0, t1)| t1 > 0.0 && t0 < dist as f64)
    })
}

/// Cast `ray`, through the gradient-index medium as chords when the scene has
/// one (straight outside its bounds at no extra cost), else straight.
fn cast(
    tr: Tracer<'_>,
    ray: &Ray,
    list: &mut InteriorList,
    st: &mut Counters,
) -> Result<(Segment, dielectric::Coincident)> {
    let scene = tr.scene;
    let Some(med) = &scene.medium else {
        tr.observe(|| RayQuery::Nearest(*ray));
        return Ok(match dielectric::trace(scene, tr.strategy, ray, list, st)? {
            Some(th) => (Segment::straight(ray, Some(th.hit)), th.coincident),
            None => (Segment::straight(ray, None), dielectric::Coincident::NONE),
        });
    };
    let mut curved = med.start_ray(ray.org.as_dvec3(), ray.dir.as_dvec3());
    let out = cast_curved(tr, med, &mut curved, ray, list, st);
    st.field_evals += curved.evaluations();
    if curved.entered() {
        st.medium_segments += 1;
    }
    out
}

/// [`cast`] through the medium: the chords of `curved` until one hits or
/// escapes.
fn cast_curved(
    tr: Tracer<'_>,
    med: &crate::media::Medium,
    curved: &mut crate::media::CurvedRay,
    ray: &Ray,
    list: &mut InteriorList,
    st: &mut Counters,
) -> Result<(Segment, dielectric::Coincident)> {
    let scene = tr.scene;
    let mut travelled = 0.0f64;
    // The first chord is inside the medium when the ray starts in its bounds;
    // every later chord is (the first one ends at the entry).
    let starts_inside = med
        .bounds()
        .clip(ray.org.as_dvec3(), ray.dir.as_dvec3())
        .is_some_and(|(t0, t1)| t0 <= 0.0 && t1 > med.tolerance());
    // A budget of chords per segment (the load-time checks bound the chord
    // count across the box; this also covers rays trapped in a duct).
    for k in 0..MAX_CHORDS_PER_SEGMENT {
        let entered_medium = k > 0 || starts_inside;
        let chord = curved.next_chord(med);
        travelled += chord.skipped;
        if chord.length == 0.0 && curved.failure().is_none() {
            // A zero-length chord is the ray leaving the bounds exactly where it
            // stands (at the box face): not a failure, nothing to cast.
            continue;
        }
        if curved.failure().is_some() || chord.length.is_nan() || chord.length < 0.0 {
            return Ok((
                Segment::failed(ray, travelled, entered_medium),
                dielectric::Coincident::NONE,
            ));
        }
        let mut r = Ray::new(chord.origin.as_vec3a(), chord.dir.as_vec3a());
        if chord.length.is_finite() {
            r.tfar = chord.length as f32;
        }
        st.chords += 1;
        // A chord that meets no geometry's box needs no query.
        let th = if med.chord_may_hit(&chord) {
            tr.observe(|| RayQuery::Nearest(r));
            dielectric::trace(scene, tr.strategy, &r, list, st)?
        } else {
            None
        };
        if let Some(th) = th {
            let p = r.org + r.dir * th.hit.t;
            let (_, tangent) = curved.refine_hit(
                med,
                &chord,
                th.hit.t as f64,
                p.as_dvec3(),
                (th.hit.ng.normalize_or(V3::Y)).as_dvec3(),
            );
            return Ok((
                Segment {
                    hit: Some(th.hit),
                    chord: r,
                    dir: (tangent.normalize()).as_vec3a(),
                    length: (travelled + th.hit.t as f64) as f32,
                    failed: false,
                    entered_medium,
                },
                th.coincident,
            ));
        }
        if !chord.length.is_finite() {
            return Ok((
                Segment {
                    hit: None,
                    chord: r,
                    dir: r.dir,
                    length: f32::INFINITY,
                    failed: false,
                    entered_medium,
                },
                dielectric::Coincident::NONE,
            ));
        }
        travelled += chord.length;
    }
    Ok((
        Segment::failed(ray, travelled, true),
        dielectric::Coincident::NONE,
    ))
}

/// Radiance along a camera ray (unit `dir`), with `list` the interior list at the camera.
pub fn radiance(
    tr: Tracer<'_>,
    org: V3,
    dir: V3,
    list: InteriorList,
    rng: &mut Rng,
    st: &mut Counters,
) -> Result<V3> {
    match tr.scene.integrator {
        IntegratorKind::Path => path(tr, org, dir, list, rng, st),
        IntegratorKind::Whitted => whitted(tr, org, dir, list, rng, st, 1),
    }
}

/// A path tracer's path between two segments: the loop state of [`path`]
/// and of [`path_lanes`], which both advance it with [`PathState::advance`].
struct PathState {
    l: V3,
    beta: V3,
    eta_scale: f32,
    /// The next segment's ray.
    ray: Ray,
    specular: bool,
    prev_p: V3,
    prev_pdf: f32,
    /// Segment index of `ray`.
    depth: u32,
    list: InteriorList,
    /// No diffuse bounce yet: the camera ray and its mirror and dielectric
    /// continuations, which a pixel's samples follow side by side nearly in
    /// parallel (Embree's coherent packets, `path_lanes`).
    only_specular: bool,
}

/// A next-event connection waiting for its shadow ray: `contrib` is added to
/// the path's radiance if `ray` is unoccluded.
struct PendingShadow {
    ray: Ray,
    contrib: V3,
}

impl PathState {
    fn new(org: V3, dir: V3, list: InteriorList) -> Self {
        PathState {
            l: V3::ZERO,
            beta: V3::ONE,
            eta_scale: 1.0,
            ray: Ray::new(org, dir),
            specular: true,
            prev_p: org,
            prev_pdf: 0.0,
            depth: 1,
            list,
            only_specular: true,
        }
    }

    /// Shade the segment `seg` just cast along `self.ray` (`sigma`: the
    /// medium's absorption before the cast): emission, the next-event
    /// connection (returned as a shadow ray to resolve before the next
    /// segment, in order), the next ray and Russian roulette. `false`: the
    /// path has ended. `surface`: the hit's surface point when the caller
    /// has already reconstructed it (`path_lanes`), else it is made here.
    /// (Forced inline: one call per segment, in the lane loop and in `path`.)
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn advance(
        &mut self,
        tr: Tracer<'_>,
        sigma: Option<V3>,
        seg: &Segment,
        coincident: &dielectric::Coincident,
        surface: Option<&SurfacePoint>,
        rng: &mut Rng,
        st: &mut Counters,
    ) -> (Option<PendingShadow>, bool) {
        let scene = tr.scene;
        let mut shadow = None;
        if seg.failed {
            st.grin_failures += 1;
            return (None, false);
        }
        let Some(hit) = &seg.hit else {
            if sigma.is_none() {
                // The sun's disk is also sampled by NEE (`light_candidate`),
                // which makes only straight paths from a diffuse vertex.
                let nee_pdf = (!self.specular && !seg.entered_medium).then_some(self.prev_pdf);
                self.l += self.beta * scene.escaped_radiance(seg.dir, nee_pdf);
            }
            return (None, false);
        };
        if let Some(s) = sigma {
            self.beta *= (-s * seg.length).exp();
        }
        let sp = match surface {
            Some(sp) => *sp,
            None => scene.surface_point(&seg.chord, hit),
        };
        // Shade with the direction the (possibly curved) ray arrives with.
        self.ray.dir = seg.dir;
        let rec = &scene.geoms[hit.geom_id as usize];
        let front = front_facing(sp.ng, self.ray.dir);

        if let Some(em) = &rec.emission {
            if front {
                let le = em.eval(sp.p, sp.uv);
                let w = match rec.light {
                    // A path through the medium cannot come from NEE (which
                    // only connects straight segments that avoid it): weight 1.
                    Some(li) if !self.specular && !seg.entered_medium => {
                        let lp = scene.light_pdf(li, self.prev_p, sp.p, self.ray.dir);
                        power_heuristic(self.prev_pdf, lp)
                    }
                    _ => 1.0,
                };
                self.l += self.beta * le * w;
            }
        }
        if self.depth >= scene.max_depth {
            return (None, false);
        }
        match &rec.material {
            Material::Black => return (None, false),
            Material::Diffuse {
                reflectance,
                two_sided,
            } => {
                if !front && !two_sided {
                    return (None, false); // one-sided: black from behind
                }
                let n = if front { sp.ns } else { -sp.ns };
                let ng = if front { sp.ng } else { -sp.ng };
                let albedo = reflectance.eval(sp.p, sp.uv);
                // Next-event estimation.
                if let Some((ls, cos)) = light_candidate(scene, sp.p, n, ng, rng) {
                    let f = albedo * FRAC_1_PI;
                    let w = if ls.delta {
                        1.0
                    } else {
                        power_heuristic(ls.pdf, cos * FRAC_1_PI)
                    };
                    let contrib = self.beta * f * ls.li * (cos * w / ls.pdf);
                    match shadow_ray(tr, sp.p, ng, ls.wi, ls.dist, st) {
                        None => self.l += contrib,
                        Some(ray) => shadow = Some(PendingShadow { ray, contrib }),
                    }
                }
                // A black reflectance (cylinder_refraction's emitting plane)
                // ends the path below (zero throughput): its direction is
                // not sampled. Only where nothing else reads it: a finite
                // throughput (so that it becomes exactly 0) and no solids
                // for the child ray to settle (which would count them).
                if albedo == V3::ZERO && self.beta.is_finite() && coincident.near.is_empty() {
                    return (shadow, false);
                }
                let wi = cosine_hemisphere(n, rng.uniform(), rng.uniform());
                if ng.dot(wi) <= 0.0 {
                    return (shadow, false);
                }
                self.beta *= albedo;
                self.prev_pdf = n.dot(wi) * FRAC_1_PI;
                self.specular = false;
                self.only_specular = false;
                self.prev_p = sp.p;
                self.ray = Ray::new(offset_origin(sp.p, ng), wi);
                tr.settle(coincident, &self.ray, &mut self.list, st);
            }
            Material::Mirror { reflectance } => {
                let n = if front { sp.ns } else { -sp.ns };
                let wi = (optics::reflect(self.ray.dir.as_dvec3(), n.as_dvec3()).normalize()).as_vec3a();
                self.beta *= *reflectance;
                self.specular = true;
                self.prev_p = sp.p;
                let side = if front { sp.ng } else { -sp.ng };
                self.ray = Ray::new(offset_origin(sp.p, side), wi);
                tr.settle(coincident, &self.ray, &mut self.list, st);
            }
            m @ (Material::Interface { .. } | Material::Solid(_)) => {
                let Some(c) = tr.boundary(m, front, coincident, &mut self.list) else {
                    return (None, false);
                };
                let d = self.ray.dir.as_dvec3();
                let n = sp.ns.as_dvec3();
                let fr = optics::fresnel_dielectric(d.dot(n).abs(), c.n1 as f64, c.n2 as f64);
                // The geometric side the incident ray came from.
                let incident_side = if front { sp.ng } else { -sp.ng };
                let refr = refracted(d, n, incident_side, c.n1, c.n2);
                if refr.is_none() {
                    st.tir += 1;
                }
                let choose_reflect = refr.is_none() || (rng.uniform() as f64) < fr;
                if choose_reflect {
                    self.ray = Ray::new(offset_origin(sp.p, incident_side), reflected(d, n, incident_side));
                    tr.settle(coincident, &self.ray, &mut self.list, st);
                } else {
                    let wi = refr.expect("checked above");
                    let k = c.n1 / c.n2;
                    self.beta *= k * k;
                    self.eta_scale /= k * k;
                    // Straight segments keep their line through index-matched boundaries.
                    let line = (c.n1 == c.n2 && !seg.entered_medium && dielectric::keeps_line(scene))
                        .then_some((&seg.chord, hit.t));
                    let next = spawn_transmitted(sp.p, -incident_side, self.ray.dir, wi, (c.n1, c.n2), line);
                    c.transmit(&mut self.list);
                    tr.settle(coincident, &next, &mut self.list, st);
                    self.ray = next;
                }
                self.specular = true;
                self.prev_p = sp.p;
            }
        }
        self.depth += 1;
        // A path with zero throughput (a black reflectance: cylinder_refraction's
        // emitting plane) can add nothing more, and would still cost rays.
        // Same image: every later term would be multiplied by 0.
        if self.beta.max_element() <= 0.0 {
            return (shadow, false);
        }
        if self.depth > scene.rr_depth {
            let q = (self.beta.max_element() * self.eta_scale).min(0.95);
            if rng.uniform() >= q {
                return (shadow, false);
            }
            self.beta /= q;
        }
        (shadow, true)
    }

    /// The path's radiance (0, counted, when it is not finite).
    fn radiance(&self, st: &mut Counters) -> V3 {
        if self.l.is_finite() {
            self.l
        } else {
            st.nan += 1;
            V3::ZERO
        }
    }
}

fn path(
    tr: Tracer<'_>,
    org: V3,
    dir: V3,
    list: InteriorList,
    rng: &mut Rng,
    st: &mut Counters,
) -> Result<V3> {
    let mut p = PathState::new(org, dir, list);
    loop {
        st.segments += 1;
        let sigma = tr.medium(&p.list);
        let (seg, coincident) = cast(tr, &p.ray, &mut p.list, st)?;
        let (shadow, go) = p.advance(tr, sigma, &seg, &coincident, None, rng, st);
        if let Some(sh) = shadow {
            if !tr.scene.embree.occluded(&sh.ray) {
                p.l += sh.contrib;
            }
        }
        if !go {
            break;
        }
    }
    Ok(p.radiance(st))
}

/// The segment of `ray` whose plain query answered `hit`, counted and
/// observed as `cast` would have.
#[inline]
fn known_segment(tr: Tracer<'_>, ray: &Ray, hit: Option<crate::ray::Hit>, st: &mut Counters) -> Segment {
    tr.observe(|| RayQuery::Nearest(*ray));
    st.queries += 1;
    Segment::straight(ray, hit)
}

/// The two Embree packets [`path_lanes`] fills (nearest-hit segments and
/// shadow rays), made once per thread's batch of calls: zeroing a packet
/// per call shows in a render's profile. With how full they went out.
#[derive(Default)]
pub struct LanePackets<P> {
    near: P,
    shadow: P,
    occupancy: Counters,
}

impl<P> LanePackets<P> {
    /// The packets' slots and the rays they carried since the last call
    /// (the `packet_*` fields of [`Counters`]; the others are zero).
    pub fn take_occupancy(&mut self) -> Counters {
        std::mem::take(&mut self.occupancy)
    }
}

/// Up to `N` paths of the path tracer traced side by side (renders use 8):
/// the segments of the live paths that a plain query answers
/// ([`dielectric::plain_query_suffices`]) go to Embree as one packet of `N`
/// rays (a coherent one while no path has met a diffuse surface), the others through
/// [`dielectric::trace`]; every batch of shadow rays is one packet. Each path
/// gives the same radiance, bit for bit, as [`radiance`] with its own `rng`:
/// the shading is `PathState::advance` in both, and each path's random
/// numbers are its own. Only where [`path_lanes_apply`] holds; `cams`, `rngs`
/// and `sts` have one entry per path (at most `N`, the width of the packet
/// type `P`).
///
/// # Errors
/// As [`radiance`].
pub fn path_lanes<const N: usize, P: RayPacket<N>>(
    tr: Tracer<'_>,
    cams: &[(V3, V3)],
    list: &InteriorList,
    rngs: &mut [Rng],
    sts: &mut [Counters],
    packets: &mut LanePackets<P>,
) -> Result<[V3; N]> {
    let n = cams.len().min(N);
    debug_assert!(path_lanes_apply(tr) && rngs.len() >= n && sts.len() >= n);
    // Lane `i < n` indexes these without a bounds check.
    let (rngs, sts) = (&mut rngs[..n], &mut sts[..n]);
    let scene = tr.scene;
    let mut paths: [Option<PathState>; N] = std::array::from_fn(|_| None);
    for (slot, &(o, d)) in paths.iter_mut().zip(cams) {
        *slot = Some(PathState::new(o, d, list.clone()));
    }
    let mut out = [V3::ZERO; N];
    let LanePackets {
        near,
        shadow,
        occupancy,
    } = packets;
    while paths.iter().any(Option::is_some) {
        near.clear();
        let mut plain: [Option<bool>; N] = [None; N];
        for (i, p) in paths.iter().enumerate() {
            if let Some(p) = p {
                plain[i] = dielectric::plain_query_suffices(scene, tr.strategy, &p.list);
                if plain[i].is_some() {
                    near.set_ray(i, &p.ray);
                }
            }
        }
        // Embree's coherent mode while every live path has only met smooth
        // surfaces (a pixel's camera rays and their refractions stay nearly
        // parallel), not only for the camera rays: it paid on refractive
        // scenes. Shadow rays go without: they are slower in it (docs/peers.md).
        let coherent = paths.iter().flatten().all(|p| p.only_specular);
        // (A packet without a lane is not sent: `RayPacket::intersect`.)
        let lanes = plain.iter().flatten().count() as u64;
        occupancy.packet_slots += if lanes > 0 { N as u64 } else { 0 };
        occupancy.packet_lanes += lanes;
        intersect_packet(scene, near, coherent);
        shadow.clear();
        // Which lanes the packet answered (the others are cast one by one
        // below), and the surface points of their hits, every lane's before
        // any lane is shaded: independent f64 square roots and divisions
        // (an analytic hit's projection and normal) the processor overlaps,
        // where each lane's shading waited on its own.
        let mut known = [false; N];
        let mut sps: [Option<SurfacePoint>; N] = [None; N];
        for i in 0..n {
            let Some(p) = &paths[i] else { continue };
            let Some(check) = plain[i] else { continue };
            let hit = near.hit(i);
            if check && !dielectric::plain_hit_is_true(scene, tr.strategy, &p.ray, hit.as_ref(), &p.list) {
                // A touch at a mesh edge or a leaked entry: the packet's
                // query was made (counted); `trace` redoes it and continues
                // past.
                sts[i].queries += 1;
                continue;
            }
            if let Some(h) = &hit {
                sps[i] = Some(scene.surface_point(&p.ray, h));
            }
            known[i] = true;
        }
        let mut pending: [Option<V3>; N] = [None; N];
        let mut ended = [false; N];
        for i in 0..n {
            let Some(p) = &mut paths[i] else { continue };
            let st = &mut sts[i];
            st.segments += 1;
            let sigma = tr.medium(&p.list);
            // The segment is built in place and shaded right here (a
            // segment moved out of a `match` was copied twice per lane).
            let (seg, cast_coincident, coincident);
            if known[i] {
                seg = known_segment(tr, &p.ray, near.hit(i), st);
                coincident = &NO_COINCIDENT;
            } else {
                (seg, cast_coincident) = cast(tr, &p.ray, &mut p.list, st)?;
                coincident = &cast_coincident;
            }
            let (sh, go) = p.advance(tr, sigma, &seg, coincident, sps[i].as_ref(), &mut rngs[i], st);
            if let Some(sh) = sh {
                shadow.set_ray(i, &sh.ray);
                pending[i] = Some(sh.contrib);
            }
            ended[i] = !go;
        }
        if pending.iter().any(Option::is_some) {
            occupancy.shadow_packet_slots += N as u64;
            occupancy.shadow_packet_lanes += pending.iter().flatten().count() as u64;
            occlude_packet(scene, shadow);
        }
        // In each path's order: its shadow ray before its next segment.
        for i in 0..n {
            let Some(p) = &mut paths[i] else { continue };
            if let Some(c) = pending[i] {
                if !shadow.occluded(i) {
                    p.l += c;
                }
            }
            if ended[i] {
                out[i] = p.radiance(&mut sts[i]);
                paths[i] = None;
            }
        }
    }
    Ok(out)
}

/// Nearest hits of the active lanes of `packet` in `scene`: Embree's, or
/// with an [`AnalyticSet`](crate::scene::shapes::AnalyticSet), Embree's
/// among the meshes completed by the set's.
#[inline]
fn intersect_packet<const N: usize, P: RayPacket<N>>(scene: &RenderScene, packet: &mut P, coherent: bool) {
    match &scene.analytic_set {
        Some(set) => {
            packet.intersect_meshes(&scene.embree, coherent);
            set.intersect(packet);
        }
        None => packet.intersect(&scene.embree, coherent),
    }
}

/// Occlusion of the active lanes of `packet` (shadow rays: not coherent),
/// as [`intersect_packet`] finds hits.
#[inline]
fn occlude_packet<const N: usize, P: RayPacket<N>>(scene: &RenderScene, packet: &mut P) {
    match &scene.analytic_set {
        Some(set) => {
            packet.occlude_meshes(&scene.embree, false);
            set.occlude(packet);
        }
        None => packet.occlude(&scene.embree, false),
    }
}

/// Whitted: direct light at diffuse surfaces (one sample per light), perfect
/// specular recursion for mirrors and both branches of dielectrics.
fn whitted(
    tr: Tracer<'_>,
    org: V3,
    dir: V3,
    mut list: InteriorList,
    rng: &mut Rng,
    st: &mut Counters,
    depth: u32,
) -> Result<V3> {
    let scene = tr.scene;
    st.segments += 1;
    let ray = Ray::new(org, dir);
    let sigma = tr.medium(&list);
    // The same (curved through a medium) cast as the path tracer.
    let (seg, coincident) = cast(tr, &ray, &mut list, st)?;
    if seg.failed {
        st.grin_failures += 1;
        return Ok(V3::ZERO);
    }
    let Some(hit) = seg.hit else {
        return Ok(if sigma.is_some() {
            V3::ZERO
        } else {
            scene.environment.eval(seg.dir)
        });
    };
    let att = sigma.map(|s| (-s * seg.length).exp()).unwrap_or(V3::ONE);
    let sp = scene.surface_point(&seg.chord, &hit);
    let dir = seg.dir;
    let rec = &scene.geoms[hit.geom_id as usize];
    let front = front_facing(sp.ng, dir);
    let mut l = V3::ZERO;
    if let (Some(em), true) = (&rec.emission, front) {
        l += em.eval(sp.p, sp.uv);
    }
    if depth >= scene.max_depth {
        return Ok(att * l);
    }
    match &rec.material {
        Material::Black => {}
        Material::Diffuse {
            reflectance,
            two_sided,
        } => {
            if front || *two_sided {
                let n = if front { sp.ns } else { -sp.ns };
                let ng = if front { sp.ng } else { -sp.ng };
                let albedo = reflectance.eval(sp.p, sp.uv);
                // One sample per light, the sun's disk among them.
                let lights = scene.nee_count();
                for _ in 0..lights {
                    if let Some((ls, cos)) = light_seen(tr, sp.p, n, ng, rng, st) {
                        l += albedo * FRAC_1_PI * ls.li * (cos / ls.pdf) / lights as f32;
                    }
                }
                // Ambient term from a constant environment (preview only).
                if let crate::scene::Environment::Constant(c) = scene.environment {
                    l += albedo * c;
                }
            }
        }
        Material::Mirror { reflectance } => {
            let n = if front { sp.ns } else { -sp.ns };
            let side = if front { sp.ng } else { -sp.ng };
            let wi = (optics::reflect(dir.as_dvec3(), n.as_dvec3()).normalize()).as_vec3a();
            let org = offset_origin(sp.p, side);
            tr.settle(&coincident, &Ray::new(org, wi), &mut list, st);
            l += *reflectance * whitted(tr, org, wi, list, rng, st, depth + 1)?;
        }
        m @ (Material::Interface { .. } | Material::Solid(_)) => {
            let Some(c) = tr.boundary(m, front, &coincident, &mut list) else {
                return Ok(att * l);
            };
            let d = dir.as_dvec3();
            let n = sp.ns.as_dvec3();
            let fr = optics::fresnel_dielectric(d.dot(n).abs(), c.n1 as f64, c.n2 as f64) as f32;
            let side = if front { sp.ng } else { -sp.ng };
            let wr = reflected(d, n, side);
            let org = offset_origin(sp.p, side);
            let mut rl = list.clone();
            tr.settle(&coincident, &Ray::new(org, wr), &mut rl, st);
            l += fr * whitted(tr, org, wr, rl, rng, st, depth + 1)?;
            if let Some(t) = refracted(d, n, side, c.n1, c.n2) {
                let k = c.n1 / c.n2;
                let (n1, n2) = (c.n1, c.n2);
                let mut nl = list;
                c.transmit(&mut nl);
                let next = spawn_transmitted(sp.p, -side, dir, t, (n1, n2), None);
                tr.settle(&coincident, &next, &mut nl, st);
                l += (1.0 - fr) * k * k * whitted(tr, next.org, next.dir, nl, rng, st, depth + 1)?;
            } else {
                st.tir += 1;
            }
        }
    }
    let out = att * l;
    if !out.is_finite() {
        st.nan += 1;
        return Ok(V3::ZERO);
    }
    Ok(out)
}

/// One surface event along a deterministic refraction-only path.
#[derive(Debug, Clone)]
pub struct PathEvent {
    /// Embree geometry id of the surface.
    pub geom: u32,
    /// The reconstructed hit point.
    pub point: V3,
    /// Distance from the previous event (or the start).
    pub t: f32,
    /// Index on the side the ray arrived from.
    pub n1: f32,
    /// Index on the far side.
    pub n2: f32,
    /// Interior list (sorted solid indices) of the ray leaving this event.
    pub list_after: Vec<u32>,
    /// Total internal reflection: the ray was reflected.
    pub tir: bool,
    /// Origin of the ray leaving this event (offset off the surface, or the
    /// origin of the line it continues on: see `next_tnear`).
    pub next_org: V3,
    /// Unit direction of the ray leaving this event.
    pub next_dir: V3,
    /// Where the ray leaving this event starts on its line (0, or just past
    /// the hit for a ray continued on its own line through an index-matched
    /// boundary: then `next_org` is that line's origin, not the hit).
    pub next_tnear: f32,
}

/// Follow a ray through dielectrics, always refracting (reflecting only under
/// total internal reflection), stopping at the first non-dielectric surface,
/// at a miss, or after `max_events`. Deterministic: used by tests and audits to
/// compare strategies and to check interior lists against point-in-solid tests.
pub fn refraction_path(
    tr: Tracer<'_>,
    org: V3,
    dir: V3,
    start: &[u32],
    max_events: usize,
    counters: &mut Counters,
) -> Result<RefractionPath> {
    let scene = tr.scene;
    let mut list = InteriorList::from_solids(&scene.solids, start);
    let mut ray = Ray::new(org, dir.normalize());
    let mut events = Vec::new();
    for _ in 0..max_events {
        let Some(dielectric::TrueHit { hit, coincident }) =
            dielectric::trace(scene, tr.strategy, &ray, &mut list, counters)?
        else {
            return Ok(RefractionPath {
                events,
                final_list: list.sorted(),
                escaped: true,
            });
        };
        let sp = scene.surface_point(&ray, &hit);
        let rec = &scene.geoms[hit.geom_id as usize];
        let front = front_facing(sp.ng, ray.dir);
        let m = &rec.material;
        if !matches!(m, Material::Interface { .. } | Material::Solid(_)) {
            return Ok(RefractionPath {
                events,
                final_list: list.sorted(),
                escaped: false,
            });
        }
        let Some(c) = tr.boundary(m, front, &coincident, &mut list) else {
            unreachable!("a dielectric material, checked above");
        };
        let d = ray.dir.as_dvec3();
        let n = sp.ng.as_dvec3();
        let incident_side = if front { sp.ng } else { -sp.ng };
        let (wi, tir) = match optics::refract(d, n, c.n1 as f64, c.n2 as f64) {
            Some(t) => {
                if let Some(nl) = c.transmitted_list() {
                    list = nl.clone();
                }
                ((t.normalize()).as_vec3a(), false)
            }
            None => ((optics::reflect(d, n).normalize()).as_vec3a(), true),
        };
        let next = if tir {
            Ray::new(offset_origin(sp.p, incident_side), wi)
        } else {
            let line = (c.n1 == c.n2 && dielectric::keeps_line(scene)).then_some((&ray, hit.t));
            spawn_transmitted(sp.p, -incident_side, ray.dir, wi, (c.n1, c.n2), line)
        };
        tr.settle(&coincident, &next, &mut list, counters);
        events.push(PathEvent {
            geom: hit.geom_id,
            point: sp.p,
            t: hit.t - ray.tnear,
            n1: c.n1,
            n2: c.n2,
            list_after: list.sorted(),
            tir,
            next_org: next.org,
            next_dir: next.dir,
            next_tnear: next.tnear,
        });
        ray = next;
    }
    Ok(RefractionPath {
        events,
        final_list: list.sorted(),
        escaped: false,
    })
}

/// Result of [`refraction_path`].
#[derive(Debug, Clone)]
pub struct RefractionPath {
    /// The surface events, in order.
    pub events: Vec<PathEvent>,
    /// Interior list after the last event.
    pub final_list: Vec<u32>,
    /// The path ended by leaving the scene (no further hit).
    pub escaped: bool,
}
