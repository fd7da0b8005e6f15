//! Unit tests of the gradient-index math (they can fail: each compares against an
//! independent answer).
use glam::DVec3;

use super::stepper::{State, Stepper};
use super::*;

fn linear(n0: f64, m: f64) -> IndexField {
    IndexField::Linear {
        n0,
        m,
        up: DVec3::Y,
        base: 0.0,
    }
}

fn hot_ground() -> IndexField {
    IndexField::HotGround {
        n_inf: 1.000_293,
        dn: 1e-4,
        h0: 0.3,
        up: DVec3::Y,
        base: 0.0,
    }
}

fn dir(deg: f64) -> DVec3 {
    let a = deg.to_radians();
    DVec3::new(a.cos(), a.sin(), 0.0)
}

fn advance(
    field: &IndexField,
    method: Method,
    tol: f64,
    step: f64,
    p: DVec3,
    d: DVec3,
    len: f64,
) -> (State, u64) {
    let mut s = Stepper::new(field, method, tol, step);
    let mut ev = 0;
    let st = State::new(field, p, d, &mut ev).unwrap();
    let mut h = f64::INFINITY;
    let end = s.advance(&st, len, &mut h, &mut Vec::new()).unwrap();
    (end, ev + s.evals)
}

#[test]
fn exact_matches_rk45_weak_to_strong_gradients_and_launches() {
    // (m, arc length, launch angles in degrees incl. grazing 1e-4 and 1e-8 rad)
    let grazing = [1e-4f64.to_degrees(), 1e-8f64.to_degrees()];
    for (m, len) in [(1e-6, 10_000.0), (1e-3, 1000.0), (0.1, 100.0), (1.0, 10.0)] {
        let f = linear(1.0, m);
        for deg in [10.0, -5.0, 0.0, -0.3, 45.0, grazing[0], grazing[1], -grazing[0]] {
            let p = DVec3::new(0.0, 2.0, 0.0);
            let (e, _) = advance(&f, Method::Exact, 1.0, 1.0, p, dir(deg), len);
            let (r, _) = advance(&f, Method::Rk45, 1e-12, 1.0, p, dir(deg), len);
            let err = (e.r - r.r).length();
            assert!(
                err <= 1e-9 * len,
                "m={m} deg={deg}: |exact − rk45| = {err:e} > 1e-9 × {len}"
            );
            assert!((e.t - r.t).length() < 1e-9, "m={m} deg={deg}: directions differ");
            // The weak gradient must still bend the ray (no cancellation to zero).
            if deg == 0.0 && m * len <= 0.01 {
                let expect = 0.5 * m / 1.0 * len * len; // parabola to first order
                let dy = e.r.y - p.y;
                assert!(
                    (dy - expect).abs() <= 0.05 * expect + 1e-12,
                    "m={m}: dy {dy} vs {expect}"
                );
            }
        }
    }
}

#[test]
fn exact_turning_point_and_default_tolerance() {
    // Falling ray in n increasing upward turns at tanh(mτ) = −w/n.
    let f = linear(1.0, 0.01);
    let p = DVec3::new(0.0, 5.0, 0.0);
    let mut ev = 0;
    let st = State::new(&f, p, dir(-8.0), &mut ev).unwrap();
    let tau = exact::turning_tau(0.01, DVec3::Y, &st).unwrap();
    let (tp, v, s) = exact::at_tau(0.01, DVec3::Y, &st, tau);
    assert!(v.y.abs() < 1e-14 * v.length());
    // Snell invariant: n·cosθ = n(turning point) (horizontal there).
    let inv = st.n * 8f64.to_radians().cos();
    assert!((f.n(tp) - inv).abs() < 1e-14);
    // rk45 at its default-like tolerance passes through the same point.
    let (r, _) = advance(&f, Method::Rk45, 1e-9, 1.0, p, dir(-8.0), s);
    assert!((r.r - tp).length() < 1e-6 * s, "{:?} vs {tp:?}", r.r);
    assert!(r.t.y.abs() < 1e-6);
}

