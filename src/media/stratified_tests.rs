//! The invariant tracer against rk45 at a tight tolerance and against the
//! linear field's closed form (exact.rs), with the paper's branch (no turning
//! point handling) failing the same threshold.
use glam::DVec3;

use super::exact;
use super::stepper::{State, Stepper};
use super::stratified::{Branch, Options, StratifiedRay};
use super::*;

fn hot_ground() -> IndexField {
    IndexField::HotGround {
        n_inf: 1.000_293,
        dn: 1.2e-4,
        h0: 0.4,
        up: DVec3::Y,
        base: 0.0,
    }
}

fn inversion() -> IndexField {
    IndexField::Inversion {
        n0: 1.000_293,
        dn: -1e-5,
        height: 10.0,
        thickness: 2.0,
        m: -2e-8,
        up: DVec3::Y,
        base: 0.0,
    }
}

/// The hot ground sampled every 5 cm: a tabulated profile.
fn table() -> IndexField {
    let hs: Vec<f64> = (0..=300).map(|i| -1.0 + 0.05 * f64::from(i)).collect();
    let f = hot_ground();
    let n = hs.iter().map(|&h| f.n_h(h).unwrap().0).collect();
    IndexField::Profile {
        heights: hs,
        n,
        up: DVec3::Y,
        base: 0.0,
        layer: None,
    }
}

fn dir(rad: f64) -> DVec3 {
    DVec3::new(rad.cos(), rad.sin(), 0.0)
}

/// rk45 at tolerance 1e-12 from (p, d) to arc length s.
fn rk45_at(f: &IndexField, p: DVec3, d: DVec3, s: f64) -> State {
    let mut ev = 0;
    let st = State::new(f, p, d, &mut ev).unwrap();
    let mut stepper = Stepper::new(f, Method::Rk45, 1e-12, 1.0);
    let mut h = f64::INFINITY;
    stepper.advance(&st, s, &mut h, &mut Vec::new()).unwrap()
}

/// The invariant tracer's position and direction at arc length s.
fn invariant_at(f: &IndexField, p: DVec3, d: DVec3, s: f64, opts: Options) -> (DVec3, DVec3) {
    let mut ray = StratifiedRay::new(f, -500.0, 800.0, p, d, opts).unwrap();
    let tau = ray.tau_at_arc(f, s);
    let pt = ray.point(f, tau);
    (ray.position(&pt), ray.direction(&pt))
}

struct Case {
    name: &'static str,
    field: IndexField,
    height: f64,
    angle: f64,
    length: f64,
    turns: bool,
}

fn cases() -> Vec<Case> {
    let g = [1e-4, 1e-8];
    let mut v = Vec::new();
    for (name, field, height) in [("hot_ground", hot_ground(), 1.2), ("profile", table(), 1.2)] {
        v.extend([
            Case {
                name,
                field: field.clone(),
                height,
                angle: 0.004,
                length: 800.0,
                turns: false,
            },
            Case {
                name,
                field: field.clone(),
                height,
                angle: -0.02,
                length: 50.0,
                turns: false,
            },
            Case {
                name,
                field: field.clone(),
                height,
                angle: -0.0052,
                length: 900.0,
                turns: true,
            },
            Case {
                name,
                field: field.clone(),
                height,
                angle: -g[0],
                length: 600.0,
                turns: true,
            },
            Case {
                name,
                field: field.clone(),
                height,
                angle: g[1],
                length: 600.0,
                turns: false,
            },
            Case {
                name,
                field: field.clone(),
                height,
                angle: 0.0,
                length: 600.0,
                turns: false,
            },
        ]);
    }
    let field = inversion();
    v.extend([
        Case {
            name: "inversion",
            field: field.clone(),
            height: 4.0,
            angle: 0.0017,
            length: 6000.0,
            turns: true,
        },
        Case {
            name: "inversion",
            field: field.clone(),
            height: 4.0,
            angle: 0.01,
            length: 1500.0,
            turns: false,
        },
        Case {
            name: "inversion",
            field: field.clone(),
            height: 14.0,
            angle: -0.001,
            length: 6000.0,
            turns: false,
        },
        Case {
            name: "inversion",
            field: field.clone(),
            height: 10.0,
            angle: g[0],
            length: 3000.0,
            turns: true,
        },
        Case {
            name: "inversion",
            field,
            height: 9.0,
            angle: g[1],
            length: 3000.0,
            turns: true,
        },
    ]);
    let lin = IndexField::Linear {
        n0: 1.000_293,
        m: 2e-5,
        up: DVec3::Y,
        base: 0.0,
    };
    v.extend([
        Case {
            name: "linear",
            field: lin.clone(),
            height: 3.0,
            angle: -0.005,
            length: 1000.0,
            turns: true,
        },
        Case {
            name: "linear",
            field: lin.clone(),
            height: 3.0,
            angle: 0.005,
            length: 1000.0,
            turns: false,
        },
        Case {
            name: "linear",
            field: lin,
            height: 3.0,
            angle: -g[1],
            length: 1000.0,
            turns: true,
        },
    ]);
    let exp = IndexField::Exponential {
        n0: 1.000_293,
        scale_height: 8000.0,
        up: DVec3::Y,
        base: 0.0,
    };
    v.extend([
        Case {
            name: "exponential",
            field: exp.clone(),
            height: 30.0,
            angle: 1e-4,
            length: 6000.0,
            turns: true,
        },
        Case {
            name: "exponential",
            field: exp,
            height: 30.0,
            angle: -0.01,
            length: 2000.0,
            turns: false,
        },
    ]);
    v
}

