//! Benchmarks that report ratios measured in one run, with provenance:
//! - `embree_bare`: Embree's own speed on incoherent rays against two
//!   overlapping ~20k-triangle meshes, with no filter, an accept-all filter and
//!   a recording filter (the physical limit for everything else).
//! - `nested`: every nested-dielectric strategy on every nested scene and the
//!   no-overlap reference scenes, trace-only (a fixed set of rays taken from
//!   real refraction paths) and full render, repeats interleaved.
//! - `chord_sweep`: render time and image change against the chord tolerance
//!   of a gradient-index medium.
//! - `grin`: every curved-ray scene against its no-field twin (`grin.rs`).
//!
//! Conventions: times are wall-clock seconds; speeds are rays per second
//! (`rays_per_s`) or millions of rays per second where a name or a printed
//! column says Mrays/s; every figure of a repeated measurement is the median
//! over the repetitions. Ratios are written as `a / b` and say which way
//! means faster where they are defined. [`BareFigures`] prints itself
//! (`Display`, what `snell bench embree` prints) and [`nested_ratios`] formats
//! the table of `snell bench nested`.
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList, ListUpdateTimer, NestedStrategy};
use crate::embree::{BuildQuality, Device, FilterHit, HitFilter, SceneBuilder, SceneFlags};
use crate::error::Result;
use crate::integrator::{refraction_path, Tracer};
use crate::ray::Ray;
use crate::render::{render, RenderOptions, RenderSettings};
use crate::sampling::{uniform_sphere, Rng};
use crate::scene::{load_scene, meshgen, BuildOptions, RenderScene};
use crate::timing::{median, spread};
use glam::Vec3A as V3;
use std::path::Path;
use std::time::Instant;

mod grin;
pub use grin::{grin, grin_pairs, grin_table, GrinBenchOptions, GrinPair, GrinRun};

/// A benchmark's medians need at least one repetition.
fn at_least_one_rep(reps: usize) -> Result<()> {
    if reps == 0 {
        return Err(crate::Error::Invalid("reps must be at least 1".into()));
    }
    Ok(())
}

/// Figures of the bare-Embree benchmark (Mrays/s, one thread).
///
/// `Display` prints what `snell bench embree` prints: a header line and one
/// line per filter with its speed and its ratio to the no-filter speed
/// (filtered Mrays/s / unfiltered Mrays/s: < 1 means the filter costs speed).
#[derive(Debug, Clone)]
pub struct BareFigures {
    /// Triangles in the scene (the two meshes together).
    pub triangles: usize,
    /// Rays cast per repetition and configuration.
    pub rays: usize,
    /// Repetitions (each configuration once per repetition, interleaved).
    pub reps: usize,
    /// Closest hit with no filter: millions of rays per second (median).
    pub no_filter: f64,
    /// A context filter that accepts every hit: millions of rays per second (median).
    pub accept_all: f64,
    /// A context filter that records up to 32 hits and accepts them: millions
    /// of rays per second (median).
    pub recording: f64,
}

impl std::fmt::Display for BareFigures {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "bare Embree, 1 thread, {} incoherent rays against two overlapping meshes ({} triangles), median of {}:",
            self.rays, self.triangles, self.reps
        )?;
        writeln!(f, "  no filter          {:8.3} Mrays/s  1.000", self.no_filter)?;
        writeln!(
            f,
            "  accept-all filter  {:8.3} Mrays/s  {:.3}",
            self.accept_all,
            self.accept_all / self.no_filter
        )?;
        write!(
            f,
            "  recording filter   {:8.3} Mrays/s  {:.3}",
            self.recording,
            self.recording / self.no_filter
        )
    }
}

struct AcceptAll;
impl HitFilter for AcceptAll {
    #[inline]
    fn accept(&mut self, _: &FilterHit) -> bool {
        true
    }
}

struct Recording {
    hits: [(u32, f32); 32],
    n: usize,
}
impl HitFilter for Recording {
    #[inline]
    fn accept(&mut self, h: &FilterHit) -> bool {
        if self.n < 32 {
            self.hits[self.n] = (h.geom_id, h.t);
            self.n += 1;
        }
        true
    }
}

