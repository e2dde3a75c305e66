//! Closest points and distances: point-triangle and segment-segment (edge-edge).
//!
//! Plain f64 (these feed the simulator's proximity response, where a tolerance
//! `d` is already in play); after Ericson, Real-Time Collision Detection, 5.1.
//! Not scale-free by themselves, unlike the intersection test
//! ([`super::tri_tri`]): products of up to four coordinates are formed
//! directly, so they overflow beyond about 2^250 and lose all precision below
//! about 2^-250. The queries call them through [`super::ccd::closest_within`]
//! and [`super::ccd::time_of_impact`], which move a stencil out of that
//! range by a power of two first.

use super::ccd::StencilKind;
use super::Aabb;
use glam::DVec3;

/// Relative slack of [`hulls_apart`], in units of the coordinates' magnitude:
/// far above the rounding of the distance functions here.
pub(crate) const APART_SLACK: f64 = 1e-9;

/// True when the convex hulls of `a` and `b` are certainly farther apart than
/// `gap`: their boxes are apart ([`Aabb::within`] fails) by more than `gap`
/// plus a slack of `APART_SLACK` times the coordinates' magnitude. The cheap element-level
/// cull in front of the distance and time-of-impact functions; it never
/// rejects a pair those compute closer than `gap`.
#[inline]
pub fn hulls_apart(a: &[DVec3], b: &[DVec3], gap: f64) -> bool {
    let (ba, bb) = (Aabb::from_points(a), Aabb::from_points(b));
    !ba.within(&bb, gap + APART_SLACK * ba.magnitude().max(bb.magnitude()))
}

/// [`hulls_apart`] for one query: `gap` and the slack fixed once, from the
/// largest coordinate magnitude of the query's positions (at least any
/// pair's own, so it rejects no pair that [`hulls_apart`] keeps), instead of
/// per pair (a third of the cull's cost).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HullCull {
    /// The distance asked for.
    pub gap: f64,
    /// `gap` plus the slack.
    reach: f64,
    /// Whether the stencils of these positions must be rescaled before their
    /// distances are formed ([`super::ccd::needs_rescale`]), or the gap's
    /// square is not a normal double.
    pub rescale: bool,
}

impl HullCull {
    /// The cull for pairs of points among `positions` closer than `gap`.
    pub fn new(gap: f64, positions: &[DVec3]) -> HullCull {
        HullCull::at_magnitude(gap, super::magnitude(positions), positions)
    }

    /// [`new`](Self::new) for `positions` whose largest coordinate magnitude
    /// ([`super::magnitude`]) is already known.
    pub fn at_magnitude(gap: f64, magnitude: f64, positions: &[DVec3]) -> HullCull {
        HullCull {
            gap,
            reach: gap + APART_SLACK * magnitude,
            rescale: !(gap * gap).is_normal() || super::ccd::needs_rescale(positions),
        }
    }

    /// The distance of a stencil with corners `c` (of the positions the cull
    /// was made for) and its closest points when it is below the gap
    /// ([`super::ccd::closest_within`]).
    #[inline]
    pub fn closest_within(&self, kind: StencilKind, c: &[DVec3; 4]) -> Option<(f64, [f64; 3])> {
        super::ccd::closest_within(kind, c, self.gap, self.rescale)
    }

    /// True when the convex hulls of `a` and `b` (points of the positions the
    /// cull was made for) are certainly farther apart than the gap.
    #[inline]
    pub fn apart(&self, a: &[DVec3], b: &[DVec3]) -> bool {
        self.boxes_apart(&Aabb::from_points(a), &Aabb::from_points(b))
    }

    /// [`apart`](Self::apart) for hulls given by their boxes.
    #[inline]
    pub fn boxes_apart(&self, a: &Aabb, b: &Aabb) -> bool {
        !a.within(b, self.reach)
    }
}

/// A lower bound on the least altitude of triangle `c` (twice its area over
/// its longest side: how close a corner comes to the line of the opposite
/// side), or 0 where none is known (degenerate, or squares that over- or
/// underflow). The cross product's rounding (a few ulps of `|e1| |e2|` per
/// component) is taken off its length first, and the quotient lowered by
/// far more than its own rounding.
pub fn least_altitude(c: &[DVec3; 3]) -> f64 {
    let (e1, e2, e3) = (c[1] - c[0], c[2] - c[0], c[2] - c[1]);
    let (l1, l2, l3) = (e1.length(), e2.length(), e3.length());
    let twice_area = e1.cross(e2).length() - 16.0 * f64::EPSILON * l1 * l2;
    let h = twice_area / l1.max(l2).max(l3) * (1.0 - 1e-12);
    // Written so that a NaN gives 0.
    if h > 0.0 && h.is_finite() {
        h
    } else {
        0.0
    }
}

