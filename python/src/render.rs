//! `snell.render` and `snell.render_result`: the library's renderer on a
//! thread of its own with the GIL released, while the calling thread waits
//! in short slices, checks Python's signals (Ctrl-C cancels the render at
//! the next tile and raises `KeyboardInterrupt`) and reports progress.
use crate::control::{Progress, RenderControl};
use crate::convert::json_to_py;
use crate::errors::lib_err;
use crate::scene::Scene;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use snell::dielectric::NestedStrategy;
use snell::render::{render_part, Aov, PartSpec, Region, RenderSettings, Rendered};
use std::sync::mpsc;
use std::time::Duration;

/// How long the calling thread waits between two checks of Python's signals.
const POLL: Duration = Duration::from_millis(50);

/// What a render is asked for, parsed from the Python arguments.
struct Request {
    settings: RenderSettings,
    aovs: Vec<Aov>,
    part: PartSpec,
    threads: Option<usize>,
}

#[allow(clippy::too_many_arguments)]
fn request(
    scene: &Scene,
    spp: Option<u32>,
    seed: Option<u64>,
    threads: Option<usize>,
    nested: &str,
    aovs: &[String],
    region: Option<(u32, u32, u32, u32)>,
    samples: Option<(u32, u32)>,
    width: Option<u32>,
    height: Option<u32>,
) -> PyResult<Request> {
    let s = &scene.scene;
    let strategy: NestedStrategy = nested
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("nested: {e}")))?;
    let mut settings = RenderSettings::from_scene(s).with_strategy(strategy);
    if let Some(v) = spp {
        if v == 0 {
            return Err(PyValueError::new_err("spp: must be at least 1"));
        }
        settings = settings.with_spp(v);
    }
    if let Some(v) = seed {
        settings = settings.with_seed(v);
    }
    if width.is_some() || height.is_some() {
        settings = settings
            .with_resolution(width.unwrap_or(s.width), height.unwrap_or(s.height))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
    }
    if threads == Some(0) {
        return Err(PyValueError::new_err(
            "threads: must be at least 1 (None: one per core)",
        ));
    }
    let aovs = aovs
        .iter()
        .map(|name| {
            Aov::ALL.into_iter().find(|a| a.name() == name).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "aovs: expected false_hits, list_depth, tir or fallbacks, got \"{name}\""
                ))
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let part = PartSpec {
        region: region.map(|(x0, x1, y0, y1)| Region { x0, x1, y0, y1 }),
        samples,
        ..PartSpec::default()
    };
    Ok(Request {
        settings,
        aovs,
        part,
        threads,
    })
}

/// Where progress goes: nowhere, a line on `sys.stderr`, or a callable.
enum ProgressOut<'py> {
    Quiet,
    Line,
    Call(Bound<'py, PyAny>),
}

impl<'py> ProgressOut<'py> {
    fn from_arg(progress: Option<Bound<'py, PyAny>>) -> PyResult<Self> {
        let Some(p) = progress else {
            return Ok(ProgressOut::Quiet);
        };
        if p.is_callable() {
            return Ok(ProgressOut::Call(p));
        }
        Ok(if p.is_truthy()? {
            ProgressOut::Line
        } else {
            ProgressOut::Quiet
        })
    }

    fn report(&self, py: Python<'py>, p: &Progress) -> PyResult<()> {
        match self {
            ProgressOut::Quiet => Ok(()),
            ProgressOut::Line => {
                let line = format!(
                    "\rsnell: {}/{} tiles, {:.2} Msamples/s, {:.1} s",
                    p.tiles_done,
                    p.tiles_total,
                    p.samples_done as f64 / p.elapsed_s.max(1e-9) / 1e6,
                    p.elapsed_s
                );
                py.import("sys")?
                    .getattr("stderr")?
                    .call_method1("write", (line,))?;
                Ok(())
            }
            ProgressOut::Call(f) => {
                let d = PyDict::new(py);
                d.set_item("tiles_done", p.tiles_done)?;
                d.set_item("tiles_total", p.tiles_total)?;
                d.set_item("samples_done", p.samples_done)?;
                d.set_item("elapsed_s", p.elapsed_s)?;
                f.call1((d,))?;
                Ok(())
            }
        }
    }

    fn finish(&self, py: Python<'py>) -> PyResult<()> {
        if let ProgressOut::Line = self {
            py.import("sys")?
                .getattr("stderr")?
                .call_method1("write", ("\n",))?;
        }
        Ok(())
    }
}

