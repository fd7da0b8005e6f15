//! A fast exact solver for many targets seen from one eye (mesh warping).
//!
//! `HollowCylinder::images` brackets roots by sampling ~1,500 impact
//! parameters per family for every target, then refines β by a secant loop
//! around a bisection: robust, ~0.6 ms per target. For a mesh the eye is
//! fixed, so the final 2-D ray of each family depends only on (b, β): we
//! tabulate it once per β bin (uniform b samples plus samples crowded at the
//! family edges), bracket each target's roots from the table of its bin
//! (a cross product per entry), and solve both equations (the ray passes the
//! target across the axis, and it climbs to the target's height) together by
//! Newton in (b, β) with a finite-difference Jacobian. A root Newton cannot
//! finish falls back to the robust refinement. The answer is the same exact
//! image (checked to 1e-9 like the slow path); what can differ is a pair of
//! images within a bin's width of a caustic, where the pair exists at the
//! target's β but not at the bin's (or the reverse).
use super::cylinder::{CylImage, CylStatus, Family, HollowCylinder};
use glam::{DVec2, DVec3};

/// Width of a β bin (the table's β is the bin centre).
const BIN: f64 = 0.01;

/// One family's table in one β bin, as linear forms in the target `p`:
/// `g = gx·p.x + gy·p.y − gc` (the target's signed distance from the final
/// ray) and `along = dir·p − ac` (must be > 0), for ascending `b`. Struct of
/// arrays so the per-target scan is a tight loop.
#[derive(Default)]
struct Table {
    b: Vec<f64>,
    gx: Vec<f64>,
    gy: Vec<f64>,
    gc: Vec<f64>,
    ac: Vec<f64>,
}

impl Table {
    fn push(&mut self, b: f64, origin: DVec2, dir: DVec2) {
        // dir × (p − o) = −dir.y·p.x + dir.x·p.y − dir × o
        self.b.push(b);
        self.gx.push(-dir.y);
        self.gy.push(dir.x);
        self.gc.push(dir.perp_dot(origin));
        self.ac.push(dir.dot(origin));
    }
}

/// Tables for one eye and one tube.
pub struct CylinderWarper {
    cyl: HollowCylinder,
    eye: DVec3,
    beta_lo: f64,
    /// [bin][family].
    tables: Vec<[Table; 4]>,
}

const FAMILIES: [Family; 4] = [Family::Through4, Family::Tir2, Family::Wall2, Family::Hollow2];

