//! Exact orientation predicates for every finite f64 input.
//!
//! Every sign here is the mathematically correct one for the given doubles: no
//! epsilons, no case lost to rounding, overflow or underflow, at any scale and
//! any spread of coordinates. Two exact evaluations sit behind one interface,
//! [`Orientation`] (signs over a small set of points named by index):
//!
//! - [`Expansion`]: Shewchuk's adaptive expansions (`robust` crate) on the
//!   points moved by one power of two ([`scale_exactly`]). Exact whenever the
//!   non-zero coordinates of the set span less than 2^500 (see
//!   [`Expansion::new`] for the bound): every real mesh, at any scale.
//! - [`super::exact_int::BigInts`]: the same signs on arbitrary-precision
//!   integers (every double is m 2^e; all are shifted to the smallest e). Exact
//!   for any finite doubles; used only for sets [`Expansion::new`] refuses.
//!
//! Callers pick with `Expansion::new(points)`, falling back to `BigInts`.

use super::exact_int::BigInts;
use glam::DVec3;
use robust::{Coord, Coord3D};
use std::cmp::Ordering;

/// Exact signs over a fixed set of points named by index: the whole vocabulary
/// of the triangle-triangle decision ([`super::tri_tri`]). Implementations
/// must return the mathematically exact answer for the points they hold.
pub trait Orientation {
    /// Sign of det[a - d, b - d, c - d] for points `[a, b, c, d]`: +1 when d
    /// lies below the plane through a, b, c seen counter-clockwise from above.
    fn orient3d(&self, p: [usize; 4]) -> i8;
    /// Sign of the signed area of `[a, b, c]` projected along `axis` (see [`project`]).
    fn orient2d(&self, axis: usize, p: [usize; 3]) -> i8;
    /// Compares coordinate `axis` of points `i` and `j`.
    fn cmp(&self, axis: usize, i: usize, j: usize) -> Ordering;
    /// An axis along which triangle `p`'s normal has a non-zero component (so
    /// that dropping it projects the plane one-to-one); None when the corners
    /// are collinear or coincide. Any such axis gives the same exact answers.
    fn normal_axis(&self, p: [usize; 3]) -> Option<usize> {
        (0..3).find(|&k| self.orient2d(k, p) != 0)
    }
    /// Points `i` and `j` coincide.
    fn same(&self, i: usize, j: usize) -> bool {
        (0..3).all(|k| self.cmp(k, i, j) == Ordering::Equal)
    }
}

/// Sign of the volume of tetrahedron (a, b, c, d): +1, 0 or -1.
/// Positive when d lies below the plane through a, b, c seen counter-clockwise
/// from above. Exact while no product overflows or underflows: use
/// [`Expansion`] for inputs of any scale.
///
/// Out of line on purpose: then the `robust` call is inlined into it (when this
/// was inlined into its callers instead, `robust` stayed a separate call and the
/// exact path cost a third more instructions on the garments).
#[inline(never)]
pub fn orient3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> i8 {
    let c3 = |p: DVec3| Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    };
    sign(robust::orient3d(c3(a), c3(b), c3(c), c3(d)))
}

/// Sign of twice the signed area of triangle (a, b, c): +1 counter-clockwise,
/// 0 collinear, -1 clockwise (same range of exactness as [`orient3d`]).
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

/// True when a, b, c are exactly collinear (or coincide): the triangle has no
/// normal. Exact for any finite input.
pub fn is_degenerate(a: DVec3, b: DVec3, c: DVec3) -> bool {
    let p = [a, b, c];
    match Expansion::new(p) {
        Some(k) => k.normal_axis([0, 1, 2]).is_none(),
        None => BigInts::new(&p).normal_axis([0, 1, 2]).is_none(),
    }
}

/// Shewchuk's expansion arithmetic on `N` points moved by one power of two.
#[derive(Debug, Clone, Copy)]
pub struct Expansion<const N: usize> {
    p: [DVec3; N],
}

/// Largest ratio (as a power of two) between the largest coordinate and the
/// smallest non-zero one that [`Expansion`] accepts.
const MAX_SPREAD: i32 = 500;

