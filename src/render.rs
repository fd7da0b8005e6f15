//! Tiles, threads and progress. Each pixel's samples draw from generators
//! seeded by (seed, pixel, sample), so the image is the same for any thread count.
pub use crate::accum::{mean_of, to_fixed, Accum, PartSpec, Region, FIXED_BITS};
use crate::camera::Camera;
use crate::counters::Counters;
use crate::dielectric::NestedStrategy;
use crate::error::{Error, Result};
pub use crate::integrator::Shading;
use crate::integrator::{CameraRays, LightSampling, RayObserver, Scheduler, Tracer};
use crate::scene::RenderScene;
use glam::Vec3A as V3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Tile edge, pixels: the unit of work of a render thread.
pub const TILE: u32 = 16;

/// A per-pixel diagnostic layer (AOV): per pixel, the mean over its samples
/// of a per-sample count (the maximum for `list_depth`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Aov {
    /// False hits skipped per sample.
    FalseHits,
    /// Deepest interior list of any sample (a maximum).
    ListDepth,
    /// Total internal reflections per sample.
    Tir,
    /// Filtered queries finished by re-casting, per sample.
    Fallbacks,
}

impl std::str::FromStr for Aov {
    type Err = String;
    /// Parses [`Aov::name`].
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Aov::ALL
            .into_iter()
            .find(|a| a.name() == s)
            .ok_or_else(|| format!("expected false_hits, list_depth, tir or fallbacks, got \"{s}\""))
    }
}

impl Aov {
    /// Every layer, in the order of [`Aovs::layers`].
    pub const ALL: [Aov; 4] = [Aov::FalseHits, Aov::ListDepth, Aov::Tir, Aov::Fallbacks];

    /// The layer's name (EXR channel, PNG suffix, `--aov` value).
    pub fn name(self) -> &'static str {
        match self {
            Aov::FalseHits => "false_hits",
            Aov::ListDepth => "list_depth",
            Aov::Tir => "tir",
            Aov::Fallbacks => "fallbacks",
        }
    }

    /// Fold one sample's counters into the pixel's value (`inv` = 1 / samples).
    #[inline]
    fn add_sample(self, pixel: &mut f32, c: &Counters, inv: f32) {
        match self {
            Aov::FalseHits => *pixel += c.false_hits as f32 * inv,
            Aov::ListDepth => *pixel = pixel.max(c.max_list_depth as f32),
            Aov::Tir => *pixel += c.tir as f32 * inv,
            Aov::Fallbacks => *pixel += c.fallbacks as f32 * inv,
        }
    }
}

/// Per-pixel diagnostic layers, one per [`Aov`] (empty unless asked for).
#[derive(Debug, Clone, Default)]
pub struct Aovs {
    /// Indexed by `Aov as usize`.
    pub layers: [Vec<f32>; 4],
}

impl Aovs {
    fn new(n: usize) -> Self {
        Aovs {
            layers: [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        }
    }

    /// The layer of `aov`, row-major like the image.
    pub fn layer(&self, aov: Aov) -> &[f32] {
        &self.layers[aov as usize]
    }
}

/// A rendered image (linear RGB, row 0 at the top) with statistics.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// Width of the rendered region, pixels.
    pub width: u32,
    /// Height of the rendered region, pixels.
    pub height: u32,
    /// Linear RGB, row-major, row 0 at the top.
    pub pixels: Vec<V3>,
    /// Per pixel and channel: estimated variance of the pixel mean (sample
    /// variance over the pixel's samples / spp). Monte Carlo noise only.
    pub variance: Vec<V3>,
    /// Diagnostic layers (empty unless asked for).
    pub aovs: Aovs,
    /// Wall time and counters.
    pub stats: RenderStats,
    /// Samples per pixel requested (every pixel of a completed tile has them).
    pub spp_done: u32,
    /// False when cancelled ([`RenderOptions::cancel`]) before every tile
    /// was started: the tiles not started are black (or hold only the
    /// samples a resumed part brought).
    pub complete: bool,
    /// Samples per pixel actually taken, per pixel (fewer than spp where cancelled).
    pub pixel_spp: Vec<f32>,
    /// Tiles rendered (fewer than `tiles_total` when cancelled).
    pub tiles_done: u32,
    /// Tiles in the region.
    pub tiles_total: u32,
    /// The pixels rendered (the whole film unless a region was asked for);
    /// `width` x `height` is its size.
    pub region: Region,
    /// Width of the whole film.
    pub film_width: u32,
    /// Height of the whole film.
    pub film_height: u32,
    /// First sample index of the range this render covers.
    pub sample_start: u32,
    /// Number of sample indices in the range (`[sample_start, sample_start + sample_count)`).
    pub sample_count: u32,
    /// Exact per-pixel sums and sample counts (kept when asked for: part files).
    pub accum: Option<Accum>,
}

