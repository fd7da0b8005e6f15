//! Parallel-plate refraction warp (Mukai et al., eq. 5), exact and robust.
//!
//! The plate: a point on its near face `Q`, a unit normal `N` pointing away
//! from the eye, thickness `W` and index `n` (ambient index 1). For a target
//! `A` behind the plate, the eye ray that refracts through the plate onto `A`
//! leaves the eye at angle θ to `N` in the plane of the eye, `N` and `A`.
//!
//! Derivation (departures from the paper noted):
//! - With `D` the lateral distance from the eye to `A` (perpendicular to `N`)
//!   and `h` the normal distance travelled in air (before and after the
//!   plate), the path satisfies `D = h·tanθ + W·tanφ`, `sinφ = sinθ/n`.
//!   We solve it in `u = tanθ ∈ [0, ∞)`, where it reads
//!   `f(u) = h·u + W·u/√(n² + (n²−1)u²) − D = 0`: strictly increasing and
//!   concave, so Newton started right of the root converges monotonically;
//!   a bracket [lo, hi] guards every step. The paper steps in θ, which loses
//!   precision near grazing (θ → 90°, tanθ → ∞); `u` does not.
//! - The straight eye ray at angle θ reaches lateral `D` when displaced
//!   towards the eye along `N` by `L = W(1 − tanφ/tanθ)`. The paper's
//!   `W{1 − tanφ·tan(π/2 − θ)}` is the same quantity but 0/0 on the axis. In
//!   `u` it is `L = W(1 − 1/√(n² + (n²−1)u²))`: exact on the axis
//!   (`W(1 − 1/n)`), exactly 0 for `n = 1`, no cancellation at grazing.
//! - The warped vertex is `A − L·N`.
use glam::DVec3;

/// A glass plate with parallel faces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plate {
    /// A point on the face nearer the eye (metres).
    pub near_face_point: DVec3,
    /// Unit normal pointing away from the eye.
    pub normal: DVec3,
    /// Thickness W > 0 (metres).
    pub thickness: f64,
    /// Index n > 0 of the glass (the surroundings have index 1).
    pub ior: f64,
}

/// Why a point has no warped image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlateStatus {
    /// The point is between the eye and the plate: it is seen directly.
    InFront,
    /// The point is inside the glass.
    InsideGlass,
    /// The eye is not in front of the near face.
    EyeNotInFront,
    /// The solver did not converge (should not happen; reported, not hidden).
    NotConverged,
}

/// The warp of one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlateImage {
    /// Where the vertex must move so that a straight eye ray sees it where refraction would.
    pub position: DVec3,
    /// Unit direction of that eye ray.
    pub eye_dir: DVec3,
    /// Angle of incidence θ at the near face (radians).
    pub theta: f64,
    /// tanθ, the variable actually solved for (exact where θ → 90°).
    pub slope: f64,
    /// Shift towards the eye along the normal (metres).
    pub shift: f64,
    /// Newton steps taken.
    pub iterations: u32,
}