impl CylinderWarper {
    /// Tables for targets whose straight elevation β0 lies in [lo, hi].
    pub fn new(cyl: HollowCylinder, eye: DVec3, lo: f64, hi: f64) -> Result<Self, CylStatus> {
        use rayon::prelude::*;
        let (e, _) = cyl.to2(eye);
        if e.length() <= cyl.outer_radius {
            return Err(CylStatus::EyeNotOutside);
        }
        let lo = lo.clamp(-0.99, 0.99) - BIN;
        let hi = hi.clamp(-0.99, 0.99) + BIN;
        let bins = (((hi - lo) / BIN).ceil() as usize).max(1);
        let bmax = cyl.outer_radius.min(e.length()) * (1.0 - 1e-15);
        let tables = (0..bins)
            .into_par_iter()
            .map(|k| {
                let beta = lo + (k as f64 + 0.5) * BIN;
                let ma = (1.0 - beta * beta).sqrt();
                let mg = (cyl.ior * cyl.ior - beta * beta).sqrt();
                let mut samples: Vec<f64> =
                    (0..=256).map(|i| -bmax + 2.0 * bmax * i as f64 / 256.0).collect();
                for edge in [cyl.inner_radius, cyl.inner_radius * mg / ma, bmax] {
                    for j in 1..=24 {
                        let off = edge * 10f64.powf(-(j as f64) / 2.0);
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
                FAMILIES.map(|fam| {
                    let mut t = Table::default();
                    for &b in &samples {
                        if let Some((o, d)) = cyl.path_public(fam, e, b, beta, fam == Family::Hollow2) {
                            t.push(b, o, d);
                        }
                    }
                    t
                })
            })
            .collect();
        Ok(CylinderWarper {
            cyl,
            eye,
            beta_lo: lo,
            tables,
        })
    }

    /// All images of `target` (as `HollowCylinder::images`).
    pub fn images(&self, target: DVec3) -> Result<Vec<CylImage>, CylStatus> {
        let c = &self.cyl;
        let (e, ev) = c.to2(self.eye);
        let (p, pv) = c.to2(target);
        let rp = p.length();
        if rp > c.inner_radius && rp < c.outer_radius {
            return Err(CylStatus::InsideGlass);
        }
        let in_hollow = rp <= c.inner_radius;
        let dist = (target - self.eye).length();
        let dv = pv - ev;
        let mut out = Vec::new();
        if let Some(direct) = c.direct_image(self.eye, target) {
            out.push(direct);
        }
        let beta0 = dv / dist;
        let bin = ((beta0 - self.beta_lo) / BIN).floor();
        if bin < 0.0 || bin as usize >= self.tables.len() {
            // Outside the tabulated range: the robust path.
            return c.images(self.eye, target);
        }
        let table = &self.tables[bin as usize];
        for (fi, &fam) in FAMILIES.iter().enumerate() {
            if (fam == Family::Hollow2) != in_hollow {
                continue;
            }
            let t = &table[fi];
            // along = dir·p − ac with dir = (gy, −gx).
            let mut prev: Option<(f64, f64)> = None;
            for k in 0..t.b.len() {
                let g = t.gx[k] * p.x + t.gy[k] * p.y - t.gc[k];
                let along = t.gy[k] * p.x - t.gx[k] * p.y - t.ac[k];
                if along <= 0.0 {
                    prev = None;
                    continue;
                }
                if let Some((b0, g0)) = prev {
                    if g0 == 0.0 || (g0 < 0.0) != (g < 0.0) {
                        let b1 = t.b[k];
                        let img = c
                            .newton_image(fam, e, p, dv, dist, self.eye, 0.5 * (b0 + b1), beta0, in_hollow)
                            .or_else(|| {
                                c.refine_public(fam, e, p, dv, dist, self.eye, b0, b1, beta0, in_hollow)
                            });
                        if let Some(img) = img {
                            if !out.iter().any(|o: &CylImage| {
                                o.family == img.family && (o.direction - img.direction).length() < 1e-9
                            }) {
                                out.push(img);
                            }
                        }
                    }
                }
                prev = Some((t.b[k], g));
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fast solver finds every image the robust one finds, and any extra
    /// image it finds is real: the exact 3-D path of its eye ray passes
    /// through the target (the robust sampler can miss a pair near a caustic).
    #[test]
    fn same_images_as_the_robust_solver() {
        let eye = DVec3::new(0.0, 0.0, 4.0);
        for inner in [0.8, 0.5] {
            let c = HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, inner, 1.5).unwrap();
            let w = CylinderWarper::new(c, eye, -0.6, 0.6).unwrap();
            let (mut same, mut total, mut extra) = (0, 0, 0);
            let glass = crate::warp::WarpGlass::Cylinder(c);
            let passes = |t: DVec3, d: DVec3| {
                glass
                    .exact_path(eye, d)
                    .segments
                    .iter()
                    .map(|s| {
                        let rel = t - s.origin;
                        (rel - s.dir * rel.dot(s.dir).clamp(0.0, s.t_end)).length()
                    })
                    .fold(f64::INFINITY, f64::min)
            };
            for i in 0..60 {
                let x = -3.0 + 6.0 * i as f64 / 59.0;
                for y in [-1.3, 0.0, 0.45] {
                    for z in [-3.0, 0.2] {
                        let t = DVec3::new(x * if z > 0.0 { 0.1 } else { 1.0 }, y, z);
                        let (Ok(a), Ok(b)) = (c.images(eye, t), w.images(t)) else {
                            continue;
                        };
                        total += 1;
                        let found_all = a.iter().all(|ia| {
                            b.iter().any(|ib| {
                                ib.family == ia.family && (ib.direction - ia.direction).length() < 1e-8
                            })
                        });
                        for ib in &b {
                            if !a.iter().any(|ia| {
                                ia.family == ib.family && (ib.direction - ia.direction).length() < 1e-8
                            }) {
                                extra += 1;
                                let miss = passes(t, ib.direction);
                                assert!(miss < 1e-8, "r={inner} {t}: extra image {ib:?} misses by {miss}");
                            }
                        }
                        if found_all {
                            same += 1;
                        } else {
                            eprintln!("r={inner} {t}: robust {a:?}\n fast {b:?}");
                        }
                    }
                }
            }
            eprintln!(
                "r={inner}: {same} of {total} targets: all robust images found; {extra} extra (verified)"
            );
            assert!(total > 200 && same == total, "r={inner}: {same} of {total} agree");
        }
    }
}
