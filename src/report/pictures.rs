//! Section 5: pictures side by side, with their differences judged against
//! seed-to-seed noise.
use super::figure::{plot, series, Picture, ReportDir, Section};
use super::metrics::image_errors;
use super::scenes::render_at;
use super::sizes::Sizes;
use super::ReportOptions;
use crate::error::Result;
use glam::Vec3A as V3;

/// 5. Pictures side by side, with differences (|a - b| × 4).
pub(super) fn pictures(
    o: &ReportOptions,
    z: &Sizes,
    out: &ReportDir,
    warp_pics: Vec<Picture>,
    log: &mut dyn FnMut(&str),
) -> Result<Section> {
    let (w, h, spp) = z.pictures;
    let pairs = [
        (
            "nested_spheres_a",
            "nested_spheres_b",
            spp,
            "Fig. 1 in both priority orders",
        ),
        (
            "glass_of_water_nested",
            "glass_of_water",
            spp,
            "nested vs interface glass of water",
        ),
        (
            "mirage_road",
            "mirage_road_nofield",
            spp.min(16),
            "inferior mirage vs no field",
        ),
        (
            "mirage_sea",
            "mirage_sea_nofield",
            spp.min(16),
            "superior mirage vs no field",
        ),
        (
            "heat_shimmer",
            "heat_shimmer_nofield",
            spp.min(16),
            "heat shimmer vs no field",
        ),
    ];
    let (mut pics, mut summary, mut plot_pts) = (vec![], vec![], vec![]);
    for (k, (a, b, spp, what)) in pairs.into_iter().enumerate() {
        let ra = render_at(&o.scenes_dir, a, w, h, spp, 1)?;
        // b and a second a with another seed: the a-b difference is judged
        // against the a-a' difference (pure noise), block means of 16x16.
        let rb = render_at(&o.scenes_dir, b, w, h, spp, 2)?;
        let ra2 = render_at(&o.scenes_dir, a, w, h, spp, 2)?;
        let noise = image_errors(&ra.pixels, &ra2.pixels, w, h, 16).1;
        let diff: Vec<V3> = ra
            .pixels
            .iter()
            .zip(&rb.pixels)
            .map(|(p, q)| (*p - *q).abs() * 4.0)
            .collect();
        let (e_px, e_blk) = image_errors(&ra.pixels, &rb.pixels, w, h, 16);
        pics.push(out.png(&format!("{a}.png"), w, h, &ra.pixels, format!("{a} ({spp} spp)"))?);
        pics.push(out.png(&format!("{b}.png"), w, h, &rb.pixels, format!("{b} ({spp} spp)"))?);
        pics.push(out.png(
            &format!("diff_{a}_{b}.png"),
            w,
            h,
            &diff,
            format!("|{a} - {b}| x 4: RMSE {e_px:.4}, 16x16 block RMSE {e_blk:.4}"),
        )?);
        summary.push(format!(
            "{what}: RMSE {e_px:.3e}, block-mean RMSE {e_blk:.3e} = {:.2}x the block-mean RMSE of {a} against itself with another seed ({noise:.3e}; about 1 = noise only) ({w}x{h}, {spp} spp)",
            e_blk / noise
        ));
        let x = k as f64 + 1.0;
        plot_pts.push(([x, e_px], [x, e_blk], [x, noise]));
        log(&format!("pictures: {a} / {b}"));
    }
    pics.extend(warp_pics);
    summary
        .push("warp frames beside their exact traces are at the end (see section 4 for their error)".into());
    Ok(Section {
        key: "pictures".into(),
        title: "Pictures side by side".into(),
        summary,
        plots: vec![plot(
            "pictures_difference",
            "Difference of each pair (1 Fig. 1 a/b, 2 water, 3 road, 4 sea, 5 shimmer)",
            "pair",
            "RMSE (linear RGB)",
            (false, false),
            vec![
                series("per pixel", plot_pts.iter().map(|p| p.0).collect()),
                series("16x16 block means", plot_pts.iter().map(|p| p.1).collect()),
                series(
                    "block means, same scene, two seeds",
                    plot_pts.iter().map(|p| p.2).collect(),
                ),
            ],
        )],
        pictures: pics,
        table: None,
    })
}
