//! Light sampling at a diffuse point and the shadow rays that test it.
use super::cast::{curved_escape, meets_medium, occlude_packet};
use super::scatter::Lambert;
use super::{RayQuery, Tracer};
use crate::counters::Counters;
use crate::embree::RayPacket;
use crate::media::sun_connect::{exit_for_launch, launch_for_exit, LaunchSolve};
use crate::ray::{offset_origin, offset_size, Ray};
use crate::sampling::{power_heuristic, Rng};
use crate::scene::shapes::SetScratch;
use crate::scene::{LightSample, RenderScene};
use glam::Vec3A as V3;

/// A next-event connection waiting for its shadow ray: `contrib` is added to
/// the path's radiance if `ray` is unoccluded.
pub(super) struct PendingShadow {
    pub(super) ray: Ray,
    pub(super) contrib: V3,
}

/// The shadow ray from `from` (offset to the side `side`) along `wi` for
/// `dist`, counted and observed; `None` when the connection is too short to
/// hold anything (then it is unoccluded without a query).
#[inline]
pub(super) fn shadow_ray(
    tr: Tracer<'_>,
    from: V3,
    side: V3,
    wi: V3,
    dist: f32,
    st: &mut Counters,
) -> Option<Ray> {
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

pub(super) fn unoccluded(tr: Tracer<'_>, from: V3, side: V3, wi: V3, dist: f32, st: &mut Counters) -> bool {
    shadow_ray(tr, from, side, wi, dist, st).is_none_or(|r| !tr.scene.embree.occluded(&r))
}

/// A light sample from the diffuse point `p` before its shadow ray: `None`
/// unless the light is above both normals (`n` shading, `ng` geometric, both
/// on the light's side; a shading normal can lean past the surface) and its
/// straight connection avoids the gradient-index medium. With its cosine at `p`.
#[inline(always)]
pub(super) fn light_candidate(
    scene: &RenderScene,
    p: V3,
    n: V3,
    ng: V3,
    rng: &mut Rng,
) -> Option<(LightSample, f32)> {
    let ls = scene.sample_light(p, rng)?;
    let cos = n.dot(ls.wi);
    (cos > 0.0 && ng.dot(ls.wi) > 0.0 && !meets_medium(scene, p, ls.wi, ls.dist)).then_some((ls, cos))
}

/// A light sample seen from the diffuse point `p` ([`light_candidate`]) and
/// not occluded. The one light-sampling test of both integrators: Whitted's
/// copy had lost the `ng` check.
pub(super) fn light_seen(
    tr: Tracer<'_>,
    p: V3,
    n: V3,
    ng: V3,
    rng: &mut Rng,
    st: &mut Counters,
) -> Option<(LightSample, f32)> {
    light_candidate(tr.scene, p, n, ng, rng).filter(|(ls, _)| unoccluded(tr, p, ng, ls.wi, ls.dist, st))
}

/// What next-event estimation draws at a diffuse point.
pub(super) enum NextEvent {
    /// A sample whose straight connection avoids the gradient-index medium,
    /// above both normals, with its cosine ([`light_candidate`]).
    Straight(LightSample, f32),
    /// A sample of the sun's disk whose straight connection meets the
    /// medium: `wi` is the direction the light must leave the medium with
    /// ([`sun_through_medium`]).
    SunThroughMedium(LightSample),
}

/// The path tracer's next-event draw at the diffuse point `p` (normals `n`
/// and `ng`): [`light_candidate`]'s, and the sun's disk through the medium.
#[inline(always)]
pub(super) fn next_event(scene: &RenderScene, p: V3, n: V3, ng: V3, rng: &mut Rng) -> Option<NextEvent> {
    let ls = scene.sample_light(p, rng)?;
    if meets_medium(scene, p, ls.wi, ls.dist) {
        // The cosine is the launch's, known only once solved. A map's
        // connections through the medium are left to BSDF sampling (its
        // escapes through the medium then weigh 1).
        let sun = ls.is_environment() && scene.environment.sun_nee().is_some();
        return sun.then_some(NextEvent::SunThroughMedium(ls));
    }
    let cos = n.dot(ls.wi);
    (cos > 0.0 && ng.dot(ls.wi) > 0.0).then_some(NextEvent::Straight(ls, cos))
}

/// A light sample from `p` whose straight connection avoids the
/// gradient-index medium, for any BSDF (the caller weighs its side and
/// cosine). The sun's disk through the medium is left to BSDF sampling here
/// ([`sun_through_medium`] solves it for Lambertian points only).
#[inline(always)]
pub(super) fn light_straight(scene: &RenderScene, p: V3, rng: &mut Rng) -> Option<LightSample> {
    let ls = scene.sample_light(p, rng)?;
    (!meets_medium(scene, p, ls.wi, ls.dist)).then_some(ls)
}

/// The sun's next-event contribution at the diffuse point `p` through a
/// stratified medium, before the path's throughput: `ls.wi`, uniform in the
/// disk, is the exit direction; the launch that leaves along it
/// (`launch_for_exit`) has the density `ls.pdf` (1/Ω × the choice) ×
/// |dΩ_exit/dΩ_launch|, which weighs it against the BSDF's density of the
/// launch (power heuristic); the curved shadow ray must meet nothing and
/// leave inside the disk. Zero where the launch has no solution (a turn
/// before the top, an exit through a side, `p` outside the bounds, a field
/// not stratified): BSDF sampling alone finds those paths, and
/// [`sun_launch_jacobian`] gives them weight 1.
///
/// The radiance is the disk's L, not (n₀/n_t)² L: radiance over n² is what
/// a ray conserves through the medium, but BSDF-sampled rays that escape
/// through it leave the factor out too (≈ 2·10⁻⁴ in air), so both
/// estimators of the same path agree.
#[inline(never)]
pub(super) fn sun_through_medium(
    tr: Tracer<'_>,
    p: V3,
    lambert: &Lambert,
    ls: &LightSample,
    st: &mut Counters,
) -> V3 {
    let scene = tr.scene;
    let (Some(med), Some(sky)) = (&scene.medium, scene.environment.sun_nee()) else {
        return V3::ZERO;
    };
    let solve = sky.sun.launch_solve();
    let Some(l) = launch_for_exit(med.field(), &med.bounds(), p.as_dvec3(), ls.wi.as_dvec3(), solve) else {
        return V3::ZERO;
    };
    let wi = l.dir.as_vec3a();
    let cos = lambert.n.dot(wi);
    if !(cos > 0.0 && lambert.ng.dot(wi) > 0.0) {
        return V3::ZERO;
    }
    let pdf = ls.pdf * l.jacobian as f32;
    let w = power_heuristic(pdf, lambert.pdf(wi));
    match curved_escape(tr, med, offset_origin(p, lambert.ng), wi, st) {
        Some(d) if sky.sun.contains(d) => lambert.f() * ls.li * (cos * w / pdf),
        _ => V3::ZERO,
    }
}

/// For a BSDF-sampled ray that left the diffuse point `p` along `wi`,
/// entered the medium and escaped along `dir`: the Jacobian
/// |dΩ_exit/dΩ_launch| of [`sun_through_medium`]'s density for that launch,
/// when it can produce it (the escape's MIS weight); `None` when it cannot
/// (`exit_for_launch` refuses exactly the launches `launch_for_exit` never
/// gives, and the analytic exit must be in the disk), or `dir` misses the
/// disk (no weight needed).
#[inline(never)]
pub(super) fn sun_launch_jacobian(scene: &RenderScene, p: V3, wi: V3, dir: V3) -> Option<f32> {
    let sky = scene.environment.sun_nee()?;
    if !sky.sun.contains(dir) {
        return None;
    }
    let med = scene.medium.as_ref()?;
    // Always the invariant's: the straight solve is a test's wrong
    // next-event side only (see `SunSampling::WrongStraightLaunch`).
    let solve = LaunchSolve::Invariant;
    let (exit, l) = exit_for_launch(med.field(), &med.bounds(), p.as_dvec3(), wi.as_dvec3(), solve)?;
    sky.sun.contains(exit.as_vec3a()).then_some(l.jacobian as f32)
}

/// The shadow rays of a step's connections (`waiting`: each with the place
/// of its path), `N` to a packet: `lit(place, contrib)` for each that
/// nothing occludes.
pub(super) fn resolve_shadows<const N: usize, P: RayPacket<N>>(
    scene: &RenderScene,
    shadow: &mut P,
    waiting: &[(u32, PendingShadow)],
    occupancy: &mut Counters,
    scratch: &mut SetScratch<N>,
    mut lit: impl FnMut(usize, V3),
) {
    for group in waiting.chunks(N) {
        shadow.clear();
        for (i, (_, sh)) in group.iter().enumerate() {
            shadow.set_ray(i, &sh.ray);
        }
        occupancy.shadow_packet_slots += N as u64;
        occupancy.shadow_packet_lanes += group.len() as u64;
        occlude_packet(scene, shadow, scratch);
        for (i, (at, sh)) in group.iter().enumerate() {
            if !shadow.occluded(i) {
                lit(*at as usize, sh.contrib);
            }
        }
    }
}
