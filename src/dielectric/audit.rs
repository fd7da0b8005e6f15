//! The interior-list audit: follow rays through a scene and compare, on every
//! segment between true hits, the medium the interior list claims (its
//! highest-ranked solid, which cannot change between true hits) with an
//! independent point-in-solid classification of the segment's midpoint; and
//! check that a ray which has left everything has an empty list.
use crate::dielectric::TraceCounters;
use crate::error::Result;
use crate::integrator::refraction_path;
use crate::scene::RenderScene;
use glam::{DVec3, Vec3A as V3};

/// Outcome of auditing one ray.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RayAudit {
    pub segments: u32,
    /// Segments whose claimed interior list differs from the point-in-solid truth.
    pub mismatches: u32,
    /// The ray escaped with a non-empty list (an entry gained and never lost).
    pub left_nonempty: bool,
}

/// Audit one ray from `org` (the start list is found by point-in-solid tests).
pub fn audit_ray(scene: &RenderScene, org: V3, dir: V3, counters: &mut TraceCounters) -> Result<RayAudit> {
    let to_d = |v: V3| DVec3::new(v.x as f64, v.y as f64, v.z as f64);
    let start = scene.solids_containing(to_d(org));
    let path = refraction_path(scene, org, dir, &start, 512, counters)?;
    let mut a = RayAudit::default();
    let mut prev = org;
    let mut claimed = start.clone();
    claimed.sort_unstable();
    for e in &path.events {
        if (e.point - prev).length() > 1e-4 {
            a.segments += 1;
            let mid = to_d((prev + e.point) * 0.5);
            if medium(scene, &scene.solids_containing(mid)) != medium(scene, &claimed) {
                a.mismatches += 1;
            }
        }
        prev = e.point;
        claimed = e.list_after.clone();
    }
    a.left_nonempty = path.escaped && !path.final_list.is_empty();
    Ok(a)
}

/// The solid whose medium a point in all of `solids` is in: the highest rank.
fn medium(scene: &RenderScene, solids: &[u32]) -> Option<u32> {
    solids
        .iter()
        .copied()
        .max_by_key(|&s| scene.solids[s as usize].rank)
}
