//! Mesh generators (rect, box, lathe, diamond-square heightfield) and the OBJ loader.
use super::Mesh;
use crate::sampling::Rng;
use glam::DVec3;
use std::path::Path;

fn f3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// A rectangle as two triangles, counter-clockwise seen from `normal`.
/// `v_axis = normal × u_axis`; uv spans [0, 1]² along (u_axis, v_axis).
pub fn rect(center: DVec3, normal: DVec3, u_axis: DVec3, size: [f64; 2]) -> Mesh {
    let v_axis = normal.cross(u_axis);
    let hu = u_axis * (size[0] * 0.5);
    let hv = v_axis * (size[1] * 0.5);
    let p = [
        center - hu - hv,
        center + hu - hv,
        center + hu + hv,
        center - hu + hv,
    ];
    let n = f3(normal);
    Mesh {
        positions: p.iter().map(|&q| f3(q)).collect(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: Some(vec![n; 4]),
        uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
    }
}

/// An axis-aligned box, outward normals, flat shaded (no shared vertices across faces).
pub fn cuboid(center: DVec3, size: DVec3) -> Mesh {
    let mut m = Mesh {
        normals: Some(vec![]),
        uvs: Some(vec![]),
        ..Default::default()
    };
    let h = size * 0.5;
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut n = DVec3::ZERO;
            n[axis] = sign;
            let mut u = DVec3::ZERO;
            u[(axis + 1) % 3] = 1.0;
            let v = n.cross(u);
            let c = center + n * h[axis];
            let (su, sv) = (h.dot(u.abs()) * 2.0, h.dot(v.abs()) * 2.0);
            let r = rect(c, n, u, [su, sv]);
            let base = m.positions.len() as u32;
            m.positions.extend(r.positions);
            m.indices.extend(r.indices.iter().map(|t| t.map(|i| i + base)));
            m.normals.as_mut().unwrap().extend(r.normals.unwrap());
            m.uvs.as_mut().unwrap().extend(r.uvs.unwrap());
        }
    }
    m
}

/// How a lathe is shaded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LatheShading {
    /// No shading normals: every facet shows its geometric normal.
    Flat,
    /// Vertex normals smooth around the axis; along the profile, a joint whose
    /// turn is at most `crease_deg` degrees is smoothed too, a sharper one (a
    /// rim, a base edge) keeps each band's own normal.
    Smooth {
        /// The largest profile turn (degrees) that is smoothed.
        crease_deg: f64,
    },
}

/// The glass of water's profile (r, y): base, outer wall, rim, inner wall,
/// inner bottom; the tests' lathe.
#[cfg(test)]
pub(crate) const GLASS_PROFILE: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [1.0, 0.0],
    [1.0, 2.5],
    [0.9, 2.5],
    [0.9, 0.1],
    [0.0, 0.1],
];

