//! Pinhole, thin-lens and orthographic cameras with the conventions of
//! `reference-scenes/scenes.json`: forward = normalize(target − position);
//! right = normalize(forward × up); true_up = right × forward; row 0 is the
//! top of the image; `fov_deg` is the full vertical field of view. An
//! orthographic camera's rays all run along forward, from a rectangle
//! centred on `position` in the plane through it across the view.
use crate::error::{Error, Result};
use glam::Vec3A as V3;

/// A pinhole, thin-lens or orthographic camera over a film of
/// `width × height` pixels, in world space (metres).
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    /// The eye point (the centre of the lens), world space; for an
    /// orthographic camera the centre of the rectangle its rays start from.
    pub position: V3,
    forward: V3,
    right: V3,
    up: V3,
    tan_half: f32,
    aspect: f32,
    width: f32,
    height: f32,
    /// Thin lens: aperture radius (0 = pinhole) and focus distance.
    lens_radius: f32,
    focus_distance: f32,
    /// Orthographic: half the view's width and height, metres (None: a
    /// perspective camera). `tan_half` and the lens are then unused.
    ortho: Option<(f32, f32)>,
}

/// The camera frame `(forward, right, true_up)` of a camera at `position`
/// looking at `target` with up hint `up`.
fn frame(position: V3, target: V3, up: V3) -> Result<(V3, V3, V3)> {
    let f = target - position;
    if f.length_squared() == 0.0 || !f.is_finite() {
        return Err(Error::Invalid("camera target equals position".into()));
    }
    let forward = f.normalize();
    let r = forward.cross(up);
    if r.length_squared() < 1e-12 {
        return Err(Error::Invalid(
            "camera up is parallel to the view direction".into(),
        ));
    }
    let right = r.normalize();
    Ok((forward, right, right.cross(forward)))
}

