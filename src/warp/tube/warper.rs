//! The fast exact solver for many targets seen from one eye (mesh
//! warping): `CylinderWarper`.
//!
//! For a mesh the eye is fixed, so the final 2-D ray of each family
//! depends only on (b, β): the warper tabulates it once per β bin
//! (`table`), brackets each target's roots from the table of its bin (the
//! plans of `plan` settle most entries once per cell of targets), and
//! solves both equations (the ray passes the target across the axis, and
//! it climbs to the target's height) together by Newton in (b, β)
//! (`polish`). A root the polish cannot finish falls back to the damped
//! Newton and the robust refinement. The answer is the same exact image
//! as the robust sampler's (checked to 1e-9); what can differ is a pair of
//! images within a bin's width of a caustic, where the pair exists at the
//! target's β but not at the bin's (or the reverse).
use super::family::Family;
use super::geometry::{Eye, HollowCylinder, Target};
use super::image::{CylImage, CylStatus, EyeTerms};
use super::lanes::{Consts, SimdLevel};
use super::plan::{Plans, PLAN_MIN_TARGETS};
use super::polish::{polish_all, Job, Polish, PolishScratch};
use super::scan::Candidate;
use super::table::{Tables, BIN, FAMILIES};
use glam::{DVec2, DVec3};

/// Tables for one eye and one tube.
pub struct CylinderWarper {
    cyl: HollowCylinder,
    /// The eye in the tube's frame (once per eye, not per target).
    pub(crate) eye: Eye,
    /// Which tables exist: hollow2, and the families of targets outside.
    hollow: bool,
    outside: bool,
    pub(crate) tables: Tables,
    /// The inverse table: scan plans for the cells of target space the
    /// targets of `for_targets` fall in (none for `new`).
    pub(crate) plans: Option<Plans>,
    /// The tube and the eye for the vector evaluations, and their level.
    lanes: Consts,
    /// The eye's terms of an image's direction (`collect`).
    terms: EyeTerms,
    /// `EDGE_SLOW_STEPS` (the tests compare with `u32::MAX`).
    edge_slow: u32,
}

impl CylinderWarper {
    /// Tables for targets whose straight elevation β0 lies in [lo, hi].
    ///
    /// # Errors
    /// `EyeNotOutside` when the eye is within the outer radius.
    pub fn new(cyl: HollowCylinder, eye: DVec3, lo: f64, hi: f64) -> Result<Self, CylStatus> {
        Self::build(cyl, eye, lo, hi, true, true)
    }

    /// Tables for `targets` (a mesh's vertices): their range of straight
    /// elevations, and only the families they can need: hollow2 when some
    /// target is in the hollow, the others when some is outside the tube
    /// (the bench's plane and the reference scene have nothing in the
    /// hollow: a third of the table entries less). A target of a kind
    /// without tables is answered by the robust sampler.
    ///
    /// # Errors
    /// `EyeNotOutside` when the eye is within the outer radius.
    pub fn for_targets(cyl: HollowCylinder, eye: DVec3, targets: &[DVec3]) -> Result<Self, CylStatus> {
        use rayon::prelude::*;
        // In parallel, as are the inverse table's passes over the targets:
        // on one thread they would be a third of this call's wall time. min,
        // max and `|` give the same answer in any order.
        type Range = (f64, f64, bool, bool);
        let empty: Range = (f64::INFINITY, f64::NEG_INFINITY, false, false);
        let (mut lo, mut hi, hollow, outside) = targets
            .par_chunks(4096)
            .map(|ch| {
                let (mut lo, mut hi, mut hollow, mut outside) = empty;
                for &t in ch {
                    let d = t - eye;
                    let l = d.length();
                    if l > 0.0 {
                        let b = d.dot(cyl.axis_direction) / l;
                        lo = lo.min(b);
                        hi = hi.max(b);
                    }
                    let rp = cyl.to2(t).0.length();
                    hollow |= rp <= cyl.inner_radius;
                    outside |= rp >= cyl.outer_radius;
                }
                (lo, hi, hollow, outside)
            })
            .reduce(
                || empty,
                |a, b| (a.0.min(b.0), a.1.max(b.1), a.2 | b.2, a.3 | b.3),
            );
        if lo > hi {
            (lo, hi) = (0.0, 0.0);
        }
        let mut w = Self::build(cyl, eye, lo, hi, hollow, outside)?;
        w.build_plans(targets, PLAN_MIN_TARGETS);
        Ok(w)
    }

