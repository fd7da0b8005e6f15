//! Emitting objects as lights of next-event estimation, and the spot light.
//!
//! An object with `emission` is sampled directly: an analytic sphere by the
//! cone of directions it fills seen from the shaded point (the sampling of
//! the `sphere` light, [`sample_sphere_cone`]; from inside a two-sided one,
//! uniformly by area), every other shape by area:
//! a triangle drawn in proportion to its area from an alias table, then a
//! point uniform on it; disks, annuli and cylinder walls (the parts of
//! analytic cylinders and tubes) likewise, each part by its area. Shapes are
//! in world space already (the object's transform applied), so areas are
//! world areas whatever the transform did to them. The area density 1/A
//! becomes a solid-angle density d²/(A |cos θ_light|) where it is used.
use super::shapes::{Analytic, Mesh};
use super::texture::Texture;
use crate::sampling::{uniform_cone, AliasTable};
use glam::{DVec3, Vec3A as V3};
use std::f32::consts::PI;
use std::sync::Arc;

/// A direction uniform in the cone of directions from `p` that meet the
/// sphere (`center`, `radius`), the distance to the sphere along it, and
/// the cone's solid-angle density; `None` from inside the sphere. The
/// sampling of the `sphere` light and of emitting analytic spheres.
#[inline(always)]
pub fn sample_sphere_cone(center: V3, radius: f32, p: V3, u1: f32, u2: f32) -> Option<(V3, f32, f32)> {
    let d = center - p;
    let d2 = d.length_squared();
    let r2 = radius * radius;
    if d2 <= r2 {
        return None;
    }
    let cos_max = (1.0 - r2 / d2).max(0.0).sqrt();
    let axis = d / d2.sqrt();
    let wi = uniform_cone(axis, cos_max, u1, u2);
    // Distance to the sphere along wi (nearest root).
    let b = d.dot(wi);
    let disc = (b * b - (d2 - r2)).max(0.0);
    let dist = b - disc.sqrt();
    Some((wi, dist, 1.0 / (2.0 * PI * (1.0 - cos_max))))
}

/// The density of [`sample_sphere_cone`] from `from` (0 inside the sphere).
#[inline]
pub fn sphere_cone_pdf(center: V3, radius: f32, from: V3) -> f32 {
    let d2 = (center - from).length_squared();
    let r2 = radius * radius;
    if d2 <= r2 {
        return 0.0;
    }
    let cos_max = (1.0 - r2 / d2).max(0.0).sqrt();
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// An emitting object as a light.
#[derive(Debug, Clone)]
pub struct Emitter {
    /// Its geometry id.
    pub geom: u32,
    /// Emitted radiance (as the object's `emission`).
    pub radiance: Texture,
    /// Emits on both sides (else only to the side its normal points to).
    pub two_sided: bool,
    /// How points on it are drawn.
    pub shape: EmitterShape,
    /// Its densities: the right ones, or a test's known-wrong ones (only
    /// tests, which have those, read it).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) sampling: EmitterSampling,
}

/// The densities an emitter is sampled and weighed with. Only the right
/// ones outside tests; the wrong ones show that the tests comparing
/// next-event estimation with BSDF sampling alone can tell.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) enum EmitterSampling {
    /// d²/(A |cos θ_light|) for points drawn by area, the cone's 1/Ω for
    /// spheres, on both sides of the MIS weights.
    #[default]
    Right,
    /// Known wrong: the area density 1/A taken as a solid-angle density
    /// (no distance² / cos conversion), on both sides.
    #[cfg(test)]
    WrongAreaPdf,
    /// Known wrong: next-event estimation weighed by MIS, but paths that
    /// hit the emitter count with weight 1 (the light is counted twice
    /// where both strategies reach it).
    #[cfg(test)]
    WrongUnweightedHit,
}

impl Emitter {
    /// The solid-angle density of a point drawn by area on this emitter
    /// (total area `area`), seen at squared distance `d2` with `cos_l` the
    /// cosine between its normal and the direction back to the viewer
    /// (0 when that side does not emit).
    #[inline]
    pub fn area_density(&self, area: f32, d2: f32, cos_l: f32) -> f32 {
        let c = if self.two_sided { cos_l.abs() } else { cos_l };
        // (Written so that NaN gives 0 too.)
        if c.is_nan() || c <= 0.0 {
            return 0.0;
        }
        #[cfg(test)]
        if self.sampling == EmitterSampling::WrongAreaPdf {
            return 1.0 / area;
        }
        d2 / (area * c)
    }

