//! `SelfQueries`: the coherent intersection, proximity and continuous queries
//! of one mesh over a sequence of frames (what the simulator calls), with the
//! candidate set kept between calls.

use crate::contacts::{impacts_dict, proximity_dict};
use crate::convert::{pairs_array, points};
use crate::errors::guard;
use crate::mesh::PyMesh;
use crate::stats::stats_dict;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use selfcd::detect::coherent::SelfQueries;
use selfcd::FrameStats;
use std::sync::{Arc, Mutex, MutexGuard};

/// The coherent self queries of one mesh; see `selfcd::detect::coherent`.
#[pyclass(name = "SelfQueries", module = "selfcd._core", frozen)]
pub struct PySelfQueries {
    inner: Mutex<(SelfQueries, FrameStats)>,
    mesh: Arc<selfcd::Mesh>,
    skin: f64,
}

impl PySelfQueries {
    fn lock(&self) -> PyResult<MutexGuard<'_, (SelfQueries, FrameStats)>> {
        self.inner
            .lock()
            .map_err(|_| PyRuntimeError::new_err("queries are unusable after an internal error"))
    }

    /// Runs `f` on the queries without the GIL, with fresh stats kept as the last call's.
    fn run<T: Send>(
        &self,
        py: Python<'_>,
        what: &str,
        f: impl FnOnce(&mut SelfQueries, &mut FrameStats) -> selfcd::Result<T> + Send,
    ) -> PyResult<T> {
        py.detach(|| {
            let mut g = self.lock()?;
            let (q, s) = &mut *g;
            *s = FrameStats::default();
            guard(what, || f(q, s))
        })
    }
}

#[pymethods]
impl PySelfQueries {
    /// Builds the hierarchy of `mesh`; candidate sets reach `skin` (> 0,
    /// finite; default a quarter of the mean edge length) beyond the distance asked for.
    #[new]
    #[pyo3(signature = (mesh, skin = None))]
    fn new(py: Python<'_>, mesh: &PyMesh, skin: Option<f64>) -> PyResult<Self> {
        let arc = mesh.inner.clone();
        let skin = skin.unwrap_or_else(|| SelfQueries::default_skin(&arc));
        let q = py.detach(|| guard("SelfQueries()", || SelfQueries::new(arc, skin)))?;
        Ok(PySelfQueries {
            inner: Mutex::new((q, FrameStats::default())),
            mesh: mesh.inner.clone(),
            skin,
        })
    }

    /// Intersecting non-adjacent face pairs at `positions`, (k,2) int64, sorted, i<j.
    #[pyo3(signature = (positions, cones = true))]
    fn intersections<'py>(
        &self,
        py: Python<'py>,
        positions: PyReadonlyArray2<'_, f64>,
        cones: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let x = points(&positions, "positions")?;
        let pairs = self.run(py, "SelfQueries.intersections", |q, s| {
            q.intersections(&x, cones, s)
        })?;
        pairs_array(py, &pairs)
    }

    /// Vertex-triangle and edge-edge pairs closer than `thickness` at `positions`.
    fn proximity<'py>(
        &self,
        py: Python<'py>,
        positions: PyReadonlyArray2<'_, f64>,
        thickness: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let x = points(&positions, "positions")?;
        let found = self.run(py, "SelfQueries.proximity", |q, s| {
            q.proximity(&x, thickness, s)
        })?;
        proximity_dict(py, &found, &self.mesh)
    }

    /// Element pairs that come within `thickness` during the linear step `x0 -> x1`.
    fn continuous<'py>(
        &self,
        py: Python<'py>,
        x0: PyReadonlyArray2<'_, f64>,
        x1: PyReadonlyArray2<'_, f64>,
        thickness: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (a, b) = (points(&x0, "x0")?, points(&x1, "x1")?);
        let found = self.run(py, "SelfQueries.continuous", |q, s| {
            q.continuous(&a, &b, thickness, s)
        })?;
        impacts_dict(py, &found)
    }

    /// The skin candidate sets reach beyond the distance asked for.
    #[getter]
    fn skin(&self) -> f64 {
        self.skin
    }

    /// FrameStats of the last call as a dict (zeros before the first call).
    #[getter]
    fn last_stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        stats_dict(py, &self.lock()?.1)
    }
}
