//! The one shading model: what a material does with light arriving at a hit
//! (pbrt's `GetBSDF` and `Sample_f`), built once per hit by [`Bsdf::at`] and
//! used by the path tracer (single rays and lanes) and the Whitted preview.
//! A new material is a new variant here; the integrators only ask it for
//! directions, weights and densities.
use super::Tracer;
use crate::bsdf::{Conductor, Frame, Plastic, RoughConductor, RoughDielectric, RoughPlastic};
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList};
use crate::optics;
use crate::ray::front_facing;
use crate::sampling::{cosine_hemisphere, Rng};
#[cfg(test)]
use crate::scene::model::BsdfVariant;
use crate::scene::{Material, SurfacePoint};
use glam::{DVec3, Vec2, Vec3, Vec3A as V3};
use std::f32::consts::FRAC_1_PI;

/// A material's response at one hit, oriented to the side the light arrives
/// from (every normal here points back towards the incident ray).
pub(super) enum Bsdf<'a> {
    /// Nothing leaves: a black material, a one-sided diffuse surface seen
    /// from behind, or a boundary the nested rule ends the path at.
    Black,
    /// Lambertian reflection.
    Diffuse(Lambert),
    /// Perfect specular reflection.
    Mirror(Mirror),
    /// A smooth dielectric boundary: Fresnel reflection or refraction.
    Dielectric(Interface),
    /// A model of [`crate::bsdf`]: rough glass, metals, plastics.
    Micro(Micro<'a>),
}

/// Which model of [`crate::bsdf`] a [`Micro`] evaluates.
pub(super) enum MicroModel<'a> {
    RoughDielectric(RoughDielectric),
    Conductor(Conductor),
    RoughConductor(RoughConductor),
    Plastic(Plastic),
    RoughPlastic(&'a RoughPlastic),
}

/// A [`crate::bsdf`] model at a hit, in the local frame about the shading
/// normal oriented to the incident side (`wo.z` > 0 but where a shading
/// normal leans past the surface).
pub(super) struct Micro<'a> {
    pub model: MicroModel<'a>,
    pub frame: Frame,
    /// The direction back along the incident ray, local.
    pub wo: Vec3,
    /// The geometric normal on the incident side.
    pub side: V3,
    /// A rough dielectric's boundary event: the list a transmission carries.
    pub boundary: Option<dielectric::Boundary>,
}

/// A direction drawn by [`Micro::sample`], in world space.
pub(super) struct MicroSample {
    pub wi: V3,
    /// f·|cos| / pdf (a delta lobe: its reflectance over its probability).
    pub weight: V3,
    pub pdf: f32,
    pub is_transmission: bool,
    pub is_delta: bool,
}

/// Lambertian reflection of `albedo` about the shading normal `n`, above the
/// geometric normal `ng`.
pub(super) struct Lambert {
    pub albedo: V3,
    pub n: V3,
    pub ng: V3,
}

/// Perfect reflection of `reflectance` into `wi`, leaving on the side `side`.
pub(super) struct Mirror {
    pub reflectance: V3,
    pub wi: V3,
    pub side: V3,
}

/// A smooth dielectric boundary met along `d` (f64: Fresnel and Snell in
/// double precision) with shading normal `n` and the indices of the nested
/// rule's `boundary`.
pub(super) struct Interface {
    pub boundary: dielectric::Boundary,
    /// Fresnel reflectance.
    pub fresnel: f64,
    /// The geometric normal on the incident side.
    pub side: V3,
    /// The refracted direction (`None`: total internal reflection).
    pub refracted: Option<V3>,
    d: DVec3,
    n: DVec3,
}

/// Which way [`Interface::sample`] sends the path.
pub(super) enum Lobe {
    Reflect(V3),
    Transmit(V3),
}

