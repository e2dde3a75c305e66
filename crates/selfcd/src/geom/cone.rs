//! Normal cones: the paper's "positive vector", after Volino & Magnenat-Thalmann.
//!
//! A cone (axis a, half-angle h) bounds a set of unit normals n when
//! angle(n, a) <= h for each. If h < 90 degrees, a itself is a positive vector:
//! a . n > 0 for every normal under the cone.
//!
//! Angles are carried as (cos, sin) pairs and combined with the addition,
//! double- and half-angle formulas, so refitting a node (a merge) needs no
//! trigonometric call: three square roots, three divisions. A cone stores half
//! of its half-angle, q = h / 2, because the merged cone's half-angle is
//! H = q1 + d/2 + q2: only d/2 and the new H/2 need a square root.

use glam::DVec3;

/// Margin kept below 90 degrees before a cone counts as positive: cos h must exceed this.
const POSITIVE_MARGIN: f64 = 1e-9;

/// Rounding slack added to every merged half-angle (radians).
const MERGE_SLACK: f64 = 16.0 * f64::EPSILON;

/// An angle in [0, 2 PI) held as its cosine and sine.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Angle {
    c: f64,
    s: f64,
}

impl Angle {
    const ZERO: Angle = Angle { c: 1.0, s: 0.0 };

    #[inline]
    fn add(self, o: Angle) -> Angle {
        Angle {
            c: self.c * o.c - self.s * o.s,
            s: self.s * o.c + self.c * o.s,
        }
    }

    #[inline]
    fn sub(self, o: Angle) -> Angle {
        Angle {
            c: self.c * o.c + self.s * o.s,
            s: self.s * o.c - self.c * o.s,
        }
    }

    /// Twice an angle in [0, PI/2].
    #[inline]
    fn double(self) -> Angle {
        Angle {
            c: self.c * self.c - self.s * self.s,
            s: 2.0 * self.c * self.s,
        }
    }

    /// Half of an angle in [0, PI]; accurate near 0 and near PI.
    #[inline]
    fn half(self) -> Angle {
        if self.c >= 0.0 {
            let c = (0.5 * (1.0 + self.c)).sqrt();
            Angle {
                c,
                s: self.s / (2.0 * c),
            }
        } else {
            let s = (0.5 * (1.0 - self.c)).sqrt();
            Angle {
                c: self.s / (2.0 * s),
                s,
            }
        }
    }

    /// True for angles in [PI, 2 PI), given the angle is below 2 PI.
    #[inline]
    fn at_least_pi(self) -> bool {
        self.s < 0.0 || (self.s == 0.0 && self.c < 0.0)
    }

    /// x <= y for angles in [0, PI]: by sine on [0, PI/2] (cosine is flat near
    /// 0, sine is not), by cosine beyond.
    #[inline]
    fn le(self, y: Angle) -> bool {
        match (self.c >= 0.0, y.c >= 0.0) {
            (true, true) => self.s <= y.s,
            (false, false) => self.c >= y.c,
            (small, _) => small,
        }
    }

    /// Widened by a tiny angle `e` (first order, conservative for e << 1).
    #[inline]
    fn widen(self, e: f64) -> Angle {
        Angle {
            c: self.c - self.s.abs() * e - e * e,
            s: self.s + self.c * e,
        }
    }

    /// Angle between unit vectors a and b, in [0, PI].
    #[inline]
    fn between(a: DVec3, b: DVec3) -> Angle {
        Angle {
            c: a.dot(b),
            s: a.cross(b).length(),
        }
    }
}

/// A cone of directions: unit `axis` and a half-angle h in [0, PI], held as
/// the cosine and sine of h / 2; the full cone (every direction) has h = PI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalCone {
    /// Unit axis.
    pub axis: DVec3,
    quarter: Angle,
}

impl NormalCone {
    /// The cone holding every direction.
    pub const FULL: NormalCone = NormalCone {
        axis: DVec3::Z,
        quarter: Angle { c: 0.0, s: 1.0 },
    };

    /// The cone of triangle (a, b, c)'s normal, widened by the rounding error of
    /// the cross product so that it holds the exact normal. A degenerate
    /// triangle (no normal) gets the full cone.
    #[inline]
    pub fn of_triangle(a: DVec3, b: DVec3, c: DVec3) -> NormalCone {
        match Self::unit_normal(a, b, c) {
            Some(unit) => Self::of_unit(unit),
            None => NormalCone::FULL,
        }
    }

