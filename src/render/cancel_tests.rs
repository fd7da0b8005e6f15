//! Cancelling a render: tiles after the cancel are skipped and reported.
use super::*;
use crate::scene::{load_scene_str, BuildOptions};
use std::sync::Mutex;

/// A glass ball in a white furnace, 64x48 (twelve tiles), 1 spp.
fn ball() -> (RenderScene, RenderSettings) {
    let text = r#"
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
[film]
width = 64
height = 48
spp = 1
[environment]
type = "constant"
radiance = [1.0, 1.0, 1.0]
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.0, 0.0, 0.0], radius = 1.0 }
material = { type = "dielectric", ior = 1.5 }
"#;
    let s = load_scene_str(
        "ball.toml",
        text,
        std::path::Path::new("."),
        &BuildOptions::default(),
    )
    .unwrap();
    let set = RenderSettings::from_scene(&s);
    (s, set)
}

/// On one thread, a token cancelled by the progress callback after the
/// first tile leaves every later tile unstarted, and the render says so;
/// every tile is still reported. A render with its own token, in the
/// same process, is not affected.
#[test]
fn a_cancelled_render_stops_at_the_next_tile_and_reports_it() {
    let (s, set) = ball();
    let cancel = CancelToken::new();
    let reports = Arc::new(Mutex::new(Vec::new()));
    let (token, log) = (cancel.clone(), reports.clone());
    let opts = RenderOptions {
        threads: Some(1),
        progress: ProgressSink::Callback(Arc::new(move |p: &RenderProgress| {
            log.lock().unwrap().push(*p);
            token.cancel();
        })),
        cancel,
        ..RenderOptions::default()
    };
    let r = render(&s, &set, &opts).unwrap();
    let tile_pixels = (TILE * TILE) as u64;
    assert_eq!(r.tiles_total, 12);
    assert_eq!(r.tiles_done, 1, "one tile before the cancel");
    assert!(!r.complete);
    assert_eq!(r.stats.counters.samples, tile_pixels);
    assert_eq!(
        r.pixel_spp.iter().filter(|&&n| n == 1.0).count() as u64,
        tile_pixels
    );
    let reports = reports.lock().unwrap();
    assert_eq!(reports.len(), 12, "skipped tiles are reported too");
    assert!(reports
        .iter()
        .all(|p| p.samples_done == tile_pixels && p.tiles_total == 12));
    assert_eq!(reports.last().map(|p| p.tiles_done), Some(12));

    let whole = render(
        &s,
        &set,
        &RenderOptions {
            threads: Some(1),
            ..RenderOptions::default()
        },
    )
    .unwrap();
    assert!(whole.complete && whole.tiles_done == 12);
    assert_eq!(whole.stats.counters.samples, 64 * 48);
}

/// A token cancelled before the render starts no tile at all.
#[test]
fn a_render_cancelled_before_it_starts_renders_nothing() {
    let (s, set) = ball();
    let opts = RenderOptions {
        threads: Some(2),
        ..RenderOptions::default()
    };
    opts.cancel.cancel();
    let r = render(&s, &set, &opts).unwrap();
    assert!(!r.complete);
    assert_eq!((r.tiles_done, r.stats.counters.samples), (0, 0));
    assert!(r.pixels.iter().all(|p| *p == V3::ZERO));
}
