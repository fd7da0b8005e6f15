//! Named metals: complex indices of refraction η + iκ per RGB channel,
//! exactly as Mitsuba 3's RGB variants use them for `conductor` and
//! `roughconductor` with `material = "<name>"`, so that images agree.
//!
//! Source: read from Mitsuba 3.9.1 (PyPI `mitsuba`, variant `scalar_rgb`)
//! with `mi.traverse(mi.load_dict({'type': 'conductor', 'material': name}))`,
//! parameters `eta.value` and `k.value`, printed to 9 significant digits
//! (every `f32` round-trips). Mitsuba computes them when the plugin loads:
//! its spectral data `data/ior/<name>.eta.spd` and `.k.spd` are integrated
//! against the CIE 1931 matching functions (`spectrum_list_to_srgb`,
//! 1000 steps over 360–830 nm, no illuminant) and converted to linear sRGB.
//! Its documentation says of the data: "identical to the data distributed
//! with PBRT. They are originally from the Luxpop database
//! (www.luxpop.com) and are based on data by Palik et al. [Handbook of
//! Optical Constants of Solids, 1998] and measurements of atomic scattering
//! factors made by the Center For X-Ray Optics (CXRO) at Berkeley and the
//! Lawrence Livermore National Laboratory (LLNL)."
//!
//! Mitsuba has no iron; its nickel is `Ni_palik` (Palik's data, the only
//! nickel entry). `none` is Mitsuba's idealised 100% mirror (η = 0, κ = 1,
//! for which the conductor Fresnel term is exactly 1).
use glam::Vec3;

/// A named conductor's complex index of refraction (relative to vacuum).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Metal {
    /// Mitsuba's material name.
    pub name: &'static str,
    /// What it is.
    pub description: &'static str,
    /// Real part η (R, G, B).
    pub eta: Vec3,
    /// Imaginary part κ, the extinction coefficient (R, G, B).
    pub k: Vec3,
}

const fn metal(name: &'static str, description: &'static str, eta: [f32; 3], k: [f32; 3]) -> Metal {
    Metal {
        name,
        description,
        eta: Vec3::new(eta[0], eta[1], eta[2]),
        k: Vec3::new(k[0], k[1], k[2]),
    }
}

/// The table (Mitsuba 3.9.1, `scalar_rgb`).
pub const METALS: &[Metal] = &[
    metal(
        "Ag",
        "silver",
        [0.1552762, 0.116727956, 0.13838764],
        [4.8283544, 3.1222224, 2.1469011],
    ),
    metal(
        "Al",
        "aluminium",
        [1.6575009, 0.8804047, 0.52124447],
        [9.223811, 6.269502, 4.837004],
    ),
    metal(
        "Au",
        "gold",
        [0.14303598, 0.37530708, 1.4420453],
        [3.982997, 2.3855565, 1.6033592],
    ),
    metal(
        "Cr",
        "chromium",
        [4.3696675, 2.9165053, 1.6549046],
        [5.206547, 4.231306, 3.7546988],
    ),
    metal(
        "Cu",
        "copper",
        [0.20100547, 0.9237495, 1.1022154],
        [3.9132621, 2.4530451, 2.1420898],
    ),
    metal(
        "Hg",
        "mercury",
        [2.3989387, 1.440028, 0.9095704],
        [6.327587, 4.371925, 3.4217637],
    ),
    metal(
        "Ir",
        "iridium",
        [3.0863, 2.0821905, 1.6179146],
        [5.592153, 4.067088, 3.267312],
    ),
    metal(
        "Ni_palik",
        "nickel (Palik)",
        [2.3673046, 1.6633731, 1.4670781],
        [4.4988117, 3.050153, 2.3454392],
    ),
    metal(
        "Rh",
        "rhodium",
        [2.5857935, 1.8602164, 1.5542634],
        [6.7822604, 4.702987, 3.976073],
    ),
    metal(
        "Ta",
        "tantalum",
        [2.062721, 2.3929389, 2.6279287],
        [2.4083598, 1.7414864, 1.9470278],
    ),
    metal(
        "TiN",
        "titanium nitride",
        [1.6484497, 1.150516, 1.3798234],
        [3.368328, 1.9434981, 1.1020677],
    ),
    metal(
        "W",
        "tungsten",
        [4.3708167, 3.3002465, 2.9984074],
        [3.5006406, 2.604874, 2.2732332],
    ),
    metal(
        "none",
        "an ideal mirror (Fresnel term 1)",
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 1.0],
    ),
];

/// The metal called `name` (Mitsuba's spelling, case-sensitive).
pub fn find(name: &str) -> Option<&'static Metal> {
    METALS.iter().find(|m| m.name == name)
}

/// The known names, comma-separated (for error messages).
pub fn names() -> String {
    METALS.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::fresnel;

    #[test]
    fn metals_look_like_their_colours() {
        let r = |name: &str| {
            let m = find(name).unwrap();
            fresnel::conductor(1.0, m.eta, m.k)
        };
        // Normal-incidence reflectance: gold and copper are red-yellow,
        // silver and aluminium nearly white and bright, "none" is a mirror.
        let au = r("Au");
        assert!(au.x > au.y && au.y > au.z && au.z < 0.5, "{au}");
        let cu = r("Cu");
        assert!(cu.x > cu.y && cu.y > cu.z, "{cu}");
        for bright in ["Ag", "Al"] {
            let v = r(bright);
            assert!(
                v.min_element() > 0.85 && v.max_element() - v.min_element() < 0.1,
                "{bright}: {v}"
            );
        }
        assert_eq!(r("none"), Vec3::ONE);
        assert!(find("Fe").is_none());
        let mut names: Vec<&str> = METALS.iter().map(|m| m.name).collect();
        names.dedup();
        assert_eq!(names.len(), METALS.len());
    }
}
