//! A sun of finite angular size in an analytic sky (`[environment] type =
//! "sky"`): the disk's radiance, its uniform cone sampling for next-event
//! estimation and that sampling's density, and the sky behind it.
//!
//! The disk is a cone of half-angle α about the unit direction `s` towards
//! the sun, of solid angle Ω = ∫₀^{2π}∫₀^α sin θ dθ dφ = 2π(1 − cos α), and
//! of uniform radiance L = E / Ω for the declared irradiance E. So E is
//! ∫ L dω over the disk (the beam's irradiance as α → 0, what
//! `Light::Directional` takes); a surface facing the sun receives
//! ∫ L cos θ dω = L π sin²α = E (1 + cos α)/2, 5·10⁻⁶ less than E for the
//! real sun (α = 0.265°).
//!
//! Precision: for the real sun 1 − cos α ≈ 1.1·10⁻⁵, which f32 (ulp 6·10⁻⁸
//! near 1) holds to half a percent only. The cone is kept in f64 as
//! 1 − cos α = 2 sin²(α/2), sampled without forming cos θ first, and a
//! direction is tested against it by |s × d|² (first order in the angle,
//! insensitive to |d| ≠ 1), not by s·d ≥ cos α.
use crate::media::sun_connect::LaunchSolve;
use crate::sampling::{power_heuristic, Rng};
use glam::{DVec3, Vec3A as V3};
use std::f64::consts::PI;

/// The real sun's mean angular diameter, degrees.
pub const SUN_DIAMETER_DEG: f64 = 0.53;

/// How the path tracer estimates the sun's disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SunSampling {
    /// Next-event estimation of the cone, MIS (power heuristic) against
    /// BSDF sampling.
    Mis,
    /// BSDF sampling alone (escaping rays that land in the disk, weight 1):
    /// the reference the MIS estimator is tested against.
    BsdfOnly,
    /// Known wrong, for tests' power: the density of a cone twice as wide
    /// everywhere the cone's density is used.
    #[cfg(test)]
    WrongWidePdf,
    /// Known wrong, for tests' power: next-event estimation as `Mis`, but
    /// escaping rays that land in the disk count with weight 1.
    #[cfg(test)]
    WrongUnweightedEscape,
    /// Known wrong, for tests' power: as `Mis`, but next-event estimation
    /// through a stratified medium launches along the exit direction itself
    /// with Jacobian 1 (`LaunchSolve::Straight`, as if the medium did not
    /// bend) while escaping rays keep the invariant's launch density. (The
    /// straight solve on both sides would be right, only wasteful: its
    /// density is the true one of the launches it makes, and the curved
    /// shadow ray checks where they leave.)
    #[cfg(test)]
    WrongStraightLaunch,
}

/// A disk of uniform radiance at infinity.
#[derive(Debug, Clone)]
pub struct Sun {
    /// Unit direction towards the sun's centre.
    dir: DVec3,
    /// 1 − cos α (α the angular radius), as 2 sin²(α/2).
    one_minus_cos: f64,
    /// sin²α.
    sin2: f64,
    /// The disk's radiance, E / Ω per channel.
    radiance: V3,
    /// How it is sampled (the default: next-event estimation with MIS).
    pub(crate) sampling: SunSampling,
}

impl Sun {
    /// The sun towards unit `dir`, of full angular diameter `diameter_deg`
    /// degrees (in (0, 180)), giving the irradiance `irradiance` (∫ L dω,
    /// see the module notes).
    pub fn new(dir: DVec3, diameter_deg: f64, irradiance: V3) -> Sun {
        let alpha = 0.5 * diameter_deg.to_radians();
        let h = (0.5 * alpha).sin();
        let one_minus_cos = 2.0 * h * h;
        let omega = 2.0 * PI * one_minus_cos;
        Sun {
            dir: dir.normalize(),
            one_minus_cos,
            sin2: alpha.sin().powi(2),
            radiance: irradiance / omega as f32,
            sampling: SunSampling::Mis,
        }
    }

    /// Unit direction towards the sun.
    pub fn direction(&self) -> DVec3 {
        self.dir
    }

    /// The disk's solid angle, 2π(1 − cos α).
    pub fn solid_angle(&self) -> f64 {
        2.0 * PI * self.one_minus_cos
    }

    /// The disk's radiance.
    pub fn radiance(&self) -> V3 {
        self.radiance
    }

    /// Is the direction `d` (any length > 0) inside the disk? By
    /// |s × d|² ≤ sin²α |d|² on the sun's side.
    #[inline]
    pub fn contains(&self, d: V3) -> bool {
        let d = d.as_dvec3();
        let c = self.dir.dot(d);
        c > 0.0 && self.dir.cross(d).length_squared() <= self.sin2 * d.length_squared()
    }

