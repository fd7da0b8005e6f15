//! The closed forms of linear and exponential profiles: the path, its
//! arc length, turning points and level crossings in τ.
use super::{Point, StratifiedRay};
use crate::media::field::IndexField;
use crate::media::quadrature;

#[derive(Debug, Clone)]
pub(super) enum ClosedKind {
    Linear { m: f64 },
    Exp { a: f64, d0: f64, hs: f64 },
}

/// q(τ) = q₁ Sh + q₂ Cm with q = h − h₀ (linear) or q = u − 1 (exponential).
#[derive(Debug, Clone)]
pub(super) struct Closed {
    pub(super) kind: ClosedKind,
    pub(super) q1: f64,
    pub(super) q2: f64,
    pub(super) k2: f64,
    /// For an exponential profile with κ² > 0: u = αE + β + γ/E, E = e^{κτ}
    /// (see `exp_modes`).
    pub(super) modes: Option<(f64, f64, f64)>,
    /// With modes: the τ of their one turning point (∞ without one), once
    /// asked for. A cast asks for the next turn at every chord and crossing,
    /// and each answer would cost a logarithm.
    pub(super) mode_turn: Option<f64>,
    /// With modes: κ = √κ², and γ/α ≤ 1 (the turn, if any, at τ ≤ 0),
    /// taken once per ray rather than per question (a cast's questions
    /// queue on the divider).
    pub(super) kappa: f64,
    pub(super) turn_behind: bool,
}

/// u = αe^{κτ} + β + γe^{−κτ} for an exponential profile with
/// C = A² − b² > 0, each coefficient free of cancellation (u spans e^{±Δh/H},
/// twenty orders of magnitude over a few metres of a thin hot layer, so
/// 1 + q₁Sh + q₂Cm would lose everything where u decays). β = A·D₀/C is the
/// fixed point; α + γ = 1 − β = (n₀D₀ + p₀²)/C; α − γ = p₀/√C. The smaller of
/// α, γ (γ when p₀ > 0) is (1 − β − |p₀|/√C)/2, which simplifies to
/// D₀²b²(A + n₀) / (2C(√C + |p₀|)(n₀√C + A|p₀|)) (all factors positive).
pub(super) fn exp_modes(a: f64, d0: f64, n0: f64, b: f64, p0: f64, c: f64) -> (f64, f64, f64) {
    let s = c.sqrt();
    let q = p0.abs();
    let beta = a * d0 / c;
    let sum = (n0 * d0 + p0 * p0) / c;
    let small = d0 * d0 * b * b * (a + n0) / (2.0 * c * (s + q) * (n0 * s + a * q));
    let big = sum - small;
    if p0 > 0.0 {
        (big, beta, small)
    } else {
        (small, beta, big)
    }
}

/// The closed form a field's rays have (None: the quadrature), before a
/// start scales an exponential profile's deficit.
pub(super) fn closed_kind(field: &IndexField) -> Option<ClosedKind> {
    match *field {
        IndexField::Constant { .. } => Some(ClosedKind::Linear { m: 0.0 }),
        IndexField::Linear { m, .. } => Some(ClosedKind::Linear { m }),
        IndexField::HotGround {
            n_inf, dn, h0: hs, ..
        } => Some(ClosedKind::Exp { a: n_inf, d0: dn, hs }),
        IndexField::Exponential {
            n0: ns, scale_height, ..
        } => Some(ClosedKind::Exp {
            a: 1.0,
            d0: -(ns - 1.0),
            hs: scale_height,
        }),
        _ => None,
    }
}

