//! Closed-form optics in f64: Fresnel, Snell, reflection. No Embree.
//!
//! Conventions: `d` is the unit incident direction (travelling towards the
//! surface); `n` is a unit normal of either orientation (functions orient it
//! against `d` themselves); `n1` is the index on the incident side, `n2` on
//! the far side. `cos_i` is the cosine of the angle of incidence, in [0, 1]
//! (absolute values are taken).
use glam::DVec3;

/// Unpolarised Fresnel reflectance of a smooth dielectric interface.
///
/// Exact for all angles: returns 0 when `n1 == n2` (even at grazing incidence,
/// where the textbook expression is 0/0), 1 under total internal reflection,
/// and stays finite in [0, 1] at the exact critical angle.
///
/// # Examples
///
/// ```
/// use snell::optics::fresnel_dielectric;
///
/// // Normal incidence, air to glass: R = ((n1 − n2) / (n1 + n2))² = 0.04.
/// let r = fresnel_dielectric(1.0, 1.0, 1.5);
/// assert!((r - 0.04).abs() < 1e-15);
///
/// // Glass to air beyond the critical angle (sin θc = 1/1.5): total reflection.
/// let cos_60 = 0.5;
/// assert_eq!(fresnel_dielectric(cos_60, 1.5, 1.0), 1.0);
///
/// // Index-matched: nothing is reflected, even at grazing incidence.
/// assert_eq!(fresnel_dielectric(0.0, 1.33, 1.33), 0.0);
/// ```
pub fn fresnel_dielectric(cos_i: f64, n1: f64, n2: f64) -> f64 {
    if n1 == n2 {
        return 0.0;
    }
    let cos_i = cos_i.abs().min(1.0);
    let eta = n1 / n2;
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    // r_s = (n1 cos_i - n2 cos_t) / (n1 cos_i + n2 cos_t); both denominators are
    // > 0 unless cos_i = cos_t = 0, which needs sin2_t = 1 (handled above) and
    // cos_i = 0 with eta = 1 (handled by n1 == n2).
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    (0.5 * (rs * rs + rp * rp)).clamp(0.0, 1.0)
}

/// Mirror reflection of `d` about the plane with normal `n` (either orientation).
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refracted direction for incident `d` crossing from index `n1` into `n2`
/// through a surface with normal `n` (either orientation). `None` under total
/// internal reflection. `n1 == n2` returns `d` exactly.
///
/// `d` must be unit length; the result is then unit length too, on the far
/// side of the surface.
///
/// # Examples
///
/// ```
/// use glam::DVec3;
/// use snell::optics::refract;
///
/// // 45° from air into glass (n = 1.5), through a floor facing up (+y).
/// let d = DVec3::new(1.0, -1.0, 0.0).normalize();
/// let t = refract(d, DVec3::Y, 1.0, 1.5).unwrap();
/// // Snell's law: n1 sin θi = n2 sin θt (the sines are the x components).
/// assert!((1.0 * d.x - 1.5 * t.x).abs() < 1e-15);
/// assert!(t.y < 0.0 && (t.length() - 1.0).abs() < 1e-15);
/// // The normal's orientation does not matter.
/// assert_eq!(refract(d, -DVec3::Y, 1.0, 1.5), Some(t));
///
/// // The same direction from glass into air is past the critical angle
/// // (sin 45° · 1.5 > 1): total internal reflection.
/// assert_eq!(refract(d, DVec3::Y, 1.5, 1.0), None);
/// ```
pub fn refract(d: DVec3, n: DVec3, n1: f64, n2: f64) -> Option<DVec3> {
    if n1 == n2 {
        return Some(d);
    }
    // Orient the normal against d.
    let (n, cos_i) = {
        let c = -d.dot(n);
        if c >= 0.0 {
            (n, c)
        } else {
            (-n, -c)
        }
    };
    let eta = n1 / n2;
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(eta * d + (eta * cos_i - cos_t) * n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn normal_incidence_matches_closed_form() {
        for (n1, n2) in [(1.0f64, 1.5f64), (1.5, 1.0), (1.0, 1.33), (1.33, 1.5)] {
            let r0 = ((n1 - n2) / (n1 + n2)).powi(2);
            assert!(close(fresnel_dielectric(1.0, n1, n2), r0, 1e-15));
        }
    }

    #[test]
    fn brewster_angle_has_zero_p_reflectance() {
        // At Brewster's angle r_p = 0, so R = r_s^2 / 2 with r_s = cos(2 θB)... use the closed form.
        let (n1, n2) = (1.0f64, 1.5f64);
        let tb = (n2 / n1).atan();
        let ci = tb.cos();
        let ct = (1.0 - (n1 / n2 * tb.sin()).powi(2)).sqrt();
        let rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
        assert!(close(fresnel_dielectric(ci, n1, n2), 0.5 * rs * rs, 1e-15));
    }

    #[test]
    fn equal_indices_give_no_reflection_and_identity_refraction() {
        for cos_i in [1.0, 0.5, 1e-9, 0.0] {
            assert_eq!(fresnel_dielectric(cos_i, 1.5, 1.5), 0.0);
        }
        let d = DVec3::new(1.0, -1e-12, 0.0).normalize();
        assert_eq!(refract(d, DVec3::Y, 1.33, 1.33), Some(d));
    }

    #[test]
    fn critical_angle_is_finite_and_total_beyond() {
        let (n1, n2) = (1.5, 1.0);
        let sc: f64 = n2 / n1;
        let cc = (1.0 - sc * sc).sqrt();
        let r = fresnel_dielectric(cc, n1, n2);
        assert!(r.is_finite() && (0.0..=1.0).contains(&r), "{r}");
        assert!(r > 0.99, "reflectance tends to 1 at the critical angle: {r}");
        assert_eq!(fresnel_dielectric(cc * 0.99, n1, n2), 1.0);
        let d = DVec3::new(sc * 1.0001, -(1.0 - (sc * 1.0001).powi(2)).sqrt(), 0.0);
        assert!(refract(d, DVec3::Y, n1, n2).is_none());
        let d = DVec3::new(sc, -cc, 0.0);
        let t = refract(d, DVec3::Y, n1, n2).unwrap();
        assert!(t.is_finite());
        assert!(t.y.abs() < 1e-6, "exits grazing at the critical angle");
    }

    #[test]
    fn snell_law_holds_for_either_normal_orientation() {
        let d = DVec3::new(0.6, -0.8, 0.0);
        for n in [DVec3::Y, -DVec3::Y] {
            let t = refract(d, n, 1.0, 1.5).unwrap();
            assert!(close(t.length(), 1.0, 1e-15));
            assert!(close(1.0 * 0.6, 1.5 * t.x, 1e-15));
            assert!(t.y < 0.0);
        }
        let r = reflect(d, DVec3::Y);
        assert_eq!(r, DVec3::new(0.6, 0.8, 0.0));
    }

    #[test]
    fn energy_is_conserved_grazing() {
        for &c in &[1e-12, 1e-6, 0.01, 0.5] {
            let r = fresnel_dielectric(c, 1.0, 1.5);
            assert!((0.0..=1.0).contains(&r));
        }
        assert!(fresnel_dielectric(0.0, 1.0, 1.5) > 0.999_999);
    }
}
