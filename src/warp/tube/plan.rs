//! The inverse table: per (β bin, cell of the 2-D target plane) that a
//! warper's targets occupy, each family's scan plan, which settles once per
//! cell the table entries that need no evaluation for any target there.
use super::scan::{Candidate, Scanner};
use super::table::{Table, Tables, BIN, BLOCK};
use glam::DVec2;

/// Side of a cell of the inverse table in the 2-D target plane (metres).
pub(crate) const CELL: f64 = 0.25;

/// Targets a (bin, cell) must hold to get a plan: a plan costs about as
/// much as scanning three or four targets.
pub(crate) const PLAN_MIN_TARGETS: usize = 4;

/// At most this many (bin, cell) slots in the inverse table's grid (beyond
/// it the targets are scanned without plans).
const MAX_SLOTS: usize = 1 << 23;

/// One step of a cell's scan plan (`Table::plan`): entries `lo..hi` quiet
/// (all valid, of one sign, |g| above the tolerance) for every target of
/// the cell, a run of entries invalid for all of them (from entry `k`), or
/// entries to evaluate per target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Seg {
    Quiet {
        lo: u32,
        hi: u32,
        neg: bool,
    },
    /// Entries `lo..hi` of one sign with |g| above the tolerance for every
    /// target of the cell, some of which may not be ahead of some of these
    /// rays: only the first and last are evaluated (`Scanner`: such a
    /// stretch makes the same candidates from its two ends).
    Ends {
        lo: u32,
        hi: u32,
    },
    Gap(u32),
    Eval {
        lo: u32,
        hi: u32,
    },
}

/// How an entry stands for every target of a cell (`Table::plan`).
#[derive(Clone, Copy, PartialEq)]
enum Class {
    /// |g| above the tolerance and of one sign (`neg`) for every target;
    /// `valid`: every target is also ahead of the ray (otherwise some may
    /// not be).
    Far { neg: bool, valid: bool },
    /// No target is ahead of the ray (or a gap entry).
    Invalid,
    /// Anything else: evaluated per target.
    Unknown,
}

/// Run-length coding of the entries' classes into a plan's segments.
struct Runs<'a> {
    segs: &'a mut Vec<Seg>,
    class: Class,
    lo: usize,
}

impl Runs<'_> {
    /// Entry `k` (ascending; a block's first entry stands for the block) is
    /// of `class`. `Far` entries of one sign join one run whatever their
    /// validity.
    #[inline]
    fn set(&mut self, k: usize, class: Class) {
        match (self.class, class) {
            (Class::Far { neg: a, valid: va }, Class::Far { neg: b, valid: vb }) if a == b && k > 0 => {
                self.class = Class::Far {
                    neg: a,
                    valid: va && vb,
                };
            }
            (x, y) if x == y && k > 0 => {}
            _ => {
                self.close(k);
                self.class = class;
            }
        }
    }

    /// Ends the current run before entry `k` (`k = n` after the last entry).
    fn close(&mut self, k: usize) {
        let (lo, hi) = (self.lo as u32, k as u32);
        if hi > lo {
            match self.class {
                Class::Invalid => self.segs.push(Seg::Gap(lo)),
                Class::Far { neg, valid: true } if hi - lo >= 2 => self.segs.push(Seg::Quiet { lo, hi, neg }),
                Class::Far { .. } if hi - lo >= 3 => self.segs.push(Seg::Ends { lo, hi }),
                _ => match self.segs.last_mut() {
                    Some(Seg::Eval { hi: h, .. }) if *h == lo => *h = hi,
                    _ => self.segs.push(Seg::Eval { lo, hi }),
                },
            }
        }
        self.lo = k;
    }
}

/// Each family's range of a plan's segments.
pub(crate) type Spans = [(u32, u32); 4];

