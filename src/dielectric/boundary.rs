//! The boundary event: what a ray does at a true hit on a dielectric surface.
//! The one place that decides entering vs leaving, the index pair, the
//! interior list after the crossing and the medium the ray travels in next.
use super::{Coincident, InteriorList, NestedStrategy};
use crate::scene::{Material, RenderScene};
use glam::Vec3A as V3;

/// A ray at a true hit on a dielectric surface (an interface or a priority
/// solid): the indices on both sides and the list a transmitted ray carries.
/// A reflected ray keeps the list [`boundary`] left in place.
#[derive(Debug, Clone, PartialEq)]
pub struct Boundary {
    /// Index on the side the ray arrives from.
    pub n1: f32,
    /// Index on the far side.
    pub n2: f32,
    /// The ray enters the solid it hit (for an interface: it arrives on the
    /// side its normal points to, i.e. from outside).
    pub entering: bool,
    /// The interior list after transmission, when it differs from the list
    /// before (a solid, or an interface with coincident solid faces).
    transmitted: Option<InteriorList>,
}

impl Boundary {
    /// The list a transmitted ray carries (`None`: the same as before).
    pub fn transmitted_list(&self) -> Option<&InteriorList> {
        self.transmitted.as_ref()
    }

    /// Move `list` across the boundary (the ray is transmitted).
    pub fn transmit(self, list: &mut InteriorList) {
        if let Some(l) = self.transmitted {
            *list = l;
        }
    }
}

/// The index of the medium a ray inside `list` travels in: its top solid's,
/// or the scene's ambient index outside every solid.
#[inline]
fn ior_of(scene: &RenderScene, list: &InteriorList) -> f32 {
    list.top()
        .map(|s| scene.solids[s as usize].ior)
        .unwrap_or(scene.ambient_ior)
}

/// Absorption coefficient (per scene unit, per channel) of the medium a ray
/// inside `list` travels through; `None` for a clear medium.
#[inline]
pub fn medium_of(scene: &RenderScene, list: &InteriorList) -> Option<V3> {
    let s = list.top()?;
    let sigma = scene.solids[s as usize].sigma_a;
    (sigma.max_element() > 0.0).then_some(sigma)
}

/// The boundary event at a true hit with material `material`, met from the
/// side of its geometric normal when `front` (`ray::front_facing`), with the
/// solid surfaces `coincident` with the hit, for a ray inside `list`.
/// `None` when the material is not dielectric.
///
/// Updates `list` for the hit itself: a ray that leaves solid O while O is
/// not in the list never saw its entry (a ray through a mesh vertex, where
/// Embree's robust mode can leak), so O goes in first. Sound by the
/// orientation check at load (normals point out of every solid). The toggle
/// strategy (the paper's) decides entering by membership instead and is left
/// as it is.
pub fn boundary(
    scene: &RenderScene,
    strategy: NestedStrategy,
    material: &Material,
    front: bool,
    coincident: &Coincident,
    list: &mut InteriorList,
) -> Option<Boundary> {
    let coincident = coincident.as_slice();
    // Solid surfaces coincident with the true hit are crossed with it.
    let with_coincident = |mut l: InteriorList| {
        for &(c, rank, entering) in coincident {
            if entering {
                l.insert(c, rank)
            } else {
                l.remove(c)
            }
        }
        l
    };
    match *material {
        Material::Interface { int_ior, ext_ior } => {
            let transmitted = (!coincident.is_empty()).then(|| with_coincident(list.clone()));
            let (n1, n2) = if front {
                (ext_ior, int_ior)
            } else {
                (int_ior, ext_ior)
            };
            Some(Boundary {
                n1,
                n2,
                entering: front,
                transmitted,
            })
        }
        Material::Solid(s) => {
            let solid = &scene.solids[s as usize];
            let entering = match strategy {
                NestedStrategy::Toggle => !list.contains(s),
                _ => {
                    if !front {
                        list.insert(s, solid.rank); // repair a missed entry
                    }
                    front
                }
            };
            let mut after = list.clone();
            let (n1, n2) = if entering {
                // Entering O: from the highest in the list (or ambient) to O
                // (O is the highest after entering: its hit is true). With
                // coincident surfaces: to the highest of the list after all of them.
                let n1 = ior_of(scene, list);
                after.insert(s, solid.rank);
                after = with_coincident(after);
                let n2 = if coincident.is_empty() {
                    solid.ior
                } else {
                    ior_of(scene, &after)
                };
                (n1, n2)
            } else {
                // Leaving O: from O to the highest remaining (or ambient).
                after.remove(s);
                after = with_coincident(after);
                (solid.ior, ior_of(scene, &after))
            };
            Some(Boundary {
                n1,
                n2,
                entering,
                transmitted: Some(after),
            })
        }
        _ => None,
    }
}
