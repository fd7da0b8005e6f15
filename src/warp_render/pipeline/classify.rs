//! Which copies a primary ray must look at, per frame's eye: the paper's
//! depth peeling in closed form.
use super::Pipeline;
use crate::warp::{CopyKey, Family, WarpGlass};
use crate::warp_render::tiles::LANES;
use glam::DVec3;

/// `WarpGlass::classify_keys` for one frame's eye, answering copy bit masks
/// (bit k: copy k) instead of keys. What depends on the eye alone is
/// computed once per frame, and the family tests compare squares
/// (|b| < r ⇔ (e × h)² < r²·|h|², and the TIR test |b|·m_a < r·m_g
/// likewise), so a tube ray costs one square root (its entry into the
/// tube, as `classify_keys` computes it) instead of five, and no key
/// look-ups. Same classes up to rounding at the family edges (tested
/// through the same pixels as `render_warped`).
// One value per frame, on the stack: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
pub(super) enum Classifier {
    /// The plate's one copy (direct and warped, see `groups`): every ray
    /// looks at it.
    Plate { bit: u8 },
    Tube {
        c: crate::warp::HollowCylinder,
        /// The frame's axes across (u, w) and along (a) the tube.
        u: DVec3,
        w: DVec3,
        a: DVec3,
        /// The eye across the axis: 2-D and as a 3-D offset (for `cyl_roots`).
        e: glam::DVec2,
        qp: DVec3,
        /// hollow2 + through4, tir2 −/+, wall2 −/+.
        bits: [u8; 5],
    },
}

impl Classifier {
    pub(super) fn new(pipe: &Pipeline, eye: DVec3) -> Classifier {
        let bit = |k: CopyKey| pipe.key_index(k).map_or(0u8, |i| 1 << i);
        let key = |family, side| CopyKey { family, side };
        match pipe.glass {
            WarpGlass::Plate(_) => Classifier::Plate {
                bit: bit(CopyKey::DIRECT),
            },
            WarpGlass::Cylinder(c) => {
                let (u, w, a) = c.frame_axes();
                let q = eye - c.axis_point;
                Classifier::Tube {
                    c,
                    u,
                    w,
                    a,
                    e: c.to2(eye).0,
                    qp: q - a * q.dot(a),
                    bits: [
                        bit(key(Family::Hollow2, 0)) | bit(key(Family::Through4, 0)),
                        bit(key(Family::Tir2, -1)),
                        bit(key(Family::Tir2, 1)),
                        bit(key(Family::Wall2, -1)),
                        bit(key(Family::Wall2, 1)),
                    ],
                }
            }
        }
    }

    /// `classify` for a tile's rays (a zero direction: no copy), written
    /// over arrays without branches so that the compiler can pair the
    /// lanes' square roots and divisions (per lane, `classify` is a
    /// latency-bound chain of three square roots and four divisions per
    /// ray with the normalisation).
    /// The same arithmetic as `classify`, so the same classes (tested).
    #[inline]
    pub(super) fn classify16(&self, rays: &[(DVec3, DVec3); LANES]) -> [(f64, u8); LANES] {
        let mut out = [(f64::INFINITY, 0u8); LANES];
        match self {
            Classifier::Plate { bit } => {
                for (o, (_, d)) in out.iter_mut().zip(rays) {
                    if *d != DVec3::ZERO {
                        o.1 = *bit;
                    }
                }
            }
            Classifier::Tube {
                c,
                u,
                w,
                a,
                e,
                qp,
                bits,
            } => {
                let (mut t, mut beta, mut cross, mut hh) =
                    ([0.0f64; LANES], [0.0f64; LANES], [0.0f64; LANES], [0.0f64; LANES]);
                let cc = qp.length_squared() - c.outer_radius * c.outer_radius;
                for l in 0..LANES {
                    let d = rays[l].1;
                    let b = d.dot(*a);
                    // `cyl_roots(qp, d − a·β, R)`'s nearer root, if ahead.
                    let dp = d - *a * b;
                    let aa = dp.length_squared();
                    let bb = qp.dot(dp);
                    let disc = bb * bb - aa * cc;
                    let s = disc.max(0.0).sqrt();
                    let k = if bb > 0.0 { -(bb + s) } else { -bb + s };
                    let t0 = (k / aa).min(cc / k);
                    let ok = aa >= 1e-300 && disc >= 0.0 && k != 0.0 && t0 > 0.0;
                    t[l] = if ok { t0 } else { f64::INFINITY };
                    beta[l] = b;
                    let h = glam::DVec2::new(d.dot(*u), d.dot(*w));
                    hh[l] = h.length_squared();
                    cross[l] = e.perp_dot(h);
                }
                let r2 = c.inner_radius * c.inner_radius;
                for l in 0..LANES {
                    if t[l] == f64::INFINITY {
                        continue;
                    }
                    let (b2h, be) = (cross[l] * cross[l], beta[l]);
                    let side = if cross[l] < 0.0 { 0 } else { 1 };
                    let m = if b2h < r2 * hh[l] {
                        bits[0]
                    } else if b2h * (1.0 - be * be).max(0.0) < r2 * hh[l] * (c.ior * c.ior - be * be).max(0.0)
                    {
                        bits[1 + side]
                    } else {
                        bits[3 + side]
                    };
                    out[l] = (t[l], m);
                }
            }
        }
        out
    }