#[test]
fn rk4_is_fourth_order() {
    let f = linear(1.0, 0.1);
    let p = DVec3::new(0.0, 1.0, 0.0);
    let len = 40.0;
    let (e, _) = advance(&f, Method::Exact, 1.0, 1.0, p, dir(-20.0), len);
    let err = |h: f64| (advance(&f, Method::Rk4, 1.0, h, p, dir(-20.0), len).0.r - e.r).length();
    let (e1, e2, e3) = (err(2.0), err(1.0), err(0.5));
    for (a, b) in [(e1, e2), (e2, e3)] {
        let ratio = a / b;
        assert!(
            (10.0..26.0).contains(&ratio),
            "halving the step divided the error by {ratio} ({a:e} → {b:e})"
        );
    }
}

/// Bogacki–Shampine's step against the linear field's closed form: the
/// local error of the solution falls 16× per halving (3rd order) and the
/// error estimate about 8× (its 2nd-order partner), and the estimate
/// bounds the solution's error. Equal weights (consistent, but 1st order)
/// fall 4×.
#[test]
fn bogacki_shampine_is_third_order_and_equal_weights_are_not() {
    use super::stepper::BS23_B;
    let f = linear(1.0, 0.1);
    let mut ev = 0;
    let st = State::new(&f, DVec3::new(0.0, 1.0, 0.0), dir(-20.0), &mut ev).unwrap();
    let step = |h: f64, b: [f64; 3]| {
        let (end, er, _) = Stepper::new(&f, Method::Rk45, 1.0, 1.0)
            .bs23_weighted(&st, h, b)
            .unwrap();
        let exact = exact::advance(&f, &st, h).unwrap();
        ((end.r - exact.r).length(), er)
    };
    let halvings = |b: [f64; 3]| {
        let (e1, s1) = step(0.8, b);
        let (e2, s2) = step(0.4, b);
        (e1 / e2, s1 / s2, e1, s1)
    };
    let (ratio, est_ratio, err, est) = halvings(BS23_B);
    assert!(
        (12.0..20.0).contains(&ratio),
        "solution error fell {ratio}× per halving"
    );
    assert!(
        (6.0..10.0).contains(&est_ratio),
        "error estimate fell {est_ratio}× per halving"
    );
    assert!(err < est, "error {err:e} above its estimate {est:e}");
    let (wrong, _, _, _) = halvings([1.0 / 3.0; 3]);
    eprintln!("per halving: solution {ratio:.1}×, estimate {est_ratio:.1}×, equal weights {wrong:.1}×");
    assert!(!(12.0..20.0).contains(&wrong), "equal weights fell {wrong}×");
}

#[test]
fn constant_field_is_a_straight_line_exactly() {
    let f = IndexField::Constant { n: 1.33 };
    let p = DVec3::new(1.0, 2.0, 3.0);
    let d = DVec3::new(0.3, -0.4, 0.5).normalize();
    for m in [Method::Rk45, Method::Rk4, Method::Exact] {
        let (e, _) = advance(&f, m, 1e-6, 0.7, p, d, 10.0);
        assert!((e.r - (p + d * 10.0)).length() < 1e-12, "{m}: {:?}", e.r);
        assert!((e.t - d).length() < 1e-15);
    }
}

#[test]
fn n_cos_theta_is_conserved_in_stratified_fields() {
    for f in [hot_ground(), linear(1.0003, -1e-4)] {
        let p = DVec3::new(0.0, 1.5, 0.0);
        let d = dir(-0.5);
        let (e, _) = advance(&f, Method::Rk45, 1e-10, 1.0, p, d, 500.0);
        let a = f.n(p) * (1.0 - d.y * d.y).sqrt();
        let b = f.n(e.r) * (1.0 - e.t.y * e.t.y).sqrt();
        assert!((a - b).abs() < 1e-12, "{} {a} vs {b}", f.kind());
    }
}

