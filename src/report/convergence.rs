//! Section 1: the path tracer's error against a high-spp reference vs wall
//! time, per reference scene.
use super::figure::{plot, series, Section, Table};
use super::metrics::{image_errors, loglog_slope};
use super::scenes::render_at;
use super::sizes::Sizes;
use super::ReportOptions;
use crate::bench::REFERENCE_SCENES;
use crate::error::Result;
use crate::render::Rendered;

/// 1. Error against a high-spp reference vs wall time, per reference scene.
pub(super) fn convergence(o: &ReportOptions, z: &Sizes, log: &mut dyn FnMut(&str)) -> Result<Section> {
    let (w, h, spps, ref_spp) = z.conv;
    let (mut block, mut pixel, mut speed) = (vec![], vec![], vec![]);
    let mut summary = vec![];
    let mut rows = vec![];
    for name in REFERENCE_SCENES {
        let reference = render_at(&o.scenes_dir, name, w, h, ref_spp, 7_777)?;
        log(&format!(
            "convergence: {name} reference {ref_spp} spp in {:.1} s",
            reference.stats.wall_s
        ));
        let (mut bp, mut pp) = (vec![], vec![]);
        let mut last: Option<Rendered> = None;
        for &spp in spps {
            let r = render_at(&o.scenes_dir, name, w, h, spp, 1)?;
            let (e_px, e_blk) = image_errors(&r.pixels, &reference.pixels, w, h, 16);
            bp.push([r.stats.wall_s, e_blk]);
            pp.push([r.stats.wall_s, e_px]);
            rows.push(vec![
                name.to_string(),
                spp.to_string(),
                format!("{:.3}", r.stats.wall_s),
                format!("{e_px:.4}"),
                format!("{e_blk:.4}"),
                format!("{:.0}", r.stats.counters.samples as f64 / r.stats.wall_s),
                format!("{:.2}", r.stats.counters.rays() as f64 / r.stats.wall_s / 1e6),
            ]);
            last = Some(r);
        }
        let (sp, sb) = (loglog_slope(&pp), loglog_slope(&bp));
        if let Some(r) = last {
            let (sps, rps) = (
                r.stats.counters.samples as f64 / r.stats.wall_s,
                r.stats.counters.rays() as f64 / r.stats.wall_s,
            );
            speed.push([sps, rps]);
            summary.push(format!(
                "{name}: slope of per-pixel RMSE vs time {sp:.2} (block-mean RMSE {sb:.2}; -0.5 is unbiased Monte Carlo); {:.0} samples/s, {:.2} Mrays/s at {} spp",
                sps,
                rps / 1e6,
                spps.last().copied().unwrap_or(0)
            ));
        }
        pixel.push(series(name, pp));
        block.push(series(name, bp));
    }
    let top = f64::from(spps.last().copied().unwrap_or(1));
    summary.push(format!(
        "{w}x{h}, spp {spps:?}; reference {ref_spp} spp with another seed (its own noise inflates the error at {top} spp by {:.0}%)",
        100.0 * ((1.0 + top / f64::from(ref_spp)).sqrt() - 1.0)
    ));
    Ok(Section {
        key: "convergence".into(),
        title: "Path tracer convergence".into(),
        summary,
        plots: vec![
            plot(
                "conv_pixel",
                "Per-pixel RMSE vs wall time",
                "wall time (s)",
                "RMSE (linear RGB)",
                (true, true),
                pixel,
            ),
            plot(
                "conv_block",
                "RMSE of 16x16 block means vs wall time",
                "wall time (s)",
                "block RMSE",
                (true, true),
                block,
            ),
        ],
        pictures: vec![],
        table: Some(Table {
            header: [
                "scene",
                "spp",
                "wall s",
                "pixel RMSE",
                "block RMSE",
                "samples/s",
                "Mrays/s",
            ]
            .map(String::from)
            .to_vec(),
            rows,
        }),
    })
}
