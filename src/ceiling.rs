//! `snell bench render`: the renderer against the Embree ceiling of its own
//! rays. A render's queries (every path segment or chord, every shadow ray;
//! see [`crate::integrator::RayRecorder`]) are recorded on a smaller render of the
//! same scene, then replayed through bare `rtcIntersect1` / `rtcOccluded1`
//! with no shading, on the same threads. The share of the ceiling is the
//! render's rate of those rays over the replay's rate:
//!
//! share = (samples/s × recorded rays per sample) ÷ replay rays/s.
//!
//! 1 would mean all the render's time is Embree's; the rest is snell's own
//! work (shading, sampling, the nested rule's bookkeeping, re-casts).
//! The same rays are also replayed in packets of eight (`rtcIntersect8` /
//! `rtcOccluded8`, incoherent): how much packets alone could buy.
//! Renders and replays are interleaved and each ratio is the median over
//! repetitions, with its range.
use crate::embree::{Packet8, RayPacket};
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
    /// Bare-Embree replay rays per second (median).
    pub replay_rays_per_s: f64,
    /// The same rays replayed in incoherent packets of eight (median): what
    /// packets alone could buy.
    pub packet_replay_rays_per_s: f64,
    /// samples/s × rays per sample ÷ replay rays/s, per repetition: median, min, max.
    pub share: [f64; 3],
    /// The same share from CPU times (render and replay threads), steadier
    /// on a shared machine; `None` where the kernel does not report them.
    pub share_cpu: Option<[f64; 3]>,
}

/// Replay `rays` through bare Embree on `pool`, one query per ray
/// (`rtcIntersect1` / `rtcOccluded1`, what the renderer does) or (`packets`)
/// in packets of eight consecutive rays of one kind (`rtcIntersect8` /
/// `rtcOccluded8`, incoherent: the log's order interleaves paths); returns
/// the wall time (s) and the CPU time of the pool's threads (s, if known).
fn replay(
    scene: &RenderScene,
    rays: &[RayQuery],
    pool: &rayon::ThreadPool,
    packets: bool,
) -> (f64, Option<f64>) {
    let t = Instant::now();
    let run = || -> u64 {
        rays.par_chunks(4096)
            .map(|chunk| {
                if packets {
                    return replay_packets(scene, chunk);
                }
                let mut n = 0u64;
                for q in chunk {
                    n += match q {
                        RayQuery::Nearest(r) => scene.embree.intersect(r).is_some() as u64,
                        RayQuery::Shadow(r) => scene.embree.occluded(r) as u64,
                    };
                }
                n
            })
            .sum()
    };
    let (hits, cpu) = crate::timing::on_pool(pool, || pool.install(run));
    std::hint::black_box(hits);
    (t.elapsed().as_secs_f64(), cpu)
}

/// The packet replay of one chunk: nearest and shadow rays gathered into two
/// packets of eight, each sent when full (and at the end).
fn replay_packets(scene: &RenderScene, chunk: &[RayQuery]) -> u64 {
    let (mut near, mut shadow) = (Packet8::new(), Packet8::new());
    let (mut nn, mut ns, mut hits) = (0usize, 0usize, 0u64);
    let mut flush = |p: &mut Packet8, k: &mut usize, occlusion: bool| {
        if occlusion {
            p.occlude(&scene.embree, false);
            hits += (0..*k).filter(|&i| p.occluded(i)).count() as u64;
        } else {
            p.intersect(&scene.embree, false);
            hits += (0..*k).filter(|&i| p.hit(i).is_some()).count() as u64;
        }
        p.clear();
        *k = 0;
    };
    for q in chunk {
        match q {
            RayQuery::Nearest(r) => {
                near.set_ray(nn, r);
                nn += 1;
                if nn == 8 {
                    flush(&mut near, &mut nn, false);
                }
            }
            RayQuery::Shadow(r) => {
                shadow.set_ray(ns, r);
                ns += 1;
                if ns == 8 {
                    flush(&mut shadow, &mut ns, true);
                }
            }
        }
    }
    if nn > 0 {
        flush(&mut near, &mut nn, false);
    }
    if ns > 0 {
        flush(&mut shadow, &mut ns, true);
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
        let (mut sps, mut qps, mut rps, mut share) = (vec![], vec![], vec![], vec![]);
        let mut pps = vec![];
        let mut share_cpu = Some(vec![]);
        for _ in 0..opts.reps.max(1) {
            let r = render(&scene, &settings, &ropts)?;
            let wall = r.stats.wall_s.max(1e-9);
            let s = r.stats.counters.samples as f64 / wall;
            let (replay_s, replay_cpu) = replay(&scene, &rays, &pool, false);
            pps.push(rays.len() as f64 / replay(&scene, &rays, &pool, true).0.max(1e-9));
            let rr = rays.len() as f64 / replay_s.max(1e-9);
            sps.push(s);
            qps.push(r.stats.counters.rays() as f64 / wall);
            rps.push(rr);
            share.push(s * rays_per_sample / rr);
            // Per CPU second: samples × rays per sample of the render ÷ rays of the replay.
            share_cpu = share_cpu
                .zip(r.stats.cpu_s.zip(replay_cpu))
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
            replay_rays_per_s: median(&rps),
            packet_replay_rays_per_s: median(&pps),
            share: median_min_max(&share),
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
        "render vs the Embree ceiling of its own rays ({w}x{h}, {spp} spp, {} threads, {} reps; rays recorded at {} spp; share = samples/s x rays per sample / bare-Embree replay rays/s, median (min-max))\n",
        opts.threads, opts.reps, opts.record_spp
    );
    s.push_str("| scene | samples/s | Embree queries/s (render) | rays/sample | replay rays/s | share of ceiling | share, CPU times | 8-packet replay rays/s |\n|---|---|---|---|---|---|---|---|\n");
    for r in runs {
        let cpu = r
            .share_cpu
            .map_or("-".into(), |c| format!("{:.2} ({:.2}-{:.2})", c[0], c[1], c[2]));
        s.push_str(&format!(
            "| {} | {:.3e} | {:.3e} | {:.2} | {:.3e} | {:.2} ({:.2}-{:.2}) | {cpu} | {:.3e} ({:.2}x) |\n",
            r.scene,
            r.samples_per_s,
            r.render_queries_per_s,
            r.rays_per_sample,
            r.replay_rays_per_s,
            r.share[0],
            r.share[1],
            r.share[2],
            r.packet_replay_rays_per_s,
            r.packet_replay_rays_per_s / r.replay_rays_per_s
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
