//! What viewers look at inside the engine: the BVH's node boxes and normal
//! cones at a chosen depth, and the particle sensor's default parameters.

use crate::convert::points;
use crate::errors::guard;
use crate::mesh::PyMesh;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use selfcd::bvh::{build::build, Bvh};
use selfcd::sensor::SensorParams;
use std::sync::{Arc, Mutex, MutexGuard};

/// The bottom-up BVH of one mesh (the one the BVH detectors build), refitted on demand.
#[pyclass(name = "Hierarchy", module = "selfcd._core", frozen)]
pub struct PyHierarchy {
    bvh: Mutex<Bvh>,
    mesh: Arc<selfcd::Mesh>,
    /// Depth of every node below the root (root: 0).
    depths: Vec<u32>,
}

impl PyHierarchy {
    fn lock(&self) -> PyResult<MutexGuard<'_, Bvh>> {
        self.bvh
            .lock()
            .map_err(|_| PyRuntimeError::new_err("hierarchy is unusable after an internal error"))
    }

    /// Ids of the cut at `depth`: nodes `depth` levels below the root, and
    /// leaves above that level (so that the cut covers every triangle once).
    fn cut(&self, bvh: &Bvh, depth: u32) -> Vec<u32> {
        (0..bvh.n_nodes() as u32)
            .rev()
            .filter(|&n| {
                let d = self.depths[n as usize];
                d == depth || (d < depth && bvh.is_leaf(n))
            })
            .collect()
    }
}

#[pymethods]
impl PyHierarchy {
    /// Builds the hierarchy of `mesh` on its rest shape.
    #[new]
    fn new(py: Python<'_>, mesh: &PyMesh) -> PyResult<Self> {
        let m = mesh.inner.clone();
        let bvh = py.detach(|| guard("Hierarchy()", || Ok(build(&m))))?;
        let mut depths = vec![0u32; bvh.n_nodes()];
        // Parents have larger ids than their children: one pass from the root down.
        for n in (bvh.n_leaves as u32..bvh.n_nodes() as u32).rev() {
            for c in bvh.children_of(n) {
                depths[c as usize] = depths[n as usize] + 1;
            }
        }
        Ok(PyHierarchy {
            bvh: Mutex::new(bvh),
            mesh: mesh.inner.clone(),
            depths,
        })
    }

    /// Refits every box and cone to (n,3) float64 `positions`.
    fn refit(&self, py: Python<'_>, positions: PyReadonlyArray2<'_, f64>) -> PyResult<()> {
        let p = points(&positions, "positions")?;
        if p.len() != self.mesh.n_vertices() {
            return Err(PyValueError::new_err(format!(
                "positions has {} rows, the mesh has {} vertices",
                p.len(),
                self.mesh.n_vertices()
            )));
        }
        py.detach(|| -> PyResult<()> {
            let mut bvh = self.lock()?;
            guard("Hierarchy.refit", || {
                bvh.refit(&self.mesh, &p);
                Ok(())
            })
        })
    }

    /// Depth of the deepest leaf (the root is depth 0).
    #[getter]
    fn max_depth(&self) -> u32 {
        self.depths.iter().copied().max().unwrap_or(0)
    }

    /// Number of nodes (2 * triangles - 1).
    #[getter]
    fn n_nodes(&self) -> usize {
        self.depths.len()
    }

    /// Boxes of the cut at `depth` (nodes that deep, and shallower leaves), (k,2,3) float64: [min, max].
    fn boxes<'py>(&self, py: Python<'py>, depth: u32) -> PyResult<Bound<'py, PyAny>> {
        let bvh = self.lock()?;
        let cut = self.cut(&bvh, depth);
        let flat: Vec<f64> = cut
            .iter()
            .flat_map(|&n| {
                let b = &bvh.boxes[n as usize];
                b.min.to_array().into_iter().chain(b.max.to_array())
            })
            .collect();
        Ok(PyArray1::from_vec(py, flat)
            .reshape([cut.len(), 2, 3])?
            .into_any())
    }

    /// For each node of the cut at `depth` (same order as `boxes`): is its normal
    /// cone under 90 degrees, so that the cone test alone culls its self-test, (k,) bool.
    fn positive_cones<'py>(&self, py: Python<'py>, depth: u32) -> PyResult<Bound<'py, PyAny>> {
        let bvh = self.lock()?;
        let flags = self
            .cut(&bvh, depth)
            .iter()
            .map(|&n| bvh.cones[n as usize].is_positive())
            .collect();
        Ok(PyArray1::from_vec(py, flags).into_any())
    }
}

/// Default values of the particle sensor's options (`sensor_options()`), as a dict.
#[pyfunction]
pub fn sensor_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let p = SensorParams::default();
    let d = PyDict::new(py);
    d.set_item("count", p.count)?;
    d.set_item("max_count", p.max_count)?;
    d.set_item("a", p.a)?;
    d.set_item("b", p.b)?;
    d.set_item("n_min", p.n_min)?;
    d.set_item("n_max", p.n_max)?;
    d.set_item("epsilon", p.epsilon)?;
    d.set_item("step_gain", p.step_gain)?;
    d.set_item("max_step", p.max_step)?;
    d.set_item("tolerance", p.tolerance)?;
    d.set_item("inner", p.inner.name())?;
    d.set_item("refit_every_frame", p.refit_every_frame)?;
    Ok(d)
}