impl Camera {
    /// A camera at `position` looking at `target`, with `up` as the up hint
    /// (need not be perpendicular), `fov_deg` the full vertical field of view
    /// in degrees, a film of `width × height` pixels, and a thin lens of
    /// radius `lens_radius` (metres; 0 = pinhole) focused at `focus_distance`
    /// metres along the view axis.
    ///
    /// # Errors
    ///
    /// [`Error::Invalid`] when position == target (or their difference is not
    /// finite), when `up` is parallel to the view direction, or when `fov_deg`
    /// is not in (0, 180).
    #[allow(clippy::too_many_arguments)]
    pub fn try_new(
        position: V3,
        target: V3,
        up: V3,
        fov_deg: f32,
        width: u32,
        height: u32,
        lens_radius: f32,
        focus_distance: f32,
    ) -> Result<Camera> {
        let (forward, right, up) = frame(position, target, up)?;
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(Error::Invalid("fov must be in (0, 180) degrees".into()));
        }
        Ok(Camera {
            position,
            forward,
            right,
            up,
            tan_half: (fov_deg.to_radians() * 0.5).tan(),
            aspect: width as f32 / height as f32,
            width: width as f32,
            height: height as f32,
            lens_radius,
            focus_distance,
            ortho: None,
        })
    }

    /// An orthographic camera: rays along `normalize(target − position)`
    /// from the `view_width × view_height` metre rectangle centred on
    /// `position` across the view (its sides along right and true up), over
    /// a film of `width × height` pixels. The view's aspect need not be the
    /// film's (Mitsuba and glTF allow non-square pixels).
    ///
    /// # Errors
    ///
    /// [`Error::Invalid`] as [`Camera::try_new`] for the frame, and unless
    /// both view sides are finite and > 0.
    pub fn try_orthographic(
        position: V3,
        target: V3,
        up: V3,
        (view_width, view_height): (f32, f32),
        width: u32,
        height: u32,
    ) -> Result<Camera> {
        let (forward, right, up) = frame(position, target, up)?;
        let ok = |v: f32| v.is_finite() && v > 0.0;
        if !(ok(view_width) && ok(view_height)) {
            return Err(Error::Invalid(format!(
                "an orthographic view must be finite and > 0 on both sides, got {view_width} x {view_height}"
            )));
        }
        Ok(Camera {
            position,
            forward,
            right,
            up,
            tan_half: 0.0,
            aspect: width as f32 / height as f32,
            width: width as f32,
            height: height as f32,
            lens_radius: 0.0,
            focus_distance: 0.0,
            ortho: Some((0.5 * view_width, 0.5 * view_height)),
        })
    }

    /// Ray origin and unit direction for film point (x, y) in pixels
    /// (x in [0, width), y in [0, height)); `lens` in [0,1)² for a thin lens.
    #[inline]
    pub fn ray(&self, x: f32, y: f32, lens: (f32, f32)) -> (V3, V3) {
        if let Some((hw, hh)) = self.ortho {
            // The film maps onto the view rectangle as it maps onto the
            // perspective camera's image plane, so pixel sampling and
            // reconstruction are the same for both.
            let sx = 2.0 * x / self.width - 1.0;
            let sy = 1.0 - 2.0 * y / self.height;
            return (
                self.position + self.right * (sx * hw) + self.up * (sy * hh),
                self.forward,
            );
        }
        let sx = (2.0 * x / self.width - 1.0) * self.tan_half * self.aspect;
        let sy = (1.0 - 2.0 * y / self.height) * self.tan_half;
        let d = (self.forward + self.right * sx + self.up * sy).normalize();
        if self.lens_radius <= 0.0 {
            return (self.position, d);
        }
        // Thin lens: points on the focal plane (distance along forward) stay sharp.
        let ft = self.focus_distance / d.dot(self.forward);
        let focus = self.position + d * ft;
        let r = self.lens_radius * lens.0.sqrt();
        let phi = 2.0 * std::f32::consts::PI * lens.1;
        let o = self.position + self.right * (r * phi.cos()) + self.up * (r * phi.sin());
        (o, (focus - o).normalize())
    }

    /// Is it a pinhole (no lens, one origin)? Then [`Camera::pinhole_dirs`]
    /// applies. An orthographic camera is not: its rays share a direction,
    /// not an origin.
    pub fn is_pinhole(&self) -> bool {
        self.lens_radius <= 0.0 && self.ortho.is_none()
    }

    /// The orthographic view's width and height in metres (None for a
    /// perspective camera).
    pub fn orthographic_view(&self) -> Option<(f32, f32)> {
        self.ortho.map(|(hw, hh)| (2.0 * hw, 2.0 * hh))
    }

    /// The directions [`Camera::ray`] gives a pinhole camera for the film
    /// points `(xs[i], ys[i])`, sixteen at once: the same operations in the
    /// same order as glam's (no fused multiply-adds; `normalize` divides by
    /// the square root of `(x² + y²) + z²`), so the same bits, at `arch`'s
    /// vector level. The lens is ignored ([`Camera::is_pinhole`] says when
    /// that is right).
    pub fn pinhole_dirs(&self, arch: pulp::Arch, xs: &[f32; 16], ys: &[f32; 16]) -> [V3; 16] {
        let d = arch.dispatch(PinholeDirs { c: self, xs, ys });
        std::array::from_fn(|i| V3::new(d[0][i], d[1][i], d[2][i]))
    }

    /// The same camera for another film size: the vertical fov kept, or an
    /// orthographic view's height, its width following the film's aspect
    /// as a perspective camera's horizontal field does (pixels keep their
    /// shape).
    pub fn with_resolution(&self, width: u32, height: u32) -> Camera {
        let aspect = width as f32 / height as f32;
        Camera {
            ortho: self.ortho.map(|(hw, hh)| (hw * (aspect / self.aspect), hh)),
            aspect: width as f32 / height as f32,
            width: width as f32,
            height: height as f32,
            ..*self
        }
    }

    /// Unit view direction, `normalize(target − position)`.
    pub fn forward(&self) -> V3 {
        self.forward
    }

    /// Film position (pixels, x right, y down) of the world point `p` for the
    /// pinhole at `position` (or the orthographic view); `None` behind the
    /// eye (the view's plane).
    pub fn project(&self, p: V3) -> Option<(f32, f32)> {
        let v = p - self.position;
        let z = v.dot(self.forward);
        if let Some((hw, hh)) = self.ortho {
            // NaN (a point not finite) is behind too.
            if z.is_nan() || z <= 0.0 {
                return None;
            }
            let (sx, sy) = (v.dot(self.right) / hw, v.dot(self.up) / hh);
            return Some(((sx + 1.0) * 0.5 * self.width, (1.0 - sy) * 0.5 * self.height));
        }
        if z <= 1e-6 * v.length() || z <= 0.0 {
            return None;
        }
        let sx = v.dot(self.right) / z / (self.tan_half * self.aspect);
        let sy = v.dot(self.up) / z / self.tan_half;
        Some(((sx + 1.0) * 0.5 * self.width, (1.0 - sy) * 0.5 * self.height))
    }

    /// Angle subtended by one pixel at the image centre (radians); 0 for an
    /// orthographic camera, whose pixels subtend no angle (callers that
    /// need one check [`Camera::orthographic_view`] first).
    pub fn pixel_angle(&self) -> f32 {
        2.0 * self.tan_half / self.height
    }

    /// Film size in pixels, `(width, height)`.
    pub fn size(&self) -> (u32, u32) {
        (self.width as u32, self.height as u32)
    }
}

