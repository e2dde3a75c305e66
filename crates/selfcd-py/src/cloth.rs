//! The cloth simulator (engine `cloth`): the paper's scenes and `Simulation`.

use crate::convert::{frames, points, points_array, triangles, triples};
use crate::detector::parse_method;
use crate::errors::{engine_err, guard};
use crate::mesh::PyMesh;
use crate::stats::{stats_columns, stats_dict};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use selfcd::cloth::obstacle::{Obstacle, Obstacles};
use selfcd::cloth::{Cloth, Material, PaperScene, SimOptions, Simulation, StepStats};
use selfcd::{DVec3, Mesh};
use std::sync::Arc;
use std::sync::{Mutex, MutexGuard};

/// Names of the paper's cloth scenes, in the paper's order.
#[pyfunction]
pub fn paper_scenes() -> Vec<&'static str> {
    PaperScene::ALL.iter().map(|s| s.name()).collect()
}

/// Names of the cloth material presets (the first is the default).
#[pyfunction]
pub fn materials() -> Vec<&'static str> {
    Material::PRESETS.iter().map(|(n, _)| *n).collect()
}

/// Scalar fields of StepStats (the detection stats are kept apart).
fn step_fields(s: &StepStats) -> [(&'static str, f64); 22] {
    [
        ("iterations", s.iterations as f64),
        ("residual", s.residual),
        ("contacts", s.contacts as f64),
        ("vertex_triangle", s.vertex_triangle as f64),
        ("obstacle_contacts", s.obstacle_contacts as f64),
        ("constrained", s.constrained as f64),
        ("impulses", s.impulses as f64),
        ("ccd_rounds", s.ccd_rounds as f64),
        ("ccd_impacts", s.ccd_impacts as f64),
        ("reverted", s.reverted as f64),
        ("zones", s.zones as f64),
        ("correction_rounds", s.correction_rounds as f64),
        ("proved_clear", s.proved_clear as u8 as f64),
        ("intersections", s.intersections as f64),
        ("obstacle_intersections", s.obstacle_intersections as f64),
        ("solve_time", s.solve_time),
        ("detect_time", s.detect_time),
        ("proximity_time", s.proximity_time),
        ("continuous_time", s.continuous_time),
        ("obstacle_time", s.obstacle_time),
        ("response_time", s.response_time),
        ("step_time", s.step_time),
    ]
}

/// True for the fields that are counts (exported as int64).
fn is_count(name: &str) -> bool {
    !matches!(
        name,
        "residual"
            | "solve_time"
            | "detect_time"
            | "proximity_time"
            | "continuous_time"
            | "obstacle_time"
            | "response_time"
            | "step_time"
    )
}

/// One step's stats as a dict, with `detection` the FrameStats dict.
fn step_dict<'py>(py: Python<'py>, s: &StepStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in step_fields(s) {
        if is_count(k) {
            d.set_item(k, v as i64)?;
        } else {
            d.set_item(k, v)?;
        }
    }
    d.set_item("detection", stats_dict(py, &s.detection)?)?;
    Ok(d)
}

/// Many steps' stats as per-field arrays, with `detection` per-field arrays too.
fn step_columns<'py>(py: Python<'py>, steps: &[StepStats]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let rows: Vec<_> = steps.iter().map(step_fields).collect();
    for (col, (name, _)) in step_fields(&StepStats::default()).iter().enumerate() {
        let vals = rows.iter().map(|r| r[col].1);
        if is_count(name) {
            d.set_item(
                *name,
                PyArray1::from_vec(py, vals.map(|v| v as i64).collect()),
            )?;
        } else {
            d.set_item(*name, PyArray1::from_vec(py, vals.collect()))?;
        }
    }
    let det: Vec<_> = steps.iter().map(|s| &s.detection).collect();
    d.set_item("detection", stats_columns(py, &det)?)?;
    Ok(d)
}

/// A cloth in motion: one of the paper's scenes or any mesh, stepped with a detection method.
#[pyclass(name = "Simulation", module = "selfcd._core", frozen)]
pub struct PySimulation {
    sim: Mutex<Simulation>,
    /// The paper's scene and its resolution, for scenes.
    scene: Option<(PaperScene, usize)>,
}

/// One obstacle from Python: keyframes (k, n, 3) and faces (m, 3).
type PyObstacle<'py> = (PyReadonlyArray3<'py, f64>, PyReadonlyArray2<'py, i64>);

impl PySimulation {
    fn lock(&self) -> PyResult<MutexGuard<'_, Simulation>> {
        self.sim
            .lock()
            .map_err(|_| PyRuntimeError::new_err("simulation is unusable after an internal error"))
    }
}

/// Frames recorded by `Simulation.run`, and every step's stats.
type Recording = (Vec<Vec<DVec3>>, Vec<f64>, Vec<StepStats>);

/// An obstacle's keyframes and triangles, converted from numpy.
type ObstacleFrames = (Vec<Vec<DVec3>>, Vec<[u32; 3]>);

