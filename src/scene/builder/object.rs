//! The `[[objects]]` section: shapes (with their transforms), materials,
//! textures; priority solids checked closed and outward facing.
use super::{v3, Builder, Pending, PendingSolid, MAX_HEIGHTFIELD_LEVELS};
use crate::bsdf;
use crate::error::Result;
use crate::scene::desc::*;
use crate::scene::emitter::{AreaSampler, Emitter, EmitterShape};
use crate::scene::meshgen;
use crate::scene::model::{Containment, Light, Material, Shape};
use crate::scene::shapes::{Analytic, Cylinder, Disk, Mesh, Rect, Sphere, Tube};
use crate::scene::texture::{load_image, Texture};
use glam::{DMat3, DMat4, DVec3, Vec3A as V3};
use std::sync::Arc;

/// The keys a smooth and a rough dielectric share.
struct DielectricKeys<'a> {
    ior: Option<f64>,
    priority: Option<i64>,
    int_ior: Option<f64>,
    ext_ior: Option<f64>,
    absorption: Option<&'a AbsorptionDesc>,
}

/// An object's transform as its shape needs it: points and directions to
/// world space, and whether it is a similarity (a uniform scale `scale`
/// times a rotation, plus a translation), the only transforms an analytic
/// shape stays analytic under.
struct Placement {
    xf: DMat4,
    lin: DMat3,
    scale: f64,
    similarity: bool,
}

impl Placement {
    fn new(xf: DMat4) -> Self {
        let lin = DMat3::from_mat4(xf);
        let scale = lin.x_axis.length();
        let similarity = (lin.y_axis.length() - scale).abs() < 1e-9 * scale
            && (lin.z_axis.length() - scale).abs() < 1e-9 * scale
            && lin.x_axis.dot(lin.y_axis).abs() < 1e-9 * scale * scale
            && lin.x_axis.dot(lin.z_axis).abs() < 1e-9 * scale * scale
            && lin.y_axis.dot(lin.z_axis).abs() < 1e-9 * scale * scale;
        Placement {
            xf,
            lin,
            scale,
            similarity,
        }
    }

    /// A point to world space.
    fn point(&self, p: DVec3) -> DVec3 {
        self.xf.transform_point3(p)
    }

    /// A direction to world space, unit length.
    fn dir(&self, d: DVec3) -> DVec3 {
        self.lin.mul_vec3(d).normalize()
    }
}