    /// The cone of the directions within `err` radians of unit `axis`.
    #[inline]
    fn of_unit((axis, err): (DVec3, f64)) -> NormalCone {
        NormalCone {
            axis,
            quarter: Angle::ZERO.widen(0.5 * err),
        }
    }

    /// Triangle (a, b, c)'s unit normal as computed, and a bound (radians) on
    /// its angle to the exact normal; `None` for a triangle too thin for that
    /// bound to stay under 1/8 radian (its normal is not known).
    #[inline]
    pub fn unit_normal(a: DVec3, b: DVec3, c: DVec3) -> Option<(DVec3, f64)> {
        let (e1, e2) = (b - a, c - a);
        let n = e1.cross(e2);
        let len2 = n.length_squared();
        let scale2 = e1.length_squared() * e2.length_squared();
        if !(len2 > (64.0 * f64::EPSILON) * (64.0 * f64::EPSILON) * scale2) {
            return None;
        }
        // |computed - exact| <= ~4 eps |e1||e2| per component: an angle of at
        // most asin(x) <= 1.06 x for x = 8 eps |e1||e2| / |n| <= 1/8.
        let inv = 1.0 / len2.sqrt();
        let err = 1.06 * 8.0 * f64::EPSILON * scale2.sqrt() * inv;
        Some((n * inv, err))
    }

    /// The cone around `axis` that holds the directions within `err` radians
    /// of each of `normals` (all vectors unit up to rounding): its half-angle
    /// is the largest angle from the axis to a normal, widened by `err` and
    /// by rounding. Any axis gives a valid cone; the normals' mean gives a
    /// tight one. A zero axis or no normal gives the full cone.
    ///
    /// The farthest normal is found by its dot product alone (a few
    /// instructions per normal, where a merge takes three square roots and a
    /// few dozen products). With the vectors' lengths within 3 eps of 1, the
    /// computed dots are within `delta = 16 eps` of the cosines, so every
    /// normal is within angle `acos(cos t - 2 delta)` of the axis, t being
    /// the angle of the one with the least dot. For t <= 90 degrees that is
    /// at most `t + p` with `1 - cos p = 2 delta` (cos(t + p) <= cos t - 2
    /// delta there, since 1 - cos t <= sin t and 2 delta <= sin p), and
    /// `p <= 2.02 sqrt(delta) < 9 sqrt(eps)` (1.3e-7 radians): the cone is
    /// widened by that. Past 90 degrees (a cone that is not positive at any
    /// width) the farthest angle is found exactly (`Angle::le`).
    pub fn around(axis: DVec3, normals: &[DVec3], err: f64) -> NormalCone {
        if axis == DVec3::ZERO || normals.is_empty() {
            return NormalCone::FULL;
        }
        let least = normals[least_dot(axis, normals)];
        if axis.dot(least) >= 0.0 {
            return Self::within_90_around(axis, least, err).unwrap_or(NormalCone::FULL);
        }
        let far = farthest(axis, normals);
        let quarter = far.half().widen(0.5 * (err + MERGE_SLACK));
        if quarter.c <= 0.0 {
            return NormalCone::FULL;
        }
        NormalCone { axis, quarter }
    }

    /// The cone of a run of leaf cones (each one triangle's normal,
    /// widened by its error, as [`of_triangle`](Self::of_triangle) makes
    /// them), computed from the leaves directly instead of by merges:
    /// [`within_90_around`](Self::within_90_around) an axis, widened by the
    /// largest leaf's half-angle, so it holds every direction of every leaf.
    /// The axis is the leaves' mean or, where that leaves a wider cone, the
    /// bisector of the leaf farthest from the mean and the leaf farthest
    /// from that one (Ritter's start for bounding spheres): within twice the
    /// narrowest cone's half-angle. The full cone when a leaf is full or
    /// wider than 90 degrees, when there is none, or when the cone would not
    /// be positive (only positive cones certify anything).
    pub fn around_leaves(leaves: &[NormalCone]) -> NormalCone {
        if leaves.iter().any(|c| !c.is_leaf_like()) {
            return NormalCone::FULL;
        }
        let widest = leaves.iter().fold(0.0f64, |w, c| w.max(c.quarter.s));
        let mean = leaves
            .iter()
            .map(|c| c.axis)
            .sum::<DVec3>()
            .normalize_or_zero();
        let farthest = |a: DVec3| {
            let least = leaves.iter().map(|c| (a.dot(c.axis), c.axis));
            least.fold(
                (f64::INFINITY, DVec3::ZERO),
                |x, y| if y.0 < x.0 { y } else { x },
            )
        };
        let (dot, p) = farthest(mean);
        let bisector = (p + farthest(p).1).normalize_or_zero();
        let (axis, least) = match farthest(bisector) {
            (d, q) if d > dot => (bisector, q),
            _ => (mean, p),
        };
        // A leaf's half-angle is 2q with sin q = s, and q <= 1.12 s for q
        // up to 45 degrees (`is_leaf_like`).
        Self::within_90_around(axis, least, 2.24 * widest).unwrap_or(NormalCone::FULL)
    }

