//! The fast solver's polish: Newton in (b, β) from the tables' first
//! guesses with the closed-form Jacobian, the running polishes of a batch
//! of targets evaluated in the lanes of a vector, four or eight at a time
//! (`lanes`).
use super::family::Family;
use super::geometry::Target;
use super::lanes::{newton_rows, Consts, LaneIn, Rows, NEXT, ROOT};
use glam::DVec2;

/// Newton in (b, β) with the closed-form Jacobian from the table's first
/// guess, one step at a time (`step`, given the evaluation at the current
/// point), so that the polishes of a batch run in vector lanes: one
/// evaluation per step instead of three. Fails (the caller then runs the
/// damped finite-difference Newton, which also handles the family edges)
/// unless the residual falls to 1e-13·dist within `POLISH_STEPS` steps at
/// a `b` near the bracket (so that it is this bracket's root, not a
/// neighbour's). In lanes the Jacobian comes with every evaluation,
/// so every step is a full Newton step.
pub(crate) struct Polish {
    pub(crate) fam: Family,
    /// The target (2-D position, height above the eye).
    p: DVec2,
    dv: f64,
    /// The first guess's b (the fallbacks start there).
    pub(crate) b0: f64,
    /// The bracket's samples.
    pub(crate) bracket: (f64, f64),
    b: f64,
    beta: f64,
    tol: f64,
    /// Accepted b, the bracket widened by its width.
    lo: f64,
    hi: f64,
    state: PolishState,
}

#[derive(Clone, Copy, PartialEq)]
enum PolishState {
    Running,
    Done,
    Failed,
}

/// One candidate root of a target: a bracket to polish, or a family edge
/// (its family and the b of the run end) for the damped Newton.
pub(crate) enum Job {
    Bracket(Polish),
    Edge(Family, f64),
}

impl Polish {
    /// A polish of target `t`'s root in `bracket` from (`b0`, the target's
    /// straight elevation).
    pub(crate) fn new(fam: Family, t: &Target, b0: f64, bracket: (f64, f64)) -> Polish {
        let width = (bracket.1 - bracket.0).abs();
        Polish {
            fam,
            p: t.p,
            dv: t.dv,
            b0,
            bracket,
            b: b0,
            beta: t.beta0(),
            tol: 1e-13 * t.dist,
            lo: bracket.0.min(bracket.1) - width,
            hi: bracket.0.max(bracket.1) + width,
            state: PolishState::Running,
        }
    }

    /// The point to evaluate next.
    #[inline]
    fn lane(&self) -> LaneIn {
        LaneIn {
            fam: self.fam,
            p: self.p,
            dv: self.dv,
            b: self.b,
            beta: self.beta,
        }
    }

    /// The residual is within the tolerance: done if `b` is near the
    /// bracket (this bracket's root, not a neighbour's).
    fn finish_at_root(&mut self) {
        self.state = if (self.lo..=self.hi).contains(&self.b) {
            PolishState::Done
        } else {
            PolishState::Failed
        };
    }

    /// The solved (b, β), if the polish converged.
    pub(crate) fn result(&self) -> Option<(f64, f64)> {
        (self.state == PolishState::Done).then_some((self.b, self.beta))
    }
}

/// `polish_all`'s buffers: the running polishes' rows, their jobs' indices
/// and the rows' outcomes of a pass.
#[derive(Default)]
pub(crate) struct PolishScratch {
    rows: Rows,
    run: Vec<u32>,
    status: Vec<u8>,
}

/// Newton steps a polish may take.
const POLISH_STEPS: usize = 6;

/// Every running polish of the batch steps once per pass, `lanes.lanes()`
/// at a time (`lanes::newton_rows`: one closed-form evaluation and one
/// Newton step per polish; the lanes overlap the dependent chains of
/// square roots and divisions of up to eight polishes, of any targets
/// and families). Each polish takes the same steps as alone. The
/// running polishes are rows of a struct of arrays (`lanes::Rows`),
/// compacted after each pass; a polish's own state is written only
/// when it ends (gathering each lane from its `Job` and scattering the
/// step back would cost about half as much as the evaluations).
pub(crate) fn polish_all(lanes: &Consts, jobs: &mut [Job], sc: &mut PolishScratch) {
    let PolishScratch { rows, run, status } = sc;
    rows.clear();
    run.clear();
    for (i, j) in jobs.iter().enumerate() {
        if let Job::Bracket(pol) = j {
            rows.push(&pol.lane(), pol.tol);
            run.push(i as u32);
        }
    }
    for _ in 0..POLISH_STEPS {
        let n = run.len();
        if n == 0 {
            break;
        }
        rows.pad(n);
        status.clear();
        status.resize(rows.b.len(), NEXT);
        newton_rows(lanes, rows, status);
        let mut kept = 0;
        for r in 0..n {
            let ji = run[r] as usize;
            match status[r] {
                NEXT => {
                    if kept != r {
                        rows.mov(r, kept);
                        run[kept] = run[r];
                    }
                    kept += 1;
                }
                st => {
                    if let Job::Bracket(pol) = &mut jobs[ji] {
                        if st == ROOT {
                            (pol.b, pol.beta) = (rows.b[r], rows.beta[r]);
                            pol.finish_at_root();
                        } else {
                            pol.state = PolishState::Failed;
                        }
                    }
                }
            }
        }
        run.truncate(kept);
    }
}
