//! Original distance (ODL, paper 2.2): the length of the shortest path between
//! two particles along the surface, and the direction of that path.
//!
//! The rest shape is the cloth "before it deforms"; cloth neither stretches
//! much nor changes its topology, so the surface distance is measured in rest
//! space. For a flat rest shape the shortest surface path is the straight
//! rest-space segment, ro = |R_j - R_i|, exact whenever the segment stays on
//! the sheet (always for a convex sheet such as the paper's square; for a sheet
//! with holes or notches it is a lower bound). The path's tangent at particle
//! i is the rest direction R_j - R_i carried to the current shape through the
//! deformation of i's triangle. Curved rest shapes need a geodesic on the rest
//! mesh, which is not implemented: [`check_flat`] refuses them.

use super::tangent::{self, TriMap};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use glam::DVec3;

/// Largest distance from the plane, relative to the rest bounding-box diagonal, that still counts as flat.
pub const FLAT_TOLERANCE: f64 = 1e-6;

/// The rest shape's mean plane: through the vertex centroid, normal to the
/// area-weighted sum of triangle normals (each flipped to agree with the
/// largest triangle's). Returns (point, unit normal).
pub fn rest_plane(mesh: &Mesh) -> (DVec3, DVec3) {
    let rest = mesh.rest();
    let crosses: Vec<DVec3> = (0..mesh.n_triangles())
        .map(|t| {
            let (e1, e2) = tangent::edges(mesh, rest, t);
            e1.cross(e2)
        })
        .collect();
    let largest = crosses.iter().copied().fold(DVec3::ZERO, |a, c| {
        if c.length_squared() > a.length_squared() {
            c
        } else {
            a
        }
    });
    let sum: DVec3 = crosses
        .iter()
        .map(|&c| if c.dot(largest) < 0.0 { -c } else { c })
        .sum();
    let centroid = rest.iter().copied().sum::<DVec3>() / rest.len() as f64;
    (centroid, sum.normalize_or(DVec3::Z))
}

/// Largest distance of a rest vertex from [`rest_plane`], relative to the rest bounding-box diagonal.
pub fn flatness_deviation(mesh: &Mesh) -> f64 {
    let rest = mesh.rest();
    let (c, n) = rest_plane(mesh);
    let lo = rest.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
    let hi = rest.iter().fold(DVec3::NEG_INFINITY, |a, &b| a.max(b));
    let diag = (hi - lo).length().max(f64::MIN_POSITIVE);
    rest.iter()
        .map(|&p| (p - c).dot(n).abs())
        .fold(0.0, f64::max)
        / diag
}

/// Ok when the rest shape is flat within [`FLAT_TOLERANCE`], else [`Error::CurvedRestShape`].
pub fn check_flat(mesh: &Mesh) -> Result<()> {
    let deviation = flatness_deviation(mesh);
    if deviation <= FLAT_TOLERANCE {
        return Ok(());
    }
    Err(Error::CurvedRestShape {
        deviation,
        what: "the particle sensor's original distance",
    })
}

/// Original distance ro = |R_j - R_i| between two particles at rest positions `ri`, `rj`.
#[inline]
pub fn original_distance(ri: DVec3, rj: DVec3) -> f64 {
    (rj - ri).length()
}

/// Unit tangent u_ij at particle i of the surface path towards j: the rest
/// direction R_j - R_i mapped through the deformation `map` of i's triangle,
/// normalised. Zero when undefined (coincident rest points or a degenerate triangle).
#[inline]
pub fn path_tangent(map: &TriMap, ri: DVec3, rj: DVec3) -> DVec3 {
    map.to_current(rj - ri)
        .map_or(DVec3::ZERO, |v| v.normalize_or_zero())
}
