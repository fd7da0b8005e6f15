//! Beyond one machine (docs/farm.md): regions x sample ranges merge into the
//! single render bit for bit, a Ctrl-C partial resumes into the uninterrupted
//! render, merge refuses parts that do not fit, `--set` errors are located,
//! and the Open Job Description templates run under `openjd` and reproduce
//! `snell render`.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SCENE: &str = "scenes/glass_of_water_nested.toml";
/// Film of the split tests: small, and spp 7 so sample ranges are uneven.
const FILM: [&str; 6] = ["--width", "40", "--height", "30", "--spp", "7"];

fn snell() -> Command {
    Command::new(env!("CARGO_BIN_EXE_snell"))
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("snell-farm-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ok(out: Output) -> Output {
    assert!(
        out.status.success(),
        "snell failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn fails(out: Output) -> String {
    assert_eq!(out.status.code(), Some(1), "expected an error");
    let e = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!e.contains("panicked"), "{e}");
    e
}

fn render(out: &Path, extra: &[&str]) -> Output {
    render_film(out, &FILM, extra)
}

fn render_film(out: &Path, film: &[&str], extra: &[&str]) -> Output {
    snell()
        .args(["render", SCENE, "-o"])
        .arg(out)
        .args(film)
        .args(["--threads", "2", "--quiet"])
        .args(extra)
        .output()
        .unwrap()
}

/// RGB of an EXR as bits (bit-for-bit comparisons).
fn rgb_bits(p: &Path) -> (usize, usize, Vec<[u32; 3]>) {
    let img = snell::scene::texture::load_image(p).unwrap();
    let bits = img
        .pixels
        .iter()
        .map(|c| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()])
        .collect();
    (img.width, img.height, bits)
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// Render a 3x2 grid of regions (explicit pixel bounds) x 3 uneven sample
/// ranges into `dir/parts`; returns the part paths.
fn split_render(dir: &Path) -> Vec<PathBuf> {
    let parts = dir.join("parts");
    std::fs::create_dir_all(&parts).unwrap();
    let mut out = Vec::new();
    for (x0, x1) in [(0, 13), (13, 27), (27, 40)] {
        for (y0, y1) in [(0, 16), (16, 30)] {
            for range in ["0:1", "1:4", "5:2"] {
                let p = parts.join(format!("p_{x0}_{y0}_{}.exr", range.replace(':', "_")));
                let region = format!("{x0},{x1},{y0},{y1}");
                let stats = p.with_extension("json");
                let stats = stats.to_str().unwrap();
                ok(render(
                    &p,
                    &["--region", &region, "--samples", range, "--stats-json", stats],
                ));
                out.push(p);
            }
        }
    }
    out
}

#[test]
fn regions_times_sample_ranges_merge_bit_for_bit() {
    let d = tmpdir("split");
    let full = d.join("full.exr");
    let full_stats = d.join("full.json");
    ok(render(&full, &["--stats-json", full_stats.to_str().unwrap()]));
    let parts = split_render(&d);
    // A region's part is the full render's pixels there (data window = region).
    let one = snell::part::read_part(&parts[0]).unwrap();
    assert_eq!(one.meta.region.to_string(), "0,13,0,16");
    assert_eq!((one.meta.sample_start, one.meta.sample_count), (0, 1));
    assert!(one.accum.counts.iter().all(|&c| c == 1));

    // A stale partial in the directory (an interrupted task, since retried) is not a part of the merge.
    std::fs::copy(&parts[0], d.join("parts/stale.partial.exr")).unwrap();
    let merged = d.join("merged.exr");
    let png = d.join("merged.png");
    let mstats = d.join("merged.json");
    ok(snell()
        .args(["merge", "--quiet", "-o"])
        .arg(&merged)
        .arg(d.join("parts"))
        .arg("--png")
        .arg(&png)
        .arg("--stats-json")
        .arg(&mstats)
        .output()
        .unwrap());
    let (a, b) = (rgb_bits(&full), rgb_bits(&merged));
    assert_eq!((a.0, a.1), (40, 30));
    assert_eq!((b.0, b.1), (40, 30));
    let differing = a.2.iter().zip(&b.2).filter(|(x, y)| x != y).count();
    assert_eq!(
        differing, 0,
        "merged differs from the single render in {differing} pixels"
    );
    assert!(png.exists());
    // The split traced exactly the same rays: counters add up to the single render's.
    let (f, m) = (json(&full_stats), json(&mstats));
    for k in ["samples", "rays", "queries", "shadow_rays", "false_hits", "tir"] {
        assert_eq!(f[k], m[k], "{k}: single {} vs merged {}", f[k], m[k]);
    }
    assert_eq!(m["parts"], 18);
    assert_eq!(f["samples"], 40 * 30 * 7);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn merge_refuses_parts_that_do_not_fit() {
    let d = tmpdir("refuse");
    let p = |n: &str| d.join(n);
    ok(render(
        &p("a.exr"),
        &["--region", "0,20,0,30", "--samples", "0:7"],
    ));
    ok(render(
        &p("b.exr"),
        &["--region", "20,40,0,30", "--samples", "0:4"],
    ));
    ok(render(
        &p("c.exr"),
        &["--region", "20,40,0,30", "--samples", "3:4"],
    ));
    ok(render(
        &p("seed.exr"),
        &["--region", "20,40,0,30", "--samples", "4:3", "--seed", "9"],
    ));
    ok(render_film(
        &p("film.exr"),
        &["--width", "41", "--height", "30", "--spp", "7"],
        &["--region", "20,40,0,30", "--samples", "4:3"],
    ));
    ok(render(
        &p("scene.exr"),
        &[
            "--region",
            "20,40,0,30",
            "--samples",
            "4:3",
            "--set",
            "objects.water.material.ior=1.34",
        ],
    ));
    ok(render(&p("plain.exr"), &[]));
    let merge = |files: &[&str]| {
        let mut c = snell();
        c.args(["merge", "--quiet", "-o"]).arg(p("m.exr"));
        for f in files {
            c.arg(p(f));
        }
        fails(c.output().unwrap())
    };
    let e = merge(&["a.exr", "b.exr", "c.exr"]);
    assert!(e.contains("overlap") && e.contains("samples 3..4"), "{e}");
    let e = merge(&["a.exr", "b.exr"]);
    assert!(
        e.contains("lack samples") && e.contains("4..7") && e.contains("x 20..40"),
        "{e}"
    );
    let e = merge(&["a.exr"]);
    assert!(e.contains("600 of 1200 pixels") && e.contains("0..7"), "{e}");
    let e = merge(&["a.exr", "b.exr", "seed.exr"]);
    assert!(e.contains("different seeds"), "{e}");
    let e = merge(&["a.exr", "b.exr", "film.exr"]);
    assert!(
        e.contains("different films") && e.contains("40x30 vs 41x30"),
        "{e}"
    );
    let e = merge(&["a.exr", "b.exr", "scene.exr"]);
    assert!(e.contains("different scenes"), "{e}");
    let e = merge(&["a.exr", "plain.exr"]);
    assert!(e.contains("not a snell part"), "{e}");
    let e = merge(&["a.exr", "missing.exr"]);
    assert!(e.contains("missing.exr"), "{e}");
    // The missing chunk completes the render.
    ok(render(
        &p("d.exr"),
        &["--region", "20,40,0,30", "--samples", "4:3"],
    ));
    ok(snell()
        .args(["merge", "--quiet", "-o"])
        .arg(p("m.exr"))
        .args([p("a.exr"), p("b.exr"), p("d.exr")])
        .output()
        .unwrap());
    assert_eq!(rgb_bits(&p("m.exr")), rgb_bits(&p("plain.exr")));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_farm_arguments_are_clear_errors() {
    let d = tmpdir("args");
    let o = d.join("x.exr");
    for (args, want) in [
        (vec!["--region", "0,50,0,10"], "outside the 40x30 film"),
        (vec!["--region", "1,2,3"], "expected x0,x1,y0,y1"),
        (vec!["--samples", "5:3"], "within the film's 7 samples"),
        (vec!["--samples", "2"], "expected START:COUNT"),
        (vec!["--sample-chunk", "4/3"], "1 <= I <= N"),
        (vec!["--region-cell", "1/2"], "IX/NX,IY/NY"),
        (vec!["--region-cell", "0/2,1/2"], "1 <= I <= N"),
        (vec!["--resume", "/nonexistent/p.exr"], "/nonexistent/p.exr"),
        (vec!["--region", "0,8,0,8", "--aov", "tir"], "not merged"),
    ] {
        let e = fails(render(&o, &args));
        assert!(e.contains(want), "{args:?}: {e}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn set_overrides_keys_and_locates_errors_like_the_file() {
    let d = tmpdir("set");
    let o = d.join("x.png");
    let small = ["--width", "8", "--height", "6", "--spp", "1"];
    let run = |set: &[&str]| {
        let mut c = snell();
        c.args(["render", SCENE, "-o"]).arg(&o).args(small).arg("--quiet");
        for s in set {
            c.args(["--set", s]);
        }
        c.output().unwrap()
    };
    ok(run(&[
        "objects.water.material.ior=1.34",
        "film.seed=3",
        "integrator.type=whitted",
    ]));
    // Unknown key: located at the key, with the keys that exist.
    let e = fails(run(&["film.sp=3"]));
    assert!(
        e.contains("--set 'film.sp=3':1:1: film.sp: unknown field `sp`"),
        "{e}"
    );
    assert!(e.contains("spp"), "{e}");
    let e = fails(run(&["objects.wter.material.ior=1.3"]));
    assert!(
        e.contains("--set 'objects.wter.material.ior=1.3':1:9:") && e.contains("water"),
        "{e}"
    );
    // Wrong type: located at the value.
    let e = fails(run(&["objects.water.material.ior=abc"]));
    assert!(
        e.contains("--set 'objects.water.material.ior=abc':1:28: objects[3].material") && e.contains("abc"),
        "{e}"
    );
    let e = fails(run(&["film.spp=many"]));
    assert!(
        e.contains("--set 'film.spp=many':1:10: film.spp: invalid type"),
        "{e}"
    );
    // Out of range: the builder's check, located at the value.
    let e = fails(run(&["objects.water.material.ior=-1"]));
    assert!(
        e.contains("--set 'objects.water.material.ior=-1':1:28: objects[3].material.ior"),
        "{e}"
    );
    let e = fails(run(&["camera.fov=400"]));
    assert!(e.contains("--set 'camera.fov=400':1:12: camera.fov"), "{e}");
    // Errors elsewhere in the file keep their file:line:col.
    let bad = d.join("bad.toml");
    std::fs::write(
        &bad,
        "[camera]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 400.0\n",
    )
    .unwrap();
    let e = fails(
        snell()
            .args(["render"])
            .arg(&bad)
            .arg("-o")
            .arg(&o)
            .args(["--set", "film.spp=2"])
            .output()
            .unwrap(),
    );
    assert!(e.contains("bad.toml:4:1: camera.fov"), "{e}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn ctrl_c_partial_resumes_into_the_uninterrupted_render() {
    let d = tmpdir("resume");
    let film = [
        "--width",
        "48",
        "--height",
        "32",
        "--spp",
        "4096",
        "--threads",
        "1",
        "--quiet",
    ];
    let out = d.join("r.exr");
    let mut child = snell()
        .args(["render", SCENE, "-o"])
        .arg(&out)
        .args(film)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1200));
    assert!(Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap()
        .success());
    assert!(child.wait().unwrap().success());
    let partial = d.join("r.partial.exr");
    assert!(
        partial.exists() && !out.exists(),
        "interrupted after 1.2 s of a render of several seconds"
    );
    let p = snell::part::read_part(&partial).unwrap();
    let done = p.accum.counts.iter().filter(|&&c| c == 4096).count();
    assert!(p.accum.counts.iter().all(|&c| c == 0 || c == 4096));
    assert!(done > 0 && done < 48 * 32, "{done} pixels done");
    // Resume: only the missing samples are rendered, and the result is the
    // uninterrupted render bit for bit.
    let stats = d.join("resumed.json");
    ok(snell()
        .args(["render", SCENE, "-o"])
        .arg(&out)
        .args(film)
        .arg("--resume")
        .arg(&partial)
        .arg("--stats-json")
        .arg(&stats)
        .output()
        .unwrap());
    assert_eq!(
        json(&stats)["samples"].as_u64().unwrap(),
        (48 * 32 - done as u64) * 4096,
        "the resumed render takes only the missing samples"
    );
    let whole = d.join("whole.exr");
    ok(snell()
        .args(["render", SCENE, "-o"])
        .arg(&whole)
        .args(film)
        .output()
        .unwrap());
    assert_eq!(rgb_bits(&out), rgb_bits(&whole));

    // A farm cancelling a task sends SIGTERM: the same partial; the retried
    // task (same command, --resume-partial) continues it and removes it.
    let task = d.join("task.exr");
    let run_task = || {
        snell()
            .args(["render", SCENE, "-o"])
            .arg(&task)
            .args(film)
            .arg("--resume-partial")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let mut child = run_task();
    std::thread::sleep(std::time::Duration::from_millis(1200));
    assert!(Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap()
        .success());
    assert!(child.wait().unwrap().success());
    let task_partial = d.join("task.partial.exr");
    assert!(task_partial.exists() && !task.exists());
    let retried = run_task().wait_with_output().unwrap();
    assert!(retried.status.success());
    assert!(String::from_utf8_lossy(&retried.stderr).is_empty(), "quiet");
    assert!(!task_partial.exists(), "the consumed partial is removed");
    assert_eq!(rgb_bits(&task), rgb_bits(&whole));
    // A partial of another scene is refused.
    let e = fails(
        snell()
            .args(["render", "scenes/three_spheres.toml", "-o"])
            .arg(d.join("x.exr"))
            .args(film)
            .arg("--resume")
            .arg(&partial)
            .output()
            .unwrap(),
    );
    assert!(e.contains("different scene"), "{e}");
    let _ = std::fs::remove_dir_all(&d);
}

/// openjd-cli from the venv `make openjd` (part of `make test`) creates.
fn openjd() -> Command {
    let venv = std::env::var_os("SNELL_OPENJD_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv"));
    let bin = venv.join("bin/openjd");
    assert!(
        bin.exists(),
        "openjd-cli is not installed at {}: run `make openjd` (or `make test`, which creates the venv and installs it)",
        bin.display()
    );
    Command::new(bin)
}

/// nested_spheres_a at 40x30 (no external files, so it can move).
fn small_scene(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string("scenes/nested_spheres_a.toml").unwrap();
    let text = text
        .replace("width = 640", "width = 40")
        .replace("height = 480", "height = 30");
    assert!(text.contains("width = 40"));
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn openjd_templates_check_and_the_still_job_reproduces_snell_render() {
    for t in ["jobs/still.yaml", "jobs/sweep.yaml"] {
        let out = openjd().args(["check", t]).output().unwrap();
        assert!(
            out.status.success(),
            "openjd check {t}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
    }
    let d = tmpdir("openjd");
    let scene = small_scene(&d);
    let outdir = d.join("out");
    let p = |k: &str, v: &dyn AsRef<std::ffi::OsStr>| {
        let mut s = std::ffi::OsString::from(format!("{k}="));
        s.push(v);
        s
    };
    let bin = env!("CARGO_BIN_EXE_snell");
    let out = openjd()
        .args(["run", "jobs/still.yaml"])
        .args([
            "-p".into(),
            p("Scene", &scene),
            "-p".into(),
            p("OutputDir", &outdir),
        ])
        .args([
            "-p",
            "Spp=6",
            "-p",
            "TilesX=2",
            "-p",
            "TilesY=2",
            "-p",
            "Chunks=3",
            "-p",
            "Threads=1",
        ])
        .args(["-p".into(), p("SnellCommand", &bin)])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "openjd run still.yaml failed:\n{log}");
    assert!(
        log.contains("openjd_progress: 100.0"),
        "tasks print progress:\n{log}"
    );
    let single = d.join("single.exr");
    ok(snell()
        .args(["render"])
        .arg(&scene)
        .arg("-o")
        .arg(&single)
        .args(["--spp", "6", "--quiet"])
        .output()
        .unwrap());
    assert_eq!(rgb_bits(&outdir.join("still.exr")), rgb_bits(&single));
    assert!(outdir.join("still.png").exists());
    let st = json(&outdir.join("still.stats.json"));
    assert_eq!(st["parts"], 12);
    assert_eq!(st["samples"], 40 * 30 * 6);
    assert!(
        outdir.join("parts/part_2_2_3.json").exists(),
        "stats beside each part"
    );

    let sweep = d.join("sweep");
    let out = openjd()
        .args(["run", "jobs/sweep.yaml"])
        .args([
            "-p".into(),
            p("Scene", &scene),
            "-p".into(),
            p("OutputDir", &sweep),
        ])
        .args([
            "-p",
            "Key=objects.left_red.material.ior",
            "-p",
            "Values=1.3,1.6",
            "-p",
            "Count=2",
        ])
        .args(["-p", "Spp=2", "-p", "Threads=1"])
        .args(["-p".into(), p("SnellCommand", &bin)])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "openjd run sweep.yaml failed:\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let table = std::fs::read_to_string(sweep.join("table.md")).unwrap();
    assert!(table.contains("| objects.left_red.material.ior |"), "{table}");
    assert!(
        table.contains("| sweep_1.json | 1.3 |") && table.contains("| sweep_2.json | 1.6 |"),
        "{table}"
    );
    assert!(sweep.join("sweep_2.png").exists());
    let _ = std::fs::remove_dir_all(&d);
}
