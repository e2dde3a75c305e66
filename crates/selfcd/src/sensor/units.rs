//! The sensor's frame: lengths in units of the mean rest edge L, measured from
//! the rest bounds' low corner, snapped to a grid of 2^-32 L.
//!
//! The snapped coordinates have the same bits whatever the mesh's scale
//! (except in the rare case that a value lies within rounding of a grid
//! point), so every decision of the sensor (which edge a walk leaves through,
//! when a geodesic field is recomputed, which pair is closest) is the same on
//! a mesh scaled by any factor, and so are the trajectories in normalised units.

use crate::mesh::Mesh;
use glam::DVec3;
use std::sync::Arc;

/// Grid spacing of the sensor's frame (mean-edge units).
pub const SNAP: f64 = 1.0 / 4_294_967_296.0;

/// `p` in the frame with `origin` and `unit`, snapped to [`SNAP`].
#[inline]
pub fn to_frame(p: DVec3, origin: DVec3, unit: f64) -> DVec3 {
    ((p - origin) / (unit * SNAP)).round() * SNAP
}

/// The mesh in the sensor's frame and the frame's origin. If snapping makes a
/// triangle degenerate (a sliver within 2^-32 L of a line), the unsnapped copy is used.
pub fn normalised(mesh: &Mesh) -> (Arc<Mesh>, DVec3) {
    let origin = mesh.rest().iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
    let unit = mesh.mean_edge_length();
    let rest = |snap: bool| -> Vec<[f64; 3]> {
        mesh.rest()
            .iter()
            .map(|&p| {
                let q = if snap {
                    to_frame(p, origin, unit)
                } else {
                    (p - origin) / unit
                };
                q.to_array()
            })
            .collect()
    };
    let tris = mesh.triangles().to_vec();
    let norm = Mesh::new(rest(true), tris.clone())
        .or_else(|_| Mesh::new(rest(false), tris))
        .map(Arc::new)
        .unwrap_or_else(|_| Arc::new(mesh.clone()));
    (norm, origin)
}
