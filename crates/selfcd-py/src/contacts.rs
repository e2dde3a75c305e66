//! Contact sets as dicts of numpy arrays: the one layout `Detector`,
//! `SelfQueries` and the one-shot functions return.

use crate::convert::rows_array;
use numpy::{Element, PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use selfcd::detect::continuous::{Impact, Impacts};
use selfcd::detect::narrow::ElementPair;
use selfcd::detect::ProximityContacts;

/// Below this many items a result array is filled on the calling thread
/// (releasing the GIL and waking the pool cost more than the copy).
const PAR_ITEMS: usize = 16_384;

/// `f` of every item, as a (len, K) array. Long ones are filled in parallel
/// without the GIL, into memory the array then owns (no copy): a proximity
/// query can return millions of contacts.
fn par_rows<'py, S: Sync, T: Element + Copy + Default + Send + Sync, const K: usize>(
    py: Python<'py>,
    items: &[S],
    f: impl Fn(&S) -> [T; K] + Sync + Send,
) -> PyResult<Bound<'py, PyAny>> {
    const { assert!(K > 0, "rows have entries") };
    let flat = if items.len() < PAR_ITEMS {
        items.iter().flat_map(&f).collect()
    } else {
        py.detach(|| {
            let mut flat = vec![T::default(); items.len() * K];
            let rows = flat.par_chunks_mut(K).zip(items.par_iter());
            rows.for_each(|(row, x)| row.copy_from_slice(&f(x)));
            flat
        })
    };
    Ok(PyArray1::from_vec(py, flat)
        .reshape([items.len(), K])?
        .into_any())
}

/// `f` of every item, as a 1-d array (see [`par_rows`]).
fn par_column<'py, S: Sync, T: Element + Copy + Send + Sync>(
    py: Python<'py>,
    items: &[S],
    f: impl Fn(&S) -> T + Sync + Send,
) -> Bound<'py, PyArray1<T>> {
    let column = if items.len() < PAR_ITEMS {
        items.iter().map(f).collect()
    } else {
        py.detach(|| items.par_iter().map(f).collect())
    };
    PyArray1::from_vec(py, column)
}

/// Proximity contacts as arrays: vertex-triangle pairs and edge-edge pairs
/// (edge ids and their vertices), with distances and closest-point parameters.
pub fn proximity_dict<'py>(
    py: Python<'py>,
    p: &ProximityContacts,
    mesh: &selfcd::Mesh,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let vt = &p.vertex_triangle;
    d.set_item(
        "vertex_triangle",
        par_rows(py, vt, |c| [c.vertex as i64, c.triangle as i64])?,
    )?;
    d.set_item(
        "vertex_triangle_distance",
        par_column(py, vt, |c| c.distance),
    )?;
    d.set_item("vertex_triangle_bary", par_rows(py, vt, |c| c.bary)?)?;
    let ee = &p.edge_edge;
    let edges = &mesh.topology().edges;
    d.set_item(
        "edge_edge",
        par_rows(py, ee, |c| [c.edges[0] as i64, c.edges[1] as i64])?,
    )?;
    let verts = |c: &selfcd::detect::EdgeEdge| {
        let (a, b) = (edges[c.edges[0] as usize], edges[c.edges[1] as usize]);
        [a[0] as i64, a[1] as i64, b[0] as i64, b[1] as i64]
    };
    d.set_item("edge_edge_vertices", par_rows(py, ee, verts)?)?;
    d.set_item("edge_edge_distance", par_column(py, ee, |c| c.distance))?;
    d.set_item("edge_edge_params", par_rows(py, ee, |c| c.params)?)?;
    Ok(d)
}

/// Impacts of a continuous query as arrays: vertex-triangle (vertex, face)
/// and edge-edge (edge ids) pairs, each with its time of impact.
pub fn impacts_dict<'py>(py: Python<'py>, found: &Impacts) -> PyResult<Bound<'py, PyDict>> {
    let ids = |i: &Impact| match i.pair {
        ElementPair::VertexTriangle(x, y) | ElementPair::EdgeEdge(x, y) => [x as i64, y as i64],
    };
    let d = PyDict::new(py);
    d.set_item(
        "vertex_triangle",
        rows_array(py, found.vertex_triangle.iter().map(ids))?,
    )?;
    d.set_item(
        "vertex_triangle_toi",
        PyArray1::from_iter(py, found.vertex_triangle.iter().map(|i| i.toi)),
    )?;
    d.set_item(
        "edge_edge",
        rows_array(py, found.edge_edge.iter().map(ids))?,
    )?;
    d.set_item(
        "edge_edge_toi",
        PyArray1::from_iter(py, found.edge_edge.iter().map(|i| i.toi)),
    )?;
    Ok(d)
}
