//! Where a key lives in a TOML document: line:column for error messages.
use crate::error::Error;
use toml_edit::{ImDocument, Item, Value};

/// A scene file's text with its parsed span map.
pub struct Source {
    /// The file name as given (or `--set '…'` for an override), the first
    /// part of every error it locates.
    pub file: String,
    /// The TOML text, after any `--set` overrides.
    pub text: String,
    doc: Option<ImDocument<String>>,
    /// With `--set` overrides: the file as written (errors at keys not
    /// overridden are located there) and where each override sits.
    base: Option<Box<Source>>,
    overrides: Vec<OverrideLoc>,
}

/// Where a `--set KEY=VALUE` override sits, for located errors.
#[derive(Debug, Clone)]
pub struct OverrideLoc {
    /// The key path it sets, with array indices (`objects[1].material.ior`).
    pub path: String,
    /// The whole argument, `KEY=VALUE`.
    pub arg: String,
    /// 1-based column of the value in `arg`.
    pub value_col: usize,
}

/// Does key path `key` lie at or below `prefix`?
fn under(key: &str, prefix: &str) -> bool {
    key == prefix
        || key
            .strip_prefix(prefix)
            .is_some_and(|r| r.starts_with('.') || r.starts_with('['))
}

/// One step of a key path.
#[derive(Debug, Clone)]
pub enum Seg {
    /// A table key, `material`.
    Key(String),
    /// An array index, `[2]` (0-based).
    Index(usize),
}

/// Parse `objects[2].material.ior` into segments.
///
/// Lenient, for locating errors: empty parts and indices that are not
/// numbers are skipped.
pub fn parse_path(path: &str) -> Vec<Seg> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let mut rest = part;
        if let Some(b) = rest.find('[') {
            if b > 0 {
                out.push(Seg::Key(rest[..b].to_string()));
            }
            rest = &rest[b..];
            while let Some(stripped) = rest.strip_prefix('[') {
                let end = stripped.find(']').unwrap_or(stripped.len());
                if let Ok(i) = stripped[..end].parse() {
                    out.push(Seg::Index(i));
                }
                rest = stripped.get(end + 1..).unwrap_or("");
            }
        } else if !rest.is_empty() {
            out.push(Seg::Key(rest.to_string()));
        }
    }
    out
}

impl Source {
    /// The text of `file`, parsed for key spans. A text that does not parse
    /// is kept: [`Source::toml_error`] still locates the parser's error, and
    /// [`Source::error`] falls back to line 1, column 1.
    pub fn new(file: &str, text: String) -> Source {
        let doc = ImDocument::parse(text.clone()).ok();
        Source {
            file: file.to_string(),
            text,
            doc,
            base: None,
            overrides: Vec::new(),
        }
    }

    /// The document after `--set` overrides (`text`), locating errors in the
    /// override's argument when the key is at, below or above an overridden
    /// one, and in `base` (the file as written) otherwise.
    pub fn with_overrides(base: Source, text: String, overrides: Vec<OverrideLoc>) -> Source {
        let mut s = Source::new(&base.file, text);
        s.base = Some(Box::new(base));
        s.overrides = overrides;
        s
    }

    /// An error at `key` caused by an override, if one sets it or a key around it.
    fn override_error(&self, key: &str, message: &str) -> Option<Error> {
        if key == "(document)" {
            return None;
        }
        let o = self
            .overrides
            .iter()
            .find(|o| under(key, &o.path))
            .or_else(|| self.overrides.iter().find(|o| under(&o.path, key)))?;
        // Unknown keys are located at the key, everything else at the value.
        let column = if message.contains("unknown field") {
            1
        } else {
            o.value_col
        };
        Some(Error::Input {
            file: format!("--set '{}'", o.arg),
            key: key.to_string(),
            line: 1,
            column,
            message: message.to_string(),
        })
    }

