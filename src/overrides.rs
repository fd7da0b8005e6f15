//! `snell render --set KEY=VALUE`: override any scene key by its path, for
//! parameter sweeps. `KEY` is a dotted path; array entries are chosen by index
//! (`objects[2]`) or, for `[[objects]]` and `[[lights]]`, by name
//! (`objects.water.material.ior=1.34`). `VALUE` is a TOML value (`1.34`,
//! `[0, 1, 2]`, `"text"`, `{ type = "mirror" }`); anything that does not parse
//! as one is taken as a string (`integrator.type=whitted`). Missing tables on
//! the way are created. The result is checked like the file itself, and an
//! error at an overridden key is located in the argument:
//! `--set 'film.spp=0':1:10: film.spp: expected 1..=16777216 samples per pixel, got 0`.
use crate::error::{Error, Result};
use crate::scene::source::{OverrideLoc, Source};
use toml_edit::{DocumentMut, Item, Table, TableLike, Value};

/// One step of an override's key, with its 1-based column in the argument.
#[derive(Debug, Clone)]
enum Step {
    Key(String),
    Index(usize),
}

/// Split `KEY=VALUE` into steps (with columns) and the value text.
fn parse_arg(arg: &str) -> Result<(Vec<(Step, usize)>, &str)> {
    let err = |col: usize, msg: String| Error::Input {
        file: format!("--set '{arg}'"),
        key: arg.split('=').next().unwrap_or("").to_string(),
        line: 1,
        column: col,
        message: msg,
    };
    let Some(eq) = arg.find('=') else {
        return Err(err(1, "expected KEY=VALUE (for example film.spp=256)".into()));
    };
    let (key, value) = (&arg[..eq], &arg[eq + 1..]);
    let mut steps = Vec::new();
    let mut pos = 0;
    for part in key.split('.') {
        let col = pos + 1;
        pos += part.len() + 1;
        let (name, mut rest) = match part.find('[') {
            Some(b) => (&part[..b], &part[b..]),
            None => (part, ""),
        };
        if name.is_empty() && (steps.is_empty() || rest.is_empty()) {
            return Err(err(col, format!("empty key segment in \"{key}\"")));
        }
        if !name.is_empty() {
            if !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                return Err(err(col, format!("invalid key segment \"{name}\"")));
            }
            steps.push((Step::Key(name.to_string()), col));
        }
        while !rest.is_empty() {
            let idx = rest
                .strip_prefix('[')
                .and_then(|r| r.split_once(']'))
                .and_then(|(i, r)| i.parse::<usize>().ok().map(|i| (i, r)));
            match idx {
                Some((i, r)) => {
                    steps.push((Step::Index(i), col));
                    rest = r;
                }
                None => return Err(err(col, format!("expected [INDEX] in \"{part}\""))),
            }
        }
    }
    Ok((steps, value))
}

/// The parsed value: TOML if it parses as a value, otherwise a string.
fn parse_value(text: &str) -> Value {
    let mut v = text.trim().parse::<Value>().unwrap_or_else(|_| Value::from(text));
    v.decor_mut().clear();
    v
}

enum Node<'a> {
    Item(&'a mut Item),
    Value(&'a mut Value),
    Table(&'a mut Table),
}

/// Where the walk failed: the step's index and the message.
type WalkError = (usize, String);

fn kind_of(v: &Value) -> &'static str {
    match v {
        Value::String(_) => "a string",
        Value::Integer(_) => "an integer",
        Value::Float(_) => "a float",
        Value::Boolean(_) => "a boolean",
        Value::Datetime(_) => "a datetime",
        Value::Array(_) => "an array",
        Value::InlineTable(_) => "a table",
    }
}

fn named_index<'a>(mut names: impl Iterator<Item = Option<&'a str>>, name: &str) -> Option<usize> {
    names.position(|n| n == Some(name))
}