/// Render on a thread of its own; the calling thread waits with the GIL
/// released, and between waits checks for Ctrl-C and reports progress.
fn run(py: Python<'_>, scene: &Scene, req: &Request, progress: &ProgressOut<'_>) -> PyResult<Rendered> {
    let control = RenderControl::new();
    let opts = control.options(req.threads, !req.aovs.is_empty());
    let (tx, mut rx) = mpsc::channel();
    let outcome = std::thread::scope(|s| {
        let worker = s.spawn(|| {
            let r = render_part(&scene.scene, &req.settings, &opts, &req.part);
            // The receiver outlives this thread (the scope joins it first).
            let _ = tx.send(r);
        });
        let mut last = None;
        loop {
            // The receiver moves into the wait and back: it is Send, not Sync.
            let (got, back) = py.detach(move || (rx.recv_timeout(POLL), rx));
            rx = back;
            match got {
                Ok(r) => {
                    // The last tiles' progress, so that a callback sees the end.
                    let now = control.progress();
                    match now.filter(|_| now != last) {
                        Some(p) => break progress.report(py, &p).map(|()| r),
                        None => break Ok(r),
                    }
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    break Err(PyRuntimeError::new_err(
                        "the render thread ended without a result",
                    ))
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {}
            }
            let reported = py.check_signals().and_then(|()| {
                let now = control.progress();
                if now.is_some() && now != last {
                    last = now;
                    now.map_or(Ok(()), |p| progress.report(py, &p))
                } else {
                    Ok(())
                }
            });
            if let Err(e) = reported {
                // Ctrl-C, or a progress callback that raised: stop at the
                // next tile and let the tiles in progress finish first.
                control.cancel();
                let _ = py.detach(|| worker.join());
                break Err(e);
            }
        }
    });
    progress.finish(py)?;
    outcome?.map_err(|e| lib_err(py, e))
}

/// One render's image, diagnostic layers and statistics.
#[pyclass(frozen, module = "snell")]
pub struct RenderResult {
    /// Linear RGB, float32, shape (height, width, 3), row 0 at the top.
    #[pyo3(get)]
    image: Py<PyArray3<f32>>,
    /// Estimated variance of each pixel mean (Monte Carlo noise), float32, (H, W, 3).
    #[pyo3(get)]
    variance: Py<PyArray3<f32>>,
    /// The diagnostic layers asked for: name → float32 array (H, W).
    #[pyo3(get)]
    aovs: Py<PyDict>,
    /// The render statistics: the counters (``samples``, ``queries``,
    /// ``false_hits``, ...), ``wall_s``, ``rays_per_s``, the settings and the
    /// provenance, under the keys of ``snell render --stats-json``.
    #[pyo3(get)]
    stats: Py<PyDict>,
    /// False when the render was cancelled before every tile was rendered.
    #[pyo3(get)]
    complete: bool,
    /// The pixels rendered, (x0, x1, y0, y1), half-open.
    #[pyo3(get)]
    region: (u32, u32, u32, u32),
    /// The sample indices rendered, (start, count).
    #[pyo3(get)]
    samples: (u32, u32),
}

#[pymethods]
impl RenderResult {
    fn __repr__(&self, py: Python<'_>) -> String {
        let shape = self.image.bind(py).shape().to_vec();
        format!(
            "<snell.RenderResult image {shape:?}, samples {:?}, complete {}>",
            self.samples,
            if self.complete { "True" } else { "False" }
        )
    }
}

use numpy::PyUntypedArrayMethods;

fn rgb_array<'py>(
    py: Python<'py>,
    px: &[glam::Vec3A],
    w: u32,
    h: u32,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let flat: Vec<f32> = px.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    let a = Array3::from_shape_vec((h as usize, w as usize, 3), flat)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py))
}

fn layer_array<'py>(py: Python<'py>, v: &[f32], w: u32, h: u32) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let a = Array2::from_shape_vec((h as usize, w as usize), v.to_vec())
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py))
}

fn result(py: Python<'_>, r: &Rendered, req: &Request) -> PyResult<RenderResult> {
    let aovs = PyDict::new(py);
    for &a in &req.aovs {
        aovs.set_item(a.name(), layer_array(py, r.aovs.layer(a), r.width, r.height)?)?;
    }
    let mut st = r.stats.to_json(&req.settings, r.spp_done);
    st["complete"] = serde_json::json!(r.complete);
    st["tiles_done"] = serde_json::json!(r.tiles_done);
    st["tiles_total"] = serde_json::json!(r.tiles_total);
    st["region"] = serde_json::json!(r.region.to_string());
    st["samples_range"] = serde_json::json!(format!("{}:{}", r.sample_start, r.sample_count));
    let stats = json_to_py(py, &st)?.cast_into::<PyDict>()?;
    Ok(RenderResult {
        image: rgb_array(py, &r.pixels, r.width, r.height)?.unbind(),
        variance: rgb_array(py, &r.variance, r.width, r.height)?.unbind(),
        aovs: aovs.unbind(),
        stats: stats.unbind(),
        complete: r.complete,
        region: (r.region.x0, r.region.x1, r.region.y0, r.region.y1),
        samples: (r.sample_start, r.sample_count),
    })
}

