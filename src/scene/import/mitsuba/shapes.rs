//! `<shape>`s: analytic spheres, cylinders and disks in world space (their
//! `to_world` must be a similarity), rectangles in world space when their
//! sides stay perpendicular, cubes and mesh files (`obj`, `ply`,
//! `serialized`) with their `to_world` as a matrix step. A rectangle or
//! sphere with a constant area emitter becomes a light; any other emitting
//! shape an object with `emission` (Mitsuba's area emitters are one-sided),
//! sampled directly as well.
use super::bsdf::{self, Surface};
use super::props::{ColorParam, Ctx, Obj};
use super::textures::{self, Uv, UvFrame};
use super::transform::{self, similarity, steps};
use super::xml::Node;
use super::Out;
use crate::error::Result;
use crate::scene::desc::*;
use glam::{DMat4, DVec3};

/// The shape's geometry and how its normal can be turned over.
struct Geometry {
    shape: ShapeDesc,
    transform: Vec<TransformDesc>,
    /// The geometry itself can face the other way (its normal is a parameter).
    flippable: bool,
    uv: Uv,
}

/// Read `<shape>` `n` into lights or objects.
pub fn shape(ctx: &Ctx<'_>, n: &Node, out: &mut Out) -> Result<()> {
    let o = Obj::new(ctx, n)?;
    let plugin = o.plugin()?;
    let (m, _) = o.transform("to_world")?;
    let flip = o.bool_or("flip_normals", false)?;
    if let Some(media) = o.objects("medium")?.first() {
        return Err(media.at.error("participating media are not supported"));
    }
    let name = n.attr("id").map(str::to_string);
    let bsdf_node = o.object("bsdf")?;
    let emitter_node = o.object("emitter")?;
    let mut g = geometry(ctx, &o, plugin, &m)?;
    if flip && g.flippable {
        flip_geometry(&mut g.shape);
    }
    let surface = bsdf::surface(ctx, bsdf_node, g.uv)?;
    let radiance = match emitter_node {
        None => None,
        Some(e) => {
            let eo = Obj::new(ctx, e)?;
            match eo.plugin()? {
                "area" => {}
                other => {
                    return Err(eo.at().error(format!(
                        "emitter \"{other}\" inside a shape: only area emitters belong there"
                    )))
                }
            }
            let r = match eo.color("radiance", true)? {
                None => ColorParam::Rgb([1.0; 3]),
                Some(c) => c,
            };
            eo.float("sampling_weight")?;
            let t = textures::color(ctx, r, g.uv, true)?;
            eo.finish()?;
            Some((t, e))
        }
    };
    // A constant-radiance rectangle or sphere is a light snell samples directly.
    if let Some((TextureDesc::Constant(rad), e)) = &radiance {
        let light = match &g.shape {
            ShapeDesc::Rect(r) if g.transform.is_empty() => Some(LightDesc::Rect(RectLightDesc {
                name: name.clone(),
                center: r.center,
                normal: r.normal,
                u_axis: r.u_axis,
                size: r.size,
                radiance: *rad,
            })),
            ShapeDesc::Sphere(s) if !flip => Some(LightDesc::Sphere(SphereLightDesc {
                name: name.clone(),
                center: s.center,
                radius: s.radius,
                radiance: *rad,
            })),
            _ => None,
        };
        if let Some(l) = light {
            if !surface.is_black() {
                ctx.warn(
                    &e.at,
                    "the emitter's own reflection is dropped: snell's lights are black (give it <bsdf type=\"diffuse\"> with reflectance 0 to match)",
                );
            }
            o.finish()?;
            out.lights.push((l, n.at.clone()));
            return Ok(());
        }
    }
    let material = surface.material(flip && !g.flippable).ok_or_else(|| {
        o.at().error(format!(
            "flip_normals on a one-sided surface of <shape type=\"{plugin}\">: snell cannot turn this shape's normal (use a twosided BSDF, or flip the mesh in the file)"
        ))
    })?;
    if flip && !g.flippable && radiance.is_some() {
        return Err(o.at().error(format!(
            "flip_normals on an emitting <shape type=\"{plugin}\">: snell cannot turn this shape's normal"
        )));
    }
    if matches!(surface, Surface::Dielectric { .. }) && radiance.is_some() {
        return Err(o.at().error("an emitting dielectric is not supported"));
    }
    o.finish()?;
    out.objects.push((
        ObjectDesc {
            name,
            shape: g.shape,
            material,
            emission: radiance.map(|(t, _)| EmissionDesc {
                radiance: t,
                two_sided: false,
            }),
            transform: g.transform,
            flip_inside_out: false,
        },
        n.at.clone(),
    ));
    Ok(())
}

