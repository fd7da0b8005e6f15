//! The path tracer's live paths as columns ([`PathColumns`]): one array
//! per component of their state, in the order they started, so that a
//! packet's rays and the vector kernel's operands are loads of consecutive
//! entries. Paths that end leave by compaction, the others keeping their
//! order. (A path's wavelengths, when spectral, would be one more column.)
use super::path::PathStart;
use crate::dielectric::InteriorList;
use crate::ray::Ray;
use crate::sampling::Rng;
use glam::Vec3A as V3;

/// The widest packet, and the most lanes shaded side by side. The columns
/// are padded by this many entries past the last path, so that the
/// kernel's loads of a last, partial packet stay in bounds.
pub(super) const MAX: usize = 16;
const PAD: usize = MAX;

/// Paths of the path tracer as columns: entry `k` of every column is path
/// `k` of the live order. What the packets and the vector kernel read
/// (rays, throughputs) is split by component; what only scalar code reads
/// stays together per path ([`PathScalars`]).
#[derive(Default)]
pub(super) struct PathColumns {
    /// Live paths (the columns hold `PAD` more entries).
    pub(super) len: usize,
    /// The next segment's ray: origin and direction (any length; the
    /// segment starts at 0 and is unbounded).
    pub(super) org: [Vec<f32>; 3],
    pub(super) dir: [Vec<f32>; 3],
    /// Throughput.
    beta: [Vec<f32>; 3],
    /// The product of the squared relative indices crossed (Russian
    /// roulette's correction).
    eta_scale: Vec<f32>,
    pub(super) scalars: Vec<PathScalars>,
    /// The solids each path is inside (kept in order only in scenes with
    /// solids: elsewhere every list stays empty).
    pub(super) lists: Vec<InteriorList>,
    /// Compaction moves `lists` too.
    with_lists: bool,
    /// The last step ended the path.
    ended: Vec<bool>,
    /// The places of the paths a compaction keeps.
    kept: Vec<usize>,
}

/// The state of a path that only its scalar phases read.
#[derive(Clone)]
pub(super) struct PathScalars {
    /// Radiance gathered so far.
    pub(super) l: V3,
    /// The last scattering vertex and the density its bounce was drawn
    /// with (an emitter's MIS weight at the next hit).
    pub(super) prev_p: V3,
    pub(super) prev_pdf: f32,
    /// Segment index of the next ray (1: the camera ray).
    pub(super) depth: u32,
    /// The last vertex was a delta lobe (or the camera).
    pub(super) specular: bool,
    /// No diffuse bounce yet (packets of these go to Embree as coherent).
    pub(super) only_specular: bool,
    /// The path's place in the order it started.
    pub(super) slot: u32,
    /// Where the next segment starts along its ray: 0 but for a ray that
    /// continues its parent's line through an index-matched boundary
    /// (`ray::spawn_transmitted`).
    pub(super) tnear: f32,
    pub(super) rng: Rng,
}