/// (Ch, Sh, Cm) at τ for κ² = k2: cosh κτ, sinh(κτ)/κ, (cosh κτ − 1)/κ²
/// (their trigonometric counterparts for κ² < 0), cancellation-free.
pub(super) fn hyp(k2: f64, t: f64) -> (f64, f64, f64) {
    let z2 = k2 * t * t;
    if z2.abs() < 1e-3 {
        // Terms to z2⁵: the next is below 1e-3⁶/12! relative.
        let ch =
            1.0 + z2 / 2.0 * (1.0 + z2 / 12.0 * (1.0 + z2 / 30.0 * (1.0 + z2 / 56.0 * (1.0 + z2 / 90.0))));
        let sh = t
            * (1.0
                + z2 / 6.0 * (1.0 + z2 / 20.0 * (1.0 + z2 / 42.0 * (1.0 + z2 / 72.0 * (1.0 + z2 / 110.0)))));
        let cm = t
            * t
            * 0.5
            * (1.0
                + z2 / 12.0 * (1.0 + z2 / 30.0 * (1.0 + z2 / 56.0 * (1.0 + z2 / 90.0 * (1.0 + z2 / 132.0)))));
        return (ch, sh, cm);
    }
    if k2 > 0.0 {
        let k = k2.sqrt();
        let em = (k * t).exp_m1();
        let ep = 1.0 + em;
        let c1 = em * em / (2.0 * ep); // cosh − 1
        (1.0 + c1, em * (2.0 + em) / (2.0 * ep * k), c1 / k2)
    } else {
        let k = (-k2).sqrt();
        let (s, c) = (k * t).sin_cos();
        let half = (0.5 * k * t).sin();
        (c, s / k, 2.0 * half * half / -k2)
    }
}

impl StratifiedRay {
    pub(super) fn closed_point(&self, c: &Closed, tau: f64) -> Point {
        self.evals.set(self.evals.get() + 1);
        match (&c.kind, c.modes) {
            (ClosedKind::Linear { m }, _) => {
                let (ch, sh, cm) = hyp(c.k2, tau);
                let dh = c.q1 * sh + c.q2 * cm;
                Point {
                    tau,
                    dh,
                    p: c.q1 * ch + c.q2 * sh,
                    n: self.n0 + m * dh,
                }
            }
            (&ClosedKind::Exp { a, d0, hs }, Some((alpha, beta, gamma))) if c.k2 * tau * tau > 1.0 => {
                // u = αE + β + γ/E; u − 1 = α(E − 1) + γ(1/E − 1).
                let k = c.kappa;
                let z = k * tau;
                let (log_u, ratio, u) = if z < 600.0 {
                    // All three modes are well scaled here (E ≥ e): u itself,
                    // not u − 1, keeps its digits where it is tiny.
                    let e = z.exp();
                    let u = alpha * e + beta + gamma / e;
                    (u.ln(), k * (alpha * e - gamma / e) / u, u)
                } else {
                    // Far out only the growing mode is left (u → −∞ where
                    // α < 0: below the field's zero, outside any valid box).
                    let inv = (-z).exp();
                    let rest = alpha + beta * inv + gamma * inv * inv;
                    if rest > 0.0 {
                        (
                            z + rest.ln(),
                            k * (alpha - gamma * inv * inv) / rest,
                            f64::INFINITY,
                        )
                    } else {
                        (f64::NEG_INFINITY, f64::NEG_INFINITY, 0.0)
                    }
                };
                Point {
                    tau,
                    dh: hs * log_u,
                    p: hs * ratio,
                    n: a - d0 / u,
                }
            }
            (&ClosedKind::Exp { a, d0, hs }, _) => {
                let (ch, sh, cm) = hyp(c.k2, tau);
                let du = c.q1 * sh + c.q2 * cm;
                let u = 1.0 + du;
                Point {
                    tau,
                    dh: hs * du.ln_1p(),
                    p: hs * (c.q1 * ch + c.q2 * sh) / u,
                    n: a - d0 / u,
                }
            }
        }
    }

    pub(super) fn closed_arc(&self, c: &Closed, tau: f64) -> f64 {
        match c.kind {
            ClosedKind::Linear { m } => {
                let (_, sh, cm) = hyp(c.k2, tau);
                self.n0 * sh + m * self.p0 * cm
            }
            ClosedKind::Exp { .. } => {
                // s = ∫ n dτ: smooth in τ, Gauss–Kronrod.
                let p = quadrature::adaptive(0.0, tau, 1e-15, 0.0, 40, &mut |t| {
                    (self.closed_point(c, t).n, 0.0)
                });
                p.last().map_or(0.0, |x| x.i0)
            }
        }
    }
}

