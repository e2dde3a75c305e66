//! Runs several methods over the same recorded frames (engine `detect::compare`).

use crate::convert::pairs_array;
use crate::detector::parse_method;
use crate::errors::guard;
use crate::mesh::PyMesh;
use crate::stats::stats_columns;
use numpy::{PyArray1, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use selfcd::detect::compare;
use selfcd::{DetectorOptions, Method};

/// Methods by name, or every method when `names` is None.
fn parse_methods(names: Option<Vec<String>>) -> PyResult<Vec<Method>> {
    match names {
        None => Ok(Method::ALL.to_vec()),
        Some(v) => v.iter().map(|n| parse_method(n)).collect(),
    }
}

/// Runs each method over `frames` ((f,n,3) float64) in order and counts, per
/// frame, the contacts it missed against the exact reference. Returns one dict
/// per method: `method`, `stats` (a dict of per-frame arrays, see
/// `Detector.last_stats`), `missed` and `spurious` (int64 per frame).
/// `progress`, if given, is called with the number of (method, frame) runs done
/// (0 during the reference pass, which runs first).
#[pyfunction]
#[pyo3(signature = (mesh, frames, methods = None, thickness = 0.0, progress = None))]
pub fn compare_methods<'py>(
    py: Python<'py>,
    mesh: &PyMesh,
    frames: PyReadonlyArray3<'_, f64>,
    methods: Option<Vec<String>>,
    thickness: f64,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyList>> {
    let list = parse_methods(methods)?;
    let opts = DetectorOptions {
        thickness,
        ..Default::default()
    };
    opts.validate().map_err(crate::errors::engine_err)?;
    let fr = crate::convert::frames(&frames)?;
    let m = mesh.inner.clone();
    let mut callback_err: Option<PyErr> = None;
    let runs = py.detach(|| {
        guard("compare_methods", || {
            compare::compare_methods_until(&m, &fr, &list, &opts, |done| {
                report(&progress, done, &mut callback_err)
            })
        })
    });
    if let Some(e) = callback_err {
        return Err(e);
    }
    let runs = runs?;
    let out = PyList::empty(py);
    for run in runs {
        let d = PyDict::new(py);
        d.set_item("method", run.method.name())?;
        let stats: Vec<_> = run.frames.iter().map(|f| &f.stats).collect();
        d.set_item("stats", stats_columns(py, &stats)?)?;
        d.set_item(
            "missed",
            PyArray1::from_vec(py, run.frames.iter().map(|f| f.missed as i64).collect()),
        )?;
        d.set_item(
            "spurious",
            PyArray1::from_vec(py, run.frames.iter().map(|f| f.spurious as i64).collect()),
        )?;
        out.append(d)?;
    }
    Ok(out)
}

/// Between steps of a long call: re-takes the GIL, runs Python's signal
/// handlers (Ctrl-C raises KeyboardInterrupt here) and then the progress
/// callback, if any; keeps the first error. Returns [`selfcd::Error::Interrupted`]
/// once there is one, so an engine loop stops at once (the caller raises `err`).
pub fn report(cb: &Option<Py<PyAny>>, done: usize, err: &mut Option<PyErr>) -> selfcd::Result<()> {
    if err.is_none() {
        let r = Python::attach(|py| {
            py.check_signals()?;
            cb.as_ref()
                .map_or(Ok(()), |cb| cb.call1(py, (done,)).map(|_| ()))
        });
        *err = r.err();
    }
    match err {
        Some(_) => Err(selfcd::Error::Interrupted),
        None => Ok(()),
    }
}

/// Exact contacts of every frame: a list of (k,2) int64 arrays.
#[pyfunction]
pub fn reference_pairs<'py>(
    py: Python<'py>,
    mesh: &PyMesh,
    frames: PyReadonlyArray3<'_, f64>,
) -> PyResult<Bound<'py, PyList>> {
    let fr = crate::convert::frames(&frames)?;
    let m = mesh.inner.clone();
    let all = py.detach(|| guard("reference_pairs", || compare::reference_pairs(&m, &fr)))?;
    let out = PyList::empty(py);
    for pairs in &all {
        out.append(pairs_array(py, pairs)?)?;
    }
    Ok(out)
}
