//! Mitsuba XML files read into one owned tree: `include`s spliced in (with
//! a depth limit and cycle check), `$name` parameters substituted from
//! `-D` and `<default>`, `<path>` search paths collected, Mitsuba 0.x
//! camelCase parameter names upgraded to snake_case. Every node keeps its
//! file and line:column.
use crate::error::{Error, Result};
use crate::scene::import::{line_col, ImportOptions, Location};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Largest XML file read (a scene's text, not its meshes).
const MAX_XML_BYTES: u64 = 64 << 20;
/// Deepest chain of includes.
const MAX_INCLUDE_DEPTH: usize = 16;
/// Most nodes in the whole tree, includes counted.
const MAX_NODES: usize = 1 << 20;

/// One XML element, attributes substituted.
#[derive(Debug, Clone)]
pub struct Node {
    /// Tag name: `shape`, `float`, `transform`, …
    pub tag: String,
    /// Attributes in document order.
    pub attrs: Vec<(String, String)>,
    /// Child elements (text and comments dropped).
    pub children: Vec<Node>,
    /// Where it is written.
    pub at: Location,
}

impl Node {
    /// The value of attribute `name`.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// The value of attribute `name`, or an error saying it is missing.
    pub fn need(&self, name: &str) -> Result<&str> {
        self.attr(name)
            .ok_or_else(|| self.at.error(format!("expected a `{name}` attribute")))
    }
}

/// The parsed scene: the root `<scene>` with includes spliced, and the
/// directories files are searched in (the scene's own first).
#[derive(Debug)]
pub struct Document {
    /// The root element.
    pub root: Node,
    /// Search paths for files, in order.
    pub search: Vec<PathBuf>,
}

impl Document {
    /// The file `name` refers to: absolute, or found in a search path
    /// (the first that has it; the scene's directory when none does).
    pub fn resolve(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        for d in &self.search {
            let c = d.join(p);
            if c.exists() {
                return c;
            }
        }
        self.search
            .first()
            .map(|d| d.join(p))
            .unwrap_or_else(|| p.to_path_buf())
    }

    /// A resolved file as the scene description names it: relative to the
    /// scene's directory when inside it, else absolute.
    pub fn desc_path(&self, resolved: &Path) -> String {
        if let Some(r) = self.search.first().and_then(|d| resolved.strip_prefix(d).ok()) {
            return r.display().to_string();
        }
        std::path::absolute(resolved)
            .unwrap_or_else(|_| resolved.to_path_buf())
            .display()
            .to_string()
    }
}

struct Reader {
    params: HashMap<String, String>,
    search: Vec<PathBuf>,
    stack: Vec<PathBuf>,
    nodes: usize,
}

/// Read the scene file at `path` and everything it includes.
pub fn read(path: &Path, opts: &ImportOptions) -> Result<Document> {
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut r = Reader {
        params: opts.defines.iter().cloned().collect(),
        search: vec![dir],
        stack: Vec::new(),
        nodes: 0,
    };
    let root = r.file(path, None)?;
    Ok(Document {
        root,
        search: r.search,
    })
}

/// Parse XML text as a scene document (the fuzzer's entry: no includes
/// are followed outside `dir`'s files).
pub fn read_str(file: &str, text: &str, dir: &Path, opts: &ImportOptions) -> Result<Document> {
    let mut r = Reader {
        params: opts.defines.iter().cloned().collect(),
        search: vec![dir.to_path_buf()],
        stack: vec![PathBuf::from(file)],
        nodes: 0,
    };
    let root = r.text(file, text)?;
    Ok(Document {
        root,
        search: r.search,
    })
}

impl Reader {
    fn file(&mut self, path: &Path, from: Option<&Location>) -> Result<Node> {
        let canon = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        if self.stack.contains(&canon) {
            let msg = format!("{} includes itself (a cycle of includes)", path.display());
            return Err(match from {
                Some(at) => at.error(msg),
                None => Error::Invalid(msg),
            });
        }
        if self.stack.len() >= MAX_INCLUDE_DEPTH {
            let msg = format!("includes nest deeper than {MAX_INCLUDE_DEPTH} files");
            return Err(match from {
                Some(at) => at.error(msg),
                None => Error::Invalid(msg),
            });
        }
        let len = std::fs::metadata(path).map_err(|e| Error::io(path, e))?.len();
        if len > MAX_XML_BYTES {
            return Err(Error::io(
                path,
                format!("{len} bytes: XML scene files over {MAX_XML_BYTES} bytes are refused"),
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        self.stack.push(canon);
        let r = self.text(&path.display().to_string(), &text);
        self.stack.pop();
        r
    }

    fn text(&mut self, file: &str, text: &str) -> Result<Node> {
        let doc = roxmltree::Document::parse_with_options(
            text,
            roxmltree::ParsingOptions {
                allow_dtd: false,
                ..Default::default()
            },
        )
        .map_err(|e| {
            let p = e.pos();
            Error::Input {
                file: file.to_string(),
                key: "(XML)".into(),
                line: p.row as usize,
                column: p.col as usize,
                message: e.to_string(),
            }
        })?;
        let root = doc.root_element();
        let at = location(file, text, root);
        if root.tag_name().name() != "scene" {
            return Err(at.error("expected the root element <scene version=\"3.0.0\">"));
        }
        let version = root
            .attribute("version")
            .ok_or_else(|| at.error("expected a `version` attribute (e.g. version=\"3.0.0\")"))?;
        let major: u32 = version
            .split('.')
            .next()
            .and_then(|m| m.trim().parse().ok())
            .ok_or_else(|| at.error(format!("expected a version such as \"3.0.0\", got \"{version}\"")))?;
        if major > 3 {
            return Err(at.error(format!("version {version}: Mitsuba 0.x to 3.x scenes are read")));
        }
        // The root's <default>s first: they hold for the whole file.
        for c in root.children().filter(|c| c.is_element()) {
            if c.tag_name().name() == "default" {
                let cat = location(file, text, c);
                let name = c
                    .attribute("name")
                    .ok_or_else(|| cat.error("expected a `name` attribute"))?;
                let value = c
                    .attribute("value")
                    .ok_or_else(|| cat.error("expected a `value` attribute"))?;
                self.params
                    .entry(name.to_string())
                    .or_insert_with(|| value.to_string());
            }
        }
        let upgrade = major < 2;
        self.node(file, text, root, upgrade)
    }

    fn node(&mut self, file: &str, text: &str, n: roxmltree::Node<'_, '_>, upgrade: bool) -> Result<Node> {
        self.nodes += 1;
        let at = location(file, text, n);
        if self.nodes > MAX_NODES {
            return Err(at.error(format!("more than {MAX_NODES} elements")));
        }
        let mut attrs = Vec::new();
        for a in n.attributes() {
            let mut v = self.substitute(&at, a.value())?;
            if upgrade && a.name() == "name" {
                v = snake_case(&v);
            }
            attrs.push((a.name().to_string(), v));
        }
        let mut out = Node {
            tag: n.tag_name().name().to_string(),
            attrs,
            children: Vec::new(),
            at,
        };
        for c in n.children().filter(|c| c.is_element()) {
            match c.tag_name().name() {
                "default" => {}
                "path" => {
                    let cat = location(file, text, c);
                    let v = c
                        .attribute("value")
                        .ok_or_else(|| cat.error("expected a `value` attribute"))?;
                    let v = self.substitute(&cat, v)?;
                    let base = self.search[0].clone();
                    self.search.push(base.join(v));
                }
                "include" => {
                    let cat = location(file, text, c);
                    let name = c
                        .attribute("filename")
                        .ok_or_else(|| cat.error("expected a `filename` attribute"))?;
                    let name = self.substitute(&cat, name)?;
                    let p = Path::new(&name);
                    let path = if p.is_absolute() {
                        p.to_path_buf()
                    } else {
                        let here = Path::new(file)
                            .parent()
                            .map(Path::to_path_buf)
                            .unwrap_or_default();
                        std::iter::once(here.join(p))
                            .chain(self.search.iter().map(|d| d.join(p)))
                            .find(|c| c.exists())
                            .unwrap_or_else(|| here.join(p))
                    };
                    if !path.is_file() {
                        return Err(cat.error(format!("included file {} not found", path.display())));
                    }
                    let inc = self.file(&path, Some(&cat))?;
                    out.children.extend(inc.children);
                }
                _ => out.children.push(self.node(file, text, c, upgrade)?),
            }
        }
        Ok(out)
    }

    /// `$name` replaced by its parameter (from `-D` or a `<default>`).
    fn substitute(&self, at: &Location, v: &str) -> Result<String> {
        if !v.contains('$') {
            return Ok(v.to_string());
        }
        let mut out = String::with_capacity(v.len());
        let mut rest = v;
        while let Some(k) = rest.find('$') {
            out.push_str(&rest[..k]);
            let after = &rest[k + 1..];
            let end = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..end];
            if name.is_empty() {
                return Err(at.error(format!("a `$` without a parameter name in \"{v}\"")));
            }
            match self.params.get(name) {
                Some(p) => out.push_str(p),
                None => {
                    return Err(at.error(format!(
                        "parameter ${name} has no value: give it with -D {name}=VALUE or a <default name=\"{name}\" value=\"…\"/>"
                    )))
                }
            }
            rest = &after[end..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// Where node `n` of `text` is, and how it reads (`<shape type="sphere" id="a">`).
fn location(file: &str, text: &str, n: roxmltree::Node<'_, '_>) -> Location {
    let (line, column) = line_col(text, n.range().start);
    let mut element = format!("<{}", n.tag_name().name());
    for key in ["type", "name", "id"] {
        if let Some(v) = n.attribute(key) {
            let v: String = v.chars().take(60).collect();
            element.push_str(&format!(" {key}=\"{v}\""));
        }
    }
    element.push('>');
    Location {
        file: file.to_string(),
        line,
        column,
        element,
    }
}

/// `toWorld` → `to_world`, `intIOR` → `int_ior` (Mitsuba 0.x names).
fn snake_case(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 4);
    let chars: Vec<char> = s.chars().collect();
    for (i, &c) in chars.iter().enumerate() {
        if c.is_ascii_uppercase() {
            let prev_lower = i > 0 && chars[i - 1].is_ascii_lowercase();
            let next_lower = chars.get(i + 1).is_some_and(|n| n.is_ascii_lowercase());
            let prev_upper = i > 0 && chars[i - 1].is_ascii_uppercase();
            if i > 0 && (prev_lower || (prev_upper && next_lower)) {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_names_become_snake_case() {
        assert_eq!(snake_case("toWorld"), "to_world");
        assert_eq!(snake_case("intIOR"), "int_ior");
        assert_eq!(snake_case("sampleCount"), "sample_count");
        assert_eq!(snake_case("radius"), "radius");
    }

    #[test]
    fn parameters_substitute_and_missing_ones_are_located() {
        let opts = ImportOptions {
            defines: vec![("spp".into(), "8".into())],
            ..Default::default()
        };
        let text = "<scene version=\"3.0.0\">\n<default name=\"spp\" value=\"4\"/>\n<default name=\"w\" value=\"32\"/>\n<integer name=\"x\" value=\"$spp$w\"/>\n</scene>";
        let d = read_str("t.xml", text, Path::new("."), &opts).unwrap();
        assert_eq!(d.root.children[0].attr("value"), Some("832"));
        let bad = "<scene version=\"3.0.0\">\n  <integer name=\"x\" value=\"$nope\"/>\n</scene>";
        match read_str("t.xml", bad, Path::new("."), &ImportOptions::default()).unwrap_err() {
            Error::Input { line, column, .. } => assert_eq!((line, column), (2, 3)),
            e => panic!("{e}"),
        }
    }
}