/// Bare Embree on `n_rays` incoherent rays, single thread, `reps` interleaved
/// repeats (at least 1), against two overlapping spheres of ~20k triangles
/// each; rays start at random points around them in random directions.
///
/// # Errors
///
/// [`crate::Error::Invalid`] when `reps` is 0; an Embree device, scene-build
/// or trace error.
pub fn embree_bare(n_rays: usize, reps: usize) -> Result<BareFigures> {
    at_least_one_rep(reps)?;
    // Two overlapping spheres of ~20k triangles each (lathe, 100 × 100).
    let profile: Vec<[f64; 2]> = (0..=100)
        .map(|i| {
            let a = std::f64::consts::PI * i as f64 / 100.0;
            [
                a.sin().abs().max(if i == 0 || i == 100 { 0.0 } else { 1e-9 }),
                -a.cos(),
            ]
        })
        .collect();
    let mut profile = profile;
    profile[0][0] = 0.0;
    profile[100][0] = 0.0;
    let sphere = meshgen::lathe(&profile, 100, meshgen::LatheShading::Flat);
    let shifted: Vec<[f32; 3]> = sphere
        .positions
        .iter()
        .map(|p| [p[0] + 0.6, p[1], p[2]])
        .collect();
    let device = Device::new("threads=1")?;
    let build = |flags: SceneFlags| -> Result<crate::embree::Scene> {
        let mut b = SceneBuilder::new(&device, flags, BuildQuality::Medium)?;
        b.add_triangles(&sphere.positions, &sphere.indices)?;
        b.add_triangles(&shifted, &sphere.indices)?;
        Ok(b.commit()?)
    };
    let plain = build(SceneFlags::default())?;
    let filtered = build(SceneFlags {
        context_filter: true,
        robust: false,
    })?;
    let mut rng = Rng::new(42);
    let rays: Vec<Ray> = (0..n_rays)
        .map(|_| {
            let o = V3::new(
                rng.uniform() * 3.0 - 1.2,
                rng.uniform() * 3.0 - 1.5,
                rng.uniform() * 3.0 - 1.5,
            );
            Ray::new(o, uniform_sphere(rng.uniform(), rng.uniform()))
        })
        .collect();
    let (mut a, mut b, mut c) = (vec![], vec![], vec![]);
    let mut sink = 0u64;
    for _ in 0..reps {
        let t = Instant::now();
        for r in &rays {
            sink += plain.intersect(r).map(|h| h.geom_id as u64).unwrap_or(7);
        }
        a.push(n_rays as f64 / t.elapsed().as_secs_f64() / 1e6);
        let t = Instant::now();
        for r in &rays {
            sink += filtered
                .intersect_filtered(r, &mut AcceptAll)?
                .map(|h| h.geom_id as u64)
                .unwrap_or(7);
        }
        b.push(n_rays as f64 / t.elapsed().as_secs_f64() / 1e6);
        let t = Instant::now();
        for r in &rays {
            let mut rec = Recording {
                hits: [(0, 0.0); 32],
                n: 0,
            };
            sink += filtered
                .intersect_filtered(r, &mut rec)?
                .map(|h| h.geom_id as u64)
                .unwrap_or(7);
            sink += rec.n as u64;
        }
        c.push(n_rays as f64 / t.elapsed().as_secs_f64() / 1e6);
    }
    std::hint::black_box(sink);
    Ok(BareFigures {
        triangles: sphere.indices.len() * 2,
        rays: n_rays,
        reps,
        no_filter: median(&a),
        accept_all: median(&b),
        recording: median(&c),
    })
}

/// The nested scenes (overlapping solids with priorities), by name in `scenes/`.
pub const NESTED_SCENES: [&str; 5] = [
    "nested_spheres_a",
    "nested_spheres_b",
    "glass_of_water_nested",
    "glass_ice_bubbles",
    "deep_nesting",
];
/// The no-overlap reference scenes, by name in `scenes/`.
pub const REFERENCE_SCENES: [&str; 3] = ["three_spheres", "glass_of_water", "cylinder_refraction"];

/// A fixed ray with the interior list at its origin.
#[derive(Clone)]
pub struct ListedRay {
    /// The ray.
    pub ray: Ray,
    /// Solid indices (into `RenderScene::solids`) containing the ray's origin.
    pub list: Vec<u32>,
}

