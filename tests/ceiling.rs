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
    let nearest = log.iter().filter(|q| matches!(q, RayQuery::Nearest(_))).count() as u64;
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
