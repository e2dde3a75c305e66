//! Tangent vectors of one triangle and its deformation.
//!
//! A tangent vector of triangle (V0, V1, V2) is written in barycentric
//! increments (d1, d2): v = d1 E1 + d2 E2 with E1 = V1 - V0, E2 = V2 - V0
//! (and d0 = -d1 - d2). The same increments read with the rest edges give the
//! rest-space vector and with the current edges the current one: this is the
//! triangle's deformation map F (rest -> current) and its inverse, without
//! forming F.

use crate::mesh::Mesh;
use glam::{DMat3, DVec3};

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

/// Dual basis (E1*, E2*) of edges (E1, E2): Ei* . Ej = delta_ij, both in the
/// triangle's plane, so (E1* . v, E2* . v) are the increments of the in-plane
/// part of v. None when the triangle is degenerate.
#[inline]
pub fn dual(e1: DVec3, e2: DVec3) -> Option<(DVec3, DVec3)> {
    let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let det = g11 * g22 - g12 * g12;
    if !(det > MIN_SIN2 * g11 * g22) {
        return None;
    }
    Some(((e1 * g22 - e2 * g12) / det, (e2 * g11 - e1 * g12) / det))
}

/// The linear map v -> a1 (d1 . v) + a2 (d2 . v) as a matrix.
#[inline]
fn outer(a1: DVec3, d1: DVec3, a2: DVec3, d2: DVec3) -> DMat3 {
    DMat3::from_cols(
        a1 * d1.x + a2 * d2.x,
        a1 * d1.y + a2 * d2.y,
        a1 * d1.z + a2 * d2.z,
    )
}

/// The deformation map of one triangle between rest and current shape:
/// F = e1 (x) E1* + e2 (x) E2* (rest -> current), formed once so each mapping
/// is one mat-vec, and the current dual basis (e1*, e2*) that turns a current
/// tangent vector into barycentric increments (the way back, F^-1 on the plane).
#[derive(Debug, Clone, Copy)]
pub struct TriMap {
    /// F: rest tangent -> current tangent; None if the rest triangle is degenerate.
    pub forward: Option<DMat3>,
    /// Current dual basis (e1*, e2*); None if the current triangle is degenerate.
    pub current_dual: Option<(DVec3, DVec3)>,
    /// Unit current normal; None when the triangle is degenerate in the current shape.
    pub normal: Option<DVec3>,
}

impl TriMap {
    /// The map of triangle `t` between `mesh`'s rest shape and `positions`.
    #[inline]
    pub fn new(mesh: &Mesh, positions: &[DVec3], t: usize) -> TriMap {
        let (r1, r2) = edges(mesh, mesh.rest(), t);
        let (c1, c2) = edges(mesh, positions, t);
        let rest_dual = dual(r1, r2);
        let cur_dual = dual(c1, c2);
        TriMap {
            forward: rest_dual.map(|(d1, d2)| outer(c1, d1, c2, d2)),
            current_dual: cur_dual,
            normal: cur_dual.map(|_| c1.cross(c2).normalize()),
        }
    }

    /// Rest tangent vector -> current tangent vector (F v); None if degenerate.
    #[inline]
    pub fn to_current(&self, v: DVec3) -> Option<DVec3> {
        self.forward.map(|f| f * v)
    }

    /// Current tangent vector -> barycentric increments (e1* . v, e2* . v) of its
    /// in-plane part; read with the rest edges they give F^-1 v. None if degenerate.
    #[inline]
    pub fn increments(&self, v: DVec3) -> Option<[f64; 2]> {
        self.current_dual.map(|(d1, d2)| [d1.dot(v), d2.dot(v)])
    }
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

    #[test]
    fn map_round_trip_through_a_stretch() {
        let mesh = Mesh::new(
            vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let cur = [
            DVec3::ZERO,
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::new(0.0, 0.0, 3.0),
        ];
        let m = TriMap::new(&mesh, &cur, 0);
        let v = DVec3::new(0.25, 0.5, 0.0);
        let c = m.to_current(v).unwrap();
        assert!((c - DVec3::new(0.0, 0.5, 1.5)).length() < 1e-15);
        let back = m.increments(c).unwrap();
        assert!((from_bary(DVec3::X, DVec3::Y, back) - v).length() < 1e-15);
        assert!((m.normal.unwrap() - DVec3::X).length() < 1e-15);
    }
}