/// Rays of real refraction paths through `scene` (always refracting, from a
/// `w`×`h` grid of camera rays): the camera rays and every continuation
/// (paths of at most 24 events, traced with the filter strategy).
///
/// # Errors
///
/// An error of a traced path (Embree failing to trace).
pub fn path_rays(scene: &RenderScene, w: u32, h: u32) -> Result<Vec<ListedRay>> {
    let mut out = Vec::new();
    let mut c = Counters::default();
    let cam = scene.camera.with_resolution(w, h);
    for y in 0..h {
        for x in 0..w {
            let (o, d) = cam.ray(x as f32 + 0.5, y as f32 + 0.5, (0.5, 0.5));
            out.push(ListedRay {
                ray: Ray::new(o, d),
                list: scene.camera_interior.clone(),
            });
            let tr = Tracer::new(scene);
            let p = refraction_path(tr, o, d, &scene.camera_interior, 24, &mut c)?;
            for e in &p.events {
                out.push(ListedRay {
                    ray: Ray {
                        tnear: e.next_tnear,
                        ..Ray::new(e.next_org, e.next_dir)
                    },
                    list: e.list_after.clone(),
                });
            }
        }
    }
    Ok(out)
}

/// One measured run: a scene, a strategy and a mode, over all repetitions
/// (serialised as is in `snell bench nested --json`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct NestedRun {
    /// Scene name (the TOML file's stem).
    pub scene: String,
    /// Strategy name: `filter`, `recast`, `toggle` or `off`.
    pub strategy: String,
    /// `trace` (the fixed set of [`path_rays`], one thread, no shading) or
    /// `render` (a full render at [`NestedBenchOptions::render`]).
    pub mode: String,
    /// Rays per second: `rays` / `wall_s`.
    pub rays_per_s: f64,
    /// False hits skipped per ray (trace) or per scene query (render), from
    /// the last repetition (the same in every repetition).
    pub false_hits_per_ray: f64,
    /// Median wall time of one repetition (seconds; in trace mode, per pass
    /// over the ray set: a repetition makes [`TRACE_RAYS_PER_REP`] rays'
    /// worth of passes).
    pub wall_s: f64,
    /// Number of repetitions the median is over.
    pub median_of: usize,
    /// Fastest and slowest of the repetitions (seconds).
    pub spread_s: [f64; 2],
    /// Rays of one repetition (trace: the ray set; render: rays cast).
    pub rays: u64,
    /// Samples per second (render mode only).
    pub samples_per_s: Option<f64>,
    /// Wall time of every repetition (repetition k of every strategy ran
    /// back to back, in an order that rotates with k, so per-repetition
    /// ratios compare runs that saw the same machine load).
    pub walls: Vec<f64>,
    /// CPU time of every repetition (seconds), in the order of `walls`;
    /// empty where the kernel does not report it. Ratios are taken from
    /// these when present: on a shared machine a run that waits for the
    /// processor loses wall time, not CPU time.
    pub cpus: Vec<f64>,
    /// Trace mode, filter only: the share of the trace time spent applying
    /// false hits to interior lists (the paper's "list updates" statistic),
    /// from one extra timed pass ([`dielectric::trace_timing_list_updates`],
    /// the clock's own cost subtracted) over the median wall time.
    pub list_update_share: Option<f64>,
}

/// The mean duration an empty interval between two clock reads measures (s):
/// the bias of each interval [`dielectric::ListUpdateTimer`] times.
pub fn clock_pair_s() -> f64 {
    let n = 100_000;
    let mut acc = 0.0;
    for _ in 0..n {
        let t0 = Instant::now();
        acc += std::hint::black_box(t0).elapsed().as_secs_f64();
    }
    acc / n as f64
}

/// Rays a trace-mode repetition casts at least: the ray set is passed over
/// as many times as it takes, so that a repetition lasts tens of
/// milliseconds (one pass of a small ray set is too short to resolve the
/// percent the no-overlap scenes are judged by).
pub const TRACE_RAYS_PER_REP: usize = 250_000;

