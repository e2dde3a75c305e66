//! Particle interaction (paper 2.3):
//!
//! ```text
//! F_i = sum_{j != i} [ t a / rs^2 unit(p_j - p_i)  -  b / ro^2 u_ij ],   t = (ro - rs) / ro
//! ```
//!
//! rs = |p_j - p_i| is the straight-line distance (SL) in the current shape,
//! ro the original distance (ODL) along the surface, u_ij the unit tangent at
//! p_i of the surface path towards j. The first term attracts particles that
//! are close in SL yet far along the surface (t near 1: a fold); the second
//! spreads particles that are close along the surface. Both distances are
//! divided by the mean rest edge length L before use, so a and b, and the
//! forces, do not depend on the mesh's scale. Pairs with ro = 0 (one particle
//! on top of another in rest space) exert nothing; with rs = 0 the attraction
//! has no direction and is left out.

use super::odl::{original_distance, path_tangent};
use super::particle::SurfacePoint;
use crate::mesh::Mesh;
use glam::DVec3;

/// Distances (in units of L) below this count as zero.
const TINY: f64 = 1e-12;

/// Where the particles are, in both shapes, and the length unit.
#[derive(Debug, Clone, Copy)]
pub struct Snapshot<'a> {
    /// The mesh.
    pub mesh: &'a Mesh,
    /// Current vertex positions.
    pub positions: &'a [DVec3],
    /// The particles.
    pub points: &'a [SurfacePoint],
    /// Current particle positions.
    pub current: &'a [DVec3],
    /// Rest particle positions.
    pub rest: &'a [DVec3],
    /// Length unit L (mean rest edge length).
    pub unit: f64,
}

/// Force on particle `i` from particle `j` (normalised units), per the formula above.
#[inline]
pub fn pair_force(s: &Snapshot, i: usize, j: usize, a: f64, b: f64) -> DVec3 {
    let ro = original_distance(s.rest[i], s.rest[j]) / s.unit;
    if !(ro > TINY) {
        return DVec3::ZERO;
    }
    let chord = (s.current[j] - s.current[i]) / s.unit;
    let rs = chord.length();
    let attract = if rs > TINY { chord / rs * ((ro - rs) / ro * a / (rs * rs)) } else { DVec3::ZERO };
    let u = path_tangent(s.mesh, s.positions, &s.points[i], s.rest[i], s.rest[j]);
    attract - u * (b / (ro * ro))
}

/// F_i for every particle i (normalised units, current-space directions).
pub fn forces(s: &Snapshot, a: f64, b: f64) -> Vec<DVec3> {
    let k = s.points.len();
    (0..k).map(|i| (0..k).filter(|&j| j != i).map(|j| pair_force(s, i, j, a, b)).sum()).collect()
}
