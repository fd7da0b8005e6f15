//! A scene description written as snell TOML (docs/scene-format.md), in the
//! layout of the hand-written scenes: top-level tables, then `[[lights]]` and
//! `[[objects]]` with inline shapes and materials. Reading the text back gives
//! the same description: floats are written in Rust's shortest form that
//! parses to the same bits.
use crate::error::{Error, Result};
use crate::scene::desc::*;
use std::fmt::Write;

/// `desc` as TOML text.
///
/// # Errors
///
/// [`Error::Invalid`] for what TOML cannot hold: an integer above
/// `i64::MAX` (a seed) or a `[medium]` field that does not serialise.
pub fn to_toml(desc: &SceneDesc) -> Result<String> {
    let mut o = String::new();
    let _ = writeln!(o, "ambient_ior = {}", num(desc.ambient_ior));
    let c = &desc.camera;
    let _ = writeln!(o, "\n[camera]");
    if c.kind != "perspective" {
        let _ = writeln!(o, "type = {}", string(&c.kind));
    }
    let _ = writeln!(o, "position = {}", vec3(c.position));
    let _ = writeln!(o, "target = {}", vec3(c.target));
    let _ = writeln!(o, "up = {}", vec3(c.up));
    if let Some(fov) = c.fov {
        let _ = writeln!(o, "fov = {}", num(fov));
    }
    if let Some([w, h]) = c.size {
        let _ = writeln!(o, "size = [{}, {}]", num(w), num(h));
    }
    if c.aperture_radius != 0.0 {
        let _ = writeln!(o, "aperture_radius = {}", num(c.aperture_radius));
    }
    if let Some(f) = c.focus_distance {
        let _ = writeln!(o, "focus_distance = {}", num(f));
    }
    if let Some(names) = &c.inside {
        let list: Vec<String> = names.iter().map(|n| string(n)).collect();
        let _ = writeln!(o, "inside = [{}]", list.join(", "));
    }
    let f = &desc.film;
    let _ = writeln!(o, "\n[film]");
    let _ = writeln!(o, "width = {}", int(f.width)?);
    let _ = writeln!(o, "height = {}", int(f.height)?);
    let _ = writeln!(o, "spp = {}", int(f.spp)?);
    let _ = writeln!(o, "seed = {}", int(f.seed)?);
    let _ = writeln!(o, "filter = {}", string(&f.filter));
    let i = &desc.integrator;
    let _ = writeln!(o, "\n[integrator]");
    let _ = writeln!(o, "type = {}", string(&i.kind));
    let _ = writeln!(o, "max_depth = {}", i.max_depth);
    let _ = writeln!(o, "rr_depth = {}", i.rr_depth);
    match &desc.environment {
        None => {}
        Some(EnvironmentDesc::Constant(e)) => {
            let _ = writeln!(o, "\n[environment]\ntype = \"constant\"");
            let _ = writeln!(o, "radiance = {}", vec3(e.radiance));
        }
        Some(EnvironmentDesc::Map(m)) => {
            let _ = writeln!(o, "\n[environment]\ntype = \"map\"");
            let _ = writeln!(o, "file = {}", string(&m.file));
            let _ = writeln!(o, "scale = {}", num(m.scale));
            if !m.to_world.is_empty() {
                let steps: Vec<String> = m.to_world.iter().map(transform_step).collect();
                let _ = writeln!(o, "to_world = [{}]", steps.join(", "));
            }
            if m.rows != "centres" {
                let _ = writeln!(o, "rows = {}", string(&m.rows));
            }
        }
        Some(EnvironmentDesc::Sky(k)) => {
            let _ = writeln!(o, "\n[environment]\ntype = \"sky\"");
            let _ = writeln!(o, "sun_direction = {}", vec3(k.sun_direction));
            let _ = writeln!(o, "sun_diameter = {}", num(k.sun_diameter));
            let _ = writeln!(o, "sun_irradiance = {}", vec3(k.sun_irradiance));
            let _ = writeln!(o, "zenith = {}", vec3(k.zenith));
            let _ = writeln!(o, "horizon = {}", vec3(k.horizon));
            let _ = writeln!(o, "ground = {}", vec3(k.ground));
        }
    }
    for l in &desc.lights {
        let _ = writeln!(o, "\n[[lights]]");
        light(&mut o, l);
    }
    for ob in &desc.objects {
        let _ = writeln!(o, "\n[[objects]]");
        object(&mut o, ob);
    }
    if let Some(m) = &desc.medium {
        let _ = writeln!(o, "\n[medium]");
        if let Some(f) = &m.field {
            let field = toml::Value::try_from(f)
                .map_err(|e| Error::Invalid(format!("medium.field: cannot be written as TOML: {e}")))?;
            let _ = writeln!(o, "field = {}", inline_value(&field));
        }
        if let Some(a) = &m.atmosphere {
            let atm = toml::Value::try_from(a)
                .map_err(|e| Error::Invalid(format!("medium.atmosphere: cannot be written as TOML: {e}")))?;
            let _ = writeln!(o, "atmosphere = {}", inline_value(&atm));
        }
        let _ = writeln!(
            o,
            "bounds = {{ min = {}, max = {} }}",
            vec3(m.bounds.min),
            vec3(m.bounds.max)
        );
        let _ = writeln!(o, "method = {}", string(&m.method));
        let _ = writeln!(o, "tolerance = {}", num(m.tolerance));
        let _ = writeln!(o, "step = {}", num(m.step));
    }
    if let Some(w) = &desc.warp {
        let _ = writeln!(o, "\n[warp]");
        let glass = match &w.glass {
            WarpGlassDesc::Plate {
                near_face_point,
                normal,
                thickness,
                ior,
            } => format!(
                "{{ kind = \"plate\", near_face_point = {}, normal = {}, thickness = {}, ior = {} }}",
                vec3(*near_face_point),
                vec3(*normal),
                num(*thickness),
                num(*ior)
            ),
            WarpGlassDesc::HollowCylinder {
                axis_point,
                axis_direction,
                outer_radius,
                inner_radius,
                ior,
            } => format!(
                "{{ kind = \"hollow_cylinder\", axis_point = {}, axis_direction = {}, outer_radius = {}, inner_radius = {}, ior = {} }}",
                vec3(*axis_point),
                vec3(*axis_direction),
                num(*outer_radius),
                num(*inner_radius),
                num(*ior)
            ),
        };
        let _ = writeln!(o, "glass = {glass}");
        let _ = writeln!(o, "subdivide = {}", num(w.subdivide));
        let _ = writeln!(o, "fresnel = {}", w.fresnel);
        let _ = writeln!(o, "method = {}", string(&w.method));
        let _ = writeln!(o, "extent = {}", num(w.extent));
    }
    Ok(o)
}

