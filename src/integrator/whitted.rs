//! The Whitted preview: direct light at diffuse surfaces (one sample per
//! light), perfect specular recursion for mirrors and both lobes of
//! dielectrics, through the same scattering model as the path tracer.
//!
//! The microfacet materials, kept cheap: a rough dielectric is previewed as
//! its smooth counterpart (both lobes recursed, same index pair); rough
//! metals and plastics get direct light through their BSDF (one sample per
//! light, no recursion); the delta reflections of a smooth metal and of a
//! smooth plastic's coating recurse like a mirror with their Fresnel
//! reflectance.
use super::cast::cast;
use super::light::{light_seen, light_straight, unoccluded};
use super::scatter::{Bsdf, Interface};
use super::Tracer;
use crate::counters::Counters;
use crate::dielectric::InteriorList;
use crate::error::Result;
use crate::ray::{front_facing, offset_origin, spawn_transmitted, Ray};
use crate::sampling::Rng;
use glam::Vec3A as V3;

/// Whitted: direct light at diffuse surfaces (one sample per light), perfect
/// specular recursion for mirrors and both branches of dielectrics.
pub(super) fn whitted(
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
    let (seg, coincident) = cast(tr, &ray, &mut list, st, None)?;
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
    if let (Some(em), true) = (&rec.emission, front || rec.emission_two_sided) {
        l += em.eval(sp.p, sp.uv);
    }
    if depth >= scene.max_depth {
        return Ok(att * l);
    }
    match Bsdf::at(tr, &rec.material, &sp, dir, &coincident, &mut list, st) {
        Bsdf::Black => {}
        Bsdf::Diffuse(lambert) => {
            // One sample per light, the sun's disk among them.
            let lights = if tr.nee() { scene.nee_count() } else { 0 };
            for _ in 0..lights {
                if let Some((ls, cos)) = light_seen(tr, sp.p, lambert.n, lambert.ng, rng, st) {
                    l += lambert.f() * ls.li * (cos / ls.pdf) / lights as f32;
                }
            }
            // Ambient term from a constant environment (preview only).
            if let crate::scene::Environment::Constant(c) = scene.environment {
                l += lambert.albedo * c;
            }
        }
        Bsdf::Mirror(mirror) => {
            let org = offset_origin(sp.p, mirror.side);
            tr.settle(&coincident, &Ray::new(org, mirror.wi), &mut list, st);
            l += mirror.reflectance * whitted(tr, org, mirror.wi, list, rng, st, depth + 1)?;
        }
        Bsdf::Dielectric(iface) => {
            l += dielectric(tr, &iface, sp.p, dir, &coincident, list, rng, st, depth)?;
        }
        Bsdf::Micro(micro) => {
            if let Some(b) = micro.boundary {
                let iface = Interface::new(b, dir, sp.ns, micro.side, st);
                l += dielectric(tr, &iface, sp.p, dir, &coincident, list, rng, st, depth)?;
            } else {
                let lights = if tr.nee() && !micro.is_delta() {
                    scene.nee_count()
                } else {
                    0
                };
                for _ in 0..lights {
                    let Some(ls) = light_straight(scene, sp.p, rng) else {
                        continue;
                    };
                    let (fc, _) = micro.eval(ls.wi);
                    if fc != V3::ZERO && unoccluded(tr, sp.p, micro.side, ls.wi, ls.dist, st) {
                        l += fc * ls.li / (ls.pdf * lights as f32);
                    }
                }
                if let Some((wi, reflectance)) = micro.delta_reflection() {
                    let org = offset_origin(sp.p, micro.side);
                    tr.settle(&coincident, &Ray::new(org, wi), &mut list, st);
                    l += reflectance * whitted(tr, org, wi, list, rng, st, depth + 1)?;
                }
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

/// Both lobes of a smooth boundary, each weighted by its Fresnel share.
#[allow(clippy::too_many_arguments)]
fn dielectric(
    tr: Tracer<'_>,
    iface: &Interface,
    p: V3,
    dir: V3,
    coincident: &crate::dielectric::Coincident,
    list: InteriorList,
    rng: &mut Rng,
    st: &mut Counters,
    depth: u32,
) -> Result<V3> {
    let fr = iface.fresnel as f32;
    let wr = iface.reflected();
    let org = offset_origin(p, iface.side);
    let mut rl = list.clone();
    tr.settle(coincident, &Ray::new(org, wr), &mut rl, st);
    let mut l = fr * whitted(tr, org, wr, rl, rng, st, depth + 1)?;
    if let Some(t) = iface.refracted {
        let (n1, n2) = (iface.boundary.n1, iface.boundary.n2);
        let k = n1 / n2;
        let mut nl = list;
        iface.boundary.clone().transmit(&mut nl);
        let next = spawn_transmitted(p, -iface.side, dir, t, (n1, n2), None);
        tr.settle(coincident, &next, &mut nl, st);
        l += (1.0 - fr) * k * k * whitted(tr, next.org, next.dir, nl, rng, st, depth + 1)?;
    }
    Ok(l)
}