/// Totals over a render: its wall time and its counters.
#[derive(Debug, Clone, Copy, Default)]
pub struct RenderStats {
    /// Wall-clock time of the render, seconds.
    pub wall_s: f64,
    /// CPU time of the render's threads, seconds (`None` where the kernel
    /// does not report it; see [`crate::timing`]).
    pub cpu_s: Option<f64>,
    /// Every event counted over the render.
    pub counters: Counters,
}

impl RenderStats {
    /// The stats JSON object (with provenance).
    pub fn to_json(&self, settings: &RenderSettings, spp: u32) -> serde_json::Value {
        let c = &self.counters;
        let mut j = serde_json::to_value(c).unwrap_or_default();
        let per = |a: u64, b: u64| a as f64 / b.max(1) as f64;
        let derived = serde_json::json!({
            "wall_s": self.wall_s,
            "cpu_s": self.cpu_s,
            "samples_per_s": c.samples as f64 / self.wall_s.max(1e-9),
            "rays": c.rays(),
            "rays_per_s": c.rays() as f64 / self.wall_s.max(1e-9),
            "width": settings.width,
            "height": settings.height,
            "spp": spp,
            "nested_strategy": settings.strategy.name(),
            "light_sampling": settings.light_sampling.name(),
            "false_hits_per_ray": per(c.false_hits, c.queries),
            "filter_calls_per_ray": per(c.filter_calls, c.queries),
            "chords_per_segment": per(c.chords, c.segments),
            "chords_per_medium_segment": per(c.chords, c.medium_segments),
            "evals_per_chord": per(c.field_evals, c.chords),
            "evals_per_medium_segment": per(c.field_evals, c.medium_segments),
            "packet_lane_share": per(c.packet_lanes, c.packet_slots),
            "shadow_packet_lane_share": per(c.shadow_packet_lanes, c.shadow_packet_slots),
            "shade_lane_share": per(c.shade_lanes, c.shade_slots),
            "set_replayed_share": per(c.set_replayed_lanes, c.set_lanes),
            "provenance": crate::provenance::json(),
        });
        if let (Some(o), serde_json::Value::Object(d)) = (j.as_object_mut(), derived) {
            o.extend(d);
        }
        j
    }
}

/// What a render is asked for beyond the scene: the film size, samples per
/// pixel, seed and nested-dielectric strategy. Starts from what the scene
/// file declares ([`RenderSettings::from_scene`]); the command line, benches
/// and tests override it here, never on the scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderSettings {
    /// Film width, pixels.
    pub width: u32,
    /// Film height, pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Seed of every pixel's sample generators.
    pub seed: u64,
    /// How false hits of nested dielectrics are skipped.
    pub strategy: NestedStrategy,
    /// Next-event estimation with MIS (the default), or BSDF sampling alone.
    pub light_sampling: LightSampling,
}

impl RenderSettings {
    /// The scene file's film (size, spp, seed) and the default strategy (filter).
    pub fn from_scene(scene: &RenderScene) -> Self {
        RenderSettings {
            width: scene.width,
            height: scene.height,
            spp: scene.spp,
            seed: scene.seed,
            strategy: NestedStrategy::Filter,
            light_sampling: LightSampling::Mis,
        }
    }

