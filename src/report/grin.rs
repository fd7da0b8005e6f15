//! Section 3: gradient-index media, the integrators' accuracy against their
//! evaluations and the chord tolerance against image error and time.
use super::figure::{plot, series, Section, Series, Table};
use super::scenes::scene_at;
use super::sizes::Sizes;
use super::ReportOptions;
use crate::bench;
use crate::error::{Error, Result};
use crate::media::grin_trace::{trace, Query};
use crate::media::{IndexField, Method};
use glam::DVec3;

/// 3. Gradient-index media: method accuracy vs evaluations; chord tolerance vs image error.
pub(super) fn grin(o: &ReportOptions, z: &Sizes, log: &mut dyn FnMut(&str)) -> Result<Section> {
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
            "hot ground, inferior mirage: 1.5 m, 0.5 deg down, 400 m",
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
