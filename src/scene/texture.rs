//! Textures (constant, world-space checker, image) and image loading for
//! textures and lat-long environment maps.
use glam::Vec3A as V3;
use std::path::Path;
use std::sync::Arc;

/// A linear-RGB float image, row 0 at the top.
#[derive(Debug)]
pub struct ImageData {
    /// Width in pixels (>= 1).
    pub width: usize,
    /// Height in pixels (>= 1).
    pub height: usize,
    /// `width × height` linear RGB values, row-major, row 0 at the top.
    pub pixels: Vec<V3>,
}

impl ImageData {
    /// Bilinear lookup with wrap-around in u and clamping in v; (u, v) in [0, 1]²,
    /// v = 0 at the top row.
    ///
    /// # Panics
    ///
    /// If the image is empty or `pixels` holds fewer than `width × height` values.
    pub fn lookup(&self, u: f32, v: f32) -> V3 {
        self.lookup_rows(u, v, Rows::Centres)
    }

    /// [`ImageData::lookup`] with the rows placed by `rows`: texel centres
    /// in u (wrapping around) and `rows` in v (clamped).
    ///
    /// # Panics
    ///
    /// If the image is empty or `pixels` holds fewer than `width × height` values.
    #[inline]
    pub fn lookup_rows(&self, u: f32, v: f32, rows: Rows) -> V3 {
        let x = (u - u.floor()) * self.width as f32 - 0.5;
        let y = match rows {
            Rows::Centres => v.clamp(0.0, 1.0) * self.height as f32 - 0.5,
            Rows::Poles => v.clamp(0.0, 1.0) * (self.height - 1) as f32,
        };
        let x0 = x.floor();
        let y0 = y.floor();
        let fx = x - x0;
        let fy = y - y0;
        let w = self.width as i64;
        let h = self.height as i64;
        let px = |xi: i64, yi: i64| {
            let xi = xi.rem_euclid(w) as usize;
            let yi = yi.clamp(0, h - 1) as usize;
            self.pixels[yi * self.width + xi]
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        px(x0, y0) * ((1.0 - fx) * (1.0 - fy))
            + px(x0 + 1, y0) * (fx * (1.0 - fy))
            + px(x0, y0 + 1) * ((1.0 - fx) * fy)
            + px(x0 + 1, y0 + 1) * (fx * fy)
    }
}

/// Where an image's rows sit in v (a lat-long map's polar angle over π).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rows {
    /// Row j's centre at v = (j + 0.5) / H: the texture convention, and
    /// snell's for environment maps.
    Centres,
    /// Row 0 at v = 0 and row H − 1 at v = 1 (on the poles of a lat-long
    /// map): Mitsuba 3's `envmap`.
    Poles,
}

/// Load an EXR (linear) or an 8-bit/HDR image (PNG/JPEG are sRGB-decoded).
///
/// EXR files give their first RGBA layer; the extension (case-insensitive)
/// chooses the decoder for `.exr` and the linear treatment of `.hdr`.
///
/// # Errors
///
/// A message (without the path) when the file cannot be read or decoded, or
/// when the image has no pixels.
pub fn load_image(path: &Path) -> Result<ImageData, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext == "exr" {
        use exr::prelude::*;
        let img = read_first_rgba_layer_from_file(
            path,
            |res, _| {
                let w = res.width();
                let h = res.height();
                (w, h, vec![V3::ZERO; w * h])
            },
            |(w, _h, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = V3::new(r, g, b);
            },
        )
        .map_err(|e| format!("cannot read EXR: {e}"))?;
        let (width, height, pixels) = img.layer_data.channel_data.pixels;
        if width == 0 || height == 0 {
            return Err("image is empty".into());
        }
        return Ok(ImageData {
            width,
            height,
            pixels,
        });
    }
    let img = image::open(path).map_err(|e| format!("cannot read image: {e}"))?;
    let linear = ext == "hdr";
    let rgb = img.to_rgb32f();
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    if w == 0 || h == 0 {
        return Err("image is empty".into());
    }
    let pixels = rgb
        .pixels()
        .map(|p| {
            let c = V3::new(p[0], p[1], p[2]);
            if linear {
                c
            } else {
                V3::new(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z))
            }
        })
        .collect();
    Ok(ImageData {
        width: w,
        height: h,
        pixels,
    })
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A reflectance or radiance texture.
#[derive(Debug, Clone)]
pub enum Texture {
    /// The same linear RGB value everywhere.
    Constant(V3),
    /// World-space checker over axes (a, b): `c0` where ⌊a/size⌋ + ⌊b/size⌋ is even.
    Checker {
        /// The world axes a and b: indices 0 = x, 1 = y, 2 = z, different.
        axes: [usize; 2],
        /// 1 / side of a square, per metre.
        inv_size: f32,
        /// Colour where the sum of the square indices is even.
        c0: V3,
        /// Colour where it is odd.
        c1: V3,
    },
    /// An image over the surface's (u, v), repeated `scale` times.
    Image {
        /// The linear-RGB image (shared between objects).
        image: Arc<ImageData>,
        /// Repeats along u and v over the shape's (u, v) in [0, 1]².
        scale: [f32; 2],
    },
}

