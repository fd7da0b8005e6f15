//! A field's parameters checked, `up` normalised.
use super::plume::WaveTable;
use super::IndexField;
use crate::media::MediumError;
use glam::DVec3;

pub(super) fn check(
    key: &str,
    ok: bool,
    expected: &str,
    value: impl std::fmt::Debug,
) -> Result<(), MediumError> {
    if ok {
        Ok(())
    } else {
        Err(MediumError::invalid(
            key,
            format!("expected {expected}, got {value:?}"),
        ))
    }
}

pub(super) fn finite(key: &str, v: f64) -> Result<(), MediumError> {
    check(key, v.is_finite(), "a finite number", v)
}

pub(super) fn unit_up(key: &str, up: DVec3) -> Result<DVec3, MediumError> {
    check(
        key,
        up.is_finite() && up.length() > 1e-12,
        "a finite non-zero vector",
        up,
    )?;
    Ok(up.normalize())
}

impl IndexField {
    /// Checks the parameters (finite, positive scales, non-zero `up`) and returns a copy
    /// with `up` normalised. `key` prefixes error keys (e.g. "medium.field").
    ///
    /// # Errors
    ///
    /// [`MediumError::Invalid`] at `key.param` for the first parameter that is
    /// not finite or out of range (H, h0, thickness, radius, height, wavelength
    /// ≤ 0, |amplitude| ≥ 1, waves outside 1..=64, a zero `up`).
    pub fn validated(&self, key: &str) -> Result<IndexField, MediumError> {
        let k = |s: &str| format!("{key}.{s}");
        let mut f = self.clone();
        match &mut f {
            IndexField::Constant { n } => finite(&k("n"), *n)?,
            IndexField::Linear { n0, m, up, base } => {
                finite(&k("n0"), *n0)?;
                finite(&k("m"), *m)?;
                finite(&k("base"), *base)?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::Exponential {
                n0,
                scale_height,
                up,
                base,
            } => {
                finite(&k("n0"), *n0)?;
                check(
                    &k("H"),
                    scale_height.is_finite() && *scale_height > 0.0,
                    "H > 0",
                    *scale_height,
                )?;
                finite(&k("base"), *base)?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::HotGround {
                n_inf,
                dn,
                h0,
                up,
                base,
            } => {
                finite(&k("n_inf"), *n_inf)?;
                finite(&k("dn"), *dn)?;
                check(&k("h0"), h0.is_finite() && *h0 > 0.0, "h0 > 0", *h0)?;
                finite(&k("base"), *base)?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::Inversion {
                n0,
                dn,
                height,
                thickness,
                m,
                up,
                base,
            } => {
                finite(&k("n0"), *n0)?;
                finite(&k("dn"), *dn)?;
                finite(&k("height"), *height)?;
                finite(&k("m"), *m)?;
                finite(&k("base"), *base)?;
                check(
                    &k("thickness"),
                    thickness.is_finite() && *thickness > 0.0,
                    "thickness > 0",
                    *thickness,
                )?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::Profile {
                heights,
                n,
                up,
                base,
                layer,
            } => {
                if let Some(l) = layer {
                    check(
                        &k("layer"),
                        l.is_finite() && *l > 0.0,
                        "a finite layer > 0 (metres)",
                        *l,
                    )?;
                }
                check(
                    &k("heights"),
                    heights.len() >= 2,
                    "at least two nodes",
                    heights.len(),
                )?;
                check(
                    &k("n"),
                    n.len() == heights.len(),
                    &format!("as many values as heights ({})", heights.len()),
                    n.len(),
                )?;
                for (i, h) in heights.iter().enumerate() {
                    finite(&k(&format!("heights[{i}]")), *h)?;
                    if i > 0 {
                        check(
                            &k(&format!("heights[{i}]")),
                            *h > heights[i - 1],
                            &format!("heights strictly increasing (above {})", heights[i - 1]),
                            *h,
                        )?;
                    }
                }
                for (i, v) in n.iter().enumerate() {
                    check(
                        &k(&format!("n[{i}]")),
                        v.is_finite() && *v > 0.0,
                        "a finite n > 0",
                        *v,
                    )?;
                }
                finite(&k("base"), *base)?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::Plume {
                n_amb,
                dn,
                center,
                radius,
                height,
                amplitude,
                wavelength,
                waves,
                seed,
                up,
                table,
            } => {
                finite(&k("n_amb"), *n_amb)?;
                finite(&k("dn"), *dn)?;
                check(&k("center"), center.is_finite(), "a finite point", *center)?;
                check(
                    &k("radius"),
                    radius.is_finite() && *radius > 0.0,
                    "radius > 0",
                    *radius,
                )?;
                check(
                    &k("height"),
                    height.is_finite() && *height > 0.0,
                    "height > 0",
                    *height,
                )?;
                check(
                    &k("amplitude"),
                    amplitude.is_finite() && amplitude.abs() < 1.0,
                    "|amplitude| < 1",
                    *amplitude,
                )?;
                check(
                    &k("wavelength"),
                    wavelength.is_finite() && *wavelength > 0.0,
                    "wavelength > 0",
                    *wavelength,
                )?;
                check(&k("waves"), (1..=64).contains(waves), "1 to 64 waves", *waves)?;
                *up = unit_up(&k("up"), *up)?;
                *table = WaveTable::new(*seed, *waves, *wavelength);
            }
        }
        Ok(f)
    }
}
