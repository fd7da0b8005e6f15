//! `snell bench render`: the renderer against the Embree ceiling of its own
//! rays. A render's queries (every path segment or chord, every shadow ray;
//! see [`crate::integrator::RayRecorder`]) are recorded on a smaller render of the
//! same scene, each thread's in its order, then replayed through bare
//! Embree with no shading, on the same threads, in the fastest mode for
//! each: the coherent rays (a pixel's camera rays and their smooth
//! continuations, [`RayQuery::Coherent`]) in coherent packets of the native
//! width (`rtcIntersect16` with AVX-512, else `8`), the others through
//! `rtcIntersect1` / `rtcOccluded1` (incoherent packets are slower than
//! single rays). The share of the ceiling is the render's rate of those
//! rays over the replay's rate:
//!
//! share = (samples/s × recorded rays per sample) ÷ ceiling rays/s.
//!
//! 1 would mean all the render's time is Embree's; the rest is snell's own
//! work (shading, sampling, the nested rule's bookkeeping, re-casts).
//! The share of an all-single-ray replay is reported beside it, and how
//! many more rays hit in one replay than in the other (0 unless rays graze
//! edges that packets and single rays decide apart).
//! Renders and replays are interleaved and each ratio is the median over
//! repetitions, with its range.
use crate::embree::{Packet16, Packet8, RayPacket};
use crate::error::Result;
use crate::integrator::{RayQuery, RayRecorder};
use crate::render::{render, RenderOptions, RenderSettings};
use crate::scene::{load_scene, BuildOptions, RenderScene};
use crate::timing::{median, median_min_max};
use rayon::prelude::*;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// What to measure.
#[derive(Debug, Clone)]
pub struct CeilingOptions {
    /// Directory of the scene files.
    pub scenes_dir: std::path::PathBuf,
    /// Scene names (files `NAME.toml`).
    pub scenes: Vec<String>,
    /// Film width, height and samples per pixel of the timed renders.
    pub render: (u32, u32, u32),
    /// Samples per pixel of the recording render (its rays are replayed).
    pub record_spp: u32,
    /// Threads of the renders and the replays.
    pub threads: usize,
    /// Interleaved repetitions (render, replay).
    pub reps: usize,
}

/// One scene's figures.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CeilingRun {
    /// Scene name.
    pub scene: String,
    /// Render samples per second (median).
    pub samples_per_s: f64,
    /// Embree queries of the render per second, re-casts included (median).
    pub render_queries_per_s: f64,
    /// Recorded rays (segments, chords, shadow rays) per sample.
    pub rays_per_sample: f64,
    /// The share of them that are coherent ([`RayQuery::Coherent`]).
    pub coherent_share: f64,
    /// How many more rays hit in one replay than in the other (0 unless a
    /// ray grazes an edge that packets and single rays decide apart).
    pub hits_differ: u64,
    /// Bare-Embree replay, one ray at a time: rays per second (median).
    pub replay_rays_per_s: f64,
    /// Bare-Embree replay in the fastest mode for each ray (coherent rays in
    /// coherent packets of the native width, the others one at a time):
    /// rays per second (median). The ceiling.
    pub best_replay_rays_per_s: f64,
    /// samples/s × rays per sample ÷ single-ray replay rays/s, per
    /// repetition: median, min, max.
    pub share_single: [f64; 3],
    /// samples/s × rays per sample ÷ the ceiling's rays/s (the fastest
    /// mode), per repetition: median, min, max.
    pub share: [f64; 3],
    /// `share` from CPU times (render and replay threads), steadier on a
    /// shared machine; `None` where the kernel does not report them.
    pub share_cpu: Option<[f64; 3]>,
}

/// How a replay sends the recorded rays to Embree.
#[derive(Debug, Clone, Copy)]
enum Replay {
    /// One query per ray (`rtcIntersect1` / `rtcOccluded1`).
    Single,
    /// The fastest mode for each ray: the coherent ones
    /// ([`RayQuery::Coherent`]) in coherent packets of `lanes` (the native
    /// width), in the order a thread asked them; the others one by one.
    Best { lanes: usize },
}

