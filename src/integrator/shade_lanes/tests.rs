//! The kernel against the scalar model it replaces, lane by lane at every
//! vector level.
use super::lane_math::sincos_turns;
use super::*;
use crate::optics;
use crate::sampling::{cosine_hemisphere, uniform_sphere};
use std::f32::consts::FRAC_1_PI;

use crate::sampling::Rng;
use crate::vector_levels as levels;

/// A full stage of random lanes, even ones Lambertian, odd ones
/// interfaces, as `prepare` leaves them (the shading normal tilted from the
/// geometric one at some), lit by a rect light above.
fn random_lanes(rng: &mut Rng, arch: pulp::Arch) -> ShadeLanes {
    let mut s = ShadeLanes {
        arch,
        light: Some(RectLight {
            corner: V3::new(-1.0, 4.0, -1.0),
            edge_u: V3::new(2.0, 0.0, 0.0),
            edge_v: V3::new(0.0, 0.0, 2.0),
            normal: V3::new(0.0, -1.0, 0.0),
            area: 4.0,
            radiance: V3::new(5.0, 4.0, 3.0),
        }),
        count: STAGE,
        ..ShadeLanes::default()
    };
    let pairs = [(1.0, 1.5), (1.5, 1.0), (1.33, 1.5), (1.5, 1.33)];
    for i in 0..STAGE {
        let side = uniform_sphere(rng.uniform(), rng.uniform());
        let tilt = if i % 4 < 2 { 0.0 } else { 0.2 };
        let n = (side + uniform_sphere(rng.uniform(), rng.uniform()) * tilt).normalize();
        let mut d = uniform_sphere(rng.uniform(), rng.uniform());
        if d.dot(side) > 0.0 {
            d = -d;
        }
        let p = V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0;
        set3(&mut s.dir, i, d);
        set3(&mut s.p, i, p);
        set3(&mut s.side, i, side);
        set3(&mut s.n, i, n);
        set3(&mut s.beta, i, V3::new(0.9, 0.5, 0.7));
        s.eta_scale[i] = 1.0;
        set3(&mut s.albedo, i, V3::new(0.8, 0.6, 0.4));
        for u in &mut s.u {
            u[i] = rng.uniform();
        }
        let (n1, n2) = pairs[i / 2 % 4];
        (s.n1[i], s.n2[i]) = (n1, n2);
        let cos_i = d.dot(n).abs().min(1.0);
        let eta = n1 / n2;
        s.tir[i] = (eta * eta * (1.0 - cos_i * cos_i).max(0.0) > 1.0) as u8 as f32;
        s.diffuse[i] = (i % 2 == 0) as u8 as f32;
        s.nee[i] = s.diffuse[i];
    }
    s
}

fn close(a: V3, b: V3) -> bool {
    (a - b).abs().max_element() <= 2e-5
}

