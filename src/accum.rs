//! What a part of a render covers and how pixels accumulate: pixel regions,
//! sample ranges, and the exact fixed-point per-pixel sums that make any
//! split of a render merge into the single render bit for bit (docs/farm.md).
use glam::Vec3A as V3;

/// Half-open pixel bounds `[x0, x1) x [y0, y1)` of the film (pbrt-v4's `--pixelbounds`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// One past the last column.
    pub x1: u32,
    /// First row (row 0 at the top).
    pub y0: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Region {
    /// The whole film.
    pub fn full(width: u32, height: u32) -> Region {
        Region {
            x0: 0,
            x1: width,
            y0: 0,
            y1: height,
        }
    }
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }
    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }
    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.width() as usize * self.height() as usize
    }
    /// The overlap of two regions, if any.
    pub fn intersect(&self, o: &Region) -> Option<Region> {
        let r = Region {
            x0: self.x0.max(o.x0),
            x1: self.x1.min(o.x1),
            y0: self.y0.max(o.y0),
            y1: self.y1.min(o.y1),
        };
        (r.x0 < r.x1 && r.y0 < r.y1).then_some(r)
    }
}

impl std::fmt::Display for Region {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.x1, self.y0, self.y1)
    }
}

/// Fraction bits of the fixed-point sample sums: a sample value `v` is
/// accumulated as `round(v * 2^FIXED_BITS)` in an `i128` with wrapping
/// (hence exactly associative) addition. Exact for |v| >= 2^-25 (where an f32
/// ulp is at least 2^-48); below that the rounding is under 1.8e-15 absolute.
pub const FIXED_BITS: i32 = 48;
/// Samples are clamped to +-2^54 before accumulation, so 2^24 samples (the
/// largest spp) cannot overflow the i128 sum.
const FIXED_CLAMP: f64 = (1u64 << 54) as f64;

/// A sample value in fixed point (NaN and infinities count as 0).
#[inline]
pub fn to_fixed(v: f32) -> i128 {
    // Every sample of magnitude in [2^-25, 2^14): v · 2^48 is an integer
    // (v's ulp is at least 2^-48) below 2^62, so the rounding below would
    // find no fraction: the product converted as it is, without the finite
    // test, the clamp and the rounding branches (the same value).
    let a = v.abs();
    if (2.0f32.powi(-25)..16384.0).contains(&a) {
        return ((v as f64) * 2f64.powi(FIXED_BITS)) as i64 as i128;
    }
    if !v.is_finite() {
        return 0;
    }
    let x = (v as f64).clamp(-FIXED_CLAMP, FIXED_CLAMP) * 2f64.powi(FIXED_BITS);
    // Fast path (every sample below 2^14 in magnitude): f64 → i64 is one
    // instruction, while f64 → i128 and `round` are library calls, per
    // sample. Rounds half away from zero, as
    // `f64::round`: `x − trunc(x)` is exact here.
    if x.abs() < 9.2e18 {
        let t = x as i64;
        let frac = x - t as f64;
        let r = if frac >= 0.5 {
            t + 1
        } else if frac <= -0.5 {
            t - 1
        } else {
            t
        };
        return r as i128;
    }
    x.round() as i128
}

/// The mean of `n` samples whose fixed-point sum is `sum`.
pub fn mean_of(sum: [i128; 3], n: u32) -> V3 {
    if n == 0 {
        return V3::ZERO;
    }
    let c = |s: i128| ((s as f64) * 2f64.powi(-FIXED_BITS) / n as f64) as f32;
    V3::new(c(sum[0]), c(sum[1]), c(sum[2]))
}

/// Exact per-pixel accumulation over a region: fixed-point sums of the RGB
/// samples and how many samples each pixel holds (indices `[start, start + n)`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Accum {
    /// Per pixel, RGB: the sum of `to_fixed(sample)` (wrapping).
    pub sums: Vec<[i128; 3]>,
    /// Per pixel: how many samples the sums hold.
    pub counts: Vec<u32>,
}

/// What part of a render to do: a region, a range of sample indices, and the
/// samples already taken (resume). The default is the whole render.
#[derive(Debug, Clone, Default)]
pub struct PartSpec {
    /// Pixels to render (default: the whole film).
    pub region: Option<Region>,
    /// Sample indices `(start, count)` of the film's spp (default: all).
    pub samples: Option<(u32, u32)>,
    /// Keep the exact sums in `Rendered::accum`.
    pub keep_sums: bool,
    /// Samples already taken per pixel of the region (from a partial part):
    /// pixel i holds indices `[start, start + counts[i])`; the render adds the rest.
    pub base: Option<Accum>,
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_fixed_conversion_equals_round() {
        let mut rng = crate::sampling::Rng::new(3);
        let mut vals = vec![
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            0.5,
            f32::MIN_POSITIVE,
            1e-20,
            3e4,
            -7e3,
            1.5e18,
            -2e16,
            // The edges of the exact-product path.
            2f32.powi(-25),
            -2f32.powi(-25),
            f32::from_bits(2f32.powi(-25).to_bits() - 1),
            -f32::from_bits(2f32.powi(-25).to_bits() - 1),
            f32::from_bits(16384f32.to_bits() - 1),
            -f32::from_bits(16384f32.to_bits() - 1),
            16384.0,
            -16384.0,
            32767.5,
        ];
        vals.extend(
            (0..20000).map(|_| (rng.uniform() - 0.5) * 10f32.powi((rng.uniform() * 30.0) as i32 - 20)),
        );
        for v in vals {
            let slow = ((v as f64).clamp(-FIXED_CLAMP, FIXED_CLAMP) * 2f64.powi(FIXED_BITS)).round() as i128;
            assert_eq!(to_fixed(v), slow, "{v}");
        }
        for v in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            assert_eq!(to_fixed(v), 0, "{v}");
        }
    }
}
