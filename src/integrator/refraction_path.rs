//! A deterministic refraction-only path through dielectrics, for tests and
//! audits that compare strategies and check interior lists, its true hits
//! found ray by ray or as the path tracer's wavefront finds them
//! ([`Queries`]).
use super::cast::intersect_packet;
use super::Tracer;
use crate::counters::Counters;
use crate::dielectric::{self, Coincident, InteriorList, TrueHit};
use crate::embree::{Packet16, RayPacket};
use crate::error::Result;
use crate::optics;
use crate::ray::{front_facing, offset_origin, spawn_transmitted, Ray};
use crate::scene::shapes::SetScratch;
use glam::Vec3A as V3;

/// One surface event along a deterministic refraction-only path.
#[derive(Debug, Clone)]
pub struct PathEvent {
    /// Embree geometry id of the surface.
    pub geom: u32,
    /// The reconstructed hit point.
    pub point: V3,
    /// Distance from the previous event (or the start).
    pub t: f32,
    /// Index on the side the ray arrived from.
    pub n1: f32,
    /// Index on the far side.
    pub n2: f32,
    /// Interior list (sorted solid indices) of the ray leaving this event.
    pub list_after: Vec<u32>,
    /// Total internal reflection: the ray was reflected.
    pub tir: bool,
    /// Origin of the ray leaving this event (offset off the surface, or the
    /// origin of the line it continues on: see `next_tnear`).
    pub next_org: V3,
    /// Unit direction of the ray leaving this event.
    pub next_dir: V3,
    /// Where the ray leaving this event starts on its line (0, or just past
    /// the hit for a ray continued on its own line through an index-matched
    /// boundary: then `next_org` is that line's origin, not the hit).
    pub next_tnear: f32,
}

/// How a refraction path finds each true hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Queries {
    /// `dielectric::trace`, ray by ray.
    Single,
    /// As the path tracer's wavefront: a (perhaps masked) packet query
    /// where `dielectric::packet_query` allows one, its hit checked and the
    /// masked solids settled, Embree's meshes completed by the analytic
    /// set; `trace` where not, or where the check refuses the packet's hit.
    Packets,
    /// The tests' known-wrong packet route: a masked query's hit stands
    /// without settling the solids its mask left out.
    #[cfg(test)]
    UnsettledPackets,
}

/// Follow a ray through dielectrics, always refracting (reflecting only under
/// total internal reflection), stopping at the first non-dielectric surface,
/// at a miss, or after `max_events`. Deterministic: used by tests and audits to
/// compare strategies and to check interior lists against point-in-solid tests.
pub fn refraction_path(
    tr: Tracer<'_>,
    org: V3,
    dir: V3,
    start: &[u32],
    max_events: usize,
    counters: &mut Counters,
) -> Result<RefractionPath> {
    refraction_path_with(tr, org, dir, start, max_events, counters, Queries::Single)
}

/// The true hit of `ray` inside `list` by the wavefront's packet query, as
/// `wavefront::stream` makes and checks it (in lane 0 of `packet`); `None`
/// when the wavefront would trace the ray alone (`list` may then hold
/// what the check settled, as in the wavefront).
fn packet_true_hit(
    tr: Tracer<'_>,
    ray: &Ray,
    list: &mut InteriorList,
    packet: &mut Packet16,
    scratch: &mut SetScratch<16>,
    c: &mut Counters,
    queries: Queries,
) -> Option<Option<TrueHit>> {
    let scene = tr.scene;
    let q = dielectric::packet_query(scene, tr.strategy, list)?;
    packet.clear();
    packet.set_ray(0, ray);
    packet.set_mask(0, q.mask);
    intersect_packet(scene, packet, false, scratch);
    packet.set_mask(0, u32::MAX);
    let hit = packet.hit(0);
    c.queries += 1;
    let known = !q.check
        || if list.is_empty() {
            dielectric::plain_hit_is_true(scene, tr.strategy, ray, hit.as_ref(), list)
        } else {
            let true_hit = dielectric::masked_hit_is_true(scene, ray, hit.as_ref(), list);
            // (The tests' wrong route leaves the masked solids as they were.)
            if true_hit && queries == Queries::Packets {
                dielectric::settle_masked_after(scene, q, ray, hit.as_ref().map(|h| h.t), list, c);
            }
            true_hit
        };
    known.then(|| {
        hit.map(|hit| TrueHit {
            hit,
            coincident: Coincident::NONE,
        })
    })
}

