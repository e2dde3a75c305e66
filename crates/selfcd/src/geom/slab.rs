//! Slabs: bounds on `v . x` over a set of points, along an axis `v` of
//! length at most 1 (a node's cone axis).
//!
//! A hierarchy node keeps the slab of its triangles along its own cone axis.
//! For a patch whose normals lie in a narrow cone the slab is thin (the
//! patch's height variation), where its axis-aligned box is as thick as the
//! patch is wide and slanted; two layers of cloth closer than their
//! triangles are wide have overlapping boxes but disjoint slabs.
//!
//! **Along another axis.** A set with `u . x` in `[lo, hi]` and `x` in a box
//! of centre `c` and half-extents `h` has, along `v`, with `s = v . u` and
//! `w = v - s u`: `v . x = s (u . x) + w . c + w . (x - c)`, so
//! `v . x` lies in `s [lo, hi] + w . c +- |w| . h` ([`Slab::carry`]). The
//! bound is tight when `v` is close to `u` (w small): a parent's slab is its
//! children's slabs carried to its axis, and a pair of nodes is apart when
//! one's slab is apart from the other's carried to it.
//!
//! **Rounding.** Slabs are computed in floating point and widened once for
//! all: [`carry_error`] bounds the rounding of a triangle's slab and of a
//! carry by the largest coordinate `m` of the hierarchy (each term is at
//! most `16 m` and takes a few roundings; the margin, `1e-13 m + 1e-300`, is
//! over 40 times that). A parent's slab is its carried children's, cut to
//! its box's own range along its axis (so that no slab's ends exceed about
//! `2 m`, and the bound holds at every level), widened by it; a pair is apart
//! only when its slabs are more than the gap plus that margin apart. Where
//! `m` exceeds 1e300 no slab is used.

use super::Aabb;
use glam::DVec3;

/// A closed range `[lo, hi]` of `v . x` along some axis `v`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slab {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

