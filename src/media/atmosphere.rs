//! Air's index of refraction from its temperature profile: the
//! `[medium] atmosphere = { ... }` of a scene, an alternative to `field`.
//!
//! ```toml
//! [medium]
//! # A hot road: 55 °C at the asphalt, 32 °C half a metre up, 30 °C at 5 m.
//! atmosphere = { heights = [0.0, 0.5, 5.0], celsius = [55.0, 32.0, 30.0], pressure = 101325.0 }
//! bounds = { min = [-500.0, -1.0, -1000.0], max = [500.0, 10.0, 10.0] }
//! ```
//!
//! - `heights` (metres along `up` above `base`, strictly increasing, at
//!   least two) and `celsius` (°C, one per height): the temperature is
//!   linear between nodes (constant lapse rates) and holds its end values
//!   beyond them (bounds usually reach below the ground, where a hot
//!   layer's lapse rate continued would boil).
//! - `pressure`: pascals at h = 0 (default 101325). Above and below, the
//!   pressure follows hydrostatic equilibrium of dry air in the temperature
//!   profile, dp/dh = −p·g·M/(R·T(h)), in closed form per linear piece
//!   (constants of the U.S. Standard Atmosphere 1976: g = 9.80665 m/s²,
//!   M = 0.0289644 kg/mol, R = 8.31432 J/(mol·K)). Water vapour's share of
//!   the weight of the air is left out (its effect on p is below 1e-3 of it
//!   over the heights of a scene).
//! - `humidity` (relative, 0–1, default 0), `co2_ppm` (default 450),
//!   `wavelength_nm` (vacuum, default 550).
//! - `up` (default +y) and `base` (default 0), as for the field kinds.
//!
//! n comes from Ciddor's equations (P. E. Ciddor, "Refractive index of air:
//! new equations for the visible and near infrared", Applied Optics 35(9),
//! 1566–1573, 1996), valid for wavelengths 300–1690 nm, −40 to +100 °C,
//! 80–120 kPa, 0–100 % humidity and 0–2000 ppm CO₂ (the range the IAG
//! adopted it for). A profile that leaves that range anywhere in the
//! medium's bounds is refused, naming the height. The modified Edlén
//! equation (Birch & Downs, Metrologia 30, 155–162, 1993, with their 1994
//! correction) is here too, as the independent check of the tests.
//!
//! The profile is tabulated over the bounds' heights into a `profile` field
//! (monotone cubic Hermite, [`super::profile`]) at nodes close enough that
//! the table is within 1e-10 of the formula (tested), so it is traced like
//! any tabulated profile.
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::field::IndexField;
use super::MediumError;

/// g·M/R of the U.S. Standard Atmosphere 1976, kelvin per metre: the
/// hydrostatic pressure's exponent.
const G_M_OVER_R: f64 = 9.80665 * 0.028_964_4 / 8.314_32;
/// 0 °C in kelvin.
const ZERO_CELSIUS: f64 = 273.15;

fn default_pressure() -> f64 {
    101_325.0
}
fn default_co2() -> f64 {
    450.0
}
fn default_wavelength() -> f64 {
    550.0
}
fn default_up() -> DVec3 {
    DVec3::Y
}

/// A stratified atmosphere given by its temperature profile (see the module
/// documentation for the keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Atmosphere {
    /// Heights of the temperature nodes, metres above `base` along `up`.
    pub heights: Vec<f64>,
    /// Temperature at each node, °C.
    pub celsius: Vec<f64>,
    /// Pressure at h = 0, pascals.
    #[serde(default = "default_pressure")]
    pub pressure: f64,
    /// Relative humidity, 0–1.
    #[serde(default)]
    pub humidity: f64,
    /// CO₂ mole fraction, parts per million.
    #[serde(default = "default_co2")]
    pub co2_ppm: f64,
    /// Vacuum wavelength, nanometres.
    #[serde(default = "default_wavelength")]
    pub wavelength_nm: f64,
    /// Unit "up" direction the height is measured along.
    #[serde(default = "default_up")]
    pub up: DVec3,
    /// Height of the origin of h along `up`, metres: h = p·up − base.
    #[serde(default)]
    pub base: f64,
}

/// The state of a parcel of air, for the refractivity formulas.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Air {
    /// Temperature, °C.
    pub celsius: f64,
    /// Pressure, pascals.
    pub pascals: f64,
    /// Relative humidity, 0–1.
    pub humidity: f64,
    /// CO₂ mole fraction, parts per million.
    pub co2_ppm: f64,
    /// Vacuum wavelength, micrometres.
    pub wavelength_um: f64,
}