/// [`refraction_path`] with its true hits found by `queries`.
pub fn refraction_path_with(
    tr: Tracer<'_>,
    org: V3,
    dir: V3,
    start: &[u32],
    max_events: usize,
    counters: &mut Counters,
    queries: Queries,
) -> Result<RefractionPath> {
    let scene = tr.scene;
    let mut list = InteriorList::from_solids(&scene.solids, start);
    let mut ray = Ray::new(org, dir.normalize());
    let mut events = Vec::new();
    let mut packets =
        (queries != Queries::Single).then(|| (Box::new(Packet16::new()), SetScratch::<16>::f32()));
    for _ in 0..max_events {
        let packed = match &mut packets {
            Some((packet, scratch)) => {
                packet_true_hit(tr, &ray, &mut list, packet, scratch, counters, queries)
            }
            None => None,
        };
        let found = match packed {
            Some(found) => found,
            None => dielectric::trace(scene, tr.strategy, &ray, &mut list, counters)?,
        };
        let Some(TrueHit { hit, coincident }) = found else {
            return Ok(RefractionPath {
                events,
                final_list: list.sorted(),
                escaped: true,
            });
        };
        let sp = scene.surface_point(&ray, &hit);
        let rec = &scene.geoms[hit.geom_id as usize];
        let front = front_facing(sp.ng, ray.dir);
        let m = &rec.material;
        if !m.is_dielectric() {
            return Ok(RefractionPath {
                events,
                final_list: list.sorted(),
                escaped: false,
            });
        }
        let Some(c) = tr.boundary(m, front, &coincident, &mut list) else {
            unreachable!("a dielectric material, checked above");
        };
        let d = ray.dir.as_dvec3();
        let n = sp.ng.as_dvec3();
        let incident_side = if front { sp.ng } else { -sp.ng };
        let (wi, tir) = match optics::refract(d, n, c.n1 as f64, c.n2 as f64) {
            Some(t) => {
                if let Some(nl) = c.transmitted_list() {
                    list = nl.clone();
                }
                ((t.normalize()).as_vec3a(), false)
            }
            None => ((optics::reflect(d, n).normalize()).as_vec3a(), true),
        };
        let next = if tir {
            Ray::new(offset_origin(sp.p, incident_side), wi)
        } else {
            let line = (c.n1 == c.n2 && dielectric::keeps_line(scene)).then_some((&ray, hit.t));
            spawn_transmitted(sp.p, -incident_side, ray.dir, wi, (c.n1, c.n2), line)
        };
        tr.settle(&coincident, &next, &mut list, counters);
        events.push(PathEvent {
            geom: hit.geom_id,
            point: sp.p,
            t: hit.t - ray.tnear,
            n1: c.n1,
            n2: c.n2,
            list_after: list.sorted(),
            tir,
            next_org: next.org,
            next_dir: next.dir,
            next_tnear: next.tnear,
        });
        ray = next;
    }
    Ok(RefractionPath {
        events,
        final_list: list.sorted(),
        escaped: false,
    })
}

/// Result of [`refraction_path`].
#[derive(Debug, Clone)]
pub struct RefractionPath {
    /// The surface events, in order.
    pub events: Vec<PathEvent>,
    /// Interior list after the last event.
    pub final_list: Vec<u32>,
    /// The path ended by leaving the scene (no further hit).
    pub escaped: bool,
}