fn walk(
    node: Node<'_>,
    steps: &[(Step, usize)],
    i: usize,
    value: &Value,
    canon: &mut String,
) -> Result<(), WalkError> {
    let last = i + 1 == steps.len();
    let step = &steps[i].0;
    let table: &mut dyn TableLike = match node {
        Node::Table(t) => t,
        Node::Item(Item::Table(t)) => t,
        Node::Item(Item::ArrayOfTables(a)) => {
            let idx = match step {
                Step::Index(k) => Some(*k).filter(|k| *k < a.len()),
                Step::Key(name) => {
                    named_index(a.iter().map(|t| t.get("name").and_then(|n| n.as_str())), name)
                }
            };
            let Some(k) = idx else {
                let names: Vec<String> = a
                    .iter()
                    .enumerate()
                    .map(|(j, t)| {
                        t.get("name")
                            .and_then(|n| n.as_str())
                            .map(str::to_string)
                            .unwrap_or(format!("[{j}]"))
                    })
                    .collect();
                return Err((
                    i,
                    format!("no entry {} here (entries: {})", show(step), names.join(", ")),
                ));
            };
            canon.push_str(&format!("[{k}]"));
            if last {
                return Err((i, "cannot replace a whole table entry; set its keys".into()));
            }
            let t = a.get_mut(k).ok_or((i, "index out of range".to_string()))?;
            return walk(Node::Table(t), steps, i + 1, value, canon);
        }
        Node::Item(Item::Value(v)) | Node::Value(v) => match v {
            Value::InlineTable(t) => t,
            Value::Array(a) => {
                let idx = match step {
                    Step::Index(k) => Some(*k).filter(|k| *k < a.len()),
                    Step::Key(name) => named_index(
                        a.iter().map(|e| {
                            e.as_inline_table()
                                .and_then(|t| t.get("name"))
                                .and_then(|n| n.as_str())
                        }),
                        name,
                    ),
                };
                let Some(k) = idx else {
                    return Err((i, format!("no entry {} in an array of {}", show(step), a.len())));
                };
                canon.push_str(&format!("[{k}]"));
                let e = a.get_mut(k).ok_or((i, "index out of range".to_string()))?;
                if last {
                    let decor = e.decor().clone();
                    *e = value.clone();
                    *e.decor_mut() = decor;
                    return Ok(());
                }
                return walk(Node::Value(e), steps, i + 1, value, canon);
            }
            other => {
                return Err((
                    i,
                    format!("the value here is {}, not a table or an array", kind_of(other)),
                ));
            }
        },
        Node::Item(Item::None) => return Err((i, "nothing here".into())),
    };
    let Step::Key(k) = step else {
        return Err((i, format!("{} is a table, not an array", show(step))));
    };
    if !canon.is_empty() {
        canon.push('.');
    }
    canon.push_str(k);
    if last {
        table.insert(k, Item::Value(value.clone()));
        return Ok(());
    }
    if table.get(k).is_none() {
        let mut t = Table::new();
        t.set_implicit(true);
        table.insert(k, Item::Table(t));
    }
    let next = table
        .get_mut(k)
        .ok_or((i, "cannot create this table".to_string()))?;
    walk(Node::Item(next), steps, i + 1, value, canon)
}

fn show(step: &Step) -> String {
    match step {
        Step::Key(k) => format!("named \"{k}\""),
        Step::Index(i) => format!("[{i}]"),
    }
}

