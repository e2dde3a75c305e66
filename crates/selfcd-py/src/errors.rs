//! Engine errors and panics turned into Python exceptions.

use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::PyErr;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Engine error -> `ValueError` carrying the engine's message; an allocation
/// failure -> `MemoryError` (with the size asked for); an interrupted call ->
/// `KeyboardInterrupt`.
pub fn engine_err(e: selfcd::Error) -> PyErr {
    match e {
        selfcd::Error::OutOfMemory { .. } => PyMemoryError::new_err(e.to_string()),
        selfcd::Error::Interrupted => PyKeyboardInterrupt::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Runs `f`, turning a panic into a `RuntimeError` so it never unwinds into Python.
pub fn guard<T>(what: &str, f: impl FnOnce() -> selfcd::Result<T>) -> Result<T, PyErr> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r.map_err(engine_err),
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(PyRuntimeError::new_err(format!(
                "internal error in {what}: {msg} (please report this)"
            )))
        }
    }
}
