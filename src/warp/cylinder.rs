//! Hollow-cylinder refraction warp, exact in 3-D (Mukai et al. work in 2-D).
//!
//! Reduction (a departure from the paper, which ignores the vertical
//! component): refraction at a vertical cylinder conserves `β = n·d_v` (the
//! index times the direction's component along the axis), because the normal
//! is horizontal. The horizontal projection then refracts like a 2-D ray with
//! effective indices `m = √(n² − β²)` (air: `√(1 − β²)`), and a horizontal
//! run `ℓ` in a medium climbs `ℓ·β/m`. In a rotationally symmetric medium the
//! 2-D "angular momentum" `m·b` (index × impact parameter) is conserved, so
//! the family of a ray follows from its impact parameter `b` in air:
//! `|b| < r` through the hollow (`through4`); `r < |b| < r·m_g/m_a` total
//! internal reflection at the inner wall (`tir2`); `r·m_g/m_a < |b| < R`
//! through the wall only (`wall2`, impossible when `r·m_g/m_a ≥ R`, e.g.
//! R = 1, r = 0.8, n = 1.5); a target in the hollow is reached by `hollow2`.
//! For a target P the unknowns are `b` and `β`: for fixed β every image is a
//! root of the signed distance of P from the final 2-D ray, found by sampling
//! the family's `b` interval (denser near its edges) and bisection; β is then
//! corrected by a secant iteration on the climb until both equations hold.
use glam::{DVec2, DVec3};

/// A thick glass tube, infinitely tall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HollowCylinder {
    /// A point on the axis (metres).
    pub axis_point: DVec3,
    /// Unit axis direction.
    pub axis_direction: DVec3,
    /// Outer radius R (metres).
    pub outer_radius: f64,
    /// Inner radius r < R (metres).
    pub inner_radius: f64,
    /// Index of the glass (the surroundings have index 1).
    pub ior: f64,
    /// Cached unit vector across the axis (the frame's u; w = axis × u).
    across: DVec3,
}

/// How the eye ray reaches the target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// No refraction.
    Direct,
    /// Outer in, inner out, inner in, outer out.
    Through4,
    /// Outer in, total internal reflection at the inner wall, outer out.
    Tir2,
    /// Through the glass wall only.
    Wall2,
    /// Outer in, inner out: the target is in the hollow.
    Hollow2,
}

impl Family {
    /// Number of refractions along paths of this family.
    pub fn refractions(self) -> u32 {
        match self {
            Family::Direct => 0,
            Family::Through4 => 4,
            _ => 2,
        }
    }
}

/// One image of a target.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CylImage {
    /// The path family.
    pub family: Family,
    /// Unit direction of the straight eye ray that sees the target.
    pub direction: DVec3,
    /// eye + direction·|target − eye|: where the vertex must move.
    pub position: DVec3,
    /// Refractions along the path.
    pub refractions: u32,
    /// +1 upright, −1 mirrored (horizontally), relative to a direct view;
    /// 0 where it was not computed (the renderer's fast path).
    pub parity: i8,
    /// Signed impact parameter of the eye ray about the axis (metres, the
    /// 2-D `b` of the reduction; its sign tells the side of the axis).
    pub impact: f64,
}

/// Why a target has no images.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CylStatus {
    /// The eye is inside the tube's outer radius.
    EyeNotOutside,
    /// The target is inside the glass wall.
    InsideGlass,
}

/// Where to look for a root of g(b) found by scanning samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Candidate {
    /// g changes sign between these two samples (indices).
    Bracket(usize, usize),
    /// g does not change sign within the family's samples, but extrapolates
    /// to zero just past the end of a run of valid samples (a family edge):
    /// at the target's own β the root may lie inside. Start Newton at this sample.
    Edge(usize),
}

/// Sign changes of g over ascending samples `bs` (`g(k)` is `None` where
/// the family does not apply), plus run ends (family edges) where |g| falls
/// towards the edge and is below `edge_tol`: g has a square-root singularity
/// at an edge, and a root just inside the edge at the target's own β can lie
/// just outside it at the β the samples were taken for, so no sign change
/// shows; Newton from the run end finds it.
pub(crate) fn scan_candidates(bs: &[f64], g: impl Fn(usize) -> Option<f64>, edge_tol: f64) -> Vec<Candidate> {
    let mut out = Vec::new();
    let falling = |g0: f64, g1: f64| g1.abs() < g0.abs() && g1.abs() <= edge_tol && (g0 < 0.0) == (g1 < 0.0);
    let mut prev: Option<(usize, f64)> = None;
    let mut prev2: Option<(usize, f64)> = None;
    let mut run_start = true;
    for k in 0..bs.len() {
        match g(k) {
            Some(gk) => {
                if let Some((k0, g0)) = prev {
                    if g0 == 0.0 || (g0 < 0.0) != (gk < 0.0) {
                        out.push(Candidate::Bracket(k0, k));
                    } else if run_start && falling(gk, g0) {
                        // Second sample of a run: |g| falls towards the run's start.
                        out.push(Candidate::Edge(k0));
                    }
                    run_start = false;
                }
                prev2 = prev;
                prev = Some((k, gk));
            }
            None => {
                if let (Some((_, g0)), Some((b1, g1))) = (prev2, prev) {
                    if !run_start && falling(g0, g1) {
                        out.push(Candidate::Edge(b1));
                    }
                }
                prev = None;
                prev2 = None;
                run_start = true;
            }
        }
    }
    if let (Some((_, g0)), Some((b1, g1))) = (prev2, prev) {
        if !run_start && falling(g0, g1) {
            out.push(Candidate::Edge(b1));
        }
    }
    out
}

struct Frame {
    u: DVec3,
    w: DVec3,
    a: DVec3,
    c: DVec3,
}

