//! `Mesh`: a validated triangle mesh shared by detectors.

use crate::convert::{pairs_array, points, points_array, rows_array, triangles, triples};
use crate::errors::guard;
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
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
        rows_array(
            py,
            self.inner.triangles().iter().map(|t| t.map(|v| v as i64)),
        )
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