/// `--sweep KEY=V1,V2,... --sweep-index I`: the override `KEY=VI` (I counts
/// from 1; commas inside brackets or quotes do not split values).
///
/// # Errors
///
/// [`Error::Invalid`] when `spec` has no `=` or `index` is not in 1..=N for its
/// N values.
pub fn sweep_value(spec: &str, index: u32) -> Result<String> {
    let bad = |m: String| Error::Invalid(format!("--sweep '{spec}': {m}"));
    let (key, list) = spec
        .split_once('=')
        .ok_or_else(|| bad("expected KEY=V1,V2,...".into()))?;
    let mut values = Vec::new();
    let (mut depth, mut quoted, mut start) = (0i32, false, 0);
    for (i, c) in list.char_indices() {
        match c {
            '"' => quoted = !quoted,
            '[' | '{' if !quoted => depth += 1,
            ']' | '}' if !quoted => depth -= 1,
            ',' if !quoted && depth == 0 => {
                values.push(&list[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    values.push(&list[start..]);
    let n = values.len();
    let v = (index as usize)
        .checked_sub(1)
        .and_then(|i| values.get(i))
        .ok_or_else(|| bad(format!("--sweep-index {index} is not in 1..={n}")))?;
    Ok(format!("{key}={}", v.trim()))
}

/// Apply `--set` overrides to a scene source. Errors in the overrides, and
/// later errors at the keys they set, are located in the argument.
///
/// Each of `sets` is `KEY=VALUE`, applied in order (see docs/scene-format.md).
///
/// # Errors
///
/// [`Error::Input`] located in the file when the file itself is not valid
/// TOML, and located in the `--set '…'` argument (line 1, the column of the
/// offending part) for a malformed argument or a key path that does not fit
/// the document (an unknown entry name, an index out of range, a key below a
/// value).
pub fn apply(src: Source, sets: &[String]) -> Result<Source> {
    if sets.is_empty() {
        return Ok(src);
    }
    // Errors in the file itself are reported against the file first.
    toml::from_str::<toml::Value>(&src.text).map_err(|e| src.toml_error(&e))?;
    let mut doc: DocumentMut = src
        .text
        .parse()
        .map_err(|e: toml_edit::TomlError| Error::Invalid(format!("{}: {e}", src.file)))?;
    let mut locs = Vec::new();
    for arg in sets {
        let (steps, vtext) = parse_arg(arg)?;
        let value = parse_value(vtext);
        let mut canon = String::new();
        if let Err((i, msg)) = walk(Node::Table(doc.as_table_mut()), &steps, 0, &value, &mut canon) {
            return Err(Error::Input {
                file: format!("--set '{arg}'"),
                key: arg.split('=').next().unwrap_or("").to_string(),
                line: 1,
                column: steps[i].1,
                message: msg,
            });
        }
        locs.push(OverrideLoc {
            path: canon,
            arg: arg.clone(),
            value_col: arg.find('=').unwrap_or(0) + 2,
        });
    }
    let text = doc.to_string();
    Ok(Source::with_overrides(src, text, locs))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = "[camera]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\n\n[[objects]]\nname = \"a\"\nshape = { type = \"sphere\", center = [0, 0, 0], radius = 1 }\nmaterial = { type = \"dielectric\", ior = 1.5 }\n";

    fn run(sets: &[&str]) -> Result<Source> {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        apply(Source::new("s.toml", SCENE.into()), &sets)
    }

    #[test]
    fn sets_by_name_index_and_creates_tables() {
        let s = run(&[
            "objects.a.material.ior=1.34",
            "film.spp=3",
            "objects[0].shape.radius=2",
        ])
        .unwrap();
        let v: toml::Value = toml::from_str(&s.text).unwrap();
        assert_eq!(v["objects"][0]["material"]["ior"].as_float(), Some(1.34));
        assert_eq!(v["film"]["spp"].as_integer(), Some(3));
        assert_eq!(v["objects"][0]["shape"]["radius"].as_integer(), Some(2));
    }

    #[test]
    fn sweep_values_split_at_top_level_commas() {
        assert_eq!(sweep_value("a.b=1.3, 1.33,1.36", 2).unwrap(), "a.b=1.33");
        assert_eq!(sweep_value("p=[1,2],[3,4]", 2).unwrap(), "p=[3,4]");
        assert!(sweep_value("p=1,2", 3).is_err());
        assert!(sweep_value("p=1,2", 0).is_err());
    }

    #[test]
    fn bad_paths_are_located_in_the_argument() {
        let e = run(&["objects.b.material.ior=1.3"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.starts_with("--set 'objects.b.material.ior=1.3':1:9:"), "{e}");
        assert!(e.contains("entries: a"), "{e}");
        let e = run(&["camera.fov.x=1"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains(":1:12:") && e.contains("a float"), "{e}");
        assert!(run(&["film.spp"]).is_err());
        assert!(run(&["film..spp=1"]).is_err());
    }
}