impl<const N: usize> Expansion<N> {
    /// The points scaled by [`scale_exactly`] (largest coordinate in
    /// [2^300, 2^301)), or None when their non-zero coordinates span 2^500 or
    /// more (or one is infinite): then use [`BigInts`]. Precondition: no NaN.
    ///
    /// Why this is exact: afterwards every non-zero coordinate lies in
    /// [2^-200, 2^301), so (having 53 bits) it is a multiple of 2^-252. A
    /// coordinate difference is below 2^302, an orientation term (a product of
    /// three differences) below 2^906 and a multiple of 2^-756, as is every
    /// partial product and rounding error Shewchuk's expansions form; the
    /// adaptive stages' error bounds (about 2^-110 times such terms) stay above
    /// 2^-870. Nothing overflows and nothing underflows, so each expansion is
    /// the exact value and each sign is exact. The scaling itself is exact (no
    /// coordinate leaves the normal range) and changes no sign (every
    /// predicate is homogeneous).
    #[inline]
    pub fn new(mut p: [DVec3; N]) -> Option<Self> {
        let (mut hi, mut lo) = (0.0f64, f64::INFINITY);
        for x in p.iter().flat_map(|q| q.to_array()) {
            let a = x.abs();
            hi = hi.max(a);
            lo = lo.min(if a == 0.0 { f64::INFINITY } else { a });
        }
        if !hi.is_finite() {
            return None;
        }
        if hi != 0.0 {
            let top = exponent(hi);
            if top - exponent(lo) >= MAX_SPREAD {
                return None;
            }
            // What `scale_exactly` does, with the largest coordinate already known.
            let k = SAFE_EXPONENT - top;
            p.iter_mut().for_each(|q| *q = mul_pow2(*q, k));
        }
        Some(Expansion { p })
    }

    /// The scaled points.
    #[inline]
    pub fn points(&self) -> &[DVec3; N] {
        &self.p
    }
}

impl<const N: usize> Orientation for Expansion<N> {
    #[inline]
    fn orient3d(&self, [a, b, c, d]: [usize; 4]) -> i8 {
        let p = &self.p;
        orient3d(p[a], p[b], p[c], p[d])
    }

    #[inline]
    fn orient2d(&self, axis: usize, [a, b, c]: [usize; 3]) -> i8 {
        let q = |i: usize| project(self.p[i], axis);
        orient2d(q(a), q(b), q(c))
    }

    #[inline]
    fn cmp(&self, axis: usize, i: usize, j: usize) -> Ordering {
        let (x, y) = (self.p[i][axis], self.p[j][axis]);
        // Not total_cmp: -0 and +0 are the same coordinate.
        if x < y {
            Ordering::Less
        } else if x > y {
            Ordering::Greater
        } else {
            Ordering::Equal
        }
    }

    /// The axis of the largest normal component (best conditioned; any
    /// non-zero one would be exact).
    #[inline]
    fn normal_axis(&self, [a, b, c]: [usize; 3]) -> Option<usize> {
        let n = [0, 1, 2].map(|k| {
            let q = |i: usize| project(self.p[i], k);
            orient2d_value(q(a), q(b), q(c)).abs()
        });
        let best = (1..3).fold(0, |best, k| if n[k] > n[best] { k } else { best });
        (n[best] != 0.0).then_some(best)
    }
}

/// Exponent the largest coordinate is moved to by [`scale_exactly`].
const SAFE_EXPONENT: i32 = 300;

/// Multiplies `points` by one power of two so that their largest coordinate
/// lies in [2^300, 2^301) (all-zero input is left alone). Orientation signs
/// are unchanged (every predicate is homogeneous), and the scaling is exact
/// unless a coordinate falls below 2^-1022 (more than 2^1322 under the
/// largest); [`Expansion::new`] applies it only where it is exact.
pub fn scale_exactly(points: &mut [DVec3]) {
    let m = points
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    if m == 0.0 || !m.is_finite() {
        return;
    }
    let k = SAFE_EXPONENT - exponent(m);
    points.iter_mut().for_each(|p| *p = mul_pow2(*p, k));
}

/// x 2^k (for f64 or DVec3), in at most three exactly representable steps
/// (|k| may exceed 1023): exact unless the result leaves the normal range.
pub(crate) fn mul_pow2<T: std::ops::Mul<f64, Output = T>>(mut x: T, mut k: i32) -> T {
    while k != 0 {
        let step = k.clamp(-1000, 1000);
        x = x * f64::from_bits(((1023 + step) as u64) << 52);
        k -= step;
    }
    x
}

