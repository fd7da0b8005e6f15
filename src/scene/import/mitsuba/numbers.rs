//! Numbers and vectors in attribute values (`value="1, 2, 3"`, `x`, `y`, `z`).
use super::xml::Node;
use crate::error::Result;
use glam::DVec3;

/// A number attribute of `n`.
pub fn number(n: &Node, v: &str) -> Result<f64> {
    v.trim()
        .parse::<f64>()
        .map_err(|_| n.at.error(format!("expected a number, got \"{v}\"")))
}

/// Numbers separated by commas and/or spaces.
pub fn numbers(n: &Node, v: &str) -> Result<Vec<f64>> {
    v.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| number(n, t))
        .collect()
}

/// `x`, `y`, `z` attributes (each `default` when absent), or `value` with
/// one or three numbers.
pub fn xyz(n: &Node, default: f64) -> Result<DVec3> {
    if let Some(v) = n.attr("value") {
        let v = numbers(n, v)?;
        return match v[..] {
            [a] => Ok(DVec3::splat(a)),
            [a, b, c] => Ok(DVec3::new(a, b, c)),
            _ => Err(n.at.error("expected one or three numbers in `value`")),
        };
    }
    let get = |k: &str| {
        n.attr(k)
            .map(|v| number(n, v))
            .transpose()
            .map(|o| o.unwrap_or(default))
    };
    Ok(DVec3::new(get("x")?, get("y")?, get("z")?))
}
