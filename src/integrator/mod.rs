//! Integrators: an unbiased path tracer (next-event estimation with MIS for
//! area lights, Russian roulette, smooth dielectrics with exact Fresnel and
//! TIR, nested priorities) and a Whitted tracer for quick previews.
//!
//! Depth follows Mitsuba: `max_depth` counts path segments including the
//! camera ray (1 = directly visible emitters only, 2 = direct lighting).
//!
//! One concept per file: [`Tracer`] and [`radiance`] here; the segment cast
//! (straight, chords through a gradient-index medium, or a packet's) in
//! `cast`; light sampling and shadow rays in `light`; the materials' one
//! scattering model in `scatter`; the path tracer's state and step in `path`;
//! which scheduler traces a render's paths in `scheduler` (the one place
//! that decides); paths traced side by side in Embree packets, held as
//! columns, in `wavefront`, their hits shaded in vector registers by
//! `shade_lanes`; the Whitted preview in `whitted`; the deterministic
//! refraction-only path of tests and audits in `refraction_path`.
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList, NestedStrategy};
use crate::error::Result;
use crate::media::CurvedRay;
use crate::ray::Ray;
use crate::sampling::Rng;
use crate::scene::IntegratorKind;
use crate::scene::{Material, RenderScene};
use glam::Vec3A as V3;

mod camera_rays;
mod cast;
mod columns;
mod light;
mod observer;
mod path;
mod refraction_path;
mod scatter;
mod scheduler;
mod shade_lanes;
mod wavefront;
mod whitted;

pub use camera_rays::{CameraRays, CurvedStarts, Group, MAX_GROUP};
pub use cast::MAX_CHORDS_PER_SEGMENT;
pub use observer::{RayObserver, RayQuery, RayRecorder};
pub use path::PathStart;
pub use refraction_path::{refraction_path, refraction_path_with, PathEvent, Queries, RefractionPath};
pub use scheduler::{Scheduler, Shading, WavefrontMode};
pub use wavefront::{trace_paths, Wavefront};

/// How paths find the light sources (a render setting, not part of the scene).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LightSampling {
    /// Next-event estimation at every diffuse vertex, combined with BSDF
    /// sampling by multiple importance sampling (power heuristic).
    #[default]
    Mis,
    /// BSDF sampling alone: emitters (area lights, emitting objects, the
    /// sun's disk) count where a path meets them, with weight 1; point,
    /// directional and spot lights, which no path can meet, add nothing.
    /// The reference next-event estimation is judged against.
    Bsdf,
}

impl LightSampling {
    /// Its name on the command line and in stats.
    pub fn name(self) -> &'static str {
        match self {
            LightSampling::Mis => "mis",
            LightSampling::Bsdf => "bsdf",
        }
    }
}

/// What every path of a render shares: the scene, how nested dielectrics
/// are resolved and how lights are sampled (render settings, not part of
/// the scene), and who is told of the queries.
#[derive(Clone, Copy)]
pub struct Tracer<'a> {
    /// The scene.
    pub scene: &'a RenderScene,
    /// How false hits are found and skipped.
    pub strategy: NestedStrategy,
    /// Next-event estimation with MIS, or BSDF sampling alone.
    pub light_sampling: LightSampling,
    /// Told of every nearest-hit query and shadow ray (none: no cost but a branch).
    pub observer: Option<&'a dyn RayObserver>,
}

impl<'a> Tracer<'a> {
    /// A tracer of `scene` with the default strategy (the filter) and no observer.
    pub fn new(scene: &'a RenderScene) -> Self {
        Tracer {
            scene,
            strategy: NestedStrategy::Filter,
            light_sampling: LightSampling::Mis,
            observer: None,
        }
    }

    /// This tracer with another nested-dielectric strategy.
    pub fn with_strategy(self, strategy: NestedStrategy) -> Self {
        Tracer { strategy, ..self }
    }

    /// This tracer with another way of sampling lights.
    pub fn with_light_sampling(self, light_sampling: LightSampling) -> Self {
        Tracer {
            light_sampling,
            ..self
        }
    }

    /// Does it make next-event connections?
    #[inline(always)]
    fn nee(self) -> bool {
        self.light_sampling == LightSampling::Mis
    }

    /// Tell the observer, if any, of the query `q` makes.
    #[inline(always)]
    fn observe(self, q: impl FnOnce() -> RayQuery) {
        if let Some(o) = self.observer {
            o.query(q());
        }
    }

    /// The boundary event at a true hit (`dielectric::boundary` with this
    /// tracer's scene and strategy).
    fn boundary(
        self,
        material: &Material,
        front: bool,
        coincident: &dielectric::Coincident,
        list: &mut InteriorList,
    ) -> Option<dielectric::Boundary> {
        let nesting = dielectric::Nesting::of(self.scene);
        dielectric::boundary(nesting, self.strategy, material, front, coincident, list)
    }

    /// The list of `child`, spawned at a true hit with `coincident`, settled
    /// where another solid's surface passes near the hit
    /// (`dielectric::settle_child`).
    #[inline]
    fn settle(
        self,
        coincident: &dielectric::Coincident,
        child: &Ray,
        list: &mut InteriorList,
        st: &mut Counters,
    ) {
        dielectric::settle_child(self.scene, coincident, child, list, st);
    }

    /// Absorption of the medium a ray inside `list` travels through. Inline:
    /// the packet integrator asks per lane per bounce, and whether the
    /// compiler inlines it on its own varies with unrelated changes.
    #[inline]
    fn medium(self, list: &InteriorList) -> Option<V3> {
        dielectric::medium_of(dielectric::Nesting::of(self.scene), list)
    }
}

/// Radiance along a camera ray (unit `dir`), with `list` the interior list at the camera.
pub fn radiance(
    tr: Tracer<'_>,
    org: V3,
    dir: V3,
    list: InteriorList,
    rng: &mut Rng,
    st: &mut Counters,
) -> Result<V3> {
    radiance_after(tr, org, dir, list, rng, st, None)
}

/// [`radiance`], the camera ray's first segment cast as `first` (the curved
/// ray of `org`, `dir`, its flight through the medium perhaps flown already:
/// `media::fly_camera_rays`).
pub fn radiance_after(
    tr: Tracer<'_>,
    org: V3,
    dir: V3,
    list: InteriorList,
    rng: &mut Rng,
    st: &mut Counters,
    first: Option<&mut CurvedRay>,
) -> Result<V3> {
    match tr.scene.integrator {
        IntegratorKind::Path => path::path(tr, org, dir, list, rng, st, first),
        IntegratorKind::Whitted => whitted::whitted(tr, org, dir, list, rng, st, 1),
    }
}
