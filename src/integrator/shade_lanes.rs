//! The path tracer's shading of a packet's lanes side by side in vector
//! registers, for the lanes whose hit is Lambertian (any texture, any
//! light: the kernel samples a scene's single rectangle itself, and
//! [`ShadeLanes::prepare`] draws any other light's sample per lane), black,
//! a mirror, a smooth interface or the smooth boundary of a nested solid
//! (its index pair from the nested rule), rough glass of a GGX distribution
//! ([`rough`]), a smooth or GGX metal ([`conductor`]), a smooth or GGX
//! plastic ([`plastic`]), or a miss (weighed against next-event
//! estimation's sampling of a sun or a map); the wavefront gives the others
//! (Beckmann roughness, coincident solid surfaces) to the single-ray step
//! ([`ShadeLanes::prepare`] says which).
//!
//! The paths are the wavefront's columns ([`PathColumns`]): each lane goes
//! through three phases, as `PathState::advance` does for one path in turn:
//!
//! 1. [`ShadeLanes::prepare`] (scalar, per lane): the hit's material,
//!    texture and emission, the environment on a miss, and every random
//!    number the step draws, in the order `advance` draws them (so a path's
//!    numbers are the same whichever of the two shades it);
//! 2. the kernel (all lanes at once, f32, pulp's widest level): next-event
//!    estimation's point on the light, its weight and shadow ray, the
//!    cosine-weighted bounce, Fresnel reflectance, reflection and
//!    refraction, the spawn offsets and the throughput, read from and
//!    written back to the columns;
//! 3. [`ShadeLanes::finish`] (scalar, per lane): the shadow ray handed back,
//!    a transmitted path's interior list, the path's flags and Russian
//!    roulette.
//!
//! Arithmetic is f32 throughout (as Mitsuba's `llvm_ad_rgb`), where
//! `advance` solves Fresnel and Snell in f64: a path's radiance differs from
//! `advance`'s by rounding, and where a random number falls within rounding
//! of a Fresnel reflectance, or a direction within rounding of the critical
//! angle, the two pick different lobes (the tests bound how often).
use super::cast::NO_COINCIDENT;
use super::columns::{self, PacketPaths, MAX};
use super::light::PendingShadow;
use super::path::survives;
use super::Tracer;
use crate::bsdf::{RoughDielectric, RoughPlastic};
use crate::counters::Counters;
use crate::dielectric::{self, Coincident, InteriorList};
use crate::ray::{front_facing, spawn_transmitted, Hit, Ray};
use crate::sampling::{power_heuristic, Rng};
use crate::scene::{Light, Material, RenderScene, SurfacePoint};
use conductor::ConductorParams;
use glam::Vec3A as V3;
use kernel::Kernel;
use plastic::PlasticLaneParams;
use std::sync::Arc;

/// What [`ShadeLanes::prepare`] left for a lane.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Prepared {
    /// The path ended in the scalar phase (a miss, an absorbing surface,
    /// the depth limit).
    Ended,
    /// The lane waits for the kernel.
    Kernel,
    /// The kernel cannot shade this lane (nothing was done to it): the
    /// single-ray step shades it.
    Alone,
}

/// Lanes the kernel's stage holds: eight packets' worth (it is shaded
/// once another packet might not fit: [`ShadeLanes::full`]), so that its
/// vectors are nearly all full whatever share of each packet's lanes ended
/// or went alone.
pub(super) const STAGE: usize = 8 * MAX;

/// [`ShadeLanes::moves`]: the boundary changes the path's interior list.
const NEW_LIST: u8 = 1;
/// [`ShadeLanes::moves`]: the boundary is index-matched.
const MATCHED: u8 = 2;

/// The single rectangular light of a scene in the class, as the kernel
/// samples it (`RenderScene::sample_light`).
#[derive(Clone, Copy)]
struct RectLight {
    corner: V3,
    edge_u: V3,
    edge_v: V3,
    normal: V3,
    area: f32,
    radiance: V3,
}

