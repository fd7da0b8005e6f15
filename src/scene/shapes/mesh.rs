//! Triangle meshes: shading at a hit, bounds and volume, the closed-solid
//! check, and point in solid by the parity of a ray's crossings.
use super::normalize::normalize_or;
use glam::{DVec3, Vec3A as V3};

/// A triangle mesh in world space.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    /// Vertex positions, world space.
    pub positions: Vec<[f32; 3]>,
    /// Triangles (counter-clockwise seen from outside, for closed meshes).
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex shading normals (same length as positions) or none (flat).
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per-vertex texture coordinates or none.
    pub uvs: Option<Vec<[f32; 2]>>,
}

impl Mesh {
    /// Shading normal and uv at barycentrics (u, v) of triangle `prim`
    /// (Embree's convention: p = (1−u−v)·v0 + u·v1 + v·v2). Forced inline:
    /// the crate builds in 16 codegen units without LTO, so whether a call
    /// is inlined would otherwise depend on how unrelated code is
    /// partitioned, and the warp's ray pass calls it per pixel.
    #[inline(always)]
    pub fn shading(&self, prim: u32, u: f32, v: f32) -> (Option<V3>, [f32; 2]) {
        let tri = self.indices[prim as usize];
        let w = 1.0 - u - v;
        let n = self.normals.as_ref().map(|ns| {
            let [a, b, c] = tri.map(|i| V3::from(ns[i as usize]));
            (a * w + b * u + c * v).normalize_or_zero()
        });
        (
            n.filter(|n| n.length_squared() > 0.5),
            self.shading_uv(prim, u, v),
        )
    }

    /// The texture coordinates of [`Self::shading`] alone (without the
    /// normal, whose square root and division are a latency chain).
    #[inline(always)]
    pub fn shading_uv(&self, prim: u32, u: f32, v: f32) -> [f32; 2] {
        let Some(t) = self.uvs.as_ref() else {
            return [u, v];
        };
        let tri = self.indices[prim as usize];
        let w = 1.0 - u - v;
        let [a, b, c] = tri.map(|i| t[i as usize]);
        [a[0] * w + b[0] * u + c[0] * v, a[1] * w + b[1] * u + c[1] * v]
    }

    /// The shading normal of [`Self::shading`] alone (without the texture
    /// coordinates).
    #[inline(always)]
    pub fn shading_normal(&self, prim: u32, u: f32, v: f32) -> Option<V3> {
        let ns = self.normals.as_ref()?;
        let tri = self.indices[prim as usize];
        let w = 1.0 - u - v;
        let [a, b, c] = tri.map(|i| V3::from(ns[i as usize]));
        Some(normalize_or(a * w + b * u + c * v, V3::ZERO)).filter(|n| n.length_squared() > 0.5)
    }

