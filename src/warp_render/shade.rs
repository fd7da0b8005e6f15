//! The local shading model both the warp and the exact trace use, so that
//! their difference is the warp's error alone.
use super::prepare::Prepared;
use super::rays::d3;
use crate::scene::{Environment, Light, Material, RenderScene};
use glam::{DVec3, Vec3A as V3};

/// The colour of the point (`u`, `v`) of triangle `tri` of `object`,
/// weighted by `weight`, and the point: emission + reflectance ×
/// (constant environment + directional, point and spot lights with |cos|),
/// unshadowed.
pub(crate) fn shade(
    scene: &RenderScene,
    prep: &Prepared,
    object: u32,
    tri: u32,
    u: f32,
    v: f32,
    weight: f64,
) -> (V3, DVec3) {
    let o = &prep.objects[object as usize];
    let g = &scene.geoms[o.geom as usize];
    let [a, b, c] = o.mesh.indices[tri as usize].map(|i| d3(o.mesh.positions[i as usize]));
    let (u64_, v64) = (u.clamp(0.0, 1.0) as f64, v.clamp(0.0, 1.0) as f64);
    let p = a * (1.0 - u64_ - v64).max(0.0) + b * u64_ + c * v64;
    // Texture coordinates only for an image texture (a checker reads the
    // point; the uv array's loads are a tenth of `shade`), the normal only
    // for the lights, the one thing that reads it (its normalisation is a
    // fifth of `shade`, and the tube's scene is lit by its emitting plane
    // alone).
    let uv = if g.needs_uv() {
        o.mesh.shading_uv(tri, u, v)
    } else {
        [u, v]
    };
    let pf = V3::new(p.x as f32, p.y as f32, p.z as f32);
    let mut col = g.emission.as_ref().map(|e| e.eval(pf, uv)).unwrap_or(V3::ZERO);
    if let Material::Diffuse { reflectance, .. } = &g.material {
        let rho = reflectance.eval(pf, uv);
        let mut e = match &scene.environment {
            Environment::Constant(c) => *c,
            _ => V3::ZERO,
        };
        // Only point-like and directional lights shade here (emitters are
        // seen, not sampled, by the warp).
        let lit = scene.lights.iter().any(|l| {
            matches!(
                l,
                Light::Directional { .. } | Light::Point { .. } | Light::Spot(_)
            )
        });
        let n = if !lit {
            V3::ZERO
        } else {
            o.mesh.shading_normal(tri, u, v).unwrap_or_else(|| {
                let ng = (b - a).cross(c - a).normalize_or_zero();
                V3::new(ng.x as f32, ng.y as f32, ng.z as f32)
            })
        };
        for l in &scene.lights {
            match l {
                Light::Directional {
                    direction,
                    irradiance,
                } => e += *irradiance * n.dot(*direction).abs() / std::f32::consts::PI,
                Light::Point { position, intensity } => {
                    let d = *position - pf;
                    let r2 = d.length_squared().max(1e-12);
                    e += *intensity * (n.dot(d).abs() / r2.sqrt()) / (r2 * std::f32::consts::PI);
                }
                Light::Spot(sp) => {
                    let d = sp.position - pf;
                    let r2 = d.length_squared().max(1e-12);
                    e +=
                        sp.intensity_towards(pf) * (n.dot(d).abs() / r2.sqrt()) / (r2 * std::f32::consts::PI);
                }
                _ => {}
            }
        }
        col += rho * e;
    }
    (col * weight as f32, p)
}