/// A packet's lanes between the phases, component by component.
pub(super) struct ShadeLanes {
    /// Lanes staged for the kernel (prepared, not yet shaded): entries
    /// `0..count` of the arrays below, from any packets of the step.
    pub(super) count: usize,
    /// Each staged lane's path: its place in the wavefront's columns.
    pub(super) at: [u32; STAGE],
    /// The staged lanes' rays' directions and throughputs, and Russian
    /// roulette's index correction; the kernel writes the next ray's
    /// direction, origin and throughput in their place.
    dir: [[f32; STAGE]; 3],
    org: [[f32; STAGE]; 3],
    beta: [[f32; STAGE]; 3],
    eta_scale: [f32; STAGE],
    /// Per lane: 1 for a Lambertian hit, 0 for a smooth interface, 2 for
    /// rough glass, 3 for a rough metal, 4 for a smooth metal, 5 for a
    /// mirror, 6 for a smooth plastic, 7 for a rough plastic; −1 past the
    /// staged lanes.
    diffuse: [f32; STAGE],
    /// Lambertian, rough and plastic lanes that drew a light sample.
    nee: [f32; STAGE],
    /// Interface lanes past the critical angle (no random number drawn).
    tir: [f32; STAGE],
    p: [[f32; STAGE]; 3],
    /// The geometric normal on the incident side.
    side: [[f32; STAGE]; 3],
    /// The shading normal on the incident side.
    n: [[f32; STAGE]; 3],
    /// The reflectance of a Lambertian lane or a mirror; a plastic lane's
    /// base albedo after internal scattering.
    albedo: [[f32; STAGE]; 3],
    n1: [f32; STAGE],
    n2: [f32; STAGE],
    /// The step's random numbers: the light's two (`u[0]`, `u[1]`) and the
    /// bounce's two (`u[2]`, `u[3]`) at a Lambertian lane, the lobe's
    /// (`u[0]`) at a smooth interface, the light's two and the lobe's and
    /// direction's three (`u[2..5]`) at rough glass, metals and plastics.
    u: [[f32; STAGE]; 5],
    /// Rough glass, metal and plastic lanes' roughnesses along the frame's
    /// two tangents (a plastic's only in `alpha[0]`: it is isotropic).
    alpha: [[f32; STAGE]; 2],
    /// Metal lanes' complex index η + iκ and reflectance factor; a plastic
    /// lane's coating index ratio in `eta[0]` and reflectance factor.
    eta: [[f32; STAGE]; 3],
    kappa: [[f32; STAGE]; 3],
    spec: [[f32; STAGE]; 3],
    /// Plastic lanes' lobe weight s (`PlasticTerms`).
    lobe_weight: [f32; STAGE],
    /// Rough plastic lanes' coating: its place in `coatings`.
    coat: [u32; STAGE],
    /// The rough plastics met since [`ShadeLanes::start`], whose
    /// transmittance tables the kernel reads.
    coatings: Vec<Arc<RoughPlastic>>,
    /// A light sample drawn in [`ShadeLanes::prepare`] (any light but the
    /// kernel's rectangle): its direction, distance, radiance and density;
    /// `ls_delta` 1 for a point or directional light (no MIS).
    ls_wi: [[f32; STAGE]; 3],
    ls_dist: [f32; STAGE],
    ls_li: [[f32; STAGE]; 3],
    ls_pdf: [f32; STAGE],
    ls_delta: [f32; STAGE],
    // The kernel's answers (besides the next rays and throughputs above).
    prev_pdf: [f32; STAGE],
    /// The bounce fell below the surface: the path ends.
    below: [f32; STAGE],
    /// 1: the connection needs its shadow ray; 2: too short to hold
    /// anything, its contribution counts as it is; 0: none.
    shadow: [f32; STAGE],
    shadow_org: [[f32; STAGE]; 3],
    shadow_dir: [[f32; STAGE]; 3],
    shadow_tfar: [f32; STAGE],
    contrib: [[f32; STAGE]; 3],
    /// Interface lanes the kernel transmitted (1) or reflected (0).
    transmit: [f32; STAGE],
    /// Lanes whose sample is a delta reflection (a smooth plastic's
    /// coating): the path's next vertex is weighed as after a mirror.
    delta: [f32; STAGE],
    /// What a transmission does at an interface lane besides the kernel's
    /// ray: [`NEW_LIST`], [`MATCHED`] (0 for most, whose other entries below
    /// are then stale).
    moves: [u8; STAGE],
    /// The interior list a transmission carries ([`NEW_LIST`]).
    after: [Option<InteriorList>; STAGE],
    /// The transmitted ray through an index-matched boundary ([`MATCHED`]):
    /// its own line continued, or spawned off the hit along its direction.
    matched: [Option<Ray>; STAGE],
    arch: pulp::Arch,
    /// The scene's only light when it is a rectangle (and the environment
    /// is not sampled): the kernel samples it itself. Otherwise `prepare`
    /// draws each lane's light sample with `RenderScene::sample_light`.
    light: Option<RectLight>,
    /// Some path continued its line through an index-matched boundary
    /// (`PathScalars::tnear`) since [`ShadeLanes::start`].
    pub(super) lined: bool,
    /// The render tests' known-wrong variant.
    #[cfg(test)]
    variant: crate::scene::model::BsdfVariant,
}

