//! `snell merge`: assemble regions and sum sample ranges of part files into
//! the whole render. Sums are the exact fixed-point ones of
//! [`crate::render::Accum`], so the merged image equals the single render bit
//! for bit. Parts of different films, scenes or seeds, overlapping samples and
//! missing pixels or samples are refused with the files and pixels involved.
use crate::error::{Error, Result};
use crate::part::{Part, PartMeta};
use crate::render::{mean_of, Accum, Region};
use glam::Vec3A as V3;
use std::path::{Path, PathBuf};

/// The merged render.
#[derive(Debug, Clone)]
pub struct Merged {
    /// The whole film, all samples.
    pub meta: PartMeta,
    /// Pixel means, row 0 at the top.
    pub pixels: Vec<V3>,
    /// The exact sums (every pixel holds all samples).
    pub accum: Accum,
    /// The parts' stats summed (see [`sum_stats`]).
    pub stats: serde_json::Value,
}

/// Expand the command line's inputs: a directory stands for its `.exr` files
/// (sorted by name; hidden temporaries and `NAME.partial.exr` files, which an
/// interrupted task leaves and a retried one resumes, are left out).
///
/// # Errors
///
/// [`Error::Io`] when a directory cannot be read or holds no parts;
/// [`Error::Invalid`] when `args` names no file at all.
pub fn collect_inputs(args: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for a in args {
        if a.is_dir() {
            let mut v: Vec<PathBuf> = std::fs::read_dir(a)
                .map_err(|e| Error::io(a, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    let name = p
                        .file_name()
                        .map(|n| n.to_string_lossy().to_string())
                        .unwrap_or_default();
                    name.ends_with(".exr") && !name.starts_with('.') && !name.ends_with(".partial.exr")
                })
                .collect();
            v.sort();
            if v.is_empty() {
                return Err(Error::io(a, "no .exr parts in this directory"));
            }
            out.extend(v);
        } else {
            out.push(a.clone());
        }
    }
    if out.is_empty() {
        return Err(Error::Invalid("merge: no parts given".into()));
    }
    Ok(out)
}

fn name(p: &Path) -> String {
    p.display().to_string()
}

/// Check that two parts belong to the same render.
fn same_render(a: &Part, b: &Part) -> Result<()> {
    let (ma, mb) = (&a.meta, &b.meta);
    let diff = |what: &str, x: String, y: String| {
        Err(Error::Invalid(format!(
            "merge: {} and {} are parts of different {what}: {x} vs {y}",
            name(&a.path),
            name(&b.path)
        )))
    };
    if (ma.film_width, ma.film_height) != (mb.film_width, mb.film_height) {
        return diff(
            "films",
            format!("{}x{}", ma.film_width, ma.film_height),
            format!("{}x{}", mb.film_width, mb.film_height),
        );
    }
    if ma.spp != mb.spp {
        return diff("films", format!("{} spp", ma.spp), format!("{} spp", mb.spp));
    }
    if ma.scene_id != mb.scene_id {
        return diff(
            "scenes (the scene text, its --set overrides or --nested differ)",
            ma.scene_id.clone(),
            mb.scene_id.clone(),
        );
    }
    if ma.seed != mb.seed {
        return diff("seeds", ma.seed.to_string(), mb.seed.to_string());
    }
    Ok(())
}

/// Index of pixel (x, y) in a part's arrays.
fn at(p: &Part, x: u32, y: u32) -> usize {
    let r = &p.meta.region;
    ((y - r.y0) * r.width() + x - r.x0) as usize
}

/// Samples a part holds at a pixel: `[lo, hi)`.
fn held(p: &Part, x: u32, y: u32) -> (u32, u32) {
    let c = p.accum.counts[at(p, x, y)];
    (p.meta.sample_start, p.meta.sample_start + c)
}

