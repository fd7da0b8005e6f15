use super::*;
use std::f64::consts::PI;

/// A 16×8 map: a dim gradient, a bright spot and a black texel.
fn map() -> ImageData {
    let (w, h) = (16, 8);
    let mut pixels = Vec::with_capacity(w * h);
    for j in 0..h {
        for i in 0..w {
            let base = 0.05 + 0.02 * ((i * 7 + j * 3) % 5) as f32;
            pixels.push(V3::new(base, base * 1.5, base * 0.5));
        }
    }
    pixels[2 * w + 3] = V3::new(400.0, 300.0, 200.0);
    pixels[5 * w + 11] = V3::ZERO;
    ImageData {
        width: w,
        height: h,
        pixels,
    }
}

/// World-to-map rotations: none, a turn about a skew axis, and a quarter
/// turn about x (the map's poles on the world's horizon).
fn rotations() -> Vec<Option<Mat3A>> {
    let skew = Mat3A::from_axis_angle(glam::Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let quarter = Mat3A::from_rotation_x(std::f32::consts::FRAC_PI_2);
    vec![None, Some(skew), Some(quarter)]
}

const NZ: usize = 16;
const NPHI: usize = 32;
/// Midpoints per bin side: world directions on a grid equal in area
/// (z = cos θ_w and φ_w uniform), so each point stands for dω = dz dφ.
const SUB: usize = 64;

/// The bin of world direction `d`: z = d.y in 16 bands, φ in 32 sectors.
fn bin(d: V3) -> usize {
    let z = ((d.y as f64 + 1.0) * 0.5 * NZ as f64) as usize;
    let phi = (d.z as f64).atan2(d.x as f64) / (2.0 * PI) + 0.5;
    let p = (phi * NPHI as f64) as usize;
    z.min(NZ - 1) * NPHI + p.min(NPHI - 1)
}

/// Per bin, the integral of the world density (midpoint rule).
fn bin_masses(s: &EnvSampler, to_local: Option<&Mat3A>) -> Vec<f64> {
    let (nz, nphi) = (NZ * SUB, NPHI * SUB);
    let (dz, dphi) = (2.0 / nz as f64, 2.0 * PI / nphi as f64);
    let mut mass = vec![0.0; NZ * NPHI];
    for a in 0..nz {
        let z = -1.0 + (a as f64 + 0.5) * dz;
        let r = (1.0 - z * z).sqrt();
        for b in 0..nphi {
            let phi = -PI + (b as f64 + 0.5) * dphi;
            let d = V3::new((r * phi.cos()) as f32, z as f32, (r * phi.sin()) as f32);
            mass[(a / SUB) * NPHI + b / SUB] += s.pdf_world(to_local, d) as f64 * dz * dphi;
        }
    }
    mass
}

/// The density's integral over the sphere, and the chi-square of 400 000
/// samples' bin counts against the bin masses (with the bins' count).
fn check(s: &EnvSampler, to_local: Option<&Mat3A>) -> (f64, f64, usize) {
    let mass = bin_masses(s, to_local);
    let total: f64 = mass.iter().sum();
    let n = 400_000;
    let mut rng = crate::sampling::Rng::new(11);
    let mut counts = vec![0u32; NZ * NPHI];
    let mut mismatched = 0;
    for _ in 0..n {
        let Some((d, pdf)) = s.sample_world(to_local, rng.uniform_f64(), rng.uniform_f64()) else {
            continue;
        };
        assert!((d.length() - 1.0).abs() < 1e-5, "unit: {d}");
        let back = s.pdf_world(to_local, d);
        if (back - pdf).abs() > 1e-4 * pdf {
            mismatched += 1;
        }
        counts[bin(d)] += 1;
    }
    // A sample within rounding of a cell's edge can read its neighbour.
    assert!(
        mismatched < n / 1000,
        "pdf of the sample's direction differs: {mismatched} of {n}"
    );
    let (mut chi2, mut bins) = (0.0, 0);
    for (c, m) in counts.iter().zip(&mass) {
        let e = m * n as f64;
        if e >= 5.0 {
            chi2 += (*c as f64 - e).powi(2) / e;
            bins += 1;
        }
    }
    (total, chi2, bins)
}

#[test]
fn the_density_integrates_to_one_and_samples_follow_it_for_both_row_settings_and_rotations() {
    let img = map();
    for rows in [Rows::Centres, Rows::Poles] {
        let mut s = EnvSampler::new(&img, rows).expect("a lit map");
        for r in rotations() {
            let (total, chi2, bins) = check(&s, r.as_ref());
            // χ² has mean `bins` − 1 and spread √(2 bins): 6 spreads.
            let limit = bins as f64 + 6.0 * (2.0 * bins as f64).sqrt();
            eprintln!(
                "{rows:?} {r:?}: ∫ pdf dω = {total:.5}, χ² = {chi2:.0} over {bins} bins (limit {limit:.0})"
            );
            assert!((total - 1.0).abs() < 1e-3, "{rows:?}: ∫ = {total}");
            assert!(chi2 < limit, "{rows:?}: χ² {chi2} over {bins} bins");
            // Known wrong: without 1/sin θ the density is not one over the
            // sphere, nor the samples' distribution.
            s.sampling = EnvSampling::WrongNoSinJacobian;
            let (wrong_total, wrong_chi2, _) = check(&s, r.as_ref());
            eprintln!("  without 1/sin θ: ∫ = {wrong_total:.4}, χ² = {wrong_chi2:.0}");
            assert!((wrong_total - 1.0).abs() > 1e-2, "no power: ∫ {wrong_total}");
            assert!(wrong_chi2 > limit, "no power: χ² {wrong_chi2}");
            s.sampling = EnvSampling::Right;
        }
    }
}

#[test]
fn the_density_is_positive_wherever_the_map_is_lit_and_a_black_map_has_none() {
    // One lit texel: every direction whose bilinear lookup reads it is
    // sampled (the cells' weights are the lookup's exact means).
    for rows in [Rows::Centres, Rows::Poles] {
        let (w, h) = (8, 4);
        let mut pixels = vec![V3::ZERO; w * h];
        pixels[w + 5] = V3::ONE;
        let img = ImageData {
            width: w,
            height: h,
            pixels,
        };
        let s = EnvSampler::new(&img, rows).expect("one lit texel");
        let mut rng = crate::sampling::Rng::new(5);
        for _ in 0..20_000 {
            let d = crate::sampling::uniform_sphere(rng.uniform(), rng.uniform());
            let u = 0.5 + d.x.atan2(-d.z) / std::f32::consts::TAU;
            let v = d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
            if img.lookup_rows(u, v, rows).x > 1e-4 {
                assert!(s.pdf(d) > 0.0, "{rows:?}: lit at {d} but density 0");
            }
        }
        let black = ImageData {
            width: w,
            height: h,
            pixels: vec![V3::ZERO; w * h],
        };
        assert!(EnvSampler::new(&black, rows).is_none());
    }
    // Non-finite and negative texels count as black rather than poisoning
    // the distribution.
    let mut pixels = vec![V3::ZERO; 8 * 4];
    pixels[0] = V3::splat(f32::NAN);
    pixels[1] = V3::splat(-1.0);
    pixels[8] = V3::splat(f32::INFINITY);
    pixels[2 * 8 + 5] = V3::ONE;
    let img = ImageData {
        width: 8,
        height: 4,
        pixels,
    };
    let s = EnvSampler::new(&img, Rows::Centres).expect("one lit texel");
    let (d, pdf) = s.sample(0.3, 0.6).expect("a sample");
    assert!(pdf.is_finite() && pdf > 0.0 && d.is_finite());
}
