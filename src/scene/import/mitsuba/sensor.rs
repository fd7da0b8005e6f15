//! `<sensor>` (perspective, thinlens, orthographic) with its `<film>` and
//! `<sampler>`, and `<integrator>`: snell's camera, film and integrator.
use super::props::{Ctx, Obj};
use super::transform;
use super::xml::Node;
use crate::error::Result;
use crate::scene::desc::{CameraDesc, FilmDesc, IntegratorDesc};
use glam::DVec3;

/// snell's deepest path, standing in for Mitsuba's unlimited `max_depth = -1`.
pub const MAX_DEPTH: u32 = 1024;

/// The camera and film of a `<sensor>`.
pub fn sensor(ctx: &Ctx<'_>, n: &Node) -> Result<(CameraDesc, FilmDesc)> {
    let o = Obj::new(ctx, n)?;
    let plugin = o.plugin()?;
    let thin = match plugin {
        "perspective" => false,
        "thinlens" => true,
        "orthographic" => return orthographic(ctx, o),
        "telecentric" => return Err(o.at().error(
            "<sensor type=\"telecentric\">: snell has perspective, thin-lens and orthographic cameras only",
        )),
        other => {
            return Err(o.at().error(format!(
                "unknown sensor \"{other}\" (expected perspective, thinlens or orthographic)"
            )))
        }
    };
    let film = film(ctx, &o)?;
    let (w, h) = (film.width as f64, film.height as f64);
    if film.width == 0 || film.height == 0 {
        return Err(o.at().error("the film needs a width and height of at least 1"));
    }
    let fov_y = field_of_view(ctx, &o, w, h)?;
    let (m, tnode) = o.transform("to_world")?;
    let (position, target, up) = camera_frame(&m, tnode)?;
    for k in ["near_clip", "far_clip"] {
        if let Some(v) = o.float(k)? {
            let default = if k == "near_clip" { 1e-2 } else { 1e4 };
            if v != default {
                ctx.warn(o.at(), format!("{k} = {v} is ignored: snell does not clip"));
            }
        }
    }
    for k in ["principal_point_offset_x", "principal_point_offset_y"] {
        if o.float(k)?.is_some_and(|v| v != 0.0) {
            ctx.warn(
                o.at(),
                format!("{k} is ignored: snell's image is centred on the view axis"),
            );
        }
    }
    for k in ["shutter_open", "shutter_close"] {
        o.float(k)?;
    }
    let (aperture_radius, focus_distance) = if thin {
        (
            o.float_or("aperture_radius", 0.0)?,
            Some(o.float_or("focus_distance", 0.0)?),
        )
    } else {
        (0.0, None)
    };
    o.finish()?;
    Ok((
        CameraDesc {
            kind: "perspective".into(),
            position: position.to_array(),
            target: target.to_array(),
            up: up.to_array(),
            fov: Some(fov_y),
            size: None,
            aperture_radius,
            focus_distance,
            inside: None,
        },
        film,
    ))
}

