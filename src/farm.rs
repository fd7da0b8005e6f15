//! Render-farm helpers for the CLI: loading a scene with `--set` overrides,
//! turning `--region`/`--samples` (or their grid forms `--region-cell` and
//! `--sample-chunk`, convenient in job templates) and `--resume` into a
//! [`PartSpec`], process CPU time, and the stats table of a sweep. See docs/farm.md.
use crate::error::{Error, Result};
use crate::part::{read_part, scene_id, PartMeta};
use crate::render::{Accum, PartSpec, Region, RenderSettings};
use crate::scene::source::Source;
use crate::scene::{build_scene_text, BuildOptions, RenderScene, SceneText};
use std::path::{Path, PathBuf};

/// Load a scene file with `--set` overrides; returns the scene and its
/// [`scene_id`] (of the text after overrides and `tag`, what else makes
/// the image: [`crate::render::id_tag`]).
///
/// # Errors
///
/// [`Error::Io`] when the file cannot be read; [`Error::Input`] for a
/// malformed override or an invalid scene (located in the file or in the
/// `--set` argument); any error of building the scene.
pub fn load(path: &Path, sets: &[String], opts: &BuildOptions, tag: &str) -> Result<(RenderScene, String)> {
    let text = SceneText::read(path, &opts.import)?;
    let src = crate::overrides::apply(Source::new(&text.source.file, text.source.text.clone()), sets)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let scene = build_scene_text(&text, &src, &dir, opts)?;
    Ok((scene, scene_id(&src.text, tag)))
}

/// `x0,x1,y0,y1`: half-open pixel bounds.
///
/// Only the syntax is checked here; the bounds are checked against the film
/// when the render starts.
///
/// # Errors
///
/// [`Error::Invalid`] unless `s` is four comma-separated unsigned integers.
pub fn parse_region(s: &str) -> Result<Region> {
    let v: Vec<u32> = s
        .split(',')
        .map(|t| t.trim().parse())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| {
            Error::Invalid(format!(
                "--region {s}: expected x0,x1,y0,y1 (four pixel bounds, half-open)"
            ))
        })?;
    match v[..] {
        [x0, x1, y0, y1] => Ok(Region { x0, x1, y0, y1 }),
        _ => Err(Error::Invalid(format!(
            "--region {s}: expected x0,x1,y0,y1 (four pixel bounds, half-open)"
        ))),
    }
}

/// `I/N`: item I (counting from 1) of N; returns the 0-based index and N.
fn index_of(flag: &str, s: &str) -> Result<(u32, u32)> {
    let bad = || Error::Invalid(format!("{flag} {s}: expected I/N with 1 <= I <= N"));
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n): (u32, u32) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if i == 0 || i > n {
        return Err(bad());
    }
    Ok((i - 1, n))
}

/// `IX/NX,IY/NY`: cell (IX, IY) of an NX x NY grid over the film, counting
/// from 1 (`1/4,1/4` is the top-left cell), as farm task ranges do.
///
/// # Errors
///
/// [`Error::Invalid`] for a malformed `s`, an index outside 1..=N, or a grid
/// finer than the film (it would have empty cells).
pub fn region_cell(s: &str, width: u32, height: u32) -> Result<Region> {
    let (a, b) = s
        .split_once(',')
        .ok_or_else(|| Error::Invalid(format!("--region-cell {s}: expected IX/NX,IY/NY")))?;
    let (ix, nx) = index_of("--region-cell", a)?;
    let (iy, ny) = index_of("--region-cell", b)?;
    if nx > width || ny > height {
        return Err(Error::Invalid(format!(
            "--region-cell {s}: a {nx}x{ny} grid has empty cells on a {width}x{height} film"
        )));
    }
    let cut = |i: u32, n: u32, len: u32| (i as u64 * len as u64 / n as u64) as u32;
    Ok(Region {
        x0: cut(ix, nx, width),
        x1: cut(ix + 1, nx, width),
        y0: cut(iy, ny, height),
        y1: cut(iy + 1, ny, height),
    })
}

/// `START:COUNT`: sample indices `[START, START + COUNT)`.
///
/// # Errors
///
/// [`Error::Invalid`] unless `s` is two unsigned integers separated by `:`.
pub fn parse_samples(s: &str) -> Result<(u32, u32)> {
    let bad = || Error::Invalid(format!("--samples {s}: expected START:COUNT"));
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    Ok((
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    ))
}

