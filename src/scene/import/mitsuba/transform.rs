//! `<transform>`: `translate`, `rotate`, `scale`, `matrix` and `lookat`
//! steps, each applied after the ones before it (as Mitsuba composes them),
//! and the snell transform steps of a matrix.
use super::numbers::{number, numbers, xyz};
use super::xml::Node;
use crate::error::Result;
use crate::scene::desc::TransformDesc;
use glam::{DMat3, DMat4, DVec3, DVec4};

/// The matrix of a `<transform>` element.
pub fn parse(t: &Node) -> Result<DMat4> {
    let mut m = DMat4::IDENTITY;
    for s in &t.children {
        let step = match s.tag.as_str() {
            "translate" => DMat4::from_translation(xyz(s, 0.0)?),
            "scale" => DMat4::from_scale(xyz(s, 1.0)?),
            "rotate" => {
                let axis = xyz(s, 0.0)?;
                let angle = number(s, s.need("angle")?)?;
                if !(axis.is_finite() && axis.length() > 1e-12) {
                    return Err(s.at.error("expected a non-zero rotation axis (x, y, z or value)"));
                }
                DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
            }
            "matrix" => {
                let v = numbers(s, s.need("value")?)?;
                match v.len() {
                    16 => DMat4::from_cols_array(&v.try_into().unwrap_or([0.0; 16])).transpose(),
                    9 => DMat4::from_mat3(
                        DMat3::from_cols_array(&v.try_into().unwrap_or([0.0; 9])).transpose(),
                    ),
                    n => return Err(s.at.error(format!("expected 16 (or 9) numbers, got {n}"))),
                }
            }
            "lookat" => {
                let (o, t, up) = lookat_args(s)?;
                lookat(s, o, t, up)?
            }
            other => {
                return Err(s.at.error(format!(
                    "expected translate, rotate, scale, matrix or lookat, found <{other}>"
                )))
            }
        };
        if !step.is_finite() {
            return Err(s.at.error("the step is not finite"));
        }
        m = step * m;
    }
    Ok(m)
}

/// `origin`, `target` and `up` of a `<lookat>` (up defaults to +y).
pub fn lookat_args(s: &Node) -> Result<(DVec3, DVec3, DVec3)> {
    let v3 = |k: &str| -> Result<Option<DVec3>> {
        match s.attr(k) {
            None => Ok(None),
            Some(v) => match numbers(s, v)?[..] {
                [a, b, c] => Ok(Some(DVec3::new(a, b, c))),
                _ => Err(s.at.error(format!("`{k}`: expected three numbers"))),
            },
        }
    };
    let o = v3("origin")?.ok_or_else(|| s.at.error("expected an `origin` attribute"))?;
    let t = v3("target")?.ok_or_else(|| s.at.error("expected a `target` attribute"))?;
    Ok((o, t, v3("up")?.unwrap_or(DVec3::Y)))
}

/// Mitsuba's look-at: columns (left, up, forward, origin), left = up × forward.
fn lookat(s: &Node, o: DVec3, t: DVec3, up: DVec3) -> Result<DMat4> {
    let dir = (t - o).normalize_or_zero();
    let left = up.cross(dir).normalize_or_zero();
    if dir == DVec3::ZERO || left == DVec3::ZERO {
        return Err(s
            .at
            .error("origin equals target, or up is parallel to the view direction"));
    }
    let new_up = dir.cross(left);
    Ok(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        DVec4::new(o.x, o.y, o.z, 1.0),
    ))
}

/// Scale factor of `m` if it is a similarity (rotation, possibly a mirror,
/// uniform scale, translation).
pub fn similarity(m: &DMat4) -> Option<f64> {
    let l = DMat3::from_mat4(*m);
    let s = l.x_axis.length();
    let tol = 1e-9 * s;
    let ok = s > 0.0
        && (l.y_axis.length() - s).abs() < tol
        && (l.z_axis.length() - s).abs() < tol
        && l.x_axis.dot(l.y_axis).abs() < tol * s
        && l.x_axis.dot(l.z_axis).abs() < tol * s
        && l.y_axis.dot(l.z_axis).abs() < tol * s;
    ok.then_some(s)
}

/// `m` as snell transform steps: none for the identity, a translation for
/// a pure translation, else one `matrix` step.
pub fn steps(m: &DMat4) -> Vec<TransformDesc> {
    if *m == DMat4::IDENTITY {
        return Vec::new();
    }
    let step = |translate, matrix| TransformDesc {
        translate,
        rotate: None,
        scale: None,
        matrix,
    };
    if DMat3::from_mat4(*m) == DMat3::IDENTITY {
        return vec![step(Some(m.w_axis.truncate().to_array()), None)];
    }
    let rows = m.transpose().to_cols_array_2d();
    vec![step(None, Some(rows))]
}

/// A point through `m`.
pub fn point(m: &DMat4, p: DVec3) -> DVec3 {
    m.transform_point3(p)
}

/// A direction through `m` (not normalised).
pub fn vector(m: &DMat4, v: DVec3) -> DVec3 {
    m.transform_vector3(v)
}

/// A normal through `m` (inverse transpose), normalised.
pub fn normal(m: &DMat4, n: DVec3) -> DVec3 {
    (DMat3::from_mat4(*m).inverse().transpose() * n).normalize_or_zero()
}
