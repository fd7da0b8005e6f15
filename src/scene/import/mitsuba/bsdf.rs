//! `<bsdf>`s as snell materials. `diffuse`, `dielectric`, `roughdielectric`,
//! `conductor`, `roughconductor`, `plastic`, `roughplastic` and `twosided`
//! map exactly (a `conductor` of `material="none"` as a mirror); what snell
//! cannot represent (anisotropic or textured roughness, textured metal or
//! plastic colours) is refused, as is what it has no kind for.
use super::ior;
use super::props::{ColorParam, Ctx, Obj};
use super::textures::{self, Uv};
use super::xml::Node;
use crate::bsdf::metals;
use crate::error::Result;
use crate::scene::desc::{
    ConductorDesc, DielectricDesc, DiffuseDesc, DistributionDesc, MaterialDesc, MirrorDesc, PlasticDesc,
    RoughConductorDesc, RoughDielectricDesc, RoughPlasticDesc, TextureDesc,
};

/// A surface's material, before the shape's `flip_normals` is applied.
pub enum Surface {
    /// Lambertian, one- or two-sided.
    Diffuse {
        /// Albedo.
        reflectance: TextureDesc,
        /// Both sides.
        two_sided: bool,
    },
    /// A dielectric interface (int on the side opposite the normal),
    /// smooth or rough.
    Dielectric {
        /// Index inside.
        int_ior: f64,
        /// Index outside.
        ext_ior: f64,
        /// A rough one's distribution and alpha.
        rough: Option<(DistributionDesc, f64)>,
    },
    /// A perfect mirror.
    Mirror([f64; 3]),
    /// A metal or a plastic: one-sided unless its `two_sided` is set.
    OneSided(MaterialDesc),
}

impl Surface {
    /// The snell material, with the surface's normal flipped when `flip`:
    /// an interface swaps its indices, a two-sided diffuse is unchanged;
    /// `None` when only the geometry can flip (one-sided diffuse, mirror).
    pub fn material(&self, flip: bool) -> Option<MaterialDesc> {
        Some(match self {
            Surface::Diffuse {
                reflectance,
                two_sided,
            } => {
                if flip && !two_sided {
                    return None;
                }
                MaterialDesc::Diffuse(DiffuseDesc {
                    reflectance: reflectance.clone(),
                    two_sided: *two_sided,
                })
            }
            Surface::Dielectric {
                int_ior,
                ext_ior,
                rough,
            } => {
                let (i, e) = if flip {
                    (*ext_ior, *int_ior)
                } else {
                    (*int_ior, *ext_ior)
                };
                match rough {
                    None => MaterialDesc::Dielectric(DielectricDesc {
                        ior: None,
                        priority: None,
                        int_ior: Some(i),
                        ext_ior: Some(e),
                        absorption: None,
                    }),
                    Some((distribution, alpha)) => MaterialDesc::RoughDielectric(RoughDielectricDesc {
                        ior: None,
                        priority: None,
                        int_ior: Some(i),
                        ext_ior: Some(e),
                        absorption: None,
                        distribution: *distribution,
                        alpha: *alpha,
                    }),
                }
            }
            Surface::OneSided(m) => {
                if flip && !one_sided_is_two_sided(m) {
                    return None;
                }
                m.clone()
            }
            Surface::Mirror(r) => {
                if flip {
                    return None;
                }
                MaterialDesc::Mirror(MirrorDesc { reflectance: *r })
            }
        })
    }

    /// Does the surface reflect nothing (a black one-sided diffuse)?
    pub fn is_black(&self) -> bool {
        matches!(self, Surface::Diffuse { reflectance, .. } if is_black(reflectance))
    }
}

/// Does a metal or plastic reflect on both sides?
fn one_sided_is_two_sided(m: &MaterialDesc) -> bool {
    match m {
        MaterialDesc::Conductor(c) => c.two_sided,
        MaterialDesc::RoughConductor(c) => c.two_sided,
        MaterialDesc::Plastic(p) => p.two_sided,
        MaterialDesc::RoughPlastic(p) => p.two_sided,
        _ => false,
    }
}

/// The same metal or plastic, reflecting on both sides.
fn make_two_sided(mut m: MaterialDesc) -> MaterialDesc {
    match &mut m {
        MaterialDesc::Conductor(c) => c.two_sided = true,
        MaterialDesc::RoughConductor(c) => c.two_sided = true,
        MaterialDesc::Plastic(p) => p.two_sided = true,
        MaterialDesc::RoughPlastic(p) => p.two_sided = true,
        _ => {}
    }
    m
}

