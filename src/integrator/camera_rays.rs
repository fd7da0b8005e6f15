//! Camera rays: where a render's paths begin. Sample `s` of pixel (x, y)
//! draws its ray from the first four numbers of its own generator (seeded by
//! the render's seed, the pixel and `s`): the jitter in the pixel, then the
//! lens. Every way a render builds them gives the same rays bit for bit: one
//! at a time, up to sixteen paths' starts for the packets (a pinhole's
//! directions computed side by side), a pixel's group of samples traced path
//! by path, and through a gradient-index medium their curved rays, begun
//! together per group or flown side by side per tile row.
use super::path::PathStart;
use crate::camera::Camera;
use crate::media::{CurvedRay, Medium};
use crate::ray::Ray;
use crate::sampling::{PixelKey, Rng};
use glam::{DVec3, Vec3A as V3};
use std::ops::Range;

/// The most samples built together: a packet's paths, a pixel's group.
pub const MAX_GROUP: usize = 16;

/// The camera rays of one render: its camera, seed and film width.
pub struct CameraRays {
    camera: Camera,
    seed: u64,
    /// The film's width, which numbers the pixels.
    film_width: u32,
    /// The vector level of a pinhole's directions.
    arch: pulp::Arch,
}

/// The camera rays of a group of samples of one pixel ([`CameraRays::group`]).
pub struct Group {
    /// Each sample's generator, after drawing its ray; past the group's
    /// size, a copy of the first one's, never to be read.
    pub rngs: [Rng; MAX_GROUP],
    /// Each sample's camera ray: origin and unit direction.
    pub rays: [(V3, V3); MAX_GROUP],
}

impl CameraRays {
    /// The rays of `camera` for a render with `seed` on a film `film_width`
    /// pixels wide, a pinhole's directions at vector level `arch`.
    pub fn new(camera: Camera, seed: u64, film_width: u32, arch: pulp::Arch) -> Self {
        CameraRays {
            camera,
            seed,
            film_width,
            arch,
        }
    }

    /// The index of pixel (x, y) on the film.
    fn pixel(&self, x: u32, y: u32) -> u64 {
        y as u64 * self.film_width as u64 + x as u64
    }

    /// The camera ray of sample `s` of pixel (x, y) and its generator, as it
    /// is after drawing the ray (the path goes on with it).
    pub fn one(&self, x: u32, y: u32, s: u32) -> (Rng, (V3, V3)) {
        let mut rng = Rng::for_sample(self.seed, self.pixel(x, y), s as u64);
        let ray = self.from_rng(x, y, &mut rng);
        (rng, ray)
    }

    /// A camera ray through pixel (x, y) from the next four numbers of `rng`.
    pub fn from_rng(&self, x: u32, y: u32, rng: &mut Rng) -> (V3, V3) {
        let fx = x as f32 + rng.uniform();
        let fy = y as f32 + rng.uniform();
        let lens = (rng.uniform(), rng.uniform());
        self.camera.ray(fx, fy, lens)
    }

    /// The paths of up to [`MAX_GROUP`] samples `(k, s)` (pixel `k` of the
    /// w-wide tile at (x0, y0), sample `s`) onto `out`: each one's camera ray
    /// and its generator after drawing it, as [`Self::one`] gives them (a
    /// pinhole's directions computed sixteen at once, the same bits).
    pub fn starts(&self, group: &[(usize, u32)], (x0, y0): (u32, u32), w: u32, out: &mut Vec<PathStart>) {
        let first = out.len();
        let pinhole = self.camera.is_pinhole();
        let (mut xs, mut ys) = ([0.0f32; MAX_GROUP], [0.0f32; MAX_GROUP]);
        // A pixel's samples come in turn: its place and key are computed once.
        let mut at: Option<(usize, u32, u32, PixelKey)> = None;
        for (i, &(k, s)) in group.iter().enumerate() {
            let (x, y, key) = match at {
                Some((j, x, y, key)) if j == k => (x, y, key),
                _ => {
                    let (x, y) = (x0 + k as u32 % w, y0 + k as u32 / w);
                    let key = PixelKey::new(self.seed, self.pixel(x, y));
                    at = Some((k, x, y, key));
                    (x, y, key)
                }
            };
            let mut rng = Rng::for_pixel_sample(key, s as u64);
            let ray = if pinhole {
                // The same draws as `from_rng`; the lens's two are unused.
                xs[i] = x as f32 + rng.uniform();
                ys[i] = y as f32 + rng.uniform();
                rng.uniform();
                rng.uniform();
                (self.camera.position, V3::ZERO)
            } else {
                self.from_rng(x, y, &mut rng)
            };
            out.push(PathStart { ray, rng });
        }
        if pinhole {
            let dirs = self.camera.pinhole_dirs(self.arch, &xs, &ys);
            for (p, d) in out[first..].iter_mut().zip(dirs) {
                p.ray.1 = d;
            }
        }
    }

    /// The camera rays of samples `s..s + lanes` of pixel (x, y) (`lanes`
    /// at most [`MAX_GROUP`]), each with its generator after drawing it.
    pub fn group(&self, x: u32, y: u32, s: u32, lanes: usize) -> Group {
        let pixel = self.pixel(x, y);
        // Lanes past `lanes` are never read: they hold a copy of the
        // first generator instead of seeding one each.
        let first = Rng::for_sample(self.seed, pixel, s as u64);
        let mut rngs: [Rng; MAX_GROUP] = std::array::from_fn(|i| {
            if i == 0 || i >= lanes {
                first.clone()
            } else {
                Rng::for_sample(self.seed, pixel, s as u64 + i as u64)
            }
        });
        let mut rays = [(V3::ZERO, V3::ZERO); MAX_GROUP];
        for (rng, ray) in rngs.iter_mut().zip(&mut rays).take(lanes) {
            *ray = self.from_rng(x, y, rng);
        }
        Group { rngs, rays }
    }

