//! The Mitsuba 3 XML importer: the reference scenes written as XML describe
//! and render the same scenes as their TOML (block means within the
//! seed-to-seed noise, and a wrong variant fails the same threshold); the
//! description survives `convert`'s TOML; mapping rules; located errors.
use snell::render::{render, RenderOptions, RenderSettings, Rendered};
use snell::scene::desc::SceneDesc;
use snell::scene::import::{mitsuba, to_toml, ImportOptions};
use snell::scene::{load_scene, load_scene_str, BuildOptions, RenderScene};
use snell::Error;
use std::path::Path;

const REFERENCE: [&str; 3] = ["three_spheres", "glass_of_water", "cylinder_refraction"];

fn import_text(text: &str, opts: &ImportOptions) -> snell::Result<snell::scene::import::Imported> {
    mitsuba::import_str("t.xml", text, Path::new("scenes"), opts)
}

/// Build XML text through the importer, as `snell render` does.
fn build_xml(text: &str) -> RenderScene {
    let imp = import_text(text, &ImportOptions::default()).unwrap();
    let toml = to_toml(&imp.desc).unwrap();
    load_scene_str(
        "t.xml (imported)",
        &toml,
        Path::new("scenes"),
        &BuildOptions::default(),
    )
    .unwrap()
}

fn go(s: &RenderScene, seed: u64) -> Rendered {
    let set = RenderSettings::from_scene(s)
        .with_resolution(320, 240)
        .unwrap()
        .with_spp(16)
        .with_seed(seed);
    let opts = RenderOptions {
        threads: Some(2),
        want_aovs: false,
        ..Default::default()
    };
    render(s, &set, &opts).unwrap()
}

/// 16×16 block means of channel `ch`.
fn blocks(r: &Rendered, ch: usize) -> Vec<f64> {
    let k = 16;
    let (bw, bh) = (r.width / k, r.height / k);
    let mut out = vec![0.0; (bw * bh) as usize];
    for y in 0..bh * k {
        for x in 0..bw * k {
            out[((y / k) * bw + x / k) as usize] += r.pixels[(y * r.width + x) as usize][ch] as f64;
        }
    }
    out.iter().map(|s| s / (k * k) as f64).collect()
}

/// Block RMS of `img` against `r1`, over the RMS between two seeds of the
/// reference (`r1`, `r2`): about 1 for a render of the same scene.
fn score(img: &Rendered, r1: &Rendered, r2: &Rendered) -> f64 {
    let rms = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
    let (mut num, mut den) = (0.0, 0.0);
    for ch in 0..3 {
        let (a, b, n) = (blocks(r1, ch), blocks(r2, ch), blocks(img, ch));
        num += rms(&n, &a);
        den += rms(&a, &b);
    }
    (num / den).sqrt()
}

#[test]
fn reference_xml_describes_the_toml_scene() {
    for name in REFERENCE {
        let toml = std::fs::read_to_string(format!("scenes/{name}.toml")).unwrap();
        let want: SceneDesc = toml::from_str(&toml).unwrap();
        let path = format!("scenes/{name}.xml");
        let got = snell::scene::import::import_scene(Path::new(&path), &ImportOptions::default()).unwrap();
        assert!(got.warnings.is_empty(), "{name}: {:?}", got.warnings);
        assert_eq!(format!("{:?}", got.desc), format!("{want:?}"), "{name}");
    }
}

/// The issue's criterion: each reference XML, rendered through the importer,
/// matches its TOML by 16×16 block means within 1.5× the TOML's own
/// seed-to-seed noise; a known-wrong variant of each XML fails it.
#[test]
fn reference_xml_renders_like_the_toml_within_noise() {
    let threshold = 1.5;
    let wrong = [
        (
            "three_spheres",
            "<float name=\"int_ior\" value=\"1.5\"/>",
            "<float name=\"int_ior\" value=\"1.4\"/>",
        ),
        (
            "glass_of_water",
            "<float name=\"int_ior\" value=\"1.33\"/>\n            <float name=\"ext_ior\" value=\"1.0\"/>",
            "<float name=\"int_ior\" value=\"1.2\"/>\n            <float name=\"ext_ior\" value=\"1.0\"/>",
        ),
        (
            "cylinder_refraction",
            "<boolean name=\"flip_normals\" value=\"true\"/>",
            "",
        ),
    ];
    for (name, from, to) in wrong {
        let toml = load_scene(
            Path::new(&format!("scenes/{name}.toml")),
            &BuildOptions::default(),
        )
        .unwrap();
        let (r1, r2) = (go(&toml, 1), go(&toml, 2));
        let xml_path = format!("scenes/{name}.xml");
        let xml = load_scene(Path::new(&xml_path), &BuildOptions::default()).unwrap();
        let good = score(&go(&xml, 3), &r1, &r2);
        let text = std::fs::read_to_string(&xml_path).unwrap();
        let bad_text = text.replace(from, to);
        assert_ne!(text, bad_text, "{name}: the wrong variant must change the scene");
        let bad = score(&go(&build_xml(&bad_text), 3), &r1, &r2);
        eprintln!("{name}: imported {good:.2}, wrong variant {bad:.2} (threshold {threshold})");
        assert!(good <= threshold, "{name}: the imported XML differs ({good:.2})");
        assert!(
            bad > threshold,
            "{name}: no power, the wrong variant passes ({bad:.2})"
        );
    }
}

