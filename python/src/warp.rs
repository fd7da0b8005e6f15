//! `snell.warp.plate` and `snell.warp.hollow_cylinder`: every image of each
//! vertex of an (N, 3) array, solved in parallel (rayon) with the GIL
//! released. Images, families and statuses are those of `snell warp-points`.
use crate::arrays::{array1, points, rows3};
use glam::DVec3;
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike1, PyArrayLikeDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use snell::warp::approx_tube::approx_tube_image;
use snell::warp::{CylImage, CylStatus, CylinderWarper, Family, HollowCylinder, Plate, PlateStatus};

/// Vertices per parallel work item.
const CHUNK: usize = 4096;

/// Family codes of [`WarpImages::family`], in the order of `FAMILIES`.
const FAMILY_ORDER: [Family; 5] = [
    Family::Direct,
    Family::Through4,
    Family::Tir2,
    Family::Wall2,
    Family::Hollow2,
];

/// The names of the family codes (as `snell warp-points` spells them).
const FAMILIES: [&str; 5] = ["direct", "through4", "tir2", "wall2", "hollow2"];

/// A vertex's outcome, as `snell warp-points` words it; the code is the index.
const STATUSES: [&str; 7] = [
    "ok",
    "ok: no image",
    "error: point has non-finite coordinates",
    "error: the point is inside the glass",
    "error: the eye is not in front of the plate",
    "error: the solver did not converge",
    "error: the point is inside the glass wall",
];
const OK: u8 = 0;
const NO_IMAGE: u8 = 1;
const NOT_FINITE: u8 = 2;
const PLATE_INSIDE: u8 = 3;
const EYE_NOT_IN_FRONT: u8 = 4;
const NOT_CONVERGED: u8 = 5;
const TUBE_INSIDE: u8 = 6;
/// The tube's status when the eye is within its outer radius (after the table above).
const EYE_NOT_OUTSIDE_TEXT: &str = "error: the eye is not outside the tube";

/// One image, in flat-array form.
#[derive(Clone, Copy)]
struct Image {
    family: Family,
    direction: DVec3,
    position: DVec3,
    refractions: u32,
    parity: i8,
}

impl From<&CylImage> for Image {
    fn from(im: &CylImage) -> Image {
        Image {
            family: im.family,
            direction: im.direction,
            position: im.position,
            refractions: im.refractions,
            parity: im.parity,
        }
    }
}

/// The images of a run of vertices, flat: `counts[i]` images for vertex i.
#[derive(Default)]
struct Flat {
    images: Vec<Image>,
    counts: Vec<u32>,
    status: Vec<u8>,
}

impl Flat {
    fn push(&mut self, status: u8, images: impl IntoIterator<Item = Image>) {
        let before = self.images.len();
        self.images.extend(images);
        self.counts.push((self.images.len() - before) as u32);
        self.status.push(status);
    }

    /// The chunks' images one after the other (one copy, in order).
    fn concat(chunks: Vec<Flat>) -> Flat {
        let mut f = Flat {
            images: Vec::with_capacity(chunks.iter().map(|c| c.images.len()).sum()),
            counts: Vec::with_capacity(chunks.iter().map(|c| c.counts.len()).sum()),
            status: Vec::with_capacity(chunks.iter().map(|c| c.status.len()).sum()),
        };
        for c in chunks {
            f.images.extend(c.images);
            f.counts.extend(c.counts);
            f.status.extend(c.status);
        }
        f
    }
}