impl<'a> Bsdf<'a> {
    /// The response of `material` at `sp` to light arriving along `dir`. A dielectric boundary is
    /// resolved against the path's interior `list` (the nested rule may
    /// change it) and counts its total internal reflections in `st`.
    #[inline(always)]
    pub fn at(
        tr: Tracer<'_>,
        material: &'a Material,
        sp: &SurfacePoint,
        dir: V3,
        coincident: &dielectric::Coincident,
        list: &mut InteriorList,
        st: &mut Counters,
    ) -> Bsdf<'a> {
        let front = front_facing(sp.ng, dir);
        let side = if front { sp.ng } else { -sp.ng };
        let n = if front { sp.ns } else { -sp.ns };
        match material {
            Material::Black => Bsdf::Black,
            Material::Diffuse {
                reflectance,
                two_sided,
            } => {
                if !front && !two_sided {
                    return Bsdf::Black;
                }
                Bsdf::Diffuse(Lambert {
                    albedo: reflectance.eval(sp.p, sp.uv),
                    n,
                    ng: side,
                })
            }
            Material::Mirror { reflectance } => Bsdf::Mirror(Mirror {
                reflectance: *reflectance,
                wi: optics::reflect(dir.as_dvec3(), n.as_dvec3())
                    .normalize()
                    .as_vec3a(),
                side,
            }),
            m @ (Material::Interface { .. } | Material::Solid(_)) => {
                let Some(boundary) = tr.boundary(m, front, coincident, list) else {
                    return Bsdf::Black;
                };
                // The unoriented shading normal: Fresnel takes |cos|, and
                // `optics::refract` orients it itself.
                Bsdf::Dielectric(Interface::new(boundary, dir, sp.ns, side, st))
            }
            m @ (Material::RoughInterface { distribution, .. }
            | Material::RoughSolid { distribution, .. }) => {
                let Some(boundary) = tr.boundary(m, front, coincident, list) else {
                    return Bsdf::Black;
                };
                // An index-matched boundary scatters nothing (the microfacet
                // model degenerates to a delta there): the smooth pass-through.
                let model = match RoughDielectric::try_new(*distribution, boundary.n1, boundary.n2) {
                    Ok(m) if boundary.n1 != boundary.n2 => m,
                    _ => return Bsdf::Dielectric(Interface::new(boundary, dir, sp.ns, side, st)),
                };
                Bsdf::Micro(Micro::new(
                    MicroModel::RoughDielectric(model),
                    n,
                    dir,
                    side,
                    Some(boundary),
                ))
            }
            Material::Conductor { bsdf, two_sided } => {
                Micro::one_sided(front, *two_sided, MicroModel::Conductor(*bsdf), n, dir, side)
            }
            Material::RoughConductor { bsdf, two_sided } => {
                Micro::one_sided(front, *two_sided, MicroModel::RoughConductor(*bsdf), n, dir, side)
            }
            Material::Plastic { bsdf, two_sided } => {
                Micro::one_sided(front, *two_sided, MicroModel::Plastic(*bsdf), n, dir, side)
            }
            Material::RoughPlastic { bsdf, two_sided } => {
                Micro::one_sided(front, *two_sided, MicroModel::RoughPlastic(bsdf), n, dir, side)
            }
        }
    }
}

impl Interface {
    /// The smooth boundary `boundary` met along `dir` with shading normal
    /// `ns` (either orientation), the geometric normal on the incident side
    /// being `side`; a total internal reflection is counted in `st`.
    #[inline(always)]
    pub fn new(boundary: dielectric::Boundary, dir: V3, ns: V3, side: V3, st: &mut Counters) -> Interface {
        let d = dir.as_dvec3();
        let n = ns.as_dvec3();
        let fresnel = optics::fresnel_dielectric(d.dot(n).abs(), boundary.n1 as f64, boundary.n2 as f64);
        let refracted = refracted(d, n, side, boundary.n1, boundary.n2);
        if refracted.is_none() {
            st.tir += 1;
        }
        Interface {
            boundary,
            fresnel,
            side,
            refracted,
            d,
            n,
        }
    }
}

