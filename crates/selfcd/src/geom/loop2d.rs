//! Closed loops of segments in the plane: the 2-D geometry of the contour test
//! (see [`crate::bvh::certify`] for the theorem it serves).
//!
//! Decisions are conservative: a loop is reported simple, or two loops apart,
//! only with a margin far above the rounding of the projection; near-touching
//! is "not simple". A `false` costs speed (no cull), never a missed contact.

use super::predicates::{exponent, mul_pow2};
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

    /// The plane's origin.
    pub fn origin(&self) -> DVec3 {
        self.origin
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
        let cross = cross(a, b);
        let scale = len2(a).max(len2(b));
        // Strictly left, with a relative margin far above the rounding of the projection.
        // (NaN or infinite values never pass.)
        if !(scale >= MIN_SCALE2)
            || cross.partial_cmp(&(1e-9 * scale)) != Some(std::cmp::Ordering::Greater)
        {
            return false;
        }
        crossings += (a[1] <= 0.0 && b[1] > 0.0) as u32;
    }
    crossings == 1
}

/// The star test over a linear motion: `start[k]` moving to `end[k]` (the
/// same directed edges, projected at the start and end of the motion), with
/// `c` fixed. Passes when [`star_about`] passes at the start and `c` stays
/// strictly left of every edge at every time: `cross(a(t) - c, b(t) - c)`
/// is quadratic in t with Bernstein coefficients `cross(A0, B0)`,
/// `(cross(A0, B1) + cross(A1, B0)) / 2` and `cross(A1, B1)` (A, B the ends
/// relative to c), all above the star test's margin. The winding number is
/// an integer that cannot change while c stays off the loop, so it is 1 at
/// every time, and the loop is star-shaped about c throughout.
pub fn swept_star_about(start: &[Seg], end: &[Seg], c: [f64; 2]) -> bool {
    if start.len() != end.len() || !star_about(start, c) {
        return false;
    }
    let rel = |p: [f64; 2]| [p[0] - c[0], p[1] - c[1]];
    start.iter().zip(end).all(|(s, e)| {
        let (a0, b0, a1, b1) = (rel(s.p[0]), rel(s.p[1]), rel(e.p[0]), rel(e.p[1]));
        let scale = len2(a0).max(len2(b0)).max(len2(a1)).max(len2(b1));
        let margin = 1e-9 * scale;
        let mid = 0.5 * (cross(a0, b1) + cross(a1, b0));
        // (NaN or infinite values never pass.)
        scale >= MIN_SCALE2
            && scale.is_finite()
            && cross(a0, b0) > margin
            && mid > margin
            && cross(a1, b1) > margin
    })
}

/// [`star_about`], and when it passes, how far the loop's vertices may move
/// with it still passing in exact arithmetic: `Some(s)` means that every
/// loop whose vertices are each within `s` of these (any common translation
/// of the loop and `c` removed) has `c` strictly left of every edge and winds
/// around it once, and so does every loop on the straight way there (the
/// winding number cannot change while `c` stays off the loop).
///
/// With `a`, `b` an edge's ends relative to `c`, `M = max(|a|, |b|)` and each
/// end moved by at most `s <= M / 2`, the cross product loses at most
/// `s (|a| + |b|) + s^2`, and the star test's margin grows to at most
/// `2.25e-9 M^2`; `s` is the root of `s^2 + s (|a| + |b|) = cross - 2.25e-9 M^2`,
/// shrunk by a relative 1e-9 for its own rounding.
pub fn star_slack(segs: &[Seg], c: [f64; 2]) -> Option<f64> {
    if !star_about(segs, c) {
        return None;
    }
    let slack = segs.iter().fold(f64::INFINITY, |slack, s| {
        let a = [s.p[0][0] - c[0], s.p[0][1] - c[1]];
        let b = [s.p[1][0] - c[0], s.p[1][1] - c[1]];
        let (la, lb) = (len(a), len(b));
        let m = la.max(lb);
        let v = cross(a, b) - 2.25e-9 * m * m;
        if !(v > 0.0 && m * m >= 4.0 * MIN_SCALE2) {
            return 0.0;
        }
        slack.min(quadratic_root(1.0, la + lb, v).min(0.5 * m))
    });
    Some(slack * (1.0 - 1e-9))
}

/// The positive root of `k s^2 + b s = v` (k, b, v >= 0).
#[inline]
fn quadratic_root(k: f64, b: f64, v: f64) -> f64 {
    // 2v / (b + sqrt(b^2 + 4kv)): no cancellation when b^2 >> kv.
    2.0 * v / (b + (b * b + 4.0 * k * v).sqrt())
}

/// 2-D cross product (z of the 3-D one).
#[inline]
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

#[inline]
fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

#[inline]
fn len2(p: [f64; 2]) -> f64 {
    dot(p, p)
}

#[inline]
fn len(p: [f64; 2]) -> f64 {
    len2(p).sqrt()
}

/// Smallest squared length the margins below are taken relative to. The
/// margins (1e-9 and 1e-12 of a squared length) then stay above 1e-282, far
/// above the absolute error underflow adds to a product (2^-1074): below it
/// a loop is refused (no cull), never decided on underflowed arithmetic.
const MIN_SCALE2: f64 = 1e-270;

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

/// Twice the signed area of (a, b, c) in floating point. Its rounding error is
/// below 4 ulp of |b - a| |c - a|, so any comparison against the margins used
/// here (at least 1e-12 times the squared extent of the loops) has the sign of
/// the exact value; no adaptive predicate is needed.
#[inline]
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// True when two projected edges meet only where the mesh says they may: not
/// at all, at their one shared vertex (without folding back onto each other),
/// or everywhere when they are the same mesh edge (the glue of two patches).
/// Decided with a margin `eps` on orientation values: near-touching is "not clear".
#[inline(never)]
fn edges_clear(a: &Seg, b: &Seg, eps: f64) -> bool {
    let shared = |v: u32| b.v.contains(&v);
    match (shared(a.v[0]), shared(a.v[1])) {
        (true, true) => true,
        (false, false) => {
            let boxes_apart = (0..2).any(|k| {
                a.p[0][k].max(a.p[1][k]) < b.p[0][k].min(b.p[1][k])
                    || b.p[0][k].max(b.p[1][k]) < a.p[0][k].min(a.p[1][k])
            });
            let side = |s: &Seg, p: [f64; 2]| orient(s.p[0], s.p[1], p);
            let one_side = |s: &Seg, t: &Seg| {
                let (x, y) = (side(s, t.p[0]), side(s, t.p[1]));
                (x > eps && y > eps) || (x < -eps && y < -eps)
            };
            boxes_apart || one_side(a, b) || one_side(b, a)
        }
        (sa0, _) => {
            // One shared vertex s: the edges leave it in different directions.
            let [s, fa, fb] = shared_start(a, b, sa0);
            let (da, db) = ([fa[0] - s[0], fa[1] - s[1]], [fb[0] - s[0], fb[1] - s[1]]);
            orient(s, fa, fb).abs() > eps || dot(da, db) < 0.0
        }
    }
}

/// Edges `a` and `b` sharing one vertex (`a`'s start when `sa0`, else its
/// end): that vertex's position and the far ends of `a` and `b`.
#[inline]
fn shared_start(a: &Seg, b: &Seg, sa0: bool) -> [[f64; 2]; 3] {
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
    [s, fa, fb]
}