fn medium(field: IndexField, method: Method, tol: f64, step: f64) -> Medium {
    let b = Aabb::new(DVec3::new(-1.0, 0.0, -10.0), DVec3::new(2000.0, 50.0, 10.0));
    Medium::try_new(field, b, method, tol, step).unwrap()
}

fn trace_chords(m: &Medium, p: DVec3, d: DVec3) -> (CurvedRay, Vec<(Chord, State)>) {
    let mut ray = m.start_ray(p, d);
    let mut out = Vec::new();
    for _ in 0..100_000 {
        let before = ray.st;
        let c = ray.next_chord(m);
        if !c.length.is_finite() || c.length == 0.0 {
            break;
        }
        out.push((c, before));
    }
    (ray, out)
}

#[test]
fn inferior_mirage_turns_upward_and_chords_stay_within_tolerance() {
    let tol = 1e-3;
    let m = medium(hot_ground(), Method::Rk45, tol, 1.0);
    let p = DVec3::new(0.0, 1.5, 0.0);
    let (ray, chords) = trace_chords(&m, p, dir(-0.5));
    assert!(ray.failure().is_none());
    assert!(
        ray.direction().y > 0.0,
        "launched down, must come back up: {:?}",
        ray.direction()
    );
    assert!(chords.iter().any(|(c, _)| c.dir.y > 0.0) && chords[0].0.dir.y < 0.0);
    let lowest = chords
        .iter()
        .map(|(c, _)| c.origin.y)
        .fold(f64::INFINITY, f64::min);
    assert!(lowest > 0.0 && lowest < 1.0, "turning height {lowest}");
    // Every chord against the dense arc from its start (rk45 at 1e-12).
    let mut worst = 0.0f64;
    for (c, st) in chords.iter().filter(|(_, st)| st.n.is_finite()) {
        let mut s = Stepper::new(m.field(), Method::Rk45, 1e-12, 1.0);
        let mut h = f64::INFINITY;
        let arc = c.length * 1.000_001;
        for k in 1..=16 {
            let q = s
                .advance(st, arc * k as f64 / 16.0, &mut h, &mut Vec::new())
                .unwrap();
            let u = (q.r - c.origin).dot(c.dir).clamp(0.0, c.length);
            worst = worst.max((q.r - (c.origin + c.dir * u)).length());
        }
    }
    assert!(
        worst <= tol * 1.05,
        "chord deviates {worst:e} m from the arc (tolerance {tol:e})"
    );
    assert!(
        worst > tol * 0.05,
        "chords are needlessly short: worst deviation {worst:e}"
    );
}

#[test]
fn chord_count_falls_as_tolerance_grows_and_refine_lands_on_the_arc() {
    let f = linear(1.0, 0.01);
    let p = DVec3::new(0.0, 1.0, 0.0);
    let mut counts = Vec::new();
    for tol in [1e-6, 1e-4, 1e-2] {
        let m = medium(f.clone(), Method::Rk45, tol, 1.0);
        counts.push(trace_chords(&m, p, dir(0.0)).1.len());
    }
    assert!(counts[0] > counts[1] && counts[1] > counts[2], "{counts:?}");
    // Refine against the plane x = 30.
    let m = medium(f.clone(), Method::Rk45, 1e-3, 1.0);
    let mut ray = m.start_ray(p, dir(0.0));
    loop {
        let c = ray.next_chord(&m);
        assert!(c.length.is_finite() && c.length > 0.0);
        let end = c.origin + c.dir * c.length;
        if end.x >= 30.0 {
            let t = (30.0 - c.origin.x) / c.dir.x;
            let hit = c.origin + c.dir * t;
            let (q, tan) = ray.refine_hit(&m, &c, t, hit, DVec3::X);
            assert!((q.x - 30.0).abs() < 1e-9, "{q:?}");
            // Against the closed form at the same x.
            let mut ev = 0;
            let st = State::new(&f, p, dir(0.0), &mut ev).unwrap();
            let (pe, ve, _) = exact::at_tau(0.01, DVec3::Y, &st, 30.0 / st.v.x);
            assert!((q - pe).length() < 1e-6, "refined {q:?} vs exact {pe:?}");
            assert!((tan - ve.normalize()).length() < 1e-6);
            assert!(
                (hit - pe).length() > 1e-5,
                "the chord point itself was already on the arc?"
            );
            break;
        }
    }
}

