//! `snell report -o DIR [--quick]`: run the measurements and write
//! `DIR/index.html` (plots as inline SVG, images as PNG files beside it) and
//! `DIR/figures.json` (every number plotted, with provenance). Five sections:
//! path-tracer convergence, nested strategies, gradient-index media, warp,
//! pictures side by side. Everything is measured in this one run.
mod page;

use crate::audit::audit_scene;
use crate::bench::{self, NestedBenchOptions, NESTED_SCENES, REFERENCE_SCENES};
use crate::dielectric::NestedStrategy;
use crate::error::{Error, Result};
use crate::image_io::{encode_png, write_atomic};
use crate::integrator::Tracer;
use crate::media::grin_trace::{trace, Query};
use crate::media::{IndexField, Method};
use crate::render::{render, RenderOptions, RenderSettings, Rendered};
use crate::scene::{load_scene, BuildOptions, RenderScene};
use crate::warp_render::pipeline::Pipeline;
use crate::warp_render::{build_originals, compare, grid_scene, render_exact, Frame};
use glam::{DVec3, Vec3A as V3};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One curve of a plot; `spread` (optional) is a [low, high] bar per point.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Series {
    /// Legend entry.
    pub name: String,
    /// `[x, y]` in the plot's units, in drawing order.
    pub points: Vec<[f64; 2]>,
    /// `[low, high]` per point (e.g. fastest..slowest repetition), drawn as a bar.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spread: Option<Vec<[f64; 2]>>,
}

/// A plot: every number it draws is in its series.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Plot {
    /// Key of the plot in figures.json and its anchor in the page.
    pub id: String,
    /// Caption drawn above the plot.
    pub title: String,
    /// Label of the x axis, with its unit.
    pub x: String,
    /// Label of the y axis, with its unit.
    pub y: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The curves (empty ones are dropped).
    pub series: Vec<Series>,
}

/// An image written beside the page.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Picture {
    /// File name of the PNG, relative to the report directory.
    pub file: String,
    /// Caption under the image.
    pub caption: String,
}

/// A table shown under a section's plots.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Table {
    /// Column titles.
    pub header: Vec<String>,
    /// Cells, already formatted, one `Vec` per row.
    pub rows: Vec<Vec<String>>,
}

/// One section of the report.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Section {
    /// Key of the section in figures.json (`convergence`, `nested`, …).
    pub key: String,
    /// Heading in the page.
    pub title: String,
    /// One-line findings, shown at the top of the section.
    pub summary: Vec<String>,
    /// The section's plots, in page order.
    pub plots: Vec<Plot>,
    /// The section's images, in page order.
    pub pictures: Vec<Picture>,
    /// An optional table under the plots.
    pub table: Option<Table>,
}

/// Options of `snell report`.
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// The report directory (`-o DIR`): created if missing; index.html,
    /// figures.json and the PNG files are written there.
    pub out: PathBuf,
    /// `--quick`: small images and few repetitions (seconds instead of minutes).
    pub quick: bool,
    /// Directory of the scene files the report renders (the repository's `scenes/`).
    pub scenes_dir: PathBuf,
}