    fn build(
        cyl: HollowCylinder,
        eye: DVec3,
        lo: f64,
        hi: f64,
        hollow: bool,
        outside: bool,
    ) -> Result<Self, CylStatus> {
        let eye = cyl.eye(eye);
        if eye.e.length() <= cyl.outer_radius {
            return Err(CylStatus::EyeNotOutside);
        }
        Ok(CylinderWarper {
            cyl,
            eye,
            hollow,
            outside,
            tables: Tables::build(&cyl, eye.e, lo, hi, hollow, outside),
            plans: None,
            lanes: Consts::new(&cyl, eye.e),
            terms: EyeTerms::for_tube(&cyl, eye.e),
            edge_slow: EDGE_SLOW_STEPS,
        })
    }

    /// Evaluates the Newton polishes at most at level `max` from now on
    /// (the widest the CPU has is the default): the bench and the tests
    /// compare the levels, whose images are the same bits.
    pub fn set_simd_level(&mut self, max: SimdLevel) {
        self.lanes = Consts::with_level(&self.cyl, self.eye.e, max);
    }

    /// The level the Newton polishes are evaluated at.
    pub fn simd_level(&self) -> SimdLevel {
        self.lanes.level()
    }

    /// Where a target falls: how the solvers see it, and its β bin
    /// (`None` outside the tabulated range). The solver and the inverse
    /// table use this one function, so that a target always meets the plan
    /// of the cell it was located in.
    #[inline]
    pub(crate) fn locate(&self, target: DVec3) -> (Target, Option<usize>) {
        let t = self.cyl.target(&self.eye, target);
        (t, self.tables.bin_of(t.beta0()))
    }

    /// Builds the inverse table for `targets`: one scan plan per (β bin,
    /// cell of the 2-D target plane, family) that at least `min_targets` of
    /// them fall in (see `Plans`).
    pub(crate) fn build_plans(&mut self, targets: &[DVec3], min_targets: usize) {
        use rayon::prelude::*;
        let located: Vec<(DVec2, usize)> = targets
            .par_iter()
            .filter_map(|&t| {
                let (t, bin) = self.locate(t);
                (t.dist > 0.0 && t.p.is_finite()).then_some((t.p, bin?))
            })
            .collect();
        if let Some(plans) = Plans::build(&self.tables, self.eye.e, &located, min_targets) {
            self.plans = Some(plans);
        }
    }

    /// All images of `target` (as `HollowCylinder::images`).
    pub fn images(&self, target: DVec3) -> Result<Vec<CylImage>, CylStatus> {
        let mut out = Vec::new();
        self.images_into(target, true, &mut out)?;
        Ok(out)
    }

    /// The same images without their parity (0): what the renderer needs.
    pub fn images_no_parity(&self, target: DVec3) -> Result<Vec<CylImage>, CylStatus> {
        let mut out = Vec::new();
        self.images_into(target, false, &mut out)?;
        Ok(out)
    }

    /// The images of `target` into `out` (cleared first), with their parity
    /// or without it (0, the renderer's call): the same images as `images`
    /// without an allocation per target when `out` is reused. Outside the
    /// tabulated β range `out` gets the robust sampler's images.
    ///
    /// # Errors
    /// As `HollowCylinder::images` (a target inside the glass).
    pub fn images_into(&self, target: DVec3, parity: bool, out: &mut Vec<CylImage>) -> Result<(), CylStatus> {
        out.clear();
        let mut res = Ok(());
        self.images_batch(&[target], parity, |_, r| match r {
            Ok(ims) => out.extend_from_slice(ims),
            Err(e) => res = Err(e),
        });
        res
    }

