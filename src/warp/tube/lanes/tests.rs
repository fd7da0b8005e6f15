//! Every level's lanes against the scalar `resid_jac` and `step`, bit for
//! bit.
use super::*;
use crate::warp::tube::test_rng::Lcg;

const FAMS: [Family; 4] = [Family::Through4, Family::Tir2, Family::Wall2, Family::Hollow2];

/// Every level this CPU has, widest first (the scalar level always).
fn levels() -> Vec<SimdLevel> {
    [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Scalar]
        .into_iter()
        .filter(|&l| SimdLevel::detect() >= l)
        .collect()
}

/// A random lane: every family, with targets and points in and out of
/// their domains, so that about half the evaluations are `None`.
fn random_lane(rng: &mut Lcg, r_in: f64) -> LaneIn {
    let fam = FAMS[(rng.next() * 4.0) as usize % 4];
    let p = if fam == Family::Hollow2 {
        DVec2::new(rng.next() - 0.5, rng.next() - 0.5) * r_in
    } else {
        DVec2::new(rng.next() * 12.0 - 6.0, rng.next() * 12.0 - 6.0)
    };
    LaneIn {
        fam,
        p,
        dv: rng.next() * 6.0 - 3.0,
        b: rng.next() * 2.2 - 1.1,
        beta: rng.next() * 1.8 - 0.9,
    }
}

/// The edges of the domains: b on the radii, at ±0 and at the eye's
/// distance, β at 0, at the step's bound and beyond 1, NaNs, and a
/// target on the axis; every family for each.
fn edge_lanes(r_in: f64, rho: f64) -> Vec<LaneIn> {
    let bs = [
        0.0,
        -0.0,
        r_in,
        -r_in,
        1.0,
        -1.0,
        rho,
        f64::MIN_POSITIVE,
        r_in * (1.0 - f64::EPSILON),
        1.0 - f64::EPSILON,
        f64::NAN,
        f64::INFINITY,
    ];
    let betas = [0.0, -0.0, 0.999_999, -0.999_999, 0.5, 1.0, 1.2, f64::NAN];
    let ps = [DVec2::ZERO, DVec2::new(r_in * 0.5, 0.1), DVec2::new(3.0, -2.0)];
    let mut out = Vec::new();
    for &fam in &FAMS {
        for &b in &bs {
            for &beta in &betas {
                for &p in &ps {
                    out.push(LaneIn {
                        fam,
                        p,
                        dv: 0.7,
                        b,
                        beta,
                    });
                }
            }
        }
    }
    out
}

/// `lanes` as padded rows, with their tolerances.
fn rows_of(lanes: &[LaneIn], tol: impl Fn(usize) -> f64) -> Rows {
    let mut rows = Rows::default();
    for (i, l) in lanes.iter().enumerate() {
        rows.push(l, tol(i));
    }
    rows.pad(lanes.len());
    assert_eq!(rows.b.len() % PAD, 0);
    rows
}

/// The bits of `x`, but one for every NaN: Rust leaves a NaN result's
/// sign and payload unspecified (x86 propagates the first operand's
/// NaN, and LLVM may swap the operands of a commutative operation), so
/// only NaN-ness is the function's answer; every other bit, the sign
/// of a zero included, must agree.
fn canon(x: f64) -> u64 {
    if x.is_nan() {
        f64::NAN.to_bits()
    } else {
        x.to_bits()
    }
}

fn bits(o: &LaneOut) -> Option<[u64; 6]> {
    o.map(|(r, j)| [r[0], r[1], j[0][0], j[0][1], j[1][0], j[1][1]].map(canon))
}

fn step_bits(s: Step) -> Option<(u64, u64)> {
    match s {
        Step::Next(b, beta) => Some((canon(b), canon(beta))),
        Step::Root => Some((0, 1)),
        Step::Fail => None,
    }
}

/// The lanes whose evaluation at `k`'s level differs from the scalar
/// `resid_jac` in any bit (or in being `None`).
fn mismatches(k: &Consts, c: &HollowCylinder, eye: DVec2, lanes: &[LaneIn]) -> usize {
    let rows = rows_of(lanes, |_| 0.0);
    let got = resid_jac_rows(k, &rows);
    assert_eq!(got.len(), rows.b.len());
    lanes
        .iter()
        .zip(&got)
        .filter(|(l, g)| bits(g) != bits(&c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta)))
        .count()
}

/// This CPU's levels are pulp's tokens: AVX-512 where it has AVX-512
/// F/BW/CD/DQ/VL, AVX2 where it has AVX2 and FMA, and a cap is obeyed.
#[test]
fn the_level_follows_the_cpu_and_the_cap() {
    let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, 0.8, 1.5).unwrap();
    let e = DVec2::new(0.3, 4.0);
    #[cfg(target_arch = "x86_64")]
    let (v3, v4) = {
        use std::arch::is_x86_feature_detected as has;
        let v3 = has!("avx2") && has!("fma") && has!("bmi1") && has!("bmi2") && has!("lzcnt");
        let v4 = v3
            && has!("avx512f")
            && has!("avx512bw")
            && has!("avx512cd")
            && has!("avx512dq")
            && has!("avx512vl");
        (v3, v4)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let (v3, v4) = (false, false);
    let best = if v4 {
        SimdLevel::Avx512
    } else if v3 {
        SimdLevel::Avx2
    } else {
        SimdLevel::Scalar
    };
    assert_eq!(SimdLevel::detect(), best);
    assert_eq!(Consts::new(&c, e).level(), best);
    for cap in [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Scalar] {
        let k = Consts::with_level(&c, e, cap);
        assert_eq!(k.level(), cap.min(best), "{cap:?}");
        assert_eq!(k.lanes(), cap.min(best).lanes());
    }
    println!("this CPU: {best:?}, levels tested {:?}", levels());
}