/// The inverse table: per (β bin, cell of the 2-D target plane) that the
/// warper's targets occupy, each family's scan plan. A target's images are
/// fixed by three numbers (its 2-D position and its height, i.e. its β
/// bin); within a cell of the plane and a bin, most table entries keep
/// their sign and stay far from the target for every target, so the plan
/// lists only the entries near a root or a family edge, which are then
/// evaluated per target; the rest are settled once per cell. Same
/// candidates as the full scan (`Table::plan`), so the same image count
/// and the same first guesses.
pub(crate) struct Plans {
    /// Lower corner of cell (0, 0).
    origin: DVec2,
    pub(crate) nx: usize,
    pub(crate) ny: usize,
    /// [bin][iy][ix] → index into `spans`, `u32::MAX` for none.
    slot: Vec<u32>,
    /// Per plan, each family's range of `segs`.
    pub(crate) spans: Vec<Spans>,
    pub(crate) segs: Vec<Seg>,
}

impl Plans {
    #[inline]
    pub(crate) fn slot_of(&self, bin: usize, p: DVec2) -> Option<usize> {
        // The cell's floor, by truncation as in `locate`.
        let fx = (p.x - self.origin.x) / CELL;
        let fy = (p.y - self.origin.y) / CELL;
        if !(fx >= 0.0 && fy >= 0.0 && (fx as usize) < self.nx && (fy as usize) < self.ny) {
            return None;
        }
        Some((bin * self.ny + fy as usize) * self.nx + fx as usize)
    }

    /// The cell's corners, widened by 1e-9 for the rounding of `slot_of`.
    pub(crate) fn cell_box(&self, ix: usize, iy: usize) -> [DVec2; 2] {
        let lo = self.origin + DVec2::new(ix as f64, iy as f64) * CELL;
        let pad = DVec2::splat(1e-9 * (1.0 + lo.abs().max_element()));
        [lo - pad, lo + DVec2::splat(CELL) + pad]
    }

    /// The plans of the cell holding `p` in bin `bin`, if built.
    #[inline]
    pub(crate) fn find(&self, bin: usize, p: DVec2) -> Option<(&Plans, &Spans)> {
        let i = *self.slot.get(self.slot_of(bin, p)?)?;
        (i != u32::MAX).then(|| (self, &self.spans[i as usize]))
    }
}

impl Plans {
    /// The plans for targets located at `located` (2-D position and β bin,
    /// as `CylinderWarper::locate` finds them) seen from the eye at `e`
    /// (across the axis): one per (β bin, cell of `CELL`², family) that at
    /// least `min_targets` of them fall in. `None` when no target is
    /// located or the grid would exceed `MAX_SLOTS`.
    pub(crate) fn build(
        tables: &Tables,
        e: DVec2,
        located: &[(DVec2, usize)],
        min_targets: usize,
    ) -> Option<Plans> {
        use rayon::prelude::*;
        if located.is_empty() {
            return None;
        }
        let inf = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        let (lo, hi) = located
            .par_chunks(4096)
            .map(|ch| ch.iter().fold(inf, |(lo, hi), &(p, _)| (lo.min(p), hi.max(p))))
            .reduce(|| inf, |a, b| (a.0.min(b.0), a.1.max(b.1)));
        let nx = ((hi.x - lo.x) / CELL).floor() as usize + 1;
        let ny = ((hi.y - lo.y) / CELL).floor() as usize + 1;
        let bins = tables.bins.len();
        if nx.saturating_mul(ny).saturating_mul(bins) > MAX_SLOTS {
            return None;
        }
        let mut plans = Plans {
            origin: lo,
            nx,
            ny,
            slot: vec![0; nx * ny * bins],
            spans: Vec::new(),
            segs: Vec::new(),
        };
        // Only cells holding at least `min_targets` targets get a plan
        // (`slot` counts them first).
        let slots: Vec<u32> = located
            .par_iter()
            .map(|&(p, bin)| plans.slot_of(bin, p).map_or(u32::MAX, |k| k as u32))
            .collect();
        for &k in &slots {
            if k != u32::MAX {
                plans.slot[k as usize] += 1;
            }
        }
        let keys: Vec<usize> = (0..plans.slot.len())
            .filter(|&k| plans.slot[k] as usize >= min_targets)
            .collect();
        plans.slot.fill(u32::MAX);
        let built: Vec<(Vec<Seg>, Spans)> = keys
            .par_iter()
            .map(|&key| {
                let (bin, iy, ix) = (key / (nx * ny), (key / nx) % ny, key % nx);
                let cell = plans.cell_box(ix, iy);
                let (dmin, dmax) = dist_range(tables, e, bin, cell);
                let mut segs = Vec::new();
                let spans = tables.bins[bin].each_ref().map(|t| {
                    let start = segs.len() as u32;
                    t.plan(cell, dmin, dmax, &mut segs);
                    (start, segs.len() as u32)
                });
                (segs, spans)
            })
            .collect();
        for (&key, (segs, spans)) in keys.iter().zip(built) {
            plans.slot[key] = plans.spans.len() as u32;
            let base = plans.segs.len() as u32;
            plans.segs.extend(segs);
            plans.spans.push(spans.map(|(a, b)| (a + base, b + base)));
        }
        Some(plans)
    }
}

