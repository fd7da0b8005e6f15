//! Scenes written by other tools: glTF 2.0 (`.gltf`, `.glb`) and Mitsuba 3
//! XML (`.xml`). Each importer produces snell's own [`SceneDesc`], which is
//! written out as TOML ([`to_toml`]) and built like any TOML scene, so
//! validation, `--set` overrides and every later feature are shared, and
//! `snell convert` is that TOML. docs/import-gltf.md and
//! docs/import-mitsuba.md say what maps to what and what is refused.
use crate::error::{Error, Result};
use crate::scene::desc::SceneDesc;
use crate::scene::source::Source;
use std::path::Path;

mod cie;
pub mod gltf;
mod meshes;
pub mod mitsuba;
pub mod ply;
pub mod serialized;
mod toml_out;

pub use meshes::load_mesh;
pub use toml_out::to_toml;

/// Largest vertex or triangle count an imported mesh may declare: counts
/// from a file are checked against it (and against the file's size) before
/// anything is allocated.
pub const MAX_MESH_ELEMENTS: u64 = 1 << 26;

/// Options of an import (the CLI's `-D`, `--strict` and `--lenient`).
#[derive(Debug, Clone, Default)]
pub struct ImportOptions {
    /// Mitsuba `$name` parameters given on the command line (`-D name=value`);
    /// they take precedence over the file's `<default>`s.
    pub defines: Vec<(String, String)>,
    /// Refuse the scene when something cannot be mapped exactly (every
    /// warning becomes an error).
    pub strict: bool,
    /// Unknown plugins and parameters become warnings instead of errors.
    pub lenient: bool,
}

/// Which importer reads a scene file, chosen by its extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneFormat {
    /// snell's own TOML (any other extension).
    Toml,
    /// glTF 2.0, `.gltf` or `.glb`.
    Gltf,
    /// Mitsuba 3 XML, `.xml`.
    Mitsuba,
}

impl SceneFormat {
    /// The format of the scene file at `path`, by extension (case-insensitive).
    pub fn of(path: &Path) -> SceneFormat {
        match path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .as_deref()
        {
            Some("gltf" | "glb") => SceneFormat::Gltf,
            Some("xml") => SceneFormat::Mitsuba,
            _ => SceneFormat::Toml,
        }
    }
}

/// A place in an imported file: `file:line:column` (XML) or `file` with a
/// JSON pointer (glTF), and the element there.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// The file as given.
    pub file: String,
    /// 1-based line (1 for glTF).
    pub line: usize,
    /// 1-based column (1 for glTF).
    pub column: usize,
    /// The element: `<shape type="sphere" id="ball">`, or a JSON pointer
    /// such as `/materials/0/extensions/KHR_materials_ior/ior`.
    pub element: String,
}

impl Location {
    /// An input error here.
    pub fn error(&self, message: impl Into<String>) -> Error {
        Error::Input {
            file: self.file.clone(),
            key: self.element.clone(),
            line: self.line,
            column: self.column,
            message: message.into(),
        }
    }

    /// A warning here, as the CLI prints it.
    pub fn warning(&self, message: impl std::fmt::Display) -> Warning {
        Warning {
            at: self.clone(),
            message: message.to_string(),
        }
    }
}

/// Something an importer could not map exactly (dropped or approximated),
/// or, with `lenient`, an unknown plugin or parameter it skipped.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Warning {
    /// Where.
    pub at: Location,
    /// What was not mapped and what was done instead.
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}: {}",
            self.at.file, self.at.line, self.at.column, self.at.element, self.message
        )
    }
}

/// An imported scene: the description, what could not be mapped, and where
/// each part of the description came from.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The scene in snell's terms.
    pub desc: SceneDesc,
    /// One per material (or element) that could not be mapped exactly.
    pub warnings: Vec<Warning>,
    /// Key paths of the description (`objects[2]`, `camera`, `lights[0]`)
    /// and the element each came from, for errors found when building.
    pub origins: Vec<(String, Location)>,
}

impl Imported {
    /// Where key path `key` came from: the origin of its longest prefix.
    pub fn origin(&self, key: &str) -> Option<&Location> {
        self.origins
            .iter()
            .filter(|(k, _)| {
                key == k
                    || key
                        .strip_prefix(k.as_str())
                        .is_some_and(|r| r.starts_with('.') || r.starts_with('['))
            })
            .max_by_key(|(k, _)| k.len())
            .map(|(_, l)| l)
    }

    /// With `strict`, the first warning as an error.
    fn check_strict(&self, strict: bool) -> Result<()> {
        match self.warnings.first() {
            Some(w) if strict => Err(w.at.error(format!(
                "{} (--strict refuses what cannot be mapped exactly; {} warning(s) in all)",
                w.message,
                self.warnings.len()
            ))),
            _ => Ok(()),
        }
    }
}

