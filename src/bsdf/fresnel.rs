//! Fresnel reflectance of smooth interfaces, and reflection and refraction
//! about a (micro)facet normal, in the BSDFs' local conventions (Mitsuba 3's
//! `fresnel.h`).
//!
//! - [`dielectric`]: unpolarised reflectance between two dielectrics, with
//!   the transmitted cosine and the relative indices in the direction of
//!   travel. `eta` is the index of the −z side over the +z side (interior
//!   over exterior); the sign of `cos_theta_i` says which side the light
//!   arrives from. The reflectance itself is [`crate::optics::fresnel_dielectric`]
//!   (f64, exact at grazing incidence and at the critical angle).
//! - [`conductor`]: unpolarised reflectance of a conductor with complex
//!   relative index η + iκ per colour channel: the exact closed form (Moeller,
//!   *Optics*, 1988, as in Mitsuba's `fresnel_conductor`), in f64.
//! - [`diffuse_reflectance`]: the fraction of diffuse (cosine-weighted)
//!   light a dielectric boundary reflects, 2∫₀¹ F(μ) μ dμ, by the fits
//!   Mitsuba's `fresnel_diffuse_reflectance` uses (Egan and Hilgeman 1973
//!   for η < 1, d'Eon and Irving 2011 for η ≥ 1).
//!
//! Directions point away from the surface: [`reflect`] and [`refract`] take
//! the direction light leaves along (or arrives from) and return the other.
use crate::optics;
use glam::Vec3;

/// [`dielectric`]'s result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DielectricFresnel {
    /// Unpolarised Fresnel reflectance (1 under total internal reflection).
    pub r: f32,
    /// Cosine of the transmitted direction with the normal, of the sign
    /// opposite to `cos_theta_i` (0 under total internal reflection).
    pub cos_theta_t: f32,
    /// Index of the far side over the incident side.
    pub eta_it: f32,
    /// Index of the incident side over the far side (1 / `eta_it`): the
    /// factor that scales the tangential part of the refracted direction.
    pub eta_ti: f32,
}

/// Fresnel reflection at a smooth dielectric boundary with normal +z, for
/// light on the side of the sign of `cos_theta_i` (the cosine of its
/// direction with the normal) and `eta` = η(−z side) / η(+z side).
pub fn dielectric(cos_theta_i: f32, eta: f32) -> DielectricFresnel {
    let c = f64::from(cos_theta_i).clamp(-1.0, 1.0);
    let eta = f64::from(eta);
    let (eta_it, eta_ti) = if c >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let r = dielectric_reflectance(c, eta);
    let cos_t2 = 1.0 - eta_ti * eta_ti * (1.0 - c * c);
    let cos_t = cos_t2.max(0.0).sqrt();
    DielectricFresnel {
        r: r as f32,
        cos_theta_t: if c >= 0.0 { -cos_t } else { cos_t } as f32,
        eta_it: eta_it as f32,
        eta_ti: eta_ti as f32,
    }
}

/// [`dielectric`]'s reflectance alone, in f64 throughout (for callers
/// whose cosines are f64: near the critical angle 1 − F has a square-root
/// slope, and f32 cosines lose its digits).
pub fn dielectric_reflectance(cos_theta_i: f64, eta: f64) -> f64 {
    let c = cos_theta_i.clamp(-1.0, 1.0);
    let eta_it = if c >= 0.0 { eta } else { 1.0 / eta };
    // optics takes the absolute indices of both sides; only their ratio matters.
    optics::fresnel_dielectric(c.abs(), 1.0, eta_it)
}

/// One channel of [`conductor`], in f64: reflectance for the cosine of
/// incidence `cos_theta_i` (its absolute value) and the complex relative
/// index `eta` + i`k`.
///
/// With a² + b² = |n̂² − sin²θ| and a = Re √(n̂² − sin²θ):
/// R_s = (a² + b² + cos²θ − 2a cosθ) / (a² + b² + cos²θ + 2a cosθ),
/// R_p = R_s (a² + b² cos²θ + sin⁴θ − 2a cosθ sin²θ) / (… + 2a cosθ sin²θ),
/// R = (R_s + R_p) / 2.
pub fn conductor_channel(cos_theta_i: f64, eta: f64, k: f64) -> f64 {
    let c = cos_theta_i.abs().min(1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let t1 = eta * eta - k * k - s2;
    let a2pb2 = (t1 * t1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2pb2 + t1)).max(0.0).sqrt();
    let term1 = a2pb2 + c2;
    let term2 = 2.0 * c * a;
    // Both denominators vanish only for a zero index at normal incidence
    // (n̂ = 0 is no material); call that lossless rather than 0/0.
    let rs = if term1 + term2 > 0.0 {
        (term1 - term2) / (term1 + term2)
    } else {
        1.0
    };
    let term3 = a2pb2 * c2 + s4;
    let term4 = term2 * s2;
    let rp = if term3 + term4 > 0.0 {
        rs * (term3 - term4) / (term3 + term4)
    } else {
        rs
    };
    (0.5 * (rs + rp)).clamp(0.0, 1.0)
}

