//! Section 4: the warp's frame pipeline against the exact trace, over vertex
//! counts and film sizes.
use super::figure::{plot, series, Picture, ReportDir, Section, Table};
use super::sizes::Sizes;
use super::ReportOptions;
use crate::error::{Error, Result};
use crate::timing;
use crate::warp_render::pipeline::Pipeline;
use crate::warp_render::{build_originals, compare, grid_scene, render_exact, Frame};
use glam::Vec3A as V3;

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
        frame_s: timing::median(&ft),
        exact_s: timing::median(&et),
        px_mean: cmp.px_mean,
        px_p95: cmp.px_p95,
        last: (frame, exact, heat),
    })
}

/// 4. Warp vs exact trace; returns the section and the tube's pictures for section 5.
pub(super) fn warp(
    o: &ReportOptions,
    z: &Sizes,
    out: &ReportDir,
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