impl Table {
    /// The scan by a cell's plan (`plan`): the same candidates as
    /// `candidates_into` for a target in the cell.
    pub(crate) fn candidates_plan(
        &self,
        p: DVec2,
        edge_tol: f64,
        along_min: f64,
        segs: &[Seg],
        out: &mut Vec<Candidate>,
    ) {
        let mut sc = Scanner::new(edge_tol, out);
        for seg in segs {
            match *seg {
                Seg::Quiet { lo, hi, neg } => {
                    sc.quiet(lo as usize, hi as usize, if neg { -1.0 } else { 1.0 })
                }
                Seg::Gap(k) => sc.push(k as usize, None),
                Seg::Ends { lo, hi } => {
                    let (lo, hi) = (lo as usize, hi as usize);
                    self.eval_one(&mut sc, lo, p, along_min);
                    self.eval_one(&mut sc, hi - 1, p, along_min);
                }
                Seg::Eval { lo, hi } => self.eval_into(&mut sc, lo as usize, hi as usize, p, along_min),
            }
        }
        sc.finish();
    }

    /// The scan plan of this table for every target whose 2-D position is
    /// in `cell` (corners, inclusive) and whose distance from the eye is in
    /// `[dmin, dmax]` (so its edge tolerance is at most `0.5·BIN·dmax` and
    /// its `along_min = −0.02·dist` in `[−0.02·dmax, −0.02·dmin]`, as
    /// the warper sets them). Over the cell each entry's g and `along`
    /// lie within their values at the cell's centre ± the linear forms'
    /// spread over the half-widths (plus the rounding margin of the
    /// blocks, `1e-12·(sum of |terms| + 1)`), and each block's bounds
    /// likewise. An entry (or a whole block) is
    /// - quiet of one sign when it is surely valid (`along` above
    ///   `−0.02·dmin`) and |g| surely above `0.5·BIN·dmax`: runs of two or
    ///   more become one `Seg::Quiet` (`Scanner::quiet` gives the same
    ///   candidates as pushing them);
    /// - of one sign with |g| surely above the tolerance but perhaps not
    ///   valid for every target: a run of such entries (quiet ones of the
    ///   same sign included) is a `Seg::Ends`, whose first and last entries
    ///   are evaluated per target (the stretch of `Scanner`'s argument:
    ///   its valid entries are all of one sign and above the tolerance);
    /// - surely invalid (`along` at most `−0.02·dmax`, or a gap entry):
    ///   a run of them is one `Seg::Gap` (after the first `None` the
    ///   scanner's state no longer changes);
    /// - otherwise evaluated per target (`Seg::Eval`).
    ///
    /// Whole blocks are classed by their bounds first (as the per-target
    /// scan does); only the entries of a block whose g is not settled are
    /// classed one by one.
    ///
    /// So the plan finds the full scan's candidates for every target the
    /// cell and distance range hold (tested against `scan_candidates`).
    pub(super) fn plan(&self, cell: [DVec2; 2], dmin: f64, dmax: f64, segs: &mut Vec<Seg>) {
        let n = self.b.len();
        let [c0, c1] = cell;
        let mid = (c0 + c1) * 0.5;
        let half = (c1 - c0) * 0.5;
        let (ax, ay) = (c0.x.abs().max(c1.x.abs()), c0.y.abs().max(c1.y.abs()));
        let tol = 0.5 * BIN * dmax * (1.0 + 1e-9);
        let valid_above = -0.02 * dmin * (1.0 - 1e-9);
        let invalid_below = -0.02 * dmax * (1.0 + 1e-9);
        let mut runs = Runs {
            segs,
            class: Class::Unknown,
            lo: 0,
        };
        for (j, bl) in self.blocks.iter().enumerate() {
            let (lo, hi) = (j * BLOCK, ((j + 1) * BLOCK).min(n));
            let m = bl.gx * mid.x + bl.gy * mid.y - bl.gc;
            let mr = bl.gx.abs() * half.x
                + bl.gy.abs() * half.y
                + 1e-12 * (bl.gx.abs() * ax + bl.gy.abs() * ay + bl.gc.abs() + 1.0)
                + bl.ex * ax
                + bl.ey * ay
                + bl.ec;
            let am = bl.gy * mid.x - bl.gx * mid.y - bl.ac;
            let ar = bl.gy.abs() * half.x
                + bl.gx.abs() * half.y
                + 1e-12 * (bl.gy.abs() * ax + bl.gx.abs() * ay + bl.ac.abs() + 1.0)
                + bl.ey * ax
                + bl.ex * ay
                + bl.eac;
            if m.abs() - mr > tol {
                // Every entry of one sign, far from every target; whether
                // the targets are ahead may be settled too.
                let class = if am + ar <= invalid_below {
                    Class::Invalid
                } else {
                    Class::Far {
                        neg: m < 0.0,
                        valid: am - ar > valid_above,
                    }
                };
                runs.set(lo, class);
                continue;
            }
            for k in lo..hi {
                let (gx, gy, gc, ac) = (self.gx[k], self.gy[k], self.gc[k], self.ac[k]);
                let class = if gx.is_nan() {
                    Class::Invalid
                } else {
                    let g = gx * mid.x + gy * mid.y - gc;
                    let gr = gx.abs() * half.x
                        + gy.abs() * half.y
                        + 1e-12 * (gx.abs() * ax + gy.abs() * ay + gc.abs() + 1.0);
                    let a = gy * mid.x - gx * mid.y - ac;
                    let ar = gy.abs() * half.x
                        + gx.abs() * half.y
                        + 1e-12 * (gy.abs() * ax + gx.abs() * ay + ac.abs() + 1.0);
                    if a + ar <= invalid_below {
                        Class::Invalid
                    } else if g.abs() - gr > tol {
                        Class::Far {
                            neg: g < 0.0,
                            valid: a - ar > valid_above,
                        }
                    } else {
                        Class::Unknown
                    }
                };
                runs.set(k, class);
            }
        }
        runs.close(n);
    }
}