/// Mitsuba 3's `orthographic` sensor (src/sensors/orthographic.cpp and
/// `orthographic_projection` in include/mitsuba/render/sensor.h): in its own
/// frame it sees x in [−1, 1] and y in [−1/aspect, 1/aspect] (aspect = the
/// film's width / height), looking along +z, with rays starting on the near
/// plane z = `near_clip`; `to_world` (usually a scale, then a `<lookat>`)
/// places and sizes that. So the view is 2·|to_world x| wide and
/// 2·|to_world y| / aspect high, and snell's rays start where Mitsuba's do:
/// `position` is to_world·(0, 0, near_clip). Parallel rays make that shift
/// exactly Mitsuba's near clip; its far clip snell does not apply.
fn orthographic(ctx: &Ctx<'_>, o: Obj<'_, '_>) -> Result<(CameraDesc, FilmDesc)> {
    let film = film(ctx, &o)?;
    let aspect = film.width as f64 / film.height as f64;
    let (m, tnode) = o.transform("to_world")?;
    let near = o.float_or("near_clip", 1e-2)?;
    let far = o.float_or("far_clip", 1e4)?;
    if !(near.is_finite() && far.is_finite() && near >= 0.0 && far > near) {
        return Err(o.at().error(format!(
            "near_clip {near}, far_clip {far}: expected 0 <= near_clip < far_clip, both finite"
        )));
    }
    if far != 1e4 {
        ctx.warn(
            o.at(),
            format!("far_clip = {far} is ignored: snell does not clip"),
        );
    }
    for k in ["shutter_open", "shutter_close"] {
        o.float(k)?;
    }
    o.finish()?;
    let at = tnode.map(|t| &t.at);
    let bad = |msg: String| match at {
        Some(a) => a.error(msg),
        None => crate::error::Error::Invalid(msg),
    };
    // The camera's axes in the world: image left, up and forward, each
    // scaled by to_world.
    let (x, y, z) = (
        transform::vector(&m, DVec3::X),
        transform::vector(&m, DVec3::Y),
        transform::vector(&m, DVec3::Z),
    );
    let (lx, ly, lz) = (x.length(), y.length(), z.length());
    if !(lx > 0.0 && ly > 0.0 && lz > 0.0 && (lx * ly * lz).is_finite()) {
        return Err(bad(
            "the orthographic sensor's to_world collapses or overflows an axis".into(),
        ));
    }
    let (left, up, f) = (x / lx, y / ly, z / lz);
    let skew = left.dot(up).abs().max(left.dot(f).abs()).max(up.dot(f).abs());
    // Mitsuba's image x runs along −left: it must be snell's forward × up,
    // or the image would come out mirrored.
    if skew > 1e-6 || f.cross(up).dot(-left) < 0.0 {
        return Err(bad(
            "the orthographic sensor's to_world must be a rotation, translation and a scale along \
             its axes (no skew or mirror)"
                .into(),
        ));
    }
    let position = transform::point(&m, DVec3::new(0.0, 0.0, near));
    Ok((
        CameraDesc {
            kind: "orthographic".into(),
            position: position.to_array(),
            target: (position + f).to_array(),
            up: up.to_array(),
            fov: None,
            size: Some([2.0 * lx, 2.0 * ly / aspect]),
            aperture_radius: 0.0,
            focus_distance: None,
            inside: None,
        },
        film,
    ))
}

/// snell's vertical field of view (degrees) for Mitsuba 3's `parse_fov`
/// (src/render/sensor.cpp) on a `w` × `h` film: `fov` along `fov_axis`
/// (default x; "smaller" and "larger" name y or x by the film's aspect),
/// else `focal_length` (default "50mm") as a 35 mm-equivalent diagonal.
/// Mitsuba turns every field into a horizontal one; the vertical follows
/// from the aspect, as its projection does.
fn field_of_view(ctx: &Ctx<'_>, o: &Obj<'_, '_>, w: f64, h: f64) -> Result<f64> {
    let aspect = w / h;
    let (fov, axis) = match (o.float("fov")?, o.string("focal_length")?) {
        (Some(_), Some((_, at))) => return Err(at.error("give fov or focal_length, not both")),
        (Some(f), None) => {
            let (name, at) = match o.string("fov_axis")? {
                Some((s, at)) => (s.to_ascii_lowercase(), at),
                None => ("x".to_string(), o.at()),
            };
            let axis = match name.as_str() {
                "smaller" if aspect > 1.0 => "y",
                "smaller" => "x",
                "larger" if aspect > 1.0 => "x",
                "larger" => "y",
                "x" => "x",
                "y" => "y",
                "diagonal" => "diagonal",
                other => {
                    return Err(at.error(format!(
                        "fov_axis \"{other}\": expected x, y, diagonal, smaller or larger"
                    )))
                }
            };
            (f, axis)
        }
        (None, focal) => {
            // Mitsuba reads fov_axis only with a fov and refuses what it leaves unread.
            if let Some((_, at)) = o.string("fov_axis")? {
                ctx.unknown(
                    at,
                    "fov_axis applies to a fov only (this sensor's field is its focal_length)".into(),
                )?;
            }
            let (text, at) = focal.unwrap_or(("50mm", o.at()));
            let mm: f64 = text
                .strip_suffix("mm")
                .unwrap_or(text)
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite() && *v > 0.0)
                .ok_or_else(|| {
                    at.error(format!(
                        "expected a focal length > 0 such as \"50mm\", got \"{text}\""
                    ))
                })?;
            // The diagonal of a 36 × 24 mm frame.
            let d = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt();
            ((2.0 * (d / (2.0 * mm)).atan()).to_degrees(), "diagonal")
        }
    };
    let half = (fov.to_radians() / 2.0).tan();
    let x_fov = match axis {
        "x" => fov,
        "y" => (2.0 * (half * aspect).atan()).to_degrees(),
        _ => {
            let width = 2.0 * half / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            (2.0 * (width * 0.5).atan()).to_degrees()
        }
    };
    if !(x_fov > 0.0 && x_fov < 180.0) {
        return Err(o.at().error(format!(
            "fov {fov} along {axis}: expected a horizontal field in (0, 180) degrees, got {x_fov}"
        )));
    }
    // A field given along y keeps the file's number.
    Ok(if axis == "y" {
        fov
    } else {
        (2.0 * ((x_fov.to_radians() / 2.0).tan() / aspect).atan()).to_degrees()
    })
}