/// `K/N`: chunk K (counting from 1) of the film's spp cut into N ranges;
/// returns `(start, count)`.
///
/// # Errors
///
/// [`Error::Invalid`] for a malformed `s`, K outside 1..=N, or N > `spp`
/// (some chunks would be empty).
pub fn sample_chunk(s: &str, spp: u32) -> Result<(u32, u32)> {
    let (k, n) = index_of("--sample-chunk", s)?;
    if n > spp {
        return Err(Error::Invalid(format!(
            "--sample-chunk {s}: {n} chunks of {spp} samples per pixel leave some empty"
        )));
    }
    let cut = |i: u32| (i as u64 * spp as u64 / n as u64) as u32;
    Ok((cut(k), cut(k + 1) - cut(k)))
}

/// The farm options of `snell render`.
#[derive(Debug, Clone, Default)]
pub struct FarmArgs {
    /// `--region x0,x1,y0,y1`.
    pub region: Option<String>,
    /// `--region-cell IX/NX,IY/NY`.
    pub region_cell: Option<String>,
    /// `--samples START:COUNT`.
    pub samples: Option<String>,
    /// `--sample-chunk K/N`.
    pub sample_chunk: Option<String>,
    /// `--resume PART.exr`.
    pub resume: Option<PathBuf>,
    /// Write a part (with exact sums) even for a whole render.
    pub part: bool,
}

/// What to render and how to label the result.
#[derive(Debug, Clone)]
pub struct Plan {
    /// What to render.
    pub spec: PartSpec,
    /// How to label the part file.
    pub meta: PartMeta,
    /// Whether the output is a part (region, sample range, resume or `--part`).
    pub is_part: bool,
}

/// Turn the farm options into a plan for a render with `settings`. With `--resume` the region
/// and sample range default to the part's, and must match when given.
///
/// `id` is the scene's [`scene_id`]; `keep_sums` asks for exact sums even for a
/// whole render.
///
/// # Errors
///
/// [`Error::Invalid`] when both forms of an option are given or one does not
/// parse, or when the `--resume` part differs from this render (film, spp,
/// seed, scene id, region or sample range); [`Error::Io`] when the part cannot
/// be read.
pub fn plan(settings: &RenderSettings, id: &str, a: &FarmArgs, keep_sums: bool) -> Result<Plan> {
    if a.region.is_some() && a.region_cell.is_some() {
        return Err(Error::Invalid("give --region or --region-cell, not both".into()));
    }
    if a.samples.is_some() && a.sample_chunk.is_some() {
        return Err(Error::Invalid(
            "give --samples or --sample-chunk, not both".into(),
        ));
    }
    let mut region = match (&a.region, &a.region_cell) {
        (Some(r), _) => Some(parse_region(r)?),
        (_, Some(c)) => Some(region_cell(c, settings.width, settings.height)?),
        _ => None,
    };
    let mut samples = match (&a.samples, &a.sample_chunk) {
        (Some(s), _) => Some(parse_samples(s)?),
        (_, Some(c)) => Some(sample_chunk(c, settings.spp)?),
        _ => None,
    };
    let mut base = None;
    if let Some(path) = &a.resume {
        let p = read_part(path)?;
        let m = &p.meta;
        let bad = |what: &str, part: String, now: String| {
            Err(Error::Invalid(format!(
                "--resume {}: the part has a different {what} ({part}) than this render ({now})",
                path.display()
            )))
        };
        if (m.film_width, m.film_height) != (settings.width, settings.height) {
            return bad(
                "film",
                format!("{}x{}", m.film_width, m.film_height),
                format!("{}x{}", settings.width, settings.height),
            );
        }
        if m.spp != settings.spp {
            return bad("spp", m.spp.to_string(), settings.spp.to_string());
        }
        if m.seed != settings.seed {
            return bad("seed", m.seed.to_string(), settings.seed.to_string());
        }
        if m.scene_id != id {
            return bad(
                "scene (text, --set overrides or --nested)",
                m.scene_id.clone(),
                id.to_string(),
            );
        }
        if *region.get_or_insert(m.region) != m.region {
            return bad(
                "region",
                m.region.to_string(),
                region.unwrap_or(m.region).to_string(),
            );
        }
        let range = (m.sample_start, m.sample_count);
        if *samples.get_or_insert(range) != range {
            let s = samples.unwrap_or(range);
            return bad(
                "sample range",
                format!("{}:{}", range.0, range.1),
                format!("{}:{}", s.0, s.1),
            );
        }
        base = Some(Accum {
            sums: p.accum.sums,
            counts: p.accum.counts,
        });
    }
    let is_part = region.is_some() || samples.is_some() || base.is_some() || a.part;
    let r = region.unwrap_or(Region::full(settings.width, settings.height));
    let (start, count) = samples.unwrap_or((0, settings.spp));
    Ok(Plan {
        spec: PartSpec {
            region,
            samples,
            keep_sums: keep_sums || is_part,
            base,
        },
        meta: PartMeta {
            film_width: settings.width,
            film_height: settings.height,
            spp: settings.spp,
            seed: settings.seed,
            scene_id: id.to_string(),
            region: r,
            sample_start: start,
            sample_count: count,
        },
        is_part,
    })
}

