//! `<texture>`s on surfaces: a `checkerboard` over a rectangle's (u, v)
//! becomes snell's world-space checker when its squares line up with two
//! world axes; a `bitmap` on an OBJ mesh becomes an image texture.
use super::props::{ColorParam, Ctx, Obj};
use crate::error::Result;
use crate::scene::desc::{CheckerDesc, ImageTextureDesc, TextureDesc, TextureTable};
use glam::{DMat4, DVec3};

/// How a shape's (u, v) lies in the world, when it is planar and affine:
/// the world point at (u, v) is `origin + u du + v dv` (Mitsuba's rectangle).
#[derive(Debug, Clone, Copy)]
pub struct UvFrame {
    /// World point at (0, 0).
    pub origin: DVec3,
    /// World offset from u = 0 to u = 1.
    pub du: DVec3,
    /// World offset from v = 0 to v = 1.
    pub dv: DVec3,
}

/// What a surface's (u, v) is, for textures.
#[derive(Debug, Clone, Copy)]
pub enum Uv {
    /// An affine frame (rectangles).
    Frame(UvFrame),
    /// An OBJ mesh's texture coordinates (read as Mitsuba flips them).
    Obj,
    /// Anything else: textures cannot be mapped.
    None,
}

/// A colour parameter as a snell texture.
pub fn color(ctx: &Ctx<'_>, c: ColorParam<'_>, uv: Uv, emitter: bool) -> Result<TextureDesc> {
    match c {
        ColorParam::Rgb(v) => Ok(TextureDesc::Constant(v)),
        ColorParam::Texture(n) => {
            let o = Obj::new(ctx, n)?;
            let t = match o.plugin()? {
                "checkerboard" => checkerboard(&o, uv, emitter)?,
                "bitmap" => bitmap(ctx, &o, uv)?,
                other => {
                    return Err(o.at().error(format!(
                        "texture \"{other}\" is not supported (snell maps checkerboard on rectangles and bitmap on OBJ meshes)"
                    )))
                }
            };
            o.finish()?;
            Ok(t)
        }
    }
}

fn constant(o: &Obj<'_, '_>, key: &str, default: f64, emitter: bool) -> Result<[f64; 3]> {
    match o.color(key, emitter)? {
        None => Ok([default; 3]),
        Some(ColorParam::Rgb(v)) => Ok(v),
        Some(ColorParam::Texture(t)) => Err(t.at.error("a texture inside a checkerboard is not supported")),
    }
}

/// 2-D affine map of `to_uv` (Mitsuba keeps the x, y rows and columns and
/// the translation of the 4×4): `[[a, b, tx], [c, d, ty]]`.
fn uv_affine(m: &DMat4) -> [[f64; 3]; 2] {
    [
        [m.x_axis.x, m.y_axis.x, m.w_axis.x],
        [m.x_axis.y, m.y_axis.y, m.w_axis.y],
    ]
}

fn checkerboard(o: &Obj<'_, '_>, uv: Uv, emitter: bool) -> Result<TextureDesc> {
    let c0 = constant(o, "color0", 0.4, emitter)?;
    let c1 = constant(o, "color1", 0.2, emitter)?;
    let (m, _) = o.transform("to_uv")?;
    let Uv::Frame(f) = uv else {
        return Err(o.at().error(
            "a checkerboard maps to snell's world-space checker only on a <shape type=\"rectangle\">",
        ));
    };
    let a = uv_affine(&m);
    let fail = || {
        o.at().error(
            "this checkerboard's squares do not line up with two world axes (snell's checker is in world coordinates)",
        )
    };
    // Row r of to_uv is u' = a·u + b·v + t. On the rectangle that must be
    // world coordinate p_i / (2 size) + offset for one axis i.
    let mut axes = Vec::new();
    let mut size = None::<f64>;
    let mut parity = 0i64;
    for row in a {
        let mut found = None;
        for i in 0..3 {
            let (du, dv) = (f.du[i], f.dv[i]);
            // (row[0], row[1]) = (du, dv) / (2 s) for some s != 0.
            let scale = if du.abs() > dv.abs() {
                row[0] / du
            } else {
                row[1] / dv
            };
            if !scale.is_finite() || scale == 0.0 {
                continue;
            }
            let tol = 1e-9 * (row[0].abs() + row[1].abs()).max(1e-300);
            if (row[0] - scale * du).abs() <= tol && (row[1] - scale * dv).abs() <= tol {
                found = Some((i, scale));
                break;
            }
        }
        let (i, scale) = found.ok_or_else(fail)?;
        let s = 1.0 / (2.0 * scale.abs());
        match size {
            None => size = Some(s),
            Some(prev) if ((prev - s) / prev).abs() < 1e-9 => {}
            Some(_) => return Err(fail()),
        }
        // u' = sign · p_i / (2s) + off, off = t − scale·origin_i; 2·off
        // must be an integer for the squares to fall on snell's grid.
        let off2 = 2.0 * (row[2] - scale * f.origin[i]);
        let k = off2.round();
        if (off2 - k).abs() > 1e-6 {
            return Err(fail());
        }
        parity += k as i64 + i64::from(scale < 0.0);
        axes.push(i);
    }
    if axes[0] == axes[1] {
        return Err(fail());
    }
    let name = |i: usize| ["x", "y", "z"][i].to_string();
    let (color0, color1) = if parity.rem_euclid(2) == 0 {
        (c0, c1)
    } else {
        (c1, c0)
    };
    Ok(TextureDesc::Table(TextureTable::Checker(CheckerDesc {
        axes: [name(axes[0]), name(axes[1])],
        size: size.unwrap_or(1.0),
        color0,
        color1,
    })))
}

fn bitmap(ctx: &Ctx<'_>, o: &Obj<'_, '_>, uv: Uv) -> Result<TextureDesc> {
    let (file, at) = o
        .string("filename")?
        .ok_or_else(|| o.at().error("expected <string name=\"filename\">"))?;
    let (m, _) = o.transform("to_uv")?;
    if o.bool_or("raw", false)? {
        ctx.warn(o.at(), "raw = true: snell decodes 8-bit images as sRGB");
    }
    for k in ["filter_type", "wrap_mode", "format"] {
        if let Some((v, _)) = o.string(k)? {
            if !matches!(v, "bilinear" | "repeat" | "variant") {
                ctx.warn(o.at(), format!("{k} = \"{v}\" is ignored"));
            }
        }
    }
    if !matches!(uv, Uv::Obj) {
        return Err(o.at().error(
            "a bitmap is mapped on <shape type=\"obj\"> only (other shapes' (u, v) differ from snell's)",
        ));
    }
    let a = uv_affine(&m);
    if a[0][1] != 0.0
        || a[1][0] != 0.0
        || a[0][2] != 0.0
        || a[1][2] != 0.0
        || a[0][0] <= 0.0
        || a[1][1] <= 0.0
    {
        return Err(o.at().error("a bitmap's to_uv may only scale (by factors > 0)"));
    }
    let path = ctx.doc.resolve(file);
    if !path.is_file() {
        return Err(at.error(format!("{} not found", path.display())));
    }
    Ok(TextureDesc::Table(TextureTable::Image(ImageTextureDesc {
        file: ctx.doc.desc_path(&path),
        uv_scale: [a[0][0], a[1][1]],
    })))
}
