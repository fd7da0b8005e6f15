//! `cargo bench --bench warp [-- --json FILE]`: the refraction warp's speed
//! against its error. Every speed is a ratio measured in this run, beside
//! the machine, commit and Embree version; repetitions are interleaved and
//! the median is reported (the machine is shared and noisy).
//!
//! - Solvers: plate warp (four-lane batch vs the scalar solver, 1 and 2
//!   threads, and the memory bandwidth of a plain copy of the same arrays),
//!   exact cylinder (fast tables + Newton vs the robust sampler), the
//!   paper's C→B→A (time, and its angular error against exact).
//! - Frames at 1600×1200, 100k vertices: the frame pipeline (warp, copies,
//!   packet rays), the one-shot renderer it replaces, the exact trace
//!   (single rays, the reference, and in packets).
//! - Orbit: the camera circles the tube for N frames (vertices re-solved
//!   every frame): frames/s of the warp and of the exact trace, and the
//!   per-frame error.
//! - Vertex sweep (Tables 1, 2) and resolution sweep (Table 3).
//!
//! Arguments (after `--`; `USAGE`):
//! - `--quick`: a short run (smaller films and sweeps, fewer repetitions;
//!   the cylinder solver still at 100k vertices).
//! - `--only PART`: one part alone, no JSON: `solvers`, `cylinder`,
//!   `frames`, `orbit`, `pipeline:SCENE` (the warp frame of one scene at
//!   1600×1200, CPU seconds per phase) or `rays:SCENE` (its ray pass).
//! - `--reps N`: N repetitions instead of 5 (3 with `--quick`).
//! - `--no-parity` (with `--only cylinder`): time only the warp's call
//!   (`images_batch` without parity), e.g. for instruction counts.
//! - `--json FILE`: write the figures (not with `--only`).
use glam::{DVec3, Vec3A};
use rayon::prelude::*;
use snell::camera::Camera;
use snell::timing::{self, median};
use snell::warp::{
    approx_tube::approx_tube_image, CylinderWarper, HollowCylinder, Plate, PlateStatus, SimdLevel, WarpGlass,
};
use snell::warp_render::pipeline::Pipeline;
use snell::warp_render::{
    build_originals, compare, grid_scene as setup, render_exact, render_exact_packets, render_warped,
    warp_scene, Comparison, Frame,
};
use std::time::Instant;

const USAGE: &str = "usage: cargo bench --bench warp -- [--quick] \
[--only solvers|cylinder|frames|orbit|pipeline:SCENE|rays:SCENE] [--reps N] [--no-parity] [--json FILE]";

/// One part of the bench run alone (`--only`), for profiling and A/B runs.
#[derive(Debug, Clone, PartialEq)]
enum Part {
    Solvers,
    Cylinder,
    Frames,
    Orbit,
    /// The warp frame of one scene, CPU seconds per phase.
    Pipeline(String),
    /// The warp frame's ray pass of one scene.
    Rays(String),
}

/// The bench's command line.
#[derive(Debug, Default)]
struct Options {
    /// A short run: smaller sizes, fewer repetitions.
    quick: bool,
    /// One part alone (no JSON).
    only: Option<Part>,
    /// Repetitions of the timed runs.
    reps: usize,
    /// With `--only cylinder`: skip the parity pass.
    no_parity: bool,
    /// Where to write the figures as JSON.
    json: Option<String>,
}

