//! `snell report --quick` end to end: every plot has series with finite
//! points, every image exists and decodes as a PNG, figures.json has the five
//! sections; an unwritable directory is a clear error.
use std::path::Path;
use std::process::Command;

fn snell() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_snell"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

#[test]
fn quick_report_is_complete() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report_quick");
    let _ = std::fs::remove_dir_all(&dir);
    let t = std::time::Instant::now();
    let out = snell()
        .args(["report", "--quick", "-o"])
        .arg(&dir)
        .output()
        .unwrap();
    let secs = t.elapsed().as_secs_f64();
    assert!(
        out.status.success(),
        "snell report failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("snell report --quick: {secs:.1} s");
    assert!(secs < 180.0, "--quick took {secs:.1} s (limit 3 minutes)");

    let figures: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("figures.json")).unwrap()).unwrap();
    for key in ["commit", "embree_version", "machine", "threads", "date"] {
        assert!(!figures["provenance"][key].is_null(), "provenance lacks {key}");
    }
    let sections = figures["sections"].as_object().expect("sections object");
    let mut keys: Vec<&str> = sections.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(keys, ["convergence", "grin", "nested", "pictures", "warp"]);

    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let (mut plots, mut images) = (0, 0);
    for (key, s) in sections {
        let ps = s["plots"].as_array().unwrap();
        assert!(!ps.is_empty(), "section {key} has no plots");
        assert!(
            !s["summary"].as_array().unwrap().is_empty(),
            "section {key} has no summary"
        );
        for p in ps {
            let id = p["id"].as_str().unwrap();
            let series = p["series"].as_array().unwrap();
            assert!(!series.is_empty(), "plot {id} has no series");
            for se in series {
                let pts = se["points"].as_array().unwrap();
                assert!(!pts.is_empty(), "plot {id}, series {} is empty", se["name"]);
                for pt in pts {
                    let xy: Vec<f64> = pt
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(|v| v.as_f64().unwrap_or(f64::NAN))
                        .collect();
                    assert!(
                        xy.len() == 2 && xy.iter().all(|v| v.is_finite()),
                        "plot {id}, series {}: point {pt} is not finite",
                        se["name"]
                    );
                }
            }
            assert!(
                html.contains(&format!("<figure id=\"{id}\"><svg")),
                "plot {id} not inlined as SVG"
            );
            plots += 1;
        }
        for pic in s["pictures"].as_array().unwrap() {
            let file = pic["file"].as_str().unwrap();
            let img = image::open(dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
            assert!(img.width() > 0 && img.height() > 0);
            assert!(
                html.contains(&format!("src=\"{file}\"")),
                "{file} not on the page"
            );
            images += 1;
        }
    }
    assert_eq!(html.matches("<svg").count(), plots, "one inline SVG per plot");
    // Fig. 1 a/b with their difference, the glass pair, three mirage pairs, warp vs exact.
    assert!(images >= 15 + 4 + 2, "only {images} images");
    assert!(!dir.join(".snell-report-probe").exists());
}

#[test]
fn unwritable_directory_is_a_clear_error() {
    let base = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report_not_a_dir");
    std::fs::write(&base, "a file").unwrap();
    let out = snell()
        .args(["report", "--quick", "-o"])
        .arg(base.join("sub"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("report directory") && err.contains("report_not_a_dir"),
        "{err}"
    );
}
