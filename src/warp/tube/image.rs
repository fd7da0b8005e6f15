//! A target's images: what the solvers answer, and how a solved (b, β)
//! becomes one (direction, position, parity).
use super::family::Family;
use super::geometry::{circle, Eye, HollowCylinder, Target};
use super::path::EyeRays;
use glam::{DVec2, DVec3};

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

/// What an image's direction needs of the eye and the tube's frame, once
/// per eye (the fast solver keeps one per warper; `image_at` makes one per
/// call: the same arithmetic, so an image is the same bits either way).
#[derive(Clone, Copy, Debug)]
pub(crate) struct EyeTerms {
    rays: EyeRays,
    u: DVec3,
    w: DVec3,
    a: DVec3,
}

impl EyeTerms {
    /// The terms for `e` in the tube `c`'s frame.
    pub(crate) fn for_tube(c: &HollowCylinder, e: DVec2) -> EyeTerms {
        let f = c.frame();
        EyeTerms {
            rays: EyeRays::new(e),
            u: f.u,
            w: f.w,
            a: f.a,
        }
    }

    /// The image of a solved (b, β) without its parity (the renderer's
    /// path), the frame and the eye's terms from `self`. The direction is
    /// unit as built (`h` unit across an orthonormal frame, scaled by
    /// √(1 − β²), plus β along the axis), to a few ulps: two independent
    /// square roots and no normalisation.
    #[inline]
    pub(crate) fn image(&self, fam: Family, eye: DVec3, dist: f64, b: f64, beta: f64) -> CylImage {
        let h = self.rays.unit_dir_for(b);
        let direction = (self.u * h.x + self.w * h.y) * (1.0 - beta * beta).max(0.0).sqrt() + self.a * beta;
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

impl HollowCylinder {
    /// The direct image of `target` (seen as `t` from `eye`), when the
    /// straight line from the eye misses the tube.
    pub(crate) fn direct_image(&self, eye: &Eye, t: &Target, target: DVec3) -> Option<CylImage> {
        if t.in_hollow {
            return None;
        }
        let (e, p) = (eye.e, t.p);
        let seg = p - e;
        let l = seg.length();
        let blocked =
            l > 0.0 && circle(e, seg / l, self.outer_radius).is_some_and(|(t0, t1)| t1 > 0.0 && t0 < l);
        if blocked {
            return None;
        }
        Some(CylImage {
            family: Family::Direct,
            direction: (target - eye.at) / t.dist,
            position: target,
            refractions: 0,
            parity: 1,
            impact: 0.0,
        })
    }

    /// The image for a solved (b, β): direction, position and, with
    /// `with_parity`, its parity (three more path evaluations).
    pub(crate) fn image_at(
        &self,
        fam: Family,
        eye: &Eye,
        t: &Target,
        b: f64,
        beta: f64,
        with_parity: bool,
    ) -> Option<CylImage> {
        let (e, p) = (eye.e, t.p);
        let gval = |b: f64, beta: f64| self.signed_miss(fam, e, p, b, beta, t.in_hollow);
        let img = EyeTerms::for_tube(self, e).image(fam, eye.at, t.dist, b, beta);
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
