//! The plume's turbulence waves and its n and ∇n, eight points or waves
//! side by side in vector lanes.
use super::fast_math::{exp_nonpositive, sin_cos_reduced};
use super::IndexField;
use glam::DVec3;

/// A plume's turbulence waves (wave vector, phase), a cache of what
/// `seed`, `waves` and `wavelength` determine: always equal to another
/// table, so fields compare by their parameters. With the waves in chunks
/// of [`WAVE_LANES`] (kx, ky, kz, phase; the last padded with k = 0, phase 0)
/// and the vector instructions their sines are computed with.
#[derive(Clone, Default)]
pub struct WaveTable(
    pub(super) Vec<(DVec3, f64)>,
    pub(super) f64,
    pub(super) Vec<[[f64; WAVE_LANES]; 4]>,
    pub(super) pulp::Arch,
);

/// Waves evaluated side by side: eight f64 lanes are one AVX-512 register,
/// two AVX2 ones.
pub(super) const WAVE_LANES: usize = 8;

impl WaveTable {
    pub(super) fn new(seed: u64, waves: u32, wavelength: f64) -> WaveTable {
        let w: Vec<(DVec3, f64)> = (0..waves).map(|i| wave(seed, i, wavelength)).collect();
        let k_mean = w.iter().map(|w| w.0.length()).sum::<f64>() / f64::from(waves.max(1));
        let chunks = w
            .chunks(WAVE_LANES)
            .map(|c| {
                let get = |j: usize| c.get(j).copied().unwrap_or((DVec3::ZERO, 0.0));
                [
                    std::array::from_fn(|j| get(j).0.x),
                    std::array::from_fn(|j| get(j).0.y),
                    std::array::from_fn(|j| get(j).0.z),
                    std::array::from_fn(|j| get(j).1),
                ]
            })
            .collect();
        WaveTable(w, k_mean, chunks, pulp::Arch::new())
    }

    /// Σ sin(k·p + φ), Σ k cos(k·p + φ) over the waves, and the largest
    /// |phase| met. The sines and cosines of a chunk are computed side by
    /// side (the loop compiled for the CPU's widest vectors, chosen at run
    /// time); the sums then run in the waves' order, even and odd waves
    /// apart, as the two-lane code before them did, so the result does not
    /// depend on the vector width.
    pub(super) fn sums(&self, p: DVec3) -> (f64, DVec3, f64) {
        self.3.dispatch(WaveSums { table: self, p })
    }
}

/// [`WaveTable::sums`] at `p`, compiled for each vector level (a `WithSimd`
/// whose body is inlined into pulp's per-level functions, so the lane loop
/// is vectorised for the level dispatched to).
pub(super) struct WaveSums<'a> {
    pub(super) table: &'a WaveTable,
    pub(super) p: DVec3,
}

impl pulp::WithSimd for WaveSums<'_> {
    type Output = (f64, DVec3, f64);

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
        let WaveSums { table, p } = self;
        let n = table.0.len();
        let (mut t, mut gx, mut gy, mut gz, mut far) = ([0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2], [0.0f64; 2]);
        for (c, [kx, ky, kz, ph]) in table.2.iter().enumerate() {
            let (mut sin, mut cos, mut abs) = ([0.0; WAVE_LANES], [0.0; WAVE_LANES], [0.0; WAVE_LANES]);
            for l in 0..WAVE_LANES {
                let a = kx[l] * p.x + ky[l] * p.y + kz[l] * p.z + ph[l];
                abs[l] = a.abs();
                (sin[l], cos[l]) = sin_cos_reduced(a);
            }
            for l in 0..WAVE_LANES.min(n - c * WAVE_LANES) {
                let e = l % 2;
                far[e] = far[e].max(abs[l]);
                t[e] += sin[l];
                gx[e] += kx[l] * cos[l];
                gy[e] += ky[l] * cos[l];
                gz[e] += kz[l] * cos[l];
            }
        }
        (
            t[0] + t[1],
            DVec3::new(gx[0] + gx[1], gy[0] + gy[1], gz[0] + gz[1]),
            far[0].max(far[1]),
        )
    }
}

