//! `snell warp-render`: a `[warp]` scene rendered through warped meshes,
//! optionally against the exact trace, and its report lines.
use crate::args::WarpRenderArgs;
use crate::write::write_json;
use snell::scene::{load_scene, BuildOptions};
use snell::Result;
use std::path::Path;

pub fn warp_render(a: WarpRenderArgs) -> Result<()> {
    use snell::warp_render::{run as warp_run, WarpRunOptions};
    let mut s = load_scene(&a.scene, &BuildOptions::default())?;
    if a.width.is_some() || a.height.is_some() {
        s.set_resolution(a.width.unwrap_or(s.width), a.height.unwrap_or(s.height))?;
    }
    let rep = warp_run(
        &s,
        &WarpRunOptions {
            threads: a.threads,
            subdivide: a.subdivide,
            method: a.method.map(Into::into),
            fresnel: a.fresnel.then_some(true),
            compare: a.compare.is_some(),
        },
    )?;
    let f = &rep.frame;
    snell::image_io::save(&a.output, f.width, f.height, &f.pixels, &[], &[])?;
    if let (Some(path), Some((ex, cmp, heat))) = (&a.compare, &rep.exact) {
        snell::image_io::save(path, ex.width, ex.height, heat, &[], &[])?;
        if let Some(p) = &a.exact_output {
            snell::image_io::save(p, ex.width, ex.height, &ex.pixels, &[], &[])?;
        }
        if !a.quiet {
            eprintln!("{}", warp_comparison_line(cmp, path));
            eprintln!("{}", warp_speed_line(&rep, ex));
        }
    }
    if !a.quiet {
        eprintln!("{}", warp_summary_line(&rep));
    }
    if let Some(p) = &a.stats_json {
        write_json(p, &rep.to_json())?;
    }
    say!("{}", a.output.display());
    Ok(())
}

// The warp report's lines (its types live in `snell::warp_render`).

/// Warp frame against the exact trace: image RMSE and position error, in
/// scene units and in pixel footprints.
fn warp_comparison_line(cmp: &snell::warp_render::Comparison, heatmap: &Path) -> String {
    format!(
        "compare: RMSE {:.4}; position error over {} matched pixels: mean {:.3e} / median {:.3e} / p95 {:.3e} / max {:.3e} units = mean {:.3} / median {:.3} / p95 {:.3} / max {:.2} pixel footprints; {} pixels ({:.2}%) show different objects; heatmap {}",
        cmp.rmse,
        cmp.matched,
        cmp.pos_mean,
        cmp.pos_median,
        cmp.pos_p95,
        cmp.pos_max,
        cmp.px_mean,
        cmp.px_median,
        cmp.px_p95,
        cmp.px_max,
        cmp.mismatched,
        100.0 * cmp.mismatched as f64 / cmp.pixels.max(1) as f64,
        heatmap.display()
    )
}

/// Seconds per warp frame (and its parts) against the exact trace; the
/// ratios are exact time / warp time (> 1: the warp is faster).
fn warp_speed_line(rep: &snell::warp_render::WarpReport, exact: &snell::warp_render::Frame) -> String {
    format!(
        "speed: warp frame {:.4} s (warp {:.4} + copies {:.4} + primary rays {:.4}) vs exact trace {:.4} s: {:.2}x (render only {:.2}x)",
        rep.frame_s(),
        rep.warp_s,
        rep.build_s,
        rep.frame.render_s,
        exact.render_s,
        exact.render_s / rep.frame_s().max(1e-12),
        exact.render_s / rep.frame.render_s.max(1e-12)
    )
}

/// The warped meshes: size, images, dropped triangles, copies per object.
fn warp_summary_line(rep: &snell::warp_render::WarpReport) -> String {
    format!(
        "warp: {} vertices, {} triangles (longest projected edge {:.2} px), {} images, {} triangles in no copy, {} outside the view; copies {:?}",
        rep.vertices, rep.triangles, rep.max_edge_px, rep.images, rep.dropped_triangles, rep.culled_triangles, rep.copies
    )
}
