//! Rays and hits, the bottom layer every other module stands on: [`Ray`] and
//! [`Hit`] (what Embree is asked and answers), spawning a child ray off a
//! surface ([`offset_origin`], [`spawn_transmitted`], [`just_past`], their constant
//! [`OFFSET_ULPS`]) and the [`crossing_window`] within which two surface
//! reports are one crossing.
//!
//! Conventions: positions in scene units (metres in the shipped scenes);
//! `dir` need not be unit length, `t` is in units of `|dir|`; geometric
//! normals as the shape reports them (for closed solids they point out of
//! the solid, checked at load).
use glam::{DVec3, Vec3A as V3};

/// A ray: `org + t·dir` for `t` in `[tnear, tfar]`. `dir` need not be unit
/// length; `t` is then in units of `|dir|`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub org: V3,
    /// Direction (any non-zero length).
    pub dir: V3,
    /// Start of the interval, ≥ 0.
    pub tnear: f32,
    /// End of the interval (`f32::INFINITY` for an unbounded ray).
    pub tfar: f32,
}

impl Ray {
    /// What Embree's `ray.valid()` demands (Debian's build asserts on it and
    /// aborts): finite origin and direction, 0 <= tnear, tnear <= tfar, no NaN.
    #[inline]
    pub fn is_valid(&self) -> bool {
        // One mask test for both vectors; `tnear` finite and >= 0 is one
        // test of its bits (+0 up to the largest finite, or -0: LLVM turned
        // the two float tests into a dozen integer ones), and `tnear <= tfar`
        // is false for a NaN `tfar`. The same answer as the six tests one by
        // one, at a third of the instructions per packet lane.
        let b = self.tnear.to_bits();
        (self.org.is_finite_mask() & self.dir.is_finite_mask()).all()
            && (b < 0x7f80_0000 || b == 0x8000_0000)
            && self.tnear <= self.tfar
    }

    /// The unbounded ray `org + t·dir`, `t ≥ 0`.
    pub fn new(org: V3, dir: V3) -> Ray {
        Ray {
            org,
            dir,
            tnear: 0.0,
            tfar: f32::INFINITY,
        }
    }
}

/// The nearest accepted hit of a query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Embree's geometry id (index into the scene's geometry records).
    pub geom_id: u32,
    /// Primitive within the geometry (triangle index, or the analytic shape's part).
    pub prim_id: u32,
    /// Ray parameter of the hit, in units of `|dir|`.
    pub t: f32,
    /// Unnormalised geometric normal as Embree reports it (for triangles
    /// `(v1-v0)×(v2-v0)`, i.e. facing the side from which the winding is
    /// counter-clockwise; for user shapes, the shape's own normal).
    pub ng: V3,
    /// First barycentric coordinate (triangles) or the shape's own parameter.
    pub u: f32,
    /// Second barycentric coordinate (triangles) or the shape's own parameter.
    pub v: f32,
}

/// Does a ray along `dir` meet the surface with geometric normal `ng` from
/// the side `ng` points to? For a closed solid (normals point out, checked at
/// load) this is "the ray enters": the one test of entering vs leaving.
#[inline]
pub fn front_facing(ng: V3, dir: V3) -> bool {
    ng.dot(dir) < 0.0
}

/// Relative size of the spawn offset, in units of f32 epsilon times the hit
/// point's largest coordinate: a bound on the error of the reconstructed hit
/// point (a few ulps from reconstruction and rounding to f32) with a safety
/// factor of 2.
pub const OFFSET_ULPS: f32 = 8.0;

/// The spawn offset at `p`: the error bound of a reconstructed hit point,
/// which scales with the magnitude of its coordinates.
#[inline]
pub fn offset_size(p: V3) -> f32 {
    OFFSET_ULPS * f32::EPSILON * (p.abs().max_element() + 0.5)
}

/// Origin for a ray leaving `p` to the side `side` (a unit normal pointing to
/// where the new ray goes): offset along the normal by [`offset_size`].
#[inline]
pub fn offset_origin(p: V3, side: V3) -> V3 {
    p + side * offset_size(p)
}

/// The smallest ray parameter beyond `t`: where a ray that continues on its
/// own line after a crossing at `t` starts (`tnear`), so that the crossing
/// itself (the same root of the same line, bit for bit) is not reported
/// again while every surface beyond it is.
#[inline]
pub fn just_past(t: f32) -> f32 {
    let t = t.max(0.0);
    f32::from_bits(t.to_bits() + 1)
}