    /// Another film size (the camera keeps its vertical field of view, an
    /// orthographic camera its view's height).
    ///
    /// # Errors
    /// A zero size or more than `scene::MAX_PIXELS` pixels.
    pub fn with_resolution(mut self, width: u32, height: u32) -> Result<Self> {
        if width == 0 || height == 0 || (width as u64) * (height as u64) > crate::scene::MAX_PIXELS {
            return Err(Error::Invalid(format!(
                "resolution {width}x{height} is out of range"
            )));
        }
        self.width = width;
        self.height = height;
        Ok(self)
    }

    /// Another number of samples per pixel.
    pub fn with_spp(mut self, spp: u32) -> Self {
        self.spp = spp;
        self
    }

    /// Another seed.
    pub fn with_seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Another nested-dielectric strategy.
    pub fn with_strategy(mut self, strategy: NestedStrategy) -> Self {
        self.strategy = strategy;
        self
    }

    /// Another way of sampling lights.
    pub fn with_light_sampling(mut self, light_sampling: LightSampling) -> Self {
        self.light_sampling = light_sampling;
        self
    }

    /// What besides the scene's text makes the image: the nested strategy,
    /// and the light sampling when it is not the default (so that parts of
    /// renders that differ in them are never merged).
    pub fn id_tag(&self) -> String {
        id_tag(self.strategy, self.light_sampling)
    }

    /// The scene's camera at this film size.
    pub fn camera(&self, scene: &RenderScene) -> Camera {
        scene.camera.with_resolution(self.width, self.height)
    }
}

/// [`RenderSettings::id_tag`] of a render with `strategy` and `light_sampling`.
pub fn id_tag(strategy: NestedStrategy, light_sampling: LightSampling) -> String {
    match light_sampling {
        LightSampling::Mis => strategy.name().to_string(),
        other => format!("{}+{}", strategy.name(), other.name()),
    }
}

/// How a render runs and who hears of it, beyond what it renders: threads,
/// diagnostic layers, progress, cancellation and an observer of its rays.
/// The default: one thread per core, no layers, no progress, never
/// cancelled, not observed.
#[derive(Clone, Default)]
pub struct RenderOptions {
    /// Render threads (`None`: one per core).
    pub threads: Option<usize>,
    /// Where progress goes.
    pub progress: ProgressSink,
    /// Keep the diagnostic layers (`Rendered::aovs`).
    pub want_aovs: bool,
    /// Stops the render at the next tile when cancelled (keep a clone to
    /// cancel it from elsewhere).
    pub cancel: CancelToken,
    /// Told of every Embree query of the render's paths
    /// ([`RayRecorder`](crate::integrator::RayRecorder) keeps them).
    pub observer: Option<Arc<dyn RayObserver>>,
    /// How many paths the path tracer traces side by side in one Embree
    /// packet. The image does not depend on it.
    pub packet_width: PacketWidth,
    /// How camera rays fly through a 3-D gradient-index field (the path
    /// tracer's). The image does not depend on it.
    pub flights: Flights,
    /// How the path tracer shades a packet's paths (vector shading where
    /// the scene's materials and lights allow it).
    pub shading: Shading,
}

/// How the path tracer's camera rays cross a 3-D gradient-index field where
/// no geometry is near ([`RenderOptions::flights`]; `media::fly_camera_rays`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Flights {
    /// A tile row's camera rays together, their field evaluations eight per
    /// vector operation.
    #[default]
    SideBySide,
    /// Each ray alone when its path gets there.
    OneByOne,
}

/// The width of the path tracer's packets ([`RenderOptions::packet_width`]):
/// a wavefront's live paths go to Embree this many at a time.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum PacketWidth {
    /// Sixteen where Embree's 16-wide packets are native (a CPU with
    /// AVX-512), else eight (a 16-wide query would be two 8-wide ones).
    #[default]
    Auto,
    /// Eight paths per packet.
    Eight,
    /// Sixteen paths per packet.
    Sixteen,
}

