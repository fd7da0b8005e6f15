//! The fast solver's tables: for one eye, per β bin and family, the final
//! 2-D rays of sampled impact parameters as linear forms in the target, so
//! that bracketing a target's roots is a tight loop (the bounded scan).
use super::family::Family;
use super::geometry::HollowCylinder;
use super::scan::{Candidate, Scanner};
use glam::DVec2;

#[cfg(test)]
use super::scan::scan_candidates;

/// Width of a β bin (the table's β is the bin centre). Wider bins halve
/// the tables and the plans (a per-frame cost that parallelises poorly)
/// for a little more work per target: a wider edge tolerance
/// (`0.5·BIN·dist`) and first guesses from a farther bin centre.
pub(crate) const BIN: f64 = 0.02;

/// The families with tables, in the order of a bin's tables.
pub(crate) const FAMILIES: [Family; 4] = [Family::Through4, Family::Tir2, Family::Wall2, Family::Hollow2];

/// The tables of one eye and tube.
pub(crate) struct Tables {
    /// The lower edge of bin 0 in β.
    pub(crate) beta_lo: f64,
    /// [bin][family, as `FAMILIES`].
    pub(crate) bins: Vec<[Table; 4]>,
}

impl Tables {
    /// Tables for the eye at `e` (across the axis) and targets whose
    /// straight elevation lies in [`lo`, `hi`]: hollow2's when `hollow`
    /// (some target is in the hollow), the others' when `outside`.
    pub(crate) fn build(
        cyl: &HollowCylinder,
        e: DVec2,
        lo: f64,
        hi: f64,
        hollow: bool,
        outside: bool,
    ) -> Tables {
        use rayon::prelude::*;
        let lo = lo.clamp(-0.99, 0.99) - BIN;
        let hi = hi.clamp(-0.99, 0.99) + BIN;
        let n = (((hi - lo) / BIN).ceil() as usize).max(1);
        let bmax = cyl.outer_radius.min(e.length()) * (1.0 - 1e-15);
        let bins = (0..n)
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
                let tir_edge = cyl.inner_radius * mg / ma;
                FAMILIES.map(|fam| {
                    let mut t = Table::default();
                    if !(if fam == Family::Hollow2 { hollow } else { outside }) {
                        return t;
                    }
                    // Only the samples inside the family's b domain: `path`
                    // would reject the others after most of its square
                    // roots. Widened by 1e-9 so that `path` alone decides at
                    // the edges.
                    let (lo, hi) = (1.0 - 1e-9, 1.0 + 1e-9);
                    let inside = |b: f64| {
                        let ab = b.abs();
                        match fam {
                            Family::Through4 | Family::Hollow2 => ab < cyl.inner_radius * hi,
                            Family::Tir2 => ab > cyl.inner_radius * lo && ab < tir_edge * hi,
                            _ => ab > tir_edge * lo,
                        }
                    };
                    for &b in samples.iter().filter(|&&b| inside(b)) {
                        if let Some((o, d)) = cyl.final_ray(fam, e, b, beta, fam == Family::Hollow2) {
                            if t.b.last().is_some_and(|&last| last < 0.0 && b > 0.0) {
                                // tir2 and wall2 have a band on each side of
                                // the axis: mark the gap between them, or the
                                // scan would bracket a "root" across it (a
                                // failed Newton and a bisection each).
                                t.push_gap();
                            }
                            t.push(b, o, d);
                        }
                    }
                    t.finish_blocks();
                    t
                })
            })
            .collect();
        Tables { beta_lo: lo, bins }
    }

    /// The bin of the straight elevation `beta0` (`None` outside the
    /// tabulated range).
    #[inline]
    pub(crate) fn bin_of(&self, beta0: f64) -> Option<usize> {
        // floor() by truncation where it is the same (x ≥ 0; a NaN fails):
        // the baseline x86-64 has no rounding instruction, floor is a call.
        let x = (beta0 - self.beta_lo) / BIN;
        (x >= 0.0 && (x as usize) < self.bins.len()).then_some(x as usize)
    }
}

/// One family's table in one β bin, as linear forms in the target `p`:
/// `g = gx·p.x + gy·p.y − gc` (the target's signed distance from the final
/// ray) and `along = dir·p − ac` (must be > 0), for ascending `b`. Struct of
/// arrays so the per-target scan is a tight loop.
#[derive(Default)]
pub(crate) struct Table {
    pub(crate) b: Vec<f64>,
    pub(crate) gx: Vec<f64>,
    pub(crate) gy: Vec<f64>,
    pub(crate) gc: Vec<f64>,
    pub(crate) ac: Vec<f64>,
    /// Per block of `BLOCK` consecutive entries: the middle entry's linear
    /// forms and the largest deviation of the block's coefficients from them.
    pub(crate) blocks: Vec<Block>,
}

/// Entries per block of the bounded scan.
pub(crate) const BLOCK: usize = 16;