/// Render a scene; the full result (image, variance, layers, statistics).
///
/// The arguments are those of :func:`render`; the result is a
/// :class:`RenderResult`.
#[pyfunction]
#[pyo3(signature = (scene, spp=None, seed=None, threads=None, nested="filter", aovs=Vec::new(), region=None, samples=None, width=None, height=None, progress=None))]
#[pyo3(
    text_signature = "(scene, spp=None, seed=None, threads=None, nested='filter', aovs=(), region=None, samples=None, width=None, height=None, progress=None)"
)]
#[allow(clippy::too_many_arguments)]
pub fn render_result(
    py: Python<'_>,
    scene: &Bound<'_, Scene>,
    spp: Option<u32>,
    seed: Option<u64>,
    threads: Option<usize>,
    nested: &str,
    aovs: Vec<String>,
    region: Option<(u32, u32, u32, u32)>,
    samples: Option<(u32, u32)>,
    width: Option<u32>,
    height: Option<u32>,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<RenderResult> {
    let scene = scene.get();
    let req = request(
        scene, spp, seed, threads, nested, &aovs, region, samples, width, height,
    )?;
    let out = ProgressOut::from_arg(progress)?;
    let r = run(py, scene, &req, &out)?;
    result(py, &r, &req)
}

/// Render a scene with the path tracer: the same pixels, bit for bit, as
/// ``snell render`` at the same settings.
///
/// Args:
///     scene: a :class:`Scene`.
///     spp: samples per pixel (default: the scene's ``film.spp``).
///     seed: seed of the sample generators (default: ``film.seed``).
///     threads: render threads (default None: one per core). The image does
///         not depend on it.
///     nested: how false hits of nested dielectrics are skipped: ``"filter"``
///         (default, inside Embree), ``"recast"``, ``"toggle"`` or ``"off"``.
///     aovs: diagnostic layers to return as well: any of ``"false_hits"``,
///         ``"list_depth"``, ``"tir"``, ``"fallbacks"`` (per-pixel means of
///         per-sample counts; ``list_depth`` is a maximum).
///     region: only pixels ``(x0, x1, y0, y1)``, half-open (default: the
///         whole film); the image is then the region's size.
///     samples: only sample indices ``(start, count)`` of the film's spp
///         (default: all); parts merge exactly into the whole render.
///     width, height: another film size in pixels (the camera keeps its
///         vertical field of view; default: the scene's ``film``).
///     progress: ``True`` prints progress to ``sys.stderr``; a callable is
///         called with a dict (``tiles_done``, ``tiles_total``,
///         ``samples_done``, ``elapsed_s`` in seconds) from the calling thread.
///
/// Returns:
///     The image: a C-contiguous float32 array of shape (height, width, 3),
///     linear RGB (radiance, no tone mapping), row 0 at the top. With
///     ``aovs``, a tuple ``(image, {name: float32 array (height, width)})``.
///     :func:`render_result` returns the statistics as well.
///
/// The GIL is released while the render runs: other Python threads go on.
/// Ctrl-C stops the render at the next tile and raises ``KeyboardInterrupt``.
#[pyfunction]
#[pyo3(signature = (scene, spp=None, seed=None, threads=None, nested="filter", aovs=Vec::new(), region=None, samples=None, width=None, height=None, progress=None))]
#[pyo3(
    text_signature = "(scene, spp=None, seed=None, threads=None, nested='filter', aovs=(), region=None, samples=None, width=None, height=None, progress=None)"
)]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    scene: &Bound<'py, Scene>,
    spp: Option<u32>,
    seed: Option<u64>,
    threads: Option<usize>,
    nested: &str,
    aovs: Vec<String>,
    region: Option<(u32, u32, u32, u32)>,
    samples: Option<(u32, u32)>,
    width: Option<u32>,
    height: Option<u32>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let want_aovs = !aovs.is_empty();
    let r = render_result(
        py, scene, spp, seed, threads, nested, aovs, region, samples, width, height, progress,
    )?;
    use pyo3::IntoPyObjectExt;
    if want_aovs {
        (r.image, r.aovs).into_bound_py_any(py)
    } else {
        Ok(r.image.into_bound(py).into_any())
    }
}