/// A profile of (radius, height) points revolved around +y, `segments` around.
/// Consecutive profile points form bands; points on the axis (r = 0) produce
/// fans, not degenerate triangles. Winding: a profile walked bottom → top on
/// the outside (increasing y at r > 0) faces away from the axis.
///
/// Flat: vertices are shared around and along the profile. Smooth: every band
/// has its own rings (same f32 positions as its neighbours', so the mesh is
/// still closed after welding and Embree still sees no cracks) carrying the
/// band's normal, or at a smooth joint the mean of the two bands' normals.
pub fn lathe(profile: &[[f64; 2]], segments: u32, shading: LatheShading) -> Mesh {
    let crease_deg = match shading {
        LatheShading::Flat => return lathe_shared(profile, segments),
        LatheShading::Smooth { crease_deg } => crease_deg,
    };
    let s = segments as usize;
    let angle = |k: f64| std::f64::consts::TAU * k / s as f64;
    // Position of ring point k of profile point p: the same expression as the
    // flat lathe, so rings of neighbouring bands have bit-identical positions.
    let pos = |p: [f64; 2], k: usize| -> [f32; 3] {
        if p[0] == 0.0 {
            [0.0, p[1] as f32, 0.0]
        } else {
            let a = angle(k as f64);
            [(p[0] * a.cos()) as f32, p[1] as f32, (-p[0] * a.sin()) as f32]
        }
    };
    // Outward normal of band i in the (r, y) plane: the profile direction
    // turned clockwise, (dy, −dr) (up the outside → +r; along the base → −y).
    let nb = profile.len().saturating_sub(1);
    let band_n: Vec<Option<[f64; 2]>> = (0..nb)
        .map(|i| {
            let (dr, dy) = (
                profile[i + 1][0] - profile[i][0],
                profile[i + 1][1] - profile[i][1],
            );
            let l = dr.hypot(dy);
            (l > 0.0).then(|| [dy / l, -dr / l])
        })
        .collect();
    let cos_crease = crease_deg.to_radians().cos();
    // Normal at profile point `at` for band `b`: smoothed with the other band
    // meeting there when the joint turns by at most the crease angle.
    let joint_n = |b: usize, at: usize| -> [f64; 2] {
        let own = band_n[b].unwrap_or([0.0, 0.0]);
        let other = if at == b {
            b.checked_sub(1)
        } else {
            (b + 1 < nb).then_some(b + 1)
        };
        match other.and_then(|o| band_n[o]) {
            Some(o) if own[0] * o[0] + own[1] * o[1] >= cos_crease => {
                let (r, y) = (own[0] + o[0], own[1] + o[1]);
                let l = r.hypot(y);
                [r / l, y / l]
            }
            _ => own,
        }
    };
    let n3 = |n: [f64; 2], a: f64| -> [f32; 3] {
        [(n[0] * a.cos()) as f32, n[1] as f32, (-n[0] * a.sin()) as f32]
    };
    let mut m = Mesh {
        normals: Some(vec![]),
        ..Default::default()
    };
    for b in 0..nb {
        let ends = [b, b + 1];
        let on_axis = ends.map(|i| profile[i][0] == 0.0);
        if on_axis[0] && on_axis[1] {
            continue;
        }
        // One ring per end: s vertices; an axis end gets s copies of the axis
        // point whose normals follow the facet's mid angle (a cone's tip has
        // no single normal).
        let mut ring = [0u32; 2];
        for (e, &i) in ends.iter().enumerate() {
            ring[e] = m.positions.len() as u32;
            let n = joint_n(b, i);
            for k in 0..s {
                m.positions.push(pos(profile[i], k));
                let a = if on_axis[e] {
                    angle(k as f64 + 0.5)
                } else {
                    angle(k as f64)
                };
                m.normals.as_mut().expect("set above").push(n3(n, a));
            }
        }
        let idx = |e: usize, k: usize| ring[e] + (k % s) as u32;
        for k in 0..s {
            let (a0, a1, b0, b1) = (idx(0, k), idx(0, k + 1), idx(1, k), idx(1, k + 1));
            // A fan's axis vertex is the copy at this facet's own angle (k).
            if !on_axis[0] {
                let b1 = if on_axis[1] { b0 } else { b1 };
                m.indices.push([a0, a1, b1]);
            }
            if !on_axis[1] {
                m.indices.push([a0, b1, b0]);
            }
        }
    }
    m
}

/// The flat lathe: vertices shared around and along the profile, no normals.
fn lathe_shared(profile: &[[f64; 2]], segments: u32) -> Mesh {
    let s = segments as usize;
    let mut m = Mesh::default();
    let mut ring_start = Vec::with_capacity(profile.len());
    for p in profile {
        ring_start.push(m.positions.len() as u32);
        if p[0] == 0.0 {
            m.positions.push([0.0, p[1] as f32, 0.0]);
        } else {
            for k in 0..s {
                let a = std::f64::consts::TAU * k as f64 / s as f64;
                m.positions
                    .push([(p[0] * a.cos()) as f32, p[1] as f32, (-p[0] * a.sin()) as f32]);
            }
        }
    }
    let idx = |ring: usize, k: usize| -> u32 {
        if profile[ring][0] == 0.0 {
            ring_start[ring]
        } else {
            ring_start[ring] + (k % s) as u32
        }
    };
    for i in 0..profile.len().saturating_sub(1) {
        let (a_axis, b_axis) = (profile[i][0] == 0.0, profile[i + 1][0] == 0.0);
        for k in 0..s {
            let (a0, a1, b0, b1) = (idx(i, k), idx(i, k + 1), idx(i + 1, k), idx(i + 1, k + 1));
            // Angle increases counter-clockwise seen from +y, so (a0, a1, b1) faces outward
            // for a profile going up.
            if !a_axis {
                m.indices.push([a0, a1, b1]);
            }
            if !b_axis {
                m.indices.push([a0, b1, b0]);
            }
            if a_axis && b_axis {
                break;
            }
        }
    }
    m
}

