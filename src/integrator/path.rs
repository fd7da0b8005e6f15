//! The path tracer: a path's state between segments and the step that
//! shades one segment (emission, scattering, the next-event connection, the
//! next ray, Russian roulette), shared by single rays and [`super::lanes`].
use super::cast::{cast, cast_curved_into, Segment};
use super::light::{
    light_straight, next_event, shadow_ray, sun_launch_jacobian, sun_through_medium, NextEvent, PendingShadow,
};
use super::scatter::{Bsdf, Lobe};
use super::Tracer;
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList};
use crate::error::Result;
use crate::media::CurvedRay;
use crate::ray::{front_facing, offset_origin, spawn_transmitted, Ray};
use crate::sampling::{power_heuristic, Rng};
use crate::scene::{RenderScene, SurfacePoint};
use glam::Vec3A as V3;

/// A path tracer's path between two segments: the loop state of [`path`]
/// and of the wavefront's single-ray step ([`trace_paths`](super::trace_paths)),
/// which both advance it with [`PathState::advance`].
pub(super) struct PathState {
    pub(super) l: V3,
    pub(super) beta: V3,
    pub(super) eta_scale: f32,
    /// The next segment's ray.
    pub(super) ray: Ray,
    pub(super) specular: bool,
    pub(super) prev_p: V3,
    pub(super) prev_pdf: f32,
    /// The direction the path left its last diffuse vertex (`prev_p`) with:
    /// where it escapes after curving through the medium, the sun's
    /// next-event density of that launch weighs it.
    pub(super) prev_wi: V3,
    /// The last non-delta vertex was Lambertian: only there does next-event
    /// estimation also sample the sun through the medium.
    pub(super) prev_lambert: bool,
    /// Segment index of `ray`.
    pub(super) depth: u32,
    pub(super) list: InteriorList,
    /// No diffuse bounce yet: the camera ray and its mirror and dielectric
    /// continuations, which a pixel's samples follow side by side nearly in
    /// parallel (Embree's coherent packets, in the wavefront).
    pub(super) only_specular: bool,
}