#[test]
fn outside_the_bounds_rays_are_straight_and_free() {
    let m = medium(linear(1.0, 0.01), Method::Rk45, 1e-3, 1.0);
    let mut ray = m.start_ray(DVec3::new(-10.0, 10.0, 0.0), DVec3::X);
    let c = ray.next_chord(&m);
    assert!((c.length - 9.0).abs() < 1e-12 && ray.is_inside());
    let mut miss = m.start_ray(DVec3::new(-10.0, 100.0, 0.0), DVec3::X);
    assert_eq!(miss.next_chord(&m).length, f64::INFINITY);
    assert_eq!(miss.evaluations(), 0);
    // A ray that enters, bends and leaves through the top ends with an infinite chord.
    let mut up = m.start_ray(DVec3::new(0.0, 45.0, 0.0), dir(30.0));
    let mut last = None;
    for _ in 0..10_000 {
        let c = up.next_chord(&m);
        if c.length.is_infinite() {
            last = Some(c);
            break;
        }
    }
    let c = last.unwrap();
    assert!((c.origin.y - 50.0).abs() < 1e-3, "left at {:?}", c.origin);
}

#[test]
fn horizontal_launch_bends_but_the_paper_methods_stay_straight() {
    let f = linear(1.0, 0.01);
    let p = DVec3::new(0.0, 1.0, 0.0);
    for method in [Method::Rk45, Method::Rk4, Method::Exact] {
        let m = medium(f.clone(), method, 1e-4, 0.5);
        let (ray, _) = trace_chords(&m, p, DVec3::X);
        assert!(ray.position().y > 40.0, "{method}: {:?}", ray.position());
    }
    for method in [Method::Slab, Method::Length, Method::Euler, Method::PaperRk4] {
        let m = medium(f.clone(), method, 1e-4, 0.5);
        let (ray, _) = trace_chords(&m, p, DVec3::X);
        assert_eq!(ray.position().y, 1.0, "{method}");
        assert!(ray.failure().is_none());
    }
}

#[test]
fn paper_euler_fails_at_the_turning_point_slab_reflects() {
    let p = DVec3::new(0.0, 1.5, 0.0);
    for method in [Method::Euler, Method::PaperRk4] {
        let m = medium(hot_ground(), method, 1e-3, 0.05);
        let (ray, _) = trace_chords(&m, p, dir(-0.5));
        let msg = ray.failure().expect("must fail");
        assert!(msg.contains("turning point") && msg.contains("NaN"), "{msg}");
        assert!(ray.position().is_finite());
    }
    for method in [Method::Slab, Method::Length] {
        let m = medium(hot_ground(), method, 1e-3, 0.05);
        let (ray, _) = trace_chords(&m, p, dir(-0.5));
        assert!(ray.failure().is_none(), "{method}: {:?}", ray.failure());
        assert!(ray.direction().y > 0.0, "{method} should reflect upward");
    }
}

#[test]
fn slab_equals_euler_and_paper_rk4_typo_costs_a_third() {
    let f = linear(1.0, 0.01);
    let (h, n_steps) = (1.0, 10);
    let p = DVec3::ZERO;
    let d = dir(10.0);
    let run = |method| {
        let mut ev = 0;
        let mut st = State::new(&f, p, d, &mut ev).unwrap();
        for _ in 0..n_steps {
            match mirage_study::segment(&f, method, h, &st, &mut ev).unwrap() {
                mirage_study::Seg::To(s) => st = s,
                mirage_study::Seg::Forever => panic!("not horizontal"),
            }
        }
        st
    };
    let (slab, euler, prk4) = (run(Method::Slab), run(Method::Euler), run(Method::PaperRk4));
    assert!((slab.r - euler.r).length() < 1e-9, "{:?} {:?}", slab.r, euler.r);
    assert!((euler.r.y - 10.0).abs() < 1e-12);
    // Exact horizontal distance at height 10: x = (b/m) ln((n + √(n²−b²))/(n0(1+cosΦ0))).
    let b = d.x; // n0 sinΦ0, Φ from the vertical
    let n = 1.1f64;
    let x = b / 0.01 * ((n + (n * n - b * b).sqrt()) / (1.0 + d.y)).ln();
    assert!(
        (prk4.r.x / x - 2.0 / 3.0).abs() < 0.01,
        "paper_rk4 {} vs exact {x}",
        prk4.r.x
    );
    assert!((euler.r.x - x).abs() / x < 0.1);
}