/// Every image of every vertex: flat arrays of images, and per vertex the
/// number of its images, where they start and its status.
///
/// The images of vertex ``i`` are rows ``offsets[i]:offsets[i + 1]`` of
/// ``positions``, ``directions``, ``family``, ``refractions`` and ``parity``.
#[pyclass(frozen, module = "snell.warp")]
pub struct WarpImages {
    /// Where each image's vertex must move (eye + direction · distance to the
    /// vertex), float64 (M, 3), metres.
    #[pyo3(get)]
    positions: Py<PyArray2<f64>>,
    /// Unit direction of the straight eye ray that sees each image, float64 (M, 3).
    #[pyo3(get)]
    directions: Py<PyArray2<f64>>,
    /// Path family of each image, uint8 (M,): an index into ``FAMILIES``.
    #[pyo3(get)]
    family: Py<PyArray1<u8>>,
    /// Refractions along each image's path, uint32 (M,).
    #[pyo3(get)]
    refractions: Py<PyArray1<u32>>,
    /// +1 upright, -1 mirrored relative to a direct view, int8 (M,).
    #[pyo3(get)]
    parity: Py<PyArray1<i8>>,
    /// Images per vertex, uint32 (N,).
    #[pyo3(get)]
    counts: Py<PyArray1<u32>>,
    /// Start of each vertex's images, int64 (N + 1,); the last is M.
    #[pyo3(get)]
    offsets: Py<PyArray1<i64>>,
    /// Outcome per vertex, uint8 (N,): an index into ``STATUSES`` (0 and 1 are "ok").
    #[pyo3(get)]
    status: Py<PyArray1<u8>>,
    /// The texts of the status codes, as ``snell warp-points`` reports them.
    #[pyo3(get)]
    statuses: Vec<String>,
}

#[pymethods]
impl WarpImages {
    /// The names of the family codes: ``("direct", "through4", "tir2", "wall2", "hollow2")``.
    #[classattr]
    #[allow(non_snake_case)]
    fn FAMILIES() -> Vec<&'static str> {
        FAMILIES.to_vec()
    }

    /// Vertex index of each image, int64 (M,) (made when asked for).
    #[getter]
    fn vertex<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        use numpy::PyArrayMethods;
        let counts = self.counts.bind(py).readonly();
        let v: Vec<i64> = counts
            .as_array()
            .iter()
            .enumerate()
            .flat_map(|(i, &c)| std::iter::repeat_n(i as i64, c as usize))
            .collect();
        array1(py, v)
    }

    /// Each vertex's status as text (``"ok"``, ``"ok: no image"`` or ``"error: ..."``).
    fn messages(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        use numpy::PyArrayMethods;
        let codes = self.status.bind(py).readonly();
        Ok(codes
            .as_array()
            .iter()
            .map(|&c| self.statuses[c as usize].clone())
            .collect())
    }

    fn __len__(&self, py: Python<'_>) -> usize {
        use numpy::PyUntypedArrayMethods;
        self.counts.bind(py).len()
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        use numpy::PyUntypedArrayMethods;
        format!(
            "<snell.warp.WarpImages {} vertices, {} images>",
            self.counts.bind(py).len(),
            self.family.bind(py).len()
        )
    }
}

/// The images as the arrays of a [`WarpImages`] (structure of arrays).
struct Rows {
    positions: Vec<f64>,
    directions: Vec<f64>,
    family: Vec<u8>,
    refractions: Vec<u32>,
    parity: Vec<i8>,
    counts: Vec<u32>,
    status: Vec<u8>,
}

impl Rows {
    fn from_flat(f: Flat) -> Rows {
        let ims = &f.images;
        let xyz = |v: DVec3| v.to_array();
        Rows {
            positions: ims.iter().flat_map(|i| xyz(i.position)).collect(),
            directions: ims.iter().flat_map(|i| xyz(i.direction)).collect(),
            family: ims.iter().map(|i| family_code(i.family)).collect(),
            refractions: ims.iter().map(|i| i.refractions).collect(),
            parity: ims.iter().map(|i| i.parity).collect(),
            counts: f.counts,
            status: f.status,
        }
    }
}

fn images_object(py: Python<'_>, r: Rows, statuses: Vec<String>) -> WarpImages {
    let offsets = py.detach(|| {
        let mut offsets = Vec::with_capacity(r.counts.len() + 1);
        let mut at = 0i64;
        offsets.push(0);
        for &c in &r.counts {
            at += c as i64;
            offsets.push(at);
        }
        offsets
    });
    WarpImages {
        positions: rows3(py, r.positions).unbind(),
        directions: rows3(py, r.directions).unbind(),
        family: array1(py, r.family).unbind(),
        refractions: array1(py, r.refractions).unbind(),
        parity: array1(py, r.parity).unbind(),
        counts: array1(py, r.counts).unbind(),
        offsets: array1(py, offsets).unbind(),
        status: array1(py, r.status).unbind(),
        statuses,
    }
}

