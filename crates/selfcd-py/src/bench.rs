//! The scaling benchmark (engine `bench::scaling`), so the CLI measures exactly
//! what the engine's example binary measures.

use crate::detector::parse_method;
use crate::errors::{engine_err, guard};
use crate::stats::stats_dict;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use selfcd::bench::{scaling_until, ScalingRow};
use selfcd::scene::BenchState;

/// Names of the benchmark's states, in report order.
#[pyfunction]
pub fn bench_states() -> Vec<&'static str> {
    BenchState::ALL.iter().map(|s| s.name()).collect()
}

/// Measures every (size, state, method): `reps` detections of one frame after a
/// warm-up, medians reported. Returns one dict per row; `progress`, if given, is
/// called after each row with the number of rows done.
#[pyfunction]
#[pyo3(signature = (sizes, states, methods, reps = 3, progress = None))]
pub fn bench_scaling<'py>(
    py: Python<'py>,
    sizes: Vec<usize>,
    states: Vec<String>,
    methods: Vec<String>,
    reps: usize,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyList>> {
    let states: Vec<BenchState> = states
        .iter()
        .map(|s| s.parse().map_err(engine_err))
        .collect::<PyResult<_>>()?;
    let methods = methods
        .iter()
        .map(|m| parse_method(m))
        .collect::<PyResult<Vec<_>>>()?;
    let mut done = 0usize;
    let mut cb_err: Option<PyErr> = None;
    let rows = py.detach(|| {
        guard("bench_scaling", || {
            scaling_until(&sizes, &states, &methods, reps, |_| {
                done += 1;
                crate::compare::report(&progress, done, &mut cb_err)
            })
        })
    });
    if let Some(e) = cb_err {
        return Err(e);
    }
    let rows = rows?;
    let out = PyList::empty(py);
    for r in &rows {
        out.append(row_dict(py, r)?)?;
    }
    Ok(out)
}

/// One row as a dict; `stats` holds the FrameStats of the last repetition.
fn row_dict<'py>(py: Python<'py>, r: &ScalingRow) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("triangles", r.triangles)?;
    d.set_item("state", r.state.name())?;
    d.set_item("method", r.method.name())?;
    d.set_item("build_time", r.build_time)?;
    d.set_item("refit_time", r.refit_time)?;
    d.set_item("traverse_time", r.traverse_time)?;
    d.set_item("bvh_bytes_per_triangle", r.bvh_bytes_per_triangle)?;
    d.set_item("stats", stats_dict(py, &r.stats)?)?;
    Ok(d)
}
