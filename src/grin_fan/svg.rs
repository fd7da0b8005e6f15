//! The fan as an SVG picture: the index as shading, the scene's profile,
//! the rays coloured by elevation, their hits marked by object. Heights
//! and distances have their own scales (a mirage lives in metres of height
//! over hundreds of metres); the title says how much heights are stretched.
use super::{Fan, IndexSlice};
use std::fmt::Write;

const WIDTH: f64 = 1000.0;
const HEIGHT: f64 = 560.0;
/// The plot area: left, top, right, bottom (pixels).
const AREA: [f64; 4] = [72.0, 44.0, 800.0, 506.0];
/// Object colours (matplotlib's tab10), in order of first appearance.
const PALETTE: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22",
    "#17becf",
];

/// Map from (distance, height) to the picture.
struct Frame {
    d: [f64; 2],
    h: [f64; 2],
}

impl Frame {
    fn x(&self, d: f64) -> f64 {
        AREA[0] + (AREA[2] - AREA[0]) * (d - self.d[0]) / (self.d[1] - self.d[0])
    }
    fn y(&self, h: f64) -> f64 {
        AREA[3] - (AREA[3] - AREA[1]) * (h - self.h[0]) / (self.h[1] - self.h[0])
    }
    /// How many times heights are stretched against distances.
    fn exaggeration(&self) -> f64 {
        let per_m_h = (AREA[3] - AREA[1]) / (self.h[1] - self.h[0]);
        let per_m_d = (AREA[2] - AREA[0]) / (self.d[1] - self.d[0]);
        per_m_h / per_m_d
    }
}

/// The SVG document of `fan`, titled `title` (e.g. the scene's file name).
pub fn fan_svg(fan: &Fan, title: &str) -> String {
    let f = Frame {
        d: fan.distance_range,
        h: fan.height_range,
    };
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{WIDTH}" height="{HEIGHT}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<clipPath id="area"><rect x="{}" y="{}" width="{}" height="{}"/></clipPath>"#,
        AREA[0],
        AREA[1],
        AREA[2] - AREA[0],
        AREA[3] - AREA[1]
    );
    s.push_str("<g clip-path=\"url(#area)\">\n");
    let n_range = fan.index.as_ref().and_then(|ix| shade_index(&mut s, ix));
    draw_profile(&mut s, fan, &f);
    draw_rays(&mut s, fan, &f);
    s.push_str("</g>\n");
    // The eye.
    let _ = writeln!(
        s,
        r#"<circle cx="{:.2}" cy="{:.2}" r="4" fill="black"><title>eye</title></circle>"#,
        f.x(0.0),
        f.y(fan.eye_height)
    );
    draw_axes(&mut s, &f);
    let what = match fan.tolerance {
        Some(t) => format!("rk45 at {t:.1e} m"),
        None => "no medium: straight rays".to_string(),
    };
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" font-size="14">{} — {} rays, {} — heights stretched ×{:.3e}</text>"#,
        AREA[0],
        escape(title),
        fan.rays.len(),
        what,
        f.exaggeration()
    );
    draw_legend(&mut s, fan, n_range);
    s.push_str("</svg>\n");
    s
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Colour of a ray by its place in the fan (0 lowest, 1 highest): blue to red.
fn ray_colour(t: f64) -> String {
    let lerp = |a: f64, b: f64| (a + (b - a) * t.clamp(0.0, 1.0)).round() as u8;
    format!(
        "#{:02x}{:02x}{:02x}",
        lerp(59.0, 180.0),
        lerp(76.0, 4.0),
        lerp(192.0, 38.0)
    )
}

/// Colour of the index, 0 at its lowest (hot air) to 1 at its highest.
fn index_colour(t: f64) -> String {
    let lerp = |a: f64, b: f64| (a + (b - a) * t.clamp(0.0, 1.0)).round() as u8;
    format!(
        "#{:02x}{:02x}{:02x}",
        lerp(255.0, 214.0),
        lerp(190.0, 232.0),
        lerp(130.0, 255.0)
    )
}