/// Sizes of one run (quick or full).
struct Sizes {
    conv: (u32, u32, &'static [u32], u32),
    nested_reps: usize,
    nested_grid: (u32, u32),
    nested_render: (u32, u32, u32),
    audit_rays: u64,
    grin_full: bool,
    chord: [(&'static str, u32, u32, &'static [f64]); 3],
    warp_film: (u32, u32),
    warp_vertices: &'static [usize],
    warp_films: &'static [(u32, u32)],
    warp_sweep_vertices: usize,
    warp_reps: usize,
    pictures: (u32, u32, u32),
}

const QUICK: Sizes = Sizes {
    conv: (64, 48, &[4, 8, 16, 32, 64], 512),
    nested_reps: 3,
    nested_grid: (24, 18),
    nested_render: (48, 36, 2),
    audit_rays: 2_000,
    grin_full: false,
    chord: [
        ("mirage_road", 64, 24, &[1.0, 0.1, 0.01, 0.001]),
        ("mirage_sea", 64, 32, &[3.0, 0.3, 0.03, 0.003]),
        ("heat_shimmer", 32, 24, &[0.01, 0.003, 0.001, 0.0003]),
    ],
    warp_film: (96, 72),
    warp_vertices: &[1_000, 4_000],
    warp_films: &[(64, 48), (128, 96)],
    warp_sweep_vertices: 2_000,
    warp_reps: 1,
    pictures: (64, 48, 4),
};

const FULL: Sizes = Sizes {
    conv: (192, 144, &[4, 8, 16, 32, 64, 128, 256], 2048),
    nested_reps: 5,
    nested_grid: (160, 120),
    nested_render: (160, 120, 8),
    audit_rays: 100_000,
    grin_full: true,
    chord: [
        (
            "mirage_road",
            240,
            80,
            &[1.0, 0.3, 0.1, 0.03, 0.01, 0.003, 0.0003],
        ),
        ("mirage_sea", 240, 120, &[3.0, 0.3, 0.03, 0.003, 0.0003]),
        ("heat_shimmer", 120, 90, &[0.01, 0.003, 0.001, 0.0003, 0.0001]),
    ],
    warp_film: (640, 480),
    warp_vertices: &[25_000, 50_000, 100_000, 200_000],
    warp_films: &[(320, 240), (640, 480), (1024, 768)],
    warp_sweep_vertices: 100_000,
    warp_reps: 3,
    pictures: (320, 240, 64),
};

fn series(name: impl Into<String>, points: Vec<[f64; 2]>) -> Series {
    Series {
        name: name.into(),
        points,
        spread: None,
    }
}

fn plot(id: &str, title: &str, x: &str, y: &str, log: (bool, bool), series: Vec<Series>) -> Plot {
    Plot {
        id: id.into(),
        title: title.into(),
        x: x.into(),
        y: y.into(),
        log_x: log.0,
        log_y: log.1,
        series: series.into_iter().filter(|s| !s.points.is_empty()).collect(),
    }
}

/// Root-mean-square difference of two images over pixels and channels, and
/// the same over the means of `k`×`k` blocks (partial blocks at the edges dropped).
pub fn image_errors(a: &[V3], b: &[V3], w: u32, h: u32, k: u32) -> (f64, f64) {
    let n = a.len().min(b.len()).max(1) as f64;
    let se: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| (*p - *q).length_squared() as f64)
        .sum();
    let (bw, bh) = ((w / k).max(1), (h / k).max(1));
    let k = k.min(w).min(h).max(1);
    let mut sums = vec![[0f64; 3]; (bw * bh) as usize];
    for y in 0..bh * k {
        for x in 0..bw * k {
            let i = (y * w + x) as usize;
            let d = a[i] - b[i];
            let cell = &mut sums[((y / k) * bw + x / k) as usize];
            for (c, s) in cell.iter_mut().enumerate() {
                *s += d[c] as f64;
            }
        }
    }
    let kk = (k * k) as f64;
    let bse: f64 = sums
        .iter()
        .flat_map(|c| c.iter())
        .map(|s| (s / kk) * (s / kk))
        .sum();
    ((se / (3.0 * n)).sqrt(), (bse / (3.0 * sums.len() as f64)).sqrt())
}

/// Least-squares slope of log10(y) against log10(x).
fn loglog_slope(points: &[[f64; 2]]) -> f64 {
    let p: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p[0] > 0.0 && p[1] > 0.0)
        .map(|p| (p[0].log10(), p[1].log10()))
        .collect();
    let n = p.len() as f64;
    let (mx, my) = (
        p.iter().map(|q| q.0).sum::<f64>() / n,
        p.iter().map(|q| q.1).sum::<f64>() / n,
    );
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    let sxx: f64 = p.iter().map(|q| (q.0 - mx) * (q.0 - mx)).sum();
    sxy / sxx
}

/// UTC date and time (seconds) without a date crate.
fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// The report being written: its directory and its pictures.
struct Out {
    dir: PathBuf,
}

impl Out {
    fn png(&self, name: &str, w: u32, h: u32, px: &[V3], caption: String) -> Result<Picture> {
        write_atomic(&self.dir.join(name), &encode_png(w, h, px)?)?;
        Ok(Picture {
            file: name.into(),
            caption,
        })
    }
}

fn quiet() -> RenderOptions {
    RenderOptions {
        threads: None,
        want_aovs: false,
        ..Default::default()
    }
}

fn scene_at(
    dir: &Path,
    name: &str,
    w: u32,
    h: u32,
    spp: u32,
    seed: u64,
) -> Result<(RenderScene, RenderSettings)> {
    let s = load_scene(&dir.join(format!("{name}.toml")), &BuildOptions::default())?;
    let set = RenderSettings::from_scene(&s)
        .with_resolution(w, h)?
        .with_spp(spp)
        .with_seed(seed);
    Ok((s, set))
}

/// Render scene `name` of `dir` at `w`×`h`, `spp`, `seed`.
fn render_at(dir: &Path, name: &str, w: u32, h: u32, spp: u32, seed: u64) -> Result<Rendered> {
    let (s, set) = scene_at(dir, name, w, h, spp, seed)?;
    render(&s, &set, &quiet())
}

