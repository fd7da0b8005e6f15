//! Property-based scene documents (proptest): typed scene structures with
//! random, often out-of-range values (negative sizes, zero, 1e300, 1e-300,
//! inf, nan, huge counts), wrong enum tags and unknown keys, written as TOML.
//! Every document must end in a rendered image (tiny, no NaN reaching the
//! film) or a located error naming the file, line and key: never a panic, an
//! unlocated error or more than a second of work.
use proptest::prelude::*;
use snell::render::{render, RenderOptions, RenderSettings};
use snell::scene::{load_scene_str, BuildOptions};
use std::path::Path;
use std::time::Instant;

/// A number as TOML: mostly plausible, sometimes an edge case.
fn num(lo: f64, hi: f64) -> impl Strategy<Value = String> {
    prop_oneof![
        80 => (lo..hi).prop_map(|x| format!("{x:?}")),
        1 => prop::sample::select(vec![
            "0.0", "-0.0", "-1.0", "1e300", "-1e300", "1e-300", "inf", "-inf", "nan", "1e16"
        ])
        .prop_map(str::to_string),
    ]
}

fn vec3(lo: f64, hi: f64) -> impl Strategy<Value = String> {
    prop_oneof![
        60 => (num(lo, hi), num(lo, hi), num(lo, hi)).prop_map(|(a, b, c)| format!("[{a}, {b}, {c}]")),
        1 => prop::sample::select(vec!["[0.0, 0.0, 0.0]", "[1.0, 2.0]", "[]", "\"up\""]).prop_map(str::to_string),
    ]
}

/// A count: mostly small, sometimes absurd.
fn count(lo: u64, hi: u64) -> impl Strategy<Value = String> {
    prop_oneof![
        40 => (lo..hi).prop_map(|x| x.to_string()),
        1 => prop::sample::select(vec!["0", "1000000000", "1000000000000", "18446744073709551615", "-3", "2.5"])
            .prop_map(str::to_string),
    ]
}

fn shape() -> impl Strategy<Value = String> {
    prop_oneof![
        (vec3(-3.0, 3.0), num(0.01, 2.0))
            .prop_map(|(c, r)| format!("{{ type = \"sphere\", center = {c}, radius = {r} }}")),
        (vec3(-3.0, 3.0), vec3(-1.0, 1.0), num(0.1, 4.0), num(0.1, 4.0)).prop_map(|(c, n, a, b)| format!(
            "{{ type = \"rect\", center = {c}, normal = {n}, u_axis = [1.0, 0.0, 0.0], size = [{a}, {b}] }}"
        )),
        (vec3(-3.0, 3.0), vec3(0.05, 3.0))
            .prop_map(|(c, s)| format!("{{ type = \"box\", center = {c}, size = {s} }}")),
        (vec3(-2.0, 2.0), vec3(-2.0, 2.0), num(0.05, 1.0), any::<bool>()).prop_map(
            |(a, b, r, caps)| format!(
                "{{ type = \"cylinder\", p0 = {a}, p1 = {b}, radius = {r}, caps = {caps} }}"
            )
        ),
        (vec3(-2.0, 2.0), vec3(-2.0, 2.0), num(0.2, 1.0), num(0.05, 0.9)).prop_map(|(a, b, o, i)| format!(
            "{{ type = \"tube\", p0 = {a}, p1 = {b}, outer_radius = {o}, inner_radius = {i} }}"
        )),
        (vec3(-3.0, 3.0), vec3(-1.0, 1.0), num(0.1, 2.0), num(0.0, 0.1)).prop_map(|(c, n, r, i)| format!(
            "{{ type = \"disk\", center = {c}, normal = {n}, radius = {r}, inner_radius = {i} }}"
        )),
        (num(1.0, 20.0), count(0, 8), num(0.0, 0.5), num(0.0, 1.0)).prop_map(|(s, l, h, r)| format!(
            "{{ type = \"heightfield\", size = [{s}, {s}], levels = {l}, height = {h}, roughness = {r} }}"
        )),
        (
            prop::collection::vec((num(0.0, 1.0), num(-1.0, 1.0)), 0..5),
            count(3, 64)
        )
            .prop_map(|(pts, seg)| {
                let p: Vec<String> = pts.iter().map(|(r, y)| format!("[{r}, {y}]")).collect();
                format!(
                    "{{ type = \"lathe\", profile = [{}], segments = {seg} }}",
                    p.join(", ")
                )
            }),
        Just("{ type = \"mesh\", file = \"glass_air.obj\" }".to_string()),
        Just("{ type = \"mesh\", file = \"missing.obj\" }".to_string()),
    ]
}

