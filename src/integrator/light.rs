//! Light sampling at a diffuse point and the shadow rays that test it.
use super::cast::meets_medium;
use super::{RayQuery, Tracer};
use crate::counters::Counters;
use crate::ray::{offset_origin, offset_size, Ray};
use crate::sampling::Rng;
use crate::scene::{LightSample, RenderScene};
use glam::Vec3A as V3;

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