/// The kernel at every vector level against the scalar model it
/// replaces: the bounce against `sampling::cosine_hemisphere`, the
/// interface against `optics` in f64 (Fresnel's choice, reflection,
/// refraction, the radiance scale), the light sample against its
/// definition. A bounce with its two numbers swapped is caught.
#[test]
fn the_kernel_is_the_scalar_model_at_every_level() {
    for arch in levels() {
        let mut rng = Rng::new(7);
        let (mut checked, mut swapped_caught, mut diffuse) = (0, 0, 0);
        for _ in 0..500 {
            let mut s = random_lanes(&mut rng, arch);
            let (before_dir, before_beta) = (s.dir, s.beta);
            assert_eq!(s.shade() % STAGE, 0, "{arch:?}: whole vectors");
            let c = &s;
            for i in 0..STAGE {
                let (d, n, side, p) = (
                    get3(&before_dir, i),
                    get3(&s.n, i),
                    get3(&s.side, i),
                    get3(&s.p, i),
                );
                let dir = get3(&c.dir, i);
                let beta0 = get3(&before_beta, i);
                if s.diffuse[i] != 0.0 {
                    let wi = cosine_hemisphere(n, s.u[2][i], s.u[3][i]);
                    assert_eq!(s.below[i] != 0.0, side.dot(wi) <= 0.0, "{arch:?} lane {i}");
                    assert!(close(dir, wi), "{arch:?} lane {i}: {dir} vs {wi}");
                    diffuse += 1;
                    swapped_caught += !close(dir, cosine_hemisphere(n, s.u[3][i], s.u[2][i])) as u32;
                    assert!((s.prev_pdf[i] - n.dot(wi) * FRAC_1_PI).abs() < 1e-5);
                    assert!(close(get3(&c.beta, i), beta0 * get3(&s.albedo, i)));
                    // The light sample: its point, weight and shadow ray.
                    let l = s.light.unwrap();
                    let q = l.corner + l.edge_u * s.u[0][i] + l.edge_v * s.u[1][i];
                    let to = q - p;
                    let lw = to.normalize();
                    let (cos, cos_l) = (n.dot(lw), -l.normal.dot(lw));
                    let seen = cos > 0.0 && cos_l > 0.0 && side.dot(lw) > 0.0;
                    assert_eq!(s.shadow[i] != 0.0, seen, "{arch:?} lane {i}");
                    if seen {
                        let pdf = to.length_squared() / (l.area * cos_l);
                        let w = power_heuristic(pdf, cos * FRAC_1_PI);
                        let c = beta0 * get3(&s.albedo, i) * FRAC_1_PI * l.radiance * (cos * w / pdf);
                        let got = get3(&s.contrib, i);
                        // Both in f32, in other orders: the light's cosine
                        // and distance near grazing carry their rounding
                        // into the density (seen up to 1.0e-4 relative).
                        assert!(
                            (got - c).abs().max_element() <= 3e-4 * c.max_element(),
                            "{got} vs {c}"
                        );
                        assert!(close(get3(&s.shadow_dir, i), lw));
                    }
                } else {
                    let (dd, nd) = (d.as_dvec3(), n.as_dvec3());
                    let (n1, n2) = (s.n1[i] as f64, s.n2[i] as f64);
                    let f = optics::fresnel_dielectric(dd.dot(nd).abs(), n1, n2);
                    let u = s.u[0][i] as f64;
                    if s.tir[i] == 0.0 && (u - f).abs() < 1e-5 {
                        continue; // a tie within rounding
                    }
                    let reflect = s.tir[i] != 0.0 || u < f;
                    let want = if reflect {
                        optics::reflect(dd, nd).normalize()
                    } else {
                        optics::refract(dd, nd, n1, n2).unwrap().normalize()
                    };
                    // Where the shading normal sends it to the wrong side,
                    // the kernel turns to the geometric normal: not checked here.
                    let right_side = (want.as_vec3a().dot(side) > 0.0) == reflect;
                    if right_side {
                        assert!(close(dir, want.as_vec3a()), "{arch:?} lane {i}: {dir} vs {want}");
                    }
                    let k = if reflect { 1.0 } else { (n1 / n2).powi(2) as f32 };
                    assert!(close(get3(&c.beta, i), beta0 * k));
                    let eta = if reflect { 1.0 } else { (n2 / n1).powi(2) as f32 };
                    assert!((c.eta_scale[i] - eta).abs() < 1e-5, "{arch:?} lane {i}");
                    let off = if reflect { side } else { -side };
                    let org = get3(&c.org, i);
                    assert!(org.distance(p) < 1e-5 && (org - p).dot(off) > 0.0);
                }
                checked += 1;
            }
        }
        assert!(checked > 14000, "{arch:?}: {checked}");
        // Swapping the bounce's numbers moves nearly every direction.
        assert!(
            swapped_caught * 10 > diffuse * 9,
            "{arch:?}: {swapped_caught} of {diffuse}"
        );
    }
}

/// The kernel's sine and cosine of whole turns against the library's.
#[test]
fn sincos_of_turns_is_accurate_at_every_level() {
    struct Probe(Vec<f32>);
    impl pulp::WithSimd for Probe {
        type Output = Vec<(f32, f32)>;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, simd: S) -> Self::Output {
            let mut out = Vec::new();
            for c in self.0.chunks(S::F32_LANES) {
                let u = simd.partial_load_f32s(c);
                let (sin, cos) = sincos_turns(simd, u);
                let (mut a, mut b) = (vec![0.0; c.len()], vec![0.0; c.len()]);
                simd.partial_store_f32s(&mut a, sin);
                simd.partial_store_f32s(&mut b, cos);
                out.extend(a.into_iter().zip(b));
            }
            out
        }
    }
    let us: Vec<f32> = (0..=1 << 16).map(|k| k as f32 / (1 << 16) as f32).collect();
    for arch in levels() {
        let got = arch.dispatch(Probe(us.clone()));
        let worst = us
            .iter()
            .zip(&got)
            .map(|(&u, &(s, c))| {
                let phi = 2.0 * std::f64::consts::PI * u as f64;
                (s as f64 - phi.sin()).abs().max((c as f64 - phi.cos()).abs())
            })
            .fold(0.0, f64::max);
        assert!(worst < 3e-7, "{arch:?}: {worst}");
    }
}