/// `passes` passes of `strategy` over `rays` on the calling thread: the
/// wall time and CPU time (`None` where the clock fails) per pass, and the
/// counters of one pass. With `timer`, the filter's list updates are timed
/// into it.
fn trace_only(
    scene: &RenderScene,
    strategy: NestedStrategy,
    rays: &[ListedRay],
    passes: usize,
    mut timer: Option<&mut ListUpdateTimer>,
) -> Result<(f64, Option<f64>, Counters)> {
    let mut c = Counters::default();
    let passes = passes.max(1);
    let t = Instant::now();
    let (sink, cpu) = crate::timing::on_this_thread(|| -> Result<u64> {
        let mut sink = 0u64;
        for _ in 0..passes {
            c = Counters::default();
            for r in rays {
                let mut list = InteriorList::from_solids(&scene.solids, &r.list);
                let h = match timer.as_deref_mut() {
                    Some(timer) => dielectric::trace_timing_list_updates(
                        scene, strategy, &r.ray, &mut list, &mut c, timer,
                    )?,
                    None => dielectric::trace(scene, strategy, &r.ray, &mut list, &mut c)?,
                };
                sink += h.map(|h| h.hit.geom_id as u64).unwrap_or(3) + list.len() as u64;
            }
        }
        Ok(sink)
    });
    std::hint::black_box(sink?);
    let n = passes as f64;
    Ok((t.elapsed().as_secs_f64() / n, cpu.map(|x| x / n), c))
}

/// Options of the nested benchmark (the default: every nested and reference
/// scene in `scenes/`, 5 repetitions, one thread).
#[derive(Debug, Clone)]
pub struct NestedBenchOptions {
    /// Directory holding `NAME.toml` for every name of `scenes`.
    pub scenes_dir: std::path::PathBuf,
    /// Repetitions (at least 1); every strategy runs once per repetition,
    /// back to back.
    pub reps: usize,
    /// Width and height of the camera-ray grid the trace-only rays start from.
    pub trace_grid: (u32, u32),
    /// Rays a trace-mode repetition casts at least (whole passes over the
    /// ray set; 0: one pass). Default [`TRACE_RAYS_PER_REP`].
    pub trace_rays_per_rep: usize,
    /// Width, height and samples per pixel of the render mode (seed 1).
    pub render: (u32, u32, u32),
    /// Render threads (trace-only runs on the calling thread).
    pub threads: usize,
    /// Scene names (without `.toml`).
    pub scenes: Vec<String>,
    /// Strategies to run (the ratio table needs all four; with fewer, each
    /// run's speed is listed instead). For profiling one strategy alone.
    pub strategies: Vec<NestedStrategy>,
    /// Run the trace-only mode.
    pub trace: bool,
    /// Run the render mode.
    pub render_mode: bool,
}

impl Default for NestedBenchOptions {
    fn default() -> Self {
        NestedBenchOptions {
            scenes_dir: "scenes".into(),
            reps: 5,
            trace_grid: (160, 120),
            trace_rays_per_rep: TRACE_RAYS_PER_REP,
            render: (160, 120, 8),
            threads: 1,
            scenes: NESTED_SCENES
                .iter()
                .chain(REFERENCE_SCENES.iter())
                .map(|s| s.to_string())
                .collect(),
            strategies: vec![
                NestedStrategy::Filter,
                NestedStrategy::Recast,
                NestedStrategy::Toggle,
                NestedStrategy::Off,
            ],
            trace: true,
            render_mode: true,
        }
    }
}

