//! The rectangle, or any parallelogram: the analytic twin of the
//! two-triangle mesh `meshgen::rect` makes, for scenes whose few analytic
//! shapes the path tracer intersects itself (`set`), where two triangles
//! would cost a whole Embree packet query.
use super::bounds::pad;
use super::segment::{candidate, Segment};
use super::Mesh;
use crate::embree::{Bounds, Candidates};
use glam::DVec3;

/// The parallelogram `corner + a·edge_u + b·edge_v`, `a, b ∈ [0, 1]`, with
/// the normal the mesh rect's triangles have (their winding's), so that a
/// one-sided emitter or a checker texture looks the same on either.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// The corner where the texture coordinates are (0, 0).
    pub corner: DVec3,
    /// The edge along which u goes from 0 to 1.
    pub edge_u: DVec3,
    /// The edge along which v goes from 0 to 1.
    pub edge_v: DVec3,
    /// Unit normal (± `edge_u × edge_v`, as the mesh's winding was).
    pub normal: DVec3,
}

impl Rect {
    /// The parallelogram spanned by `edge_u` and `edge_v` from `corner`,
    /// facing `edge_u × edge_v` or, when `flip`, away from it; `None` when
    /// the edges span no area (or are not finite).
    pub fn new(corner: DVec3, edge_u: DVec3, edge_v: DVec3, flip: bool) -> Option<Rect> {
        let n = edge_u.cross(edge_v);
        let n2 = n.length_squared();
        if !(n2 > 0.0 && n2.is_finite() && corner.is_finite()) {
            return None;
        }
        let normal = n / n2.sqrt();
        Some(Rect {
            corner,
            edge_u,
            edge_v,
            normal: if flip { -normal } else { normal },
        })
    }

    /// The vectors whose dot products with `p − corner` are a point's
    /// coordinates (a, b) along the edges: the basis dual to the edges in
    /// the plane (they need not be perpendicular). Made when needed rather
    /// than kept: every light holds an [`Analytic`](super::Analytic), whose
    /// size is its largest shape's.
    #[inline(always)]
    pub(super) fn dual(&self) -> (DVec3, DVec3) {
        let n = self.edge_u.cross(self.edge_v);
        let n2 = n.length_squared();
        (self.edge_v.cross(n) / n2, n.cross(self.edge_u) / n2)
    }

    /// The twin of a mesh `meshgen::rect` made (then transformed): its
    /// vertices 0, 1 and 3 are the corners at texture coordinates (0, 0),
    /// (1, 0) and (0, 1), and its first triangle's winding gives the side
    /// the normal faces. `None` for any other mesh.
    pub fn of_mesh(m: &Mesh) -> Option<Rect> {
        let uvs = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        if m.positions.len() != 4 || m.indices.len() != 2 || m.uvs.as_deref() != Some(&uvs[..]) {
            return None;
        }
        let flip = match m.indices[..] {
            [[0, 1, 2], [0, 2, 3]] => false,
            [[0, 2, 1], [0, 3, 2]] => true,
            _ => return None,
        };
        let p = |i: usize| DVec3::from(m.positions[i].map(f64::from));
        Rect::new(p(0), p(1) - p(0), p(3) - p(0), flip)
    }

    /// A point's coordinates along the two edges (the parallelogram is
    /// where both lie in [0, 1]).
    #[inline(always)]
    fn coords(&self, p: DVec3) -> (f64, f64) {
        let q = p - self.corner;
        let (to_a, to_b) = self.dual();
        (q.dot(to_a), q.dot(to_b))
    }

    /// The crossing of the segment with the parallelogram, if the segment
    /// keeps it ([`Segment::plane_crossing`]).
    #[inline]
    pub(super) fn crossing(&self, seg: &Segment) -> Option<f64> {
        let t = seg.plane_crossing(self.corner, self.normal)?;
        let (a, b) = self.coords(seg.o + seg.d * t);
        ((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)).then_some(t)
    }

    /// The crossing of the segment, onto `out`.
    #[inline(always)]
    pub(super) fn intersect(&self, seg: &Segment, out: &mut Candidates) {
        if let Some(t) = self.crossing(seg) {
            out.push(candidate(t, self.normal));
        }
    }

    /// `p` moved along the normal onto the plane.
    #[inline(always)]
    pub(super) fn project(&self, p: DVec3) -> DVec3 {
        p - self.normal * (p - self.corner).dot(self.normal)
    }

    /// Texture coordinates at `p` on the surface: its coordinates along the
    /// edges, as the mesh interpolates them from its corners', kept in
    /// [0, 1]² (a hit's point may stray by rounding).
    pub(super) fn uv(&self, p: DVec3) -> [f32; 2] {
        let (a, b) = self.coords(p);
        [a.clamp(0.0, 1.0) as f32, b.clamp(0.0, 1.0) as f32]
    }