/// A plume's parameters as plain numbers, for [`PlumeConsts::at`].
#[derive(Clone, Copy)]
pub(super) struct PlumeConsts {
    pub(super) n_amb: f64,
    pub(super) dn: f64,
    pub(super) center: DVec3,
    pub(super) radius: f64,
    pub(super) height: f64,
    pub(super) amplitude: f64,
    /// 1 / the number of waves.
    pub(super) inv: f64,
    pub(super) up: DVec3,
}

impl PlumeConsts {
    pub(super) fn of(f: &IndexField) -> Option<PlumeConsts> {
        match *f {
            IndexField::Plume {
                n_amb,
                dn,
                center,
                radius,
                height,
                amplitude,
                waves,
                up,
                ..
            } => Some(PlumeConsts {
                n_amb,
                dn,
                center,
                radius,
                height,
                amplitude,
                inv: 1.0 / f64::from(waves),
                up,
            }),
            _ => None,
        }
    }

    /// n and ∇n at (x, y, z) from the waves' sums (see the field's doc):
    /// scalar arithmetic only, the arithmetic shared by one point at a time
    /// and eight side by side (one vector lane each), so both give the same
    /// bits.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn at(
        &self,
        x: f64,
        y: f64,
        z: f64,
        t_sum: f64,
        sx: f64,
        sy: f64,
        sz: f64,
    ) -> (f64, f64, f64, f64) {
        let c = self;
        let (qx, qy, qz) = (x - c.center.x, y - c.center.y, z - c.center.z);
        let h = qx * c.up.x + qy * c.up.y + qz * c.up.z;
        let (rx, ry, rz) = (qx - c.up.x * h, qy - c.up.y * h, qz - c.up.z * h);
        let rho2 = rx * rx + ry * ry + rz * rz;
        let hh = h / c.height;
        let g = exp_nonpositive(-rho2 / (2.0 * c.radius * c.radius) - hh * hh);
        let (r2, a) = (c.radius * c.radius, 2.0 * h / (c.height * c.height));
        let (ggx, ggy, ggz) = (
            g * (-rx / r2 - c.up.x * a),
            g * (-ry / r2 - c.up.y * a),
            g * (-rz / r2 - c.up.z * a),
        );
        let (t, tx, ty, tz) = if c.amplitude != 0.0 {
            (t_sum * c.inv, sx * c.inv, sy * c.inv, sz * c.inv)
        } else {
            (0.0, 0.0, 0.0, 0.0)
        };
        let f = 1.0 + c.amplitude * t;
        let n = c.n_amb - c.dn * g * f;
        let (m, ga) = (-c.dn, g * c.amplitude);
        (
            n,
            m * (ggx * f + ga * tx),
            m * (ggy * f + ga * ty),
            m * (ggz * f + ga * tz),
        )
    }
}

/// [`IndexField::eval_many`]'s eight points, each a lane: every wave's
/// phase, sine and cosine for the eight points side by side, summed per
/// point in the waves' order (even and odd apart, as [`WaveSums`]), then
/// [`IndexField::plume_at`] per lane.
pub(super) struct PointLanes<'a> {
    pub(super) consts: PlumeConsts,
    pub(super) table: &'a WaveTable,
    pub(super) pts: [DVec3; WAVE_LANES],
}

