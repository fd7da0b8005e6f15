//! Culling the tube's copies to the camera's pyramid of primary rays.
use crate::scene::RenderScene;
use crate::warp_render::rays::d3;
use glam::DVec3;

/// The four side planes of the camera's pyramid of primary rays (planes
/// through the eye), widened to a pixel and a half beyond the outermost
/// pixel centres. A triangle whose three vertices lie strictly outside one
/// of them lies wholly outside it (it is their convex hull), and every
/// primary ray `eye + t·d`, t > 0, lies inside it, so no primary ray meets
/// the triangle: leaving it out of a copy's BVH changes no pixel. The margin
/// (~1e-3 rad at 1600×1200) dwarfs the f32 rounding of the copies' vertices
/// and of Embree's rays (~1e-7 relative).
///
/// A vertical tube keeps a ray's slope along its axis, so a scene taller
/// than the view leaves much of each copy unseen, and building those BVHs
/// would dominate the copies phase. Only the tube's copies are culled: the
/// plate's triangle sets do not depend on the camera, which is what lets a
/// moving camera refit them.
pub(super) struct Frustum {
    eye: DVec3,
    /// Inward normals (not unit).
    normals: [DVec3; 4],
}

/// How far beyond the outermost pixel centres the culling pyramid's planes
/// lie, in pixels.
pub(super) const CULL_MARGIN_PX: f32 = 1.5;

impl Frustum {
    /// The pyramid of `scene`'s camera over its film (the warp renderer's
    /// rays: `pixel_ray`), its planes `margin` pixels beyond the outermost
    /// pixel centres (`CULL_MARGIN_PX`), or `None` when they are degenerate.
    pub(super) fn of(scene: &RenderScene, margin: f32) -> Option<Frustum> {
        let (w, h) = (scene.width as f32, scene.height as f32);
        let (lo, wx, hy) = (0.5 - margin, w - 0.5 + margin, h - 0.5 + margin);
        // Lens sample (0, 0): the ray from the eye, as `pixel_ray`.
        let ray = |x: f32, y: f32| {
            let (o, d) = scene.camera.ray(x, y, (0.0, 0.0));
            (d3(o.to_array()), d3(d.to_array()))
        };
        let (eye, tl) = ray(lo, lo);
        let (tr, bl, br) = (ray(wx, lo).1, ray(lo, hy).1, ray(wx, hy).1);
        let centre = ray(0.5 * w, 0.5 * h).1;
        let mut normals = [tl.cross(bl), bl.cross(br), br.cross(tr), tr.cross(tl)];
        for n in &mut normals {
            if n.dot(centre) < 0.0 {
                *n = -*n;
            }
        }
        // Every corner inside the other planes, or the pyramid is not one
        // (a fov near 180°, a degenerate film): then nothing is culled.
        let ok = normals.iter().all(|n| {
            n.is_finite()
                && n.dot(centre) > 0.0
                && [tl, tr, bl, br].iter().all(|c| n.dot(*c) > -1e-9 * n.length())
        });
        ok.then_some(Frustum { eye, normals })
    }

    /// Bit k set when `q` lies strictly outside plane k.
    #[inline]
    pub(super) fn outcode(&self, q: DVec3) -> u8 {
        let d = q - self.eye;
        let mut code = 0;
        for (k, n) in self.normals.iter().enumerate() {
            code |= u8::from(n.dot(d) < 0.0) << k;
        }
        code
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::tube_at_160x120;
    use super::super::Pipeline;
    use glam::Vec3A as V3;

    /// Culling the tube's copies to the camera's pyramid changes no pixel
    /// (the same frame as with nothing culled, from three eyes, one looking
    /// off the tube's centre and one at an odd film size) while it leaves
    /// out a sixth or more of the copies' triangles (22–27k of 96k here).
    /// Its power: the same culling with the pyramid narrowed to 3 pixels
    /// inside the film's edge (a wrong margin) changes the frame.
    #[test]
    fn culling_to_the_camera_changes_no_pixel() {
        let (mut s, spec, prep) = tube_at_160x120();
        let mut culled = Pipeline::new(&s, &spec, &prep, false).unwrap();
        let mut all = Pipeline::new(&s, &spec, &prep, false).unwrap();
        all.cull_margin_px = None;
        let mut narrow = Pipeline::new(&s, &spec, &prep, false).unwrap();
        narrow.cull_margin_px = Some(-3.0);
        let pos = s.camera.position;
        for (dx, target, (w, h)) in [
            (0.0f32, V3::ZERO, (160, 120)),
            (0.4, V3::new(0.9, 0.5, 0.0), (160, 120)),
            (-0.2, V3::ZERO, (131, 97)),
        ] {
            s.set_resolution(w, h).unwrap();
            s.camera = crate::camera::Camera::try_new(
                pos + V3::new(dx, 0.1, 0.0),
                target,
                V3::Y,
                40.0,
                w,
                h,
                0.0,
                1.0,
            )
            .unwrap();
            let fc = culled.warp(&s).unwrap();
            let fa = all.warp(&s).unwrap();
            narrow.warp(&s).unwrap();
            let kept = |p: &Pipeline| p.copy_sizes().iter().map(|c| c.1).sum::<usize>();
            let (kc, ka) = (kept(&culled), kept(&all));
            assert_eq!(fa.culled_triangles, 0);
            assert_eq!(kc + fc.culled_triangles, ka, "{fc:?}");
            assert!(6 * fc.culled_triangles >= ka, "{fc:?} of {ka}");
            let (a, b) = (culled.render(&s, &spec, &prep), all.render(&s, &spec, &prep));
            assert!(a.pixels == b.pixels && a.shown == b.shown, "eye offset {dx}");
            let c = narrow.render(&s, &spec, &prep);
            let differ = c.shown.iter().zip(&b.shown).filter(|(x, y)| x != y).count();
            assert!(differ > 100, "a narrowed pyramid changed only {differ} pixels");
        }
    }
}
