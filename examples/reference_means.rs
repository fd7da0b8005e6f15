//! Regenerates tests/data/reference_means.json: image means of the reference
//! scenes at 80×60 with many samples, and their Monte Carlo standard errors.
//! Run: cargo run --release --example reference_means -- 2048 > tests/data/reference_means.json
use snell::render::{render, RenderOptions, RenderSettings};
use snell::scene::{load_scene, BuildOptions};
use std::path::Path;

fn main() -> snell::Result<()> {
    let spp: u32 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1024);
    let mut out = serde_json::Map::new();
    out.insert(
        "made_by".into(),
        format!(
            "cargo run --release --example reference_means -- {spp} (80x60, seed 999, strategy filter); {}",
            snell::provenance::line()
        )
        .into(),
    );
    for name in ["three_spheres", "glass_of_water", "cylinder_refraction"] {
        let s = load_scene(
            Path::new(&format!("scenes/{name}.toml")),
            &BuildOptions::default(),
        )?;
        let set = RenderSettings::from_scene(&s)
            .with_resolution(80, 60)?
            .with_spp(spp)
            .with_seed(999);
        let r = render(
            &s,
            &set,
            &RenderOptions {
                threads: None,
                want_aovs: false,
                ..Default::default()
            },
        )?;
        let ms: Vec<(f64, f64)> = (0..3).map(|c| r.mean_and_se(c)).collect();
        out.insert(
            name.into(),
            serde_json::json!({"mean": ms.iter().map(|m| m.0).collect::<Vec<_>>(), "se": ms.iter().map(|m| m.1).collect::<Vec<_>>(), "spp": spp}),
        );
    }
    println!("{}", serde_json::to_string_pretty(&out).unwrap());
    Ok(())
}
