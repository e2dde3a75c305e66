//! Closed loops of segments in the plane: the 2-D geometry of the contour test
//! (see [`crate::bvh::patch`] for the theorem it serves).
//!
//! Decisions are conservative: a loop is reported simple, or two loops apart,
//! only with a margin far above the rounding of the projection; near-touching
//! is "not simple". A `false` costs speed (no cull), never a missed contact.

use crate::geom::predicates::orient2d_value;
use glam::DVec3;

/// A contour edge projected on the plane normal to a cone axis: endpoints and vertex ids.
#[derive(Debug, Clone, Copy)]
pub struct Seg {
    /// Projected start and end.
    pub p: [[f64; 2]; 2],
    /// Vertex ids of start and end.
    pub v: [u32; 2],
}

/// The plane normal to a cone axis through an origin, with a right-handed
/// basis (u, w, axis): counter-clockwise seen from +axis stays counter-clockwise.
#[derive(Debug, Clone, Copy)]
pub struct Plane {
    origin: DVec3,
    u: DVec3,
    w: DVec3,
}

impl Plane {
    /// The plane normal to unit `axis` through `origin`.
    pub fn new(axis: DVec3, origin: DVec3) -> Plane {
        let u = axis.any_orthonormal_vector();
        Plane {
            origin,
            u,
            w: axis.cross(u),
        }
    }

    /// 2D coordinates of the projection of `p`.
    #[inline]
    pub fn project(&self, p: DVec3) -> [f64; 2] {
        let d = p - self.origin;
        [d.dot(self.u), d.dot(self.w)]
    }
}

/// The star test: does centre `c` lie strictly left of every projected edge,
/// with the contour winding around it exactly once? With every edge turning
/// counter-clockwise around c, the winding number is the number of edges
/// crossing the ray from c along +u (all cross it upwards): no angle is computed.
pub fn star_about(segs: &[Seg], c: [f64; 2]) -> bool {
    if segs.len() < 3 {
        return false;
    }
    let mut crossings = 0;
    for s in segs {
        let a = [s.p[0][0] - c[0], s.p[0][1] - c[1]];
        let b = [s.p[1][0] - c[0], s.p[1][1] - c[1]];
        let cross = a[0] * b[1] - a[1] * b[0];
        let scale = (a[0] * a[0] + a[1] * a[1]).max(b[0] * b[0] + b[1] * b[1]);
        // Strictly left, with a relative margin far above the rounding of the projection.
        // (NaN or infinite values never pass.)
        if cross.partial_cmp(&(1e-9 * scale)) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        crossings += (a[1] <= 0.0 && b[1] > 0.0) as u32;
    }
    crossings == 1
}

