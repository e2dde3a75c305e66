//! `Mesh`: a validated triangle mesh shared by detectors.

use crate::contacts::{impacts_dict, proximity_dict};
use crate::convert::{pairs_array, points, points_array, rows_array, triangles, triples};
use crate::errors::guard;
use crate::stats::stats_dict;
use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use selfcd::{DVec3, Mesh};
use std::sync::Arc;

/// A triangle mesh: rest positions, faces and topology, validated once.
#[pyclass(name = "Mesh", module = "selfcd._core", frozen)]
pub struct PyMesh {
    /// The engine mesh, shared with every detector built on it.
    pub inner: Arc<Mesh>,
    /// False when the vertices were screened and all lie at distinct positions.
    may_repeat: bool,
}

impl PyMesh {
    /// A wrapper around an engine mesh that is already validated (not
    /// screened: `may_repeat_positions` is true).
    pub fn wrap(inner: Arc<Mesh>) -> PyMesh {
        PyMesh {
            inner,
            may_repeat: true,
        }
    }
}

#[pymethods]
impl PyMesh {
    /// Validates an (n,3) float64 vertex array and an (m,3) int64 face array.
    /// With `screen_positions`, also screens the vertices for repeated
    /// positions (see `may_repeat_positions`).
    #[new]
    #[pyo3(signature = (vertices, faces, screen_positions=false))]
    fn new(
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
        screen_positions: bool,
    ) -> PyResult<Self> {
        let (v, f) = (triples(&vertices, "vertices")?, triangles(&faces)?);
        let built = py.detach(|| guard("Mesh()", || Mesh::screened(v, f, screen_positions)));
        let (mesh, may_repeat) = built?;
        Ok(PyMesh {
            inner: Arc::new(mesh),
            may_repeat,
        })
    }

    /// False only when the constructor screened the vertices
    /// (`screen_positions=True`) and found every position distinct, so that
    /// welding would merge nothing; true otherwise (some positions may repeat:
    /// the exact grouping, `position_groups`, decides).
    #[getter]
    fn may_repeat_positions(&self) -> bool {
        self.may_repeat
    }

    /// Rest positions, (n,3) float64 (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        points_array(py, self.inner.rest())
    }

    /// Faces, (m,3) int64 (a copy).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        rows_array(py, self.inner.triangles(), |t| t.map(i64::from))
    }

    /// Unique undirected edges, (e,2) int64, smaller vertex first; edge ids index this array.
    #[getter]
    fn edges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        pairs_array(py, &self.inner.topology().edges)
    }

    /// Number of vertices.
    #[getter]
    fn n_vertices(&self) -> usize {
        self.inner.n_vertices()
    }

    /// Number of faces.
    #[getter]
    fn n_faces(&self) -> usize {
        self.inner.n_triangles()
    }

    /// Mean rest edge length (the sensor's length unit).
    #[getter]
    fn mean_edge_length(&self) -> f64 {
        self.inner.mean_edge_length()
    }

    fn __repr__(&self) -> String {
        format!(
            "Mesh(n_vertices={}, n_faces={})",
            self.inner.n_vertices(),
            self.inner.n_triangles()
        )
    }
}

/// Groups of equal positions (see `selfcd::weld`): (group id of every vertex,
/// first vertex of every group), both int64, groups in first-occurrence order.
#[pyfunction]
pub fn position_groups<'py>(
    py: Python<'py>,
    positions: PyReadonlyArray2<'_, f64>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let p = points(&positions, "vertices")?;
    let g = py.detach(|| selfcd::weld::position_groups(&p));
    let ids = |v: &[u32]| PyArray1::from_vec(py, v.iter().map(|&x| x as i64).collect()).into_any();
    Ok((ids(&g.group), ids(&g.first)))
}

/// Runs `query` on the mesh at `positions` (None: at its rest shape, not
/// copied) without the GIL, engine errors raised as `what`'s.
fn at_positions<T: Send>(
    py: Python<'_>,
    mesh: &PyMesh,
    positions: Option<PyReadonlyArray2<'_, f64>>,
    what: &str,
    query: impl FnOnce(&Arc<Mesh>, &[DVec3]) -> selfcd::Result<T> + Send,
) -> PyResult<T> {
    let p = positions.map(|p| points(&p, "positions")).transpose()?;
    let m = mesh.inner.clone();
    py.detach(|| guard(what, || query(&m, p.as_deref().unwrap_or(m.rest()))))
}

