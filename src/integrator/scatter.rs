//! The one shading model: what a material does with light arriving at a hit
//! (pbrt's `GetBSDF` and `Sample_f`), built once per hit by [`Bsdf::at`] and
//! used by the path tracer (single rays and lanes) and the Whitted preview.
//! A new material is a new variant here; the integrators only ask it for
//! directions, weights and densities.
use super::Tracer;
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList};
use crate::optics;
use crate::ray::front_facing;
use crate::sampling::{cosine_hemisphere, Rng};
use crate::scene::{Material, SurfacePoint};
use glam::{DVec3, Vec3A as V3};
use std::f32::consts::FRAC_1_PI;

/// A material's response at one hit, oriented to the side the light arrives
/// from (every normal here points back towards the incident ray).
pub(super) enum Bsdf {
    /// Nothing leaves: a black material, a one-sided diffuse surface seen
    /// from behind, or a boundary the nested rule ends the path at.
    Black,
    /// Lambertian reflection.
    Diffuse(Lambert),
    /// Perfect specular reflection.
    Mirror(Mirror),
    /// A smooth dielectric boundary: Fresnel reflection or refraction.
    Dielectric(Interface),
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

impl Bsdf {
    /// The response of `material` at `sp` to light arriving along `dir`. A dielectric boundary is
    /// resolved against the path's interior `list` (the nested rule may
    /// change it) and counts its total internal reflections in `st`.
    #[inline(always)]
    pub fn at(
        tr: Tracer<'_>,
        material: &Material,
        sp: &SurfacePoint,
        dir: V3,
        coincident: &dielectric::Coincident,
        list: &mut InteriorList,
        st: &mut Counters,
    ) -> Bsdf {
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
                let d = dir.as_dvec3();
                // The unoriented shading normal: Fresnel takes |cos|, and
                // `optics::refract` orients it itself.
                let n = sp.ns.as_dvec3();
                let fresnel =
                    optics::fresnel_dielectric(d.dot(n).abs(), boundary.n1 as f64, boundary.n2 as f64);
                let refracted = refracted(d, n, side, boundary.n1, boundary.n2);
                if refracted.is_none() {
                    st.tir += 1;
                }
                Bsdf::Dielectric(Interface {
                    boundary,
                    fresnel,
                    side,
                    refracted,
                    d,
                    n,
                })
            }
        }
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
