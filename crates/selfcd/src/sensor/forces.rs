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
//! has no direction and is left out. Between components ro is infinite: no
//! repulsion, and attraction only (t below clamped at 0).
//!
//! On a curved rest shape t is measured against the rest chord c0 = |R_j - R_i|
//! instead, t = (c0 - rs) / c0: how much closer the pair is than at rest. The
//! paper's t is that on its flat sheet (c0 = ro); with ro in its place, every
//! pair of a sphere or tube at rest would attract (the chord is shorter than the
//! geodesic) and the particles would bunch up where nothing folded.
//!
//! Between components t is measured against the rest chord too, clamped to
//! [0, 1]: t = max(0, (c0 - rs) / c0). The paper's t = 1 there pulls every
//! particle towards every particle of every other component at any distance,
//! with nothing to balance it but the own component's repulsion: the body's
//! particles were pulled towards its seven small components and never settled
//! (a garment on a body likewise). Measured against the rest chord, pieces that
//! keep their rest placement (a garment worn on a body) exert nothing on each
//! other, and pieces that approach each other (a sheet coming down on another)
//! attract as t rises towards 1.

use super::odl::{Located, OriginalDistance, Path};
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

/// Force on particle `i` from particle `j` (normalised units), per the formula
/// above; `path` is the original path from i to j.
#[inline]
pub fn pair_force(i: &Local, j: &Local, path: &Path, a: f64, b: f64) -> DVec3 {
    let ro = path.length;
    if !(ro > TINY) {
        return DVec3::ZERO;
    }
    let chord = j.current - i.current;
    let rs = chord.length();
    let c0 = if path.chord > TINY { path.chord } else { ro };
    let t = match (ro.is_finite(), c0.is_finite()) {
        (true, _) => (c0 - rs) / c0,
        (false, true) => ((c0 - rs) / c0).max(0.0),
        (false, false) => 1.0,
    };
    let attract = if rs > TINY {
        chord * (t * a / (rs * rs * rs))
    } else {
        DVec3::ZERO
    };
    if !ro.is_finite() {
        return attract;
    }
    let tangent = i
        .map
        .to_current(path.direction)
        .map_or(DVec3::ZERO, |v| v.normalize_or_zero());
    attract - tangent * (b / (ro * ro))
}

/// Writes F_i for every particle i (normalised units, current-space directions)
/// into `out`; `at` is [`OriginalDistance::locate`] of `points`.
pub fn forces(
    locals: &[Local],
    (points, at): (&[SurfacePoint], &[Located]),
    odl: &OriginalDistance,
    a: f64,
    b: f64,
    out: &mut Vec<DVec3>,
) {
    out.clear();
    out.extend(locals.iter().enumerate().map(|(i, li)| {
        let from = (&points[i], &at[i]);
        locals
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(j, lj)| {
                let path = odl.path_between(from, (&points[j], &at[j]), j);
                pair_force(li, lj, &path, a, b)
            })
            .sum::<DVec3>()
    }));
}