fn family_code(f: Family) -> u8 {
    FAMILY_ORDER.iter().position(|&x| x == f).unwrap_or(0) as u8
}

fn vec3(name: &str, a: &PyArrayLike1<'_, f64, AllowTypeChange>) -> PyResult<DVec3> {
    match a.as_slice() {
        Ok([x, y, z]) => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(PyValueError::new_err(format!("{name}: expected three numbers"))),
    }
}

fn statuses() -> Vec<String> {
    STATUSES.iter().map(|s| s.to_string()).collect()
}

/// Solve every chunk of `pts` in parallel and join the chunks in order.
fn solve(pts: &[DVec3], each: impl Fn(&[DVec3], &mut Flat) + Sync) -> Flat {
    let chunks: Vec<Flat> = pts
        .par_chunks(CHUNK)
        .map(|ch| {
            let mut f = Flat::default();
            each(ch, &mut f);
            f
        })
        .collect();
    Flat::concat(chunks)
}

/// Warp vertices behind a glass plate with parallel faces (Mukai et al.).
///
/// For each vertex: its one image (where the vertex must move so that a
/// straight eye ray sees it where refraction through the plate would), or
/// the vertex itself (family ``direct``) when it is between the eye and the
/// plate. The images and statuses are those of ``snell warp-points``.
///
/// Args:
///     vertices: (N, 3) points, metres.
///     eye: the eye (3 numbers), in front of the near face.
///     near_face_point: a point on the face nearer the eye.
///     normal: the faces' normal, pointing away from the eye (normalised).
///     thickness: the plate's thickness W > 0, metres.
///     ior: the glass's index n > 0 (the surroundings have index 1).
///     solver: ``"batch"`` (default: the mesh warp's solver, four vertices
///         at a time, positions within rounding of the scalar one's) or
///         ``"scalar"`` (the one ``snell warp-points`` runs: the same
///         numbers bit for bit, slower).
///
/// Returns:
///     :class:`WarpImages`.
///
/// Raises:
///     ValueError: an invalid plate or solver, or arrays of the wrong shape.
#[pyfunction]
#[pyo3(signature = (vertices, eye, near_face_point, normal, thickness, ior, solver="batch"))]
#[allow(clippy::too_many_arguments)]
pub fn plate(
    py: Python<'_>,
    vertices: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    eye: PyArrayLike1<'_, f64, AllowTypeChange>,
    near_face_point: PyArrayLike1<'_, f64, AllowTypeChange>,
    normal: PyArrayLike1<'_, f64, AllowTypeChange>,
    thickness: f64,
    ior: f64,
    solver: &str,
) -> PyResult<WarpImages> {
    let pts = points("vertices", &vertices)?;
    let eye = vec3("eye", &eye)?;
    if !eye.is_finite() {
        return Err(PyValueError::new_err("eye: expected finite coordinates"));
    }
    let pl = Plate::try_new(
        vec3("near_face_point", &near_face_point)?,
        vec3("normal", &normal)?,
        thickness,
        ior,
    )
    .map_err(|e| PyValueError::new_err(format!("plate: {e}")))?;
    let scalar = match solver {
        "batch" => false,
        "scalar" => true,
        s => {
            return Err(PyValueError::new_err(format!(
                "solver: expected \"batch\" or \"scalar\", got \"{s}\""
            )))
        }
    };
    let rows = py.detach(|| plate_rows(&pl, eye, &pts, scalar));
    Ok(images_object(py, rows, statuses()))
}