/// Run the nested benchmark; returns every run (medians over interleaved
/// repeats): per scene, filter, recast, toggle and off in trace mode then
/// render mode. `progress` receives a line per scene.
///
/// # Errors
///
/// [`crate::Error::Invalid`] when `reps` is 0; a scene that does not load or
/// build; a render or trace error.
pub fn nested(opts: &NestedBenchOptions, mut progress: impl FnMut(&str)) -> Result<Vec<NestedRun>> {
    at_least_one_rep(opts.reps)?;
    if opts.strategies.is_empty() || !(opts.trace || opts.render_mode) {
        return Err(crate::Error::Invalid(
            "bench nested: at least one strategy and one mode (trace, render)".into(),
        ));
    }
    let strategies = &opts.strategies[..];
    let mut runs = Vec::new();
    for name in &opts.scenes {
        let path = opts.scenes_dir.join(format!("{name}.toml"));
        // One scene for every strategy: the context-filter flag is set
        // whenever solids overlap and costs the others nothing.
        let scene = load_scene(Path::new(&path), &BuildOptions::default())?;
        let settings = RenderSettings::from_scene(&scene)
            .with_resolution(opts.render.0, opts.render.1)?
            .with_spp(opts.render.2)
            .with_seed(1);
        let rays = if opts.trace {
            path_rays(&scene, opts.trace_grid.0, opts.trace_grid.1)?
        } else {
            Vec::new()
        };
        let passes = opts.trace_rays_per_rep.div_ceil(rays.len().max(1)).max(1);
        progress(&format!(
            "{name}: {} trace rays, {passes} passes per repetition",
            rays.len()
        ));
        let mut trace_t = vec![vec![]; strategies.len()];
        let mut trace_cpu: Vec<Vec<Option<f64>>> = vec![vec![]; strategies.len()];
        let mut render_cpu: Vec<Vec<Option<f64>>> = vec![vec![]; strategies.len()];
        let mut trace_c = vec![Counters::default(); strategies.len()];
        let mut render_t = vec![vec![]; strategies.len()];
        let mut render_stats = vec![None; strategies.len()];
        for rep in 0..opts.reps {
            // The order rotates with the repetition: whichever strategy runs
            // first after the scene load or the previous render meets cold
            // caches, which shows where all four run the same plain query.
            let order = |k: usize| (k + rep) % strategies.len();
            for k in (0..strategies.len()).map(order).filter(|_| opts.trace) {
                let (t, cpu, c) = trace_only(&scene, strategies[k], &rays, passes, None)?;
                trace_t[k].push(t);
                trace_cpu[k].push(cpu);
                trace_c[k] = c;
            }
            for k in (0..strategies.len()).map(order).filter(|_| opts.render_mode) {
                let s = strategies[k];
                let r = render(
                    &scene,
                    &settings.with_strategy(s),
                    &RenderOptions {
                        threads: Some(opts.threads),
                        ..RenderOptions::default()
                    },
                )?;
                render_t[k].push(r.stats.wall_s);
                render_cpu[k].push(r.stats.cpu_s);
                render_stats[k] = Some(r.stats);
            }
        }
        // The paper's statistic, from one extra pass with the list updates timed.
        let update_s = if opts.trace && strategies.contains(&NestedStrategy::Filter) {
            let mut timer = ListUpdateTimer::default();
            trace_only(&scene, NestedStrategy::Filter, &rays, 1, Some(&mut timer))?;
            (timer.seconds - timer.count as f64 * clock_pair_s()).max(0.0)
        } else {
            0.0
        };
        // Every repetition's CPU time, or none.
        let all = |v: &[Option<f64>]| {
            v.iter()
                .copied()
                .collect::<Option<Vec<f64>>>()
                .unwrap_or_default()
        };
        for (k, s) in strategies.iter().enumerate() {
            if opts.trace {
                let wall = median(&trace_t[k]);
                runs.push(NestedRun {
                    scene: name.clone(),
                    strategy: s.name().into(),
                    mode: "trace".into(),
                    rays_per_s: rays.len() as f64 / wall,
                    false_hits_per_ray: trace_c[k].false_hits as f64 / rays.len() as f64,
                    wall_s: wall,
                    median_of: opts.reps,
                    spread_s: spread(&trace_t[k]),
                    rays: rays.len() as u64,
                    samples_per_s: None,
                    walls: trace_t[k].clone(),
                    cpus: all(&trace_cpu[k]),
                    list_update_share: (*s == NestedStrategy::Filter).then(|| update_s / wall),
                });
            }
            if !opts.render_mode {
                continue;
            }
            let wall = median(&render_t[k]);
            let st = render_stats[k].expect("at least one repeat");
            runs.push(NestedRun {
                scene: name.clone(),
                strategy: s.name().into(),
                mode: "render".into(),
                rays_per_s: st.counters.rays() as f64 / wall,
                false_hits_per_ray: st.counters.false_hits as f64 / st.counters.queries.max(1) as f64,
                wall_s: wall,
                median_of: opts.reps,
                spread_s: spread(&render_t[k]),
                rays: st.counters.rays(),
                samples_per_s: Some(st.counters.samples as f64 / wall),
                walls: render_t[k].clone(),
                cpus: all(&render_cpu[k]),
                list_update_share: None,
            });
        }
    }
    Ok(runs)
}

/// Speed ratio `other / filter` per interleaved repetition: (median, min,
/// max), from wall times in seconds (so > 1 means filter is faster). A ratio
/// whose range straddles 1 is within noise. NaNs when there are no
/// repetitions.
pub fn ratio_spread(filter: &[f64], other: &[f64]) -> (f64, f64, f64) {
    let r: Vec<f64> = filter.iter().zip(other).map(|(f, o)| o / f.max(1e-12)).collect();
    let [m, lo, hi] = crate::timing::median_min_max(&r);
    (m, lo, hi)
}