/// 1. Error against a high-spp reference vs wall time, per reference scene.
fn convergence(o: &ReportOptions, z: &Sizes, log: &mut dyn FnMut(&str)) -> Result<Section> {
    let (w, h, spps, ref_spp) = z.conv;
    let (mut block, mut pixel, mut speed) = (vec![], vec![], vec![]);
    let mut summary = vec![];
    let mut rows = vec![];
    for name in REFERENCE_SCENES {
        let reference = render_at(&o.scenes_dir, name, w, h, ref_spp, 7_777)?;
        log(&format!(
            "convergence: {name} reference {ref_spp} spp in {:.1} s",
            reference.stats.wall_s
        ));
        let (mut bp, mut pp) = (vec![], vec![]);
        let mut last: Option<Rendered> = None;
        for &spp in spps {
            let r = render_at(&o.scenes_dir, name, w, h, spp, 1)?;
            let (e_px, e_blk) = image_errors(&r.pixels, &reference.pixels, w, h, 16);
            bp.push([r.stats.wall_s, e_blk]);
            pp.push([r.stats.wall_s, e_px]);
            rows.push(vec![
                name.to_string(),
                spp.to_string(),
                format!("{:.3}", r.stats.wall_s),
                format!("{e_px:.4}"),
                format!("{e_blk:.4}"),
                format!("{:.0}", r.stats.counters.samples as f64 / r.stats.wall_s),
                format!("{:.2}", r.stats.counters.rays() as f64 / r.stats.wall_s / 1e6),
            ]);
            last = Some(r);
        }
        let (sp, sb) = (loglog_slope(&pp), loglog_slope(&bp));
        if let Some(r) = last {
            let (sps, rps) = (
                r.stats.counters.samples as f64 / r.stats.wall_s,
                r.stats.counters.rays() as f64 / r.stats.wall_s,
            );
            speed.push([sps, rps]);
            summary.push(format!(
                "{name}: slope of per-pixel RMSE vs time {sp:.2} (block-mean RMSE {sb:.2}; -0.5 is unbiased Monte Carlo); {:.0} samples/s, {:.2} Mrays/s at {} spp",
                sps,
                rps / 1e6,
                spps.last().copied().unwrap_or(0)
            ));
        }
        pixel.push(series(name, pp));
        block.push(series(name, bp));
    }
    let top = f64::from(spps.last().copied().unwrap_or(1));
    summary.push(format!(
        "{w}x{h}, spp {spps:?}; reference {ref_spp} spp with another seed (its own noise inflates the error at {top} spp by {:.0}%)",
        100.0 * ((1.0 + top / f64::from(ref_spp)).sqrt() - 1.0)
    ));
    Ok(Section {
        key: "convergence".into(),
        title: "Path tracer convergence".into(),
        summary,
        plots: vec![
            plot(
                "conv_pixel",
                "Per-pixel RMSE vs wall time",
                "wall time (s)",
                "RMSE (linear RGB)",
                (true, true),
                pixel,
            ),
            plot(
                "conv_block",
                "RMSE of 16x16 block means vs wall time",
                "wall time (s)",
                "block RMSE",
                (true, true),
                block,
            ),
        ],
        pictures: vec![],
        table: Some(Table {
            header: [
                "scene",
                "spp",
                "wall s",
                "pixel RMSE",
                "block RMSE",
                "samples/s",
                "Mrays/s",
            ]
            .map(String::from)
            .to_vec(),
            rows,
        }),
    })
}