fn material() -> impl Strategy<Value = String> {
    prop_oneof![
        vec3(0.0, 1.0).prop_map(|c| format!("{{ type = \"diffuse\", reflectance = {c} }}")),
        (num(0.05, 2.0), vec3(0.0, 1.0)).prop_map(|(s, c)| format!(
            "{{ type = \"diffuse\", reflectance = {{ type = \"checker\", axes = [\"x\", \"z\"], size = {s}, color0 = {c}, color1 = [0.1, 0.1, 0.1] }} }}"
        )),
        vec3(0.0, 1.0).prop_map(|c| format!("{{ type = \"mirror\", reflectance = {c} }}")),
        (num(1.0, 2.5), -3i64..5).prop_map(|(n, p)| format!("{{ type = \"dielectric\", ior = {n}, priority = {p} }}")),
        (num(1.0, 2.5), num(1.0, 1.5))
            .prop_map(|(a, b)| format!("{{ type = \"dielectric\", int_ior = {a}, ext_ior = {b} }}")),
        (num(1.0, 2.0), vec3(0.0, 1.0), num(0.01, 5.0)).prop_map(|(n, c, d)| format!(
            "{{ type = \"dielectric\", ior = {n}, absorption = {{ color = {c}, distance = {d} }} }}"
        )),
        Just("{ type = \"black\" }".to_string()),
    ]
}

fn object(i: usize) -> impl Strategy<Value = String> {
    (
        shape(),
        material(),
        prop::option::of(vec3(0.0, 3.0)),
        prop::option::of(vec3(-1.0, 1.0)),
    )
        .prop_map(move |(s, m, emission, translate)| {
            let mut t = format!("[[objects]]\nname = \"o{i}\"\nshape = {s}\nmaterial = {m}\n");
            if let Some(e) = emission {
                t += &format!("emission = {{ radiance = {e} }}\n");
            }
            if let Some(tr) = translate {
                t += &format!("transform = [{{ translate = {tr} }}]\n");
            }
            t
        })
}

fn light() -> impl Strategy<Value = String> {
    prop_oneof![
        (vec3(-3.0, 3.0), vec3(0.0, 20.0))
            .prop_map(|(p, i)| format!("[[lights]]\ntype = \"point\"\nposition = {p}\nintensity = {i}\n")),
        (vec3(-1.0, 1.0), vec3(0.0, 5.0))
            .prop_map(|(d, e)| format!("[[lights]]\ntype = \"directional\"\ndirection = {d}\nirradiance = {e}\n")),
        (vec3(-3.0, 3.0), num(0.1, 2.0), vec3(0.0, 10.0)).prop_map(|(c, s, r)| format!(
            "[[lights]]\ntype = \"rect\"\ncenter = {c}\nnormal = [0.0, -1.0, 0.0]\nu_axis = [1.0, 0.0, 0.0]\nsize = [{s}, {s}]\nradiance = {r}\n"
        )),
        (vec3(-3.0, 3.0), num(0.05, 1.0), vec3(0.0, 10.0))
            .prop_map(|(c, r, l)| format!("[[lights]]\ntype = \"sphere\"\ncenter = {c}\nradius = {r}\nradiance = {l}\n")),
    ]
}