/// Reusable buffers of the loop tests: once warm, a test allocates nothing.
#[derive(Debug, Clone, Default)]
pub struct LoopScratch {
    /// Open-addressing table start vertex -> edge starting there.
    next: Vec<[u32; 2]>,
    /// The edge ids of the last loop [`one_cycle`] accepted, in cycle order.
    cycle: Vec<u32>,
    /// The edges of a loop in cycle order (see [`in_cycle_order`]).
    ordered: Vec<Seg>,
    /// Box of each edge.
    boxes: Vec<EdgeBox>,
    /// Box of each run of [`RUN`] consecutive edges (small lists).
    runs: Vec<EdgeBox>,
    /// Extent (min, max) of each edge along the sweep direction.
    spans: Vec<(f64, f64)>,
    /// Edge ids ordered by the bucket of their span's start.
    order: Vec<u32>,
    /// Start of each bucket in `order` (one more entry than buckets).
    start: Vec<u32>,
    /// The edges moved to magnitude about 1 ([`ends_clear_of_edges`]).
    scaled: Vec<Seg>,
}

/// Empty slot of the vertex table.
const EMPTY: u32 = u32::MAX;

#[inline]
fn slot(v: u32, mask: usize) -> usize {
    ((v as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as usize & mask
}

/// Do the edges form one cycle, each vertex starting exactly one edge? O(m)
/// with a hash table from each edge's start vertex to the edge. When they
/// do, `cycle` holds them in cycle order, from the first.
fn one_cycle(segs: &[Seg], table: &mut Vec<[u32; 2]>, cycle: &mut Vec<u32>) -> bool {
    let m = segs.len();
    let mask = (2 * m).next_power_of_two() - 1;
    table.clear();
    table.resize(mask + 1, [EMPTY, 0]);
    for (i, s) in segs.iter().enumerate() {
        let mut h = slot(s.v[0], mask);
        while table[h][0] != EMPTY {
            if table[h][0] == s.v[0] {
                return false;
            }
            h = (h + 1) & mask;
        }
        table[h] = [s.v[0], i as u32];
    }
    // Walk start -> end from the first edge: back after exactly m steps.
    cycle.clear();
    cycle.push(0);
    let mut at = segs[0].v[1];
    while at != segs[0].v[0] {
        if cycle.len() >= m {
            return false;
        }
        match next_edge(table, at) {
            Some(k) => {
                cycle.push(k as u32);
                at = segs[k].v[1];
            }
            None => return false,
        }
    }
    cycle.len() == m
}

/// The edge starting at vertex `v` in the table [`one_cycle`] filled.
#[inline]
fn next_edge(table: &[[u32; 2]], v: u32) -> Option<usize> {
    let mask = table.len() - 1;
    let mut h = slot(v, mask);
    loop {
        match table[h][0] {
            EMPTY => return None,
            k if k == v => return Some(table[h][1] as usize),
            _ => h = (h + 1) & mask,
        }
    }
}

/// Is the projected contour one simple counter-clockwise loop? Every vertex
/// starts exactly one edge, the edges form a single cycle, no two edges meet
/// except consecutive ones at their shared vertex, and the signed area is
/// positive. The edge pairs are compared in cycle order: every pair of runs
/// of consecutive edges, then the edge pairs of runs whose boxes meet, or a
/// bucket grid for long loops (O(m) expected); no allocation once `scratch`
/// is warm.
pub fn simple_ccw_loop(segs: &[Seg], scratch: &mut LoopScratch) -> bool {
    let Some(ext2) = one_ccw_cycle(segs, scratch) else {
        return false;
    };
    in_cycle_order(segs, scratch, |ordered, scratch| {
        all_pairs_clear(ordered, None, 1e-12 * ext2, scratch)
    })
}

/// `f` of the loop [`one_cycle`] just accepted, in cycle order when the
/// pair tests use runs of consecutive edges (whose boxes are then tight),
/// else as given.
fn in_cycle_order<R>(
    segs: &[Seg],
    scratch: &mut LoopScratch,
    f: impl FnOnce(&[Seg], &mut LoopScratch) -> R,
) -> R {
    if segs.len() <= FEW || segs.len() > SMALL {
        return f(segs, scratch); // all pairs, or buckets: any order does
    }
    let mut ordered = std::mem::take(&mut scratch.ordered);
    ordered.clear();
    ordered.extend(scratch.cycle.iter().map(|&k| segs[k as usize]));
    let r = f(&ordered, scratch);
    scratch.ordered = ordered;
    r
}

/// The conditions of [`simple_ccw_loop`] but the edge pairs: one cycle with
/// a positive signed area. Returns the squared extent of the loop.
fn one_ccw_cycle(segs: &[Seg], scratch: &mut LoopScratch) -> Option<f64> {
    if segs.len() < 3 || !one_cycle(segs, &mut scratch.next, &mut scratch.cycle) {
        return None;
    }
    ccw_extent2(segs)
}

/// A pair of contour edges a re-check compares ([`close_pairs`]): the
/// edges' ids and the pair's slack, rounded down: how far every end may
/// move with the pair certainly staying clear.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosePair {
    /// Edge ids: into the tested list, or whatever the holder maps them to.
    pub edges: [u32; 2],
    /// How far every vertex may move with the pair staying clear.
    pub slack: f32,
}

/// What re-checks loops that passed their test after their vertices moved
/// ([`close_pairs`]).
#[derive(Debug, Clone, Copy)]
pub struct Reach {
    /// The move (of every vertex, any common translation removed) below
    /// which the close pairs decide.
    pub moved: f64,
    /// The move (at most `moved`) below which the loops' signed areas
    /// certainly stay positive; beyond it (and below `moved`) they must be
    /// measured again ([`is_ccw`]).
    pub area: f64,
    /// The margin [`still_clear`] compares with: above the rounding of the
    /// edges' orientations at any move below `moved`.
    pub eps: f64,
}

/// For loops that just passed their test, `segs` holding one loop, or two
/// (the first's `split` edges, then the second's): the pairs of edges that
/// a move of every vertex (any common translation removed) by less than
/// `pad` could make meet, into `out` (cleared) sorted by slack, and the
/// move below which they decide ([`Reach`]).
///
/// A pair is listed when its boxes, grown by `pad` on every side, meet
/// (closer than `2 pad`) and its slack is below `pad`; the others stay clear
/// below `pad`. Below [`Reach::moved`] (at most `pad`) the other conditions
/// of the tests hold as well: with two loops, a vertex of each found outside
/// the other (as [`loops_meet_only_where_shared`] asks) stays outside while
/// it moves less than half its distance to the other (it cannot cross the
/// other loop on the straight way there); and a loop's signed area stays
/// positive below [`Reach::area`] (it changes by at most `2 d L + m d^2`
/// for a move `d`, perimeter `L` and `m` edges), or else must be measured.
/// So the loops still pass while the listed pairs whose slack the move
/// reaches are clear ([`still_clear`]), and their areas are positive: one
/// pass over those pairs (and, beyond `area`, over the edges), without the
/// cycle walk and sweep of a test.
/// None for non-finite coordinates, or loops with no room to move.
pub fn close_pairs(
    segs: &[Seg],
    split: usize,
    pad: f64,
    scratch: &mut LoopScratch,
    out: &mut Vec<ClosePair>,
) -> Option<Reach> {
    out.clear();
    let ext2 = extent2(segs);
    let (eps, extent) = (1e-12 * ext2, ext2.sqrt());
    let cell = std::cell::RefCell::new(std::mem::take(out));
    let ok = pairs_clear(
        segs,
        None,
        None,
        pad,
        |i, j| {
            // (A pair not clear now has a negative slack: listed.)
            let slack = pair_slack(&segs[i], &segs[j], eps, extent);
            if !(slack >= pad) {
                let slack = round_down(slack.max(-1.0));
                let edges = [i as u32, j as u32];
                cell.borrow_mut().push(ClosePair { edges, slack });
            }
            true
        },
        scratch,
    );
    *out = cell.into_inner();
    out.sort_unstable_by(|a, b| a.slack.total_cmp(&b.slack));
    let (a, b) = segs.split_at(split.min(segs.len()));
    let (mut moved, mut area) = (pad, area_reach(a, pad));
    if !b.is_empty() {
        area = area.min(area_reach(b, pad));
        moved = moved.min(outside_reach(a, b)?).min(outside_reach(b, a)?);
    }
    // Less the rounding margin of the projection (as the slacks').
    let margin = |d: f64| d * (1.0 - 1e-9) - 1e-9 * extent;
    let (moved, area) = (margin(moved), margin(area).min(moved));
    let grown = extent + 3.0 * moved;
    (ok && moved > 0.0).then_some(Reach {
        moved,
        area,
        eps: 1e-12 * grown * grown,
    })
}

/// `x` as an `f32` no larger than `x`.
pub fn round_down(x: f64) -> f32 {
    let y = x as f32;
    if y as f64 > x {
        y.next_down()
    } else {
        y
    }
}

/// A move (at most `pad`) below which the loop of `segs`, counter-clockwise
/// now, keeps a signed area above [`ccw_extent2`]'s margin in exact
/// arithmetic: with twice the area `A`, perimeter `L`, `m` edges and extent
/// `E`, a move `d <= pad` changes `A` by at most `2 d L + m d^2 <= d (2 L +
/// m pad)` and grows the extent by at most `3 d`, so `A - d (2 L + m pad) >
/// 2e-9 (E + 3 d)^2` (the test's margin and the rounding of `A`) suffices;
/// the extent must also stay above the tests' smallest scale. 0 when none.
fn area_reach(segs: &[Seg], pad: f64) -> f64 {
    let area2: f64 = segs.iter().map(|s| cross(s.p[0], s.p[1])).sum();
    let perimeter: f64 = segs
        .iter()
        .map(|s| len([s.p[1][0] - s.p[0][0], s.p[1][1] - s.p[0][1]]))
        .sum();
    let e = extent2(segs).sqrt();
    let m = segs.len() as f64;
    let room = area2 - 2e-9 * e * e;
    let per_move = (2.0 * perimeter + m * pad) * (1.0 + 1e-9) + 2e-9 * (6.0 * e + 9.0 * pad);
    let d = (room / per_move).min((e - MIN_SCALE2.sqrt()) / 3.0) * (1.0 - 1e-9);
    if d > 0.0 {
        d
    } else {
        0.0
    }
}

/// A move below which the vertex of loop `a` that [`neither_inside`] finds
/// outside loop `b` stays outside: half its distance to `b` (both may move,
/// so the gap closes by at most twice the move). None when there is no such
/// vertex.
fn outside_reach(a: &[Seg], b: &[Seg]) -> Option<f64> {
    let on_b = |v: u32| b.iter().any(|e| e.v[0] == v);
    let w = a.iter().find(|e| !on_b(e.v[0]))?.p[0];
    if inside(w, b) {
        return None;
    }
    let gap = b
        .iter()
        .map(|e| point_seg_distance(w, e))
        .fold(f64::INFINITY, f64::min);
    Some(0.5 * gap)
}

/// Do loops that passed their test still pass, every vertex having moved
/// (any common translation removed) by less than their [`Reach::area`]
/// and by at most `moved`? Exactly when their [`close_pairs`] (sorted by
/// slack) whose slack `moved` reaches are clear now, with margin `eps`
/// ([`Reach::eps`]), `seg` giving each edge (by id) as it is now. (Between
/// `Reach::area` and `Reach::moved`, when also each loop [`is_ccw`].)
pub fn still_clear(
    pairs: &[ClosePair],
    moved: f64,
    eps: f64,
    seg: impl Fn(u32) -> Option<Seg>,
) -> bool {
    pairs
        .iter()
        .take_while(|c| !(moved < c.slack as f64))
        .all(|c| match (seg(c.edges[0]), seg(c.edges[1])) {
            (Some(a), Some(b)) => edges_clear(&a, &b, eps),
            _ => false,
        })
}

/// Is the loop of `segs` counter-clockwise (its signed area positive, with
/// the margin of the loop tests)?
pub fn is_ccw(segs: &[Seg]) -> bool {
    ccw_extent2(segs).is_some()
}

/// The squared extent of the loop of `segs` when its signed area is
/// positive (as [`one_ccw_cycle`] asks), else None.
fn ccw_extent2(segs: &[Seg]) -> Option<f64> {
    let area2: f64 = segs.iter().map(|s| cross(s.p[0], s.p[1])).sum();
    let ext2 = extent2(segs);
    let positive = area2.partial_cmp(&(1e-9 * ext2)) == Some(std::cmp::Ordering::Greater);
    (ext2 >= MIN_SCALE2 && positive).then_some(ext2)
}

/// [`simple_ccw_loop`], and when it passes, how far (at most `cap`) the
/// vertices may move with the loop still simple and counter-clockwise in
/// exact arithmetic, also at every point of the straight way there (so its
/// orientation, which only a self-touching loop could flip, stays):
/// `Some(s)` bounds the move of every vertex, any common translation removed.
/// Two edges sharing no vertex stay apart while each moves less than half
/// their distance; two sharing one keep an angle between them (see
/// `adjacent_slack`).
///
/// Consecutive edges (the only ones sharing a vertex in one cycle) come
/// first: on real contours they usually set the least slack. The other pairs are then compared
/// only where their boxes are within twice that slack, plus the slack's own
/// margin (`1e-9` of the extent), of each other (and never beyond `2 cap`):
/// a pair farther apart has a slack above it, so the answer is the one of
/// comparing every pair within `2 cap`.
pub fn simple_ccw_loop_slack(segs: &[Seg], scratch: &mut LoopScratch, cap: f64) -> Option<f64> {
    let ext2 = one_ccw_cycle(segs, scratch)?;
    let (eps, extent) = (1e-12 * ext2, ext2.sqrt());
    let m = segs.len();
    let cycle = &scratch.cycle;
    let slack = (0..m).fold(cap, |slack, k| {
        let (a, b) = (cycle[k] as usize, cycle[(k + 1) % m] as usize);
        slack.min(pair_slack(&segs[a], &segs[b], eps, extent))
    });
    if !(slack >= 0.0) {
        return None;
    }
    let near = std::cell::Cell::new(slack);
    // The grown boxes meet wherever the plain ones do, so every pair
    // `simple_ccw_loop` compares is compared (and must be clear) here too.
    let ok = in_cycle_order(segs, scratch, |ordered, scratch| {
        pairs_clear(
            ordered,
            None,
            None,
            cap.min(slack + 1e-9 * extent),
            |i, j| {
                let (a, b) = (&ordered[i], &ordered[j]);
                if a.v[1] == b.v[0] || b.v[1] == a.v[0] {
                    return true; // consecutive: done above
                }
                let s = pair_slack(a, b, eps, extent);
                near.set(near.get().min(s));
                s >= 0.0
            },
            scratch,
        )
    });
    ok.then(|| near.get().max(0.0) * (1.0 - 1e-9))
}

/// How far two clear edges of one loop may each move and stay clear
/// ([`simple_ccw_loop_slack`]); negative when they are not clear now.
fn pair_slack(a: &Seg, b: &Seg, eps: f64, extent: f64) -> f64 {
    if !edges_clear(a, b, eps) {
        return -1.0;
    }
    let shared = |v: u32| b.v.contains(&v);
    match (shared(a.v[0]), shared(a.v[1])) {
        (true, true) => f64::INFINITY,
        (false, false) => 0.5 * (seg_distance(a, b) - 1e-9 * extent),
        (sa0, _) => {
            let [s, fa, fb] = shared_start(a, b, sa0);
            adjacent_slack(
                [fa[0] - s[0], fa[1] - s[1]],
                [fb[0] - s[0], fb[1] - s[1]],
                extent,
            )
        }
    }
}

/// Two edges leaving a shared vertex along `da` and `db` overlap beyond it
/// only when they point the same way: the angle `theta` between them is 0.
/// Each end moving by at most `s` moves `da` by at most `2 s`, which turns
/// its direction by at most `asin(2 s / |da|)` (while `2 s < |da|`); the
/// angle cannot close while the two turns add up to less than `theta`,
/// which holds for `s < min(|da|, |db|) sin(theta / 2) / 2` (then each turn
/// is below `theta / 2`). `sin(theta / 2)` is half the distance between the
/// unit directions; its rounding near 0 is a few ulps of the edges' length,
/// far below the `1e-9 extent` the slack is shrunk by for the rounding of
/// the projection and of itself.
/// (A bound on the cross and dot products alone gave `s` about 0.21
/// `|da|` for a straight run of edges, where this gives 0.5 `|da|`.)
fn adjacent_slack(da: [f64; 2], db: [f64; 2], extent: f64) -> f64 {
    // min(la, lb) sin(theta / 2) / 2 = |da lb - db la| / (4 max(la, lb)).
    let (la, lb) = (len(da), len(db));
    let chord = len([da[0] * lb - db[0] * la, da[1] * lb - db[1] * la]);
    let s = 0.25 * chord / la.max(lb) * (1.0 - 1e-12) - 1e-9 * extent;
    // (NaN, from a zero-length edge, gives 0.)
    s.max(0.0)
}

/// Distance between two segments that do not meet: the least distance from
/// an end of one to the other. (Not `geom::distance::segment_segment_distance2`:
/// a slack must never exceed the distance, and this end-point form's rounding
/// is a few ulps of the extent, which the slack's margin covers; the general
/// solve's rounding near parallel segments is not bounded there.)
fn seg_distance(a: &Seg, b: &Seg) -> f64 {
    point_seg_distance(a.p[0], b)
        .min(point_seg_distance(a.p[1], b))
        .min(point_seg_distance(b.p[0], a))
        .min(point_seg_distance(b.p[1], a))
}

/// Distance from `p` to segment `s` (rounding: a few ulps of the extent,
/// as [`seg_distance`]'s).
fn point_seg_distance(p: [f64; 2], s: &Seg) -> f64 {
    let [q, r] = s.p;
    let d = [r[0] - q[0], r[1] - q[1]];
    let w = [p[0] - q[0], p[1] - q[1]];
    let d2 = len2(d);
    let t = if d2 > 0.0 {
        (dot(w, d) / d2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    len([w[0] - t * d[0], w[1] - t * d[1]])
}

/// Is every end of each edge of `segs` (a contour that passed
/// [`star_about`] or [`simple_ccw_loop`]: edges meet only at common ends)
/// farther than `clearance` (> 0) from every edge not ending there? The
/// pairs whose boxes come within the clearance are compared
/// (the sweep of the loop tests), on coordinates moved by a power of two
/// (exact) to magnitude about 1, so that no square over- or underflows.
/// The distances round by a few ulps of the extent: a caller's clearance
/// must hold its own margin above that. Refuses non-finite coordinates.
pub fn ends_clear_of_edges(segs: &[Seg], clearance: f64, scratch: &mut LoopScratch) -> bool {
    let magnitude = segs
        .iter()
        .flat_map(|s| s.p.as_flattened())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    if !magnitude.is_finite() || !(clearance > 0.0) {
        return false;
    }
    let k = if magnitude > 0.0 {
        -exponent(magnitude)
    } else {
        0
    };
    let mut scaled = std::mem::take(&mut scratch.scaled);
    scaled.clear();
    scaled.extend(segs.iter().map(|s| Seg {
        p: s.p.map(|p| p.map(|x| mul_pow2(x, k))),
        v: s.v,
    }));
    let clearance = mul_pow2(clearance, k);
    // An end of one edge against the other edge, where it is not an end of it.
    let apart = |a: &Seg, b: &Seg| {
        (0..2).all(|i| b.v.contains(&a.v[i]) || point_seg_distance(a.p[i], b) > clearance)
    };
    let clear = pairs_clear(
        &scaled,
        None,
        None,
        clearance,
        |i, j| apart(&scaled[i], &scaled[j]) && apart(&scaled[j], &scaled[i]),
        scratch,
    );
    scratch.scaled = scaled;
    clear
}

/// Is the projected contour one simple counter-clockwise loop at every time
/// of a linear motion from `start` to `end` (the same directed edges at both
/// ends)? [`simple_ccw_loop`]'s conditions at the start, then every pair of
/// edges whose boxes over the motion meet must stay clear for the whole
/// motion (`edges_stay_clear`): a loop simple at the start that never has
/// two edges meet where the mesh does not join them stays simple, and its
/// orientation cannot flip. Refuses what it cannot decide.
pub fn swept_simple_ccw_loop(start: &[Seg], end: &[Seg], scratch: &mut LoopScratch) -> bool {
    if start.len() != end.len() || !simple_ccw_loop(start, scratch) {
        return false;
    }
    let ext2 = extent2(start).max(extent2(end));
    if !(ext2.is_finite()) {
        return false;
    }
    let eps = 1e-12 * ext2;
    pairs_clear(
        start,
        None,
        Some(end),
        0.0,
        |i, j| edges_stay_clear([&start[i], &end[i]], [&start[j], &end[j]], eps),
        scratch,
    )
}

/// Bernstein coefficients over t in [0, 1] of `f(U(t), V(t))` for a bilinear
/// `f` (cross or dot) of vectors moving linearly from `u0, v0` to `u1, v1`.
#[inline]
fn bernstein(
    f: impl Fn([f64; 2], [f64; 2]) -> f64,
    [u0, u1]: [[f64; 2]; 2],
    [v0, v1]: [[f64; 2]; 2],
) -> [f64; 3] {
    [f(u0, v0), 0.5 * (f(u0, v1) + f(u1, v0)), f(u1, v1)]
}

/// Two moving edges (each `[at start, at end]`) meet at no time of the
/// motion except where the mesh joins them (the same edge, or one shared
/// vertex without folding back): like [`edges_clear`], with every
/// orientation value's Bernstein coefficients (so its value at every time)
/// beyond the margin `eps`.
fn edges_stay_clear(a: [&Seg; 2], b: [&Seg; 2], eps: f64) -> bool {
    let sub = |p: [f64; 2], q: [f64; 2]| [p[0] - q[0], p[1] - q[1]];
    // The vector from point i of edge x to point j of edge y, at both ends.
    let vec = |x: [&Seg; 2], i: usize, y: [&Seg; 2], j: usize| {
        [sub(y[0].p[j], x[0].p[i]), sub(y[1].p[j], x[1].p[i])]
    };
    let above = |c: [f64; 3]| c.iter().all(|&x| x > eps);
    let below = |c: [f64; 3]| c.iter().all(|&x| x < -eps);
    let shared = |v: u32| b[0].v.contains(&v);
    match (shared(a[0].v[0]), shared(a[0].v[1])) {
        (true, true) => true,
        (false, false) => {
            // Both ends of one edge stay strictly on one side of the other's line.
            let one_side = |s: [&Seg; 2], t: [&Seg; 2]| {
                let dir = vec(s, 0, s, 1);
                let (p, q) = (
                    bernstein(cross, dir, vec(s, 0, t, 0)),
                    bernstein(cross, dir, vec(s, 0, t, 1)),
                );
                (above(p) && above(q)) || (below(p) && below(q))
            };
            one_side(a, b) || one_side(b, a)
        }
        (sa0, _) => {
            // One shared vertex: the edges leave it in directions that never
            // become the same (never collinear, or always more than 90 degrees apart).
            let ia = if sa0 { 0 } else { 1 };
            let ib = if b[0].v[0] == a[0].v[ia] { 0 } else { 1 };
            let (da, db) = (vec(a, ia, a, 1 - ia), vec(b, ib, b, 1 - ib));
            let c = bernstein(cross, da, db);
            above(c) || below(c) || below(bernstein(dot, da, db))
        }
    }
}

/// Every pair of edges (one from `a`, one from `b`; or two distinct edges of
/// `a` when `b` is None) is clear (see `edges_clear`). Edges whose extents
/// along a sweep direction, or whose closed boxes, are apart are clear, so
/// only pairs overlapping in both are compared. Up to [`FEW`] edges every
/// pair's boxes are compared; up to [`SMALL`], the boxes of runs of [`RUN`]
/// consecutive edges first (tight when the list is in cycle order), then the
/// edge pairs of runs that meet. Beyond, the extents are bucketed by
/// their start (m buckets over the whole range, a counting sort), and each
/// edge is compared with the edges starting within its own extent: every
/// overlapping pair has one edge starting inside the other's extent, and is
/// met exactly once. A loop crosses each place along the sweep a few times
/// only, so this is O(m) expected. Non-finite coordinates are never clear.
fn all_pairs_clear(a: &[Seg], b: Option<&[Seg]>, eps: f64, scratch: &mut LoopScratch) -> bool {
    let get = |i| edge_at(a, b, i);
    pairs_clear(
        a,
        b,
        None,
        0.0,
        |i, j| edges_clear(get(i), get(j), eps),
        scratch,
    )
}

/// Edge `i` of the lists `a` then `b` (the numbering of [`pairs_clear`]).
#[inline]
fn edge_at<'a>(a: &'a [Seg], b: Option<&'a [Seg]>, i: usize) -> &'a Seg {
    match b {
        Some(b) if i >= a.len() => &b[i - a.len()],
        _ => &a[i],
    }
}

/// [`all_pairs_clear`] with the test `clear(i, j)` on edge ids (`a`'s, then
/// `b`'s), and, when `a_end` is given, `a`'s edges moving linearly to
/// `a_end` (same order; `b` must be None): the boxes then hold both ends.
/// Boxes are grown by `pad` (>= 0) on every side: pairs whose boxes are up
/// to `2 pad` apart are compared too.
fn pairs_clear(
    a: &[Seg],
    b: Option<&[Seg]>,
    a_end: Option<&[Seg]>,
    pad: f64,
    clear: impl Fn(usize, usize) -> bool,
    scratch: &mut LoopScratch,
) -> bool {
    let m = a.len() + b.map_or(0, <[Seg]>::len);
    let get = |i| edge_at(a, b, i);
    // Pairs to compare: distinct edges of one list, or one edge of each list.
    let wanted = |i: usize, j: usize| b.is_none() || ((i < a.len()) != (j < a.len()));
    // Sweep along a direction 22.5 degrees off the plane's axes, so that the
    // axis-aligned and diagonal edges of grid-like meshes do not all share a range.
    const D: [f64; 2] = [0.923_879_532_511_286_7, 0.382_683_432_365_089_8];
    let LoopScratch {
        boxes,
        spans,
        order,
        start,
        ..
    } = scratch;
    boxes.clear();
    spans.clear();
    let (mut first, mut last) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, s) in a.iter().chain(b.unwrap_or(&[])).enumerate() {
        let [[x0, y0], [x1, y1]] = s.p;
        // A NaN or infinite coordinate (or a sum overflowing) is never clear.
        if !(x0 + y0 + x1 + y1).is_finite() {
            return false;
        }
        let mut bx = EdgeBox {
            lo: [min(x0, x1), min(y0, y1)],
            hi: [max(x0, x1), max(y0, y1)],
        };
        if let Some(e) = a_end.and_then(|e| e.get(i)) {
            let [[x0, y0], [x1, y1]] = e.p;
            if !(x0 + y0 + x1 + y1).is_finite() {
                return false;
            }
            bx.lo = [min(bx.lo[0], min(x0, x1)), min(bx.lo[1], min(y0, y1))];
            bx.hi = [max(bx.hi[0], max(x0, x1)), max(bx.hi[1], max(y0, y1))];
        }
        bx.lo = [bx.lo[0] - pad, bx.lo[1] - pad];
        bx.hi = [bx.hi[0] + pad, bx.hi[1] + pad];
        boxes.push(bx);
    }
    match b {
        // Very few edges: every pair's boxes.
        _ if m <= FEW => {
            return (0..m).all(|i| {
                (i + 1..m).all(|j| !wanted(i, j) || !boxes[i].meets(&boxes[j]) || clear(i, j))
            });
        }
        // Few edges: every pair of runs, then the edge pairs of runs that
        // meet, which is cheaper than bucketing.
        _ if m <= SMALL => {
            let runs = &mut scratch.runs;
            runs.clear();
            runs.extend(boxes.chunks(RUN).map(|c| {
                c.iter().fold(c[0], |r, x| EdgeBox {
                    lo: [min(r.lo[0], x.lo[0]), min(r.lo[1], x.lo[1])],
                    hi: [max(r.hi[0], x.hi[0]), max(r.hi[1], x.hi[1])],
                })
            }));
            let edges = |r: usize| r * RUN..m.min(r * RUN + RUN);
            let n_a = a.len().div_ceil(RUN);
            let last = if b.is_none() { runs.len() } else { n_a };
            return (0..last).all(|r| {
                // Runs of `b` start at a run boundary only when `a`'s length
                // is a multiple of RUN; a run mixing both is compared with
                // itself, and `wanted` keeps one edge of each list.
                let first = if b.is_none() {
                    r
                } else {
                    r.max(n_a.saturating_sub(1))
                };
                (first..runs.len()).all(|q| {
                    !runs[r].meets(&runs[q])
                        || edges(r).all(|i| {
                            let from = if q == r { i + 1 } else { q * RUN };
                            (from..edges(q).end)
                                .all(|j| !wanted(i, j) || !boxes[i].meets(&boxes[j]) || clear(i, j))
                        })
                })
            });
        }
        _ => {}
    }
    for (i, bx) in boxes.iter().enumerate() {
        let span = if a_end.is_some() {
            // D's components are positive: the extent of the box over the motion.
            (
                D[0] * bx.lo[0] + D[1] * bx.lo[1],
                D[0] * bx.hi[0] + D[1] * bx.hi[1],
            )
        } else {
            let [[x0, y0], [x1, y1]] = get(i).p;
            let (u, v) = (D[0] * x0 + D[1] * y0, D[0] * x1 + D[1] * y1);
            // |D| = 1 with positive components: a box grown by `pad` spans
            // at most `(D[0] + D[1]) pad` more each way.
            let grow = (D[0] + D[1]) * pad;
            (min(u, v) - grow, max(u, v) + grow)
        };
        first = min(first, span.0);
        last = max(last, span.1);
        spans.push(span);
    }
    // Bucket of a position along the sweep: monotone in the position, so the
    // buckets from that of lo to that of hi hold every edge starting in [lo, hi].
    let scale = if last > first {
        m as f64 / (last - first)
    } else {
        0.0
    };
    let bucket = |x: f64| (((x - first) * scale) as u32).min(m as u32 - 1) as usize;
    start.clear();
    start.resize(m + 1, 0);
    for s in spans.iter() {
        start[bucket(s.0) + 1] += 1;
    }
    for k in 0..m {
        start[k + 1] += start[k];
    }
    order.clear();
    order.resize(m, 0);
    for (i, s) in spans.iter().enumerate() {
        // `start[k]` is advanced past each placed edge, then restored below.
        let k = bucket(s.0);
        order[start[k] as usize] = i as u32;
        start[k] += 1;
    }
    for k in (1..=m).rev() {
        start[k] = start[k - 1];
    }
    start[0] = 0;
    for (i, &(lo, hi)) in spans.iter().enumerate() {
        let range = start[bucket(lo)] as usize..start[bucket(hi) + 1] as usize;
        for &j in &order[range] {
            let j = j as usize;
            let lj = spans[j].0;
            // Each overlapping pair once: from the edge starting first (ties by id).
            if lj < lo || lj > hi || (lj == lo && j <= i) || !wanted(i, j) {
                continue;
            }
            if boxes[i].meets(&boxes[j]) && !clear(i, j) {
                return false;
            }
        }
    }
    true
}

/// Lists of up to this many edges in all compare every pair's boxes.
const FEW: usize = 24;

/// Lists of up to this many edges in all compare every pair of runs' boxes.
const SMALL: usize = 160;

/// Consecutive edges of a run (the small lists' first level).
const RUN: usize = 4;

/// Minimum of two finite numbers (no NaN handling).
#[inline]
fn min(x: f64, y: f64) -> f64 {
    if x < y {
        x
    } else {
        y
    }
}

/// Maximum of two finite numbers (no NaN handling).
#[inline]
fn max(x: f64, y: f64) -> f64 {
    if x > y {
        x
    } else {
        y
    }
}

/// Closed box of a projected edge.
#[derive(Debug, Clone, Copy)]
struct EdgeBox {
    lo: [f64; 2],
    hi: [f64; 2],
}

impl EdgeBox {
    /// The closed boxes share a point.
    #[inline]
    fn meets(&self, o: &EdgeBox) -> bool {
        self.lo[0] <= o.hi[0]
            && o.lo[0] <= self.hi[0]
            && self.lo[1] <= o.hi[1]
            && o.lo[1] <= self.hi[1]
    }
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
pub fn loops_meet_only_where_shared(a: &[Seg], b: &[Seg], scratch: &mut LoopScratch) -> bool {
    let ext2 = extent2(a).max(extent2(b));
    ext2 >= MIN_SCALE2 && all_pairs_clear(a, Some(b), 1e-12 * ext2, scratch) && neither_inside(a, b)
}

/// [`loops_meet_only_where_shared`], and when it passes, how far (at most
/// `cap`) the vertices of both loops may move with it still passing in
/// exact arithmetic, on the whole straight way there: every pair of edges
/// (one of each loop) stays clear as in [`simple_ccw_loop_slack`]. While the
/// loops meet only where they share vertices, a vertex of one cannot cross
/// the other, so neither comes inside the other.
pub fn loops_meet_only_where_shared_slack(
    a: &[Seg],
    b: &[Seg],
    scratch: &mut LoopScratch,
    cap: f64,
) -> Option<f64> {
    let ext2 = extent2(a).max(extent2(b));
    if !(ext2 >= MIN_SCALE2) || !neither_inside(a, b) {
        return None;
    }
    let (eps, extent) = (1e-12 * ext2, ext2.sqrt());
    let slack = std::cell::Cell::new(cap);
    let edge = |i| edge_at(a, Some(b), i);
    let ok = pairs_clear(
        a,
        Some(b),
        None,
        cap,
        |i, j| {
            let s = pair_slack(edge(i), edge(j), eps, extent);
            slack.set(slack.get().min(s));
            s >= 0.0
        },
        scratch,
    );
    ok.then(|| slack.get().max(0.0) * (1.0 - 1e-9))
}

/// Has each of two loops a vertex off the other that lies outside it?
fn neither_inside(a: &[Seg], b: &[Seg]) -> bool {
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

    pub(super) fn loop_of(points: &[[f64; 2]], ids: &[u32]) -> Vec<Seg> {
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

    /// A U: simple, not star-shaped about its box centre (1.5, 1.5).
    fn u_shape() -> Vec<Seg> {
        loop_of(
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
        )
    }

    /// Moves every vertex of a loop by a random vector of length up to `r`
    /// (the same vertex the same way in both edges that hold it).
    fn jiggle(segs: &[Seg], r: f64, rng: &mut crate::scene::SplitMix) -> Vec<Seg> {
        let mut moved = std::collections::HashMap::new();
        for s in segs {
            for v in s.v {
                moved.entry(v).or_insert_with(|| {
                    let a = std::f64::consts::TAU * rng.unit();
                    let l = r * rng.unit().sqrt();
                    [l * a.cos(), l * a.sin()]
                });
            }
        }
        segs.iter()
            .map(|s| {
                let m = |k: usize| {
                    let d = moved[&s.v[k]];
                    [s.p[k][0] + d[0], s.p[k][1] + d[1]]
                };
                Seg {
                    p: [m(0), m(1)],
                    v: s.v,
                }
            })
            .collect()
    }

    /// What a kept certificate's re-check decides for loops `moved` (the
    /// first `split` edges one loop, the rest another) by up to `r` since
    /// their close pairs and reach were found, as `ContourCull::reused`
    /// does: the pairs that `r` reaches clear, and each loop's orientation
    /// measured again only beyond the area reach.
    fn rechecked(
        moved: &[Seg],
        split: usize,
        (pairs, reach): (&[ClosePair], &Reach),
        r: f64,
    ) -> bool {
        let (a, b) = moved.split_at(split);
        still_clear(pairs, r, reach.eps, |i| moved.get(i as usize).copied())
            && (r < reach.area || is_ccw(a) && (b.is_empty() || is_ccw(b)))
    }

    /// The outcomes of re-checks compared with the full tests.
    #[derive(Default)]
    struct Outcomes {
        same: u32,
        broken: u32,
    }

    impl Outcomes {
        /// Asserts that loops `moved` by 0.999 of their reach are re-checked
        /// ([`rechecked`]) as the full tests decide (`full`), and counts it.
        fn agree(
            &mut self,
            moved: &[Seg],
            split: usize,
            found: (&[ClosePair], &Reach),
            full: bool,
            round: usize,
        ) {
            let kept = rechecked(moved, split, found, 0.999 * found.1.moved);
            assert_eq!(kept, full, "round {round}");
            self.same += full as u32;
            self.broken += !full as u32;
        }

        /// Both outcomes occurred often enough for the comparison to mean something.
        fn assert_both(&self) {
            let (same, broken) = (self.same, self.broken);
            assert!(same > 100 && broken > 20, "both outcomes: {same} {broken}");
        }
    }

    /// Moved by less than the pad, a loop is simple and counter-clockwise by
    /// its close pairs exactly when it is by the full test, whether the move
    /// keeps it simple or not: U-shaped loops with slots of several widths
    /// and zig-zag edges, jiggled by up to 0.999 of their reach (a common
    /// translation added, which changes nothing).
    #[test]
    fn close_pairs_decide_a_loop_moved_less_than_the_pad() {
        let mut rng = crate::scene::SplitMix::new(31);
        let mut scratch = LoopScratch::default();
        let mut seen = Outcomes::default();
        for round in 0..400 {
            let w = [0.002, 0.02, 0.2, 0.5][round % 4];
            let n = 3 + round % 9;
            // A U whose bottom is a zig-zag of `n` teeth and whose slot is `w` wide.
            let mut p = vec![[0.0, 0.0]];
            for k in 1..n {
                let x = 3.0 * k as f64 / n as f64;
                p.push([x, if k % 2 == 1 { -0.1 } else { 0.0 }]);
            }
            p.extend([[3.0, 0.0], [3.0, 3.0], [1.5 + w, 3.0], [1.5 + w, 1.0]]);
            p.extend([[1.5, 1.0], [1.5, 3.0], [0.0, 3.0]]);
            let ids: Vec<u32> = (0..p.len() as u32).collect();
            let segs = loop_of(&p, &ids);
            assert!(simple_ccw_loop(&segs, &mut scratch), "round {round}");
            let pad = [0.001, 0.01, 0.1, 0.3][(round / 4) % 4];
            let mut pairs = Vec::new();
            let reach = close_pairs(&segs, segs.len(), pad, &mut scratch, &mut pairs).unwrap();
            assert!(
                reach.moved <= pad && reach.moved > 0.5 * pad.min(0.05),
                "{round}"
            );
            let t = [rng.unit() * 5.0, rng.unit() * 5.0];
            let moved: Vec<Seg> = jiggle(&segs, 0.999 * reach.moved, &mut rng)
                .iter()
                .map(|s| Seg {
                    p: s.p.map(|q| [q[0] + t[0], q[1] + t[1]]),
                    v: s.v,
                })
                .collect();
            let full = simple_ccw_loop(&moved, &mut scratch);
            seen.agree(&moved, segs.len(), (&pairs, &reach), full, round);
        }
        seen.assert_both();
    }

    /// The area reach of a close pair list bounds the moves that keep a
    /// loop counter-clockwise: a sliver triangle `h` high is flipped by a
    /// move of `h / 2` of its apex and base, and its reach stays below
    /// that; moved by up to its reach, it stays counter-clockwise.
    #[test]
    fn area_reach_keeps_a_sliver_counter_clockwise() {
        let mut rng = crate::scene::SplitMix::new(9);
        let mut scratch = LoopScratch::default();
        for h in [0.3, 0.03, 0.003] {
            let sliver = loop_of(&[[0., 0.], [1., 0.], [0.5, h]], &[0, 1, 2]);
            let mut pairs = Vec::new();
            let reach = close_pairs(&sliver, sliver.len(), 0.5, &mut scratch, &mut pairs).unwrap();
            assert!(reach.area > 0.0 && reach.area < 0.5 * h, "{h}: {reach:?}");
            for _ in 0..2000 {
                assert!(is_ccw(&jiggle(&sliver, 0.999 * reach.area, &mut rng)));
            }
        }
    }

    /// Two loops pinched at a vertex, moved by less than their reach: their
    /// close pairs (of the list of both) decide as the full tests do, whether
    /// the move keeps them apart or not: a square and a quad touching it at
    /// a corner, one of the quad's vertices `g` above the square's top edge.
    #[test]
    fn close_pairs_decide_two_loops_moved_less_than_the_pad() {
        let mut rng = crate::scene::SplitMix::new(5);
        let mut scratch = LoopScratch::default();
        let mut seen = Outcomes::default();
        let a = loop_of(&[[0., 0.], [1., 0.], [1., 1.], [0., 1.]], &[0, 1, 2, 3]);
        for round in 0..800 {
            let g = [0.002, 0.02, 0.1, 0.3][round % 4];
            let b = loop_of(
                &[[1., 1.], [2., 1.], [2., 2.], [1.2, 1. + g]],
                &[2, 4, 5, 6],
            );
            assert!(loops_meet_only_where_shared(&a, &b, &mut scratch));
            let both: Vec<Seg> = a.iter().chain(&b).copied().collect();
            let pad = [0.01, 0.05, 0.1, 0.3][(round / 4) % 4];
            let mut pairs = Vec::new();
            let reach = close_pairs(&both, a.len(), pad, &mut scratch, &mut pairs).unwrap();
            let moved = jiggle(&both, 0.999 * reach.moved, &mut rng);
            let (ma, mb) = moved.split_at(a.len());
            let full = simple_ccw_loop(ma, &mut scratch)
                && simple_ccw_loop(mb, &mut scratch)
                && loops_meet_only_where_shared(ma, mb, &mut scratch);
            seen.agree(&moved, a.len(), (&pairs, &reach), full, round);
        }
        seen.assert_both();
    }

    /// Loops moved by up to their slack (less a hair) still pass; slacks are
    /// positive on shapes with room, and zero or absent where there is none.
    #[test]
    fn slacks_bound_the_moves_that_keep_a_loop_passing() {
        let mut rng = crate::scene::SplitMix::new(3);
        let ids: Vec<u32> = (0..8).collect();
        let square = loop_of(&[[0., 0.], [1., 0.], [1., 1.], [0., 1.]], &ids[..4]);
        let u = u_shape();
        let star = star_slack(&square, [0.5, 0.5]).unwrap();
        assert!(star > 0.1 && star < 0.5, "{star}");
        assert_eq!(star_slack(&u, [1.5, 1.5]), None);
        let mut scratch = LoopScratch::default();
        let simple = simple_ccw_loop_slack(&u, &mut scratch, 10.0).unwrap();
        assert!(simple > 0.05 && simple < 0.5, "{simple}");
        assert!(simple_ccw_loop_slack(&u, &mut scratch, 0.01).unwrap() <= 0.01);
        // A square with a vertex in the middle of each side: straight runs
        // of two edges, whose slack is half the edge (0.25), less the corners'.
        let runs = loop_of(
            &[
                [0., 0.],
                [0.5, 0.],
                [1., 0.],
                [1., 0.5],
                [1., 1.],
                [0.5, 1.],
                [0., 1.],
                [0., 0.5],
            ],
            &ids,
        );
        let straight = simple_ccw_loop_slack(&runs, &mut scratch, 10.0).unwrap();
        assert!(straight > 0.17 && straight < 0.25, "{straight}");
        for _ in 0..2000 {
            let moved = jiggle(&square, 0.999 * star, &mut rng);
            assert!(star_about(&moved, [0.5, 0.5]));
            let moved = jiggle(&u, 0.999 * simple, &mut rng);
            assert!(simple_ccw_loop(&moved, &mut scratch));
            let moved = jiggle(&runs, 0.999 * straight, &mut rng);
            assert!(simple_ccw_loop(&moved, &mut scratch));
        }
        // A loop that a small move breaks has a small slack: the U with its
        // slot narrowed to 1e-3.
        let narrow = loop_of(
            &[
                [0., 0.],
                [3., 0.],
                [3., 3.],
                [1.001, 3.],
                [1.001, 1.],
                [1., 1.],
                [1., 3.],
                [0., 3.],
            ],
            &ids,
        );
        let tight = simple_ccw_loop_slack(&narrow, &mut scratch, 10.0).unwrap();
        assert!(tight < 5e-4, "{tight}");
    }

    /// Two loops pinched at a vertex, moved by up to their slack (less a
    /// hair, the shared vertex the same way in both), still meet only there.
    #[test]
    fn pinched_slack_bounds_the_moves_that_keep_loops_apart() {
        let mut rng = crate::scene::SplitMix::new(7);
        let a = loop_of(&[[0., 0.], [1., 0.], [1., 1.], [0., 1.]], &[0, 1, 2, 3]);
        // A square touching `a` at its corner (1, 1), its own corner 0.3 from `a`'s top edge.
        let b = loop_of(&[[1., 1.], [2., 1.], [2., 2.], [1.2, 1.3]], &[2, 4, 5, 6]);
        let mut scratch = LoopScratch::default();
        let slack = loops_meet_only_where_shared_slack(&a, &b, &mut scratch, 10.0).unwrap();
        assert!(slack > 0.01 && slack < 0.2, "{slack}");
        let inner = loop_of(&[[1., 1.], [0.5, 0.8], [0.8, 0.5]], &[2, 7, 8]);
        assert_eq!(
            loops_meet_only_where_shared_slack(&a, &inner, &mut scratch, 10.0),
            None
        );
        for _ in 0..2000 {
            let both: Vec<Seg> = a.iter().chain(&b).copied().collect();
            let moved = jiggle(&both, 0.999 * slack, &mut rng);
            let (ma, mb) = moved.split_at(a.len());
            assert!(loops_meet_only_where_shared(ma, mb, &mut scratch));
        }
    }

    #[test]
    fn simple_loops_and_stars() {
        let square = loop_of(&[[0., 0.], [1., 0.], [1., 1.], [0., 1.]], &[0, 1, 2, 3]);
        assert!(
            simple_ccw_loop(&square, &mut LoopScratch::default())
                && star_about(&square, [0.5, 0.5])
        );
        assert!(!star_about(&square, [1.5, 0.5]), "centre outside");
        let cw: Vec<Seg> = square
            .iter()
            .rev()
            .map(|s| Seg {
                p: [s.p[1], s.p[0]],
                v: [s.v[1], s.v[0]],
            })
            .collect();
        assert!(!simple_ccw_loop(&cw, &mut LoopScratch::default()) && !star_about(&cw, [0.5, 0.5]));
        let bowtie = loop_of(&[[0., 0.], [1., 1.], [1., 0.], [0., 1.]], &[0, 1, 2, 3]);
        assert!(!simple_ccw_loop(&bowtie, &mut LoopScratch::default()));
        // A U shape: simple but not star-shaped about its box centre.
        let u = u_shape();
        assert!(simple_ccw_loop(&u, &mut LoopScratch::default()) && !star_about(&u, [1.5, 1.5]));
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
        assert!(loops_meet_only_where_shared(
            &a,
            &b,
            &mut LoopScratch::default()
        ));
        let inner = loop_of(&[[1., 1.], [0.5, 0.8], [0.8, 0.5]], &[2, 7, 8]);
        assert!(
            !loops_meet_only_where_shared(&a, &inner, &mut LoopScratch::default()),
            "nested"
        );
        let crossing = loop_of(&[[1., 1.], [2., 1.], [0.5, 0.5]], &[2, 9, 10]);
        assert!(!loops_meet_only_where_shared(
            &a,
            &crossing,
            &mut LoopScratch::default()
        ));
    }
}

#[cfg(test)]
mod sweep_tests {
    use super::*;
    use crate::scene::SplitMix;

    /// Every pair of edges compared, no box or sweep shortcut.
    fn all_pairs_reference(a: &[Seg], b: Option<&[Seg]>, eps: f64) -> bool {
        match b {
            None => (0..a.len()).all(|i| (i + 1..a.len()).all(|j| edges_clear(&a[i], &a[j], eps))),
            Some(b) => a.iter().all(|x| b.iter().all(|y| edges_clear(x, y, eps))),
        }
    }

    /// A closed loop through `n` points on a noisy circle (often self-crossing
    /// when the noise is large), on a grid-aligned square when `square`.
    fn noisy_loop(
        rng: &mut SplitMix,
        n: usize,
        noise: f64,
        square: bool,
        first_id: u32,
    ) -> Vec<Seg> {
        let pts: Vec<[f64; 2]> = (0..n)
            .map(|k| {
                let t = k as f64 / n as f64;
                let (x, y) = if square {
                    // Four collinear runs of edges, as a grid patch's contour.
                    let s = 4.0 * t;
                    match s as usize {
                        0 => (s, 0.0),
                        1 => (1.0, s - 1.0),
                        2 => (3.0 - s, 1.0),
                        _ => (0.0, 4.0 - s),
                    }
                } else {
                    let a = std::f64::consts::TAU * t;
                    (a.cos(), a.sin())
                };
                [
                    x + noise * (rng.unit() - 0.5),
                    y + noise * (rng.unit() - 0.5),
                ]
            })
            .collect();
        (0..n)
            .map(|i| {
                let j = (i + 1) % n;
                Seg {
                    p: [pts[i], pts[j]],
                    v: [first_id + i as u32, first_id + j as u32],
                }
            })
            .collect()
    }

    #[test]
    fn sweep_decides_as_all_pairs() {
        let mut rng = SplitMix::new(11);
        let mut scratch = LoopScratch::default();
        let (mut clear, mut crossed) = (0, 0);
        for round in 0..400 {
            let n = 5 + round % 200;
            let noise = [0.0, 0.05, 0.3, 1.0][round % 4];
            let square = round % 3 == 0;
            let a = noisy_loop(&mut rng, n, noise, square, 0);
            let want = all_pairs_reference(&a, None, 1e-12);
            assert_eq!(
                all_pairs_clear(&a, None, 1e-12, &mut scratch),
                want,
                "round {round}"
            );
            let b = noisy_loop(&mut rng, 3 + round % 80, noise, !square, 1000);
            let want2 = all_pairs_reference(&a, Some(&b), 1e-12);
            assert_eq!(
                all_pairs_clear(&a, Some(&b), 1e-12, &mut scratch),
                want2,
                "round {round}"
            );
            clear += want as u32;
            crossed += !want as u32;
        }
        assert!(
            clear > 50 && crossed > 50,
            "both outcomes exercised: {clear} {crossed}"
        );
    }

    /// The slack of every pair whose boxes are within `2 cap` (the
    /// definition), against the version that compares consecutive edges
    /// first and the others within twice their least slack: bit-identical.
    #[test]
    fn slack_is_the_least_over_every_pair_within_the_cap() {
        use super::tests::loop_of;
        let reference = |a: &[Seg], cap: f64| -> Option<f64> {
            let mut scratch = LoopScratch::default();
            let ext2 = one_ccw_cycle(a, &mut scratch)?;
            let (eps, extent) = (1e-12 * ext2, ext2.sqrt());
            let grown = |s: &Seg| {
                let (lo, hi) = seg_bounds(std::slice::from_ref(s));
                ([lo[0] - cap, lo[1] - cap], [hi[0] + cap, hi[1] + cap])
            };
            let mut slack = cap;
            for i in 0..a.len() {
                for j in i + 1..a.len() {
                    let ((li, hi), (lj, hj)) = (grown(&a[i]), grown(&a[j]));
                    if (0..2).all(|k| li[k] <= hj[k] && lj[k] <= hi[k]) {
                        let s = pair_slack(&a[i], &a[j], eps, extent);
                        if s < 0.0 {
                            return None;
                        }
                        slack = slack.min(s);
                    }
                }
            }
            Some(slack.max(0.0) * (1.0 - 1e-9))
        };
        let mut rng = SplitMix::new(5);
        let mut scratch = LoopScratch::default();
        let (mut some, mut none) = (0, 0);
        for round in 0..600 {
            let n = 4 + round % 150;
            let noise = [0.0, 0.01, 0.05, 0.6][(round / 2) % 4];
            let a = if round % 2 == 0 {
                noisy_loop(&mut rng, n, noise, round % 3 == 0, 0)
            } else {
                // A spike from the top reaching down to w above the bottom
                // edge: the least slack is between edges that share no vertex.
                let w = 1e-4 + 0.4 * rng.unit();
                let mut p = vec![[0., 0.], [3., 0.], [3., 3.], [2., 3.]];
                p.extend([[1.5, w], [1., 3.], [0., 3.], [0., 2.]]);
                let ids: Vec<u32> = (0..8).collect();
                let mut u = loop_of(&p, &ids);
                for s in &mut u {
                    for q in &mut s.p {
                        *q = [q[0] + 1e-3 * noise * q[1], q[1] + 1e-3 * noise * q[0]];
                    }
                }
                u
            };
            let cap = [1e-3, 0.02, 0.2, 10.0][(round / 4) % 4];
            let want = reference(&a, cap);
            assert_eq!(
                simple_ccw_loop_slack(&a, &mut scratch, cap),
                want,
                "round {round}"
            );
            some += want.is_some() as u32;
            none += want.is_none() as u32;
        }
        assert!(
            some > 100 && none > 20,
            "both outcomes exercised: {some} {none}"
        );
    }

    #[test]
    fn one_cycle_rejects_two_loops_and_pinches() {
        let (mut t, mut c) = (Vec::new(), Vec::new());
        let ring = |ids: &[u32]| -> Vec<Seg> {
            (0..ids.len())
                .map(|i| Seg {
                    p: [[0.0; 2]; 2],
                    v: [ids[i], ids[(i + 1) % ids.len()]],
                })
                .collect()
        };
        assert!(one_cycle(&ring(&[4, 2, 9, 7]), &mut t, &mut c));
        assert_eq!(c, [0, 1, 2, 3], "cycle order");
        let mut shuffled = ring(&[4, 2, 9, 7]);
        shuffled.swap(1, 3);
        assert!(one_cycle(&shuffled, &mut t, &mut c));
        assert_eq!(c, [0, 3, 2, 1], "cycle order from a shuffled list");
        let mut two = ring(&[1, 2, 3]);
        two.extend(ring(&[5, 6, 7]));
        assert!(!one_cycle(&two, &mut t, &mut c), "two cycles");
        let mut pinch = ring(&[1, 2, 3]);
        pinch.extend(ring(&[1, 6, 7]));
        assert!(
            !one_cycle(&pinch, &mut t, &mut c),
            "vertex 1 starts two edges"
        );
        let mut open = ring(&[1, 2, 3, 4]);
        open.pop();
        assert!(!one_cycle(&open, &mut t, &mut c), "not closed");
    }
}