/// 2. Nested strategies: trace and render time, false hits, audit.
fn nested(o: &ReportOptions, z: &Sizes, log: &mut dyn FnMut(&str)) -> Result<Section> {
    let runs = bench::nested(
        &NestedBenchOptions {
            scenes_dir: o.scenes_dir.clone(),
            reps: z.nested_reps,
            trace_grid: z.nested_grid,
            // One pass per repetition: the report plots speeds, it does not
            // judge 1 % differences (and `--quick` runs in the tests).
            trace_rays_per_rep: 0,
            render: z.nested_render,
            threads: rayon::current_num_threads(),
            scenes: NESTED_SCENES.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        },
        |m| log(&format!("nested: {m}")),
    )?;
    let strategies = [
        NestedStrategy::Filter,
        NestedStrategy::Recast,
        NestedStrategy::Toggle,
        NestedStrategy::Off,
    ];
    let idx = |scene: &str| NESTED_SCENES.iter().position(|s| *s == scene).unwrap_or(0) as f64 + 1.0;
    let by = |mode: &str, st: &str, f: &dyn Fn(&bench::NestedRun) -> [f64; 2]| -> Vec<[f64; 2]> {
        runs.iter()
            .filter(|r| r.mode == mode && r.strategy == st)
            .map(f)
            .collect()
    };
    let mut plots = vec![];
    for mode in ["trace", "render"] {
        let s = strategies
            .iter()
            .map(|st| Series {
                name: st.name().into(),
                points: by(mode, st.name(), &|r| [idx(&r.scene), r.wall_s]),
                spread: Some(by(mode, st.name(), &|r| r.spread_s)),
            })
            .collect();
        plots.push(plot(
            &format!("nested_{mode}"),
            &format!("{mode} time per scene (median, bar = fastest..slowest)"),
            "scene (1..5, see the table)",
            "seconds",
            (false, true),
            s,
        ));
    }
    let fh = strategies
        .iter()
        .map(|st| {
            series(
                st.name(),
                by("trace", st.name(), &|r| [idx(&r.scene), r.false_hits_per_ray]),
            )
        })
        .collect();
    plots.push(plot(
        "nested_false_hits",
        "False hits per ray (trace rays)",
        "scene",
        "false hits / ray",
        (false, false),
        fh,
    ));
    let audited = [
        NestedStrategy::Filter,
        NestedStrategy::Recast,
        NestedStrategy::Toggle,
    ];
    let mut wrong = vec![vec![]; audited.len()];
    let mut rows = vec![];
    for name in NESTED_SCENES {
        let mut row = vec![format!("{} {name}", idx(name))];
        for st in strategies {
            let get = |mode: &str| {
                runs.iter()
                    .find(|r| r.scene == name && r.mode == mode && r.strategy == st.name())
            };
            if let (Some(t), Some(r)) = (get("trace"), get("render")) {
                row.push(format!(
                    "{:.4} [{:.4}..{:.4}] / {:.3} [{:.3}..{:.3}]",
                    t.wall_s, t.spread_s[0], t.spread_s[1], r.wall_s, r.spread_s[0], r.spread_s[1]
                ));
            }
        }
        for (k, &st) in audited.iter().enumerate() {
            let s = load_scene(
                &o.scenes_dir.join(format!("{name}.toml")),
                &BuildOptions::default(),
            )?;
            let tr = Tracer::new(&s).with_strategy(st);
            let a = audit_scene(tr, z.audit_rays, 1)?;
            wrong[k].push([idx(name), a.wrong_rays as f64]);
            row.push(a.wrong_rays.to_string());
        }
        log(&format!("nested: audited {name}"));
        rows.push(row);
    }
    plots.push(plot(
        "nested_audit",
        &format!("Audit: wrong rays of {} per strategy", z.audit_rays),
        "scene",
        "wrong rays",
        (false, false),
        audited
            .iter()
            .zip(wrong)
            .map(|(s, p)| series(s.name(), p))
            .collect(),
    ));
    let mut summary = vec![];
    for name in NESTED_SCENES {
        let t = |st: &str, mode: &str| {
            runs.iter()
                .find(|r| r.scene == name && r.mode == mode && r.strategy == st)
                .map(|r| (r.wall_s, r.false_hits_per_ray))
                .unwrap_or((f64::NAN, f64::NAN))
        };
        summary.push(format!(
            "{name}: trace recast/filter {:.2}x, toggle/filter {:.2}x, filter/off {:.2}x; render recast/filter {:.2}x; {:.3} false hits/ray",
            t("recast", "trace").0 / t("filter", "trace").0,
            t("toggle", "trace").0 / t("filter", "trace").0,
            t("filter", "trace").0 / t("off", "trace").0,
            t("recast", "render").0 / t("filter", "render").0,
            t("filter", "trace").1
        ));
    }
    let (rw, rh, rspp) = z.nested_render;
    summary.push(format!(
        "median of {} interleaved repetitions; trace rays from a {}x{} grid of refraction paths; renders {rw}x{rh} at {rspp} spp",
        z.nested_reps, z.nested_grid.0, z.nested_grid.1
    ));
    let mut header = vec!["scene".to_string()];
    header.extend(
        strategies
            .iter()
            .map(|s| format!("{} trace s / render s", s.name())),
    );
    header.extend(audited.iter().map(|s| format!("{} wrong rays", s.name())));
    Ok(Section {
        key: "nested".into(),
        title: "Nested strategies".into(),
        summary,
        plots,
        pictures: vec![],
        table: Some(Table { header, rows }),
    })
}