    /// 1-based line and column of a byte offset.
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let before = &self.text[..offset];
        let line = before.matches('\n').count() + 1;
        let col = before.rfind('\n').map(|i| offset - i).unwrap_or(offset + 1);
        (line, col)
    }

    /// Span start of the deepest existing item along `path`.
    fn offset_of(&self, path: &[Seg]) -> Option<usize> {
        let doc = self.doc.as_ref()?;
        let mut best = None;
        let mut item: ItemRef<'_> = ItemRef::Item(doc.as_item());
        for seg in path {
            let next = match (&item, seg) {
                (ItemRef::Item(Item::Table(t)), Seg::Key(k)) => {
                    if let Some((key, it)) = t.get_key_value(k) {
                        best = key.span().map(|s| s.start).or(best);
                        Some(ItemRef::Item(it))
                    } else {
                        None
                    }
                }
                (ItemRef::Item(Item::ArrayOfTables(a)), Seg::Index(i)) => a.get(*i).map(|t| {
                    best = t.span().map(|s| s.start).or(best);
                    ItemRef::Table(t)
                }),
                (ItemRef::Table(t), Seg::Key(k)) => t.get_key_value(k).map(|(key, it)| {
                    best = key.span().map(|s| s.start).or(best);
                    ItemRef::Item(it)
                }),
                (ItemRef::Item(Item::Value(v)), s) | (&ItemRef::Value(v), s) => value_child(v, s).map(|c| {
                    best = c.span().map(|s| s.start).or(best);
                    ItemRef::Value(c)
                }),
                _ => None,
            };
            match next {
                Some(n) => item = n,
                None => break,
            }
        }
        best
    }

    /// Byte offset → key path of the deepest item whose span contains it.
    pub fn path_at(&self, offset: usize) -> String {
        let Some(doc) = self.doc.as_ref() else {
            return "(document)".into();
        };
        let mut path = String::new();
        walk_table(doc.as_table(), offset, &mut path);
        if path.is_empty() {
            "(document)".into()
        } else {
            path
        }
    }

    /// An input error at `key` (a path such as `objects[2].shape.radius`).
    pub fn error(&self, key: &str, message: impl Into<String>) -> Error {
        let message = message.into();
        if let Some(e) = self.override_error(key, &message) {
            return e;
        }
        if let Some(b) = &self.base {
            return b.error(key, message);
        }
        let (line, column) = self
            .offset_of(&parse_path(key))
            .map(|o| self.line_col(o))
            .unwrap_or((1, 1));
        Error::Input {
            file: self.file.clone(),
            key: key.to_string(),
            line,
            column,
            message,
        }
    }

    /// Convert a TOML/serde error into an input error with the key path.
    pub fn toml_error(&self, e: &toml::de::Error) -> Error {
        let offset = e.span().map(|s| s.start).unwrap_or(0);
        if self.base.is_some() {
            return self.error(&self.path_at(offset), e.message().trim());
        }
        let (line, column) = self.line_col(offset);
        Error::Input {
            file: self.file.clone(),
            key: self.path_at(offset),
            line,
            column,
            message: e.message().trim().to_string(),
        }
    }
}

enum ItemRef<'a> {
    Item(&'a Item),
    Table(&'a toml_edit::Table),
    Value(&'a Value),
}

fn value_child<'a>(v: &'a Value, s: &Seg) -> Option<&'a Value> {
    match (v, s) {
        (Value::InlineTable(t), Seg::Key(k)) => t.get(k),
        (Value::Array(a), Seg::Index(i)) => a.get(*i),
        _ => None,
    }
}

fn contains(span: Option<std::ops::Range<usize>>, offset: usize) -> bool {
    span.map(|s| s.start <= offset && offset <= s.end)
        .unwrap_or(false)
}

fn push_key(path: &mut String, k: &str) {
    if !path.is_empty() {
        path.push('.');
    }
    path.push_str(k);
}

fn walk_table(t: &toml_edit::Table, offset: usize, path: &mut String) {
    for (k, item) in t.iter() {
        let key_span = t.key(k).and_then(|key| key.span());
        match item {
            Item::Table(sub) => {
                if contains(sub.span(), offset) || contains(key_span.clone(), offset) {
                    push_key(path, k);
                    walk_table(sub, offset, path);
                    return;
                }
                // Tables' own spans cover the header only; look inside too.
                let before = path.len();
                push_key(path, k);
                let inner = path.len();
                walk_table(sub, offset, path);
                if path.len() > inner {
                    return;
                }
                path.truncate(before);
            }
            Item::ArrayOfTables(a) => {
                for (i, sub) in a.iter().enumerate() {
                    let before = path.len();
                    push_key(path, k);
                    path.push_str(&format!("[{i}]"));
                    let inner = path.len();
                    if contains(sub.span(), offset) {
                        walk_table(sub, offset, path);
                        return;
                    }
                    walk_table(sub, offset, path);
                    if path.len() > inner {
                        return;
                    }
                    path.truncate(before);
                }
            }
            Item::Value(v) => {
                if contains(v.span(), offset) || contains(key_span, offset) {
                    push_key(path, k);
                    walk_value(v, offset, path);
                    return;
                }
            }
            Item::None => {}
        }
    }
}

fn walk_value(v: &Value, offset: usize, path: &mut String) {
    match v {
        Value::InlineTable(t) => {
            for (k, c) in t.iter() {
                let ks = t.key(k).and_then(|key| key.span());
                if contains(c.span(), offset) || contains(ks, offset) {
                    push_key(path, k);
                    walk_value(c, offset, path);
                    return;
                }
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                if contains(c.span(), offset) {
                    path.push_str(&format!("[{i}]"));
                    walk_value(c, offset, path);
                    return;
                }
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locates_nested_keys() {
        let text = "[camera]\nfov = 3\n\n[[objects]]\nname = \"a\"\n\n[[objects]]\nshape = { type = \"sphere\", radius = -1 }\n";
        let s = Source::new("x.toml", text.into());
        match s.error("objects[1].shape.radius", "negative") {
            Error::Input { line, column, .. } => {
                assert_eq!(line, 8);
                assert!(column > 20, "{column}");
            }
            e => panic!("{e}"),
        }
        let off = text.find("-1").unwrap();
        assert_eq!(s.path_at(off), "objects[1].shape.radius");
    }
}
