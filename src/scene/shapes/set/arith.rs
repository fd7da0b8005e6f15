//! The f64 lane arithmetic the kernels are written in.
// The kernel's arithmetic is written with these macros, not closures: a
// closure is a function of its own, compiled without the vector unit's
// target features, and left out of line its intrinsics are calls.
macro_rules! v {
    ($simd:ident, $op:ident, $($arg:expr),+) => {
        $simd.$op($($arg),+)
    };
}

/// x·x' + y·y' + z·z', summed left to right as glam's `dot`.
macro_rules! dot {
    ($simd:ident, $x:expr, $y:expr, $z:expr, $x2:expr, $y2:expr, $z2:expr) => {
        v!(
            $simd,
            add_f64s,
            v!(
                $simd,
                add_f64s,
                v!($simd, mul_f64s, $x, $x2),
                v!($simd, mul_f64s, $y, $y2)
            ),
            v!($simd, mul_f64s, $z, $z2)
        )
    };
}

/// A vector's three components, each splat across the lanes.
macro_rules! splat3 {
    ($simd:ident, $v:expr) => {
        (
            $simd.splat_f64s($v.x),
            $simd.splat_f64s($v.y),
            $simd.splat_f64s($v.z),
        )
    };
}

/// Is `t` within `[lo, hi]`?
macro_rules! within {
    ($simd:ident, $t:expr, $lo:expr, $hi:expr) => {
        v!(
            $simd,
            and_m64s,
            v!($simd, greater_than_or_equal_f64s, $t, $lo),
            v!($simd, less_than_or_equal_f64s, $t, $hi)
        )
    };
}

pub(super) use {dot, splat3, v, within};
