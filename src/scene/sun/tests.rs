use super::*;

fn real_sun() -> Sun {
    Sun::new(DVec3::new(0.3, 0.8, -0.2), SUN_DIAMETER_DEG, V3::splat(1000.0))
}

#[test]
fn the_disk_radiance_times_its_solid_angle_is_the_irradiance() {
    for deg in [SUN_DIAMETER_DEG, 5.0, 40.0] {
        let s = Sun::new(DVec3::Y, deg, V3::new(1000.0, 500.0, 2.0));
        let a = 0.5 * deg.to_radians();
        let omega = 2.0 * PI * (1.0 - a.cos());
        assert!(
            (s.solid_angle() / omega - 1.0).abs() < 1e-9,
            "{deg}: {} vs {omega}",
            s.solid_angle()
        );
        let e = s.radiance().as_dvec3() * s.solid_angle();
        assert!(
            (e - DVec3::new(1000.0, 500.0, 2.0)).abs().max_element() < 1e-3,
            "{deg}: {e}"
        );
        assert!((s.pdf() * s.solid_angle() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn cone_samples_are_in_the_disk_and_uniform_in_solid_angle() {
    let mut rng = Rng::new(11);
    for deg in [SUN_DIAMETER_DEG, 16.0] {
        let s = Sun::new(DVec3::new(0.3, 0.8, -0.2), deg, V3::ONE);
        let omc = 1.0 - (0.5 * deg.to_radians()).cos();
        let n = 200_000;
        let (mut sum_w, mut sum_cos_facing) = (0.0, 0.0);
        for _ in 0..n {
            let d = s.sample(rng.uniform_f64(), rng.uniform_f64());
            assert!(s.contains(d.as_vec3a()), "{deg}: {d} outside");
            // 1 − cos θ to the axis, from the cross product (precise near 0).
            let sin2 = s.direction().cross(d).length_squared();
            let w = sin2 / (1.0 + (1.0 - sin2).sqrt());
            sum_w += w / omc;
            sum_cos_facing += 1.0 - w;
        }
        // Uniform in solid angle: (1 − cos θ)/(1 − cos α) is uniform on [0, 1).
        let mean_w = sum_w / n as f64;
        assert!(
            (mean_w - 0.5).abs() < 4.0 * (1.0 / 12.0f64 / n as f64).sqrt(),
            "{deg}: {mean_w}"
        );
        // A facing surface gets L π sin²α = E (1 + cos α)/2 (module notes):
        // E · mean cos θ over uniform samples.
        let facing = sum_cos_facing / n as f64;
        let a = 0.5 * deg.to_radians();
        assert!(
            (facing - 0.5 * (1.0 + a.cos())).abs() < 1e-3 * omc + 1e-12,
            "{deg}: {facing}"
        );
    }
}

#[test]
fn the_disk_edge_is_resolved_at_the_real_suns_size() {
    let s = real_sun();
    let a = 0.5 * SUN_DIAMETER_DEG.to_radians();
    let (t, _) = s.direction().any_orthonormal_pair();
    let at = |ang: f64| (s.direction() * ang.cos() + t * ang.sin()).as_vec3a();
    assert!(s.contains(at(0.0)));
    assert!(s.contains(at(a * 0.999)));
    assert!(!s.contains(at(a * 1.001)));
    assert!(!s.contains(-s.direction().as_vec3a()));
    // Scale does not matter.
    assert!(s.contains(at(a * 0.999) * 7.0));
}

#[test]
fn sky_blends_zenith_and_horizon_and_is_ground_below() {
    let sky = Sky {
        sun: real_sun(),
        zenith: V3::new(0.0, 0.0, 1.0),
        horizon: V3::new(1.0, 0.0, 0.0),
        ground: V3::new(0.0, 1.0, 0.0),
    };
    assert_eq!(sky.eval(V3::Y), V3::new(0.0, 0.0, 1.0));
    assert_eq!(sky.eval(V3::X), V3::new(1.0, 0.0, 0.0));
    let e30 = V3::new(0.75f32.sqrt(), 0.5, 0.0);
    assert!((sky.eval(e30) - V3::new(0.5, 0.0, 0.5)).abs().max_element() < 1e-6);
    assert_eq!(sky.eval(-V3::Y), V3::new(0.0, 1.0, 0.0));
    assert_eq!(sky.eval(sky.sun.direction().as_vec3a()), sky.sun.radiance());
}
