//! The Embree layer end to end: analytic answers, filters and their documented traps.
use glam::Vec3A as V3;
use snell::embree::*;

fn device() -> Device {
    Device::new("threads=1").expect("Embree device")
}

/// One triangle in the plane z = -2 around the -z axis.
fn tri_scene(flags: SceneFlags) -> Scene {
    let d = device();
    let mut b = SceneBuilder::new(&d, flags, BuildQuality::Medium).unwrap();
    b.add_triangles(
        &[[-1.0, -1.0, -2.0], [1.0, -1.0, -2.0], [0.0, 1.0, -2.0]],
        &[[0, 1, 2]],
    )
    .unwrap();
    b.commit().unwrap()
}

#[test]
fn ray_hits_triangle_at_analytic_t_and_misses_off_it() {
    let s = tri_scene(SceneFlags::default());
    let dir = V3::new(0.1, 0.05, -1.0);
    let h = s.intersect(&Ray::new(V3::ZERO, dir)).expect("hit");
    // plane z = -2: t = 2 / |dz| in units of |dir| (dir not normalised)
    assert!((h.t - 2.0).abs() < 1e-6, "t = {}", h.t);
    assert_eq!(h.geom_id, 0);
    // Ng = (v1-v0)x(v2-v0) points +z (towards the origin)
    assert!(h.ng.z > 0.0);
    assert!(s
        .intersect(&Ray::new(V3::ZERO, V3::new(0.9, 0.0, -1.0)))
        .is_none());
    let mut r = Ray::new(V3::ZERO, dir);
    r.tfar = 1.9;
    assert!(s.intersect(&r).is_none(), "tfar must clip");
}

#[test]
fn occluded_agrees_with_intersect() {
    let s = tri_scene(SceneFlags::default());
    for i in 0..400 {
        let x = (i % 20) as f32 / 10.0 - 1.0;
        let y = (i / 20) as f32 / 10.0 - 1.0;
        let r = Ray::new(V3::ZERO, V3::new(x, y, -2.0));
        assert_eq!(s.intersect(&r).is_some(), s.occluded(&r), "ray {i}");
    }
}

