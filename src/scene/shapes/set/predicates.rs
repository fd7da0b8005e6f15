//! The scalar code's keep and touch tests, operation for operation, on
//! f64 lanes.
use super::arith::{dot, v, within};

/// Relative and absolute slack around an interval's ends beyond which a
/// root's f32 rounding cannot move it across: twice an f32 ulp, and a few
/// of the smallest subnormals.
pub(super) const SLACK_REL: f64 = 1.0 / (1u64 << 21) as f64;
pub(super) const SLACK_ABS: f64 = 1e-44;

/// Does `Segment::keeps` keep the root `t` of lanes whose interval is
/// `[tn, lim]` (`lim`: the f32 end, or a kept crossing's t whose f32 it
/// became)? As masks: kept for sure, and unsure. Exact where sure: `t >=
/// tn` implies `t as f32 >= tn` for an f32 `tn` (rounding is monotone), and
/// past the slack the rounding cannot reach the end.
#[inline(always)]
pub(super) fn keeps<S: pulp::Simd>(simd: S, t: S::f64s, tn: S::f64s, lim: S::f64s) -> (S::m64s, S::m64s) {
    let (rel, abs) = (simd.splat_f64s(SLACK_REL), simd.splat_f64s(SLACK_ABS));
    let tn_slack = v!(
        simd,
        add_f64s,
        v!(simd, mul_f64s, v!(simd, abs_f64s, tn), rel),
        abs
    );
    let lim_slack = v!(
        simd,
        add_f64s,
        v!(simd, mul_f64s, v!(simd, abs_f64s, lim), rel),
        abs
    );
    let finite = v!(
        simd,
        less_than_f64s,
        v!(simd, abs_f64s, t),
        simd.splat_f64s(f64::INFINITY)
    );
    let kept = v!(simd, and_m64s, finite, within!(simd, t, tn, lim));
    let dropped = v!(
        simd,
        or_m64s,
        v!(simd, not_m64s, finite),
        v!(
            simd,
            or_m64s,
            v!(simd, less_than_f64s, t, v!(simd, sub_f64s, tn, tn_slack)),
            v!(simd, greater_than_f64s, t, v!(simd, add_f64s, lim, lim_slack))
        )
    );
    (kept, v!(simd, not_m64s, v!(simd, or_m64s, kept, dropped)))
}

/// `Segment::is_touch` of the lanes' roots `t0`, `t1` on the rays `o + t·d`,
/// operation for operation.
#[inline(always)]
pub(super) fn touches<S: pulp::Simd>(
    simd: S,
    t0: S::f64s,
    t1: S::f64s,
    o: [S::f64s; 3],
    d: [S::f64s; 3],
) -> S::m64s {
    // |o| and |d| by their largest components (`max_element` of `abs`).
    macro_rules! largest {
        ($v:expr) => {
            v!(
                simd,
                max_f64s,
                v!(simd, abs_f64s, $v[0]),
                v!(
                    simd,
                    max_f64s,
                    v!(simd, abs_f64s, $v[1]),
                    v!(simd, abs_f64s, $v[2])
                )
            )
        };
    }
    let (o_max, d_max) = (largest!(o), largest!(d));
    const K: f64 = 2.0 * crate::ray::OFFSET_ULPS as f64 * f32::EPSILON as f64;
    const KM: f64 = K * (1.0 + 1e-9);
    let gap = v!(simd, abs_f64s, v!(simd, sub_f64s, t1, t0));
    let a0 = v!(simd, abs_f64s, t0);
    let small = v!(
        simd,
        less_than_or_equal_f64s,
        gap,
        v!(
            simd,
            add_f64s,
            simd.splat_f64s(1e-6),
            v!(simd, mul_f64s, a0, simd.splat_f64s(4e-7))
        )
    );
    let t_max = v!(simd, max_f64s, a0, v!(simd, abs_f64s, t1));
    let km = simd.splat_f64s(KM);
    let beyond = v!(
        simd,
        greater_than_f64s,
        v!(
            simd,
            mul_f64s,
            v!(simd, sub_f64s, gap, v!(simd, mul_f64s, km, t_max)),
            d_max
        ),
        v!(
            simd,
            mul_f64s,
            km,
            v!(simd, add_f64s, o_max, simd.splat_f64s(0.5))
        )
    );
    // Only lanes neither small nor beyond need the window (a division).
    let near = v!(
        simd,
        and_m64s,
        v!(simd, not_m64s, small),
        v!(simd, not_m64s, beyond)
    );
    if simd.first_true_m64s(near) == S::F64_LANES {
        return small;
    }
    // `ray::crossing_window_f64(o, d, t_max)`, with glam's `length`.
    let d_len = v!(simd, sqrt_f64s, dot!(simd, d[0], d[1], d[2], d[0], d[1], d[2]));
    let sum = v!(
        simd,
        add_f64s,
        v!(simd, add_f64s, o_max, v!(simd, mul_f64s, t_max, d_len)),
        simd.splat_f64s(0.5)
    );
    let window = v!(simd, div_f64s, v!(simd, mul_f64s, simd.splat_f64s(K), sum), d_len);
    v!(
        simd,
        or_m64s,
        small,
        v!(
            simd,
            and_m64s,
            near,
            v!(simd, less_than_or_equal_f64s, gap, window)
        )
    )
}