impl Default for ShadeLanes {
    fn default() -> Self {
        let one = [0.0; STAGE];
        let three = [one; 3];
        ShadeLanes {
            count: 0,
            at: [0; STAGE],
            dir: three,
            org: three,
            beta: three,
            eta_scale: one,
            diffuse: one,
            nee: one,
            tir: one,
            p: three,
            side: three,
            n: three,
            albedo: three,
            n1: one,
            n2: one,
            u: [one; 5],
            alpha: [one; 2],
            eta: three,
            kappa: three,
            spec: three,
            lobe_weight: one,
            coat: [0; STAGE],
            coatings: Vec::new(),
            ls_wi: three,
            ls_dist: one,
            ls_li: three,
            ls_pdf: one,
            ls_delta: one,
            prev_pdf: one,
            below: one,
            shadow: one,
            shadow_org: three,
            shadow_dir: three,
            shadow_tfar: one,
            contrib: three,
            transmit: one,
            delta: one,
            moves: [0; STAGE],
            after: std::array::from_fn(|_| None),
            matched: [None; STAGE],
            arch: pulp::Arch::default(),
            light: None,
            lined: false,
            #[cfg(test)]
            variant: Default::default(),
        }
    }
}

fn set3(a: &mut [[f32; STAGE]; 3], i: usize, v: V3) {
    a[0][i] = v.x;
    a[1][i] = v.y;
    a[2][i] = v.z;
}

fn get3(a: &[[f32; STAGE]; 3], i: usize) -> V3 {
    V3::new(a[0][i], a[1][i], a[2][i])
}

impl ShadeLanes {
    /// Ready for a step of `scene` (once per wavefront).
    pub(super) fn start(&mut self, scene: &RenderScene) {
        #[cfg(test)]
        {
            self.variant = scene.bsdf_variant;
        }
        self.light = match scene.lights.as_slice() {
            [Light::Rect {
                corner,
                edge_u,
                edge_v,
                normal,
                area,
                radiance,
            }] if !scene.environment.is_sampled() => Some(RectLight {
                corner: *corner,
                edge_u: *edge_u,
                edge_v: *edge_v,
                normal: *normal,
                area: *area,
                radiance: *radiance,
            }),
            _ => None,
        };
        self.lined = false;
        // (The stage is empty: no lane refers to them.)
        self.coatings.clear();
    }

