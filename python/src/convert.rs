//! Python values to and from the documents the library reads and writes: a
//! dict becomes a TOML scene or a JSON field description, a JSON result
//! becomes a dict. Every refusal names the key path of the bad value.
use numpy::PyUntypedArray;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

/// A Python value read into the shapes both TOML and JSON share.
#[derive(Debug, Clone, PartialEq)]
pub enum Plain {
    /// `True` / `False`.
    Bool(bool),
    /// An integer that fits in an `i64` (Python ints and NumPy integer scalars).
    Int(i64),
    /// A float (Python floats and NumPy floating scalars).
    Float(f64),
    /// A string.
    Str(String),
    /// A list, tuple or NumPy array (arrays become nested lists).
    List(Vec<Plain>),
    /// A dict with string keys, in the dict's order.
    Table(Vec<(String, Plain)>),
}

/// Why a value cannot be read: its key path and what was wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct BadValue {
    /// Dotted key path with indices, `objects[0].material.ior`.
    pub key: String,
    /// What was expected and what was found.
    pub message: String,
}

fn child(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

fn type_name(v: &Bound<'_, PyAny>) -> String {
    v.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// Read `v` (at key path `path`) into a [`Plain`] value.
///
/// # Errors
/// A [`BadValue`] at the first value that is not a bool, number, string,
/// list, tuple, NumPy array or dict with string keys (`None` included:
/// a key that should take its default is left out).
pub fn plain(v: &Bound<'_, PyAny>, path: &str) -> Result<Plain, BadValue> {
    let bad = |message: String| BadValue {
        key: if path.is_empty() {
            "(document)".into()
        } else {
            path.to_string()
        },
        message,
    };
    // bool before int: Python's bool is an int.
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(Plain::Bool(b.is_true()));
    }
    if let Ok(i) = v.cast::<PyInt>() {
        return i
            .extract::<i64>()
            .map(Plain::Int)
            .map_err(|_| bad(format!("integer {i} does not fit in 64 bits")));
    }
    if let Ok(f) = v.cast::<PyFloat>() {
        return Ok(Plain::Float(f.value()));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return s
            .to_cow()
            .map(|s| Plain::Str(s.to_string()))
            .map_err(|e| bad(format!("the string is not valid UTF-8: {e}")));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut out = Vec::with_capacity(d.len());
        for (k, val) in d.iter() {
            let Ok(k) = k.cast::<PyString>().map(|k| k.to_string()) else {
                return Err(bad(format!(
                    "expected string keys, got the {} key {}",
                    type_name(&k),
                    k.repr().map(|r| r.to_string()).unwrap_or_default()
                )));
            };
            let value = plain(&val, &child(path, &k))?;
            out.push((k, value));
        }
        return Ok(Plain::Table(out));
    }
    if v.cast::<PyList>().is_ok() || v.cast::<PyTuple>().is_ok() {
        let mut out = Vec::new();
        let iter = v.try_iter().map_err(|e| bad(e.to_string()))?;
        for (i, item) in iter.enumerate() {
            let item = item.map_err(|e| bad(e.to_string()))?;
            out.push(plain(&item, &format!("{path}[{i}]"))?);
        }
        return Ok(Plain::List(out));
    }
    if v.cast::<PyUntypedArray>().is_ok() {
        let list = v.call_method0("tolist").map_err(|e| bad(e.to_string()))?;
        return plain(&list, path);
    }
    // NumPy scalars (np.float32, np.int64, ...) are neither float nor int.
    if v.hasattr("dtype").unwrap_or(false) {
        if let Ok(item) = v.call_method0("item") {
            if !item.is(v) {
                return plain(&item, path);
            }
        }
    }
    if v.is_none() {
        return Err(bad(
            "None is not a value: leave the key out to take its default".into()
        ));
    }
    Err(bad(format!(
        "expected a bool, number, string, list or dict, got {}",
        type_name(v)
    )))
}

impl Plain {
    /// The TOML value.
    pub fn to_toml(&self) -> toml::Value {
        match self {
            Plain::Bool(b) => toml::Value::Boolean(*b),
            Plain::Int(i) => toml::Value::Integer(*i),
            Plain::Float(f) => toml::Value::Float(*f),
            Plain::Str(s) => toml::Value::String(s.clone()),
            Plain::List(l) => toml::Value::Array(l.iter().map(Plain::to_toml).collect()),
            Plain::Table(t) => toml::Value::Table(t.iter().map(|(k, v)| (k.clone(), v.to_toml())).collect()),
        }
    }

    /// The JSON value; `path` locates a non-finite float (JSON has none).
    ///
    /// # Errors
    /// A [`BadValue`] at a NaN or infinite float.
    pub fn to_json(&self, path: &str) -> Result<serde_json::Value, BadValue> {
        Ok(match self {
            Plain::Bool(b) => serde_json::Value::Bool(*b),
            Plain::Int(i) => serde_json::Value::from(*i),
            Plain::Float(f) => serde_json::Number::from_f64(*f)
                .map(serde_json::Value::Number)
                .ok_or_else(|| BadValue {
                    key: path.to_string(),
                    message: format!("expected a finite number, got {f}"),
                })?,
            Plain::Str(s) => serde_json::Value::String(s.clone()),
            Plain::List(l) => serde_json::Value::Array(
                l.iter()
                    .enumerate()
                    .map(|(i, v)| v.to_json(&format!("{path}[{i}]")))
                    .collect::<Result<_, _>>()?,
            ),
            Plain::Table(t) => serde_json::Value::Object(
                t.iter()
                    .map(|(k, v)| Ok((k.clone(), v.to_json(&child(path, k))?)))
                    .collect::<Result<_, BadValue>>()?,
            ),
        })
    }
}

/// A scene dict as TOML text (the scene loader's input).
///
/// # Errors
/// A [`BadValue`] when `v` is not a dict or holds a value TOML cannot.
pub fn scene_toml(v: &Bound<'_, PyAny>) -> Result<String, BadValue> {
    let doc = plain(v, "")?;
    let toml::Value::Table(table) = doc.to_toml() else {
        return Err(BadValue {
            key: "(document)".into(),
            message: format!("expected a dict of scene keys, got {}", type_name(v)),
        });
    };
    toml::to_string(&table).map_err(|e| BadValue {
        key: "(document)".into(),
        message: format!("cannot be written as TOML: {e}"),
    })
}

/// A value as the text of a `--set KEY=VALUE` override (a TOML value).
///
/// # Errors
/// A [`BadValue`] at `key` when `v` is no TOML value.
pub fn override_text(v: &Bound<'_, PyAny>, key: &str) -> Result<String, BadValue> {
    let value = plain(v, key)?.to_toml();
    Ok(value.to_string())
}

/// A JSON value as the Python value it reads as (dicts, lists, str, int, float, bool, None).
pub fn json_to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use pyo3::IntoPyObjectExt;
    Ok(match v {
        serde_json::Value::Null => py.None().into_bound(py),
        serde_json::Value::Bool(b) => b.into_bound_py_any(py)?,
        serde_json::Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into_bound_py_any(py)?
            } else if let Some(u) = n.as_u64() {
                u.into_bound_py_any(py)?
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_bound_py_any(py)?
            }
        }
        serde_json::Value::String(s) => s.into_bound_py_any(py)?,
        serde_json::Value::Array(a) => {
            let l = PyList::empty(py);
            for x in a {
                l.append(json_to_py(py, x)?)?;
            }
            l.into_any()
        }
        serde_json::Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}
