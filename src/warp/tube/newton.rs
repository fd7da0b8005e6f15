//! The damped Newton in (b, β) with a finite-difference Jacobian: the
//! robust sampler's polish and the fast solver's fallback, the one solver
//! that also handles images at the family edges.
use super::family::Family;
use super::geometry::{Eye, HollowCylinder, Target};
use super::image::CylImage;

impl HollowCylinder {
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
    pub(crate) fn newton_image(&self, fam: Family, eye: &Eye, t: &Target, b0: f64) -> Option<CylImage> {
        self.newton_image_opts(fam, eye, t, b0, true, u32::MAX)
    }

    /// `newton_image` from (`b0`, the target's straight elevation); without
    /// `parity` the image's parity is left 0 (the renderer does not need
    /// it; it costs three path evaluations).
    ///
    /// The Jacobian (finite differences, two path evaluations) is reused
    /// while full steps keep cutting the residual at least tenfold (a chord
    /// step; from the tables' first guess the second step then needs no new
    /// Jacobian); a step that fails with a reused Jacobian is retried with a
    /// fresh one, so the stall test below only ever judges fresh ones.
    ///
    /// `slow_limit`: give up after this many accepted steps in a row that
    /// each leave more than half of the residual (`u32::MAX`: never). The
    /// fast solver's edge candidates pass a small limit: most of them have
    /// no image and crawl, every step keeping most of the residual, while
    /// the edge images converge in a few steps that each cut it a
    /// hundredfold. Giving up can only lose an image, never accept a wrong
    /// one (acceptance is the residual test below);
    /// `impatient_edges_find_the_same_images` holds the limit to the
    /// patient search's images.
    pub(crate) fn newton_image_opts(
        &self,
        fam: Family,
        eye: &Eye,
        t: &Target,
        b0: f64,
        parity: bool,
        slow_limit: u32,
    ) -> Option<CylImage> {
        let (e, p, dv, dist) = (eye.e, t.p, t.dv, t.dist);
        let beta0 = t.beta0();
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
            let path = self.path(fam, e, b, beta, t.in_hollow)?;
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
            // Forward difference, or backward if forward is outside (the
            // backward point is evaluated only then).
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
        self.image_at(fam, eye, t, to_b(s, beta), beta, parity)
    }
}