impl PacketWidth {
    /// The width on `device`: 8 or 16.
    pub fn lanes(self, device: &crate::embree::Device) -> usize {
        match self {
            PacketWidth::Eight => 8,
            PacketWidth::Sixteen => 16,
            PacketWidth::Auto if device.native_packet16() => 16,
            PacketWidth::Auto => 8,
        }
    }
}

impl std::fmt::Debug for RenderOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RenderOptions")
            .field("threads", &self.threads)
            .field("progress", &self.progress)
            .field("want_aovs", &self.want_aovs)
            .field("cancel", &self.cancel)
            .field("observer", &self.observer.as_ref().map(|_| "RayObserver"))
            .field("packet_width", &self.packet_width)
            .field("flights", &self.flights)
            .field("shading", &self.shading)
            .finish()
    }
}

/// A render's cancellation flag: [`cancel`](CancelToken::cancel) makes the
/// render it was given stop at the next tile (tiles in progress finish).
/// Clones share the flag, so a signal handler or another thread can hold
/// one; each render has its own unless given the same one.
#[derive(Debug, Clone, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    /// A token not cancelled.
    pub fn new() -> Self {
        Self::default()
    }

    /// Cancel the renders holding this token (or a clone of it).
    pub fn cancel(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Has [`cancel`](CancelToken::cancel) been called?
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// A render's progress after one more tile (rendered, or skipped when cancelled).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderProgress {
    /// Tiles finished so far.
    pub tiles_done: u64,
    /// Tiles of the render.
    pub tiles_total: u64,
    /// Samples taken so far.
    pub samples_done: u64,
    /// Seconds since the tiles started.
    pub elapsed_s: f64,
}

/// Where a render reports its progress.
#[derive(Clone, Default)]
pub enum ProgressSink {
    /// Nowhere.
    #[default]
    None,
    /// A progress bar on stderr, when stderr is a terminal and the crate
    /// has the `progress-bar` feature (without it, nothing).
    Bar,
    /// Lines on stderr at every 10% (`openjd_progress: P`, which farm
    /// managers running Open Job Description read, and a human line).
    Lines,
    /// A function called after every tile, from the render's threads.
    Callback(Arc<dyn Fn(&RenderProgress) + Send + Sync>),
}

impl std::fmt::Debug for ProgressSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ProgressSink::None => "None",
            ProgressSink::Bar => "Bar",
            ProgressSink::Lines => "Lines",
            ProgressSink::Callback(_) => "Callback",
        })
    }
}

impl ProgressSink {
    /// Report `p` (`bar`: the progress bar, made for [`ProgressSink::Bar`]).
    fn report(&self, p: &RenderProgress, bar: Option<&ProgressBar>) {
        let rate = || p.samples_done as f64 / p.elapsed_s.max(1e-9) / 1e6;
        match self {
            ProgressSink::None => {}
            ProgressSink::Bar => {
                if let Some(b) = bar {
                    b.inc(1);
                    b.set_message(format!("{:.2} Msamples/s", rate()));
                }
            }
            ProgressSink::Lines => {
                let (done, total) = (p.tiles_done, p.tiles_total);
                if (done * 10 / total) != ((done - 1) * 10 / total) {
                    eprintln!(
                        "openjd_progress: {:.1}\nsnell: {done}/{total} tiles, {:.2} Msamples/s, {:.1} s",
                        100.0 * done as f64 / total as f64,
                        rate(),
                        p.elapsed_s
                    );
                }
            }
            ProgressSink::Callback(f) => f(p),
        }
    }
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

/// Where a tile's samples go: each pixel's sums, the diagnostic layers
/// (if asked for) and the counters.
struct TileSums<'a> {
    pix: &'a mut [PixelSum],
    aov: &'a mut Option<Aovs>,
    stats: &'a mut Counters,
}

/// A pixel's samples as a tile adds them up: the exact fixed-point sum
/// (what the image holds) and the f32 sums its variance comes from.
#[derive(Clone, Copy)]
struct PixelSum {
    acc: [i128; 3],
    sum: V3,
    sumsq: V3,
}

