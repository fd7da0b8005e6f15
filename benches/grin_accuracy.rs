//! Gradient-index integrators: end-point error against the closed form (linear field)
//! or a tight rk45 reference (other fields), against cost (field evaluations, steps and
//! wall time as a ratio to rk45 at tolerance 1e-8 measured in the same run), so a user
//! can pick a point on the curve. Then the paper's percent-error table (its h and N)
//! beside the ray-equation methods at the same step counts.
//!
//! `cargo bench --bench grin_accuracy`
use std::time::Instant;

use glam::DVec3;
use snell::media::grin_trace::{trace, Query};
use snell::media::stepper::State;
use snell::media::{mirage_study, IndexField, Method};

/// (end, evaluations, steps, seconds per trace) or the failure message.
fn run(q: &Query) -> Result<(DVec3, u64, u64, f64), String> {
    let a = trace(q)?;
    let end = a.end.ok_or("no end")?;
    let t0 = Instant::now();
    let mut reps = 0u32;
    while reps < 3 || (t0.elapsed().as_secs_f64() < 0.05 && reps < 100_000) {
        std::hint::black_box(trace(std::hint::black_box(q))?);
        reps += 1;
    }
    let secs = t0.elapsed().as_secs_f64() / f64::from(reps);
    Ok((end, a.evaluations, a.steps, secs))
}

/// Evaluations needed for `target` error, interpolated log-log between the
/// two settings that bracket it (settings in any order).
fn evals_at(points: &[(f64, f64)], target: f64) -> Option<f64> {
    let mut p: Vec<(f64, f64)> = points.iter().copied().filter(|q| q.1 > 0.0).collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    p.windows(2).find_map(|w| {
        let ((e0, r0), (e1, r1)) = (w[0], w[1]);
        if (r0 - target) * (r1 - target) > 0.0 || r0 == r1 {
            return None;
        }
        let f = (target.ln() - r0.ln()) / (r1.ln() - r0.ln());
        Some((e0.ln() + f * (e1.ln() - e0.ln())).exp())
    })
}

/// A log-log plot (relative end-point error against evaluations), one panel
/// per case, written as plain SVG (no plotting dependency).
/// (method name, points (evaluations, relative error)).
type Curve = (String, Vec<(f64, f64)>);

fn svg(plots: &[(String, Vec<Curve>)]) -> String {
    let (pw, ph, m) = (520.0, 340.0, 60.0);
    let colours = [
        "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
    ];
    let mut out = format!(
        "<svg xmlns='http://www.w3.org/2000/svg' width='{}' height='{}' font-family='sans-serif' font-size='11'>\n",
        2.0 * pw,
        ph * plots.len().div_ceil(2) as f64
    );
    for (k, (title, curves)) in plots.iter().enumerate() {
        let (ox, oy) = ((k % 2) as f64 * pw, (k / 2) as f64 * ph);
        let (x0, x1, y0, y1) = (1.0f64, 7.0f64, -16.0f64, 0.0f64); // log10 ranges
        let sx = |e: f64| ox + m + (e.log10().clamp(x0, x1) - x0) / (x1 - x0) * (pw - 1.5 * m);
        let sy =
            |r: f64| oy + ph - m + (y0 - r.max(1e-16).log10().clamp(y0, y1)) / (y1 - y0) * (ph - 1.6 * m);
        out += &format!(
            "<text x='{}' y='{}' font-weight='bold'>{}</text>\n",
            ox + m,
            oy + 18.0,
            title
        );
        for d in (x0 as i32)..=(x1 as i32) {
            let x = sx(10f64.powi(d));
            out += &format!(
                "<line x1='{x}' y1='{}' x2='{x}' y2='{}' stroke='#ddd'/><text x='{}' y='{}'>1e{d}</text>\n",
                sy(1.0),
                sy(1e-16),
                x - 10.0,
                sy(1e-16) + 14.0
            );
        }
        for d in ((y0 as i32)..=(y1 as i32)).step_by(2) {
            let y = sy(10f64.powi(d));
            out += &format!(
                "<line x1='{}' y1='{y}' x2='{}' y2='{y}' stroke='#ddd'/><text x='{}' y='{}'>1e{d}</text>\n",
                sx(10.0),
                sx(1e7),
                ox + 12.0,
                y + 4.0
            );
        }
        out += &format!(
            "<text x='{}' y='{}'>field evaluations</text><text x='{}' y='{}' transform='rotate(-90 {} {})'>relative end-point error</text>\n",
            ox + pw / 2.0 - 40.0,
            oy + ph - 12.0,
            ox + 10.0,
            oy + ph / 2.0 + 50.0,
            ox + 10.0,
            oy + ph / 2.0 + 50.0
        );
        for (i, (name, pts)) in curves.iter().enumerate() {
            let c = colours[i % colours.len()];
            let mut pts = pts.clone();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let line: Vec<String> = pts
                .iter()
                .map(|(e, r)| format!("{:.1},{:.1}", sx(*e), sy(*r)))
                .collect();
            out += &format!(
                "<polyline fill='none' stroke='{c}' stroke-width='1.5' points='{}'/>\n",
                line.join(" ")
            );
            for (e, r) in &pts {
                out += &format!(
                    "<circle cx='{:.1}' cy='{:.1}' r='2.5' fill='{c}'/>\n",
                    sx(*e),
                    sy(*r)
                );
            }
            out += &format!(
                "<text x='{}' y='{}' fill='{c}'>{name}</text>\n",
                ox + pw - 1.4 * m,
                oy + 40.0 + 14.0 * i as f64
            );
        }
    }
    out + "</svg>\n"
}

