//! A ray's start and restart: its invariants, and the closed forms' set-up,
//! for one ray or several side by side.
use super::closed::{closed_kind, exp_modes, Closed, ClosedKind};
use super::legs::Quad;
use super::{Branch, Form, Options, StratifiedRay};
use crate::media::field::IndexField;
use glam::DVec3;

/// What a ray keeps of its last start for the next (see
/// [`StratifiedRay::kept_scale`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeptScale {
    pub(super) h0: f64,
    pub(super) hs: f64,
    pub(super) u: f64,
}

impl KeptScale {
    /// e^{−h₀/H} at start height `h0` for scale height `hs`: the kept value
    /// when it was taken there, else computed.
    #[inline]
    pub(super) fn scale_at(self, h0: f64, hs: f64) -> f64 {
        if self.h0 == h0 && self.hs == hs {
            self.u
        } else {
            (-h0 / hs).exp()
        }
    }

    /// Nothing kept: the next start computes its scale.
    pub const NONE: KeptScale = KeptScale {
        h0: f64::NAN,
        hs: f64::NAN,
        u: f64::NAN,
    };
}

/// One ray's start from [`StratifiedRay::restart_lanes`].
#[derive(Debug, Clone, Copy)]
pub struct LaneStart {
    pub(super) start: ExpStart,
    pub(super) r: DVec3,
    pub(super) up: DVec3,
    pub(super) a: f64,
    pub(super) hs: f64,
    pub(super) u_scale: f64,
}

/// What a start gives an exponential profile's closed form (see
/// `StratifiedRay::restart`).
#[derive(Debug, Clone, Copy)]
pub(super) struct ExpStart {
    pub(super) h0: f64,
    pub(super) e: DVec3,
    /// The deficit at the start, D₀ = D·e^{−h₀/H}.
    pub(super) d0: f64,
    pub(super) n0: f64,
    pub(super) b: f64,
    pub(super) p0: f64,
    pub(super) g0: f64,
    pub(super) q1: f64,
    pub(super) q2: f64,
    pub(super) k2: f64,
    pub(super) modes: Option<(f64, f64, f64)>,
    pub(super) kappa: f64,
    pub(super) turn_behind: bool,
}

/// The closed-form starts of `N` rays of the profile n = a − d0·e^{−h/H}
/// (`hs` = H): ray `i` along unit `t[i]` from height `h0[i]`, where
/// e^{−h₀/H} = `u_scale[i]`. Each quantity for every ray before the next:
/// one ray's set-up is a chain of roots and divisions, and several rays'
/// chains side by side overlap instead of waiting one after the other.
/// (The same operations in the same order as one ray alone: the results do
/// not depend on N.)
#[inline(always)]
pub(super) fn exp_starts<const N: usize>(
    a: f64,
    d0: f64,
    hs: f64,
    up: DVec3,
    t: &[DVec3; N],
    h0: &[f64; N],
    u_scale: &[f64; N],
) -> [ExpStart; N] {
    // Plain loops over arrays (`array::from_fn`'s closures were not inlined).
    let (mut w0, mut c0, mut horiz, mut e) = ([0.0; N], [0.0; N], [DVec3::ZERO; N], [DVec3::ZERO; N]);
    for i in 0..N {
        w0[i] = t[i].dot(up);
        horiz[i] = t[i] - up * w0[i];
        c0[i] = horiz[i].length();
    }
    for i in 0..N {
        e[i] = if c0[i] > 0.0 {
            horiz[i] / c0[i]
        } else {
            up.any_orthonormal_vector()
        };
    }
    let (mut d0s, mut n0, mut b, mut p0, mut g0) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N], [0.0; N]);
    for i in 0..N {
        d0s[i] = d0 * u_scale[i];
        // The same formula the closed form uses (u₀ = 1).
        n0[i] = a - d0s[i];
        b[i] = n0[i] * c0[i];
        p0[i] = n0[i] * w0[i];
        g0[i] = n0[i] * w0[i] * w0[i] / (1.0 + c0[i]);
    }
    let (mut c, mut k2, mut q1, mut q2) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
    for i in 0..N {
        c[i] = (d0s[i] + g0[i]) * (a + b[i]);
        k2[i] = c[i] / (hs * hs);
        q1[i] = p0[i] / hs;
        q2[i] = (p0[i] * p0[i] + n0[i] * d0s[i]) / (hs * hs);
    }
    let mut modes = [None; N];
    for i in 0..N {
        if c[i] > 0.0 {
            modes[i] = Some(exp_modes(a, d0s[i], n0[i], b[i], p0[i], c[i]));
        }
    }
    let mut out = [ExpStart {
        h0: 0.0,
        e: DVec3::ZERO,
        d0: 0.0,
        n0: 0.0,
        b: 0.0,
        p0: 0.0,
        g0: 0.0,
        q1: 0.0,
        q2: 0.0,
        k2: 0.0,
        modes: None,
        kappa: f64::NAN,
        turn_behind: false,
    }; N];
    for i in 0..N {
        out[i] = ExpStart {
            h0: h0[i],
            e: e[i],
            d0: d0s[i],
            n0: n0[i],
            b: b[i],
            p0: p0[i],
            g0: g0[i],
            q1: q1[i],
            q2: q2[i],
            k2: k2[i],
            modes: modes[i],
            kappa: if modes[i].is_some() {
                k2[i].sqrt()
            } else {
                f64::NAN
            },
            turn_behind: modes[i].is_some_and(|(alpha, _, gamma)| gamma / alpha <= 1.0),
        };
    }
    out
}

