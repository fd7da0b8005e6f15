//! The output rules of `snell render` (docs/farm.md). A complete render is
//! written to OUTPUT, an interrupted one to NAME.partial.EXT. A part (a region,
//! a sample range, a resumed render, `--part`) and an interrupted EXR are part
//! EXRs with exact sums, so that they can be merged or resumed; any other
//! render is an image with its diagnostic layers (EXR channels, or grey PNGs
//! beside a PNG). `--resume-partial` continues OUTPUT's own partial and removes
//! it once the render completes.
use snell::farm::Plan;
use snell::render::{Aov, Rendered};
use snell::Result;
use std::path::{Path, PathBuf};

/// Whether `path` names an EXR (the only format that holds layers and sums).
pub fn is_exr(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// Where a render continues from.
pub struct Resume {
    /// The part whose missing samples are rendered: `--resume`, or OUTPUT's own partial.
    pub from: Option<PathBuf>,
    /// OUTPUT's own partial found by `--resume-partial`: removed once the render completes.
    own_partial: Option<PathBuf>,
}

impl Resume {
    /// `--resume PART.exr` as given; without it and with `--resume-partial`,
    /// OUTPUT's own partial when there is one (announced unless `quiet`).
    pub fn new(output: &Path, resume: Option<&PathBuf>, resume_partial: bool, quiet: bool) -> Resume {
        let own_partial = snell::farm::partial_path(output);
        if resume_partial && resume.is_none() && own_partial.is_file() {
            if !quiet {
                eprintln!("resuming {}", own_partial.display());
            }
            Resume {
                from: Some(own_partial.clone()),
                own_partial: Some(own_partial),
            }
        } else {
            Resume {
                from: resume.cloned(),
                own_partial: None,
            }
        }
    }

    /// After `r` was written to `written`: a partial that the render completed
    /// into OUTPUT is consumed (a directory of parts must not hold it twice).
    pub fn finish(&self, r: &Rendered, written: &Path, output: &Path) {
        if let Some(p) = &self.own_partial {
            if r.complete && written == output {
                let _ = std::fs::remove_file(p);
            }
        }
    }
}

/// The file `r` goes to: OUTPUT when complete, NAME.partial.EXT when
/// interrupted (said on stderr, with how much was done).
pub fn written_path(output: &Path, r: &Rendered) -> PathBuf {
    if r.complete {
        return output.to_path_buf();
    }
    let p = snell::farm::partial_path(output);
    eprintln!(
        "interrupted: {} of {} tiles done ({} spp each, the rest black); writing {}",
        r.tiles_done,
        r.tiles_total,
        r.spp_done,
        p.display()
    );
    p
}

/// The written file's attributes: samples per pixel, whether it is complete,
/// the tiles done, the build's provenance.
pub fn attributes(r: &Rendered) -> [(&'static str, String); 4] {
    [
        ("spp", r.spp_done.to_string()),
        ("complete", r.complete.to_string()),
        ("tiles_done", format!("{}/{}", r.tiles_done, r.tiles_total)),
        ("provenance", snell::provenance::line()),
    ]
}

/// Write `r` to `path` in the form the rules above give, with `attrs`; a part
/// EXR also carries `stats`. An interrupted render adds each pixel's sample
/// count as an `spp` layer.
pub fn write_render(
    path: &Path,
    r: &Rendered,
    plan: &Plan,
    aov: &[Aov],
    attrs: &[(&str, String)],
    stats: &serde_json::Value,
    quiet: bool,
) -> Result<()> {
    let is_exr = is_exr(path);
    let mut layers: Vec<(&str, &[f32])> = aov.iter().map(|&l| (l.name(), r.aovs.layer(l))).collect();
    if !r.complete {
        layers.push(("spp", &r.pixel_spp));
    }
    match (&r.accum, is_exr && (plan.is_part || !r.complete)) {
        (Some(acc), true) => {
            snell::part::write_part(path, &plan.meta, &r.pixels, acc, attrs, Some(stats))?;
        }
        _ => snell::image_io::save(
            path,
            r.width,
            r.height,
            &r.pixels,
            if is_exr { &layers } else { &[] },
            attrs,
        )?,
    }
    if !is_exr {
        save_aov_pngs(path, r, &layers, quiet)?;
    }
    Ok(())
}

/// Beside a PNG, each AOV layer as its own grey PNG (NAME.LAYER.png), scaled
/// so that its maximum is white.
fn save_aov_pngs(output: &Path, r: &Rendered, layers: &[(&str, &[f32])], quiet: bool) -> Result<()> {
    for (name, vals) in layers.iter().filter(|l| l.0 != "spp") {
        let max = vals.iter().cloned().fold(0.0f32, f32::max).max(1e-9);
        let px: Vec<glam::Vec3A> = vals.iter().map(|v| glam::Vec3A::splat(v / max)).collect();
        let p = output.with_extension(format!("{name}.png"));
        snell::image_io::save(&p, r.width, r.height, &px, &[], &[])?;
        if !quiet {
            eprintln!("{name}: {} (white = {max})", p.display());
        }
    }
    Ok(())
}