#[test]
fn invariant_agrees_with_rk45_rising_falling_turning_grazing() {
    let opts_q = Options {
        quadrature: true,
        branch: Branch::Turn,
    };
    let paper = Options {
        quadrature: true,
        branch: Branch::Paper,
    };
    let mut worst = 0.0f64;
    let mut paper_worst_turning = f64::INFINITY;
    for c in cases() {
        let f = c.field.validated("f").unwrap();
        let p = DVec3::new(0.0, c.height, 0.0);
        let d = dir(c.angle);
        // The ray must really turn (or not) as the case says.
        let mut ray = StratifiedRay::new(&f, -50.0, 80.0, p, d, Options::default()).unwrap();
        let tau_end = ray.tau_at_arc(&f, c.length);
        let turned = ray.next_turn(&f, 0.0) < tau_end;
        assert_eq!(turned, c.turns, "{} at {} rad: turning point", c.name, c.angle);
        for s in [c.length / 3.0, c.length] {
            let r = rk45_at(&f, p, d, s);
            for opts in [Options::default(), opts_q] {
                let (q, t) = invariant_at(&f, p, d, s, opts);
                let err = (q - r.r).length() / s;
                worst = worst.max(err);
                assert!(
                    err <= 1e-9,
                    "{} angle {} s {s} ({:?}): |invariant − rk45| = {:.3e} × s",
                    c.name,
                    c.angle,
                    opts,
                    err
                );
                assert!(
                    (t - r.t).length() <= 1e-9,
                    "{} angle {}: directions",
                    c.name,
                    c.angle
                );
            }
            if c.turns && s == c.length {
                let (q, _) = invariant_at(&f, p, d, s, paper);
                paper_worst_turning = paper_worst_turning.min((q - r.r).length() / s);
            }
        }
    }
    eprintln!("worst |invariant − rk45| / s = {worst:.2e}; paper branch on turning rays >= {paper_worst_turning:.2e}");
    assert!(
        paper_worst_turning > 1e-9,
        "no power: the paper's branch also passes on turning rays ({paper_worst_turning:e})"
    );
}

#[test]
fn invariant_matches_the_linear_closed_form_of_exact_rs() {
    let f = IndexField::Linear {
        n0: 1.0,
        m: 0.01,
        up: DVec3::Y,
        base: 0.0,
    };
    for deg in [10.0f64, -8.0, 0.0, 1e-6] {
        let p = DVec3::new(0.0, 5.0, 0.0);
        let d = dir(deg.to_radians());
        let mut ev = 0;
        let st = State::new(&f, p, d, &mut ev).unwrap();
        for s in [1.0, 40.0, 300.0] {
            let e = exact::advance(&f, &st, s).unwrap();
            for quadrature in [false, true] {
                let (q, t) = invariant_at(
                    &f,
                    p,
                    d,
                    s,
                    Options {
                        quadrature,
                        branch: Branch::Turn,
                    },
                );
                assert!(
                    (q - e.r).length() <= 1e-11 * s,
                    "deg {deg} s {s} quadrature {quadrature}: {q:?} vs {:?}",
                    e.r
                );
                assert!((t - e.t).length() <= 1e-11);
            }
        }
    }
}

