//! One path segment: the first true hit along a ray, straight, or as a
//! chain of chords through a gradient-index medium (straight outside its
//! bounds at no extra cost); and the plain segments and shadow rays of
//! paths traced side by side, as packets.
use super::{RayQuery, Tracer};
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList};
use crate::embree::RayPacket;
use crate::error::Result;
use crate::ray::{Hit, Ray};
use crate::scene::shapes::{SetScratch, SurfaceLanes};
use crate::scene::{RenderScene, SurfacePoint};
use glam::Vec3A as V3;

/// One path segment: the first true hit (if any) and the straight chord it
/// lies on, the direction the ray arrives with and the distance travelled.
/// The solid surfaces coincident with the hit travel beside it (a
/// [`dielectric::Coincident`] from [`cast`], or [`NO_COINCIDENT`] for a
/// plain query): a segment is built per path and per bounce, and carrying
/// the 112-byte record in it would cost a copy of it per segment.
pub(super) struct Segment {
    /// The first true hit.
    pub hit: Option<crate::ray::Hit>,
    /// The straight ray (a chord inside a medium) the hit was found on.
    pub chord: Ray,
    /// Unit direction at the end (the tangent of the curved path at the hit,
    /// or the direction the ray leaves to infinity with).
    pub dir: V3,
    /// Path length to the hit (sum of chords).
    pub length: f32,
    /// The curved-ray integrator failed (e.g. the paper's Euler at a turning
    /// point): the path ends black.
    pub failed: bool,
    /// The ray reached the medium's bounds before its hit (or escape), so it
    /// may have curved: no straight next-event connection can produce it.
    pub entered_medium: bool,
}

/// The coincident surfaces of a plain query's hit (none).
pub(super) static NO_COINCIDENT: dielectric::Coincident = dielectric::Coincident::NONE;