/// Closest point of triangle (a, b, c) to `p`, as barycentric weights (wa, wb, wc).
/// Works for degenerate triangles too (then it returns a closest point on an edge).
pub fn point_triangle_closest(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = va + vb + vc;
    // Zero or NaN (from an overflowed degenerate triangle).
    if denom.abs().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        // Degenerate triangle: closest point on its longest edge is found above or here.
        return closest_on_edges(p, a, b, c);
    }
    let (v, w) = (vb / denom, vc / denom);
    [1.0 - v - w, v, w]
}

fn closest_on_edges(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let on = |x: DVec3, y: DVec3| {
        let d = y - x;
        let l = d.length_squared();
        if l > 0.0 {
            ((p - x).dot(d) / l).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    let (s, t, u) = (on(a, b), on(b, c), on(c, a));
    let cands = [[1.0 - s, s, 0.0], [0.0, 1.0 - t, t], [u, 0.0, 1.0 - u]];
    let dist = |w: &[f64; 3]| (a * w[0] + b * w[1] + c * w[2] - p).length_squared();
    cands
        .into_iter()
        .min_by(|x, y| dist(x).total_cmp(&dist(y)))
        .unwrap()
}

/// Squared distance from `p` to triangle (a, b, c), with the barycentric weights of the closest point.
pub fn point_triangle_distance2(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (f64, [f64; 3]) {
    let w = point_triangle_closest(p, a, b, c);
    ((a * w[0] + b * w[1] + c * w[2] - p).length_squared(), w)
}

/// Closest points of segments p1-q1 and p2-q2 as parameters (s, t) in `[0, 1]^2`,
/// with the squared distance. Parallel and zero-length segments are handled.
pub fn segment_segment_distance2(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> (f64, f64, f64) {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let (s, t);
    if a <= 0.0 && e <= 0.0 {
        return (r.length_squared(), 0.0, 0.0);
    }
    if a <= 0.0 {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(r);
        if e <= 0.0 {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let s0 = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            } else {
                t = t0;
                s = s0;
            }
        }
    }
    let d = (p1 + d1 * s) - (p2 + d2 * t);
    (d.length_squared(), s, t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SplitMix;

    /// The query-wide cull keeps every pair the per-pair one keeps, at any
    /// scale, including pairs just past the gap (where only the slack keeps them).
    #[test]
    fn hull_cull_keeps_what_hulls_apart_keeps() {
        let mut rng = SplitMix::new(7);
        let mut unit = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        for scale in [1e-300, 1e-9, 1.0, 1e6, 1e300] {
            let x: Vec<DVec3> = (0..400)
                .map(|_| DVec3::new(unit(), unit(), unit()) * scale)
                .collect();
            let gap = 0.05 * scale;
            let cull = HullCull::new(gap, &x);
            let (mut kept, mut near) = (0, 0);
            for k in 0..x.len() - 4 {
                let (a, b) = (&x[k..k + 2], &x[k + 2..k + 4]);
                let apart = hulls_apart(a, b, gap);
                kept += !apart as usize;
                assert!(apart || !cull.apart(a, b), "scale {scale}, pair {k}");
                // A copy moved to just past the gap along x: kept by the slack only.
                let past = gap * (1.0 + 1e-12);
                let c = [a[0], a[0]];
                let d = [c[0] + DVec3::X * past, c[0] + DVec3::X * past];
                if !hulls_apart(&c, &d, gap) {
                    near += 1;
                    assert!(!cull.apart(&c, &d));
                }
            }
            assert!(kept > 0 && near > 0, "scale {scale}: {kept} {near}");
        }
    }

    #[test]
    fn point_triangle_regions() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let (d2, w) = point_triangle_distance2(DVec3::new(0.25, 0.25, 2.0), a, b, c);
        assert!((d2 - 4.0).abs() < 1e-12 && (w[1] - 0.25).abs() < 1e-12);
        let (d2, w) = point_triangle_distance2(DVec3::new(2.0, -1.0, 0.0), a, b, c);
        assert!((d2 - 2.0).abs() < 1e-12 && w == [0.0, 1.0, 0.0]);
        let (d2, _) = point_triangle_distance2(DVec3::new(1.0, 1.0, 0.0), a, b, c);
        assert!((d2 - 0.5).abs() < 1e-12);
    }

    #[test]
    fn segment_segment_cases() {
        let (d2, s, t) = segment_segment_distance2(
            DVec3::ZERO,
            DVec3::X,
            DVec3::new(0.5, -1.0, 1.0),
            DVec3::new(0.5, 1.0, 1.0),
        );
        assert!((d2 - 1.0).abs() < 1e-12 && (s - 0.5).abs() < 1e-12 && (t - 0.5).abs() < 1e-12);
        // Parallel, overlapping.
        let (d2, _, _) = segment_segment_distance2(
            DVec3::ZERO,
            DVec3::X,
            DVec3::new(0.5, 0.0, 2.0),
            DVec3::new(1.5, 0.0, 2.0),
        );
        assert!((d2 - 4.0).abs() < 1e-12);
        // Degenerate.
        let (d2, _, _) = segment_segment_distance2(DVec3::ZERO, DVec3::ZERO, DVec3::Y, DVec3::Y);
        assert_eq!(d2, 1.0);
    }
}