/// 3. Gradient-index media: method accuracy vs evaluations; chord tolerance vs image error.
fn grin(o: &ReportOptions, z: &Sizes, log: &mut dyn FnMut(&str)) -> Result<Section> {
    let deg = |a: f64| DVec3::new(a.to_radians().cos(), a.to_radians().sin(), 0.0);
    let cases = [
        (
            "linear n = 1 + 0.01 h, 10 deg up, 100 m",
            IndexField::Linear {
                n0: 1.0,
                m: 0.01,
                up: DVec3::Y,
                base: 0.0,
            },
            DVec3::ZERO,
            deg(10.0),
            100.0,
        ),
        (
            "hot ground (inferior mirage), 1.5 m, 0.5 deg down, 400 m",
            IndexField::HotGround {
                n_inf: 1.000_293,
                dn: 1e-4,
                h0: 0.3,
                up: DVec3::Y,
                base: 0.0,
            },
            DVec3::new(0.0, 1.5, 0.0),
            deg(-0.5),
            400.0,
        ),
    ];
    let tols: &[f64] = if z.grin_full {
        &[1e-4, 1e-6, 1e-8, 1e-10, 1e-12]
    } else {
        &[1e-4, 1e-6, 1e-8]
    };
    let steps: &[f64] = if z.grin_full {
        &[10.0, 3.0, 1.0, 0.3, 0.1, 0.03]
    } else {
        &[10.0, 1.0, 0.1]
    };
    let paper_steps: &[f64] = if z.grin_full {
        &[0.1, 0.01, 0.001]
    } else {
        &[0.1, 0.01]
    };
    let mut plots = vec![];
    let mut summary = vec![];
    for (k, (title, field, p, d, len)) in cases.iter().enumerate() {
        let linear = matches!(field, IndexField::Linear { .. });
        let (rm, rt) = if linear {
            (Method::Exact, 1.0)
        } else {
            (Method::Rk45, 1e-13)
        };
        let reference = trace(&Query::along(field, *p, *d, *len, rm, rt, 1.0))
            .map_err(|e| Error::Invalid(format!("report: grin reference: {e}")))?
            .end
            .ok_or_else(|| Error::Invalid("report: grin reference has no end".into()))?;
        let mut settings: Vec<(Method, f64, f64)> = tols.iter().map(|&t| (Method::Rk45, t, 1.0)).collect();
        settings.extend(steps.iter().map(|&h| (Method::Rk4, 1.0, h)));
        for m in [Method::Slab, Method::Length, Method::Euler, Method::PaperRk4] {
            settings.extend(paper_steps.iter().map(|&h| (m, 1.0, h)));
        }
        if linear {
            settings.push((Method::Exact, 1.0, 1.0));
        }
        let mut curves: Vec<Series> = vec![];
        for (m, tol, h) in settings {
            // A method that fails at a setting (a paper method at a turning
            // point) has no point there.
            let Ok(a) = trace(&Query::along(field, *p, *d, *len, m, tol, h)) else {
                continue;
            };
            let Some(end) = a.end else { continue };
            // Floor at 1e-16: the closed form matches itself exactly.
            let err = ((end - reference).length() / len).max(1e-16);
            let pt = [(a.evaluations as f64).max(1.0), err];
            match curves.iter_mut().find(|c| c.name == m.name()) {
                Some(c) => c.points.push(pt),
                None => curves.push(series(m.name(), vec![pt])),
            }
        }
        let best = |name: &str| {
            curves
                .iter()
                .find(|c| c.name == name)
                .and_then(|c| c.points.iter().map(|p| p[1]).min_by(f64::total_cmp))
                .map_or_else(|| "failed".to_string(), |e| format!("{e:.1e}"))
        };
        summary.push(format!(
            "{title}: best relative end-point error rk45 {}, rk4 {}, paper methods slab {} / length {} / euler {} / paper_rk4 {} (reference {}; failed = no setting reached the end)",
            best("rk45"),
            best("rk4"),
            best("slab"),
            best("length"),
            best("euler"),
            best("paper_rk4"),
            if linear { "closed form" } else { "rk45 at 1e-13" }
        ));
        plots.push(plot(
            &format!("grin_accuracy_{k}"),
            title,
            "gradient evaluations",
            "relative end-point error",
            (true, true),
            curves,
        ));
    }
    log("grin: accuracy done");
    let (mut err, mut time, mut rows) = (vec![], vec![], vec![]);
    for (name, w, h, tols) in z.chord {
        let (mut s, set) = scene_at(&o.scenes_dir, name, w, h, 1, 1)?;
        let runs = bench::chord_sweep(&mut s, &set, tols, None)?;
        let fine = runs.last().map(|r| r.wall_s).unwrap_or(1.0);
        err.push(series(name, runs.iter().map(|r| [r.tolerance, r.rmse]).collect()));
        time.push(series(
            name,
            runs.iter().map(|r| [r.tolerance, r.wall_s]).collect(),
        ));
        for r in &runs {
            rows.push(vec![
                name.to_string(),
                format!("{}", r.tolerance),
                format!("{:.3}", r.wall_s),
                format!("{:.2}", r.wall_s / fine),
                format!("{:.1}", r.chords_per_segment),
                format!("{:.4}", r.rmse),
                format!("{:.2}%", 100.0 * r.changed),
            ]);
        }
        if let (Some(c), Some(f)) = (runs.first(), runs.last()) {
            summary.push(format!(
                "{name} ({w}x{h}, 1 spp): chord tolerance {} m gives RMSE {:.2e} against {} m in {:.2}x its time ({:.1} vs {:.1} chords per segment)",
                c.tolerance,
                c.rmse,
                f.tolerance,
                c.wall_s / f.wall_s,
                c.chords_per_segment,
                f.chords_per_segment
            ));
        }
        log(&format!("grin: chord sweep {name}"));
    }
    plots.push(plot(
        "grin_chord_error",
        "Chord tolerance vs image RMSE (against the finest)",
        "chord tolerance (m)",
        "RMSE (linear RGB)",
        (true, false),
        err,
    ));
    plots.push(plot(
        "grin_chord_time",
        "Chord tolerance vs render time",
        "chord tolerance (m)",
        "wall time (s)",
        (true, true),
        time,
    ));
    Ok(Section {
        key: "grin".into(),
        title: "Gradient-index media".into(),
        summary,
        plots,
        pictures: vec![],
        table: Some(Table {
            header: [
                "scene",
                "tolerance m",
                "wall s",
                "time / finest",
                "chords/segment",
                "RMSE",
                "changed px",
            ]
            .map(String::from)
            .to_vec(),
            rows,
        }),
    })
}