    /// How a launch through a stratified medium is solved for an exit
    /// direction in the disk.
    #[inline]
    pub(crate) fn launch_solve(&self) -> LaunchSolve {
        match self.sampling {
            #[cfg(test)]
            SunSampling::WrongStraightLaunch => LaunchSolve::Straight,
            _ => LaunchSolve::Invariant,
        }
    }

    /// The cone's 1 − cos of its half-angle as sampled (`WrongWidePdf`:
    /// twice the angle, ≈ 4 times the solid angle).
    fn pdf_one_minus_cos(&self) -> f64 {
        match self.sampling {
            #[cfg(test)]
            SunSampling::WrongWidePdf => {
                let h = (2.0 * (0.5 * self.one_minus_cos).sqrt().asin()).sin();
                2.0 * h * h
            }
            _ => self.one_minus_cos,
        }
    }

    /// The solid-angle density of [`Sun::sample`]: 1/Ω inside the cone
    /// (the cone's area element is sin θ dθ dφ and the sample is uniform in
    /// it), 0 outside.
    #[inline]
    pub fn pdf(&self) -> f64 {
        1.0 / (2.0 * PI * self.pdf_one_minus_cos())
    }

    /// A direction uniform in the cone from two uniform numbers in [0, 1).
    /// Uniform in solid angle: 1 − cos θ = u₁ (1 − cos α) (its cdf is
    /// (1 − cos θ)/(1 − cos α)), φ = 2π u₂, and
    /// sin θ = √((1 − cos θ)(1 + cos θ)) without rounding cos θ.
    pub fn sample(&self, u1: f64, u2: f64) -> DVec3 {
        let w = u1 * self.one_minus_cos;
        let sin_t = (w * (2.0 - w)).max(0.0).sqrt();
        let phi = 2.0 * PI * u2;
        let (t, b) = self.dir.any_orthonormal_pair();
        (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + self.dir * (1.0 - w)).normalize()
    }
}

/// The sun in an analytic sky: above the horizon (y up), the radiance
/// blends from `horizon` to `zenith` linearly in sin(elevation) = d.y;
/// below it, the constant `ground`. The disk replaces the sky where it is
/// (wherever it points: the ground colour does not hide a low sun).
#[derive(Debug, Clone)]
pub struct Sky {
    /// The sun.
    pub sun: Sun,
    /// Radiance straight up.
    pub zenith: V3,
    /// Radiance at the horizon.
    pub horizon: V3,
    /// Radiance from below the horizon.
    pub ground: V3,
}

impl Sky {
    /// The sky's radiance alone along `d` (unit), as if there were no sun.
    #[inline]
    pub fn sky(&self, d: V3) -> V3 {
        if d.y >= 0.0 {
            self.horizon + (self.zenith - self.horizon) * d.y.min(1.0)
        } else {
            self.ground
        }
    }

    /// Radiance arriving along −`d`: the sun inside its disk, the sky elsewhere.
    #[inline]
    pub fn eval(&self, d: V3) -> V3 {
        if self.sun.contains(d) {
            self.sun.radiance
        } else {
            self.sky(d)
        }
    }

    /// Is the sun's disk sampled by next-event estimation?
    #[inline]
    pub fn sun_nee(&self) -> bool {
        self.sun.sampling != SunSampling::BsdfOnly && self.sun.radiance.max_element() > 0.0
    }

    /// A next-event sample of the disk, uniform in its cone: the direction
    /// and the sampling's solid-angle density (before the choice among the
    /// scene's lights).
    #[inline]
    pub fn sample_sun(&self, rng: &mut Rng) -> (V3, f64) {
        let (u1, u2) = (rng.uniform_f64(), rng.uniform_f64());
        (self.sun.sample(u1, u2).as_vec3a(), self.sun.pdf())
    }

    /// The radiance an escaping ray along `d` adds, weighted against the
    /// sun's next-event estimation: `mis` is, when next-event estimation
    /// could have made the same path, the solid-angle density the ray left
    /// its diffuse vertex with and the Jacobian |dΩ_exit/dΩ_launch| from the
    /// disk's directions to that launch's (1 for a straight path), `None`
    /// otherwise (weight 1); `choice` is the probability that a next-event
    /// sample is the sun's. Next-event estimation's density for the launch
    /// is the disk's 1/Ω × `choice` × the Jacobian.
    #[inline]
    pub fn escaped(&self, d: V3, mis: Option<(f32, f32)>, choice: f32) -> V3 {
        if !self.sun.contains(d) {
            return self.sky(d);
        }
        let w = match (mis, self.sun.sampling) {
            (_, SunSampling::BsdfOnly) | (None, _) => 1.0,
            #[cfg(test)]
            (_, SunSampling::WrongUnweightedEscape) => 1.0,
            (Some((p, jacobian)), _) => power_heuristic(p, (self.sun.pdf() as f32) * choice * jacobian),
        };
        self.sun.radiance * w
    }
}

#[cfg(test)]
mod tests;
