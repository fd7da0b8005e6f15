//! [`Counters`]: every event count snell keeps, one type from a single query
//! up to a whole render. A query, a sample, a tile and a render each hold one;
//! they add up with `+=` (sums, except `max_list_depth`, which is a maximum),
//! and serialise with serde under the keys of the stats JSON. A new counter
//! is a new field here and the line that counts it.
use serde::Serialize;
use std::ops::AddAssign;

/// Event counts. Units: events (rays, hits, samples), never time.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    /// Camera samples taken.
    pub samples: u64,
    /// Nearest-hit Embree queries (including re-casts past false hits and touches).
    pub queries: u64,
    /// Occlusion (shadow) queries.
    pub shadow_rays: u64,
    /// Distinct false crossings of nested dielectrics (hits on a solid ranked
    /// below the ray's top solid), skipped.
    pub false_hits: u64,
    /// Calls of the false-hit filter inside Embree.
    pub filter_calls: u64,
    /// Filtered queries that recorded more false hits than the filter holds
    /// and were finished by re-casting.
    pub fallbacks: u64,
    /// Deepest interior list seen (a maximum, not a sum).
    pub max_list_depth: u64,
    /// Interior lists that outgrew their inline storage.
    pub list_spills: u64,
    /// Memberships decided by point-in-solid near a true hit, where the list
    /// and the queries disagreed with it (`dielectric::settle_child`: another
    /// solid's surface within the spawn offset of the hit).
    pub settled: u64,
    /// Total internal reflections.
    pub tir: u64,
    /// Samples whose radiance was NaN or infinite (counted black).
    #[serde(rename = "nan_or_inf_samples")]
    pub nan: u64,
    /// Path segments (straight or curved) traced.
    pub segments: u64,
    /// Straight chords cast for curved rays in a gradient-index medium.
    pub chords: u64,
    /// Curved rays whose integrator failed (the path ended black).
    pub grin_failures: u64,
    /// Path segments that entered a gradient-index medium's bounds.
    pub medium_segments: u64,
    /// Field evaluations (n and ∇n at one point) for curved rays.
    pub field_evals: u64,
    /// Lanes of the path tracer's nearest-hit packets sent to Embree (packets
    /// × their width): `packet_lanes / packet_slots` is the share of the
    /// vector lanes that carried a ray.
    pub packet_slots: u64,
    /// Rays those packets carried.
    pub packet_lanes: u64,
    /// Lanes of the path tracer's shadow packets (packets × width).
    pub shadow_packet_slots: u64,
    /// Shadow rays those packets carried.
    pub shadow_packet_lanes: u64,
    /// Lanes of the vector shading kernel's calls (calls × packet width):
    /// `shade_lanes / shade_slots` is the share of them that shaded a path.
    pub shade_slots: u64,
    /// Paths those calls shaded.
    pub shade_lanes: u64,
    /// Lanes of the path tracer's packets that the analytic set's vector
    /// kernels answered (nearest hits and shadow rays).
    pub set_lanes: u64,
    /// Those answered again by its scalar f64 code: `set_replayed_lanes /
    /// set_lanes` is the share the kernels could not be sure of.
    pub set_replayed_lanes: u64,
    /// Light samples drawn for next-event estimation (at non-delta vertices
    /// that reflect something, before the last depth); those facing away
    /// from the surface or the light cast no shadow ray.
    pub nee_draws: u64,
    /// Paths of the path tracer that ended by leaving the scene.
    pub ended_escaped: u64,
    /// Paths that ended at a hit at the maximum depth.
    pub ended_max_depth: u64,
    /// Paths that Russian roulette ended.
    pub ended_roulette: u64,
    /// Paths that ended with nothing left to carry: a black surface (a
    /// light's back, a black reflectance), zero throughput, or no sampled
    /// direction.
    pub ended_absorbed: u64,
}

impl Counters {
    /// Every Embree query: nearest-hit queries plus shadow rays.
    pub fn rays(&self) -> u64 {
        self.queries + self.shadow_rays
    }
}

impl AddAssign for Counters {
    fn add_assign(&mut self, o: Counters) {
        // Destructured so that a new field cannot be forgotten here.
        let Counters {
            samples,
            queries,
            shadow_rays,
            false_hits,
            filter_calls,
            fallbacks,
            max_list_depth,
            list_spills,
            settled,
            tir,
            nan,
            segments,
            chords,
            grin_failures,
            medium_segments,
            field_evals,
            packet_slots,
            packet_lanes,
            shadow_packet_slots,
            shadow_packet_lanes,
            shade_slots,
            shade_lanes,
            set_lanes,
            set_replayed_lanes,
            nee_draws,
            ended_escaped,
            ended_max_depth,
            ended_roulette,
            ended_absorbed,
        } = o;
        self.samples += samples;
        self.queries += queries;
        self.shadow_rays += shadow_rays;
        self.false_hits += false_hits;
        self.filter_calls += filter_calls;
        self.fallbacks += fallbacks;
        self.max_list_depth = self.max_list_depth.max(max_list_depth);
        self.list_spills += list_spills;
        self.settled += settled;
        self.tir += tir;
        self.nan += nan;
        self.segments += segments;
        self.chords += chords;
        self.grin_failures += grin_failures;
        self.medium_segments += medium_segments;
        self.field_evals += field_evals;
        self.packet_slots += packet_slots;
        self.packet_lanes += packet_lanes;
        self.shadow_packet_slots += shadow_packet_slots;
        self.shadow_packet_lanes += shadow_packet_lanes;
        self.shade_slots += shade_slots;
        self.shade_lanes += shade_lanes;
        self.set_lanes += set_lanes;
        self.set_replayed_lanes += set_replayed_lanes;
        self.nee_draws += nee_draws;
        self.ended_escaped += ended_escaped;
        self.ended_max_depth += ended_max_depth;
        self.ended_roulette += ended_roulette;
        self.ended_absorbed += ended_absorbed;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn add_sums_and_keeps_the_deepest_list() {
        let a = Counters {
            queries: 3,
            max_list_depth: 5,
            nan: 1,
            ..Default::default()
        };
        let mut b = Counters {
            queries: 4,
            max_list_depth: 2,
            ..Default::default()
        };
        b += a;
        assert_eq!((b.queries, b.max_list_depth, b.nan), (7, 5, 1));
        let json = serde_json::to_value(b).unwrap();
        assert_eq!(json["nan_or_inf_samples"], 1);
        assert_eq!(json["queries"], 7);
    }
}
