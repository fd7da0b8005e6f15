//! `snell.trace_path`: one ray through the scene's nested solids, its
//! boundary events as the nested rule decides them (false hits skipped).
use crate::errors::lib_err;
use crate::scene::Scene;
use glam::{DVec3, Vec3A};
use numpy::AllowTypeChange;
use numpy::PyArrayLike1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use snell::counters::Counters;
use snell::dielectric::NestedStrategy;
use snell::integrator::{refraction_path, Tracer};

fn vec3(name: &str, a: &PyArrayLike1<'_, f64, AllowTypeChange>) -> PyResult<DVec3> {
    match a.as_slice() {
        Ok([x, y, z]) if x.is_finite() && y.is_finite() && z.is_finite() => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(PyValueError::new_err(format!(
            "{name}: expected three finite numbers"
        ))),
    }
}

/// Trace one ray through the scene's dielectric solids.
///
/// The ray refracts (or reflects totally) at every true boundary, as the
/// nested rule decides it: surfaces of a solid that a higher-priority solid
/// holds are false hits and skipped. It stops when it leaves the scene, hits
/// a surface that is not a dielectric boundary, or after ``max_events``.
///
/// Args:
///     scene: a :class:`Scene`.
///     origin: start point (3 numbers, scene units).
///     direction: direction (3 numbers, need not be unit length).
///     inside: names of the solids the origin is inside (default None: found
///         by point-in-solid tests).
///     nested: ``"filter"`` (default), ``"recast"``, ``"toggle"`` or ``"off"``.
///     max_events: most boundary events to follow (default 64).
///
/// Returns:
///     A dict: ``events``, a list of dicts (``point`` [x, y, z], ``n1`` the
///     index the ray arrives in, ``n2`` the index beyond, ``entering`` whether
///     the ray enters the solid it hits, ``solid`` its name, ``tir`` total
///     internal reflection, ``direction`` the ray leaving the event, ``inside``
///     the solids the leaving ray is inside); ``inside`` (the final interior
///     list, solid names); ``escaped`` (the ray left the scene);
///     ``false_hits`` (surfaces skipped on the way).
#[pyfunction]
#[pyo3(signature = (scene, origin, direction, inside=None, nested="filter", max_events=64))]
pub fn trace_path<'py>(
    py: Python<'py>,
    scene: &Bound<'py, Scene>,
    origin: PyArrayLike1<'py, f64, AllowTypeChange>,
    direction: PyArrayLike1<'py, f64, AllowTypeChange>,
    inside: Option<Vec<String>>,
    nested: &str,
    max_events: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let s = &scene.get().scene;
    let o = vec3("origin", &origin)?;
    let d = vec3("direction", &direction)?;
    if d.length() == 0.0 {
        return Err(PyValueError::new_err("direction: expected a non-zero vector"));
    }
    let strategy: NestedStrategy = nested
        .parse()
        .map_err(|e: String| PyValueError::new_err(format!("nested: {e}")))?;
    let start: Vec<u32> = match inside {
        None => s.solids_containing(o),
        Some(names) => names
            .iter()
            .map(|n| {
                s.solids
                    .iter()
                    .position(|x| &x.name == n)
                    .map(|i| i as u32)
                    .ok_or_else(|| {
                        PyValueError::new_err(format!("inside: no dielectric solid named \"{n}\""))
                    })
            })
            .collect::<PyResult<_>>()?,
    };
    let mut counters = Counters::default();
    let path = py
        .detach(|| {
            refraction_path(
                Tracer::new(s).with_strategy(strategy),
                o.as_vec3a(),
                d.as_vec3a(),
                &start,
                max_events,
                &mut counters,
            )
        })
        .map_err(|e| lib_err(py, e))?;
    let names =
        |list: &[u32]| -> Vec<String> { list.iter().map(|&i| s.solids[i as usize].name.clone()).collect() };
    let xyz = |v: Vec3A| [v.x, v.y, v.z];
    let events = pyo3::types::PyList::empty(py);
    // The interior list before each event: the start's, then the previous event's.
    let mut before: &[u32] = &start;
    for e in &path.events {
        let solid = s.solid_by_geom.get(e.geom as usize).copied().flatten();
        let ev = PyDict::new(py);
        ev.set_item("point", xyz(e.point))?;
        ev.set_item("n1", e.n1)?;
        ev.set_item("n2", e.n2)?;
        ev.set_item("entering", solid.is_some_and(|k| !before.contains(&k)))?;
        ev.set_item("solid", solid.map(|k| s.solids[k as usize].name.clone()))?;
        ev.set_item("tir", e.tir)?;
        ev.set_item("direction", xyz(e.next_dir))?;
        ev.set_item("inside", names(&e.list_after))?;
        events.append(ev)?;
        before = &e.list_after;
    }
    let out = PyDict::new(py);
    out.set_item("events", events)?;
    out.set_item("inside", names(&path.final_list))?;
    out.set_item("escaped", path.escaped)?;
    out.set_item("false_hits", counters.false_hits)?;
    Ok(out)
}
