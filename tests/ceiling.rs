//! `snell bench render`'s recording: the rays it replays are the render's
//! own, and each render's observer hears only that render.
use snell::integrator::{RayQuery, RayRecorder};
use snell::render::{render, RenderOptions, RenderSettings, Rendered};
use snell::scene::{load_scene, BuildOptions, RenderScene};
use std::path::Path;
use std::sync::Arc;

fn scene(name: &str) -> RenderScene {
    load_scene(
        Path::new(&format!("scenes/{name}.toml")),
        &BuildOptions::default(),
    )
    .unwrap()
}

fn settings(s: &RenderScene, spp: u32) -> RenderSettings {
    RenderSettings::from_scene(s)
        .with_resolution(24, 18)
        .unwrap()
        .with_spp(spp)
}

/// Render `s` at 24x18 and `spp` with `recorder` as its observer.
fn render_into(s: &RenderScene, spp: u32, recorder: &Arc<RayRecorder>) -> Rendered {
    let opts = RenderOptions {
        threads: Some(2),
        observer: Some(recorder.clone()),
        ..RenderOptions::default()
    };
    render(s, &settings(s, spp), &opts).unwrap()
}

/// Render `s` at 24x18 and `spp`, recording its queries.
fn recorded(s: &RenderScene, spp: u32) -> (Rendered, Vec<RayQuery>) {
    let recorder = Arc::new(RayRecorder::new());
    let r = render_into(s, spp, &recorder);
    (r, recorder.take())
}

/// The recorded queries match the render's counters: one nearest-hit query
/// per path segment and one per shadow ray.
fn assert_matches_counters(name: &str, r: &Rendered, log: &[RayQuery]) {
    let nearest = log
        .iter()
        .filter(|q| matches!(q, RayQuery::Nearest(_) | RayQuery::Coherent(_)))
        .count() as u64;
    let shadow = log.len() as u64 - nearest;
    let c = r.stats.counters;
    assert_eq!(nearest, c.segments, "{name}: one nearest-hit query per segment");
    assert_eq!(shadow, c.shadow_rays, "{name}: shadow rays");
    assert!(nearest >= c.samples, "{name}: at least the camera rays");
}

/// Every recorded query is one the counters saw: one nearest-hit query per
/// path segment (no medium here; the nested rule's re-casts are neither
/// recorded nor segments) and one per shadow ray.
/// A recorder that missed a call site, or recorded twice, would fail.
#[test]
fn recorded_rays_are_the_renders_queries() {
    for name in ["three_spheres", "glass_of_water", "nested_spheres_a"] {
        let s = scene(name);
        let recorder = Arc::new(RayRecorder::new());
        let r = render_into(&s, 2, &recorder);
        assert_matches_counters(name, &r, &recorder.take());
        // A later render without the observer is not heard by it.
        let opts = RenderOptions {
            threads: Some(2),
            ..RenderOptions::default()
        };
        render(&s, &settings(&s, 2), &opts).unwrap();
        assert!(recorder.take().is_empty(), "{name}: recording must stop");
    }
}

/// Two renders at once in one process, each with its own recorder, record
/// independently: each log matches its own render's counters (a shared,
/// process-wide log would hold both renders' rays).
#[test]
fn two_renders_at_once_record_independently() {
    let (a, b) = (scene("three_spheres"), scene("glass_of_water"));
    let ((ra, la), (rb, lb)) = std::thread::scope(|sc| {
        let ta = sc.spawn(|| recorded(&a, 3));
        let tb = sc.spawn(|| recorded(&b, 1));
        (ta.join().unwrap(), tb.join().unwrap())
    });
    assert_matches_counters("three_spheres", &ra, &la);
    assert_matches_counters("glass_of_water", &rb, &lb);
    assert_ne!(la.len(), lb.len(), "two different renders");
}

/// The coherent queries are the camera rays and their smooth continuations:
/// on three_spheres (no solids, so every segment is a packet query) at
/// least one per sample, each thread's in its order, so a pixel's camera
/// rays come one after another; a diffuse scene's later segments are not
/// coherent. And `snell bench render` replays them in packets and one by
/// one with the same hits, but for at most one ray in a thousand.
#[test]
fn coherent_queries_are_the_camera_rays_and_the_ceiling_replays_them() {
    let s = scene("three_spheres");
    let (r, log) = recorded(&s, 2);
    let coherent: Vec<_> = log
        .iter()
        .filter_map(|q| match q {
            RayQuery::Coherent(ray) => Some(*ray),
            _ => None,
        })
        .collect();
    let c = r.stats.counters;
    assert!(
        coherent.len() as u64 >= c.samples,
        "three_spheres: every camera ray is coherent"
    );
    assert!(
        (coherent.len() as u64) < c.segments,
        "three_spheres: bounces off the floor are not"
    );
    // A pixel's two camera rays (from the pinhole) are next to each other
    // in the log: one thread's order, not the two threads' interleaved.
    let cam = settings(&s, 2).camera(&s);
    let eye = coherent[0].org;
    let pixel = |r: &snell::ray::Ray| {
        (r.org == eye)
            .then(|| cam.project(r.org + r.dir))
            .flatten()
            .map(|(x, y)| (x.floor() as i32, y.floor() as i32))
    };
    let pairs = coherent
        .windows(2)
        .filter(|w| pixel(&w[0]).is_some() && pixel(&w[0]) == pixel(&w[1]))
        .count() as u64;
    assert!(
        pairs * 100 >= c.samples / 2 * 95,
        "{pairs} of {} pixels' pairs",
        c.samples / 2
    );
    let opts = snell::ceiling::CeilingOptions {
        scenes: vec!["three_spheres".into(), "glass_of_water_nested".into()],
        render: (32, 24, 2),
        record_spp: 1,
        reps: 1,
        ..Default::default()
    };
    for run in snell::ceiling::ceiling(&opts, |_| {}).unwrap() {
        assert!(run.coherent_share > 0.05, "{}: {}", run.scene, run.coherent_share);
        let rays = run.rays_per_sample * (32 * 24) as f64;
        assert!(
            (run.hits_differ as f64) <= rays * 1e-3,
            "{}: {} of {rays} rays hit in one replay only",
            run.scene,
            run.hits_differ
        );
        // A ratio of two timings: only that it is one (its size is the
        // bench's business, and a loaded or unoptimised test run moves it).
        assert!(
            run.share[0].is_finite() && run.share[0] > 0.0,
            "{}: {:?}",
            run.scene,
            run.share
        );
    }
}
