//! glTF materials as snell materials. Transmission (with `KHR_materials_ior`
//! and `KHR_materials_volume`) makes a dielectric: a priority solid on a
//! closed mesh (Beer–Lambert absorption from the volume's attenuation,
//! priority from the `snell:priority` extra), an interface on an open one.
//! A fully metallic material is a rough conductor tinted by its base colour
//! (see [`map`]). Everything else is diffuse with its base colour (a texture
//! file when it has one). What does not map is listed in one warning per material.
use crate::scene::desc::*;
use serde_json::Value;

/// The extras key holding a dielectric's nesting priority (an integer).
pub const PRIORITY_KEY: &str = "snell:priority";

/// Extensions whose meaning is mapped (others are listed as not mapped).
const MAPPED_EXTENSIONS: &[&str] = &[
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_emissive_strength",
];

/// A glTF material in snell's terms.
pub struct Mapped {
    /// The surface.
    pub material: MaterialDesc,
    /// Constant or textured emission.
    pub emission: Option<EmissionDesc>,
    /// What could not be mapped (empty: exact).
    pub lost: Vec<String>,
    /// Opaque and black apart from its emission (a light candidate).
    pub black: bool,
}

/// The f64 a file's decimal meant, from the f32 the `gltf` crate keeps it as
/// (`1.33`, not `1.3300000429153442`): the shortest decimal that reads back
/// as that f32.
pub fn short(x: f32) -> f64 {
    format!("{x}").parse().unwrap_or(x as f64)
}

/// The extras object of a glTF item, if it is one.
pub fn extras(e: &gltf::json::Extras) -> Option<serde_json::Map<String, Value>> {
    let raw = e.as_ref()?;
    match serde_json::from_str::<Value>(raw.get()) {
        Ok(Value::Object(m)) => Some(m),
        _ => None,
    }
}