#[test]
fn the_invariant_is_kept_and_turning_points_sit_where_n_equals_it() {
    for f in [hot_ground(), inversion(), table()] {
        let h = if matches!(f, IndexField::Inversion { .. }) {
            9.5
        } else {
            1.2
        };
        let p = DVec3::new(0.0, h, 0.0);
        let a = if matches!(f, IndexField::Inversion { .. }) {
            0.0015
        } else {
            -0.005
        };
        for quadrature in [false, true] {
            let mut ray = StratifiedRay::new(
                &f,
                -50.0,
                80.0,
                p,
                dir(a),
                Options {
                    quadrature,
                    branch: Branch::Turn,
                },
            )
            .unwrap();
            let b = ray.invariant();
            let t = ray.next_turn(&f, 0.0);
            assert!(t.is_finite(), "{}: no turning point", f.kind());
            let pt = ray.point(&f, t);
            let n_t = f.n_h(ray.start_height() + pt.dh).unwrap().0;
            assert!(
                (n_t - b).abs() < 1e-15,
                "{}: n at the turn {n_t} vs b {b}",
                f.kind()
            );
            assert!(pt.p.abs() < 1e-7, "{}: p at the turn {}", f.kind(), pt.p);
            for tau in [0.3 * t, 2.0 * t] {
                let q = ray.point(&f, tau);
                let v = ray.velocity(&q);
                // Energy: |v|² = b² + p² = n(h)², with n from the field.
                let n_field = f.n_h(ray.start_height() + q.dh).unwrap().0;
                assert!((v.length() - n_field).abs() < 1e-12, "{}: |v| = n", f.kind());
            }
        }
    }
}

#[test]
fn profile_validation_names_the_node_and_interpolation_stays_between_nodes() {
    let bad = |heights: Vec<f64>, n: Vec<f64>| {
        IndexField::Profile {
            heights,
            n,
            up: DVec3::Y,
            base: 0.0,
            layer: None,
        }
        .validated("medium.field")
        .unwrap_err()
        .to_string()
    };
    let s = bad(vec![0.0, 2.0, 1.0], vec![1.0, 1.0, 1.0]);
    assert!(
        s.starts_with("medium.field.heights[2]:") && s.contains("increasing"),
        "{s}"
    );
    let s = bad(vec![0.0, 1.0], vec![1.0]);
    assert!(s.starts_with("medium.field.n:") && s.contains("as many"), "{s}");
    let s = bad(vec![0.0], vec![1.0]);
    assert!(s.starts_with("medium.field.heights:"), "{s}");
    let s = bad(vec![0.0, 1.0], vec![1.0, -1.0]);
    assert!(s.starts_with("medium.field.n[1]:"), "{s}");
    // Monotone data stay monotone (no overshoot); n' is continuous at nodes.
    let f = IndexField::Profile {
        heights: vec![0.0, 0.1, 1.0, 5.0],
        n: vec![1.0, 1.0002, 1.00025, 1.0003],
        up: DVec3::Y,
        base: 0.0,
        layer: None,
    };
    let mut last = 0.0;
    for i in 0..=500 {
        let h = 5.0 * f64::from(i) / 500.0;
        let (n, slope) = f.n_h(h).unwrap();
        assert!(
            n >= last && slope >= 0.0,
            "h {h}: n {n} after {last}, slope {slope}"
        );
        last = n;
    }
    for node in [0.1, 1.0] {
        let (a, b) = (f.n_h(node - 1e-9).unwrap().1, f.n_h(node + 1e-9).unwrap().1);
        assert!(
            (a - b).abs() < 1e-6 * a.abs(),
            "slope jumps at {node}: {a} vs {b}"
        );
    }
}

