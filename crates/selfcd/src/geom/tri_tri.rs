//! Exact intersection of closed triangles in 3D, for any finite coordinates.
//!
//! Two closed triangles intersect iff (a) they are coplanar and their
//! projections overlap, or (b) some edge of one meets the other: the extreme
//! points of the convex set `A ∩ B` lie on an edge of A or of B when the planes
//! differ. Every decision is an exact sign ([`Orientation`]) over the six
//! corners, so touching at a point, along an edge and coplanar overlap are all
//! reported, and nothing is lost to rounding, overflow or underflow.
//! Degenerate (collapsed) triangles are handled as their edges. Pairs in
//! general position (no corner on the other's plane, the usual crossing
//! contact) take a shortcut: two more orientations instead of the edge
//! tests (`crossing`).
//!
//! The corners are named by index: a = 0, 1, 2 and b = 3, 4, 5. The decision is
//! written once, generic over the arithmetic: Shewchuk's expansions for every
//! ordinary pair ([`Expansion`]), big integers for pairs whose coordinates
//! span 2^500 or more ([`BigInts`]).

use super::exact_int::BigInts;
use super::predicates::{certainly_one_side, Expansion, Orientation};
use super::Aabb;
use glam::DVec3;
use std::cmp::Ordering;

/// How a triangle pair was decided.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decision {
    /// The floating-point filter proved the triangles apart.
    FilterApart,
    /// The exact test ran; its answer.
    Exact(bool),
}

impl Decision {
    /// True when the triangles share a point.
    #[inline]
    pub fn intersect(self) -> bool {
        self == Decision::Exact(true)
    }
}

/// The exact test behind a floating-point filter: first the error-bounded
/// plane-side test ([`certainly_one_side`]) both ways; when it cannot decide,
/// [`triangles_intersect`].
#[inline]
pub fn triangles_intersect_filtered(a: &[DVec3; 3], b: &[DVec3; 3]) -> Decision {
    if certainly_one_side(a, b) || certainly_one_side(b, a) {
        return Decision::FilterApart;
    }
    Decision::Exact(triangles_intersect(a, b))
}

/// A lower bound on the distance between triangles `a` and `b`: how far
/// one lies on one side of the other's plane (the larger of the two ways),
/// or 0 when neither does (or the bound is lost to rounding: degenerate,
/// sliver, overflowing or underflowing triangles). Each point of a triangle
/// is a convex combination of its corners, so while no corner moves more
/// than half of it the triangles stay apart.
///
/// Rounding: with `u = t1 - t0`, `v = t2 - t0`, `w = q - t0` and `n = u x v`,
/// the computed `w . n` is within `20 eps |w| |u| |v|` of the exact one
/// (eps = 2^-53), plus at most 2^-1073 from products that underflow; each
/// corner's is taken less `1e-12 W |u| |v|` with `W >= |w|` (450 times the
/// first) and 1e-320 (the second, 100 times), and the least divided by
/// `|n|` (relative rounding, taken off with the `1 - 1e-12`). A plane
/// normal under 1e-280 (a triangle near 1e-140 across or smaller, or a
/// sliver) gives 0.
pub fn plane_clearance(a: &[DVec3; 3], b: &[DVec3; 3]) -> f64 {
    one_side_clearance(a, b).max(one_side_clearance(b, a))
}

/// How far all corners of `p` lie on one side of the plane of `t` (0 if not).
#[inline]
fn one_side_clearance(t: &[DVec3; 3], p: &[DVec3; 3]) -> f64 {
    let (u, v) = (t[1] - t[0], t[2] - t[0]);
    let n = u.cross(v);
    let w = p.map(|q| q - t[0]);
    let d = w.map(|w| w.dot(n));
    let (lo, hi) = (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]));
    // Cheap refusal first: the corners straddle the plane.
    if !(lo > 0.0 || hi < 0.0) {
        return 0.0;
    }
    let len = n.length();
    // A bound on every |w| (the largest coordinate, times sqrt 3).
    let far = w[0].abs().max(w[1].abs()).max(w[2].abs()).max_element() * 1.7320508075688774;
    let err = 1e-12 * far * (u.length_squared() * v.length_squared()).sqrt() + 1e-320;
    let least = if lo > 0.0 { lo } else { -hi } - err;
    // (NaN from an overflow fails the comparison.)
    if len >= 1e-280 && least > 0.0 && err.is_finite() {
        least / len * (1.0 - 1e-12)
    } else {
        0.0
    }
}

