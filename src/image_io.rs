//! Image output by extension: `.png` is sRGB 8-bit (clamped, no tone mapping),
//! `.exr` is linear float32. Every file is written to a unique temporary file
//! in the target directory and renamed, so a reader never sees a partial file
//! and two renders never collide on temporary names.
use crate::error::{Error, Result};
use glam::Vec3A as V3;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// sRGB transfer function on a linear value clamped to [0, 1].
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = if c.is_finite() { c.clamp(0.0, 1.0) } else { 0.0 };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

static TMP_COUNTER: AtomicU64 = AtomicU64::new(0);

fn temp_path(path: &Path) -> PathBuf {
    let n = TMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    let name = path
        .file_name()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.{n}.{nanos}.tmp", std::process::id()))
}

/// Write `bytes` to `path` atomically (temporary file in the same directory, then rename).
///
/// # Errors
///
/// [`Error::Io`] when the directory does not exist or the file cannot be
/// written or renamed; the temporary file is removed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if !dir.is_dir() {
        return Err(Error::io(
            path,
            format!("directory {} does not exist", dir.display()),
        ));
    }
    let tmp = temp_path(path);
    let res = (|| -> std::io::Result<()> {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = res {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, format!("cannot write: {e}")));
    }
    Ok(())
}

/// Extra float layers for EXR output (name, values per pixel).
pub type Layer<'a> = (&'a str, &'a [f32]);

/// Encode and write an image; the format follows the extension.
///
/// `pixels` are linear RGB, row-major, row 0 at the top. `layers` (extra
/// channels) and `attrs` (header attributes, name and text) are written to
/// `.exr` only and ignored for `.png`.
///
/// # Errors
///
/// [`Error::Io`] for an extension other than `.png`/`.exr` or a failed
/// write; [`Error::Invalid`] when encoding fails (e.g. `pixels` is not
/// `width × height` long for a PNG).
///
/// # Panics
///
/// Writing an `.exr` panics when `pixels` or a layer holds fewer than
/// `width × height` values.
pub fn save(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[V3],
    layers: &[Layer<'_>],
    attrs: &[(&str, String)],
) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    let bytes = match ext.as_str() {
        "png" => encode_png(width, height, pixels)?,
        "exr" => encode_exr(width, height, pixels, layers, attrs)?,
        other => {
            return Err(Error::io(
                path,
                format!(
                "unknown output extension \".{other}\": expected .png (sRGB 8-bit) or .exr (linear float)"
            ),
            ))
        }
    };
    write_atomic(path, &bytes)
}

/// Encode linear RGB `pixels` (row-major, row 0 at the top) as an 8-bit sRGB
/// PNG: each channel clamped to [0, 1], no tone mapping.
///
/// # Errors
///
/// [`Error::Invalid`] when `pixels` is not `width × height` long or the
/// encoder fails.
pub fn encode_png(width: u32, height: u32, pixels: &[V3]) -> Result<Vec<u8>> {
    let mut buf = Vec::with_capacity(pixels.len() * 3);
    for p in pixels {
        for c in [p.x, p.y, p.z] {
            buf.push((linear_to_srgb(c) * 255.0 + 0.5) as u8);
        }
    }
    let img = image::RgbImage::from_raw(width, height, buf)
        .ok_or_else(|| Error::Invalid("image size mismatch".into()))?;
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)
        .map_err(|e| Error::Invalid(format!("PNG encoding failed: {e}")))?;
    Ok(out.into_inner())
}

/// Encode linear RGB `pixels` (row-major, row 0 at the top) as a float32 EXR
/// with channels R, G, B, one more channel per layer (named by the layer), and
/// `attrs` as text attributes of the header. Lossless compression.
///
/// # Errors
///
/// [`Error::Invalid`] when the encoder fails.
///
/// # Panics
///
/// When `pixels` or a layer holds fewer than `width × height` values.
pub fn encode_exr(
    width: u32,
    height: u32,
    pixels: &[V3],
    layers: &[Layer<'_>],
    attrs: &[(&str, String)],
) -> Result<Vec<u8>> {
    use exr::prelude::{
        AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, LayerAttributes, SmallVec,
        Text, WritableImage,
    };
    let (w, h) = (width as usize, height as usize);
    let chan = |name: &str, f: &dyn Fn(usize) -> f32| {
        AnyChannel::new(name, FlatSamples::F32((0..w * h).map(f).collect()))
    };
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    list.push(chan("R", &|i| pixels[i].x));
    list.push(chan("G", &|i| pixels[i].y));
    list.push(chan("B", &|i| pixels[i].z));
    for (name, vals) in layers {
        list.push(chan(name, &|i| vals[i]));
    }
    let mut attributes = LayerAttributes::named("snell");
    for (k, v) in attrs {
        attributes
            .other
            .insert(Text::from(*k), AttributeValue::Text(Text::from(v.as_str())));
    }
    let layer = exr::prelude::Layer::new(
        (w, h),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = Image::from_layer(layer);
    let mut out = std::io::Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut out)
        .map_err(|e| Error::Invalid(format!("EXR encoding failed: {e}")))?;
    Ok(out.into_inner())
}

/// Read the RGB channels of an EXR written by `save` (tests, comparisons):
/// `(width, height, pixels)`, row 0 at the top.
///
/// # Errors
///
/// [`Error::Io`] when the file cannot be read or decoded.
pub fn read_exr_rgb(path: &Path) -> Result<(u32, u32, Vec<V3>)> {
    let img = crate::scene::texture::load_image(path).map_err(|e| Error::io(path, e))?;
    Ok((img.width as u32, img.height as u32, img.pixels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_endpoints_and_clamping() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        assert_eq!(linear_to_srgb(7.0), linear_to_srgb(1.0));
        assert_eq!(linear_to_srgb(f32::NAN), 0.0);
        assert!((linear_to_srgb(0.2140) - 0.5).abs() < 1e-3);
    }

    #[test]
    fn atomic_write_to_missing_directory_fails_cleanly() {
        let e = write_atomic(Path::new("/nonexistent-dir-snell/x.png"), b"abc").unwrap_err();
        assert!(e.to_string().contains("does not exist"), "{e}");
    }

    #[test]
    fn exr_round_trip() {
        let dir = std::env::temp_dir().join(format!("snell-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.exr");
        let px: Vec<V3> = (0..6).map(|i| V3::new(i as f32, 0.5, 2.0)).collect();
        save(
            &p,
            3,
            2,
            &px,
            &[("false_hits", &[1.0; 6])],
            &[("spp", "4".into())],
        )
        .unwrap();
        let (w, h, back) = read_exr_rgb(&p).unwrap();
        assert_eq!((w, h), (3, 2));
        assert_eq!(back, px);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
