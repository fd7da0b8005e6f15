//! Where a target's roots are: the scan of g(b) over ascending samples
//! (sign changes, and run ends falling towards a family edge), in full
//! (`scan_candidates`) and as a stream that can skip stretches it knows
//! hold no candidate (`Scanner`).

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

/// `scan_candidates` as a stream: entries are pushed in ascending order
/// (index, g or None where the family's ray does not reach the target).
/// For a stretch of entries whose valid ones all have the same sign of g
/// and |g| above the edge tolerance, pushing only its first and last
/// entries finds the same candidates as pushing them all: a candidate
/// needs a sign change between neighbouring valid entries (none inside the
/// stretch, and its first entry meets its predecessor as in the full scan)
/// or a run end with |g| falling to the tolerance (every falling test
/// inside or just after the stretch has one of the stretch's |g| as the
/// smaller value, above the tolerance). The state after it may differ in
/// the run count and the value before last, but both only feed falling
/// tests whose smaller value is the stretch's last |g|, so no later
/// candidate changes. Tested against `scan_candidates`.
///
/// The state is plain scalars (a count of valid entries in the current run,
/// capped at 2, and the last two values) rather than `Option`s: copying an
/// `Option<(usize, f64)>` pair reads back 16 bytes just written as two
/// 8-byte stores, a store-forwarding stall in the solver's hottest loop.
pub(crate) struct Scanner<'a> {
    out: &'a mut Vec<Candidate>,
    /// Valid entries in the current run, at most 2.
    run: u8,
    prev_k: usize,
    prev_g: f64,
    prev2_g: f64,
    tol: f64,
}

impl<'a> Scanner<'a> {
    pub(crate) fn new(tol: f64, out: &'a mut Vec<Candidate>) -> Scanner<'a> {
        Scanner {
            out,
            run: 0,
            prev_k: 0,
            prev_g: 0.0,
            prev2_g: 0.0,
            tol,
        }
    }

    #[inline]
    fn falling(&self, g0: f64, g1: f64) -> bool {
        g1.abs() < g0.abs() && g1.abs() <= self.tol && (g0 < 0.0) == (g1 < 0.0)
    }

    #[inline]
    pub(crate) fn push(&mut self, k: usize, g: Option<f64>) {
        match g {
            Some(gk) => {
                if self.run >= 1 {
                    let g0 = self.prev_g;
                    if g0 == 0.0 || (g0 < 0.0) != (gk < 0.0) {
                        self.out.push(Candidate::Bracket(self.prev_k, k));
                    } else if self.run == 1 && self.falling(gk, g0) {
                        // Second entry of a run: |g| falls towards its start.
                        self.out.push(Candidate::Edge(self.prev_k));
                    }
                }
                self.prev2_g = self.prev_g;
                self.prev_k = k;
                self.prev_g = gk;
                self.run = (self.run + 1).min(2);
            }
            None => {
                self.end_run();
                self.run = 0;
            }
        }
    }

    /// A stretch `lo..hi` (at least two entries) known to be all valid, of
    /// the sign of `s` (nonzero) and with |g| above the tolerance, without
    /// its values: the same candidates as pushing every entry. Pushing its
    /// first entry as ±∞ instead of g(lo) decides the same tests (a sign
    /// change against the entry before; a fall towards a run start needs
    /// that entry's |g| ≤ tol < |g(lo)|, true for ∞ as well); inside the
    /// stretch nothing changes sign or falls below the tolerance; after it
    /// the state is a run of at least two whose last values are of sign s
    /// and above the tolerance, which is all the later tests read of them
    /// (a bracket needs their sign; a fall needs the later |g| ≤ tol, hence
    /// below them, whatever they are).
    #[inline]
    pub(crate) fn quiet(&mut self, lo: usize, hi: usize, s: f64) {
        let v = if s < 0.0 { f64::NEG_INFINITY } else { f64::INFINITY };
        self.push(lo, Some(v));
        self.run = 2;
        self.prev_k = hi - 1;
        self.prev_g = v;
        self.prev2_g = v;
    }

    #[inline]
    fn end_run(&mut self) {
        if self.run >= 2 && self.falling(self.prev2_g, self.prev_g) {
            self.out.push(Candidate::Edge(self.prev_k));
        }
    }

    pub(crate) fn finish(mut self) {
        self.end_run();
    }
}
