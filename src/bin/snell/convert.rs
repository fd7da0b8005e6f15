//! `snell convert`: a glTF or Mitsuba scene written as snell TOML.
use crate::args::ConvertArgs;
use crate::write::write_or_print;
use snell::Result;
use std::path::Path;

/// The imported scene as TOML (to the output or stdout), its warnings on stderr.
pub fn convert(a: ConvertArgs) -> Result<()> {
    // Relative paths in the TOML (meshes, textures) start from the output's directory.
    let dir = a
        .output
        .as_ref()
        .map(|o| o.parent().map(Path::to_path_buf).unwrap_or_default());
    let (toml, warnings) = snell::scene::import::convert(&a.input, dir.as_deref(), &a.import.options()?)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    write_or_print(a.output, &toml)
}