    /// Embree's bounds: the four corners' box, padded.
    pub(super) fn bounds(&self) -> Bounds {
        let (c, u, v) = (self.corner, self.edge_u, self.edge_v);
        let corners = [c, c + u, c + v, c + u + v];
        let lo = corners.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
        let hi = corners.iter().fold(DVec3::NEG_INFINITY, |a, &b| a.max(b));
        pad(lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::embree::{BuildQuality, Device, SceneBuilder, SceneFlags};
    use crate::ray::Ray;
    use crate::scene::meshgen;
    use glam::Vec3A as V3;

    /// How many of `rays` a rect answers otherwise than Embree does for the
    /// two triangles of `mesh`: a hit where Embree misses or the reverse
    /// (unless the plane's crossing lies within 1e-5 of an edge, plus the
    /// slack below), t off by
    /// more than a relative 1e-5, or the normal or the texture coordinates
    /// (the mesh's interpolated at Embree's barycentrics) off by more than
    /// 1e-5; and how many hits were grazing enough for Embree's f32 to
    /// need more slack than that.
    ///
    /// Embree finds a triangle's t and barycentrics in f32: a few ulps of
    /// the coordinates across the plane, divided by the cosine of the ray
    /// with the normal, along the ray. The analytic rect's are f64 (from the
    /// same f32 corners). So t and uv may also differ by 2e-7 of the
    /// coordinates over the cosine (world units).
    fn disagreements(rect: &Rect, mesh: &Mesh, rays: &[Ray]) -> (usize, usize) {
        let device = Device::new("").unwrap();
        let mut b = SceneBuilder::new(&device, SceneFlags::default(), BuildQuality::Medium).unwrap();
        b.add_triangles(&mesh.positions, &mesh.indices).unwrap();
        let scene = b.commit().unwrap();
        let (mut bad, mut grazing) = (0, 0);
        for r in rays {
            let want = scene.intersect(r);
            let mut c = Candidates::default();
            rect.intersect(&Segment::new(r.org, r.dir, r.tnear, r.tfar), &mut c);
            let got = c.as_slice().first();
            let ok = match (want, got) {
                (None, None) => true,
                (Some(w), Some(g)) => {
                    let p = (r.org + r.dir * g.t).as_dvec3();
                    let uv = mesh.shading_uv(w.prim_id, w.u, w.v);
                    let n = V3::from(g.ng);
                    let (o, d) = (r.org.as_dvec3(), r.dir.as_dvec3());
                    let extent = o.abs().max_element().max(p.abs().max_element());
                    let slack = 2e-7 * extent * d.length() / d.dot(rect.normal).abs();
                    let edges = [rect.edge_u.length(), rect.edge_v.length()];
                    grazing += usize::from(slack > 1e-5 * edges[0].min(edges[1]));
                    let (dt, t) = ((g.t - w.t).abs() as f64, w.t.abs() as f64);
                    dt <= 1e-5 * t + slack / d.length()
                        && (n - w.ng.normalize()).length() <= 1e-5
                        && (0..2).all(|i| ((rect.uv(p)[i] - uv[i]).abs() as f64) <= 1e-5 + slack / edges[i])
                }
                _ => {
                    // Near an edge, either answer: the plane's crossing, its
                    // distance to the nearest edge line (in world units).
                    let (o, d) = (r.org.as_dvec3(), r.dir.as_dvec3());
                    let t = (rect.corner - o).dot(rect.normal) / d.dot(rect.normal);
                    let p = o + d * t;
                    let (a, b) = rect.coords(p);
                    let edge = (a.abs().min((1.0 - a).abs()) * rect.edge_u.length())
                        .min(b.abs().min((1.0 - b).abs()) * rect.edge_v.length());
                    let extent = o.abs().max_element().max(p.abs().max_element());
                    let slack = 2e-7 * extent * d.length() / d.dot(rect.normal).abs();
                    edge <= 1e-5 + slack
                }
            };
            bad += usize::from(!ok);
        }
        (bad, grazing)
    }

    /// Rays aimed at and around the parallelogram (its edges and corners
    /// included), from either side, some with a bounded interval.
    fn rays_at(rect: &Rect, seed: u64, count: usize) -> Vec<Ray> {
        let mut rng = crate::sampling::Rng::new(seed);
        let mut u = move || rng.uniform_f64();
        (0..count)
            .map(|k| {
                let (a, b) = if k % 4 == 0 {
                    // At an edge or a corner, within a hair or a little more.
                    let snap = |x: f64| if x < 0.5 { 0.0 } else { 1.0 };
                    let e = (u() - 0.5) * if k % 8 == 0 { 1e-6 } else { 4e-4 };
                    match k % 3 {
                        0 => (snap(u()) + e, u()),
                        1 => (u(), snap(u()) + e),
                        _ => (snap(u()) + e, snap(u()) + e),
                    }
                } else {
                    (u() * 1.4 - 0.2, u() * 1.4 - 0.2)
                };
                let aim = rect.corner + rect.edge_u * a + rect.edge_v * b;
                let off = DVec3::new(u(), u(), u()) * 8.0 - DVec3::splat(4.0);
                let org = aim + off;
                let mut r = Ray::new(org.as_vec3a(), (aim - org).as_vec3a() * (0.2 + u() as f32));
                if u() < 0.3 {
                    r.tnear = u() as f32;
                    r.tfar = r.tnear + 6.0 * u() as f32;
                }
                r
            })
            .collect()
    }

    /// Rects as the builder makes them (meshgen's, with a shear or a mirror
    /// transform or none) and their analytic twins.
    fn cases() -> Vec<(Mesh, Rect)> {
        let n = DVec3::new(0.3, 1.0, -0.4).normalize();
        let u = n.any_orthonormal_pair().0;
        let plain = meshgen::rect(DVec3::new(0.5, -1.2, 0.3), n, u, [3.0, 1.25]);
        let ground = meshgen::rect(DVec3::new(0.0, -1.0, 0.0), DVec3::Y, DVec3::X, [8.0, 8.0]);
        let mut sheared = plain.clone();
        for p in &mut sheared.positions {
            *p = [p[0] + 0.7 * p[1], p[1], p[2] - 0.2 * p[0]];
        }
        let mut mirrored = plain.clone();
        for p in &mut mirrored.positions {
            p[0] = -p[0];
        }
        for t in &mut mirrored.indices {
            t.swap(1, 2);
        }
        [plain, ground, sheared, mirrored]
            .into_iter()
            .map(|m| {
                let r = Rect::of_mesh(&m).expect("a rect mesh");
                (m, r)
            })
            .collect()
    }

    /// The analytic rect answers as Embree does for its two triangles: the
    /// same hits and misses (but within 1e-5 of an edge), t, normal and
    /// texture coordinates (to Embree's f32 precision for grazing rays), for
    /// many rays from either side, at its edges
    /// and corners, for a plain rect, the scenes' ground, a sheared one and
    /// a mirrored one (the normal turns with the winding). The check has
    /// power: the rect with its edges swapped (its normal turned and its
    /// coordinates swapped) or a relative 1e-4 larger disagrees.
    #[test]
    fn a_rect_answers_as_its_two_triangles() {
        for (k, (mesh, rect)) in cases().into_iter().enumerate() {
            let rays = rays_at(&rect, 7 + k as u64, 20_000);
            let (bad, grazing) = disagreements(&rect, &mesh, &rays);
            assert_eq!(bad, 0, "case {k}: {rect:?}");
            // The slack is the grazing rays' alone.
            assert!(grazing < 1000, "case {k}: {grazing} of 20000 rays grazing");
            let hits = rays
                .iter()
                .filter(|r| {
                    let mut c = Candidates::default();
                    rect.intersect(&Segment::new(r.org, r.dir, r.tnear, r.tfar), &mut c);
                    !c.as_slice().is_empty()
                })
                .count();
            assert!(
                hits > 8_000,
                "case {k}: {hits} hits: the rays should meet the rect"
            );
            let flipped = rect.normal.dot(rect.edge_u.cross(rect.edge_v)) < 0.0;
            let swapped = Rect::new(rect.corner, rect.edge_v, rect.edge_u, flipped).unwrap();
            assert!(
                disagreements(&swapped, &mesh, &rays).0 > 1000,
                "case {k}: swapped edges"
            );
            let grown = Rect::new(rect.corner, rect.edge_u * (1.0 + 1e-4), rect.edge_v, flipped).unwrap();
            assert!(
                disagreements(&grown, &mesh, &rays).0 > 1000,
                "case {k}: a larger rect"
            );
        }
    }

    /// A ray parallel to the plane meets nothing (also one in the plane);
    /// a degenerate rect is refused; only rect meshes have twins.
    #[test]
    fn parallel_rays_degenerate_rects_and_other_meshes() {
        let (_, rect) = cases().remove(1);
        for org in [V3::new(-5.0, -1.0, 0.5), V3::new(-5.0, -0.5, 0.5)] {
            let mut c = Candidates::default();
            rect.intersect(&Segment::new(org, V3::X, 0.0, f32::INFINITY), &mut c);
            assert!(c.as_slice().is_empty(), "{org}");
        }
        assert!(Rect::new(DVec3::ZERO, DVec3::X, DVec3::X * 2.0, false).is_none());
        assert!(Rect::new(DVec3::ZERO, DVec3::X, DVec3::new(f64::NAN, 0.0, 0.0), false).is_none());
        let cube = meshgen::cuboid(DVec3::ZERO, DVec3::ONE);
        assert!(Rect::of_mesh(&cube).is_none());
    }
}