fn light(o: &mut String, l: &LightDesc) {
    let name = |o: &mut String, n: &Option<String>| {
        if let Some(n) = n {
            let _ = writeln!(o, "name = {}", string(n));
        }
    };
    match l {
        LightDesc::Point(p) => {
            name(o, &p.name);
            let _ = writeln!(o, "type = \"point\"");
            let _ = writeln!(o, "position = {}", vec3(p.position));
            let _ = writeln!(o, "intensity = {}", vec3(p.intensity));
        }
        LightDesc::Directional(d) => {
            name(o, &d.name);
            let _ = writeln!(o, "type = \"directional\"");
            let _ = writeln!(o, "direction = {}", vec3(d.direction));
            let _ = writeln!(o, "irradiance = {}", vec3(d.irradiance));
        }
        LightDesc::Rect(r) => {
            name(o, &r.name);
            let _ = writeln!(o, "type = \"rect\"");
            let _ = writeln!(o, "center = {}", vec3(r.center));
            let _ = writeln!(o, "normal = {}", vec3(r.normal));
            let _ = writeln!(o, "u_axis = {}", vec3(r.u_axis));
            let _ = writeln!(o, "size = [{}, {}]", num(r.size[0]), num(r.size[1]));
            let _ = writeln!(o, "radiance = {}", vec3(r.radiance));
        }
        LightDesc::Sphere(s) => {
            name(o, &s.name);
            let _ = writeln!(o, "type = \"sphere\"");
            let _ = writeln!(o, "center = {}", vec3(s.center));
            let _ = writeln!(o, "radius = {}", num(s.radius));
            let _ = writeln!(o, "radiance = {}", vec3(s.radiance));
        }
        LightDesc::Spot(s) => {
            name(o, &s.name);
            let _ = writeln!(o, "type = \"spot\"");
            let _ = writeln!(o, "position = {}", vec3(s.position));
            if let Some(d) = s.direction {
                let _ = writeln!(o, "direction = {}", vec3(d));
            }
            if let Some(t) = s.target {
                let _ = writeln!(o, "target = {}", vec3(t));
            }
            let _ = writeln!(o, "intensity = {}", vec3(s.intensity));
            let _ = writeln!(o, "cutoff_angle = {}", num(s.cutoff_angle));
            if let Some(b) = s.beam_width {
                let _ = writeln!(o, "beam_width = {}", num(b));
            }
        }
    }
}

