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

/// Next-event estimation skips connections through the medium's bounds and
/// BSDF-sampled hits of a light through the medium get full weight: with a
/// constant-index "medium" (rays straight) the image must equal the one
/// without it (the MIS bookkeeping), only noisier. Also a regression test for
/// zero-length chords at the box faces, which used to end paths as
/// "integrator failures" (56,707 of them in this scene).
#[test]
fn next_event_estimation_around_a_medium_is_unbiased() {
    let scene = |medium: bool| {
        format!(
            r#"
[camera]
position = [0.0, 1.5, 3.0]
target = [0.0, 0.0, 0.0]
fov = 50.0
[film]
width = 24
height = 18
spp = 256
[integrator]
type = "path"
max_depth = 3
[[lights]]
type = "rect"
center = [0.0, 2.0, 0.0]
normal = [0.0, -1.0, 0.0]
u_axis = [1.0, 0.0, 0.0]
size = [1.0, 1.0]
radiance = [4.0, 4.0, 4.0]
[[objects]]
name = "floor"
shape = {{ type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [4.0, 4.0] }}
material = {{ type = "diffuse", reflectance = [0.7, 0.7, 0.7] }}
{}
"#,
            if medium {
                "[medium]\nfield = { kind = \"constant\", n = 1.000293 }\nbounds = { min = [-3.0, 0.5, -3.0], max = [0.3, 1.5, 3.0] }\n"
            } else {
                ""
            }
        )
    };
    let run = |text: String| {
        let s = snell::scene::load_scene_str("nee.toml", &text, Path::new("."), &BuildOptions::default())
            .unwrap();
        render(
            &s,
            &RenderOptions {
                threads: Some(2),
                quiet: true,
                want_aovs: false,
            },
        )
        .unwrap()
    };
    let with = run(scene(true));
    let without = run(scene(false));
    assert!(with.stats.chords > 0 && without.stats.chords == 0);
    let (m1, se1) = with.mean_and_se(0);
    let (m0, se0) = without.mean_and_se(0);
    let z = (m1 - m0).abs() / (se1 * se1 + se0 * se0).sqrt();
    assert_eq!(with.stats.grin_failures, 0);
    eprintln!("mean with a constant medium {m1:.4} ± {se1:.4}, without {m0:.4} ± {se0:.4}: {z:.2} SE");
    assert!(z < 5.0, "{m1} ± {se1} vs {m0} ± {se0}");
    assert!(
        se1 > se0,
        "without NEE through the bounds the estimate must be noisier"
    );
}