fn overlaps(a: &Part, b: &Part) -> Result<()> {
    let Some(r) = a.meta.region.intersect(&b.meta.region) else {
        return Ok(());
    };
    let (sa, sb) = (&a.meta, &b.meta);
    if sa.sample_start + sa.sample_count <= sb.sample_start
        || sb.sample_start + sb.sample_count <= sa.sample_start
    {
        return Ok(());
    }
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            let (a0, a1) = held(a, x, y);
            let (b0, b1) = held(b, x, y);
            let (lo, hi) = (a0.max(b0), a1.min(b1));
            if lo < hi {
                return Err(Error::Invalid(format!(
                    "merge: {} (region {}, samples {}:{}) and {} (region {}, samples {}:{}) overlap: both hold samples {lo}..{hi} of pixel ({x}, {y}) in region {r}",
                    name(&a.path),
                    sa.region,
                    sa.sample_start,
                    sa.sample_count,
                    name(&b.path),
                    sb.region,
                    sb.sample_start,
                    sb.sample_count
                )));
            }
        }
    }
    Ok(())
}

/// Describe the pixels that lack samples.
fn gaps(parts: &[Part], meta: &PartMeta, counts: &[u64]) -> Option<String> {
    let w = meta.film_width;
    let spp = meta.spp as u64;
    let mut missing = 0u64;
    let mut empty = 0u64;
    let mut bbox: Option<Region> = None;
    let mut first = None;
    for (i, &c) in counts.iter().enumerate() {
        if c == spp {
            continue;
        }
        missing += 1;
        empty += (c == 0) as u64;
        let (x, y) = (i as u32 % w, i as u32 / w);
        first.get_or_insert((x, y));
        let b = bbox.get_or_insert(Region {
            x0: x,
            x1: x + 1,
            y0: y,
            y1: y + 1,
        });
        b.x0 = b.x0.min(x);
        b.x1 = b.x1.max(x + 1);
        b.y0 = b.y0.min(y);
        b.y1 = b.y1.max(y + 1);
    }
    let (x, y) = first?;
    let b = bbox?;
    let mut have: Vec<(u32, u32)> = parts
        .iter()
        .filter(|p| {
            let r = &p.meta.region;
            (r.x0..r.x1).contains(&x) && (r.y0..r.y1).contains(&y)
        })
        .map(|p| held(p, x, y))
        .filter(|(a, b)| a < b)
        .collect();
    have.sort();
    let mut lacks = Vec::new();
    let mut next = 0;
    for (a, b) in have {
        if a > next {
            lacks.push(format!("{next}..{a}"));
        }
        next = next.max(b);
    }
    if next < meta.spp {
        lacks.push(format!("{next}..{}", meta.spp));
    }
    Some(format!(
        "merge: the parts do not cover the render: {missing} of {} pixels lack samples ({empty} have none), within x {}..{}, y {}..{} (region {b}); pixel ({x}, {y}) lacks samples {} of 0..{}",
        counts.len(),
        b.x0,
        b.x1,
        b.y0,
        b.y1,
        lacks.join(", "),
        meta.spp
    ))
}

/// Merge parts into the whole render.
///
/// # Errors
///
/// [`Error::Invalid`], naming the files and pixels involved, when `parts` is
/// empty, parts come from different films, scenes or seeds, two parts hold the
/// same samples of a pixel, or some pixel lacks some samples.
pub fn merge(parts: &[Part]) -> Result<Merged> {
    let Some(first) = parts.first() else {
        return Err(Error::Invalid("merge: no parts given".into()));
    };
    for p in &parts[1..] {
        same_render(first, p)?;
    }
    for (i, a) in parts.iter().enumerate() {
        for b in &parts[i + 1..] {
            overlaps(a, b)?;
        }
    }
    let m = &first.meta;
    let (w, h) = (m.film_width, m.film_height);
    let n = w as usize * h as usize;
    let mut sums = vec![[0i128; 3]; n];
    let mut counts = vec![0u64; n];
    for p in parts {
        let r = &p.meta.region;
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let (src, dst) = (at(p, x, y), (y * w + x) as usize);
                for (d, s) in sums[dst].iter_mut().zip(&p.accum.sums[src]) {
                    *d = d.wrapping_add(*s);
                }
                counts[dst] += p.accum.counts[src] as u64;
            }
        }
    }
    let meta = PartMeta {
        region: Region::full(w, h),
        sample_start: 0,
        sample_count: m.spp,
        ..m.clone()
    };
    if let Some(msg) = gaps(parts, &meta, &counts) {
        return Err(Error::Invalid(msg));
    }
    let pixels = sums.iter().map(|s| mean_of(*s, m.spp)).collect();
    let stats = sum_stats(parts.iter().map(|p| p.stats.as_ref()), parts.len());
    Ok(Merged {
        meta,
        pixels,
        accum: Accum {
            sums,
            counts: vec![m.spp; n],
        },
        stats,
    })
}