/// One-shot exact query: intersecting non-adjacent face pairs of `mesh` at
/// `positions` (None: at its rest shape).
#[pyfunction]
#[pyo3(signature = (mesh, positions=None))]
pub fn self_intersections<'py>(
    py: Python<'py>,
    mesh: &PyMesh,
    positions: Option<PyReadonlyArray2<'_, f64>>,
) -> PyResult<Bound<'py, PyAny>> {
    let pairs = at_positions(py, mesh, positions, "self_intersections", |m, at| {
        selfcd::self_intersections(m, at)
    })?;
    pairs_array(py, &pairs)
}

/// The one-shot query of [`self_intersections`] with what it did: the pairs
/// and a stats dict with a `Detector`'s `last_stats` keys (`traverse_time`
/// the whole query, hierarchy included). `positions` as there.
#[pyfunction]
#[pyo3(signature = (mesh, positions=None))]
pub fn one_shot_detection<'py>(
    py: Python<'py>,
    mesh: &PyMesh,
    positions: Option<PyReadonlyArray2<'_, f64>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let det = at_positions(py, mesh, positions, "one_shot_detection", |m, at| {
        selfcd::detect::one_shot_detection(m, at)
    })?;
    Ok((pairs_array(py, &det.pairs)?, stats_dict(py, &det.stats)?))
}

/// Early-exit query: some intersecting non-adjacent face pair `(i, j)`, i < j,
/// or None; the one-shot query stopping at the first one found. `positions`
/// as in [`self_intersections`].
#[pyfunction]
#[pyo3(signature = (mesh, positions=None))]
pub fn first_intersection(
    py: Python<'_>,
    mesh: &PyMesh,
    positions: Option<PyReadonlyArray2<'_, f64>>,
) -> PyResult<Option<(u32, u32)>> {
    let pair = at_positions(py, mesh, positions, "first_intersection", |m, at| {
        selfcd::detect::first::first_intersection(m, at)
    })?;
    Ok(pair.map(|[a, b]| (a, b)))
}

/// Continuous query: every vertex-triangle and edge-edge pair that comes within
/// `thickness` while the mesh moves linearly from `x0` to `x1`, as a dict of
/// (k,2) int64 pairs and (k,) float64 conservative times of impact in [0, 1]:
/// the one-shot query (`selfcd::detect::continuous::continuous_impacts`).
#[pyfunction]
#[pyo3(signature = (mesh, x0, x1, thickness=0.0))]
pub fn continuous_impacts<'py>(
    py: Python<'py>,
    mesh: &PyMesh,
    x0: PyReadonlyArray2<'_, f64>,
    x1: PyReadonlyArray2<'_, f64>,
    thickness: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let (a, b) = (points(&x0, "x0")?, points(&x1, "x1")?);
    let m = mesh.inner.clone();
    let found = py.detach(|| {
        guard("continuous_impacts", || {
            selfcd::detect::continuous::continuous_impacts(&m, &a, &b, thickness).map(|(i, _)| i)
        })
    })?;
    impacts_dict(py, &found)
}

/// One-shot proximity query: every vertex-triangle and edge-edge pair (not
/// sharing a vertex) closer than `thickness` (> 0) at `positions`, as the dict
/// of a `Detector`'s `last_proximity` (the same contacts, to the bit); at most
/// `max_contacts` of them (default that of a `Detector`), else an error.
#[pyfunction]
#[pyo3(signature = (mesh, positions, thickness, max_contacts=None))]
pub fn proximity_contacts<'py>(
    py: Python<'py>,
    mesh: &PyMesh,
    positions: PyReadonlyArray2<'_, f64>,
    thickness: f64,
    max_contacts: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let x = points(&positions, "positions")?;
    let m = mesh.inner.clone();
    let max = max_contacts.unwrap_or(selfcd::detect::narrow::DEFAULT_MAX_CONTACTS);
    let found = py.detach(|| {
        guard("proximity_contacts", || {
            selfcd::detect::proximity_contacts(&m, &x, thickness, max).map(|(p, _)| p)
        })
    })?;
    proximity_dict(py, &found, &m)
}