/// Position, target and up of the camera placed by `m`: a single
/// `<lookat>`'s own numbers, else read from the matrix (which must be a
/// rotation and translation: snell's images are never mirrored or skewed).
fn camera_frame(m: &glam::DMat4, t: Option<&Node>) -> Result<(DVec3, DVec3, DVec3)> {
    if let Some(t) = t {
        if let [s] = &t.children[..] {
            if s.tag == "lookat" {
                return transform::lookat_args(s);
            }
        }
    }
    let at = t.map(|t| &t.at);
    let p = transform::point(m, DVec3::ZERO);
    let f = transform::vector(m, DVec3::Z);
    let up = transform::vector(m, DVec3::Y);
    let left = transform::vector(m, DVec3::X);
    let ortho = (f.length() - 1.0).abs() < 1e-6
        && (up.length() - 1.0).abs() < 1e-6
        && f.dot(up).abs() < 1e-6
        && left.dot(f).abs() < 1e-6;
    // Mitsuba's image x runs along −left: it must be snell's forward × up.
    let mirrored = f.cross(up).dot(-left) < 0.0;
    if !ortho || mirrored {
        let msg = "the sensor's to_world must be a rotation and translation (no scale, skew or mirror)";
        return Err(match at {
            Some(a) => a.error(msg),
            None => crate::error::Error::Invalid(msg.into()),
        });
    }
    Ok((p, p + f, up))
}