impl Options {
    /// The options of `args` (the arguments after the program's name).
    /// `--bench`, which cargo passes to every bench, is ignored.
    fn parse(args: impl IntoIterator<Item = String>) -> Result<Options, String> {
        let mut o = Options::default();
        let mut reps = None;
        let mut args = args.into_iter();
        while let Some(a) = args.next() {
            let mut value = |name: &str| args.next().ok_or_else(|| format!("{name}: expected a value"));
            match a.as_str() {
                "--bench" => {}
                "--quick" => o.quick = true,
                "--no-parity" => o.no_parity = true,
                "--json" => o.json = Some(value("--json")?),
                "--reps" => {
                    let v = value("--reps")?;
                    match v.parse::<usize>() {
                        Ok(n) if n >= 1 => reps = Some(n),
                        _ => return Err(format!("--reps: expected a whole number >= 1, got \"{v}\"")),
                    }
                }
                "--only" => {
                    let v = value("--only")?;
                    o.only = Some(match v.as_str() {
                        "solvers" => Part::Solvers,
                        "cylinder" => Part::Cylinder,
                        "frames" => Part::Frames,
                        "orbit" => Part::Orbit,
                        _ => match (v.strip_prefix("pipeline:"), v.strip_prefix("rays:")) {
                            (Some(scene), _) if !scene.is_empty() => Part::Pipeline(scene.into()),
                            (_, Some(scene)) if !scene.is_empty() => Part::Rays(scene.into()),
                            _ => {
                                return Err(format!(
                                    "--only: expected solvers, cylinder, frames, orbit, pipeline:SCENE or \
                                     rays:SCENE, got \"{v}\""
                                ))
                            }
                        },
                    });
                }
                _ => return Err(format!("unknown argument \"{a}\"")),
            }
        }
        if o.no_parity && o.only != Some(Part::Cylinder) {
            return Err("--no-parity: only with --only cylinder".into());
        }
        if o.json.is_some() && o.only.is_some() {
            return Err("--json: not with --only (one part alone writes no JSON)".into());
        }
        o.reps = reps.unwrap_or(if o.quick { 3 } else { 5 });
        Ok(o)
    }
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

/// Figures for the summary and the JSON.
#[derive(Default)]
struct Summary {
    plate_vps: f64,
    plate_vps_1t: f64,
    plate_vps_cpu: f64,
    plate_scalar_vps: f64,
    plate_gbs: f64,
    copy_gbs: f64,
    cyl_100k_ms: f64,
    /// The fast solve alone (no tables) per 100k vertices at each SIMD
    /// level this CPU has, widest first.
    cyl_levels_100k_ms: Vec<(SimdLevel, f64)>,
    cyl_parity_100k_ms: f64,
    cyl_us_per_vertex: f64,
    cyl_images: f64,
    frames: Vec<serde_json::Value>,
    tube: Option<FrameFigures>,
    plate: Option<FrameFigures>,
    orbit: Option<serde_json::Value>,
}

fn solvers(sum: &mut Summary, opts: &Options) {
    println!("\n## Solvers\n");
    let eye = DVec3::new(0.0, 0.0, 4.0);
    if opts.only == Some(Part::Cylinder) {
        return cylinder_solver(sum, eye, opts);
    }
    let n = if opts.quick { 300 } else { 1000 };
    // Plate: tilted, 0.3 thick, targets behind it, as a mesh stores them (f32).
    let plate = Plate::try_new(DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.2, -0.1, -1.0), 0.3, 1.5).unwrap();
    let pts: Vec<[f32; 3]> = (0..n * n)
        .map(|i| {
            [
                (-6.0 + 12.0 * (i % n) as f64 / n as f64) as f32,
                (-4.5 + 9.0 * (i / n) as f64 / n as f64) as f32,
                -3.0,
            ]
        })
        .collect();
    let pts64: Vec<DVec3> = pts
        .iter()
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect();
    let mut out = vec![[0.0f32; 3]; pts.len()];
    let mut class: Vec<Result<bool, PlateStatus>> = vec![Ok(false); pts.len()];
    let mut copy_dst = vec![[0.0f32; 3]; pts.len()];
    const CHUNK: usize = 4096;
    let batch = |out: &mut [[f32; 3]], class: &mut [Result<bool, PlateStatus>]| {
        let t = Instant::now();
        out.par_chunks_mut(CHUNK)
            .zip(class.par_chunks_mut(CHUNK))
            .zip(pts.par_chunks(CHUNK))
            .for_each(|((o, c), p)| plate.warp_batch(eye, p, o, c));
        t.elapsed().as_secs_f64()
    };
    // Process CPU time for the batch run ten times: vertices per CPU-second,
    // whatever else the shared machine runs.
    let cpu_s = || snell::timing::process_cpu_s().unwrap_or(0.0);
    let (c0, t0) = (cpu_s(), Instant::now());
    for _ in 0..10 {
        batch(&mut out, &mut class);
    }
    let (cpu10, wall10) = (cpu_s() - c0, t0.elapsed().as_secs_f64());
    sum.plate_vps_cpu = 10.0 * pts.len() as f64 / cpu10.max(1e-9);
    println!(
        "plate batch x10 on 2 threads: {wall10:.3} s wall, {cpu10:.2} CPU-s (the process got {:.2} cores): {:.1} M vertices per CPU-second",
        cpu10 / wall10,
        sum.plate_vps_cpu / 1e6
    );
    let (mut tb, mut tb1, mut ts, mut tc) = (vec![], vec![], vec![], vec![]);
    let one = pool(1);
    for _ in 0..opts.reps {
        tb.push(batch(&mut out, &mut class));
        tb1.push(one.install(|| batch(&mut out, &mut class)));
        let t = Instant::now();
        let v: Vec<DVec3> = pts64
            .par_iter()
            .map(|p| plate.warped_position(eye, *p).unwrap())
            .collect();
        ts.push(t.elapsed().as_secs_f64());
        drop(v);
        let t = Instant::now();
        copy_dst
            .par_chunks_mut(CHUNK)
            .zip(pts.par_chunks(CHUNK))
            .for_each(|(d, s)| d.copy_from_slice(s));
        tc.push(t.elapsed().as_secs_f64());
    }
    let (tb, tb1, ts, tc) = (median(&tb), median(&tb1), median(&ts), median(&tc));
    let nv = pts.len() as f64;
    let bytes = (12 + 12 + std::mem::size_of::<Result<bool, PlateStatus>>()) as f64;
    // Re-trace a sample (f64 lanes) with vector Snell through the plate.
    let g = WarpGlass::Plate(plate);
    let mut worst: f64 = 0.0;
    for c in pts64.chunks(4).step_by(997) {
        if c.len() < 4 {
            continue;
        }
        let r = plate.warp_lanes(eye, &[c[0], c[1], c[2], c[3]]);
        for (p, w) in c.iter().zip(r) {
            let w = w.unwrap();
            let path = g.exact_path(eye, (w - eye).normalize());
            let last = path.segments.last().unwrap();
            let rel = *p - last.origin;
            worst = worst.max((rel - last.dir * rel.dot(last.dir)).length() / (*p - eye).length());
        }
    }
    assert!(class.iter().all(|c| *c == Ok(true)) && out.iter().flatten().all(|x| x.is_finite()));
    sum.plate_vps = nv / tb;
    sum.plate_vps_1t = nv / tb1;
    sum.plate_scalar_vps = nv / ts;
    sum.plate_gbs = nv * bytes / tb / 1e9;
    sum.copy_gbs = nv * 24.0 / tc / 1e9;
    println!(
        "plate warp, {} vertices (f32 in and out), median of {} interleaved runs:\n  batch (4 f64 lanes) 2 threads {:.1} M vertices/s, 1 thread {:.1} M/s; scalar solver 2 threads {:.1} M/s ({:.2}x)\n  batch moves {:.0} bytes/vertex = {:.2} GB/s; a plain parallel copy of the same f32 arrays: {:.2} GB/s ({:.0} M vertices/s)\n  re-traced miss / distance <= {:.1e}",
        pts.len(),
        opts.reps,
        sum.plate_vps / 1e6,
        sum.plate_vps_1t / 1e6,
        sum.plate_scalar_vps / 1e6,
        ts / tb,
        bytes,
        sum.plate_gbs,
        sum.copy_gbs,
        nv / tc / 1e6,
        worst
    );
    cylinder_solver(sum, eye, opts);
}