    /// True when every direction under each of `leaves` (cones as
    /// [`around_leaves`](Self::around_leaves) takes) lies strictly within
    /// 90 degrees of unit `v`, with the margin of
    /// [`within_90_of`](Self::within_90_of) (1e-9 on a cosine): by one dot
    /// product a leaf, where `within_90_of` takes a square root. A leaf of axis a and
    /// half-angle h = 2q holds directions within 90 degrees of v when
    /// angle(a, v) < 90 - h, i.e. cos angle(a, v) > sin h, and sin h <= 2 sin q = 2s.
    /// With a and v unit up to a few eps, the computed dot is within 8 eps
    /// of that cosine, far below the margin added.
    pub fn leaves_within_90_of(leaves: &[NormalCone], v: DVec3) -> bool {
        leaves.iter().all(|c| {
            c.is_leaf_like()
                && c.axis.dot(v) > 2.0 * c.quarter.s + POSITIVE_MARGIN + 16.0 * f64::EPSILON
        })
    }

    /// A cone narrow enough for the leaf bounds above: not full, and its
    /// quarter angle at most 45 degrees (c >= s).
    #[inline]
    fn is_leaf_like(&self) -> bool {
        self.quarter.c >= self.quarter.s && self.quarter.s >= 0.0
    }

    /// [`around`](Self::around) when `least` is the normal with the least
    /// dot product with `axis` and that dot is not negative (`None`
    /// otherwise, or for a zero axis): callers that scan the normals their
    /// own way (in parallel, through an index) need only that one.
    pub fn within_90_around(axis: DVec3, least: DVec3, err: f64) -> Option<NormalCone> {
        let far = Angle::between(axis, least);
        if axis == DVec3::ZERO || far.c < 0.0 {
            return None;
        }
        let quarter = far.half().widen(0.5 * (err + 9.0 * f64::EPSILON.sqrt()));
        (quarter.c > 0.0).then_some(NormalCone { axis, quarter })
    }

    /// The cone of triangle (a, b, c)'s normal over the whole of a linear
    /// motion from corners `x0` to `x1`: the cone of its
    /// [`swept_unit_normals`](Self::swept_unit_normals), the full cone when
    /// they are not known.
    pub fn of_swept_triangle(x0: [DVec3; 3], x1: [DVec3; 3]) -> NormalCone {
        let Some(units) = Self::swept_unit_normals(x0, x1) else {
            return NormalCone::FULL;
        };
        let [c0, c1, c2] = units.map(Self::of_unit);
        // Equal cones (a triangle that does not move) are not merged: the
        // merge of two cones on one axis can round to the full cone.
        let merge = |a: NormalCone, b: NormalCone| if a == b { a } else { a.merge(&b) };
        merge(merge(c0, c1), c2)
    }

