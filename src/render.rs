//! Tiles, threads and progress. Each pixel's samples draw from generators
//! seeded by (seed, pixel, sample), so the image is the same for any thread count.
use crate::dielectric::InteriorList;
use crate::error::{Error, Result};
use crate::integrator::{radiance, SampleStats};
use crate::sampling::Rng;
use crate::scene::RenderScene;
use glam::Vec3A as V3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

pub const TILE: u32 = 16;

/// Per-pixel diagnostic layers (means over the pixel's samples).
#[derive(Debug, Clone, Default)]
pub struct Aovs {
    pub false_hits: Vec<f32>,
    pub list_depth: Vec<f32>,
    pub tir: Vec<f32>,
    pub fallbacks: Vec<f32>,
}

/// A rendered image (linear RGB, row 0 at the top) with statistics.
#[derive(Debug, Clone)]
pub struct Rendered {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<V3>,
    /// Per pixel and channel: estimated variance of the pixel mean (sample
    /// variance over the pixel's samples / spp). Monte Carlo noise only.
    pub variance: Vec<V3>,
    pub aovs: Aovs,
    pub stats: RenderStats,
    /// Samples per pixel requested (every pixel of a completed tile has them).
    pub spp_done: u32,
    /// False when interrupted: tiles not started are black.
    pub complete: bool,
    /// Samples per pixel actually taken, per pixel (spp or 0 when interrupted).
    pub pixel_spp: Vec<f32>,
    pub tiles_done: u32,
    pub tiles_total: u32,
}

/// Totals over a render.
#[derive(Debug, Clone, Copy, Default)]
pub struct RenderStats {
    pub wall_s: f64,
    pub samples: u64,
    /// Embree queries (nearest-hit casts, including re-casts) plus shadow rays.
    pub rays: u64,
    pub queries: u64,
    pub shadow_rays: u64,
    pub false_hits: u64,
    pub filter_calls: u64,
    pub fallbacks: u64,
    pub max_list_depth: u64,
    pub list_spills: u64,
    pub tir: u64,
    pub nan: u64,
    pub segments: u64,
    pub chords: u64,
    pub grin_failures: u64,
}

impl RenderStats {
    fn add(&mut self, s: &SampleStats) {
        self.queries += s.counters.queries;
        self.shadow_rays += s.shadow_rays as u64;
        self.false_hits += s.counters.false_hits;
        self.filter_calls += s.counters.filter_calls;
        self.fallbacks += s.counters.fallbacks;
        self.max_list_depth = self.max_list_depth.max(s.counters.max_list_depth);
        self.list_spills += s.counters.spills;
        self.tir += s.tir as u64;
        self.nan += s.nan as u64;
        self.segments += s.segments as u64;
        self.chords += s.chords as u64;
        self.grin_failures += s.grin_failures as u64;
    }

    fn merge(&mut self, o: &RenderStats) {
        self.samples += o.samples;
        self.queries += o.queries;
        self.shadow_rays += o.shadow_rays;
        self.false_hits += o.false_hits;
        self.filter_calls += o.filter_calls;
        self.fallbacks += o.fallbacks;
        self.max_list_depth = self.max_list_depth.max(o.max_list_depth);
        self.list_spills += o.list_spills;
        self.tir += o.tir;
        self.nan += o.nan;
        self.segments += o.segments;
        self.chords += o.chords;
        self.grin_failures += o.grin_failures;
    }