/// Four lanes of the plate's slope solve (see `Plate::solve_slope`): the
/// paraxial bound, one fixed-point step, then Newton steps, two for every
/// lane and a third only when some lane's second step was above 1e-8
/// relative; returns the slopes, each lane's last step and the shifts `L(u)`.
///
/// Plain arithmetic on `[f64; 4]`. LLVM keeps it scalar for the generic
/// x86_64 target (no packed sqrt/div in the binary: its cost model finds
/// SSE2's packed division no cheaper), and intrinsics would need `unsafe`,
/// which the crate keeps to `src/embree/` and the tube's lanes; so the gain
/// over the scalar solver is fewer steps and no per-vertex branches, not
/// SIMD.
#[inline(always)]
fn newton4(
    h: &[f64; 4],
    d2: &[f64; 4],
    w: f64,
    n2: f64,
    k: f64,
    inv_n: f64,
) -> ([f64; 4], [f64; 4], [f64; 4]) {
    let mut d = [0.0; 4];
    let mut u = [0.0; 4];
    for l in 0..4 {
        d[l] = d2[l].sqrt();
        let u0 = d[l] / (h[l] + w * inv_n);
        u[l] = (d[l] - w * u0 / (n2 + k * u0 * u0).sqrt()) / h[l];
    }
    let mut last = [0.0; 4];
    let step = |u: &mut [f64; 4], last: &mut [f64; 4]| {
        for l in 0..4 {
            let inv = 1.0 / (n2 + k * u[l] * u[l]).sqrt();
            let fu = h[l] * u[l] + w * u[l] * inv - d[l];
            let df = h[l] + w * n2 * inv * inv * inv;
            let next = u[l] - fu / df;
            let next = if next < 0.0 { 0.0 } else { next };
            last[l] = (next - u[l]).abs();
            u[l] = next;
        }
    };
    step(&mut u, &mut last);
    step(&mut u, &mut last);
    if (0..4).any(|l| last[l] > 1e-8 * u[l]) {
        step(&mut u, &mut last);
    }
    let mut shift = [0.0; 4];
    for l in 0..4 {
        shift[l] = w * (1.0 - 1.0 / (n2 + k * u[l] * u[l]).sqrt());
    }
    (u, last, shift)
}

impl Plate {
    /// Validated construction: finite values, non-zero normal (normalised), W > 0, n > 0.
    pub fn try_new(near_face_point: DVec3, normal: DVec3, thickness: f64, ior: f64) -> Result<Plate, String> {
        if !near_face_point.is_finite() {
            return Err("near_face_point: expected finite coordinates".into());
        }
        if !normal.is_finite() || normal.length() < 1e-300 {
            return Err("normal: expected a finite, non-zero vector".into());
        }
        if !(thickness.is_finite() && thickness > 0.0) {
            return Err(format!("thickness: expected a finite value > 0, got {thickness}"));
        }
        if !(ior.is_finite() && ior > 0.0) {
            return Err(format!("ior: expected a finite value > 0, got {ior}"));
        }
        Ok(Plate {
            near_face_point,
            normal: normal.normalize(),
            thickness,
            ior,
        })
    }

    /// `L(u)`: the shift along the normal for eye-ray slope `u = tanθ`.
    pub fn shift(&self, u: f64) -> f64 {
        let n2 = self.ior * self.ior;
        self.thickness * (1.0 - 1.0 / (n2 + (n2 - 1.0) * u * u).sqrt())
    }

    /// The warped image of `target` seen from `eye`.
    pub fn warp(&self, eye: DVec3, target: DVec3) -> Result<PlateImage, PlateStatus> {
        let (u, it) = self.slope_for(eye, target)?;
        let shift = self.shift(u);
        let position = target - self.normal * shift;
        let eye_dir = (position - eye).normalize();
        Ok(PlateImage {
            position,
            eye_dir,
            theta: u.atan(),
            slope: u,
            shift,
            iterations: it,
        })
    }

    /// Only the warped position (the mesh warp's inner loop).
    #[inline]
    pub fn warped_position(&self, eye: DVec3, target: DVec3) -> Result<DVec3, PlateStatus> {
        let (u, _) = self.slope_for(eye, target)?;
        Ok(target - self.normal * self.shift(u))
    }

    /// Classify `target` and solve for the eye ray's slope tanθ.
    #[inline]
    fn slope_for(&self, eye: DVec3, target: DVec3) -> Result<(f64, u32), PlateStatus> {
        let n = self.normal;
        let e = (eye - self.near_face_point).dot(n);
        let a = (target - self.near_face_point).dot(n);
        let w = self.thickness;
        if e >= 0.0 {
            return Err(PlateStatus::EyeNotInFront);
        }
        // Points within rounding of the exit face count as on it.
        let tol = 1e-12 * (w + (target - self.near_face_point).length());
        if a <= 0.0 {
            return Err(PlateStatus::InFront);
        }
        if a < w - tol {
            return Err(PlateStatus::InsideGlass);
        }
        let a = a.max(w);
        let rel = target - eye;
        let lateral = rel - n * rel.dot(n);
        let d = lateral.length();
        let h = (a - e) - w; // normal distance travelled in air, > 0 (eye strictly in front)
        let (u, it) = if self.ior >= 1.0 {
            self.solve_slope(h, d).ok_or(PlateStatus::NotConverged)?
        } else {
            self.solve_slope_bracketed(h, d)
                .ok_or(PlateStatus::NotConverged)?
        };
        Ok((u, it))
    }