    /// The point at barycentrics (u, v) of triangle `prim`, in f64 then rounded.
    #[inline]
    pub fn point(&self, prim: u32, u: f32, v: f32) -> V3 {
        let tri = self.indices[prim as usize];
        let (u, v) = (u.clamp(0.0, 1.0) as f64, v.clamp(0.0, 1.0) as f64);
        let w = (1.0 - u - v).max(0.0);
        let [a, b, c] = tri.map(|i| {
            let q = self.positions[i as usize];
            DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64)
        });
        let p = a * w + b * u + c * v;
        p.as_vec3a()
    }

    /// Axis-aligned bounds.
    pub fn aabb(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in &self.positions {
            let p = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            lo = lo.min(p);
            hi = hi.max(p);
        }
        (lo, hi)
    }

    /// Signed volume (positive for outward-facing closed meshes).
    pub fn signed_volume(&self) -> f64 {
        self.indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| {
                    let p = self.positions[i as usize];
                    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
                });
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Reverse the winding (and normals) of every triangle.
    pub fn flip(&mut self) {
        for t in &mut self.indices {
            t.swap(1, 2);
        }
        if let Some(ns) = &mut self.normals {
            for n in ns {
                *n = [-n[0], -n[1], -n[2]];
            }
        }
    }

    /// Closed-solid check: after welding equal positions, every edge must be
    /// used by exactly two triangles with opposite winding. Returns a
    /// description of the first violation.
    pub fn check_closed(&self) -> Result<(), String> {
        use std::collections::HashMap;
        let mut weld: HashMap<[u32; 3], u32> = HashMap::new();
        let ids: Vec<u32> = self
            .positions
            .iter()
            .map(|p| {
                let key = p.map(|c| if c == 0.0 { 0 } else { c.to_bits() });
                let n = weld.len() as u32;
                *weld.entry(key).or_insert(n)
            })
            .collect();
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &self.indices {
            let v = t.map(|i| ids[i as usize]);
            for k in 0..3 {
                *directed.entry((v[k], v[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &count) in &directed {
            if count != 1 {
                return Err(format!(
                    "an edge is used {count} times with the same winding (inconsistent orientation or non-manifold)"
                ));
            }
            if !directed.contains_key(&(b, a)) {
                return Err("it has an open edge (used by one triangle only): the mesh is not closed".into());
            }
        }
        Ok(())
    }

    /// Point-in-solid by ray parity (for closed meshes), with a fixed oblique direction.
    pub fn contains(&self, p: DVec3) -> bool {
        self.crossings(p, 0..self.indices.len() as u32) % 2 == 1
    }

    /// The direction of the point-in-solid parity ray (not axis-aligned, so
    /// it rarely runs along an edge of an axis-aligned mesh).
    pub(super) fn parity_dir() -> DVec3 {
        DVec3::new(0.5773, 0.5774, 0.5773).normalize()
    }

    /// Squared distance from `p` to triangle `tri`, exact (closest point by
    /// region, Ericson, *Real-Time Collision Detection* §5.1.5) when it may
    /// be at most `bound`; some value above `bound` (the squared distance to
    /// the triangle's plane) when the plane alone is farther; 0 for a
    /// degenerate triangle.
    pub fn distance_squared(&self, tri: u32, p: DVec3, bound: f64) -> f64 {
        let [a, b, c] = self.indices[tri as usize].map(|i| {
            let q = self.positions[i as usize];
            DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64)
        });
        let ab = b - a;
        let ac = c - a;
        let ap = p - a;
        let n = ab.cross(ac);
        let nn = n.length_squared();
        if nn == 0.0 {
            // A degenerate triangle (a segment or a point): called near, so
            // the answer stays conservative. Its edges are its neighbours'.
            return 0.0;
        }
        let h = ap.dot(n);
        // Most triangles of a cell are far from the point's plane.
        if h * h > bound * nn {
            return h * h / nn;
        }
        let d1 = ab.dot(ap);
        let d2 = ac.dot(ap);
        if d1 <= 0.0 && d2 <= 0.0 {
            return ap.length_squared();
        }
        let bp = p - b;
        let d3 = ab.dot(bp);
        let d4 = ac.dot(bp);
        if d3 >= 0.0 && d4 <= d3 {
            return bp.length_squared();
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            let v = d1 / (d1 - d3);
            return (ap - ab * v).length_squared();
        }
        let cp = p - c;
        let d5 = ab.dot(cp);
        let d6 = ac.dot(cp);
        if d6 >= 0.0 && d5 <= d6 {
            return cp.length_squared();
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            let w = d2 / (d2 - d6);
            return (ap - ac * w).length_squared();
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            return (bp - (c - b) * w).length_squared();
        }
        // va + vb + vc = |ab × ac|² > 0 here.
        let denom = va + vb + vc;
        let v = vb / denom;
        let w = vc / denom;
        (ap - ab * v - ac * w).length_squared()
    }

    /// Crossings of the parity ray from `p` with the triangles `tris`.
    pub(super) fn crossings(&self, p: DVec3, tris: impl IntoIterator<Item = u32>) -> u32 {
        let d = Self::parity_dir();
        let mut crossings = 0;
        for ti in tris {
            let t = &self.indices[ti as usize];
            let [a, b, c] = t.map(|i| {
                let q = self.positions[i as usize];
                DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64)
            });
            // Möller–Trumbore in f64.
            let e1 = b - a;
            let e2 = c - a;
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-300 {
                continue;
            }
            let inv = 1.0 / det;
            let tv = p - a;
            let u = tv.dot(pv) * inv;
            if !(0.0..=1.0).contains(&u) {
                continue;
            }
            let qv = tv.cross(e1);
            let v = d.dot(qv) * inv;
            if v < 0.0 || u + v > 1.0 {
                continue;
            }
            if e2.dot(qv) * inv > 0.0 {
                crossings += 1;
            }
        }
        crossings
    }
}