/// floor(log2 |x|) for finite non-zero x (subnormals included).
pub(crate) fn exponent(x: f64) -> i32 {
    let bits = x.abs().to_bits();
    let e = (bits >> 52) as i32;
    if e == 0 {
        // Subnormal: 2^-1074 times the mantissa.
        -1074 + (63 - bits.leading_zeros() as i32)
    } else {
        e - 1023
    }
}

/// 2^-1021: added to the filter's permanent to cover underflow.
const UNDERFLOW: f64 = 4.450147717014403e-308;

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
///
/// Underflow adds an absolute error of at most 2^-1075 to each product (and
/// none to a sum). The six products u_i v_j reach d multiplied by |w_k|, the
/// three w_k n_k directly: at most |w|_1 2^-1074 + 2^-1073 in all (up to a
/// factor 1 + 5u). Adding 2^-1021 to each component of P's cross-product
/// factor adds 16u 2^-1021 |w|_1 = 2^-1070 |w|_1 to the bound, sixteen times
/// the first part, and the constant is far below the smallest bound used
/// (2^-960). It matters when the coordinates span a wide range (a huge w
/// against a cross product whose products underflow); it changes no bound of
/// an ordinary pair.
#[inline]
pub fn certainly_one_side(t: &[DVec3; 3], p: &[DVec3; 3]) -> bool {
    const MIN_BOUND: f64 = 1.0e-289; // < 2^-960
    let (u, v) = (t[1] - t[0], t[2] - t[0]);
    let n = u.cross(v);
    let perm = DVec3::new(
        (u.y * v.z).abs() + (u.z * v.y).abs(),
        (u.z * v.x).abs() + (u.x * v.z).abs(),
        (u.x * v.y).abs() + (u.y * v.x).abs(),
    ) + DVec3::splat(UNDERFLOW);
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
        assert_eq!(UNDERFLOW, 2.0 * f64::MIN_POSITIVE);
        // A huge w against a cross product whose products underflow: the true
        // side is 2^-100 - 2^-101 (the first from u.y v.z = 2^-1100, which
        // underflows), the computed one sees only the -2^-101; undecided, never "below".
        let s = 2f64.powi(-550);
        let t2 = [
            DVec3::ZERO,
            DVec3::new(0.0, s, 0.0),
            DVec3::new(-1.0, 0.0, s),
        ];
        let q = DVec3::new(2f64.powi(1000), 0.0, -(2f64.powi(449)));
        assert!(!certainly_one_side(&t2, &[q; 3]));
        // Overflow: undecided, never wrong.
        let huge = above.map(|q| q * 1e300);
        assert!(!certainly_one_side(&t.map(|q| q * 1e300), &huge));
    }

    #[test]
    fn expansions_refuse_wide_spreads_and_big_integers_take_them() {
        let near = [
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(2f64.powi(-400), 0.0, -0.0),
        ];
        assert!(Expansion::new(near).is_some());
        let far = [DVec3::new(1e300, 0.0, 0.0), DVec3::new(1e-300, 0.0, 0.0)];
        assert!(Expansion::new(far).is_none());
        assert!(Expansion::new([DVec3::new(f64::INFINITY, 0.0, 0.0)]).is_none());
        assert!(Expansion::new([DVec3::ZERO; 3]).is_some());
        // Collinear only in exact arithmetic: (0,0,0), (t, t, 0), (1e300, 1e300, 0)
        // with t subnormal; one ulp of the far point off the line is not.
        let t = f64::from_bits(3);
        let (o, a) = (DVec3::ZERO, DVec3::new(t, t, 0.0));
        let b = DVec3::new(1e300, 1e300, 0.0);
        assert!(is_degenerate(o, a, b));
        let b_up = DVec3::new(1e300, f64::from_bits(1e300f64.to_bits() + 1), 0.0);
        assert!(!is_degenerate(o, a, b_up));
        // Largest finite values: the edge vectors overflow f64, the sign does not.
        let m = f64::MAX;
        assert!(is_degenerate(
            DVec3::splat(-m),
            DVec3::splat(m),
            DVec3::splat(t)
        ));
        assert!(!is_degenerate(
            DVec3::splat(-m),
            DVec3::splat(m),
            DVec3::new(t, t, 0.0)
        ));
    }
}