/// The columns of the `N` paths of one packet, as arrays: lane `i` is
/// path `base + i` (lanes past the live paths hold padding).
pub(super) struct PacketPaths<'a, const N: usize> {
    pub(super) org: [&'a mut [f32; N]; 3],
    pub(super) dir: [&'a mut [f32; N]; 3],
    pub(super) beta: [&'a mut [f32; N]; 3],
    pub(super) eta_scale: &'a mut [f32; N],
    pub(super) s: &'a mut [PathScalars; N],
    /// The paths' interior lists (empty in a scene without solids).
    pub(super) lists: &'a mut [InteriorList; N],
    pub(super) ended: &'a mut [bool; N],
}

impl<const N: usize> PacketPaths<'_, N> {
    /// Lane `i`'s next ray.
    #[inline(always)]
    pub(super) fn ray(&self, i: usize) -> Ray {
        let mut ray = Ray::new(get3(&self.org, i), get3(&self.dir, i));
        ray.tnear = self.s[i].tnear;
        ray
    }

    /// Lane `i`'s next ray set to `ray` (unbounded: the wavefront's rays are).
    #[inline(always)]
    pub(super) fn set_ray(&mut self, i: usize, ray: &Ray) {
        set3(&mut self.org, i, ray.org);
        set3(&mut self.dir, i, ray.dir);
        self.s[i].tnear = ray.tnear;
    }
}

/// Entry `i` of three columns, as a vector.
#[inline(always)]
pub(super) fn get3<const N: usize>(a: &[&mut [f32; N]; 3], i: usize) -> V3 {
    V3::new(a[0][i], a[1][i], a[2][i])
}

/// Entry `i` of three columns set to `v`.
#[inline(always)]
pub(super) fn set3<const N: usize>(a: &mut [&mut [f32; N]; 3], i: usize, v: V3) {
    a[0][i] = v.x;
    a[1][i] = v.y;
    a[2][i] = v.z;
}

/// Entries `base..base + M` of `column` as an array (in bounds: the
/// columns are padded).
#[inline(always)]
fn lanes<T, const M: usize>(column: &mut [T], base: usize) -> &mut [T; M] {
    (&mut column[base..base + M]).try_into().expect("padded columns")
}

/// Entries `base..base + M` of three columns.
#[inline(always)]
fn lanes3<const M: usize>(c: &mut [Vec<f32>; 3], base: usize) -> [&mut [f32; M]; 3] {
    let [x, y, z] = c;
    [lanes(x, base), lanes(y, base), lanes(z, base)]
}

/// Entry `kept[w] - from` of `column` moved to `w`, for every `w` (`kept`
/// increasing from `from` on: each entry is read before it is overwritten).
#[inline(always)]
fn gather<T: Copy>(column: &mut [T], kept: &[usize], from: usize) {
    for (w, &k) in kept.iter().enumerate() {
        column[w] = column[k - from];
    }
}

impl PathColumns {
    /// The paths `starts`, at the start of their camera rays inside `list`
    /// (filled column by column: cheaper than path by path). `with_lists`:
    /// the scene has solids, so the lists change and compaction moves them.
    pub(super) fn start(&mut self, starts: &[PathStart], list: &InteriorList, with_lists: bool) {
        let n = starts.len();
        self.len = n;
        for c in 0..3 {
            fill(&mut self.org[c], starts.iter().map(|s| s.ray.0[c]));
            fill(&mut self.dir[c], starts.iter().map(|s| s.ray.1[c]));
            fill(&mut self.beta[c], std::iter::repeat_n(1.0, n));
        }
        fill(&mut self.eta_scale, std::iter::repeat_n(1.0, n));
        fill(&mut self.ended, std::iter::repeat_n(false, n));
        fill(
            &mut self.scalars,
            starts.iter().enumerate().map(|(slot, s)| PathScalars {
                l: V3::ZERO,
                prev_p: s.ray.0,
                prev_pdf: 0.0,
                depth: 1,
                specular: true,
                only_specular: true,
                slot: slot as u32,
                tnear: 0.0,
                rng: s.rng.clone(),
            }),
        );
        // Without solids every list is and stays empty: filled only when a
        // wavefront with solids may have left others, or there are too few.
        if with_lists || self.with_lists || self.lists.len() < n + PAD {
            fill(&mut self.lists, std::iter::repeat_n(list.clone(), n + PAD));
        }
        self.with_lists = with_lists;
        // `PAD` more of each, for the packets' views and the kernel's loads.
        let m = n + PAD;
        for c in 0..3 {
            self.org[c].resize(m, 0.0);
            self.dir[c].resize(m, 0.0);
            self.beta[c].resize(m, 0.0);
        }
        self.eta_scale.resize(m, 1.0);
        self.ended.resize(m, true);
        let pad = self.scalars.first().cloned();
        if let Some(pad) = pad {
            self.scalars.resize(m, pad);
        }
    }

    /// The `N` paths from `base` on, as arrays.
    #[inline(always)]
    pub(super) fn packet<const N: usize>(&mut self, base: usize) -> PacketPaths<'_, N> {
        PacketPaths {
            org: lanes3(&mut self.org, base),
            dir: lanes3(&mut self.dir, base),
            beta: lanes3(&mut self.beta, base),
            eta_scale: lanes(&mut self.eta_scale, base),
            s: lanes(&mut self.scalars, base),
            lists: lanes(&mut self.lists, base),
            ended: lanes(&mut self.ended, base),
        }
    }

    /// Drop the ended paths, keeping the others' order: each ended path's
    /// slot and radiance go to `gone` first, in order.
    pub(super) fn compact(&mut self, mut gone: impl FnMut(u32, V3)) {
        let n = self.len;
        // The paths before the first ended one stay where they are.
        let Some(first) = self.ended[..n].iter().position(|&e| e) else {
            return;
        };
        self.kept.clear();
        for k in first..n {
            if self.ended[k] {
                let s = &self.scalars[k];
                gone(s.slot, s.l);
            } else {
                self.kept.push(k);
            }
        }
        let kept = &self.kept[..];
        for c in 0..3 {
            gather(&mut self.org[c][first..n], kept, first);
            gather(&mut self.dir[c][first..n], kept, first);
            gather(&mut self.beta[c][first..n], kept, first);
        }
        gather(&mut self.eta_scale[first..n], kept, first);
        for (w, &k) in kept.iter().enumerate() {
            self.scalars[first + w] = self.scalars[k].clone();
        }
        if self.with_lists {
            // (A swap: what lands at `k` is an ended path's or one moved already.)
            for (w, &k) in kept.iter().enumerate() {
                self.lists.swap(first + w, k);
            }
        }
        self.len = first + kept.len();
        self.ended[first..self.len].fill(false);
    }
}

/// `column`'s entries replaced by `values`.
fn fill<T>(column: &mut Vec<T>, values: impl Iterator<Item = T>) {
    column.clear();
    column.extend(values);
}