    /// The images of every target of `targets`, handed to `each` with the
    /// target's index in order (`Err` as `images_into`). Targets are solved
    /// `BATCH_PER_LANE` per vector lane at a time: their Newton polishes
    /// are evaluated four or eight at once (`lanes`), so this is the
    /// renderer's call; `images_into` is a batch of one.
    pub fn images_batch<F>(&self, targets: &[DVec3], parity: bool, mut each: F)
    where
        F: FnMut(usize, Result<&[CylImage], CylStatus>),
    {
        let mut sc = SCRATCH.with(|c| c.take());
        let batch = BATCH_PER_LANE * self.lanes.lanes().max(4);
        for (ci, chunk) in targets.chunks(batch).enumerate() {
            sc.jobs.clear();
            sc.ctx.clear();
            if sc.outs.len() < chunk.len() {
                sc.outs.resize_with(chunk.len(), Vec::new);
            }
            for (i, &target) in chunk.iter().enumerate() {
                let out = &mut sc.outs[i];
                out.clear();
                let ctx = self.prepare(target, out, &mut sc.cands, &mut sc.jobs);
                sc.ctx.push(ctx);
            }
            polish_all(&self.lanes, &mut sc.jobs, &mut sc.polish);
            let mut start = 0;
            for (i, ctx) in sc.ctx.iter().enumerate() {
                let out = &mut sc.outs[i];
                let res = match *ctx {
                    Prepared::Done(res) => res,
                    Prepared::Jobs { end, target } => {
                        let jobs = &sc.jobs[start..end];
                        start = end;
                        self.collect(jobs, &target, parity, out);
                        Ok(())
                    }
                };
                each(ci * batch + i, res.map(|()| &out[..]));
            }
        }
        SCRATCH.with(|c| c.replace(sc));
    }

    /// A target's first phase: its direct image into `out`, and a polish
    /// job per bracket (or an edge job) onto `jobs`; or the whole answer
    /// when the target is inside the glass or answered by the robust
    /// sampler.
    fn prepare(
        &self,
        target: DVec3,
        out: &mut Vec<CylImage>,
        cands: &mut Vec<Candidate>,
        jobs: &mut Vec<Job>,
    ) -> Prepared {
        let c = &self.cyl;
        let (t, bin) = self.locate(target);
        let (p, dist, in_hollow) = (t.p, t.dist, t.in_hollow);
        let rp = p.length();
        if rp > c.inner_radius && rp < c.outer_radius {
            return Prepared::Done(Err(CylStatus::InsideGlass));
        }
        if let Some(direct) = c.direct_image(&self.eye, &t, target) {
            out.push(direct);
        }
        let tabulated = if in_hollow { self.hollow } else { self.outside };
        let Some(bin) = bin.filter(|_| tabulated) else {
            // Outside the tabulated range or kinds: the robust path.
            return Prepared::Done(c.images(self.eye.at, target).map(|v| *out = v));
        };
        let table = &self.tables.bins[bin];
        // The cell's scan plans, if the inverse table has them.
        let plan = self.plans.as_ref().and_then(|pl| pl.find(bin, p));
        // Edge candidates: a run end whose |g| falls below this. The family
        // edge moves with β, and an image's β can be a bin or two from the
        // table's (a tolerance of 0.001·dist loses tir2 images at the TIR
        // edge in `no_image_lost_on_random_targets`).
        let edge_tol = 0.5 * BIN * dist;
        // Entries whose final ray starts up to 2 % of the distance beyond the
        // target still bracket: for a target just outside the tube the root
        // can sit where `along` crosses 0 between two entries (the same test
        // loses a through4 image without it). Newton then demands along > 0
        // at the image itself.
        let along_min = -0.02 * dist;
        for (fi, &fam) in FAMILIES.iter().enumerate() {
            if (fam == Family::Hollow2) != in_hollow {
                continue;
            }
            let tab = &table[fi];
            let gk = |k: usize| tab.gx[k] * p.x + tab.gy[k] * p.y - tab.gc[k];
            cands.clear();
            match plan {
                Some((pl, spans)) => {
                    let (a, b) = spans[fi];
                    tab.candidates_plan(p, edge_tol, along_min, &pl.segs[a as usize..b as usize], cands);
                }
                None => {
                    tab.candidates_into(p, edge_tol, along_min, cands);
                }
            }
            for &cand in cands.iter() {
                jobs.push(match cand {
                    Candidate::Bracket(k0, k1) => {
                        // First guesses: b by the secant through the two
                        // samples, β the target's straight elevation (a
                        // closer β costs more than the Newton steps it
                        // saves).
                        let (g0, g1) = (gk(k0), gk(k1));
                        let w = if g0 == g1 { 0.5 } else { g0 / (g0 - g1) };
                        let b = tab.b[k0] + w * (tab.b[k1] - tab.b[k0]);
                        Job::Bracket(Polish::new(fam, &t, b, (tab.b[k0], tab.b[k1])))
                    }
                    Candidate::Edge(k) => Job::Edge(fam, tab.b[k]),
                });
            }
        }
        Prepared::Jobs {
            end: jobs.len(),
            target: t,
        }
    }