/// Fresnel reflectance of a conductor per colour channel: the complex index
/// is `eta` + i`k` relative to the medium the light arrives in (an absolute
/// index divided by the outer medium's). Mitsuba's `fresnel_conductor`
/// assumes light arrives from outside; the absolute value of `cos_theta_i`
/// is taken here, to the same effect.
pub fn conductor(cos_theta_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let c = f64::from(cos_theta_i);
    let r = |i: usize| conductor_channel(c, f64::from(eta[i]), f64::from(k[i])) as f32;
    Vec3::new(r(0), r(1), r(2))
}

/// The diffuse Fresnel reflectance F_dr(η) = 2∫₀¹ F(μ) μ dμ for light
/// arriving from the side whose index is 1/`eta` times the other's (η > 1:
/// from the optically thinner side), by Mitsuba's fits: Egan and Hilgeman
/// (1973) for η < 1, d'Eon and Irving (2011) for η ≥ 1, each accurate to
/// about 1% where it is used (checked against the integral in the tests).
pub fn diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        0.919317 + inv * (-3.4793 + inv * (6.75335 + inv * (-7.80989 + inv * (4.98554 + inv * -1.36881))))
    }
}

/// The mirror image of `w` about the unit normal `m` (both pointing away
/// from the surface on the same side): 2(w·m)m − w.
#[inline]
pub fn reflect(w: Vec3, m: Vec3) -> Vec3 {
    2.0 * w.dot(m) * m - w
}

