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
