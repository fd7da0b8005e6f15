//! The `[warp]` section: the glass of an analytic warp, validated, and added
//! to the scene as dielectric geometry so that `snell render` traces it.
use super::{Builder, Pending};
use crate::error::Result;
use crate::scene::desc::*;
use crate::scene::model::{Material, Shape};
use crate::scene::shapes::{Analytic, Cylinder, Mesh};
use glam::DVec3;
use std::sync::Arc;

impl Builder<'_> {
    /// Validate `[warp]` and add its glass as dielectric geometry (interfaces
    /// glass | ambient) for the full trace.
    pub(super) fn warp(
        &self,
        w: &WarpDesc,
        ambient: f64,
        pending: &mut Vec<Pending>,
    ) -> Result<crate::warp::WarpSpec> {
        use crate::warp::{HollowCylinder, Plate, WarpGlass, WarpMethod, WarpSpec};
        if ambient != 1.0 {
            return Err(self.err(
                "ambient_ior",
                format!("a [warp] scene needs ambient_ior = 1.0 (the warp math assumes air of index 1), got {ambient}"),
            ));
        }
        let method = match w.method.as_str() {
            "exact" => WarpMethod::Exact,
            "paper" => WarpMethod::Paper,
            o => {
                return Err(self.err(
                    "warp.method",
                    format!("expected \"exact\" or \"paper\", got \"{o}\""),
                ))
            }
        };
        if !(w.subdivide.is_finite() && w.subdivide >= 0.05) {
            return Err(self.err(
                "warp.subdivide",
                format!(
                    "expected a projected edge length >= 0.05 pixels, got {}",
                    w.subdivide
                ),
            ));
        }
        let extent = self.positive("warp.extent", w.extent)?;
        let first = pending.len() as u32;
        let glass = match &w.glass {
            WarpGlassDesc::Plate {
                near_face_point,
                normal,
                thickness,
                ior,
            } => {
                let q = self.finite3("warp.glass.near_face_point", *near_face_point)?;
                let nrm = self.unit("warp.glass.normal", *normal)?;
                let wt = self.positive("warp.glass.thickness", *thickness)?;
                let plate = Plate::try_new(q, nrm, wt, *ior).map_err(|e| self.err("warp.glass", e))?;
                // A box: `extent` square across, `thickness` deep, outward winding.
                let (u, v) = {
                    let helper = if nrm.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
                    let u = nrm.cross(helper).normalize();
                    (u, nrm.cross(u))
                };
                let h = extent * 0.5;
                let mut positions = Vec::with_capacity(8);
                for k in 0..8 {
                    let p = q
                        + u * if k & 1 == 0 { -h } else { h }
                        + v * if k & 2 == 0 { -h } else { h }
                        + nrm * if k & 4 == 0 { 0.0 } else { wt };
                    positions.push([p.x as f32, p.y as f32, p.z as f32]);
                }
                let quads = [
                    [0, 2, 3, 1],
                    [4, 5, 7, 6],
                    [0, 1, 5, 4],
                    [2, 6, 7, 3],
                    [0, 4, 6, 2],
                    [1, 3, 7, 5],
                ];
                let mut indices = Vec::new();
                for qd in quads {
                    indices.push([qd[0], qd[1], qd[2]]);
                    indices.push([qd[0], qd[2], qd[3]]);
                }
                let mut mesh = Mesh {
                    positions,
                    indices,
                    normals: None,
                    uvs: None,
                };
                if mesh.signed_volume() < 0.0 {
                    mesh.flip();
                }
                pending.push(glass_pending(
                    "warp_glass_plate",
                    Shape::Mesh(Arc::new(mesh)),
                    *ior,
                ));
                WarpGlass::Plate(plate)
            }
            WarpGlassDesc::HollowCylinder {
                axis_point,
                axis_direction,
                outer_radius,
                inner_radius,
                ior,
            } => {
                let c = self.finite3("warp.glass.axis_point", *axis_point)?;
                let a = self.unit("warp.glass.axis_direction", *axis_direction)?;
                let tube = HollowCylinder::try_new(c, a, *outer_radius, *inner_radius, *ior)
                    .map_err(|e| self.err("warp.glass", e))?;
                for (name, radius, inward) in [
                    ("warp_glass_outer", *outer_radius, false),
                    ("warp_glass_inner", *inner_radius, true),
                ] {
                    let side = Analytic::Cylinder(Cylinder {
                        p0: c - a * (extent * 0.5),
                        axis: a,
                        height: extent,
                        radius,
                        inward,
                        caps: false,
                    });
                    pending.push(glass_pending(name, Shape::Analytic(side), *ior));
                }
                WarpGlass::Cylinder(tube)
            }
        };
        Ok(WarpSpec {
            glass,
            glass_geoms: (first..pending.len() as u32).collect(),
            subdivide: w.subdivide,
            fresnel: w.fresnel,
            method,
        })
    }
}

/// The warp's glass as scene geometry for `snell render`: an interface of
/// index `ior` in air, neither emitting nor a solid.
fn glass_pending(name: &str, shape: Shape, ior: f64) -> Pending {
    Pending {
        name: name.into(),
        name_key: "warp.glass".into(),
        shape,
        material: Material::Interface {
            int_ior: ior as f32,
            ext_ior: 1.0,
        },
        emission: None,
        emission_two_sided: false,
        light: None,
        solid: None,
        analytic_twin: None,
    }
}