    /// Does a path that hits the emitter weigh itself against next-event
    /// estimation? (Always, but in a known-wrong test variant.)
    #[inline(always)]
    pub(crate) fn weighs_hits(&self) -> bool {
        #[cfg(test)]
        if self.sampling == EmitterSampling::WrongUnweightedHit {
            return false;
        }
        true
    }
}

/// How an emitter is sampled.
#[derive(Debug, Clone)]
pub enum EmitterShape {
    /// By the cone of directions it fills ([`sample_sphere_cone`]).
    Sphere {
        /// The sphere (f64, for texture coordinates).
        sphere: Analytic,
        /// Its centre in f32.
        center: V3,
        /// Its radius in f32.
        radius: f32,
    },
    /// By area.
    Area(AreaSampler),
}

/// A point drawn on an emitter's surface.
#[derive(Debug, Clone, Copy)]
pub struct AreaPoint {
    /// The point.
    pub p: V3,
    /// The unit geometric normal there, with the shape's convention (the
    /// one a hit there reports).
    pub n: V3,
    /// Texture coordinates, as a hit there has them.
    pub uv: [f32; 2],
}

/// Uniform points over a surface by area: which part (triangle, disk,
/// wall) from an alias table, then a point uniform on it.
#[derive(Debug, Clone)]
pub struct AreaSampler {
    parts: Parts,
    table: AliasTable,
    /// Total area (world units²).
    area: f32,
}

#[derive(Debug, Clone)]
enum Parts {
    Triangles(Arc<Mesh>),
    Patches(Vec<Patch>, Analytic),
}

/// A part of an analytic shape sampled by area.
#[derive(Debug, Clone, Copy)]
enum Patch {
    /// A disk or annulus in the plane through `center` spanned by `t`, `b`;
    /// `normal` is the one a hit on it reports.
    Annulus {
        center: DVec3,
        normal: DVec3,
        t: DVec3,
        b: DVec3,
        inner: f64,
        outer: f64,
    },
    /// A cylinder's wall from `base` along unit `axis` for `height`; normals
    /// radial, towards the axis when `inward`.
    Wall {
        base: DVec3,
        axis: DVec3,
        t: DVec3,
        b: DVec3,
        height: f64,
        radius: f64,
        inward: bool,
    },
    /// A parallelogram from `corner` along `edge_u` and `edge_v`, facing
    /// `normal`.
    Parallelogram {
        corner: DVec3,
        edge_u: DVec3,
        edge_v: DVec3,
        normal: DVec3,
    },
}

impl Patch {
    fn annulus(center: DVec3, plane_normal: DVec3, normal: DVec3, inner: f64, outer: f64) -> Patch {
        let (t, b) = plane_normal.any_orthonormal_pair();
        Patch::Annulus {
            center,
            normal,
            t,
            b,
            inner,
            outer,
        }
    }

    fn wall(base: DVec3, axis: DVec3, height: f64, radius: f64, inward: bool) -> Patch {
        let (t, b) = axis.any_orthonormal_pair();
        Patch::Wall {
            base,
            axis,
            t,
            b,
            height,
            radius,
            inward,
        }
    }

    fn area(&self) -> f64 {
        match *self {
            Patch::Annulus { inner, outer, .. } => std::f64::consts::PI * (outer * outer - inner * inner),
            Patch::Wall { height, radius, .. } => std::f64::consts::TAU * radius * height,
            Patch::Parallelogram { edge_u, edge_v, .. } => edge_u.cross(edge_v).length(),
        }
    }

    /// A point uniform on the patch by area, and the normal there.
    fn sample(&self, u1: f64, u2: f64) -> (DVec3, DVec3) {
        let phi = std::f64::consts::TAU * u2;
        let (s, c) = phi.sin_cos();
        match *self {
            Patch::Annulus {
                center,
                normal,
                t,
                b,
                inner,
                outer,
            } => {
                let r = (inner * inner + u1 * (outer * outer - inner * inner)).sqrt();
                (center + (t * c + b * s) * r, normal)
            }
            Patch::Wall {
                base,
                axis,
                t,
                b,
                height,
                radius,
                inward,
            } => {
                let radial = t * c + b * s;
                let n = if inward { -radial } else { radial };
                (base + axis * (height * u1) + radial * radius, n)
            }
            Patch::Parallelogram {
                corner,
                edge_u,
                edge_v,
                normal,
            } => (corner + edge_u * u1 + edge_v * u2, normal),
        }
    }
}

