//! Experiment: bare Embree on a render's recorded rays, single rays vs
//! packets of eight (in log order, i.e. incoherent), and camera rays in 4x2
//! pixel blocks. `cargo run --release --example packet_ceiling -- scenes/three_spheres.toml`
use snell::embree::warp_ffi::Packet8;
use snell::integrator::ray_log::{self, Logged};
use snell::ray::Ray;
use snell::render::{render, RenderOptions, RenderSettings};
use snell::scene::{load_scene, BuildOptions};
use std::time::Instant;

fn main() -> snell::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    let scene = load_scene(std::path::Path::new(&a[1]), &BuildOptions::default())?;
    let settings = RenderSettings::from_scene(&scene)
        .with_resolution(320, 240)?
        .with_spp(4)
        .with_seed(1);
    let ropts = RenderOptions {
        threads: Some(1),
        quiet: true,
        want_aovs: false,
    };
    ray_log::start();
    render(&scene, &settings, &ropts)?;
    let rays = ray_log::stop();
    let near: Vec<Ray> = rays
        .iter()
        .filter_map(|q| {
            if let Logged::Nearest(r) = q {
                Some(*r)
            } else {
                None
            }
        })
        .collect();
    let shadow: Vec<Ray> = rays
        .iter()
        .filter_map(|q| if let Logged::Shadow(r) = q { Some(*r) } else { None })
        .collect();
    let cam = settings.camera(&scene);
    let (w, h) = (640u32, 480u32);
    let cam = cam.with_resolution(w, h);
    let mut camrays = Vec::new();
    for by in (0..h).step_by(2) {
        for bx in (0..w).step_by(4) {
            for j in 0..2 {
                for i in 0..4 {
                    let (o, d) = cam.ray((bx + i) as f32 + 0.5, (by + j) as f32 + 0.5, (0.5, 0.5));
                    camrays.push(Ray::new(o, d));
                }
            }
        }
    }
    for rep in 0..3 {
        let time = |f: &mut dyn FnMut() -> u64| {
            let t = Instant::now();
            let x = f();
            std::hint::black_box(x);
            t.elapsed().as_secs_f64()
        };
        let e = &scene.embree;
        let n1 = time(&mut || near.iter().map(|r| e.intersect(r).is_some() as u64).sum());
        let n8 = time(&mut || {
            let mut p = Packet8::new();
            let mut s = 0;
            for c in near.chunks(8) {
                p.clear();
                for (i, r) in c.iter().enumerate() {
                    p.set_ray(i, r);
                }
                e.intersect8_incoherent(&mut p);
                for i in 0..c.len() {
                    s += p.hit(i).is_some() as u64;
                }
            }
            s
        });
        let s1 = time(&mut || shadow.iter().map(|r| e.occluded(r) as u64).sum());
        let s8 = time(&mut || {
            let mut p = Packet8::new();
            let mut s = 0;
            for c in shadow.chunks(8) {
                p.clear();
                for (i, r) in c.iter().enumerate() {
                    p.set_ray(i, r);
                }
                e.occluded8(&mut p, false);
                for i in 0..c.len() {
                    s += p.occluded(i) as u64;
                }
            }
            s
        });
        let c1 = time(&mut || camrays.iter().map(|r| e.intersect(r).is_some() as u64).sum());
        let c8 = time(&mut || {
            let mut p = Packet8::new();
            let mut s = 0;
            for c in camrays.chunks(8) {
                p.clear();
                for (i, r) in c.iter().enumerate() {
                    p.set_ray(i, r);
                }
                e.intersect8(&mut p);
                for i in 0..c.len() {
                    s += p.hit(i).is_some() as u64;
                }
            }
            s
        });
        println!(
            "rep {rep}: nearest {} rays: 1-ray {:.1} Mr/s, 8-packet {:.1} Mr/s ({:.2}x) | shadow {}: {:.1} vs {:.1} ({:.2}x) | camera 4x2 {}: {:.1} vs {:.1} ({:.2}x)",
            near.len(), near.len() as f64 / n1 / 1e6, near.len() as f64 / n8 / 1e6, n1 / n8,
            shadow.len(), shadow.len() as f64 / s1 / 1e6, shadow.len() as f64 / s8 / 1e6, s1 / s8,
            camrays.len(), camrays.len() as f64 / c1 / 1e6, camrays.len() as f64 / c8 / 1e6, c1 / c8
        );
    }
    Ok(())
}
