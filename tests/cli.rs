//! The `snell` binary end to end: version/provenance, render with AOVs and
//! stats, clear errors for bad input and unwritable outputs.
use std::path::{Path, PathBuf};
use std::process::Command;

fn snell() -> Command {
    Command::new(env!("CARGO_BIN_EXE_snell"))
}

/// Renders `scene` to `exr` at `film` (e.g. `--width`, `--spp` and their
/// values) with `extra`, quietly on two threads, and returns its pixels'
/// bits (an image test's exact comparison).
fn rendered_bits(scene: &str, exr: &Path, film: &[&str], extra: &[&str]) -> Vec<u32> {
    let out = snell()
        .args(["render", scene, "-o"])
        .arg(exr)
        .args(film)
        .args(["--threads", "2", "--quiet"])
        .args(extra)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (_, _, px) = snell::image_io::read_exr_rgb(exr).unwrap();
    px.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("snell-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn version_prints_provenance() {
    let out = snell().arg("--version").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(text.contains("commit ") && text.contains("Embree 3."), "{text}");
    assert!(text.contains("rustc") && text.contains("profile"), "{text}");
}

#[test]
fn render_writes_exr_with_aovs_and_stats_json() {
    let d = tmpdir("render");
    let exr = d.join("n.exr");
    let stats = d.join("s.json");
    let out = snell()
        .args(["render", "scenes/nested_spheres_a.toml", "-o"])
        .arg(&exr)
        .args([
            "--width",
            "32",
            "--height",
            "24",
            "--spp",
            "2",
            "--threads",
            "2",
            "--quiet",
        ])
        .args(["--aov", "false_hits,list_depth,tir,fallbacks", "--stats-json"])
        .arg(&stats)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let img = snell::scene::texture::load_image(&exr).unwrap();
    assert_eq!((img.width, img.height), (32, 24));
    let s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    for key in [
        "wall_s",
        "samples_per_s",
        "rays_per_s",
        "rays",
        "false_hits_per_ray",
        "filter_calls_per_ray",
        "max_list_depth",
        "fallbacks",
    ] {
        assert!(s.get(key).is_some(), "stats lack {key}: {s}");
    }
    assert!(s["provenance"]["embree_version"]
        .as_str()
        .unwrap()
        .starts_with('3'));
    assert!(s["false_hits_per_ray"].as_f64().unwrap() > 0.0);
    // How Embree built it: nested solids that overlap need both flags.
    let eb = &s["embree_scene"];
    assert_eq!(
        (&eb["robust"], &eb["context_filter"], &eb["build_quality"]),
        (
            &serde_json::json!(true),
            &serde_json::json!(true),
            &serde_json::json!("medium")
        ),
        "{eb}"
    );
    // No temporary files are left behind.
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_scene_and_unwritable_output_are_clear_errors() {
    let d = tmpdir("bad");
    let bad = d.join("bad.toml");
    std::fs::write(
        &bad,
        "[camera]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 400.0\n",
    )
    .unwrap();
    let out = snell()
        .args(["render"])
        .arg(&bad)
        .args(["-o"])
        .arg(d.join("x.png"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.toml:4:") && err.contains("camera.fov"), "{err}");
    assert!(!err.contains("panicked"));

    let out = snell()
        .args([
            "render",
            "scenes/three_spheres.toml",
            "-o",
            "/nonexistent-snell-dir/x.png",
        ])
        .args(["--width", "8", "--height", "6", "--spp", "1", "--quiet"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("/nonexistent-snell-dir/x.png") && err.contains("does not exist"),
        "{err}"
    );

    let out = snell()
        .args(["render", "scenes/three_spheres.toml", "-o"])
        .arg(d.join("x.tiff"))
        .args(["--width", "8", "--height", "6", "--spp", "1", "--quiet"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected .png"));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn ctrl_c_stops_at_a_tile_boundary_and_writes_a_partial_image() {
    let d = tmpdir("sigint");
    let out = d.join("big.exr");
    let mut child = snell()
        .args(["render", "scenes/glass_ice_bubbles.toml", "-o"])
        .arg(&out)
        .args([
            "--spp",
            "4096",
            "--width",
            "64",
            "--height",
            "48",
            "--threads",
            "1",
            "--quiet",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let st = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(st.success());
    let status = child.wait().unwrap();
    assert!(status.success(), "the interrupted render exits cleanly");
    let partial = d.join("big.partial.exr");
    assert!(partial.exists(), "the image so far is written, clearly named");
    assert!(!out.exists(), "the complete name is not used for a partial image");
    let img = snell::scene::texture::load_image(&partial).unwrap();
    assert_eq!((img.width, img.height), (64, 48));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn grin_trace_and_warp_points_batch_tools() {
    let d = tmpdir("batch");
    let q = d.join("q.json");
    std::fs::write(
        &q,
        r#"{"queries": [{"id": "a", "field": {"kind": "linear", "n0": 1.0, "m": 0.01},
            "start": [0, 0, 0], "direction": [0.9848, 0.1736, 0], "stop": {"x": 100.0},
            "method": "rk45", "tolerance": 1e-10},
           {"id": "b", "field": {"kind": "linear", "n0": 1.0, "m": 0.01},
            "start": [0, 0, 0], "direction": [0.9848, 0.1736, 0], "stop": {"x": 100.0}, "method": "exact"},
           {"id": "bad", "field": {"kind": "linear", "n0": 1.0}, "start": [0, 0, 0],
            "direction": [1, 0, 0], "stop": {"x": 1.0}, "method": "rk45"}]}"#,
    )
    .unwrap();
    let out = d.join("r.json");
    let st = snell()
        .args(["grin-trace"])
        .arg(&q)
        .arg("-o")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let res = r["results"].as_array().unwrap();
    let (a, b) = (&res[0], &res[1]);
    assert_eq!(a["status"], "ok");
    for k in 0..3 {
        let (x, y) = (a["end"][k].as_f64().unwrap(), b["end"][k].as_f64().unwrap());
        assert!((x - y).abs() < 1e-7, "rk45 vs exact end point: {x} vs {y}");
    }
    assert_ne!(res[2]["status"], "ok", "a bad query gets its own error status");

    let w = d.join("w.json");
    std::fs::write(
        &w,
        r#"{"eye": [0, 0, 4], "glass": {"kind": "hollow_cylinder", "axis_point": [0, 0, 0], "axis_direction": [0, 1, 0],
            "outer_radius": 1.0, "inner_radius": 0.8, "ior": 1.5}, "method": "exact", "points": [[0.5, 0, -2.5], [0, 0.5, -4]]}"#,
    )
    .unwrap();
    let o = snell().args(["warp-points"]).arg(&w).output().unwrap();
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["points"][1]["images"]
        .as_array()
        .unwrap()
        .iter()
        .any(|i| i["family"] == "through4"));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn grin_fan_writes_svg_and_json_and_refuses_bad_flags() {
    let d = tmpdir("fan");
    let (svg, json) = (d.join("fan.svg"), d.join("fan.json"));
    let out = snell()
        .args(["grin-fan", "scenes/mirage_road.toml", "--rays", "7", "-o"])
        .arg(&svg)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert_eq!(text.matches("<polyline").count(), 7);
    let fan: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(fan["rays"].as_array().unwrap().len(), 7);
    assert!(
        fan["objects"].as_array().unwrap().iter().any(|o| o == "car"),
        "{}",
        fan["objects"]
    );
    for (args, says) in [
        (vec!["--rays", "1"], "--rays"),
        (vec!["--from", "2", "--to", "-2"], "--from/--to"),
        (vec!["--from", "-1"], "--to"),
    ] {
        let out = snell()
            .args(["grin-fan", "scenes/mirage_road.toml", "-o"])
            .arg(d.join("bad.svg"))
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(says), "{args:?}: {err}");
        assert!(!d.join("bad.svg").exists());
    }
}

/// `--analytic-shapes embree` (Embree's callbacks) and the default (the
/// analytic set) give the same image bit for bit on a scene of analytic
/// shapes alone (cylinder_refraction with an emitting disk for its rect:
/// with `embree` a rect stays two triangles, the image of the scene
/// itself changes by the triangles' rounding); another seed does not (the
/// comparison can fail). A value it does not know is a clear error.
#[test]
fn analytic_shapes_flag_keeps_the_image() {
    let d = tmpdir("analytic");
    let text = std::fs::read_to_string("scenes/cylinder_refraction.toml").unwrap();
    let rect = r#"shape = { type = "rect", center = [0.0, 0.0, -3.0], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [100.0, 100.0] }"#;
    let disk =
        r#"shape = { type = "disk", center = [0.0, 0.0, -3.0], normal = [0.0, 0.0, 1.0], radius = 60.0 }"#;
    assert!(text.contains(rect), "the scene's emitting rect moved");
    let scene = d.join("cylinders_and_disk.toml");
    std::fs::write(&scene, text.replace(rect, disk)).unwrap();
    const FILM: [&str; 6] = ["--width", "32", "--height", "24", "--spp", "2"];
    let render =
        |name: &str, extra: &[&str]| rendered_bits(scene.to_str().unwrap(), &d.join(name), &FILM, extra);
    let set = render("set.exr", &[]);
    let embree = render("embree.exr", &["--analytic-shapes", "embree"]);
    assert_eq!(set, embree);
    assert_ne!(set, render("seed.exr", &["--seed", "1"]));
    let out = snell()
        .args([
            "render",
            "scenes/cylinder_refraction.toml",
            "--analytic-shapes",
            "f32",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("analytic-shapes"));
    let _ = std::fs::remove_dir_all(&d);
}

/// Paths traced 8 or 16 to a packet give the same image bit for bit (each
/// path is its own, whatever shares its packet), on a scene with nested
/// solids and one with the analytic set; another seed does not, and a width
/// Embree has no packet for is refused.
#[test]
fn packet_width_keeps_the_image() {
    let d = tmpdir("packet_width");
    const FILM: [&str; 6] = ["--width", "32", "--height", "24", "--spp", "20"];
    let render = |scene: &str, name: &str, extra: &[&str]| rendered_bits(scene, &d.join(name), &FILM, extra);
    for scene in ["scenes/glass_of_water_nested.toml", "scenes/three_spheres.toml"] {
        let eight = render(scene, "8.exr", &["--packet-width", "8"]);
        let sixteen = render(scene, "16.exr", &["--packet-width", "16"]);
        assert_eq!(eight, sixteen, "{scene}");
        assert_ne!(
            eight,
            render(scene, "seed.exr", &["--packet-width", "8", "--seed", "1"]),
            "{scene}"
        );
    }
    let out = snell()
        .args(["render", "scenes/three_spheres.toml", "--packet-width", "4"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("packet-width"));
    let _ = std::fs::remove_dir_all(&d);
}

/// `--flights side-by-side` (the default: a tile row's camera rays flown
/// through the plume together) and `one-by-one` render the same image bit
/// for bit, on a film whose last tile is part-width, at an odd spp; another
/// seed changes it; an unknown value is refused.
#[test]
fn flights_side_by_side_keep_the_image() {
    let d = tmpdir("flights");
    const FILM: [&str; 6] = ["--width", "40", "--height", "30", "--spp", "3"];
    let render =
        |name: &str, extra: &[&str]| rendered_bits("scenes/heat_shimmer.toml", &d.join(name), &FILM, extra);
    let together = render("side.exr", &["--flights", "side-by-side"]);
    assert_eq!(together, render("alone.exr", &["--flights", "one-by-one"]));
    assert_eq!(together, render("default.exr", &[]));
    assert_ne!(together, render("seed.exr", &["--seed", "1"]));
    let out = snell()
        .args(["render", "scenes/heat_shimmer.toml", "--flights", "sideways"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("flights"));
    let _ = std::fs::remove_dir_all(&d);
}

/// `--light-sampling`: `mis` is the default (the same image bit for bit),
/// `bsdf` renders another image of the same scene and says so in the stats;
/// an unknown value is refused.
#[test]
fn light_sampling_flag_turns_next_event_estimation_off() {
    let d = tmpdir("light_sampling");
    const FILM: [&str; 6] = ["--width", "32", "--height", "24", "--spp", "2"];
    let scene = "scenes/lamps.toml";
    let default = rendered_bits(scene, &d.join("default.exr"), &FILM, &[]);
    assert_eq!(
        default,
        rendered_bits(scene, &d.join("mis.exr"), &FILM, &["--light-sampling", "mis"])
    );
    let stats = d.join("s.json");
    let bsdf = rendered_bits(
        scene,
        &d.join("bsdf.exr"),
        &FILM,
        &[
            "--light-sampling",
            "bsdf",
            "--stats-json",
            stats.to_str().unwrap(),
        ],
    );
    assert_ne!(default, bsdf);
    let s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(s["light_sampling"], "bsdf", "{s}");
    let out = snell()
        .args([
            "render",
            scene,
            "-o",
            d.join("x.exr").to_str().unwrap(),
            "--light-sampling",
            "none",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("light-sampling"));
    let _ = std::fs::remove_dir_all(&d);
}

/// glTF has no world light: `--set` gives an imported scene its
/// environment, a constant one key by key or a whole table (a map), also
/// replacing the one a file names (docs/import-gltf.md).
#[test]
fn set_gives_a_gltf_scene_its_environment() {
    let d = tmpdir("gltf-env");
    // A triangle in the upper right of the view; the top-left pixel sees the sky.
    let gltf = d.join("t.gltf");
    std::fs::write(
        &gltf,
        r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
 "nodes": [{"camera": 0, "translation": [0.0, 0.0, 3.0]}, {"mesh": 0}],
 "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
 "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
 "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
               {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
 "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
 "buffers": [{"byteLength": 44, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="}]}"#,
    )
    .unwrap();
    let sky = [0.75f32, 0.5, 0.25];
    let px = vec![glam::Vec3A::from(sky); 8 * 4];
    std::fs::write(
        d.join("sky.exr"),
        snell::image_io::encode_exr(8, 4, &px, &[], &[]).unwrap(),
    )
    .unwrap();
    let film = ["--width", "16", "--height", "12", "--spp", "4"];
    let corner = |scene: &Path, extra: &[&str]| -> [f32; 3] {
        let exr = d.join("o.exr");
        let bits = rendered_bits(scene.to_str().unwrap(), &exr, &film, extra);
        [0, 1, 2].map(|k| f32::from_bits(bits[k]))
    };
    assert_eq!(corner(&gltf, &[]), [0.0; 3], "no environment: black");
    let c = corner(
        &gltf,
        &[
            "--set",
            "environment.type=constant",
            "--set",
            "environment.radiance=[0.25, 0.5, 1.0]",
        ],
    );
    assert_eq!(c, [0.25, 0.5, 1.0]);
    // A map, relative to the glTF's directory, as one inline table.
    let c = corner(
        &gltf,
        &[
            "--set",
            r#"environment={ type = "map", file = "sky.exr", rows = "poles" }"#,
        ],
    );
    assert!(c.iter().zip(sky).all(|(a, b)| (a - b).abs() < 1e-6), "{c:?}");
    // The glass of water names a constant 0.3 in its extras: a table
    // replaces it (a uniform 0.3 map renders the same, twice that does not).
    let grey = vec![glam::Vec3A::splat(0.3); 8 * 4];
    std::fs::write(
        d.join("grey.exr"),
        snell::image_io::encode_exr(8, 4, &grey, &[], &[]).unwrap(),
    )
    .unwrap();
    let glb = "scenes/glass_of_water.glb";
    // The map is importance-sampled where the constant is not: the two
    // agree in expectation, not path by path, so their image means are
    // compared, at enough samples for a few percent of noise.
    let film = ["--width", "16", "--height", "12", "--spp", "64"];
    let image = |extra: &[&str]| {
        let bits = rendered_bits(glb, &d.join("g.exr"), &film, extra);
        bits.into_iter().map(f32::from_bits).collect::<Vec<f32>>()
    };
    let map = |scale: f64| {
        format!(
            "environment={{ type = \"map\", file = {:?}, scale = {scale} }}",
            d.join("grey.exr").to_str().unwrap()
        )
    };
    let plain = image(&[]);
    let same = image(&["--set", &map(1.0)]);
    let twice = image(&["--set", &map(2.0)]);
    let mean = |a: &[f32]| a.iter().map(|&x| x as f64).sum::<f64>() / a.len() as f64;
    let (same, twice) = (mean(&same) / mean(&plain), mean(&twice) / mean(&plain));
    eprintln!("image mean against the constant's: uniform map {same:.4}, twice the map {twice:.4}");
    assert!((same - 1.0).abs() < 0.03, "{same}");
    assert!(twice > 1.1, "{twice}");
    // A key the environment does not have is an error naming it.
    let out = snell()
        .args(["render"])
        .arg(&gltf)
        .arg("-o")
        .arg(d.join("x.exr"))
        .args([
            "--set",
            "environment.type=constant",
            "--set",
            "environment.radius=1.0",
        ])
        .args(film)
        .arg("--quiet")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("radius") && !err.contains("panicked"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

/// `--stats-json` names the method the medium was traced by, `auto`
/// resolved: invariant for mirage_road's height-only closed-form field,
/// rk45 for hot_road_air's tabulated profile (`Method::auto_for`), the
/// method an override sets, and null without a medium.
#[test]
fn stats_json_names_the_method_auto_chose() {
    let d = tmpdir("grin_method");
    let stats = |scene: &str, extra: &[&str]| {
        let json = d.join("s.json");
        let out = snell()
            .args(["render", scene, "-o"])
            .arg(d.join("x.png"))
            .args([
                "--width",
                "8",
                "--height",
                "4",
                "--spp",
                "1",
                "--threads",
                "1",
                "--quiet",
            ])
            .arg("--stats-json")
            .arg(&json)
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        (s["grin_method"].clone(), s["grin_field"].clone())
    };
    use serde_json::json;
    assert_eq!(
        stats("scenes/mirage_road.toml", &[]),
        (json!("invariant"), json!("hot_ground"))
    );
    assert_eq!(
        stats("scenes/mirage_road.toml", &["--set", "medium.method=rk45"]),
        (json!("rk45"), json!("hot_ground"))
    );
    assert_eq!(
        stats("scenes/hot_road_air.toml", &[]),
        (json!("rk45"), json!("profile"))
    );
    assert_eq!(
        stats("scenes/mirage_road_nofield.toml", &[]),
        (json!(null), json!(null))
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// `snell bench grin --scenes DIR`: one row per medium scene with a finite
/// positive ratio, the Markdown written whole with the provenance and the
/// command; a medium scene without a twin is an error naming both files.
#[test]
fn bench_grin_tables_each_medium_scene_against_its_twin() {
    let d = tmpdir("bench_grin");
    let scenes = d.join("scenes");
    let _ = std::fs::remove_dir_all(&scenes);
    std::fs::create_dir_all(&scenes).unwrap();
    let twin = r#"
[camera]
position = [0.0, 1.0, 5.0]
target = [0.0, 0.5, 0.0]
fov = 40.0

[film]
width = 16
height = 8
spp = 1

[environment]
type = "constant"
radiance = [0.5, 0.7, 1.0]

[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.0, 0.5, 0.0], radius = 0.5 }
material = { type = "diffuse", reflectance = [0.6, 0.1, 0.1] }
"#;
    let medium = format!(
        "{twin}\n[medium]\nfield = {{ kind = \"plume\", n_amb = 1.0, dn = 0.01, center = [0.0, 1.2, 0.0], radius = 0.3, height = 1.0, amplitude = 0.5, wavelength = 0.2, waves = 3, seed = 1 }}\nbounds = {{ min = [-1.0, 1.1, -1.0], max = [1.0, 2.5, 1.0] }}\n"
    );
    std::fs::write(scenes.join("air.toml"), &medium).unwrap();
    std::fs::write(scenes.join("air_nofield.toml"), twin).unwrap();
    let md = d.join("grin.md");
    let bench = |extra: &[&str]| {
        snell()
            .args(["bench", "grin", "--scenes"])
            .arg(&scenes)
            .args(["--reps", "2", "--spp", "1", "--scale", "0.5"])
            .args(extra)
            .output()
            .unwrap()
    };
    let out = bench(&["--markdown", md.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let doc = std::fs::read_to_string(&md).unwrap();
    assert!(
        doc.starts_with("provenance: ") && doc.contains("Embree 3.") && doc.contains("SIMD"),
        "{doc}"
    );
    assert!(
        doc.contains("`snell bench grin --scenes") && !doc.contains("--markdown"),
        "{doc}"
    );
    let rows: Vec<&str> = doc.lines().filter(|l| l.starts_with("| air ")).collect();
    assert_eq!(rows.len(), 1, "{doc}");
    let cells: Vec<&str> = rows[0].split('|').map(str::trim).collect();
    // | scene | twin | field | method | film | chords | scene s | twin s | ratio | CPU ratio |
    assert_eq!(
        &cells[1..6],
        ["air", "air_nofield", "plume", "rk45 (auto)", "8×4×1"],
        "{doc}"
    );
    let ratio: f64 = cells[9].split('×').next().unwrap().parse().unwrap();
    assert!(ratio.is_finite() && ratio > 0.0, "{doc}");
    // The table is on stdout too; no temporary file is left beside the document.
    assert!(String::from_utf8_lossy(&out.stdout).contains(rows[0]));
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");

    std::fs::write(scenes.join("lone.toml"), &medium).unwrap();
    let out = bench(&[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("lone.toml") && err.contains("lone_nofield.toml"),
        "{err}"
    );
    let out = bench(&["--frobnicate"]);
    assert!(!out.status.success());
    let _ = std::fs::remove_dir_all(&d);
}