/// Replay `rays` through bare Embree on `pool` as `mode` says; returns the
/// rays that hit, the wall time (s) and the CPU time of the pool's threads
/// (s, if known).
fn replay(
    scene: &RenderScene,
    rays: &[RayQuery],
    pool: &rayon::ThreadPool,
    mode: Replay,
) -> (u64, f64, Option<f64>) {
    let t = Instant::now();
    let run = || -> u64 {
        rays.par_chunks(4096)
            .map(|chunk| match mode {
                Replay::Single => chunk.iter().map(|q| replay_one(scene, q)).sum(),
                Replay::Best { lanes: 16 } => replay_best::<16, Packet16>(scene, chunk),
                Replay::Best { .. } => replay_best::<8, Packet8>(scene, chunk),
            })
            .sum()
    };
    let (hits, cpu) = crate::timing::on_pool(pool, || pool.install(run));
    (hits, t.elapsed().as_secs_f64(), cpu)
}

/// One ray by itself: 1 if it hit (or is occluded).
fn replay_one(scene: &RenderScene, q: &RayQuery) -> u64 {
    match q {
        RayQuery::Nearest(r) | RayQuery::Coherent(r) => scene.embree.intersect(r).is_some() as u64,
        RayQuery::Shadow(r) => scene.embree.occluded(r) as u64,
    }
}

/// [`Replay::Best`] of one chunk: its coherent rays gathered into coherent
/// packets of `N`, each sent when full (and at the end), the others one by
/// one; returns the rays that hit.
fn replay_best<const N: usize, P: RayPacket<N> + Default>(scene: &RenderScene, chunk: &[RayQuery]) -> u64 {
    let mut packet = P::default();
    let (mut k, mut hits) = (0usize, 0u64);
    let flush = |p: &mut P, k: &mut usize| {
        p.intersect(&scene.embree, true);
        let h = (0..*k).filter(|&i| p.hit(i).is_some()).count() as u64;
        p.clear();
        *k = 0;
        h
    };
    for q in chunk {
        match q {
            RayQuery::Coherent(r) => {
                packet.set_ray(k, r);
                k += 1;
                if k == N {
                    hits += flush(&mut packet, &mut k);
                }
            }
            other => hits += replay_one(scene, other),
        }
    }
    if k > 0 {
        hits += flush(&mut packet, &mut k);
    }
    hits
}

/// Measure every scene of `opts`; `progress` gets a line per step.
///
/// # Errors
/// A scene that does not load or render, or threads that cannot start.
pub fn ceiling(opts: &CeilingOptions, mut progress: impl FnMut(&str)) -> Result<Vec<CeilingRun>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()
        .map_err(|e| crate::Error::Invalid(format!("cannot start threads: {e}")))?;
    let ropts = RenderOptions {
        threads: Some(opts.threads),
        ..RenderOptions::default()
    };
    let mut out = Vec::new();
    for name in &opts.scenes {
        let scene = load_scene(
            &opts.scenes_dir.join(format!("{name}.toml")),
            &BuildOptions::default(),
        )?;
        let (w, h, spp) = opts.render;
        let settings = RenderSettings::from_scene(&scene)
            .with_resolution(w, h)?
            .with_spp(spp)
            .with_seed(1);
        // Record the rays of a smaller render of the same film.
        let recorder = Arc::new(RayRecorder::new());
        let recording = RenderOptions {
            observer: Some(recorder.clone()),
            ..ropts.clone()
        };
        let rec = render(&scene, &settings.with_spp(opts.record_spp.max(1)), &recording)?;
        let rays = recorder.take();
        let rays_per_sample = rays.len() as f64 / rec.stats.counters.samples.max(1) as f64;
        progress(&format!(
            "{name}: {} rays recorded ({rays_per_sample:.2} per sample)",
            rays.len()
        ));
        let best = Replay::Best {
            lanes: crate::render::PacketWidth::Auto.lanes(scene.embree.device()),
        };
        let coherent = rays.iter().filter(|q| matches!(q, RayQuery::Coherent(_))).count();
        let (mut sps, mut qps, mut rps, mut bps) = (vec![], vec![], vec![], vec![]);
        let (mut share, mut share_best) = (vec![], vec![]);
        let mut share_cpu = Some(vec![]);
        let mut hits_differ = 0u64;
        for _ in 0..opts.reps.max(1) {
            let r = render(&scene, &settings, &ropts)?;
            let wall = r.stats.wall_s.max(1e-9);
            let s = r.stats.counters.samples as f64 / wall;
            let (single_hits, replay_s, _) = replay(&scene, &rays, &pool, Replay::Single);
            let (best_hits, best_s, best_cpu) = replay(&scene, &rays, &pool, best);
            // Both modes ask the same queries of the same scene: they may
            // differ only where a ray grazes an edge (reported, not hidden).
            hits_differ = hits_differ.max(single_hits.abs_diff(best_hits));
            let rr = rays.len() as f64 / replay_s.max(1e-9);
            let br = rays.len() as f64 / best_s.max(1e-9);
            sps.push(s);
            qps.push(r.stats.counters.rays() as f64 / wall);
            rps.push(rr);
            bps.push(br);
            share.push(s * rays_per_sample / rr);
            share_best.push(s * rays_per_sample / br);
            // Per CPU second: samples × rays per sample of the render ÷ rays of the replay.
            share_cpu = share_cpu
                .zip(r.stats.cpu_s.zip(best_cpu))
                .map(|(mut v, (rc, pc))| {
                    let render_rays_per_cpu_s =
                        r.stats.counters.samples as f64 * rays_per_sample / rc.max(1e-9);
                    v.push(render_rays_per_cpu_s / (rays.len() as f64 / pc.max(1e-9)));
                    v
                });
        }
        let run = CeilingRun {
            scene: name.clone(),
            samples_per_s: median(&sps),
            render_queries_per_s: median(&qps),
            rays_per_sample,
            coherent_share: coherent as f64 / rays.len().max(1) as f64,
            hits_differ,
            replay_rays_per_s: median(&rps),
            best_replay_rays_per_s: median(&bps),
            share_single: median_min_max(&share),
            share: median_min_max(&share_best),
            share_cpu: share_cpu.map(|v| median_min_max(&v)),
        };
        progress(&format!("{name}: share of the ceiling {:.2}", run.share[0]));
        out.push(run);
    }
    Ok(out)
}

