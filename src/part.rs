//! Part files: EXRs of a region and a range of sample indices that carry what
//! an exact merge needs. Besides R, G, B (the pixel means) and `spp` (samples
//! each pixel holds) a part has twelve `uint` channels `sum.R0`..`sum.B3`: the
//! fixed-point sample sums of [`crate::render::Accum`] as four little-endian
//! 32-bit words each. The data window is the region, the display window the
//! film. Header attributes (strings): `snell_film` (`WxH`), `snell_spp` (the
//! film's spp), `snell_seed`, `snell_scene` (a hash of the scene text after
//! `--set`, of the nested strategy and of a non-default light sampling), `snell_region` (`x0,x1,y0,y1`),
//! `snell_samples` (`START:COUNT`), `snell_fixed_bits` and `snell_stats` (the
//! task's stats JSON).
use crate::error::{Error, Result};
use crate::render::{mean_of, Accum, Region, FIXED_BITS};
use glam::Vec3A as V3;
use std::path::{Path, PathBuf};

/// Identity of a part: which film, scene, seed, region and sample range.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PartMeta {
    /// Width of the whole film.
    pub film_width: u32,
    /// Height of the whole film.
    pub film_height: u32,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// The film's seed.
    pub seed: u64,
    /// [`scene_id`] of the scene the part was rendered from.
    pub scene_id: String,
    /// The pixels the part covers (its EXR's data window).
    pub region: Region,
    /// First sample index of the part's range.
    pub sample_start: u32,
    /// Sample indices in the range: `[sample_start, sample_start + sample_count)`.
    pub sample_count: u32,
}

/// A part read back from disk.
#[derive(Debug, Clone)]
pub struct Part {
    /// The file it was read from.
    pub path: PathBuf,
    /// Film, scene, region and sample range.
    pub meta: PartMeta,
    /// Per pixel of the region: pixel i holds samples `[sample_start, sample_start + counts[i])`.
    pub accum: Accum,
    /// The task's stats JSON (when it was recorded).
    pub stats: Option<serde_json::Value>,
}

/// A stable identity for a scene: FNV-1a (64 bit) of the scene text (after
/// `--set` overrides) and the render settings that change the image beside
/// it (`nested`: `render::id_tag`, the nested-dielectric strategy's name
/// unless lights are sampled otherwise than by default). Files the scene
/// refers to (meshes, textures) are not part of it.
pub fn scene_id(text: &str, nested: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes().chain([0u8]).chain(nested.bytes()) {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

const COLORS: [char; 3] = ['R', 'G', 'B'];

/// Encode a part EXR: `pixels` and `accum` cover `meta.region`.
///
/// `attrs` are extra header attributes; `stats` is recorded as `snell_stats`.
///
/// # Errors
///
/// [`Error::Invalid`] when `pixels` or `accum` do not hold one entry per pixel
/// of the region, or when the EXR encoder fails.
pub fn encode_part(
    meta: &PartMeta,
    pixels: &[V3],
    accum: &Accum,
    attrs: &[(&str, String)],
    stats: Option<&serde_json::Value>,
) -> Result<Vec<u8>> {
    use exr::prelude::{
        AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, IntegerBounds,
        LayerAttributes, SmallVec, Text, Vec2, WritableImage,
    };
    let n = meta.region.pixels();
    if pixels.len() != n || accum.sums.len() != n || accum.counts.len() != n {
        return Err(Error::Invalid(
            "part: pixel count does not match the region".into(),
        ));
    }
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in COLORS.iter().enumerate() {
        list.push(AnyChannel::new(
            name.to_string().as_str(),
            FlatSamples::F32(pixels.iter().map(|p| p[c]).collect()),
        ));
        for w in 0..4 {
            let words = accum
                .sums
                .iter()
                .map(|s| ((s[c] as u128) >> (32 * w)) as u32)
                .collect();
            list.push(AnyChannel::new(
                format!("sum.{name}{w}").as_str(),
                FlatSamples::U32(words),
            ));
        }
    }
    list.push(AnyChannel::new(
        "spp",
        FlatSamples::F32(accum.counts.iter().map(|&c| c as f32).collect()),
    ));
    let mut attributes = LayerAttributes::named("snell");
    attributes.layer_position = Vec2(meta.region.x0 as i32, meta.region.y0 as i32);
    let r = &meta.region;
    let mut text: Vec<(&str, String)> = vec![
        ("snell_film", format!("{}x{}", meta.film_width, meta.film_height)),
        ("snell_spp", meta.spp.to_string()),
        ("snell_seed", meta.seed.to_string()),
        ("snell_scene", meta.scene_id.clone()),
        ("snell_region", r.to_string()),
        (
            "snell_samples",
            format!("{}:{}", meta.sample_start, meta.sample_count),
        ),
        ("snell_fixed_bits", FIXED_BITS.to_string()),
    ];
    if let Some(s) = stats {
        text.push(("snell_stats", s.to_string()));
    }
    text.extend(attrs.iter().cloned());
    for (k, v) in text {
        attributes
            .other
            .insert(Text::from(k), AttributeValue::Text(Text::from(v.as_str())));
    }
    let layer = exr::prelude::Layer::new(
        (r.width() as usize, r.height() as usize),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list),
    );
    let mut image = Image::from_layer(layer);
    image.attributes.display_window =
        IntegerBounds::new((0, 0), (meta.film_width as usize, meta.film_height as usize));
    let mut out = std::io::Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut out)
        .map_err(|e| Error::Invalid(format!("EXR encoding failed: {e}")))?;
    Ok(out.into_inner())
}