impl<'a> Micro<'a> {
    /// `model` about the oriented shading normal `n`, met along `dir`.
    pub(super) fn new(
        model: MicroModel<'a>,
        n: V3,
        dir: V3,
        side: V3,
        boundary: Option<dielectric::Boundary>,
    ) -> Micro<'a> {
        let frame = Frame::from_normal(Vec3::from(n));
        Micro {
            model,
            wo: frame.to_local(Vec3::from(-dir)),
            frame,
            side,
            boundary,
        }
    }

    /// A one-sided model (black from behind unless `two_sided`).
    fn one_sided(front: bool, two_sided: bool, model: MicroModel<'a>, n: V3, dir: V3, side: V3) -> Bsdf<'a> {
        if !front && !two_sided {
            return Bsdf::Black;
        }
        Bsdf::Micro(Micro::new(model, n, dir, side, None))
    }

    /// Only delta lobes (a smooth metal): nothing for next-event estimation.
    #[inline]
    pub fn is_delta(&self) -> bool {
        matches!(self.model, MicroModel::Conductor(_))
    }

    /// f(wo, wi)·|cos θi| and the density of [`Micro::sample`] at the world
    /// direction `wi`; zero where the geometric normal puts `wi` on the other
    /// side from the shading frame's (no light leaks through a leaning normal).
    #[inline]
    pub fn eval(&self, wi: V3) -> (V3, f32) {
        let local = self.frame.to_local(Vec3::from(wi));
        let geometric_reflection = wi.dot(self.side) > 0.0;
        if (local.z * self.wo.z > 0.0) != geometric_reflection {
            return (V3::ZERO, 0.0);
        }
        let wo = self.wo;
        let (f, pdf) = match &self.model {
            MicroModel::RoughDielectric(m) => (m.f(wo, local), m.pdf(wo, local)),
            MicroModel::Conductor(m) => (m.f(wo, local), m.pdf(wo, local)),
            MicroModel::RoughConductor(m) => (m.f(wo, local), m.pdf(wo, local)),
            MicroModel::Plastic(m) => (m.f(wo, local), m.pdf(wo, local)),
            MicroModel::RoughPlastic(m) => (m.f(wo, local), m.pdf(wo, local)),
        };
        (V3::from(f * local.z.abs()), pdf)
    }

    /// A direction from the model's own sampling (three random numbers,
    /// always drawn); `None` where the model gives none or the geometric
    /// normal disagrees with its side.
    #[inline]
    pub fn sample(&self, rng: &mut Rng) -> Option<MicroSample> {
        let u_lobe = rng.uniform();
        let u = Vec2::new(rng.uniform(), rng.uniform());
        let wo = self.wo;
        let s = match &self.model {
            MicroModel::RoughDielectric(m) => m.sample(wo, u_lobe, u),
            MicroModel::Conductor(m) => m.sample(wo),
            MicroModel::RoughConductor(m) => m.sample(wo, u),
            MicroModel::Plastic(m) => m.sample(wo, u_lobe, u),
            MicroModel::RoughPlastic(m) => m.sample(wo, u_lobe, u),
        }?;
        let wi = V3::from(self.frame.to_world(s.wi)).normalize_or_zero();
        if (wi.dot(self.side) > 0.0) == s.is_transmission || !s.weight.is_finite() {
            return None;
        }
        Some(MicroSample {
            wi,
            weight: V3::from(s.weight),
            pdf: s.pdf,
            is_transmission: s.is_transmission,
            is_delta: s.is_delta,
        })
    }

    /// The delta reflection's direction and reflectance (a smooth metal or
    /// a smooth plastic's coating), for the Whitted preview.
    pub fn delta_reflection(&self) -> Option<(V3, V3)> {
        let s = match &self.model {
            MicroModel::Conductor(m) => m.sample(self.wo),
            // u_lobe = 0 always picks the coating; weight × probability is its reflectance.
            MicroModel::Plastic(m) => m.sample(self.wo, 0.0, Vec2::ZERO),
            _ => None,
        }
        .filter(|s| s.is_delta)?;
        let wi = V3::from(self.frame.to_world(s.wi)).normalize_or_zero();
        (wi.dot(self.side) > 0.0).then(|| (wi, V3::from(s.weight * s.pdf)))
    }

    /// The radiance factor (n1/n2)² a transmission's weight already carries
    /// (1 for reflection): what the path's `eta_scale` divides out.
    #[inline]
    pub fn radiance_scale(&self) -> f32 {
        match &self.boundary {
            Some(b) => {
                let k = b.n1 / b.n2;
                k * k
            }
            None => 1.0,
        }
    }
}