fn object(o: &mut String, ob: &ObjectDesc) {
    if let Some(n) = &ob.name {
        let _ = writeln!(o, "name = {}", string(n));
    }
    let _ = writeln!(o, "shape = {}", shape(&ob.shape));
    let _ = writeln!(o, "material = {}", material(&ob.material));
    if let Some(e) = &ob.emission {
        let two = if e.two_sided { ", two_sided = true" } else { "" };
        let _ = writeln!(o, "emission = {{ radiance = {}{two} }}", texture(&e.radiance));
    }
    if !ob.transform.is_empty() {
        let steps: Vec<String> = ob.transform.iter().map(transform_step).collect();
        let _ = writeln!(o, "transform = [{}]", steps.join(", "));
    }
    if ob.flip_inside_out {
        let _ = writeln!(o, "flip_inside_out = true");
    }
}

fn shape(s: &ShapeDesc) -> String {
    match s {
        ShapeDesc::Sphere(s) => format!(
            "{{ type = \"sphere\", center = {}, radius = {} }}",
            vec3(s.center),
            num(s.radius)
        ),
        ShapeDesc::Rect(r) => format!(
            "{{ type = \"rect\", center = {}, normal = {}, u_axis = {}, size = [{}, {}] }}",
            vec3(r.center),
            vec3(r.normal),
            vec3(r.u_axis),
            num(r.size[0]),
            num(r.size[1])
        ),
        ShapeDesc::Disk(d) => format!(
            "{{ type = \"disk\", center = {}, normal = {}, radius = {}, inner_radius = {} }}",
            vec3(d.center),
            vec3(d.normal),
            num(d.radius),
            num(d.inner_radius)
        ),
        ShapeDesc::Box(b) => format!(
            "{{ type = \"box\", center = {}, size = {} }}",
            vec3(b.center),
            vec3(b.size)
        ),
        ShapeDesc::Cylinder(c) => format!(
            "{{ type = \"cylinder\", p0 = {}, p1 = {}, radius = {}, normal = {}, caps = {} }}",
            vec3(c.p0),
            vec3(c.p1),
            num(c.radius),
            string(&c.normal),
            c.caps
        ),
        ShapeDesc::Tube(t) => format!(
            "{{ type = \"tube\", p0 = {}, p1 = {}, outer_radius = {}, inner_radius = {} }}",
            vec3(t.p0),
            vec3(t.p1),
            num(t.outer_radius),
            num(t.inner_radius)
        ),
        ShapeDesc::Lathe(l) => {
            let pts: Vec<String> = l
                .profile
                .iter()
                .map(|p| format!("[{}, {}]", num(p[0]), num(p[1])))
                .collect();
            format!(
                "{{ type = \"lathe\", profile = [{}], segments = {}, smooth = {}, crease_angle = {} }}",
                pts.join(", "),
                l.segments,
                l.smooth,
                num(l.crease_angle)
            )
        }
        ShapeDesc::Mesh(m) => {
            let mut s = format!("{{ type = \"mesh\", file = {}, smooth = {}", string(&m.file), m.smooth);
            for (k, v) in [
                ("shape_index", m.shape_index),
                ("mesh", m.mesh),
                ("primitive", m.primitive),
            ] {
                if let Some(v) = v {
                    let _ = write!(s, ", {k} = {v}");
                }
            }
            s + " }"
        }
        ShapeDesc::Heightfield(h) => format!(
            "{{ type = \"heightfield\", size = [{}, {}], levels = {}, height = {}, roughness = {}, seed = {} }}",
            num(h.size[0]),
            num(h.size[1]),
            h.levels,
            num(h.height),
            num(h.roughness),
            h.seed.min(i64::MAX as u64)
        ),
    }
}