fn medium() -> impl Strategy<Value = String> {
    let field = prop_oneof![
        num(0.5, 2.0).prop_map(|n| format!("{{ kind = \"constant\", n = {n} }}")),
        (num(0.9, 1.5), num(-0.05, 0.05)).prop_map(|(a, m)| format!("{{ kind = \"linear\", n0 = {a}, m = {m} }}")),
        (num(1.0, 1.001), num(0.0, 0.001), num(0.01, 2.0))
            .prop_map(|(a, d, h)| format!("{{ kind = \"hot_ground\", n_inf = {a}, dn = {d}, h0 = {h} }}")),
        (num(1.0, 1.001), num(-0.001, 0.001), num(0.0, 3.0), num(0.001, 2.0)).prop_map(|(a, d, h, t)| format!(
            "{{ kind = \"inversion\", n0 = {a}, dn = {d}, height = {h}, thickness = {t} }}"
        )),
        (num(1.0, 1.01), num(0.0, 0.05), num(0.05, 1.0), num(0.0, 1.0), num(0.001, 1.0)).prop_map(
            |(a, d, r, amp, w)| format!(
                "{{ kind = \"plume\", n_amb = {a}, dn = {d}, center = [0.0, 0.0, 0.0], radius = {r}, height = 2.0, amplitude = {amp}, wavelength = {w} }}"
            )
        ),
    ];
    (
        field,
        vec3(-4.0, 0.0),
        vec3(0.1, 4.0),
        prop::sample::select(vec!["rk45", "rk4", "exact", "slab", "euler", "magic"]),
        num(1e-6, 0.1),
        num(0.001, 1.0),
    )
        .prop_map(|(f, lo, hi, m, tol, step)| {
            format!("[medium]\nfield = {f}\nbounds = {{ min = {lo}, max = {hi} }}\nmethod = \"{m}\"\ntolerance = {tol}\nstep = {step}\n")
        })
}

prop_compose! {
    fn document()(
        pos in vec3(-5.0, 5.0),
        fov in num(1.0, 120.0),
        width in count(1, 64),
        height in count(1, 48),
        spp in count(1, 4),
        integrator in prop_oneof![12 => Just("path"), 4 => Just("whitted"), 1 => Just("bidir")],
        depth in count(1, 12),
        ambient in num(0.5, 2.0),
        env in prop::option::of(vec3(0.0, 1.0)),
        lights in prop::collection::vec(light(), 0..3),
        objects in prop::collection::vec(0usize..1, 0..4).prop_flat_map(|v| {
            let n = v.len();
            (0..n).map(object).collect::<Vec<_>>()
        }),
        medium in prop::option::weighted(0.3, medium()),
        unknown in prop::option::weighted(0.05, prop::sample::select(vec!["camera", "film", "integrator"])),
    ) -> String {
        let mut t = format!("ambient_ior = {ambient}\n\n[camera]\nposition = {pos}\ntarget = [0.0, 0.0, 0.0]\nfov = {fov}\n");
        if unknown == Some("camera") {
            t += "colour = 1\n";
        }
        t += &format!("\n[film]\nwidth = {width}\nheight = {height}\nspp = {spp}\n");
        if unknown == Some("film") {
            t += "colour = 1\n";
        }
        t += &format!("\n[integrator]\ntype = \"{integrator}\"\nmax_depth = {depth}\n");
        if unknown == Some("integrator") {
            t += "colour = 1\n";
        }
        if let Some(e) = env {
            t += &format!("\n[environment]\ntype = \"constant\"\nradiance = {e}\n");
        }
        if let Some(m) = medium {
            t += "\n";
            t += &m;
        }
        for l in lights {
            t += "\n";
            t += &l;
        }
        for o in objects {
            t += "\n";
            t += &o;
        }
        t
    }
}

