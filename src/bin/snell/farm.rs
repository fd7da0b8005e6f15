//! `snell merge` and `snell table`: the render farm's parts merged into the
//! whole render, and the stats table of a sweep.
use crate::args::{MergeArgs, TableArgs};
use crate::output::is_exr;
use crate::write::write_json;
use snell::Result;

pub fn merge(a: MergeArgs) -> Result<()> {
    if a.mkdir {
        snell::farm::make_parent(&a.output)?;
    }
    let files = snell::merge::collect_inputs(&a.parts)?;
    let parts = files
        .iter()
        .map(|f| snell::part::read_part(f))
        .collect::<Result<Vec<_>>>()?;
    let m = snell::merge::merge(&parts)?;
    let (w, h) = (m.meta.film_width, m.meta.film_height);
    let attrs = [
        ("spp", m.meta.spp.to_string()),
        ("complete", "true".to_string()),
        ("merged_parts", files.len().to_string()),
        ("provenance", snell::provenance::line()),
    ];
    if a.part && is_exr(&a.output) {
        snell::part::write_part(&a.output, &m.meta, &m.pixels, &m.accum, &attrs, Some(&m.stats))?;
    } else {
        snell::image_io::save(&a.output, w, h, &m.pixels, &[], &attrs)?;
    }
    if let Some(p) = &a.png {
        snell::image_io::save(p, w, h, &m.pixels, &[], &[])?;
    }
    if let Some(p) = &a.stats_json {
        write_json(p, &m.stats)?;
    }
    if !a.quiet {
        eprintln!(
            "merged {} parts into {w}x{h} at {} spp: {} rays, {:.2} s of task time",
            files.len(),
            m.meta.spp,
            m.stats["rays"],
            m.stats["wall_s"].as_f64().unwrap_or(0.0)
        );
    }
    say!("{}", a.output.display());
    Ok(())
}

pub fn table(a: TableArgs) -> Result<()> {
    let t = snell::farm::stats_table(&a.stats)?;
    match a.output {
        Some(p) => snell::image_io::write_atomic(&p, t.as_bytes()),
        None => {
            say!("{}", t.trim_end());
            Ok(())
        }
    }
}