#[test]
fn validation_errors_name_the_key() {
    let b = Aabb::new(DVec3::new(0.0, 0.0, 0.0), DVec3::new(10.0, 20.0, 10.0));
    let e = |r: Result<Medium, MediumError>| r.unwrap_err().to_string();
    let s = e(Medium::try_new(linear(1.0, -0.1), b, Method::Rk45, 1e-3, 1.0));
    assert!(
        s.starts_with("medium.field:") && s.contains("n > 0") && s.contains("-1"),
        "{s}"
    );
    let s = e(Medium::try_new(linear(1.0, 0.0), b, Method::Rk45, 0.0, 1.0));
    assert!(s.starts_with("medium.tolerance:"), "{s}");
    let s = e(Medium::try_new(linear(1.0, 0.0), b, Method::Rk4, 1e-3, -1.0));
    assert!(s.starts_with("medium.step:"), "{s}");
    let inf = Aabb::new(DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY));
    let s = e(Medium::try_new(linear(1.0, 0.0), inf, Method::Rk45, 1e-3, 1.0));
    assert!(s.starts_with("medium.bounds:") && s.contains("bounded"), "{s}");
    let s = e(Medium::try_new(hot_ground(), b, Method::Exact, 1e-3, 1.0));
    assert!(s.starts_with("medium.method:") && s.contains("linear"), "{s}");
    // An inversion whose dip goes negative inside the box, found at the interior minimum.
    let inv = IndexField::Inversion {
        n0: 1.0,
        dn: -3.0,
        height: 10.0,
        thickness: 1.0,
        m: 0.1,
        up: DVec3::Y,
        base: 0.0,
    };
    let s = e(Medium::try_new(inv, b, Method::Rk45, 1e-3, 1.0));
    assert!(s.starts_with("medium.field:"), "{s}");
    assert!("warp".parse::<Method>().unwrap_err().to_string().contains("rk45"));
    assert_eq!("paper_rk4".parse::<Method>().unwrap(), Method::PaperRk4);
}

#[test]
fn analytic_gradients_match_finite_differences() {
    let fields = [
        hot_ground(),
        linear(1.0, 0.3),
        IndexField::Exponential {
            n0: 1.000_293,
            scale_height: 8000.0,
            up: DVec3::new(0.1, 1.0, 0.0).normalize(),
            base: 3.0,
        },
        IndexField::Inversion {
            n0: 1.0003,
            dn: -5e-5,
            height: 10.0,
            thickness: 2.0,
            m: -1e-6,
            up: DVec3::Y,
            base: 0.0,
        },
        IndexField::Plume {
            n_amb: 1.0003,
            dn: 1e-4,
            center: DVec3::new(0.0, 0.0, 0.0),
            radius: 0.5,
            height: 2.0,
            amplitude: 0.3,
            wavelength: 0.2,
            waves: 6,
            seed: 7,
            up: DVec3::Y,
            table: Default::default(),
        },
    ];
    for f in fields {
        for p in [
            DVec3::new(0.1, 0.2, 0.3),
            DVec3::new(-0.4, 9.5, 0.2),
            DVec3::new(0.3, 1.0, -0.2),
        ] {
            let g = f.grad(p);
            let hstep = 1e-5;
            let fd = DVec3::new(
                (f.n(p + DVec3::X * hstep) - f.n(p - DVec3::X * hstep)) / (2.0 * hstep),
                (f.n(p + DVec3::Y * hstep) - f.n(p - DVec3::Y * hstep)) / (2.0 * hstep),
                (f.n(p + DVec3::Z * hstep) - f.n(p - DVec3::Z * hstep)) / (2.0 * hstep),
            );
            assert!(
                (g - fd).length() <= 1e-6 * g.length().max(1e-9) + 1e-10,
                "{}: {g:?} vs {fd:?}",
                f.kind()
            );
        }
    }
}