    /// Phase 1 for lane `i` of `paths`, whose segment along its ray was
    /// just cast (`sigma`: the absorption of the medium it crossed; `at`: its
    /// hit and surface point, `None` for a miss; `coincident`: the solid
    /// surfaces at the hit). Emission and a miss are added to the path here,
    /// a boundary's index pair resolved (the path's list updated for the hit
    /// itself), the step's random numbers drawn, and what the kernel needs
    /// stored. [`Prepared::Alone`] before any of that when the kernel cannot
    /// shade the lane.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn prepare<const N: usize>(
        &mut self,
        i: usize,
        place: usize,
        tr: Tracer<'_>,
        paths: &mut PacketPaths<'_, N>,
        sigma: Option<V3>,
        at: Option<(&Hit, &SurfacePoint)>,
        coincident: &Coincident,
        st: &mut Counters,
    ) -> Prepared {
        let scene = tr.scene;
        // The lane's place in the kernel's stage, if it goes there.
        let j = self.count;
        let dir = columns::get3(&paths.dir, i);
        let Some((hit, sp)) = at else {
            // Weighed against next-event estimation's sampling of the sun or
            // a map after a diffuse vertex, as `advance` weighs it. (A path
            // that escapes inside an absorbing solid brings nothing.)
            if sigma.is_none() {
                let beta = columns::get3(&paths.beta, i);
                let mis = (!paths.s[i].specular).then_some((paths.s[i].prev_pdf, 1.0));
                paths.s[i].l += beta * scene.escaped_radiance(dir, mis);
            }
            st.ended_escaped += 1;
            return Prepared::Ended;
        };
        // Solid surfaces coincident with the hit, or passing near it, are
        // crossed and settled by the single-ray step.
        if !std::ptr::eq(coincident, &NO_COINCIDENT) && *coincident != Coincident::NONE {
            return Prepared::Alone;
        }
        let rec = &scene.geoms[hit.geom_id as usize];
        let front = front_facing(sp.ng, dir);
        // What the kernel does at this hit: `None` for the single-ray step.
        let albedo = match &rec.material {
            Material::Diffuse {
                reflectance,
                two_sided,
            } if front || *two_sided => Some(reflectance.eval(sp.p, sp.uv)),
            Material::Diffuse { .. } | Material::Black | Material::Interface { .. } | Material::Solid(_) => {
                None
            }
            // Rough glass of a distribution the kernel models (GGX).
            Material::RoughInterface { distribution, .. } | Material::RoughSolid { distribution, .. }
                if rough::supports(distribution) =>
            {
                None
            }
            Material::Mirror { .. } => None,
            // Smooth metals and GGX ones.
            m @ (Material::Conductor { .. } | Material::RoughConductor { .. })
                if ConductorParams::of(m).is_some() =>
            {
                None
            }
            // Smooth plastics and GGX ones.
            m @ (Material::Plastic { .. } | Material::RoughPlastic { .. })
                if PlasticLaneParams::of(m).is_some() =>
            {
                None
            }
            _ => return Prepared::Alone,
        };
        let mut beta = columns::get3(&paths.beta, i);
        if let Some(s) = sigma {
            beta *= (-s * (hit.t - paths.s[i].tnear)).exp();
            columns::set3(&mut paths.beta, i, beta);
        }
        if let Some(em) = &rec.emission {
            if front || rec.emission_two_sided {
                let le = em.eval(sp.p, sp.uv);
                let w = match rec.light {
                    Some(li) if !paths.s[i].specular => {
                        let lp = scene.light_pdf(li, paths.s[i].prev_p, sp.p, sp.ng, dir);
                        power_heuristic(paths.s[i].prev_pdf, lp)
                    }
                    _ => 1.0,
                };
                paths.s[i].l += beta * le * w;
            }
        }
        let rng = &mut paths.s[i].rng;
        if paths.s[i].depth >= scene.max_depth {
            st.ended_max_depth += 1;
            return Prepared::Ended;
        }
        let side = if front { sp.ng } else { -sp.ng };
        let n = if front { sp.ns } else { -sp.ns };
        match (&rec.material, albedo) {
            (Material::Diffuse { .. }, Some(albedo)) => {
                st.nee_draws += (albedo != V3::ZERO) as u64;
                let nee = albedo != V3::ZERO && self.draw_light(j, scene, sp.p, rng);
                // A black reflectance ends the path without a bounce (as `advance`).
                if albedo == V3::ZERO && beta.is_finite() {
                    st.ended_absorbed += 1;
                    return Prepared::Ended;
                }
                self.u[2][j] = rng.uniform();
                self.u[3][j] = rng.uniform();
                self.diffuse[j] = 1.0;
                self.nee[j] = if nee { 1.0 } else { 0.0 };
                set3(&mut self.albedo, j, albedo);
            }
            (
                m @ (Material::Interface { .. }
                | Material::Solid(_)
                | Material::RoughInterface { .. }
                | Material::RoughSolid { .. }),
                _,
            ) => {
                let Some(boundary) = tr.boundary(m, front, coincident, &mut paths.lists[i]) else {
                    st.ended_absorbed += 1;
                    return Prepared::Ended;
                };
                let (n1, n2) = (boundary.n1, boundary.n2);
                #[cfg(test)]
                let (n1, n2) = self.wrong_pair(scene, m, boundary.entering, (n1, n2));
                self.n1[j] = n1;
                self.n2[j] = n2;
                // Rough glass as `Bsdf::at` makes it: the smooth boundary
                // where the indices match (the model degenerates there).
                let rough = match m {
                    Material::RoughInterface { distribution, .. }
                    | Material::RoughSolid { distribution, .. } => Some(*distribution)
                        .filter(|d| n1 != n2 && RoughDielectric::try_new(*d, n1, n2).is_ok()),
                    _ => None,
                };
                if let Some(distribution) = rough {
                    self.draw_micro(j, scene, sp.p, rng, true, st);
                    self.alpha[0][j] = distribution.alpha_u();
                    self.alpha[1][j] = distribution.alpha_v();
                    self.moves[j] = match boundary.into_transmitted() {
                        Some(list) => {
                            self.after[j] = Some(list);
                            NEW_LIST
                        }
                        None => 0,
                    };
                    self.diffuse[j] = 2.0;
                    set3(&mut self.p, j, sp.p);
                    set3(&mut self.side, j, side);
                    set3(&mut self.n, j, n);
                    self.stage(place, dir, beta, paths.eta_scale[i]);
                    return Prepared::Kernel;
                }
                // Past the critical angle no number is drawn (`Interface::sample`).
                let cos_i = dir.dot(n).abs().min(1.0);
                let eta = n1 / n2;
                let tir = eta * eta * (1.0 - cos_i * cos_i).max(0.0) > 1.0;
                if tir {
                    st.tir += 1;
                } else {
                    self.u[0][j] = rng.uniform();
                }
                // Through an index-matched boundary the path goes on along
                // its own line (`ray::spawn_transmitted`), not from an offset.
                let mut moves = 0;
                if n1 == n2 {
                    let ray = paths.ray(i);
                    let line = dielectric::keeps_line(scene).then_some((&ray, hit.t));
                    self.matched[j] = Some(spawn_transmitted(sp.p, -side, dir, dir, (n1, n2), line));
                    moves |= MATCHED;
                }
                if let Some(list) = boundary.into_transmitted() {
                    self.after[j] = Some(list);
                    moves |= NEW_LIST;
                }
                self.moves[j] = moves;
                self.diffuse[j] = 0.0;
                self.tir[j] = if tir { 1.0 } else { 0.0 };
            }
            (Material::Mirror { reflectance }, _) => {
                // A perfect mirror draws nothing.
                set3(&mut self.albedo, j, *reflectance);
                self.diffuse[j] = 5.0;
            }
            (m @ (Material::Conductor { .. } | Material::RoughConductor { .. }), _) => {
                let Some(c) = ConductorParams::of(m).filter(|c| front || c.two_sided) else {
                    // Black from behind (one-sided).
                    st.ended_absorbed += 1;
                    return Prepared::Ended;
                };
                // A smooth metal has no light sample (only a delta lobe);
                // its lobe's number is drawn and not used.
                self.draw_micro(j, scene, sp.p, rng, !c.smooth, st);
                set3(&mut self.eta, j, c.eta);
                set3(&mut self.kappa, j, c.k);
                set3(&mut self.spec, j, c.specular_reflectance);
                self.alpha[0][j] = c.alpha_u;
                self.alpha[1][j] = c.alpha_v;
                self.diffuse[j] = if c.smooth { 4.0 } else { 3.0 };
            }
            (m @ (Material::Plastic { .. } | Material::RoughPlastic { .. }), _) => {
                let Some(c) = PlasticLaneParams::of(m).filter(|c| front || c.two_sided) else {
                    // Black from behind (one-sided).
                    st.ended_absorbed += 1;
                    return Prepared::Ended;
                };
                // Even a smooth plastic's light sample: its diffuse lobe has a density.
                self.draw_micro(j, scene, sp.p, rng, true, st);
                let t = c.terms;
                self.eta[0][j] = t.eta;
                set3(&mut self.albedo, j, t.base.into());
                set3(&mut self.spec, j, t.specular.into());
                self.lobe_weight[j] = t.specular_sampling_weight;
                self.alpha[0][j] = c.alpha;
                self.diffuse[j] = match c.rough {
                    Some(r) => {
                        self.coat[j] = self.coating(r);
                        7.0
                    }
                    None => 6.0,
                };
            }
            _ => {
                // Black, or a one-sided diffuse surface seen from behind.
                st.ended_absorbed += 1;
                return Prepared::Ended;
            }
        }
        set3(&mut self.p, j, sp.p);
        set3(&mut self.side, j, side);
        set3(&mut self.n, j, n);
        self.stage(place, dir, beta, paths.eta_scale[i]);
        Prepared::Kernel
    }

    /// The lane just prepared joins the stage (`place`: its path's place
    /// in the wavefront), with its ray's direction and its throughput.
    #[inline(always)]
    fn stage(&mut self, place: usize, dir: V3, beta: V3, eta_scale: f32) {
        let j = self.count;
        self.at[j] = place as u32;
        set3(&mut self.dir, j, dir);
        set3(&mut self.beta, j, beta);
        self.eta_scale[j] = eta_scale;
        self.count += 1;
    }

    /// `Micro`'s draws for lane `j` at `p`, in its order: next-event
    /// estimation's (where `nee`: the model has a lobe with a density),
    /// then the sample's three (the lobe's, then the direction's two).
    #[inline(always)]
    fn draw_micro(
        &mut self,
        j: usize,
        scene: &RenderScene,
        p: V3,
        rng: &mut Rng,
        nee: bool,
        st: &mut Counters,
    ) {
        let drew = nee && {
            st.nee_draws += 1;
            self.draw_light(j, scene, p, rng)
        };
        self.nee[j] = if drew { 1.0 } else { 0.0 };
        for k in 2..5 {
            self.u[k][j] = rng.uniform();
        }
    }

    /// The place of the rough plastic `p` in the coatings the kernel reads
    /// (added when first met).
    #[inline(always)]
    fn coating(&mut self, p: &Arc<RoughPlastic>) -> u32 {
        let i = match self.coatings.iter().position(|q| Arc::ptr_eq(p, q)) {
            Some(i) => i,
            None => {
                self.coatings.push(Arc::clone(p));
                self.coatings.len() - 1
            }
        };
        i as u32
    }

    /// Next-event estimation's draw for lane `i` at `p`, as `next_event`
    /// draws (no medium here for a connection to meet): the kernel's
    /// rectangle's numbers, or any other light's sample. `false`: no sample.
    #[inline(always)]
    fn draw_light(&mut self, i: usize, scene: &RenderScene, p: V3, rng: &mut Rng) -> bool {
        if self.light.is_some() {
            // The light's choice (one light: drawn, not read), then its point.
            rng.uniform();
            self.u[0][i] = rng.uniform();
            self.u[1][i] = rng.uniform();
            return true;
        }
        let Some(ls) = scene.sample_light(p, rng) else {
            return false;
        };
        set3(&mut self.ls_wi, i, ls.wi);
        set3(&mut self.ls_li, i, ls.li);
        self.ls_dist[i] = ls.dist;
        self.ls_pdf[i] = ls.pdf;
        self.ls_delta[i] = if ls.delta { 1.0 } else { 0.0 };
        true
    }

    /// The known-wrong variants the kernel can be (tests only): next-event
    /// estimation weighed against twice the bounce's density, an interface
    /// reflecting with half its Fresnel reflectance, and next-event
    /// estimation without the cosine at the point, and a transmitted
    /// connection through rough glass with its radiance scale twice.
    #[inline(always)]
    fn wrong(&self) -> (bool, bool, bool, bool) {
        #[cfg(test)]
        {
            use crate::scene::model::BsdfVariant;
            (
                self.variant == BsdfVariant::WrongMisPdf,
                self.variant == BsdfVariant::WrongHalfFresnel,
                self.variant == BsdfVariant::WrongNeeCosine,
                self.variant == BsdfVariant::WrongDoubleScale,
            )
        }
        #[cfg(not(test))]
        (false, false, false, false)
    }

    /// Rough glass's model in the kernel: the right one, or the render
    /// tests' known-wrong one.
    #[inline(always)]
    fn rough_variant(&self) -> rough::Variant {
        #[cfg(test)]
        {
            use crate::scene::model::BsdfVariant;
            match self.variant {
                BsdfVariant::WrongRoughFresnel => return rough::Variant::HalfFresnel,
                BsdfVariant::WrongJacobian => return rough::Variant::ReflectionJacobian,
                _ => {}
            }
        }
        rough::Variant::Right
    }

    /// Metals' model in the kernel: the right one, or the render tests'
    /// known-wrong one.
    #[inline(always)]
    fn metal_variant(&self) -> conductor::Variant {
        #[cfg(test)]
        if self.variant == crate::scene::model::BsdfVariant::WrongMetalFresnel {
            return conductor::Variant::NoAbsorption;
        }
        conductor::Variant::Right
    }

    /// Plastics' model in the kernel: the right one, or the render tests'
    /// known-wrong one.
    #[inline(always)]
    fn plastic_variant(&self) -> plastic::Variant {
        #[cfg(test)]
        if self.variant == crate::scene::model::BsdfVariant::WrongPlasticFresnel {
            return plastic::Variant::HalfFresnel;
        }
        plastic::Variant::Right
    }

    /// The render tests' known-wrong nested boundary: a solid's index pair
    /// against the ambient medium, as if no other solid held the path
    /// (air → water at a glass-water boundary).
    #[cfg(test)]
    fn wrong_pair(&self, scene: &RenderScene, m: &Material, entering: bool, pair: (f32, f32)) -> (f32, f32) {
        match m {
            Material::Solid(s) if self.variant == crate::scene::model::BsdfVariant::WrongNestedPair => {
                let (ior, amb) = (scene.solids[*s as usize].ior, scene.ambient_ior);
                if entering {
                    (amb, ior)
                } else {
                    (ior, amb)
                }
            }
            _ => pair,
        }
    }

    /// Should the stage be shaded before another packet's lanes are
    /// prepared (no room for a whole packet of `n` more)?
    #[inline(always)]
    pub(super) fn full(&self, n: usize) -> bool {
        self.count > STAGE - n
    }

    /// Phase 2: the kernel over the staged lanes; returns the vector lanes
    /// it computed (whole vectors). The stage is emptied by the caller's
    /// [`ShadeLanes::finish`] of each lane and [`ShadeLanes::clear`].
    pub(super) fn shade(&mut self) -> usize {
        // Lanes past the staged ones, in the last vector, are of no kind.
        self.diffuse[self.count..].fill(-1.0);
        let arch = self.arch;
        let lanes = self.count;
        arch.dispatch(Kernel { s: self, lanes })
    }

    /// After the staged lanes' [`ShadeLanes::finish`]: an empty stage.
    #[inline(always)]
    pub(super) fn clear(&mut self) {
        self.count = 0;
    }

    /// Phase 3 for lane `i` of `paths`, which `prepare` sent to the kernel: the
    /// connection (a shadow ray to resolve before the next segment, or a
    /// contribution added now), the path's flags, Russian roulette. `false`:
    /// the path has ended.
    #[inline(always)]
    pub(super) fn finish<const N: usize>(
        &mut self,
        j: usize,
        i: usize,
        scene: &RenderScene,
        paths: &mut PacketPaths<'_, N>,
        st: &mut Counters,
    ) -> (Option<PendingShadow>, bool) {
        let mut shadow = None;
        // The kernel's next ray and throughput (a ray through an
        // index-matched boundary is set again below).
        columns::set3(&mut paths.dir, i, get3(&self.dir, j));
        columns::set3(&mut paths.org, i, get3(&self.org, j));
        columns::set3(&mut paths.beta, i, get3(&self.beta, j));
        paths.eta_scale[i] = self.eta_scale[j];
        let kind = self.diffuse[j];
        // Lambertian, rough glass, rough metal and plastic lanes: a light
        // sample each, and (but a smooth plastic's coating reflection) a
        // bounce drawn from a density.
        let lit = kind == 1.0 || kind == 2.0 || kind == 3.0 || kind == 6.0 || kind == 7.0;
        if lit && self.shadow[j] != 0.0 {
            st.shadow_rays += 1;
            let contrib = get3(&self.contrib, j);
            if self.shadow[j] == 2.0 {
                paths.s[i].l += contrib;
            } else {
                let mut ray = Ray::new(get3(&self.shadow_org, j), get3(&self.shadow_dir, j));
                ray.tfar = self.shadow_tfar[j];
                shadow = Some(PendingShadow { ray, contrib });
            }
        }
        // No direction drawn (a sample below the surface): the path ends.
        if self.below[j] != 0.0 {
            st.ended_absorbed += 1;
            return (shadow, false);
        }
        paths.s[i].tnear = 0.0;
        if lit && self.delta[j] == 0.0 {
            paths.s[i].prev_pdf = self.prev_pdf[j];
            paths.s[i].specular = false;
            paths.s[i].only_specular = false;
        } else {
            paths.s[i].specular = true;
        }
        // A transmission through a boundary (smooth or rough).
        if (kind == 0.0 || kind == 2.0) && self.transmit[j] != 0.0 && self.moves[j] != 0 {
            if let Some(list) = self.after[j].take().filter(|_| self.moves[j] & NEW_LIST != 0) {
                #[cfg(test)]
                let list = if self.variant == crate::scene::model::BsdfVariant::WrongNestedList {
                    paths.lists[i].clone()
                } else {
                    list
                };
                paths.lists[i] = list;
            }
            if let Some(ray) = self.matched[j].filter(|_| self.moves[j] & MATCHED != 0) {
                paths.set_ray(i, &ray);
                self.lined |= ray.tnear != 0.0;
            }
        }
        paths.s[i].prev_p = get3(&self.p, j);
        let mut beta = columns::get3(&paths.beta, i);
        let go = survives(
            &mut beta,
            paths.eta_scale[i],
            &mut paths.s[i].depth,
            scene,
            &mut paths.s[i].rng,
            st,
        );
        columns::set3(&mut paths.beta, i, beta);
        (shadow, go)
    }
}

mod conductor;
mod ggx;
mod kernel;
#[cfg(test)]
mod lane_check;
mod lane_math;
mod plastic;
mod rough;

#[cfg(test)]
mod tests;