/// The table `snell bench render` prints.
pub fn table(runs: &[CeilingRun], opts: &CeilingOptions) -> String {
    let (w, h, spp) = opts.render;
    let mut s = format!(
        "render vs the Embree ceiling of its own rays ({w}x{h}, {spp} spp, {} threads, {} reps; rays recorded at {} spp; ceiling = bare-Embree replay of those rays, the coherent ones in coherent native-width packets, the others one by one; share = samples/s x rays per sample / ceiling rays/s, median (min-max))\n",
        opts.threads, opts.reps, opts.record_spp
    );
    s.push_str("| scene | samples/s | Embree queries/s (render) | rays/sample | coherent | ceiling rays/s (packets + single) | share of ceiling | share, CPU times | single-ray replay rays/s | share of single-ray replay | hits differ |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in runs {
        let cpu = r
            .share_cpu
            .map_or("-".into(), |c| format!("{:.2} ({:.2}-{:.2})", c[0], c[1], c[2]));
        s.push_str(&format!(
            "| {} | {:.3e} | {:.3e} | {:.2} | {:.2} | {:.3e} | {:.2} ({:.2}-{:.2}) | {cpu} | {:.3e} | {:.2} ({:.2}-{:.2}) | {} |\n",
            r.scene,
            r.samples_per_s,
            r.render_queries_per_s,
            r.rays_per_sample,
            r.coherent_share,
            r.best_replay_rays_per_s,
            r.share[0],
            r.share[1],
            r.share[2],
            r.replay_rays_per_s,
            r.share_single[0],
            r.share_single[1],
            r.share_single[2],
            r.hits_differ,
        ));
    }
    s
}

/// The default scene set: the reference scenes and the nested ones.
pub fn default_scenes() -> Vec<String> {
    [
        "three_spheres",
        "glass_of_water",
        "cylinder_refraction",
        "glass_of_water_nested",
        "glass_ice_bubbles",
        "deep_nesting",
        "nested_spheres_a",
    ]
    .map(String::from)
    .to_vec()
}

/// Defaults: 320x240, 16 spp timed, 4 spp recorded, 2 threads, 3 reps.
impl Default for CeilingOptions {
    fn default() -> Self {
        CeilingOptions {
            scenes_dir: Path::new("scenes").to_path_buf(),
            scenes: default_scenes(),
            render: (320, 240, 16),
            record_spp: 4,
            threads: 2,
            reps: 3,
        }
    }
}