/// Shades the cells (runs of one shade merged); returns the range of n.
fn shade_index(s: &mut String, ix: &IndexSlice) -> Option<(f64, f64)> {
    let (lo, hi) =
        ix.n.iter()
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &n| {
                (a.min(n), b.max(n))
            });
    if hi <= lo || hi.is_nan() || lo.is_nan() {
        return None;
    }
    const LEVELS: f64 = 48.0;
    let (cw, ch) = (
        (AREA[2] - AREA[0]) / ix.columns as f64,
        (AREA[3] - AREA[1]) / ix.rows as f64,
    );
    let level = |n: Option<f64>| n.map(|n| ((n - lo) / (hi - lo) * LEVELS).round() as i64);
    for j in 0..ix.rows {
        let row = &ix.n[j * ix.columns..(j + 1) * ix.columns];
        let mut i = 0;
        while i < ix.columns {
            let l = level(row[i]);
            let mut k = i + 1;
            while k < ix.columns && level(row[k]) == l {
                k += 1;
            }
            if let Some(l) = l {
                let _ = writeln!(
                    s,
                    r#"<rect x="{:.2}" y="{:.2}" width="{:.2}" height="{:.2}" fill="{}"/>"#,
                    AREA[0] + i as f64 * cw,
                    AREA[3] - (j + 1) as f64 * ch,
                    (k - i) as f64 * cw + 0.3,
                    ch + 0.3,
                    index_colour(l as f64 / LEVELS)
                );
            }
            i = k;
        }
    }
    Some((lo, hi))
}

fn draw_profile(s: &mut String, fan: &Fan, f: &Frame) {
    // Filled runs of columns that found a surface.
    let mut run: Vec<(f64, f64)> = Vec::new();
    let flush = |run: &mut Vec<(f64, f64)>, s: &mut String| {
        if run.len() >= 2 {
            let mut pts = format!("{:.2},{:.2}", f.x(run[0].0), AREA[3] + 1.0);
            for (d, h) in run.iter() {
                let _ = write!(pts, " {:.2},{:.2}", f.x(*d), f.y(*h));
            }
            let _ = write!(pts, " {:.2},{:.2}", f.x(run[run.len() - 1].0), AREA[3] + 1.0);
            let _ = writeln!(s, r##"<polygon points="{pts}" fill="#cfc8bd"/>"##);
        }
        run.clear();
    };
    for c in &fan.profile {
        match c.height {
            Some(h) => run.push((c.distance, h)),
            None => flush(&mut run, s),
        }
    }
    flush(&mut run, s);
    // The surface line, coloured by object.
    for w in fan.profile.windows(2) {
        if let (Some(h0), Some(h1), Some(o)) = (w[0].height, w[1].height, w[0].object) {
            let _ = writeln!(
                s,
                r#"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="{}" stroke-width="2"/>"#,
                f.x(w[0].distance),
                f.y(h0),
                f.x(w[1].distance),
                f.y(h1),
                PALETTE[o % PALETTE.len()]
            );
        }
    }
}

fn draw_rays(s: &mut String, fan: &Fan, f: &Frame) {
    let last = (fan.rays.len().max(2) - 1) as f64;
    for (i, r) in fan.rays.iter().enumerate() {
        let mut pts = String::new();
        for p in &r.points {
            let _ = write!(pts, "{:.2},{:.2} ", f.x(p[0]), f.y(p[1]));
        }
        let dash = if r.failure.is_some() {
            r#" stroke-dasharray="4 3""#
        } else {
            ""
        };
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="1"{dash}><title>elevation {:.4}°{}</title></polyline>"#,
            pts.trim_end(),
            ray_colour(i as f64 / last),
            r.elevation_deg,
            r.failure
                .as_deref()
                .map(|w| format!(": {}", escape(w)))
                .unwrap_or_default()
        );
    }
    for r in &fan.rays {
        if let Some(h) = &r.hit {
            let k = fan.objects.iter().position(|o| *o == h.object).unwrap_or(0);
            let _ = writeln!(
                s,
                r#"<circle cx="{:.2}" cy="{:.2}" r="2.5" fill="{}"><title>{} at {:.3} m, {:.4} m</title></circle>"#,
                f.x(h.at[0]),
                f.y(h.at[1]),
                PALETTE[k % PALETTE.len()],
                escape(&h.object),
                h.at[0],
                h.at[1]
            );
        }
    }
}

