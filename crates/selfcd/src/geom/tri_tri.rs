//! Exact intersection of closed triangles in 3D.
//!
//! Two closed triangles intersect iff (a) they are coplanar and their
//! projections overlap, or (b) some edge of one meets the other: the extreme
//! points of the convex set `A ∩ B` lie on an edge of A or of B when the planes
//! differ. Every decision is an exact orientation sign, so touching at a point,
//! along an edge and coplanar overlap are all reported, and nothing is lost to
//! rounding. Degenerate (collapsed) triangles are handled as their edges.

use super::predicates::{
    certainly_one_side, dominant_axis, is_degenerate, orient3d, point_in_triangle_2d, project,
    scale_exactly, segments_intersect_2d,
};
use glam::DVec3;

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

/// The exact test behind a floating-point filter, for any finite scale:
/// first the error-bounded plane-side test ([`certainly_one_side`]) both ways;
/// when it cannot decide, both triangles are scaled by one power of two
/// ([`scale_exactly`]) and given [`triangles_intersect`].
#[inline]
pub fn triangles_intersect_filtered(a: &[DVec3; 3], b: &[DVec3; 3]) -> Decision {
    if certainly_one_side(a, b) || certainly_one_side(b, a) {
        return Decision::FilterApart;
    }
    let mut p = [a[0], a[1], a[2], b[0], b[1], b[2]];
    scale_exactly(&mut p);
    Decision::Exact(triangles_intersect(
        &[p[0], p[1], p[2]],
        &[p[3], p[4], p[5]],
    ))
}

/// True when closed triangles `a` and `b` share at least one point (exact
/// while no orientation product overflows or underflows: see
/// [`triangles_intersect_filtered`] for inputs of any scale).
pub fn triangles_intersect(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    // Plane-side rejection first: it settles most pairs, and it is valid for
    // degenerate triangles too (their orientations are all zero, never one-sided).
    let sb = b.map(|p| orient3d(a[0], a[1], a[2], p));
    if strictly_one_side(sb) {
        return false;
    }
    let sa = a.map(|p| orient3d(b[0], b[1], b[2], p));
    if strictly_one_side(sa) {
        return false;
    }
    let da = is_degenerate(a[0], a[1], a[2]);
    let db = is_degenerate(b[0], b[1], b[2]);
    let any_edge =
        |x: &[DVec3; 3], y: &[DVec3; 3]| edges(x).iter().any(|e| segment_triangle(e[0], e[1], y));
    match (da, db) {
        (true, true) => edges(a).iter().any(|ea| {
            edges(b)
                .iter()
                .any(|eb| segments_intersect_3d(ea[0], ea[1], eb[0], eb[1]))
        }),
        (true, false) => any_edge(a, b),
        (false, true) => any_edge(b, a),
        (false, false) if sb == [0; 3] => {
            let k = dominant_axis(a[0], a[1], a[2]);
            triangles_intersect_2d(a.map(|p| project(p, k)), b.map(|p| project(p, k)))
        }
        (false, false) => any_edge(a, b) || any_edge(b, a),
    }
}

fn edges(t: &[DVec3; 3]) -> [[DVec3; 2]; 3] {
    [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]]
}

fn strictly_one_side(s: [i8; 3]) -> bool {
    s.iter().all(|&x| x > 0) || s.iter().all(|&x| x < 0)
}

/// Closed segment [p, q] against closed non-degenerate triangle t.
pub fn segment_triangle(p: DVec3, q: DVec3, t: &[DVec3; 3]) -> bool {
    let op = orient3d(t[0], t[1], t[2], p);
    let oq = orient3d(t[0], t[1], t[2], q);
    if op * oq > 0 {
        return false;
    }
    if op == 0 && oq == 0 {
        let k = dominant_axis(t[0], t[1], t[2]);
        let t2 = t.map(|v| project(v, k));
        let (p2, q2) = (project(p, k), project(q, k));
        return point_in_triangle_2d(p2, t2)
            || (0..3).any(|i| segments_intersect_2d(p2, q2, t2[i], t2[(i + 1) % 3]));
    }
    // The segment crosses (or ends on) the plane at one point: the line through
    // it hits the closed triangle iff it passes on the same side of all three edges.
    let s = [
        orient3d(p, q, t[0], t[1]),
        orient3d(p, q, t[1], t[2]),
        orient3d(p, q, t[2], t[0]),
    ];
    s.iter().all(|&x| x >= 0) || s.iter().all(|&x| x <= 0)
}

/// Closed 2D triangles (both non-degenerate) share a point.
fn triangles_intersect_2d(a: [[f64; 2]; 3], b: [[f64; 2]; 3]) -> bool {
    (0..3)
        .any(|i| (0..3).any(|j| segments_intersect_2d(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3])))
        || point_in_triangle_2d(a[0], b)
        || point_in_triangle_2d(b[0], a)
}

/// Closed 3D segments share a point (zero-length segments allowed).
pub fn segments_intersect_3d(p1: DVec3, p2: DVec3, q1: DVec3, q2: DVec3) -> bool {
    if orient3d(p1, p2, q1, q2) != 0 {
        return false; // skew lines never meet
    }
    let k = if !is_degenerate(p1, p2, q1) {
        dominant_axis(p1, p2, q1)
    } else if !is_degenerate(p1, p2, q2) {
        dominant_axis(p1, p2, q2)
    } else if !is_degenerate(q1, q2, p1) {
        dominant_axis(q1, q2, p1)
    } else {
        // All four points on one line (or coincident): drop the axis the line is
        // most nearly perpendicular to, which keeps the line one-to-one.
        let d = if (p2 - p1).length_squared() >= (q2 - q1).length_squared() {
            p2 - p1
        } else {
            q2 - q1
        };
        if d == DVec3::ZERO {
            return p1 == q1; // two points (any projection could merge them)
        }
        let d = d.abs();
        if d.x <= d.y && d.x <= d.z {
            0
        } else if d.y <= d.z {
            1
        } else {
            2
        }
    };
    segments_intersect_2d(
        project(p1, k),
        project(p2, k),
        project(q1, k),
        project(q2, k),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

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