impl AreaSampler {
    /// The triangles of `mesh` by area; `None` when it has no area.
    pub fn mesh(mesh: Arc<Mesh>) -> Option<AreaSampler> {
        let areas: Vec<f64> = mesh
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| DVec3::from(mesh.positions[i as usize].map(f64::from)));
                0.5 * (b - a).cross(c - a).length()
            })
            .collect();
        let table = AliasTable::new(&areas)?;
        let area = areas.iter().sum::<f64>() as f32;
        (area > 0.0 && area.is_finite()).then_some(AreaSampler {
            parts: Parts::Triangles(mesh),
            table,
            area,
        })
    }

    /// The parts of an analytic disk, cylinder, tube or rect by area (`None` for a
    /// sphere, which is sampled by its cone, or a shape without area).
    pub fn analytic(a: &Analytic) -> Option<AreaSampler> {
        let patches = match *a {
            Analytic::Sphere(_) => return None,
            Analytic::Disk(d) => vec![Patch::annulus(d.center, d.normal, d.normal, d.inner, d.radius)],
            Analytic::Rect(r) => vec![Patch::Parallelogram {
                corner: r.corner,
                edge_u: r.edge_u,
                edge_v: r.edge_v,
                normal: r.normal,
            }],
            Analytic::Cylinder(c) => {
                let mut v = vec![Patch::wall(c.p0, c.axis, c.height, c.radius, c.inward)];
                if c.caps {
                    let top = c.p0 + c.axis * c.height;
                    v.push(Patch::annulus(c.p0, c.axis, -c.axis, 0.0, c.radius));
                    v.push(Patch::annulus(top, c.axis, c.axis, 0.0, c.radius));
                }
                v
            }
            Analytic::Tube(t) => {
                let top = t.p0 + t.axis * t.height;
                vec![
                    Patch::wall(t.p0, t.axis, t.height, t.outer, false),
                    Patch::wall(t.p0, t.axis, t.height, t.inner, true),
                    Patch::annulus(t.p0, t.axis, -t.axis, t.inner, t.outer),
                    Patch::annulus(top, t.axis, t.axis, t.inner, t.outer),
                ]
            }
        };
        let areas: Vec<f64> = patches.iter().map(Patch::area).collect();
        let table = AliasTable::new(&areas)?;
        let area = areas.iter().sum::<f64>() as f32;
        (area > 0.0 && area.is_finite()).then_some(AreaSampler {
            parts: Parts::Patches(patches, *a),
            table,
            area,
        })
    }

    /// Total area.
    #[inline]
    pub fn area(&self) -> f32 {
        self.area
    }

    /// A point uniform by area: `u0` (53 bits) picks the part, `u1`, `u2`
    /// the point on it. Texture coordinates only when `uv` is asked for.
    pub fn sample(&self, u0: f64, u1: f32, u2: f32, uv: bool) -> AreaPoint {
        let k = self.table.sample(u0);
        match &self.parts {
            Parts::Triangles(m) => {
                // Uniform on the triangle: (1 − √u1) at v0, in Embree's
                // barycentrics p = (1−u−v)·v0 + u·v1 + v·v2.
                let su = u1.sqrt();
                let (bu, bv) = (su * (1.0 - u2), su * u2);
                let prim = k as u32;
                let p = m.point(prim, bu, bv);
                let [a, b, c] = m.indices[k].map(|i| DVec3::from(m.positions[i as usize].map(f64::from)));
                let n = (b - a).cross(c - a).normalize_or(DVec3::Y).as_vec3a();
                let uv = if uv {
                    m.shading_uv(prim, bu, bv)
                } else {
                    [0.0, 0.0]
                };
                AreaPoint { p, n, uv }
            }
            Parts::Patches(ps, a) => {
                let (p, n) = ps[k].sample(u1 as f64, u2 as f64);
                let uv = if uv { a.uv(p) } else { [0.0, 0.0] };
                AreaPoint {
                    p: p.as_vec3a(),
                    n: n.as_vec3a(),
                    uv,
                }
            }
        }
    }
}