impl Segment {
    /// The curved-ray integrator failed after `travelled` along the path
    /// that started as `ray`: no hit, the path ends black.
    pub(super) fn failed(ray: &Ray, travelled: f64, entered_medium: bool) -> Segment {
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
    pub(super) fn straight(ray: &Ray, hit: Option<crate::ray::Hit>) -> Segment {
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

/// Chords one curved segment may take before the path is ended (and counted
/// as an integrator failure).
pub const MAX_CHORDS_PER_SEGMENT: u32 = 200_000;

/// Does the straight segment from `p` along unit `wi` for `dist` meet the
/// gradient-index medium's bounds? Next-event estimation is only used for
/// connections that do not (light travels straight outside the bounds); a
/// connection that does would need the curved path between two points.
pub(super) fn meets_medium(scene: &RenderScene, p: V3, wi: V3, dist: f32) -> bool {
    scene.medium.as_ref().is_some_and(|m| {
        m.bounds()
            .clip(p.as_dvec3(), wi.as_dvec3())
            .is_some_and(|(t0, t1)| t1 > 0.0 && t0 < dist as f64)
    })
}

/// Cast `ray`, through the gradient-index medium as chords when the scene has
/// one (straight outside its bounds at no extra cost), else straight;
/// `curved`: the ray's curved ray made beforehand (its flight perhaps flown).
pub(super) fn cast(
    tr: Tracer<'_>,
    ray: &Ray,
    list: &mut InteriorList,
    st: &mut Counters,
    curved: Option<&mut crate::media::CurvedRay>,
) -> Result<(Segment, dielectric::Coincident)> {
    let scene = tr.scene;
    let Some(med) = &scene.medium else {
        tr.observe(|| RayQuery::Nearest(*ray));
        return Ok(match dielectric::trace(scene, tr.strategy, ray, list, st)? {
            Some(th) => (Segment::straight(ray, Some(th.hit)), th.coincident),
            None => (Segment::straight(ray, None), dielectric::Coincident::NONE),
        });
    };
    let mut own;
    let curved = match curved {
        Some(c) => c,
        None => {
            own = med.start_ray(ray.org.as_dvec3(), ray.dir.as_dvec3());
            &mut own
        }
    };
    let mut seg = Segment::failed(ray, 0.0, false);
    let mut coincident = dielectric::Coincident::NONE;
    cast_curved_into(tr, med, curved, ray, list, st, &mut seg, &mut coincident)?;
    Ok((seg, coincident))
}

/// [`cast`] through the medium `med` with the curved ray `curved`, the
/// segment and its coincident surfaces written into `seg` and `coincident`:
/// the path tracer's loop keeps them across segments, and a returned pair
/// (some 200 bytes in a `Result`) was copied out of it at every segment.
#[allow(clippy::too_many_arguments)]
pub(super) fn cast_curved_into(
    tr: Tracer<'_>,
    med: &crate::media::Medium,
    curved: &mut crate::media::CurvedRay,
    ray: &Ray,
    list: &mut InteriorList,
    st: &mut Counters,
    seg: &mut Segment,
    coincident: &mut dielectric::Coincident,
) -> Result<()> {
    let out = cast_curved(tr, med, curved, ray, list, st, seg, coincident);
    st.field_evals += curved.evaluations();
    if curved.entered() {
        st.medium_segments += 1;
    }
    out
}

/// [`cast`] through the medium: the chords of `curved` until one hits or
/// escapes (written into `seg` and `coincident`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn cast_curved(
    tr: Tracer<'_>,
    med: &crate::media::Medium,
    curved: &mut crate::media::CurvedRay,
    ray: &Ray,
    list: &mut InteriorList,
    st: &mut Counters,
    seg: &mut Segment,
    coincident: &mut dielectric::Coincident,
) -> Result<()> {
    let scene = tr.scene;
    let mut travelled = 0.0f64;
    // A budget of chords per segment (the load-time checks bound the chord
    // count across the box; this also covers rays trapped in a duct).
    for k in 0..MAX_CHORDS_PER_SEGMENT {
        let chord = curved.next_chord(med);
        // The first chord is inside the medium when the ray starts in its
        // bounds; every later chord is (the first one ends at the entry).
        let entered_medium = k > 0 || curved.started_inside();
        travelled += chord.skipped;
        if chord.length == 0.0 && curved.failure().is_none() {
            // A zero-length chord is the ray leaving the bounds exactly where it
            // stands (at the box face): not a failure, nothing to cast.
            continue;
        }
        if curved.failure().is_some() || chord.length.is_nan() || chord.length < 0.0 {
            *seg = Segment::failed(ray, travelled, entered_medium);
            *coincident = dielectric::Coincident::NONE;
            return Ok(());
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
            *seg = Segment {
                hit: Some(th.hit),
                chord: r,
                dir: (tangent.normalize()).as_vec3a(),
                length: (travelled + th.hit.t as f64) as f32,
                failed: false,
                entered_medium,
            };
            *coincident = th.coincident;
            return Ok(());
        }
        if !chord.length.is_finite() {
            *seg = Segment {
                hit: None,
                chord: r,
                dir: r.dir,
                length: f32::INFINITY,
                failed: false,
                entered_medium,
            };
            *coincident = dielectric::Coincident::NONE;
            return Ok(());
        }
        travelled += chord.length;
    }
    *seg = Segment::failed(ray, travelled, true);
    *coincident = dielectric::Coincident::NONE;
    Ok(())
}

/// A shadow ray that curves: from `org` along unit `dir` through the
/// medium, chord by chord as [`cast`] casts a segment, each chord that may
/// meet geometry one occlusion query. The direction it leaves to infinity
/// with when nothing is in its way; `None` when something is, or the
/// integrator failed, or the chords ran out (a path would end there too).
pub(super) fn curved_escape(
    tr: Tracer<'_>,
    med: &crate::media::Medium,
    org: V3,
    dir: V3,
    st: &mut Counters,
) -> Option<V3> {
    let mut curved = med.start_ray(org.as_dvec3(), dir.as_dvec3());
    let mut out = None;
    for _ in 0..MAX_CHORDS_PER_SEGMENT {
        let chord = curved.next_chord(med);
        if curved.failure().is_some() || chord.length.is_nan() || chord.length < 0.0 {
            break;
        }
        if chord.length == 0.0 {
            continue;
        }
        st.chords += 1;
        if med.chord_may_hit(&chord) {
            let mut r = Ray::new(chord.origin.as_vec3a(), chord.dir.as_vec3a());
            if chord.length.is_finite() {
                r.tfar = chord.length as f32;
            }
            st.shadow_rays += 1;
            tr.observe(|| RayQuery::Shadow(r));
            if tr.scene.embree.occluded(&r) {
                break;
            }
        }
        if !chord.length.is_finite() {
            out = Some(chord.dir.as_vec3a());
            break;
        }
    }
    st.field_evals += curved.evaluations();
    out
}

/// The segment of `ray` whose plain query answered `hit`, counted and
/// observed as `cast` would have (`coherent`: as a path's that has met only
/// smooth surfaces, [`RayQuery::Coherent`]).
#[inline]
pub(super) fn known_segment(
    tr: Tracer<'_>,
    ray: &Ray,
    hit: Option<crate::ray::Hit>,
    coherent: bool,
    st: &mut Counters,
) -> Segment {
    tr.observe(|| {
        if coherent {
            RayQuery::Coherent(*ray)
        } else {
            RayQuery::Nearest(*ray)
        }
    });
    st.queries += 1;
    Segment::straight(ray, hit)
}

/// Nearest hits of the active lanes of `packet` in `scene`: Embree's, or
/// with an [`AnalyticSet`](crate::scene::shapes::AnalyticSet), Embree's
/// among the meshes completed by the set's. Whether any hit is the set's.
#[inline]
pub(super) fn intersect_packet<const N: usize, P: RayPacket<N>>(
    scene: &RenderScene,
    packet: &mut P,
    coherent: bool,
    scratch: &mut SetScratch<N>,
) -> bool {
    match &scene.analytic_set {
        Some(set) => {
            packet.intersect_meshes(&scene.embree, coherent);
            set.intersect(packet, scratch)
        }
        None => {
            packet.intersect(&scene.embree, coherent);
            false
        }
    }
}

/// Occlusion of the active lanes of `packet` (shadow rays: not coherent),
/// as [`intersect_packet`] finds hits.
#[inline]
pub(super) fn occlude_packet<const N: usize, P: RayPacket<N>>(
    scene: &RenderScene,
    packet: &mut P,
    scratch: &mut SetScratch<N>,
) {
    match &scene.analytic_set {
        Some(set) => {
            packet.occlude_meshes(&scene.embree, false);
            set.occlude(packet, scratch);
        }
        None => packet.occlude(&scene.embree, false),
    }
}

/// The surface point of lane `i`'s hit `h` on the lane's ray (`ray`, asked
/// for only when needed): from the analytic set's solve where it answered
/// the lane (`set_points`: it answered some), else the scene's own.
#[inline(always)]
pub(super) fn packet_surface_point<const N: usize>(
    scene: &RenderScene,
    (set_points, surfaces): (bool, &SurfaceLanes<N>),
    i: usize,
    h: &Hit,
    ray: impl FnOnce() -> Ray,
) -> SurfacePoint {
    let solved = (set_points && surfaces.done[i] != 0.0)
        .then(|| {
            let s = surfaces;
            let pd = glam::DVec3::new(s.pd[0][i], s.pd[1][i], s.pd[2][i]);
            let p = V3::new(s.p[0][i], s.p[1][i], s.p[2][i]);
            let ng = V3::new(s.ng[0][i], s.ng[1][i], s.ng[2][i]);
            scene.analytic_surface_point(h, pd, p, ng)
        })
        .flatten();
    solved.unwrap_or_else(|| scene.surface_point(&ray(), h))
}