/// Ratio tables: filter/recast and filter/off, per scene and mode, each as
/// the median of per-repetition ratios with its range; `~` marks a ratio
/// whose range includes 1 (the two strategies are within noise of each
/// other). First from CPU times (where every run has them: steady on a
/// shared machine), then from wall times. Speeds in Mrays/s (wall); ratios
/// are time of the other strategy / time of filter (> 1 means filter is
/// faster). One line per scene and mode, with a header and a closing legend
/// line per table; every line ends in a newline. A scene lacking one of the
/// four strategies in a mode is left out.
pub fn nested_ratios(runs: &[NestedRun]) -> String {
    let mut out = String::new();
    if runs
        .iter()
        .all(|r| !r.cpus.is_empty() && r.cpus.len() == r.walls.len())
    {
        out.push_str("ratios of CPU times:\n");
        out.push_str(&ratio_table(runs, |r| &r.cpus));
        out.push_str("ratios of wall times:\n");
    }
    out.push_str(&ratio_table(runs, |r| &r.walls));
    out
}

/// [`nested_ratios`]' table with the per-repetition times `times` picks.
fn ratio_table(runs: &[NestedRun], times: impl Fn(&NestedRun) -> &Vec<f64>) -> String {
    let mut out = String::from(
        "scene                   mode    filter Mrays/s  recast  toggle  off   filter/recast (min-max)   filter/off (min-max)      false hits/ray  list upd\n",
    );
    let mut scenes: Vec<&str> = runs.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    let fmt = |(m, lo, hi): (f64, f64, f64)| {
        let tilde = if lo <= 1.0 && hi >= 1.0 { "~" } else { " " };
        format!("{tilde}{m:>6.3} ({lo:.3}-{hi:.3})")
    };
    for s in scenes {
        for mode in ["trace", "render"] {
            // Render speed is compared by wall time (the same samples for all).
            let get = |st: &str| {
                runs.iter()
                    .find(|r| r.scene == s && r.mode == mode && r.strategy == st)
            };
            let (Some(f), Some(rc), Some(tg), Some(off)) =
                (get("filter"), get("recast"), get("toggle"), get("off"))
            else {
                // Fewer strategies than the ratios need: their speeds alone.
                for r in runs.iter().filter(|r| r.scene == s && r.mode == mode) {
                    out.push_str(&format!(
                        "{s:<23} {mode:<7} {:<7} {:>8.3} Mrays/s, median of {} ({:.4}-{:.4} s)\n",
                        r.strategy,
                        r.rays_per_s / 1e6,
                        r.median_of,
                        r.spread_s[0],
                        r.spread_s[1]
                    ));
                }
                continue;
            };
            out.push_str(&format!(
                "{s:<23} {mode:<7} {:>13.3} {:>7.3} {:>7.3} {:>6.3} {:>24} {:>24} {:>15.3} {:>9}\n",
                f.rays_per_s / 1e6,
                rc.rays_per_s / 1e6,
                tg.rays_per_s / 1e6,
                off.rays_per_s / 1e6,
                fmt(ratio_spread(times(f), times(rc))),
                fmt(ratio_spread(times(f), times(off))),
                f.false_hits_per_ray,
                f.list_update_share
                    .map_or("-".into(), |x| format!("{:.3}%", 100.0 * x))
            ));
        }
    }
    out.push_str("(speed ratios: time of the other strategy / time of filter, median over interleaved repetitions with their range; > 1 means filter is faster; ~ = within noise; list upd = share of the filter's trace time spent applying false hits to interior lists)\n");
    out
}

/// One render of a chord-tolerance sweep.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ChordRun {
    /// The medium's chord tolerance (chord–arc deviation, metres).
    pub tolerance: f64,
    /// Render wall time (seconds).
    pub wall_s: f64,
    /// Rays per second of the render.
    pub rays_per_s: f64,
    /// Straight chords cast per path segment.
    pub chords_per_segment: f64,
    /// RMSE of linear RGB against the finest tolerance's render (same pixels,
    /// same random numbers: only the chords differ).
    pub rmse: f64,
    /// Share of pixels differing by more than 0.05 in some channel.
    pub changed: f64,
}

