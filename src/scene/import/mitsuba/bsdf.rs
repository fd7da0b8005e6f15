//! `<bsdf>`s as snell materials. `diffuse`, `dielectric`, `twosided` and a
//! smooth `conductor` of `material="none"` map exactly; rough variants,
//! coloured conductors and `plastic` map to their nearest smooth kind with
//! one warning per material; what snell has no kind for is refused.
use super::ior;
use super::props::{ColorParam, Ctx, Obj};
use super::textures::{self, Uv};
use super::xml::Node;
use crate::error::Result;
use crate::scene::desc::{DielectricDesc, DiffuseDesc, MaterialDesc, MirrorDesc, TextureDesc};

/// A surface's material, before the shape's `flip_normals` is applied.
pub enum Surface {
    /// Lambertian, one- or two-sided.
    Diffuse {
        /// Albedo.
        reflectance: TextureDesc,
        /// Both sides.
        two_sided: bool,
    },
    /// A smooth dielectric interface (int on the side opposite the normal).
    Dielectric {
        /// Index inside.
        int_ior: f64,
        /// Index outside.
        ext_ior: f64,
    },
    /// A perfect mirror.
    Mirror([f64; 3]),
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
            Surface::Dielectric { int_ior, ext_ior } => {
                let (i, e) = if flip {
                    (*ext_ior, *int_ior)
                } else {
                    (*int_ior, *ext_ior)
                };
                MaterialDesc::Dielectric(DielectricDesc {
                    ior: None,
                    priority: None,
                    int_ior: Some(i),
                    ext_ior: Some(e),
                    absorption: None,
                })
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
    let rough_note = |o: &Obj<'_, '_>| -> Result<()> {
        let alpha = o.float("alpha")?.unwrap_or(0.1);
        let au = o.float("alpha_u")?;
        let av = o.float("alpha_v")?;
        o.string("distribution")?;
        o.bool_or("sample_visible", true)?;
        ctx.warn(
            o.at(),
            format!(
                "roughness (alpha {}) is dropped: snell's {} are smooth",
                au.or(av).unwrap_or(alpha),
                if plugin.contains("dielectric") {
                    "dielectrics"
                } else {
                    "mirrors"
                }
            ),
        );
        Ok(())
    };
    let s = match plugin {
        "diffuse" => Surface::Diffuse {
            reflectance: reflectance(ctx, &o, "reflectance", uv)?,
            two_sided: false,
        },
        "dielectric" | "roughdielectric" => {
            if plugin == "roughdielectric" {
                rough_note(&o)?;
            }
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
            Surface::Dielectric { int_ior, ext_ior }
        }
        "conductor" | "roughconductor" => {
            if plugin == "roughconductor" {
                rough_note(&o)?;
            }
            let material = o.string("material")?.map(|(m, _)| m.to_string());
            let eta = o.color("eta", false)?.is_some() || o.color("k", false)?.is_some();
            let r = match o.color("specular_reflectance", false)? {
                None => [1.0; 3],
                Some(ColorParam::Rgb(v)) => v,
                Some(ColorParam::Texture(t)) => {
                    return Err(t.at.error("a textured specular_reflectance is not supported"))
                }
            };
            if eta || material.as_deref().is_some_and(|m| m != "none") {
                ctx.warn(
                    o.at(),
                    format!(
                        "the conductor's Fresnel ({}) is dropped: rendered as a mirror of reflectance {r:?} (snell has no metals)",
                        material.as_deref().unwrap_or("eta, k")
                    ),
                );
            }
            Surface::Mirror(r)
        }
        "plastic" | "roughplastic" => {
            if plugin == "roughplastic" {
                o.float("alpha")?;
                o.string("distribution")?;
            }
            let refl = reflectance(ctx, &o, "diffuse_reflectance", uv)?;
            o.color("specular_reflectance", false)?;
            ior::param(&o, "int_ior", "polypropylene")?;
            ior::param(&o, "ext_ior", "air")?;
            o.bool_or("nonlinear", false)?;
            ctx.warn(
                o.at(),
                format!("\"{plugin}\": its specular coat is dropped, rendered as its diffuse base"),
            );
            Surface::Diffuse {
                reflectance: refl,
                two_sided: false,
            }
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
                "\"{plugin}\" has no counterpart in snell (diffuse, dielectric, mirror)"
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