impl StratifiedRay {
    /// The ray from `r` with unit direction `t` in the stratified `field`
    /// (validated, `up` unit), inside heights [lo, hi] (the box's: quadrature
    /// legs end there).
    ///
    /// # Errors
    ///
    /// A message when the field is not stratified, or n at `r` is not finite
    /// and > 0.
    pub fn new(
        field: &IndexField,
        lo: f64,
        hi: f64,
        r: DVec3,
        t: DVec3,
        opts: Options,
    ) -> Result<Self, String> {
        let mut ray = StratifiedRay {
            r0: r,
            up: DVec3::Y,
            e: DVec3::X,
            h0: 0.0,
            n0: 1.0,
            b: 1.0,
            p0: 0.0,
            g0: 0.0,
            evals: std::cell::Cell::new(0),
            u_scale: 1.0,
            u_scale_hs: f64::NAN,
            form: Form::Quad(Quad {
                legs: Vec::new(),
                lo,
                hi,
                branch: opts.branch,
                done: true,
            }),
        };
        ray.restart(field, lo, hi, r, t, opts)?;
        Ok(ray)
    }

    /// Makes this the ray [`StratifiedRay::new`] would make, in place: a
    /// render starts one per path segment, and a new one moved into its
    /// place would be a copy of a few hundred bytes each time. On an error
    /// the ray is left as it was.
    ///
    /// # Errors
    ///
    /// As [`StratifiedRay::new`].
    pub fn restart(
        &mut self,
        field: &IndexField,
        lo: f64,
        hi: f64,
        r: DVec3,
        t: DVec3,
        opts: Options,
    ) -> Result<(), String> {
        let s = field.strata().ok_or_else(|| {
            format!(
                "the invariant tracer needs a stratified field, not {}",
                field.kind()
            )
        })?;
        let up = s.up;
        let closed = if opts.quadrature || opts.branch == Branch::Paper {
            None
        } else {
            closed_kind(field)
        };
        if let Some(ClosedKind::Exp { a, d0, hs }) = closed {
            let h0 = r.dot(up) - s.base;
            let u_scale = self.u_scale_at(h0, hs);
            let [start] = exp_starts(a, d0, hs, up, &[t], &[h0], &[u_scale]);
            crate::media::state::check_n(start.n0, r)?;
            self.set_exp(&start, r, up, a, hs, u_scale);
            return Ok(());
        }
        let h0 = r.dot(up) - s.base;
        let w0 = t.dot(up);
        let horiz = t - up * w0;
        let c0 = horiz.length();
        let e = if c0 > 0.0 {
            horiz / c0
        } else {
            up.any_orthonormal_vector()
        };
        let u_scale = 1.0;
        let u_scale_hs = f64::NAN;
        let n0 = field.n_h(h0).map_or(f64::NAN, |v| v.0);
        crate::media::state::check_n(n0, r)?;
        let b = n0 * c0;
        let p0 = n0 * w0;
        let g0 = n0 * w0 * w0 / (1.0 + c0);
        // (Exponential profiles returned above.)
        if let Some(ClosedKind::Linear { m }) = closed {
            let (q1, q2, k2) = (p0, n0 * m, m * m);
            *self = StratifiedRay {
                r0: r,
                up,
                e,
                h0,
                n0,
                b,
                p0,
                g0,
                evals: std::cell::Cell::new(1),
                u_scale,
                u_scale_hs,
                form: Form::Closed(Closed {
                    kind: ClosedKind::Linear { m },
                    q1,
                    q2,
                    k2,
                    modes: None,
                    mode_turn: None,
                    kappa: f64::NAN,
                    turn_behind: false,
                }),
            };
            return Ok(());
        }
        let mut ray = StratifiedRay {
            r0: r,
            up,
            e,
            h0,
            n0,
            b,
            p0,
            g0,
            evals: std::cell::Cell::new(1),
            u_scale,
            u_scale_hs,
            form: Form::Quad(Quad {
                legs: Vec::new(),
                lo: lo.min(h0),
                hi: hi.max(h0),
                branch: opts.branch,
                done: false,
            }),
        };
        let first = ray.first_leg(field);
        let Form::Quad(q) = &mut ray.form else {
            unreachable!("set above")
        };
        q.done = first.straight || (!first.turn_b);
        q.legs.push(first);
        *self = ray;
        Ok(())
    }