/// Compressibility of moist air (the BIPM-1981/91 formula Ciddor uses), at
/// `t_k` kelvin, `p` pascals and water mole fraction `xw`.
fn compressibility(t_k: f64, p: f64, xw: f64) -> f64 {
    let t = t_k - ZERO_CELSIUS;
    let (a0, a1, a2) = (1.58123e-6, -2.9331e-8, 1.1043e-10);
    let (b0, b1) = (5.707e-6, -2.051e-8);
    let (c0, c1) = (1.9898e-4, -2.376e-6);
    let (d, e) = (1.83e-11, -0.765e-8);
    let pt = p / t_k;
    1.0 - pt * (a0 + a1 * t + a2 * t * t + (b0 + b1 * t) * xw + (c0 + c1 * t) * xw * xw)
        + pt * pt * (d + e * xw * xw)
}

/// Saturation vapour pressure, pascals: over water at or above 0 °C (the
/// formula Ciddor gives), over ice below (the one his paper pairs with it).
fn saturation_vapour_pressure(celsius: f64) -> f64 {
    let t = celsius + ZERO_CELSIUS;
    if celsius >= 0.0 {
        (1.237_884_7e-5 * t * t - 1.912_131_6e-2 * t + 33.937_110_47 - 6.343_164_5e3 / t).exp()
    } else {
        10f64.powf(-2663.5 / t + 12.537)
    }
}

/// n of `air` by Ciddor (1996). The caller checks the formula's range
/// ([`check_ciddor_range`]).
pub fn ciddor(air: &Air) -> f64 {
    let s2 = 1.0 / (air.wavelength_um * air.wavelength_um);
    let t_k = air.celsius + ZERO_CELSIUS;
    let p = air.pascals;
    const R: f64 = 8.314_510;
    // Standard dry air (15 °C, 101325 Pa, 450 ppm CO₂), then its CO₂.
    let n_as = (5_792_105.0 / (238.0185 - s2) + 167_917.0 / (57.362 - s2)) * 1e-8;
    let n_axs = n_as * (1.0 + 0.534e-6 * (air.co2_ppm - 450.0));
    // Water vapour at 20 °C, 1333 Pa.
    let n_ws = 1.022 * (295.235 + 2.6422 * s2 - 0.032_380 * s2 * s2 + 0.004_028 * s2 * s2 * s2) * 1e-8;
    let ma = 1e-3 * (28.9635 + 12.011e-6 * (air.co2_ppm - 400.0));
    let mw = 0.018_015;
    let enhancement = 1.00062 + 3.14e-8 * p + 5.6e-7 * air.celsius * air.celsius;
    let xw = enhancement * air.humidity * saturation_vapour_pressure(air.celsius) / p;
    let rho_axs = 101_325.0 * ma / (compressibility(288.15, 101_325.0, 0.0) * R * 288.15);
    let rho_ws = 1333.0 * mw / (compressibility(293.15, 1333.0, 1.0) * R * 293.15);
    let z = compressibility(t_k, p, xw);
    let rho_a = p * ma * (1.0 - xw) / (z * R * t_k);
    let rho_w = p * mw * xw / (z * R * t_k);
    1.0 + (rho_a / rho_axs) * n_axs + (rho_w / rho_ws) * n_ws
}

/// n of `air` by the modified Edlén equation (Birch & Downs 1993/1994),
/// for the tests' comparison; its water term takes the partial pressure of
/// water vapour from the same saturation pressure as [`ciddor`].
pub fn edlen(air: &Air) -> f64 {
    let s2 = 1.0 / (air.wavelength_um * air.wavelength_um);
    let t = air.celsius;
    let p = air.pascals;
    let n_s = (8342.54 + 2_406_147.0 / (130.0 - s2) + 15_998.0 / (38.9 - s2)) * 1e-8;
    let n_tp = p * n_s / 96_095.43 * (1.0 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1.0 + 0.003_661 * t);
    let pv = air.humidity * saturation_vapour_pressure(t);
    1.0 + n_tp - 292.75 / (t + ZERO_CELSIUS) * (3.7345 - 0.0401 * s2) * pv * 1e-10
}

