//! Trace one refraction path and print its events (interior lists, indices):
//! `cargo run --release --example trace_one -- SCENE STRATEGY ox oy oz dx dy dz [list]`
use glam::Vec3A as V3;
use snell::counters::Counters;
use snell::dielectric::NestedStrategy;
use snell::integrator::{refraction_path, Tracer};
use snell::scene::{load_scene, BuildOptions};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let strat: NestedStrategy = a[2].parse().unwrap();
    let s = load_scene(std::path::Path::new(&a[1]), &BuildOptions::default()).unwrap();
    let v: Vec<f32> = a[3..9].iter().map(|x| x.parse().unwrap()).collect();
    let o = V3::new(v[0], v[1], v[2]);
    let d = V3::new(v[3], v[4], v[5]);
    let mut c = Counters::default();
    let start: Vec<u32> = a
        .get(9)
        .map(|x| x.split(",").map(|y| y.parse().unwrap()).collect())
        .unwrap_or_default();
    let p = refraction_path(Tracer::new(&s).with_strategy(strat), o, d, &start, 512, &mut c).unwrap();
    for e in &p.events {
        println!(
            "geom {} t {} point {:?} n {}->{} list {:?} next_org {:?}",
            e.geom, e.t, e.point, e.n1, e.n2, e.list_after, e.next_org
        );
    }
    println!("final {:?} escaped {}", p.final_list, p.escaped);
}