    /// e^{−h₀/H} at the start height `h0` for scale height `hs`: kept from
    /// the last start when that was at the same height (a camera's rays all
    /// start at its height).
    pub(super) fn u_scale_at(&self, h0: f64, hs: f64) -> f64 {
        self.kept_scale().scale_at(h0, hs)
    }

    /// Makes this the closed-form ray of an exponential profile (n = a − d0·e^{−h/H}
    /// at the profile's base) that `start` describes, from `r`.
    pub(super) fn set_exp(&mut self, start: &ExpStart, r: DVec3, up: DVec3, a: f64, hs: f64, u_scale: f64) {
        self.r0 = r;
        self.up = up;
        self.e = start.e;
        self.h0 = start.h0;
        self.n0 = start.n0;
        self.b = start.b;
        self.p0 = start.p0;
        self.g0 = start.g0;
        self.evals.set(1);
        self.u_scale = u_scale;
        self.u_scale_hs = hs;
        let closed = Closed {
            kind: ClosedKind::Exp { a, d0: start.d0, hs },
            q1: start.q1,
            q2: start.q2,
            k2: start.k2,
            modes: start.modes,
            mode_turn: None,
            kappa: start.kappa,
            turn_behind: start.turn_behind,
        };
        match &mut self.form {
            Form::Closed(c) => *c = closed,
            form => *form = Form::Closed(closed),
        }
    }

    /// The start height, scale height and e^{−h₀/H} this ray keeps for the
    /// next start at the same height (see [`StratifiedRay::restart_lanes`]).
    pub fn kept_scale(&self) -> KeptScale {
        KeptScale {
            h0: self.h0,
            hs: self.u_scale_hs,
            u: self.u_scale,
        }
    }

    /// What [`StratifiedRay::restart`] with default options computes for
    /// `N` rays of a field whose rays have the exponential profile's closed
    /// form, ray `i` from `r[i]` along unit `t[i]` (`kept[i]`: what the ray
    /// to restart keeps). Computed lane by lane, so that the rays' chains of
    /// roots and divisions overlap in the processor; each applied with
    /// [`StratifiedRay::restart_from`]. None where that does not apply (no
    /// such form, or a start's index not valid): restart them one by one.
    // Inlined (with `exp_starts`) into its caller: left out of line, its
    // array of starts is returned through a copy, 1 % of a mirage render.
    #[inline(always)]
    pub fn restart_lanes<const N: usize>(
        field: &IndexField,
        r: &[DVec3; N],
        t: &[DVec3; N],
        kept: &[KeptScale; N],
    ) -> Option<[LaneStart; N]> {
        let (Some(s), Some(ClosedKind::Exp { a, d0, hs })) = (field.strata(), closed_kind(field)) else {
            return None;
        };
        let (mut h0, mut u_scale) = ([0.0; N], [0.0; N]);
        for i in 0..N {
            h0[i] = r[i].dot(s.up) - s.base;
            u_scale[i] = kept[i].scale_at(h0[i], hs);
        }
        let starts = exp_starts(a, d0, hs, s.up, t, &h0, &u_scale);
        if starts.iter().any(|st| !(st.n0.is_finite() && st.n0 > 0.0)) {
            return None;
        }
        Some(std::array::from_fn(|i| LaneStart {
            start: starts[i],
            r: r[i],
            up: s.up,
            a,
            hs,
            u_scale: u_scale[i],
        }))
    }

    /// Makes this the ray one lane of [`StratifiedRay::restart_lanes`] describes.
    pub fn restart_from(&mut self, lane: &LaneStart) {
        self.set_exp(&lane.start, lane.r, lane.up, lane.a, lane.hs, lane.u_scale);
    }
}
