//! Flights (rk45 without chords where no geometry is near, straight where a
//! bound on ∇n says the field cannot matter) against the chord tracer at a
//! tight tolerance, on rays from heat_shimmer's camera through its plume.
use glam::DVec3;

use super::*;

fn plume() -> IndexField {
    IndexField::Plume {
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
}

const EYE: DVec3 = DVec3::new(0.0, 1.0, 4.0);
/// heat_shimmer's pixel: 30° over 240 rows.
const PIXEL: f64 = 30.0 / 240.0 * std::f64::consts::PI / 180.0;

fn medium(tol: f64) -> Medium {
    let bounds = Aabb::new(DVec3::new(-0.9, 0.25, -0.9), DVec3::new(0.9, 3.2, 0.9));
    Medium::try_new(plume(), bounds, Method::Rk45, tol, 1.0).unwrap()
}

/// The scene's hot plate and wall, outside the bounds.
fn flying(fraction: f64) -> Medium {
    medium(5e-4)
        .with_pixel_tolerance(Some(fraction))
        .unwrap()
        .with_view(EYE, PIXEL)
        .with_obstacles([
            Aabb::new(DVec3::new(-0.35, 0.0, -0.35), DVec3::new(0.35, 0.2, 0.35)),
            Aabb::new(DVec3::new(-6.0, -1.5, -6.0), DVec3::new(6.0, 4.5, -6.0)),
        ])
}

/// The straight line a ray leaves the bounds on (origin, direction) and the
/// field evaluations it took.
fn leave(m: &Medium, d: DVec3) -> (DVec3, DVec3, u64) {
    let mut ray = m.start_ray(EYE, d);
    for _ in 0..100_000 {
        let c = ray.next_chord(m);
        assert!(ray.failure().is_none(), "{:?}", ray.failure());
        if c.length.is_infinite() {
            return (c.origin, c.dir, ray.evaluations());
        }
    }
    panic!("no way out along {d:?}");
}

/// Rays over the plume's side of the image: every fourth pixel row and
/// column of a 320×240 film whose ray meets the bounds.
fn rays() -> Vec<DVec3> {
    let half = (15f64).to_radians().tan();
    let mut v = Vec::new();
    for j in (0..240).step_by(8) {
        for i in (0..320).step_by(8) {
            let x = (2.0 * (i as f64 + 0.5) / 320.0 - 1.0) * half * 320.0 / 240.0;
            let y = (1.0 - 2.0 * (j as f64 + 0.5) / 240.0) * half;
            let d = DVec3::new(x, y, -1.0).normalize();
            if medium(5e-4).bounds().clip(EYE, d).is_some() {
                v.push(d);
            }
        }
    }
    v
}

/// What an error in the exit line moves in the image, in pixels: the
/// position's over its distance from the eye plus the direction's.
fn pixels(a: (DVec3, DVec3), b: (DVec3, DVec3)) -> f64 {
    ((a.0 - b.0).length() / (a.0 - EYE).length() + (a.1 - b.1).length()) / PIXEL
}

/// Image errors (pixels) of `m` against the chord tracer at 1e-9 m, sorted
/// from the worst, and the mean evaluations per ray.
fn errors(m: &Medium) -> (Vec<f64>, f64) {
    let fine = medium(1e-9);
    let rays = rays();
    let mut errs = Vec::new();
    let mut evals = 0;
    for &d in &rays {
        let (o, t, e) = leave(m, d);
        let (fo, ft, _) = leave(&fine, d);
        errs.push(pixels((o, t), (fo, ft)));
        evals += e;
    }
    errs.sort_by(|a, b| b.total_cmp(a));
    (errs, evals as f64 / rays.len() as f64)
}

/// Every flight of heat_shimmer's rays leaves the plume on the line the
/// chord tracer finds at 1e-9 m: median within 0.05 px, 90 % within 0.25
/// px, all within 1.5 px (the turbulence focuses like a lens array, so a
/// step's error can grow on the way: the chords at the scene's 5e-4 m, with
/// 7× the evaluations, are within 0.04 px). The same with a box inside the
/// bounds (rays near it cast chords). Two variants fail: straight stretches
/// on a gradient bound a thousand times too small, and steps up to 1.5
/// wavelengths (too sparse for the pair's three evaluations).
#[test]
fn flights_agree_with_the_chord_tracer_and_a_bound_too_small_does_not() {
    assert!(flying(1.0).flies() && !medium(5e-4).flies());
    let quantiles = |e: &[f64]| (e[e.len() / 2], e[e.len() / 10], e[0]);
    let (errs, evals) = errors(&flying(super::DEFAULT_FLIGHT_PIXEL_TOLERANCE));
    let (median, p90, worst) = quantiles(&errs);
    eprintln!(
        "{} rays: median {median:.3} px, 90 % {p90:.3}, worst {worst:.3}; {evals:.1} evaluations per ray",
        errs.len()
    );
    assert!(median <= 0.05 && p90 <= 0.25 && worst <= 1.5);
    // A box inside the bounds (beside the plume's core): rays near it cast
    // chords, the others fly; the exits agree as well.
    let near = flying(1.0).with_obstacles([Aabb::new(DVec3::new(0.3, 0.9, 0.2), DVec3::new(0.5, 1.1, 0.4))]);
    let (errs, near_evals) = errors(&near);
    let (median, p90, worst) = quantiles(&errs);
    eprintln!("with a box inside: median {median:.3} px, 90 % {p90:.3}, worst {worst:.3}; {near_evals:.1} evaluations per ray");
    assert!(median <= 0.05 && p90 <= 0.25 && worst <= 1.5 && near_evals > evals);
    let (wrong, _) = errors(&flying(1.0).with_straight_scale(1e-3));
    let (median, p90, worst) = quantiles(&wrong);
    eprintln!("bound ×1e-3: median {median:.3} px, 90 % {p90:.3}, worst {worst:.3}");
    assert!(median > 0.05, "{median}");
    let base = flying(1.0);
    let long = base.field().flight_step() * 1.5 / crate::media::field::FLIGHT_WAVELENGTHS;
    let (sparse, sparse_evals) = errors(&base.with_flight_step(long));
    let (median, p90, worst) = quantiles(&sparse);
    eprintln!("steps of 1.5 wavelengths: median {median:.3} px, 90 % {p90:.3}, worst {worst:.3}; {sparse_evals:.1} evaluations per ray");
    assert!(median > 0.05 && p90 > 0.25, "{median} {p90}");
}

/// A ray that flies and then casts chords near a box inside the bounds: a
/// hit on the first chord after the flight is refined on the arc (the
/// chord tracer at 1e-9 m crossing the same plane), not on an arc from
/// where the flight began.
#[test]
fn hits_after_a_flight_are_refined_on_the_arc() {
    let boxed = flying(1.0).with_obstacles([Aabb::new(DVec3::new(0.3, 0.9, 0.2), DVec3::new(0.5, 1.1, 0.4))]);
    // The first chord of `ray` crossing the plane through q with normal n
    // (at or after the first one with `skipped` > 0 when `after_flight`).
    let crossing = |m: &Medium, ray: &mut CurvedRay, q: DVec3, n: DVec3, after_flight: bool| {
        for _ in 0..100_000 {
            let c = ray.next_chord(m);
            assert!(ray.failure().is_none() && c.length > 0.0);
            if after_flight {
                if c.skipped > 0.0 && ray.is_inside() {
                    return (c, 0.5 * c.length, c.origin + c.dir * (0.5 * c.length));
                }
                continue;
            }
            let t = (q - c.origin).dot(n) / c.dir.dot(n);
            if t >= 0.0 && t <= c.length {
                return (c, t, c.origin + c.dir * t);
            }
        }
        panic!("no such chord");
    };
    let d = (DVec3::new(0.4, 1.0, 0.4) - EYE).normalize();
    let mut ray = boxed.start_ray(EYE, d);
    let (chord, t, p) = crossing(&boxed, &mut ray, DVec3::ZERO, DVec3::Z, true);
    let (hit, _) = ray.refine_hit(&boxed, &chord, t, p, chord.dir);
    let fine = medium(1e-9);
    let (_, _, arc) = crossing(&fine, &mut fine.start_ray(EYE, d), p, chord.dir, false);
    let miss = (hit - arc).length();
    eprintln!(
        "refined hit {miss:.2e} m from the arc's crossing (chord after {:.3} m of flight)",
        chord.skipped
    );
    assert!(miss < 1e-3, "{miss}");
}

/// The chords of `ray` until it leaves for good (at most 10,000), and its
/// evaluations.
fn chords_of(m: &Medium, ray: &mut CurvedRay) -> (Vec<Chord>, u64) {
    let mut v = Vec::new();
    for _ in 0..10_000 {
        let c = ray.next_chord(m);
        v.push(c);
        if c.length.is_infinite() || ray.failure().is_some() {
            break;
        }
    }
    (v, ray.evaluations())
}

/// heat_shimmer's camera rays flown side by side (eight field evaluations
/// per vector operation) then cast take the chords, bit for bit, and the
/// evaluations of each ray alone, with a box inside the bounds that some
/// rays stop flying near. Power: the flight flown beforehand is what a ray
/// takes (moved a millimetre, the ray follows it), and one flown for
/// another start is refused.
#[test]
fn rays_flown_side_by_side_cast_as_rays_alone() {
    let boxed = flying(1.0).with_obstacles([Aabb::new(DVec3::new(0.3, 0.9, 0.2), DVec3::new(0.5, 1.1, 0.4))]);
    for m in [flying(1.0), boxed] {
        let dirs = rays();
        let mut side: Vec<CurvedRay> = dirs.iter().map(|&d| m.start_ray(EYE, d)).collect();
        fly_camera_rays(&m, &mut side);
        let flown = side.iter().filter(|r| r.flown.is_some()).count();
        assert!(flown * 10 > dirs.len() * 9, "{flown} of {} flown", dirs.len());
        for (r, &d) in side.iter_mut().zip(&dirs) {
            let together = chords_of(&m, r);
            assert!(r.flown.is_none());
            assert_eq!(together, chords_of(&m, &mut m.start_ray(EYE, d)), "along {d}");
        }
    }
    let m = flying(1.0);
    let (d0, d1) = (
        DVec3::new(0.02, 0.01, -1.0).normalize(),
        DVec3::new(-0.03, 0.02, -1.0).normalize(),
    );
    let alone = chords_of(&m, &mut m.start_ray(EYE, d0));
    let mut pair = [m.start_ray(EYE, d0), m.start_ray(EYE, d1)];
    fly_camera_rays(&m, &mut pair);
    let [mut a, mut b] = pair;
    let mut moved = a.clone();
    if let Some(f) = moved.flown.as_mut() {
        f.flight.st.r.y += 1e-3;
    }
    assert_ne!(chords_of(&m, &mut moved).0, alone.0);
    std::mem::swap(&mut a.flown, &mut b.flown);
    assert_eq!(chords_of(&m, &mut a), alone);
}

/// A ray after a diffuse bounce (`CurvedRay::after_diffuse`) flies as a
/// camera ray of a medium whose pixel tolerance is the indirect scale times
/// larger, bit for bit; a restart makes it a camera ray again. The two
/// tolerances give different flights (steps up to 20 wavelengths, so that
/// the tolerance, not the cap, sets them), and the looser one fewer
/// evaluations.
#[test]
fn rays_after_a_diffuse_bounce_fly_at_the_indirect_tolerance() {
    let step = 20.0 * plume().flight_step() / crate::media::field::FLIGHT_WAVELENGTHS;
    let m = flying(0.05).with_flight_step(step);
    let k = m.indirect_tolerance_scale();
    let loose = flying(0.05 * k).with_flight_step(step);
    let (mut differ, mut evals) = (0, [0u64; 2]);
    for d in rays() {
        let mut after = m.start_ray(EYE, d);
        after.after_diffuse(&m);
        let (a, _) = chords_of(&m, &mut after);
        let (b, eb) = chords_of(&loose, &mut loose.start_ray(EYE, d));
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "{d:?}");
        let mut camera = m.start_ray(EYE, d);
        after.after_diffuse(&m);
        m.restart_ray(&mut after, EYE, d);
        let (c, ec) = chords_of(&m, &mut camera);
        let (c2, _) = chords_of(&m, &mut after);
        assert_eq!(format!("{c:?}"), format!("{c2:?}"), "{d:?}");
        differ += usize::from(format!("{a:?}") != format!("{c:?}"));
        evals[0] += eb;
        evals[1] += ec;
    }
    assert!(differ > 0 && evals[0] < evals[1], "{differ} {evals:?}");
}
