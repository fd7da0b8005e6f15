//! The 2-D reduction's final ray: where an eye ray of impact parameter `b`
//! and axial slope β leaves the tube, in closed form, for each family.
use super::family::Family;
use super::geometry::HollowCylinder;
use glam::DVec2;

#[cfg(test)]
use super::geometry::circle;

/// The horizontal eye rays of one eye by impact parameter
/// (`b = e × h`, |b| < |e|): what depends on the eye alone, computed once.
#[derive(Clone, Copy, Debug)]
pub(crate) struct EyeRays {
    rho: f64,
    /// −1/ρ.
    neg_inv_rho: f64,
    inward: DVec2,
    perp: DVec2,
}

impl EyeRays {
    pub(crate) fn new(e: DVec2) -> EyeRays {
        let rho = e.length();
        let inward = -e / rho;
        EyeRays {
            rho,
            neg_inv_rho: -1.0 / rho,
            inward,
            perp: DVec2::new(-inward.y, inward.x),
        }
    }

    /// The unit horizontal direction of impact parameter `b`.
    #[inline]
    pub(crate) fn dir_for(&self, b: f64) -> DVec2 {
        let s = (b / self.rho).clamp(-1.0, 1.0);
        // e × (inward·c + perp·x) = rho·x·(−inward × perp)… solve for x giving b.
        let x = -s; // because e × perp = −rho (see test below)
        (self.inward * (1.0 - x * x).max(0.0).sqrt() + self.perp * x).normalize()
    }

    /// `dir_for` without the division and the normalisation: `inward` and
    /// `perp` are orthonormal, so the sum is a unit vector to a few ulps,
    /// for a square root instead of three square roots and two divisions
    /// in a row (an image's direction, once per image).
    #[inline]
    pub(crate) fn unit_dir_for(&self, b: f64) -> DVec2 {
        let x = (b * self.neg_inv_rho).clamp(-1.0, 1.0);
        self.inward * (1.0 - x * x).max(0.0).sqrt() + self.perp * x
    }
}

#[cfg(test)]
fn refract2(d: DVec2, n: DVec2, m1: f64, m2: f64) -> Option<DVec2> {
    let t = crate::optics::refract(d.extend(0.0), n.extend(0.0), m1, m2)?;
    Some(t.truncate().normalize())
}

#[cfg(test)]
fn reflect2(d: DVec2, n: DVec2) -> DVec2 {
    (d - 2.0 * d.dot(n) * n).normalize()
}

/// The final 2-D ray of a family for impact parameter `b`, with horizontal
/// lengths in air and glass up to its origin. `None` if the family does not
/// apply to this `b`.
pub(crate) struct Path2 {
    pub(crate) origin: DVec2,
    pub(crate) dir: DVec2,
    pub(crate) air: f64,
    pub(crate) glass: f64,
    /// The effective indices √(1 − β²) and √(n² − β²) of the path's β
    /// (kept so that callers do not take the square roots again).
    pub(crate) ma: f64,
    pub(crate) mg: f64,
}

impl HollowCylinder {
    /// Horizontal eye direction for impact parameter b (b = e × h, |b| < |e|).
    pub(crate) fn dir_for(e: DVec2, b: f64) -> DVec2 {
        EyeRays::new(e).dir_for(b)
    }

