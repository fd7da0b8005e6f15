//! `snell warp-render` as a library call: prepare, warp and render a
//! `[warp]` scene, and the exact trace with `compare`.
use super::compare::{compare, Comparison};
use super::exact::{build_originals, render_exact_packets};
use super::frame::Frame;
use super::pipeline;
use super::prepare::prepare;
use crate::error::{Error, Result};
use crate::scene::RenderScene;
use crate::warp::WarpMethod;
use glam::Vec3A as V3;
use std::time::Instant;

/// What `snell warp-render` does, as a library call (the bench and tests use it).
#[derive(Debug, Clone, Default)]
pub struct WarpRunOptions {
    /// Render threads (`None`: one per core).
    pub threads: Option<usize>,
    /// Override of `[warp].subdivide` (pixels).
    pub subdivide: Option<f64>,
    /// Override of `[warp].method`.
    pub method: Option<WarpMethod>,
    /// Override of `[warp].fresnel`.
    pub fresnel: Option<bool>,
    /// Also run the exact trace and compare.
    pub compare: bool,
}

/// Everything one warp render measured.
pub struct WarpReport {
    /// The warped frame.
    pub frame: Frame,
    /// The exact trace, its comparison with the frame and the error heat map (with `compare`).
    pub exact: Option<(Frame, Comparison, Vec<V3>)>,
    /// Vertices after subdivision.
    pub vertices: usize,
    /// Triangles after subdivision.
    pub triangles: usize,
    /// Longest projected edge after subdivision (pixels).
    pub max_edge_px: f64,
    /// Seconds subdividing.
    pub subdivide_s: f64,
    /// Seconds moving vertices.
    pub warp_s: f64,
    /// Seconds building the copies' BVHs.
    pub build_s: f64,
    /// Vertex images found.
    pub images: usize,
    /// Triangles whose vertices have no image copy in common (`Warped`'s).
    pub dropped_triangles: usize,
    /// Triangles left out of the tube's copies as no primary ray can meet
    /// them (outside the camera's pyramid of rays; not in `copies`).
    pub culled_triangles: usize,
    /// Triangles per copy, by copy name.
    pub copies: Vec<(String, usize)>,
    /// Exact trace: BVH build of the unwarped meshes and the trace itself.
    pub exact_build_s: f64,
}

impl WarpReport {
    /// Seconds for one warped frame: warp + copy BVHs + primary rays.
    pub fn frame_s(&self) -> f64 {
        self.warp_s + self.build_s + self.frame.render_s
    }

    /// The report as JSON (timings, sizes, speed-up, the comparison).
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::json!({
            "width": self.frame.width,
            "height": self.frame.height,
            "vertices": self.vertices,
            "triangles": self.triangles,
            "max_projected_edge_px": self.max_edge_px,
            "subdivide_s": self.subdivide_s,
            "warp_s": self.warp_s,
            "copy_build_s": self.build_s,
            "render_s": self.frame.render_s,
            "frame_s": self.frame_s(),
            "frames_per_s": 1.0 / self.frame_s().max(1e-12),
            "vertices_per_s": self.vertices as f64 / self.warp_s.max(1e-12),
            "images": self.images,
            "dropped_triangles": self.dropped_triangles,
            "culled_triangles": self.culled_triangles,
            "copies": self.copies.iter().map(|(k, n)| serde_json::json!({"copy": k, "triangles": n})).collect::<Vec<_>>(),
            "provenance": crate::provenance::json(),
        });
        if let Some((ex, cmp, _)) = &self.exact {
            v["exact_trace_s"] = serde_json::json!(ex.render_s);
            v["exact_build_s"] = serde_json::json!(self.exact_build_s);
            v["speedup_render"] = serde_json::json!(ex.render_s / self.frame.render_s.max(1e-12));
            v["speedup_frame"] = serde_json::json!(ex.render_s / self.frame_s().max(1e-12));
            v["comparison"] = serde_json::to_value(cmp).unwrap_or_default();
        }
        v
    }
}

/// Prepare, warp and render a `[warp]` scene (and the exact trace if asked).
pub fn run(scene: &RenderScene, opts: &WarpRunOptions) -> Result<WarpReport> {
    let Some(spec0) = &scene.warp else {
        return Err(Error::Invalid(
            "the scene has no [warp] table: warp-render needs one warp glass (docs/warp.md)".into(),
        ));
    };
    let mut spec = spec0.clone();
    if let Some(s) = opts.subdivide {
        if !(s.is_finite() && s >= 0.05) {
            return Err(Error::Invalid(format!(
                "--subdivide: expected a projected edge length >= 0.05 pixels, got {s}"
            )));
        }
        spec.subdivide = s;
    }
    if let Some(m) = opts.method {
        spec.method = m;
    }
    if let Some(f) = opts.fresnel {
        spec.fresnel = f;
    }
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = opts.threads {
        pool = pool.num_threads(t.max(1));
    }
    let pool = pool
        .build()
        .map_err(|e| Error::Invalid(format!("cannot start worker threads: {e}")))?;
    pool.install(|| {
        let t0 = Instant::now();
        let prep = prepare(scene, &spec, spec.subdivide)?;
        let subdivide_s = t0.elapsed().as_secs_f64();
        let mut pipe = pipeline::Pipeline::new(scene, &spec, &prep, false)?;
        let warped = pipe.warp(scene)?;
        let frame = pipe.render(scene, &spec, &prep);
        let mut exact_build_s = 0.0;
        let exact = if opts.compare {
            let orig = build_originals(scene, &prep)?;
            exact_build_s = orig.build_s;
            let ex = render_exact_packets(scene, &spec, &prep, &orig);
            let (cmp, heat) = compare(scene, &frame, &ex);
            Some((ex, cmp, heat))
        } else {
            None
        };
        Ok(WarpReport {
            vertices: prep.vertices,
            triangles: prep.triangles,
            max_edge_px: prep.max_edge_px,
            subdivide_s,
            warp_s: warped.warp_s,
            build_s: warped.build_s,
            images: warped.images,
            dropped_triangles: warped.dropped_triangles,
            culled_triangles: warped.culled_triangles,
            copies: pipe.copy_sizes(),
            frame,
            exact,
            exact_build_s,
        })
    })
}