/// Ciddor's stated range, or what is outside it.
fn check_ciddor_range(air: &Air) -> Result<(), String> {
    let checks = [
        (
            (0.3..=1.69).contains(&air.wavelength_um),
            format!("wavelength {} nm (300–1690)", air.wavelength_um * 1e3),
        ),
        (
            (-40.0..=100.0).contains(&air.celsius),
            format!("temperature {:.2} °C (−40 to 100)", air.celsius),
        ),
        (
            (80_000.0..=120_000.0).contains(&air.pascals),
            format!("pressure {:.0} Pa (80–120 kPa)", air.pascals),
        ),
        (
            (0.0..=1.0).contains(&air.humidity),
            format!("humidity {} (0–1)", air.humidity),
        ),
        (
            (0.0..=2000.0).contains(&air.co2_ppm),
            format!("CO₂ {} ppm (0–2000)", air.co2_ppm),
        ),
    ];
    match checks.into_iter().find(|(ok, _)| !ok) {
        None => Ok(()),
        Some((_, what)) => Err(format!("{what} is outside the range of Ciddor's equations")),
    }
}

impl Atmosphere {
    /// Checks the keys (at `key.heights` etc.).
    fn check(&self, key: &str) -> Result<(), MediumError> {
        let k = |s: &str| format!("{key}.{s}");
        let h = &self.heights;
        if h.len() < 2 {
            return Err(MediumError::invalid(
                k("heights"),
                format!("expected at least two nodes, got {}", h.len()),
            ));
        }
        if self.celsius.len() != h.len() {
            return Err(MediumError::invalid(
                k("celsius"),
                format!(
                    "expected as many temperatures as heights ({}), got {}",
                    h.len(),
                    self.celsius.len()
                ),
            ));
        }
        for (i, w) in h.windows(2).enumerate() {
            if !(w[0].is_finite() && w[1].is_finite() && w[0] < w[1]) {
                return Err(MediumError::invalid(
                    k("heights"),
                    format!(
                        "expected finite, strictly increasing heights, got {} then {} at {}",
                        w[0],
                        w[1],
                        i + 1
                    ),
                ));
            }
        }
        if let Some(t) = self.celsius.iter().find(|t| !t.is_finite()) {
            return Err(MediumError::invalid(
                k("celsius"),
                format!("expected finite temperatures, got {t}"),
            ));
        }
        for (name, v) in [
            ("pressure", self.pressure),
            ("humidity", self.humidity),
            ("co2_ppm", self.co2_ppm),
            ("wavelength_nm", self.wavelength_nm),
            ("base", self.base),
        ] {
            if !v.is_finite() {
                return Err(MediumError::invalid(
                    k(name),
                    format!("expected a finite number, got {v}"),
                ));
            }
        }
        if !(self.up.is_finite() && self.up.length() > 1e-12) {
            return Err(MediumError::invalid(
                k("up"),
                format!("expected a non-zero finite vector, got {}", self.up),
            ));
        }
        Ok(())
    }

    /// Temperature at height `h`, °C (linear between nodes, the end values
    /// beyond).
    pub fn celsius_at(&self, h: f64) -> f64 {
        let (hs, ts) = (&self.heights, &self.celsius);
        let last = hs.len() - 1;
        if h <= hs[0] {
            return ts[0];
        }
        if h >= hs[last] {
            return ts[last];
        }
        let i = hs.partition_point(|&v| v <= h).saturating_sub(1).min(last - 1);
        ts[i] + (ts[i + 1] - ts[i]) * (h - hs[i]) / (hs[i + 1] - hs[i])
    }