/// A spot light (Mitsuba 3's `spot`): a point emitting `intensity` (W/sr)
/// along its axis, the same out to `beam_width` from the axis, falling
/// linearly in the angle to zero at `cutoff_angle`, nothing beyond.
#[derive(Debug, Clone, Copy)]
pub struct Spot {
    /// Position.
    pub position: V3,
    /// Unit direction the light points to (the cone's axis).
    pub axis: V3,
    /// Radiant intensity on the axis, W/sr per channel.
    pub intensity: V3,
    /// The cone's half-angle, radians.
    cutoff: f32,
    cos_cutoff: f32,
    cos_beam: f32,
    /// 1 / (cutoff − beam), 0 when they are equal (no transition band).
    inv_transition: f32,
}

impl Spot {
    /// The spot at `position` pointing along unit `axis`, with the cone's
    /// half-angle `cutoff_deg` and the beam's `beam_deg` (degrees,
    /// 0 <= beam <= cutoff, checked by the builder).
    pub fn new(position: V3, axis: V3, intensity: V3, cutoff_deg: f64, beam_deg: f64) -> Spot {
        // In f32, as Mitsuba's scalar parameters are.
        let cutoff = cutoff_deg.to_radians() as f32;
        let beam = beam_deg.to_radians() as f32;
        Spot {
            position,
            axis,
            intensity,
            cutoff,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            inv_transition: if cutoff > beam { 1.0 / (cutoff - beam) } else { 0.0 },
        }
    }

    /// The fraction of the axis intensity emitted at `cos_theta` from the
    /// axis: 1 inside the beam, (cutoff − θ)/(cutoff − beam) in the band, 0
    /// from the cutoff on (Mitsuba 3's `falloff_curve`).
    #[inline]
    pub fn falloff(&self, cos_theta: f32) -> f32 {
        if cos_theta <= self.cos_cutoff {
            0.0
        } else if cos_theta >= self.cos_beam {
            1.0
        } else {
            ((self.cutoff - cos_theta.clamp(-1.0, 1.0).acos()) * self.inv_transition).clamp(0.0, 1.0)
        }
    }

    /// The intensity (W/sr) sent towards `q`.
    #[inline]
    pub fn intensity_towards(&self, q: V3) -> V3 {
        let d = (q - self.position).normalize_or_zero();
        self.intensity * self.falloff(d.dot(self.axis))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::scene::shapes::{Cylinder, Disk, Rect, Sphere, Tube};

    /// The sampler's points lie on the shape, spread by area: the mean of a
    /// linear function over the samples against its exact mean.
    #[test]
    fn analytic_parts_are_sampled_by_area_on_the_surface() {
        let axis = DVec3::new(0.3, 1.0, -0.2).normalize();
        let shapes = [
            Analytic::Disk(Disk {
                center: DVec3::new(1.0, 2.0, 3.0),
                normal: axis,
                radius: 2.0,
                inner: 0.5,
            }),
            Analytic::Cylinder(Cylinder {
                p0: DVec3::ZERO,
                axis,
                height: 3.0,
                radius: 0.5,
                inward: true,
                caps: false,
            }),
            Analytic::Cylinder(Cylinder {
                p0: DVec3::ZERO,
                axis,
                height: 3.0,
                radius: 0.5,
                inward: false,
                caps: true,
            }),
            Analytic::Tube(Tube {
                p0: DVec3::ONE,
                axis,
                height: 1.0,
                outer: 1.0,
                inner: 0.8,
            }),
            // A sheared one: edges 2 and 1.5 apart at 60°, across the axis.
            Analytic::Rect({
                let (t, b) = axis.any_orthonormal_pair();
                Rect::new(
                    DVec3::new(0.5, -1.0, 2.0),
                    t * 2.0,
                    (t * 0.5 + b * 0.75f64.sqrt()) * 1.5,
                    true,
                )
                .unwrap()
            }),
        ];
        let pi = std::f64::consts::PI;
        let want_area = [
            pi * (4.0 - 0.25),
            2.0 * pi * 0.5 * 3.0,
            2.0 * pi * 1.5 + 2.0 * pi * 0.25,
            2.0 * pi * 1.8 + 2.0 * pi * 0.36,
            2.0 * 1.5 * 0.75f64.sqrt(),
        ];
        let mut rng = Rng::new(5);
        for (a, want) in shapes.iter().zip(want_area) {
            let s = AreaSampler::analytic(a).unwrap();
            assert!(
                (s.area() as f64 - want).abs() < 1e-5 * want,
                "{a:?}: {} vs {want}",
                s.area()
            );
            let m = 100_000;
            let mut h = 0.0f64;
            for _ in 0..m {
                let q = s.sample(rng.uniform_f64(), rng.uniform(), rng.uniform(), false);
                let qd = q.p.as_dvec3();
                // On the surface, with the normal a hit there reports.
                let prim = (0..a.prims())
                    .min_by(|&i, &j| {
                        let di = (a.project(i, qd) - qd).length();
                        let dj = (a.project(j, qd) - qd).length();
                        di.total_cmp(&dj)
                    })
                    .unwrap();
                assert!(
                    (a.project(prim, qd) - qd).length() < 1e-5,
                    "{a:?}: {qd} off the surface"
                );
                assert!(
                    (a.normal(prim, qd).as_vec3a() - q.n).length() < 1e-4,
                    "{a:?}: normal at {qd}"
                );
                h += qd.dot(axis);
            }
            // The mean height along the axis: the walls' is the middle, the
            // disk's its centre's; caps weigh by their areas.
            let hm = match a {
                Analytic::Disk(d) => d.center.dot(axis),
                Analytic::Cylinder(c) => c.p0.dot(axis) + 1.5,
                Analytic::Tube(t) => t.p0.dot(axis) + 0.5,
                Analytic::Rect(r) => (r.corner + (r.edge_u + r.edge_v) * 0.5).dot(axis),
                _ => unreachable!(),
            };
            let spread = 1.5;
            assert!(
                (h / m as f64 - hm).abs() < 5.0 * spread / (m as f64).sqrt(),
                "{a:?}: {}",
                h / m as f64
            );
        }
        let sphere = Analytic::Sphere(Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
        });
        assert!(AreaSampler::analytic(&sphere).is_none());
    }