/// A tick step of 1, 2 or 5 times a power of ten giving about `n` ticks.
fn tick_step(lo: f64, hi: f64, n: f64) -> f64 {
    let raw = (hi - lo) / n;
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&st| st >= raw)
        .unwrap_or(10.0 * p)
}

/// Decimals that show `step` exactly.
fn decimals(step: f64) -> usize {
    (-step.log10().floor()).max(0.0) as usize
}

fn draw_axes(s: &mut String, f: &Frame) {
    let _ = writeln!(
        s,
        r#"<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="black"/>"#,
        AREA[0],
        AREA[1],
        AREA[2] - AREA[0],
        AREA[3] - AREA[1]
    );
    let sd = tick_step(f.d[0], f.d[1], 8.0);
    for k in (f.d[0] / sd).ceil() as i64..=(f.d[1] / sd + 1e-9).floor() as i64 {
        let d = k as f64 * sd;
        let x = f.x(d);
        let _ = writeln!(
            s,
            r#"<line x1="{x:.2}" y1="{}" x2="{x:.2}" y2="{}" stroke="black"/><text x="{x:.2}" y="{}" text-anchor="middle">{:.*}</text>"#,
            AREA[3],
            AREA[3] + 5.0,
            AREA[3] + 18.0,
            decimals(sd),
            d + 0.0 // no "-0"
        );
    }
    let sh = tick_step(f.h[0], f.h[1], 8.0);
    for k in (f.h[0] / sh).ceil() as i64..=(f.h[1] / sh + 1e-9).floor() as i64 {
        let h = k as f64 * sh;
        let y = f.y(h);
        let _ = writeln!(
            s,
            r#"<line x1="{}" y1="{y:.2}" x2="{}" y2="{y:.2}" stroke="black"/><text x="{}" y="{:.2}" text-anchor="end">{:.*}</text>"#,
            AREA[0] - 5.0,
            AREA[0],
            AREA[0] - 8.0,
            y + 4.0,
            decimals(sh),
            h + 0.0
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{}" text-anchor="middle">distance from the eye along the view (m)</text>"#,
        0.5 * (AREA[0] + AREA[2]),
        AREA[3] + 38.0
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate(18 {:.1}) rotate(-90)" text-anchor="middle">height (m)</text>"#,
        0.5 * (AREA[1] + AREA[3])
    );
}

fn draw_legend(s: &mut String, fan: &Fan, n_range: Option<(f64, f64)>) {
    let x = AREA[2] + 16.0;
    let mut y = AREA[1] + 10.0;
    let lo = fan.rays.first().map_or(0.0, |r| r.elevation_deg);
    let hi = fan.rays.last().map_or(0.0, |r| r.elevation_deg);
    for (t, label) in [(1.0, hi), (0.0, lo)] {
        let _ = writeln!(
            s,
            r#"<line x1="{x}" y1="{y}" x2="{}" y2="{y}" stroke="{}" stroke-width="2"/><text x="{}" y="{}">ray at {label:.4}°</text>"#,
            x + 22.0,
            ray_colour(t),
            x + 28.0,
            y + 4.0
        );
        y += 18.0;
    }
    y += 8.0;
    for (k, o) in fan.objects.iter().enumerate() {
        let _ = writeln!(
            s,
            r#"<circle cx="{}" cy="{y}" r="5" fill="{}"/><text x="{}" y="{}">{}</text>"#,
            x + 11.0,
            PALETTE[k % PALETTE.len()],
            x + 28.0,
            y + 4.0,
            escape(o)
        );
        y += 18.0;
    }
    if let Some((lo, hi)) = n_range {
        y += 8.0;
        for (t, n) in [(0.0, lo), (1.0, hi)] {
            let _ = writeln!(
                s,
                r##"<rect x="{x}" y="{}" width="22" height="12" fill="{}" stroke="#999"/><text x="{}" y="{}">n − 1 = {:.5e}</text>"##,
                y - 6.0,
                index_colour(t),
                x + 28.0,
                y + 4.0,
                n - 1.0
            );
            y += 18.0;
        }
    }
}