impl PathState {
    pub(super) fn new(org: V3, dir: V3, list: InteriorList) -> Self {
        PathState {
            l: V3::ZERO,
            beta: V3::ONE,
            eta_scale: 1.0,
            ray: Ray::new(org, dir),
            specular: true,
            prev_p: org,
            prev_pdf: 0.0,
            prev_wi: dir,
            prev_lambert: true,
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
    /// has already reconstructed it (the wavefront), else it is made here.
    /// (Forced inline: one call per segment, in the lane loop and in `path`.)
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn advance(
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
                // The sun's disk is also sampled by NEE (`next_event`): along
                // straight paths from a diffuse vertex, and along curved ones
                // through a stratified medium (`sun_through_medium`), whose
                // density of this launch `sun_launch_jacobian` gives.
                let mis = match (self.specular || !tr.nee(), seg.entered_medium) {
                    (true, _) => None,
                    (false, false) => Some((self.prev_pdf, 1.0)),
                    (false, true) if self.prev_lambert => {
                        sun_launch_jacobian(scene, self.prev_p, self.prev_wi, seg.dir)
                            .map(|j| (self.prev_pdf, j))
                    }
                    (false, true) => None,
                };
                self.l += self.beta * scene.escaped_radiance(seg.dir, mis);
            }
            st.ended_escaped += 1;
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
            if front || rec.emission_two_sided {
                let le = em.eval(sp.p, sp.uv);
                let w = match rec.light {
                    // A path through the medium cannot come from NEE (which
                    // only connects straight segments that avoid it): weight 1.
                    Some(li) if !self.specular && !seg.entered_medium && tr.nee() => {
                        let lp = scene.light_pdf(li, self.prev_p, sp.p, sp.ng, self.ray.dir);
                        power_heuristic(self.prev_pdf, lp)
                    }
                    _ => 1.0,
                };
                self.l += self.beta * le * w;
            }
        }
        if self.depth >= scene.max_depth {
            st.ended_max_depth += 1;
            return (None, false);
        }
        let bsdf = Bsdf::at(
            tr,
            &rec.material,
            &sp,
            self.ray.dir,
            coincident,
            &mut self.list,
            st,
        );
        match bsdf {
            Bsdf::Black => {
                st.ended_absorbed += 1;
                return (None, false);
            }
            Bsdf::Diffuse(lambert) => {
                // Next-event estimation (none where the surface reflects
                // nothing: its connections would all weigh 0).
                let nee = tr.nee() && lambert.albedo != V3::ZERO;
                st.nee_draws += nee as u64;
                match nee
                    .then(|| next_event(scene, sp.p, lambert.n, lambert.ng, rng))
                    .flatten()
                {
                    Some(NextEvent::Straight(ls, cos)) => {
                        let w = if ls.delta {
                            1.0
                        } else {
                            power_heuristic(ls.pdf, lambert.pdf(ls.wi))
                        };
                        let contrib = self.beta * lambert.f() * ls.li * (cos * w / ls.pdf);
                        match shadow_ray(tr, sp.p, lambert.ng, ls.wi, ls.dist, st) {
                            None => self.l += contrib,
                            Some(ray) => shadow = Some(PendingShadow { ray, contrib }),
                        }
                    }
                    // Its curved shadow ray is cast here (the wavefront never
                    // runs with a medium).
                    Some(NextEvent::SunThroughMedium(ls)) => {
                        self.l += self.beta * sun_through_medium(tr, sp.p, &lambert, &ls, st);
                    }
                    None => {}
                }
                // A black reflectance (cylinder_refraction's emitting plane)
                // ends the path below (zero throughput): its direction is
                // not sampled. Only where nothing else reads it: a finite
                // throughput (so that it becomes exactly 0) and no solids
                // for the child ray to settle (which would count them).
                if lambert.albedo == V3::ZERO && self.beta.is_finite() && coincident.near.is_empty() {
                    st.ended_absorbed += 1;
                    return (shadow, false);
                }
                let Some(wi) = lambert.sample(rng) else {
                    st.ended_absorbed += 1;
                    return (shadow, false);
                };
                self.beta *= lambert.albedo;
                self.prev_pdf = lambert.pdf(wi);
                self.prev_wi = wi;
                self.prev_lambert = true;
                self.specular = false;
                self.only_specular = false;
                self.prev_p = sp.p;
                self.ray = Ray::new(offset_origin(sp.p, lambert.ng), wi);
                tr.settle(coincident, &self.ray, &mut self.list, st);
            }
            Bsdf::Mirror(mirror) => {
                self.beta *= mirror.reflectance;
                self.specular = true;
                self.prev_p = sp.p;
                self.ray = Ray::new(offset_origin(sp.p, mirror.side), mirror.wi);
                tr.settle(coincident, &self.ray, &mut self.list, st);
            }
            Bsdf::Dielectric(iface) => {
                match iface.sample(rng) {
                    Lobe::Reflect(wi) => {
                        self.ray = Ray::new(offset_origin(sp.p, iface.side), wi);
                        tr.settle(coincident, &self.ray, &mut self.list, st);
                    }
                    Lobe::Transmit(wi) => {
                        let k2 = iface.radiance_scale();
                        self.beta *= k2;
                        self.eta_scale /= k2;
                        let (n1, n2) = (iface.boundary.n1, iface.boundary.n2);
                        // Straight segments keep their line through index-matched boundaries.
                        let line = (n1 == n2 && !seg.entered_medium && dielectric::keeps_line(scene))
                            .then_some((&seg.chord, hit.t));
                        let next = spawn_transmitted(sp.p, -iface.side, self.ray.dir, wi, (n1, n2), line);
                        iface.boundary.transmit(&mut self.list);
                        tr.settle(coincident, &next, &mut self.list, st);
                        self.ray = next;
                    }
                }
                self.specular = true;
                self.prev_p = sp.p;
            }
            Bsdf::Micro(micro) => {
                if tr.nee() && !micro.is_delta() {
                    st.nee_draws += 1;
                    if let Some(ls) = light_straight(scene, sp.p, rng) {
                        let (fc, pdf) = micro.eval(ls.wi);
                        #[cfg(test)]
                        let (fc, pdf) = micro.wrong_eval(scene.bsdf_variant, ls.wi, fc, pdf);
                        if fc != V3::ZERO {
                            let w = if ls.delta {
                                1.0
                            } else {
                                power_heuristic(ls.pdf, pdf)
                            };
                            let contrib = self.beta * fc * ls.li * (w / ls.pdf);
                            // A transmitted connection leaves from the far side.
                            let side = if ls.wi.dot(micro.side) > 0.0 {
                                micro.side
                            } else {
                                -micro.side
                            };
                            match shadow_ray(tr, sp.p, side, ls.wi, ls.dist, st) {
                                None => self.l += contrib,
                                Some(ray) => shadow = Some(PendingShadow { ray, contrib }),
                            }
                        }
                    }
                }
                let Some(s) = micro.sample(rng) else {
                    st.ended_absorbed += 1;
                    return (shadow, false);
                };
                #[cfg(test)]
                let s = micro.wrong_sample(scene.bsdf_variant, s);
                self.beta *= s.weight;
                self.specular = s.is_delta;
                if !s.is_delta {
                    self.prev_pdf = s.pdf;
                    self.prev_wi = s.wi;
                    self.prev_lambert = false;
                    self.only_specular = false;
                }
                self.prev_p = sp.p;
                if s.is_transmission {
                    // The weight carries (n1/n2)² already; Russian roulette
                    // looks through it as for the smooth boundary.
                    self.eta_scale /= micro.radiance_scale();
                    let next = Ray::new(offset_origin(sp.p, -micro.side), s.wi);
                    if let Some(b) = micro.boundary {
                        b.transmit(&mut self.list);
                    }
                    tr.settle(coincident, &next, &mut self.list, st);
                    self.ray = next;
                } else {
                    self.ray = Ray::new(offset_origin(sp.p, micro.side), s.wi);
                    tr.settle(coincident, &self.ray, &mut self.list, st);
                }
            }
        }
        (shadow, self.survives(scene, rng, st))
    }

