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
use super::tangent::TriMap;
use crate::mesh::Mesh;
use glam::DVec3;

/// Distances (in units of L) below this count as zero.
const TINY: f64 = 1e-12;

/// One particle as seen in one update: its positions in both shapes (divided
/// by L) and the deformation map of its triangle.
#[derive(Debug, Clone, Copy)]
pub struct Local {
    /// Current position / L.
    pub current: DVec3,
    /// Rest position / L.
    pub rest: DVec3,
    /// Deformation map of the particle's triangle.
    pub map: TriMap,
}

impl Local {
    /// The particle `p` at `positions`, lengths in units of `unit`.
    #[inline]
    pub fn new(mesh: &Mesh, positions: &[DVec3], p: &SurfacePoint, unit: f64) -> Local {
        Local {
            current: p.position(mesh, positions) / unit,
            rest: p.rest_position(mesh) / unit,
            map: TriMap::new(mesh, positions, p.tri as usize),
        }
    }
}

/// Force on particle `i` from particle `j` (normalised units), per the formula above.
#[inline]
pub fn pair_force(i: &Local, j: &Local, a: f64, b: f64) -> DVec3 {
    let ro = original_distance(i.rest, j.rest);
    if !(ro > TINY) {
        return DVec3::ZERO;
    }
    let chord = j.current - i.current;
    let rs = chord.length();
    let attract = if rs > TINY {
        chord * ((ro - rs) / ro * a / (rs * rs * rs))
    } else {
        DVec3::ZERO
    };
    attract - path_tangent(&i.map, i.rest, j.rest) * (b / (ro * ro))
}

/// Writes F_i for every particle i (normalised units, current-space directions) into `out`.
pub fn forces(locals: &[Local], a: f64, b: f64, out: &mut Vec<DVec3>) {
    out.clear();
    out.extend(locals.iter().enumerate().map(|(i, li)| {
        locals
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, lj)| pair_force(li, lj, a, b))
            .sum::<DVec3>()
    }));
}