    /// Solve `f(u) = h·u + W·u/√(n² + (n²−1)u²) − D = 0` for n ≥ 1. `f` is
    /// increasing and concave, so Newton from the paraxial guess
    /// `D/(h + W/n)` (a lower bound: the glass term is at most `W·u/n`)
    /// climbs monotonically to the root, and from an upper bound its first
    /// step lands below the root; no bracket is needed. Once a step
    /// is below 1e-8 relative, the next one (quadratic convergence) is below
    /// ~1e-16 and is taken without a further test: 2–3 steps in all.
    #[inline]
    fn solve_slope(&self, h: f64, d: f64) -> Option<(f64, u32)> {
        let w = self.thickness;
        let n2 = self.ior * self.ior;
        let k = n2 - 1.0;
        // Paraxial lower bound, then one fixed-point step u = (D − W·u/s(u))/h
        // (an upper bound, since W·u/s(u) increases): close when h ≫ W.
        let u0 = d / (h + w / self.ior);
        let mut u = (d - w * u0 / (n2 + k * u0 * u0).sqrt()) / h;
        let step = |u: f64| {
            let inv = 1.0 / (n2 + k * u * u).sqrt();
            let fu = h * u + w * u * inv - d;
            let df = h + w * n2 * inv * inv * inv;
            (u - fu / df).max(0.0)
        };
        for it in 1..=60u32 {
            let next = step(u);
            if (next - u).abs() <= 1e-8 * next || next == u {
                return Some((if next == u { next } else { step(next) }, it + 1));
            }
            u = next;
        }
        None
    }

    /// Warp four points at once (the mesh warp's inner loop): straight-line
    /// f64 code over four lanes that the compiler keeps in SIMD registers.
    /// Every lane takes the same steps: the paraxial lower bound, one
    /// fixed-point step (an upper bound), then three Newton steps, as in
    /// `solve_slope`; a lane whose last step is still above 1e-8 relative
    /// (near grazing), or any lane when n < 1, is redone by the scalar solver,
    /// so the answers are the scalar ones to rounding.
    #[inline]
    pub fn warp_lanes(&self, eye: DVec3, pts: &[DVec3; 4]) -> [Result<DVec3, PlateStatus>; 4] {
        let n = self.normal;
        let q = self.near_face_point;
        let w = self.thickness;
        let n2 = self.ior * self.ior;
        let k = n2 - 1.0;
        let e = (eye - q).dot(n);
        if e >= 0.0 {
            return [Err(PlateStatus::EyeNotInFront); 4];
        }
        if self.ior < 1.0 {
            return pts.map(|p| self.warped_position(eye, p));
        }
        // Structure of arrays, plain arithmetic on [f64; 4] (no early exits,
        // selects instead of branches) so that LLVM can use packed sqrt/div.
        let mut a = [0.0; 4];
        let mut d2 = [0.0; 4];
        let mut h = [0.0; 4];
        for l in 0..4 {
            let p = pts[l];
            a[l] = (p - q).dot(n);
            let rel = p - eye;
            let lat = rel - n * rel.dot(n);
            d2[l] = lat.length_squared();
            let aw = if a[l] > w { a[l] } else { w };
            h[l] = (aw - e) - w;
        }
        let (u, last, shift) = newton4(&h, &d2, w, n2, k, 1.0 / self.ior);
        let mut out = [Ok(DVec3::ZERO); 4];
        for l in 0..4 {
            let p = pts[l];
            out[l] = if a[l] <= 0.0 {
                Err(PlateStatus::InFront)
            } else if a[l] < w && a[l] < w - 1e-12 * (w + (p - q).length()) {
                // Points within rounding of the exit face count as on it.
                Err(PlateStatus::InsideGlass)
            } else if last[l] > 1e-8 * u[l] {
                self.warped_position(eye, p)
            } else {
                Ok(p - n * shift[l])
            };
        }
        out
    }