/// Bounds of a block: for any target p, every entry's
/// `g = gx·p.x + gy·p.y − gc` is within `dx·|p.x| + dy·|p.y| + dc` of the
/// middle entry's, and its `along = gy·p.x − gx·p.y − ac` within
/// `dy·|p.x| + dx·|p.y| + dac` of the middle entry's (dx, dy, dc, dac the
/// largest deviations of the block's coefficients from the middle entry's).
/// Stored with the rounding margin of the linear forms folded in (a few
/// ulps of their terms, `1e-12·(|gx|·|p.x| + |gy|·|p.y| + |gc| + 1)`):
/// `ex = dx + 1e-12·|gx|`, `ey = dy + 1e-12·|gy|`,
/// `ec = dc + 1e-12·(|gc| + 1)`, `eac = dac + 1e-12·(|ac| + 1)`, so a test
/// is three multiply-adds. `ec` is +∞ for a block of one entry (never
/// skipped) and `eac` NaN for a block holding a gap entry (never quiet).
#[derive(Clone, Copy, Default)]
pub(crate) struct Block {
    pub(crate) gx: f64,
    pub(crate) gy: f64,
    pub(crate) gc: f64,
    pub(crate) ac: f64,
    pub(crate) ex: f64,
    pub(crate) ey: f64,
    pub(crate) ec: f64,
    pub(crate) eac: f64,
}

impl Table {
    /// The bounded scan: a block whose entries all have the same sign of g
    /// and |g| above the edge tolerance (by its bounds) can hold no
    /// candidate; only its first and last entries go through the scanner
    /// (the same candidates as the full scan, see `Scanner`). The others are
    /// evaluated entry by entry.
    #[cfg(test)]
    fn candidates(&self, p: DVec2, edge_tol: f64, along_min: f64) -> (Vec<Candidate>, usize) {
        let mut out = Vec::new();
        let quiet = self.candidates_into(p, edge_tol, along_min, &mut out);
        (out, quiet)
    }

    /// The full scan's candidates (every entry, `scan_candidates`): what
    /// the bounded scan and the plans must find.
    #[cfg(test)]
    pub(crate) fn full_candidates(&self, p: DVec2, edge_tol: f64, along_min: f64) -> Vec<Candidate> {
        scan_candidates(
            &self.b,
            |k| {
                let along = self.gy[k] * p.x - self.gx[k] * p.y - self.ac[k];
                (along > along_min).then(|| self.gx[k] * p.x + self.gy[k] * p.y - self.gc[k])
            },
            edge_tol,
        )
    }

    /// `candidates`, appended to `out` (a buffer reused across families).
    /// An entry counts when the target is more than `along_min` ahead of its
    /// final ray's origin. Returns the number of quiet blocks (evaluated by
    /// their bounds alone), for the tests.
    pub(crate) fn candidates_into(
        &self,
        p: DVec2,
        edge_tol: f64,
        along_min: f64,
        out: &mut Vec<Candidate>,
    ) -> usize {
        let n = self.b.len();
        let gk = |k: usize| self.gx[k] * p.x + self.gy[k] * p.y - self.gc[k];
        let ak = |k: usize| self.gy[k] * p.x - self.gx[k] * p.y - self.ac[k];
        let (ax, ay) = (p.x.abs(), p.y.abs());
        let mut sc = Scanner::new(edge_tol, out);
        let mut quiet = 0;
        for (j, bl) in self.blocks.iter().enumerate() {
            let (lo, hi) = (j * BLOCK, ((j + 1) * BLOCK).min(n));
            let m = bl.gx * p.x + bl.gy * p.y - bl.gc;
            if m.abs() > bl.ex * ax + bl.ey * ay + bl.ec + edge_tol {
                let am = bl.gy * p.x - bl.gx * p.y - bl.ac;
                if am - (bl.ey * ax + bl.ex * ay + bl.eac) > along_min {
                    // Every entry valid, of the sign of m, |g| above the
                    // tolerance: the scanner needs only that sign
                    // (`Scanner::quiet`), no entry is evaluated.
                    sc.quiet(lo, hi, m);
                    quiet += 1;
                } else {
                    // Whether the target is ahead of the ray (along > 0) may
                    // change inside the block; that only splits runs, which
                    // cannot make a candidate here (see `Scanner`).
                    sc.push(lo, (ak(lo) > along_min).then(|| gk(lo)));
                    sc.push(hi - 1, (ak(hi - 1) > along_min).then(|| gk(hi - 1)));
                }
            } else {
                self.eval_into(&mut sc, lo, hi, p, along_min);
            }
        }
        sc.finish();
        quiet
    }

