//! The `[[lights]]` section: lights for next-event estimation; area lights
//! are also geometry (black bodies that emit), pending like objects.
use super::{Builder, Pending};
use crate::error::Result;
use crate::scene::desc::*;
use crate::scene::emitter::Spot;
use crate::scene::meshgen;
use crate::scene::model::{Light, Material, Shape};
use crate::scene::shapes::{Analytic, Rect, Sphere};
use crate::scene::texture::Texture;
use std::sync::Arc;

impl Builder<'_> {
    /// Every light of `d`; rect and sphere lights also push their geometry.
    pub(super) fn lights(&self, d: &SceneDesc, pending: &mut Vec<Pending>) -> Result<Vec<Light>> {
        let mut lights = Vec::new();
        for (i, l) in d.lights.iter().enumerate() {
            let k = format!("lights[{i}]");
            match l {
                LightDesc::Point(p) => lights.push(Light::Point {
                    position: (self.finite3(&format!("{k}.position"), p.position)?).as_vec3a(),
                    intensity: self.color(&format!("{k}.intensity"), p.intensity)?,
                }),
                LightDesc::Directional(p) => lights.push(Light::Directional {
                    direction: (self.unit(&format!("{k}.direction"), p.direction)?).as_vec3a(),
                    irradiance: self.color(&format!("{k}.irradiance"), p.irradiance)?,
                }),
                LightDesc::Rect(r) => {
                    let center = self.finite3(&format!("{k}.center"), r.center)?;
                    let normal = self.unit(&format!("{k}.normal"), r.normal)?;
                    let u = self.unit(&format!("{k}.u_axis"), r.u_axis)?;
                    if normal.dot(u).abs() > 1e-6 {
                        return Err(self.err(
                            &format!("{k}.u_axis"),
                            "u_axis must be perpendicular to the normal",
                        ));
                    }
                    let su = self.positive(&format!("{k}.size[0]"), r.size[0])?;
                    let sv = self.positive(&format!("{k}.size[1]"), r.size[1])?;
                    let radiance = self.color(&format!("{k}.radiance"), r.radiance)?;
                    let v = normal.cross(u);
                    let li = lights.len() as u32;
                    lights.push(Light::Rect {
                        corner: (center - u * su * 0.5 - v * sv * 0.5).as_vec3a(),
                        edge_u: (u * su).as_vec3a(),
                        edge_v: (v * sv).as_vec3a(),
                        normal: normal.as_vec3a(),
                        area: (su * sv) as f32,
                        radiance,
                    });
                    let mesh = meshgen::rect(center, normal, u, [su, sv]);
                    pending.push(Pending {
                        name: r.name.clone().unwrap_or_else(|| k.clone()),
                        name_key: format!("{k}.name"),
                        analytic_twin: Rect::of_mesh(&mesh).map(Analytic::Rect),
                        shape: Shape::Mesh(Arc::new(mesh)),
                        material: Material::Black,
                        emission: Some(Texture::Constant(radiance)),
                        emission_two_sided: false,
                        light: Some(li),
                        solid: None,
                    });
                }
                LightDesc::Sphere(s) => {
                    let center = self.finite3(&format!("{k}.center"), s.center)?;
                    let radius = self.positive(&format!("{k}.radius"), s.radius)?;
                    let radiance = self.color(&format!("{k}.radiance"), s.radiance)?;
                    let li = lights.len() as u32;
                    lights.push(Light::Sphere {
                        center: center.as_vec3a(),
                        radius: radius as f32,
                        radiance,
                    });
                    pending.push(Pending {
                        name: s.name.clone().unwrap_or_else(|| k.clone()),
                        name_key: format!("{k}.name"),
                        shape: Shape::Analytic(Analytic::Sphere(Sphere { center, radius })),
                        material: Material::Black,
                        emission: Some(Texture::Constant(radiance)),
                        emission_two_sided: false,
                        light: Some(li),
                        solid: None,
                        analytic_twin: None,
                    });
                }
                LightDesc::Spot(s) => lights.push(Light::Spot(self.spot(&k, s)?)),
            }
        }
        Ok(lights)
    }

    /// A spot light: an axis from `direction` or `target`, and the cone's
    /// angles checked (0 < cutoff <= 90, 0 <= beam <= cutoff).
    fn spot(&self, k: &str, s: &SpotLightDesc) -> Result<Spot> {
        let position = self.finite3(&format!("{k}.position"), s.position)?;
        let axis = match (s.direction, s.target) {
            (Some(d), None) => self.unit(&format!("{k}.direction"), d)?,
            (None, Some(t)) => {
                let t = self.finite3(&format!("{k}.target"), t)?;
                let d = t - position;
                if d.length() < 1e-12 {
                    return Err(self.err(&format!("{k}.target"), "the target must differ from the position"));
                }
                d.normalize()
            }
            (Some(_), Some(_)) => {
                return Err(self.err(
                    &format!("{k}.target"),
                    "give either `direction` or `target`, not both",
                ))
            }
            (None, None) => {
                return Err(self.err(
                    k,
                    "a spot light needs `direction` or `target` (where its axis points)",
                ))
            }
        };
        let intensity = self.color(&format!("{k}.intensity"), s.intensity)?;
        let cutoff = s.cutoff_angle;
        if !(cutoff.is_finite() && cutoff > 0.0 && cutoff <= 90.0) {
            return Err(self.err(
                &format!("{k}.cutoff_angle"),
                format!("expected the cone's half-angle in (0, 90] degrees, got {cutoff}"),
            ));
        }
        let beam = s.beam_width.unwrap_or(cutoff * 0.75);
        if !(beam.is_finite() && beam >= 0.0) {
            return Err(self.err(
                &format!("{k}.beam_width"),
                format!("expected an angle >= 0 degrees, got {beam}"),
            ));
        }
        if beam > cutoff {
            return Err(self.err(
                &format!("{k}.beam_width"),
                format!("beam_width ({beam}) must not exceed cutoff_angle ({cutoff})"),
            ));
        }
        Ok(Spot::new(
            position.as_vec3a(),
            axis.as_vec3a(),
            intensity,
            cutoff,
            beam,
        ))
    }
}