#[test]
fn grin_trace_round_trip_and_bad_queries() {
    let input = r#"{"queries": [
      {"id": "a", "field": {"kind": "linear", "n0": 1.0, "m": 0.01},
       "start": [0, 0, 0], "direction": [0.9848, 0.1736, 0], "stop": {"x": 100.0},
       "method": "rk45", "tolerance": 1e-10},
      {"id": "b", "field": {"kind": "linear", "n0": 1.0, "m": 0.01},
       "start": [0, 0, 0], "direction": [0.9848, 0.1736, 0], "stop": {"x": 100.0},
       "method": "exact"},
      {"id": "c", "field": {"kind": "hot_ground", "n_inf": 1.000293, "dn": 1e-4, "h0": 0.3},
       "start": [0, 1.5, 0], "direction": [1, -0.0087, 0], "stop": {"s": 400.0},
       "method": "rk45", "tolerance": 1e-9},
      {"id": "d", "field": {"kind": "linear", "n0": 1.0, "m": 0.01, "colour": 3},
       "start": [0, 0, 0], "direction": [1, 0, 0], "stop": {"x": 1.0}, "method": "rk45"},
      {"id": "e", "field": {"kind": "linear", "n0": 1.0},
       "start": [0, 0, 0], "direction": [1, 0, 0], "stop": {"x": 1.0}, "method": "rk45"},
      {"id": "f", "field": {"kind": "exponential", "n0": 1.0003, "H": 8000},
       "start": [0, 0, 0], "direction": [1, 0, 0], "stop": {"x": 1.0}, "method": "rk45", "tolerance": -1},
      {"id": "g", "field": {"kind": "hot_ground", "n_inf": 1.000293, "dn": 1e-4, "h0": 0.3},
       "start": [0, 1.5, 0], "direction": [1, -0.0087, 0], "stop": {"s": 400.0},
       "method": "euler", "step": 0.01}
    ]}"#;
    let out = grin_trace_json(input).unwrap();
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let r = v["results"].as_array().unwrap();
    assert_eq!(r.len(), 7);
    let vec3 = |x: &serde_json::Value| {
        DVec3::new(
            x[0].as_f64().unwrap(),
            x[1].as_f64().unwrap(),
            x[2].as_f64().unwrap(),
        )
    };
    assert_eq!(r[0]["status"], "ok");
    let (a, b) = (vec3(&r[0]["end"]), vec3(&r[1]["end"]));
    assert!(
        (a.x - 100.0).abs() < 1e-12 && (a - b).length() < 1e-7,
        "{a:?} vs {b:?}"
    );
    assert!(r[0]["evaluations"].as_u64().unwrap() > 10);
    let ext = r[2]["extrema"].as_array().unwrap();
    assert_eq!(ext.len(), 1, "{}", r[2]);
    assert!(vec3(&ext[0]["position"]).y < 1.0);
    assert!(
        r[3]["status"]
            .as_str()
            .unwrap()
            .contains("unknown field `colour`"),
        "{}",
        r[3]
    );
    assert!(
        r[4]["status"].as_str().unwrap().contains("missing field `m`"),
        "{}",
        r[4]
    );
    assert!(r[5]["status"].as_str().unwrap().contains("tolerance"), "{}", r[5]);
    let g = r[6]["status"].as_str().unwrap();
    assert!(g.contains("turning point"), "{g}");
    // Whole-document errors.
    assert!(grin_trace_json("{\"queries\": [], \"extra\": 1}")
        .unwrap_err()
        .to_string()
        .contains("unknown field"));
    assert!(grin_trace_json("{\"queries\": [{\"id\": \"x\", \"start\": [1e999, 0, 0]}]}").is_err());
    assert!(grin_trace_json("not json").is_err());
    // The answers deserialize again (round trip of the output format).
    let again: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(again, v);
}