/// One warp measurement: the frame pipeline and the exact trace, compared.
struct WarpRow {
    vertices: usize,
    pixels: f64,
    frame_s: f64,
    exact_s: f64,
    px_mean: f64,
    px_p95: f64,
    last: (Frame, Frame, Vec<V3>),
}

fn warp_row(path: &str, w: u32, h: u32, vertices: usize, reps: usize) -> Result<WarpRow> {
    let (scene, prep) = grid_scene(path, w, h, vertices)?;
    let spec = scene
        .warp
        .clone()
        .ok_or_else(|| Error::Invalid(format!("{path}: not a [warp] scene")))?;
    let orig = build_originals(&scene, &prep)?;
    let (mut ft, mut et, mut last) = (vec![], vec![], None);
    for _ in 0..reps.max(1) {
        let mut pipe = Pipeline::new(&scene, &spec, &prep, false)?;
        let f = pipe.warp(&scene)?;
        let frame = pipe.render(&scene, &spec, &prep);
        ft.push(f.warp_s + f.build_s + frame.render_s);
        let exact = render_exact(&scene, &spec, &prep, &orig);
        et.push(exact.render_s);
        last = Some((frame, exact));
    }
    let (frame, exact) = last.ok_or_else(|| Error::Invalid("warp: no repetition".into()))?;
    let (cmp, heat) = compare(&scene, &frame, &exact);
    Ok(WarpRow {
        vertices: prep.vertices,
        pixels: f64::from(w * h),
        frame_s: crate::timing::median(&ft),
        exact_s: crate::timing::median(&et),
        px_mean: cmp.px_mean,
        px_p95: cmp.px_p95,
        last: (frame, exact, heat),
    })
}

