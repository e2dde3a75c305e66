//! `Detector`: one method on one mesh, keeping its BVH (and sensor) between calls.

use crate::contacts::proximity_dict;
use crate::convert::{pairs_array, points, points_array};
use crate::errors::{engine_err, guard};
use crate::mesh::PyMesh;
use crate::stats::stats_dict;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::{PyRuntimeError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use selfcd::sensor::SensorParams;
use selfcd::{Detection, Detector, DetectorOptions, Method};
use std::sync::{Arc, Mutex, MutexGuard};

/// Parses a method name through the engine's `FromStr` (so new methods appear by themselves).
pub fn parse_method(name: &str) -> PyResult<Method> {
    name.parse::<Method>().map_err(engine_err)
}

/// Builds the engine options from the thickness and the method's keyword options.
/// Sensor parameters (`SensorParams` fields) are accepted by `sensor-gated` only.
pub fn build_options(
    method: Method,
    thickness: f64,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<DetectorOptions> {
    let mut opts = DetectorOptions {
        thickness,
        ..Default::default()
    };
    if let Some(d) = options {
        for (key, value) in d.iter() {
            let key: String = key.extract()?;
            if method != Method::SensorGated {
                return Err(PyTypeError::new_err(format!(
                    "unknown option {key:?} for method {:?}: it takes no options besides thickness",
                    method.name()
                )));
            }
            set_sensor_option(&mut opts.sensor, &key, &value)?;
        }
    }
    opts.validate().map_err(engine_err)?;
    Ok(opts)
}

/// Names of the particle sensor's options (fields of the engine's `SensorParams`).
pub const SENSOR_OPTIONS: [&str; 12] = [
    "count",
    "max_count",
    "a",
    "b",
    "n_min",
    "n_max",
    "epsilon",
    "step_gain",
    "max_step",
    "tolerance",
    "inner",
    "refit_every_frame",
];

/// Sets one sensor parameter from a Python value; wrong names or types raise TypeError.
fn set_sensor_option(p: &mut SensorParams, key: &str, v: &Bound<'_, PyAny>) -> PyResult<()> {
    let bad = |what: &str| PyTypeError::new_err(format!("sensor option {key:?} must be {what}"));
    match key {
        "count" => p.count = v.extract().map_err(|_| bad("a non-negative integer"))?,
        "max_count" => p.max_count = v.extract().map_err(|_| bad("a non-negative integer"))?,
        "a" => p.a = v.extract().map_err(|_| bad("a number"))?,
        "b" => p.b = v.extract().map_err(|_| bad("a number"))?,
        "n_min" => p.n_min = v.extract().map_err(|_| bad("a non-negative integer"))?,
        "n_max" => p.n_max = v.extract().map_err(|_| bad("a non-negative integer"))?,
        "epsilon" => p.epsilon = v.extract().map_err(|_| bad("a number"))?,
        "step_gain" => p.step_gain = v.extract().map_err(|_| bad("a number"))?,
        "max_step" => p.max_step = v.extract().map_err(|_| bad("a number"))?,
        "tolerance" => p.tolerance = v.extract().map_err(|_| bad("a number"))?,
        "inner" => {
            p.inner = parse_method(&v.extract::<String>().map_err(|_| bad("a method name"))?)?
        }
        "refit_every_frame" => p.refit_every_frame = v.extract().map_err(|_| bad("a bool"))?,
        _ => {
            return Err(PyTypeError::new_err(format!(
                "unknown option {key:?} for method \"sensor-gated\"; expected one of {}",
                SENSOR_OPTIONS.join(", ")
            )))
        }
    }
    Ok(())
}

/// A self-collision detector for one mesh and one method.
#[pyclass(name = "Detector", module = "selfcd._core", frozen)]
pub struct PyDetector {
    det: Mutex<Box<dyn Detector>>,
    last: Mutex<Option<Detection>>,
    mesh: Arc<selfcd::Mesh>,
    method: Method,
    thickness: f64,
}

impl PyDetector {
    fn lock_det(&self) -> PyResult<MutexGuard<'_, Box<dyn Detector>>> {
        self.det
            .lock()
            .map_err(|_| PyRuntimeError::new_err("detector is unusable after an internal error"))
    }

    fn lock_last(&self) -> PyResult<MutexGuard<'_, Option<Detection>>> {
        self.last
            .lock()
            .map_err(|_| PyRuntimeError::new_err("detector is unusable after an internal error"))
    }
}

#[pymethods]
impl PyDetector {
    /// Builds the detector (its BVH, and sensor for sensor-gated) for `mesh`.
    #[new]
    #[pyo3(signature = (mesh, method, thickness = 0.0, options = None, max_contacts = None))]
    fn new(
        py: Python<'_>,
        mesh: &PyMesh,
        method: &str,
        thickness: f64,
        options: Option<&Bound<'_, PyDict>>,
        max_contacts: Option<usize>,
    ) -> PyResult<Self> {
        let m = parse_method(method)?;
        let opts = build_options(m, thickness, options)?;
        let arc = mesh.inner.clone();
        let mut det = py.detach(|| guard("Detector()", || selfcd::new_detector(arc, m, &opts)))?;
        if let Some(max) = max_contacts {
            det.set_max_contacts(max);
        }
        Ok(PyDetector {
            det: Mutex::new(det),
            last: Mutex::new(None),
            mesh: mesh.inner.clone(),
            method: m,
            thickness,
        })
    }

    /// Detects at `positions` ((n,3) float64); returns intersecting face pairs, (k,2) int64, sorted, i<j.
    fn detect<'py>(
        &self,
        py: Python<'py>,
        positions: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let p = points(&positions, "positions")?;
        let found = py.detach(|| -> PyResult<Detection> {
            let mut det = self.lock_det()?;
            guard("Detector.detect", || det.detect(&p))
        })?;
        let pairs = pairs_array(py, &found.pairs)?;
        *self.lock_last()? = Some(found);
        Ok(pairs)
    }

    /// Current sensor particle positions, (k,3) float64; (0,3) for methods without a sensor.
    fn particles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let p = self.lock_det()?.particles();
        points_array(py, &p)
    }

    /// The method's name.
    #[getter]
    fn method(&self) -> &'static str {
        self.method.name()
    }

    /// Proximity thickness.
    #[getter]
    fn thickness(&self) -> f64 {
        self.thickness
    }

    /// Number of mesh vertices the detector expects.
    #[getter]
    fn n_vertices(&self) -> usize {
        self.mesh.n_vertices()
    }

    /// FrameStats of the last `detect` call as a dict, or None before the first call.
    #[getter]
    fn last_stats<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        match &*self.lock_last()? {
            Some(d) => Ok(Some(stats_dict(py, &d.stats)?)),
            None => Ok(None),
        }
    }

    /// Proximity contacts of the last call as a dict of arrays, or None before the first call.
    #[getter]
    fn last_proximity<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        match &*self.lock_last()? {
            Some(d) => Ok(Some(proximity_dict(py, &d.proximity, &self.mesh)?)),
            None => Ok(None),
        }
    }
}