#[pymethods]
impl PySimulation {
    /// The paper's scene `scene` at `resolution` x `resolution` vertices, detecting with `method`.
    /// `dt` overrides the time step (default 1/60 s); `self_collision=False` lets the cloth pass through itself.
    #[new]
    #[pyo3(signature = (scene, resolution = 11, method = "bvh-cones-contour", dt = None, self_collision = true))]
    fn new(
        scene: &str,
        resolution: usize,
        method: &str,
        dt: Option<f64>,
        self_collision: bool,
    ) -> PyResult<Self> {
        let sc: PaperScene = scene.parse().map_err(engine_err)?;
        let m = parse_method(method)?;
        let sim = guard("Simulation()", || {
            let cloth = sc.cloth(resolution, Material::default())?;
            let mut opts = SimOptions::for_cloth(&cloth);
            opts.dt = dt.unwrap_or(opts.dt);
            opts.self_collision = self_collision;
            Simulation::new(cloth, m, opts)
        })?;
        Ok(PySimulation {
            sim: Mutex::new(sim),
            scene: Some((sc, resolution)),
        })
    }

    /// A cloth over any mesh: rest shape `rest` (default: `vertices`), starting at
    /// `vertices`, with `pins` (vertex ids) fixed, `gravity` (m/s^2), material
    /// preset `material`, and `obstacles`: (keyframes (k, n, 3), faces) played
    /// at `frame_time` seconds per keyframe.
    #[staticmethod]
    #[pyo3(signature = (vertices, faces, rest = None, pins = None, obstacles = Vec::new(), frame_time = 1.0 / 60.0,
        gravity = (0.0, 0.0, -9.81), material = "cotton", method = "bvh-cones-contour", dt = None,
        self_collision = true, friction = None, obstacle_friction = None))]
    #[allow(clippy::too_many_arguments)]
    fn from_mesh(
        vertices: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
        rest: Option<PyReadonlyArray2<'_, f64>>,
        pins: Option<PyReadonlyArray1<'_, i64>>,
        obstacles: Vec<PyObstacle<'_>>,
        frame_time: f64,
        gravity: (f64, f64, f64),
        material: &str,
        method: &str,
        dt: Option<f64>,
        self_collision: bool,
        friction: Option<f64>,
        obstacle_friction: Option<f64>,
    ) -> PyResult<Self> {
        let m = parse_method(method)?;
        let start = points(&vertices, "vertices")?;
        let rest = match rest {
            Some(r) => triples(&r, "rest")?,
            None => start.iter().map(|p| p.to_array()).collect(),
        };
        let tris = triangles(&faces)?;
        let pins: Vec<u32> = match pins {
            Some(p) => p
                .as_array()
                .iter()
                .map(|&i| {
                    u32::try_from(i)
                        .map_err(|_| PyValueError::new_err(format!("pin {i} is not a vertex id")))
                })
                .collect::<PyResult<_>>()?,
            None => Vec::new(),
        };
        let parts: Vec<ObstacleFrames> = obstacles
            .iter()
            .map(|(v, f)| Ok((frames(v)?, triangles(f)?)))
            .collect::<PyResult<_>>()?;
        let sim = guard("Simulation.from_mesh()", || {
            let mut cloth = Cloth::new(
                Arc::new(Mesh::new(rest, tris)?),
                Material::preset(material)?,
                &pins,
            )?;
            cloth.set_gravity(DVec3::from(gravity))?;
            let mut opts = SimOptions::for_cloth(&cloth);
            opts.dt = dt.unwrap_or(opts.dt);
            opts.self_collision = self_collision;
            opts.contact.friction = friction.unwrap_or(opts.contact.friction);
            opts.contact.obstacle_friction =
                obstacle_friction.unwrap_or(opts.contact.obstacle_friction);
            let mut sim = Simulation::new(cloth, m, opts)?;
            sim.set_state(start, vec![DVec3::ZERO; sim.positions().len()])?;
            if !parts.is_empty() {
                let obs = parts
                    .into_iter()
                    .map(|(k, f)| {
                        Obstacle::animated(
                            k.into_iter()
                                .map(|p| p.iter().map(|q| q.to_array()).collect())
                                .collect(),
                            f,
                            frame_time,
                        )
                    })
                    .collect::<selfcd::Result<Vec<_>>>()?;
                sim.set_obstacles(Some(Obstacles::new(obs)?));
            }
            Ok(sim)
        })?;
        Ok(PySimulation {
            sim: Mutex::new(sim),
            scene: None,
        })
    }

    /// Obstacle positions (all obstacles merged, in order) at the current time, (n, 3).
    #[getter]
    fn obstacle_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        points_array(py, &self.lock()?.obstacle_positions())
    }

    /// Faces of the merged obstacle mesh, (m, 3) int64 (empty without obstacles).
    #[getter]
    fn obstacle_faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let sim = self.lock()?;
        let tris = sim.obstacles().map_or(&[][..], |o| o.mesh().triangles());
        crate::convert::rows_array(py, tris, |t| t.map(i64::from))
    }

    /// Advances one time step; returns its stats (a dict, `detection` holding the FrameStats).
    fn step<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let st = py.detach(|| -> PyResult<StepStats> {
            let mut sim = self.lock()?;
            guard("Simulation.step", || sim.step())
        })?;
        step_dict(py, &st)
    }

    /// Runs `steps` steps, recording positions every `every` steps (and the start).
    /// Returns (frames (f,n,3), times (f,), stats: per-step arrays). `progress`, if
    /// given, is called with the number of steps done.
    #[pyo3(signature = (steps, every = 1, progress = None))]
    fn run<'py>(
        &self,
        py: Python<'py>,
        steps: usize,
        every: usize,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyDict>)> {
        if every == 0 {
            return Err(PyValueError::new_err("every must be at least 1"));
        }
        let mut cb_err = None;
        let (frames, times, stats): Recording = py.detach(|| -> PyResult<Recording> {
            let mut sim = self.lock()?;
            let (mut frames, mut times) = (vec![sim.positions().to_vec()], vec![sim.time()]);
            let mut stats = Vec::with_capacity(steps);
            for k in 1..=steps {
                stats.push(guard("Simulation.run", || sim.step())?);
                if k % every == 0 {
                    frames.push(sim.positions().to_vec());
                    times.push(sim.time());
                }
                if crate::compare::report(&progress, k, &mut cb_err).is_err() {
                    break;
                }
            }
            Ok((frames, times, stats))
        })?;
        if let Some(e) = cb_err {
            return Err(e);
        }
        let n = frames.first().map_or(0, |f| f.len());
        let flat: Vec<f64> = frames.iter().flatten().flat_map(|p| p.to_array()).collect();
        let arr = PyArray1::from_vec(py, flat)
            .reshape([frames.len(), n, 3])?
            .into_any();
        Ok((
            arr,
            PyArray1::from_vec(py, times).into_any(),
            step_columns(py, &stats)?,
        ))
    }

    /// Current positions, (n,3) float64.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        points_array(py, self.lock()?.positions())
    }

    /// Current velocities, (n,3) float64.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        points_array(py, self.lock()?.velocities())
    }

    /// The cloth's mesh (rest shape and faces).
    #[getter]
    fn mesh(&self) -> PyResult<PyMesh> {
        Ok(PyMesh::wrap(self.lock()?.cloth().mesh().clone()))
    }

    /// Which vertices are pinned, (n,) bool.
    #[getter]
    fn pinned<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(PyArray1::from_vec(py, self.lock()?.cloth().pinned().to_vec()).into_any())
    }

    /// The scene's name (None for a mesh).
    #[getter]
    fn scene(&self) -> Option<&'static str> {
        self.scene.map(|(s, _)| s.name())
    }

    /// Vertices per side (None for a mesh).
    #[getter]
    fn resolution(&self) -> Option<usize> {
        self.scene.map(|(_, n)| n)
    }

    /// The detection method driving the collision response.
    #[getter]
    fn method(&self) -> PyResult<&'static str> {
        Ok(self.lock()?.method().name())
    }

    /// Time step (s).
    #[getter]
    fn dt(&self) -> PyResult<f64> {
        Ok(self.lock()?.options().dt)
    }

    /// Contact thickness d (m): the distance the cloth keeps from itself.
    #[getter]
    fn contact_thickness(&self) -> PyResult<f64> {
        Ok(self.lock()?.options().contact.thickness)
    }

    /// Distance the detector reports proximity contacts within, d + margin (m).
    #[getter]
    fn contact_distance(&self) -> PyResult<f64> {
        Ok(self.lock()?.options().contact.detection_distance())
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> PyResult<f64> {
        Ok(self.lock()?.time())
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> PyResult<u64> {
        Ok(self.lock()?.steps())
    }

    /// Energy of the current state: dict of kinetic, gravity, elastic, total (J).
    fn energy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let e = self.lock()?.energy();
        let d = PyDict::new(py);
        d.set_item("kinetic", e.kinetic)?;
        d.set_item("gravity", e.gravity)?;
        d.set_item("elastic", e.elastic)?;
        d.set_item("total", e.total())?;
        Ok(d)
    }

    fn __repr__(&self) -> PyResult<String> {
        Ok(match self.scene {
            Some((s, n)) => format!("Simulation(scene={:?}, resolution={n})", s.name()),
            None => format!(
                "Simulation(mesh with {} vertices)",
                self.lock()?.positions().len()
            ),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::debug_field_names;

    #[test]
    fn every_step_stats_field_is_exported() {
        let engine = debug_field_names(&format!("{:?}", StepStats::default()));
        let ours: Vec<&str> = step_fields(&StepStats::default())
            .iter()
            .map(|(k, _)| *k)
            .collect();
        assert!(engine.len() > 10, "parsed {engine:?}");
        for name in engine.iter().filter(|n| *n != "detection") {
            assert!(
                ours.contains(&name.as_str()),
                "StepStats.{name} is not exported by cloth::step_fields"
            );
        }
    }
}