    /// Evaluate the entries `lo..hi` for the target `p` into `sc`: g where
    /// the target is ahead of the entry's ray (`along > along_min`), a gap
    /// where it is not. Always inlined: called for a few entries at a time,
    /// as a call its prologue, bounds checks and the scanner's state through
    /// memory cost about a third of its instructions.
    #[inline(always)]
    pub(crate) fn eval_into(&self, sc: &mut Scanner<'_>, lo: usize, hi: usize, p: DVec2, along_min: f64) {
        let rows = self.gx[lo..hi]
            .iter()
            .zip(&self.gy[lo..hi])
            .zip(&self.gc[lo..hi])
            .zip(&self.ac[lo..hi]);
        for (k, (((&gx, &gy), &gc), &ac)) in (lo..hi).zip(rows) {
            let along = gy * p.x - gx * p.y - ac;
            sc.push(k, (along > along_min).then_some(gx * p.x + gy * p.y - gc));
        }
    }

    /// `eval_into` of the one entry `k`.
    #[inline(always)]
    pub(crate) fn eval_one(&self, sc: &mut Scanner<'_>, k: usize, p: DVec2, along_min: f64) {
        let (gx, gy) = (self.gx[k], self.gy[k]);
        let along = gy * p.x - gx * p.y - self.ac[k];
        sc.push(k, (along > along_min).then(|| gx * p.x + gy * p.y - self.gc[k]));
    }

    fn finish_blocks(&mut self) {
        let n = self.b.len();
        self.blocks = (0..n.div_ceil(BLOCK))
            .map(|j| {
                let (lo, hi) = (j * BLOCK, ((j + 1) * BLOCK).min(n));
                let m = (lo + hi) / 2;
                let (gx, gy, gc, ac) = (self.gx[m], self.gy[m], self.gc[m], self.ac[m]);
                let (mut dx, mut dy, mut dc, mut dac) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
                for k in lo..hi {
                    dx = dx.max((self.gx[k] - gx).abs());
                    dy = dy.max((self.gy[k] - gy).abs());
                    dc = dc.max((self.gc[k] - gc).abs());
                    // NaN (a gap entry) propagates here, unlike `f64::max`.
                    let d = (self.ac[k] - ac).abs();
                    dac = if d.is_nan() || dac.is_nan() {
                        f64::NAN
                    } else {
                        dac.max(d)
                    };
                }
                Block {
                    gx,
                    gy,
                    gc,
                    ac,
                    ex: dx + 1e-12 * gx.abs(),
                    ey: dy + 1e-12 * gy.abs(),
                    ec: if hi - lo >= 2 {
                        dc + 1e-12 * (gc.abs() + 1.0)
                    } else {
                        f64::INFINITY
                    },
                    eac: dac + 1e-12 * (ac.abs() + 1.0),
                }
            })
            .collect();
    }

    /// An entry that is no entry: NaN coefficients, so that the scan sees
    /// `None` there (along > 0 fails) and the block bounds (`f64::max`
    /// skips NaN) still cover the valid entries around it.
    fn push_gap(&mut self) {
        for v in [&mut self.gx, &mut self.gy, &mut self.gc, &mut self.ac] {
            v.push(f64::NAN);
        }
        self.b.push(0.0);
    }

    fn push(&mut self, b: f64, origin: DVec2, dir: DVec2) {
        // dir × (p − o) = −dir.y·p.x + dir.x·p.y − dir × o
        self.b.push(b);
        self.gx.push(-dir.y);
        self.gy.push(dir.x);
        self.gc.push(dir.perp_dot(origin));
        self.ac.push(dir.dot(origin));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// The bounded scan finds exactly the candidates of the full scan
    /// (every table entry), over targets near and far, in and around the
    /// tube, for every family and β bin they fall in.
    #[test]
    fn bounded_scan_equals_the_full_scan() {
        let eye = DVec3::new(0.3, 0.1, 4.0);
        for inner in [0.8, 0.5] {
            let c = HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, inner, 1.5).unwrap();
            let (e, _) = c.to2(eye);
            let tables = Tables::build(&c, e, -0.6, 0.6, true, true);
            let mut skipped = 0usize;
            let mut quiet = 0usize;
            let mut total = 0usize;
            for i in 0..400 {
                let a = i as f64 * 0.0157;
                let rad = 0.3 + 6.0 * ((i * 7919) % 400) as f64 / 400.0;
                let p = DVec2::new(rad * a.sin(), rad * a.cos() * 0.9 - 0.5);
                if (p - e).length() < 0.2 || (p.length() > inner && p.length() < 1.0) {
                    continue;
                }
                for table in tables.bins.iter().step_by(7) {
                    for t in table.iter() {
                        for (tol, along_min) in [(1e-3, 0.0), (0.05, -0.1)] {
                            let full = t.full_candidates(p, tol, along_min);
                            let (fast, q) = t.candidates(p, tol, along_min);
                            assert_eq!(full, fast, "r={inner} p={p} tol={tol}");
                            quiet += q;
                            total += t.b.len();
                            skipped += t.blocks.len();
                        }
                    }
                }
            }
            // Most blocks take the quiet path (no entry evaluated), so the
            // comparison exercises it.
            assert!(
                total > 100_000 && skipped > 0 && quiet > skipped / 4,
                "{total} {skipped} {quiet}"
            );
            eprintln!("r={inner}: {quiet} quiet blocks of {skipped}");
        }
    }
}