impl Frame {
    fn to2(&self, p: DVec3) -> (DVec2, f64) {
        let q = p - self.c;
        (DVec2::new(q.dot(self.u), q.dot(self.w)), q.dot(self.a))
    }
}

/// What an image's direction needs of the eye and the tube's frame, once
/// per eye (the fast solver keeps one per warper; `dir_for` and `finish`
/// build one per call). The arithmetic is `dir_for`'s and `finish`'s, only
/// hoisted, so an image is the same bits either way.
#[derive(Clone, Copy, Debug)]
pub(crate) struct EyeTerms {
    rho: f64,
    inward: DVec2,
    perp: DVec2,
    u: DVec3,
    w: DVec3,
    a: DVec3,
}

impl EyeTerms {
    fn new(e: DVec2) -> EyeTerms {
        let rho = e.length();
        let inward = -e / rho;
        EyeTerms {
            rho,
            inward,
            perp: DVec2::new(-inward.y, inward.x),
            u: DVec3::ZERO,
            w: DVec3::ZERO,
            a: DVec3::ZERO,
        }
    }

    /// The terms for `e` in the tube `c`'s frame.
    pub(crate) fn for_tube(c: &HollowCylinder, e: DVec2) -> EyeTerms {
        let f = c.frame();
        EyeTerms {
            u: f.u,
            w: f.w,
            a: f.a,
            ..EyeTerms::new(e)
        }
    }

    /// `HollowCylinder::dir_for`.
    #[inline]
    fn dir_for(&self, b: f64) -> DVec2 {
        let s = (b / self.rho).clamp(-1.0, 1.0);
        // e × (inward·c + perp·x) = rho·x·(−inward × perp)… solve for x giving b.
        let x = -s; // because e × perp = −rho (see test below)
        (self.inward * (1.0 - x * x).max(0.0).sqrt() + self.perp * x).normalize()
    }

