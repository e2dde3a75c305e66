//! numpy arrays <-> engine types, whole arrays at a time.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use selfcd::DVec3;

/// Checks that a 2-d array has 3 columns; `what` names it in the error.
fn check_cols(shape: &[usize], what: &str) -> PyResult<()> {
    if shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape (n, 3), got {shape:?}"
        )));
    }
    Ok(())
}

/// An (n,3) float64 array as points.
pub fn points(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<DVec3>> {
    check_cols(a.shape(), what)?;
    if let Ok(flat) = a.as_slice() {
        // C order, the common case: one pass over the buffer.
        let p = flat.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2]));
        return Ok(p.collect());
    }
    Ok(a.as_array()
        .rows()
        .into_iter()
        .map(|r| DVec3::new(r[0], r[1], r[2]))
        .collect())
}

/// An (n,3) float64 array as coordinate triples.
pub fn triples(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<[f64; 3]>> {
    Ok(points(a, what)?.into_iter().map(|p| p.to_array()).collect())
}

/// An (m,3) int64 array as triangles; negative or too-large indices are named.
pub fn triangles(a: &PyReadonlyArray2<'_, i64>) -> PyResult<Vec<[u32; 3]>> {
    check_cols(a.shape(), "faces")?;
    if let Ok(flat) = a.as_slice() {
        // C order, the common case: one pass over the buffer.
        let fits = flat.iter().all(|&i| u32::try_from(i).is_ok());
        if fits {
            let tri = |c: &[i64]| [c[0] as u32, c[1] as u32, c[2] as u32];
            return Ok(flat.chunks_exact(3).map(tri).collect());
        }
    }
    let view = a.as_array();
    let mut out = Vec::with_capacity(view.nrows());
    for (t, r) in view.rows().into_iter().enumerate() {
        let mut tri = [0u32; 3];
        for k in 0..3 {
            tri[k] = u32::try_from(r[k]).map_err(|_| {
                PyValueError::new_err(format!(
                    "face {t} has vertex index {} (indices must be in 0..2^32)",
                    r[k]
                ))
            })?;
        }
        out.push(tri);
    }
    Ok(out)
}

/// An (f,n,3) float64 array as a list of frames.
pub fn frames(a: &PyReadonlyArray3<'_, f64>) -> PyResult<Vec<Vec<DVec3>>> {
    let s = a.shape();
    if s[2] != 3 {
        return Err(PyValueError::new_err(format!(
            "frames must have shape (frames, n, 3), got {s:?}"
        )));
    }
    let view = a.as_array();
    Ok(view
        .outer_iter()
        .map(|f| {
            f.rows()
                .into_iter()
                .map(|r| DVec3::new(r[0], r[1], r[2]))
                .collect()
        })
        .collect())
}

/// Points as a new (n,3) float64 array.
pub fn points_array<'py>(py: Python<'py>, p: &[DVec3]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f64> = p.iter().flat_map(|v| v.to_array()).collect();
    Ok(PyArray1::from_vec(py, flat)
        .reshape([p.len(), 3])?
        .into_any())
}

/// Rows of `K` values as a new (k,K) array.
pub fn rows_array<'py, T: numpy::Element + Copy, const K: usize>(
    py: Python<'py>,
    rows: impl ExactSizeIterator<Item = [T; K]>,
) -> PyResult<Bound<'py, PyAny>> {
    let n = rows.len();
    let flat: Vec<T> = rows.flat_map(|r| r.into_iter()).collect();
    Ok(PyArray1::from_vec(py, flat).reshape([n, K])?.into_any())
}

/// Sorted triangle pairs as a new (k,2) int64 array.
pub fn pairs_array<'py>(py: Python<'py>, pairs: &[[u32; 2]]) -> PyResult<Bound<'py, PyAny>> {
    rows_array(py, pairs.iter().map(|p| [p[0] as i64, p[1] as i64]))
}