    /// The end of a scattering step, once the next ray is set: one segment
    /// deeper, then does the path go on? Not with zero throughput, nor when
    /// Russian roulette ends it (one random number past `rr_depth`).
    #[inline(always)]
    pub(super) fn survives(&mut self, scene: &RenderScene, rng: &mut Rng, st: &mut Counters) -> bool {
        survives(&mut self.beta, self.eta_scale, &mut self.depth, scene, rng, st)
    }

    /// The path's radiance (0, counted, when it is not finite).
    pub(super) fn radiance(&self, st: &mut Counters) -> V3 {
        finite_radiance(self.l, st)
    }
}

/// A path's radiance `l`, or 0 (counted) when it is not finite.
#[inline]
pub(super) fn finite_radiance(l: V3, st: &mut Counters) -> V3 {
    if l.is_finite() {
        l
    } else {
        st.nan += 1;
        V3::ZERO
    }
}

/// One path for [`trace_paths`](super::trace_paths) to start.
pub struct PathStart {
    /// The camera ray: origin and unit direction.
    pub ray: (V3, V3),
    /// The path's generator, after drawing `ray`.
    pub rng: Rng,
}

/// The end of a step for a path with throughput `beta` at segment `depth`
/// (which it increments): `false` when the path ends, with zero throughput
/// or by Russian roulette (`eta_scale` corrects the throughput for the
/// indices crossed); a survivor's throughput is divided by its chance.
#[inline(always)]
pub(super) fn survives(
    beta: &mut V3,
    eta_scale: f32,
    depth: &mut u32,
    scene: &RenderScene,
    rng: &mut Rng,
    st: &mut Counters,
) -> bool {
    *depth += 1;
    // A path with zero throughput (a black reflectance: cylinder_refraction's
    // emitting plane) can add nothing more, and would still cost rays.
    // Same image: every later term would be multiplied by 0.
    if beta.max_element() <= 0.0 {
        st.ended_absorbed += 1;
        return false;
    }
    if *depth > scene.rr_depth {
        let q = (beta.max_element() * eta_scale).min(0.95);
        if rng.uniform() >= q {
            st.ended_roulette += 1;
            return false;
        }
        *beta /= q;
    }
    true
}

pub(super) fn path(
    tr: Tracer<'_>,
    org: V3,
    dir: V3,
    list: InteriorList,
    rng: &mut Rng,
    st: &mut Counters,
    first: Option<&mut CurvedRay>,
) -> Result<V3> {
    let mut p = PathState::new(org, dir, list);
    // Through a medium every segment is a curved ray, each started in the
    // storage of the last (a fresh one would be a copy of several hundred
    // bytes per segment).
    let mut spare = None;
    let mut curved = match (first, &tr.scene.medium) {
        (Some(c), _) => Some(c),
        (None, Some(m)) => Some(spare.insert(m.start_ray(org.as_dvec3(), dir.as_dvec3()))),
        (None, None) => None,
    };
    // Through a medium the segment is written in place (`cast_curved_into`).
    let mut seg = Segment::failed(&p.ray, 0.0, false);
    let mut coincident = dielectric::Coincident::NONE;
    loop {
        st.segments += 1;
        let sigma = tr.medium(&p.list);
        match (curved.as_deref_mut(), &tr.scene.medium) {
            (Some(c), Some(m)) => {
                cast_curved_into(tr, m, c, &p.ray, &mut p.list, st, &mut seg, &mut coincident)?
            }
            (c, _) => (seg, coincident) = cast(tr, &p.ray, &mut p.list, st, c)?,
        }
        let (shadow, go) = p.advance(tr, sigma, &seg, &coincident, None, rng, st);
        if let Some(sh) = shadow {
            if !tr.scene.embree.occluded(&sh.ray) {
                p.l += sh.contrib;
            }
        }
        if !go {
            break;
        }
        if let (Some(c), Some(m)) = (curved.as_deref_mut(), &tr.scene.medium) {
            m.restart_ray(c, p.ray.org.as_dvec3(), p.ray.dir.as_dvec3());
            if !p.only_specular {
                c.after_diffuse(m);
            }
        }
    }
    Ok(p.radiance(st))
}