impl pulp::WithSimd for PointLanes<'_> {
    type Output = ([(f64, DVec3); WAVE_LANES], [f64; WAVE_LANES]);

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
        let PointLanes { consts, table, pts } = self;
        let px: [f64; WAVE_LANES] = std::array::from_fn(|l| pts[l].x);
        let py: [f64; WAVE_LANES] = std::array::from_fn(|l| pts[l].y);
        let pz: [f64; WAVE_LANES] = std::array::from_fn(|l| pts[l].z);
        let mut t = [[0.0; WAVE_LANES]; 2];
        let mut gx = [[0.0; WAVE_LANES]; 2];
        let mut gy = [[0.0; WAVE_LANES]; 2];
        let mut gz = [[0.0; WAVE_LANES]; 2];
        let mut far = [[0.0f64; WAVE_LANES]; 2];
        for (w, &(k, ph)) in table.0.iter().enumerate() {
            let e = w % 2;
            for l in 0..WAVE_LANES {
                let a = k.x * px[l] + k.y * py[l] + k.z * pz[l] + ph;
                let (sin, cos) = sin_cos_reduced(a);
                far[e][l] = far[e][l].max(a.abs());
                t[e][l] += sin;
                gx[e][l] += k.x * cos;
                gy[e][l] += k.y * cos;
                gz[e][l] += k.z * cos;
            }
        }
        let (mut n, mut ox, mut oy, mut oz, mut far_out) = (
            [0.0; WAVE_LANES],
            [0.0; WAVE_LANES],
            [0.0; WAVE_LANES],
            [0.0; WAVE_LANES],
            [0.0; WAVE_LANES],
        );
        for l in 0..WAVE_LANES {
            (n[l], ox[l], oy[l], oz[l]) = consts.at(
                px[l],
                py[l],
                pz[l],
                t[0][l] + t[1][l],
                gx[0][l] + gx[1][l],
                gy[0][l] + gy[1][l],
                gz[0][l] + gz[1][l],
            );
            far_out[l] = far[0][l].max(far[1][l]);
        }
        (
            std::array::from_fn(|l| (n[l], DVec3::new(ox[l], oy[l], oz[l]))),
            far_out,
        )
    }
}

impl PartialEq for WaveTable {
    fn eq(&self, _: &WaveTable) -> bool {
        true
    }
}

impl std::fmt::Debug for WaveTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "WaveTable({} waves)", self.0.len())
    }
}

pub(super) fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

