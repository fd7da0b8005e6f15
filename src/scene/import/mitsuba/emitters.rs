//! Top-level `<emitter>`s: `constant` and `envmap` become the environment,
//! `point`, `directional` and `spot` lights; `area` emitters belong inside
//! shapes (see `shapes`).
use super::props::{ColorParam, Ctx, Obj};
use super::transform;
use super::xml::Node;
use super::Out;
use crate::error::Result;
use crate::scene::desc::*;
use glam::{DMat4, DVec3};

/// snell's `to_world` for an `envmap` placed by Mitsuba's `m`. Mitsuba
/// reads map direction (x, y, z) at u = atan2(x, −z)/2π, snell at 0.5 +
/// atan2(x, −z)/2π: the same map turned half a turn about +y, so snell's
/// rotation is `m`'s followed by that turn (none when they cancel).
fn envmap_to_world(o: &Obj<'_, '_>, m: &DMat4) -> Result<Vec<TransformDesc>> {
    let r = glam::DMat3::from_mat4(*m);
    let gram = r.transpose() * r - glam::DMat3::IDENTITY;
    let off = gram.to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs()));
    if !(off <= 1e-6 && r.determinant() > 0.0) {
        return Err(o.at().error(
            "an envmap's to_world must be a rotation (translations are ignored; no scale, skew or mirror)",
        ));
    }
    // Negating x and z is exact, unlike a product with a computed half turn.
    let turned = glam::DMat3::from_cols(-r.x_axis, r.y_axis, -r.z_axis);
    if turned.abs_diff_eq(glam::DMat3::IDENTITY, 1e-12) {
        return Ok(Vec::new());
    }
    let c = |v: DVec3| v.to_array();
    let [x, y, z] = [c(turned.x_axis), c(turned.y_axis), c(turned.z_axis)];
    Ok(vec![TransformDesc {
        translate: None,
        rotate: None,
        scale: None,
        matrix: Some([
            [x[0], y[0], z[0], 0.0],
            [x[1], y[1], z[1], 0.0],
            [x[2], y[2], z[2], 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]),
    }])
}

/// Read top-level `<emitter>` `n`.
pub fn top_level(ctx: &Ctx<'_>, n: &Node, out: &mut Out) -> Result<()> {
    let o = Obj::new(ctx, n)?;
    let plugin = o.plugin()?;
    let name = n.attr("id").map(str::to_string);
    let constant = |key: &str| -> Result<[f64; 3]> {
        match o.color(key, true)? {
            None => Ok([1.0; 3]),
            Some(ColorParam::Rgb(v)) => Ok(v),
            Some(ColorParam::Texture(t)) => Err(t.at.error(format!(
                "a textured {key} is not supported on a <emitter type=\"{plugin}\">"
            ))),
        }
    };
    o.float("sampling_weight")?;
    let mut set_env = |e: EnvironmentDesc| -> Result<()> {
        if let Some((_, at)) = &out.environment {
            return Err(n.at.error(format!(
                "a second environment emitter (the first is at line {}): snell has one environment",
                at.line
            )));
        }
        out.environment = Some((e, n.at.clone()));
        Ok(())
    };
    match plugin {
        "constant" => {
            let radiance = constant("radiance")?;
            set_env(EnvironmentDesc::Constant(ConstantEnv { radiance }))?;
        }
        "envmap" => {
            let (file, at) = o
                .string("filename")?
                .ok_or_else(|| o.at().error("expected <string name=\"filename\">"))?;
            let path = ctx.doc.resolve(file);
            if !path.is_file() {
                return Err(at.error(format!("{} not found", path.display())));
            }
            let scale = o.float_or("scale", 1.0)?;
            let (m, _) = o.transform("to_world")?;
            let to_world = envmap_to_world(&o, &m)?;
            // Only importance sampling changes; the radiance does not.
            o.bool_or("mis_compensation", false)?;
            o.string("filter_type")?;
            o.string("wrap_mode")?;
            set_env(EnvironmentDesc::Map(MapEnv {
                file: ctx.doc.desc_path(&path),
                scale,
                to_world,
                // Mitsuba interpolates its rows from pole to pole.
                rows: "poles".into(),
            }))?;
        }
        "point" => {
            let (m, t) = o.transform("to_world")?;
            let position = match o.point("position")? {
                Some(p) if t.is_some() => {
                    return Err(o
                        .at()
                        .error(format!("give position or to_world, not both (position {p})")))
                }
                Some(p) => p,
                None => transform::point(&m, DVec3::ZERO),
            };
            let intensity = constant("intensity")?;
            out.lights.push((
                LightDesc::Point(PointLightDesc {
                    name,
                    position: position.to_array(),
                    intensity,
                }),
                n.at.clone(),
            ));
        }
        "directional" => {
            let (m, t) = o.transform("to_world")?;
            let direction = match o.point("direction")? {
                Some(_) if t.is_some() => return Err(o.at().error("give direction or to_world, not both")),
                Some(d) => d,
                None => transform::vector(&m, DVec3::Z),
            };
            let irradiance = constant("irradiance")?;
            out.lights.push((
                LightDesc::Directional(DirectionalLightDesc {
                    name,
                    direction: direction.to_array(),
                    irradiance,
                }),
                n.at.clone(),
            ));
        }
        "spot" => {
            // Mitsuba's spot sits at the origin of `to_world` and points
            // along its +z; snell's cone is round, so `to_world` must not
            // stretch it.
            let (m, _) = o.transform("to_world")?;
            if transform::similarity(&m).is_none() {
                return Err(o.at().error(
                    "a spot light's to_world must be a similarity (translations, rotations, uniform scales): snell's cone is round",
                ));
            }
            let intensity = constant("intensity")?;
            let cutoff_angle = o.float_or("cutoff_angle", 20.0)?;
            let beam_width = o.float_or("beam_width", cutoff_angle * 0.75)?;
            if let Some(t) = o.color("texture", true)? {
                let at = match t {
                    ColorParam::Texture(t) => &t.at,
                    ColorParam::Rgb(_) => o.at(),
                };
                ctx.unknown(at, "a spot light's projected texture is not supported".into())?;
            }
            out.lights.push((
                LightDesc::Spot(SpotLightDesc {
                    name,
                    position: transform::point(&m, DVec3::ZERO).to_array(),
                    direction: Some(transform::vector(&m, DVec3::Z).to_array()),
                    target: None,
                    intensity,
                    cutoff_angle,
                    beam_width: Some(beam_width),
                }),
                n.at.clone(),
            ));
        }
        "area" => {
            return Err(o
                .at()
                .error("an area emitter belongs inside a <shape> (it makes that shape emit)"))
        }
        other => return Err(o.at().error(format!("unknown emitter \"{other}\""))),
    }
    o.finish()
}