    /// The directions of a triangle's normal over a linear motion from
    /// corners `x0` to `x1`, as three unit vectors with bounds (radians) on
    /// their angles to exact vectors whose positive combinations hold every
    /// normal of the motion: with edges `e_k(t) = e_k + t d_k`, the normal
    /// `n(t) = e1(t) x e2(t)` is quadratic in t; in the Bernstein basis of
    /// [0, 1] its control vectors are `n(0)`, `n(0) + (e1 x d2 + d1 x e2) / 2`
    /// and `n(1)`, and `n(t)` is a positive combination of them. So a cone
    /// holding the three (each widened by its bound) holds `n(t)` for every
    /// t, and if it is positive no `n(t)` vanishes. `None` when a control
    /// vector is too short for its rounding (its bound would pass 1/8 radian).
    pub fn swept_unit_normals(x0: [DVec3; 3], x1: [DVec3; 3]) -> Option<[(DVec3, f64); 3]> {
        let (e1, e2) = (x0[1] - x0[0], x0[2] - x0[0]);
        let (f1, f2) = (x1[1] - x1[0], x1[2] - x1[0]);
        let (d1, d2) = (f1 - e1, f2 - e2);
        let n0 = e1.cross(e2);
        let mid = n0 + (e1.cross(d2) + d1.cross(e2)) * 0.5;
        let n1 = f1.cross(f2);
        // Rounding (per component): the ends' normals as in `of_triangle`,
        // within 4 eps |e1| |e2| (resp. |f1| |f2|); the middle one also
        // carries the rounding of d = f - e and two more cross products,
        // within 16 eps (|e1| + |f1|) (|e2| + |f2|) all told. A triangle that
        // does not move has d = 0 exactly and its middle vector is n(0).
        let eps8 = 8.0 * f64::EPSILON;
        let (err0, err1) = (
            eps8 * e1.length() * e2.length(),
            eps8 * f1.length() * f2.length(),
        );
        let err_mid = if d1 == DVec3::ZERO && d2 == DVec3::ZERO {
            err0
        } else {
            2.0 * eps8 * (e1.length() + f1.length()) * (e2.length() + f2.length())
        };
        Some([
            Self::unit_within(n0, err0)?,
            Self::unit_within(mid, err_mid)?,
            Self::unit_within(n1, err1)?,
        ])
    }

    /// Vector `n` (known within `err`, absolute) as a unit vector and a
    /// bound (radians) on its angle to the exact one; `None` when `n` is not
    /// 8 times longer than `err`.
    fn unit_within(n: DVec3, err: f64) -> Option<(DVec3, f64)> {
        let len2 = n.length_squared();
        if !(len2 > 64.0 * err * err) {
            return None;
        }
        // An angle of at most asin(x) <= 1.06 x for x = err / |n| <= 1/8.
        let inv = 1.0 / len2.sqrt();
        Some((n * inv, 1.06 * err * inv))
    }

    /// A cone from an axis (normalised here) and a half-angle in radians.
    pub fn new(axis: DVec3, half_angle: f64) -> NormalCone {
        if half_angle >= std::f64::consts::PI || axis.length_squared() == 0.0 {
            return NormalCone::FULL;
        }
        let q = 0.5 * half_angle.max(0.0);
        NormalCone {
            axis: axis.normalize(),
            quarter: Angle {
                c: q.cos(),
                s: q.sin(),
            },
        }
    }

    /// The cosine of the half-angle: every direction under the cone (every
    /// exact normal it was fitted to) makes at most this angle with the
    /// axis, up to the cosine's own rounding (a few ulps). Not positive for
    /// the full cone.
    #[inline]
    pub fn cos_half(&self) -> f64 {
        self.half().c
    }

    /// Half-angle in radians (for reports; the engine works with cosines and sines).
    pub fn half_angle(&self) -> f64 {
        2.0 * self.quarter.s.atan2(self.quarter.c)
    }

    #[inline]
    fn half(&self) -> Angle {
        self.quarter.double()
    }

    #[inline]
    fn is_full(&self) -> bool {
        self.quarter.c <= 0.0
    }

    /// True when a positive vector exists: every normal under the cone has a
    /// positive dot product with the axis (half-angle below 90 degrees, with margin).
    #[inline]
    pub fn is_positive(&self) -> bool {
        self.half().c > POSITIVE_MARGIN
    }

    /// True when every direction under the cone is strictly within 90 degrees
    /// of unit vector `v` (with the margin of [`is_positive`](Self::is_positive)):
    /// the angle between the axes plus the half-angle stays below 90 degrees.
    #[inline]
    pub fn within_90_of(&self, v: DVec3) -> bool {
        if self.is_full() {
            return false;
        }
        let reach = Angle::between(self.axis, v)
            .widen(MERGE_SLACK)
            .add(self.half());
        !reach.at_least_pi() && reach.c > POSITIVE_MARGIN
    }