/// True when closed triangles `a` and `b` share at least one point. Exact for
/// every finite input (precondition: no NaN or infinite coordinate).
pub fn triangles_intersect(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    let p = [a[0], a[1], a[2], b[0], b[1], b[2]];
    match Expansion::new(p) {
        Some(k) => intersect(&k, [a, b]),
        None => intersect(&BigInts::new(&p), [a, b]),
    }
}

/// Bit c set when triangle `t` lies in a plane normal to axis c (its
/// corners share coordinate c exactly; both arithmetics take coordinates
/// exactly, so they compare alike). [`on_axis_plane`]'s test, as a mask
/// of one triangle read from its coordinates: the pair test reads each
/// triangle's once and uses it twice (the coplanar check and its plane
/// sides); the versions that asked through the arithmetic cost the
/// garments' and the crumpled grid's exact tests 0.3-0.9% more
/// instructions than before (BENCHMARKS.md, thirty-second landing), this
/// one 0.1%.
#[inline]
fn flat_axes(t: &[DVec3; 3]) -> u32 {
    (t[0].cmpeq(t[1]) & t[0].cmpeq(t[2])).bitmask()
}

/// True when point `p` lies in closed triangle `t` (a degenerate triangle as
/// the segment or point it is). Exact for every finite input; decided by
/// comparisons when `p` is outside the triangle's box, by one orientation
/// when it is off the triangle's plane.
pub fn point_in_triangle(p: DVec3, t: &[DVec3; 3]) -> bool {
    if !boxes_meet(&[p], t) {
        return false;
    }
    let q = [t[0], t[1], t[2], p];
    match Expansion::new(q) {
        Some(k) => point_in_triangle_3d(&k),
        None => point_in_triangle_3d(&BigInts::new(&q)),
    }
}