/// Diamond-square terrain: (2^levels + 1)² vertices over `size` (x, z), centred
/// at the origin, heights in metres, deterministic in `seed`. Faces +y.
pub fn heightfield(size: [f64; 2], levels: u32, height: f64, roughness: f64, seed: u64) -> Mesh {
    let n = (1usize << levels) + 1;
    let mut h = vec![0.0f64; n * n];
    let mut rng = Rng::new(seed);
    let mut amp = height;
    let mut step = n - 1;
    let mut rnd = |amp: f64| (rng.uniform_f64() * 2.0 - 1.0) * amp;
    for &(i, j) in &[(0, 0), (0, n - 1), (n - 1, 0), (n - 1, n - 1)] {
        h[i * n + j] = rnd(amp);
    }
    while step > 1 {
        let half = step / 2;
        // Diamond step.
        for i in (half..n).step_by(step) {
            for j in (half..n).step_by(step) {
                let avg = (h[(i - half) * n + j - half]
                    + h[(i - half) * n + j + half]
                    + h[(i + half) * n + j - half]
                    + h[(i + half) * n + j + half])
                    / 4.0;
                h[i * n + j] = avg + rnd(amp);
            }
        }
        // Square step.
        for i in (0..n).step_by(half) {
            let start = if (i / half).is_multiple_of(2) { half } else { 0 };
            for j in (start..n).step_by(step) {
                let mut sum = 0.0;
                let mut cnt = 0.0;
                if i >= half {
                    sum += h[(i - half) * n + j];
                    cnt += 1.0;
                }
                if i + half < n {
                    sum += h[(i + half) * n + j];
                    cnt += 1.0;
                }
                if j >= half {
                    sum += h[i * n + j - half];
                    cnt += 1.0;
                }
                if j + half < n {
                    sum += h[i * n + j + half];
                    cnt += 1.0;
                }
                h[i * n + j] = sum / cnt + rnd(amp);
            }
        }
        amp *= roughness;
        step = half;
    }
    let mut m = Mesh::default();
    let mut uvs = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let x = (j as f64 / (n - 1) as f64 - 0.5) * size[0];
            let z = (i as f64 / (n - 1) as f64 - 0.5) * size[1];
            m.positions.push([x as f32, h[i * n + j] as f32, z as f32]);
            uvs.push([j as f32 / (n - 1) as f32, i as f32 / (n - 1) as f32]);
        }
    }
    for i in 0..n - 1 {
        for j in 0..n - 1 {
            let a = (i * n + j) as u32;
            let b = a + 1;
            let c = a + n as u32;
            let d = c + 1;
            // Counter-clockwise seen from +y: (a, c, b) since z grows with i.
            m.indices.push([a, c, b]);
            m.indices.push([b, c, d]);
        }
    }
    // Smooth normals by area-weighted face normals.
    let mut normals = vec![DVec3::ZERO; m.positions.len()];
    for t in &m.indices {
        let [a, b, c] = t.map(|i| {
            let p = m.positions[i as usize];
            DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
        });
        let fnrm = (b - a).cross(c - a);
        for i in t {
            normals[*i as usize] += fnrm;
        }
    }
    m.normals = Some(normals.iter().map(|n| f3(n.normalize_or(DVec3::Y))).collect());
    m.uvs = Some(uvs);
    m
}

