//! The robust sampler: every image of one target, without tables. About
//! 1,500 samples of b per family (crowded at the family edges), each sign
//! change of the target's miss refined by bisection in b inside a secant
//! iteration on β, each family edge by the damped Newton. The fast solver
//! (`CylinderWarper`) is tested against it.
use super::family::Family;
use super::geometry::{Eye, HollowCylinder, Target};
use super::image::{CylImage, CylStatus};
use super::scan::{scan_candidates, Candidate};
use glam::DVec3;

impl HollowCylinder {
    /// All images of `target` seen from `eye`.
    pub fn images(&self, eye: DVec3, target: DVec3) -> Result<Vec<CylImage>, CylStatus> {
        let eye = self.eye(eye);
        let t = self.target(&eye, target);
        let (e, p, dist, in_hollow) = (eye.e, t.p, t.dist, t.in_hollow);
        let (big, small) = (self.outer_radius, self.inner_radius);
        if e.length() <= big {
            return Err(CylStatus::EyeNotOutside);
        }
        let rp = p.length();
        if rp > small && rp < big {
            return Err(CylStatus::InsideGlass);
        }
        let mut out = Vec::new();
        // Direct: the horizontal segment e → p must miss the outer circle.
        out.extend(self.direct_image(&eye, &t, target));
        let families: &[Family] = if in_hollow {
            &[Family::Hollow2]
        } else {
            &[Family::Through4, Family::Tir2, Family::Wall2]
        };
        let rho = e.length();
        let bmax = big.min(rho) * (1.0 - 1e-15);
        for &fam in families {
            // For a first β take the straight elevation; refine per root below.
            let beta0 = t.beta0();
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
                        self.refine(fam, &eye, &t, (lo0, hi0))
                            .or_else(|| self.newton_image(fam, &eye, &t, 0.5 * (lo0 + hi0)))
                    }
                    Candidate::Edge(k) => self.newton_image(fam, &eye, &t, samples[k]),
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

    /// The root in the bracket (`lo0`, `hi0`) of b: bisection in b for
    /// fixed β, inside a secant iteration on β (from the target's straight
    /// elevation) until the path climbs to the target.
    pub(crate) fn refine(&self, fam: Family, eye: &Eye, t: &Target, bracket: (f64, f64)) -> Option<CylImage> {
        let (e, p, dv, dist, in_hollow) = (eye.e, t.p, t.dv, t.dist, t.in_hollow);
        let (lo0, hi0) = bracket;
        let beta0 = t.beta0();
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
        self.image_at(fam, eye, t, b, beta, true)
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
