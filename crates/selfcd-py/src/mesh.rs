//! `Mesh`: a validated triangle mesh shared by detectors.

use crate::contacts::impacts_dict;
use crate::convert::{pairs_array, points, points_array, rows_array, triangles, triples};
use crate::errors::guard;
use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use selfcd::Mesh;
use std::sync::Arc;

/// A triangle mesh: rest positions, faces and topology, validated once.
#[pyclass(name = "Mesh", module = "selfcd._core", frozen)]
pub struct PyMesh {
    /// The engine mesh, shared with every detector built on it.
    pub inner: Arc<Mesh>,
}

#[pymethods]
impl PyMesh {
    /// Validates an (n,3) float64 vertex array and an (m,3) int64 face array.
    #[new]
    fn new(
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
    ) -> PyResult<Self> {
        let v = triples(&vertices, "vertices")?;
        let f = triangles(&faces)?;
        let mesh = py.detach(|| guard("Mesh()", || Mesh::new(v, f)))?;
        Ok(PyMesh {
            inner: Arc::new(mesh),
        })
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

/// One-shot exact query: intersecting non-adjacent face pairs of `mesh` at `positions`.
#[pyfunction]
pub fn self_intersections<'py>(
    py: Python<'py>,
    mesh: &PyMesh,
    positions: PyReadonlyArray2<'_, f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = points(&positions, "positions")?;
    let m = mesh.inner.clone();
    let pairs = py.detach(|| guard("self_intersections", || selfcd::self_intersections(&m, &p)))?;
    pairs_array(py, &pairs)
}

/// Early-exit query: some intersecting non-adjacent face pair `(i, j)`, i < j,
/// or None; stops the traversal at the first one found.
#[pyfunction]
pub fn first_intersection(
    mesh: &PyMesh,
    positions: PyReadonlyArray2<'_, f64>,
) -> PyResult<Option<(u32, u32)>> {
    let p = points(&positions, "positions")?;
    let m = mesh.inner.clone();
    let py = positions.py();
    let pair = py.detach(|| {
        guard("first_intersection", || {
            selfcd::detect::first::first_intersection(&m, &p)
        })
    })?;
    Ok(pair.map(|[a, b]| (a, b)))
}

/// Continuous query: every vertex-triangle and edge-edge pair that comes within
/// `thickness` while the mesh moves linearly from `x0` to `x1`, as a dict of
/// (k,2) int64 pairs and (k,) float64 conservative times of impact in [0, 1].
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
            let mut det = selfcd::detect::hierarchy::BvhDetector::new(m, selfcd::Method::Bvh, 0.0);
            det.continuous(&a, &b, thickness)
        })
    })?;
    impacts_dict(py, &found)
}