    /// The final 2-D ray in closed form (the solvers' inner loop).
    ///
    /// In a rotationally symmetric system a ray is fixed by its impact
    /// parameter: in air it keeps `b`, in glass `L = m_a·b/m_g`; a refraction
    /// at a circle of radius ρ turns the direction by the difference of the
    /// angles with sines b/ρ and L/ρ, and a reflection by π − 2θ. With
    /// θ1 = asin(|b|/R), θ2 = asin(|L|/R), θ3 = asin(|L|/r), θ4 = asin(|b|/r)
    /// the total turn (counter-clockwise for b > 0) is
    /// through4 2(θ1 − θ2) − 2(θ4 − θ3); tir2 2(θ1 − θ2) − (π − 2θ3);
    /// wall2 2(θ1 − θ2); hollow2 (θ1 − θ2) − (θ4 − θ3). Chord lengths are
    /// ρ·cos of those angles. Rotations are composed as unit complex numbers
    /// from sines and cosines, so the path costs a handful of independent
    /// square roots instead of a chain of circle intersections. Checked
    /// against the traced `path_traced` in the tests.
    pub(crate) fn path(
        &self,
        fam: Family,
        e: DVec2,
        b: f64,
        beta: f64,
        target_in_hollow: bool,
    ) -> Option<Path2> {
        let (big, small) = (self.outer_radius, self.inner_radius);
        let ab = b.abs();
        if ab >= big || ab >= e.length() {
            return None;
        }
        let ma = (1.0 - beta * beta).sqrt();
        let mg = (self.ior * self.ior - beta * beta).sqrt();
        let al = ab * ma / mg; // |L| in glass
        let h0 = Self::dir_for(e, b);
        let sg = if b < 0.0 { -1.0 } else { 1.0 };
        // (cos, sin) of the angles.
        let s1 = ab / big;
        let c1 = (1.0 - s1 * s1).sqrt();
        let s2 = al / big;
        let c2 = (1.0 - s2 * s2).sqrt();
        let rot12 = DVec2::new(c1 * c2 + s1 * s2, s1 * c2 - c1 * s2); // θ1 − θ2
        let air0 = -e.dot(h0) - big * c1;
        if air0 <= 0.0 {
            return None;
        }
        let mul = |a: DVec2, b: DVec2| DVec2::new(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
        let (turn, air, glass, final_radius, first) = match fam {
            Family::Wall2 => {
                if al < small {
                    return None;
                }
                (mul(rot12, rot12), air0, 2.0 * big * c2, big, false)
            }
            Family::Tir2 => {
                if ab <= small || al >= small {
                    return None;
                }
                let s3 = al / small;
                let c3 = (1.0 - s3 * s3).sqrt();
                // Rotation by −(π − 2θ3) = (−cos 2θ3, −sin 2θ3).
                let refl = DVec2::new(-(1.0 - 2.0 * s3 * s3), -2.0 * s3 * c3);
                let g = 2.0 * (big * c2 - small * c3);
                (mul(mul(rot12, rot12), refl), air0, g, big, false)
            }
            Family::Through4 | Family::Hollow2 => {
                if ab >= small || (fam == Family::Hollow2) != target_in_hollow {
                    return None;
                }
                let s3 = al / small;
                let c3 = (1.0 - s3 * s3).sqrt();
                let s4 = ab / small;
                let c4 = (1.0 - s4 * s4).sqrt();
                let rot43 = DVec2::new(c4 * c3 + s4 * s3, -(s4 * c3 - c4 * s3)); // −(θ4 − θ3)
                let half = mul(rot12, rot43);
                let g1 = big * c2 - small * c3;
                if fam == Family::Hollow2 {
                    (half, air0, g1, small, true)
                } else {
                    (mul(half, half), air0 + 2.0 * small * c4, 2.0 * g1, big, false)
                }
            }
            Family::Direct => return None,
        };
        let turn = DVec2::new(turn.x, sg * turn.y);
        let hf = mul(h0, turn);
        // The final line keeps impact b: closest point to the axis c = −b·h⊥.
        let perp = DVec2::new(-hf.y, hf.x);
        let c = -perp * b;
        let half_chord = (final_radius * final_radius - b * b).max(0.0).sqrt();
        let origin = c + hf * if first { -half_chord } else { half_chord };
        Some(Path2 {
            origin,
            dir: hf,
            air,
            glass,
            ma,
            mg,
        })
    }

    /// The same path followed interface by interface (circle intersections
    /// and vector Snell): the reference `path` is tested against.
    #[cfg(test)]
    pub(crate) fn path_traced(
        &self,
        fam: Family,
        e: DVec2,
        b: f64,
        beta: f64,
        target_in_hollow: bool,
    ) -> Option<Path2> {
        let (big, small) = (self.outer_radius, self.inner_radius);
        let ma = (1.0 - beta * beta).sqrt();
        let mg = (self.ior * self.ior - beta * beta).sqrt();
        let h0 = Self::dir_for(e, b);
        let (s0, _) = circle(e, h0, big)?;
        if s0 <= 0.0 {
            return None;
        }
        let q1 = e + h0 * s0;
        let h1 = refract2(h0, q1 / big, ma, mg)?;
        let mut air = s0;
        let mut glass = 0.0;
        let inner_hit = circle(q1, h1, small).filter(|&(t0, _)| t0 > 1e-12);
        match (fam, inner_hit) {
            (Family::Wall2, None) => {
                let (_, s1) = circle(q1, h1, big)?;
                let q2 = q1 + h1 * s1;
                glass += s1;
                let h2 = refract2(h1, q2 / big, mg, ma)?;
                Some(Path2 {
                    origin: q2,
                    dir: h2,
                    air,
                    glass,
                    ma,
                    mg,
                })
            }
            (Family::Wall2, Some(_)) | (_, None) => None,
            (fam, Some((t_in, _))) => {
                let q2 = q1 + h1 * t_in;
                glass += t_in;
                let n_in = q2 / small; // points into the glass
                match refract2(h1, n_in, mg, ma) {
                    None => {
                        if fam != Family::Tir2 {
                            return None;
                        }
                        let h2 = reflect2(h1, n_in);
                        let (_, s2) = circle(q2, h2, big)?;
                        let q3 = q2 + h2 * s2;
                        glass += s2;
                        let h3 = refract2(h2, q3 / big, mg, ma)?;
                        Some(Path2 {
                            origin: q3,
                            dir: h3,
                            air,
                            glass,
                            ma,
                            mg,
                        })
                    }
                    Some(h2) => match fam {
                        Family::Hollow2 if target_in_hollow => Some(Path2 {
                            origin: q2,
                            dir: h2,
                            air,
                            glass,
                            ma,
                            mg,
                        }),
                        Family::Through4 if !target_in_hollow => {
                            let (_, s2) = circle(q2, h2, small)?;
                            let q3 = q2 + h2 * s2;
                            air += s2;
                            let h3 = refract2(h2, q3 / small, ma, mg)?;
                            let (_, s3) = circle(q3, h3, big)?;
                            let q4 = q3 + h3 * s3;
                            glass += s3;
                            let h4 = refract2(h3, q4 / big, mg, ma)?;
                            Some(Path2 {
                                origin: q4,
                                dir: h4,
                                air,
                                glass,
                                ma,
                                mg,
                            })
                        }
                        _ => None,
                    },
                }
            }
        }
    }

    /// The final 2-D ray (origin, unit direction) of the family `fam`.
    pub(crate) fn final_ray(
        &self,
        fam: Family,
        e: DVec2,
        b: f64,
        beta: f64,
        in_hollow: bool,
    ) -> Option<(DVec2, DVec2)> {
        self.path(fam, e, b, beta, in_hollow).map(|p| (p.origin, p.dir))
    }

    /// Signed distance of the target `p` from the final 2-D ray of `fam` for
    /// (b, β), or `None` if the family does not apply or `p` is behind the ray.
    pub(crate) fn signed_miss(
        &self,
        fam: Family,
        e: DVec2,
        p: DVec2,
        b: f64,
        beta: f64,
        in_hollow: bool,
    ) -> Option<f64> {
        let path = self.path(fam, e, b, beta, in_hollow)?;
        let rel = p - path.origin;
        (rel.dot(path.dir) > 0.0).then(|| path.dir.perp_dot(rel))
    }

    /// The interval of impact parameters where `fam` applies for β, on the
    /// side of `b` (the two-refraction families have a band on each side).
    pub(crate) fn domain(&self, fam: Family, beta: f64, b: f64) -> (f64, f64) {
        let (big, small) = (self.outer_radius, self.inner_radius);
        if matches!(fam, Family::Through4 | Family::Hollow2 | Family::Direct) {
            return (-small, small);
        }
        let ma = (1.0 - beta * beta).sqrt();
        let mg = (self.ior * self.ior - beta * beta).sqrt();
        let tir_edge = (small * mg / ma).min(big);
        let (lo, hi) = match fam {
            Family::Through4 | Family::Hollow2 | Family::Direct => return (-small, small),
            Family::Tir2 => (small, tir_edge),
            Family::Wall2 => (tir_edge, big),
        };
        if b < 0.0 {
            (-hi, -lo)
        } else {
            (lo, hi)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tube(inner: f64) -> HollowCylinder {
        HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, inner, 1.5).unwrap()
    }

    #[test]
    fn closed_form_path_matches_the_traced_one() {
        let mut checked = 0;
        for inner in [0.8, 0.5] {
            let c = tube(inner);
            for e in [DVec2::new(0.0, 4.0), DVec2::new(1.3, -2.5)] {
                for fam in [Family::Through4, Family::Tir2, Family::Wall2, Family::Hollow2] {
                    for beta in [0.0, 0.3, -0.6] {
                        for i in 0..=400 {
                            let b = -0.999 + 1.998 * i as f64 / 400.0;
                            let hollow = fam == Family::Hollow2;
                            let a = c.path(fam, e, b, beta, hollow);
                            let t = c.path_traced(fam, e, b, beta, hollow);
                            match (a, t) {
                                (Some(a), Some(t)) => {
                                    checked += 1;
                                    assert!(
                                        (a.dir - t.dir).length() < 1e-12,
                                        "{fam:?} b={b}: {:?} vs {:?}",
                                        a.dir,
                                        t.dir
                                    );
                                    assert!((a.origin - t.origin).length() < 1e-12, "{fam:?} b={b}: origin");
                                    assert!(
                                        (a.air - t.air).abs() < 1e-12 && (a.glass - t.glass).abs() < 1e-12,
                                        "{fam:?} b={b}: lengths"
                                    );
                                }
                                (None, None) => {}
                                (a, t) => panic!(
                                    "{fam:?} b={b} beta={beta} r={inner}: closed {} traced {}",
                                    a.is_some(),
                                    t.is_some()
                                ),
                            }
                        }
                    }
                }
            }
        }
        assert!(checked > 3000, "{checked}");
    }

    #[test]
    fn impact_parameter_direction_convention() {
        let e = DVec2::new(0.0, 4.0);
        for b in [-0.9, -0.1, 0.0, 0.5] {
            let h = HollowCylinder::dir_for(e, b);
            assert!((e.perp_dot(h) - b).abs() < 1e-12, "{b}: {}", e.perp_dot(h));
        }
    }
}