    /// Warp a mesh's vertices (f32, as Embree stores them): `out[i]` gets the
    /// warped position of `pts[i]`, or `pts[i]` itself when the point is in
    /// front of the plate (seen directly); `class[i]` is `Ok(true)` warped,
    /// `Ok(false)` in front, `Err` no image.
    pub fn warp_batch(
        &self,
        eye: DVec3,
        pts: &[[f32; 3]],
        out: &mut [[f32; 3]],
        class: &mut [Result<bool, PlateStatus>],
    ) {
        assert!(out.len() == pts.len() && class.len() == pts.len());
        let d3 = |p: [f32; 3]| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        let f3 = |p: DVec3| [p.x as f32, p.y as f32, p.z as f32];
        for ((pc, oc), cc) in pts.chunks(4).zip(out.chunks_mut(4)).zip(class.chunks_mut(4)) {
            let mut lanes = [DVec3::ZERO; 4];
            for (l, p) in pc.iter().enumerate() {
                lanes[l] = d3(*p);
            }
            // Padding lanes repeat the first point (results discarded).
            for l in pc.len()..4 {
                lanes[l] = lanes[0];
            }
            let r = self.warp_lanes(eye, &lanes);
            for l in 0..pc.len() {
                match r[l] {
                    Ok(p) => {
                        oc[l] = f3(p);
                        cc[l] = Ok(true);
                    }
                    Err(PlateStatus::InFront) => {
                        oc[l] = pc[l];
                        cc[l] = Ok(false);
                    }
                    Err(s) => {
                        oc[l] = pc[l];
                        cc[l] = Err(s);
                    }
                }
            }
        }
    }

    /// The general solver (also n < 1, where total internal reflection bounds
    /// the slope): Newton guarded by a bracket, bisection when a step leaves it.
    fn solve_slope_bracketed(&self, h: f64, d: f64) -> Option<(f64, u32)> {
        let w = self.thickness;
        let n2 = self.ior * self.ior;
        let k = n2 - 1.0;
        let f = |u: f64| h * u + w * u / (n2 + k * u * u).sqrt() - d;
        let df = |u: f64| h + w * n2 / (n2 + k * u * u).powf(1.5);
        let (mut lo, mut hi) = (0.0f64, d / h);
        if k < 0.0 {
            // n < 1: the slope in air stays below the critical one, where the
            // glass term grows without bound (beyond it the root is NaN).
            hi = hi.min(self.ior / (-k).sqrt() * (1.0 - 1e-9));
        }
        let mut guard = 0;
        while f(hi) < 0.0 && guard < 200 {
            hi = if k < 0.0 {
                let uc = self.ior / (-k).sqrt();
                uc - (uc - hi) * 1e-3
            } else {
                hi * 2.0 + 1.0
            };
            guard += 1;
        }
        let fh = f(hi);
        if fh.is_nan() || fh < 0.0 {
            // Beyond reach in f64 (n < 1 within rounding of the critical angle).
            return None;
        }
        let mut u = hi;
        if d == 0.0 {
            return Some((0.0, 0));
        }
        for it in 1..=200u32 {
            let fu = f(u);
            if fu > 0.0 {
                hi = hi.min(u);
            } else {
                lo = lo.max(u);
            }
            let mut next = u - fu / df(u);
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - u).abs() <= 1e-15 * next.abs().max(1e-300) || hi - lo <= 1e-15 * hi.abs() {
                return Some((next, it));
            }
            u = next;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent check: trace the straight eye ray's direction through the
    /// plate with Snell's law and return where it crosses the target's plane.
    fn forward(p: &Plate, eye: DVec3, dir: DVec3, target: DVec3) -> DVec3 {
        let n = p.normal;
        // Enter the near face.
        let t0 = (p.near_face_point - eye).dot(n) / dir.dot(n);
        let p0 = eye + dir * t0;
        let d1 = crate::optics::refract(dir, n, 1.0, p.ior).unwrap();
        let t1 = p.thickness / d1.dot(n);
        let p1 = p0 + d1 * t1;
        let d2 = crate::optics::refract(d1, n, p.ior, 1.0).unwrap();
        let t2 = (target - p1).dot(n) / d2.dot(n);
        p1 + d2 * t2
    }

    fn plate(w: f64, n: f64, normal: DVec3) -> Plate {
        Plate::try_new(DVec3::new(0.0, 0.0, -1.0), normal, w, n).unwrap()
    }

    #[test]
    fn refracted_path_lands_on_the_target() {
        let eye = DVec3::ZERO;
        for normal in [DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.3, -0.1, -1.0)] {
            let p = plate(0.2, 1.5, normal);
            for target in [
                DVec3::new(0.5, 0.2, -3.0),
                DVec3::new(-2.0, 1.0, -2.5),
                DVec3::new(10.0, 0.0, -4.0),
            ] {
                let img = p.warp(eye, target).unwrap();
                let hit = forward(&p, eye, img.eye_dir, target);
                assert!(
                    (hit - target).length() < 1e-9 * target.length(),
                    "{target}: {hit}"
                );
            }
        }
    }

