//! Orientation signs on arbitrary-precision integers: exact for any finite
//! doubles, at any scale and any spread.
//!
//! Every finite double is m 2^e with an integer m (|m| < 2^53) and an integer
//! e >= -1074. Shifting all coordinates of a point set to the smallest
//! exponent E present gives integers X = m 2^(e - E) (at most 2^2098) whose
//! ratios are the ratios of the doubles, so every orientation determinant of
//! the integers is the determinant of the doubles times a positive power of
//! two: same sign. Integer arithmetic has no rounding, overflow or underflow.
//!
//! Slow (a determinant of 2000-bit integers); the triangle test uses it only
//! for the rare point sets [`super::predicates::Expansion`] cannot take.

use super::predicates::Orientation;
use glam::DVec3;
use num_bigint::{BigInt, Sign};
use std::cmp::Ordering;

/// The exact integer image of a point set (coordinates scaled by 2^-E).
#[derive(Debug, Clone)]
pub struct BigInts {
    p: Vec<[BigInt; 3]>,
}

/// Integer mantissa and exponent of a finite double: x = m 2^e, m odd or zero.
fn decompose(x: f64) -> (i64, i32) {
    let bits = x.to_bits();
    let field = ((bits >> 52) & 0x7ff) as i32;
    let frac = (bits & ((1u64 << 52) - 1)) as i64;
    let (mut m, mut e) = if field == 0 {
        (frac, -1074) // subnormal (or zero)
    } else {
        (frac | (1i64 << 52), field - 1075)
    };
    if m != 0 {
        let tz = m.trailing_zeros();
        m >>= tz;
        e += tz as i32;
    }
    (if bits >> 63 == 1 { -m } else { m }, e)
}

impl BigInts {
    /// Exact integer images of `points`. Precondition: every coordinate is
    /// finite (the mesh and position checks refuse the others).
    pub fn new(points: &[DVec3]) -> BigInts {
        let parts: Vec<[(i64, i32); 3]> =
            points.iter().map(|q| q.to_array().map(decompose)).collect();
        let base = parts
            .iter()
            .flatten()
            .filter(|(m, _)| *m != 0)
            .map(|&(_, e)| e)
            .min()
            .unwrap_or(0);
        let p = parts
            .iter()
            .map(|c| c.map(|(m, e)| BigInt::from(m) << (e - base) as usize))
            .collect();
        BigInts { p }
    }

    /// Coordinate `axis` of point `i` minus that of point `j`.
    fn diff(&self, axis: usize, i: usize, j: usize) -> BigInt {
        &self.p[i][axis] - &self.p[j][axis]
    }
}

fn sign(x: &BigInt) -> i8 {
    match x.sign() {
        Sign::Plus => 1,
        Sign::Minus => -1,
        Sign::NoSign => 0,
    }
}

impl Orientation for BigInts {
    fn orient3d(&self, [a, b, c, d]: [usize; 4]) -> i8 {
        let r = |i: usize| [0, 1, 2].map(|k| self.diff(k, i, d));
        let (u, v, w) = (r(a), r(b), r(c));
        let det = &u[0] * (&v[1] * &w[2] - &v[2] * &w[1]) - &u[1] * (&v[0] * &w[2] - &v[2] * &w[0])
            + &u[2] * (&v[0] * &w[1] - &v[1] * &w[0]);
        sign(&det)
    }

    fn orient2d(&self, axis: usize, [a, b, c]: [usize; 3]) -> i8 {
        // The two kept coordinates in the cyclic order of `predicates::project`.
        let (x, y) = ((axis + 1) % 3, (axis + 2) % 3);
        let det = self.diff(x, a, c) * self.diff(y, b, c) - self.diff(y, a, c) * self.diff(x, b, c);
        sign(&det)
    }

    fn cmp(&self, axis: usize, i: usize, j: usize) -> Ordering {
        self.p[i][axis].cmp(&self.p[j][axis])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::predicates::{orient3d, Expansion};

    #[test]
    fn decompose_is_exact() {
        for x in [
            0.0,
            -0.0,
            1.0,
            -3.0,
            0.1,
            f64::MAX,
            -f64::MIN_POSITIVE,
            f64::from_bits(5),
        ] {
            let (m, e) = decompose(x);
            assert_eq!(
                m as f64 * 2f64.powi(e.clamp(-1000, 1000)) * 2f64.powi(e - e.clamp(-1000, 1000)),
                x
            );
        }
        assert_eq!(decompose(f64::from_bits(1)), (1, -1074));
        assert_eq!(decompose(-6.0), (-3, 1));
    }

    #[test]
    fn agrees_with_expansions_where_both_apply() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s % 9) as f64 * 0.25 - 1.0
        };
        for _ in 0..2000 {
            let p: [DVec3; 4] = [(); 4].map(|_| DVec3::new(next(), next(), next()));
            let big = BigInts::new(&p);
            let e = Expansion::new(p).unwrap();
            assert_eq!(big.orient3d([0, 1, 2, 3]), orient3d(p[0], p[1], p[2], p[3]));
            assert_eq!(big.orient3d([0, 1, 2, 3]), e.orient3d([0, 1, 2, 3]));
            for k in 0..3 {
                assert_eq!(big.orient2d(k, [0, 1, 2]), e.orient2d(k, [0, 1, 2]));
                assert_eq!(big.cmp(k, 0, 1), e.cmp(k, 0, 1));
            }
        }
    }
}
