//! How a tile's samples are traced: as wavefronts of paths in Embree packets
//! ([`trace_paths`]), or path by path (through a gradient-index medium, or
//! by the Whitted tracer). Either way each sample's radiance goes to its
//! pixel in sample order.
use super::{Aov, TileJob, TileSums};
use crate::counters::Counters;
use crate::dielectric::InteriorList;
use crate::error::Result;
use crate::integrator::{
    radiance_after, trace_paths, CurvedStarts, Group, PathStart, Tracer, Wavefront, WavefrontMode, MAX_GROUP,
};
use glam::Vec3A as V3;

/// The most paths traced side by side: [`PacketWidth::lanes`](super::PacketWidth::lanes) (8 or 16).
const MAX_PATHS_PER_PACKET: usize = 16;

/// Samples a tile streams through its packets at a time ([`trace_paths`]):
/// their radiance waits in a buffer of this many until all have ended, then
/// goes to the pixels in sample order, as a pixel-by-pixel render adds them.
const STREAM_WINDOW: usize = 1024;

/// A thread's packets and wavefront storage for [`trace_paths`], of the
/// render's width.
pub(super) enum Lanes {
    Eight(Box<Wavefront<crate::embree::Packet8>>),
    Sixteen(Box<Wavefront<crate::embree::Packet16>>),
}

impl Lanes {
    pub(super) fn of_width(lanes: usize) -> Lanes {
        match lanes {
            16 => Lanes::Sixteen(Box::default()),
            _ => Lanes::Eight(Box::default()),
        }
    }

    /// [`trace_paths`] at this width.
    #[allow(clippy::too_many_arguments)]
    fn stream(
        &mut self,
        tr: Tracer<'_>,
        mode: WavefrontMode,
        list: &InteriorList,
        starts: &[PathStart],
        done: impl FnMut(u32, V3, &Counters),
        per_path: bool,
        stats: &mut Counters,
    ) -> Result<()> {
        match self {
            Lanes::Eight(p) => trace_paths::<8, _>(tr, mode, list, starts, done, per_path, stats, p),
            Lanes::Sixteen(p) => trace_paths::<16, _>(tr, mode, list, starts, done, per_path, stats, p),
        }
    }

    fn take_occupancy(&mut self) -> Counters {
        match self {
            Lanes::Eight(p) => p.take_occupancy(),
            Lanes::Sixteen(p) => p.take_occupancy(),
        }
    }
}

impl TileJob<'_> {
    /// The samples of a w × h tile at (x0, y0) (`taken[k]` of pixel `k`, row
    /// by row) traced as wavefronts of up to [`STREAM_WINDOW`] paths
    /// ([`trace_paths`], in `mode`), the tile's samples in order, a pixel's
    /// side by side.
    /// Each sample's radiance is added to its pixel in sample order.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn stream_tile(
        &self,
        tracer: Tracer<'_>,
        mode: WavefrontMode,
        lanes: &mut Lanes,
        (x0, y0): (u32, u32),
        (w, h): (u32, u32),
        taken: &[u32],
        TileSums { pix, aov, stats }: TileSums<'_>,
    ) -> Result<()> {
        let list = InteriorList::from_solids(&tracer.scene.solids, &tracer.scene.camera_interior);
        // Each sample's own counts only where a layer reads them.
        let per_path = aov.is_some();
        // The tile's samples in order: (pixel index in the tile, sample index).
        let mut samples = (0..(w * h) as usize)
            .flat_map(|k| (self.start + self.count - taken[k]..self.start + self.count).map(move |s| (k, s)));
        let mut window = Vec::with_capacity(STREAM_WINDOW);
        let mut starts = Vec::with_capacity(STREAM_WINDOW);
        let mut ls = vec![V3::ZERO; STREAM_WINDOW];
        let mut own = vec![Counters::default(); if per_path { STREAM_WINDOW } else { 0 }];
        loop {
            window.clear();
            window.extend(samples.by_ref().take(STREAM_WINDOW));
            if window.is_empty() {
                break;
            }
            starts.clear();
            for group in window.chunks(MAX_GROUP) {
                self.rays.starts(group, (x0, y0), w, &mut starts);
            }
            // A path's index in `starts` is its sample's in `window`.
            let done = |t: u32, l: V3, st: &Counters| {
                ls[t as usize] = l;
                if per_path {
                    own[t as usize] = *st;
                }
            };
            lanes.stream(tracer, mode, &list, &starts, done, per_path, stats)?;
            for (t, &(k, _)) in window.iter().enumerate() {
                pix[k].add(ls[t]);
                if let Some(a) = aov.as_mut() {
                    let inv = 1.0 / taken[k] as f32;
                    for (layer, kind) in a.layers.iter_mut().zip(Aov::ALL) {
                        kind.add_sample(&mut layer[k], &own[t], inv);
                    }
                }
            }
        }
        *stats += lanes.take_occupancy();
        Ok(())
    }

    /// The samples of a w × h tile at (x0, y0) traced path by path (through
    /// a gradient-index medium, or by the Whitted tracer), as
    /// [`Self::stream_tile`] takes and adds them.
    pub(super) fn trace_tile(
        &self,
        tracer: Tracer<'_>,
        (x0, y0): (u32, u32),
        (w, h): (u32, u32),
        taken: &[u32],
        TileSums { pix, aov, stats }: TileSums<'_>,
    ) -> Result<()> {
        let scene = tracer.scene;
        let start_list = InteriorList::from_solids(&scene.solids, &scene.camera_interior);
        // A group's counters (reset per group, as far as it uses them).
        let mut sts = [Counters::default(); MAX_PATHS_PER_PACKET];
        let width = if self.packet_lanes == 16 { 16 } else { 8 };
        // The camera rays' curved rays through a medium.
        let mut curved = CurvedStarts::new(scene.medium.as_ref(), self.fly_rows, width);
        for j in 0..h {
            curved.row(&self.rays, (x0, y0 + j), w, |x, y| {
                self.start + self.base_at(x, y).1..self.start + self.count
            });
            for i in 0..w {
                let (x, y) = (x0 + i, y0 + j);
                let k = (j * w + i) as usize;
                let inv = 1.0 / taken[k].max(1) as f32;
                // The pixel's samples in groups of up to `width`, whose curved
                // camera rays are begun together.
                let mut s = self.start + self.count - taken[k];
                while s < self.start + self.count {
                    let lanes = (self.start + self.count - s).min(width as u32) as usize;
                    let Group { mut rngs, rays } = self.rays.group(x, y, s, lanes);
                    let per_sample = if aov.is_some() { lanes } else { 1 };
                    sts[..per_sample].fill(Counters::default());
                    curved.begin_group(&rays[..lanes]);
                    for i in 0..lanes {
                        let (o, d) = rays[i];
                        let l = radiance_after(
                            tracer,
                            o,
                            d,
                            start_list.clone(),
                            &mut rngs[i],
                            &mut sts[i.min(per_sample - 1)],
                            curved.take(i),
                        )?;
                        pix[k].add(l);
                        if let Some(a) = aov.as_mut() {
                            for (layer, kind) in a.layers.iter_mut().zip(Aov::ALL) {
                                kind.add_sample(&mut layer[k], &sts[i], inv);
                            }
                        }
                    }
                    for st in &sts[..per_sample] {
                        *stats += *st;
                    }
                    s += lanes as u32;
                }
            }
        }
        Ok(())
    }
}