fn material(m: &MaterialDesc) -> String {
    match m {
        MaterialDesc::Diffuse(d) => format!(
            "{{ type = \"diffuse\", reflectance = {}, two_sided = {} }}",
            texture(&d.reflectance),
            d.two_sided
        ),
        MaterialDesc::Mirror(m) => format!("{{ type = \"mirror\", reflectance = {} }}", vec3(m.reflectance)),
        MaterialDesc::Black(_) => "{ type = \"black\" }".into(),
        MaterialDesc::Dielectric(d) => {
            dielectric(
                "dielectric",
                d.ior,
                d.int_ior,
                d.ext_ior,
                d.priority,
                d.absorption.as_ref(),
            ) + " }"
        }
        MaterialDesc::RoughDielectric(d) => {
            dielectric(
                "rough_dielectric",
                d.ior,
                d.int_ior,
                d.ext_ior,
                d.priority,
                d.absorption.as_ref(),
            ) + &roughness(d.distribution, d.alpha)
                + " }"
        }
        MaterialDesc::Conductor(c) => {
            conductor(
                "conductor",
                &c.material,
                c.eta,
                c.k,
                c.specular_reflectance,
                c.two_sided,
            ) + " }"
        }
        MaterialDesc::RoughConductor(c) => {
            conductor(
                "rough_conductor",
                &c.material,
                c.eta,
                c.k,
                c.specular_reflectance,
                c.two_sided,
            ) + &roughness(c.distribution, c.alpha)
                + " }"
        }
        MaterialDesc::Plastic(p) => {
            plastic(
                "plastic",
                p.diffuse_reflectance,
                p.specular_reflectance,
                p.int_ior,
                p.ext_ior,
                p.nonlinear,
                p.two_sided,
            ) + " }"
        }
        MaterialDesc::RoughPlastic(p) => {
            plastic(
                "rough_plastic",
                p.diffuse_reflectance,
                p.specular_reflectance,
                p.int_ior,
                p.ext_ior,
                p.nonlinear,
                p.two_sided,
            ) + &roughness(p.distribution, p.alpha)
                + " }"
        }
    }
}

/// A dielectric's table without its closing brace.
fn dielectric(
    ty: &str,
    ior: Option<f64>,
    int_ior: Option<f64>,
    ext_ior: Option<f64>,
    priority: Option<i64>,
    absorption: Option<&AbsorptionDesc>,
) -> String {
    let mut s = format!("{{ type = \"{ty}\"");
    for (k, v) in [("ior", ior), ("int_ior", int_ior), ("ext_ior", ext_ior)] {
        if let Some(v) = v {
            let _ = write!(s, ", {k} = {}", num(v));
        }
    }
    if let Some(p) = priority {
        let _ = write!(s, ", priority = {p}");
    }
    if let Some(a) = absorption {
        let _ = write!(
            s,
            ", absorption = {{ color = {}, distance = {} }}",
            vec3(a.color),
            num(a.distance)
        );
    }
    s
}

/// The roughness keys, each after a comma.
fn roughness(d: DistributionDesc, alpha: f64) -> String {
    let d = match d {
        DistributionDesc::Ggx => "ggx",
        DistributionDesc::Beckmann => "beckmann",
    };
    format!(", distribution = \"{d}\", alpha = {}", num(alpha))
}

/// A conductor's table without its closing brace.
fn conductor(
    ty: &str,
    material: &Option<String>,
    eta: Option<Vec3>,
    k: Option<Vec3>,
    spec: Vec3,
    two_sided: bool,
) -> String {
    let mut s = format!("{{ type = \"{ty}\"");
    if let Some(m) = material {
        let _ = write!(s, ", material = {}", string(m));
    }
    for (key, v) in [("eta", eta), ("k", k)] {
        if let Some(v) = v {
            let _ = write!(s, ", {key} = {}", vec3(v));
        }
    }
    let _ = write!(
        s,
        ", specular_reflectance = {}, two_sided = {two_sided}",
        vec3(spec)
    );
    s
}

/// A plastic's table without its closing brace.
fn plastic(
    ty: &str,
    diffuse: Vec3,
    spec: Vec3,
    int_ior: f64,
    ext_ior: f64,
    nonlinear: bool,
    two_sided: bool,
) -> String {
    format!(
        "{{ type = \"{ty}\", diffuse_reflectance = {}, specular_reflectance = {}, int_ior = {}, ext_ior = {}, nonlinear = {nonlinear}, two_sided = {two_sided}",
        vec3(diffuse),
        vec3(spec),
        num(int_ior),
        num(ext_ior)
    )
}

