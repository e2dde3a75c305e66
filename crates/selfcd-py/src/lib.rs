//! `selfcd._core`: the Python extension module over the selfcd engine.
//!
//! Thin by design: arrays cross the boundary whole (numpy in, numpy out),
//! every long call releases the GIL, engine errors become `ValueError` with the
//! engine's message (`MemoryError` for an allocation failure, `KeyboardInterrupt`
//! for Ctrl-C during a long call), and a panic (which the engine should never
//! raise) becomes a `RuntimeError` instead of unwinding into the interpreter.

/// mimalloc: see Cargo.toml.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

mod bench;
mod cloth;
mod compare;
mod contacts;
mod convert;
mod detector;
mod errors;
mod inspect;
mod mesh;
mod pool;
mod queries;
mod scene;
mod stats;

use pyo3::prelude::*;
use selfcd::Method;

/// Names of every detection method the engine knows, in report order.
#[pyfunction]
fn methods() -> Vec<&'static str> {
    Method::ALL.iter().map(|m| m.name()).collect()
}

/// Names of the methods that may miss contacts by design.
#[pyfunction]
fn non_conservative_methods() -> Vec<&'static str> {
    Method::ALL
        .iter()
        .filter(|m| !m.is_conservative())
        .map(|m| m.name())
        .collect()
}

/// Names of the keyword options the `sensor-gated` method takes (the sensor's parameters).
#[pyfunction]
fn sensor_options() -> Vec<&'static str> {
    detector::SENSOR_OPTIONS.to_vec()
}

/// The extension module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    pool::init();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    m.add_function(wrap_pyfunction!(non_conservative_methods, m)?)?;
    m.add_function(wrap_pyfunction!(sensor_options, m)?)?;
    m.add_class::<mesh::PyMesh>()?;
    m.add_class::<cloth::PySimulation>()?;
    m.add_function(wrap_pyfunction!(cloth::paper_scenes, m)?)?;
    m.add_function(wrap_pyfunction!(cloth::materials, m)?)?;
    m.add_class::<detector::PyDetector>()?;
    m.add_class::<queries::PySelfQueries>()?;
    m.add_class::<inspect::PyHierarchy>()?;
    m.add_function(wrap_pyfunction!(inspect::sensor_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::self_intersections, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::position_groups, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::first_intersection, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::one_shot_detection, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::continuous_impacts, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::proximity_contacts, m)?)?;
    m.add_function(wrap_pyfunction!(compare::compare_methods, m)?)?;
    m.add_function(wrap_pyfunction!(compare::reference_pairs, m)?)?;
    m.add_function(wrap_pyfunction!(bench::bench_scaling, m)?)?;
    m.add_function(wrap_pyfunction!(bench::bench_states, m)?)?;
    m.add_function(wrap_pyfunction!(scene::grid, m)?)?;
    m.add_function(wrap_pyfunction!(scene::deform, m)?)?;
    Ok(())
}