fn geometry(ctx: &Ctx<'_>, o: &Obj<'_, '_>, plugin: &str, m: &DMat4) -> Result<Geometry> {
    let need_similarity = |what: &str| -> Result<f64> {
        similarity(m).ok_or_else(|| {
            o.at().error(format!(
                "a {what} takes only translations, rotations and uniform scales in to_world (snell's {what}s are analytic)"
            ))
        })
    };
    let positive = |k: &str, v: f64| -> Result<f64> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(o.at().error(format!("{k} = {v}: expected a number > 0")))
        }
    };
    let simple = |shape| Geometry {
        shape,
        transform: Vec::new(),
        flippable: false,
        uv: Uv::None,
    };
    Ok(match plugin {
        "sphere" => {
            let c = o.point("center")?.unwrap_or(DVec3::ZERO);
            let r = positive("radius", o.float_or("radius", 1.0)?)?;
            let s = need_similarity("sphere")?;
            simple(ShapeDesc::Sphere(SphereDesc {
                center: transform::point(m, c).to_array(),
                radius: r * s,
            }))
        }
        "cylinder" => {
            let p0 = o.point("p0")?.unwrap_or(DVec3::ZERO);
            let p1 = o.point("p1")?.unwrap_or(DVec3::Z);
            let r = positive("radius", o.float_or("radius", 1.0)?)?;
            let s = need_similarity("cylinder")?;
            if p0 == p1 {
                return Err(o.at().error("p0 and p1 must differ"));
            }
            Geometry {
                flippable: true,
                ..simple(ShapeDesc::Cylinder(CylinderDesc {
                    p0: transform::point(m, p0).to_array(),
                    p1: transform::point(m, p1).to_array(),
                    radius: r * s,
                    normal: "out".into(),
                    caps: false,
                }))
            }
        }
        "disk" => {
            let s = need_similarity("disk")?;
            Geometry {
                flippable: true,
                ..simple(ShapeDesc::Disk(DiskDesc {
                    center: transform::point(m, DVec3::ZERO).to_array(),
                    normal: transform::normal(m, DVec3::Z).to_array(),
                    radius: s,
                    inner_radius: 0.0,
                }))
            }
        }
        "rectangle" => {
            let c = transform::point(m, DVec3::ZERO);
            let x = transform::vector(m, DVec3::X);
            let y = transform::vector(m, DVec3::Y);
            let uv = Uv::Frame(UvFrame {
                origin: c - x - y,
                du: 2.0 * x,
                dv: 2.0 * y,
            });
            let (lx, ly) = (x.length(), y.length());
            if lx > 0.0 && ly > 0.0 && x.dot(y).abs() <= 1e-12 * lx * ly {
                Geometry {
                    shape: ShapeDesc::Rect(RectDesc {
                        center: c.to_array(),
                        // Mitsuba's normal is to_world's inverse transpose of +z:
                        // x × y, turned over by a mirroring to_world.
                        normal: (x.cross(y).normalize() * glam::DMat3::from_mat4(*m).determinant().signum()
                            + DVec3::ZERO)
                            .to_array(),
                        u_axis: (x / lx).to_array(),
                        size: [2.0 * lx, 2.0 * ly],
                    }),
                    transform: Vec::new(),
                    flippable: true,
                    uv,
                }
            } else {
                Geometry {
                    shape: ShapeDesc::Rect(RectDesc {
                        center: [0.0; 3],
                        normal: [0.0, 0.0, 1.0],
                        u_axis: [1.0, 0.0, 0.0],
                        size: [2.0, 2.0],
                    }),
                    transform: steps(m),
                    flippable: false,
                    uv,
                }
            }
        }
        "cube" => Geometry {
            transform: steps(m),
            ..simple(ShapeDesc::Box(BoxDesc {
                center: [0.0; 3],
                size: [2.0; 3],
            }))
        },
        "obj" | "ply" | "serialized" => {
            let (file, at) = o
                .string("filename")?
                .ok_or_else(|| o.at().error("expected <string name=\"filename\">"))?;
            let path = ctx.doc.resolve(file);
            if !path.is_file() {
                return Err(at.error(format!("{} not found", path.display())));
            }
            let face_normals = o.bool_or("face_normals", false)?;
            let flip_tex = if plugin == "obj" {
                o.bool_or("flip_tex_coords", true)?
            } else {
                false
            };
            let shape_index = if plugin == "serialized" {
                match o.int("shape_index")? {
                    None => None,
                    Some(i) if i >= 0 => Some(i as u64),
                    Some(i) => return Err(o.at().error(format!("shape_index {i}: expected 0 or more"))),
                }
            } else {
                None
            };
            Geometry {
                shape: ShapeDesc::Mesh(MeshDesc {
                    file: ctx.doc.desc_path(&path),
                    smooth: !face_normals,
                    shape_index,
                    mesh: None,
                    primitive: None,
                }),
                transform: steps(m),
                flippable: false,
                uv: if flip_tex { Uv::Obj } else { Uv::None },
            }
        }
        "shapegroup" | "instance" | "bsplinecurve" | "linearcurve" | "sdfgrid" | "ellipsoids"
        | "ellipsoidsmesh" => {
            return Err(o
                .at()
                .error(format!("<shape type=\"{plugin}\"> is not supported by snell")))
        }
        other => return Err(o.at().error(format!("unknown shape \"{other}\""))),
    })
}

/// Turn a flippable shape's normal over.
fn flip_geometry(s: &mut ShapeDesc) {
    match s {
        ShapeDesc::Cylinder(c) => c.normal = "in".into(),
        ShapeDesc::Disk(d) => d.normal = d.normal.map(|x| -x),
        ShapeDesc::Rect(r) => r.normal = r.normal.map(|x| -x),
        _ => {}
    }
}
