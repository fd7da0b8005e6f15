//! The report's page: plots drawn with `plotters` (SVG backend, inlined into
//! the HTML), tables and images beside the page, and `figures.json`.
use super::figure::{Plot, Section};
use crate::error::{Error, Result};
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

fn plot_err(e: impl std::fmt::Debug) -> Error {
    Error::Invalid(format!("report: drawing a plot: {e:?}"))
}

/// The range an axis needs for these values (positive values only on a log
/// axis), widened a little so points do not sit on the frame.
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let (l, h) = (lo.log10(), hi.log10());
        let pad = ((h - l) * 0.05).max(0.05);
        (10f64.powf(l - pad), 10f64.powf(h + pad))
    } else {
        let pad = ((hi - lo) * 0.05).max(lo.abs().max(hi.abs()) * 0.05).max(1e-12);
        (lo - pad, hi + pad)
    }
}

/// Draw `plot` as an SVG string.
pub fn svg(plot: &Plot) -> Result<String> {
    let xs = plot.series.iter().flat_map(|s| s.points.iter().map(|p| p[0]));
    let ys = plot.series.iter().flat_map(|s| {
        let spread = s.spread.iter().flatten().flat_map(|p| [p[0], p[1]]);
        s.points.iter().map(|p| p[1]).chain(spread)
    });
    let (x0, x1) = axis_range(xs, plot.log_x);
    let (y0, y1) = axis_range(ys, plot.log_y);
    match (plot.log_x, plot.log_y) {
        (false, false) => draw(plot, x0..x1, y0..y1),
        (true, false) => draw(plot, (x0..x1).log_scale(), y0..y1),
        (false, true) => draw(plot, x0..x1, (y0..y1).log_scale()),
        (true, true) => draw(plot, (x0..x1).log_scale(), (y0..y1).log_scale()),
    }
}

fn draw<X, Y>(plot: &Plot, x: X, y: Y) -> Result<String>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (560, 380)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&plot.title, ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(x, y)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc(&plot.x)
            .y_desc(&plot.y)
            .x_labels(8)
            .y_labels(8)
            .x_label_formatter(&|v| label(*v))
            .y_label_formatter(&|v| label(*v))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(plot_err)?;
        let ok = |p: &[f64; 2]| {
            p[0].is_finite() && p[1].is_finite() && (!plot.log_x || p[0] > 0.0) && (!plot.log_y || p[1] > 0.0)
        };
        for (i, s) in plot.series.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()];
            let pts: Vec<(f64, f64)> = s.points.iter().filter(|p| ok(p)).map(|p| (p[0], p[1])).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(plot_err)?
                .label(s.name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2)));
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(plot_err)?;
            if let Some(spread) = &s.spread {
                let bars = s
                    .points
                    .iter()
                    .zip(spread)
                    .filter(|(p, r)| ok(p) && ok(&[p[0], r[0]]) && ok(&[p[0], r[1]]));
                chart
                    .draw_series(
                        bars.map(|(p, r)| ErrorBar::new_vertical(p[0], r[0], p[1], r[1], color.filled(), 8)),
                    )
                    .map_err(plot_err)?;
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(out)
}

/// A short tick label: 3 significant digits, exponent form outside 1e-3..1e5.
fn label(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.0e}")
    } else {
        let digits = (2 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The whole page.
pub fn html(provenance: &serde_json::Value, command: &str, sections: &[Section]) -> Result<String> {
    let mut h = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>snell report</title>\n<style>\
         body{font-family:sans-serif;max-width:1200px;margin:1em auto;padding:0 1em;color:#222}\
         .plots,.pics{display:flex;flex-wrap:wrap;gap:12px}figure{margin:0}figcaption{font-size:13px;max-width:360px}\
         table{border-collapse:collapse;font-size:13px;margin:8px 0}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}\
         .prov{background:#f4f4f4;padding:6px 10px;font-size:13px}img{image-rendering:pixelated;width:320px}\
         </style></head><body>\n<h1>snell report</h1>\n<div class=\"prov\">",
    );
    if let Some(o) = provenance.as_object() {
        for (k, v) in o {
            let v = v.as_str().map(str::to_string).unwrap_or_else(|| v.to_string());
            h.push_str(&format!("<b>{}</b>: {} &nbsp; ", esc(k), esc(&v)));
        }
    }
    h.push_str(&format!(
        "<br><b>command</b>: <code>{}</code></div>\n",
        esc(command)
    ));
    for (i, s) in sections.iter().enumerate() {
        h.push_str(&format!("<h2>{}. {}</h2>\n<ul>", i + 1, esc(&s.title)));
        for line in &s.summary {
            h.push_str(&format!("<li>{}</li>", esc(line)));
        }
        h.push_str("</ul>\n<div class=\"plots\">");
        for p in &s.plots {
            h.push_str(&format!("<figure id=\"{}\">{}</figure>", esc(&p.id), svg(p)?));
        }
        h.push_str("</div>\n");
        if let Some(t) = &s.table {
            h.push_str("<table><tr>");
            for c in &t.header {
                h.push_str(&format!("<th>{}</th>", esc(c)));
            }
            h.push_str("</tr>");
            for r in &t.rows {
                h.push_str("<tr>");
                for c in r {
                    h.push_str(&format!("<td>{}</td>", esc(c)));
                }
                h.push_str("</tr>");
            }
            h.push_str("</table>\n");
        }
        h.push_str("<div class=\"pics\">");
        for p in &s.pictures {
            h.push_str(&format!(
                "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
                esc(&p.file),
                esc(&p.caption),
                esc(&p.caption)
            ));
        }
        h.push_str("</div>\n");
    }
    h.push_str("</body></html>\n");
    Ok(h)
}