/// The `<film>` and `<sampler>` of sensor `o`.
fn film(ctx: &Ctx<'_>, o: &Obj<'_, '_>) -> Result<FilmDesc> {
    let mut film = FilmDesc {
        width: 768,
        height: 576,
        spp: 4,
        seed: 0,
        filter: "box".into(),
    };
    if let Some(f) = o.object("film")? {
        let f = Obj::new(ctx, f)?;
        match f.plugin()? {
            "hdrfilm" | "specfilm" => {}
            other => {
                return Err(f
                    .at()
                    .error(format!("unknown film \"{other}\" (expected hdrfilm)")))
            }
        }
        let size = |k: &str, d: u64| -> Result<u64> {
            match f.int(k)? {
                None => Ok(d),
                Some(v) if (1..=1 << 16).contains(&v) => Ok(v as u64),
                Some(v) => Err(f.at().error(format!("{k} {v}: expected 1..=65536 pixels"))),
            }
        };
        film.width = size("width", 768)?;
        film.height = size("height", 576)?;
        for k in ["crop_offset_x", "crop_offset_y", "crop_width", "crop_height"] {
            if f.int(k)?.is_some() {
                ctx.warn(
                    f.at(),
                    format!("{k} is ignored: snell renders the whole film (use --region)"),
                );
            }
        }
        for k in ["file_format", "pixel_format", "component_format"] {
            f.string(k)?;
        }
        for k in ["sample_border", "compensate", "banner", "high_quality_edges"] {
            f.bool_or(k, false)?;
        }
        match f.object("rfilter")? {
            None => ctx.warn(
                f.at(),
                "no <rfilter>: Mitsuba's default is a Gaussian; snell renders a one-pixel box",
            ),
            Some(r) => {
                let r = Obj::new(ctx, r)?;
                let p = r.plugin()?;
                if p != "box" {
                    ctx.warn(
                        r.at(),
                        format!("rfilter \"{p}\" rendered as a one-pixel box (snell's only filter)"),
                    );
                }
                r.float("radius")?;
                r.float("stddev")?;
                r.float("b")?;
                r.float("c")?;
                r.int("lobes")?;
                r.finish()?;
            }
        }
        f.finish()?;
    } else {
        ctx.warn(
            o.at(),
            "no <film>: Mitsuba's default 768x576 with a Gaussian filter, rendered with a box",
        );
    }
    if let Some(s) = o.object("sampler")? {
        let s = Obj::new(ctx, s)?;
        match s.plugin()? {
            "independent" | "stratified" | "multijitter" | "orthogonal" | "ldsampler" => {}
            other => return Err(s.at().error(format!("unknown sampler \"{other}\""))),
        }
        match s.int("sample_count")? {
            None => {}
            Some(v) if v >= 1 => film.spp = v as u64,
            Some(v) => return Err(s.at().error(format!("sample_count {v}: expected at least 1"))),
        }
        match s.int("seed")? {
            None => {}
            Some(v) if v >= 0 => film.seed = v as u64,
            Some(v) => return Err(s.at().error(format!("seed {v}: expected 0 or more"))),
        }
        s.bool_or("jitter", true)?;
        s.float("strength")?;
        s.finish()?;
    }
    Ok(film)
}

/// An `<integrator>`: path-tracing kinds map to snell's path tracer.
pub fn integrator(ctx: &Ctx<'_>, n: &Node) -> Result<IntegratorDesc> {
    let o = Obj::new(ctx, n)?;
    let plugin = o.plugin()?;
    let r = match plugin {
        "path" | "volpath" | "volpathmis" | "prb" | "direct" => {
            let depth = if plugin == "direct" {
                for k in ["emitter_samples", "bsdf_samples", "shading_samples"] {
                    o.int(k)?;
                }
                2
            } else {
                match o.int("max_depth")? {
                    None | Some(-1) => MAX_DEPTH,
                    Some(d) if d >= 0 => (d as u64).min(u32::MAX as u64) as u32,
                    Some(d) => return Err(o.at().error(format!("max_depth {d}: expected -1 or a depth >= 0"))),
                }
            };
            let rr = match o.int("rr_depth")? {
                None => 5,
                Some(d) if d >= 0 => (d as u64).min(u32::MAX as u64) as u32,
                Some(d) => return Err(o.at().error(format!("rr_depth {d}: expected a depth >= 0"))),
            };
            if o.bool_or("hide_emitters", false)? {
                ctx.warn(o.at(), "hide_emitters is ignored: snell shows emitters seen directly");
            }
            IntegratorDesc {
                kind: "path".into(),
                max_depth: depth,
                rr_depth: rr,
            }
        }
        "moment" | "aov" => {
            o.string("aovs")?;
            let inner = o.objects("integrator")?;
            let Some(first) = inner.first() else {
                return Err(o.at().error(format!("<integrator type=\"{plugin}\"> wraps no integrator")));
            };
            ctx.warn(
                o.at(),
                format!("the \"{plugin}\" wrapper is unwrapped: snell renders its inner integrator (no extra channels)"),
            );
            integrator(ctx, first)?
        }
        other => {
            return Err(o.at().error(format!(
                "unknown integrator \"{other}\" (snell maps path, volpath, volpathmis, prb, direct, and the moment/aov wrappers)"
            )))
        }
    };
    o.finish()?;
    Ok(r)
}