    #[test]
    fn on_axis_and_just_off_axis() {
        let p = plate(0.2, 1.5, DVec3::new(0.0, 0.0, -1.0));
        let img = p.warp(DVec3::ZERO, DVec3::new(0.0, 0.0, -3.0)).unwrap();
        assert_eq!(img.shift, 0.2 * (1.0 - 1.0 / 1.5));
        assert_eq!(img.theta, 0.0);
        let img2 = p.warp(DVec3::ZERO, DVec3::new(1e-12, 0.0, -3.0)).unwrap();
        assert!((img2.shift - img.shift).abs() < 1e-15);
        let hit = forward(&p, DVec3::ZERO, img2.eye_dir, DVec3::new(1e-12, 0.0, -3.0));
        assert!((hit.x - 1e-12).abs() < 1e-21, "{}", hit.x);
    }

    #[test]
    fn thin_plate_grazing_angles_and_index_one() {
        let p = plate(1e-6, 1.5, DVec3::new(0.0, 0.0, -1.0));
        let t = DVec3::new(0.7, 0.0, -2.0);
        let img = p.warp(DVec3::ZERO, t).unwrap();
        assert!((forward(&p, DVec3::ZERO, img.eye_dir, t) - t).length() < 1e-12);
        // Within 2e-6 rad of 90°: lateral distance / depth = tan(90° − 2e-6).
        let p = plate(0.2, 1.5, DVec3::new(0.0, 0.0, -1.0));
        let depth = 3.0;
        let t = DVec3::new(depth / 2e-6, 0.0, -depth);
        let img = p.warp(DVec3::ZERO, t).unwrap();
        assert!(std::f64::consts::FRAC_PI_2 - img.theta < 3e-6);
        // A forward trace is ill-conditioned here (dD/dθ = h/cos²θ ≈ 1e12), so
        // check eq. 5 itself: D = h·tanθ + W·tanφ to 1e-13 relative.
        let (u, h, d) = (img.slope, depth - 0.2, t.x);
        let sin_t = u / (1.0 + u * u).sqrt();
        let tan_phi = (sin_t / 1.5) / (1.0 - (sin_t / 1.5).powi(2)).sqrt();
        let res = h * u + 0.2 * tan_phi - d;
        assert!(res.abs() < 1e-13 * d, "residual {res}");
        let p1 = plate(0.2, 1.0, DVec3::new(0.0, 0.0, -1.0));
        let img = p1.warp(DVec3::ZERO, DVec3::new(0.3, 0.1, -2.0)).unwrap();
        assert_eq!(img.shift, 0.0);
        assert_eq!(img.position, DVec3::new(0.3, 0.1, -2.0));
    }