    /// A target's last phase: each job's image (the polished root, or the
    /// fallbacks), in job order, onto `out` unless already there.
    fn collect(&self, jobs: &[Job], t: &Target, parity: bool, out: &mut Vec<CylImage>) {
        let (c, eye) = (&self.cyl, &self.eye);
        for job in jobs {
            let img = match *job {
                Job::Bracket(ref pol) => {
                    let fam = pol.fam;
                    pol.result()
                        .and_then(|(b, beta)| {
                            if parity {
                                c.image_at(fam, eye, t, b, beta, true)
                            } else {
                                // `image_at` without the parity, the eye's
                                // terms hoisted (the same bits).
                                Some(self.terms.image(fam, eye.at, t.dist, b, beta))
                            }
                        })
                        .or_else(|| c.newton_image_opts(fam, eye, t, pol.b0, parity, u32::MAX))
                        .or_else(|| c.refine(fam, eye, t, pol.bracket))
                }
                // Impatient: see `newton_image_opts`' `slow_limit`.
                Job::Edge(fam, bk) => c.newton_image_opts(fam, eye, t, bk, parity, self.edge_slow),
            };
            if let Some(img) = img {
                if !out.iter().any(|o: &CylImage| {
                    o.family == img.family && (o.direction - img.direction).length_squared() < 1e-18
                }) {
                    out.push(img);
                }
            }
        }
    }
}

/// Targets per batch of `images_batch` per lane of an evaluation (at least
/// four lanes' worth: the scalar level gains nothing from smaller batches).
/// ~2 polishes each: eight evaluations per pass at first, fewer as the
/// polishes converge.
const BATCH_PER_LANE: usize = 4;

/// A target after `prepare`.
#[derive(Clone, Copy)]
enum Prepared {
    /// Answered (the robust sampler's images are in its `out`), or an error.
    Done(Result<(), CylStatus>),
    /// Its jobs end at `end` in the batch's job list (they start where the
    /// previous target's ended).
    Jobs { end: usize, target: Target },
}

/// A thread's buffers for `images_batch`, reused across calls (no
/// allocation per target).
#[derive(Default)]
struct Scratch {
    outs: Vec<Vec<CylImage>>,
    ctx: Vec<Prepared>,
    jobs: Vec<Job>,
    cands: Vec<Candidate>,
    polish: PolishScratch,
}

/// An edge candidate's damped Newton gives up after this many slow steps
/// in a row (`HollowCylinder::newton_image_opts`' `slow_limit`; 3 loses an
/// image in the tests, so 10 leaves a margin).
const EDGE_SLOW_STEPS: u32 = 10;

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

#[cfg(test)]
mod tests {
    use super::super::test_rng::Lcg;
    use super::*;

