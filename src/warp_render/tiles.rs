//! The packet renderers' tiles of pixels and their primary rays.
use crate::scene::RenderScene;
use glam::DVec3;

/// The packets of both packet renderers: tiles of `TILE_W` × `TILE_H`
/// pixels, one `rtcIntersect16` per query (square tiles keep a packet's
/// rays coherent; cheaper than spans of eight along a row, and than 8 × 2).
pub(crate) const TILE_W: usize = 4;
pub(crate) const TILE_H: usize = 4;
/// Rays per packet.
pub(crate) const LANES: usize = TILE_W * TILE_H;

/// One tile of the packet renders, in a band of `rows` (≤ `TILE_H`) rows of
/// a film `w` pixels wide: lane `l` is pixel (x0 + l % TILE_W, band row
/// l / TILE_W), when that pixel is on the film.
pub(crate) struct Tile {
    x0: usize,
    y0: usize,
    nx: usize,
    rows: usize,
    w: usize,
}

impl Tile {
    /// The tile at column `x0` of band `band` (of `TILE_H` rows).
    pub(crate) fn new(x0: usize, band: usize, rows: usize, w: usize) -> Tile {
        Tile {
            x0,
            y0: band * TILE_H,
            nx: TILE_W.min(w - x0),
            rows,
            w,
        }
    }

    /// Lane `l`'s pixel: its index in the band's slice of the frame and its
    /// film coordinates; `None` past the film's right or bottom edge.
    pub(crate) fn lane(&self, l: usize) -> Option<(usize, u32, u32)> {
        let (dx, dy) = (l % TILE_W, l / TILE_W);
        (dx < self.nx && dy < self.rows).then(|| {
            (
                dy * self.w + self.x0 + dx,
                (self.x0 + dx) as u32,
                (self.y0 + dy) as u32,
            )
        })
    }
}

/// The tile's eye rays, as `pixel_ray` makes them (bit for bit: the same
/// f32 camera ray, then the same f64 normalisation, done here lane-wise over
/// arrays so that the compiler can pair the square roots and divisions);
/// lanes off the film get a zero ray, which `classify16` gives no copy.
#[inline]
pub(crate) fn tile_rays(scene: &RenderScene, tile: &Tile) -> [(DVec3, DVec3); LANES] {
    let mut org = [DVec3::ZERO; LANES];
    let (mut x, mut y, mut z) = ([0.0f64; LANES], [0.0f64; LANES], [0.0f64; LANES]);
    let mut live = [false; LANES];
    for l in 0..LANES {
        if let Some((_, px, py)) = tile.lane(l) {
            let (o, d) = scene.camera.ray(px as f32 + 0.5, py as f32 + 0.5, (0.0, 0.0));
            org[l] = DVec3::new(o.x as f64, o.y as f64, o.z as f64);
            (x[l], y[l], z[l]) = (d.x as f64, d.y as f64, d.z as f64);
            live[l] = true;
        } else {
            (x[l], y[l], z[l]) = (0.0, 0.0, 1.0);
        }
    }
    // `DVec3::normalize`: self · (1 / √(x² + y² + z²)), in that order.
    let mut r = [0.0f64; LANES];
    for l in 0..LANES {
        r[l] = 1.0 / (x[l] * x[l] + y[l] * y[l] + z[l] * z[l]).sqrt();
    }
    let mut out = [(DVec3::ZERO, DVec3::ZERO); LANES];
    for l in 0..LANES {
        if live[l] {
            out[l] = (org[l], DVec3::new(x[l] * r[l], y[l] * r[l], z[l] * r[l]));
        }
    }
    out
}