/// Sum the parts' stats: counters and times add up (`wall_s` becomes the
/// total task time, `max_task_wall_s` the longest task), `max_list_depth` is
/// the maximum, rates are recomputed over the total task time.
pub fn sum_stats<'a>(
    stats: impl Iterator<Item = Option<&'a serde_json::Value>>,
    parts: usize,
) -> serde_json::Value {
    const SUMMED: [&str; 33] = [
        "wall_s",
        "cpu_s",
        "tiles_cpu_s",
        "samples",
        "rays",
        "queries",
        "shadow_rays",
        "false_hits",
        "filter_calls",
        "fallbacks",
        "list_spills",
        "settled",
        "tir",
        "nan_or_inf_samples",
        "segments",
        "chords",
        "grin_failures",
        "medium_segments",
        "field_evals",
        "packet_slots",
        "packet_lanes",
        "shadow_packet_slots",
        "shadow_packet_lanes",
        "shade_slots",
        "shade_lanes",
        "set_lanes",
        "set_replayed_lanes",
        "nee_draws",
        "ended_escaped",
        "ended_max_depth",
        "ended_roulette",
        "ended_absorbed",
        "load_s",
    ];
    let mut ints = std::collections::BTreeMap::<&str, u64>::new();
    let mut floats = std::collections::BTreeMap::<&str, f64>::new();
    let mut with_stats = 0;
    let mut max_wall = 0.0f64;
    let mut max_depth = 0u64;
    for s in stats.flatten() {
        with_stats += 1;
        for k in SUMMED {
            match s.get(k) {
                Some(v) if v.is_u64() => *ints.entry(k).or_default() += v.as_u64().unwrap_or(0),
                Some(v) => *floats.entry(k).or_default() += v.as_f64().unwrap_or(0.0),
                None => {}
            }
        }
        max_wall = max_wall.max(s.get("wall_s").and_then(|v| v.as_f64()).unwrap_or(0.0));
        max_depth = max_depth.max(s.get("max_list_depth").and_then(|v| v.as_u64()).unwrap_or(0));
    }
    let mut out = serde_json::Map::new();
    for (k, v) in &ints {
        out.insert(k.to_string(), serde_json::json!(v));
    }
    for (k, v) in &floats {
        out.insert(k.to_string(), serde_json::json!(v));
    }
    let get = |k: &str| out.get(k).and_then(|v| v.as_f64()).unwrap_or(0.0);
    let (wall, samples, rays, queries) = (get("wall_s"), get("samples"), get("rays"), get("queries"));
    let derived = serde_json::json!({
        "parts": parts,
        "parts_with_stats": with_stats,
        "max_task_wall_s": max_wall,
        "max_list_depth": max_depth,
        "samples_per_s": samples / wall.max(1e-9),
        "rays_per_s": rays / wall.max(1e-9),
        "false_hits_per_ray": get("false_hits") / queries.max(1.0),
        "packet_lane_share": get("packet_lanes") / get("packet_slots").max(1.0),
        "shadow_packet_lane_share": get("shadow_packet_lanes") / get("shadow_packet_slots").max(1.0),
        "shade_lane_share": get("shade_lanes") / get("shade_slots").max(1.0),
        "set_replayed_share": get("set_replayed_lanes") / get("set_lanes").max(1.0),
        "provenance": crate::provenance::json(),
    });
    if let serde_json::Value::Object(d) = derived {
        out.extend(d);
    }
    serde_json::Value::Object(out)
}