fn texture(t: &TextureDesc) -> String {
    match t {
        TextureDesc::Constant(c) => vec3(*c),
        TextureDesc::Table(TextureTable::Checker(c)) => format!(
            "{{ type = \"checker\", axes = [{}, {}], size = {}, color0 = {}, color1 = {} }}",
            string(&c.axes[0]),
            string(&c.axes[1]),
            num(c.size),
            vec3(c.color0),
            vec3(c.color1)
        ),
        TextureDesc::Table(TextureTable::Image(i)) => format!(
            "{{ type = \"image\", file = {}, uv_scale = [{}, {}] }}",
            string(&i.file),
            num(i.uv_scale[0]),
            num(i.uv_scale[1])
        ),
    }
}

fn transform_step(t: &TransformDesc) -> String {
    let mut parts = Vec::new();
    if let Some(v) = t.translate {
        parts.push(format!("translate = {}", vec3(v)));
    }
    if let Some(r) = &t.rotate {
        parts.push(format!(
            "rotate = {{ axis = {}, degrees = {} }}",
            vec3(r.axis),
            num(r.degrees)
        ));
    }
    match &t.scale {
        Some(ScaleDesc::Uniform(s)) => parts.push(format!("scale = {}", num(*s))),
        Some(ScaleDesc::PerAxis(s)) => parts.push(format!("scale = {}", vec3(*s))),
        None => {}
    }
    if let Some(m) = &t.matrix {
        let rows: Vec<String> = m.iter().map(|r| format!("[{}]", r.map(num).join(", "))).collect();
        parts.push(format!("matrix = [{}]", rows.join(", ")));
    }
    format!("{{ {} }}", parts.join(", "))
}

/// A float that TOML reads back to the same bits (`nan` loses its payload).
fn num(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        // `{:?}` is the shortest round-trip form and always has a `.` or an
        // exponent, so TOML reads a float.
        format!("{x:?}")
    }
}

fn vec3(v: Vec3) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

fn int(v: u64) -> Result<String> {
    if v > i64::MAX as u64 {
        return Err(Error::Invalid(format!(
            "{v} does not fit TOML's integers (at most {})",
            i64::MAX
        )));
    }
    Ok(v.to_string())
}

/// A TOML basic string.
fn string(s: &str) -> String {
    let mut o = String::with_capacity(s.len() + 2);
    o.push('"');
    for c in s.chars() {
        match c {
            '"' => o.push_str("\\\""),
            '\\' => o.push_str("\\\\"),
            '\n' => o.push_str("\\n"),
            '\t' => o.push_str("\\t"),
            '\r' => o.push_str("\\r"),
            c if (c as u32) < 0x20 || c == '\u{7f}' => {
                let _ = write!(o, "\\u{:04X}", c as u32);
            }
            c => o.push(c),
        }
    }
    o.push('"');
    o
}

/// A TOML value on one line (tables inline).
fn inline_value(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => string(s),
        toml::Value::Integer(i) => i.to_string(),
        toml::Value::Float(f) => num(*f),
        toml::Value::Boolean(b) => b.to_string(),
        toml::Value::Datetime(d) => d.to_string(),
        toml::Value::Array(a) => format!("[{}]", a.iter().map(inline_value).collect::<Vec<_>>().join(", ")),
        toml::Value::Table(t) => format!(
            "{{ {} }}",
            t.iter()
                .map(|(k, v)| format!("{} = {}", string(k), inline_value(v)))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_and_strings_read_back_the_same() {
        for x in [0.1, 1.0, -0.0, 1e-300, 1.5046000480651855, 1e22, f64::MAX] {
            let v: toml::Value = toml::from_str(&format!("x = {}", num(x))).unwrap();
            assert_eq!(v["x"].as_float().unwrap().to_bits(), x.to_bits(), "{x}");
        }
        let s = "a\"b\\c\nd\u{1}é";
        let v: toml::Value = toml::from_str(&format!("x = {}", string(s))).unwrap();
        assert_eq!(v["x"].as_str().unwrap(), s);
    }
}