/// `convert` writes the description; reading that TOML gives it back.
#[test]
fn converted_toml_reads_back_as_the_same_description() {
    let mut texts: Vec<String> = REFERENCE
        .iter()
        .map(|n| std::fs::read_to_string(format!("scenes/{n}.xml")).unwrap())
        .collect();
    texts.push(FEATURES.to_string());
    for text in texts {
        let imp = import_text(&text, &ImportOptions::default()).unwrap();
        let toml = to_toml(&imp.desc).unwrap();
        let back: SceneDesc = toml::from_str(&toml).unwrap();
        assert_eq!(format!("{back:?}"), format!("{:?}", imp.desc), "{toml}");
    }
}

/// Many mappings in one scene (every value here is checked below).
const FEATURES: &str = r#"<scene version="3.0.0">
  <default name="res" value="64"/>
  <integrator type="moment"><integrator type="direct"/></integrator>
  <sensor type="thinlens">
    <float name="fov" value="60"/>
    <float name="aperture_radius" value="0.05"/>
    <float name="focus_distance" value="4"/>
    <transform name="to_world"><lookat origin="0, 1, 5" target="0, 1, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="32"/><rfilter type="box"/></film>
    <sampler type="stratified"><integer name="sample_count" value="9"/></sampler>
  </sensor>
  <emitter type="point" id="bulb"><point name="position" x="0" y="3" z="0"/><spectrum name="intensity" value="2"/></emitter>
  <emitter type="directional"><vector name="direction" x="0" y="-1" z="0"/><rgb name="irradiance" value="0.5"/></emitter>
  <shape type="sphere" id="gem">
    <transform name="to_world"><scale value="2"/><translate x="1"/></transform>
    <float name="radius" value="0.25"/>
    <bsdf type="roughdielectric"><string name="int_ior" value="diamond"/><string name="ext_ior" value="water"/></bsdf>
  </shape>
  <shape type="cube" id="crate">
    <transform name="to_world"><scale x="1" y="2" z="3"/><rotate y="1" angle="30"/></transform>
    <bsdf type="twosided"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.2, 700:0.6"/></bsdf></bsdf>
  </shape>
  <shape type="disk" id="lid">
    <boolean name="flip_normals" value="true"/>
    <bsdf type="conductor"/>
  </shape>
</scene>"#;

