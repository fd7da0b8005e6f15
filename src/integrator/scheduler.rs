//! Which scheduler traces a render's paths, decided in one place
//! ([`Scheduler::of`]): the wavefront (paths side by side in Embree packets,
//! shaded in vector registers where the kernel models the hit), or path by
//! path (curved rays through a gradient-index medium, the Whitted tracer).
//! Both run the same model: the wavefront's single-ray step is the scalar
//! path tracer's, and its kernel is held to it by the lane-parity tests.
use super::Tracer;
use crate::scene::IntegratorKind;

/// How the path tracer shades a packet's paths (a render option). The two
/// give the same image up to rounding: vector shading is f32 throughout
/// (and so are its packets' queries of the analytic shapes, where no solids
/// overlap: `shapes::SetScratch::f32`), scalar shading solves Fresnel and
/// Snell in f64 and queries the analytic shapes in f64, the reference that
/// single rays reproduce bit for bit (a path whose random number falls
/// within rounding of a Fresnel reflectance takes the other lobe).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Shading {
    /// A packet's paths side by side in vector registers where their hits
    /// allow it (the materials and lights `ShadeLanes::prepare` models), the
    /// others one by one.
    #[default]
    Vector,
    /// One path at a time (`PathState::advance`).
    Scalar,
}

/// How a render's paths are traced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheduler {
    /// Wavefronts of paths in packets ([`trace_paths`](super::trace_paths)).
    Wavefront(WavefrontMode),
    /// One path at a time ([`radiance_after`](super::radiance_after)):
    /// through a gradient-index medium (curved segments are chains of
    /// queries), and the Whitted tracer.
    PathByPath,
}

/// What a wavefront does with its lanes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WavefrontMode {
    /// Lanes the kernel models are shaded in vector registers; the others
    /// (all of them when `false`) by the single-ray step.
    pub kernel: bool,
    /// The packets' queries of the analytic shapes in f32 lanes (f64, bit
    /// for bit the single rays' answers, when `false`).
    pub f32_set: bool,
}

impl WavefrontMode {
    /// The reference: every lane shaded by the single-ray step, the analytic
    /// shapes queried in f64 (each path bit for bit the single-ray path's).
    pub const SCALAR: WavefrontMode = WavefrontMode {
        kernel: false,
        f32_set: false,
    };
}

impl Scheduler {
    /// The scheduler of a render of `tr` with `shading`. The kernel shades
    /// only with next-event estimation and without an observer (which is
    /// told of every query the single-ray step makes); the f32 set only
    /// where no solids overlap (the nested rule decides coincident surfaces
    /// from the f64 answers).
    pub fn of(tr: Tracer<'_>, shading: Shading) -> Scheduler {
        let scene = tr.scene;
        if scene.integrator != IntegratorKind::Path || scene.medium.is_some() {
            return Scheduler::PathByPath;
        }
        let vector = shading == Shading::Vector;
        Scheduler::Wavefront(WavefrontMode {
            kernel: vector && tr.nee() && tr.observer.is_none(),
            f32_set: vector && !scene.has_overlap,
        })
    }
}
