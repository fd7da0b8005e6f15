//! Point in solid for a closed mesh at the cost of a few triangles: the
//! triangles binned along the parity ray ([`ContainsGrid`]), and the mesh's
//! bounds cut into cells classified once ([`InOutCells`]).
use super::mesh::Mesh;
use glam::DVec3;

/// A point-in-solid accelerator for a closed mesh: the triangles binned by
/// their projection along the parity ray's direction onto a uniform 2-D grid,
/// so a query tests only the triangles whose projected bounds (padded) cover
/// the point's projection. The same Möller–Trumbore test on a superset of the
/// triangles the parity ray can hit: answers equal `Mesh::contains` (test),
/// at O(triangles per cell) instead of O(triangles).
#[derive(Debug)]
pub struct ContainsGrid {
    mesh: std::sync::Arc<Mesh>,
    axes: [DVec3; 2],
    lo: [f64; 2],
    inv_cell: [f64; 2],
    n: [usize; 2],
    /// Cell c's triangles are `tris[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    tris: Vec<u32>,
    /// Each triangle's plane: unit normal and offset (`n·x = d`); zero for
    /// a degenerate triangle. Gates `surface_near`'s exact distances.
    planes: Vec<[f64; 4]>,
    /// The mesh's bounds cut into cells, each classified on first use.
    cells: InOutCells,
}

/// The bounds of a closed mesh cut into at most 64 cells a side, each
/// classified on first use as wholly outside, wholly inside, or mixed (the
/// surface may pass through it). A point in a classified whole cell gets
/// its answer from one load; a point in a mixed cell (or outside the
/// bounds) from the parity test. A cell is whole when no triangle comes
/// within its half-diagonal of its centre (`ContainsGrid::surface_near`,
/// never false when one does), so every point of it lies on the same side
/// as the centre; the side is taken from two parity tests (the centre and
/// a point a quarter cell off it), and a cell where they disagree (a parity
/// ray through an edge) stays mixed. Most of the nested rule's
/// point-in-solid queries land in whole cells, away from the surface.
#[derive(Debug)]
struct InOutCells {
    lo: DVec3,
    size: DVec3,
    n: [usize; 3],
    /// `UNKNOWN`, `OUTSIDE`, `INSIDE` or `MIXED` per cell, x fastest.
    /// Relaxed loads and stores: a cell's class is a function of the mesh,
    /// so two threads classifying it store the same value.
    state: Vec<std::sync::atomic::AtomicU8>,
}

const CELL_UNKNOWN: u8 = 0;
const CELL_OUTSIDE: u8 = 1;
const CELL_INSIDE: u8 = 2;
const CELL_MIXED: u8 = 3;

impl InOutCells {
    /// Cells over the bounds (`lo`, `hi`), the longest side cut in 64.
    fn new(lo: DVec3, hi: DVec3) -> Self {
        let ext = (hi - lo).max(DVec3::splat(1e-9 * (1.0 + lo.abs().max(hi.abs()).max_element())));
        let cell = ext.max_element() / 64.0;
        let n = ext.to_array().map(|e| ((e / cell).ceil() as usize).clamp(1, 64));
        let size = ext / DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
        InOutCells {
            lo,
            size,
            n,
            state: (0..n[0] * n[1] * n[2])
                .map(|_| std::sync::atomic::AtomicU8::new(CELL_UNKNOWN))
                .collect(),
        }
    }

    /// The cell holding `p` (its index and its coordinates); `None` outside
    /// the bounds.
    #[inline]
    fn cell_of(&self, p: DVec3) -> Option<(usize, [usize; 3])> {
        let x = (p - self.lo) / self.size;
        let mut i = [0usize; 3];
        for k in 0..3 {
            // `!(..)` also rejects NaN.
            if !(x[k] >= 0.0 && x[k] < self.n[k] as f64) {
                return None;
            }
            i[k] = x[k] as usize;
        }
        Some(((i[2] * self.n[1] + i[1]) * self.n[0] + i[0], i))
    }

    fn centre(&self, i: [usize; 3]) -> DVec3 {
        self.lo + (DVec3::new(i[0] as f64, i[1] as f64, i[2] as f64) + 0.5) * self.size
    }
}