/// True when closed segments `[a, b]` and `[c, d]` share a point (zero-length
/// segments allowed). Exact for every finite input; decided by comparisons
/// when their boxes are apart, by one orientation when they are skew.
pub fn segments_intersect(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> bool {
    if !boxes_meet(&[a, b], &[c, d]) {
        return false;
    }
    let q = [a, b, c, d];
    match Expansion::new(q) {
        Some(k) => segments_intersect_3d(&k, 0, 1, 2, 3),
        None => segments_intersect_3d(&BigInts::new(&q), 0, 1, 2, 3),
    }
}

/// Do the closed boxes of point sets `a` and `b` share a point? (Exact:
/// comparisons only.)
#[inline]
fn boxes_meet(a: &[DVec3], b: &[DVec3]) -> bool {
    Aabb::from_points(a).overlaps(&Aabb::from_points(b))
}

/// Do points `p` share one coordinate exactly (lie in a plane normal to an
/// axis)? Then they are coplanar, which comparisons settle where the
/// orientation's filter could not (its value is exactly 0): a sheet of
/// cloth lying flat, as the benchmark grids and many rest shapes do.
#[inline]
fn on_axis_plane<K: Orientation, const N: usize>(k: &K, p: [usize; N]) -> bool {
    (0..3).any(|c| p[1..].iter().all(|&q| k.cmp(c, p[0], q) == Ordering::Equal))
}

/// Point 3 lies in closed triangle 0, 1, 2 of `k`.
fn point_in_triangle_3d<K: Orientation>(k: &K) -> bool {
    let t = [0, 1, 2];
    if !on_axis_plane(k, [0, 1, 2, 3]) && k.orient3d([0, 1, 2, 3]) != 0 {
        return false; // off the plane (a degenerate triangle's volume is 0)
    }
    match k.normal_axis(t) {
        Some(axis) => point_in_triangle_2d(k, axis, 3, t),
        None => edges(t)
            .iter()
            .any(|e| segments_intersect_3d(k, e[0], e[1], 3, 3)),
    }
}

const A: [usize; 3] = [0, 1, 2];
const B: [usize; 3] = [3, 4, 5];

/// The decision on corners a = 0, 1, 2 and b = 3, 4, 5 of `k`, the
/// triangles `[a, b]` (read for [`flat_axes`]).
#[inline]
fn intersect<K: Orientation>(k: &K, [a, b]: [&[DVec3; 3]; 2]) -> bool {
    let fa = flat_axes(a);
    // Both in one plane normal to an axis: all six orientations below are
    // exactly 0, which their filters cannot show (each would take the exact
    // fallback); comparisons can, and the pair takes the path those zeros
    // lead to.
    if fa != 0 {
        let common = fa & flat_axes(b) & a[0].cmpeq(b[0]).bitmask();
        if common != 0 {
            return edge_tests(k, [0; 3], [0; 3]);
        }
    }
    // Plane-side rejection first: it settles most pairs, and it is valid for
    // degenerate triangles too (their orientations are all zero, never one-sided).
    let sb = match fa {
        0 => B.map(|p| k.orient3d([A[0], A[1], A[2], p])),
        _ => flat_plane_sides(k, A, fa, B),
    };
    if strictly_one_side(sb) {
        return false;
    }
    let sa = match flat_axes(b) {
        0 => A.map(|p| k.orient3d([B[0], B[1], B[2], p])),
        fb => flat_plane_sides(k, B, fb, A),
    };
    if strictly_one_side(sa) {
        return false;
    }
    if sa.iter().chain(&sb).all(|&x| x != 0) {
        crossing(k, sa, sb)
    } else {
        edge_tests(k, sa, sb)
    }
}

/// The sides of the plane of triangle `t`, which lies in a plane normal to
/// an axis (`flat`: its [`flat_axes`], not 0), that points `o` lie on:
/// `orient3d([t0, t1, t2, p])` for each p, by a comparison each and one
/// orientation in the plane. With c such an axis, `det[t0 - p, t1 - p,
/// t2 - p] = (t0 - p) . ((t1 - t0) x (t2 - t0))`, and that cross product
/// points along c, so the volume is `(t0_c - p_c)` times the area of `t`
/// projected along c. That is where the orientations' filters fail: a
/// flat sheet's neighbours, a fold whose corners lie exactly on a flat
/// layer's plane, have volumes exactly 0, and each would take the exact
/// fallback. (Out of line: the usual triangle, not flat, keeps its path
/// as it was.)
#[inline(never)]
fn flat_plane_sides<K: Orientation>(k: &K, t: [usize; 3], flat: u32, o: [usize; 3]) -> [i8; 3] {
    let c = flat.trailing_zeros() as usize;
    let area = k.orient2d(c, t);
    o.map(|p| area * k.cmp(c, t[0], p) as i8)
}

/// The decision once neither triangle is strictly on one side of the
/// other's plane (`sa`: a's corners' sides of b's plane, `sb`: b's of a's),
/// by their edges: correct for every such pair, degenerate and coplanar
/// ones included.
fn edge_tests<K: Orientation>(k: &K, sa: [i8; 3], sb: [i8; 3]) -> bool {
    let na = k.normal_axis(A);
    let nb = k.normal_axis(B);
    // Corner i's side of the other triangle's plane (a: 0..3, b: 3..6).
    let side = [sa[0], sa[1], sa[2], sb[0], sb[1], sb[2]];
    let any_edge = |x: [usize; 3], y: [usize; 3], axis: usize| {
        edges(x)
            .iter()
            .any(|&[p, q]| segment_triangle(k, [p, q], [side[p], side[q]], y, axis))
    };
    match (na, nb) {
        (None, None) => edges(A).iter().any(|ea| {
            edges(B)
                .iter()
                .any(|eb| segments_intersect_3d(k, ea[0], ea[1], eb[0], eb[1]))
        }),
        (None, Some(ax)) => any_edge(A, B, ax),
        (Some(ax), None) => any_edge(B, A, ax),
        (Some(ax), Some(_)) if sb == [0; 3] => triangles_intersect_2d(k, ax, A, B),
        (Some(ax), Some(bx)) => any_edge(A, B, bx) || any_edge(B, A, ax),
    }
}

/// Triangles a and b in general position: every corner strictly off the
/// other's plane (`sa`, `sb`: the corners' sides, none 0), each with corners
/// on both sides. Then the triangles meet iff the segments they cut from the
/// line where the planes meet overlap, which two orientations decide
/// (Guigue and Devillers 2003): rotate each triangle so that its first
/// corner (p1, p2) is alone on its side of the other's plane, turn each so
/// that that corner lies on the same side (swapping the other two corners),
/// and the segments overlap iff neither orientation puts one interval
/// strictly past the other.
fn crossing<K: Orientation>(k: &K, sa: [i8; 3], sb: [i8; 3]) -> bool {
    crossing_orientations(k, sa, sb).iter().all(|&x| x <= 0)
}

/// The two orientations [`crossing`] decides by (both at most 0: the
/// segments overlap; both negative: in more than a point).
fn crossing_orientations<K: Orientation>(k: &K, sa: [i8; 3], sb: [i8; 3]) -> [i8; 2] {
    // The corner alone on its side: the one whose sign its two followers share.
    let alone = |s: [i8; 3]| {
        (0..3)
            .find(|&i| s[(i + 1) % 3] == s[(i + 2) % 3])
            .unwrap_or(0)
    };
    let (i, j) = (alone(sa), alone(sb));
    let (p1, mut q1, mut r1) = (A[i], A[(i + 1) % 3], A[(i + 2) % 3]);
    let (p2, mut q2, mut r2) = (B[j], B[(j + 1) % 3], B[(j + 2) % 3]);
    // p1 below b's plane as oriented (q2, r2 swapped otherwise), and p2 below a's.
    if sa[i] < 0 {
        std::mem::swap(&mut q2, &mut r2);
    }
    if sb[j] < 0 {
        std::mem::swap(&mut q1, &mut r1);
    }
    [k.orient3d([p1, q1, p2, q2]), k.orient3d([p1, r1, r2, p2])]
}

fn edges(t: [usize; 3]) -> [[usize; 2]; 3] {
    [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]]
}

