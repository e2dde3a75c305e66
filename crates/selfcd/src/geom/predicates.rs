//! Exact orientation predicates (Shewchuk's adaptive arithmetic, `robust` crate)
//! and the exact 2D tests built on them.
//!
//! Every function here returns the mathematically correct answer for its f64
//! inputs: no epsilons, no case lost to rounding.

use glam::DVec3;
use robust::{Coord, Coord3D};

/// Sign of the volume of tetrahedron (a, b, c, d): +1, 0 or -1.
/// Positive when d lies below the plane through a, b, c seen counter-clockwise from above.
#[inline]
pub fn orient3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> i8 {
    let c3 = |p: DVec3| Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    };
    sign(robust::orient3d(c3(a), c3(b), c3(c), c3(d)))
}

/// Sign of twice the signed area of triangle (a, b, c): +1 counter-clockwise, 0 collinear, -1 clockwise.
#[inline]
pub fn orient2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> i8 {
    sign(orient2d_value(a, b, c))
}

/// Twice the signed area of (a, b, c): sign exact, magnitude approximate.
#[inline]
fn orient2d_value(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    let c2 = |p: [f64; 2]| Coord { x: p[0], y: p[1] };
    robust::orient2d(c2(a), c2(b), c2(c))
}

#[inline]
fn sign(x: f64) -> i8 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// Drops coordinate `axis` keeping the other two in cyclic order, so that the
/// projection keeps orientation for normals pointing along +axis.
#[inline]
pub fn project(p: DVec3, axis: usize) -> [f64; 2] {
    match axis {
        0 => [p.y, p.z],
        1 => [p.z, p.x],
        _ => [p.x, p.y],
    }
}

/// Signed normal components of (a, b, c), each with its exact sign (magnitudes approximate).
#[inline]
fn normal_signs(a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    [0, 1, 2].map(|k| orient2d_value(project(a, k), project(b, k), project(c, k)))
}

/// True when a, b, c are exactly collinear (or coincide): the triangle has no normal.
pub fn is_degenerate(a: DVec3, b: DVec3, c: DVec3) -> bool {
    normal_signs(a, b, c) == [0.0; 3]
}

/// The axis along which triangle (a, b, c) has its largest normal component.
/// Dropping it projects the triangle's plane one-to-one; the chosen component is
/// exactly non-zero whenever the triangle is not degenerate.
pub fn dominant_axis(a: DVec3, b: DVec3, c: DVec3) -> usize {
    let n = normal_signs(a, b, c);
    let mut best = 0;
    for k in 1..3 {
        if n[k].abs() > n[best].abs() {
            best = k;
        }
    }
    best
}

/// True when collinear point `p` lies on the closed segment [a, b] (exact comparisons).
#[inline]
fn on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> bool {
    (0..2).all(|k| a[k].min(b[k]) <= p[k] && p[k] <= a[k].max(b[k]))
}

/// Do closed 2D segments [p1, p2] and [q1, q2] share a point? Zero-length segments allowed.
pub fn segments_intersect_2d(p1: [f64; 2], p2: [f64; 2], q1: [f64; 2], q2: [f64; 2]) -> bool {
    let d1 = orient2d(q1, q2, p1);
    let d2 = orient2d(q1, q2, p2);
    let d3 = orient2d(p1, p2, q1);
    let d4 = orient2d(p1, p2, q2);
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    (d1 == 0 && on_segment(q1, q2, p1))
        || (d2 == 0 && on_segment(q1, q2, p2))
        || (d3 == 0 && on_segment(p1, p2, q1))
        || (d4 == 0 && on_segment(p1, p2, q2))
}

/// Is `p` in the closed 2D triangle t (any orientation, t not degenerate)?
pub fn point_in_triangle_2d(p: [f64; 2], t: [[f64; 2]; 3]) -> bool {
    let o = [
        orient2d(t[0], t[1], p),
        orient2d(t[1], t[2], p),
        orient2d(t[2], t[0], p),
    ];
    o.iter().all(|&s| s >= 0) || o.iter().all(|&s| s <= 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orientation_is_exact_near_degeneracy() {
        // Points on the line y = x with coordinates that round badly in naive arithmetic.
        let a = [0.5, 0.5];
        let b = [12.0, 12.0];
        let c = [24.0, 24.0];
        assert_eq!(orient2d(a, b, c), 0);
        let c_up = [24.0, f64::from_bits(24.0f64.to_bits() + 1)];
        assert_eq!(orient2d(a, b, c_up), 1);
        let d = DVec3::new(0.5, 0.25, 1.0);
        assert_eq!(
            orient3d(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ZERO + d * 0.0),
            0
        );
        assert!(is_degenerate(DVec3::ZERO, d, 3.0 * d));
        assert!(!is_degenerate(DVec3::ZERO, d, DVec3::X));
    }

    #[test]
    fn segments_touching_and_collinear() {
        assert!(segments_intersect_2d(
            [0., 0.],
            [1., 0.],
            [1., 0.],
            [2., 5.]
        ));
        assert!(segments_intersect_2d(
            [0., 0.],
            [2., 0.],
            [1., 0.],
            [3., 0.]
        ));
        assert!(!segments_intersect_2d(
            [0., 0.],
            [1., 0.],
            [2., 0.],
            [3., 0.]
        ));
        assert!(segments_intersect_2d(
            [0., 0.],
            [0., 0.],
            [-1., -1.],
            [1., 1.]
        ));
        assert!(point_in_triangle_2d(
            [0., 0.],
            [[0., 0.], [1., 0.], [0., 1.]]
        ));
        assert!(!point_in_triangle_2d(
            [1., 1.],
            [[0., 0.], [1., 0.], [0., 1.]]
        ));
    }
}