/// Every lane at every level this CPU has is the scalar `resid_jac`,
/// bit for bit, for every family, in and out of its domain (the `None`s
/// too) and on its edges, with the families mixed across the lanes.
#[test]
fn every_level_equals_the_scalar_resid_jac() {
    let mut rng = Lcg(7);
    for (r_in, eye) in [(0.8, DVec2::new(0.3, 4.0)), (0.5, DVec2::new(-2.5, -1.5))] {
        let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, r_in, 1.5).unwrap();
        let mut lanes: Vec<LaneIn> = (0..20_000).map(|_| random_lane(&mut rng, r_in)).collect();
        let some = lanes
            .iter()
            .filter(|l| c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta).is_some())
            .count();
        assert!(some > 2000 && lanes.len() - some > 2000, "{some}");
        let edges = edge_lanes(r_in, eye.length());
        let edge_some = edges
            .iter()
            .filter(|l| c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta).is_some())
            .count();
        assert!(edge_some > 20 && edges.len() - edge_some > 20, "{edge_some}");
        lanes.extend(edges);
        // An odd count: the last evaluation is padded.
        lanes.push(random_lane(&mut rng, r_in));
        for level in levels() {
            let k = Consts::with_level(&c, eye, level);
            assert_eq!(k.level(), level);
            assert_eq!(mismatches(&k, &c, eye, &lanes), 0, "{level:?}");
        }
    }
}

/// The bit-for-bit comparison has the power to see a change of the
/// operations: with one product-difference of the residual fused into
/// a multiply-add (one rounding less), many lanes at every vector
/// level differ from the scalar function.
#[test]
fn a_fused_multiply_add_is_caught() {
    let mut rng = Lcg(11);
    let eye = DVec2::new(0.3, 4.0);
    let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, 0.8, 1.5).unwrap();
    let lanes: Vec<LaneIn> = (0..4000).map(|_| random_lane(&mut rng, 0.8)).collect();
    for level in levels() {
        let mut k = Consts::with_level(&c, eye, level);
        assert_eq!(mismatches(&k, &c, eye, &lanes), 0, "{level:?}");
        k.fused = true;
        let bad = mismatches(&k, &c, eye, &lanes);
        println!("{level:?}: {bad} of {} lanes differ when fused", lanes.len());
        if level == SimdLevel::Scalar {
            // The scalar level is the scalar function itself.
            assert_eq!(bad, 0);
        } else {
            assert!(bad > 100, "{level:?}: {bad}");
        }
    }
}

/// `newton_rows` at every level (the rows loaded as vectors, the next
/// point stored back) is `step` of each row bit for bit, padding
/// included, edges too, and leaves a row that does not step where it
/// was.
#[test]
fn every_level_steps_as_the_scalar_step() {
    let mut rng = Lcg(13);
    let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, 0.5, 1.5).unwrap();
    let eye = DVec2::new(0.3, 4.0);
    let mut seen = [0; 3];
    let mut sizes: Vec<usize> = vec![1, 3, 4, 7, 8, 9, 64, 101, 5000];
    let edges = edge_lanes(0.5, eye.length());
    sizes.push(edges.len());
    for (si, &n) in sizes.iter().enumerate() {
        let lanes: Vec<LaneIn> = if si == sizes.len() - 1 {
            edges.clone()
        } else {
            (0..n).map(|_| random_lane(&mut rng, 0.5)).collect()
        };
        // Some tolerances above any residual (roots), most tiny.
        let tols: Vec<f64> = (0..n)
            .map(|_| {
                if rng.next() < 0.2 {
                    1e3
                } else {
                    rng.next().powi(8) * 4.0
                }
            })
            .collect();
        let want: Vec<Step> = lanes
            .iter()
            .zip(&tols)
            .map(|(l, &tol)| step(c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta), l.b, l.beta, tol))
            .collect();
        for level in levels() {
            let k = Consts::with_level(&c, eye, level);
            let mut rows = rows_of(&lanes, |i| tols[i]);
            let mut status = vec![NEXT; rows.b.len()];
            newton_rows(&k, &mut rows, &mut status);
            for (i, (l, w)) in lanes.iter().zip(&want).enumerate() {
                let got = match status[i] {
                    FAIL => Step::Fail,
                    ROOT => Step::Root,
                    _ => Step::Next(rows.b[i], rows.beta[i]),
                };
                assert_eq!(step_bits(got), step_bits(*w), "{level:?} {l:?}");
                if status[i] != NEXT {
                    assert_eq!(
                        (canon(rows.b[i]), canon(rows.beta[i])),
                        (canon(l.b), canon(l.beta))
                    );
                }
                seen[status[i] as usize] += 1;
            }
        }
    }
    assert!(seen.iter().all(|&n| n > 100), "{seen:?}");
}