    /// `self.merge(o).is_positive()`, without building the merged axis, and
    /// with a cheap early "no" first: the merged half-angle is (h1 + d + h2) / 2
    /// (or h1 or h2 when one cone holds the other, and then d < h1 - h2 <
    /// PI - h1 - h2), so when the axes' dot product shows d > PI - h1 - h2,
    /// i.e. cos d < -cos(h1 + h2), with a margin (1e-6) far above the rounding
    /// of both sides, the merged cone reaches 90 degrees and is not positive.
    #[inline]
    pub fn merge_is_positive(&self, o: &NormalCone) -> bool {
        if !self.is_positive() || !o.is_positive() {
            // A merged cone holds both, so it is no narrower than either.
            return self.merge(o).is_positive();
        }
        let (h1, h2) = (self.half(), o.half());
        if self.axis.dot(o.axis) < -h1.add(h2).c - 1e-6 {
            return false;
        }
        match self.merged_half(o) {
            Merged::First => self.is_positive(),
            Merged::Second => o.is_positive(),
            Merged::Full => false,
            Merged::Arc { quarter, .. } => quarter.double().c > POSITIVE_MARGIN,
        }
    }

    /// Smallest cone around the great-circle arc between the axes holding both:
    /// half-angle H = (h1 + d + h2) / 2, axis turned from the first axis towards
    /// the second by H - h1, where d is the angle between the axes.
    #[inline]
    pub fn merge(&self, o: &NormalCone) -> NormalCone {
        match self.merged_half(o) {
            Merged::First => *self,
            Merged::Second => *o,
            Merged::Full => NormalCone::FULL,
            Merged::Arc { h, d, quarter } => {
                let t = h.sub(self.half());
                // k x a = (b - a cos d) / sin d for k = unit(a x b).
                let axis = self.axis * t.c + (o.axis - self.axis * d.c) * (t.s / d.s);
                // Unit up to rounding: one Newton step for 1/|axis| keeps it so without a square root.
                let axis = axis * (1.5 - 0.5 * axis.length_squared());
                NormalCone { axis, quarter }
            }
        }
    }

    /// The half-angle part of [`merge`](Self::merge) (inlined into both
    /// callers, so that the refit's merge pays nothing for the split).
    #[inline(always)]
    fn merged_half(&self, o: &NormalCone) -> Merged {
        if self.is_full() || o.is_full() {
            return Merged::Full;
        }
        let (h1, h2) = (self.half(), o.half());
        let d = Angle::between(self.axis, o.axis);
        let (dh1, dh2) = (d.add(h1), d.add(h2));
        if !dh2.at_least_pi() && dh2.le(h1) {
            return Merged::First;
        }
        if !dh1.at_least_pi() && dh1.le(h2) {
            return Merged::Second;
        }
        let h = self.quarter.add(d.half()).add(o.quarter).widen(MERGE_SLACK);
        if h.at_least_pi() || d.s == 0.0 {
            return Merged::Full;
        }
        Merged::Arc {
            h,
            d,
            quarter: h.half(),
        }
    }
}

/// Index of the vector of `normals` (not empty) with the least dot product
/// with `axis` (the first of equals): the farthest from it, up to rounding.
fn least_dot(axis: DVec3, normals: &[DVec3]) -> usize {
    let (mut low, mut k) = (f64::INFINITY, 0);
    for (i, n) in normals.iter().enumerate() {
        let dot = axis.dot(*n);
        if dot < low {
            (low, k) = (dot, i);
        }
    }
    k
}

/// The largest angle from unit `axis` to one of unit `normals`, compared as
/// cosine and sine ([`Angle::le`]): exact to rounding at any angle.
fn farthest(axis: DVec3, normals: &[DVec3]) -> Angle {
    let mut far = Angle::ZERO;
    for &n in normals {
        let t = Angle::between(axis, n);
        if !t.le(far) {
            far = t;
        }
    }
    far
}

/// What a merge of two cones is, before its axis is built.
enum Merged {
    /// The first cone holds the second.
    First,
    /// The second cone holds the first.
    Second,
    /// Every direction.
    Full,
    /// The cone around the arc between the axes: half-angle `h`, its half
    /// `quarter`, and the angle `d` between the axes.
    Arc { h: Angle, d: Angle, quarter: Angle },
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SplitMix;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    fn holds(outer: &NormalCone, inner: &NormalCone) -> bool {
        *outer == NormalCone::FULL
            || outer.axis.dot(inner.axis).clamp(-1.0, 1.0).acos() + inner.half_angle()
                <= outer.half_angle() + 1e-12
    }

