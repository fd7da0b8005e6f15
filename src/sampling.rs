//! Random numbers and sampling. Every random choice draws from a generator
//! seeded by (seed, pixel, sample), so an image does not depend on threads.
use glam::Vec3A as V3;
use std::f32::consts::PI;

/// SplitMix64 finaliser: a bijective 64-bit mix.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// What seeds the generators of one pixel's samples in a render with a
/// given seed (see [`Rng::for_pixel_sample`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelKey(u64);

impl PixelKey {
    /// The key of pixel `pixel` (row-major index) at seed `seed`.
    #[inline]
    pub fn new(seed: u64, pixel: u64) -> PixelKey {
        PixelKey(mix64(seed ^ mix64(pixel.wrapping_add(0x9e37_79b9_7f4a_7c15))))
    }
}

/// PCG32 (O'Neill), seeded per (seed, pixel, sample).
///
/// Deterministic: equal seeds give equal sequences on every platform and
/// thread, which is what makes an image reproducible at equal seed.
///
/// # Examples
///
/// ```
/// use snell::sampling::Rng;
///
/// // The generator of sample 3 of pixel 10 in a render with seed 42.
/// let mut a = Rng::for_sample(42, 10, 3);
/// let mut b = Rng::for_sample(42, 10, 3);
/// let u = a.uniform();
/// assert!((0.0..1.0).contains(&u));
/// assert_eq!(u, b.uniform()); // same stream
///
/// // Another sample of the same pixel draws from another stream.
/// let mut c = Rng::for_sample(42, 10, 4);
/// let xs: Vec<u32> = (0..4).map(|_| a.next_u32()).collect();
/// let ys: Vec<u32> = (0..4).map(|_| c.next_u32()).collect();
/// assert_ne!(xs, ys);
/// ```
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// The generator for one camera path: sample `sample` of pixel `pixel`
    /// (row-major index) in a render with seed `seed`.
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Rng {
        Rng::for_pixel_sample(PixelKey::new(seed, pixel), sample)
    }

    /// [`Rng::for_sample`] with the pixel's part computed once, for a
    /// pixel's samples in turn.
    #[inline]
    pub fn for_pixel_sample(key: PixelKey, sample: u64) -> Rng {
        let s = key.0;
        let stream = mix64(sample ^ 0xda94_2042_e4dd_58b5);
        let mut r = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(s);
        r.next_u32();
        r
    }

    /// A generator from one 64-bit seed (tests, audits).
    pub fn new(seed: u64) -> Rng {
        Rng::for_sample(seed, 0, 0)
    }

    /// The next 32 uniformly distributed bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1), with 24 random bits (every value exactly representable).
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform in [0, 1), f64, with 53 random bits (two draws).
    #[inline]
    pub fn uniform_f64(&mut self) -> f64 {
        let hi = (self.next_u32() as u64) << 21;
        let lo = (self.next_u32() >> 11) as u64;
        (hi | lo) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// An orthonormal basis (t, b, n) around unit `n` (Duff et al. 2017):
/// returns `(t, b)`, right-handed with `n` (t × b = n).
#[inline]
pub fn basis(n: V3) -> (V3, V3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        V3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        V3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Cosine-weighted direction around unit `n`; pdf = cos/π.
#[inline]
pub fn cosine_hemisphere(n: V3, u1: f32, u2: f32) -> V3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (t, b) = basis(n);
    let z = (1.0 - u1).max(0.0).sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize()
}

/// Uniform direction in the cone around unit `axis` with cos half-angle `cos_max`.
#[inline]
pub fn uniform_cone(axis: V3, cos_max: f32, u1: f32, u2: f32) -> V3 {
    let cos_t = 1.0 - u1 * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    let (t, b) = basis(axis);
    (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + axis * cos_t).normalize()
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u1: f32, u2: f32) -> V3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    V3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Power heuristic (β = 2) for multiple importance sampling.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if a + b == 0.0 {
        0.0
    } else {
        a / (a + b)
    }
}

/// Walker's alias table (Vose's construction): draws index `i` with
/// probability `weights[i] / Σ weights` in constant time, whatever the
/// number of entries (an emitting mesh's triangles by area).
#[derive(Debug, Clone)]
pub struct AliasTable {
    /// Per bucket: the probability of keeping the bucket's own index.
    keep: Vec<f64>,
    /// Per bucket: the index taken otherwise.
    alias: Vec<u32>,
}

