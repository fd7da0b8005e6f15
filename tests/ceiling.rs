//! `snell bench render`'s recording: the rays it replays are the render's own.
//! (Its own test binary: the ray log is process-wide.)
use snell::integrator::ray_log::{self, Logged};
use snell::render::{render, RenderOptions, RenderSettings};
use snell::scene::{load_scene, BuildOptions};
use std::path::Path;

/// Every recorded query is one the counters saw: one nearest-hit query per
/// path segment (no medium here; the nested rule's re-casts are neither
/// recorded nor segments) and one per shadow ray.
/// A log that missed a call site, or recorded twice, would fail.
#[test]
fn recorded_rays_are_the_renders_queries() {
    for name in ["three_spheres", "glass_of_water", "nested_spheres_a"] {
        let s = load_scene(
            Path::new(&format!("scenes/{name}.toml")),
            &BuildOptions::default(),
        )
        .unwrap();
        let set = RenderSettings::from_scene(&s)
            .with_resolution(24, 18)
            .unwrap()
            .with_spp(2);
        let opts = RenderOptions {
            threads: Some(2),
            quiet: true,
            want_aovs: false,
        };
        ray_log::start();
        let r = render(&s, &set, &opts).unwrap();
        let log = ray_log::stop();
        let nearest = log.iter().filter(|q| matches!(q, Logged::Nearest(_))).count() as u64;
        let shadow = log.len() as u64 - nearest;
        let c = r.stats.counters;
        assert_eq!(nearest, c.segments, "{name}: one nearest-hit query per segment");
        assert_eq!(shadow, c.shadow_rays, "{name}: shadow rays");
        assert!(nearest >= c.samples, "{name}: at least the camera rays");
        // Off again: a second render records nothing.
        render(&s, &set, &opts).unwrap();
        assert!(ray_log::stop().is_empty(), "{name}: recording must stop");
    }
}