/// The direction refracted from `w` through the facet with unit normal `m`,
/// given [`dielectric`]'s `cos_theta_t` and `eta_ti` for cos = w·m: the
/// tangential part scales by `eta_ti` and reverses, the normal part is
/// `cos_theta_t` (on the other side). Unit when `w` and `m` are.
#[inline]
pub fn refract(w: Vec3, m: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    m * (w.dot(m) * eta_ti + cos_theta_t) - w * eta_ti
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::quadrature::gauss_legendre;

    /// A complex number, for an independent conductor Fresnel.
    #[derive(Clone, Copy)]
    struct C(f64, f64);
    impl C {
        fn add(self, o: C) -> C {
            C(self.0 + o.0, self.1 + o.1)
        }
        fn sub(self, o: C) -> C {
            C(self.0 - o.0, self.1 - o.1)
        }
        fn mul(self, o: C) -> C {
            C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
        }
        fn div(self, o: C) -> C {
            let d = o.0 * o.0 + o.1 * o.1;
            C(
                (self.0 * o.0 + self.1 * o.1) / d,
                (self.1 * o.0 - self.0 * o.1) / d,
            )
        }
        fn norm2(self) -> f64 {
            self.0 * self.0 + self.1 * self.1
        }
        /// The principal square root (Re ≥ 0).
        fn sqrt(self) -> C {
            let r = self.norm2().sqrt();
            let re = (0.5 * (r + self.0)).max(0.0).sqrt();
            let im = (0.5 * (r - self.0)).max(0.0).sqrt().copysign(self.1);
            C(re, im)
        }
    }

    /// r_s and r_p from the textbook amplitudes with complex n̂ = η + iκ:
    /// w = √(n̂² − sin²θ), r_s = (cosθ − w)/(cosθ + w), r_p = (n̂² cosθ − w)/(n̂² cosθ + w).
    fn conductor_complex(cos: f64, eta: f64, k: f64) -> f64 {
        let n = C(eta, k);
        let n2 = n.mul(n);
        let c = C(cos, 0.0);
        let w = n2.sub(C(1.0 - cos * cos, 0.0)).sqrt();
        let rs = c.sub(w).div(c.add(w));
        let rp = n2.mul(c).sub(w).div(n2.mul(c).add(w));
        0.5 * (rs.norm2() + rp.norm2())
    }

    #[test]
    fn conductor_closed_form_matches_complex_amplitudes() {
        for &(eta, k) in &[
            (0.143, 3.98),
            (1.657, 9.22),
            (4.37, 5.2),
            (0.2, 0.0),
            (1.5, 0.0),
            (2.0, 0.5),
        ] {
            for i in 0..=20 {
                let cos = i as f64 / 20.0;
                let a = conductor_channel(cos, eta, k);
                let b = conductor_complex(cos, eta, k);
                assert!(
                    (a - b).abs() < 1e-12,
                    "η = {eta}, κ = {k}, cos = {cos}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn conductor_with_no_absorption_is_a_dielectric_and_none_is_a_mirror() {
        for eta in [1.2f32, 1.5, 2.4] {
            for cos in [1.0f32, 0.7, 0.3, 0.05] {
                let c = conductor(cos, Vec3::splat(eta), Vec3::ZERO).x;
                let d = dielectric(cos, eta).r;
                assert!((c - d).abs() < 1e-6, "η = {eta}, cos = {cos}: {c} vs {d}");
            }
        }
        // Mitsuba's "none": η = 0, κ = 1 reflects everything at every angle.
        for cos in [1.0f32, 0.5, 0.01, 0.0] {
            assert!(
                (conductor(cos, Vec3::ZERO, Vec3::ONE) - Vec3::ONE)
                    .abs()
                    .max_element()
                    < 1e-6
            );
        }
    }

    #[test]
    fn dielectric_is_symmetric_and_refract_obeys_snell() {
        let eta = 1.5f32;
        for i in 1..20 {
            let ci = i as f32 / 20.0;
            for side in [1.0f32, -1.0] {
                let fr = dielectric(side * ci, eta);
                let w = Vec3::new((1.0 - ci * ci).sqrt(), 0.0, side * ci);
                if fr.r < 1.0 {
                    let t = refract(w, Vec3::Z, fr.cos_theta_t, fr.eta_ti);
                    assert!((t.length() - 1.0).abs() < 1e-6);
                    assert!(t.z * w.z < 0.0, "transmitted to the other side");
                    // n_i sin θi = n_t sin θt, with sin the tangential parts (reversed).
                    assert!((w.x + fr.eta_it * t.x).abs() < 1e-6, "{w} {t}");
                    // Stokes: light coming back along −t's mirror sees the same reflectance.
                    let back = dielectric(t.z, eta);
                    assert!((back.r - fr.r).abs() < 1e-5, "{} vs {}", back.r, fr.r);
                    assert!((back.eta_it * fr.eta_it - 1.0).abs() < 1e-6);
                } else {
                    assert!(
                        side < 0.0 && fr.cos_theta_t == 0.0,
                        "TIR only from the dense side"
                    );
                }
            }
        }
        let r = reflect(Vec3::new(0.6, 0.0, 0.8), Vec3::Z);
        assert!((r - Vec3::new(-0.6, 0.0, 0.8)).length() < 1e-7);
    }

    /// 2∫₀¹ F(μ) μ dμ by a 256-point Gauss–Legendre rule in each of the two
    /// pieces split at the critical cosine μc, with μ = a + (b − a) s²
    /// (1 − F grows like √(μ − μc) beyond it; the substitution makes the
    /// integrand smooth).
    fn diffuse_reflectance_integral(eta: f64) -> f64 {
        let crit = if eta < 1.0 { (1.0 - eta * eta).sqrt() } else { 0.0 };
        let (x, w) = gauss_legendre(256);
        let mut sum = 0.0;
        for (a, b) in [(0.0, crit), (crit, 1.0)] {
            for (x, w) in x.iter().zip(&w) {
                let s = 0.5 * (x + 1.0);
                let mu = a + (b - a) * s * s;
                let dmu = 2.0 * (b - a) * s * 0.5;
                sum += w * dmu * 2.0 * mu * optics::fresnel_dielectric(mu, 1.0, eta);
            }
        }
        sum
    }

    #[test]
    fn diffuse_reflectance_fits_are_close_to_the_integral() {
        // Mitsuba's fits: relative errors below 1% over the indices plastics use.
        for i in 0..=20 {
            let eta = 1.05 + i as f64 * 0.05; // 1.05 ..= 2.05
            for e in [eta, 1.0 / eta] {
                let fit = diffuse_reflectance(e as f32) as f64;
                let exact = diffuse_reflectance_integral(e);
                assert!(
                    ((fit - exact) / exact).abs() < 0.01,
                    "η = {e}: fit {fit}, integral {exact}"
                );
            }
        }
        // The integral's own check: from the dense side, light beyond the
        // critical cone is reflected entirely, so F_dr(1/η) = 1 − (1 − F_dr(η)) / η².
        for eta in [1.33f64, 1.5, 2.0] {
            let outer = diffuse_reflectance_integral(eta);
            let inner = diffuse_reflectance_integral(1.0 / eta);
            assert!((inner - (1.0 - (1.0 - outer) / (eta * eta))).abs() < 1e-9);
        }
    }
}