    /// (distance to the glass, copies to look at beyond it) for unit `d`.
    #[cfg(test)]
    fn classify(&self, d: DVec3) -> (f64, u8) {
        match self {
            Classifier::Plate { bit } => (f64::INFINITY, *bit),
            Classifier::Tube {
                c,
                u,
                w,
                a,
                e,
                qp,
                bits,
            } => {
                let beta = d.dot(*a);
                let t_enter = match crate::warp::glass::cyl_roots(*qp, d - *a * beta, c.outer_radius) {
                    Some((t0, _)) if t0 > 0.0 => t0,
                    _ => return (f64::INFINITY, 0),
                };
                let h = glam::DVec2::new(d.dot(*u), d.dot(*w));
                let hh = h.length_squared();
                // b·|h| = e × h.
                let cross = e.perp_dot(h);
                let r2 = c.inner_radius * c.inner_radius;
                let b2h = cross * cross;
                let side = if cross < 0.0 { 0 } else { 1 };
                let m = if b2h < r2 * hh {
                    bits[0]
                } else if b2h * (1.0 - beta * beta).max(0.0)
                    < r2 * hh * (c.ior * c.ior - beta * beta).max(0.0)
                {
                    bits[1 + side]
                } else {
                    bits[3 + side]
                };
                (t_enter, m)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::looking_at_origin;
    use super::*;
    use crate::warp_render::prepare::prepare;
    use crate::warp_render::rays::{d3, pixel_ray};
    use crate::warp_render::tiles::{tile_rays, Tile, TILE_H, TILE_W};
    use glam::Vec3A as V3;

    /// `tile_rays` + `classify16` give every pixel of a frame (the film's
    /// ragged right and bottom edges included) `pixel_ray`'s ray and
    /// `classify`'s class, bit for bit, on both scenes, from two eyes.
    #[test]
    fn tile_rays_and_classes_are_the_per_pixel_ones() {
        for scene in ["scenes/warp_cylinder.toml", "scenes/warp_plate.toml"] {
            let mut s = crate::scene::load_scene(
                std::path::Path::new(scene),
                &crate::scene::BuildOptions::default(),
            )
            .unwrap();
            let (w, h) = (163u32, 122u32);
            s.set_resolution(w, h).unwrap();
            let spec = s.warp.clone().unwrap();
            let prep = prepare(&s, &spec, 1e9).unwrap();
            let pipe = Pipeline::new(&s, &spec, &prep, false).unwrap();
            let pos = s.camera.position;
            let mut classes = [0usize; 8];
            for dx in [0.0f32, 0.31] {
                s.camera = looking_at_origin(pos + V3::new(dx, 0.2, 0.0), w, h);
                let eye = d3(s.camera.position.to_array());
                let cl = Classifier::new(&pipe, eye);
                for band in 0..(h as usize).div_ceil(TILE_H) {
                    let rows = TILE_H.min(h as usize - band * TILE_H);
                    for x0 in (0..w as usize).step_by(TILE_W) {
                        let tile = Tile::new(x0, band, rows, w as usize);
                        let rays = tile_rays(&s, &tile);
                        let class = cl.classify16(&rays);
                        for l in 0..LANES {
                            match tile.lane(l) {
                                Some((_, x, y)) => {
                                    let r = pixel_ray(&s, x, y);
                                    assert_eq!(rays[l], r, "{scene} ({x}, {y})");
                                    let c = cl.classify(r.1);
                                    assert!(
                                        c.1 == class[l].1 && c.0.to_bits() == class[l].0.to_bits(),
                                        "{scene} ({x}, {y}): {c:?} {:?}",
                                        class[l]
                                    );
                                    classes[c.1.trailing_zeros().min(7) as usize] += 1;
                                }
                                None => assert_eq!(class[l].1, 0),
                            }
                        }
                    }
                }
            }
            // The tube's eyes see every class: direct only, hollow2 +
            // through4, tir2 on both sides.
            if scene.ends_with("cylinder.toml") {
                assert!(classes.iter().filter(|&&n| n > 100).count() >= 4, "{classes:?}");
            }
        }
    }
}
