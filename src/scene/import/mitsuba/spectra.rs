//! Mitsuba spectra as the linear RGB its RGB variants use: a uniform value
//! is grey for reflectances and `value · xyz_to_srgb(1, 1, 1)` for emitters
//! (a flat spectrum is not white under sRGB's D65 white point);
//! `wavelength:value` lists are integrated against the CIE 1931 curves
//! (reflectances under D65) with 1000 steps over 360–830 nm, converted to
//! sRGB, and clamped (reflectances to [0, 1], emitters to >= 0).
use crate::scene::import::cie;

/// `value="0.5"` or `value="400:0.1, 500:0.2"`: (wavelength, value) pairs,
/// or one pair with wavelength 0 for a uniform spectrum.
pub fn parse_value(v: &str) -> Result<Vec<(f64, f64)>, String> {
    let toks: Vec<&str> = v
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .collect();
    let num = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|_| format!("expected a number, got \"{t}\""))
    };
    match toks[..] {
        [] => Err("expected a value or wavelength:value pairs".into()),
        [t] if !t.contains(':') => Ok(vec![(0.0, num(t)?)]),
        _ => {
            let mut out = Vec::with_capacity(toks.len());
            for t in toks {
                let (w, x) = t
                    .split_once(':')
                    .ok_or_else(|| format!("expected wavelength:value, got \"{t}\""))?;
                out.push((num(w)?, num(x)?));
            }
            check_pairs(&out)?;
            Ok(out)
        }
    }
}

/// A spectrum file: lines `wavelength value`, `#` comments.
pub fn parse_file(text: &str) -> Result<Vec<(f64, f64)>, String> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let t: Vec<&str> = l.split_whitespace().collect();
        let [w, v] = t[..] else {
            return Err(format!("line {}: expected \"wavelength value\"", i + 1));
        };
        let p = |s: &str| {
            s.parse::<f64>()
                .map_err(|_| format!("line {}: expected a number, got \"{s}\"", i + 1))
        };
        out.push((p(w)?, p(v)?));
    }
    check_pairs(&out)?;
    Ok(out)
}

fn check_pairs(p: &[(f64, f64)]) -> Result<(), String> {
    if p.len() < 2 {
        return Err("expected at least two wavelength:value pairs".into());
    }
    if p.iter().any(|(w, v)| !w.is_finite() || !v.is_finite()) {
        return Err("expected finite wavelengths and values".into());
    }
    if p.windows(2).any(|w| w[1].0 <= w[0].0) {
        return Err("expected increasing wavelengths".into());
    }
    Ok(())
}

/// Linear RGB of a spectrum, as Mitsuba's RGB variants compute it.
pub fn to_rgb(pairs: &[(f64, f64)], emitter: bool) -> [f64; 3] {
    if let [(_, v)] = pairs {
        return if emitter {
            cie::xyz_to_srgb(*v, *v, *v)
        } else {
            [*v, *v, *v]
        };
    }
    const STEPS: usize = 1000;
    let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
    for i in 0..STEPS {
        let w = cie::CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (cie::CIE_MAX - cie::CIE_MIN);
        let (first, last) = (pairs[0].0, pairs[pairs.len() - 1].0);
        if w < first || w > last {
            continue;
        }
        let k = pairs
            .partition_point(|p| p.0 <= w)
            .saturating_sub(1)
            .min(pairs.len() - 2);
        let ((w0, v0), (w1, v1)) = (pairs[k], pairs[k + 1]);
        let v = ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1);
        let weight = v * if emitter {
            1.0
        } else {
            cie::lookup(&cie::D65, w) * cie::CIE_D65_NORMALIZATION
        };
        x += cie::lookup(&cie::CIE_X, w) * weight;
        y += cie::lookup(&cie::CIE_Y, w) * weight;
        z += cie::lookup(&cie::CIE_Z, w) * weight;
    }
    let s = (cie::CIE_MAX - cie::CIE_MIN) * cie::CIE_Y_NORMALIZATION / STEPS as f64;
    let rgb = cie::xyz_to_srgb(x * s, y * s, z * s);
    rgb.map(|c| if emitter { c.max(0.0) } else { c.clamp(0.0, 1.0) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_reflectance_is_grey_and_flat_emission_is_mitsubas_purple() {
        // A flat reflectance spectrum under D65 is (very nearly) white.
        let w = to_rgb(&parse_value("360:0.5, 830:0.5").unwrap(), false);
        for c in w {
            assert!((c - 0.5).abs() < 0.01, "{w:?}");
        }
        assert_eq!(to_rgb(&parse_value("0.5").unwrap(), false), [0.5; 3]);
        let e = to_rgb(&parse_value("1").unwrap(), true);
        assert!(
            (e[0] - 1.204794).abs() < 1e-6 && (e[2] - 0.908916).abs() < 1e-6,
            "{e:?}"
        );
        // A red-only reflectance is red.
        let r = to_rgb(&parse_value("360:0, 599:0, 600:1, 830:1").unwrap(), false);
        assert!(r[0] > 0.5 && r[2] < 0.05, "{r:?}");
        assert!(parse_value("500:1, 400:2").is_err());
    }
}
