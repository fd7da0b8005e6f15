//! Curved rays in the renderer: the inferior-mirage scene against the same
//! scene with no field.
use snell::render::{render, RenderOptions};
use snell::scene::{load_scene, BuildOptions};
use std::path::Path;

fn row_blue_excess(path: &str) -> (Vec<f64>, snell::render::RenderStats) {
    let mut s = load_scene(Path::new(path), &BuildOptions::default()).unwrap();
    s.set_resolution(96, 32).unwrap();
    s.spp = 2;
    let r = render(
        &s,
        &RenderOptions {
            threads: Some(2),
            quiet: true,
            want_aovs: false,
        },
    )
    .unwrap();
    // Per row: mean of (blue − red); the sky is blue, the desert floor is not.
    let rows = (0..r.height)
        .map(|y| {
            (0..r.width)
                .map(|x| {
                    let p = r.pixels[(y * r.width + x) as usize];
                    (p.z - p.x) as f64
                })
                .sum::<f64>()
                / r.width as f64
        })
        .collect();
    (rows, r.stats)
}

#[test]
fn hot_road_shows_the_sky_below_the_horizon() {
    let (field, st) = row_blue_excess("scenes/mirage_road.toml");
    let (plain, st0) = row_blue_excess("scenes/mirage_road_nofield.toml");
    assert!(
        st.chords > 0 && st0.chords == 0,
        "only the field scene casts chords"
    );
    assert_eq!(st.nan, 0);
    // Rows that see the ground without the field but the sky with it.
    let sky = 0.3; // blue − red of the sky is 0.45; of the floor below 0.
    let mirage_rows = field
        .iter()
        .zip(&plain)
        .filter(|(f, p)| **f > sky && **p < 0.1)
        .count();
    let lost_rows = field
        .iter()
        .zip(&plain)
        .filter(|(f, p)| **f < 0.1 && **p > sky)
        .count();
    eprintln!("rows showing sky only with the field: {mirage_rows}; the reverse: {lost_rows}");
    assert!(
        mirage_rows >= 3,
        "the inferior mirage must show the sky on the road"
    );
    assert_eq!(
        lost_rows, 0,
        "the field must not hide sky the straight view shows"
    );
}