/// Write a part EXR atomically.
///
/// # Errors
///
/// The errors of [`encode_part`], and [`Error::Io`] when the file cannot be
/// written.
pub fn write_part(
    path: &Path,
    meta: &PartMeta,
    pixels: &[V3],
    accum: &Accum,
    attrs: &[(&str, String)],
    stats: Option<&serde_json::Value>,
) -> Result<()> {
    let bytes = encode_part(meta, pixels, accum, attrs, stats)?;
    crate::image_io::write_atomic(path, &bytes)
}

fn parse_pair<T: std::str::FromStr>(s: &str, sep: char) -> Option<(T, T)> {
    let (a, b) = s.split_once(sep)?;
    Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
}

/// Read a part EXR (refusing, with the reason, files that are not parts).
///
/// # Errors
///
/// [`Error::Io`] naming `path` when the file is not a readable EXR, or its part
/// attributes or channels are missing, malformed or inconsistent (a region
/// outside the film, a data window other than the region, …).
pub fn read_part(path: &Path) -> Result<Part> {
    use exr::prelude::{read, AttributeValue, FlatSamples, ReadChannels, ReadLayers};
    let bad = |m: String| Error::io(path, m);
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| bad(format!("cannot read EXR: {e}")))?;
    let layer = &img.layer_data;
    let attr = |k: &str| -> Option<String> {
        layer
            .attributes
            .other
            .get(&exr::prelude::Text::from(k))
            .or_else(|| img.attributes.other.get(&exr::prelude::Text::from(k)))
            .and_then(|v| match v {
                AttributeValue::Text(t) => Some(t.to_string()),
                _ => None,
            })
    };
    let need = |k: &str| {
        attr(k).ok_or_else(|| {
            bad(format!(
                "not a snell part (no {k} attribute): render parts as .exr with --region, --samples or --part"
            ))
        })
    };
    let (fw, fh) =
        parse_pair::<u32>(&need("snell_film")?, 'x').ok_or_else(|| bad("bad snell_film".into()))?;
    if fw as u64 * fh as u64 > crate::scene::builder::MAX_PIXELS {
        return Err(bad(format!("film {fw}x{fh} is larger than snell renders")));
    }
    let spp: u32 = need("snell_spp")?
        .parse()
        .map_err(|_| bad("bad snell_spp".into()))?;
    let seed: u64 = need("snell_seed")?
        .parse()
        .map_err(|_| bad("bad snell_seed".into()))?;
    let scene_id = need("snell_scene")?;
    let rv: Vec<u32> = need("snell_region")?
        .split(',')
        .map(|v| v.trim().parse())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| bad("bad snell_region".into()))?;
    let (start, count) =
        parse_pair::<u32>(&need("snell_samples")?, ':').ok_or_else(|| bad("bad snell_samples".into()))?;
    let bits: i32 = need("snell_fixed_bits")?.parse().unwrap_or(-1);
    if bits != FIXED_BITS {
        return Err(bad(format!(
            "fixed-point sums with {bits} fraction bits; this snell uses {FIXED_BITS}"
        )));
    }
    if rv.len() != 4 {
        return Err(bad("bad snell_region".into()));
    }
    let region = Region {
        x0: rv[0],
        x1: rv[1],
        y0: rv[2],
        y1: rv[3],
    };
    if region.x0 >= region.x1 || region.y0 >= region.y1 || region.x1 > fw || region.y1 > fh {
        return Err(bad(format!("region {region} is outside the {fw}x{fh} film")));
    }
    if count == 0 || start as u64 + count as u64 > spp as u64 {
        return Err(bad(format!(
            "samples {start}:{count} are outside the film's {spp} spp"
        )));
    }
    let size = layer.size;
    let pos = layer.attributes.layer_position;
    if (size.0, size.1) != (region.width() as usize, region.height() as usize)
        || (pos.0, pos.1) != (region.x0 as i32, region.y0 as i32)
    {
        return Err(bad(format!("the data window does not match the region {region}")));
    }
    let n = region.pixels();
    let chan = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
    };
    let mut sums = vec![[0i128; 3]; n];
    for (c, cname) in COLORS.iter().enumerate() {
        for w in 0..4 {
            let name = format!("sum.{cname}{w}");
            match chan(&name).map(|c| &c.sample_data) {
                Some(FlatSamples::U32(v)) if v.len() == n => {
                    for (s, &word) in sums.iter_mut().zip(v) {
                        s[c] = ((s[c] as u128) | ((word as u128) << (32 * w))) as i128;
                    }
                }
                _ => return Err(bad(format!("missing or malformed channel {name}"))),
            }
        }
    }
    let counts: Vec<u32> = match chan("spp").map(|c| &c.sample_data) {
        Some(FlatSamples::F32(v)) if v.len() == n => v.iter().map(|&c| c as u32).collect(),
        _ => return Err(bad("missing or malformed channel spp".into())),
    };
    if let Some(c) = counts.iter().find(|&&c| c > count) {
        return Err(bad(format!(
            "a pixel holds {c} samples, more than the part's {count}"
        )));
    }
    let stats = attr("snell_stats").and_then(|s| serde_json::from_str(&s).ok());
    Ok(Part {
        path: path.to_path_buf(),
        meta: PartMeta {
            film_width: fw,
            film_height: fh,
            spp,
            seed,
            scene_id,
            region,
            sample_start: start,
            sample_count: count,
        },
        accum: Accum { sums, counts },
        stats,
    })
}