    #[test]
    fn mesh_triangles_are_drawn_by_area() {
        // Two triangles of areas 1 and 3 (a stretched quad's halves).
        let mesh = Mesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 2.0, 0.0],
                [3.0, 0.0, 1.0],
                [3.0, 2.0, 1.0],
                [6.0, 0.0, 1.0],
            ],
            indices: vec![[0, 1, 2], [3, 4, 5]],
            normals: None,
            uvs: None,
        };
        let s = AreaSampler::mesh(Arc::new(mesh)).unwrap();
        assert!((s.area() - 4.0).abs() < 1e-6);
        let mut rng = Rng::new(9);
        let m = 100_000;
        let mut second = 0;
        let mut centroid = V3::ZERO;
        for _ in 0..m {
            let q = s.sample(rng.uniform_f64(), rng.uniform(), rng.uniform(), true);
            if q.p.z > 0.5 {
                second += 1;
                assert!(
                    (q.n - V3::new(0.0, 0.0, -1.0)).length() < 1e-6,
                    "winding (3, 4, 5) faces -z"
                );
            } else {
                assert!((q.n - V3::Z).length() < 1e-6);
                centroid += q.p;
            }
        }
        let f = second as f64 / m as f64;
        assert!((f - 0.75).abs() < 5.0 * (0.75f64 * 0.25 / m as f64).sqrt(), "{f}");
        // Uniform on a triangle: the mean is the centroid (1/3, 2/3).
        let c = centroid / (m - second) as f32;
        assert!((c - V3::new(1.0 / 3.0, 2.0 / 3.0, 0.0)).length() < 0.01, "{c}");
    }

    #[test]
    fn spot_falloff_follows_mitsuba() {
        let s = Spot::new(V3::ZERO, V3::NEG_Y, V3::ONE, 30.0, 20.0);
        let at = |deg: f32| s.falloff(deg.to_radians().cos());
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(19.9), 1.0);
        assert!((at(25.0) - 0.5).abs() < 1e-4, "{}", at(25.0));
        assert!((at(27.5) - 0.25).abs() < 1e-4);
        assert_eq!(at(30.01), 0.0);
        assert_eq!(at(90.0), 0.0);
        assert_eq!(at(180.0), 0.0);
        // No band: a hard edge.
        let hard = Spot::new(V3::ZERO, V3::NEG_Y, V3::ONE, 30.0, 30.0);
        assert_eq!(hard.falloff(29.9f32.to_radians().cos()), 1.0);
        assert_eq!(hard.falloff(30.1f32.to_radians().cos()), 0.0);
        // Towards a point: the direction from the light.
        assert_eq!(s.intensity_towards(V3::new(0.0, -2.0, 0.0)), V3::ONE);
        assert_eq!(s.intensity_towards(V3::new(0.0, 2.0, 0.0)), V3::ZERO);
    }
}