#[test]
fn features_map_as_documented() {
    let imp = import_text(FEATURES, &ImportOptions::default()).unwrap();
    let d = &imp.desc;
    assert_eq!((d.film.width, d.film.height, d.film.spp), (64, 32, 9));
    assert_eq!((d.integrator.kind.as_str(), d.integrator.max_depth), ("path", 2));
    assert_eq!(d.camera.aperture_radius, 0.05);
    assert_eq!(d.camera.focus_distance, Some(4.0));
    // fov_axis x (Mitsuba's default) on a 2:1 film: the vertical field is narrower.
    let want = 2.0 * ((30f64).to_radians().tan() / 2.0).atan().to_degrees();
    let fov = d.camera.fov.unwrap();
    assert!((fov - want).abs() < 1e-12, "{fov}");
    let dbg = format!("{d:?}");
    // A uniform emitter spectrum is Mitsuba's RGB-variant purple, not white.
    assert!(dbg.contains("intensity: [2.409588"), "{dbg}");
    // Named indices; a uniform scale of 2 doubles the sphere.
    assert!(
        dbg.contains("int_ior: Some(2.419), ext_ior: Some(1.333)"),
        "{dbg}"
    );
    assert!(dbg.contains("center: [1.0, 0.0, 0.0], radius: 0.5"), "{dbg}");
    // A flipped disk faces down; the conductor is a mirror.
    assert!(
        dbg.contains("normal: [-0.0, -0.0, -1.0]") || dbg.contains("normal: [0.0, 0.0, -1.0]"),
        "{dbg}"
    );
    assert!(
        dbg.contains("Mirror(MirrorDesc { reflectance: [1.0, 1.0, 1.0] })"),
        "{dbg}"
    );
    // The rough dielectric keeps its roughness (Mitsuba's defaults: Beckmann, 0.1).
    assert!(
        dbg.contains("RoughDielectric(RoughDielectricDesc")
            && dbg.contains("distribution: Beckmann, alpha: 0.1"),
        "{dbg}"
    );
    // One warning: the moment wrapper.
    let w: Vec<String> = imp.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("t.xml:3:3: <integrator type=\"moment\">") && w[0].contains("unwrapped"),
        "{w:?}"
    );
    // It builds and renders.
    let s = build_xml(FEATURES);
    assert_eq!(s.lights.len(), 2);
    // --strict refuses it at the first warning.
    let strict = ImportOptions {
        strict: true,
        ..Default::default()
    };
    let dir = std::env::temp_dir().join(format!("snell-import-strict-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("features.xml");
    std::fs::write(&f, FEATURES).unwrap();
    match snell::scene::import::import_scene(&f, &strict) {
        Err(Error::Input { line: 3, message, .. }) => assert!(message.contains("--strict"), "{message}"),
        r => panic!("{:?}", r.map(|_| ())),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn err_of(text: &str, opts: &ImportOptions) -> (usize, usize, String) {
    match import_text(text, opts) {
        Err(Error::Input {
            line,
            column,
            key,
            message,
            ..
        }) => (line, column, format!("{key}: {message}")),
        Err(e) => panic!("not located: {e}"),
        Ok(_) => panic!("accepted: {text}"),
    }
}

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><rfilter type="box"/></film></sensor>"#;

#[test]
fn unknown_and_unsupported_things_are_located_errors() {
    let o = ImportOptions::default();
    let scene = |body: &str| format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>");
    let (l, c, m) = err_of(
        &scene("<shape type=\"sphere\">\n  <float name=\"radiuss\" value=\"1\"/>\n</shape>"),
        &o,
    );
    assert_eq!((l, c), (4, 3), "{m}");
    assert!(m.contains("unknown parameter \"radiuss\""), "{m}");
    let (l, _, m) = err_of(&scene("<shape type=\"teapot\"/>"), &o);
    assert!(l == 3 && m.contains("unknown shape \"teapot\""), "{m}");
    let (_, _, m) = err_of(
        &scene("<emitter type=\"spot\"><texture name=\"texture\" type=\"bitmap\"><string name=\"filename\" value=\"x.png\"/></texture></emitter>"),
        &o,
    );
    assert!(m.contains("projected texture"), "{m}");
    let (_, _, m) = err_of(
        &scene("<emitter type=\"spot\"><transform name=\"to_world\"><scale x=\"2\"/></transform></emitter>"),
        &o,
    );
    assert!(m.contains("similarity"), "{m}");
    let (_, _, m) = err_of(&scene("<shape type=\"sphere\"><bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"unobtainium\"/></bsdf></shape>"), &o);
    assert!(
        m.contains("unknown index of refraction") && m.contains("bk7"),
        "{m}"
    );
    let (_, _, m) = err_of(&scene("<shape type=\"sphere\"><ref id=\"nope\"/></shape>"), &o);
    assert!(m.contains("no object with id \"nope\""), "{m}");
    let (_, _, m) = err_of(
        &scene("<shape type=\"sphere\"><transform name=\"to_world\"><scale x=\"2\"/></transform></shape>"),
        &o,
    );
    assert!(m.contains("uniform scales"), "{m}");
    let (l, c, m) = err_of(
        "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n</scene>",
        &o,
    );
    assert!(l == 3 && c > 0 && m.contains("XML"), "{l}:{c} {m}");
    let (_, _, m) = err_of(&scene("<integer name=\"x\" value=\"$missing\"/>"), &o);
    assert!(m.contains("-D missing=VALUE"), "{m}");
    // --lenient skips the unknown parameter with a warning.
    let lenient = ImportOptions {
        lenient: true,
        ..Default::default()
    };
    let imp = import_text(
        &scene("<shape type=\"sphere\"><float name=\"radiuss\" value=\"1\"/></shape>"),
        &lenient,
    )
    .unwrap();
    assert_eq!(imp.warnings.len(), 1, "{:?}", imp.warnings);
    assert!(imp.warnings[0].message.contains("radiuss"), "{:?}", imp.warnings);
}

/// Mitsuba's `spot`: at `to_world`'s origin, along its +z, with the cone's
/// angles and Mitsuba's defaults (20°, beam 3/4 of it); it survives
/// `convert`'s TOML and builds.
#[test]
fn spot_emitters_map_to_spot_lights() {
    use snell::scene::desc::LightDesc;
    let text = format!(
        "<scene version=\"3.0.0\">\n{SENSOR}\n\
         <emitter type=\"spot\" id=\"key\"><transform name=\"to_world\"><lookat origin=\"1, 2, 3\" target=\"1, 0, 3\" up=\"0, 0, 1\"/></transform>\
         <rgb name=\"intensity\" value=\"5, 4, 3\"/><float name=\"cutoff_angle\" value=\"40\"/><float name=\"beam_width\" value=\"10\"/></emitter>\n\
         <emitter type=\"spot\"/>\n\
         <shape type=\"sphere\"/>\n</scene>"
    );
    let imp = import_text(&text, &ImportOptions::default()).unwrap();
    let spots: Vec<_> = imp
        .desc
        .lights
        .iter()
        .map(|l| match l {
            LightDesc::Spot(s) => s.clone(),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(spots.len(), 2);
    let s = &spots[0];
    assert_eq!(s.name.as_deref(), Some("key"));
    assert!((glam::DVec3::from(s.position) - glam::DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
    let d = glam::DVec3::from(s.direction.unwrap()).normalize();
    assert!((d - glam::DVec3::NEG_Y).length() < 1e-12, "{d}");
    assert_eq!(
        (s.intensity, s.cutoff_angle, s.beam_width),
        ([5.0, 4.0, 3.0], 40.0, Some(10.0))
    );
    let s = &spots[1];
    assert_eq!(
        (s.position, s.cutoff_angle, s.beam_width),
        ([0.0; 3], 20.0, Some(15.0))
    );
    assert_eq!(s.direction, Some([0.0, 0.0, 1.0]));
    let scene = build_xml(&text);
    assert_eq!(scene.lights.len(), 2);
    // A cone Mitsuba accepts and snell does not: located in the XML.
    let wide = text.replace("value=\"40\"", "value=\"100\"");
    let toml = to_toml(&import_text(&wide, &ImportOptions::default()).unwrap().desc).unwrap();
    let e = load_scene_str(
        "t.xml (imported)",
        &toml,
        Path::new("scenes"),
        &BuildOptions::default(),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("lights[0].cutoff_angle") && e.contains("(0, 90]"),
        "{e}"
    );
}

#[test]
fn defines_override_defaults() {
    let text = std::fs::read_to_string("scenes/three_spheres.xml").unwrap();
    let o = ImportOptions {
        defines: vec![("spp".into(), "3".into()), ("width".into(), "100".into())],
        ..Default::default()
    };
    let d = import_text(&text, &o).unwrap().desc;
    assert_eq!((d.film.spp, d.film.width, d.film.height), (3, 100, 480));
}

#[test]
fn build_errors_are_placed_in_the_xml() {
    // A zero-radius cylinder passes the importer and fails in the builder:
    // the error names the XML element's line, and the description's key.
    let dir = std::env::temp_dir().join(format!("snell-import-relocate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("bad.xml");
    std::fs::write(
        &f,
        format!("<scene version=\"3.0.0\">\n{SENSOR}\n<shape type=\"rectangle\">\n<transform name=\"to_world\"><scale x=\"1e300\"/></transform>\n</shape>\n</scene>"),
    )
    .unwrap();
    let e = match load_scene(&f, &BuildOptions::default()) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("accepted"),
    };
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        e.contains("bad.xml:3:1: <shape type=\"rectangle\">: objects[0]"),
        "{e}"
    );
}

/// `ply` and `serialized` shapes: snell reads the files itself; a shape
/// index past the file's shapes is an error placed at the XML element.
#[test]
fn ply_and_serialized_meshes_load_and_bad_indices_are_placed() {
    use snell::scene::import::serialized;
    use snell::scene::shapes::Mesh;
    let dir = std::env::temp_dir().join(format!("snell-import-meshes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let quad = Mesh {
        positions: vec![
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: None,
        uvs: None,
    };
    std::fs::write(dir.join("quad.serialized"), serialized::write_v4(&quad, "quad")).unwrap();
    std::fs::write(
        dir.join("quad.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n-1 -1 0\n1 -1 0\n1 1 0\n-1 1 0\n4 0 1 2 3\n",
    )
    .unwrap();
    let scene = |index: u32| {
        format!(
            "<scene version=\"3.0.0\">\n{SENSOR}\n<shape type=\"ply\"><string name=\"filename\" value=\"quad.ply\"/></shape>\n<shape type=\"serialized\">\n<string name=\"filename\" value=\"quad.serialized\"/>\n<integer name=\"shape_index\" value=\"{index}\"/>\n<transform name=\"to_world\"><translate z=\"-1\"/></transform>\n</shape>\n</scene>"
        )
    };
    let f = dir.join("meshes.xml");
    std::fs::write(&f, scene(0)).unwrap();
    let s = load_scene(&f, &BuildOptions::default()).unwrap();
    assert_eq!(s.geoms.len(), 2);
    std::fs::write(&f, scene(5)).unwrap();
    let e = load_scene(&f, &BuildOptions::default())
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        e.contains("meshes.xml:4:1: <shape type=\"serialized\">: objects[1].shape.shape_index")
            && e.contains("out of range"),
        "{e}"
    );
}

/// A scene of one sphere with `bsdf` (XML), imported.
fn sphere_with(bsdf: &str) -> snell::Result<snell::scene::import::Imported> {
    let xml = format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective"><transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film></sensor>
  <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
  <shape type="sphere">{bsdf}</shape>
</scene>"#
    );
    import_text(&xml, &ImportOptions::default())
}

#[test]
fn rough_metal_and_plastic_bsdfs_map_exactly_and_refuse_what_they_cannot() {
    let cases = [
        (
            r#"<bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/><float name="alpha" value="0.3"/></bsdf>"#,
            r#"RoughConductor(RoughConductorDesc { material: Some("Au"), eta: None, k: None, specular_reflectance: [1.0, 1.0, 1.0], two_sided: false, distribution: Ggx, alpha: 0.3 })"#,
        ),
        (
            r#"<bsdf type="twosided"><bsdf type="conductor"><rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9, 2.4, 2.2"/></bsdf></bsdf>"#,
            r#"Conductor(ConductorDesc { material: None, eta: Some([0.2, 0.9, 1.1]), k: Some([3.9, 2.4, 2.2]), specular_reflectance: [1.0, 1.0, 1.0], two_sided: true })"#,
        ),
        (
            r#"<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/><boolean name="nonlinear" value="true"/></bsdf>"#,
            r#"Plastic(PlasticDesc { diffuse_reflectance: [0.1, 0.2, 0.3], specular_reflectance: [1.0, 1.0, 1.0], int_ior: 1.49, ext_ior: 1.000277, nonlinear: true, two_sided: false })"#,
        ),
        (
            r#"<bsdf type="roughplastic"><float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.2"/></bsdf>"#,
            r#"RoughPlastic(RoughPlasticDesc { diffuse_reflectance: [0.5, 0.5, 0.5], specular_reflectance: [1.0, 1.0, 1.0], int_ior: 1.49, ext_ior: 1.000277, nonlinear: false, two_sided: false, distribution: Beckmann, alpha: 0.2 })"#,
        ),
    ];
    for (bsdf, want) in cases {
        let imp = sphere_with(bsdf).unwrap();
        let dbg = format!("{:?}", imp.desc.objects[0].material);
        assert_eq!(dbg, want, "{bsdf}");
        assert!(imp.warnings.is_empty(), "{bsdf}: {:?}", imp.warnings);
        // The TOML written back builds.
        let toml = to_toml(&imp.desc).unwrap();
        load_scene_str("t.toml", &toml, Path::new("scenes"), &BuildOptions::default()).unwrap();
    }
    for (bsdf, want) in [
        (
            r#"<bsdf type="roughconductor"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/></bsdf>"#,
            "anisotropic",
        ),
        (
            r#"<bsdf type="roughdielectric"><texture type="bitmap" name="alpha"><string name="filename" value="a.png"/></texture></bsdf>"#,
            "textured alpha",
        ),
        (
            r#"<bsdf type="conductor"><string name="material" value="Xx"/></bsdf>"#,
            "unknown metal",
        ),
        (
            r#"<bsdf type="roughplastic"><string name="distribution" value="phong"/></bsdf>"#,
            "unknown distribution",
        ),
    ] {
        match sphere_with(bsdf) {
            Err(e) => assert!(e.to_string().contains(want), "{bsdf}: {e}"),
            Ok(_) => panic!("accepted: {bsdf}"),
        }
    }
}

/// The vertical field of view the importer gives a `perspective` sensor
/// with `params` on a `w` × `h` film.
fn imported_fov(w: u32, h: u32, params: &str) -> snell::Result<f64> {
    let xml = format!(
        r#"<scene version="3.0.0"><sensor type="perspective">{params}<film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/><rfilter type="box"/></film></sensor></scene>"#
    );
    Ok(import_text(&xml, &ImportOptions::default())?
        .desc
        .camera
        .fov
        .unwrap_or(f64::NAN))
}

/// What a sensor's field is, written out from Mitsuba 3's `parse_fov`
/// (src/render/sensor.cpp) and `perspective_projection`
/// (include/mitsuba/render/sensor.h): the half-width tangent of the
/// image plane at unit distance, then the vertical field in degrees from
/// the film's aspect.
#[derive(Clone, Copy, Debug)]
enum Field<'a> {
    Fov(f64, &'a str),
    FocalMm(f64),
    Default,
}

fn mitsuba_vertical_fov(w: u32, h: u32, f: Field<'_>) -> f64 {
    let (w, h) = (w as f64, h as f64);
    let tan_half = |deg: f64| (deg.to_radians() / 2.0).tan();
    // Tangents of the half-angles across the film's width and height.
    let across_width = match f {
        Field::Fov(fov, "x") => tan_half(fov),
        Field::Fov(fov, "y") => tan_half(fov) * w / h,
        // The diagonal's half-tangent, shared out along the diagonal.
        Field::Fov(fov, "diagonal") => tan_half(fov) * w / w.hypot(h),
        // Mitsuba: "smaller" is y when the film is wider than tall, else x.
        Field::Fov(fov, "smaller") if w > h => tan_half(fov) * w / h,
        Field::Fov(fov, "smaller") => tan_half(fov),
        Field::Fov(fov, "larger") if w > h => tan_half(fov),
        Field::Fov(fov, "larger") => tan_half(fov) * w / h,
        Field::Fov(_, other) => panic!("{other}"),
        // The 35 mm frame's diagonal (36 × 24 mm) over twice the focal length.
        Field::FocalMm(mm) => 36f64.hypot(24.0) / (2.0 * mm) * w / w.hypot(h),
        Field::Default => 36f64.hypot(24.0) / 100.0 * w / w.hypot(h),
    };
    2.0 * (across_width * h / w).atan().to_degrees()
}

/// A `perspective` sensor maps as Mitsuba 3's: every `fov_axis`, a
/// `focal_length`, and no field at all (Mitsuba's 50 mm, 34.02° across a
/// square film), on square, wide and tall films. Known wrong: the 90° the
/// importer used to default to, and a diagonal field read as a horizontal one.
#[test]
fn perspective_fields_of_view_map_as_mitsubas() {
    let films = [(512, 512), (640, 480), (300, 700), (1920, 800)];
    let mut cases: Vec<(String, Field<'_>)> = Vec::new();
    for axis in ["x", "y", "diagonal", "smaller", "larger"] {
        for fov in [10.0, 40.0, 75.5, 120.0] {
            cases.push((
                format!(r#"<float name="fov" value="{fov}"/><string name="fov_axis" value="{axis}"/>"#),
                Field::Fov(fov, axis),
            ));
        }
    }
    cases.push((r#"<float name="fov" value="40"/>"#.into(), Field::Fov(40.0, "x")));
    // Mitsuba lower-cases the axis name.
    cases.push((
        r#"<float name="fov" value="40"/><string name="fov_axis" value="Diagonal"/>"#.into(),
        Field::Fov(40.0, "diagonal"),
    ));
    for (f, mm) in [("35mm", 35.0), ("50mm", 50.0), ("120", 120.0), ("17.5mm", 17.5)] {
        cases.push((
            format!(r#"<string name="focal_length" value="{f}"/>"#),
            Field::FocalMm(mm),
        ));
    }
    cases.push((String::new(), Field::Default));
    for (w, h) in films {
        for (params, field) in &cases {
            let got = imported_fov(w, h, params).unwrap();
            let want = mitsuba_vertical_fov(w, h, *field);
            assert!(
                (got - want).abs() < 1e-9,
                "{w}x{h} {params}: imported {got}, Mitsuba {want}"
            );
        }
        // Known wrong: no field as 90° across the width; a diagonal as x.
        let none = imported_fov(w, h, "").unwrap();
        let ninety = mitsuba_vertical_fov(w, h, Field::Fov(90.0, "x"));
        assert!((none - ninety).abs() > 1.0, "{w}x{h}: {none} vs {ninety}");
        let diag = imported_fov(
            w,
            h,
            r#"<float name="fov" value="40"/><string name="fov_axis" value="diagonal"/>"#,
        )
        .unwrap();
        let as_x = mitsuba_vertical_fov(w, h, Field::Fov(40.0, "x"));
        assert!((diag - as_x).abs() > 1.0, "{w}x{h}: {diag} vs {as_x}");
    }
    // Mitsuba's default across a square film: 34.02° horizontally.
    let square = imported_fov(512, 512, "").unwrap();
    assert!((square - 34.02).abs() < 0.005, "{square}");
    // A fov_axis without a fov is unused (Mitsuba refuses unused
    // parameters); both fov and focal_length is an error; a bad axis names itself.
    for (params, want) in [
        (r#"<string name="fov_axis" value="y"/>"#, "fov_axis"),
        (
            r#"<float name="fov" value="40"/><string name="focal_length" value="50mm"/>"#,
            "not both",
        ),
        (
            r#"<float name="fov" value="40"/><string name="fov_axis" value="z"/>"#,
            "fov_axis \"z\"",
        ),
        (r#"<string name="focal_length" value="wide"/>"#, "focal length"),
        (r#"<string name="focal_length" value="-5mm"/>"#, "focal length"),
    ] {
        match imported_fov(640, 480, params) {
            Err(e) => assert!(e.to_string().contains(want), "{params}: {e}"),
            Ok(f) => panic!("accepted {params}: {f}"),
        }
    }
}

/// A `w` × `h` map of values that differ from texel to texel (row 0 on top).
fn envmap_texels(w: usize, h: usize) -> Vec<[f64; 3]> {
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    (0..w * h)
        .map(|_| {
            [0, 1, 2].map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                0.1 + (s >> 40) as f64 / (1u64 << 24) as f64
            })
        })
        .collect()
}

/// Rotation by `deg` degrees about `axis` (Rodrigues), rows of the matrix.
fn rotation(axis: [f64; 3], deg: f64) -> [[f64; 3]; 3] {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let [x, y, z] = axis.map(|a| a / n);
    let (s, c) = deg.to_radians().sin_cos();
    let t = 1.0 - c;
    [
        [c + t * x * x, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, c + t * y * y, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, c + t * z * z],
    ]
}

/// How a map is looked up, for the known-wrong variants.
#[derive(Clone, Copy, PartialEq)]
enum EnvLookup {
    /// Mitsuba 3's own.
    Mitsuba,
    /// Mitsuba's turned half a turn about +y (no turn when importing).
    NoTurn,
    /// Rows at pixel centres (v·H − 0.5) instead of on the poles.
    RowCentres,
}

/// The radiance Mitsuba 3's `envmap` (src/emitters/envmap.cpp) gives a ray
/// along world direction `d`: the map-space direction is to_world⁻¹·d, u =
/// atan2(x, −z)/2π and v = acos(y)/π; bilinear over texels at u·W − 0.5
/// (wrapping around) and v·(H − 1) (row 0 on the upper pole, row H − 1 on
/// the lower).
fn mitsuba_envmap(
    px: &[[f64; 3]],
    (w, h): (usize, usize),
    to_world: &[[f64; 3]; 3],
    scale: f64,
    d: [f64; 3],
    how: EnvLookup,
) -> [f64; 3] {
    let local: [f64; 3] = [0, 1, 2].map(|i| (0..3).map(|k| to_world[k][i] * d[k]).sum::<f64>());
    let n = local.iter().map(|c| c * c).sum::<f64>().sqrt();
    let l = local.map(|c| c / n);
    let mut u = l[0].atan2(-l[2]) / std::f64::consts::TAU;
    if how == EnvLookup::NoTurn {
        u += 0.5;
    }
    let v = l[1].clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
    let x = (u - u.floor()) * w as f64 - 0.5;
    let (y, y0) = if how == EnvLookup::RowCentres {
        let y = v * h as f64 - 0.5;
        (y, y.floor())
    } else {
        let y = v * (h - 1) as f64;
        (y, y.floor().min((h - 2) as f64))
    };
    let x0 = x.floor();
    let (fx, fy) = (x - x0, y - y0);
    let at = |xi: f64, yi: f64| {
        let xi = (xi as i64).rem_euclid(w as i64) as usize;
        let yi = (yi as i64).clamp(0, h as i64 - 1) as usize;
        px[yi * w + xi]
    };
    let (a, b, c, e) = (
        at(x0, y0),
        at(x0 + 1.0, y0),
        at(x0, y0 + 1.0),
        at(x0 + 1.0, y0 + 1.0),
    );
    [0, 1, 2].map(|k| {
        let top = (1.0 - fx) * a[k] + fx * b[k];
        let bottom = (1.0 - fx) * c[k] + fx * e[k];
        scale * ((1.0 - fy) * top + fy * bottom)
    })
}

/// Directions spread over the sphere (none exactly on a pole).
fn spread_directions(n: usize) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - (i as f64 + 0.5) / n as f64 * 2.0;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f64;
            [r * phi.cos(), y, r * phi.sin()]
        })
        .collect()
}

/// Mitsuba's `envmap`, with and without `to_world`, imports so that every
/// direction reads the value Mitsuba's formula gives (the 180° turn about
/// +y between the two lat-long conventions and Mitsuba's rows on the
/// poles); known wrong: the lookup without the turn, and rows at pixel
/// centres.
#[test]
fn envmaps_look_up_what_mitsuba_looks_up() {
    let dir = std::env::temp_dir().join(format!("snell-import-envmap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (16usize, 8usize);
    let texels = envmap_texels(w, h);
    let v3: Vec<glam::Vec3A> = texels
        .iter()
        .map(|t| glam::Vec3A::new(t[0] as f32, t[1] as f32, t[2] as f32))
        .collect();
    std::fs::write(
        dir.join("sky.exr"),
        snell::image_io::encode_exr(w as u32, h as u32, &v3, &[], &[]).unwrap(),
    )
    .unwrap();
    // The texels as stored (f32).
    let px: Vec<[f64; 3]> = v3.iter().map(|p| [p.x as f64, p.y as f64, p.z as f64]).collect();
    let ident = rotation([0.0, 1.0, 0.0], 0.0);
    let cases = [
        ("", ident),
        (
            r#"<transform name="to_world"><rotate x="0.3" y="1" z="-0.4" angle="37"/></transform>"#,
            rotation([0.3, 1.0, -0.4], 37.0),
        ),
        (
            r#"<transform name="to_world"><rotate y="1" angle="180"/></transform>"#,
            rotation([0.0, 1.0, 0.0], 180.0),
        ),
        (
            r#"<transform name="to_world"><rotate x="1" angle="-90"/><translate x="5"/></transform>"#,
            rotation([1.0, 0.0, 0.0], -90.0),
        ),
    ];
    let dirs = spread_directions(400);
    for (xf, m) in cases {
        let xml = format!(
            r#"<scene version="3.0.0">
{SENSOR}
<emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="1.5"/>{xf}</emitter>
<shape type="sphere"/>
</scene>"#
        );
        let imp = mitsuba::import_str("t.xml", &xml, &dir, &ImportOptions::default()).unwrap();
        assert!(
            imp.warnings.iter().all(|w| !w.message.contains("orientation")),
            "{:?}",
            imp.warnings
        );
        let toml = to_toml(&imp.desc).unwrap();
        let scene = load_scene_str("t.xml (imported)", &toml, &dir, &BuildOptions::default()).unwrap();
        let worst = |how: EnvLookup| {
            dirs.iter()
                .map(|d| {
                    let got = scene
                        .environment
                        .eval(glam::Vec3A::new(d[0] as f32, d[1] as f32, d[2] as f32));
                    let want = mitsuba_envmap(&px, (w, h), &m, 1.5, *d, how);
                    (0..3)
                        .map(|k| (got[k] as f64 - want[k]).abs())
                        .fold(0.0, f64::max)
                })
                .fold(0.0, f64::max)
        };
        let good = worst(EnvLookup::Mitsuba);
        assert!(good < 1e-4, "{xf}: {good}\n{toml}");
        let no_turn = worst(EnvLookup::NoTurn);
        let centres = worst(EnvLookup::RowCentres);
        eprintln!(
            "envmap {xf:?}: worst difference {good:.1e}; no turn {no_turn:.2}, rows at centres {centres:.2}"
        );
        assert!(
            no_turn > 0.1 && centres > 0.05,
            "{xf}: no power ({no_turn}, {centres})"
        );
    }
    // Scales, skews and mirrors have no counterpart: refused at the emitter.
    for xf in [
        r#"<scale value="2"/>"#,
        r#"<scale x="-1"/>"#,
        r#"<matrix value="1 0.5 0 0  0 1 0 0  0 0 1 0  0 0 0 1"/>"#,
    ] {
        let xml = format!(
            "<scene version=\"3.0.0\">\n{SENSOR}\n<emitter type=\"envmap\"><string name=\"filename\" value=\"sky.exr\"/><transform name=\"to_world\">{xf}</transform></emitter>\n</scene>"
        );
        match mitsuba::import_str("t.xml", &xml, &dir, &ImportOptions::default()) {
            Err(Error::Input { line, message, .. }) => {
                assert_eq!(line, 3, "{message}");
                assert!(message.contains("rotation"), "{xf}: {message}");
            }
            r => panic!("{xf}: {:?}", r.map(|_| ())),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A JPEG texture loads from snell's TOML and from a Mitsuba `bitmap`,
/// and its texels are the decoded JPEG's (8-bit sRGB, decoded to linear).
#[test]
fn jpeg_textures_load_in_toml_and_xml() {
    use snell::scene::model::Material;
    use snell::scene::texture::Texture;
    let dir = std::env::temp_dir().join(format!("snell-import-jpeg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (12u32, 6u32);
    let img = image::RgbImage::from_fn(w, h, |x, y| {
        image::Rgb([(x * 20) as u8, (y * 40) as u8, ((x + y) * 9) as u8])
    });
    let jpg = dir.join("wood.jpg");
    img.save(&jpg).unwrap();
    // What the file decodes to, from the image crate's own decoder, in linear RGB.
    let decoded = image::open(&jpg).unwrap().to_rgb8();
    let lin = |c: u8| {
        let c = c as f64 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let want: Vec<[f64; 3]> = decoded
        .pixels()
        .map(|p| [lin(p[0]), lin(p[1]), lin(p[2])])
        .collect();
    std::fs::write(
        dir.join("quad.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    )
    .unwrap();
    let toml = "[camera]\nposition = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\n[film]\nwidth = 16\nheight = 16\n\
         [[objects]]\nshape = { type = \"mesh\", file = \"quad.obj\" }\n\
         material = { type = \"diffuse\", reflectance = { type = \"image\", file = \"wood.jpg\" } }\n";
    let from_toml = load_scene_str("t.toml", toml, &dir, &BuildOptions::default()).unwrap();
    let xml = format!(
        r#"<scene version="3.0.0">
{SENSOR}
<shape type="obj"><string name="filename" value="quad.obj"/>
  <bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="wood.jpg"/></texture></bsdf>
</shape>
</scene>"#
    );
    let imp = mitsuba::import_str("t.xml", &xml, &dir, &ImportOptions::default()).unwrap();
    let from_xml = load_scene_str(
        "t.xml (imported)",
        &to_toml(&imp.desc).unwrap(),
        &dir,
        &BuildOptions::default(),
    )
    .unwrap();
    for (what, scene) in [("toml", &from_toml), ("xml", &from_xml)] {
        let image = match &scene.geoms[0].material {
            Material::Diffuse {
                reflectance: Texture::Image { image, .. },
                ..
            } => image.clone(),
            other => panic!("{what}: {other:?}"),
        };
        assert_eq!((image.width, image.height), (w as usize, h as usize), "{what}");
        for (i, (got, want)) in image.pixels.iter().zip(&want).enumerate() {
            for k in 0..3 {
                assert!(
                    (got[k] as f64 - want[k]).abs() < 1e-6,
                    "{what}: texel {i} channel {k}: {} vs {}",
                    got[k],
                    want[k]
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Mitsuba 3's `orthographic` sensor (src/sensors/orthographic.cpp,
/// `orthographic_projection` in include/mitsuba/render/sensor.h): a film
/// sample (u, v) in [0, 1]² starts its ray at the camera-space point
/// ((1 − 2u), (1 − 2v) / aspect, near_clip) through to_world, along
/// to_world's +z. The built camera's rays start at the same points for
/// film points all over; scale, `near_clip` and a 2:1 film included. Bad
/// sensors are refused.
#[test]
fn an_orthographic_sensor_starts_its_rays_where_mitsuba_does() {
    let xml = |inner: &str| {
        format!(
            r#"<scene version="3.0.0"><sensor type="orthographic">{inner}<film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="32"/><rfilter type="box"/></film></sensor><shape type="sphere"><point name="center" x="0" y="1" z="-5"/><bsdf type="diffuse"/></shape></scene>"#
        )
    };
    let good = xml(
        r#"<float name="near_clip" value="0.5"/><transform name="to_world"><scale x="2" y="3" z="2"/><lookat origin="1, 1, 10" target="1, 1, 0" up="0, 1, 0"/></transform>"#,
    );
    let imp = import_text(&good, &ImportOptions::default()).unwrap();
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    let c = &imp.desc.camera;
    assert_eq!(c.kind, "orthographic");
    // 2·sx wide, 2·sy / aspect high; the near plane 0.5 · sz along the view.
    assert_eq!((c.fov, c.size), (None, Some([4.0, 3.0])));
    assert_eq!(c.position, [1.0, 1.0, 9.0]);
    let s = build_xml(&good);
    // Mitsuba's ray for sample (u, v), written out: lookat's frame is
    // left = up × dir = −x, up = +y, dir = −z here.
    let mitsuba = |u: f64, v: f64| {
        let aspect = 2.0;
        let local = glam::DVec3::new(1.0 - 2.0 * u, (1.0 - 2.0 * v) / aspect, 0.5);
        let scaled = local * glam::DVec3::new(2.0, 3.0, 2.0);
        glam::DVec3::new(1.0, 1.0, 10.0) + glam::DVec3::new(-scaled.x, scaled.y, -scaled.z)
    };
    for (u, v) in [(0.0, 0.0), (1.0, 1.0), (0.25, 0.8), (0.6, 0.1), (0.5, 0.5)] {
        let (o, d) = s.camera.ray(u as f32 * 64.0, v as f32 * 32.0, (0.0, 0.0));
        let want = mitsuba(u, v);
        assert!(
            (o.as_dvec3() - want).length() < 1e-5,
            "({u}, {v}): snell {o}, Mitsuba {want}"
        );
        assert_eq!(d.to_array(), [0.0, 0.0, -1.0]);
    }

    let refused = [
        (
            r#"<transform name="to_world"><scale x="-1" y="1"/></transform>"#,
            "mirror",
        ),
        (
            r#"<transform name="to_world"><matrix value="1 0.5 0 0  0 1 0 0  0 0 1 0  0 0 0 1"/></transform>"#,
            "skew",
        ),
        (
            r#"<float name="near_clip" value="20"/><float name="far_clip" value="10"/>"#,
            "near_clip",
        ),
        (r#"<float name="fov" value="30"/>"#, "fov"),
    ];
    for (inner, words) in refused {
        match import_text(&xml(inner), &ImportOptions::default()) {
            Err(e) => assert!(e.to_string().contains(words), "{inner}: {e}"),
            Ok(_) => panic!("accepted: {inner}"),
        }
    }
    // A far clip snell does not apply is said.
    let far = import_text(
        &xml(r#"<float name="far_clip" value="50"/>"#),
        &ImportOptions::default(),
    )
    .unwrap();
    assert!(
        far.warnings.iter().any(|w| w.to_string().contains("far_clip")),
        "{:?}",
        far.warnings
    );
}