/// Map material `m`; `closed` says whether the mesh it is on is a closed
/// solid; `image_file` turns a base colour texture's image into a file name
/// (None for an embedded image).
pub fn map(
    m: &gltf::Material<'_>,
    closed: bool,
    image_file: &dyn Fn(&gltf::Texture<'_>) -> Option<String>,
) -> Result<Mapped, (String, String)> {
    let at = match m.index() {
        Some(i) => format!("/materials/{i}"),
        None => "/materials (default)".into(),
    };
    let pbr = m.pbr_metallic_roughness();
    let base = pbr.base_color_factor();
    let (metallic, rough) = (pbr.metallic_factor(), pbr.roughness_factor());
    let mut lost = Vec::new();
    let priority = match extras(m.extras()).and_then(|x| x.get(PRIORITY_KEY).cloned()) {
        None => None,
        Some(v) => Some(v.as_i64().ok_or_else(|| {
            (
                format!("{at}/extras/{PRIORITY_KEY}"),
                format!("expected an integer priority, got {v}"),
            )
        })?),
    };
    let transmission = m.transmission();
    let t = transmission.as_ref().map_or(0.0, |t| t.transmission_factor());
    let rgb = [short(base[0]), short(base[1]), short(base[2])];
    let mut black = false;
    let material = if t >= 0.5 {
        if t < 1.0 {
            lost.push(format!("transmission {t} (rendered as 1)"));
        }
        if rough > 0.0 {
            lost.push(format!("roughness {rough} (snell's dielectrics are smooth)"));
        }
        if metallic > 0.0 {
            lost.push(format!("metallic {metallic}"));
        }
        if transmission
            .as_ref()
            .is_some_and(|t| t.transmission_texture().is_some())
        {
            lost.push("transmission texture".into());
        }
        if pbr.base_color_texture().is_some() {
            lost.push("base colour texture on a transmissive surface".into());
        }
        if rgb != [1.0; 3] {
            lost.push("base colour tint of the transmission (use the volume's attenuation)".into());
        }
        let ior = m.ior().map_or(1.5, short);
        if !(ior.is_finite() && ior > 0.0) {
            return Err((
                format!("{at}/extensions/KHR_materials_ior/ior"),
                format!("expected an index > 0, got {ior}"),
            ));
        }
        let absorption = m.volume().and_then(|v| {
            let d = short(v.attenuation_distance());
            let c = v.attenuation_color().map(|x| short(x).clamp(1e-6, 1.0));
            (d.is_finite() && d > 0.0 && c != [1.0; 3]).then_some(AbsorptionDesc {
                color: c,
                distance: d,
            })
        });
        if closed {
            MaterialDesc::Dielectric(DielectricDesc {
                ior: Some(ior),
                priority,
                int_ior: None,
                ext_ior: None,
                absorption,
            })
        } else {
            if priority.is_some() {
                lost.push(format!(
                    "{PRIORITY_KEY} on an open mesh (an interface has no priority; close the mesh)"
                ));
            }
            if absorption.is_some() {
                lost.push("volume attenuation on an open mesh (an interface has no inside)".into());
            }
            MaterialDesc::Dielectric(DielectricDesc {
                ior: None,
                priority: None,
                int_ior: Some(ior),
                ext_ior: Some(1.0),
                absorption: None,
            })
        }
    } else if metallic >= 1.0 {
        if t > 0.0 {
            lost.push(format!("transmission {t} (rendered opaque)"));
        }
        if priority.is_some() {
            lost.push(format!("{PRIORITY_KEY} on an opaque material"));
        }
        if pbr.base_color_texture().is_some() {
            lost.push("base colour texture on a metal (the factor is used)".into());
        }
        if pbr.metallic_roughness_texture().is_some() {
            lost.push("metallic-roughness texture (the factors are used)".into());
        }
        // glTF gives a metal's colour as its reflectance at normal incidence
        // (Schlick's F0), not a complex index: the ideal mirror metal ("none",
        // F = 1) scaled by the base colour keeps that colour at every angle,
        // without the whitening towards grazing.
        lost.push(format!(
            "metallic {metallic}: a conductor of reflectance base colour at every angle (no complex index)"
        ));
        let specular_reflectance = rgb.map(|c| c.clamp(0.0, 1.0));
        let two_sided = m.double_sided();
        // glTF's roughness is the square root of the microfacet alpha.
        let alpha = short(rough) * short(rough);
        if alpha > 0.0 {
            MaterialDesc::RoughConductor(RoughConductorDesc {
                material: Some("none".into()),
                eta: None,
                k: None,
                specular_reflectance,
                two_sided,
                distribution: DistributionDesc::Ggx,
                alpha: alpha.min(1.0),
            })
        } else {
            MaterialDesc::Conductor(ConductorDesc {
                material: Some("none".into()),
                eta: None,
                k: None,
                specular_reflectance,
                two_sided,
            })
        }
    } else {
        if t > 0.0 {
            lost.push(format!("transmission {t} (rendered opaque)"));
        }
        if metallic > 0.0 {
            lost.push(format!(
                "metallic {metallic} (rendered diffuse: snell has no metals)"
            ));
        }
        if priority.is_some() {
            lost.push(format!("{PRIORITY_KEY} on an opaque material"));
        }
        let reflectance = match pbr.base_color_texture() {
            None => TextureDesc::Constant(rgb.map(|c| c.clamp(0.0, 1.0))),
            Some(info) => {
                if info.tex_coord() != 0 {
                    lost.push(format!(
                        "base colour texture on TEXCOORD_{} (only TEXCOORD_0 is read)",
                        info.tex_coord()
                    ));
                }
                if info.texture_transform().is_some() {
                    lost.push("KHR_texture_transform".into());
                }
                match image_file(&info.texture()) {
                    Some(file) => {
                        if rgb != [1.0; 3] {
                            lost.push(
                                "base colour factor times the texture (the texture alone is used)".into(),
                            );
                        }
                        TextureDesc::Table(TextureTable::Image(ImageTextureDesc {
                            file,
                            uv_scale: [1.0, 1.0],
                        }))
                    }
                    None => {
                        lost.push("embedded base colour image (export textures as separate files; the factor is used)".into());
                        TextureDesc::Constant(rgb.map(|c| c.clamp(0.0, 1.0)))
                    }
                }
            }
        };
        black = matches!(reflectance, TextureDesc::Constant(c) if c == [0.0; 3]);
        MaterialDesc::Diffuse(DiffuseDesc {
            reflectance,
            two_sided: m.double_sided(),
        })
    };
    let strength = m.emissive_strength().map_or(1.0, short);
    let e = m.emissive_factor().map(|x| short(x) * strength);
    if m.emissive_texture().is_some() {
        lost.push("emissive texture (the emissive factor is used)".into());
    }
    // A double-sided material shades (and so emits from) both faces.
    let emission = (e.iter().any(|x| *x > 0.0)).then_some(EmissionDesc {
        radiance: TextureDesc::Constant(e),
        two_sided: m.double_sided(),
    });
    if m.alpha_mode() != gltf::material::AlphaMode::Opaque {
        lost.push(format!("alphaMode {:?}", m.alpha_mode()));
    }
    if m.normal_texture().is_some() {
        lost.push("normal map".into());
    }
    if let Some(ext) = m.extensions() {
        for k in ext.keys() {
            if !MAPPED_EXTENSIONS.contains(&k.as_str()) {
                lost.push(k.trim_start_matches("KHR_materials_").to_string());
            }
        }
    }
    Ok(Mapped {
        material,
        emission,
        lost,
        black,
    })
}
