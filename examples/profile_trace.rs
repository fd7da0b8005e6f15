//! Trace-only workload for profilers (perf, callgrind): the nested bench's
//! path rays of one scene traced with one strategy, `reps` times.
//! `cargo run --release --example profile_trace -- scenes/deep_nesting.toml filter 3`
use snell::bench::path_rays;
use snell::counters::Counters;
use snell::dielectric::{self, InteriorList, NestedStrategy};
use snell::scene::{load_scene, BuildOptions};

fn main() -> snell::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    let strategy: NestedStrategy = a[2].parse().map_err(snell::Error::Invalid)?;
    let reps: usize = a.get(3).and_then(|r| r.parse().ok()).unwrap_or(1);
    let scene = load_scene(std::path::Path::new(&a[1]), &BuildOptions::default())?;
    let rays = path_rays(&scene, 160, 120)?;
    let mut c = Counters::default();
    let t = std::time::Instant::now();
    let mut sink = 0u64;
    for _ in 0..reps {
        for r in &rays {
            let mut list = InteriorList::from_solids(&scene.solids, &r.list);
            let h = dielectric::trace(&scene, strategy, &r.ray, &mut list, &mut c)?;
            sink += h.map(|h| h.hit.geom_id as u64).unwrap_or(3) + list.len() as u64;
        }
    }
    std::hint::black_box(sink);
    eprintln!(
        "{} rays x {reps} in {:.3} s; queries {} false hits {} filter calls {}",
        rays.len(),
        t.elapsed().as_secs_f64(),
        c.queries,
        c.false_hits,
        c.filter_calls
    );
    Ok(())
}