/// Where an interrupted render of `output` is written: `NAME.partial.EXT`.
pub fn partial_path(output: &Path) -> PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    let ext = output
        .extension()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    output.with_file_name(format!("{stem}.partial.{ext}"))
}

/// Create the directory of `path` if it is missing (`--mkdir`).
///
/// # Errors
///
/// [`Error::Io`] when the directory cannot be created.
pub fn make_parent(path: &Path) -> Result<()> {
    match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(d) => {
            std::fs::create_dir_all(d).map_err(|e| Error::io(d, format!("cannot create directory: {e}")))
        }
        None => Ok(()),
    }
}

/// A Markdown table of stats JSON files (one row each): the `--set`
/// overrides recorded in them, then time, rays and false hits.
///
/// A directory in `inputs` stands for its `*.json` files, sorted by name.
///
/// # Errors
///
/// [`Error::Invalid`] when no file is found; [`Error::Io`] when a file or
/// directory cannot be read or a file is not JSON.
pub fn stats_table(inputs: &[PathBuf]) -> Result<String> {
    let mut files = Vec::new();
    for a in inputs {
        if a.is_dir() {
            let mut v: Vec<PathBuf> = std::fs::read_dir(a)
                .map_err(|e| Error::io(a, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "json"))
                .collect();
            v.sort();
            files.extend(v);
        } else {
            files.push(a.clone());
        }
    }
    if files.is_empty() {
        return Err(Error::Invalid("table: no stats JSON files given".into()));
    }
    let mut rows = Vec::new();
    let mut keys: Vec<String> = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).map_err(|e| Error::io(f, e))?;
        let v: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| Error::io(f, format!("not a stats JSON file: {e}")))?;
        let sets: Vec<(String, String)> = v["overrides"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|s| {
                        s.as_str()?
                            .split_once('=')
                            .map(|(k, v)| (k.to_string(), v.to_string()))
                    })
                    .collect()
            })
            .unwrap_or_default();
        for (k, _) in &sets {
            if !keys.contains(k) {
                keys.push(k.clone());
            }
        }
        rows.push((f, sets, v));
    }
    const COLS: [&str; 6] = [
        "wall_s",
        "cpu_s",
        "samples_per_s",
        "rays",
        "false_hits_per_ray",
        "tir",
    ];
    let mut out = String::from("| file |");
    for k in keys.iter().map(String::as_str).chain(COLS) {
        out.push_str(&format!(" {k} |"));
    }
    out.push_str(&format!("\n|{}\n", "---|".repeat(1 + keys.len() + COLS.len())));
    for (f, sets, v) in rows {
        out.push_str(&format!(
            "| {} |",
            f.file_name().map(|n| n.to_string_lossy()).unwrap_or_default()
        ));
        for k in &keys {
            let val = sets
                .iter()
                .find(|(a, _)| a == k)
                .map(|(_, b)| b.as_str())
                .unwrap_or("");
            out.push_str(&format!(" {val} |"));
        }
        for c in COLS {
            let cell = match &v[c] {
                serde_json::Value::Number(n) if n.is_f64() => format!("{:.4}", n.as_f64().unwrap_or(0.0)),
                serde_json::Value::Null => String::new(),
                x => x.to_string(),
            };
            out.push_str(&format!(" {cell} |"));
        }
        out.push('\n');
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_and_chunks_tile_exactly() {
        let mut covered = vec![0u32; 37 * 23];
        for ix in 0..4 {
            for iy in 0..3 {
                let r = region_cell(&format!("{}/4,{}/3", ix + 1, iy + 1), 37, 23).unwrap();
                for y in r.y0..r.y1 {
                    for x in r.x0..r.x1 {
                        covered[(y * 37 + x) as usize] += 1;
                    }
                }
            }
        }
        assert!(covered.iter().all(|&c| c == 1));
        let chunks: Vec<_> = (1..=3)
            .map(|k| sample_chunk(&format!("{k}/3"), 10).unwrap())
            .collect();
        assert_eq!(chunks, vec![(0, 3), (3, 3), (6, 4)]);
        assert!(sample_chunk("0/3", 10).is_err());
        assert!(sample_chunk("4/3", 10).is_err());
        assert!(sample_chunk("1/11", 10).is_err());
        assert!(parse_region("1,2,3").is_err());
        assert_eq!(parse_samples("4:2").unwrap(), (4, 2));
    }
}