/// Bounding box of projected edges.
fn seg_bounds(segs: &[Seg]) -> ([f64; 2], [f64; 2]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for s in segs {
        for p in s.p {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    (lo, hi)
}

/// Squared size of the projected contour's bounding box diagonal.
fn extent2(segs: &[Seg]) -> f64 {
    let (lo, hi) = seg_bounds(segs);
    (hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2)
}

/// True when two projected edges meet only where the mesh says they may: not
/// at all, at their one shared vertex (without folding back onto each other),
/// or everywhere when they are the same mesh edge (the glue of two patches).
/// Decided with a margin `eps` on orientation values: near-touching is "not clear".
fn edges_clear(a: &Seg, b: &Seg, eps: f64) -> bool {
    let shared = |v: u32| b.v.contains(&v);
    match (shared(a.v[0]), shared(a.v[1])) {
        (true, true) => true,
        (false, false) => {
            let boxes_apart = (0..2).any(|k| {
                a.p[0][k].max(a.p[1][k]) < b.p[0][k].min(b.p[1][k])
                    || b.p[0][k].max(b.p[1][k]) < a.p[0][k].min(a.p[1][k])
            });
            let side = |s: &Seg, p: [f64; 2]| orient2d_value(s.p[0], s.p[1], p);
            let one_side = |s: &Seg, t: &Seg| {
                let (x, y) = (side(s, t.p[0]), side(s, t.p[1]));
                (x > eps && y > eps) || (x < -eps && y < -eps)
            };
            boxes_apart || one_side(a, b) || one_side(b, a)
        }
        (sa0, _) => {
            // One shared vertex s: the edges leave it in different directions.
            let (s, fa) = if sa0 {
                (a.p[0], a.p[1])
            } else {
                (a.p[1], a.p[0])
            };
            let fb = if b.v[0] == a.v[if sa0 { 0 } else { 1 }] {
                b.p[1]
            } else {
                b.p[0]
            };
            let (da, db) = ([fa[0] - s[0], fa[1] - s[1]], [fb[0] - s[0], fb[1] - s[1]]);
            orient2d_value(s, fa, fb).abs() > eps || da[0] * db[0] + da[1] * db[1] < 0.0
        }
    }
}

/// Is the projected contour one simple counter-clockwise loop? Every vertex
/// starts and ends exactly one edge, the edges form a single cycle, no two
/// edges meet except consecutive ones at their shared vertex, and the signed
/// area is positive. O(m log m) plus the pairs of edges whose x-ranges overlap.
pub fn simple_ccw_loop(segs: &[Seg]) -> bool {
    let m = segs.len();
    if m < 3 {
        return false;
    }
    // One cycle: each vertex starts exactly one edge; walk start -> end from
    // the first edge and come back after exactly m steps.
    let mut by_start: Vec<(u32, u32)> = segs.iter().map(|s| (s.v[0], s.v[1])).collect();
    by_start.sort_unstable();
    if by_start.windows(2).any(|w| w[0].0 == w[1].0) {
        return false;
    }
    let next = |v: u32| {
        by_start
            .binary_search_by_key(&v, |x| x.0)
            .ok()
            .map(|i| by_start[i].1)
    };
    let (mut at, mut steps) = (segs[0].v[1], 1);
    while at != segs[0].v[0] && steps <= m {
        match next(at) {
            Some(v) => at = v,
            None => return false,
        }
        steps += 1;
    }
    if steps != m {
        return false;
    }
    let area2: f64 = segs
        .iter()
        .map(|s| s.p[0][0] * s.p[1][1] - s.p[0][1] * s.p[1][0])
        .sum();
    let ext2 = extent2(segs);
    if area2.partial_cmp(&(1e-9 * ext2)) != Some(std::cmp::Ordering::Greater) {
        return false;
    }
    all_pairs_clear(segs, segs, 1e-12 * ext2)
}

/// Every pair of edges (one from `a`, one from `b`; distinct pairs when they
/// are the same list) is clear (see `edges_clear`). Short lists are compared
/// directly; longer ones with a sweep along x, comparing only edges whose
/// x-ranges overlap.
fn all_pairs_clear(a: &[Seg], b: &[Seg], eps: f64) -> bool {
    let same = std::ptr::eq(a, b);
    if same && a.len() <= 24 {
        return (0..a.len()).all(|i| (i + 1..a.len()).all(|j| edges_clear(&a[i], &a[j], eps)));
    }
    if !same {
        let (small, big) = if a.len() <= b.len() { (a, b) } else { (b, a) };
        if small.len() <= 16 {
            // Only edges of the long loop near the short one can touch it.
            let (lo, hi) = seg_bounds(small);
            return big.iter().all(|x| {
                let (xl, xh) = seg_bounds(std::slice::from_ref(x));
                let near = (0..2).all(|k| xl[k] <= hi[k] && lo[k] <= xh[k]);
                !near || small.iter().all(|y| edges_clear(x, y, eps))
            });
        }
    }
    let pad = 0.0;
    let range = |s: &Seg| {
        (
            s.p[0][0].min(s.p[1][0]) - pad,
            s.p[0][0].max(s.p[1][0]) + pad,
        )
    };
    // Events: (x_min, x_max, list, index), sorted by x_min.
    let mut ev: Vec<(f64, f64, bool, u32)> = a
        .iter()
        .enumerate()
        .map(|(i, s)| (range(s).0, range(s).1, false, i as u32))
        .collect();
    if !same {
        ev.extend(
            b.iter()
                .enumerate()
                .map(|(i, s)| (range(s).0, range(s).1, true, i as u32)),
        );
    }
    ev.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
    let get = |e: &(f64, f64, bool, u32)| {
        if e.2 {
            &b[e.3 as usize]
        } else {
            &a[e.3 as usize]
        }
    };
    for i in 0..ev.len() {
        for j in i + 1..ev.len() {
            if ev[j].0 > ev[i].1 {
                break;
            }
            if (same || ev[i].2 != ev[j].2) && !edges_clear(get(&ev[i]), get(&ev[j]), eps) {
                return false;
            }
        }
    }
    true
}

/// Is `p` inside the closed loop `segs` (crossing number, even-odd)?
fn inside(p: [f64; 2], segs: &[Seg]) -> bool {
    let mut c = false;
    for s in segs {
        let [a, b] = s.p;
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
        {
            c = !c;
        }
    }
    c
}

/// Two simple counter-clockwise loops of adjacent patches: do they meet only
/// along the mesh edges and vertices they share, with neither inside the other?
pub fn loops_meet_only_where_shared(a: &[Seg], b: &[Seg]) -> bool {
    let eps = 1e-12 * extent2(a).max(extent2(b));
    if !all_pairs_clear(a, b, eps) {
        return false;
    }
    let outside = |s: &[Seg], loop_: &[Seg]| {
        let on_loop = |v: u32| loop_.iter().any(|e| e.v[0] == v);
        s.iter()
            .find(|e| !on_loop(e.v[0]))
            .is_some_and(|e| !inside(e.p[0], loop_))
    };
    outside(a, b) && outside(b, a)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn loop_of(points: &[[f64; 2]], ids: &[u32]) -> Vec<Seg> {
        (0..points.len())
            .map(|i| {
                let j = (i + 1) % points.len();
                Seg {
                    p: [points[i], points[j]],
                    v: [ids[i], ids[j]],
                }
            })
            .collect()
    }

    #[test]
    fn simple_loops_and_stars() {
        let square = loop_of(&[[0., 0.], [1., 0.], [1., 1.], [0., 1.]], &[0, 1, 2, 3]);
        assert!(simple_ccw_loop(&square) && star_about(&square, [0.5, 0.5]));
        assert!(!star_about(&square, [1.5, 0.5]), "centre outside");
        let cw: Vec<Seg> = square
            .iter()
            .rev()
            .map(|s| Seg {
                p: [s.p[1], s.p[0]],
                v: [s.v[1], s.v[0]],
            })
            .collect();
        assert!(!simple_ccw_loop(&cw) && !star_about(&cw, [0.5, 0.5]));
        let bowtie = loop_of(&[[0., 0.], [1., 1.], [1., 0.], [0., 1.]], &[0, 1, 2, 3]);
        assert!(!simple_ccw_loop(&bowtie));
        // A U shape: simple but not star-shaped about its box centre.
        let u = loop_of(
            &[
                [0., 0.],
                [3., 0.],
                [3., 3.],
                [2., 3.],
                [2., 1.],
                [1., 1.],
                [1., 3.],
                [0., 3.],
            ],
            &[0, 1, 2, 3, 4, 5, 6, 7],
        );
        assert!(simple_ccw_loop(&u) && !star_about(&u, [1.5, 1.5]));
        // Twice around: every edge has the centre on its left, but it winds twice.
        let twice: Vec<[f64; 2]> = (0..8)
            .map(|k| {
                let a = 4.0 * std::f64::consts::PI * k as f64 / 8.0 + 0.1 * k as f64;
                [a.cos(), a.sin()]
            })
            .collect();
        assert!(!star_about(
            &loop_of(&twice, &[0, 1, 2, 3, 4, 5, 6, 7]),
            [0.0, 0.0]
        ));
    }

    #[test]
    fn pinched_loops() {
        let a = loop_of(&[[0., 0.], [1., 0.], [1., 1.], [0., 1.]], &[0, 1, 2, 3]);
        let b = loop_of(&[[1., 1.], [2., 1.], [2., 2.], [1., 2.]], &[2, 4, 5, 6]);
        assert!(loops_meet_only_where_shared(&a, &b));
        let inner = loop_of(&[[1., 1.], [0.5, 0.8], [0.8, 0.5]], &[2, 7, 8]);
        assert!(!loops_meet_only_where_shared(&a, &inner), "nested");
        let crossing = loop_of(&[[1., 1.], [2., 1.], [0.5, 0.5]], &[2, 9, 10]);
        assert!(!loops_meet_only_where_shared(&a, &crossing));
    }
}
