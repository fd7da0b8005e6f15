//! Mitsuba's named indices of refraction (at ~589 nm, 0–20 °C; after
//! Hecht, Optics), and `int_ior`/`ext_ior` parameters given as a number or
//! a name.
use super::props::Obj;
use crate::error::Result;

/// Every name Mitsuba knows, with its index.
pub const NAMED: &[(&str, f64)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// The index a name stands for (case-insensitive).
pub fn lookup(name: &str) -> Option<f64> {
    let l = name.trim().to_ascii_lowercase();
    NAMED.iter().find(|(n, _)| *n == l).map(|(_, v)| *v)
}

/// Parameter `key` of `o` as an index: a number or a name; `default` (a
/// name) when absent.
pub fn param(o: &Obj<'_, '_>, key: &str, default: &str) -> Result<f64> {
    let v = if let Some(n) = o.value(key) {
        match n.tag.as_str() {
            "float" | "integer" => super::numbers::number(n, n.need("value")?)?,
            "string" => {
                let s = n.need("value")?;
                lookup(s).ok_or_else(|| {
                    let names: Vec<&str> = NAMED.iter().map(|(n, _)| *n).collect();
                    n.at.error(format!(
                        "unknown index of refraction \"{s}\"; known: {}",
                        names.join(", ")
                    ))
                })?
            }
            t => {
                return Err(n
                    .at
                    .error(format!("expected a <float> or <string> index, found <{t}>")))
            }
        }
    } else {
        lookup(default).unwrap_or(1.0)
    };
    if !(v.is_finite() && v > 0.0) {
        return Err(o.at().error(format!("{key} = {v}: expected an index > 0")));
    }
    Ok(v)
}