/// 4. Warp vs exact trace; returns the section and the tube's pictures for section 5.
fn warp(
    o: &ReportOptions,
    z: &Sizes,
    out: &Out,
    log: &mut dyn FnMut(&str),
) -> Result<(Section, Vec<Picture>)> {
    let (mut t_v, mut e_v, mut t_r, mut e_r, mut rows, mut pics, mut pics5) =
        (vec![], vec![], vec![], vec![], vec![], vec![], vec![]);
    let mut summary = vec![];
    for (name, file) in [("plate", "warp_plate"), ("tube", "warp_cylinder")] {
        let path = o.scenes_dir.join(format!("{file}.toml")).display().to_string();
        let (w, h) = z.warp_film;
        let mut vs = vec![];
        for &v in z.warp_vertices {
            vs.push(warp_row(&path, w, h, v, z.warp_reps)?);
        }
        let mut rs = vec![];
        for &(fw, fh) in z.warp_films {
            rs.push(warp_row(&path, fw, fh, z.warp_sweep_vertices, z.warp_reps)?);
        }
        log(&format!("warp: {name} sweeps done"));
        let pts = |rows: &[WarpRow],
                   x: &dyn Fn(&WarpRow) -> f64,
                   y: &dyn Fn(&WarpRow) -> f64|
         -> Vec<[f64; 2]> { rows.iter().map(|r| [x(r), y(r)]).collect() };
        let vx = |r: &WarpRow| r.vertices as f64;
        let px = |r: &WarpRow| r.pixels;
        t_v.push(series(
            format!("{name} warp frame"),
            pts(&vs, &vx, &|r| r.frame_s),
        ));
        t_v.push(series(
            format!("{name} exact trace"),
            pts(&vs, &vx, &|r| r.exact_s),
        ));
        e_v.push(series(format!("{name} mean"), pts(&vs, &vx, &|r| r.px_mean)));
        e_v.push(series(format!("{name} p95"), pts(&vs, &vx, &|r| r.px_p95)));
        t_r.push(series(
            format!("{name} warp frame"),
            pts(&rs, &px, &|r| r.frame_s),
        ));
        t_r.push(series(
            format!("{name} exact trace"),
            pts(&rs, &px, &|r| r.exact_s),
        ));
        e_r.push(series(format!("{name} mean"), pts(&rs, &px, &|r| r.px_mean)));
        e_r.push(series(format!("{name} p95"), pts(&rs, &px, &|r| r.px_p95)));
        for (sweep, list) in [("vertices", &vs), ("resolution", &rs)] {
            for r in list.iter() {
                rows.push(vec![
                    name.to_string(),
                    sweep.to_string(),
                    r.vertices.to_string(),
                    format!("{}x{}", r.last.0.width, r.last.0.height),
                    format!("{:.4}", r.frame_s),
                    format!("{:.4}", r.exact_s),
                    format!("{:.2}x", r.exact_s / r.frame_s),
                    format!("{:.3}", r.px_mean),
                    format!("{:.3}", r.px_p95),
                ]);
            }
        }
        if let Some(r) = rs.last() {
            summary.push(format!(
                "{name} at {}x{}, {} vertices: warp frame {:.4} s vs exact trace {:.4} s ({:.2}x), position error mean {:.3} px, p95 {:.3} px",
                r.last.0.width,
                r.last.0.height,
                r.vertices,
                r.frame_s,
                r.exact_s,
                r.exact_s / r.frame_s,
                r.px_mean,
                r.px_p95
            ));
            let (f, e, heat) = &r.last;
            let (w, h) = (f.width, f.height);
            pics.push(out.png(
                &format!("warp_{name}_heat.png"),
                w,
                h,
                heat,
                format!("{name}: position error of the warp (black 0, red 1 px, yellow >= 2 px, magenta: different objects)"),
            )?);
            pics5.push(out.png(
                &format!("warp_{name}_warp.png"),
                w,
                h,
                &f.pixels,
                format!("{name}: warp frame"),
            )?);
            pics5.push(out.png(
                &format!("warp_{name}_exact.png"),
                w,
                h,
                &e.pixels,
                format!("{name}: exact trace"),
            )?);
        }
    }
    let (w, h) = z.warp_film;
    let plots = vec![
        plot(
            "warp_time_vertices",
            &format!("Time per frame vs vertices ({w}x{h})"),
            "vertices",
            "seconds",
            (true, true),
            t_v,
        ),
        plot(
            "warp_error_vertices",
            &format!("Warp position error vs vertices ({w}x{h})"),
            "vertices",
            "pixels",
            (true, false),
            e_v,
        ),
        plot(
            "warp_time_resolution",
            &format!("Time per frame vs pixels ({} vertices)", z.warp_sweep_vertices),
            "pixels",
            "seconds",
            (true, true),
            t_r,
        ),
        plot(
            "warp_error_resolution",
            &format!(
                "Warp position error vs pixels ({} vertices)",
                z.warp_sweep_vertices
            ),
            "pixels",
            "pixels of error",
            (true, false),
            e_r,
        ),
    ];
    summary.push(format!(
        "warp frame = vertex warp + copies + primary rays in packets; exact = single-ray exact trace; median of {}",
        z.warp_reps
    ));
    Ok((
        Section {
            key: "warp".into(),
            title: "Warp vs exact trace".into(),
            summary,
            plots,
            pictures: pics,
            table: Some(Table {
                header: [
                    "scene",
                    "sweep",
                    "vertices",
                    "film",
                    "warp frame s",
                    "exact s",
                    "speed-up",
                    "px mean",
                    "px p95",
                ]
                .map(String::from)
                .to_vec(),
                rows,
            }),
        },
        pics5,
    ))
}

