//! Tangent vectors of one triangle and its deformation.
//!
//! A tangent vector of triangle (V0, V1, V2) is written in barycentric
//! increments (d1, d2): v = d1 E1 + d2 E2 with E1 = V1 - V0, E2 = V2 - V0
//! (and d0 = -d1 - d2). The same increments read with the rest edges give the
//! rest-space vector and with the current edges the current one: this is the
//! triangle's deformation map F (rest -> current) and its inverse, without
//! forming F.

use crate::mesh::Mesh;
use glam::DVec3;

/// Below this |E1 x E2|^2 / (|E1|^2 |E2|^2) (squared sine of the corner angle) a triangle has no tangent plane.
const MIN_SIN2: f64 = 1e-20;

/// The two edges (E1, E2) from corner 0 of triangle `t` in `positions`.
#[inline]
pub fn edges(mesh: &Mesh, positions: &[DVec3], t: usize) -> (DVec3, DVec3) {
    let c = mesh.corners(positions, t);
    (c[1] - c[0], c[2] - c[0])
}

/// Increments (d1, d2) of the in-plane part of `v`: the least-squares solution of
/// d1 E1 + d2 E2 = v, i.e. the Gram system [E1.E1 E1.E2; E1.E2 E2.E2] d = [E1.v, E2.v].
/// None when the triangle is degenerate (no plane) or the result is not finite.
#[inline]
pub fn to_bary(e1: DVec3, e2: DVec3, v: DVec3) -> Option<[f64; 2]> {
    let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let det = g11 * g22 - g12 * g12;
    if !(det > MIN_SIN2 * g11 * g22) {
        return None;
    }
    let (r1, r2) = (e1.dot(v), e2.dot(v));
    let d = [(g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det];
    (d[0].is_finite() && d[1].is_finite()).then_some(d)
}

/// The vector d1 E1 + d2 E2.
#[inline]
pub fn from_bary(e1: DVec3, e2: DVec3, d: [f64; 2]) -> DVec3 {
    e1 * d[0] + e2 * d[1]
}

/// Unit normal (E1 x E2 normalised) of triangle `t` in `positions`; None if degenerate.
#[inline]
pub fn normal(mesh: &Mesh, positions: &[DVec3], t: usize) -> Option<DVec3> {
    let (e1, e2) = edges(mesh, positions, t);
    let n = e1.cross(e2);
    let l2 = n.length_squared();
    (l2 > MIN_SIN2 * e1.length_squared() * e2.length_squared()).then(|| n / l2.sqrt())
}

/// Maps the tangent vector `v` of triangle `t` from shape `from` to shape `to`
/// through the triangle's deformation; None when `t` is degenerate in `from`.
#[inline]
pub fn map(mesh: &Mesh, from: &[DVec3], to: &[DVec3], t: usize, v: DVec3) -> Option<DVec3> {
    let (a1, a2) = edges(mesh, from, t);
    let d = to_bary(a1, a2, v)?;
    let (b1, b2) = edges(mesh, to, t);
    Some(from_bary(b1, b2, d))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bary_round_trip_and_degenerate() {
        let (e1, e2) = (DVec3::new(2.0, 0.0, 0.0), DVec3::new(1.0, 3.0, 0.0));
        let v = DVec3::new(0.5, -1.5, 0.0);
        let d = to_bary(e1, e2, v).unwrap();
        assert!((from_bary(e1, e2, d) - v).length() < 1e-15);
        // The out-of-plane part is dropped (least squares).
        let d2 = to_bary(e1, e2, v + DVec3::Z).unwrap();
        assert!((d2[0] - d[0]).abs() < 1e-15 && (d2[1] - d[1]).abs() < 1e-15);
        assert!(to_bary(e1, e1 * 2.0, v).is_none());
    }
}