/// One plate image per vertex, or none (with the status `snell
/// warp-points` gives): solved in place, in parallel, one row per vertex,
/// then the rows without an image dropped.
fn plate_rows(pl: &Plate, eye: DVec3, pts: &[DVec3], scalar: bool) -> Rows {
    let n = pts.len();
    let mut pos = vec![0.0; 3 * n];
    let mut dir = vec![0.0; 3 * n];
    let mut family = vec![0u8; n];
    let mut status = vec![0u8; n];
    // Vertex p's outcome into its row: its warped image, itself when it is
    // seen directly, or no image.
    let row =
        |p: DVec3, r: Result<(DVec3, DVec3), PlateStatus>, pos: &mut [f64], dir: &mut [f64], fam: &mut u8| {
            let (code, image) = match r {
                Ok(w) => (OK, Some((Family::Wall2, w))),
                Err(PlateStatus::InFront) => (OK, Some((Family::Direct, (p, (p - eye).normalize_or_zero())))),
                Err(PlateStatus::InsideGlass) => (PLATE_INSIDE, None),
                Err(PlateStatus::EyeNotInFront) => (EYE_NOT_IN_FRONT, None),
                Err(PlateStatus::NotConverged) => (NOT_CONVERGED, None),
            };
            if let Some((f, (position, direction))) = image {
                pos.copy_from_slice(&position.to_array());
                dir.copy_from_slice(&direction.to_array());
                *fam = family_code(f);
            }
            code
        };
    pos.par_chunks_mut(3 * CHUNK)
        .zip(dir.par_chunks_mut(3 * CHUNK))
        .zip(family.par_chunks_mut(CHUNK))
        .zip(status.par_chunks_mut(CHUNK))
        .zip(pts.par_chunks(CHUNK))
        .for_each(|((((pos, dir), family), status), ch)| {
            let mut solved = [Err(PlateStatus::NotConverged); 4];
            for (k, four) in ch.chunks(4).enumerate() {
                if scalar {
                    for (s, &p) in solved.iter_mut().zip(four) {
                        *s = pl.warp(eye, p).map(|im| (im.position, im.eye_dir));
                    }
                } else {
                    // Padding lanes repeat the first point (their answers are dropped).
                    let lanes: [DVec3; 4] = std::array::from_fn(|l| four.get(l).copied().unwrap_or(four[0]));
                    for (s, r) in solved.iter_mut().zip(pl.warp_lanes(eye, &lanes)) {
                        // The direction as `Plate::warp` derives it from the position.
                        *s = r.map(|w| (w, (w - eye).normalize()));
                    }
                }
                for (l, &p) in four.iter().enumerate() {
                    let i = 4 * k + l;
                    status[i] = if p.is_finite() {
                        row(
                            p,
                            solved[l],
                            &mut pos[3 * i..3 * i + 3],
                            &mut dir[3 * i..3 * i + 3],
                            &mut family[i],
                        )
                    } else {
                        NOT_FINITE
                    };
                }
            }
        });
    let refraction = |f: u8| {
        if FAMILY_ORDER[f as usize] == Family::Direct {
            0
        } else {
            2
        }
    };
    if status.iter().all(|&c| c == OK) {
        return Rows {
            positions: pos,
            directions: dir,
            refractions: family.iter().map(|&f| refraction(f)).collect(),
            parity: vec![1; n],
            counts: vec![1; n],
            family,
            status,
        };
    }
    // Some vertices have no image: keep the rows of those that have one.
    let keep: Vec<usize> = (0..n).filter(|&i| status[i] == OK).collect();
    let pick3 = |v: &[f64]| {
        keep.iter()
            .flat_map(|&i| [v[3 * i], v[3 * i + 1], v[3 * i + 2]])
            .collect()
    };
    Rows {
        positions: pick3(&pos),
        directions: pick3(&dir),
        family: keep.iter().map(|&i| family[i]).collect(),
        refractions: keep.iter().map(|&i| refraction(family[i])).collect(),
        parity: vec![1; keep.len()],
        counts: status.iter().map(|&c| u32::from(c == OK)).collect(),
        status,
    }
}

/// `plate_positions`' result: the positions and what happened to each vertex.
type Positions<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<i8>>);

