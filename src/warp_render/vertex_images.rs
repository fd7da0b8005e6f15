//! Each vertex's images: where it must move in each warped copy.
use super::rays::d3;
use crate::warp::approx_tube::approx_tube_image;
use crate::warp::{CopyKey, CylinderWarper, Family, PlateStatus, WarpGlass, WarpMethod};
use glam::DVec3;

/// Most images one vertex can have in distinct copies (direct, through4 or
/// hollow2, tir2±, wall2±).
pub const MAX_IMAGES: usize = 7;

/// The images of one vertex: (copy, warped position), at most one per copy.
/// Inline (no allocation per vertex).
#[derive(Debug, Clone, Copy)]
pub struct VertexImages {
    len: u8,
    items: [(CopyKey, [f32; 3]); MAX_IMAGES],
}

impl Default for VertexImages {
    fn default() -> Self {
        VertexImages {
            len: 0,
            items: [(CopyKey::DIRECT, [0.0; 3]); MAX_IMAGES],
        }
    }
}

impl VertexImages {
    /// Add an image unless its copy already has one (the first wins).
    pub fn push(&mut self, key: CopyKey, p: DVec3) {
        if (self.len as usize) < MAX_IMAGES && self.get(key).is_none() {
            self.items[self.len as usize] = (key, [p.x as f32, p.y as f32, p.z as f32]);
            self.len += 1;
        }
    }
    /// The image of the vertex in copy `key`, if it has one.
    pub fn get(&self, key: CopyKey) -> Option<[f32; 3]> {
        self.items[..self.len as usize]
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, p)| *p)
    }
    /// Number of images.
    pub fn len(&self) -> usize {
        self.len as usize
    }
    /// Has the vertex no image at all?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// The images (copy, warped position), in the order they were added.
    pub fn items(&self) -> &[(CopyKey, [f32; 3])] {
        &self.items[..self.len as usize]
    }
}

/// Per-eye solver state: the fast cylinder tables when they apply.
pub struct VertexSolver {
    glass: WarpGlass,
    method: WarpMethod,
    eye: DVec3,
    fast: Option<CylinderWarper>,
}

impl VertexSolver {
    /// A solver for points whose straight elevation (β along the tube's axis)
    /// lies within those of `points`.
    pub fn new(glass: WarpGlass, method: WarpMethod, eye: DVec3, points: &[DVec3]) -> Self {
        let fast = match (&glass, method) {
            (WarpGlass::Cylinder(c), WarpMethod::Exact) if !points.is_empty() => {
                CylinderWarper::for_targets(*c, eye, points).ok()
            }
            _ => None,
        };
        VertexSolver {
            glass,
            method,
            eye,
            fast,
        }
    }

    /// The images of the point `p`.
    pub fn images(&self, p: DVec3) -> VertexImages {
        vertex_images(&self.glass, self.method, self.eye, p, self.fast.as_ref())
    }

    /// Every image of every point of `pts`, as `each(index in pts, copy,
    /// warped position)`, in the order `images` keeps them (the first per
    /// copy wins there; `each` may see a copy again). The fast cylinder
    /// solver takes the points in batches (as `images_chunk`).
    pub fn each_image<F: FnMut(usize, CopyKey, DVec3)>(&self, pts: &[DVec3], mut each: F) {
        let (WarpMethod::Exact, Some(f)) = (self.method, self.fast.as_ref()) else {
            for (i, p) in pts.iter().enumerate() {
                let vi = self.images(*p);
                for (k, q) in vi.items() {
                    each(i, *k, d3(*q));
                }
            }
            return;
        };
        f.images_batch(pts, false, |i, ims| {
            for im in ims.into_iter().flatten() {
                each(i, WarpGlass::key_for(im.family, im.impact), im.position);
            }
        });
    }

    /// The images of every point of `pts` into `out` (as `images`); the
    /// fast cylinder solver takes them in batches (its Newton polishes run
    /// four at a time).
    pub fn images_chunk(&self, pts: &[DVec3], out: &mut [VertexImages]) {
        let (WarpMethod::Exact, Some(f)) = (self.method, self.fast.as_ref()) else {
            for (o, p) in out.iter_mut().zip(pts) {
                *o = self.images(*p);
            }
            return;
        };
        f.images_batch(pts, false, |i, ims| {
            let mut vi = VertexImages::default();
            if let Ok(ims) = ims {
                for im in ims {
                    vi.push(WarpGlass::key_for(im.family, im.impact), im.position);
                }
            }
            out[i] = vi;
        });
    }
}

thread_local! {
    /// The fast cylinder solver's image buffer, reused across vertices.
    static IMAGES: std::cell::RefCell<Vec<crate::warp::CylImage>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Images of one point by `method` (first image per copy key).
pub fn vertex_images(
    glass: &WarpGlass,
    method: WarpMethod,
    eye: DVec3,
    p: DVec3,
    fast: Option<&CylinderWarper>,
) -> VertexImages {
    let mut out = VertexImages::default();
    match glass {
        WarpGlass::Plate(pl) => match pl.warped_position(eye, p) {
            Ok(pos) => out.push(
                CopyKey {
                    family: Family::Wall2,
                    side: 0,
                },
                pos,
            ),
            Err(PlateStatus::InFront) => out.push(CopyKey::DIRECT, p),
            Err(_) => {}
        },
        WarpGlass::Cylinder(c) => {
            if let (WarpMethod::Exact, Some(f)) = (method, fast) {
                // The fast solver writes into the thread's buffer: no
                // allocation per vertex.
                IMAGES.with_borrow_mut(|ims| {
                    if f.images_into(p, false, ims).is_ok() {
                        for im in ims.iter() {
                            out.push(WarpGlass::key_for(im.family, im.impact), im.position);
                        }
                    }
                });
                return out;
            }
            let ims = match method {
                WarpMethod::Exact => c.images(eye, p).unwrap_or_default(),
                WarpMethod::Paper => approx_tube_image(c, eye, p).ok().flatten().into_iter().collect(),
            };
            for im in ims {
                let key = WarpGlass::key_for(im.family, im.impact);
                out.push(key, im.position);
            }
        }
    }
    out
}