/// 5. Pictures side by side, with differences (|a - b| × 4).
fn pictures(
    o: &ReportOptions,
    z: &Sizes,
    out: &Out,
    warp_pics: Vec<Picture>,
    log: &mut dyn FnMut(&str),
) -> Result<Section> {
    let (w, h, spp) = z.pictures;
    let pairs = [
        (
            "nested_spheres_a",
            "nested_spheres_b",
            spp,
            "Fig. 1 in both priority orders",
        ),
        (
            "glass_of_water_nested",
            "glass_of_water",
            spp,
            "nested vs interface glass of water",
        ),
        (
            "mirage_road",
            "mirage_road_nofield",
            spp.min(16),
            "inferior mirage vs no field",
        ),
        (
            "mirage_sea",
            "mirage_sea_nofield",
            spp.min(16),
            "superior mirage vs no field",
        ),
        (
            "heat_shimmer",
            "heat_shimmer_nofield",
            spp.min(16),
            "heat shimmer vs no field",
        ),
    ];
    let (mut pics, mut summary, mut plot_pts) = (vec![], vec![], vec![]);
    for (k, (a, b, spp, what)) in pairs.into_iter().enumerate() {
        let ra = render_at(&o.scenes_dir, a, w, h, spp, 1)?;
        // b and a second a with another seed: the a-b difference is judged
        // against the a-a' difference (pure noise), block means of 16x16.
        let rb = render_at(&o.scenes_dir, b, w, h, spp, 2)?;
        let ra2 = render_at(&o.scenes_dir, a, w, h, spp, 2)?;
        let noise = image_errors(&ra.pixels, &ra2.pixels, w, h, 16).1;
        let diff: Vec<V3> = ra
            .pixels
            .iter()
            .zip(&rb.pixels)
            .map(|(p, q)| (*p - *q).abs() * 4.0)
            .collect();
        let (e_px, e_blk) = image_errors(&ra.pixels, &rb.pixels, w, h, 16);
        pics.push(out.png(&format!("{a}.png"), w, h, &ra.pixels, format!("{a} ({spp} spp)"))?);
        pics.push(out.png(&format!("{b}.png"), w, h, &rb.pixels, format!("{b} ({spp} spp)"))?);
        pics.push(out.png(
            &format!("diff_{a}_{b}.png"),
            w,
            h,
            &diff,
            format!("|{a} - {b}| x 4: RMSE {e_px:.4}, 16x16 block RMSE {e_blk:.4}"),
        )?);
        summary.push(format!(
            "{what}: RMSE {e_px:.3e}, block-mean RMSE {e_blk:.3e} = {:.2}x the block-mean RMSE of {a} against itself with another seed ({noise:.3e}; about 1 = noise only) ({w}x{h}, {spp} spp)",
            e_blk / noise
        ));
        let x = k as f64 + 1.0;
        plot_pts.push(([x, e_px], [x, e_blk], [x, noise]));
        log(&format!("pictures: {a} / {b}"));
    }
    pics.extend(warp_pics);
    summary
        .push("warp frames beside their exact traces are at the end (see section 4 for their error)".into());
    Ok(Section {
        key: "pictures".into(),
        title: "Pictures side by side".into(),
        summary,
        plots: vec![plot(
            "pictures_difference",
            "Difference of each pair (1 Fig. 1 a/b, 2 water, 3 road, 4 sea, 5 shimmer)",
            "pair",
            "RMSE (linear RGB)",
            (false, false),
            vec![
                series("per pixel", plot_pts.iter().map(|p| p.0).collect()),
                series("16x16 block means", plot_pts.iter().map(|p| p.1).collect()),
                series(
                    "block means, same scene, two seeds",
                    plot_pts.iter().map(|p| p.2).collect(),
                ),
            ],
        )],
        pictures: pics,
        table: None,
    })
}

/// Run every measurement and write the report; returns the path of index.html.
///
/// `command` is the command line shown in the page and in figures.json; `log`
/// receives one progress line per step, prefixed with the elapsed seconds.
///
/// # Errors
///
/// [`Error::Invalid`] when the report directory cannot be created or is not
/// writable (checked before any measurement), and any error of loading or
/// rendering a scene or writing a file.
pub fn run(o: &ReportOptions, command: &str, mut log: impl FnMut(&str)) -> Result<PathBuf> {
    std::fs::create_dir_all(&o.out)
        .map_err(|e| Error::io(&o.out, format!("cannot create the report directory: {e}")))?;
    // Fail now, not after the measurements, when DIR is not writable.
    write_atomic(&o.out.join(".snell-report-probe"), b"")
        .and_then(|()| {
            std::fs::remove_file(o.out.join(".snell-report-probe")).map_err(|e| Error::io(&o.out, e))
        })
        .map_err(|e| {
            Error::Invalid(format!(
                "report directory {} is not writable: {e}",
                o.out.display()
            ))
        })?;
    let z = if o.quick { &QUICK } else { &FULL };
    let out = Out { dir: o.out.clone() };
    let t0 = Instant::now();
    let mut log = |m: &str| log(&format!("[{:6.1} s] {m}", t0.elapsed().as_secs_f64()));
    let mut provenance = crate::provenance::json();
    if let Some(p) = provenance.as_object_mut() {
        p.insert("threads".into(), rayon::current_num_threads().into());
        p.insert("date".into(), utc_now().into());
        p.insert("mode".into(), if o.quick { "quick" } else { "full" }.into());
    }
    let mut sections = vec![
        convergence(o, z, &mut log)?,
        nested(o, z, &mut log)?,
        grin(o, z, &mut log)?,
    ];
    let (w, warp_pics) = warp(o, z, &out, &mut log)?;
    sections.push(w);
    sections.push(pictures(o, z, &out, warp_pics, &mut log)?);
    if let Some(p) = provenance.as_object_mut() {
        p.insert("wall_s".into(), t0.elapsed().as_secs_f64().into());
    }
    let mut map = serde_json::Map::new();
    for s in &sections {
        map.insert(
            s.key.clone(),
            serde_json::to_value(s).map_err(|e| Error::Invalid(e.to_string()))?,
        );
    }
    let figures = serde_json::json!({"provenance": provenance, "command": command, "sections": map});
    let text = serde_json::to_string_pretty(&figures).map_err(|e| Error::Invalid(e.to_string()))?;
    write_atomic(&o.out.join("figures.json"), text.as_bytes())?;
    let index = o.out.join("index.html");
    write_atomic(&index, page::html(&provenance, command, &sections)?.as_bytes())?;
    log("done");
    Ok(index)
}
