//! numpy arrays <-> engine types, whole arrays at a time.

use numpy::{
    Element, PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
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

/// An (n,3) float64 array as points, in any memory order (C order, the
/// common case, and Fortran order, a transpose's, read in one pass each).
pub fn points(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<DVec3>> {
    check_cols(a.shape(), what)?;
    if let Some(rows) = c_rows(a) {
        return Ok(rows.iter().map(|&r| DVec3::from_array(r)).collect());
    }
    let view = a.as_array();
    if let Some(cols) = view.t().as_slice() {
        // Fortran order: the x, y and z columns one after another.
        let (x, rest) = cols.split_at(view.nrows());
        let (y, z) = rest.split_at(view.nrows());
        let p = x
            .iter()
            .zip(y)
            .zip(z)
            .map(|((&x, &y), &z)| DVec3::new(x, y, z));
        return Ok(p.collect());
    }
    Ok(view
        .rows()
        .into_iter()
        .map(|r| DVec3::new(r[0], r[1], r[2]))
        .collect())
}

/// The rows of a C-order (n,3) array, in numpy's memory.
fn c_rows<'a>(a: &'a PyReadonlyArray2<'_, f64>) -> Option<&'a [[f64; 3]]> {
    // (`as_slice` also gives a Fortran-order array's memory: check the order.)
    let flat = a.as_slice().ok().filter(|_| a.is_c_contiguous())?;
    Some(flat.as_chunks().0)
}

/// An (n,3) float64 array as coordinate triples (C order: one copy of the
/// buffer, not a conversion to points and back).
pub fn triples(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<[f64; 3]>> {
    check_cols(a.shape(), what)?;
    if let Some(rows) = c_rows(a) {
        return Ok(rows.to_vec());
    }
    Ok(points(a, what)?.into_iter().map(|p| p.to_array()).collect())
}

/// An (m,3) int64 array as triangles; negative or too-large indices are named.
pub fn triangles(a: &PyReadonlyArray2<'_, i64>) -> PyResult<Vec<[u32; 3]>> {
    check_cols(a.shape(), "faces")?;
    if let Some(flat) = a.as_slice().ok().filter(|_| a.is_c_contiguous()) {
        // C order, the common case: one pass over the buffer, converting
        // while it gathers the high bits (set for any index out of u32).
        let mut high = 0;
        let tri = |c: &[i64; 3]| {
            high |= (c[0] | c[1] | c[2]) >> 32;
            c.map(|i| i as u32)
        };
        let out: Vec<[u32; 3]> = flat.as_chunks().0.iter().map(tri).collect();
        if high == 0 {
            return Ok(out);
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
    rows_array(py, p, |v| v.to_array())
}

/// Below this many items an array is filled on the calling thread
/// (releasing the GIL and waking the pool cost more than the copy).
const PAR_ITEMS: usize = 16_384;

/// `row(item)` of every item as a new (len, K) array. Long ones are filled
/// in parallel without the GIL (a proximity query can return millions of
/// contacts), into memory the array then owns: each entry written once (no
/// zeroing first, no copy).
pub fn rows_array<'py, S: Sync, T: Element + Copy + Send + Sync, const K: usize>(
    py: Python<'py>,
    items: &[S],
    row: impl Fn(&S) -> [T; K] + Sync + Send,
) -> PyResult<Bound<'py, PyAny>> {
    const { assert!(K > 0, "rows have entries") };
    let rows: Vec<[T; K]> = if items.len() < PAR_ITEMS {
        items.iter().map(&row).collect()
    } else {
        py.detach(|| items.par_iter().map(&row).collect())
    };
    Ok(PyArray1::from_vec(py, rows.into_flattened())
        .reshape([items.len(), K])?
        .into_any())
}

/// `value(item)` of every item as a new 1-d array (see [`rows_array`]).
pub fn column_array<'py, S: Sync, T: Element + Copy + Send + Sync>(
    py: Python<'py>,
    items: &[S],
    value: impl Fn(&S) -> T + Sync + Send,
) -> Bound<'py, PyArray1<T>> {
    let column = if items.len() < PAR_ITEMS {
        items.iter().map(value).collect()
    } else {
        py.detach(|| items.par_iter().map(value).collect())
    };
    PyArray1::from_vec(py, column)
}

/// Sorted triangle pairs as a new (k,2) int64 array.
pub fn pairs_array<'py>(py: Python<'py>, pairs: &[[u32; 2]]) -> PyResult<Bound<'py, PyAny>> {
    rows_array(py, pairs, |p| p.map(i64::from))
}