/// Bounds of the distance from the eye of any target whose 2-D position
/// is in `cell` and whose straight elevation is in β bin `bin`:
/// dist = |p − e| / √(1 − β0²). Widened by 1e-9 (relative) for the
/// rounding of `locate` (a few ulps).
pub(crate) fn dist_range(tables: &Tables, e: DVec2, bin: usize, cell: [DVec2; 2]) -> (f64, f64) {
    let [c0, c1] = cell;
    let near = e.clamp(c0, c1);
    let far = DVec2::new(
        if (e.x - c0.x).abs() > (e.x - c1.x).abs() {
            c0.x
        } else {
            c1.x
        },
        if (e.y - c0.y).abs() > (e.y - c1.y).abs() {
            c0.y
        } else {
            c1.y
        },
    );
    let (h0, h1) = ((near - e).length(), (far - e).length());
    let b0 = tables.beta_lo + bin as f64 * BIN - 1e-9;
    let b1 = tables.beta_lo + (bin + 1) as f64 * BIN + 1e-9;
    let amax = b0.abs().max(b1.abs());
    let amin = if b0 <= 0.0 && b1 >= 0.0 {
        0.0
    } else {
        b0.abs().min(b1.abs())
    };
    // Near |β0| = 1 (a target almost straight along the axis from the
    // eye) 1 − β0² loses its relative precision: there the bounds are
    // dist ≥ h (always true) and no upper bound (the plan then
    // evaluates every entry per target).
    let dmin = if amin > 0.999 {
        h0 * (1.0 - 1e-9)
    } else {
        h0 / (1.0 - amin * amin).sqrt() * (1.0 - 1e-9)
    };
    let dmax = if amax > 0.999 {
        f64::INFINITY
    } else {
        h1 / (1.0 - amax * amax).sqrt() * (1.0 + 1e-9)
    };
    (dmin, dmax)
}