#[test]
fn level_crossings_in_closed_form_match_the_quadrature() {
    let lin = IndexField::Linear {
        n0: 1.000_293,
        m: 2e-5,
        up: DVec3::Y,
        base: 0.0,
    };
    let flat = IndexField::Constant { n: 1.000_293 };
    let mut checked = 0;
    for f in [hot_ground(), lin, flat] {
        for (h, a) in [
            (1.2, -0.0052),
            (1.2, 0.004),
            (7.3, -0.12),
            (0.2, -1e-4),
            (3.0, -0.005),
        ] {
            let p = DVec3::new(0.0, h, 0.0);
            let mk = |quadrature| {
                StratifiedRay::new(
                    &f,
                    -1.0,
                    12.0,
                    p,
                    dir(a),
                    Options {
                        quadrature,
                        branch: Branch::Turn,
                    },
                )
                .unwrap()
            };
            let (mut c, mut q) = (mk(false), mk(true));
            assert!(c.is_closed_form() && !q.is_closed_form());
            // Within the height limits [-1, 12] (where the quadrature's legs end).
            let t1 = [-1.0 - h, 12.0 - h]
                .into_iter()
                .filter_map(|l| c.first_height(&f, l, 0.0, 3000.0))
                .fold(3000.0, f64::min);
            for level in [-0.5, -0.1, -1e-3, 0.05, 0.5, 3.0] {
                let (tc, tq) = (
                    c.first_height(&f, level, 0.0, t1),
                    q.first_height(&f, level, 0.0, t1),
                );
                match (tc, tq) {
                    (Some(x), Some(y)) => {
                        assert!(
                            (x - y).abs() <= 1e-9 * y.max(1.0),
                            "{} h {h} a {a} level {level}: {x} vs {y}",
                            f.kind()
                        );
                        let at = c.point(&f, x);
                        assert!(
                            (at.dh - level).abs() < 1e-9,
                            "{} level {level}: reached {}",
                            f.kind(),
                            at.dh
                        );
                        // The point the crossing reports (from the root, without
                        // evaluating the path again) is the path's point there.
                        let q = c.first_height_point(&f, level, None, 0.0, t1).unwrap();
                        assert!(
                            (q.p - at.p).abs() < 1e-9 * at.p.abs().max(1e-6) && (q.n - at.n).abs() < 1e-15,
                            "{} level {level}: {q:?} vs {at:?}",
                            f.kind()
                        );
                        checked += 1;
                    }
                    (None, None) => {}
                    _ => panic!(
                        "{} h {h} a {a} level {level}: closed {tc:?} vs quadrature {tq:?}",
                        f.kind()
                    ),
                }
            }
        }
    }
    assert!(checked > 20, "{checked}");
}

/// Dense rk45 (tol 1e-11) samples of the arc from (p, d) until it leaves `b`
/// (or travels `max_len`): (arc length, position) every `ds` metres.
fn dense_arc(f: &IndexField, b: &Aabb, p: DVec3, d: DVec3, ds: f64, max_len: f64) -> Vec<(f64, DVec3)> {
    let mut ev = 0;
    let mut st = State::new(f, p, d, &mut ev).unwrap();
    let mut stepper = Stepper::new(f, Method::Rk45, 1e-11, 1.0);
    let mut h = f64::INFINITY;
    let mut out = vec![(0.0, p)];
    while st.s < max_len && b.contains(st.r) {
        st = stepper.advance(&st, ds, &mut h, &mut Vec::new()).unwrap();
        out.push((st.s, st.r));
    }
    out
}

