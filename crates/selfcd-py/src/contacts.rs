//! Contact sets as dicts of numpy arrays: the one layout `Detector`,
//! `SelfQueries` and the one-shot functions return.

use crate::convert::{column_array, rows_array};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use selfcd::detect::continuous::{Impact, Impacts};
use selfcd::detect::narrow::ElementPair;
use selfcd::detect::ProximityContacts;

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
        rows_array(py, vt, |c| [c.vertex as i64, c.triangle as i64])?,
    )?;
    d.set_item(
        "vertex_triangle_distance",
        column_array(py, vt, |c| c.distance),
    )?;
    d.set_item("vertex_triangle_bary", rows_array(py, vt, |c| c.bary)?)?;
    let ee = &p.edge_edge;
    let edges = &mesh.topology().edges;
    d.set_item(
        "edge_edge",
        rows_array(py, ee, |c| [c.edges[0] as i64, c.edges[1] as i64])?,
    )?;
    let verts = |c: &selfcd::detect::EdgeEdge| {
        let (a, b) = (edges[c.edges[0] as usize], edges[c.edges[1] as usize]);
        [a[0] as i64, a[1] as i64, b[0] as i64, b[1] as i64]
    };
    d.set_item("edge_edge_vertices", rows_array(py, ee, verts)?)?;
    d.set_item("edge_edge_distance", column_array(py, ee, |c| c.distance))?;
    d.set_item("edge_edge_params", rows_array(py, ee, |c| c.params)?)?;
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
        rows_array(py, &found.vertex_triangle, ids)?,
    )?;
    d.set_item(
        "vertex_triangle_toi",
        column_array(py, &found.vertex_triangle, |i| i.toi),
    )?;
    d.set_item("edge_edge", rows_array(py, &found.edge_edge, ids)?)?;
    d.set_item(
        "edge_edge_toi",
        column_array(py, &found.edge_edge, |i| i.toi),
    )?;
    Ok(d)
}
