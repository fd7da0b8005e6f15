//! `cargo bench --bench warp`: the refraction warp's speed against its error,
//! in sweeps like Mukai et al.'s tables. Every speed is a ratio measured in
//! this run (warp frame vs the exact trace of the same primary rays, and vs
//! `snell render` at 1 spp), beside the machine, commit and Embree version.
//!
//! - Solvers: plate warp (M vertices/s, 2 threads), exact cylinder (fast
//!   tables + Newton vs the robust sampler), the paper's C→B→A (time, and its
//!   angular error against exact).
//! - Vertex sweep (Tables 1, 2): the scene's main surface as a grid of 100k
//!   to 800k vertices, at 1600×1200.
//! - Resolution sweep (Table 3): 100k vertices, 640×480 to 1600×1200.
//!
//! Set SNELL_BENCH_QUICK=1 for a short run (fewer sizes).
use glam::DVec3;
use rayon::prelude::*;
use snell::scene::{load_scene, meshgen, BuildOptions, RenderScene};
use snell::warp::render::{build_originals, compare, prepare, render_exact, render_warped, warp_scene};
use snell::warp::{fastcyl::CylinderWarper, paper::paper_image, HollowCylinder, Plate, WarpGlass};
use std::path::Path;
use std::time::Instant;

fn quick() -> bool {
    std::env::var("SNELL_BENCH_QUICK").is_ok()
}

fn solvers() {
    println!("\n## Solvers (2 threads unless noted)\n");
    let eye = DVec3::new(0.0, 0.0, 4.0);
    let n = if quick() { 300 } else { 1000 };
    let grid = |z: f64, w: f64, h: f64| -> Vec<DVec3> {
        (0..n * n)
            .map(|i| {
                DVec3::new(
                    -w / 2.0 + w * (i % n) as f64 / n as f64,
                    -h / 2.0 + h * (i / n) as f64 / n as f64,
                    z,
                )
            })
            .collect()
    };
    // Plate: tilted, 0.3 thick, targets behind it.
    let plate = Plate::try_new(DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.2, -0.1, -1.0), 0.3, 1.5).unwrap();
    let pts = grid(-3.0, 12.0, 9.0);
    let t = Instant::now();
    let out: Vec<DVec3> = pts
        .par_iter()
        .map(|p| plate.warped_position(eye, *p).unwrap())
        .collect();
    let s = t.elapsed().as_secs_f64();
    // Re-trace a sample with vector Snell through the plate.
    let g = WarpGlass::Plate(plate);
    let worst = pts
        .iter()
        .zip(&out)
        .step_by(997)
        .map(|(p, w)| {
            let path = g.exact_path(eye, (*w - eye).normalize());
            let last = path.segments.last().unwrap();
            let rel = *p - last.origin;
            (rel - last.dir * rel.dot(last.dir)).length() / (*p - eye).length()
        })
        .fold(0.0f64, f64::max);
    println!(
        "plate warp: {} vertices in {:.4} s = {:.1} M vertices/s; re-traced miss / distance <= {:.1e}",
        pts.len(),
        s,
        pts.len() as f64 / s / 1e6,
        worst
    );
    // Cylinder: the warp_cylinder plane.
    let c = HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, 0.8, 1.5).unwrap();
    let m = if quick() { 100 } else { 316 };
    let pts: Vec<DVec3> = (0..m * m)
        .map(|i| {
            DVec3::new(
                -6.0 + 12.0 * (i % m) as f64 / m as f64,
                -4.5 + 9.0 * (i / m) as f64 / m as f64,
                -3.0,
            )
        })
        .collect();
    let t = Instant::now();
    let w = CylinderWarper::new(c, eye, -0.6, 0.6).unwrap();
    let tables = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let imgs: Vec<usize> = pts
        .par_iter()
        .map(|p| w.images(*p).map(|v| v.len()).unwrap_or(0))
        .collect();
    let fast = t.elapsed().as_secs_f64();
    let sample: Vec<DVec3> = pts.iter().step_by(pts.len() / 500).copied().collect();
    let t = Instant::now();
    let _: Vec<usize> = sample
        .par_iter()
        .map(|p| c.images(eye, *p).map(|v| v.len()).unwrap_or(0))
        .collect();
    let robust = t.elapsed().as_secs_f64() / sample.len() as f64;
    println!(
        "cylinder exact (fast): {} vertices in {:.3} s + tables {:.3} s = {:.2} us/vertex, {:.2} images/vertex; robust sampler {:.0} us/vertex ({:.0}x slower)",
        pts.len(),
        fast,
        tables,
        fast * 1e6 / pts.len() as f64,
        imgs.iter().sum::<usize>() as f64 / pts.len() as f64,
        robust * 1e6,
        robust / (fast / pts.len() as f64)
    );
    println!(
        "  aim: 100k vertices in <= 20 ms on 2 cores; reached {:.0} ms per 100k",
        (fast + tables) * 1e5 / pts.len() as f64 * 1e3
    );
    // Paper's approximation: time and angular error against exact, same family.
    let t = Instant::now();
    let paper: Vec<Option<snell::warp::CylImage>> = pts
        .par_iter()
        .map(|p| paper_image(&c, eye, *p).ok().flatten())
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

