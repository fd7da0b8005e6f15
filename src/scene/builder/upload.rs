//! Solids ranked, overlap found, and every pending geometry uploaded to
//! Embree with its record.
use super::{Builder, Pending};
use crate::embree::{Device, Scene, SceneBuilder, SceneFlags};
use crate::error::Result;
use crate::scene::model::{Containment, GeomRecord, Material, Shape, Solid};
use crate::scene::shapes::{AnalyticSet, MAX_SET_PRIMITIVES};

/// What the upload hands back to the scene.
pub(super) struct Uploaded {
    pub embree: Scene,
    pub geoms: Vec<GeomRecord>,
    pub solids: Vec<Solid>,
    pub containment: Vec<Containment>,
    pub rank_by_geom: Vec<u32>,
    pub solid_by_geom: Vec<Option<u32>>,
    pub has_overlap: bool,
    pub masked_solids: Vec<u32>,
    pub analytic_set: Option<AnalyticSet>,
}

/// Every pending mesh with an analytic twin (a rect) replaced by the twin,
/// when every mesh of the scene has one and the scene's analytic
/// primitives, the twins included, are few enough for an [`AnalyticSet`]:
/// the set then intersects them too, and the scene, left without meshes,
/// answers packets without Embree. Else all stay meshes (an
/// [`AnalyticSet`] is all or nothing; and while other meshes keep Embree's
/// packet query, a rect costs more in the set's lane loop than as two more
/// triangles there). The emitters were made of the meshes before: light
/// sampling does not change.
pub(super) fn analytic_rects(pending: &mut [Pending]) {
    let other_meshes = pending
        .iter()
        .any(|p| matches!(p.shape, Shape::Mesh(_)) && p.analytic_twin.is_none());
    if other_meshes {
        return;
    }
    let twins = pending.iter().filter(|p| p.analytic_twin.is_some()).count();
    let analytic: usize = pending
        .iter()
        .map(|p| match &p.shape {
            Shape::Analytic(a) => a.prims() as usize,
            Shape::Mesh(_) => 0,
        })
        .sum();
    if twins == 0 || twins + analytic > MAX_SET_PRIMITIVES {
        return;
    }
    for p in pending {
        if let Some(a) = p.analytic_twin.take() {
            p.shape = Shape::Analytic(a);
        }
    }
}