    /// The heights where the lapse rate changes, strictly between `a` and `b`.
    fn breaks_between(&self, a: f64, b: f64) -> impl Iterator<Item = f64> + '_ {
        let (lo, hi) = (a.min(b), a.max(b));
        self.heights.iter().copied().filter(move |&x| lo < x && x < hi)
    }

    /// Pressure at height `h`, pascals: hydrostatic from `pressure` at
    /// h = 0, in closed form over each piece of constant lapse rate
    /// (p₁ = p₀·(T₁/T₀)^(−gM/(RL)), or p₀·exp(−gMΔh/(RT)) where L = 0).
    pub fn pressure_at(&self, h: f64) -> f64 {
        let mut stops: Vec<f64> = self.breaks_between(0.0, h).collect();
        if h < 0.0 {
            stops.reverse();
        }
        stops.push(h);
        let (mut at, mut p) = (0.0, self.pressure);
        for next in stops {
            let (t0, t1) = (
                self.celsius_at(at) + ZERO_CELSIUS,
                self.celsius_at(next) + ZERO_CELSIUS,
            );
            let dh = next - at;
            let lapse = (t1 - t0) / dh;
            p *= if (lapse * dh).abs() < 1e-9 * t0 {
                (-G_M_OVER_R * dh / t0).exp()
            } else {
                (t1 / t0).powf(-G_M_OVER_R / lapse)
            };
            at = next;
        }
        p
    }

    fn air_at(&self, h: f64) -> Air {
        Air {
            celsius: self.celsius_at(h),
            pascals: self.pressure_at(h),
            humidity: self.humidity,
            co2_ppm: self.co2_ppm,
            wavelength_um: self.wavelength_nm * 1e-3,
        }
    }

    /// n at height `h` by Ciddor's equations.
    pub fn n_at(&self, h: f64) -> f64 {
        ciddor(&self.air_at(h))
    }

    /// The `profile` field of this atmosphere over heights `lo..=hi` (the
    /// medium's bounds along `up`), checked against Ciddor's range there.
    ///
    /// # Errors
    ///
    /// [`MediumError::Invalid`] at `key.<name>` for a malformed key, or when
    /// the air at some height of `lo..=hi` leaves the formula's range,
    /// naming the height.
    pub fn to_field(&self, key: &str, lo: f64, hi: f64) -> Result<IndexField, MediumError> {
        self.check(key)?;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(MediumError::invalid(
                format!("{key}.heights"),
                format!("expected the medium's bounds to span heights, got {lo} to {hi}"),
            ));
        }
        // Temperature is linear between breaks and pressure monotone, so the
        // extremes of both lie at the ends or at the breaks.
        let nodes: Vec<f64> = std::iter::once(lo)
            .chain(self.breaks_between(lo, hi))
            .chain([hi])
            .collect();
        for &h in &nodes {
            let air = self.air_at(h);
            check_ciddor_range(&air).map_err(|why| {
                MediumError::invalid(key.to_string(), format!("at h = {h:.3} m above base: {why}"))
            })?;
        }
        // Subdivide each piece of constant lapse rate: n is smooth there, and
        // at PIECES per piece the monotone cubic stays within 1e-10 of it.
        // At a break n' jumps, and the cubic's node slope (a mean of the two
        // secants) rounds the kink by about the jump times the interval:
        // intervals halving toward each break (GRADED times) keep that below
        // 1e-10 too.
        const PIECES: usize = 64;
        const GRADED: i32 = 14;
        let mut heights = Vec::with_capacity(nodes.len() * (PIECES + 2 * GRADED as usize));
        for w in nodes.windows(2) {
            let step = (w[1] - w[0]) / PIECES as f64;
            heights.extend((0..PIECES).map(|k| w[0] + step * k as f64));
            for j in 1..=GRADED {
                let f = step * 0.5f64.powi(j);
                heights.extend([w[0] + f, w[1] - f]);
            }
        }
        heights.push(hi);
        heights.sort_by(f64::total_cmp);
        heights.dedup();
        let n = heights.iter().map(|&h| self.n_at(h)).collect();
        // The bending's features are the lapse pieces, not the table's
        // spacing (the graded nodes at the breaks would cap chords at
        // nanometres).
        let layer = self
            .heights
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        IndexField::Profile {
            heights,
            n,
            up: self.up,
            base: self.base,
            layer: Some(layer),
        }
        .validated(key)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn air(celsius: f64, pascals: f64, humidity: f64, nm: f64) -> Air {
        Air {
            celsius,
            pascals,
            humidity,
            co2_ppm: 450.0,
            wavelength_um: nm * 1e-3,
        }
    }

    /// Ciddor's standard air is his dispersion formula by construction;
    /// Edlén's (an independent fit to other measurements) agrees with it
    /// within a few 1e-8 over the visible at ordinary conditions, and a
    /// formula without the density's temperature dependence does not.
    #[test]
    fn ciddor_and_edlen_agree_and_a_constant_density_does_not() {
        let mut worst = 0.0f64;
        let mut worst_wrong = 0.0f64;
        for nm in [400.0, 480.0, 550.0, 633.0] {
            for t in [0.0, 10.0, 20.0, 30.0] {
                for p in [95_000.0, 101_325.0, 105_000.0] {
                    for h in [0.0, 0.5] {
                        let a = air(t, p, h, nm);
                        let (c, e) = (ciddor(&a), edlen(&a));
                        worst = worst.max((c - e).abs());
                        // Known-wrong: standard air's refractivity scaled by
                        // pressure only (the temperature forgotten).
                        let wrong = 1.0 + (ciddor(&air(15.0, 101_325.0, 0.0, nm)) - 1.0) * p / 101_325.0;
                        worst_wrong = worst_wrong.max((c - wrong).abs());
                    }
                }
            }
        }
        eprintln!("Ciddor vs Edlén {worst:e}; pressure-only scaling {worst_wrong:e}");
        assert!(worst < 5e-8, "Ciddor vs Edlén: {worst:e}");
        assert!(
            worst_wrong > 20.0 * 5e-8,
            "the wrong variant is only {worst_wrong:e} off"
        );
        // Standard air at 15 °C is Ciddor's k-term formula itself.
        let s2 = 1.0 / (0.55f64 * 0.55);
        let std = (5_792_105.0 / (238.0185 - s2) + 167_917.0 / (57.362 - s2)) * 1e-8;
        assert!((ciddor(&air(15.0, 101_325.0, 0.0, 550.0)) - 1.0 - std).abs() < 1e-12);
    }

    fn road() -> Atmosphere {
        Atmosphere {
            heights: vec![0.0, 0.5, 5.0, 50.0],
            celsius: vec![55.0, 32.0, 30.0, 29.0],
            pressure: 101_325.0,
            humidity: 0.3,
            co2_ppm: 450.0,
            wavelength_nm: 550.0,
            up: DVec3::Y,
            base: 0.0,
        }
    }

    /// The closed-form hydrostatic pressure against a fine numerical
    /// integration of dp/dh = −p·gM/(R·T(h)); dropping the profile's
    /// temperature (an isothermal 15 °C atmosphere) fails the same bound.
    #[test]
    fn pressure_is_hydrostatic() {
        let a = road();
        for h_end in [-0.8, 0.3, 4.0, 60.0] {
            let steps = 20_000;
            let dh = h_end / steps as f64;
            let integral: f64 = (0..steps)
                .map(|i| G_M_OVER_R / (a.celsius_at((i as f64 + 0.5) * dh) + ZERO_CELSIUS) * dh)
                .sum();
            let exact = a.pressure_at(h_end);
            let rel = (exact / (a.pressure * (-integral).exp()) - 1.0).abs();
            assert!(rel < 1e-10, "h {h_end}: {rel:e}");
            let isothermal = a.pressure * (-G_M_OVER_R * h_end / 288.15).exp();
            if h_end.abs() > 1.0 {
                assert!((isothermal / exact - 1.0).abs() > 100.0 * 1e-10, "h {h_end}");
            }
        }
    }

    /// The tabulated field stays within 1e-10 of the formula everywhere in
    /// the bounds; the field with the pressure held at its ground value
    /// (no hydrostatics) is farther off than that.
    #[test]
    fn table_follows_the_formula() {
        let a = road();
        let f = a.to_field("medium.atmosphere", -1.0, 60.0).unwrap();
        let mut worst = 0.0f64;
        let mut worst_wrong = 0.0f64;
        // Evenly, and close to every break (where the cubic rounds the kink).
        let near_breaks = [0.0, 0.5, 5.0, 50.0]
            .into_iter()
            .flat_map(|b| (1..=9).flat_map(move |k| [b - 10f64.powi(-k), b + 10f64.powi(-k)]));
        let even = (0..=5000).map(|i| -1.0 + 61.0 * (i as f64 + 0.37) / 5001.0);
        for h in even.chain(near_breaks) {
            let n = f.n(DVec3::new(0.0, h, 0.0));
            worst = worst.max((n - a.n_at(h)).abs());
            let wrong = ciddor(&Air {
                pascals: a.pressure,
                ..a.air_at(h)
            });
            worst_wrong = worst_wrong.max((n - wrong).abs());
        }
        eprintln!("table vs formula {worst:e}, without hydrostatics {worst_wrong:e}");
        assert!(worst < 1e-10, "table vs formula {worst:e}");
        assert!(
            worst_wrong > 100.0 * 1e-10,
            "no-hydrostatics variant only {worst_wrong:e}"
        );
    }

    #[test]
    fn out_of_range_air_names_the_height() {
        let mut a = road();
        a.celsius[0] = 120.0;
        let e = a
            .to_field("medium.atmosphere", -1.0, 10.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("medium.atmosphere") && e.contains("temperature") && e.contains("h = "),
            "{e}"
        );
        let mut a = road();
        a.celsius = vec![20.0, 20.0];
        a.heights = vec![0.0, 3000.0];
        let e = a
            .to_field("medium.atmosphere", 0.0, 3000.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pressure"), "{e}");
        let mut a = road();
        a.celsius.pop();
        let e = a
            .to_field("medium.atmosphere", 0.0, 10.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("medium.atmosphere.celsius"), "{e}");
        let mut a = road();
        a.heights[2] = 0.4;
        let e = a
            .to_field("medium.atmosphere", 0.0, 10.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("medium.atmosphere.heights"), "{e}");
    }
}