/// Warp a mesh's vertices behind a glass plate: only the moved positions,
/// float32 as a mesh stores them (the warp renderer's call).
///
/// ``out[i]`` gets the warped position of ``vertices[i]``, or the vertex
/// itself when it is seen directly or has no image. The positions are those
/// of :func:`plate`'s default solver, rounded to float32.
///
/// Args:
///     vertices: (N, 3) points, metres (float32; other dtypes are converted).
///     eye, near_face_point, normal, thickness, ior: the plate, as :func:`plate`.
///     out: a C-contiguous float32 array of shape (N, 3) to write into
///         (default: a new one); reusing one saves its allocation.
///
/// Returns:
///     ``(positions, warped)``: the (N, 3) float32 positions (``out`` when
///     given) and an int8 array (N,): 1 warped, 0 seen directly, -1 no image
///     (inside the glass, or the eye not in front of the plate).
#[pyfunction]
#[pyo3(signature = (vertices, eye, near_face_point, normal, thickness, ior, out=None))]
#[allow(clippy::too_many_arguments)]
pub fn plate_positions<'py>(
    py: Python<'py>,
    vertices: PyArrayLikeDyn<'py, f32, AllowTypeChange>,
    eye: PyArrayLike1<'py, f64, AllowTypeChange>,
    near_face_point: PyArrayLike1<'py, f64, AllowTypeChange>,
    normal: PyArrayLike1<'py, f64, AllowTypeChange>,
    thickness: f64,
    ior: f64,
    out: Option<Bound<'py, PyArray2<f32>>>,
) -> PyResult<Positions<'py>> {
    use numpy::{PyArrayMethods, PyUntypedArrayMethods};
    let shape = vertices.shape().to_vec();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "vertices: expected an array of shape (N, 3), got {shape:?}"
        )));
    }
    let n = shape[0];
    let eye = vec3("eye", &eye)?;
    let pl = Plate::try_new(
        vec3("near_face_point", &near_face_point)?,
        vec3("normal", &normal)?,
        thickness,
        ior,
    )
    .map_err(|e| PyValueError::new_err(format!("plate: {e}")))?;
    let out = match out {
        Some(o) => {
            if o.shape() != [n, 3] {
                return Err(PyValueError::new_err(format!(
                    "out: expected shape ({n}, 3), got {:?}",
                    o.shape()
                )));
            }
            o
        }
        None => PyArray2::<f32>::zeros(py, [n, 3], false),
    };
    let flat = vertices
        .as_slice()
        .map_err(|_| PyValueError::new_err("vertices: expected a C-contiguous array"))?;
    let pts: &[[f32; 3]] = flat.as_chunks::<3>().0;
    let mut warped = vec![0i8; n];
    {
        let mut w = out.try_readwrite()?;
        let dst = w
            .as_slice_mut()
            .map_err(|_| PyValueError::new_err("out: expected a C-contiguous array"))?;
        let dst: &mut [[f32; 3]] = dst.as_chunks_mut::<3>().0;
        py.detach(|| {
            dst.par_chunks_mut(CHUNK)
                .zip(warped.par_chunks_mut(CHUNK))
                .zip(pts.par_chunks(CHUNK))
                .for_each(|((o, wc), p)| {
                    let mut class = [Ok(false); CHUNK];
                    let class = &mut class[..p.len()];
                    pl.warp_batch(eye, p, o, class);
                    for (w, c) in wc.iter_mut().zip(class.iter()) {
                        *w = match c {
                            Ok(true) => 1,
                            Ok(false) => 0,
                            Err(_) => -1,
                        };
                    }
                })
        });
    }
    Ok((out, array1(py, warped)))
}