/// Replace the scene's largest object by a grid of about `vertices` vertices.
fn with_grid(scene: &RenderScene, prep: &mut snell::warp::render::Prepared, vertices: usize) {
    let (k, _) = prep
        .objects
        .iter()
        .enumerate()
        .max_by(|a, b| {
            let area = |o: &snell::warp::render::WarpObject| {
                let (lo, hi) = o.mesh.aabb();
                let d = hi - lo;
                d.x * d.y + d.y * d.z + d.z * d.x
            };
            area(a.1).total_cmp(&area(b.1))
        })
        .unwrap();
    let _ = scene;
    let m = &prep.objects[k].mesh;
    assert_eq!(
        m.positions.len(),
        4,
        "the bench expects the main surface to be a rect"
    );
    let c = m
        .positions
        .iter()
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect::<Vec<_>>();
    let (su, sv) = ((c[1] - c[0]).length(), (c[3] - c[0]).length());
    let nx = ((vertices as f64 * su / sv).sqrt().round() as u32).max(2);
    let ny = ((vertices as f64 / nx as f64).round() as u32).max(2);
    let normal = (c[1] - c[0]).cross(c[3] - c[0]).normalize();
    prep.objects[k].mesh = meshgen::grid([c[0], c[1], c[2], c[3]], normal, nx, ny);
    prep.objects[k].levels = 0;
    prep.vertices = prep.objects.iter().map(|o| o.mesh.positions.len()).sum();
    prep.triangles = prep.objects.iter().map(|o| o.mesh.indices.len()).sum();
}

fn row(path: &str, w: u32, h: u32, vertices: usize) -> snell::Result<()> {
    let mut scene = load_scene(Path::new(path), &BuildOptions::default())?;
    scene.set_resolution(w, h)?;
    let spec = scene.warp.clone().expect("a [warp] scene");
    let mut prep = prepare(&scene, &spec, 1e9)?;
    with_grid(&scene, &mut prep, vertices);
    let warped = warp_scene(&scene, &spec, &prep)?;
    let frame = render_warped(&scene, &spec, &prep, &warped);
    let orig = build_originals(&scene, &prep)?;
    let exact = render_exact(&scene, &spec, &prep, &orig);
    let (cmp, _) = compare(&scene, &frame, &exact);
    // `snell render` of the same scene (path tracer, the glass as geometry), 1 spp.
    scene.spp = 1;
    let t = Instant::now();
    let _ = snell::render::render(
        &scene,
        &snell::render::RenderOptions {
            threads: None,
            quiet: true,
            want_aovs: false,
        },
    )?;
    let full = t.elapsed().as_secs_f64();
    let frame_s = warped.warp_s + warped.build_s + frame.render_s;
    println!(
        "| {:>9} | {:>4}x{:<4} | {:>7.4} | {:>7.4} | {:>7.4} | {:>7.4} | {:>6.1} | {:>7.4} | {:>5.2}x | {:>5.2}x | {:>7.4} | {:>5.2}x | {:>7.4} | {:>6.3} | {:>6.2}% |",
        prep.vertices,
        w,
        h,
        warped.warp_s,
        warped.build_s,
        frame.render_s,
        frame_s,
        1.0 / frame_s,
        exact.render_s,
        exact.render_s / frame_s,
        exact.render_s / frame.render_s,
        full,
        full / frame_s,
        cmp.px_mean,
        cmp.px_p95,
        100.0 * cmp.mismatched as f64 / cmp.pixels as f64
    );
    Ok(())
}

fn header() {
    println!("| vertices  | film      | warp s  | copies s| rays s  | frame s | fps    | exact s | vs exact | rays only | render 1spp s | vs render | px mean | px p95 | mismatch |");
    println!("|-----------|-----------|---------|---------|---------|---------|--------|---------|----------|-----------|---------|--------|---------|--------|----------|");
}

fn main() -> snell::Result<()> {
    println!("{}", snell::bench_header());
    println!("threads: {}", rayon::current_num_threads());
    solvers();
    let verts: &[usize] = if quick() {
        &[100_000]
    } else {
        &[100_000, 200_000, 400_000, 800_000]
    };
    let films: &[(u32, u32)] = if quick() {
        &[(640, 480)]
    } else {
        &[(640, 480), (800, 600), (1024, 768), (1600, 1200)]
    };
    for scene in ["scenes/warp_plate.toml", "scenes/warp_cylinder.toml"] {
        println!("\n## {scene}: vertex sweep at 1600x1200 (Tables 1, 2)\n");
        println!("frame = warp + copy BVHs + primary rays; 'vs exact' = exact primary-ray trace / frame; 'vs render' = snell render at 1 spp / frame; px = position error in pixel footprints; mismatch = pixels showing another object\n");
        header();
        for &v in verts {
            let (w, h) = if quick() { (640, 480) } else { (1600, 1200) };
            row(scene, w, h, v)?;
        }
        println!("\n## {scene}: resolution sweep at 100k vertices (Table 3)\n");
        header();
        for &(w, h) in films {
            row(scene, w, h, 100_000)?;
        }
    }
    Ok(())
}