/// The known-wrong variants of the render tests ([`crate::scene::model::BsdfVariant`]).
#[cfg(test)]
impl Micro<'_> {
    /// Next-event estimation's (f·cos, pdf) under `variant`.
    pub fn wrong_eval(&self, variant: BsdfVariant, wi: V3, fc: V3, pdf: f32) -> (V3, f32) {
        match variant {
            BsdfVariant::WrongMisPdf => (fc, 2.0 * pdf),
            BsdfVariant::WrongDoubleScale if wi.dot(self.side) < 0.0 => (fc * self.radiance_scale(), pdf),
            _ => (fc, pdf),
        }
    }

    /// A sample under `variant`.
    pub fn wrong_sample(&self, variant: BsdfVariant, mut s: MicroSample) -> MicroSample {
        let MicroModel::RoughDielectric(d) = &self.model else {
            return s;
        };
        if variant != BsdfVariant::WrongJacobian || !s.is_transmission {
            return s;
        }
        let (wo, wi) = (self.wo, self.frame.to_local(Vec3::from(s.wi)));
        let eta = if wo.z > 0.0 { d.eta() } else { 1.0 / d.eta() };
        let m = (wo + wi * eta).normalize();
        // The weight goes as 1/pdf: the right Jacobian over the wrong one.
        let (om, im) = (wo.dot(m), wi.dot(m));
        let denom = om + eta * im;
        s.weight *= 4.0 * eta * eta * im * im / (denom * denom);
        s
    }
}

impl Lambert {
    /// The BSDF value (the same for every pair of directions above).
    #[inline]
    pub fn f(&self) -> V3 {
        self.albedo * FRAC_1_PI
    }

    /// The solid-angle density with which [`Lambert::sample`] picks `wi`.
    #[inline]
    pub fn pdf(&self, wi: V3) -> f32 {
        self.n.dot(wi) * FRAC_1_PI
    }

    /// A cosine-weighted direction about `n` (two random numbers); `None`
    /// when it falls below the geometric surface (a shading normal leaning
    /// past it).
    #[inline]
    pub fn sample(&self, rng: &mut Rng) -> Option<V3> {
        let wi = cosine_hemisphere(self.n, rng.uniform(), rng.uniform());
        (self.ng.dot(wi) > 0.0).then_some(wi)
    }
}

impl Interface {
    /// The reflected direction.
    #[inline]
    pub fn reflected(&self) -> V3 {
        reflected(self.d, self.n, self.side)
    }

    /// Reflection with the Fresnel probability, else refraction (one random
    /// number, drawn only when both are possible): each lobe's weight over
    /// its probability is 1, but for the radiance scale of a transmission
    /// ([`Interface::radiance_scale`]).
    #[inline]
    pub fn sample(&self, rng: &mut Rng) -> Lobe {
        match self.refracted {
            None => Lobe::Reflect(self.reflected()),
            Some(_) if (rng.uniform() as f64) < self.fresnel => Lobe::Reflect(self.reflected()),
            Some(t) => Lobe::Transmit(t),
        }
    }

    /// Radiance is divided by n² across a boundary: a transmitted path's
    /// throughput is multiplied by (n1/n2)².
    #[inline]
    pub fn radiance_scale(&self) -> f32 {
        let k = self.boundary.n1 / self.boundary.n2;
        k * k
    }
}

/// The mirror direction of unit-ish `d` about the shading normal `n`; when
/// the shading normal pushes it below the surface (`incident_side` is the
/// geometric normal on the side `d` came from), about the geometric normal.
#[inline]
pub(super) fn reflected(d: DVec3, n: DVec3, incident_side: V3) -> V3 {
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