/// Queries that would run for minutes are refused up front (fixed steps) or
/// stopped at the work limit (found by the JSON fuzzer: five hangs).
#[test]
fn grin_trace_bounds_the_work_of_a_query() {
    use super::grin_trace::grin_trace_json;
    let q = |extra: &str| {
        format!(
            r#"{{"queries": [{{"id": "x", "field": {{"kind": "linear", "n0": 1.0, "m": 0.01}}, "start": [0, 0, 0], "direction": [0.9848, 0.1736, 0], "stop": {{"x": 100.0}}, {extra}}}]}}"#
        )
    };
    for (extra, want) in [
        (r#""method": "rk4", "step": 1e-300"#, "would take"),
        (r#""method": "slab", "steps": 1000000000000"#, "would take"),
        (r#""method": "length", "step": 1e-9"#, "would take"),
        (
            r#""method": "rk45", "tolerance": 1e-10, "max_length": 1e300, "stop": {"s": 1e300}"#,
            "work limit",
        ),
    ] {
        let doc = q(extra).replace(r#""stop": {"x": 100.0}, "method": "rk45""#, r#""method": "rk45""#);
        let doc = if extra.contains("\"stop\"") {
            doc.replacen(r#""stop": {"x": 100.0}, "#, "", 1)
        } else {
            doc
        };
        let t = std::time::Instant::now();
        let out = grin_trace_json(&doc).unwrap();
        assert!(out.contains(want), "{extra}: {out}");
        assert!(t.elapsed().as_secs_f64() < 5.0, "{extra}: {:?}", t.elapsed());
    }
}

/// A real hot road (`atmosphere`, scenes/hot_road_air.toml): a ray grazing
/// its 2 cm layer (turning 6 mm above the road) lands within a millimetre
/// of a dense rk45 trace (1e-12) after 300 m at the scene's tolerance; at a
/// hundred times that it misses by more.
#[test]
fn hot_road_grazing_ray_lands_on_the_dense_path() {
    let air = atmosphere::Atmosphere {
        heights: vec![0.0, 0.02, 0.2, 2.0],
        celsius: vec![55.0, 36.0, 32.0, 30.0],
        pressure: 101_325.0,
        humidity: 0.2,
        co2_ppm: 450.0,
        wavelength_nm: 550.0,
        up: DVec3::Y,
        base: 0.0,
    };
    let field = air.to_field("medium.atmosphere", 0.0, 3.0).unwrap();
    let b = Aabb::new(DVec3::new(-1.0, 0.0, -10.0), DVec3::new(400.0, 3.0, 10.0));
    let p0 = DVec3::new(0.0, 1.2, 0.0);
    let end_error = |tol: f64, deg: f64| -> f64 {
        let m = Medium::try_new(field.clone(), b, Method::Rk45, tol, 1.0).unwrap();
        let mut ray = m.start_ray(p0, dir(deg));
        while ray.position().x < 300.0 {
            let c = ray.next_chord(&m);
            assert!(ray.failure().is_none() && c.length.is_finite() && c.length > 0.0);
        }
        let (dense, _) = advance(&field, Method::Rk45, 1e-12, 1.0, p0, dir(deg), ray.arc_length());
        (ray.position() - dense.r).length()
    };
    let bound = 1e-3;
    for deg in [-0.3, -0.2, -0.1] {
        let err = end_error(2e-4, deg);
        assert!(err <= bound, "{deg}°: {err:e} m off");
    }
    let loose = end_error(2e-2, -0.3);
    assert!(loose > bound, "a 100× looser tolerance is only {loose:e} off");
}
