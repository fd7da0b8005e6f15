//! What several integration tests share.
use glam::Vec3A as V3;
use snell::counters::Counters;
use snell::dielectric::InteriorList;
use snell::embree::RayPacket;
use snell::integrator::{trace_paths, PathStart, Tracer, Wavefront, WavefrontMode};
use snell::sampling::Rng;

/// Up to `N` paths of the camera rays `cams` traced side by side by the
/// wavefront in its reference mode ([`WavefrontMode::SCALAR`]): the
/// radiance of path `i` at `i`; each path's own counts added to `sts[i]`
/// when `sts` has more than one entry, else all of them to `sts[0]`; the
/// packets' occupancy kept in `w`.
pub fn wavefront_paths<const N: usize, P: RayPacket<N>>(
    tr: Tracer<'_>,
    cams: &[(V3, V3)],
    list: &InteriorList,
    rngs: &[Rng],
    sts: &mut [Counters],
    w: &mut Wavefront<P>,
) -> [V3; N] {
    let n = cams.len().min(N);
    let per_path = sts.len() > 1;
    let starts: Vec<PathStart> = cams[..n]
        .iter()
        .zip(rngs)
        .map(|(&ray, rng)| PathStart {
            ray,
            rng: rng.clone(),
        })
        .collect();
    let (mut out, mut own, mut total) = ([V3::ZERO; N], [Counters::default(); N], Counters::default());
    let done = |i: u32, l: V3, st: &Counters| {
        out[i as usize] = l;
        own[i as usize] = *st;
    };
    trace_paths(
        tr,
        WavefrontMode::SCALAR,
        list,
        &starts,
        done,
        per_path,
        &mut total,
        w,
    )
    .unwrap();
    if per_path {
        for (s, o) in sts.iter_mut().zip(&own) {
            *s += *o;
        }
    } else {
        sts[0] += total;
    }
    out
}