    /// The image of a solved (b, β) without its parity (`finish`'s
    /// renderer path): one normalisation, the frame and the eye's terms
    /// from `self`.
    #[inline]
    pub(crate) fn image(&self, fam: Family, eye: DVec3, dist: f64, b: f64, beta: f64) -> CylImage {
        let h = self.dir_for(b);
        let dir = (self.u * h.x + self.w * h.y) * (1.0 - beta * beta).sqrt() + self.a * beta;
        let direction = dir.normalize();
        CylImage {
            family: fam,
            direction,
            position: eye + direction * dist,
            refractions: fam.refractions(),
            parity: 0,
            impact: b,
        }
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

/// Roots s of |x + s·h| = c (h unit), ascending.
pub(crate) fn circle(x: DVec2, h: DVec2, c: f64) -> Option<(f64, f64)> {
    let b = x.dot(h);
    let q = x.length_squared() - c * c;
    let disc = b * b - q;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t0 = if b > 0.0 { -(b + s) } else { -b + s };
    // Stable pair: t0 and q/t0.
    let (a0, a1) = if t0 == 0.0 { (-b, -b) } else { (t0, q / t0) };
    Some((a0.min(a1), a0.max(a1)))
}

/// The final 2-D ray of a family for impact parameter `b`, with horizontal
/// lengths in air and glass up to its origin. `None` if the family does not
/// apply to this `b`.
struct Path2 {
    origin: DVec2,
    dir: DVec2,
    air: f64,
    glass: f64,
    /// The effective indices √(1 − β²) and √(n² − β²) of the path's β
    /// (kept so that callers do not take the square roots again).
    ma: f64,
    mg: f64,
}

impl HollowCylinder {
    /// A tube from its axis, radii and index.
    ///
    /// # Errors
    /// A non-finite point or a zero axis direction (it is normalised), radii
    /// out of order (0 < r < R), or an index below 1.
    pub fn try_new(
        axis_point: DVec3,
        axis_direction: DVec3,
        outer: f64,
        inner: f64,
        ior: f64,
    ) -> Result<Self, String> {
        if !axis_point.is_finite() || !axis_direction.is_finite() || axis_direction.length() < 1e-300 {
            return Err("axis: expected a finite point and a non-zero direction".into());
        }
        if !(outer.is_finite() && inner.is_finite() && inner > 0.0 && inner < outer) {
            return Err(format!(
                "radii: expected 0 < inner_radius < outer_radius, got {inner}, {outer}"
            ));
        }
        if !(ior.is_finite() && ior >= 1.0) {
            return Err(format!("ior: expected a finite value >= 1, got {ior}"));
        }
        let a = axis_direction.normalize();
        Ok(HollowCylinder {
            axis_point,
            across: Self::across_for(a),
            axis_direction: a,
            outer_radius: outer,
            inner_radius: inner,
            ior,
        })
    }

    fn across_for(a: DVec3) -> DVec3 {
        let (u, _) = crate::sampling::basis(glam::Vec3A::new(a.x as f32, a.y as f32, a.z as f32));
        // Re-orthonormalise in f64.
        let u = DVec3::new(u.x as f64, u.y as f64, u.z as f64);
        (u - a * a.dot(u)).normalize()
    }

    #[inline]
    fn frame(&self) -> Frame {
        let a = self.axis_direction;
        Frame {
            u: self.across,
            w: a.cross(self.across),
            a,
            c: self.axis_point,
        }
    }

    /// Horizontal eye direction for impact parameter b (b = e × h, |b| < |e|).
    fn dir_for(e: DVec2, b: f64) -> DVec2 {
        EyeTerms::new(e).dir_for(b)
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
    fn path(&self, fam: Family, e: DVec2, b: f64, beta: f64, target_in_hollow: bool) -> Option<Path2> {
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
    fn path_traced(&self, fam: Family, e: DVec2, b: f64, beta: f64, target_in_hollow: bool) -> Option<Path2> {
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

    /// The frame's unit axes (u, w across the axis, a along it).
    pub fn frame_axes(&self) -> (DVec3, DVec3, DVec3) {
        let f = self.frame();
        (f.u, f.w, f.a)
    }

    /// Signed impact parameter `b` and axial direction component `β` of the
    /// ray from `eye` along unit `d`, in the frame `images` uses.
    pub fn impact_of(&self, eye: DVec3, d: DVec3) -> (f64, f64) {
        let f = self.frame();
        let (e, _) = f.to2(eye);
        let h = DVec2::new(d.dot(f.u), d.dot(f.w));
        let hl = h.length();
        if hl == 0.0 {
            return (0.0, d.dot(f.a));
        }
        (e.perp_dot(h / hl), d.dot(f.a))
    }

    /// 2-D coordinates across the axis and the height along it.
    pub(crate) fn to2(&self, p: DVec3) -> (DVec2, f64) {
        self.frame().to2(p)
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

    /// The direct image, when the straight line misses the tube, from the
    /// eye's and the target's 2-D positions `e`, `p` and their distance.
    pub(crate) fn direct_image_2d(
        &self,
        e: DVec2,
        p: DVec2,
        eye: DVec3,
        target: DVec3,
        dist: f64,
    ) -> Option<CylImage> {
        if p.length() <= self.inner_radius {
            return None;
        }
        let seg = p - e;
        let l = seg.length();
        let blocked =
            l > 0.0 && circle(e, seg / l, self.outer_radius).is_some_and(|(t0, t1)| t1 > 0.0 && t0 < l);
        if blocked {
            return None;
        }
        Some(CylImage {
            family: Family::Direct,
            direction: (target - eye) / dist,
            position: target,
            refractions: 0,
            parity: 1,
            impact: 0.0,
        })
    }

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn refine_public(
        &self,
        fam: Family,
        e: DVec2,
        p: DVec2,
        dv: f64,
        dist: f64,
        eye: DVec3,
        lo: f64,
        hi: f64,
        beta0: f64,
        in_hollow: bool,
    ) -> Option<CylImage> {
        let f = self.frame();
        self.refine(fam, e, p, dv, dist, eye, &f, lo, hi, beta0, in_hollow)
    }

    /// The residuals of `newton_image` in (b, β) directly, with their
    /// Jacobian in closed form: `([g, climb − dv], [[∂g/∂b, ∂g/∂β],
    /// [∂climb/∂b, ∂climb/∂β]])`, or `None` where the family does not apply
    /// or the target is behind the final ray.
    ///
    /// One evaluation replaces the three of a finite-difference Jacobian.
    /// The final direction's angle is ψ = ψ0(b) + sg·T, T the family's sum of
    /// the angles θ1..θ4 of `path` (dθ = d(sin θ)/cos θ); the origin
    /// o = −b·h⊥ ± hc·h with hc = √(ρ_f² − b²); then
    /// dg = −along·dψ − h × do and d along = g·dψ − h·do. Singular at the
    /// family edges (a cos θ → 0): the fast solver uses it away from them
    /// only. Checked against finite differences in the tests.
    ///
    /// The fast solver evaluates it four at a time (`lanes::resid_jac4`,
    /// tested equal to this one bit for bit) where the CPU has AVX2, and
    /// lane by lane with this one elsewhere.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn resid_jac(
        &self,
        fam: Family,
        e: DVec2,
        p: DVec2,
        dv: f64,
        b: f64,
        beta: f64,
        in_hollow: bool,
    ) -> Option<([f64; 2], [[f64; 2]; 2])> {
        let (big, small) = (self.outer_radius, self.inner_radius);
        let ab = b.abs();
        let rho = e.length();
        if ab >= big || ab >= rho {
            return None;
        }
        let ma = (1.0 - beta * beta).sqrt();
        let mg = (self.ior * self.ior - beta * beta).sqrt();
        let k = ma / mg;
        // dk/dβ = k·β·(1/m_g² − 1/m_a²).
        let k_beta = k * beta * (1.0 / (mg * mg) - 1.0 / (ma * ma));
        let al = ab * k;
        let sg = if b < 0.0 { -1.0 } else { 1.0 };
        // |L| = |b|·k: derivatives with respect to b and β.
        let (al_b, al_beta) = (sg * k, ab * k_beta);
        // h0 (as `dir_for`) and its derivative in b.
        let inward = -e / rho;
        let perp_i = DVec2::new(-inward.y, inward.x);
        let x = -(b / rho);
        let cx = (1.0 - x * x).sqrt();
        let h0 = inward * cx + perp_i * x;
        let h0_b = (inward * (-x / cx) + perp_i) * (-1.0 / rho);
        // ψ0' = h0' · h0⊥ (h0 is unit).
        let psi0_b = h0_b.dot(DVec2::new(-h0.y, h0.x));
        let s1 = ab / big;
        let c1 = (1.0 - s1 * s1).sqrt();
        let s2 = al / big;
        let c2 = (1.0 - s2 * s2).sqrt();
        let rot12 = DVec2::new(c1 * c2 + s1 * s2, s1 * c2 - c1 * s2);
        let air0 = -e.dot(h0) - big * c1;
        if air0 <= 0.0 {
            return None;
        }
        // d(air0)/db = −e·h0' + sg·s1/c1.
        let air0_b = -e.dot(h0_b) + sg * s1 / c1;
        // dθ1/d|b|, dθ2/d|L|.
        let t1 = 1.0 / (big * c1);
        let t2 = 1.0 / (big * c2);
        let mul = |a: DVec2, b: DVec2| DVec2::new(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
        // (turn, final radius, first, air, ∂air/∂b, glass, ∂glass/∂|L|,
        //  ∂T/∂|b| at fixed |L|, ∂T/∂|L|)
        let (turn, final_radius, first, air, air_b, glass, glass_al, tb, tl) = match fam {
            Family::Wall2 => {
                if al < small {
                    return None;
                }
                (
                    mul(rot12, rot12),
                    big,
                    false,
                    air0,
                    air0_b,
                    2.0 * big * c2,
                    -2.0 * s2 / c2,
                    2.0 * t1,
                    -2.0 * t2,
                )
            }
            Family::Tir2 => {
                if ab <= small || al >= small {
                    return None;
                }
                let s3 = al / small;
                let c3 = (1.0 - s3 * s3).sqrt();
                let refl = DVec2::new(-(1.0 - 2.0 * s3 * s3), -2.0 * s3 * c3);
                let t3 = 1.0 / (small * c3);
                (
                    mul(mul(rot12, rot12), refl),
                    big,
                    false,
                    air0,
                    air0_b,
                    2.0 * (big * c2 - small * c3),
                    2.0 * (-s2 / c2 + s3 / c3),
                    2.0 * t1,
                    -2.0 * t2 + 2.0 * t3,
                )
            }
            Family::Through4 | Family::Hollow2 => {
                if ab >= small || (fam == Family::Hollow2) != in_hollow {
                    return None;
                }
                let s3 = al / small;
                let c3 = (1.0 - s3 * s3).sqrt();
                let s4 = ab / small;
                let c4 = (1.0 - s4 * s4).sqrt();
                let rot43 = DVec2::new(c4 * c3 + s4 * s3, -(s4 * c3 - c4 * s3));
                let half = mul(rot12, rot43);
                let g1 = big * c2 - small * c3;
                let g1_al = -s2 / c2 + s3 / c3;
                let (t3, t4) = (1.0 / (small * c3), 1.0 / (small * c4));
                if fam == Family::Hollow2 {
                    (half, small, true, air0, air0_b, g1, g1_al, t1 - t4, -t2 + t3)
                } else {
                    (
                        mul(half, half),
                        big,
                        false,
                        air0 + 2.0 * small * c4,
                        air0_b - 2.0 * sg * s4 / c4,
                        2.0 * g1,
                        2.0 * g1_al,
                        2.0 * (t1 - t4),
                        2.0 * (-t2 + t3),
                    )
                }
            }
            Family::Direct => return None,
        };
        let turn = DVec2::new(turn.x, sg * turn.y);
        let hf = mul(h0, turn);
        let perp = DVec2::new(-hf.y, hf.x);
        // ψ = ψ0 + sg·T(|b|, |L|): d/db = ψ0' + T_|b| + T_|L|·k, d/dβ = sg·T_|L|·|b|·k'.
        let psi_b = psi0_b + tb + tl * k;
        let psi_beta = sg * tl * al_beta;
        let hc = (final_radius * final_radius - b * b).max(0.0).sqrt();
        let sigma = if first { -1.0 } else { 1.0 };
        let origin = -perp * b + hf * (sigma * hc);
        // do/db = hf·b·ψ_b − h⊥ + h⊥·ψ_b·σ·hc − hf·σ·b/hc; do/dβ = (hf·b + h⊥·σ·hc)·ψ_β.
        let swing = hf * b + perp * (sigma * hc);
        let o_b = swing * psi_b - perp - hf * (sigma * b / hc);
        let o_beta = swing * psi_beta;
        let rel = p - origin;
        let along = rel.dot(hf);
        if along <= 0.0 {
            return None;
        }
        let g = hf.perp_dot(rel);
        let g_b = -along * psi_b - hf.perp_dot(o_b);
        let g_beta = -along * psi_beta - hf.perp_dot(o_beta);
        let along_b = g * psi_b - hf.dot(o_b);
        let along_beta = g * psi_beta - hf.dot(o_beta);
        let glass_b = glass_al * al_b;
        let glass_beta = glass_al * al_beta;
        // climb = β·((air + along)/m_a + glass/m_g); dm/dβ = −β/m.
        let run = (air + along) / ma + glass / mg;
        let climb = beta * run;
        let climb_b = beta * ((air_b + along_b) / ma + glass_b / mg);
        let climb_beta = run
            + beta
                * (along_beta / ma
                    + (air + along) * beta / (ma * ma * ma)
                    + glass_beta / mg
                    + glass * beta / (mg * mg * mg));
        Some(([g, climb - dv], [[g_b, g_beta], [climb_b, climb_beta]]))
    }

    /// Signed distance of the target `p` from the final 2-D ray of `fam` for
    /// (b, β), or `None` if the family does not apply or `p` is behind the ray.
    fn signed_miss(
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
    fn domain(&self, fam: Family, beta: f64, b: f64) -> (f64, f64) {
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

    /// Newton in (b, β) together from `b0`: both residuals (distance of the
    /// target from the final ray across the axis, and the climb error along
    /// it), a finite-difference Jacobian, damped steps that must reduce the
    /// residual. `None` if it leaves the family or stalls (the caller then
    /// uses the robust `refine`).
    ///
    /// g(b) has a square-root singularity at the family edges (the ray
    /// grazes a circle there), which stalls Newton in b for images within
    /// ~1e-6 of an edge. So b is written as `edge + σ·s²` from the edge of
    /// its interval nearest `b0` (σ = ±1 pointing inside): smooth in s.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn newton_image(
        &self,
        fam: Family,
        e: DVec2,
        p: DVec2,
        dv: f64,
        dist: f64,
        eye: DVec3,
        b0: f64,
        beta0: f64,
        in_hollow: bool,
    ) -> Option<CylImage> {
        self.newton_image_opts(fam, e, p, dv, dist, eye, b0, beta0, in_hollow, true, u32::MAX)
    }

    /// `newton_image`; without `parity` the image's parity is left 0 (the
    /// renderer does not need it; it costs three path evaluations).
    ///
    /// The Jacobian (finite differences, two path evaluations) is reused
    /// while full steps keep cutting the residual at least tenfold (a chord
    /// step; from the tables' first guess the second step then needs no new
    /// Jacobian); a step that fails with a reused Jacobian is retried with a
    /// fresh one, so the stall test below only ever judges fresh ones.
    ///
    /// `slow_limit`: give up after this many accepted steps in a row that
    /// each leave more than half of the residual (`u32::MAX`: never). The
    /// fast solver's edge candidates pass a limit of 10 (issue 16, eighth
    /// round): on the bench plane 608 of 644 of them have no image, and
    /// the costliest of those crawl for all 40 iterations with every step
    /// keeping over 90 % of the residual, while every edge image found
    /// there converged within six iterations, each step but one cutting
    /// the residual a hundredfold. Giving up can only lose an image, never
    /// accept a wrong one (acceptance is the residual test below). Margin,
    /// measured when this was written: a limit of 3 loses one robust image
    /// of `no_image_lost_on_random_targets` (seam targets), 4 loses none;
    /// 1 and 2 fail `impatient_edges_find_the_same_images` as well.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn newton_image_opts(
        &self,
        fam: Family,
        e: DVec2,
        p: DVec2,
        dv: f64,
        dist: f64,
        eye: DVec3,
        b0: f64,
        beta0: f64,
        in_hollow: bool,
        parity: bool,
        slow_limit: u32,
    ) -> Option<CylImage> {
        let (lo0, hi0) = self.domain(fam, beta0, b0);
        let from_lo = (b0 - lo0) <= (hi0 - b0);
        let side = b0;
        let to_b = |s: f64, beta: f64| {
            let (lo, hi) = self.domain(fam, beta, side);
            if from_lo {
                lo + s * s
            } else {
                hi - s * s
            }
        };
        let resid = |s: f64, beta: f64| -> Option<(f64, f64)> {
            let b = to_b(s, beta);
            let path = self.path(fam, e, b, beta, in_hollow)?;
            let rel = p - path.origin;
            let along = rel.dot(path.dir);
            if along <= 0.0 {
                return None;
            }
            let climb = beta * ((path.air + along) / path.ma + path.glass / path.mg);
            Some((path.dir.perp_dot(rel), climb - dv))
        };
        let norm = |r: (f64, f64)| r.0.abs().max(r.1.abs());
        // b0 may lie just outside the family at β0 (the edge moves with β):
        // start a hair inside, where the path exists.
        let mut s = (if from_lo { b0 - lo0 } else { hi0 - b0 })
            .max(0.0)
            .sqrt()
            .max(1e-6 * self.outer_radius.sqrt());
        let mut beta = beta0;
        let mut r = resid(s, beta)?;
        let tol = 1e-13 * dist;
        let mut converged = false;
        let mut jac: Option<(f64, f64, f64, f64)> = None;
        let mut slow = 0u32;
        for _ in 0..40 {
            if norm(r) <= tol {
                converged = true;
                break;
            }
            let reused = jac.is_some();
            // Relative 1e-5 in s: a change of b of ~2e-5·s² stays thousands of
            // ulps of b even 1e-9 from an edge (1e-7 would be below b's ulp).
            // and at least 1e-6·√R, so that b moves by ≥ ~1e-12·R when s ≈ 0.
            let hs = (1e-5 * s).max(1e-6 * self.outer_radius.sqrt());
            let hbeta = 1e-8;
            // Forward difference, or backward if forward is outside. The
            // backward point is evaluated only then (issue 16, eighth round:
            // both were evaluated for every Jacobian, two of its four path
            // evaluations wasted when the forward one exists; same values).
            let fd = |fwd: Option<(f64, f64)>, bwd: &dyn Fn() -> Option<(f64, f64)>| -> Option<(f64, f64)> {
                match fwd {
                    Some(x) => Some((x.0 - r.0, x.1 - r.1)),
                    None => bwd().map(|x| (r.0 - x.0, r.1 - x.1)),
                }
            };
            let (j11, j12, j21, j22) = match jac {
                Some(j) => j,
                None => {
                    let (ds0, ds1) = fd(resid(s + hs, beta), &|| resid(s - hs, beta))?;
                    let (dt0, dt1) = fd(resid(s, beta + hbeta), &|| resid(s, beta - hbeta))?;
                    (ds0 / hs, dt0 / hbeta, ds1 / hs, dt1 / hbeta)
                }
            };
            let det = j11 * j22 - j12 * j21;
            if det == 0.0 || !det.is_finite() {
                return None;
            }
            let d_s = -(r.0 * j22 - r.1 * j12) / det;
            let d_beta = -(j11 * r.1 - j21 * r.0) / det;
            let mut lambda = 1.0;
            let mut accepted = false;
            // With a reused Jacobian only the full step is tried.
            for _ in 0..if reused { 1 } else { 12 } {
                let (ns, nbeta) = (s + lambda * d_s, beta + lambda * d_beta);
                if nbeta.abs() < 0.999_999 {
                    if let Some(nr) = resid(ns.abs(), nbeta) {
                        if norm(nr) < norm(r) {
                            slow = if norm(nr) > 0.5 * norm(r) { slow + 1 } else { 0 };
                            // Keep the Jacobian while full steps converge fast.
                            jac =
                                (lambda == 1.0 && norm(nr) <= 0.1 * norm(r)).then_some((j11, j12, j21, j22));
                            s = ns.abs();
                            beta = nbeta;
                            r = nr;
                            accepted = true;
                            break;
                        }
                    }
                }
                lambda *= 0.5;
            }
            if !accepted && reused {
                jac = None;
                continue;
            }
            if slow >= slow_limit {
                return None;
            }
            if !accepted {
                // Stalled at rounding level: near an edge dg/db is ~1e5, so
                // an ulp of b moves g by ~1e-11.
                converged = norm(r) <= 1e-10 * dist;
                break;
            }
        }
        if !converged && norm(r) > 1e-10 * dist {
            return None;
        }
        let f = self.frame();
        self.finish(fam, e, p, dist, eye, &f, to_b(s, beta), beta, in_hollow, parity)
    }

    /// All images of `target` seen from `eye`.
    pub fn images(&self, eye: DVec3, target: DVec3) -> Result<Vec<CylImage>, CylStatus> {
        let f = self.frame();
        let (e, ev) = f.to2(eye);
        let (p, pv) = f.to2(target);
        let (big, small) = (self.outer_radius, self.inner_radius);
        if e.length() <= big {
            return Err(CylStatus::EyeNotOutside);
        }
        let rp = p.length();
        if rp > small && rp < big {
            return Err(CylStatus::InsideGlass);
        }
        let in_hollow = rp <= small;
        let dv = pv - ev;
        let dist = (target - eye).length();
        let mut out = Vec::new();
        // Direct: the horizontal segment e → p must miss the outer circle.
        if !in_hollow {
            let seg = p - e;
            let l = seg.length();
            let blocked = l > 0.0 && circle(e, seg / l, big).is_some_and(|(t0, t1)| t1 > 0.0 && t0 < l);
            if !blocked {
                let d = (target - eye) / dist;
                out.push(CylImage {
                    family: Family::Direct,
                    direction: d,
                    position: target,
                    refractions: 0,
                    parity: 1,
                    impact: 0.0,
                });
            }
        }
        let families: &[Family] = if in_hollow {
            &[Family::Hollow2]
        } else {
            &[Family::Through4, Family::Tir2, Family::Wall2]
        };
        let rho = e.length();
        let bmax = big.min(rho) * (1.0 - 1e-15);
        for &fam in families {
            // For a first β take the straight elevation; refine per root below.
            let beta0 = dv / dist;
            let g = |b: f64, beta: f64| -> Option<(f64, f64)> {
                let path = self.path(fam, e, b, beta, in_hollow)?;
                let rel = p - path.origin;
                let along = rel.dot(path.dir);
                if along <= 0.0 {
                    return None;
                }
                Some((path.dir.perp_dot(rel), along))
            };
            // Sample b over (−bmax, bmax), densely near ±r, ±r·mg/ma and ±R.
            let mut samples: Vec<f64> = (0..=800).map(|i| -bmax + 2.0 * bmax * i as f64 / 800.0).collect();
            let ma = (1.0 - beta0 * beta0).sqrt();
            let mg = (self.ior * self.ior - beta0 * beta0).sqrt();
            for edge in [small, small * mg / ma, bmax] {
                for k in 1..=60 {
                    let off = edge * 10f64.powf(-(k as f64) / 4.0);
                    for s in [-1.0, 1.0] {
                        for x in [edge - off, edge + off] {
                            if x.abs() < bmax {
                                samples.push(s * x);
                            }
                        }
                    }
                }
            }
            samples.sort_by(f64::total_cmp);
            let gs: Vec<Option<f64>> = samples.iter().map(|&b| g(b, beta0).map(|x| x.0)).collect();
            for cand in scan_candidates(&samples, |k| gs[k], 1e-3 * dist) {
                let img = match cand {
                    Candidate::Bracket(k0, k1) => {
                        let (lo0, hi0) = (samples[k0], samples[k1]);
                        self.refine(fam, e, p, dv, dist, eye, &f, lo0, hi0, beta0, in_hollow)
                            .or_else(|| {
                                self.newton_image(
                                    fam,
                                    e,
                                    p,
                                    dv,
                                    dist,
                                    eye,
                                    0.5 * (lo0 + hi0),
                                    beta0,
                                    in_hollow,
                                )
                            })
                    }
                    Candidate::Edge(k) => {
                        self.newton_image(fam, e, p, dv, dist, eye, samples[k], beta0, in_hollow)
                    }
                };
                let Some(img) = img else {
                    continue;
                };
                if !out.iter().any(|o: &CylImage| {
                    o.family == img.family && (o.direction - img.direction).length() < 1e-9
                }) {
                    out.push(img);
                }
            }
        }
        Ok(out)
    }

    #[allow(clippy::too_many_arguments)]
    fn refine(
        &self,
        fam: Family,
        e: DVec2,
        p: DVec2,
        dv: f64,
        dist: f64,
        eye: DVec3,
        f: &Frame,
        lo0: f64,
        hi0: f64,
        beta0: f64,
        in_hollow: bool,
    ) -> Option<CylImage> {
        let gval = |b: f64, beta: f64| self.signed_miss(fam, e, p, b, beta, in_hollow);
        // Bisection in b for fixed β inside a bracket; widen the bracket when β moved.
        let solve_b = |beta: f64, lo: f64, hi: f64| -> Option<f64> {
            let (mut lo, mut hi) = (lo, hi);
            let mut glo = gval(lo, beta)?;
            let ghi = gval(hi, beta)?;
            if glo.signum() == ghi.signum() && glo != 0.0 {
                return None;
            }
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid == lo || mid == hi {
                    break;
                }
                let gm = gval(mid, beta)?;
                if gm.signum() == glo.signum() {
                    lo = mid;
                    glo = gm;
                } else {
                    hi = mid;
                }
            }
            Some(0.5 * (lo + hi))
        };
        let climb = |b: f64, beta: f64| -> Option<f64> {
            let path = self.path(fam, e, b, beta, in_hollow)?;
            let ma = (1.0 - beta * beta).sqrt();
            let mg = (self.ior * self.ior - beta * beta).sqrt();
            let last = (p - path.origin).dot(path.dir);
            Some(beta * ((path.air + last) / ma + path.glass / mg))
        };
        let mut beta = beta0;
        let mut b = solve_b(beta, lo0, hi0)?;
        let width = (hi0 - lo0).max(1e-9);
        let mut prev: Option<(f64, f64)> = None;
        for _ in 0..100 {
            let r = climb(b, beta)? - dv;
            if r.abs() <= 1e-13 * dist {
                break;
            }
            // Secant on β (Newton-like from a finite difference at the start).
            let next = match prev {
                Some((pb, pr)) if (r - pr) != 0.0 => beta - r * (beta - pb) / (r - pr),
                _ => beta - r / (dist.max(1e-300)),
            };
            prev = Some((beta, r));
            beta = next.clamp(-0.999_999_999, 0.999_999_999);
            // Track the root near the previous b.
            let mut k = 1.0;
            let mut found = None;
            while k < 1e6 && found.is_none() {
                found = solve_b(
                    beta,
                    (b - width * k).max(-e.length()),
                    (b + width * k).min(e.length()),
                );
                k *= 4.0;
            }
            b = found?;
        }
        let r = climb(b, beta)? - dv;
        if r.abs() > 1e-9 * dist || gval(b, beta)?.abs() > 1e-9 * dist {
            return None;
        }
        self.finish(fam, e, p, dist, eye, f, b, beta, in_hollow, true)
    }

    /// The image for a solved (b, β) (for the fast solver).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn image_at(
        &self,
        fam: Family,
        e: DVec2,
        p: DVec2,
        dist: f64,
        eye: DVec3,
        b: f64,
        beta: f64,
        in_hollow: bool,
        with_parity: bool,
    ) -> Option<CylImage> {
        let f = self.frame();
        self.finish(fam, e, p, dist, eye, &f, b, beta, in_hollow, with_parity)
    }

    /// The image for a solved (b, β): direction, position and parity.
    #[allow(clippy::too_many_arguments)]
    fn finish(
        &self,
        fam: Family,
        e: DVec2,
        p: DVec2,
        dist: f64,
        eye: DVec3,
        f: &Frame,
        b: f64,
        beta: f64,
        in_hollow: bool,
        with_parity: bool,
    ) -> Option<CylImage> {
        let gval = |b: f64, beta: f64| self.signed_miss(fam, e, p, b, beta, in_hollow);
        let terms = EyeTerms {
            u: f.u,
            w: f.w,
            a: f.a,
            ..EyeTerms::new(e)
        };
        let img = terms.image(fam, eye, dist, b, beta);
        if !with_parity {
            return Some(img);
        }
        // Parity: orientation of b → crossing position against a straight view.
        // One-sided near a family edge (the other side is outside the family).
        let (lo, hi) = self.domain(fam, beta, b);
        let db = (1e-7 * self.outer_radius)
            .min(0.5 * (b - lo).min(hi - b))
            .max(1e-15);
        let g0 = gval(b, beta)?;
        let dg = match (gval(b + db, beta), gval(b - db, beta)) {
            (Some(x), Some(y)) => x - y,
            (Some(x), None) => x - g0,
            (None, Some(y)) => g0 - y,
            (None, None) => return None,
        };
        let straight = |bb: f64| Self::dir_for(e, bb).perp_dot(p - e);
        let ds = straight(b + db) - straight(b - db);
        let parity = if dg.signum() == ds.signum() { 1 } else { -1 };
        Some(CylImage { parity, ..img })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent 3-D check: follow the eye ray through the tube with vector
    /// Snell (TIR reflects), and return the distance from the target to the
    /// final ray.
    fn trace(c: &HollowCylinder, eye: DVec3, d: DVec3, target: DVec3) -> f64 {
        let a = c.axis_direction;
        let radial = |p: DVec3| {
            let q = p - c.axis_point;
            (q - a * q.dot(a)).normalize()
        };
        let hit = |o: DVec3, d: DVec3, r: f64, far: bool| -> Option<f64> {
            let q = o - c.axis_point;
            let qp = q - a * q.dot(a);
            let dp = d - a * d.dot(a);
            let (aa, bb, cc) = (dp.dot(dp), qp.dot(dp), qp.dot(qp) - r * r);
            let disc = bb * bb - aa * cc;
            if disc < 0.0 {
                return None;
            }
            let (t0, t1) = ((-bb - disc.sqrt()) / aa, (-bb + disc.sqrt()) / aa);
            let t = if far {
                t1
            } else if t0 > 1e-9 {
                t0
            } else {
                t1
            };
            (t > 1e-9).then_some(t)
        };
        let (big, small, n) = (c.outer_radius, c.inner_radius, c.ior);
        let mut o = eye;
        let mut d = d;
        let mut index = 1.0;
        // Up to six interface events: decide by geometry which circle comes next.
        for _ in 0..6 {
            let q = o - c.axis_point;
            let rho = (q - a * q.dot(a)).length();
            let next = if rho > big * (1.0 + 1e-12) {
                hit(o, d, big, false).map(|t| (t, big, 1.0, n))
            } else if rho < small * (1.0 + 1e-12) && index == 1.0 {
                hit(o, d, small, true).map(|t| (t, small, 1.0, n))
            } else {
                // In glass: inner (near root) or outer (far root).
                match hit(o, d, small, false) {
                    Some(t) if rho > small * (1.0 + 1e-12) => Some((t, small, n, 1.0)),
                    _ => hit(o, d, big, true).map(|t| (t, big, n, 1.0)),
                }
            };
            let Some((t, _r, n1, n2)) = next else { break };
            let p = o + d * t;
            // Stop if the target lies on this segment.
            let rel = target - o;
            let along = rel.dot(d);
            if along > 0.0 && along < t && (rel - d * along).length() < 1e-6 {
                return (rel - d * along).length();
            }
            let nrm = radial(p);
            match crate::optics::refract(d, nrm, n1, n2) {
                Some(t2) => {
                    d = t2.normalize();
                    index = n2;
                }
                None => d = crate::optics::reflect(d, nrm).normalize(),
            }
            o = p;
        }
        let rel = target - o;
        (rel - d * rel.dot(d)).length()
    }

    fn tube(inner: f64) -> HollowCylinder {
        HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, inner, 1.5).unwrap()
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

    /// `resid_jac`'s residuals are those of the traced path, and its
    /// closed-form Jacobian matches central differences (away from the family
    /// edges, where it is singular), for every family, both signs of b, both
    /// eyes and several β and targets.
    #[test]
    fn closed_form_jacobian_matches_differences() {
        let mut checked = 0;
        for inner in [0.8, 0.5] {
            let c = tube(inner);
            for e in [DVec2::new(0.0, 4.0), DVec2::new(1.3, -2.5)] {
                for fam in [Family::Through4, Family::Tir2, Family::Wall2, Family::Hollow2] {
                    let hollow = fam == Family::Hollow2;
                    for beta in [0.0, 0.3, -0.6] {
                        for i in 0..=200 {
                            let b = -0.999 + 1.998 * i as f64 / 200.0;
                            let Some(t) = c.path_traced(fam, e, b, beta, hollow) else {
                                continue;
                            };
                            // Stay 1e-3 away from every edge of the family.
                            let (lo, hi) = c.domain(fam, beta, b);
                            if b - lo < 1e-3 || hi - b < 1e-3 {
                                continue;
                            }
                            // A target 1.7 along the final ray, off it by 0.05.
                            let perp = DVec2::new(-t.dir.y, t.dir.x);
                            let p = t.origin + t.dir * 1.7 + perp * 0.05;
                            let dv = 0.4;
                            let (r, j) = c.resid_jac(fam, e, p, dv, b, beta, hollow).unwrap();
                            let along = (p - t.origin).dot(t.dir);
                            let g = t.dir.perp_dot(p - t.origin);
                            let climb = beta * ((t.air + along) / t.ma + t.glass / t.mg) - dv;
                            assert!(
                                (r[0] - g).abs() < 1e-12 && (r[1] - climb).abs() < 1e-12,
                                "{fam:?} b={b}"
                            );
                            let h = 1e-6;
                            let f = |bb: f64, tt: f64| c.resid_jac(fam, e, p, dv, bb, tt, hollow).unwrap().0;
                            let (bp, bm) = (f(b + h, beta), f(b - h, beta));
                            let (tp, tm) = (f(b, beta + h), f(b, beta - h));
                            for row in 0..2 {
                                let db = (bp[row] - bm[row]) / (2.0 * h);
                                let dt = (tp[row] - tm[row]) / (2.0 * h);
                                let scale = 1.0 + db.abs().max(dt.abs());
                                assert!(
                                    (j[row][0] - db).abs() < 1e-5 * scale && (j[row][1] - dt).abs() < 1e-5 * scale,
                                    "{fam:?} r={inner} e={e} b={b} beta={beta} row {row}: {:?} vs [{db}, {dt}]",
                                    j[row]
                                );
                            }
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 1500, "{checked}");
    }

    #[test]
    fn impact_parameter_direction_convention() {
        let e = DVec2::new(0.0, 4.0);
        for b in [-0.9, -0.1, 0.0, 0.5] {
            let h = HollowCylinder::dir_for(e, b);
            assert!((e.perp_dot(h) - b).abs() < 1e-12, "{b}: {}", e.perp_dot(h));
        }
    }

    #[test]
    fn every_image_retraces_to_its_target() {
        let eye = DVec3::new(0.0, 0.0, 4.0);
        let mut counts = vec![];
        for inner in [0.8, 0.5] {
            let c = tube(inner);
            for target in [
                DVec3::new(0.5, 0.0, -2.5),
                DVec3::new(0.0, 0.5, -4.0),
                DVec3::new(0.2, -0.7, -3.0),
                DVec3::new(1.3, 0.3, -3.0),
                DVec3::new(0.1, 0.2, 0.3),
                DVec3::new(3.0, 0.4, -3.0),
            ] {
                let imgs = c.images(eye, target).unwrap();
                for im in &imgs {
                    let miss = trace(&c, eye, im.direction, target);
                    assert!(
                        miss < 1e-9 * 8.0,
                        "r={inner} {target} {:?}: misses by {miss}",
                        im.family
                    );
                }
                counts.push((inner, target, imgs.iter().map(|i| i.family).collect::<Vec<_>>()));
            }
        }
        for c in &counts {
            eprintln!("{c:?}");
        }
        // Behind the tube, on the axis plane: seen through the hollow (and not directly).
        let c = tube(0.8);
        let imgs = c.images(eye, DVec3::new(0.0, 0.5, -4.0)).unwrap();
        assert!(imgs.iter().any(|i| i.family == Family::Through4));
        assert!(!imgs.iter().any(|i| i.family == Family::Direct));
        assert!((1..=3).contains(&imgs.len()), "{imgs:?}");
        // Far to the side the target is also seen directly, with parity +1.
        let imgs = c.images(eye, DVec3::new(3.0, 0.4, -3.0)).unwrap();
        assert!(imgs.iter().any(|i| i.family == Family::Direct && i.parity == 1));
        // No wall-only path for R=1, r=0.8, n=1.5 (n·r > R); r = 0.5 allows it.
        let all08: Vec<Family> = counts
            .iter()
            .filter(|c| c.0 == 0.8)
            .flat_map(|c| c.2.clone())
            .collect();
        assert!(!all08.contains(&Family::Wall2));
        let imgs = tube(0.5).images(eye, DVec3::new(0.5, 0.0, -2.5)).unwrap();
        assert!(imgs.len() <= 4);
        // A target in the hollow is seen through the outer and inner walls.
        let imgs = c.images(eye, DVec3::new(0.1, 0.2, 0.3)).unwrap();
        assert!(!imgs.is_empty() && imgs.iter().all(|i| i.family == Family::Hollow2));
        assert_eq!(
            c.images(eye, DVec3::new(0.9, 0.0, 0.0)),
            Err(CylStatus::InsideGlass)
        );
        assert_eq!(
            c.images(DVec3::new(0.0, 0.0, 0.5), DVec3::new(0.0, 0.0, -3.0)),
            Err(CylStatus::EyeNotOutside)
        );
    }
}