/// A rough BSDF's `distribution` (Mitsuba's default: Beckmann) and
/// isotropic `alpha` (default 0.1); anisotropic or textured roughness is refused.
fn roughness(o: &Obj<'_, '_>) -> Result<(DistributionDesc, f64)> {
    let distribution = match o.string("distribution")? {
        None | Some(("beckmann", _)) => DistributionDesc::Beckmann,
        Some(("ggx", _)) => DistributionDesc::Ggx,
        Some((other, at)) => {
            return Err(at.error(format!(
                "unknown distribution \"{other}\": expected \"beckmann\" or \"ggx\""
            )))
        }
    };
    for k in ["alpha", "alpha_u", "alpha_v"] {
        if o.named_texture(k)?.is_some() {
            return Err(o.at().error(format!(
                "a textured {k} is not supported (snell's roughness is one number)"
            )));
        }
    }
    let alpha = match (o.float("alpha")?, o.float("alpha_u")?, o.float("alpha_v")?) {
        (a, None, None) => a.unwrap_or(0.1),
        (None, Some(u), Some(v)) if u == v => u,
        (None, Some(u), Some(v)) => {
            return Err(o.at().error(format!(
                "anisotropic roughness (alpha_u = {u}, alpha_v = {v}) is not supported: give one alpha"
            )))
        }
        _ => {
            return Err(o.at().error(
                "give either alpha, or both alpha_u and alpha_v (equal: snell's roughness is isotropic)",
            ))
        }
    };
    // Visible normals are always sampled: the estimate is the same either way.
    o.bool_or("sample_visible", true)?;
    Ok((distribution, alpha))
}

/// An RGB parameter that must be a constant (not a texture), `default` when absent.
fn constant_rgb(o: &Obj<'_, '_>, key: &str, default: [f64; 3]) -> Result<[f64; 3]> {
    match o.color(key, false)? {
        None => Ok(default),
        Some(ColorParam::Rgb(v)) => Ok(v),
        Some(ColorParam::Texture(t)) => Err(t.at.error(format!("a textured {key} is not supported"))),
    }
}

fn is_black(t: &TextureDesc) -> bool {
    matches!(t, TextureDesc::Constant(c) if c.iter().all(|x| *x == 0.0))
}