    /// The stats JSON object (with provenance).
    pub fn to_json(&self, scene: &RenderScene, spp: u32) -> serde_json::Value {
        let rays = self.queries + self.shadow_rays;
        serde_json::json!({
            "wall_s": self.wall_s,
            "samples": self.samples,
            "samples_per_s": self.samples as f64 / self.wall_s.max(1e-9),
            "rays": rays,
            "rays_per_s": rays as f64 / self.wall_s.max(1e-9),
            "queries": self.queries,
            "shadow_rays": self.shadow_rays,
            "width": scene.width,
            "height": scene.height,
            "spp": spp,
            "nested_strategy": scene.strategy.name(),
            "false_hits": self.false_hits,
            "false_hits_per_ray": self.false_hits as f64 / self.queries.max(1) as f64,
            "filter_calls_per_ray": self.filter_calls as f64 / self.queries.max(1) as f64,
            "max_list_depth": self.max_list_depth,
            "list_spills": self.list_spills,
            "fallbacks": self.fallbacks,
            "tir": self.tir,
            "nan_or_inf_samples": self.nan,
            "chords": self.chords,
            "chords_per_segment": self.chords as f64 / self.segments.max(1) as f64,
            "grin_failures": self.grin_failures,
            "provenance": crate::provenance::json(),
        })
    }
}

/// Render options beyond the scene file.
#[derive(Debug, Clone, Default)]
pub struct RenderOptions {
    pub threads: Option<usize>,
    pub quiet: bool,
    pub want_aovs: bool,
}

impl Rendered {
    /// Image mean of channel `ch` and its Monte Carlo standard error (from the
    /// per-pixel sample variances, so image content does not count as noise).
    pub fn mean_and_se(&self, ch: usize) -> (f64, f64) {
        let n = self.pixels.len() as f64;
        let m = self.pixels.iter().map(|p| p[ch] as f64).sum::<f64>() / n;
        let v = self.variance.iter().map(|p| p[ch] as f64).sum::<f64>() / (n * n);
        (m, v.sqrt())
    }
}

/// Set by a Ctrl-C handler to stop at the next tile boundary.
pub static INTERRUPT: AtomicBool = AtomicBool::new(false);

struct TileOut {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    px: Vec<V3>,
    var: Vec<V3>,
    aov: Option<[Vec<f32>; 4]>,
    stats: RenderStats,
    done: bool,
}

fn render_tile(scene: &RenderScene, x0: u32, y0: u32, want_aovs: bool) -> Result<TileOut> {
    let w = TILE.min(scene.width - x0);
    let h = TILE.min(scene.height - y0);
    let n = (w * h) as usize;
    let mut px = vec![V3::ZERO; n];
    let mut var = vec![V3::ZERO; n];
    let mut aov = want_aovs.then(|| [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]]);
    let mut stats = RenderStats::default();
    let spp = scene.spp;
    let inv = 1.0 / spp as f32;
    let start_list = InteriorList::from_slice(&scene.camera_interior);
    for j in 0..h {
        for i in 0..w {
            let (x, y) = (x0 + i, y0 + j);
            let pixel = y as u64 * scene.width as u64 + x as u64;
            let mut sum = V3::ZERO;
            let mut sumsq = V3::ZERO;
            let k = (j * w + i) as usize;
            for s in 0..spp {
                let mut rng = Rng::for_sample(scene.seed, pixel, s as u64);
                let fx = x as f32 + rng.uniform();
                let fy = y as f32 + rng.uniform();
                let lens = (rng.uniform(), rng.uniform());
                let (o, d) = scene.camera.ray(fx, fy, lens);
                let mut st = SampleStats::default();
                let l = radiance(scene, o, d, start_list.clone(), &mut rng, &mut st)?;
                sum += l;
                sumsq += l * l;
                stats.add(&st);
                if let Some(a) = &mut aov {
                    a[0][k] += st.counters.false_hits as f32 * inv;
                    a[1][k] = a[1][k].max(st.counters.max_list_depth as f32);
                    a[2][k] += st.tir as f32 * inv;
                    a[3][k] += st.counters.fallbacks as f32 * inv;
                }
            }
            stats.samples += spp as u64;
            px[k] = sum * inv;
            if spp > 1 {
                let s2 = ((sumsq - sum * sum * inv) / (spp - 1) as f32).max(V3::ZERO);
                var[k] = s2 * inv;
            }
        }
    }
    // Embree errors and panics in analytic shapes (which made queries miss)
    // surface here instead of as a silently wrong tile.
    scene.embree.check()?;
    Ok(TileOut {
        x0,
        y0,
        w,
        h,
        px,
        var,
        aov,
        stats,
        done: true,
    })
}