/// [`Camera::pinhole_dirs`] at a vector level: each lane's operations are
/// those of [`Camera::ray`] in its order, without fused multiply-adds.
struct PinholeDirs<'a> {
    c: &'a Camera,
    xs: &'a [f32; 16],
    ys: &'a [f32; 16],
}

impl pulp::WithSimd for PinholeDirs<'_> {
    type Output = [[f32; 16]; 3];

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> Self::Output {
        let c = self.c;
        let k = |v: f32| simd.splat_f32s(v);
        let (f, r, u) = (c.forward, c.right, c.up);
        let mut d = [[0.0f32; 16]; 3];
        let lanes = S::F32_LANES.min(16);
        for at in (0..16).step_by(lanes) {
            let end = (at + lanes).min(16);
            let x = simd.partial_load_f32s(&self.xs[at..end]);
            let y = simd.partial_load_f32s(&self.ys[at..end]);
            let sx = simd.mul_f32s(
                simd.mul_f32s(
                    simd.sub_f32s(simd.div_f32s(simd.mul_f32s(k(2.0), x), k(c.width)), k(1.0)),
                    k(c.tan_half),
                ),
                k(c.aspect),
            );
            let sy = simd.mul_f32s(
                simd.sub_f32s(k(1.0), simd.div_f32s(simd.mul_f32s(k(2.0), y), k(c.height))),
                k(c.tan_half),
            );
            let comp = |fc: f32, rc: f32, uc: f32| {
                simd.add_f32s(
                    simd.add_f32s(k(fc), simd.mul_f32s(k(rc), sx)),
                    simd.mul_f32s(k(uc), sy),
                )
            };
            let v = [comp(f.x, r.x, u.x), comp(f.y, r.y, u.y), comp(f.z, r.z, u.z)];
            let len = simd.sqrt_f32s(simd.add_f32s(
                simd.add_f32s(simd.mul_f32s(v[0], v[0]), simd.mul_f32s(v[1], v[1])),
                simd.mul_f32s(v[2], v[2]),
            ));
            for (out, v) in d.iter_mut().zip(v) {
                simd.partial_store_f32s(&mut out[at..end], simd.div_f32s(v, len));
            }
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_at_target_and_corners_follow_convention() {
        let c = Camera::try_new(V3::new(0.0, 0.0, 4.0), V3::ZERO, V3::Y, 40.0, 640, 480, 0.0, 1.0).unwrap();
        let (_, d) = c.ray(320.0, 240.0, (0.0, 0.0));
        assert!((d - V3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        let (_, d) = c.ray(0.0, 0.0, (0.0, 0.0));
        assert!(d.x < 0.0 && d.y > 0.0, "row 0 is the top, column 0 the left");
        let (_, d) = c.ray(320.0, 0.0, (0.0, 0.0));
        let half = (d.y / -d.z).atan().to_degrees();
        assert!((half - 20.0).abs() < 1e-4, "vertical fov is full: {half}");
    }

    /// Sixteen directions at once are `ray`'s bit for bit, on oblique
    /// cameras and film points all over (and past) the film. Power: the same
    /// arrays normalised by multiplying with the reciprocal length, one
    /// rounding more, differ in some lanes, so a bit-level slip would show.
    #[test]
    fn pinhole_dirs_are_the_rays_bit_for_bit() {
        let mut rng = crate::sampling::Rng::new(9);
        let mut slips = 0;
        // Every vector level in turn.
        let levels = crate::vector_levels();
        for k in 0..200 {
            let pos = V3::new(
                rng.uniform() * 8.0 - 4.0,
                rng.uniform() * 3.0,
                5.0 + k as f32 * 0.01,
            );
            let c = Camera::try_new(
                pos,
                V3::new(0.3, 0.5, -0.2),
                V3::Y,
                10.0 + k as f32 * 0.8,
                640,
                480,
                0.0,
                1.0,
            )
            .unwrap();
            assert!(c.is_pinhole());
            let xs: [f32; 16] = std::array::from_fn(|_| rng.uniform() * 700.0 - 30.0);
            let ys: [f32; 16] = std::array::from_fn(|_| rng.uniform() * 520.0 - 20.0);
            let arch = levels[k % levels.len()];
            let dirs = c.pinhole_dirs(arch, &xs, &ys);
            for i in 0..16 {
                let (o, d) = c.ray(xs[i], ys[i], (rng.uniform(), rng.uniform()));
                assert_eq!(o, c.position);
                assert_eq!(
                    d.to_array().map(f32::to_bits),
                    dirs[i].to_array().map(f32::to_bits),
                    "camera {k} lane {i}"
                );
                let sx = (2.0 * xs[i] / c.width - 1.0) * c.tan_half * c.aspect;
                let sy = (1.0 - 2.0 * ys[i] / c.height) * c.tan_half;
                let raw = c.forward + c.right * sx + c.up * sy;
                let wrong = raw * (1.0 / raw.length());
                slips += (wrong.to_array().map(f32::to_bits) != d.to_array().map(f32::to_bits)) as u32;
            }
        }
        assert!(
            slips > 100,
            "the reciprocal variant differed in only {slips} of 3200 lanes"
        );
    }

    /// An orthographic camera's rays share the view direction and start on
    /// the view rectangle: the film's corners at its corners, row 0 at the
    /// top; `project` inverts `ray`; it is no pinhole, so the packets'
    /// shared-origin shortcut is not taken for it.
    #[test]
    fn orthographic_rays_are_parallel_from_the_view_rectangle() {
        let pos = V3::new(1.0, 2.0, 5.0);
        let c = Camera::try_orthographic(pos, V3::new(1.0, 2.0, 0.0), V3::Y, (4.0, 3.0), 80, 60).unwrap();
        assert!(!c.is_pinhole());
        assert_eq!(c.orthographic_view(), Some((4.0, 3.0)));
        let (o, d) = c.ray(0.0, 0.0, (0.3, 0.7));
        assert_eq!(d, V3::new(0.0, 0.0, -1.0));
        assert!((o - (pos + V3::new(-2.0, 1.5, 0.0))).length() < 1e-6, "{o}");
        let (o, d) = c.ray(80.0, 60.0, (0.0, 0.0));
        assert_eq!(d, V3::new(0.0, 0.0, -1.0));
        assert!((o - (pos + V3::new(2.0, -1.5, 0.0))).length() < 1e-6, "{o}");
        let (x, y) = c.project(V3::new(1.5, 2.25, -30.0)).unwrap();
        assert!((x - 50.0).abs() < 1e-4 && (y - 25.0).abs() < 1e-4, "{x} {y}");
        assert!(
            c.project(pos + V3::new(0.0, 0.0, 1.0)).is_none(),
            "behind the view plane"
        );
        // Another film aspect widens the view as a perspective camera's
        // horizontal field widens; its height stays.
        assert_eq!(c.with_resolution(160, 60).orthographic_view(), Some((8.0, 3.0)));
        let bad = |v| Camera::try_orthographic(pos, V3::ZERO, V3::Y, v, 8, 8).is_err();
        assert!(bad((0.0, 1.0)) && bad((1.0, f32::NAN)) && bad((-1.0, 1.0)));
    }

    #[test]
    fn degenerate_cameras_are_errors() {
        assert!(Camera::try_new(V3::ZERO, V3::ZERO, V3::Y, 40.0, 4, 4, 0.0, 1.0).is_err());
        assert!(Camera::try_new(V3::ZERO, V3::Y, V3::Y, 40.0, 4, 4, 0.0, 1.0).is_err());
        assert!(Camera::try_new(V3::ZERO, V3::X, V3::Y, 180.0, 4, 4, 0.0, 1.0).is_err());
    }
}