fn strictly_one_side(s: [i8; 3]) -> bool {
    s.iter().all(|&x| x > 0) || s.iter().all(|&x| x < 0)
}

/// Closed segment [p, q] against closed non-degenerate triangle t, whose
/// normal has a non-zero component along `axis`; `[op, oq]`: p's and q's
/// sides of t's plane (`orient3d([t0, t1, t2, p])`, known to the caller).
fn segment_triangle<K: Orientation>(
    k: &K,
    [p, q]: [usize; 2],
    [op, oq]: [i8; 2],
    t: [usize; 3],
    axis: usize,
) -> bool {
    if op * oq > 0 {
        return false;
    }
    if op == 0 && oq == 0 {
        if beyond_an_edge_2d(k, axis, t, &[p, q]) {
            return false;
        }
        return point_in_triangle_2d(k, axis, p, t)
            || (0..3).any(|i| segments_intersect_2d(k, axis, [p, q], [t[i], t[(i + 1) % 3]]));
    }
    // The segment crosses (or ends on) the plane at one point: the line through
    // it hits the closed triangle iff it passes on the same side of all three edges.
    let s = [
        k.orient3d([p, q, t[0], t[1]]),
        k.orient3d([p, q, t[1], t[2]]),
        k.orient3d([p, q, t[2], t[0]]),
    ];
    s.iter().all(|&x| x >= 0) || s.iter().all(|&x| x <= 0)
}

/// Closed triangles a and b (both non-degenerate, coplanar, normal non-zero
/// along `axis`) share a point.
fn triangles_intersect_2d<K: Orientation>(
    k: &K,
    axis: usize,
    a: [usize; 3],
    b: [usize; 3],
) -> bool {
    if beyond_an_edge_2d(k, axis, a, &b) || beyond_an_edge_2d(k, axis, b, &a) {
        return false;
    }
    edges(a).iter().any(|&ea| {
        edges(b)
            .iter()
            .any(|&eb| segments_intersect_2d(k, axis, ea, eb))
    }) || point_in_triangle_2d(k, axis, a[0], b)
        || point_in_triangle_2d(k, axis, b[0], a)
}