    /// Tables built for the targets (`for_targets`: their β range, only the
    /// families they need) give the same images as tables for every family
    /// over a wider range; a target of a kind the tables skipped (in the
    /// hollow, for tables built for targets outside) still gets every
    /// robust image.
    #[test]
    fn tables_for_the_targets_give_the_same_images() {
        let eye = DVec3::new(0.3, 0.2, 4.0);
        let c = HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, 0.8, 1.5).unwrap();
        let outside: Vec<DVec3> = (0..400)
            .map(|i| {
                let (x, y) = ((i % 20) as f64, (i / 20) as f64);
                DVec3::new(-3.0 + 0.3 * x, -1.0 + 0.1 * y, -3.0 + 0.05 * x)
            })
            .collect();
        let all = CylinderWarper::new(c, eye, -0.7, 0.7).unwrap();
        let mut only = CylinderWarper::for_targets(c, eye, &outside).unwrap();
        assert!(only.outside && !only.hollow);
        // The inverse table's plans for every target's cell (the images
        // must be the same with them as with the scan of `all`).
        only.build_plans(&outside, 1);
        assert!(only.plans.as_ref().is_some_and(|p| !p.spans.is_empty()));
        let skipped: usize = only.tables.bins.iter().map(|t| t[3].b.len()).sum();
        assert_eq!(skipped, 0, "hollow2 tables built for targets outside");
        let mut images = 0;
        for &t in &outside {
            let (a, b) = (all.images(t).unwrap(), only.images(t).unwrap());
            assert_eq!(a.len(), b.len(), "{t}");
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(x.family, y.family, "{t}");
                assert!((x.direction - y.direction).length() < 1e-12, "{t}: {x:?} {y:?}");
            }
            images += a.len();
        }
        assert!(images > outside.len(), "{images}");
        for t in [DVec3::new(0.1, 0.3, -0.2), DVec3::new(-0.5, -0.4, 0.3)] {
            let robust = c.images(eye, t).unwrap();
            let fast = only.images(t).unwrap();
            assert!(!robust.is_empty());
            for r in &robust {
                assert!(
                    fast.iter()
                        .any(|f| f.family == r.family && (f.direction - r.direction).length() < 1e-9),
                    "{t}: {r:?} not in {fast:?}"
                );
            }
        }
    }

    /// The renderer's call gives the same images, bit for bit, at every
    /// SIMD level this CPU has (the batch size follows the level's lanes,
    /// and AVX-512 runs a last group of four rows in AVX2's lanes), for
    /// targets outside the tube and in the hollow, with and without parity.
    #[test]
    fn every_simd_level_gives_the_same_images() {
        let eye = DVec3::new(0.3, 0.2, 4.0);
        let c = HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, 0.6, 1.5).unwrap();
        let mut rng = Lcg(5);
        let pts: Vec<DVec3> = (0..3000)
            .map(|i| {
                if i % 5 == 0 {
                    // In the hollow.
                    let (r, a) = (0.55 * rng.next().sqrt(), rng.next() * std::f64::consts::TAU);
                    DVec3::new(r * a.cos(), rng.next() * 2.0 - 1.0, r * a.sin())
                } else {
                    DVec3::new(
                        rng.next() * 8.0 - 4.0,
                        rng.next() * 3.0 - 1.5,
                        -1.2 - 2.0 * rng.next(),
                    )
                }
            })
            .collect();
        let mut w = CylinderWarper::for_targets(c, eye, &pts).unwrap();
        assert_eq!(w.simd_level(), SimdLevel::detect());
        let run = |w: &CylinderWarper, parity: bool| {
            let mut out = Vec::new();
            for ch in pts.chunks(97) {
                w.images_batch(ch, parity, |_, r| out.push(format!("{r:?}")));
            }
            out
        };
        let (want, want_parity) = (run(&w, false), run(&w, true));
        let images = want.iter().filter(|s| s.contains("CylImage")).count();
        assert!(images > 2000, "{images}");
        for level in [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Scalar] {
            w.set_simd_level(level);
            assert_eq!(w.simd_level(), level.min(SimdLevel::detect()));
            // `{:?}` of an f64 is its shortest round trip: equal strings are
            // equal bits (a NaN aside).
            assert!(run(&w, false) == want, "{level:?}");
            assert!(run(&w, true) == want_parity, "{level:?}");
        }
    }

    /// An edge candidate's impatient damped Newton (`EDGE_SLOW_STEPS`)
    /// finds the same images as the patient one (`u32::MAX`, the robust
    /// sampler's): on a grid of the bench's plane and on targets whose
    /// images lie near the family edges, for r = 0.8 and 0.5. It tells a
    /// limit that is too eager: limits of 1 and 2 fail it.
    #[test]
    fn impatient_edges_find_the_same_images() {
        let images_with = |w: &CylinderWarper, pts: &[DVec3]| {
            let mut all = Vec::new();
            w.images_batch(pts, false, |_, r| {
                all.push(r.map(|v| v.to_vec()).unwrap_or_default())
            });
            all
        };
        let mut edge_images = 0;
        for (r_in, eye) in [(0.8, DVec3::new(0.0, 0.0, 4.0)), (0.5, DVec3::new(0.7, 0.3, 3.5))] {
            let c = HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, r_in, 1.5).unwrap();
            let m = 120;
            let mut pts: Vec<DVec3> = (0..m * m)
                .map(|i| {
                    DVec3::new(
                        -6.0 + 12.0 * (i % m) as f64 / m as f64,
                        -4.5 + 9.0 * (i / m) as f64 / m as f64,
                        -3.0,
                    )
                })
                .collect();
            // Targets reached by eye rays 1e-2..1e-9 inside and outside the
            // family edges (the silhouette, the inner wall's seam and TIR
            // edge), as `no_image_lost_on_random_targets` makes them.
            let (e2, _) = c.to2(eye);
            let mut rng = Lcg(11);
            for _ in 0..1500 {
                let edges = [1.0, r_in, (r_in * 1.5f64).min(1.0)];
                let edge = edges[(rng.next() * 3.0) as usize % 3];
                let off = 10f64.powf(-2.0 - 7.0 * rng.next()) * if rng.next() < 0.5 { -1.0 } else { 1.0 };
                let b = (edge + off) * if rng.next() < 0.5 { -1.0 } else { 1.0 };
                if b.abs() >= 1.0 || b.abs() >= e2.length() {
                    continue;
                }
                let beta = rng.next() * 1.2 - 0.6;
                let fams = [Family::Through4, Family::Tir2, Family::Wall2];
                let fam = fams[(rng.next() * 3.0) as usize % 3];
                if let Some((o, d)) = c.final_ray(fam, e2, b, beta, false) {
                    let q = o + d * (1.0 + 4.0 * rng.next());
                    if q.length() > 1.0 {
                        let (u, w, a) = c.frame_axes();
                        pts.push(u * q.x + w * q.y + a * (rng.next() * 4.0 - 2.0));
                    }
                }
            }
            let fast = CylinderWarper::for_targets(c, eye, &pts).unwrap();
            let mut patient = CylinderWarper::for_targets(c, eye, &pts).unwrap();
            patient.edge_slow = u32::MAX;
            let (a, b) = (images_with(&fast, &pts), images_with(&patient, &pts));
            for ((t, x), y) in pts.iter().zip(&a).zip(&b) {
                assert_eq!(x.len(), y.len(), "{t}: {x:?} {y:?}");
                for (x, y) in x.iter().zip(y) {
                    assert_eq!(x.family, y.family, "{t}");
                    assert!((x.direction - y.direction).length() < 1e-12, "{t}: {x:?} {y:?}");
                }
            }
            // How many images come from edge candidates at all: the
            // comparison must have some to compare.
            let mut none = CylinderWarper::for_targets(c, eye, &pts).unwrap();
            none.edge_slow = 0;
            let c0: usize = images_with(&none, &pts).iter().map(Vec::len).sum();
            let c1: usize = b.iter().map(Vec::len).sum();
            edge_images += c1 - c0;
        }
        assert!(edge_images > 10, "{edge_images}");
    }
}