/// The surface of `n` (a `<bsdf>` or a `<ref>` to one); no BSDF is
/// Mitsuba's default, a diffuse of 0.5. `uv` says how textures can be mapped.
pub fn surface(ctx: &Ctx<'_>, n: Option<&Node>, uv: Uv) -> Result<Surface> {
    let Some(n) = n else {
        return Ok(Surface::Diffuse {
            reflectance: TextureDesc::Constant([0.5; 3]),
            two_sided: false,
        });
    };
    let o = Obj::new(ctx, n)?;
    let plugin = o.plugin()?;
    let s = match plugin {
        "diffuse" => Surface::Diffuse {
            reflectance: reflectance(ctx, &o, "reflectance", uv)?,
            two_sided: false,
        },
        "dielectric" | "roughdielectric" => {
            let rough = if plugin == "roughdielectric" {
                Some(roughness(&o)?)
            } else {
                None
            };
            let int_ior = ior::param(&o, "int_ior", "bk7")?;
            let ext_ior = ior::param(&o, "ext_ior", "air")?;
            if o.float("eta")?.is_some() {
                return Err(o.at().error("give int_ior and ext_ior (eta alone is not mapped)"));
            }
            for k in ["specular_reflectance", "specular_transmittance"] {
                match o.color(k, false)? {
                    None => {}
                    Some(ColorParam::Rgb([1.0, 1.0, 1.0])) => {}
                    Some(_) => ctx.warn(
                        o.at(),
                        format!("{k} other than 1 is dropped: snell's dielectrics follow Fresnel alone"),
                    ),
                }
            }
            Surface::Dielectric {
                int_ior,
                ext_ior,
                rough,
            }
        }
        "conductor" | "roughconductor" => {
            let rough = if plugin == "roughconductor" {
                Some(roughness(&o)?)
            } else {
                None
            };
            let material = o.string("material")?;
            let spec = constant_rgb(&o, "specular_reflectance", [1.0; 3])?;
            let eta = match o.color("eta", false)? {
                None => None,
                Some(ColorParam::Rgb(v)) => Some(v),
                Some(ColorParam::Texture(t)) => return Err(t.at.error("a textured eta is not supported")),
            };
            let k = match o.color("k", false)? {
                None => None,
                Some(ColorParam::Rgb(v)) => Some(v),
                Some(ColorParam::Texture(t)) => return Err(t.at.error("a textured k is not supported")),
            };
            let (material, eta, k) = match (material, eta, k) {
                (None, None, None) => (None, None, None),
                (Some((m, at)), None, None) => {
                    if m != "none" && metals::find(m).is_none() {
                        return Err(at.error(format!("unknown metal \"{m}\"; known: {}", metals::names())));
                    }
                    (Some(m), None, None)
                }
                (None, Some(e), Some(k)) => (None, Some(e), Some(k)),
                _ => {
                    return Err(o
                        .at()
                        .error("give either material, or both eta and k (not a mix)"))
                }
            };
            // Mitsuba's default metal is "none": a perfect mirror.
            let material = material.unwrap_or("none").to_string();
            let (material, eta, k) = if eta.is_some() {
                (None, eta, k)
            } else {
                (Some(material), None, None)
            };
            match rough {
                None if material.as_deref() == Some("none") => Surface::Mirror(spec),
                None => Surface::OneSided(MaterialDesc::Conductor(ConductorDesc {
                    material,
                    eta,
                    k,
                    specular_reflectance: spec,
                    two_sided: false,
                })),
                Some((distribution, alpha)) => Surface::OneSided(MaterialDesc::RoughConductor(RoughConductorDesc {
                    material,
                    eta,
                    k,
                    specular_reflectance: spec,
                    two_sided: false,
                    distribution,
                    alpha,
                })),
            }
        }
        "plastic" | "roughplastic" => {
            let rough = if plugin == "roughplastic" {
                Some(roughness(&o)?)
            } else {
                None
            };
            let diffuse_reflectance = constant_rgb(&o, "diffuse_reflectance", [0.5; 3])?;
            let specular_reflectance = constant_rgb(&o, "specular_reflectance", [1.0; 3])?;
            let int_ior = ior::param(&o, "int_ior", "polypropylene")?;
            let ext_ior = ior::param(&o, "ext_ior", "air")?;
            let nonlinear = o.bool_or("nonlinear", false)?;
            Surface::OneSided(match rough {
                None => MaterialDesc::Plastic(PlasticDesc {
                    diffuse_reflectance,
                    specular_reflectance,
                    int_ior,
                    ext_ior,
                    nonlinear,
                    two_sided: false,
                }),
                Some((distribution, alpha)) => MaterialDesc::RoughPlastic(RoughPlasticDesc {
                    diffuse_reflectance,
                    specular_reflectance,
                    int_ior,
                    ext_ior,
                    nonlinear,
                    two_sided: false,
                    distribution,
                    alpha,
                }),
            })
        }
        "twosided" => {
            let inner = o.objects("bsdf")?;
            let Some(first) = inner.first() else {
                return Err(o.at().error("twosided wraps no <bsdf>"));
            };
            if inner.len() > 1 {
                ctx.warn(
                    o.at(),
                    "twosided with two different BSDFs: the front one is used on both sides",
                );
            }
            match surface(ctx, Some(first), uv)? {
                Surface::Diffuse { reflectance, .. } => Surface::Diffuse {
                    reflectance,
                    two_sided: true,
                },
                Surface::Mirror(r) => Surface::Mirror(r),
                Surface::OneSided(m) => Surface::OneSided(make_two_sided(m)),
                Surface::Dielectric { .. } => {
                    return Err(o
                        .at()
                        .error("a two-sided dielectric has no meaning (a dielectric has two sides already)"))
                }
            }
        }
        "mask" | "bumpmap" | "normalmap" | "blendbsdf" => {
            let inner = o.objects("bsdf")?;
            let Some(first) = inner.first() else {
                return Err(o.at().error(format!("{plugin} wraps no <bsdf>")));
            };
            for k in ["opacity", "weight"] {
                o.color(k, false)?;
            }
            o.objects("texture")?;
            o.float("scale")?;
            ctx.warn(
                o.at(),
                format!("\"{plugin}\" is dropped: its first inner BSDF is used"),
            );
            surface(ctx, Some(first), uv)?
        }
        "thindielectric" => {
            return Err(o
                .at()
                .error("snell has no thin dielectric: model both faces (two interfaces or a closed solid)"))
        }
        "null" => return Err(o.at().error("snell has no invisible (null) surfaces")),
        "principled" | "principledthin" | "hair" | "measured" | "pplastic" | "polarizer" | "retarder"
        | "circular" => {
            return Err(o.at().error(format!(
                "\"{plugin}\" has no counterpart in snell (diffuse, dielectric, conductor, plastic and their rough kinds)"
            )))
        }
        other => return Err(o.at().error(format!("unknown BSDF \"{other}\""))),
    };
    o.finish()?;
    Ok(s)
}

/// A reflectance parameter (default 0.5) as a snell texture.
fn reflectance(ctx: &Ctx<'_>, o: &Obj<'_, '_>, key: &str, uv: Uv) -> Result<TextureDesc> {
    match o.color(key, false)? {
        None => Ok(TextureDesc::Constant([0.5; 3])),
        Some(c) => textures::color(ctx, c, uv, false),
    }
}