/// The hollow-cylinder solvers on the warp_cylinder plane.
fn cylinder_solver(sum: &mut Summary, eye: DVec3, opts: &Options) {
    // Cylinder: the warp_cylinder plane, ~100k vertices, also with `--quick`:
    // the target is per 100k, and the tables' cost does not scale with the
    // vertex count (scaling a smaller run's up overstated it tenfold).
    let c = HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, 0.8, 1.5).unwrap();
    let m = 316;
    let pts: Vec<DVec3> = (0..m * m)
        .map(|i| {
            DVec3::new(
                -6.0 + 12.0 * (i % m) as f64 / m as f64,
                -4.5 + 9.0 * (i / m) as f64 / m as f64,
                -3.0,
            )
        })
        .collect();
    // The β range of these targets (as the renderer computes it).
    let (lo, hi) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let d = *p - eye;
            let b = d.y / d.length();
            (lo.min(b), hi.max(b))
        });
    // The warp's call (`images_no_parity`: the renderer needs no parity),
    // and `images` with the parity `warp-points` reports, interleaved.
    let (mut tt, mut tp) = (vec![], vec![]);
    // The fast solve at each SIMD level this CPU has, widest (the
    // default) first, the same images at each.
    let levels: Vec<SimdLevel> = [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Scalar]
        .into_iter()
        .filter(|&l| l <= SimdLevel::detect())
        .collect();
    let mut tl = vec![vec![]; levels.len()];
    let mut imgs = None;
    // As the renderer calls it: in chunks of 256 targets, batched.
    let solve = |w: &CylinderWarper| -> usize {
        pts.par_chunks(256)
            .map(|ch| {
                let mut n = 0;
                w.images_batch(ch, false, |_, r| n += r.map_or(0, |v| v.len()));
                n
            })
            .sum()
    };
    for _ in 0..opts.reps {
        // The renderer's call: tables for these targets (their β range and
        // the families they need).
        let t = Instant::now();
        let mut w = CylinderWarper::for_targets(c, eye, &pts).unwrap();
        tt.push(t.elapsed().as_secs_f64());
        // The levels in turn, their order rotated from one repetition to
        // the next (no level always runs first).
        for j in 0..levels.len() {
            let li = (j + tt.len()) % levels.len();
            w.set_simd_level(levels[li]);
            let t = Instant::now();
            let n = solve(&w);
            tl[li].push(t.elapsed().as_secs_f64());
            assert_eq!(*imgs.get_or_insert(n), n, "{:?}", levels[li]);
        }
        w.set_simd_level(levels[0]);
        if opts.no_parity {
            // The warp's call alone (e.g. its instruction counts).
            tp.push(0.0);
            continue;
        }
        let t = Instant::now();
        let _: usize = pts
            .par_iter()
            .map(|p| w.images(*p).map(|v| v.len()).unwrap_or(0))
            .sum();
        tp.push(t.elapsed().as_secs_f64());
    }
    let imgs = imgs.unwrap_or(0);
    let (tables, fast, with_parity) = (median(&tt), median(&tl[0]), median(&tp));
    let per_100k = |t: f64| t * 1e5 / pts.len() as f64 * 1e3;
    sum.cyl_levels_100k_ms = levels
        .iter()
        .zip(&tl)
        .map(|(l, t)| (*l, per_100k(median(t))))
        .collect();
    println!(
        "cylinder fast solve (no tables) per 100k vertices by SIMD level, median of {} interleaved runs: {}",
        opts.reps,
        sum.cyl_levels_100k_ms
            .iter()
            .map(|(l, ms)| format!("{l:?} ({} lanes) {ms:.1} ms", l.lanes()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    if opts.only == Some(Part::Cylinder) {
        // Profiling the fast solver alone.
        println!(
            "cylinder fast: {:.3} s + tables {:.3} s per {} vertices, {:.2} images/vertex (with parity {:.3} s)",
            fast,
            tables,
            pts.len(),
            imgs as f64 / pts.len() as f64,
            with_parity
        );
        return;
    }
    let w = CylinderWarper::new(c, eye, lo, hi).unwrap();
    let sample: Vec<DVec3> = pts.iter().step_by(pts.len() / 500).copied().collect();
    let t = Instant::now();
    let _: Vec<usize> = sample
        .par_iter()
        .map(|p| c.images(eye, *p).map(|v| v.len()).unwrap_or(0))
        .collect();
    let robust = t.elapsed().as_secs_f64() / sample.len() as f64;
    sum.cyl_100k_ms = (fast + tables) * 1e5 / pts.len() as f64 * 1e3;
    sum.cyl_parity_100k_ms = (with_parity + tables) * 1e5 / pts.len() as f64 * 1e3;
    sum.cyl_us_per_vertex = fast * 1e6 / pts.len() as f64;
    sum.cyl_images = imgs as f64 / pts.len() as f64;
    println!(
        "cylinder exact (fast), 2 threads: {} vertices in {:.3} s + tables {:.3} s (beta {:.2}..{:.2}) = {:.2} us/vertex, {:.2} images/vertex; robust sampler {:.0} us/vertex ({:.0}x slower)\n  aim: 100k vertices in <= 20 ms on 2 cores; reached {:.0} ms per 100k (images_no_parity, the warp's call; {:.0} ms with the parity warp-points reports)",
        pts.len(),
        fast,
        tables,
        lo,
        hi,
        sum.cyl_us_per_vertex,
        sum.cyl_images,
        robust * 1e6,
        robust / (fast / pts.len() as f64),
        sum.cyl_100k_ms,
        sum.cyl_parity_100k_ms
    );
    // Paper's approximation: time and angular error against exact, same family.
    let t = Instant::now();
    let paper: Vec<Option<snell::warp::CylImage>> = pts
        .par_iter()
        .map(|p| approx_tube_image(&c, eye, *p).ok().flatten())
        .collect();
    let paper_s = t.elapsed().as_secs_f64();
    let mut errs: Vec<f64> = pts
        .par_iter()
        .zip(&paper)
        .filter_map(|(p, pi)| {
            let pi = pi.as_ref()?;
            if pi.family == snell::warp::Family::Direct {
                return None;
            }
            w.images(*p)
                .ok()?
                .iter()
                .filter(|im| im.family == pi.family)
                .map(|im| im.direction.angle_between(pi.direction))
                .min_by(f64::total_cmp)
        })
        .collect();
    errs.sort_by(f64::total_cmp);
    let px = (40f64.to_radians() / 2.0).tan() * 2.0 / 480.0;
    if !errs.is_empty() {
        let q = |f: f64| errs[((errs.len() - 1) as f64 * f) as usize];
        println!(
            "paper C->B->A: {:.2} us/vertex; angle error vs exact over {} refracted images: median {:.2e}, p95 {:.2e}, max {:.2e} rad (= {:.1} / {:.1} / {:.1} pixels at 640x480, fov 40)",
            paper_s * 1e6 / pts.len() as f64,
            errs.len(),
            q(0.5),
            q(0.95),
            q(1.0),
            q(0.5) / px,
            q(0.95) / px,
            q(1.0) / px
        );
    }
}

/// One frame's figures (medians over interleaved repetitions).
#[derive(Clone)]
struct FrameFigures {
    vertices: usize,
    width: u32,
    height: u32,
    warp_s: f64,
    copies_s: f64,
    refit_s: f64,
    /// Rays against the refitting (SAH-built) copies.
    refit_rays_s: f64,
    rays_s: f64,
    frame_s: f64,
    /// A viewer's later frame with refitting copies: warp + refit + rays
    /// against the refitted copies. For the plate this is every frame after
    /// the first, camera moving or not: its copies' triangle sets do not
    /// depend on the eye (tested in `tests/warp_render.rs`), so they always
    /// refit. For the tube only while the camera stands still (the seams
    /// move with the eye: the orbit rebuilds every frame).
    refit_frame_s: f64,
    /// The comparison of the refitted copies' frame with the exact trace.
    refit_cmp: Comparison,
    old_frame_s: f64,
    exact_s: f64,
    exact_packets_s: f64,
    render_1spp_s: Option<f64>,
    cmp: Comparison,
}

impl FrameFigures {
    fn json(&self, scene: &str) -> serde_json::Value {
        serde_json::json!({
            "scene": scene, "vertices": self.vertices, "width": self.width, "height": self.height,
            "warp_s": self.warp_s, "copies_rebuild_s": self.copies_s, "copies_refit_s": self.refit_s, "rays_refit_copies_s": self.refit_rays_s,
            "rays_s": self.rays_s, "frame_s": self.frame_s, "one_shot_frame_s": self.old_frame_s,
            "refit_frame_s": self.refit_frame_s, "refit_speedup": self.exact_s / self.refit_frame_s,
            "refit_px_mean": self.refit_cmp.px_mean, "refit_px_p95": self.refit_cmp.px_p95,
            "exact_s": self.exact_s, "exact_packets_s": self.exact_packets_s,
            "speedup": self.exact_s / self.frame_s, "exact_over_rays": self.exact_s / self.rays_s, "speedup_vs_exact_packets": self.exact_packets_s / self.frame_s,
            "render_1spp_s": self.render_1spp_s,
            "px_mean": self.cmp.px_mean, "px_p95": self.cmp.px_p95,
            "mismatched_fraction": self.cmp.mismatched as f64 / self.cmp.pixels as f64,
        })
    }
}

/// A frame of `path` with `vertices` at w×h: the pipeline (first frame:
/// copies rebuilt; then the same camera again: refit), the one-shot
/// renderer, the exact trace (single rays and packets); interleaved.
fn frame_row(
    path: &str,
    w: u32,
    h: u32,
    vertices: usize,
    with_render: bool,
    reps: usize,
) -> snell::Result<FrameFigures> {
    let (scene, prep) = setup(path, w, h, vertices)?;
    let spec = scene.warp.clone().unwrap();
    let orig = build_originals(&scene, &prep)?;
    let (mut warp, mut copies, mut refit, mut rays, mut old, mut ex, mut exp) =
        (vec![], vec![], vec![], vec![], vec![], vec![], vec![]);
    let mut refit_rays = vec![];
    let (mut cmp, mut refit_cmp) = (None, None);
    // The viewer's frame buffers, kept across frames (as the copies are):
    // `fb` holds the rebuilt copies' frame, compared with the exact trace.
    let (mut fb, mut fb_refit) = (empty_frame(), empty_frame());
    for _ in 0..reps {
        // Copies rebuilt every frame (Embree's fast builder).
        let mut pipe = Pipeline::new(&scene, &spec, &prep, false)?;
        let f1 = pipe.warp(&scene)?;
        pipe.render_into(&scene, &spec, &prep, &mut fb);
        warp.push(f1.warp_s);
        copies.push(f1.build_s);
        rays.push(fb.render_s);
        drop(pipe);
        // Refitting copies: the second frame of an unmoved camera refits.
        let mut rpipe = Pipeline::new(&scene, &spec, &prep, true)?;
        rpipe.warp(&scene)?;
        let f2 = rpipe.warp(&scene)?;
        refit.push(f2.build_s);
        rpipe.render_into(&scene, &spec, &prep, &mut fb_refit);
        refit_rays.push(fb_refit.render_s);
        drop(rpipe);
        let warped = warp_scene(&scene, &spec, &prep)?;
        let of = render_warped(&scene, &spec, &prep, &warped);
        old.push(warped.warp_s + warped.build_s + of.render_s);
        drop(warped);
        let e = render_exact(&scene, &spec, &prep, &orig);
        ex.push(e.render_s);
        let e2 = render_exact_packets(&scene, &spec, &prep, &orig);
        exp.push(e2.render_s);
        cmp.get_or_insert_with(|| compare(&scene, &fb, &e).0);
        refit_cmp.get_or_insert_with(|| compare(&scene, &fb_refit, &e).0);
    }
    let render_1spp_s = if with_render {
        let t = Instant::now();
        let _ = snell::render::render(
            &scene,
            &snell::render::RenderSettings::from_scene(&scene).with_spp(1),
            &snell::render::RenderOptions {
                threads: None,
                want_aovs: false,
                ..Default::default()
            },
        )?;
        Some(t.elapsed().as_secs_f64())
    } else {
        None
    };
    let (warp_s, copies_s, rays_s) = (median(&warp), median(&copies), median(&rays));
    let (refit_s, refit_rays_s) = (median(&refit), median(&refit_rays));
    Ok(FrameFigures {
        vertices: prep.vertices,
        width: w,
        height: h,
        warp_s,
        copies_s,
        refit_s,
        refit_rays_s,
        rays_s,
        frame_s: warp_s + copies_s + rays_s,
        refit_frame_s: warp_s + refit_s + refit_rays_s,
        refit_cmp: refit_cmp.unwrap(),
        old_frame_s: median(&old),
        exact_s: median(&ex),
        exact_packets_s: median(&exp),
        render_1spp_s,
        cmp: cmp.unwrap(),
    })
}

fn empty_frame() -> Frame {
    Frame {
        width: 0,
        height: 0,
        pixels: Vec::new(),
        shown: Vec::new(),
        render_s: 0.0,
    }
}

fn header() {
    println!("| vertices | film | warp s | copies s (refit s) | rays s (SAH copies) | frame s | fps | one-shot s | exact s | vs exact | refit frame s (vs exact) | exact / rays | exact packets s | vs exact packets | render 1spp s | px mean | px p95 | mismatch |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
}

fn print_row(f: &FrameFigures) {
    println!(
        "| {} | {}x{} | {:.4} | {:.4} ({:.4}) | {:.4} ({:.4}) | {:.4} | {:.1} | {:.4} | {:.4} | {:.2}x | {:.4} ({:.2}x) | {:.2}x | {:.4} | {:.2}x | {} | {:.4} | {:.3} | {:.2}% |",
        f.vertices,
        f.width,
        f.height,
        f.warp_s,
        f.copies_s,
        f.refit_s,
        f.rays_s,
        f.refit_rays_s,
        f.frame_s,
        1.0 / f.frame_s,
        f.old_frame_s,
        f.exact_s,
        f.exact_s / f.frame_s,
        f.refit_frame_s,
        f.exact_s / f.refit_frame_s,
        f.exact_s / f.rays_s,
        f.exact_packets_s,
        f.exact_packets_s / f.frame_s,
        f.render_1spp_s.map(|s| format!("{s:.3}")).unwrap_or_else(|| "-".into()),
        f.cmp.px_mean,
        f.cmp.px_p95,
        100.0 * f.cmp.mismatched as f64 / f.cmp.pixels as f64
    );
}

/// The camera circles the tube's axis (radius 4 m, ±20°) for `n` frames;
/// each frame re-solves every vertex, updates the copies and traces; the
/// exact trace renders the same camera; both are compared per frame.
fn orbit(n: usize, w: u32, h: u32, vertices: usize) -> snell::Result<serde_json::Value> {
    let path = "scenes/warp_cylinder.toml";
    let (mut scene, prep) = setup(path, w, h, vertices)?;
    let spec = scene.warp.clone().unwrap();
    let orig = build_originals(&scene, &prep)?;
    let mut pipe = Pipeline::new(&scene, &spec, &prep, false)?;
    println!("| frame | angle deg | warp s | copies s | rays s | frame s | rebuilt/refit | exact s | exact packets s | px mean | px p95 | mismatch |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    let (mut tw, mut te, mut tep) = (0.0, 0.0, 0.0);
    let (mut fw, mut fe, mut fep, mut errs) = (vec![], vec![], vec![], vec![]);
    // The viewer's frame buffer, kept across frames.
    let mut fb = empty_frame();
    for i in 0..n {
        let a = (-20.0 + 40.0 * i as f64 / (n.max(2) - 1) as f64).to_radians();
        scene.camera = Camera::try_new(
            Vec3A::new(4.0 * a.sin() as f32, 0.0, 4.0 * a.cos() as f32),
            Vec3A::ZERO,
            Vec3A::Y,
            40.0,
            w,
            h,
            0.0,
            1.0,
        )?;
        let t = Instant::now();
        let f = pipe.warp(&scene)?;
        pipe.render_into(&scene, &spec, &prep, &mut fb);
        let frame_s = t.elapsed().as_secs_f64();
        let e = render_exact(&scene, &spec, &prep, &orig);
        let ep = render_exact_packets(&scene, &spec, &prep, &orig);
        let (cmp, _) = compare(&scene, &fb, &e);
        tw += frame_s;
        te += e.render_s;
        tep += ep.render_s;
        fw.push(frame_s);
        fe.push(e.render_s);
        fep.push(ep.render_s);
        errs.push(cmp.px_mean);
        println!(
            "| {} | {:.1} | {:.4} | {:.4} | {:.4} | {:.4} | {}/{} | {:.4} | {:.4} | {:.4} | {:.3} | {:.2}% |",
            i,
            a.to_degrees(),
            f.warp_s,
            f.build_s,
            fb.render_s,
            frame_s,
            f.rebuilds,
            f.refits,
            e.render_s,
            ep.render_s,
            cmp.px_mean,
            cmp.px_p95,
            100.0 * cmp.mismatched as f64 / cmp.pixels as f64
        );
        rows.push(serde_json::json!({
            "angle_deg": a.to_degrees(), "warp_s": f.warp_s, "copies_s": f.build_s, "rays_s": fb.render_s,
            "frame_s": frame_s, "rebuilt": f.rebuilds, "refit": f.refits, "exact_s": e.render_s,
            "exact_packets_s": ep.render_s, "px_mean": cmp.px_mean, "px_p95": cmp.px_p95,
            "mismatched_fraction": cmp.mismatched as f64 / cmp.pixels as f64,
        }));
    }
    let worst = errs.iter().cloned().fold(0.0f64, f64::max);
    println!(
        "\norbit, {n} frames at {w}x{h}, {} vertices: warp {:.2} frames/s (median frame {:.3} s), exact {:.2} frames/s (median {:.3} s; in packets {:.2} frames/s), speed-up {:.2}x (vs packets {:.2}x); worst per-frame mean error {:.4} px",
        prep.vertices,
        n as f64 / tw,
        median(&fw),
        n as f64 / te,
        median(&fe),
        n as f64 / tep,
        median(&fe) / median(&fw),
        median(&fep) / median(&fw),
        worst
    );
    Ok(serde_json::json!({
        "frames": n, "width": w, "height": h, "vertices": prep.vertices,
        "warp_frames_per_s": n as f64 / tw, "exact_frames_per_s": n as f64 / te,
        "exact_packets_frames_per_s": n as f64 / tep,
        "median_speedup": median(&fe) / median(&fw), "median_speedup_vs_packets": median(&fep) / median(&fw),
        "worst_px_mean": worst, "per_frame": rows,
    }))
}

fn main() -> snell::Result<()> {
    let opts = match Options::parse(std::env::args().skip(1)) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("warp bench: {e}\n{USAGE}");
            std::process::exit(2);
        }
    };
    println!("{}", snell::bench_header());
    println!("threads: {}", rayon::current_num_threads());
    let mut sum = Summary::default();
    if opts.only == Some(Part::Orbit) {
        orbit(24, 1600, 1200, 100_000)?;
        return Ok(());
    }
    if let Some(Part::Rays(path)) = &opts.only {
        // The warp frame's ray pass alone (one warp, then 10 frames into
        // one buffer; CPU seconds per frame).
        let (scene, prep) = setup(path, 1600, 1200, 100_000)?;
        let spec = scene.warp.clone().unwrap();
        let mut pipe = Pipeline::new(&scene, &spec, &prep, false)?;
        let mut fb = empty_frame();
        pipe.warp(&scene)?;
        pipe.render_into(&scene, &spec, &prep, &mut fb);
        let cpu = || timing::process_cpu_s().unwrap_or(0.0);
        let mut t = vec![];
        for _ in 0..10 {
            let c0 = cpu();
            pipe.render_into(&scene, &spec, &prep, &mut fb);
            t.push(cpu() - c0);
        }
        let [med, min, _] = timing::median_min_max(&t);
        println!("rays: CPU s per frame min {min:.4} median {med:.4}");
        return Ok(());
    }
    if let Some(Part::Pipeline(path)) = &opts.only {
        // The warp frame alone.
        let (scene, prep) = setup(path, 1600, 1200, 100_000)?;
        let spec = scene.warp.clone().unwrap();
        // Made once per scene: the tube's fixed direct copy is built here
        // (as the exact trace's BVH of the unwarped meshes, not per frame).
        let t = Instant::now();
        let mut pipe = Pipeline::new(&scene, &spec, &prep, false)?;
        println!("pipeline made in {:.4} s", t.elapsed().as_secs_f64());
        let mut fb = empty_frame();
        let cpu = || timing::process_cpu_s().unwrap_or(0.0);
        let (mut cw, mut cr, mut cf, mut ce) = (0.0, 0.0, 0.0, 0.0);
        let orig = build_originals(&scene, &prep)?;
        for _ in 0..opts.reps {
            let c0 = cpu();
            let f = pipe.warp(&scene)?;
            let c1 = cpu();
            pipe.render_into(&scene, &spec, &prep, &mut fb);
            let c2 = cpu();
            (cw, cr) = (cw + c1 - c0, cr + c2 - c1);
            let fresh = pipe.render(&scene, &spec, &prep);
            cf += cpu() - c2;
            drop(fresh);
            let c3 = cpu();
            let e = render_exact(&scene, &spec, &prep, &orig);
            ce += cpu() - c3;
            drop(e);
            println!(
                "warp {:.4} s, copies {:.4} s ({} rebuilt, {} refit, {} triangles culled), rays {:.4} s",
                f.warp_s, f.build_s, f.rebuilds, f.refits, f.culled_triangles, fb.render_s
            );
        }
        println!(
            "CPU seconds per frame: warp + copies {:.3}, rays {:.3} (into a fresh frame {:.3}); exact trace {:.3}",
            cw / opts.reps as f64,
            cr / opts.reps as f64,
            cf / opts.reps as f64,
            ce / opts.reps as f64
        );
        return Ok(());
    }
    if opts.only != Some(Part::Frames) {
        solvers(&mut sum, &opts);
    }
    if matches!(opts.only, Some(Part::Solvers | Part::Cylinder)) {
        return Ok(());
    }
    let (bw, bh) = if opts.quick { (640, 480) } else { (1600, 1200) };
    println!(
        "\n## Frames at {bw}x{bh}, 100k vertices (median of {} interleaved repetitions)\n",
        opts.reps
    );
    println!("frame = warp + copies (rebuilt, Embree's fast builder) + packet rays; refit s = the copies' update when the camera did not move (copies built with SAH once, then refitted; 'SAH copies' = the rays against those); one-shot = warp_scene + render_warped (copies built per frame, single rays); vs exact = exact trace (single rays, the reference) / frame; exact packets = the same exact trace with its pieces cast in packets of sixteen (4x4 pixel tiles, as the warp's rays)\n");
    header();
    for (name, scene) in [
        ("plate", "scenes/warp_plate.toml"),
        ("tube", "scenes/warp_cylinder.toml"),
    ] {
        let f = frame_row(scene, bw, bh, 100_000, true, opts.reps)?;
        print_row(&f);
        sum.frames.push(f.json(scene));
        if name == "tube" {
            sum.tube = Some(f);
        } else {
            sum.plate = Some(f);
        }
    }
    if opts.only.is_some() {
        return Ok(());
    }
    let n = if opts.quick { 6 } else { 24 };
    println!("\n## Orbit: the camera circles the tube, {n} frames at {bw}x{bh}, 100k vertices\n");
    sum.orbit = Some(orbit(n, bw, bh, 100_000)?);
    let verts: &[usize] = if opts.quick {
        &[100_000]
    } else {
        &[100_000, 200_000, 400_000, 800_000]
    };
    let films: &[(u32, u32)] = if opts.quick {
        &[(640, 480)]
    } else {
        &[(640, 480), (800, 600), (1024, 768), (1600, 1200)]
    };
    for scene in ["scenes/warp_plate.toml", "scenes/warp_cylinder.toml"] {
        println!("\n## {scene}: vertex sweep at {bw}x{bh} (Tables 1, 2; median of 3)\n");
        header();
        for &v in verts {
            let f = frame_row(scene, bw, bh, v, false, 3)?;
            print_row(&f);
            sum.frames.push(f.json(scene));
        }
        println!("\n## {scene}: resolution sweep at 100k vertices (Table 3; median of 3)\n");
        header();
        for &(w, h) in films {
            let f = frame_row(scene, w, h, 100_000, false, 3)?;
            print_row(&f);
            sum.frames.push(f.json(scene));
        }
    }
    let (tube, plate) = (sum.tube.clone().unwrap(), sum.plate.clone().unwrap());
    let orbit = sum.orbit.clone().unwrap();
    println!("\n## Summary against the targets ({bw}x{bh}; speed-up = exact trace / warp frame, same run)\n");
    if opts.quick {
        // A frame's fixed costs (the warp, the copies) weigh more at the
        // small film: the frame targets are judged at the full run's size.
        println!("(--quick: the frame rows are at 640x480; the frame targets are judged at 1600x1200, without --quick)\n");
    }
    println!("| what | reached | target |");
    println!("|---|---|---|");
    println!(
        "| plate vertex warp, 2 threads | {:.1} M vertices/s (1 thread {:.1}; {:.1} M per CPU-second; scalar {:.1}; copy bandwidth {:.2} GB/s = {:.0} M vertices/s) | >= 40 M/s |",
        sum.plate_vps / 1e6,
        sum.plate_vps_1t / 1e6,
        sum.plate_vps_cpu / 1e6,
        sum.plate_scalar_vps / 1e6,
        sum.copy_gbs,
        sum.copy_gbs * 1e9 / 24.0 / 1e6
    );
    println!(
        "| hollow-cylinder warp, 100k vertices | {:.0} ms ({:.2} us/vertex, {:.2} images each) | <= 20 ms |",
        sum.cyl_100k_ms, sum.cyl_us_per_vertex, sum.cyl_images
    );
    println!(
        "| warp frame vs exact trace, tube | {:.2}x at {:.4} px mean error, p95 {:.3} px (exact / warp rays alone {:.2}x; vs exact in packets {:.2}x; orbit median {:.2}x) | >= 4x at <= 0.5 px |",
        tube.exact_s / tube.frame_s,
        tube.cmp.px_mean,
        tube.cmp.px_p95,
        tube.exact_s / tube.rays_s,
        tube.exact_packets_s / tube.frame_s,
        orbit["median_speedup"].as_f64().unwrap_or(0.0)
    );
    // The plate's headline is a viewer's frame after the first: its
    // copies refit whether the camera moves or not (`refit_frame_s`); the
    // rebuilt frame's figure is printed beside it.
    println!(
        "| warp frame vs exact trace, plate | {:.2}x (refitted copies; rebuilt {:.2}x) at {:.4} px mean error, p95 {:.3} px (exact / warp rays alone {:.2}x; vs exact in packets {:.2}x, rebuilt {:.2}x) | >= 4x |",
        plate.exact_s / plate.refit_frame_s,
        plate.exact_s / plate.frame_s,
        plate.refit_cmp.px_mean,
        plate.refit_cmp.px_p95,
        plate.exact_s / plate.refit_rays_s,
        plate.exact_packets_s / plate.refit_frame_s,
        plate.exact_packets_s / plate.frame_s
    );
    if let Some(p) = &opts.json {
        let v = serde_json::json!({
            "provenance": snell::provenance::json(),
            "quick": opts.quick,
            "film": [bw, bh],
            "plate_vertices_per_s": sum.plate_vps,
            "plate_vertices_per_s_1_thread": sum.plate_vps_1t,
            "plate_vertices_per_cpu_s": sum.plate_vps_cpu,
            "plate_scalar_vertices_per_s": sum.plate_scalar_vps,
            "plate_batch_gb_per_s": sum.plate_gbs,
            "copy_gb_per_s": sum.copy_gbs,
            "cylinder_100k_ms": sum.cyl_100k_ms,
            "cylinder_100k_ms_with_parity": sum.cyl_parity_100k_ms,
            "cylinder_solve_100k_ms_by_simd_level": sum
                .cyl_levels_100k_ms
                .iter()
                .map(|(l, ms)| (format!("{l:?}"), serde_json::json!(ms)))
                .collect::<serde_json::Map<_, _>>(),
            "cylinder_us_per_vertex": sum.cyl_us_per_vertex,
            "cylinder_images_per_vertex": sum.cyl_images,
            "tube_1600_speedup": tube.exact_s / tube.frame_s,
            "tube_1600_speedup_vs_exact_packets": tube.exact_packets_s / tube.frame_s,
            "tube_1600_mean_error_px": tube.cmp.px_mean,
            "tube_1600_p95_error_px": tube.cmp.px_p95,
            "plate_1600_speedup": plate.exact_s / plate.refit_frame_s,
            "plate_1600_speedup_vs_exact_packets": plate.exact_packets_s / plate.refit_frame_s,
            "plate_1600_speedup_rebuilt": plate.exact_s / plate.frame_s,
            "plate_1600_speedup_rebuilt_vs_exact_packets": plate.exact_packets_s / plate.frame_s,
            "plate_1600_mean_error_px": plate.refit_cmp.px_mean,
            "plate_1600_p95_error_px": plate.refit_cmp.px_p95,
            "orbit": orbit,
            "frames": sum.frames,
        });
        std::fs::write(p, serde_json::to_string_pretty(&v).unwrap_or_default())
            .map_err(|e| snell::Error::Invalid(format!("{p}: {e}")))?;
        println!("\nwrote {p}");
    }
    Ok(())
}