impl Texture {
    #[inline]
    /// Does `eval` read its `uv` argument? (Only image textures do; the
    /// checker is in world space.)
    pub fn needs_uv(&self) -> bool {
        matches!(self, Texture::Image { .. })
    }

    /// The linear RGB value at world-space point `p` (read by the checker) with
    /// surface coordinates `uv` (read by image textures; v = 0 at the image's
    /// bottom row).
    #[inline]
    pub fn eval(&self, p: V3, uv: [f32; 2]) -> V3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checker {
                axes,
                inv_size,
                c0,
                c1,
            } => {
                // Checker in world coordinates, evaluated in f64 so squares stay
                // exact far from the origin.
                let p = p.to_array();
                let a = floor_i64(p[axes[0]] as f64 * *inv_size as f64);
                let b = floor_i64(p[axes[1]] as f64 * *inv_size as f64);
                // Parities separately: a and b saturate at ±i64::MAX far out.
                // (`x & 1` is `x.rem_euclid(2)` for every i64, so the sum of
                // the two is even iff their low bits agree.)
                if (a ^ b) & 1 == 0 {
                    *c0
                } else {
                    *c1
                }
            }
            Texture::Image { image, scale } => image.lookup(uv[0] * scale[0], 1.0 - uv[1] * scale[1]),
        }
    }

    /// Largest channel value anywhere (for validating reflectance ≤ 1).
    pub fn max_value(&self) -> f32 {
        match self {
            Texture::Constant(c) => c.max_element(),
            Texture::Checker { c0, c1, .. } => c0.max_element().max(c1.max_element()),
            Texture::Image { image, .. } => image.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max),
        }
    }
}

/// `x.floor() as i64`, without the call: on the baseline x86-64 target (no
/// SSE4.1 `roundsd`) `f64::floor` is a library call per texture lookup.
/// The truncation is exact for every f64
/// in i64's range and saturates outside it, as `as i64` does; NaN gives 0.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t.saturating_sub(((t as f64) > x) as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_i64_is_floor_then_cast() {
        let xs = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            1.5,
            -1.5,
            2.999999999,
            -2.000000001,
            1e15 + 0.5,
            -1e15 - 0.5,
            4.5e15,
            -4.5e15,
            1e19,
            -1e19,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        for x in xs {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x}");
        }
        // Power: truncation alone differs on negative non-integers.
        assert_ne!(-1.5f64 as i64, (-1.5f64).floor() as i64);
    }

    #[test]
    fn checker_follows_reference_definition() {
        let t = Texture::Checker {
            axes: [0, 2],
            inv_size: 2.0,
            c0: V3::ONE,
            c1: V3::ZERO,
        };
        assert_eq!(t.eval(V3::new(0.1, 0.0, 0.1), [0.0; 2]), V3::ONE);
        assert_eq!(t.eval(V3::new(0.6, 0.0, 0.1), [0.0; 2]), V3::ZERO);
        assert_eq!(
            t.eval(V3::new(-0.1, 0.0, 0.1), [0.0; 2]),
            V3::ZERO,
            "floor, not truncation"
        );
        assert_eq!(t.eval(V3::new(-0.1, 0.0, -0.1), [0.0; 2]), V3::ONE);
    }
}