fn distance_to_polyline(q: DVec3, arc: &[(f64, DVec3)]) -> f64 {
    arc.windows(2)
        .map(|w| {
            let (a, c) = (w[0].1, w[1].1);
            let ab = c - a;
            let u = ((q - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            (q - (a + ab * u)).length()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Casts `d` from `eye` through `m` until it leaves: the worst deviation of
/// a chord from the rk45 `arc`, over `judge`'s tolerance at the chord (so a
/// medium can be judged by another's tolerance), the chords and the length
/// skipped. Skipped stretches must keep the arc out of `boxes`; the exit
/// must be on the arc.
fn chords_against_arc(
    m: &Medium,
    judge: &Medium,
    eye: DVec3,
    d: DVec3,
    arc: &[(f64, DVec3)],
    boxes: &[Aabb],
) -> (f64, u32, f64) {
    let (mut worst, mut chords, mut skipped) = (0.0f64, 0, 0.0);
    let mut ray = m.start_ray(eye, d);
    let mut at = eye;
    for _ in 0..100_000 {
        let c = ray.next_chord(m);
        assert!(ray.failure().is_none(), "{:?}", ray.failure());
        if c.skipped > 0.0 {
            // The skipped stretch, from `at` to the chord's origin: its arc
            // samples stay out of the (unpadded) boxes.
            skipped += c.skipped;
            let (lo, hi) = (at.z.max(c.origin.z), at.z.min(c.origin.z));
            for (_, q) in arc.iter().filter(|(_, q)| q.z <= lo && q.z >= hi) {
                assert!(
                    boxes.iter().all(|b| !b.contains(*q)),
                    "skipped over geometry at {q:?}"
                );
            }
        }
        if !c.length.is_finite() {
            // Leaves where rk45 leaves (to 1e-6 of the path).
            let exit = arc.last().unwrap();
            let err = distance_to_polyline(c.origin, &arc[arc.len().saturating_sub(3)..]);
            assert!(
                err < 1e-6 * exit.0 + 1e-6,
                "exit {:?} off the arc by {err:e}",
                c.origin
            );
            return (worst, chords, skipped);
        }
        if c.length == 0.0 {
            continue;
        }
        chords += 1;
        let tol = judge
            .tolerance_at(c.origin)
            .min(judge.tolerance_at(c.origin + c.dir * c.length));
        for i in 0..=8 {
            let q = c.origin + c.dir * (c.length * f64::from(i) / 8.0);
            worst = worst.max(distance_to_polyline(q, arc) / tol);
        }
        at = c.origin + c.dir * c.length;
    }
    panic!("the ray never left the medium");
}

/// Method invariant in a road-like medium: every chord lies within its
/// footprint tolerance of the rk45 arc (tol 1e-11), the stretches it skips
/// come near no geometry box, and the ray leaves the box where rk45 does.
/// The same rays with the boxes unknown chord everything (no skipping), all
/// within the tolerance too; with the pixel tolerance ×100 (the known-wrong
/// variant) those chords fail the same threshold.
#[test]
fn invariant_chords_follow_the_arc_and_skip_only_clear_stretches() {
    let f = hot_ground();
    let bounds = Aabb::new(DVec3::new(-300.0, -1.0, -1200.0), DVec3::new(300.0, 12.0, 10.0));
    let ground = Aabb::new(DVec3::new(-400.0, -0.08, -1300.0), DVec3::new(400.0, 0.0, 50.0));
    let car = Aabb::new(DVec3::new(-5.0, 0.0, -301.0), DVec3::new(-1.0, 2.0, -299.0));
    let eye = DVec3::new(0.0, 1.2, 0.0);
    let pixel = 3f64.to_radians() / 160.0;
    let medium = |fraction: f64, boxes: Option<[Aabb; 2]>| {
        let m = Medium::try_new(f.clone(), bounds, Method::Invariant, 1e-3, 1.0)
            .unwrap()
            .with_pixel_tolerance(Some(fraction))
            .unwrap()
            .with_view(eye, pixel);
        match boxes {
            Some(b) => m.with_obstacles(b),
            None => m,
        }
    };
    let m = medium(DEFAULT_PIXEL_TOLERANCE, Some([ground, car]));
    let blind = medium(DEFAULT_PIXEL_TOLERANCE, None);
    let wrong = medium(100.0 * DEFAULT_PIXEL_TOLERANCE, None);
    let (mut chords, mut skipped, mut worst) = (0, 0.0, [0.0f64; 3]);
    for k in 0..40 {
        let a = -0.007 + 0.009 * f64::from(k) / 40.0;
        let d = DVec3::new(-0.01 * f64::from(k % 5) / 4.0, a, -1.0).normalize();
        let arc = dense_arc(&f, &bounds, eye, d, 0.5, 5000.0);
        let (w, c, s) = chords_against_arc(&m, &m, eye, d, &arc, &[ground, car]);
        (worst[0], chords, skipped) = (worst[0].max(w), chords + c, skipped + s);
        let (w, c, s) = chords_against_arc(&blind, &blind, eye, d, &arc, &[]);
        assert!(c > 0 && s == 0.0, "without boxes every stretch is cast");
        worst[1] = worst[1].max(w);
        worst[2] = worst[2].max(chords_against_arc(&wrong, &blind, eye, d, &arc, &[]).0);
    }
    eprintln!(
        "{chords} chords, {skipped:.0} m skipped; worst deviation / tolerance: {:.3} with boxes, {:.3} without, {:.1} at x100 the pixel tolerance",
        worst[0], worst[1], worst[2]
    );
    assert!(chords > 0 && skipped > 1000.0);
    // The dense arc is a polyline (0.5 m pieces): its own error is far below
    // the tolerances here (≥ 1e-6·distance).
    assert!(
        worst[0] <= 1.05 && worst[1] <= 1.05,
        "chords stray {worst:?} × their tolerance from the arc"
    );
    assert!(
        worst[2] > 1.05,
        "no power: chords at x100 the pixel tolerance stay within it ({:.3})",
        worst[2]
    );
}

/// Rays that enter through the box's faces where they start (from a floor
/// below its bottom face, from an eye on its top edge) get through in a few
/// chords without failing: a ray on the bottom face going up must not count
/// that face as its way out (it did, and re-entered there forever).
#[test]
fn invariant_rays_starting_on_the_faces_get_through() {
    let bounds = Aabb::new(DVec3::new(-3.0, 0.5, -3.0), DVec3::new(0.3, 1.5, 3.0));
    let floor = Aabb::new(DVec3::new(-2.0, 0.0, -2.0), DVec3::new(2.0, 0.0, 2.0));
    let light = Aabb::new(DVec3::new(-0.5, 2.0, -0.5), DVec3::new(0.5, 2.0, 0.5));
    let eye = DVec3::new(0.0, 1.5, 3.0);
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for f in [IndexField::Constant { n: 1.000_293 }, hot_ground()] {
        let m = Medium::try_new(f.clone(), bounds, Method::Invariant, 1e-3, 1.0)
            .unwrap()
            .with_view(eye, 0.05)
            .with_obstacles([floor, light]);
        let mut worst = 0;
        for i in 0..4000 {
            let (o, d) = if i % 2 == 0 {
                let q = DVec3::new(4.0 * rnd() - 2.0, 0.0, 4.0 * rnd() - 2.0);
                (eye, (q - eye).normalize())
            } else {
                let o = DVec3::new(4.0 * rnd() - 2.0, 0.0, 4.0 * rnd() - 2.0);
                (o, DVec3::new(rnd() - 0.5, rnd(), rnd() - 0.5).normalize())
            };
            let mut ray = m.start_ray(o, d);
            let mut n = 0;
            while n < 1000 {
                let c = ray.next_chord(&m);
                n += 1;
                assert!(
                    ray.failure().is_none(),
                    "{} from {o:?} along {d:?}: {:?}",
                    f.kind(),
                    ray.failure()
                );
                if !c.length.is_finite() {
                    break;
                }
            }
            worst = worst.max(n);
        }
        assert!(worst < 50, "{}: {worst} chords for one ray", f.kind());
    }
}

/// Rays restarted side by side (`restart_lanes`, as a pixel's camera rays
/// are) are the rays `restart` makes one by one, field for field; the
/// comparison tells rays apart (a lane's start given to another ray fails).
#[test]
fn restarted_side_by_side_equals_one_by_one() {
    let field = hot_ground();
    let eye = DVec3::new(0.3, 1.2, -0.7);
    let dirs = [
        DVec3::new(0.0, -0.01, -1.0),
        DVec3::new(0.2, 0.3, -1.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(-1.0, -0.002, 0.1),
    ]
    .map(DVec3::normalize);
    let starts = [eye, eye, DVec3::new(5.0, 0.01, 3.0), eye];
    let one = |r: DVec3, t: DVec3| StratifiedRay::new(&field, -1.0, 12.0, r, t, Options::default()).unwrap();
    let expect: Vec<String> = (0..4).map(|i| format!("{:?}", one(starts[i], dirs[i]))).collect();
    // Rays that last started elsewhere (no kept scale) and at these heights.
    for reuse in [false, true] {
        let mut rays: Vec<StratifiedRay> = (0..4)
            .map(|i| {
                one(
                    if reuse {
                        starts[i]
                    } else {
                        DVec3::new(0.0, 3.0, 0.0)
                    },
                    DVec3::X,
                )
            })
            .collect();
        let kept = std::array::from_fn(|i| rays[i].kept_scale());
        let lanes =
            StratifiedRay::restart_lanes(&field, &starts, &dirs, &kept).expect("a hot ground has lanes");
        for (ray, lane) in rays.iter_mut().zip(&lanes) {
            ray.restart_from(lane);
        }
        for i in 0..4 {
            assert_eq!(format!("{:?}", rays[i]), expect[i], "lane {i}, reused {reuse}");
        }
        let mut swapped = rays[0].clone();
        swapped.restart_from(&lanes[1]);
        assert_ne!(format!("{:?}", swapped), expect[0]);
    }
    // Fields without the exponential closed form take no lanes.
    let kept = [super::stratified::KeptScale::NONE; 4];
    assert!(StratifiedRay::restart_lanes(&inversion(), &starts, &dirs, &kept).is_none());
}