/// Render `scene` (which must have a `[medium]`) at each chord tolerance and
/// compare every image with the render at the last (finest) one. The
/// scene's medium is restored afterwards.
///
/// # Errors
///
/// [`crate::Error::Invalid`] when the scene has no `[medium]` or a tolerance
/// is not a valid medium tolerance (finite, > 0); a render error.
pub fn chord_sweep(
    scene: &mut RenderScene,
    settings: &RenderSettings,
    tolerances: &[f64],
    threads: Option<usize>,
) -> Result<Vec<ChordRun>> {
    let Some(m0) = scene.medium.clone() else {
        return Err(crate::Error::Invalid(
            "chord sweep: the scene has no [medium]".into(),
        ));
    };
    let mut images = Vec::new();
    for &tol in tolerances {
        // Metres bound the ray-equation methods' chords; `invariant` chords
        // follow the pixel footprint instead, so its media are swept as rk45.
        let method = match m0.method() {
            crate::media::Method::Invariant => crate::media::Method::Rk45,
            other => other,
        };
        let m = m0
            .retuned(method, tol)
            .map_err(|e| crate::Error::Invalid(format!("chord sweep: {e:?}")))?;
        scene.medium = Some(m);
        let r = crate::render::render(
            scene,
            settings,
            &crate::render::RenderOptions {
                threads,
                ..Default::default()
            },
        )?;
        images.push(r);
    }
    scene.medium = Some(m0);
    let reference = images.last().map(|r| r.pixels.clone()).unwrap_or_default();
    Ok(tolerances
        .iter()
        .zip(&images)
        .map(|(&tolerance, r)| {
            let mut se = 0.0f64;
            let mut changed = 0usize;
            for (a, b) in r.pixels.iter().zip(&reference) {
                let d = *a - *b;
                se += (d * d).element_sum() as f64;
                if d.abs().max_element() > 0.05 {
                    changed += 1;
                }
            }
            let n = reference.len().max(1) as f64;
            ChordRun {
                tolerance,
                wall_s: r.stats.wall_s,
                rays_per_s: r.stats.counters.rays() as f64 / r.stats.wall_s.max(1e-12),
                chords_per_segment: r.stats.counters.chords as f64 / r.stats.counters.segments.max(1) as f64,
                rmse: (se / (3.0 * n)).sqrt(),
                changed: changed as f64 / n,
            }
        })
        .collect())
}

#[cfg(test)]
mod ratio_tests {
    use super::{nested_ratios, ratio_spread, NestedRun};

    fn run(strategy: &str, walls: &[f64], cpus: &[f64]) -> NestedRun {
        NestedRun {
            scene: "s".into(),
            strategy: strategy.into(),
            mode: "trace".into(),
            rays_per_s: 1.0,
            false_hits_per_ray: 0.0,
            wall_s: walls[0],
            median_of: walls.len(),
            spread_s: [walls[0], walls[0]],
            rays: 1,
            samples_per_s: None,
            walls: walls.to_vec(),
            cpus: cpus.to_vec(),
            list_update_share: None,
        }
    }

    /// The first table's ratios come from CPU times, the second's from wall
    /// times; without CPU times for every run, only the wall table.
    #[test]
    fn ratio_tables_take_cpu_times_first() {
        let runs = vec![
            run("filter", &[1.0, 1.0, 1.0], &[1.0, 1.0, 1.0]),
            run("recast", &[1.0, 1.1, 0.9], &[2.0, 2.0, 2.0]),
            run("toggle", &[1.0, 1.0, 1.0], &[2.0, 2.0, 2.0]),
            run("off", &[0.5, 0.5, 0.5], &[0.8, 0.8, 0.8]),
        ];
        let t = nested_ratios(&runs);
        let (cpu, wall) = t.split_once("ratios of wall times:").expect("two tables");
        assert!(cpu.contains("ratios of CPU times"), "{t}");
        assert!(
            cpu.contains(" 2.000 (2.000-2.000)") && cpu.contains(" 0.800 (0.800-0.800)"),
            "{t}"
        );
        assert!(
            wall.contains("~ 1.000 (0.900-1.100)") && wall.contains(" 0.500 (0.500-0.500)"),
            "{t}"
        );
        let mut no_cpu = runs.clone();
        no_cpu[1].cpus.clear();
        let t = nested_ratios(&no_cpu);
        assert!(!t.contains("CPU") && t.contains("~ 1.000 (0.900-1.100)"), "{t}");
    }

    #[test]
    fn per_repetition_ratios_and_their_range() {
        let (m, lo, hi) = ratio_spread(&[1.0, 2.0, 1.0], &[2.0, 2.0, 1.5]);
        assert_eq!((m, lo, hi), (1.5, 1.0, 2.0));
    }
}