/// Warp vertices seen through a thick glass tube (a hollow cylinder,
/// infinitely tall), exactly in 3-D.
///
/// A vertex can have several images (through the hollow, by total internal
/// reflection at the inner wall, through the wall only, or directly), or
/// none. The images, families and parities are those of ``snell warp-points``.
///
/// Args:
///     vertices: (N, 3) points, metres.
///     eye: the eye (3 numbers), outside the tube.
///     axis_point: a point on the axis.
///     axis_direction: the axis (normalised).
///     outer_radius, inner_radius: 0 < inner < outer, metres.
///     ior: the glass's index (>= 1; the surroundings have index 1).
///     method: ``"exact"`` (default) or ``"paper"`` (Mukai et al.'s C→B→A
///         approximation: one image at most).
///     solver: for ``"exact"``: ``"tables"`` (default: the warp renderer's
///         tabulated solver with a Newton polish, directions within 1e-12 of
///         the sampler's) or ``"sampler"`` (the robust sampler ``snell
///         warp-points`` runs: the same numbers bit for bit, two orders of
///         magnitude slower).
///     parity: find each image's parity (default True); without it
///         ``parity`` is 0 and the tables solver does less work.
///
/// Returns:
///     :class:`WarpImages`.
///
/// Raises:
///     ValueError: an invalid tube, method or solver, or arrays of the wrong shape.
#[pyfunction]
#[pyo3(signature = (vertices, eye, axis_point, axis_direction, outer_radius, inner_radius, ior, method="exact", solver="tables", parity=true))]
#[allow(clippy::too_many_arguments)]
pub fn hollow_cylinder(
    py: Python<'_>,
    vertices: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    eye: PyArrayLike1<'_, f64, AllowTypeChange>,
    axis_point: PyArrayLike1<'_, f64, AllowTypeChange>,
    axis_direction: PyArrayLike1<'_, f64, AllowTypeChange>,
    outer_radius: f64,
    inner_radius: f64,
    ior: f64,
    method: &str,
    solver: &str,
    parity: bool,
) -> PyResult<WarpImages> {
    let pts = points("vertices", &vertices)?;
    let eye = vec3("eye", &eye)?;
    if !eye.is_finite() {
        return Err(PyValueError::new_err("eye: expected finite coordinates"));
    }
    let c = HollowCylinder::try_new(
        vec3("axis_point", &axis_point)?,
        vec3("axis_direction", &axis_direction)?,
        outer_radius,
        inner_radius,
        ior,
    )
    .map_err(|e| PyValueError::new_err(format!("hollow_cylinder: {e}")))?;
    #[derive(Clone, Copy)]
    enum How {
        Tables,
        Sampler,
        Paper,
    }
    let how = match (method, solver) {
        ("exact", "tables") => How::Tables,
        ("exact", "sampler") => How::Sampler,
        ("paper", _) => How::Paper,
        ("exact", s) => {
            return Err(PyValueError::new_err(format!(
                "solver: expected \"tables\" or \"sampler\", got \"{s}\""
            )))
        }
        (m, _) => {
            return Err(PyValueError::new_err(format!(
                "method: expected \"exact\" or \"paper\", got \"{m}\""
            )))
        }
    };
    let mut texts = statuses();
    let eye_not_outside = texts.len() as u8;
    texts.push(EYE_NOT_OUTSIDE_TEXT.to_string());
    let outcome = |r: Result<&[CylImage], CylStatus>, out: &mut Flat| match r {
        Ok(ims) => out.push(
            if ims.is_empty() { NO_IMAGE } else { OK },
            ims.iter().map(Image::from),
        ),
        Err(CylStatus::InsideGlass) => out.push(TUBE_INSIDE, []),
        Err(CylStatus::EyeNotOutside) => out.push(eye_not_outside, []),
    };
    let flat = py.detach(|| match how {
        How::Tables => {
            let finite: Vec<DVec3> = pts.iter().copied().filter(|p| p.is_finite()).collect();
            match CylinderWarper::for_targets(c, eye, &finite) {
                Err(status) => {
                    let mut f = Flat::default();
                    for p in &pts {
                        if p.is_finite() {
                            outcome(Err(status), &mut f);
                        } else {
                            f.push(NOT_FINITE, []);
                        }
                    }
                    f
                }
                Ok(w) => solve(&pts, |ch, out| {
                    if ch.iter().all(|p| p.is_finite()) {
                        w.images_batch(ch, parity, |_, r| outcome(r, out));
                    } else {
                        for &p in ch {
                            if p.is_finite() {
                                w.images_batch(&[p], parity, |_, r| outcome(r, out));
                            } else {
                                out.push(NOT_FINITE, []);
                            }
                        }
                    }
                }),
            }
        }
        How::Sampler | How::Paper => solve(&pts, |ch, out| {
            for &p in ch {
                if !p.is_finite() {
                    out.push(NOT_FINITE, []);
                    continue;
                }
                match how {
                    How::Paper => {
                        let r = approx_tube_image(&c, eye, p).map(|o| o.into_iter().collect::<Vec<_>>());
                        outcome(r.as_deref().map_err(|e| *e), out);
                    }
                    _ => {
                        let r = c.images(eye, p);
                        outcome(r.as_deref().map_err(|e| *e), out);
                    }
                }
            }
        }),
    });
    let mut rows = py.detach(|| Rows::from_flat(flat));
    if !parity {
        // The sampler and the paper's method find it anyway: drop it, as asked.
        rows.parity.fill(0);
    }
    Ok(images_object(py, rows, texts))
}