impl Slab {
    /// The whole line: bounds nothing.
    pub const ALL: Slab = Slab {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// The slab of a triangle's corners along `v` (|v| <= 1), up to the
    /// rounding [`carry_error`] bounds.
    #[inline]
    pub fn of_corners(v: DVec3, c: &[DVec3; 3]) -> Slab {
        let d = c.map(|p| v.dot(p));
        Slab {
            lo: d[0].min(d[1]).min(d[2]),
            hi: d[0].max(d[1]).max(d[2]),
        }
    }

    /// A bound along `v` (|v| <= 1) on a set that is in `self` along `u`
    /// (|u| <= 1) and in `b` (see the module doc), up to rounding: widen it
    /// by [`carry_error`] (or compare with that margin) before relying on it.
    #[inline]
    pub fn carry(&self, u: DVec3, b: &Aabb, v: DVec3) -> Slab {
        let s = v.dot(u);
        let (a, z) = (s * self.lo, s * self.hi);
        let rest = Slab::of_box(v - s * u, b);
        Slab {
            lo: a.min(z) + rest.lo,
            hi: a.max(z) + rest.hi,
        }
    }

    /// The range of `v . x` over box `b` (any `v`), up to rounding.
    #[inline]
    pub fn of_box(v: DVec3, b: &Aabb) -> Slab {
        let mid = 0.5 * v.dot(b.min + b.max);
        let half = 0.5 * v.abs().dot(b.max - b.min);
        Slab {
            lo: mid - half,
            hi: mid + half,
        }
    }

    /// The common part of two bounds on one set (on the same axis).
    #[inline]
    pub fn intersect(&self, o: &Slab) -> Slab {
        Slab {
            lo: self.lo.max(o.lo),
            hi: self.hi.min(o.hi),
        }
    }

    /// Widened by `err` on both sides; [`ALL`](Self::ALL) when not finite.
    #[inline]
    pub fn widen(&self, err: f64) -> Slab {
        let s = Slab {
            lo: self.lo - err,
            hi: self.hi + err,
        };
        if s.lo.is_finite() && s.hi.is_finite() {
            s
        } else {
            Slab::ALL
        }
    }

    /// The smallest slab holding both (on the same axis).
    #[inline]
    pub fn union(&self, o: &Slab) -> Slab {
        Slab {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    /// True when the ranges are more than `gap` apart (never for
    /// [`ALL`](Self::ALL), nor when either end is NaN).
    #[inline]
    pub fn apart(&self, o: &Slab, gap: f64) -> bool {
        o.lo - self.hi > gap || self.lo - o.hi > gap
    }
}

/// A bound on the rounding of [`Slab::carry`] for slabs and boxes whose
/// coordinates are at most `m` in magnitude (slab ends at most `2 m`): every
/// term of the carry is at most `16 m` and takes a few roundings. None when
/// `m` exceeds 1e300, where a carry could overflow: no slab bounds anything there.
#[inline]
pub fn carry_error(m: f64) -> Option<f64> {
    (m <= 1e300).then_some(1e-13 * m + 1e-300)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SplitMix;

    fn unit(rng: &mut SplitMix) -> DVec3 {
        DVec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5).normalize()
    }

    #[test]
    fn carried_slabs_hold_every_point() {
        let mut rng = SplitMix::new(5);
        for k in 0..2000 {
            let scale = [1e-200, 1e-3, 1.0, 1e4, 1e200][k % 5];
            let offset = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * scale * 10.0;
            let mut tri = || {
                [0; 3]
                    .map(|_| offset + DVec3::new(rng.unit(), rng.unit(), 0.01 * rng.unit()) * scale)
            };
            let (t, s) = (tri(), tri());
            let (u, w, v) = (unit(&mut rng), unit(&mut rng), unit(&mut rng));
            let (bt, bs) = (Aabb::from_points(&t), Aabb::from_points(&s));
            let b = bt.union(&bs);
            let err = carry_error(b.magnitude()).unwrap();
            // A parent of the two triangles, as `Bvh::fit_slabs` makes it.
            let (st, ss) = (Slab::of_corners(u, &t), Slab::of_corners(w, &s));
            let carried = st.carry(u, &bt, v).union(&ss.carry(w, &bs, v));
            let parent = carried.intersect(&Slab::of_box(v, &b)).widen(err);
            let carried = parent.carry(v, &b, u).widen(err);
            for p in t.iter().chain(&s) {
                let d = v.dot(*p);
                assert!(parent.lo <= d && d <= parent.hi, "{k}");
                let d = u.dot(*p);
                assert!(carried.lo <= d && d <= carried.hi, "{k}");
            }
        }
    }

    #[test]
    fn parallel_layers_are_apart_where_boxes_are_not() {
        // Two slanted unit squares (two triangles each) 1e-3 apart along their normal.
        let n = DVec3::new(1.0, 1.0, 1.0).normalize();
        let e1 = DVec3::new(1.0, -1.0, 0.0).normalize();
        let e2 = n.cross(e1);
        let square = |o: f64| {
            let c = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
                .map(|[a, b]| a * e1 + b * e2 + o * n);
            let slab = Slab::of_corners(n, &[c[0], c[1], c[2]])
                .union(&Slab::of_corners(n, &[c[0], c[2], c[3]]));
            (slab, Aabb::from_points(&c))
        };
        let ((sp, bp), (sq, bq)) = (square(0.0), square(1e-3));
        assert!(bp.overlaps(&bq));
        let err = carry_error(2.0).unwrap();
        assert!(sp.apart(&sq.carry(n, &bq, n), err));
        assert!(
            !sp.apart(&sq.carry(n, &bq, n), 2e-3 + err),
            "within the gap"
        );
        assert!(!Slab::ALL.apart(&sp, 0.0) && !sp.apart(&Slab::ALL, 0.0));
    }

    #[test]
    fn no_margin_beyond_1e300() {
        assert_eq!(carry_error(1e301), None);
        assert_eq!(carry_error(f64::INFINITY), None);
        assert!(carry_error(1e300).is_some_and(|e| e.is_finite()));
        let big = DVec3::splat(1e308);
        let b = Aabb::from_points(&[big, -big]);
        assert_eq!(
            Slab {
                lo: -1e308,
                hi: 1e308
            }
            .widen(1e308),
            Slab::ALL
        );
        assert!(!Slab::ALL
            .carry(DVec3::X, &b, DVec3::Y)
            .apart(&Slab::ALL, 0.0));
    }
}