impl Builder<'_> {
    /// Rank the solids by (priority, declaration order), find whether any
    /// two may overlap (bounds intersect), and build the Embree scene (with
    /// a twin of its meshes alone when `set_wanted` and the analytic shapes
    /// are few enough for an [`AnalyticSet`]).
    pub(super) fn upload(&self, pending: Vec<Pending>, set_wanted: bool) -> Result<Uploaded> {
        // Solids: ranks by (priority, declaration order).
        let mut order: Vec<usize> = (0..pending.len())
            .filter(|&i| pending[i].solid.is_some())
            .collect();
        order.sort_by_key(|&i| (pending[i].solid.as_ref().map(|s| s.priority).unwrap_or(0), i));
        let mut rank_of = vec![u32::MAX; pending.len()];
        for (r, &i) in order.iter().enumerate() {
            rank_of[i] = r as u32;
        }
        let has_solids = !order.is_empty();
        let mut has_overlap = false;
        for (a, &i) in order.iter().enumerate() {
            for &j in &order[a + 1..] {
                let (pa, pb) = (
                    &pending[i].solid.as_ref().unwrap().aabb,
                    &pending[j].solid.as_ref().unwrap().aabb,
                );
                if pa.0.cmple(pb.1).all() && pb.0.cmple(pa.1).all() {
                    has_overlap = true;
                }
            }
        }

        // The context-filter flag costs nothing for queries without a filter
        // (Embree checks it only where a filter is installed), so it is
        // set whenever a filter could be needed, whatever strategy renders.
        let flags = SceneFlags {
            context_filter: has_overlap,
            robust: self.opts.robust.unwrap_or(has_solids),
        };
        let device = Device::new("")?;
        // Analytic solids of rank < 31 with an exact point-in-solid test get
        // geometry mask bit `rank`; a filtered query then leaves those ranked
        // below its P0 out of the traversal by its ray mask, and settles them
        // by point-in-solid instead (`dielectric::trace`).
        let use_masks = has_overlap && device.ray_masks();
        let mut masked_solids = Vec::new();
        let mut masked_geoms = Vec::new();
        let mut eb = SceneBuilder::new(&device, flags, self.opts.quality)?;
        // Geometry ids follow `pending`'s order (asserted below).
        let mut analytic_set = set_wanted
            .then(|| {
                AnalyticSet::try_new(pending.iter().enumerate().filter_map(|(i, p)| match &p.shape {
                    Shape::Analytic(a) => Some((i as u32, *a)),
                    Shape::Mesh(_) => None,
                }))
            })
            .flatten();
        if analytic_set.is_some() {
            eb = eb.with_meshes_only()?;
        }
        let mut geoms = Vec::with_capacity(pending.len());
        let mut solids = Vec::new();
        let mut containment = Vec::new();
        let mut rank_by_geom = Vec::new();
        let mut solid_by_geom = Vec::new();
        for (i, p) in pending.into_iter().enumerate() {
            let id = match &p.shape {
                Shape::Mesh(m) => eb.add_triangles(&m.positions, &m.indices)?,
                Shape::Analytic(a) => {
                    let maskable = use_masks
                        && rank_of[i] < 31
                        && p.solid
                            .as_ref()
                            .is_some_and(|s| matches!(&s.containment, Containment::Analytic(c) if c.contains(glam::DVec3::ZERO).is_some()));
                    if maskable {
                        masked_solids.push((rank_of[i], solids.len() as u32));
                        masked_geoms.push((i as u32, rank_of[i]));
                        eb.add_user_masked(Box::new(*a), 1 << rank_of[i])?
                    } else {
                        eb.add_user(Box::new(*a))?
                    }
                }
            };
            debug_assert_eq!(id as usize, geoms.len());
            let mut material = p.material;
            let mut solid_idx = None;
            if let Some(s) = p.solid {
                let si = solids.len() as u32;
                solids.push(Solid {
                    name: p.name.clone(),
                    geom: id,
                    priority: s.priority,
                    rank: rank_of[i],
                    ior: s.ior as f32,
                    sigma_a: s.sigma_a,
                    aabb: s.aabb,
                });
                containment.push(s.containment);
                // The placeholder carries a rough surface's distribution.
                material = match material {
                    Material::RoughSolid { distribution, .. } => Material::RoughSolid {
                        solid: si,
                        distribution,
                    },
                    _ => Material::Solid(si),
                };
                solid_idx = Some(si);
            }
            rank_by_geom.push(rank_of[i]);
            solid_by_geom.push(solid_idx);
            geoms.push(GeomRecord {
                name: p.name,
                shape: p.shape,
                material,
                emission: p.emission,
                emission_two_sided: p.emission_two_sided,
                light: p.light,
            });
        }
        // The set sees what Embree sees of the masked solids.
        if let Some(set) = &mut analytic_set {
            set.hide_ranks(&masked_geoms);
        }
        let embree = eb.commit()?;
        Ok(Uploaded {
            embree,
            geoms,
            solids,
            containment,
            rank_by_geom,
            solid_by_geom,
            has_overlap,
            analytic_set,
            masked_solids: {
                masked_solids.sort_unstable();
                masked_solids.into_iter().map(|(_, s)| s).collect()
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::shapes::Analytic;
    use crate::scene::{load_scene_str, BuildOptions, RenderScene, Shape};

    /// `balls` spheres above a ground rect, lit by a rect light.
    fn scene(balls: usize, extra: &str, opts: &BuildOptions) -> RenderScene {
        let mut text = format!(
            r#"
{extra}
[camera]
position = [0.0, 1.0, 6.0]
target = [0.0, 0.5, 0.0]
fov = 40.0
[film]
width = 8
height = 8
spp = 1
[[lights]]
type = "rect"
center = [0.0, 3.0, 0.0]
normal = [0.0, -1.0, 0.0]
u_axis = [1.0, 0.0, 0.0]
size = [1.0, 0.5]
radiance = [5.0, 5.0, 5.0]
[[objects]]
name = "ground"
shape = {{ type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [8.0, 8.0] }}
material = {{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }}
"#
        );
        for i in 0..balls {
            text += &format!(
                r#"
[[objects]]
name = "ball{i}"
shape = {{ type = "sphere", center = [{}, 0.5, 0.0], radius = 0.4 }}
material = {{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }}
"#,
                i as f64 - 3.0
            );
        }
        load_scene_str("rects.toml", &text, std::path::Path::new("."), opts).unwrap()
    }

    /// How many rects are analytic, and how many meshes are left.
    fn rects_and_meshes(s: &RenderScene) -> (usize, usize) {
        let rects = s
            .geoms
            .iter()
            .filter(|g| matches!(g.shape, Shape::Analytic(Analytic::Rect(_))))
            .count();
        let meshes = s
            .geoms
            .iter()
            .filter(|g| matches!(g.shape, Shape::Mesh(_)))
            .count();
        (rects, meshes)
    }

    /// Rects are analytic only in a scene built for the analytic set (the
    /// path tracer, no medium, the option on) whose primitives, rects
    /// included, stay within its limit; then the set holds them. (Not in a
    /// `[warp]` scene: tests/warp_render.rs, above the warp renderer.)
    #[test]
    fn rects_are_analytic_only_for_the_analytic_set() {
        let set = BuildOptions::default();
        let s = scene(3, "", &set);
        assert_eq!(rects_and_meshes(&s), (2, 0));
        assert_eq!(s.analytic_set.as_ref().map(|a| a.len()), Some(5));
        // Six balls and two rects: eight primitives, the limit.
        assert_eq!(rects_and_meshes(&scene(6, "", &set)), (2, 0));
        // Seven: the rects stay meshes, the balls make the set.
        let s = scene(7, "", &set);
        assert_eq!(rects_and_meshes(&s), (0, 2));
        assert_eq!(s.analytic_set.as_ref().map(|a| a.len()), Some(7));
        let off = BuildOptions {
            analytic_set: false,
            ..BuildOptions::default()
        };
        assert_eq!(rects_and_meshes(&scene(3, "", &off)), (0, 2));
        // Another mesh keeps Embree's query: the rects stay triangles in it.
        let cube = "[[objects]]\nshape = { type = \"box\", center = [0.0, 2.0, 0.0], size = [0.5, 0.5, 0.5] }\nmaterial = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }";
        assert_eq!(rects_and_meshes(&scene(1, cube, &set)), (0, 3));
        let whitted = "[integrator]\ntype = \"whitted\"";
        assert_eq!(rects_and_meshes(&scene(3, whitted, &set)), (0, 2));
    }
}
