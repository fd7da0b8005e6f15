//! Writing a command's documents: JSON files (atomically), text to a file or
//! to stdout.
use snell::{Error, Result};
use std::path::{Path, PathBuf};

/// Write `value` as pretty JSON to `path` (atomically).
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value).map_err(|e| Error::Invalid(e.to_string()))?;
    snell::image_io::write_atomic(path, text.as_bytes())
}

/// Write benchmark runs as a JSON array, each object with the provenance.
pub fn write_runs_json(path: &Path, runs: &[impl serde::Serialize]) -> Result<()> {
    let prov = snell::provenance::json();
    let v: Vec<serde_json::Value> = runs
        .iter()
        .map(|r| {
            let mut o = serde_json::to_value(r).unwrap_or_default();
            o["provenance"] = prov.clone();
            o
        })
        .collect();
    write_json(path, &v)
}

/// Write `text` to `output`, or print it when there is none.
pub fn write_or_print(output: Option<PathBuf>, text: &str) -> Result<()> {
    match output {
        Some(p) => snell::image_io::write_atomic(&p, text.as_bytes())?,
        None => say!("{text}"),
    }
    Ok(())
}
