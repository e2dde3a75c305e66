//! Built-in meshes and analytic deformations (engine `scene`).

use crate::convert::{points, points_array, rows_array};
use crate::errors::guard;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use selfcd::scene::{self, Deformation};

/// A square grid cloth of `n x n` vertices over [0, size]^2 in the xy plane:
/// returns (vertices (n*n,3) float64, faces (2(n-1)^2,3) int64).
#[pyfunction]
#[pyo3(signature = (n, size = 1.0))]
pub fn grid<'py>(
    py: Python<'py>,
    n: usize,
    size: f64,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    if !(2..=4096).contains(&n) {
        return Err(PyValueError::new_err(format!(
            "grid side n must be in 2..=4096, got {n}"
        )));
    }
    if !(size.is_finite() && size > 0.0) {
        return Err(PyValueError::new_err(format!(
            "grid size must be finite and > 0, got {size}"
        )));
    }
    let (v, f) = scene::grid(n, size);
    let pts: Vec<_> = v.iter().map(|p| selfcd::DVec3::from_array(*p)).collect();
    Ok((
        points_array(py, &pts)?,
        rows_array(py, &f, |t| t.map(|i| i as i64))?,
    ))
}

/// Number parameter `key` of a shape, or its default.
fn num(params: Option<&Bound<'_, PyDict>>, key: &str, default: f64) -> PyResult<f64> {
    match params.map(|d| d.get_item(key)).transpose()?.flatten() {
        Some(v) => v
            .extract::<f64>()
            .map_err(|_| PyTypeError::new_err(format!("shape parameter {key} must be a number"))),
        None => Ok(default),
    }
}

/// A whole-number parameter (layers, seed) given as a number: must be an integer >= 0.
fn count(v: f64, key: &str) -> PyResult<usize> {
    if v.is_finite() && v >= 0.0 && v.fract() == 0.0 && v < 2f64.powi(53) {
        Ok(v as usize)
    } else {
        Err(PyValueError::new_err(format!(
            "shape parameter {key} must be a whole number >= 0, got {v}"
        )))
    }
}

/// The parameter names each shape takes.
fn shape_keys(shape: &str) -> Option<&'static [&'static str]> {
    Some(match shape {
        "flat" => &[],
        "fold" => &["angle", "radius"],
        "zfold" => &["layers", "gap"],
        "crumple" => &["amplitude", "wavelength", "seed"],
        "twist" => &["turns"],
        "roll" => &["turns", "gap"],
        "noise" => &["amplitude", "seed"],
        _ => return None,
    })
}

/// Builds the engine deformation `shape` from its keyword parameters.
fn deformation(shape: &str, params: Option<&Bound<'_, PyDict>>) -> PyResult<Deformation> {
    let keys = shape_keys(shape).ok_or_else(|| {
        PyValueError::new_err(format!(
            "unknown shape {shape:?}; expected flat, fold, zfold, crumple, twist, roll or noise"
        ))
    })?;
    if let Some(d) = params {
        for k in d.keys() {
            let k: String = k.extract()?;
            if !keys.contains(&k.as_str()) {
                return Err(PyTypeError::new_err(format!(
                    "shape {shape:?} takes {keys:?}, not {k:?}"
                )));
            }
        }
    }
    let p = |k, dflt| num(params, k, dflt);
    Ok(match shape {
        "flat" => Deformation::Flat,
        "fold" => Deformation::Fold {
            angle: p("angle", std::f64::consts::PI)?,
            radius: p("radius", 0.05)?,
        },
        "zfold" => Deformation::ZFold {
            layers: count(p("layers", 3.0)?, "layers")?,
            gap: p("gap", 0.02)?,
        },
        "crumple" => Deformation::Crumple {
            amplitude: p("amplitude", 0.1)?,
            wavelength: p("wavelength", 0.5)?,
            seed: count(p("seed", 1.0)?, "seed")? as u64,
        },
        "twist" => Deformation::Twist {
            turns: p("turns", 0.5)?,
        },
        "roll" => Deformation::Roll {
            turns: p("turns", 1.5)?,
            gap: p("gap", 0.02)?,
        },
        _ => Deformation::Noise {
            amplitude: p("amplitude", 0.01)?,
            seed: count(p("seed", 1.0)?, "seed")? as u64,
        },
    })
}

/// Puts a flat rest shape `rest` ((n,3) float64) into `shape`; returns (n,3) positions.
/// Lengths in the parameters are fractions of the rest shape's width along x.
#[pyfunction]
#[pyo3(signature = (rest, shape, **params))]
pub fn deform<'py>(
    py: Python<'py>,
    rest: PyReadonlyArray2<'_, f64>,
    shape: &str,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let r = points(&rest, "rest")?;
    let d = deformation(shape, params)?;
    d.validate().map_err(crate::errors::engine_err)?;
    let out = py.detach(|| guard("deform", || Ok(d.apply(&r))))?;
    points_array(py, &out)
}
