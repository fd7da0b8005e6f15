//! The boundary event: what a ray does at a true hit on a dielectric surface.
//! The one place that decides entering vs leaving, the index pair, the
//! interior list after the crossing and the medium the ray travels in next.
use super::{Coincident, InteriorList, NestedStrategy};
use crate::scene::{Material, RenderScene, Solid};
use glam::Vec3A as V3;

/// What the nested rule needs of a scene: its priority solids (rank, index,
/// absorption) and the ambient index. No Embree: property tests build it
/// from bare [`Solid`]s.
#[derive(Debug, Clone, Copy)]
pub struct Nesting<'a> {
    /// The scene's solids, indexed by solid index.
    pub solids: &'a [Solid],
    /// Index of the medium outside every solid.
    pub ambient_ior: f32,
}

impl<'a> Nesting<'a> {
    /// The nesting view of `scene`.
    #[inline]
    pub fn of(scene: &'a RenderScene) -> Self {
        Nesting {
            solids: &scene.solids,
            ambient_ior: scene.ambient_ior,
        }
    }
}

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

    /// The list a transmitted ray carries, taken (`None`: the same as before).
    pub fn into_transmitted(self) -> Option<InteriorList> {
        self.transmitted
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
fn ior_of(nesting: Nesting<'_>, list: &InteriorList) -> f32 {
    list.top()
        .map(|s| nesting.solids[s as usize].ior)
        .unwrap_or(nesting.ambient_ior)
}

/// Absorption coefficient (per scene unit, per channel) of the medium a ray
/// inside `list` travels through; `None` for a clear medium.
#[inline]
pub fn medium_of(nesting: Nesting<'_>, list: &InteriorList) -> Option<V3> {
    let s = list.top()?;
    let sigma = nesting.solids[s as usize].sigma_a;
    (sigma.max_element() > 0.0).then_some(sigma)
}

/// May a straight ray continue on its own line through an index-matched
/// boundary of `scene` (`ray::spawn_transmitted`)? Not when the scene has
/// mesh solids: a line keeps the aim of the ray it continues, and a ray aimed
/// exactly at a mesh vertex meets no triangle there (Embree's robust mode
/// closes edge leaks, not vertex ones), so a line kept from the eye leaked
/// into a solid far along it where a ray spawned from the last hit did not.
/// Analytic solids do not leak, and their roots are only consistent from one
/// origin (the reason for keeping the line).
pub fn keeps_line(scene: &RenderScene) -> bool {
    scene.medium.is_none()
        && !scene
            .solids
            .iter()
            .any(|s| matches!(scene.geoms[s.geom as usize].shape, crate::scene::Shape::Mesh(_)))
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
#[inline]
pub fn boundary(
    nesting: Nesting<'_>,
    strategy: NestedStrategy,
    material: &Material,
    front: bool,
    coincident: &Coincident,
    list: &mut InteriorList,
) -> Option<Boundary> {
    // The common case, inline: an interface with nothing coincident leaves
    // the list as it is (the general case builds and moves lists).
    if let (Material::Interface { int_ior, ext_ior }, true) = (material, coincident.is_empty()) {
        let (n1, n2) = if front {
            (*ext_ior, *int_ior)
        } else {
            (*int_ior, *ext_ior)
        };
        return Some(Boundary {
            n1,
            n2,
            entering: front,
            transmitted: None,
        });
    }
    boundary_of_any(nesting, strategy, material, front, coincident, list)
}

/// [`boundary`] for every material and coincidence.
#[inline(never)]
fn boundary_of_any(
    nesting: Nesting<'_>,
    strategy: NestedStrategy,
    material: &Material,
    front: bool,
    coincident: &Coincident,
    list: &mut InteriorList,
) -> Option<Boundary> {
    // Solid surfaces coincident with the true hit are crossed with it.
    let with_coincident = |mut l: InteriorList| {
        for (c, rank, entering) in coincident.iter() {
            if entering {
                l.insert(c, rank)
            } else {
                l.remove(c)
            }
        }
        l
    };
    match *material {
        Material::Interface { int_ior, ext_ior } | Material::RoughInterface { int_ior, ext_ior, .. } => {
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
        Material::Solid(s) | Material::RoughSolid { solid: s, .. } => {
            let solid = &nesting.solids[s as usize];
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
                let n1 = ior_of(nesting, list);
                after.insert(s, solid.rank);
                after = with_coincident(after);
                let n2 = if coincident.is_empty() {
                    solid.ior
                } else {
                    ior_of(nesting, &after)
                };
                (n1, n2)
            } else {
                // Leaving O: from O to the highest remaining (or ambient).
                after.remove(s);
                after = with_coincident(after);
                (solid.ior, ior_of(nesting, &after))
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

#[cfg(test)]
mod tests {
    //! The nested rule without Embree: solids are intervals of a line
    //! (closed solids cut by one ray), crossed in order by a ray that skips
    //! false hits as the filter does (`apply_rejected` up to and at the true
    //! hit, accepted surfaces at the same point as coincident faces), and
    //! meets every true hit with [`boundary`]. Checked against brute force:
    //! which intervals contain the point just before and just after.
    use super::*;
    use crate::dielectric::{apply_rejected, Rejected, NEAR_CAPACITY};
    use glam::DVec3;
    use proptest::prelude::*;

    fn solid(rank: u32, ior: f32) -> Solid {
        Solid {
            name: format!("s{rank}"),
            geom: rank,
            priority: rank as i64,
            rank,
            ior,
            sigma_a: V3::ZERO,
            aabb: (DVec3::ZERO, DVec3::ZERO),
        }
    }

    /// One surface of the line: solid, position, entering.
    #[derive(Debug, Clone, Copy)]
    struct Surface {
        solid: u32,
        x: i32,
        entering: bool,
    }

    /// Top solid's index at x (brute force), or the ambient index.
    fn brute_ior(solids: &[Solid], spans: &[(i32, i32)], x: f64) -> f32 {
        spans
            .iter()
            .enumerate()
            .filter(|(_, &(a, b))| (a as f64) < x && x < b as f64)
            .max_by_key(|(i, _)| solids[*i].rank)
            .map(|(i, _)| solids[i].ior)
            .unwrap_or(1.0)
    }

    fn brute_inside(spans: &[(i32, i32)], x: f64) -> Vec<u32> {
        (0..spans.len() as u32)
            .filter(|&i| (spans[i as usize].0 as f64) < x && x < spans[i as usize].1 as f64)
            .collect()
    }

    /// Cross every surface from x = -inf; `nesting_rule = false` is the
    /// known-wrong variant: every hit is true. Returns the first disagreement.
    fn walk(solids: &[Solid], spans: &[(i32, i32)], pick: usize, nesting_rule: bool) -> Result<(), String> {
        let nesting = Nesting {
            solids,
            ambient_ior: 1.0,
        };
        let mut surfaces: Vec<Surface> = Vec::new();
        for (i, &(a, b)) in spans.iter().enumerate() {
            surfaces.push(Surface {
                solid: i as u32,
                x: a,
                entering: true,
            });
            surfaces.push(Surface {
                solid: i as u32,
                x: b,
                entering: false,
            });
        }
        let mut list = InteriorList::new();
        let mut x_cur = i32::MIN;
        loop {
            let p0 = if nesting_rule {
                list.top_rank().unwrap_or(0)
            } else {
                0
            };
            let rank = |s: &Surface| solids[s.solid as usize].rank;
            let ahead: Vec<Surface> = surfaces.iter().copied().filter(|s| s.x > x_cur).collect();
            let hit_x = ahead.iter().filter(|s| rank(s) >= p0).map(|s| s.x).min();
            let limit = hit_x.map(|x| x as f32).unwrap_or(f32::INFINITY) + 0.5;
            let mut rejected: Vec<Rejected> = ahead
                .iter()
                .filter(|s| rank(s) < p0)
                .map(|s| Rejected {
                    solid: s.solid,
                    rank: rank(s),
                    prim: 0,
                    t: s.x as f32,
                    entering: s.entering,
                    near_edge: false,
                })
                .collect();
            apply_rejected(&mut list, &mut rejected, limit, 0.25);
            let Some(hx) = hit_x else {
                return if list.is_empty() {
                    Ok(())
                } else {
                    Err(format!("left every solid with {:?} in the list", list.sorted()))
                };
            };
            // The true hit (Embree returns any one of equal t) and the
            // accepted surfaces at the same point.
            let at: Vec<Surface> = ahead
                .iter()
                .copied()
                .filter(|s| s.x == hx && rank(s) >= p0)
                .collect();
            let hit = at[pick % at.len()];
            let mut coincident = Coincident::default();
            for s in &at {
                if s.solid != hit.solid {
                    coincident.push(s.solid, rank(s), s.entering);
                }
            }
            let b = boundary(
                nesting,
                NestedStrategy::Filter,
                &Material::Solid(hit.solid),
                hit.entering,
                &coincident,
                &mut list,
            )
            .ok_or("a solid is a dielectric")?;
            let (n1, n2) = (b.n1, b.n2);
            b.transmit(&mut list);
            let (before, after) = (hx as f64 - 0.5, hx as f64 + 0.5);
            let want = (brute_ior(solids, spans, before), brute_ior(solids, spans, after));
            if (n1, n2) != want {
                return Err(format!(
                    "at x = {hx}: indices {:?}, brute force {want:?}",
                    (n1, n2)
                ));
            }
            if list.sorted() != brute_inside(spans, after) {
                return Err(format!(
                    "after x = {hx}: list {:?}, brute force {:?}",
                    list.sorted(),
                    brute_inside(spans, after)
                ));
            }
            x_cur = hx;
        }
    }

    /// Random priority sets: 1-6 solids, ranks a random permutation, indices
    /// distinct per rank; spans on a coarse grid so that faces often coincide.
    fn scenes() -> impl Strategy<Value = (Vec<Solid>, Vec<(i32, i32)>, usize)> {
        (1usize..=6)
            .prop_flat_map(|n| {
                (
                    Just((0..n as u32).collect::<Vec<u32>>()).prop_shuffle(),
                    proptest::collection::vec((0i32..12, 1i32..8), n),
                    0usize..4,
                )
            })
            .prop_map(|(ranks, spans, pick)| {
                let solids = ranks.iter().map(|&r| solid(r, 1.1 + 0.1 * r as f32)).collect();
                let spans = spans.into_iter().map(|(a, len)| (a, a + len)).collect();
                (solids, spans, pick)
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn boundary_events_match_point_classification((solids, spans, pick) in scenes()) {
            // More than NEAR_CAPACITY surfaces at one point overflow the
            // filter's records, and trace() re-does that query by re-casting
            // (tested end to end in tests/nested.rs), which this line model
            // does not cover: such scenes are rejected, counted by proptest.
            let most_at_one_point = spans
                .iter()
                .flat_map(|&(a, b)| [a, b])
                .map(|x| spans.iter().filter(|&&(a, b)| a == x || b == x).count())
                .max()
                .unwrap_or(0);
            prop_assume!(most_at_one_point <= NEAR_CAPACITY);
            prop_assert_eq!(walk(&solids, &spans, pick, true), Ok(()));
        }
    }

    /// The same check has power: with every hit taken as true (no nested
    /// rule) a glass (rank 1) holding water (rank 0) that overlaps it gets
    /// the wrong indices, while the rule gets them right.
    #[test]
    fn the_check_fails_without_the_nested_rule() {
        let solids = [solid(0, 1.33), solid(1, 1.5)];
        let spans = [(2, 8), (0, 6)]; // water 2..8 overlaps glass 0..6
        assert_eq!(walk(&solids, &spans, 0, true), Ok(()));
        let wrong = walk(&solids, &spans, 0, false);
        assert!(wrong.is_err(), "{wrong:?}");
    }
}