impl PixelSum {
    fn new(acc: [i128; 3]) -> Self {
        PixelSum {
            acc,
            sum: V3::ZERO,
            sumsq: V3::ZERO,
        }
    }

    fn add(&mut self, l: V3) {
        for (a, v) in self.acc.iter_mut().zip(l.to_array()) {
            *a = a.wrapping_add(to_fixed(v));
        }
        self.sum += l;
        self.sumsq += l * l;
    }
}

struct TileOut {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    px: Vec<V3>,
    var: Vec<V3>,
    aov: Option<Aovs>,
    sums: Vec<[i128; 3]>,
    counts: Vec<u32>,
    stats: Counters,
    done: bool,
}

/// What every tile of one render shares.
struct TileJob<'a> {
    scene: &'a RenderScene,
    settings: &'a RenderSettings,
    /// The render's camera rays.
    rays: CameraRays,
    region: Region,
    start: u32,
    count: u32,
    base: Option<&'a Accum>,
    want_aovs: bool,
    observer: Option<&'a dyn RayObserver>,
    /// Paths per packet (8 or 16).
    packet_lanes: usize,
    /// Vector or scalar shading (for [`Scheduler::of`]).
    shading: Shading,
    /// Fly each tile row's camera rays side by side (the path tracer through
    /// a medium with flights).
    fly_rows: bool,
}

impl TileJob<'_> {
    /// Sum and count already held by pixel (x, y).
    fn base_at(&self, x: u32, y: u32) -> ([i128; 3], u32) {
        match self.base {
            Some(b) => {
                let i = ((y - self.region.y0) * self.region.width() + x - self.region.x0) as usize;
                (b.sums[i], b.counts[i])
            }
            None => ([0; 3], 0),
        }
    }

    /// Render the tile at (x0, y0) with the thread's `lanes`, or (`skip`)
    /// only carry over the samples already held.
    fn tile(&self, lanes: &mut trace::Lanes, x0: u32, y0: u32, skip: bool) -> Result<TileOut> {
        let scene = self.scene;
        let w = TILE.min(self.region.x1 - x0);
        let h = TILE.min(self.region.y1 - y0);
        let n = (w * h) as usize;
        let mut px = vec![V3::ZERO; n];
        let mut var = vec![V3::ZERO; n];
        let mut sums = vec![[0i128; 3]; n];
        let mut counts = vec![0u32; n];
        let mut aov = (self.want_aovs && !skip).then(|| Aovs::new(n));
        let mut stats = Counters::default();
        // Each pixel's sums so far (from the samples already held), their
        // number and the number of samples it takes here.
        let mut pix = Vec::with_capacity(n);
        let mut held = Vec::with_capacity(n);
        for j in 0..h {
            for i in 0..w {
                let (acc, k) = self.base_at(x0 + i, y0 + j);
                pix.push(PixelSum::new(acc));
                held.push(k);
            }
        }
        let taken: Vec<u32> = held
            .iter()
            .map(|&k| if skip { 0 } else { self.count - k })
            .collect();
        if !skip {
            let tracer = Tracer {
                scene,
                strategy: self.settings.strategy,
                light_sampling: self.settings.light_sampling,
                observer: self.observer,
            };
            let sums = TileSums {
                pix: &mut pix,
                aov: &mut aov,
                stats: &mut stats,
            };
            match Scheduler::of(tracer, self.shading) {
                Scheduler::Wavefront(mode) => {
                    self.stream_tile(tracer, mode, lanes, (x0, y0), (w, h), &taken, sums)?
                }
                Scheduler::PathByPath => self.trace_tile(tracer, (x0, y0), (w, h), &taken, sums)?,
            }
        }
        for k in 0..n {
            let p = &pix[k];
            let count = held[k] + taken[k];
            stats.samples += taken[k] as u64;
            sums[k] = p.acc;
            counts[k] = count;
            px[k] = mean_of(p.acc, count);
            if taken[k] > 1 {
                let inv = 1.0 / taken[k] as f32;
                let s2 = ((p.sumsq - p.sum * p.sum * inv) / (taken[k] - 1) as f32).max(V3::ZERO);
                var[k] = s2 * inv;
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
            sums,
            counts,
            stats,
            done: !skip,
        })
    }
}