/// Load every model of an OBJ file into one mesh (triangulated). Errors name the file.
pub fn load_obj(path: &Path, smooth: bool) -> Result<Mesh, String> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj(path, &opts).map_err(|e| format!("cannot load OBJ: {e}"))?;
    let mut m = Mesh::default();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut all_normals = smooth;
    let mut all_uvs = true;
    for model in &models {
        let mm = &model.mesh;
        let base = m.positions.len() as u32;
        let nv = mm.positions.len() / 3;
        for k in 0..nv {
            m.positions.push([
                mm.positions[3 * k],
                mm.positions[3 * k + 1],
                mm.positions[3 * k + 2],
            ]);
        }
        if mm.normals.len() == nv * 3 {
            for k in 0..nv {
                normals.push([mm.normals[3 * k], mm.normals[3 * k + 1], mm.normals[3 * k + 2]]);
            }
        } else {
            all_normals = false;
        }
        if mm.texcoords.len() == nv * 2 {
            for k in 0..nv {
                uvs.push([mm.texcoords[2 * k], mm.texcoords[2 * k + 1]]);
            }
        } else {
            all_uvs = false;
        }
        for t in mm.indices.chunks(3) {
            if t.len() == 3 {
                m.indices.push([t[0] + base, t[1] + base, t[2] + base]);
            }
        }
    }
    if m.indices.is_empty() {
        return Err("the OBJ file has no faces".into());
    }
    if all_normals {
        m.normals = Some(normals);
    }
    if all_uvs {
        m.uvs = Some(uvs);
    }
    for (k, p) in m.positions.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(format!("vertex {} has a non-finite coordinate", k + 1));
        }
    }
    Ok(m)
}

/// First degenerate (zero-area) triangle, as (face index, reason).
pub fn find_degenerate(m: &Mesh) -> Option<usize> {
    m.indices.iter().position(|t| {
        let [a, b, c] = t.map(|i| {
            let p = m.positions[i as usize];
            DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
        });
        let area2 = (b - a).cross(c - a).length();
        let scale = (b - a).length().max((c - a).length()).max(1e-30);
        area2.is_nan() || area2 <= 1e-12 * scale * scale
    })
}