impl ContainsGrid {
    /// Bin `mesh`'s triangles.
    pub fn new(mesh: std::sync::Arc<Mesh>) -> Self {
        let d = Mesh::parity_dir();
        let u = d.any_orthonormal_vector();
        let axes = [u, d.cross(u)];
        let proj = |i: u32| -> [f64; 2] {
            let q = mesh.positions[i as usize];
            let q = DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64);
            [q.dot(axes[0]), q.dot(axes[1])]
        };
        let boxes: Vec<([f64; 2], [f64; 2])> = mesh
            .indices
            .iter()
            .map(|t| {
                let p = t.map(proj);
                let lo = [0, 1].map(|k| p[0][k].min(p[1][k]).min(p[2][k]));
                let hi = [0, 1].map(|k| p[0][k].max(p[1][k]).max(p[2][k]));
                (lo, hi)
            })
            .collect();
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for (a, b) in &boxes {
            for k in 0..2 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
            }
        }
        // Pad every box by far more than the rounding of the projection and
        // of Möller–Trumbore's barycentrics, so no triangle the exact test
        // could accept is missed.
        let ext = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-30);
        let pad = 1e-7 * ext + 1e-30;
        // Four cells per triangle's worth of side: the cells are binned by the
        // triangle's own extent in each row (below), so a long thin triangle
        // (a lathe's wall, seen along the diagonal) covers a strip of cells,
        // not its whole bounding box.
        let side = ((4.0 * mesh.indices.len() as f64).sqrt().ceil() as usize).clamp(1, 2048);
        let n = [side, side];
        let span = [0, 1].map(|k| (hi[k] - lo[k]) + 2.0 * pad);
        let lo = [lo[0] - pad, lo[1] - pad];
        let inv_cell = [0, 1].map(|k| n[k] as f64 / span[k].max(1e-300));
        let cell_of = |x: f64, k: usize| -> usize {
            (((x - lo[k]) * inv_cell[k]).floor().max(0.0) as usize).min(n[k] - 1)
        };
        // Per triangle: its rows, and in each row the columns its projection
        // (padded) covers: the x extent of the triangle clipped to the row's
        // band, widened by the pad. Convex, so the extent is reached at the
        // corners inside the band or where the edges cross its two lines.
        let cell_h = span[1] / n[1] as f64;
        let ranges: Vec<Vec<(usize, usize, usize)>> = mesh
            .indices
            .iter()
            .zip(&boxes)
            .map(|(t, (a, b))| {
                let p = t.map(proj);
                let (y0, y1) = (cell_of(a[1] - pad, 1), cell_of(b[1] + pad, 1));
                (y0..=y1)
                    .filter_map(|y| {
                        let ya = lo[1] + y as f64 * cell_h - pad;
                        let yb = lo[1] + (y + 1) as f64 * cell_h + pad;
                        let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
                        for i in 0..3 {
                            let (u, w) = (p[i], p[(i + 1) % 3]);
                            if u[1] >= ya && u[1] <= yb {
                                x0 = x0.min(u[0]);
                                x1 = x1.max(u[0]);
                            }
                            for c in [ya, yb] {
                                if (u[1] - c) * (w[1] - c) < 0.0 {
                                    let x = u[0] + (c - u[1]) / (w[1] - u[1]) * (w[0] - u[0]);
                                    x0 = x0.min(x);
                                    x1 = x1.max(x);
                                }
                            }
                        }
                        // Rounding in the crossings is far below the pad; clamp to the box.
                        (x0 <= x1)
                            .then(|| (y, cell_of(x0.max(a[0]) - pad, 0), cell_of(x1.min(b[0]) + pad, 0)))
                    })
                    .collect()
            })
            .collect();
        let mut count = vec![0u32; n[0] * n[1] + 1];
        for r in &ranges {
            for &(y, x0, x1) in r {
                for x in x0..=x1 {
                    count[y * n[0] + x + 1] += 1;
                }
            }
        }
        for c in 1..count.len() {
            count[c] += count[c - 1];
        }
        let start = count.clone();
        let mut fill = count;
        let mut tris = vec![0u32; *start.last().unwrap_or(&0) as usize];
        for (t, r) in ranges.iter().enumerate() {
            for &(y, x0, x1) in r {
                for x in x0..=x1 {
                    let c = y * n[0] + x;
                    tris[fill[c] as usize] = t as u32;
                    fill[c] += 1;
                }
            }
        }
        let planes = mesh
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| DVec3::from_array(mesh.positions[i as usize].map(f64::from)));
                let n = (b - a).cross(c - a).normalize_or_zero();
                [n.x, n.y, n.z, n.dot(a)]
            })
            .collect();
        let (blo, bhi) = mesh.aabb();
        Self {
            mesh,
            axes,
            lo,
            inv_cell,
            n,
            start,
            tris,
            planes,
            cells: InOutCells::new(blo, bhi),
        }
    }

    /// Is `p` inside the mesh? From its cell's class where the cell is whole
    /// (`InOutCells`), else [`Self::parity_contains`].
    #[inline]
    pub fn contains(&self, p: DVec3) -> bool {
        use std::sync::atomic::Ordering::Relaxed;
        let Some((c, i)) = self.cells.cell_of(p) else {
            return self.parity_contains(p);
        };
        let mut class = self.cells.state[c].load(Relaxed);
        if class == CELL_UNKNOWN {
            class = self.classify(i);
            self.cells.state[c].store(class, Relaxed);
        }
        match class {
            CELL_OUTSIDE => false,
            CELL_INSIDE => true,
            _ => self.parity_contains(p),
        }
    }

    /// The class of cell `i` (see [`InOutCells`]).
    #[cold]
    fn classify(&self, i: [usize; 3]) -> u8 {
        let c = self.cells.centre(i);
        let half = 0.5 * self.cells.size.length();
        // Widened far beyond the rounding of the distance tests.
        if self.surface_near(c, half * (1.0 + 1e-6) + 1e-9 * (1.0 + c.abs().max_element())) {
            return CELL_MIXED;
        }
        let a = self.parity_contains(c);
        let b = self.parity_contains(c + 0.25 * self.cells.size * DVec3::new(1.0, -0.7, 0.4));
        match (a, b) {
            (true, true) => CELL_INSIDE,
            (false, false) => CELL_OUTSIDE,
            _ => CELL_MIXED,
        }
    }

    /// Is `p` inside the mesh? (Parity of the parity ray's crossings.)
    pub fn parity_contains(&self, p: DVec3) -> bool {
        let q = [p.dot(self.axes[0]), p.dot(self.axes[1])];
        let mut cell = [0usize; 2];
        for k in 0..2 {
            let x = (q[k] - self.lo[k]) * self.inv_cell[k];
            if !(x >= 0.0 && x < self.n[k] as f64) {
                // Outside every padded projected triangle: no crossing.
                return false;
            }
            cell[k] = x as usize;
        }
        let c = cell[1] * self.n[0] + cell[0];
        let tris = &self.tris[self.start[c] as usize..self.start[c + 1] as usize];
        self.mesh.crossings(p, tris.iter().copied()) % 2 == 1
    }

    /// Might the mesh's surface pass within `tol` of `p`? Never false when
    /// some triangle is within `tol` (the triangles of every cell the
    /// projected disc of radius `tol` overlaps are tested by exact
    /// point–triangle distance); O(triangles per cell), like [`Self::contains`].
    pub fn surface_near(&self, p: DVec3, tol: f64) -> bool {
        let q = [p.dot(self.axes[0]), p.dot(self.axes[1])];
        let mut range = [(0usize, 0usize); 2];
        for k in 0..2 {
            let a = (q[k] - tol - self.lo[k]) * self.inv_cell[k];
            let b = (q[k] + tol - self.lo[k]) * self.inv_cell[k];
            // `!(..)` also rejects NaN.
            if !(b >= 0.0 && a < self.n[k] as f64) {
                return false;
            }
            range[k] = (a.max(0.0) as usize, (b as usize).min(self.n[k] - 1));
        }
        let tol2 = tol * tol;
        for y in range[1].0..=range[1].1 {
            for x in range[0].0..=range[0].1 {
                let c = y * self.n[0] + x;
                let tris = &self.tris[self.start[c] as usize..self.start[c + 1] as usize];
                let near = |&t: &u32| {
                    let [nx, ny, nz, d] = self.planes[t as usize];
                    // Most triangles of a cell are far from the point's plane.
                    (nx * p.x + ny * p.y + nz * p.z - d).abs() <= tol
                        && self.mesh.distance_squared(t, p, tol2) <= tol2
                };
                if tris.iter().any(near) {
                    return true;
                }
            }
        }
        false
    }

    /// Triangles a query at `p` tests (0 outside the grid).
    #[cfg(test)]
    fn tested(&self, p: DVec3) -> usize {
        let q = [p.dot(self.axes[0]), p.dot(self.axes[1])];
        let x = [0, 1].map(|k| (q[k] - self.lo[k]) * self.inv_cell[k]);
        if (0..2).any(|k| !(x[k] >= 0.0 && x[k] < self.n[k] as f64)) {
            return 0;
        }
        let c = x[1] as usize * self.n[0] + x[0] as usize;
        (self.start[c + 1] - self.start[c]) as usize
    }

    /// The mesh.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_distance_is_exact_and_the_grid_finds_every_near_surface() {
        use crate::scene::meshgen::{lathe, LatheShading};
        let p = crate::scene::meshgen::GLASS_PROFILE;
        let m = std::sync::Arc::new(lathe(&p, 48, LatheShading::Flat));
        let mut rng = crate::sampling::Rng::new(11);
        // The closed form against a dense barycentric sampling of one triangle
        // (an independent upper bound, within the sampling's spacing).
        for _ in 0..200 {
            let t = (rng.uniform_f64() * m.indices.len() as f64) as u32;
            let q = DVec3::new(
                rng.uniform_f64() * 3.0 - 1.5,
                rng.uniform_f64() * 3.0 - 0.25,
                rng.uniform_f64() * 3.0 - 1.5,
            );
            let [a, b, c] =
                m.indices[t as usize].map(|i| DVec3::from_array(m.positions[i as usize].map(f64::from)));
            let k = 200;
            let mut best = f64::INFINITY;
            for i in 0..=k {
                for j in 0..=(k - i) {
                    let (u, v) = (i as f64 / k as f64, j as f64 / k as f64);
                    best = best.min((a + (b - a) * u + (c - a) * v - q).length());
                }
            }
            let exact = m.distance_squared(t, q, f64::INFINITY).sqrt();
            let spacing = (b - a).length().max((c - a).length()) / k as f64;
            assert!(
                exact <= best + 1e-12 && best - exact <= spacing,
                "{exact} vs sampled {best}"
            );
        }
        // The grid's answer equals brute force over every triangle, for points
        // scattered near the surface at distances around the tolerance.
        let g = ContainsGrid::new(m.clone());
        let tol = 1e-5;
        let (mut near, mut far) = (0, 0);
        for _ in 0..20000 {
            let t = (rng.uniform_f64() * m.indices.len() as f64) as usize;
            let [a, b, c] = m.indices[t].map(|i| DVec3::from_array(m.positions[i as usize].map(f64::from)));
            let (u, v) = (rng.uniform_f64(), rng.uniform_f64());
            let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
            let on = a + (b - a) * u + (c - a) * v;
            let dir = DVec3::new(
                rng.uniform_f64() - 0.5,
                rng.uniform_f64() - 0.5,
                rng.uniform_f64() - 0.5,
            )
            .normalize();
            let q = on + dir * (rng.uniform_f64() * 3.0 * tol);
            let brute = (0..m.indices.len() as u32)
                .map(|t| m.distance_squared(t, q, f64::INFINITY))
                .fold(f64::INFINITY, f64::min);
            let expect = brute <= tol * tol;
            assert_eq!(g.surface_near(q, tol), expect, "{q}: brute {}", brute.sqrt());
            if expect {
                near += 1;
            } else {
                far += 1;
            }
        }
        assert!(
            near > 3000 && far > 3000,
            "both answers sampled: {near} near, {far} far"
        );
        // Far outside the grid: nothing near.
        assert!(!g.surface_near(DVec3::new(5.0, 1.0, 5.0), tol));
    }

    /// The cell cache answers as the parity test does, at points scattered
    /// through the bounds and a hair off the surface, on the glass lathe
    /// and a rotated box; most points are answered from whole cells. Its
    /// power: classifying each cell by its centre alone (no surface gate)
    /// gets points wrong.
    #[test]
    fn cell_cache_agrees_with_parity() {
        use crate::scene::meshgen::{lathe, LatheShading};
        let glass = lathe(
            &crate::scene::meshgen::GLASS_PROFILE,
            96,
            LatheShading::Smooth { crease_deg: 30.0 },
        );
        let mut cube = lathe(
            &[[0.0, -0.35], [0.5, -0.35], [0.5, 0.35], [0.0, 0.35]],
            4,
            LatheShading::Flat,
        );
        let rot = glam::DQuat::from_axis_angle(DVec3::new(1.0, 0.3, 0.2).normalize(), 0.44);
        for v in &mut cube.positions {
            let q = rot * DVec3::from_array(v.map(f64::from)) + DVec3::new(-0.25, 1.75, 0.1);
            *v = q.to_array().map(|c| c as f32);
        }
        let mut rng = crate::sampling::Rng::new(9);
        for m in [glass, cube] {
            let m = std::sync::Arc::new(m);
            let g = ContainsGrid::new(m.clone());
            let (lo, hi) = m.aabb();
            let mut pts: Vec<DVec3> = (0..40000)
                .map(|_| {
                    let u = DVec3::new(rng.uniform_f64(), rng.uniform_f64(), rng.uniform_f64());
                    lo - 0.05 + (hi - lo + 0.1) * u
                })
                .collect();
            for t in m.indices.iter() {
                let [a, b, c] = t.map(|i| DVec3::from_array(m.positions[i as usize].map(f64::from)));
                let n = (b - a).cross(c - a).normalize();
                let on = (a + b + c) / 3.0;
                pts.extend([on + n * 1e-6, on - n * 1e-6, on + n * 1e-3, on - n * 1e-3]);
            }
            let (mut whole, mut naive_wrong) = (0, 0);
            for &q in &pts {
                let exact = g.parity_contains(q);
                assert_eq!(g.contains(q), exact, "{q}");
                if let Some((c, i)) = g.cells.cell_of(q) {
                    let class = g.cells.state[c].load(std::sync::atomic::Ordering::Relaxed);
                    whole += (class == CELL_INSIDE || class == CELL_OUTSIDE) as u32;
                    naive_wrong += (g.parity_contains(g.cells.centre(i)) != exact) as u32;
                }
            }
            assert!(
                whole as usize > pts.len() / 2,
                "{whole} of {} from whole cells",
                pts.len()
            );
            assert!(
                naive_wrong > 50,
                "centre-only classes get {naive_wrong} points wrong"
            );
        }
    }

    #[test]
    fn contains_grid_agrees_with_brute_force_parity() {
        use crate::scene::meshgen::{lathe, LatheShading};
        let p = crate::scene::meshgen::GLASS_PROFILE;
        let m = std::sync::Arc::new(lathe(&p, 96, LatheShading::Smooth { crease_deg: 30.0 }));
        let g = ContainsGrid::new(m.clone());
        let mut rng = crate::sampling::Rng::new(5);
        let mut inside = 0;
        let mut pts: Vec<DVec3> = (0..20000)
            .map(|_| {
                DVec3::new(
                    rng.uniform_f64() * 2.4 - 1.2,
                    rng.uniform_f64() * 2.8 - 0.1,
                    rng.uniform_f64() * 2.4 - 1.2,
                )
            })
            .collect();
        // Points at and a hair off vertices and edge midpoints: the hard cases.
        for t in m.indices.iter().step_by(7) {
            let a = DVec3::from_array(m.positions[t[0] as usize].map(|c| c as f64));
            let b = DVec3::from_array(m.positions[t[1] as usize].map(|c| c as f64));
            for q in [a, (a + b) * 0.5] {
                pts.extend([q, q + DVec3::splat(1e-9), q - DVec3::splat(1e-7)]);
            }
        }
        let mut tested = 0;
        for &q in &pts {
            let (fast, slow) = (g.contains(q), m.contains(q));
            assert_eq!(fast, slow, "{q}");
            inside += fast as u32;
            tested += g.tested(q);
        }
        assert!(inside > 500, "the sample must include inside points: {inside}");
        // The binning follows each triangle's extent per row, not its bounds:
        // a query tests a few of the 1152 triangles.
        let mean = tested as f64 / pts.len() as f64;
        assert!(mean < 20.0, "mean triangles tested per query: {mean:.1}");
    }
}