fn config() -> ProptestConfig {
    // A fixed seed keeps CI deterministic; SNELL_PROPTEST_SEED explores others.
    let seed = std::env::var("SNELL_PROPTEST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2026);
    ProptestConfig {
        cases: 400,
        failure_persistence: None,
        rng_seed: proptest::test_runner::RngSeed::Fixed(seed),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn any_scene_document_renders_or_fails_with_a_located_error(doc in document()) {
        let t = Instant::now();
        match load_scene_str("p.toml", &doc, Path::new("scenes"), &BuildOptions::default()) {
            Ok(s) => {
                let (w, h) = (s.width.min(8), s.height.min(6));
                let set = RenderSettings::from_scene(&s).with_resolution(w, h).expect("a smaller film is always valid");
                let r = render(&s, &set.with_spp(1), &RenderOptions { threads: Some(1), want_aovs: false, ..Default::default() });
                prop_assert!(r.is_ok(), "render failed: {:?}\n{doc}", r.err());
                let r = r.unwrap();
                prop_assert!(r.pixels.iter().all(|p| p.is_finite()), "non-finite pixel\n{doc}");
            }
            Err(e) => {
                let msg = e.to_string();
                // file:line:col: key: message
                let located = msg.starts_with("p.toml:")
                    && msg.split(':').nth(1).is_some_and(|l| l.trim().parse::<u32>().is_ok());
                prop_assert!(located, "unlocated error: {msg}\n{doc}");
            }
        }
        let el = t.elapsed().as_secs_f64();
        prop_assert!(el < 1.0 * if cfg!(debug_assertions) { 5.0 } else { 1.0 }, "{el:.2} s\n{doc}");
    }
}

/// What the strategies found, kept as regression tests: each is now a located
/// error, before any allocation or ray.
#[test]
fn regressions_found_by_the_strategies() {
    let base = "[camera]\nposition = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 20.0\n[film]\nwidth = 4\nheight = 3\nspp = 1\n";
    let cases = [
        // An index of 1e300 in a medium: 5.6 s of integrator crawl for 42 rays.
        (
            "[medium]\nfield = { kind = \"inversion\", n0 = 1e300, dn = 0.0001, height = 2.0, thickness = 1.0 }\nbounds = { min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }\n[[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n",
            "medium.field",
        ),
        // 1e9 heightfield levels: the memory estimate overflowed (a panic in debug builds).
        (
            "[[objects]]\nshape = { type = \"heightfield\", size = [1.0, 1.0], levels = 1000000000, height = 0.0, roughness = 0.5 }\nmaterial = { type = \"black\" }\n",
            "levels",
        ),
        // A checker of 1e-300 m: 1/size is infinite in f32 and the parity sum overflowed.
        (
            "[[objects]]\nshape = { type = \"sphere\", center = [0.0, 0.0, 0.0], radius = 1.0 }\nmaterial = { type = \"diffuse\", reflectance = { type = \"checker\", axes = [\"x\", \"z\"], size = 1e-300, color0 = [0.0, 0.0, 0.0], color1 = [0.1, 0.1, 0.1] } }\n",
            "size",
        ),
    ];
    for (extra, key) in cases {
        check(base, extra, key);
    }
    // The absurd sizes, each refused with the estimated cost.
    for (extra, key) in [
        (
            "[medium]\nfield = { kind = \"constant\", n = 1.0 }\nbounds = { min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }\ntolerance = 1e-300\n[[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n",
            "chords per metre",
        ),
        (
            "[[objects]]\nshape = { type = \"heightfield\", size = [1.0, 1.0], levels = 14, height = 0.0, roughness = 0.5 }\nmaterial = { type = \"black\" }\n",
            "5.37e8 triangles",
        ),
    ] {
        check(base, extra, key);
    }
}

fn check(base: &str, extra: &str, key: &str) {
    {
        let doc = format!("{base}{extra}");
        let e = load_scene_str("r.toml", &doc, Path::new("scenes"), &BuildOptions::default())
            .err()
            .unwrap_or_else(|| panic!("accepted:\n{doc}"))
            .to_string();
        assert!(e.starts_with("r.toml:") && e.contains(key), "{key}: {e}");
    }
}