/// Import a glTF or Mitsuba scene file (by extension).
///
/// # Errors
///
/// [`Error::Io`] when a file cannot be read, [`Error::Input`] naming the
/// file, line:column or JSON pointer, and what was expected, for anything
/// malformed, unknown or refused; with `strict`, the first warning.
pub fn import_scene(path: &Path, opts: &ImportOptions) -> Result<Imported> {
    let imported = match SceneFormat::of(path) {
        SceneFormat::Gltf => gltf::import(path, opts)?,
        SceneFormat::Mitsuba => mitsuba::import(path, opts)?,
        SceneFormat::Toml => {
            return Err(Error::Invalid(format!(
                "{}: not a glTF (.gltf, .glb) or Mitsuba (.xml) scene",
                path.display()
            )))
        }
    };
    imported.check_strict(opts.strict)?;
    Ok(imported)
}

/// A scene file as the TOML the builder reads: the file's own text, or the
/// imported description written as TOML, with what the import found.
pub struct SceneText {
    /// The TOML (for imports, named `FILE (imported)` in errors the import
    /// cannot place).
    pub source: Source,
    /// The import, for glTF and Mitsuba files.
    pub imported: Option<Imported>,
}

impl SceneText {
    /// Read (and for glTF/Mitsuba, import) the scene file at `path`.
    ///
    /// # Errors
    ///
    /// As [`import_scene`]; [`Error::Io`] for an unreadable TOML file.
    pub fn read(path: &Path, opts: &ImportOptions) -> Result<SceneText> {
        if SceneFormat::of(path) == SceneFormat::Toml {
            let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
            return Ok(SceneText {
                source: Source::new(&path.display().to_string(), text),
                imported: None,
            });
        }
        let imported = import_scene(path, opts)?;
        let toml = to_toml(&imported.desc)?;
        Ok(SceneText {
            source: Source::new(&format!("{} (imported)", path.display()), toml),
            imported: Some(imported),
        })
    }

    /// The import's warnings, as lines for the scene's warning list.
    pub fn warnings(&self) -> Vec<String> {
        self.imported
            .iter()
            .flat_map(|i| i.warnings.iter().map(|w| w.to_string()))
            .collect()
    }

    /// An error of building the imported TOML, placed at the element of the
    /// imported file that the key came from (the key stays in the message).
    pub fn relocate(&self, e: Error) -> Error {
        let Some(imp) = &self.imported else { return e };
        match e {
            Error::Input {
                file,
                key,
                line,
                column,
                message,
            } if file == self.source.file => match imp.origin(&key) {
                Some(at) => at.error(format!("{key}: {message}")),
                None => Error::Input {
                    file,
                    key,
                    line,
                    column,
                    message,
                },
            },
            e => e,
        }
    }
}

/// 1-based line and column of byte `offset` in `text`.
pub(crate) fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text.as_bytes()[..offset];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let col = match before.iter().rposition(|&b| b == b'\n') {
        Some(i) => offset - i,
        None => offset + 1,
    };
    (line, col)
}

/// `snell convert`: the scene at `input` as snell TOML, its file names
/// (meshes, textures, maps) valid from `out_dir` (the directory the TOML is
/// written to; `None`: beside the input), and the import's warnings.
///
/// # Errors
///
/// As [`import_scene`].
pub fn convert(input: &Path, out_dir: Option<&Path>, opts: &ImportOptions) -> Result<(String, Vec<Warning>)> {
    let mut imported = import_scene(input, opts)?;
    let from = input.parent().map(Path::to_path_buf).unwrap_or_default();
    if let Some(to) = out_dir {
        let same = match (from.canonicalize(), to.canonicalize()) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        if !same {
            rebase_files(&mut imported.desc, &from);
        }
    }
    Ok((to_toml(&imported.desc)?, imported.warnings))
}

/// Make every relative file name of `desc` absolute, from directory `from`.
fn rebase_files(desc: &mut SceneDesc, from: &Path) {
    use crate::scene::desc::{EnvironmentDesc, ShapeDesc, TextureDesc, TextureTable};
    let fix = |f: &mut String| {
        let p = Path::new(f.as_str());
        if p.is_relative() {
            let j = from.join(p);
            *f = std::path::absolute(&j).unwrap_or(j).display().to_string();
        }
    };
    let fix_tex = |t: &mut TextureDesc| {
        if let TextureDesc::Table(TextureTable::Image(i)) = t {
            fix(&mut i.file);
        }
    };
    if let Some(EnvironmentDesc::Map(m)) = &mut desc.environment {
        fix(&mut m.file);
    }
    for o in &mut desc.objects {
        if let ShapeDesc::Mesh(m) = &mut o.shape {
            fix(&mut m.file);
        }
        if let crate::scene::desc::MaterialDesc::Diffuse(d) = &mut o.material {
            fix_tex(&mut d.reflectance);
        }
        if let Some(e) = &mut o.emission {
            fix_tex(&mut e.radiance);
        }
    }
}