/// Two parallel quads (geometry 0 at z=-1, geometry 1 at z=-2), each two
/// triangles sharing the diagonal edge x = y.
fn two_quads(flags: SceneFlags, quality: BuildQuality) -> Scene {
    let d = device();
    let mut b = SceneBuilder::new(&d, flags, quality).unwrap();
    for z in [-1.0f32, -2.0] {
        b.add_triangles(
            &[[-1.0, -1.0, z], [1.0, -1.0, z], [1.0, 1.0, z], [-1.0, 1.0, z]],
            &[[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
    }
    b.commit().unwrap()
}

struct Reject {
    geom: u32,
    calls: Vec<(u32, u32, f32)>,
}
impl HitFilter for Reject {
    fn accept(&mut self, h: &FilterHit) -> bool {
        self.calls.push((h.geom_id, h.prim_id, h.t));
        h.geom_id != self.geom
    }
}

#[test]
fn context_filter_rejecting_geometry_lets_ray_reach_the_one_behind() {
    let flags = SceneFlags {
        context_filter: true,
        robust: false,
    };
    let s = two_quads(flags, BuildQuality::Medium);
    let ray = Ray::new(V3::new(0.3, -0.2, 0.0), V3::new(0.0, 0.0, -1.0));
    let mut f = Reject {
        geom: 0,
        calls: vec![],
    };
    let h = s.intersect_filtered(&ray, &mut f).unwrap().expect("hit behind");
    assert_eq!(h.geom_id, 1);
    assert!((h.t - 2.0).abs() < 1e-6);
    assert!(f.calls.iter().any(|c| c.0 == 0), "the rejected hit was seen");

    // Trap 1: with an accept-all filter the nearest hit is geometry 0, yet Embree
    // may call the filter for geometry 1 as well (a hit beyond the final one),
    // depending on traversal order. Across many rays it happens.
    let mut beyond = 0;
    for i in 0..2000 {
        let x = ((i * 37) % 199) as f32 / 100.0 - 0.99;
        let y = ((i * 91) % 197) as f32 / 99.0 - 0.99;
        let r = Ray::new(V3::new(x, y, 0.0), V3::new(0.0, 0.0, -1.0));
        let mut acc = Reject {
            geom: u32::MAX,
            calls: vec![],
        };
        let h = s.intersect_filtered(&r, &mut acc).unwrap().unwrap();
        assert_eq!(h.geom_id, 0);
        if acc.calls.iter().any(|c| c.0 == 1) {
            beyond += 1;
        }
    }
    eprintln!("filter saw a hit beyond the final one on {beyond}/2000 rays");
    // Not asserted to be > 0: it depends on the BVH Embree builds; the rule in
    // docs/design.md must be (and is) correct either way. What must hold is above.
}

#[test]
fn filter_called_twice_for_a_ray_through_a_shared_edge() {
    let flags = SceneFlags {
        context_filter: true,
        robust: false,
    };
    let s = two_quads(flags, BuildQuality::High);
    // The diagonal x = y is shared by both triangles of each quad.
    let mut twice = 0;
    for i in 0..50 {
        let p = i as f32 / 50.0 - 0.5;
        let r = Ray::new(V3::new(p, p, 0.0), V3::new(0.0, 0.0, -1.0));
        let mut f = Reject {
            geom: 0,
            calls: vec![],
        };
        s.intersect_filtered(&r, &mut f).unwrap();
        let on_g0: Vec<_> = f.calls.iter().filter(|c| c.0 == 0).collect();
        if on_g0.len() >= 2 {
            twice += 1;
            // Same crossing: t equal within a few ulps, different prims or repeated.
            assert!((on_g0[0].2 - on_g0[1].2).abs() <= 4.0 * f32::EPSILON * on_g0[0].2.abs());
        }
    }
    assert!(
        twice > 0,
        "a ray through the shared edge reports the crossing twice"
    );
}

struct Ball {
    c: V3,
    r: f32,
}
impl UserShape for Ball {
    fn bounds(&self, _: u32) -> Bounds {
        Bounds {
            lower: (self.c - V3::splat(self.r)).into(),
            upper: (self.c + V3::splat(self.r)).into(),
        }
    }
    fn intersect(&self, _: u32, o: V3, d: V3, out: &mut Candidates) {
        let oc = o - self.c;
        let a = d.dot(d);
        let b = oc.dot(d);
        let c = oc.dot(oc) - self.r * self.r;
        let disc = b * b - a * c;
        if disc < 0.0 {
            return;
        }
        let s = disc.sqrt();
        for t in [(-b - s) / a, (-b + s) / a] {
            let p = o + d * t;
            out.push(Candidate {
                t,
                ng: (p - self.c).into(),
                u: 0.0,
                v: 0.0,
            });
        }
    }
}

#[test]
fn user_sphere_hit_at_analytic_t_and_through_the_filter() {
    let d = device();
    let mut b = SceneBuilder::new(
        &d,
        SceneFlags {
            context_filter: true,
            robust: false,
        },
        BuildQuality::Medium,
    )
    .unwrap();
    let g = b
        .add_user(Box::new(Ball {
            c: V3::new(0.0, 0.0, -5.0),
            r: 1.0,
        }))
        .unwrap();
    let s = b.commit().unwrap();
    let ray = Ray::new(V3::ZERO, V3::new(0.0, 0.0, -1.0));
    let h = s.intersect(&ray).unwrap();
    assert_eq!(h.geom_id, g);
    assert!((h.t - 4.0).abs() < 1e-5);
    assert!(h.ng.z > 0.0);
    // Off-centre: analytic t = 5 - sqrt(1 - 0.6^2) = 4.2
    let h = s
        .intersect(&Ray::new(V3::new(0.6, 0.0, 0.0), V3::new(0.0, 0.0, -1.0)))
        .unwrap();
    assert!((h.t - 4.2).abs() < 1e-5, "{}", h.t);
    // A filter that rejects the entry hit sees it, and the exit hit is returned.
    struct RejectFirst(Vec<f32>);
    impl HitFilter for RejectFirst {
        fn accept(&mut self, h: &FilterHit) -> bool {
            self.0.push(h.t);
            h.t > 5.0
        }
    }
    let mut f = RejectFirst(vec![]);
    let h = s.intersect_filtered(&ray, &mut f).unwrap().unwrap();
    assert!((h.t - 6.0).abs() < 1e-5);
    assert!(h.ng.z < 0.0, "exit normal points away from the centre");
    assert!(
        f.0.iter().any(|t| (t - 4.0).abs() < 1e-5),
        "entry hit went through the filter"
    );
    assert!(s.occluded(&ray));
    let mut none = RejectFirst(vec![]);
    let mut r = ray;
    r.tfar = 5.5;
    assert!(
        !s.occluded_filtered(&r, &mut none).unwrap(),
        "occlusion filter rejected the only hit in range"
    );
}

#[test]
fn invalid_embree_call_is_an_error_with_embrees_message() {
    let d = device();
    let e = d.property(987_654).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("RTC_ERROR_INVALID_ARGUMENT"), "{msg}");
    assert!(
        msg.len() > "Embree error RTC_ERROR_INVALID_ARGUMENT: ".len() + 3,
        "{msg}"
    );
    // The device is still usable.
    assert!(d.property(0).is_ok());
}

#[test]
fn panic_in_filter_becomes_an_error_and_the_process_goes_on() {
    struct Boom;
    impl HitFilter for Boom {
        fn accept(&mut self, _: &FilterHit) -> bool {
            panic!("filter exploded on purpose")
        }
    }
    let flags = SceneFlags {
        context_filter: true,
        robust: false,
    };
    let s = two_quads(flags, BuildQuality::Medium);
    let ray = Ray::new(V3::new(0.3, -0.2, 0.0), V3::new(0.0, 0.0, -1.0));
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let r = s.intersect_filtered(&ray, &mut Boom);
    std::panic::set_hook(prev);
    let e = r.unwrap_err();
    assert!(e.to_string().contains("filter exploded on purpose"), "{e}");
    // Queries still work afterwards.
    assert_eq!(s.intersect(&ray).unwrap().geom_id, 0);
}

#[test]
fn invalid_rays_never_reach_embree() {
    // Debian's Embree asserts on invalid rays and aborts; the wrapper refuses them.
    let s = tri_scene(SceneFlags::default());
    for r in [
        Ray::new(V3::new(f32::NAN, 0.0, 0.0), V3::new(0.0, 0.0, -1.0)),
        Ray::new(V3::ZERO, V3::new(0.0, f32::INFINITY, -1.0)),
        Ray {
            org: V3::ZERO,
            dir: V3::new(0.0, 0.0, -1.0),
            tnear: -1.0,
            tfar: 10.0,
        },
        Ray {
            org: V3::ZERO,
            dir: V3::new(0.0, 0.0, -1.0),
            tnear: 5.0,
            tfar: 1.0,
        },
        Ray {
            org: V3::ZERO,
            dir: V3::new(0.0, 0.0, -1.0),
            tnear: 0.0,
            tfar: f32::NAN,
        },
    ] {
        assert!(!r.is_valid());
        assert!(s.intersect(&r).is_none());
        assert!(!s.occluded(&r));
    }
    assert!(Ray::new(V3::ZERO, V3::new(0.0, 0.0, -1.0)).is_valid());
}

/// A unit box whose intersection panics (its bounds, with `bounds_panic`, too).
struct Exploding {
    bounds_panic: bool,
}

impl UserShape for Exploding {
    fn bounds(&self, _: u32) -> Bounds {
        assert!(!self.bounds_panic, "bounds exploded on purpose");
        Bounds {
            lower: [-1.0; 3],
            upper: [1.0; 3],
        }
    }
    fn intersect(&self, _: u32, _: V3, _: V3, _: &mut Candidates) {
        panic!("analytic shape exploded on purpose")
    }
}

/// `f` with the panic message printer silenced (the panics are expected).
fn quietly<R>(f: impl FnOnce() -> R) -> R {
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let r = f();
    std::panic::set_hook(prev);
    r
}

/// A panic inside an analytic shape's callback cannot unwind into Embree:
/// the query sees a miss, and `Scene::check` (which renders call per tile)
/// reports it. Only for the scene of the broken shape: another scene's
/// check stays clean.
#[test]
fn panic_in_user_geometry_is_reported_by_check_of_its_scene_only() {
    let d = device();
    let mut b = SceneBuilder::new(&d, SceneFlags::default(), BuildQuality::Medium).unwrap();
    b.add_user(Box::new(Exploding { bounds_panic: false })).unwrap();
    let s = b.commit().unwrap();
    let other = tri_scene(SceneFlags::default());
    assert!(s.check().is_ok(), "no query yet");
    let ray = Ray::new(V3::new(0.0, 0.0, 5.0), V3::new(0.0, 0.0, -1.0));
    let h = quietly(|| s.intersect(&ray));
    assert!(h.is_none());
    let e = s.check().unwrap_err();
    assert!(e.to_string().contains("analytic shape"), "{e}");
    assert!(e.to_string().contains("exploded on purpose"), "{e}");
    assert!(other.check().is_ok(), "another scene's shapes did not panic");
}

/// A shape whose bounds panic while the scene is built makes the build an
/// error (its box was never set).
#[test]
fn panic_in_user_geometry_bounds_fails_the_build() {
    let d = device();
    let mut b = SceneBuilder::new(&d, SceneFlags::default(), BuildQuality::Medium).unwrap();
    b.add_user(Box::new(Exploding { bounds_panic: true })).unwrap();
    let e = quietly(|| b.commit()).err().expect("the build fails");
    assert!(e.to_string().contains("bounds exploded on purpose"), "{e}");
}

/// A filtered query on a scene without the context-filter flag is an error,
/// not an abort inside Debian's assertion-enabled Embree.
#[test]
fn filtered_query_without_the_flag_is_an_error() {
    struct Any;
    impl HitFilter for Any {
        fn accept(&mut self, _: &FilterHit) -> bool {
            true
        }
    }
    let s = two_quads(SceneFlags::default(), BuildQuality::Medium);
    let ray = Ray::new(V3::new(0.3, -0.2, 0.0), V3::new(0.0, 0.0, -1.0));
    assert!(s.intersect_filtered(&ray, &mut Any).is_err());
    assert!(s.occluded_filtered(&ray, &mut Any).is_err());
}