/// The ray transmitted at `p` into the side `exit_side` (a unit normal),
/// arriving along `dir_in` and refracted to `refracted`, between indices
/// `n1` and `n2`. The one place every integrator spawns a transmitted ray.
///
/// Through an index-matched boundary (n1 = n2) the ray does not bend, and
/// when it travels straight (`line`: the straight ray it arrived on and the
/// hit's t on it) it continues on that very line: same origin, same
/// direction, `tnear` [`just_past`] the hit. No spawn offset, so nothing is
/// stepped over: a surface a hair beyond the hit (the next sphere's entry
/// where the paper's Fig. 1 spheres meet, which Embree never presents to the
/// filter once the nearer hit has shortened the ray) is found by the next
/// query, and the next query computes every analytic root from the same
/// origin, so a crossing and a tangent touch are judged the same way on both
/// sides of the hit. (A spawned origin, along the ray or along the normal,
/// moved the line: a grazing exit stepped sideways out of a solid whose entry
/// was recorded, and a step along the ray passed entries within the step.)
///
/// Otherwise (a refraction, or a curved ray with no straight line to keep)
/// the ray starts off the surface: `offset_origin` along the normal, or for
/// n1 = n2 with cos ≥ 0.6 moved along itself by the same margin.
pub fn spawn_transmitted(
    p: V3,
    exit_side: V3,
    dir_in: V3,
    refracted: V3,
    (n1, n2): (f32, f32),
    line: Option<(&Ray, f32)>,
) -> Ray {
    if n1 != n2 {
        return Ray::new(offset_origin(p, exit_side), refracted);
    }
    if let Some((r, t)) = line {
        return Ray {
            org: r.org,
            dir: r.dir,
            tnear: just_past(t),
            tfar: f32::INFINITY,
        };
    }
    let d = dir_in.normalize_or_zero();
    let cos = exit_side.normalize_or_zero().dot(d);
    if cos >= 0.6 {
        Ray::new(p + d * (offset_size(p) / cos), d)
    } else {
        Ray::new(offset_origin(p, exit_side), d)
    }
}

/// Two reports within this distance (in units of t) are the same crossing:
/// Embree reports shared edges twice with t an ulp or two apart, and surfaces
/// of two solids closer than the spawn offset of [`offset_origin`] (twice its
/// size here) cannot be told apart by the next ray.
#[inline]
pub fn crossing_window(org: V3, dir: V3, t: f32) -> f32 {
    let (a, b) = window_coefficients(org, dir);
    a + b * if t.is_finite() { t.abs() } else { 0.0 }
}

/// `crossing_window(org, dir, t) = a + b·|t|`: the two coefficients, so a
/// filter can evaluate the window per callback without a square root.
#[inline]
pub fn window_coefficients(org: V3, dir: V3) -> (f32, f32) {
    let k = 2.0 * OFFSET_ULPS * f32::EPSILON;
    (k * (org.abs().max_element() + 0.5) / dir.length(), k)
}

/// [`crossing_window`] in f64, for analytic shapes that solve in f64: two
/// roots closer than this are one tangent touch. (Forced inline: the
/// analytic shapes' callbacks call it per ray and primitive.)
#[inline(always)]
pub fn crossing_window_f64(org: DVec3, dir: DVec3, t: f64) -> f64 {
    let dl = dir.length();
    2.0 * OFFSET_ULPS as f64 * f32::EPSILON as f64 * (org.abs().max_element() + t.abs() * dl + 0.5) / dl
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_and_f64_windows_agree() {
        let (o, d) = (V3::new(3.0, -7.0, 1.0), V3::new(0.3, 0.4, -2.0));
        for t in [0.0f32, 0.5, 10.0, 1e4] {
            let a = crossing_window(o, d, t) as f64;
            let b = crossing_window_f64(o.as_dvec3(), d.as_dvec3(), t as f64);
            assert!((a - b).abs() <= 1e-6 * b, "t {t}: {a} vs {b}");
        }
    }

    #[test]
    fn matched_spawn_stays_on_the_line() {
        let p = V3::new(1.0, 2.0, 3.0);
        let d = V3::new(0.0, 0.0, 1.0);
        let chord = Ray::new(V3::new(1.0, 2.0, 1.0), d);
        // Straight: the same line, starting just past the hit.
        let r = spawn_transmitted(p, V3::Z, d, V3::X, (1.5, 1.5), Some((&chord, 2.0)));
        assert_eq!((r.org, r.dir), (chord.org, chord.dir));
        assert!(r.tnear > 2.0 && r.tnear - 2.0 <= f32::EPSILON * 2.0);
        // No line to keep (a curved ray): moved along the ray, inside the window.
        let r = spawn_transmitted(p, V3::Z, d, V3::X, (1.5, 1.5), None);
        assert_eq!(r.dir, d, "index-matched: the direction is kept");
        assert_eq!((r.org - p).normalize(), d, "moved along the ray");
        assert!((r.org - p).length() <= crossing_window(p, d, 0.0));
        // Grazing exit: the normal offset, not a long step along the ray.
        let r2 = spawn_transmitted(p, V3::Z, V3::new(1.0, 0.0, 0.1), V3::X, (1.5, 1.5), None);
        assert_eq!(r2.org, offset_origin(p, V3::Z));
        // Different indices: the refracted direction, the normal offset.
        let r3 = spawn_transmitted(p, V3::Z, d, V3::X, (1.0, 1.5), Some((&chord, 2.0)));
        assert_eq!((r3.org, r3.dir), (offset_origin(p, V3::Z), V3::X));
    }
}