/// Render `scene` with `settings`.
///
/// # Errors
/// Embree errors and panics in analytic shapes during the render, a nested
/// trace that cannot finish, or threads that cannot start.
pub fn render(scene: &RenderScene, settings: &RenderSettings, opts: &RenderOptions) -> Result<Rendered> {
    render_part(scene, settings, opts, &PartSpec::default())
}

/// Render a part of `scene`: a region, a range of sample indices, optionally
/// continuing from samples already taken. Every pixel's value is the exact
/// (fixed-point) sum of its samples divided by their number, so any split of
/// a render into parts merges into the same image bit for bit.
///
/// # Errors
/// As [`render`], and a region or sample range outside the film, or a
/// resumed part that does not fit it.
pub fn render_part(
    scene: &RenderScene,
    settings: &RenderSettings,
    opts: &RenderOptions,
    part: &PartSpec,
) -> Result<Rendered> {
    let (fw, fh) = (settings.width, settings.height);
    let region = part.region.unwrap_or(Region::full(fw, fh));
    if region.x0 >= region.x1 || region.y0 >= region.y1 || region.x1 > fw || region.y1 > fh {
        return Err(Error::Invalid(format!(
            "region {region} (x0,x1,y0,y1, half-open) is empty or outside the {fw}x{fh} film"
        )));
    }
    let (start, count) = part.samples.unwrap_or((0, settings.spp));
    if count == 0 || start as u64 + count as u64 > settings.spp as u64 {
        return Err(Error::Invalid(format!(
            "samples {start}:{count} (START:COUNT) must be a non-empty range within the film's {} samples per pixel",
            settings.spp
        )));
    }
    if let Some(b) = &part.base {
        if b.sums.len() != region.pixels() || b.counts.len() != region.pixels() {
            return Err(Error::Invalid(
                "resume: the part's size does not match the region".into(),
            ));
        }
        if let Some(c) = b.counts.iter().find(|&&c| c > count) {
            return Err(Error::Invalid(format!(
                "resume: a pixel holds {c} samples, more than the range's {count}"
            )));
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::Invalid(format!("cannot start render threads: {e}")))?;
    let job = TileJob {
        scene,
        settings,
        rays: CameraRays::new(
            settings.camera(scene),
            settings.seed,
            settings.width,
            pulp::Arch::new(),
        ),
        region,
        start,
        count,
        base: part.base.as_ref(),
        want_aovs: opts.want_aovs,
        observer: opts.observer.as_deref(),
        shading: opts.shading,
        packet_lanes: match opts.packet_width.lanes(scene.embree.device()) {
            // Fewer samples per pixel than a packet holds: half of it would
            // go out empty.
            16 if opts.packet_width == PacketWidth::Auto && count < 16 => 8,
            w => w,
        },
        fly_rows: opts.flights == Flights::SideBySide
            && scene.integrator == crate::scene::IntegratorKind::Path
            && scene.medium.as_ref().is_some_and(|m| m.flies()),
    };
    let mut tiles = Vec::new();
    for y in (region.y0..region.y1).step_by(TILE as usize) {
        for x in (region.x0..region.x1).step_by(TILE as usize) {
            tiles.push((x, y));
        }
    }
    let total = tiles.len() as u64;
    let bar = matches!(opts.progress, ProgressSink::Bar)
        .then(|| progress_bar(total))
        .flatten();
    let samples_done = AtomicU64::new(0);
    let tiles_finished = AtomicU64::new(0);
    let start_t = Instant::now();
    let run_tiles = || -> Vec<Result<TileOut>> {
        tiles
            .par_iter()
            // Each thread's packets and wavefront storage, kept from tile to tile.
            .map_init(
                || trace::Lanes::of_width(job.packet_lanes),
                |lanes, &(x, y)| {
                    let t = job.tile(lanes, x, y, opts.cancel.is_cancelled())?;
                    let s = samples_done.fetch_add(t.stats.samples, Ordering::Relaxed) + t.stats.samples;
                    let done = tiles_finished.fetch_add(1, Ordering::Relaxed) + 1;
                    let p = RenderProgress {
                        tiles_done: done,
                        tiles_total: total,
                        samples_done: s,
                        elapsed_s: start_t.elapsed().as_secs_f64(),
                    };
                    opts.progress.report(&p, bar.as_ref());
                    Ok(t)
                },
            )
            .collect()
    };
    let (results, cpu) = crate::timing::on_pool(&pool, || pool.install(run_tiles));
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let wall = start_t.elapsed().as_secs_f64();
    let rw = region.width();
    let n = region.pixels();
    let mut pixels = vec![V3::ZERO; n];
    let mut variance = vec![V3::ZERO; n];
    let mut aovs = if opts.want_aovs {
        Aovs::new(n)
    } else {
        Aovs::default()
    };
    let mut accum = part.keep_sums.then(|| Accum {
        sums: vec![[0; 3]; n],
        counts: vec![0; n],
    });
    let mut stats = RenderStats::default();
    let mut pixel_spp = vec![0.0f32; n];
    let mut tiles_done = 0;
    for r in results {
        let t = r?;
        tiles_done += t.done as u32;
        stats.counters += t.stats;
        for j in 0..t.h {
            for i in 0..t.w {
                let dst = ((t.y0 - region.y0 + j) * rw + t.x0 - region.x0 + i) as usize;
                let src = (j * t.w + i) as usize;
                pixels[dst] = t.px[src];
                variance[dst] = t.var[src];
                pixel_spp[dst] = t.counts[src] as f32;
                if let Some(a) = &mut accum {
                    a.sums[dst] = t.sums[src];
                    a.counts[dst] = t.counts[src];
                }
                if let Some(a) = &t.aov {
                    for (to, from) in aovs.layers.iter_mut().zip(&a.layers) {
                        to[dst] = from[src];
                    }
                }
            }
        }
    }
    let complete = pixel_spp.iter().all(|&c| c == count as f32);
    stats.wall_s = wall;
    stats.cpu_s = cpu;
    Ok(Rendered {
        width: rw,
        height: region.height(),
        pixels,
        variance,
        aovs,
        stats,
        spp_done: count,
        complete,
        pixel_spp,
        tiles_done,
        tiles_total: total as u32,
        region,
        film_width: fw,
        film_height: fh,
        sample_start: start,
        sample_count: count,
        accum,
    })
}

/// The terminal progress bar [`ProgressSink::Bar`] draws.
#[cfg(feature = "progress-bar")]
type ProgressBar = indicatif::ProgressBar;
#[cfg(not(feature = "progress-bar"))]
type ProgressBar = NoProgressBar;

/// A bar of `total` tiles on stderr, if it is a terminal.
#[cfg(feature = "progress-bar")]
fn progress_bar(total: u64) -> Option<ProgressBar> {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let b = indicatif::ProgressBar::new(total);
    b.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} tiles {msg} ETA {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    Some(b)
}

/// Without the `progress-bar` feature there is no bar to draw.
#[cfg(not(feature = "progress-bar"))]
fn progress_bar(_total: u64) -> Option<ProgressBar> {
    None
}

/// The progress bar's methods the render calls, doing nothing: the library
/// builds without indicatif, and [`ProgressSink::Bar`] then draws nothing.
#[cfg(not(feature = "progress-bar"))]
struct NoProgressBar;

#[cfg(not(feature = "progress-bar"))]
impl NoProgressBar {
    fn inc(&self, _: u64) {}
    fn set_message(&self, _: String) {}
    fn finish_and_clear(&self) {}
}

mod trace;

#[cfg(test)]
mod cancel_tests;

#[cfg(test)]
mod sun_tests;

#[cfg(test)]
mod light_tests;

#[cfg(test)]
mod material_tests;

#[cfg(test)]
mod shading_tests;