/// The real roots of a·x² + b·x + c = 0 (stable: no cancellation between b
/// and the root of the discriminant); NaN where there is none.
pub(super) fn quadratic_roots(a: f64, b: f64, c: f64) -> [f64; 2] {
    if a == 0.0 {
        return [if b != 0.0 { -c / b } else { f64::NAN }, f64::NAN];
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return [f64::NAN; 2];
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    if q == 0.0 {
        return [0.0, f64::NAN];
    }
    [q / a, c / q]
}

/// The optical parameters (any order, τ ≥ 0 not enforced) where the height
/// above the start of a closed-form ray equals `level`, solved exactly: with
/// E = e^{κτ} the height's linearising coordinate is αE + β + γ/E, a
/// quadratic in E (in τ itself when κ = 0). None where that form does not
/// apply (an oscillating exponential profile, κ² < 0).
pub(super) fn closed_level_roots(c: &Closed, level: f64) -> Option<[f64; 2]> {
    let k2 = c.k2;
    let (alpha, beta, gamma, target) = match (&c.kind, c.modes) {
        (&ClosedKind::Exp { hs, .. }, Some((a, b, g))) => (a, b, g, (level / hs).exp()),
        (ClosedKind::Linear { .. }, _) if k2 == 0.0 => {
            // q₁τ + q₂τ²/2 = level.
            return Some(quadratic_roots(0.5 * c.q2, c.q1, -level));
        }
        (ClosedKind::Linear { .. }, _) if k2 > 0.0 => {
            let k = k2.sqrt();
            (
                c.q1 / (2.0 * k) + c.q2 / (2.0 * k2),
                -c.q2 / k2,
                -c.q1 / (2.0 * k) + c.q2 / (2.0 * k2),
                level,
            )
        }
        _ => return None,
    };
    let k = k2.sqrt();
    // Only positive roots are crossings (ln of the others would be NaN, and
    // slow).
    Some(quadratic_roots(alpha, beta - target, gamma).map(|e| if e > 0.0 { e.ln() / k } else { f64::NAN }))
}

/// Can the quadratic's roots have lost digits? When the modes αE + β + γ/E
/// are far larger than the level they sum to (only for an exponential
/// profile's u near 0, or a linear field's large 1/m modes).
pub(super) fn closed_level_ill_conditioned(c: &Closed, level: f64) -> bool {
    match (&c.kind, c.modes) {
        (&ClosedKind::Exp { hs, .. }, Some((a, b, g))) => {
            // u = e^{level/H} ≥ e^{−7} unless the level is far below.
            level < -7.0 * hs || a.abs() + b.abs() + g.abs() > 1e3
        }
        _ => true,
    }
}

/// The τ where u = αE + β + γ/E turns (∞ if it does not): u' = κ(αE − γ/E)
/// = 0 at E² = γ/α (accurate where tanh κτ = ratio near 1 would round the
/// turn away).
pub(super) fn modes_turn(alpha: f64, gamma: f64, kappa: f64) -> f64 {
    let r = gamma / alpha;
    if r > 0.0 {
        r.ln() / (2.0 * kappa)
    } else {
        f64::INFINITY
    }
}

/// Where q' = q₁ Ch + q₂ Sh vanishes after τ (a form without modes; see
/// [`modes_turn`] for those).
pub(super) fn closed_next_turn(c: &Closed, tau: f64) -> f64 {
    let (q1, q2, k2) = (c.q1, c.q2, c.k2);
    if q2 == 0.0 {
        return f64::INFINITY;
    }
    let cand = if k2 > 0.0 {
        // q₁ cosh κτ + (q₂/κ) sinh κτ = 0: tanh κτ = −κ q₁/q₂.
        let k = k2.sqrt();
        let r = -k * q1 / q2;
        if r.abs() >= 1.0 {
            return f64::INFINITY;
        }
        r.atanh() / k
    } else if k2 == 0.0 {
        -q1 / q2
    } else {
        // tan κτ = −κ q₁/q₂: every π/κ.
        let k = (-k2).sqrt();
        let base = (-k * q1 / q2).atan();
        let step = std::f64::consts::PI / k;
        let n = ((tau - base / k) / step).floor() + 1.0;
        let t = base / k + n * step;
        return if t > tau { t } else { t + step };
    };
    if cand > tau {
        cand
    } else {
        f64::INFINITY
    }
}