    /// The curved rays of the camera rays of w × h pixels from (x0, y0)
    /// (pixel (x, y)'s samples `samples(x, y)`, pixel by pixel, row by row),
    /// flown side by side through the medium
    /// ([`crate::media::fly_camera_rays`]).
    pub fn flown(
        &self,
        med: &Medium,
        (x0, y0): (u32, u32),
        (w, h): (u32, u32),
        samples: impl Fn(u32, u32) -> Range<u32>,
    ) -> Vec<CurvedRay> {
        let mut rays = Vec::new();
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                for s in samples(x, y) {
                    let (o, d) = self.one(x, y, s).1;
                    let ray = Ray::new(o, d);
                    rays.push(med.start_ray(ray.org.as_dvec3(), ray.dir.as_dvec3()));
                }
            }
        }
        crate::media::fly_camera_rays(med, &mut rays);
        rays
    }
}

/// The curved rays the camera rays of a tile start in, through a
/// gradient-index medium, for a trace path by path: each tile row's flown
/// side by side beforehand (with flights), or else each group's begun
/// together ([`CurvedRay::begin_lanes`]) in storage kept from group to group
/// (see [`Medium::restart_ray`]). None without a medium.
pub struct CurvedStarts<'m> {
    medium: Option<&'m Medium>,
    fly: bool,
    /// A group's curved rays (a medium without flights).
    group: Vec<CurvedRay>,
    /// The row's flown curved rays (with flights), and the next to hand out.
    flown: Vec<CurvedRay>,
    next: usize,
}

impl<'m> CurvedStarts<'m> {
    /// For groups of up to `width` samples through `medium`, flying each
    /// row's camera rays if `fly`.
    pub fn new(medium: Option<&'m Medium>, fly: bool, width: usize) -> Self {
        let group = match (medium, fly) {
            (Some(med), false) => (0..width).map(|_| med.start_ray(DVec3::ZERO, DVec3::X)).collect(),
            _ => Vec::new(),
        };
        CurvedStarts {
            medium,
            fly,
            group,
            flown: Vec::new(),
            next: 0,
        }
    }

    /// Start the row of w pixels from (x0, y) whose samples the trace takes
    /// in turn (pixel (x, y)'s `samples(x, y)`): with flights, its camera
    /// rays are flown together now ([`CameraRays::flown`]). A row at a time:
    /// a whole tile's flights at once stay in flight longer than the caches
    /// hold them.
    pub fn row(
        &mut self,
        rays: &CameraRays,
        (x0, y): (u32, u32),
        w: u32,
        samples: impl Fn(u32, u32) -> Range<u32>,
    ) {
        self.flown = match (self.medium, self.fly) {
            (Some(med), true) => rays.flown(med, (x0, y), (w, 1), samples),
            _ => Vec::new(),
        };
        self.next = 0;
    }

    /// Begin the curved rays of a group's camera rays `rays` together
    /// ([`CurvedRay::begin`]; a medium without flights).
    pub fn begin_group(&mut self, rays: &[(V3, V3)]) {
        if let (Some(med), false) = (self.medium, self.group.is_empty()) {
            for (c, &(o, d)) in self.group.iter_mut().zip(rays) {
                let ray = Ray::new(o, d);
                med.restart_ray(c, ray.org.as_dvec3(), ray.dir.as_dvec3());
            }
            let mut quads = self.group[..rays.len()].chunks_exact_mut(4);
            for quad in &mut quads {
                if let Ok(quad) = <&mut [CurvedRay; 4]>::try_from(quad) {
                    CurvedRay::begin_lanes(quad, med);
                }
            }
            for c in quads.into_remainder() {
                c.begin(med);
            }
        }
    }

    /// The curved ray camera ray `i` of the group starts in: the row's next
    /// flown one, else the group's `i`th (None without a medium).
    pub fn take(&mut self, i: usize) -> Option<&mut CurvedRay> {
        if self.next < self.flown.len() {
            self.next += 1;
            return Some(&mut self.flown[self.next - 1]);
        }
        self.group.get_mut(i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An orthographic camera's rays differ in origin, not direction: its
    /// packets' starts and a pixel's group are `one`'s rays bit for bit (the
    /// pinhole shortcut, which keeps one origin, would fail this).
    #[test]
    fn orthographic_starts_and_groups_are_the_single_rays() {
        let cam =
            Camera::try_orthographic(V3::new(0.3, 1.0, 4.0), V3::ZERO, V3::Y, (2.0, 1.5), 40, 30).unwrap();
        let rays = CameraRays::new(cam, 11, 40, pulp::Arch::new());
        let group: Vec<(usize, u32)> = (0..16).map(|i| (i / 3, i as u32 % 3)).collect();
        let mut out = Vec::new();
        rays.starts(&group, (8, 4), 5, &mut out);
        let bits = |(o, d): (V3, V3)| [o.to_array(), d.to_array()].map(|a| a.map(f32::to_bits));
        let mut origins = std::collections::HashSet::new();
        for (p, &(k, s)) in out.iter().zip(&group) {
            let (x, y) = (8 + k as u32 % 5, 4 + k as u32 / 5);
            assert_eq!(bits(p.ray), bits(rays.one(x, y, s).1), "sample {k} {s}");
            origins.insert(bits(p.ray)[0]);
        }
        assert!(origins.len() > 8, "the origins should differ");
        let g = rays.group(3, 7, 2, 5);
        for i in 0..5 {
            assert_eq!(bits(g.rays[i]), bits(rays.one(3, 7, 2 + i as u32).1));
        }
    }
}