impl Builder<'_> {
    pub(super) fn object(&self, i: usize, o: &ObjectDesc, warnings: &mut Vec<String>) -> Result<Pending> {
        let k = format!("objects[{i}]");
        let name = o.name.clone().unwrap_or_else(|| k.clone());
        let (shape, closed_mesh) = self.shape(&k, o)?;
        let (material, solid, shape) = self.material(&k, o, &name, shape, closed_mesh, warnings)?;
        let emission = match &o.emission {
            Some(e) => Some(self.texture(&format!("{k}.emission.radiance"), &e.radiance)?),
            None => None,
        };
        let analytic_twin = match (&o.shape, &shape) {
            (ShapeDesc::Rect(_), Shape::Mesh(m)) if solid.is_none() => Rect::of_mesh(m).map(Analytic::Rect),
            _ => None,
        };
        Ok(Pending {
            name,
            name_key: format!("{k}.name"),
            shape,
            material,
            emission,
            emission_two_sided: o.emission.as_ref().is_some_and(|e| e.two_sided),
            light: None,
            solid,
            analytic_twin,
        })
    }

    /// The light of the pending object `key` (geometry `geom`) when it
    /// emits: an analytic sphere sampled by its cone, anything else by area.
    /// `None` when it does not emit (or emits nothing anywhere).
    pub(super) fn emitter(&self, key: &str, geom: u32, p: &Pending) -> Result<Option<Light>> {
        let Some(radiance) = &p.emission else {
            return Ok(None);
        };
        if radiance.max_value() <= 0.0 {
            return Ok(None);
        }
        let shape = match &p.shape {
            Shape::Analytic(a @ Analytic::Sphere(s)) => EmitterShape::Sphere {
                sphere: *a,
                center: s.center.as_vec3a(),
                radius: s.radius as f32,
            },
            Shape::Analytic(a) => EmitterShape::Area(AreaSampler::analytic(a).ok_or_else(|| {
                self.err(
                    &format!("{key}.shape"),
                    "an emitting shape needs a positive, finite area",
                )
            })?),
            Shape::Mesh(m) => EmitterShape::Area(AreaSampler::mesh(m.clone()).ok_or_else(|| {
                self.err(
                    &format!("{key}.shape"),
                    "an emitting mesh needs a positive, finite area",
                )
            })?),
        };
        Ok(Some(Light::Emitter(Emitter {
            geom,
            radiance: radiance.clone(),
            two_sided: p.emission_two_sided,
            shape,
            sampling: Default::default(),
        })))
    }

    /// The shape of object `k` in world space (its transform applied), and
    /// whether it is a closed mesh (checked further when used as a solid:
    /// boxes and OBJ meshes are required to be, lathes are when both ends
    /// of the profile lie on the axis).
    fn shape(&self, k: &str, o: &ObjectDesc) -> Result<(Shape, bool)> {
        let pl = Placement::new(self.transform(&format!("{k}.transform"), &o.transform)?);
        let sk = format!("{k}.shape");
        let (shape, closed_mesh) = match &o.shape {
            ShapeDesc::Sphere(s) => (self.sphere(k, &sk, s, &pl)?, false),
            ShapeDesc::Rect(r) => (self.rect(&sk, r, &pl)?, false),
            ShapeDesc::Disk(dk) => (self.disk(k, &sk, dk, &pl)?, false),
            ShapeDesc::Box(b) => (self.cuboid(&sk, b, &pl)?, true),
            ShapeDesc::Cylinder(cy) => (self.cylinder(k, &sk, cy, &pl)?, false),
            ShapeDesc::Tube(t) => (self.tube(k, &sk, t, &pl)?, false),
            ShapeDesc::Lathe(l) => self.lathe(&sk, l, &pl)?,
            ShapeDesc::Mesh(m) => (self.obj_mesh(&sk, m, &pl)?, true),
            ShapeDesc::Heightfield(h) => (self.heightfield(&sk, h, &pl)?, false),
        };
        // Embree works in f32: everything must stay finite (and sane) there.
        let (lo, hi) = match &shape {
            Shape::Mesh(m) => m.aabb(),
            Shape::Analytic(a) => a.aabb(),
        };
        if !(lo.is_finite() && hi.is_finite()) || lo.abs().max(hi.abs()).max_element() > 1e15 {
            return Err(self.err(
                &sk,
                "the shape's coordinates are not finite or exceed 1e15 m (Embree works in f32)",
            ));
        }
        if let Shape::Mesh(m) = &shape {
            if let Some(face) = meshgen::find_degenerate(m) {
                return Err(self.err(&sk, format!("triangle {} is degenerate (zero area)", face + 1)));
            }
        }

        Ok((shape, closed_mesh))
    }

    /// `a`, if the object's transform keeps it analytic (a similarity).
    fn analytic(&self, k: &str, pl: &Placement, a: Analytic) -> Result<Shape> {
        if !pl.similarity {
            return Err(self.err(
                &format!("{k}.transform"),
                "analytic shapes take only translations, rotations and uniform scales; use a mesh for other transforms",
            ));
        }
        Ok(Shape::Analytic(a))
    }

    /// An analytic sphere.
    fn sphere(&self, k: &str, sk: &str, s: &SphereDesc, pl: &Placement) -> Result<Shape> {
        self.analytic(
            k,
            pl,
            Analytic::Sphere(Sphere {
                center: pl.point(self.finite3(&format!("{sk}.center"), s.center)?),
                radius: self.positive(&format!("{sk}.radius"), s.radius)? * pl.scale,
            }),
        )
    }

    /// A rectangle (two triangles).
    fn rect(&self, sk: &str, r: &RectDesc, pl: &Placement) -> Result<Shape> {
        let c = self.finite3(&format!("{sk}.center"), r.center)?;
        let n = self.unit(&format!("{sk}.normal"), r.normal)?;
        let u = self.unit(&format!("{sk}.u_axis"), r.u_axis)?;
        if n.dot(u).abs() > 1e-6 {
            return Err(self.err(
                &format!("{sk}.u_axis"),
                "u_axis must be perpendicular to the normal",
            ));
        }
        let su = self.positive(&format!("{sk}.size[0]"), r.size[0])?;
        let sv = self.positive(&format!("{sk}.size[1]"), r.size[1])?;
        Ok(Shape::Mesh(Arc::new(
            self.xf_mesh(meshgen::rect(c, n, u, [su, sv]), &pl.xf),
        )))
    }

    /// An analytic disk or annulus.
    fn disk(&self, k: &str, sk: &str, dk: &DiskDesc, pl: &Placement) -> Result<Shape> {
        let r = self.positive(&format!("{sk}.radius"), dk.radius)?;
        if !(dk.inner_radius.is_finite() && dk.inner_radius >= 0.0 && dk.inner_radius < r) {
            return Err(self.err(
                &format!("{sk}.inner_radius"),
                "expected 0 <= inner_radius < radius",
            ));
        }
        self.analytic(
            k,
            pl,
            Analytic::Disk(Disk {
                center: pl.point(self.finite3(&format!("{sk}.center"), dk.center)?),
                normal: pl.dir(self.unit(&format!("{sk}.normal"), dk.normal)?),
                radius: r * pl.scale,
                inner: dk.inner_radius * pl.scale,
            }),
        )
    }

    /// A closed cuboid mesh.
    fn cuboid(&self, sk: &str, b: &BoxDesc, pl: &Placement) -> Result<Shape> {
        let c = self.finite3(&format!("{sk}.center"), b.center)?;
        let s = self.finite3(&format!("{sk}.size"), b.size)?;
        if s.min_element() <= 0.0 {
            return Err(self.err(&format!("{sk}.size"), "expected three sizes > 0"));
        }
        Ok(Shape::Mesh(Arc::new(self.xf_mesh(meshgen::cuboid(c, s), &pl.xf))))
    }

    /// An analytic cylinder, open or capped.
    fn cylinder(&self, k: &str, sk: &str, cy: &CylinderDesc, pl: &Placement) -> Result<Shape> {
        let p0 = self.finite3(&format!("{sk}.p0"), cy.p0)?;
        let p1 = self.finite3(&format!("{sk}.p1"), cy.p1)?;
        let r = self.positive(&format!("{sk}.radius"), cy.radius)?;
        let inward = match cy.normal.as_str() {
            "out" => false,
            "in" => true,
            o => {
                return Err(self.err(
                    &format!("{sk}.normal"),
                    format!("expected \"out\" or \"in\", got \"{o}\""),
                ))
            }
        };
        if cy.caps && inward {
            return Err(self.err(
                &format!("{sk}.caps"),
                "a capped (solid) cylinder needs normal = \"out\"",
            ));
        }
        let (a, axis, h) = self.axis(sk, pl, p0, p1)?;
        self.analytic(
            k,
            pl,
            Analytic::Cylinder(Cylinder {
                p0: a,
                axis,
                height: h,
                radius: r * pl.scale,
                inward,
                caps: cy.caps,
            }),
        )
    }

    /// The world-space axis from `p0` to `p1` of shape `sk`: its start, unit
    /// direction and length.
    fn axis(&self, sk: &str, pl: &Placement, p0: DVec3, p1: DVec3) -> Result<(DVec3, DVec3, f64)> {
        let (a, b) = (pl.point(p0), pl.point(p1));
        let h = (b - a).length();
        if h <= 0.0 {
            return Err(self.err(&format!("{sk}.p1"), "p0 and p1 must differ"));
        }
        Ok((a, (b - a) / h, h))
    }

    /// An analytic thick-walled tube.
    fn tube(&self, k: &str, sk: &str, t: &TubeDesc, pl: &Placement) -> Result<Shape> {
        let p0 = self.finite3(&format!("{sk}.p0"), t.p0)?;
        let p1 = self.finite3(&format!("{sk}.p1"), t.p1)?;
        let ro = self.positive(&format!("{sk}.outer_radius"), t.outer_radius)?;
        let ri = self.positive(&format!("{sk}.inner_radius"), t.inner_radius)?;
        if ri >= ro {
            return Err(self.err(
                &format!("{sk}.inner_radius"),
                "expected inner_radius < outer_radius",
            ));
        }
        let (a, axis, h) = self.axis(sk, pl, p0, p1)?;
        self.analytic(
            k,
            pl,
            Analytic::Tube(Tube {
                p0: a,
                axis,
                height: h,
                outer: ro * pl.scale,
                inner: ri * pl.scale,
            }),
        )
    }

    /// A revolved profile, and whether it is closed (both ends on the axis).
    fn lathe(&self, sk: &str, l: &LatheDesc, pl: &Placement) -> Result<(Shape, bool)> {
        if l.profile.len() < 2 {
            return Err(self.err(
                &format!("{sk}.profile"),
                "expected at least two (radius, height) points",
            ));
        }
        for (j, p) in l.profile.iter().enumerate() {
            if !(p[0].is_finite() && p[1].is_finite() && p[0] >= 0.0) {
                return Err(self.err(
                    &format!("{sk}.profile[{j}]"),
                    "expected (radius >= 0, height), finite",
                ));
            }
        }
        if !(3..=1 << 16).contains(&l.segments) {
            return Err(self.err(&format!("{sk}.segments"), "expected 3..=65536 segments"));
        }
        let first = l.profile[0];
        let last = l.profile[l.profile.len() - 1];
        let closed = first[0] == 0.0 && last[0] == 0.0;
        if !(0.0..=180.0).contains(&l.crease_angle) {
            return Err(self.err(&format!("{sk}.crease_angle"), "expected degrees in 0..=180"));
        }
        let shading = if l.smooth {
            meshgen::LatheShading::Smooth {
                crease_deg: l.crease_angle,
            }
        } else {
            meshgen::LatheShading::Flat
        };
        Ok((
            Shape::Mesh(Arc::new(
                self.xf_mesh(meshgen::lathe(&l.profile, l.segments, shading), &pl.xf),
            )),
            closed,
        ))
    }

    /// Triangles from a mesh file (OBJ, PLY, `.serialized`, glTF).
    fn obj_mesh(&self, sk: &str, m: &MeshDesc, pl: &Placement) -> Result<Shape> {
        let path = self.resolve(&m.file);
        let mesh = crate::scene::import::load_mesh(&path, m)
            .map_err(|(key, e)| self.err(&format!("{sk}.{key}"), format!("{}: {e}", path.display())))?;
        Ok(Shape::Mesh(Arc::new(self.xf_mesh(mesh, &pl.xf))))
    }

    /// Diamond-square terrain.
    fn heightfield(&self, sk: &str, h: &HeightfieldDesc, pl: &Placement) -> Result<Shape> {
        if h.levels == 0 || h.levels > MAX_HEIGHTFIELD_LEVELS {
            // In f64: 2^levels overflows any integer for absurd levels.
            let n = 2f64.powi(h.levels.min(2000) as i32) + 1.0;
            return Err(self.err(
                &format!("{sk}.levels"),
                format!(
                    "expected 1..={MAX_HEIGHTFIELD_LEVELS} levels; {} levels would be {:.2e} triangles (~{:.1e} bytes)",
                    h.levels,
                    2.0 * (n - 1.0) * (n - 1.0),
                    n * n * 48.0
                ),
            ));
        }
        let sx = self.positive(&format!("{sk}.size[0]"), h.size[0])?;
        let sz = self.positive(&format!("{sk}.size[1]"), h.size[1])?;
        if !(h.height.is_finite() && h.height >= 0.0) {
            return Err(self.err(&format!("{sk}.height"), "expected a finite height >= 0"));
        }
        if !(h.roughness > 0.0 && h.roughness < 1.0) {
            return Err(self.err(&format!("{sk}.roughness"), "expected 0 < roughness < 1"));
        }
        Ok(Shape::Mesh(Arc::new(self.xf_mesh(
            meshgen::heightfield([sx, sz], h.levels, h.height, h.roughness, h.seed),
            &pl.xf,
        ))))
    }

    /// The material of object `k`; for a priority solid also its solid
    /// record (the shape is checked closed and outward facing, and flipped
    /// when `flip_inside_out` asks for it, hence returned).
    fn material(
        &self,
        k: &str,
        o: &ObjectDesc,
        name: &str,
        mut shape: Shape,
        closed_mesh: bool,
        warnings: &mut Vec<String>,
    ) -> Result<(Material, Option<PendingSolid>, Shape)> {
        let mk = format!("{k}.material");
        let mut solid = None;
        let material = match &o.material {
            MaterialDesc::Diffuse(dd) => {
                let t = self.texture(&format!("{mk}.reflectance"), &dd.reflectance)?;
                if t.max_value() > 1.0 {
                    return Err(self.err(
                        &format!("{mk}.reflectance"),
                        "a reflectance above 1 creates energy",
                    ));
                }
                Material::Diffuse {
                    reflectance: t,
                    two_sided: dd.two_sided,
                }
            }
            MaterialDesc::Mirror(m) => Material::Mirror {
                reflectance: self.color(&format!("{mk}.reflectance"), m.reflectance)?,
            },
            MaterialDesc::Black(_) => Material::Black,
            MaterialDesc::Dielectric(dd) => self.dielectric(
                k,
                o,
                name,
                &mut shape,
                closed_mesh,
                warnings,
                DielectricKeys {
                    ior: dd.ior,
                    priority: dd.priority,
                    int_ior: dd.int_ior,
                    ext_ior: dd.ext_ior,
                    absorption: dd.absorption.as_ref(),
                },
                None,
                &mut solid,
            )?,
            MaterialDesc::RoughDielectric(dd) => {
                let distribution = self.distribution(&mk, dd.distribution, dd.alpha)?;
                self.dielectric(
                    k,
                    o,
                    name,
                    &mut shape,
                    closed_mesh,
                    warnings,
                    DielectricKeys {
                        ior: dd.ior,
                        priority: dd.priority,
                        int_ior: dd.int_ior,
                        ext_ior: dd.ext_ior,
                        absorption: dd.absorption.as_ref(),
                    },
                    Some(distribution),
                    &mut solid,
                )?
            }
            MaterialDesc::Conductor(c) => Material::Conductor {
                bsdf: {
                    let (eta, kk, spec) = self.metal(&mk, &c.material, c.eta, c.k, c.specular_reflectance)?;
                    bsdf::Conductor::try_new(eta, kk, spec).map_err(|e| self.err(&mk, e.to_string()))?
                },
                two_sided: c.two_sided,
            },
            MaterialDesc::RoughConductor(c) => Material::RoughConductor {
                bsdf: {
                    let (eta, kk, spec) = self.metal(&mk, &c.material, c.eta, c.k, c.specular_reflectance)?;
                    let d = self.distribution(&mk, c.distribution, c.alpha)?;
                    bsdf::RoughConductor::try_new(d, eta, kk, spec)
                        .map_err(|e| self.err(&mk, e.to_string()))?
                },
                two_sided: c.two_sided,
            },
            MaterialDesc::Plastic(p) => Material::Plastic {
                bsdf: {
                    let params = self.plastic(
                        &mk,
                        p.diffuse_reflectance,
                        p.specular_reflectance,
                        p.int_ior,
                        p.ext_ior,
                        p.nonlinear,
                    )?;
                    bsdf::Plastic::try_new(&params).map_err(|e| self.err(&mk, e.to_string()))?
                },
                two_sided: p.two_sided,
            },
            MaterialDesc::RoughPlastic(p) => Material::RoughPlastic {
                bsdf: {
                    let params = self.plastic(
                        &mk,
                        p.diffuse_reflectance,
                        p.specular_reflectance,
                        p.int_ior,
                        p.ext_ior,
                        p.nonlinear,
                    )?;
                    let d = self.distribution(&mk, p.distribution, p.alpha)?;
                    // The coating's tables: once per material, shared by every hit.
                    Arc::new(
                        bsdf::RoughPlastic::try_new(&params, d).map_err(|e| self.err(&mk, e.to_string()))?,
                    )
                },
                two_sided: p.two_sided,
            },
        };
        Ok((material, solid, shape))
    }

    /// A dielectric (smooth, or rough with `roughness`): a priority solid
    /// given by `ior` (its record goes to `solid`; the material returned is a
    /// placeholder until the solid's index is known) or an interface given by
    /// `int_ior` and `ext_ior`.
    #[allow(clippy::too_many_arguments)]
    fn dielectric(
        &self,
        k: &str,
        o: &ObjectDesc,
        name: &str,
        shape: &mut Shape,
        closed_mesh: bool,
        warnings: &mut Vec<String>,
        dd: DielectricKeys<'_>,
        roughness: Option<bsdf::MicrofacetDistribution>,
        solid: &mut Option<PendingSolid>,
    ) -> Result<Material> {
        let sk = format!("{k}.shape");
        let mk = format!("{k}.material");
        Ok(match (dd.ior, dd.int_ior, dd.ext_ior) {
            (Some(ior), None, None) => {
                let ior = self.positive(&format!("{mk}.ior"), ior)?;
                let sigma_a = match &dd.absorption {
                    None => V3::ZERO,
                    Some(a) => {
                        let c = self.color(&format!("{mk}.absorption.color"), a.color)?;
                        if c.min_element() <= 0.0 || c.max_element() > 1.0 {
                            return Err(self.err(
                                &format!("{mk}.absorption.color"),
                                "expected transmitted colour in (0, 1]",
                            ));
                        }
                        let dist = self.positive(&format!("{mk}.absorption.distance"), a.distance)?;
                        V3::new(-c.x.ln(), -c.y.ln(), -c.z.ln()) / dist as f32
                    }
                };
                // A priority solid must be closed and outward facing.
                let mut flipped = None;
                let containment = match &*shape {
                    Shape::Analytic(a) => {
                        if a.contains(DVec3::ZERO).is_none() {
                            return Err(self.err(
                                &sk,
                                format!("dielectric solid \"{name}\" must be closed: use a sphere, a capped cylinder, a tube, a box, a closed lathe or a closed mesh (or int_ior/ext_ior for an open interface)"),
                            ));
                        }
                        Containment::Analytic(*a)
                    }
                    Shape::Mesh(m) => {
                        if !closed_mesh {
                            return Err(
                                self.err(&sk, format!("dielectric solid \"{name}\" must be a closed mesh"))
                            );
                        }
                        m.check_closed().map_err(|e| {
                            self.err(
                                &sk,
                                format!("dielectric solid \"{name}\" is not a closed solid: {e}"),
                            )
                        })?;
                        let vol = m.signed_volume();
                        if vol <= 0.0 && !o.flip_inside_out {
                            return Err(self.err(
                                &sk,
                                format!("dielectric solid \"{name}\" is inside out (signed volume {vol:.3e} <= 0); set flip_inside_out = true to flip it"),
                            ));
                        }
                        if vol <= 0.0 {
                            warnings.push(format!(
                                "{}: {k}: \"{name}\" was inside out (negative volume); flipped",
                                self.src.file
                            ));
                            let mut fm = (**m).clone();
                            fm.flip();
                            flipped = Some(Arc::new(fm));
                        }
                        Containment::Mesh(Arc::new(crate::scene::shapes::ContainsGrid::new(
                            flipped.clone().unwrap_or_else(|| m.clone()),
                        )))
                    }
                };
                if let Some(fm) = flipped {
                    *shape = Shape::Mesh(fm);
                }
                let aabb = match &*shape {
                    Shape::Analytic(a) => a.aabb(),
                    Shape::Mesh(m) => m.aabb(),
                };
                *solid = Some(PendingSolid {
                    priority: dd.priority.unwrap_or(0),
                    ior,
                    sigma_a,
                    containment,
                    aabb,
                });
                // Replaced by the solid's material when its index is known.
                match roughness {
                    None => Material::Black,
                    Some(distribution) => Material::RoughSolid {
                        solid: u32::MAX,
                        distribution,
                    },
                }
            }
            (None, Some(int), Some(ext)) => {
                if dd.priority.is_some() {
                    return Err(self.err(
                        &format!("{mk}.priority"),
                        "priority applies to solids given by `ior`, not to int_ior/ext_ior interfaces",
                    ));
                }
                if dd.absorption.is_some() {
                    return Err(self.err(
                        &format!("{mk}.absorption"),
                        "absorption needs a closed solid given by `ior` (an interface has no inside)",
                    ));
                }
                let int_ior = self.positive(&format!("{mk}.int_ior"), int)? as f32;
                let ext_ior = self.positive(&format!("{mk}.ext_ior"), ext)? as f32;
                match roughness {
                    None => Material::Interface { int_ior, ext_ior },
                    // An index-matched interface scatters nothing: kept smooth (a pass-through).
                    Some(_) if int_ior == ext_ior => Material::Interface { int_ior, ext_ior },
                    Some(distribution) => Material::RoughInterface {
                        int_ior,
                        ext_ior,
                        distribution,
                    },
                }
            }
            _ => {
                return Err(self.err(&mk, "a dielectric needs either `ior` (a closed solid, with optional priority) or both `int_ior` and `ext_ior`"));
            }
        })
    }

    /// A checked microfacet distribution from `distribution` and `alpha` (keys of `mk`).
    fn distribution(
        &self,
        mk: &str,
        kind: DistributionDesc,
        alpha: f64,
    ) -> Result<bsdf::MicrofacetDistribution> {
        if !(alpha.is_finite() && alpha > 0.0 && alpha <= 1.0) {
            return Err(self.err(
                &format!("{mk}.alpha"),
                format!("expected a roughness in (0, 1], got {alpha}"),
            ));
        }
        let kind = match kind {
            DistributionDesc::Ggx => bsdf::MicrofacetKind::Ggx,
            DistributionDesc::Beckmann => bsdf::MicrofacetKind::Beckmann,
        };
        bsdf::MicrofacetDistribution::isotropic(kind, alpha as f32)
            .map_err(|e| self.err(&format!("{mk}.alpha"), e.to_string()))
    }

    /// A metal's complex index and reflectance factor: a named `material` or
    /// both `eta` and `k` (keys of `mk`).
    fn metal(
        &self,
        mk: &str,
        material: &Option<String>,
        eta: Option<Vec3>,
        k: Option<Vec3>,
        specular_reflectance: Vec3,
    ) -> Result<(glam::Vec3, glam::Vec3, glam::Vec3)> {
        let spec = self.color(&format!("{mk}.specular_reflectance"), specular_reflectance)?;
        match (material, eta, k) {
            (Some(m), None, None) => {
                let metal = bsdf::metals::find(m).ok_or_else(|| {
                    self.err(
                        &format!("{mk}.material"),
                        format!("unknown metal {m:?}; known: {}", bsdf::metals::names()),
                    )
                })?;
                Ok((metal.eta, metal.k, spec.into()))
            }
            (None, Some(eta), Some(k)) => Ok((
                self.color(&format!("{mk}.eta"), eta)?.into(),
                self.color(&format!("{mk}.k"), k)?.into(),
                spec.into(),
            )),
            _ => Err(self.err(
                mk,
                "a conductor needs either `material` (a named metal) or both `eta` and `k`",
            )),
        }
    }

    /// A plastic's checked parameters (keys of `mk`).
    fn plastic(
        &self,
        mk: &str,
        diffuse: Vec3,
        specular: Vec3,
        int_ior: f64,
        ext_ior: f64,
        nonlinear: bool,
    ) -> Result<bsdf::PlasticParams> {
        let diffuse = self.color(&format!("{mk}.diffuse_reflectance"), diffuse)?;
        if diffuse.max_element() > 1.0 {
            return Err(self.err(
                &format!("{mk}.diffuse_reflectance"),
                "a reflectance above 1 creates energy",
            ));
        }
        let int_ior = self.positive(&format!("{mk}.int_ior"), int_ior)?;
        let ext_ior = self.positive(&format!("{mk}.ext_ior"), ext_ior)?;
        if int_ior == ext_ior {
            return Err(self.err(
                &format!("{mk}.int_ior"),
                "expected an index different from ext_ior (an index-matched coating reflects nothing)",
            ));
        }
        Ok(bsdf::PlasticParams {
            int_ior: int_ior as f32,
            ext_ior: ext_ior as f32,
            diffuse_reflectance: diffuse.into(),
            specular_reflectance: self
                .color(&format!("{mk}.specular_reflectance"), specular)?
                .into(),
            nonlinear,
        })
    }

    fn texture(&self, key: &str, t: &TextureDesc) -> Result<Texture> {
        Ok(match t {
            TextureDesc::Constant(c) => Texture::Constant(self.color(key, *c)?),
            TextureDesc::Table(TextureTable::Checker(c)) => {
                let axis = |k: usize| -> Result<usize> {
                    match c.axes[k].as_str() {
                        "x" => Ok(0),
                        "y" => Ok(1),
                        "z" => Ok(2),
                        other => Err(self.err(
                            &format!("{key}.axes[{k}]"),
                            format!("expected \"x\", \"y\" or \"z\", got \"{other}\""),
                        )),
                    }
                };
                let axes = [axis(0)?, axis(1)?];
                if axes[0] == axes[1] {
                    return Err(self.err(&format!("{key}.axes"), "the two checker axes must differ"));
                }
                let size = self.positive(&format!("{key}.size"), c.size)?;
                if size < 1e-9 {
                    return Err(self.err(
                        &format!("{key}.size"),
                        format!("expected a square size >= 1e-9 m, got {size:e}"),
                    ));
                }
                Texture::Checker {
                    axes,
                    inv_size: (1.0 / size) as f32,
                    c0: self.color(&format!("{key}.color0"), c.color0)?,
                    c1: self.color(&format!("{key}.color1"), c.color1)?,
                }
            }
            TextureDesc::Table(TextureTable::Image(im)) => {
                let path = self.resolve(&im.file);
                let image = load_image(&path)
                    .map_err(|e| self.err(&format!("{key}.file"), format!("{}: {e}", path.display())))?;
                let s0 = self.positive(&format!("{key}.uv_scale[0]"), im.uv_scale[0])?;
                let s1 = self.positive(&format!("{key}.uv_scale[1]"), im.uv_scale[1])?;
                Texture::Image {
                    image: Arc::new(image),
                    scale: [s0 as f32, s1 as f32],
                }
            }
        })
    }

    pub(super) fn transform(&self, key: &str, list: &[TransformDesc]) -> Result<DMat4> {
        let mut m = DMat4::IDENTITY;
        for (i, t) in list.iter().enumerate() {
            let k = format!("{key}[{i}]");
            let mut step = DMat4::IDENTITY;
            let mut count = 0;
            if let Some(s) = &t.scale {
                count += 1;
                let s = match s {
                    ScaleDesc::Uniform(u) => DVec3::splat(*u),
                    ScaleDesc::PerAxis(a) => v3(*a),
                };
                if !s.is_finite() || s.min_element() <= 0.0 {
                    return Err(self.err(&format!("{k}.scale"), "expected finite scale factors > 0"));
                }
                step = DMat4::from_scale(s);
            }
            if let Some(r) = &t.rotate {
                count += 1;
                let axis = self.unit(&format!("{k}.rotate.axis"), r.axis)?;
                if !r.degrees.is_finite() {
                    return Err(self.err(&format!("{k}.rotate.degrees"), "expected a finite angle"));
                }
                step = DMat4::from_axis_angle(axis, r.degrees.to_radians());
            }
            if let Some(rows) = &t.matrix {
                count += 1;
                step = self.matrix(&format!("{k}.matrix"), rows)?;
            }
            if let Some(tr) = t.translate {
                count += 1;
                step = DMat4::from_translation(self.finite3(&format!("{k}.translate"), tr)?);
            }
            if count != 1 {
                return Err(self.err(
                    &k,
                    "each transform step needs exactly one of translate, rotate, scale, matrix",
                ));
            }
            m = step * m;
        }
        Ok(m)
    }

    /// A `matrix` step: finite, affine (last row 0 0 0 1) and invertible.
    fn matrix(&self, key: &str, rows: &[[f64; 4]; 4]) -> Result<DMat4> {
        if !rows.iter().flatten().all(|x| x.is_finite() && x.abs() <= 1e15) {
            return Err(self.err(key, "expected finite numbers within ±1e15"));
        }
        if rows[3] != [0.0, 0.0, 0.0, 1.0] {
            return Err(self.err(
                key,
                "expected an affine matrix: the last row must be [0, 0, 0, 1]",
            ));
        }
        let m = DMat4::from_cols_array_2d(rows).transpose();
        let lin = DMat3::from_mat4(m);
        let size = lin.x_axis.length() * lin.y_axis.length() * lin.z_axis.length();
        if lin.determinant().is_nan() || lin.determinant().abs() <= 1e-12 * size || size == 0.0 {
            return Err(self.err(key, "expected an invertible matrix"));
        }
        Ok(m)
    }

    fn xf_mesh(&self, mut m: Mesh, xf: &DMat4) -> Mesh {
        if *xf == DMat4::IDENTITY {
            return m;
        }
        for p in &mut m.positions {
            let q = xf.transform_point3(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            *p = [q.x as f32, q.y as f32, q.z as f32];
        }
        let nm = DMat3::from_mat4(*xf).inverse().transpose();
        if let Some(ns) = &mut m.normals {
            for n in ns {
                let q = (nm * DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64)).normalize_or(DVec3::Y);
                *n = [q.x as f32, q.y as f32, q.z as f32];
            }
        }
        if DMat3::from_mat4(*xf).determinant() < 0.0 {
            // A mirroring transform would turn the mesh inside out: keep outward winding.
            for t in &mut m.indices {
                t.swap(1, 2);
            }
        }
        m
    }
}