/// Render `scene` with its film settings.
pub fn render(scene: &RenderScene, opts: &RenderOptions) -> Result<Rendered> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::Invalid(format!("cannot start render threads: {e}")))?;
    let mut tiles = Vec::new();
    for y in (0..scene.height).step_by(TILE as usize) {
        for x in (0..scene.width).step_by(TILE as usize) {
            tiles.push((x, y));
        }
    }
    let total = tiles.len() as u64;
    let bar = progress_bar(total, opts.quiet);
    let samples_done = AtomicU64::new(0);
    let start = Instant::now();
    let results: Vec<Result<TileOut>> = pool.install(|| {
        tiles
            .par_iter()
            .map(|&(x, y)| {
                if INTERRUPT.load(Ordering::Relaxed) {
                    let w = TILE.min(scene.width - x);
                    let h = TILE.min(scene.height - y);
                    return Ok(TileOut {
                        x0: x,
                        y0: y,
                        w,
                        h,
                        px: vec![V3::ZERO; (w * h) as usize],
                        var: vec![V3::ZERO; (w * h) as usize],
                        aov: None,
                        stats: RenderStats::default(),
                        done: false,
                    });
                }
                let t = render_tile(scene, x, y, opts.want_aovs)?;
                let s = samples_done.fetch_add(t.stats.samples, Ordering::Relaxed) + t.stats.samples;
                if let Some(b) = &bar {
                    b.inc(1);
                    let el = start.elapsed().as_secs_f64().max(1e-9);
                    b.set_message(format!("{:.2} Msamples/s", s as f64 / el / 1e6));
                }
                Ok(t)
            })
            .collect()
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let wall = start.elapsed().as_secs_f64();
    let n = (scene.width * scene.height) as usize;
    let mut pixels = vec![V3::ZERO; n];
    let mut variance = vec![V3::ZERO; n];
    let mut aovs = Aovs::default();
    if opts.want_aovs {
        aovs = Aovs {
            false_hits: vec![0.0; n],
            list_depth: vec![0.0; n],
            tir: vec![0.0; n],
            fallbacks: vec![0.0; n],
        };
    }
    let mut stats = RenderStats::default();
    let mut complete = true;
    let mut pixel_spp = vec![0.0f32; n];
    let mut tiles_done = 0;
    for r in results {
        let t = r?;
        complete &= t.done;
        tiles_done += t.done as u32;
        stats.merge(&t.stats);
        for j in 0..t.h {
            for i in 0..t.w {
                let dst = ((t.y0 + j) * scene.width + t.x0 + i) as usize;
                let src = (j * t.w + i) as usize;
                pixels[dst] = t.px[src];
                variance[dst] = t.var[src];
                pixel_spp[dst] = if t.done { scene.spp as f32 } else { 0.0 };
                if let Some(a) = &t.aov {
                    aovs.false_hits[dst] = a[0][src];
                    aovs.list_depth[dst] = a[1][src];
                    aovs.tir[dst] = a[2][src];
                    aovs.fallbacks[dst] = a[3][src];
                }
            }
        }
    }
    stats.wall_s = wall;
    stats.rays = stats.queries + stats.shadow_rays;
    Ok(Rendered {
        width: scene.width,
        height: scene.height,
        pixels,
        variance,
        aovs,
        stats,
        spp_done: scene.spp,
        complete,
        pixel_spp,
        tiles_done,
        tiles_total: total as u32,
    })
}

fn progress_bar(total: u64, quiet: bool) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let b = indicatif::ProgressBar::new(total);
    b.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} tiles {msg} ETA {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    Some(b)
}