/// A bilinear grid of `nx` × `ny` vertices over the quad `corners` (in the
/// order of `rect`: counter-clockwise seen from `normal`), uv over [0, 1]².
/// Used by the warp benchmarks to set a vertex count.
pub fn grid(corners: [DVec3; 4], normal: DVec3, nx: u32, ny: u32) -> Mesh {
    let (nx, ny) = (nx.max(2), ny.max(2));
    let mut positions = Vec::with_capacity((nx * ny) as usize);
    let mut uvs = Vec::with_capacity((nx * ny) as usize);
    for j in 0..ny {
        let v = j as f64 / (ny - 1) as f64;
        for i in 0..nx {
            let u = i as f64 / (nx - 1) as f64;
            let p = corners[0] * ((1.0 - u) * (1.0 - v))
                + corners[1] * (u * (1.0 - v))
                + corners[2] * (u * v)
                + corners[3] * ((1.0 - u) * v);
            positions.push(f3(p));
            uvs.push([u as f32, v as f32]);
        }
    }
    let mut indices = Vec::with_capacity(((nx - 1) * (ny - 1) * 2) as usize);
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let a = j * nx + i;
            let (b, c, d) = (a + 1, a + 1 + nx, a + nx);
            indices.push([a, b, c]);
            indices.push([a, c, d]);
        }
    }
    Mesh {
        normals: Some(vec![f3(normal); positions.len()]),
        positions,
        indices,
        uvs: Some(uvs),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn grid_spans_the_quad_with_the_asked_vertices() {
        let c = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        let m = grid(c, DVec3::Z, 5, 3);
        assert_eq!(m.positions.len(), 15);
        assert_eq!(m.indices.len(), 16);
        assert_eq!(m.aabb(), (c[0], c[2]));
        // Counter-clockwise seen from +z, area 2.
        let area: f64 = m
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| DVec3::from(m.positions[i as usize].map(|x| x as f64)));
                (b - a).cross(c - a).z * 0.5
            })
            .sum();
        assert!((area - 2.0).abs() < 1e-9, "{area}");
    }

    use super::*;

    #[test]
    fn box_is_closed_with_positive_volume_after_welding() {
        let b = cuboid(DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0));
        b.check_closed().unwrap();
        assert!((b.signed_volume() - 6.0).abs() < 1e-5);
        assert!(b.contains(DVec3::new(0.1, 0.2, 0.3)));
        assert!(!b.contains(DVec3::new(0.6, 0.0, 0.0)));
    }

    #[test]
    fn closed_lathe_is_a_solid_and_open_lathe_is_not() {
        // A cylinder of radius 1, height 1, closed by fans at both ends.
        let p = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let m = lathe(&p, 64, LatheShading::Flat);
        m.check_closed().unwrap();
        let v = m.signed_volume();
        let exact = 0.5 * 64.0 * (std::f64::consts::TAU / 64.0).sin();
        assert!((v - exact).abs() < 1e-4, "{v} vs {exact}");
        assert!(find_degenerate(&m).is_none());
        let open = lathe(&p[1..3], 64, LatheShading::Flat);
        assert!(open.check_closed().is_err());
    }

    #[test]
    fn smooth_lathe_is_closed_smooth_around_and_sharp_at_corners() {
        let p = GLASS_PROFILE;
        let flat = lathe(&p, 64, LatheShading::Flat);
        let m = lathe(&p, 64, LatheShading::Smooth { crease_deg: 30.0 });
        m.check_closed().unwrap();
        assert!(find_degenerate(&m).is_none());
        assert!((m.signed_volume() - flat.signed_volume()).abs() < 1e-9);
        let ns = m.normals.as_ref().unwrap();
        assert_eq!(ns.len(), m.positions.len());
        for (q, n) in m.positions.iter().zip(ns) {
            let (q, n) = (
                DVec3::from_array(q.map(|c| c as f64)),
                DVec3::from_array(n.map(|c| c as f64)),
            );
            let r = q.x.hypot(q.z);
            let radial = DVec3::new(q.x, 0.0, q.z) / r.max(1e-30);
            assert!((n.length() - 1.0).abs() < 1e-6);
            // Every vertex normal is the pure normal of one band: radial (±)
            // on the walls, ±y on base, rim and inner bottom; none is the
            // 45° mean a smoothed 90° corner would give.
            let is_wall = (n.dot(radial).abs() - 1.0).abs() < 1e-6 && n.y.abs() < 1e-6;
            let is_cap = (n.y.abs() - 1.0).abs() < 1e-6;
            assert!(is_wall || is_cap, "vertex {q} normal {n}");
        }
        // The shading normal at a point of the outer wall is radial (smooth
        // around), while the facet's geometric normal is not.
        let t = m
            .indices
            .iter()
            .position(|t| {
                t.iter().all(|&i| {
                    (m.positions[i as usize][0].hypot(m.positions[i as usize][2]) - 1.0).abs() < 1e-6
                }) && (0..3).any(|k| m.positions[t[k] as usize][1] == 0.0)
                    && (0..3).any(|k| m.positions[t[k] as usize][1] == 2.5)
            })
            .unwrap();
        let (n, _) = m.shading(t as u32, 0.3, 0.3);
        let q = m.point(t as u32, 0.3, 0.3);
        let radial = glam::Vec3A::new(q.x, 0.0, q.z).normalize();
        assert!(n.unwrap().dot(radial) > 1.0 - 1e-6);
        assert!(flat.normals.is_none());
        // A fine profile of a sphere is smooth across its joints (turn < crease).
        let sph: Vec<[f64; 2]> = (0..=32)
            .map(|i| {
                let a = std::f64::consts::PI * (i as f64 / 32.0 - 0.5);
                [if i == 0 || i == 32 { 0.0 } else { a.cos() }, a.sin()]
            })
            .collect();
        let m = lathe(&sph, 64, LatheShading::Smooth { crease_deg: 30.0 });
        m.check_closed().unwrap();
        for (q, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
            let (q, n) = (
                DVec3::from_array(q.map(|c| c as f64)),
                DVec3::from_array(n.map(|c| c as f64)),
            );
            if q.x.hypot(q.z) > 0.1 {
                assert!(n.dot(q.normalize()) > 0.995, "{q} {n}");
            }
        }
    }

    #[test]
    fn heightfield_is_deterministic_and_faces_up() {
        let a = heightfield([10.0, 10.0], 4, 1.0, 0.5, 7);
        let b = heightfield([10.0, 10.0], 4, 1.0, 0.5, 7);
        assert_eq!(a.positions, b.positions);
        assert_eq!(a.positions.len(), 17 * 17);
        let t = a.indices[0].map(|i| DVec3::from_array(a.positions[i as usize].map(|c| c as f64)));
        assert!((t[1] - t[0]).cross(t[2] - t[0]).y > 0.0);
    }
}