/// Do points `o` lie strictly beyond one edge of triangle `t` (all
/// projected along `axis`), on the side of its line away from `t`? Then
/// they, and their convex hull, miss the closed triangle: it lies in the
/// closed half-plane on the other side. A cheap refusal before the
/// edge-by-edge tests, which must all run to show that coplanar elements
/// are apart; two closed triangles apart in a plane, or a segment apart
/// from one, are most often separated so (at most 10 signs each way,
/// against 42 for every edge pair and both corners). False for a
/// degenerate `t` (no inside to be away from).
fn beyond_an_edge_2d<K: Orientation>(k: &K, axis: usize, t: [usize; 3], o: &[usize]) -> bool {
    // The sign of each edge's third corner: the triangle's orientation
    // (a cyclic shift of its corners keeps it).
    let inside = k.orient2d(axis, t);
    inside != 0
        && edges(t)
            .iter()
            .any(|&[p, q]| o.iter().all(|&r| k.orient2d(axis, [p, q, r]) == -inside))
}

/// Closed 3D segments [p1, p2] and [q1, q2] share a point (zero-length segments allowed).
fn segments_intersect_3d<K: Orientation>(
    k: &K,
    p1: usize,
    p2: usize,
    q1: usize,
    q2: usize,
) -> bool {
    if !on_axis_plane(k, [p1, p2, q1, q2]) && k.orient3d([p1, p2, q1, q2]) != 0 {
        return false; // skew lines never meet
    }
    let axis = k
        .normal_axis([p1, p2, q1])
        .or_else(|| k.normal_axis([p1, p2, q2]))
        .or_else(|| k.normal_axis([q1, q2, p1]));
    if let Some(axis) = axis {
        return segments_intersect_2d(k, axis, [p1, p2], [q1, q2]);
    }
    // All four points on one line (or coincident): keep a coordinate along
    // which the line moves, which projects it one-to-one.
    let moving = |i: usize, j: usize| (0..3).find(|&c| k.cmp(c, i, j) != Ordering::Equal);
    match moving(p1, p2).or_else(|| moving(q1, q2)) {
        Some(c) => segments_intersect_2d(k, (c + 1) % 3, [p1, p2], [q1, q2]),
        None => k.same(p1, q1), // two points
    }
}

/// Coordinates of the projection along `axis` (see [`super::predicates::project`]).
fn kept(axis: usize) -> [usize; 2] {
    [(axis + 1) % 3, (axis + 2) % 3]
}

/// Collinear point `r` lies on closed segment [a, b] (projected along `axis`).
fn on_segment<K: Orientation>(k: &K, axis: usize, [a, b]: [usize; 2], r: usize) -> bool {
    kept(axis).iter().all(|&c| {
        let (lo, hi) = match k.cmp(c, a, b) {
            Ordering::Greater => (b, a),
            _ => (a, b),
        };
        k.cmp(c, lo, r) != Ordering::Greater && k.cmp(c, r, hi) != Ordering::Greater
    })
}

/// Closed segments p and q, projected along `axis`, share a point.
fn segments_intersect_2d<K: Orientation>(k: &K, axis: usize, p: [usize; 2], q: [usize; 2]) -> bool {
    let d1 = k.orient2d(axis, [q[0], q[1], p[0]]);
    let d2 = k.orient2d(axis, [q[0], q[1], p[1]]);
    let d3 = k.orient2d(axis, [p[0], p[1], q[0]]);
    let d4 = k.orient2d(axis, [p[0], p[1], q[1]]);
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    (d1 == 0 && on_segment(k, axis, q, p[0]))
        || (d2 == 0 && on_segment(k, axis, q, p[1]))
        || (d3 == 0 && on_segment(k, axis, p, q[0]))
        || (d4 == 0 && on_segment(k, axis, p, q[1]))
}