pub(super) fn unit01(state: &mut u64) -> f64 {
    (splitmix(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// The i-th turbulence wave: wave vector and phase (deterministic in seed).
pub(super) fn wave(seed: u64, i: u32, wavelength: f64) -> (DVec3, f64) {
    let mut st = seed ^ (u64::from(i) + 1).wrapping_mul(0xD1B5_4A32_D192_ED03);
    let z = 2.0 * unit01(&mut st) - 1.0;
    let phi = std::f64::consts::TAU * unit01(&mut st);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let dir = DVec3::new(r * phi.cos(), z, r * phi.sin());
    // Wavelengths spread over [0.5, 2] × wavelength.
    let lambda = wavelength * 2f64.powf(2.0 * unit01(&mut st) - 1.0);
    let phase = std::f64::consts::TAU * unit01(&mut st);
    (dir * (std::f64::consts::TAU / lambda), phase)
}

impl IndexField {
    /// A plume's n and ∇n at `p` from its waves' sums Σ sin and Σ k cos
    /// there (not yet divided by their number), through
    /// [`PlumeConsts::at`].
    #[inline(always)]
    pub(super) fn plume_at(&self, p: DVec3, t_sum: f64, grad_t_sum: DVec3) -> (f64, DVec3) {
        match PlumeConsts::of(self) {
            Some(c) => {
                let (n, gx, gy, gz) = c.at(p.x, p.y, p.z, t_sum, grad_t_sum.x, grad_t_sum.y, grad_t_sum.z);
                (n, DVec3::new(gx, gy, gz))
            }
            None => (f64::NAN, DVec3::ZERO),
        }
    }

    /// [`IndexField::eval`] at each of `ps` into `out`, the same bits. A
    /// plume's points are taken eight at a time, each a vector lane (the
    /// Gaussian's exponential and each wave's sine and cosine one vector
    /// operation for eight points): what makes several rays' flights side by
    /// side cheaper than one after another.
    pub fn eval_many(&self, ps: &[DVec3], out: &mut [(f64, DVec3)]) {
        debug_assert_eq!(ps.len(), out.len());
        let IndexField::Plume {
            amplitude,
            waves,
            ref table,
            ..
        } = *self
        else {
            for (p, o) in ps.iter().zip(out.iter_mut()) {
                *o = self.eval(*p);
            }
            return;
        };
        let consts = match PlumeConsts::of(self) {
            Some(c) if amplitude != 0.0 && table.0.len() == waves as usize => c,
            _ => {
                for (p, o) in ps.iter().zip(out.iter_mut()) {
                    *o = self.eval(*p);
                }
                return;
            }
        };
        for (pc, oc) in ps.chunks(WAVE_LANES).zip(out.chunks_mut(WAVE_LANES)) {
            let mut pts = [pc[0]; WAVE_LANES];
            pts[..pc.len()].copy_from_slice(pc);
            let (res, far) = table.3.dispatch(PointLanes { consts, table, pts });
            for (l, o) in oc.iter_mut().enumerate() {
                *o = if far[l] < 1e6 { res[l] } else { self.eval(pc[l]) };
            }
        }
    }
}

#[cfg(test)]
mod wave_sum_tests {
    use super::{exp_nonpositive, sin_cos_reduced, IndexField, PlumeConsts, PointLanes, WaveSums, WaveTable};
    use glam::DVec3;

    /// The sums two waves at a time, even and odd apart, in the waves'
    /// order: the arithmetic every vector level must reproduce bit for bit.
    /// `one_sum`: all waves in one running sum instead (a known-wrong order).
    fn reference(t: &WaveTable, p: DVec3, one_sum: bool) -> (f64, DVec3, f64) {
        let (mut s, mut g, mut far) = ([0.0; 2], [DVec3::ZERO; 2], [0.0f64; 2]);
        for (i, (k, ph)) in t.0.iter().enumerate() {
            let e = if one_sum { 0 } else { i % 2 };
            let a = k.x * p.x + k.y * p.y + k.z * p.z + ph;
            far[e] = far[e].max(a.abs());
            let (sin, cos) = sin_cos_reduced(a);
            s[e] += sin;
            g[e] = DVec3::new(g[e].x + k.x * cos, g[e].y + k.y * cos, g[e].z + k.z * cos);
        }
        (s[0] + s[1], g[0] + g[1], far[0].max(far[1]))
    }

    fn bits(v: (f64, DVec3, f64)) -> [u64; 5] {
        [v.0, v.1.x, v.1.y, v.1.z, v.2].map(f64::to_bits)
    }

    #[test]
    fn every_vector_level_sums_the_waves_as_the_reference() {
        let mut levels = vec![("scalar", pulp::Arch::Scalar)];
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(s) = pulp::x86::V3::try_new() {
                levels.push(("avx2", pulp::Arch::V3(s)));
            }
            if let Some(s) = pulp::x86::V4::try_new() {
                levels.push(("avx512", pulp::Arch::V4(s)));
            }
        }
        let (mut points, mut caught) = (0, 0);
        // 1, 6 (the shipped scene's), 8, 9 and 21 waves: partial and whole chunks.
        for (waves, seed) in [(1, 5), (6, 3), (8, 1), (9, 7), (21, 2)] {
            let table = WaveTable::new(seed, waves, 0.2);
            for i in 0..2000 {
                let f = i as f64;
                let p = DVec3::new((f * 0.37).sin() * 0.9, 0.25 + f * 1.3e-3, (f * 0.53).cos() * 0.9);
                let want = bits(reference(&table, p, false));
                for (name, level) in &levels {
                    assert_eq!(
                        bits(level.dispatch(WaveSums { table: &table, p })),
                        want,
                        "{name}, {waves} waves at {p}"
                    );
                }
                points += 1;
                caught += usize::from(waves > 2 && bits(reference(&table, p, true)) != want);
            }
        }
        // Power: summing in another order changes the bits at most points.
        assert!(
            caught > points / 2,
            "a reordered sum differs at only {caught} of {points} points"
        );
    }

    /// The branch-free exponential against libm over the Gaussian's range:
    /// within 1 ulp, 0 below −700, NaN through. Power: the polynomial
    /// stopped at r⁴ misses by more than a thousand.
    #[test]
    fn the_branch_free_exponential_is_libms_within_an_ulp() {
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        let (mut worst, mut n) = (0, 0);
        for i in 0..200_000 {
            let x = -700.0 * (i as f64 / 200_000.0).powi(3) - 1e-3 * ((i * 7919) % 1000) as f64 / 1000.0;
            worst = worst.max(ulps(exp_nonpositive(x), x.exp()));
            n += 1;
        }
        for x in [
            0.0,
            -0.0,
            -1e-300,
            -0.5 * std::f64::consts::LN_2,
            -std::f64::consts::LN_2,
            -1.0,
            -699.99,
        ] {
            worst = worst.max(ulps(exp_nonpositive(x), x.exp()));
        }
        eprintln!("exp over {n} points: worst {worst} ulp");
        assert!(worst <= 1, "{worst} ulp");
        assert_eq!(exp_nonpositive(-700.5), 0.0);
        assert_eq!(exp_nonpositive(f64::NEG_INFINITY), 0.0);
        assert!(exp_nonpositive(f64::NAN).is_nan());
        // A truncated polynomial (the power check).
        let truncated = |x: f64| {
            let k = (x / std::f64::consts::LN_2).round();
            let r = x - k * std::f64::consts::LN_2;
            (1.0 + r + r * r / 2.0 + r * r * r / 6.0 + r.powi(4) / 24.0) * 2f64.powi(k as i32)
        };
        assert!(ulps(truncated(-0.3), (-0.3f64).exp()) > 1000);
    }

    /// Eight points side by side give each point's own evaluation bit for
    /// bit, at every vector level, for a part chunk and past it, with a
    /// point whose phases are out of the kernel's range among them.
    #[test]
    fn points_side_by_side_evaluate_as_one_at_a_time() {
        let field = IndexField::Plume {
            n_amb: 1.000293,
            dn: 0.012,
            center: DVec3::new(0.0, 0.25, 0.0),
            radius: 0.3,
            height: 2.5,
            amplitude: 0.7,
            wavelength: 0.2,
            waves: 6,
            seed: 3,
            up: DVec3::Y,
            table: Default::default(),
        }
        .validated("medium.field")
        .unwrap();
        let IndexField::Plume { ref table, .. } = field else {
            unreachable!()
        };
        let bits = |v: (f64, DVec3)| [v.0, v.1.x, v.1.y, v.1.z].map(f64::to_bits);
        let mut levels = vec![pulp::Arch::Scalar];
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(s) = pulp::x86::V3::try_new() {
                levels.push(pulp::Arch::V3(s));
            }
            if let Some(s) = pulp::x86::V4::try_new() {
                levels.push(pulp::Arch::V4(s));
            }
        }
        for i in 0..500 {
            let f = i as f64;
            let pts: [DVec3; 8] = std::array::from_fn(|l| {
                let g = f + l as f64 * 0.173;
                DVec3::new((g * 0.37).sin() * 0.9, 0.25 + g * 5e-3, (g * 0.53).cos() * 0.9)
            });
            for level in &levels {
                let (res, _) = level.dispatch(PointLanes {
                    consts: PlumeConsts::of(&field).unwrap(),
                    table,
                    pts,
                });
                for l in 0..8 {
                    assert_eq!(bits(res[l]), bits(field.eval(pts[l])), "lane {l} at {}", pts[l]);
                }
            }
        }
        let mut ps: Vec<DVec3> = (0..11).map(|i| DVec3::new(0.05 * i as f64, 1.0, -0.3)).collect();
        ps[4] = DVec3::new(3e5, 1.0, 0.0);
        let mut out = vec![(0.0, DVec3::ZERO); ps.len()];
        field.eval_many(&ps, &mut out);
        for (p, o) in ps.iter().zip(&out) {
            assert_eq!(bits(*o), bits(field.eval(*p)), "at {p}");
        }
        // Power: the waves summed in one running sum (another order) change
        // the bits at most points.
        let (mut caught, mut points) = (0, 0);
        for i in 0..1000 {
            let f = i as f64;
            let p = DVec3::new((f * 0.37).sin() * 0.9, 0.25 + f * 2e-3, (f * 0.53).cos() * 0.9);
            let (sum, g, _) = reference(table, p, true);
            caught += usize::from(bits(field.plume_at(p, sum, g)) != bits(field.eval(p)));
            points += 1;
        }
        assert!(
            caught > points / 2,
            "another order differs at only {caught} of {points}"
        );
    }
}