fn dir(deg: f64) -> DVec3 {
    let a = deg.to_radians();
    DVec3::new(a.cos(), a.sin(), 0.0)
}

fn main() {
    println!("{}", snell::bench_header());
    let cases: Vec<(&str, IndexField, DVec3, DVec3, f64)> = vec![
        (
            "linear m=0.01, 10° up, 100 m",
            IndexField::Linear {
                n0: 1.0,
                m: 0.01,
                up: DVec3::Y,
                base: 0.0,
            },
            DVec3::ZERO,
            dir(10.0),
            100.0,
        ),
        (
            "hot_ground, inferior mirage: 1.5 m, 0.5° down, 400 m",
            IndexField::HotGround {
                n_inf: 1.000_293,
                dn: 1e-4,
                h0: 0.3,
                up: DVec3::Y,
                base: 0.0,
            },
            DVec3::new(0.0, 1.5, 0.0),
            dir(-0.5),
            400.0,
        ),
        (
            "inversion (superior mirage), 9 m, 0.2° up, 2000 m",
            IndexField::Inversion {
                n0: 1.000_29,
                dn: -6e-5,
                height: 10.0,
                thickness: 1.0,
                m: 0.0,
                up: DVec3::Y,
                base: 0.0,
            },
            DVec3::new(0.0, 9.0, 0.0),
            dir(0.2),
            2000.0,
        ),
        (
            "thin inversion crossed at 3°, 300 m (a sharp feature on a long ray)",
            IndexField::Inversion {
                n0: 1.000_293,
                dn: -1e-4,
                height: 8.0,
                thickness: 0.3,
                m: 0.0,
                up: DVec3::Y,
                base: 0.0,
            },
            DVec3::ZERO,
            dir(3.0),
            300.0,
        ),
    ];
    let mut plots: Vec<(String, Vec<Curve>)> = Vec::new();
    for (name, field, p, d, len) in &cases {
        println!("\n## {name}");
        let is_linear = matches!(field, IndexField::Linear { .. });
        let reference = if is_linear {
            run(&Query::along(field, *p, *d, *len, Method::Exact, 1.0, 1.0)).map(|r| r.0)
        } else {
            run(&Query::along(field, *p, *d, *len, Method::Rk45, 1e-13, 1.0)).map(|r| r.0)
        };
        let Ok(reference) = reference else {
            println!("reference failed: {reference:?}");
            continue;
        };
        println!(
            "reference: {} at {:.9?}",
            if is_linear { "exact" } else { "rk45 tol 1e-13" },
            reference
        );
        let base = run(&Query::along(field, *p, *d, *len, Method::Rk45, 1e-8, 1.0))
            .map(|r| r.3)
            .unwrap_or(f64::NAN);
        println!(
            "{:<10} {:>12} {:>14} {:>10} {:>10} {:>12}",
            "method", "setting", "rel. error", "evals", "steps", "time/rk45@1e-8"
        );
        let mut settings: Vec<(Method, f64, f64, String)> = Vec::new();
        for tol in [1e-4, 1e-6, 1e-8, 1e-10, 1e-12] {
            settings.push((Method::Rk45, tol, 1.0, format!("tol {tol:.0e}")));
        }
        for h in [10.0, 3.0, 1.0, 0.3, 0.1, 0.03] {
            settings.push((Method::Rk4, 1.0, h, format!("h {h}")));
        }
        for m in [Method::Slab, Method::Length, Method::Euler, Method::PaperRk4] {
            for h in [0.1, 0.01, 0.001] {
                settings.push((m, 1.0, h, format!("h {h}")));
            }
        }
        if is_linear {
            settings.push((Method::Exact, 1.0, 1.0, "closed form".into()));
        }
        let mut curves: Vec<Curve> = Vec::new();
        for (m, tol, h, label) in settings {
            match run(&Query::along(field, *p, *d, *len, m, tol, h)) {
                Ok((end, evals, steps, secs)) => {
                    let err = (end - reference).length() / len;
                    match curves.iter_mut().find(|c| c.0 == m.name()) {
                        Some(c) => c.1.push((evals as f64, err)),
                        None => curves.push((m.name().to_string(), vec![(evals as f64, err)])),
                    }
                    println!(
                        "{:<10} {:>12} {:>14.3e} {:>10} {:>10} {:>12.3}",
                        m.name(),
                        label,
                        err,
                        evals,
                        steps,
                        secs / base
                    )
                }
                Err(e) => {
                    let short: String = e.chars().take(70).collect();
                    println!("{:<10} {:>12} failed: {short}", m.name(), label)
                }
            }
        }
        // The aim: rk45 at 1e-9 relative error with >= 10x fewer evaluations
        // than fixed-step rk4 at the same error (log-log interpolation).
        let at = |name: &str| curves.iter().find(|c| c.0 == name).map(|c| evals_at(&c.1, 1e-9));
        if let (Some(Some(a)), Some(Some(b))) = (at("rk45"), at("rk4")) {
            println!(
                "evaluations for 1e-9 relative error: rk45 {a:.0}, rk4 {b:.0}: rk4 / rk45 = {:.1} (aim >= 10)",
                b / a
            );
        }
        plots.push((name.to_string(), curves));
    }
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/grin_accuracy.svg");
    match std::fs::write(&path, svg(&plots)) {
        Ok(()) => println!(
            "\nplot (error against evaluations, per case and method): {}",
            path.display()
        ),
        Err(e) => println!("\nplot not written: {e}"),
    }

    // The paper's table: n = n0 + m·y with n0 = 1, m = 0.01, a launch 10° above the
    // horizontal from y = 0 (the paper does not give its parameters), N steps of h in
    // height; percent error of the horizontal distance at height N·h against the closed
    // form. rk4 and rk45 integrate the ray equation over the same arc length, rk4 in
    // the same N steps.
    println!(
        "\n## the paper's table (n0 = 1, m = 0.01, 10° launch; percent error of the horizontal distance)"
    );
    let field = IndexField::Linear {
        n0: 1.0,
        m: 0.01,
        up: DVec3::Y,
        base: 0.0,
    };
    let d = dir(10.0);
    println!(
        "{:>5} {:>5} {:>11} {:>11} {:>11} {:>11} {:>11} {:>11}",
        "h", "N", "slab", "length", "euler", "paper_rk4", "rk4 (N)", "rk45 1e-9"
    );
    for h in [1.0, 0.5] {
        for n_steps in [10u32, 100] {
            let height = h * f64::from(n_steps);
            let b = d.x;
            let n = 1.0 + 0.01 * height;
            let x_exact = b / 0.01 * ((n + (n * n - b * b).sqrt()) / (1.0 + d.y)).ln();
            let mut row = Vec::new();
            for m in [Method::Slab, Method::Length, Method::Euler, Method::PaperRk4] {
                let mut ev = 0;
                let Ok(mut st) = State::new(&field, DVec3::ZERO, d, &mut ev) else {
                    continue;
                };
                let mut ok = true;
                for _ in 0..n_steps {
                    match mirage_study::segment(&field, m, h, &st, &mut ev) {
                        Ok(mirage_study::Seg::To(s)) => st = s,
                        _ => ok = false,
                    }
                }
                // The length method steps in arc length: read its x at height N·h
                // (interpolated along its polyline is not needed: report at its end height).
                let x = if m == Method::Length {
                    // Horizontal distance at the same height on the exact curve.
                    let nn = 1.0 + 0.01 * st.r.y;
                    let xe = b / 0.01 * ((nn + (nn * nn - b * b).sqrt()) / (1.0 + d.y)).ln();
                    row.push(if ok {
                        (st.r.x - xe).abs() / xe * 100.0
                    } else {
                        f64::NAN
                    });
                    continue;
                } else {
                    st.r.x
                };
                row.push(if ok {
                    (x - x_exact).abs() / x_exact * 100.0
                } else {
                    f64::NAN
                });
            }
            // Ray-equation methods: arc length to height N·h from the closed form, then
            // compare the end point's x.
            let mut ev = 0;
            let st0 = State::new(&field, DVec3::ZERO, d, &mut ev).expect("n > 0");
            let w = st0.v.y;
            // tau at which h(τ) = height: solve with the monotone arc length.
            let (mut lo, mut hi) = (0.0f64, 1e6f64);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                let (pp, _, _) = snell::media::exact::at_tau(0.01, DVec3::Y, &st0, mid);
                if pp.y < height {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            let _ = w;
            let (_, _, arc) = snell::media::exact::at_tau(0.01, DVec3::Y, &st0, lo);
            for (m, tol, step) in [
                (Method::Rk4, 1.0, arc / f64::from(n_steps)),
                (Method::Rk45, 1e-9, 1.0),
            ] {
                let q = Query::along(&field, DVec3::ZERO, d, arc, m, tol, step);
                let e = trace(&q).ok().and_then(|a| a.end).map_or(f64::NAN, |e| e.x);
                row.push((e - x_exact).abs() / x_exact * 100.0);
            }
            print!("{h:>5} {n_steps:>5}");
            for v in row {
                print!(" {v:>11.3e}");
            }
            println!();
        }
    }
    println!("(paper: slab = euler 4.83 / 0.82 / 3.39 / 0.73 %, length 12.98 / 2.53 / 16.84 / 4.21 %, RK 2.8e-3 / 3.3e-4 / 3.5e-4 / 4.6e-5 %)");
    chord_sweeps();
}

/// Renders of the mirage scenes across chord tolerances: cost (render time as
/// a ratio to the finest tolerance, same run), chords per segment, and image
/// error against the finest tolerance's render (same pixels and random numbers).
fn chord_sweeps() {
    use snell::scene::{load_scene, BuildOptions};
    println!("\n## chord tolerance against image error (renders, 2 threads)");
    for (path, w, h, spp, tols) in [
        (
            "scenes/mirage_road.toml",
            240,
            80,
            2,
            vec![1.0, 0.3, 0.1, 0.03, 0.01, 0.003, 0.0003],
        ),
        (
            "scenes/mirage_sea.toml",
            240,
            120,
            1,
            vec![3.0, 0.3, 0.03, 0.003, 0.0003],
        ),
        (
            "scenes/heat_shimmer.toml",
            120,
            90,
            1,
            vec![0.01, 0.003, 0.001, 0.0003, 0.0001],
        ),
    ] {
        let mut s = match load_scene(std::path::Path::new(path), &BuildOptions::default()) {
            Ok(s) => s,
            Err(e) => {
                println!("{path}: {e}");
                continue;
            }
        };
        let Ok(set) = snell::render::RenderSettings::from_scene(&s).with_resolution(w, h) else {
            continue;
        };
        match snell::bench::chord_sweep(&mut s, &set.with_spp(spp), &tols, None) {
            Ok(runs) => {
                println!(
                    "\n{path} ({w}x{h}, {spp} spp); reference = tolerance {} m",
                    tols.last().unwrap_or(&0.0)
                );
                println!(
                    "{:>10} {:>14} {:>16} {:>10} {:>12}",
                    "tol (m)", "time / finest", "chords/segment", "RMSE", "changed px"
                );
                let fine = runs.last().map(|r| r.wall_s).unwrap_or(1.0);
                for r in &runs {
                    println!(
                        "{:>10} {:>14.2} {:>16.1} {:>10.4} {:>11.2}%",
                        r.tolerance,
                        r.wall_s / fine,
                        r.chords_per_segment,
                        r.rmse,
                        100.0 * r.changed
                    );
                }
            }
            Err(e) => println!("{path}: {e}"),
        }
    }
}