/// Point `r` lies in closed triangle t (any orientation, not degenerate), projected along `axis`.
fn point_in_triangle_2d<K: Orientation>(k: &K, axis: usize, r: usize, t: [usize; 3]) -> bool {
    let o = [
        k.orient2d(axis, [t[0], t[1], r]),
        k.orient2d(axis, [t[1], t[2], r]),
        k.orient2d(axis, [t[2], t[0], r]),
    ];
    o.iter().all(|&s| s >= 0) || o.iter().all(|&s| s <= 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// For a pair in general position (every corner strictly off the other's
    /// plane, each triangle with corners on both sides): what
    /// [`crossing`] decides, what the edge tests decide, and whether one of
    /// its two orientations is 0 (the segments touch at an end).
    fn both_ways(a: [DVec3; 3], b: [DVec3; 3]) -> Option<(bool, bool, bool)> {
        let kx = Expansion::new([a[0], a[1], a[2], b[0], b[1], b[2]])?;
        let sb = B.map(|q| kx.orient3d([A[0], A[1], A[2], q]));
        let sa = A.map(|q| kx.orient3d([B[0], B[1], B[2], q]));
        if strictly_one_side(sa) || strictly_one_side(sb) || sa.iter().chain(&sb).any(|&x| x == 0) {
            return None;
        }
        let edges_say = edge_tests(&kx, sa, sb);
        let touch = crossing_orientations(&kx, sa, sb).contains(&0);
        Some((crossing(&kx, sa, sb), edges_say, touch))
    }

    /// The general-position shortcut decides as the edge tests do, on
    /// random pairs (most crossing planes, many meeting) at several scales,
    /// and on small integer corners, where the segments on the planes' line
    /// often touch exactly at an end.
    #[test]
    fn crossing_agrees_with_the_edge_tests() {
        let mut rng = crate::scene::SplitMix::new(23);
        let (mut general, mut meet, mut touching) = (0, 0, 0);
        for n in 0..500_000 {
            let (a, b) = if n < 200_000 {
                let mut r = || 2.0 * rng.unit() - 1.0;
                let (scale, spread) = ([1.0, 1e-3, 1e5][n % 3], [1.0, 0.3, 0.05][n / 3 % 3]);
                let c = DVec3::new(r(), r(), r()) * 0.5;
                let mut tri =
                    |o: DVec3| [(); 3].map(|_| (o + DVec3::new(r(), r(), r()) * spread) * scale);
                (tri(DVec3::ZERO), tri(c * spread))
            } else {
                let mut i = || (rng.next_u64() % 7) as f64 - 3.0;
                let mut tri = || [(); 3].map(|_| DVec3::new(i(), i(), i()));
                (tri(), tri())
            };
            let Some((got, want, touch)) = both_ways(a, b) else {
                continue;
            };
            (general, meet, touching) =
                (general + 1, meet + want as usize, touching + touch as usize);
            assert_eq!(got, want, "pair {n}: {a:?} {b:?}");
        }
        assert!(
            general > 60_000 && meet > 10_000 && touching > 100,
            "{general} {meet} {touching}"
        );
    }

    /// The point and segment tests decide as the triangle test does on the
    /// elements as collapsed triangles: on small-integer coordinates (many
    /// coplanar, collinear, coincident and touching cases), scaled to the
    /// extremes of the doubles, and spread beyond the expansions' range.
    #[test]
    fn point_and_segment_tests_agree_with_collapsed_triangles() {
        let mut rng = crate::scene::SplitMix::new(31);
        let mut grid = || (rng.next_u64() % 3) as f64 - 1.0;
        let (mut touching, mut total) = (0, 0);
        for _ in 0..20_000 {
            let p: [DVec3; 4] = std::array::from_fn(|_| v(grid(), grid(), grid()));
            for scale in [1.0, 2f64.powi(-1000), 2f64.powi(1000), 3.0e-7] {
                let q = p.map(|x| x * scale);
                let mut spread = q;
                spread[3] = spread[3] * 2f64.powi(-600) + q[0];
                for q in [q, spread] {
                    let want = triangles_intersect(&[q[3]; 3], &[q[0], q[1], q[2]]);
                    assert_eq!(point_in_triangle(q[3], &[q[0], q[1], q[2]]), want, "{q:?}");
                    let want = triangles_intersect(&[q[0], q[1], q[1]], &[q[2], q[3], q[3]]);
                    assert_eq!(segments_intersect(q[0], q[1], q[2], q[3]), want, "{q:?}");
                    touching += want as u32;
                    total += 1;
                }
            }
        }
        assert!(
            touching > total / 10 && touching < total * 9 / 10,
            "{touching} of {total}"
        );
    }

    /// Pairs lying in one plane normal to an axis (decided by comparisons,
    /// without orientations) get the answer of the same pairs mapped into
    /// a tilted plane by an exact injective affine map (decided through
    /// the orientations), on small-integer corners (touching, collinear,
    /// collapsed and overlapping cases) and for each axis.
    #[test]
    fn axis_plane_pairs_agree_with_tilted_ones() {
        let mut rng = crate::scene::SplitMix::new(37);
        let mut grid = || (rng.next_u64() % 5) as f64 - 2.0;
        let (mut meet, mut total) = (0, 0);
        for n in 0..60_000 {
            let uv: [[f64; 2]; 6] = std::array::from_fn(|_| [grid(), grid()]);
            let axis = n % 3;
            // The plane normal to `axis` at 3, and the plane w = u + 2v.
            let place = |[u, w]: [f64; 2], c: f64| {
                let mut x = [0.0; 3];
                (x[axis], x[(axis + 1) % 3], x[(axis + 2) % 3]) = (c, u, w);
                DVec3::from(x)
            };
            let flat = uv.map(|p| place(p, 3.0));
            let tilted = uv.map(|p| place(p, p[0] + 2.0 * p[1]));
            let split = |q: [DVec3; 6]| ([q[0], q[1], q[2]], [q[3], q[4], q[5]]);
            let ((a, b), (c, d)) = (split(flat), split(tilted));
            let want = triangles_intersect(&c, &d);
            assert_eq!(triangles_intersect(&a, &b), want, "{uv:?} axis {axis}");
            meet += want as u32;
            total += 1;
        }
        assert!(
            meet > total / 10 && meet < total * 9 / 10,
            "{meet} of {total}"
        );
    }

    /// The plane sides of a triangle in an axis plane, taken by
    /// comparisons and one orientation in the plane, are the orientations'
    /// own signs: small-integer corners (collapsed triangles, points on the
    /// plane), each axis, and scaled to the extremes.
    #[test]
    fn plane_sides_in_an_axis_plane_are_the_orientations() {
        let mut rng = crate::scene::SplitMix::new(41);
        let mut grid = || (rng.next_u64() % 5) as f64 - 2.0;
        let mut zeros = 0;
        for n in 0..30_000 {
            let axis = n % 3;
            let mut p: [DVec3; 6] = std::array::from_fn(|_| v(grid(), grid(), grid()));
            for q in &mut p[..3] {
                q[axis] = 1.0;
            }
            for scale in [1.0, 2f64.powi(-1000), 2f64.powi(1000)] {
                let q = p.map(|x| x * scale);
                let kx = Expansion::new(q).unwrap();
                let want = B.map(|j| kx.orient3d([A[0], A[1], A[2], j]));
                let flat = flat_axes(&[q[0], q[1], q[2]]);
                assert_ne!(flat, 0);
                assert_eq!(flat_plane_sides(&kx, A, flat, B), want, "{p:?} axis {axis}");
                zeros += want.iter().filter(|&&x| x == 0).count();
            }
        }
        assert!(zeros > 10_000, "{zeros}");
    }

    /// The plane clearance never exceeds the distance between the
    /// triangles, and corners moved by less than half of it leave them
    /// apart; at every scale, and 0 where the triangles cross a plane.
    #[test]
    fn plane_clearance_bounds_the_distance() {
        use crate::geom::distance::{point_triangle_distance2, segment_segment_distance2};
        let mut rng = crate::scene::SplitMix::new(11);
        let mut r = || 2.0 * rng.unit() - 1.0;
        let distance = |a: &[DVec3; 3], b: &[DVec3; 3]| {
            let mut d2 = f64::INFINITY;
            for (p, t) in [(a, b), (b, a)] {
                for q in p {
                    d2 = d2.min(point_triangle_distance2(*q, t[0], t[1], t[2]).0);
                }
            }
            for i in 0..3 {
                for j in 0..3 {
                    let (e, f) = ([a[i], a[(i + 1) % 3]], [b[j], b[(j + 1) % 3]]);
                    d2 = d2.min(segment_segment_distance2(e[0], e[1], f[0], f[1]).0);
                }
            }
            d2.sqrt()
        };
        let (mut some, mut none) = (0, 0);
        for k in 0..4000 {
            let scale = [1.0, 2f64.powi(300), 2f64.powi(-300), 2f64.powi(-480)][k % 4];
            let lift = 0.5 * r();
            let mut v = || DVec3::new(r(), r(), r());
            let a = [v(), v(), v()];
            let b = [v(), v(), v()].map(|p| p + DVec3::new(0.0, 0.0, lift));
            let c = plane_clearance(&a.map(|p| p * scale), &b.map(|p| p * scale)) / scale;
            assert!(c >= 0.0 && c <= distance(&a, &b) * (1.0 + 1e-9), "{k}: {c}");
            if c > 0.0 {
                some += 1;
                let mut jiggle = |p: DVec3| {
                    let d = DVec3::new(r(), r(), r()).normalize_or_zero();
                    p + d * (0.4999 * c * r().abs())
                };
                let (a2, b2) = (a.map(&mut jiggle), b.map(&mut jiggle));
                assert!(!triangles_intersect(&a2, &b2), "{k}");
            } else {
                none += 1;
            }
        }
        assert!(some > 500 && none > 500, "{some} {none}");
        // Underflowing planes give nothing.
        let tiny = 2f64.powi(-520);
        let a = [DVec3::ZERO, DVec3::X * tiny, DVec3::Y * tiny];
        assert_eq!(plane_clearance(&a, &a.map(|p| p + DVec3::Z * tiny)), 0.0);
    }

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn crossing_and_separated() {
        let a = [v(0., 0., 0.), v(2., 0., 0.), v(0., 2., 0.)];
        let b = [v(0.5, 0.5, -1.), v(0.5, 0.5, 1.), v(1.5, 1.5, 0.3)];
        assert!(triangles_intersect(&a, &b));
        let c = b.map(|p| p + v(0., 0., 1.5));
        assert!(!triangles_intersect(&a, &c));
    }

    #[test]
    fn touching_at_a_point_and_along_an_edge() {
        let a = [v(0., 0., 0.), v(2., 0., 0.), v(0., 2., 0.)];
        // Vertex of b touches the interior of a.
        let b = [v(0.5, 0.5, 0.), v(1., 1., 1.), v(0., 1., 1.)];
        assert!(triangles_intersect(&a, &b));
        // Edge of b lies on edge of a, b rises out of plane.
        let c = [v(0.5, 0., 0.), v(1.5, 0., 0.), v(1., -1., 1.)];
        assert!(triangles_intersect(&a, &c));
        // Moved off by the smallest step: no contact.
        let eps = f64::from_bits(1u64); // smallest subnormal
        let d = b.map(|p| p + v(0., 0., eps));
        assert!(!triangles_intersect(&a, &d));
    }

    #[test]
    fn coplanar_cases() {
        let a = [v(0., 0., 0.), v(2., 0., 0.), v(0., 2., 0.)];
        let inside = [v(0.2, 0.2, 0.), v(0.5, 0.2, 0.), v(0.2, 0.5, 0.)];
        assert!(triangles_intersect(&a, &inside));
        let overlap = [v(1., 1., 0.), v(3., 1., 0.), v(1., 3., 0.)];
        assert!(triangles_intersect(&a, &overlap)); // touches the hypotenuse at (1,1)
        let apart = [v(1.1, 1.1, 0.), v(3., 1., 0.), v(1., 3., 0.)];
        assert!(!triangles_intersect(&a, &apart));
        // Coplanar in a tilted plane.
        let r = |p: DVec3| v(p.x, p.y * 0.6 - p.z * 0.8, p.y * 0.8 + p.z * 0.6);
        assert!(triangles_intersect(&a.map(r), &inside.map(r)));
    }

    #[test]
    fn near_parallel_slivers() {
        let a = [v(0., 0., 0.), v(1e6, 0., 0.), v(0., 1e-6, 0.)];
        let b = [v(1., -1., 1e-300), v(1., 1., 1e-300), v(2., 0., 1e-300)];
        assert!(!triangles_intersect(&a, &b));
        let c = [v(1., -1., -1e-300), v(1., 1., 1e-300), v(2., 0., 1e-300)];
        assert!(triangles_intersect(&a, &c));
    }

    #[test]
    fn degenerate_triangles_as_segments() {
        let a = [v(0., 0., 0.), v(2., 0., 0.), v(0., 2., 0.)];
        let needle = [v(0.5, 0.5, -1.), v(0.5, 0.5, 1.), v(0.5, 0.5, 0.)];
        assert!(triangles_intersect(&a, &needle));
        let point = [v(0.5, 0.5, 0.1); 3];
        assert!(!triangles_intersect(&a, &point));
        assert!(triangles_intersect(&needle, &[v(0.5, 0.5, 0.5); 3]));
    }
}