    /// The four-lane batch gives the scalar answers (to 1e-12 relative) on
    /// a sweep that includes grazing lanes (scalar fallback), points in
    /// front, inside the glass and on the exit face, and each warped lane
    /// re-traces onto its target to 1e-9.
    #[test]
    fn batch_lanes_match_the_scalar_solver() {
        let eye = DVec3::new(0.1, 0.2, 0.0);
        for (normal, n) in [
            (DVec3::new(0.0, 0.0, -1.0), 1.5),
            (DVec3::new(0.3, -0.1, -1.0), 1.7),
            (DVec3::new(0.0, 0.1, -1.0), 0.8),
        ] {
            let p = plate(0.3, n, normal);
            let mut pts = Vec::new();
            for i in 0..40 {
                let x = -5.0 + 0.25 * i as f64;
                for z in [-0.5, -1.1, -1.3, -1.3 - 1e-13, -3.0, -40.0] {
                    pts.push(DVec3::new(x * x * x, 0.3 * x, z));
                }
            }
            pts.push(DVec3::new(3.0 / 2e-6, 0.0, -3.0));
            while pts.len() % 4 != 0 {
                pts.push(DVec3::new(0.0, 0.0, -2.0));
            }
            let mut warped = 0;
            for c in pts.chunks(4) {
                let lanes = [c[0], c[1], c[2], c[3]];
                let r = p.warp_lanes(eye, &lanes);
                for l in 0..4 {
                    let s = p.warped_position(eye, lanes[l]);
                    match (r[l], s) {
                        (Ok(a), Ok(b)) => {
                            assert!(
                                (a - b).length() <= 1e-12 * (b - eye).length(),
                                "{}: {a} vs {b}",
                                lanes[l]
                            );
                            let dist = (lanes[l] - eye).length();
                            // (n < 1 near the critical angle: a forward trace is
                            // ill-conditioned; the lanes are the scalar answers there.)
                            if dist < 1e3 && n >= 1.0 {
                                let hit = forward(&p, eye, (a - eye).normalize(), lanes[l]);
                                assert!((hit - lanes[l]).length() < 1e-9 * dist, "{}: {hit}", lanes[l]);
                            }
                            warped += 1;
                        }
                        (a, b) => assert_eq!(a, b, "{}", lanes[l]),
                    }
                }
            }
            assert!(warped > 100, "{warped}");
        }
    }

    #[test]
    fn exit_face_front_and_inside() {
        let p = plate(0.2, 1.5, DVec3::new(0.0, 0.0, -1.0));
        // On the exit face (z = −1.2): no air after the plate.
        let t = DVec3::new(0.4, 0.0, -1.2);
        let img = p.warp(DVec3::ZERO, t).unwrap();
        assert!((forward(&p, DVec3::ZERO, img.eye_dir, t) - t).length() < 1e-12);
        assert_eq!(
            p.warp(DVec3::ZERO, DVec3::new(0.0, 0.0, -0.5)),
            Err(PlateStatus::InFront)
        );
        assert_eq!(
            p.warp(DVec3::ZERO, DVec3::new(0.0, 0.0, -1.1)),
            Err(PlateStatus::InsideGlass)
        );
        assert_eq!(
            p.warp(DVec3::new(0.0, 0.0, -5.0), DVec3::new(0.0, 0.0, -6.0)),
            Err(PlateStatus::EyeNotInFront)
        );
        assert!(Plate::try_new(DVec3::ZERO, DVec3::ZERO, 0.1, 1.5).is_err());
        assert!(Plate::try_new(DVec3::ZERO, DVec3::Z, -0.1, 1.5).is_err());
    }
}