impl AliasTable {
    /// The table of `weights` (each finite and >= 0); `None` when there is
    /// no entry, more than `u32::MAX`, or the weights do not sum to a
    /// finite positive number.
    pub fn new(weights: &[f64]) -> Option<AliasTable> {
        let n = weights.len();
        let total: f64 = weights.iter().sum();
        if n == 0 || n > u32::MAX as usize || !(total.is_finite() && total > 0.0) {
            return None;
        }
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return None;
        }
        // Scaled so that the mean is 1: a bucket holds exactly 1.
        let mut scaled: Vec<f64> = weights.iter().map(|w| w * n as f64 / total).collect();
        let mut keep = vec![1.0; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            keep[s] = scaled[s];
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What is left holds 1 up to rounding: it keeps its own index.
        Some(AliasTable { keep, alias })
    }

    /// The number of entries.
    pub fn len(&self) -> usize {
        self.keep.len()
    }

    /// Never empty (`new` refuses no entries); for clippy's `len` rule.
    pub fn is_empty(&self) -> bool {
        self.keep.is_empty()
    }

    /// The index drawn by `u` uniform in [0, 1) (53 bits: one draw picks
    /// the bucket and, with what is left, the coin).
    #[inline]
    pub fn sample(&self, u: f64) -> usize {
        let n = self.keep.len();
        let x = u * n as f64;
        let i = (x as usize).min(n - 1);
        if x - (i as f64) < self.keep[i] {
            i
        } else {
            self.alias[i] as usize
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = (0..4)
            .map(|_| 0)
            .scan(Rng::for_sample(1, 2, 3), |r, _: u32| Some(r.next_u32()))
            .collect();
        let b: Vec<u32> = (0..4)
            .map(|_| 0)
            .scan(Rng::for_sample(1, 2, 3), |r, _: u32| Some(r.next_u32()))
            .collect();
        let c: Vec<u32> = (0..4)
            .map(|_| 0)
            .scan(Rng::for_sample(1, 2, 4), |r, _: u32| Some(r.next_u32()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn uniform_mean_and_range() {
        let mut r = Rng::new(7);
        let n = 100_000;
        let mut s = 0.0f64;
        for _ in 0..n {
            let u = r.uniform();
            assert!((0.0..1.0).contains(&u));
            s += u as f64;
        }
        let mean = s / n as f64;
        // sd of the mean = 1/sqrt(12 n) ≈ 9.1e-4; 5 sd.
        assert!((mean - 0.5).abs() < 4.6e-3, "{mean}");
    }

    #[test]
    fn cosine_hemisphere_mean_cos_is_two_thirds() {
        let mut r = Rng::new(3);
        let n = V3::new(0.3, 0.4, -0.866).normalize();
        let m = 50_000;
        let mut s = 0.0f64;
        for _ in 0..m {
            let d = cosine_hemisphere(n, r.uniform(), r.uniform());
            let c = d.dot(n);
            assert!(c >= -1e-6);
            s += c as f64;
        }
        // E[cos] under pdf cos/π is 2/3; sd(cos) = sqrt(1/2 - 4/9) ≈ 0.236.
        assert!((s / m as f64 - 2.0 / 3.0).abs() < 5.0 * 0.236 / (m as f64).sqrt());
    }

    #[test]
    fn alias_table_draws_in_proportion_to_the_weights() {
        let w = [0.0, 1.0, 3.0, 0.5, 0.5, 2.0, 1e-3];
        let t = AliasTable::new(&w).unwrap();
        let total: f64 = w.iter().sum();
        let mut r = Rng::new(11);
        let m = 400_000;
        let mut counts = [0usize; 7];
        for _ in 0..m {
            counts[t.sample(r.uniform_f64())] += 1;
        }
        for (i, (&c, &wi)) in counts.iter().zip(&w).enumerate() {
            let p = wi / total;
            let sd = (p * (1.0 - p) / m as f64).sqrt();
            let f = c as f64 / m as f64;
            assert!((f - p).abs() <= 5.0 * sd + 1e-12, "entry {i}: {f} vs {p}");
        }
        assert_eq!(counts[0], 0, "a zero weight is never drawn");
        assert!(AliasTable::new(&[]).is_none());
        assert!(AliasTable::new(&[0.0, 0.0]).is_none());
        assert!(AliasTable::new(&[1.0, f64::NAN]).is_none());
        // The last bucket at u just below 1.
        let one = AliasTable::new(&[1.0]).unwrap();
        assert_eq!(one.sample(1.0 - f64::EPSILON), 0);
    }
}
