//! `snell report -o DIR [--quick]`: run the measurements and write
//! `DIR/index.html` (plots as inline SVG, images as PNG files beside it) and
//! `DIR/figures.json` (every number plotted, with provenance). Five sections:
//! path-tracer convergence, nested strategies, gradient-index media, warp,
//! pictures side by side. Everything is measured in this one run.
//!
//! One file per section; `figure` is what a section holds (every number it
//! plots), `page` draws it, `sizes` sets how long the run takes.
mod clock;
mod convergence;
mod figure;
mod grin;
mod metrics;
mod nested;
mod page;
mod pictures;
mod scenes;
mod sizes;
mod warp;

use crate::error::{Error, Result};
use crate::image_io::write_atomic;
use figure::ReportDir;
use sizes::{FULL, QUICK};
use std::path::PathBuf;
use std::time::Instant;

/// Options of `snell report`.
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// The report directory (`-o DIR`): created if missing; index.html,
    /// figures.json and the PNG files are written there.
    pub out: PathBuf,
    /// `--quick`: small images and few repetitions (seconds instead of minutes).
    pub quick: bool,
    /// Directory of the scene files the report renders (the repository's `scenes/`).
    pub scenes_dir: PathBuf,
}

/// Run every measurement and write the report; returns the path of index.html.
///
/// `command` is the command line shown in the page and in figures.json; `log`
/// receives one progress line per step, prefixed with the elapsed seconds.
///
/// # Errors
///
/// [`Error::Invalid`] when the report directory cannot be created or is not
/// writable (checked before any measurement), and any error of loading or
/// rendering a scene or writing a file.
pub fn run(o: &ReportOptions, command: &str, mut log: impl FnMut(&str)) -> Result<PathBuf> {
    std::fs::create_dir_all(&o.out)
        .map_err(|e| Error::io(&o.out, format!("cannot create the report directory: {e}")))?;
    // Fail now, not after the measurements, when DIR is not writable.
    write_atomic(&o.out.join(".snell-report-probe"), b"")
        .and_then(|()| {
            std::fs::remove_file(o.out.join(".snell-report-probe")).map_err(|e| Error::io(&o.out, e))
        })
        .map_err(|e| {
            Error::Invalid(format!(
                "report directory {} is not writable: {e}",
                o.out.display()
            ))
        })?;
    let z = if o.quick { &QUICK } else { &FULL };
    let out = ReportDir { dir: o.out.clone() };
    let t0 = Instant::now();
    let mut log = |m: &str| log(&format!("[{:6.1} s] {m}", t0.elapsed().as_secs_f64()));
    let mut provenance = crate::provenance::json();
    if let Some(p) = provenance.as_object_mut() {
        p.insert("threads".into(), rayon::current_num_threads().into());
        p.insert("date".into(), clock::utc_now().into());
        p.insert("mode".into(), if o.quick { "quick" } else { "full" }.into());
    }
    let mut sections = vec![
        convergence::convergence(o, z, &mut log)?,
        nested::nested(o, z, &mut log)?,
        grin::grin(o, z, &mut log)?,
    ];
    let (w, warp_pics) = warp::warp(o, z, &out, &mut log)?;
    sections.push(w);
    sections.push(pictures::pictures(o, z, &out, warp_pics, &mut log)?);
    if let Some(p) = provenance.as_object_mut() {
        p.insert("wall_s".into(), t0.elapsed().as_secs_f64().into());
    }
    let mut map = serde_json::Map::new();
    for s in &sections {
        map.insert(
            s.key.clone(),
            serde_json::to_value(s).map_err(|e| Error::Invalid(e.to_string()))?,
        );
    }
    let figures = serde_json::json!({"provenance": provenance, "command": command, "sections": map});
    let text = serde_json::to_string_pretty(&figures).map_err(|e| Error::Invalid(e.to_string()))?;
    write_atomic(&o.out.join("figures.json"), text.as_bytes())?;
    let index = o.out.join("index.html");
    write_atomic(&index, page::html(&provenance, command, &sections)?.as_bytes())?;
    log("done");
    Ok(index)
}