/// The pixel means of a part.
pub fn part_pixels(accum: &Accum) -> Vec<V3> {
    accum
        .sums
        .iter()
        .zip(&accum.counts)
        .map(|(s, &n)| mean_of(*s, n))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_round_trip_keeps_sums_exactly() {
        let meta = PartMeta {
            film_width: 5,
            film_height: 4,
            spp: 9,
            seed: 3,
            scene_id: scene_id("x", "filter"),
            region: Region {
                x0: 1,
                x1: 4,
                y0: 2,
                y1: 4,
            },
            sample_start: 2,
            sample_count: 5,
        };
        let sums: Vec<[i128; 3]> = (0..6i128)
            .map(|i| [i << 90, -(i * 12345) - 1, (1i128 << 100) + i])
            .collect();
        let accum = Accum {
            sums,
            counts: vec![5, 5, 0, 5, 3, 5],
        };
        let dir = std::env::temp_dir().join(format!("snell-part-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("p.exr");
        let stats = serde_json::json!({"rays": 7});
        write_part(&p, &meta, &part_pixels(&accum), &accum, &[], Some(&stats)).unwrap();
        let back = read_part(&p).unwrap();
        assert_eq!(back.meta, meta);
        assert_eq!(back.accum, accum);
        assert_eq!(back.stats, Some(stats));
        let (w, h, _) = crate::image_io::read_exr_rgb(&p).unwrap();
        assert_eq!((w, h), (3, 2));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
