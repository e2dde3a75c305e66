//! Exact orientation predicates (Shewchuk's adaptive arithmetic, `robust` crate)
//! and the exact 2D tests built on them.
//!
//! Every function here returns the mathematically correct answer for its f64
//! inputs: no epsilons, no case lost to rounding. Shewchuk's arithmetic is
//! exact only while no product overflows or underflows, so callers that may
//! see any finite scale first move their points with [`scale_exactly`].

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
pub fn orient2d_value(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
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

/// True when a, b, c are exactly collinear (or coincide): the triangle has no
/// normal. Exact at any scale (the points are scaled by a power of two first).
pub fn is_degenerate(a: DVec3, b: DVec3, c: DVec3) -> bool {
    let mut p = [a, b, c];
    scale_exactly(&mut p);
    normal_signs(p[0], p[1], p[2]) == [0.0; 3]
}

/// Exponent the largest coordinate is moved to by [`scale_exactly`].
const SAFE_EXPONENT: i32 = 300;

/// Multiplies `points` by one power of two so that their largest coordinate
/// lies in [2^300, 2^301) (all-zero input is left alone). Orientation signs
/// are unchanged (every predicate is homogeneous), and the scaling is exact
/// unless a coordinate falls below 2^-1022 (more than 2^1322 under the
/// largest). Afterwards the exact predicates cannot overflow (a product of
/// three differences stays below 2^906), and they cannot underflow while every
/// non-zero coordinate is at least 2^-300 (each term of an orientation
/// determinant is a multiple of 2^-1074): so they are exact whenever the
/// non-zero coordinates of one call span less than 2^600, at any scale.
pub fn scale_exactly(points: &mut [DVec3]) {
    let m = points
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    if m == 0.0 || !m.is_finite() {
        return;
    }
    let mut k = SAFE_EXPONENT - exponent(m);
    // 2^k in at most three exactly representable steps (|k| may exceed 1023).
    while k != 0 {
        let step = k.clamp(-1000, 1000);
        let f = f64::from_bits(((1023 + step) as u64) << 52);
        points.iter_mut().for_each(|p| *p *= f);
        k -= step;
    }
}

/// floor(log2 |x|) for finite non-zero x (subnormals included).
fn exponent(x: f64) -> i32 {
    let bits = x.abs().to_bits();
    let e = (bits >> 52) as i32;
    if e == 0 {
        // Subnormal: 2^-1074 times the mantissa.
        -1074 + (63 - bits.leading_zeros() as i32)
    } else {
        e - 1023
    }
}

/// Unit roundoff of f64 (2^-53).
const UNIT: f64 = f64::EPSILON / 2.0;

/// Floating-point filter: true only when every point of `p` lies strictly on
/// one side of the plane of triangle `t` (then `p` and `t` cannot meet);
/// false means "not decided" (use the exact predicates).
///
/// Error bound: the side of q is d = (q - t0) . ((t1 - t0) x (t2 - t0)), a sum
/// of six signed terms w_k u_i v_j, each computed with at most eight roundings
/// (three differences, two products, the cross product's subtraction, two
/// additions of the dot product), so |fl(d) - d| <= gamma_8 P where P is the
/// exact sum of |w_k u_i v_j| (Higham, Accuracy and Stability, 3.1) and gamma_8
/// = 8u / (1 - 8u). The computed P is at least (1 - gamma_9) times the exact
/// one, so 16u times the computed P bounds the error with room to spare. The
/// decision is refused when that bound is below 2^-960 (underflow could break
/// the analysis there) or anything is not finite (overflow).
#[inline]
pub fn certainly_one_side(t: &[DVec3; 3], p: &[DVec3; 3]) -> bool {
    const MIN_BOUND: f64 = 1.0e-289; // < 2^-960
    let (u, v) = (t[1] - t[0], t[2] - t[0]);
    let n = u.cross(v);
    let perm = DVec3::new(
        (u.y * v.z).abs() + (u.z * v.y).abs(),
        (u.z * v.x).abs() + (u.x * v.z).abs(),
        (u.x * v.y).abs() + (u.y * v.x).abs(),
    );
    let (mut above, mut below) = (0, 0);
    for q in p {
        let w = *q - t[0];
        let d = w.dot(n);
        let bound = 16.0 * UNIT * w.abs().dot(perm);
        if bound >= MIN_BOUND {
            above += (d > bound) as u32;
            below += (d < -bound) as u32;
        }
    }
    above == 3 || below == 3
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
    fn scaling_is_exact_and_keeps_signs() {
        let p = [DVec3::new(0.5, 0.25, 1.0), DVec3::new(-3.0, 1e-300, 7.0)];
        for s in [
            1.0,
            2f64.powi(1020),
            f64::from_bits(1),
            2f64.powi(-900),
            2f64.powi(1000),
        ] {
            let mut q = p.map(|x| x * s);
            scale_exactly(&mut q);
            let m = q.iter().fold(0.0f64, |m, x| m.max(x.abs().max_element()));
            if (p[1] * s).z != 0.0 {
                assert!(
                    (2f64.powi(300)..2f64.powi(301)).contains(&m),
                    "{s:e}: {m:e}"
                );
            }
        }
        // A unit triangle at 2^1000 and at 2^-1000: still not degenerate.
        for s in [2f64.powi(1000), 2f64.powi(-1000)] {
            assert!(!is_degenerate(DVec3::ZERO * s, DVec3::X * s, DVec3::Y * s));
        }
        assert_eq!(exponent(f64::from_bits(1)), -1074);
        assert_eq!(exponent(3.0), 1);
    }

    #[test]
    fn filter_decides_only_certain_sides() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let above = [
            DVec3::new(0.1, 0.1, 1.0),
            DVec3::new(2.0, 0.0, 0.5),
            DVec3::new(0.0, 0.0, 1e-3),
        ];
        assert!(certainly_one_side(&t, &above));
        let below = above.map(|q| q * DVec3::new(1.0, 1.0, -1.0));
        assert!(certainly_one_side(&t, &below));
        // Touching (a zero side) and one ulp above near a large offset: undecided.
        let touching = [above[0], above[1], DVec3::new(5.0, 5.0, 0.0)];
        assert!(!certainly_one_side(&t, &touching));
        let tiny = [above[0], above[1], DVec3::new(1e6, 1e6, 1e-300)];
        assert!(!certainly_one_side(&t, &tiny));
        // Overflow: undecided, never wrong.
        let huge = above.map(|q| q * 1e300);
        assert!(!certainly_one_side(&t.map(|q| q * 1e300), &huge));
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
