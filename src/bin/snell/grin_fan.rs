//! `snell grin-fan`: load the scene with its overrides, trace the fan, write
//! the SVG (and the JSON when asked).
use crate::args::GrinFanArgs;
use snell::grin_fan::{fan_svg, trace_fan, FanOptions};
use snell::scene::BuildOptions;
use snell::Result;

pub fn grin_fan(a: GrinFanArgs) -> Result<()> {
    let build = BuildOptions {
        import: a.import.options()?,
        ..BuildOptions::default()
    };
    let (scene, _) = snell::farm::load(&a.scene, &a.set, &build, "filter")?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    if scene.medium.is_none() {
        eprintln!(
            "warning: {} has no [medium]: the fan's rays are straight",
            a.scene.display()
        );
    }
    let opts = FanOptions {
        rays: a.rays,
        elevations: a.from.zip(a.to),
        max_distance: a.max_distance,
        tolerance: a.tolerance,
        toward: a.toward.as_deref().map(parse_point).transpose()?,
        ..FanOptions::default()
    };
    let fan = trace_fan(&scene, &opts)?;
    for r in fan.rays.iter().filter(|r| r.failure.is_some()) {
        eprintln!(
            "warning: the ray at {:.4}° stopped early: {}",
            r.elevation_deg,
            r.failure.as_deref().unwrap_or_default()
        );
    }
    let title = a
        .scene
        .file_name()
        .map_or_else(String::new, |f| f.to_string_lossy().into_owned());
    snell::image_io::write_atomic(&a.output, fan_svg(&fan, &title).as_bytes())?;
    if let Some(j) = &a.json {
        crate::write::write_json(j, &fan)?;
    }
    Ok(())
}

/// `X,Y,Z` as a world point.
fn parse_point(s: &str) -> Result<glam::DVec3> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| {
            snell::Error::Invalid(format!("--toward {s}: expected X,Y,Z (three numbers, metres)"))
        })?;
    match v[..] {
        [x, y, z] => Ok(glam::DVec3::new(x, y, z)),
        _ => Err(snell::Error::Invalid(format!(
            "--toward {s}: expected X,Y,Z (three numbers, metres)"
        ))),
    }
}
