//! Section 2: the nested strategies' trace and render times, false hits and
//! audit.
use super::figure::{plot, series, Section, Series, Table};
use super::sizes::Sizes;
use super::ReportOptions;
use crate::audit::audit_scene;
use crate::bench::{self, NestedBenchOptions, NESTED_SCENES};
use crate::dielectric::NestedStrategy;
use crate::error::Result;
use crate::integrator::Tracer;
use crate::scene::{load_scene, BuildOptions};

/// 2. Nested strategies: trace and render time, false hits, audit.
pub(super) fn nested(o: &ReportOptions, z: &Sizes, log: &mut dyn FnMut(&str)) -> Result<Section> {
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