    /// Leaf cones of triangles tilted up to `tilt` radians from +z.
    fn leaves(rng: &mut SplitMix, count: usize, tilt: f64) -> Vec<NormalCone> {
        (0..count)
            .map(|_| {
                let (phi, t) = (2.0 * PI * rng.unit(), tilt * rng.unit());
                let d = DVec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos());
                // A triangle with normal d (up to rounding), at some scale.
                let u = d.any_orthonormal_vector() * (0.1 + rng.unit());
                let w = d.cross(u);
                let p = rng.direction() * 3.0;
                NormalCone::of_triangle(p, p + u, p + w)
            })
            .collect()
    }

    #[test]
    fn cones_around_leaves_hold_every_leaf() {
        let mut rng = SplitMix::new(11);
        for round in 0..300 {
            let tilt = [0.1, 0.8, 1.4, 1.6, 2.5][round % 5];
            let ls = leaves(&mut rng, 1 + round % 40, tilt);
            let c = NormalCone::around_leaves(&ls);
            assert!(ls.iter().all(|l| holds(&c, l)), "round {round}");
            let merged = ls[1..].iter().fold(ls[0], |m, l| m.merge(l));
            // Positive when the merged cone (no narrower than the narrowest)
            // is under 45 degrees: the mean axis is within twice that.
            if merged.half_angle() < 0.5 * FRAC_PI_2 {
                assert!(c.is_positive(), "round {round}");
            }
            // Where positive, every leaf (with its width) within 90 degrees.
            if c.is_positive() {
                assert!(ls.iter().all(|l| l.axis.dot(c.axis).clamp(-1.0, 1.0).acos()
                    + l.half_angle()
                    < FRAC_PI_2));
            }
        }
        assert_eq!(NormalCone::around_leaves(&[]), NormalCone::FULL);
        let flat = NormalCone::of_triangle(DVec3::ZERO, DVec3::X, 2.0 * DVec3::X);
        assert_eq!(NormalCone::around_leaves(&[flat]), NormalCone::FULL);
    }

    /// The dot-product test agrees with each leaf's own `within_90_of` and
    /// with the angles themselves, and never passes a full (degenerate) leaf.
    #[test]
    fn leaves_within_90_by_dot_products() {
        let mut rng = SplitMix::new(12);
        for round in 0..2000 {
            let ls = leaves(&mut rng, 1 + round % 8, 1.7);
            let v = rng.direction();
            let fast = NormalCone::leaves_within_90_of(&ls, v);
            let each = ls.iter().all(|l| l.within_90_of(v));
            let angles = ls
                .iter()
                .all(|l| l.axis.dot(v).clamp(-1.0, 1.0).acos() + l.half_angle() < FRAC_PI_2);
            assert!(!fast || (each && angles), "round {round}");
            if each {
                // Only leaves within a hair of 90 degrees may differ.
                let near = ls.iter().any(|l| l.axis.dot(v).abs() < 1e-6);
                assert!(fast || near, "round {round}");
            }
        }
        let flat = NormalCone::of_triangle(DVec3::ZERO, DVec3::X, 2.0 * DVec3::X);
        assert!(!NormalCone::leaves_within_90_of(&[flat], DVec3::Z));
    }

    #[test]
    fn merge_holds_both_cones() {
        let a = NormalCone::of_triangle(DVec3::ZERO, DVec3::X, DVec3::Y); // +z
        assert!(a.half_angle() < 1e-12 && (a.axis - DVec3::Z).length() < 1e-15);
        let b = NormalCone::new(DVec3::new(1.0, 0.0, 1.0), 0.1);
        let m = a.merge(&b);
        assert!(holds(&m, &a) && holds(&m, &b));
        assert!((m.half_angle() - (FRAC_PI_4 + 0.1) / 2.0).abs() < 1e-12);
        assert!(m.is_positive());
        assert!(!a.merge(&NormalCone::new(-DVec3::Z, 0.0)).is_positive());
        // Normals 90 degrees apart still have a positive vector (their bisector).
        assert!((a.merge(&NormalCone::new(DVec3::X, 0.0)).half_angle() - FRAC_PI_4).abs() < 1e-12);
    }

    #[test]
    fn merge_matches_the_trigonometric_formula() {
        let mut rng = SplitMix::new(3);
        for _ in 0..2000 {
            let a = NormalCone::new(rng.direction(), PI * rng.unit() * rng.unit());
            let b = NormalCone::new(rng.direction(), PI * rng.unit() * rng.unit());
            let m = a.merge(&b);
            assert!(holds(&m, &a) && holds(&m, &b), "{a:?} {b:?} -> {m:?}");
            let d = a.axis.dot(b.axis).clamp(-1.0, 1.0).acos();
            let want = (a.half_angle() + d + b.half_angle()) / 2.0;
            let want = want.max(a.half_angle()).max(b.half_angle());
            if want < PI - 1e-6 && !m.is_full() {
                let contained =
                    d + b.half_angle() <= a.half_angle() || d + a.half_angle() <= b.half_angle();
                if !contained {
                    assert!(
                        (m.half_angle() - want).abs() < 1e-9,
                        "{} vs {want}",
                        m.half_angle()
                    );
                }
            }
        }
    }

    #[test]
    fn merge_is_positive_agrees_with_merge() {
        let mut rng = SplitMix::new(5);
        let (mut yes, mut no) = (0, 0);
        for _ in 0..20000 {
            // Half-angles up to 90 degrees, and axes often nearly opposite.
            let a = NormalCone::new(rng.direction(), 0.5 * PI * rng.unit());
            let dir = if rng.unit() < 0.5 {
                -a.axis + 0.3 * rng.direction()
            } else {
                rng.direction()
            };
            let b = NormalCone::new(dir, 0.5 * PI * rng.unit() * rng.unit());
            let want = a.merge(&b).is_positive();
            assert_eq!(a.merge_is_positive(&b), want, "{a:?} {b:?}");
            yes += want as u32;
            no += !want as u32;
        }
        assert!(yes > 1000 && no > 1000, "{yes} {no}");
    }

    #[test]
    fn nearly_equal_axes_merge_to_a_tight_cone() {
        // Axes equal up to rounding (not exactly unit): must not blow up to the full cone.
        let a = NormalCone {
            axis: DVec3::new(0.0, 0.0, 0.9999999999999999),
            quarter: Angle { c: 1.0, s: 1.9e-15 },
        };
        let b = NormalCone {
            axis: DVec3::new(0.0, -0.0, 0.9999999999999999),
            quarter: Angle { c: 1.0, s: 2.7e-15 },
        };
        let m = a.merge(&b);
        assert!(m.is_positive() && m.half_angle() < 1e-12, "{m:?}");
    }

    /// `around` holds every normal, is at most 1.4e-7 radians wider than the
    /// largest angle from its axis (exact below 90 degrees too), and is
    /// positive exactly when that angle is under 90 degrees by more than that.
    #[test]
    fn a_cone_around_an_axis_holds_every_normal_tightly() {
        let mut rng = SplitMix::new(9);
        for spread in [1e-9, 1e-4, 0.3, 1.4, 1.6, 3.0] {
            for _ in 0..300 {
                let axis = rng.direction();
                let normals: Vec<DVec3> = (0..16)
                    .map(|_| (axis + spread * rng.direction()).normalize())
                    .collect();
                let mean = normals.iter().sum::<DVec3>().normalize();
                let cone = NormalCone::around(mean, &normals, 0.0);
                let far = normals
                    .iter()
                    .map(|n| mean.cross(*n).length().atan2(mean.dot(*n)))
                    .fold(0.0, f64::max);
                if cone == NormalCone::FULL {
                    assert!(far > 0.5 * PI, "{spread}: {far}");
                    continue;
                }
                for n in &normals {
                    assert!(holds(&cone, &NormalCone::new(*n, 0.0)), "{spread}");
                }
                assert!(cone.half_angle() >= far && cone.half_angle() <= far + 1.4e-7);
                if far < 0.5 * PI - 1e-6 {
                    assert!(cone.is_positive(), "{spread}: {far}");
                }
            }
        }
        assert_eq!(
            NormalCone::around(DVec3::ZERO, &[DVec3::Z], 0.0),
            NormalCone::FULL
        );
        assert_eq!(NormalCone::around(DVec3::Z, &[], 0.0), NormalCone::FULL);
    }

    #[test]
    fn degenerate_triangle_has_full_cone() {
        let c = NormalCone::of_triangle(DVec3::ZERO, DVec3::X, 2.0 * DVec3::X);
        assert_eq!(c, NormalCone::FULL);
        assert!(!c.is_positive());
    }
}
