//! Coherent self queries: one hierarchy per mesh serves the intersection,
//! proximity and continuous queries of a sequence of frames, and a candidate
//! set of element pairs is reused from frame to frame where the mesh moved
//! coherently enough not to change the answers (a Verlet list with a
//! per-region validity test).
//!
//! **Candidate set.** At reference positions `r` it holds every owned element
//! pair (vertex-triangle, edge-edge; see [`for_each_owned_pair`]) closer than
//! `R = reach + skin`.
//!
//! **Relative displacement.** Let `e_i = x_i - r_i`. A point of one element is
//! `sum a_i x_i`, of the other `sum b_j x_j` (convex weights), so their
//! difference is `sum a_i b_j (r_i - r_j) + sum a_i b_j (e_i - e_j)`: the
//! pair's distance changed by at most its *spread* `max |e_i - e_j|` over
//! vertices i of one side and j of the other. No common translation or
//! rotation needs removing: a smooth motion has small spreads between nearby
//! elements however far it carried them. For a linear motion `x0 -> x1`,
//! `e_i(t) - e_j(t)` is a convex combination of the ends', so the larger of
//! the two ends' spreads bounds it over the whole step. The queries take the
//! spread over the pair's two visiting triangles
//! ([`ElementPair::visiting_triangles`], which hold its vertices): a larger
//! bound, shared by every pair of those triangles, read off the leaves'
//! displacement boxes.
//!
//! **Query.** For a query within `d`, a pair of spread `< R - d` that is within
//! `d` was within `R` at `r`: it is a candidate. So the answer is (a) the
//! candidates of spread `< R - d`, tested, plus (b) the pairs of spread
//! `>= R - d`, found by the fresh query's traversal with one more cull: a node,
//! or a pair of nodes, whose displacement boxes have spread `< R - d` holds no
//! pair of kind (b) (the spread of boxes bounds the spread of every pair in
//! them). Both parts run exactly the fresh query's arithmetic (box tests
//! included) on disjoint sets whose union holds every pair the fresh query
//! reports, so the answer equals it; `tests/continuous.rs` checks that on
//! simulated sequences. A mesh that moved coherently culls the traversal near
//! the root.
//!
//! **Rebuilds.** Part (b) grows as the set ages, so the last query of the
//! same kind (distance and number of ends) predicts the next one's: a query
//! rebuilds the set first, at its own positions, when the last query of its
//! kind tested a good share of a rebuild in part (b). It pays the rebuild
//! instead of a part (b) at least as costly (rather than that part (b) and
//! then the rebuild at the next query), and queries of other kinds (a
//! continuous query's thinner distance leaves it a wider allowance) keep
//! using the set meanwhile.
//!
//! **Sets that die young.** A rebuild costs several queries (it gathers
//! every pair within `R` and sorts them), so a set pays only when it serves
//! many. Where the mesh moves faster than the skin allows (a falling,
//! crumpling cloth goes stale every four or five steps) a proximity query
//! that needs a new set after one that served fewer than [`REUSE_MIN`]
//! queries answers one-shot instead ([`super::proximity_contacts`]: the
//! top-down hierarchy with its certificates, the same contacts to the bit)
//! and records that answer for the continuous queries as a set-based one
//! would. It tries a set again after a streak of such answers, twice as
//! long after each set that dies young too (at most [`SKIP_MOST`]).
//!
//! **Continuous queries after a proximity query.** A simulator asks for
//! the pairs within `reach` at `x0`, then for the pairs that come within a
//! thinner `thickness` over the step `x0 -> x1`. Taken as a set without
//! skin, with reference `x0`, the proximity answer covers the continuous
//! query as the candidate set does (its allowance is `reach - thickness`,
//! and the spread is the step's own displacement, one end): a pair of
//! spread below it that comes within `thickness` was within `reach` at
//! `x0`, so it is in the answer. One step moves the mesh less than the
//! steps since the candidate set's reference did, and the answer is smaller
//! than the set, so the continuous query reads it whenever it starts where
//! the last proximity query was taken (on the 20k centre scene its time
//! fell from 19 to 12 ms a step; BENCHMARKS.md, twenty-first landing).
//!
//! **Repeated continuous queries.** A continuous query from the same start
//! with the same thickness as the last one, whose end positions differ only
//! at a few vertices (impulses changed their velocities), keeps the last
//! answer's pairs whose two visiting triangles touch none of those vertices
//! (everything the fresh query computes for such a pair reads only their
//! positions) and tests the triangle pairs that touch one, by a traversal
//! of the hierarchy refitted to the new sweep that skips the nodes without
//! such a triangle. Where the fresh query took the start's node boxes, it
//! also skips node pairs a coordinate axis keeps apart over the step
//! (their start boxes and those moved by their displacement boxes): a
//! sheet falling or sliding along itself sweeps every triangle's box over
//! its neighbours', and only the relative motion tells them apart.
//!
//! **Intersections after moving a few vertices.** The simulator checks the
//! end of a step for intersections, moves the vertices of intersecting
//! triangles rigidly (impact zones) and checks again. The second check's
//! answer keeps the first one's pairs away from the moved vertices (their
//! triangles did not change) and tests again, the same two ways as a
//! repeated continuous query, the triangle pairs at a moved vertex
//! ([`SelfQueries::intersections_after_moving`]). On the 80k centre
//! cloth's first 60 steps this took the checks from 28.3-28.5 to
//! 10.7-11.3 ms a step (BENCHMARKS.md, thirty-first landing).

use super::continuous::{candidate_toi, check_args, element_toi, stay_apart, Impact, Impacts};
use super::narrow::{
    check_thickness, collect_proximity, for_each_owned_near, for_each_owned_pair, guard_add,
    sorted_by_key, ElementPair, Intersect, Near, Proximity, ProximityContacts,
    DEFAULT_MAX_CONTACTS,
};
use crate::bvh::certify::Cull;
use crate::bvh::traverse::{self_traverse, traverse, LeafVisitor, TraverseOptions};
use crate::bvh::{build::build, Bvh};
use crate::error::{Error, Result};
use crate::geom::ccd::{boxes_stay_apart, boxes_stay_apart_on_axes};
use crate::geom::distance::HullCull;
use crate::geom::{magnitude, Aabb};
use crate::mesh::Mesh;
use crate::stats::{Counters, FrameStats};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Below this many items a loop runs on one thread.
const PAR_MIN: usize = 4096;

/// What the hierarchy's boxes are fitted to: static boxes at `at` when
/// `fitted`, else nothing yet or a swept motion. `at` keeps its buffer
/// across frames (no allocation per refit).
#[derive(Debug, Clone, Default, PartialEq)]
struct Fit {
    fitted: bool,
    at: Vec<DVec3>,
}

/// Element pairs closer than `reach + skin` at `reference`, in two tiers.
/// The pairs within `reach` come first, in the order of the
/// queries' answers (vertex-triangle pairs, then edge-edge, each kind by its
/// ids), so what a query takes from them comes out sorted; the pairs in the
/// skin follow by increasing distance, so a query scans only the prefix near
/// enough for it (on a flat sheet the skin holds most pairs and a query takes
/// none). Only the traversal's and the skin's shares need sorting and merging in.
#[derive(Debug, Clone, Default)]
struct Candidates {
    reference: Vec<DVec3>,
    reach: f64,
    skin: f64,
    pairs: Vec<ElementPair>,
    /// Number of vertex-triangle pairs within `reach` (the first ones).
    vertex_triangles: usize,
    /// Number of pairs within `reach` (the first tier).
    within: usize,
    /// Visiting triangles of each pair ([`ElementPair::visiting_triangles`]).
    tris: Vec<[u32; 2]>,
    /// Distance of each pair at `reference`.
    distance: Vec<f64>,
    /// Largest coordinate magnitude at `reference` (for the rounding slack).
    magnitude: f64,
    /// Leaf pairs the build tested: what a rebuild costs.
    build_tests: u64,
}

/// An element pair with its visiting triangles ([`ElementPair::visiting_triangles`]).
type Visited = (ElementPair, [u32; 2]);

/// Relative slack on the distance bounds below: covers rounding (1e-9 of the
/// coordinates) and the time-of-impact resolution (1e-6 of the distances,
/// taken 1000 times wider: a pair grazing the bound must not stall the
/// continuous iteration into its cap).
const SLACK: (f64, f64) = (1e-9, 1e-3);

/// A reuse query whose fresh part (b) tested more leaf pairs than this
/// fraction of the last build's marks the set stale for its kind: the next
/// query of that kind rebuilds first ([`Kind`]). Measured on the centre
/// scene's settled pile at 20k (`cloth center 101 40 bvh-cones-contour 150`,
/// one thread, detection ms per step): 0.15 112.8, 0.2 112.5, 0.25 112.3,
/// 0.35 121.3. (Under the earlier rule, where any query's part (b) made the
/// next query rebuild, 0.25 was also the best of 0.125-1.0.)
const STALE_SHARE: f64 = 0.25;

/// What predicts a query's part (b): its distance (bits) and number of ends
/// (1 for proximity, 2 for a motion). Queries of one kind in a sequence see
/// the set age alike.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Kind {
    distance: u64,
    ends: usize,
}

impl Kind {
    /// The kind of a query within `distance` at `ends` position arrays.
    fn new(distance: f64, ends: usize) -> Kind {
        Kind {
            distance: distance.to_bits(),
            ends,
        }
    }
}

impl Candidates {
    /// Becomes the answer `near` of a proximity query within `reach` at
    /// `x`, as a set without skin: its pairs are every owned pair within
    /// `reach` at `x`, in the answer's order. Reuses this set's buffers (a
    /// simulator records an answer every step).
    fn set_answer(&mut self, mesh: &Mesh, x: &[DVec3], reach: f64, near: &ProximityContacts) {
        self.reference.clear();
        self.reference.extend_from_slice(x);
        let vt = (near.vertex_triangle.iter()).map(|c| {
            (
                c.distance,
                ElementPair::VertexTriangle(c.vertex, c.triangle),
            )
        });
        let ee = (near.edge_edge.iter())
            .map(|c| (c.distance, ElementPair::EdgeEdge(c.edges[0], c.edges[1])));
        self.distance.clear();
        self.pairs.clear();
        for (d, p) in vt.chain(ee) {
            self.distance.push(d);
            self.pairs.push(p);
        }
        self.tris.clear();
        let visiting = |p: &ElementPair| p.visiting_triangles(mesh);
        if self.pairs.len() >= PAR_MIN {
            self.tris.par_extend(self.pairs.par_iter().map(visiting));
        } else {
            self.tris.extend(self.pairs.iter().map(visiting));
        }
        (self.reach, self.skin, self.magnitude) = (reach, 0.0, magnitude(x));
        (self.vertex_triangles, self.within) = (near.vertex_triangle.len(), self.pairs.len());
        self.build_tests = 0;
    }

    /// Marks the set empty (no reference), keeping its buffers.
    fn clear(&mut self) {
        self.reference.clear();
    }

    /// The spread below which every pair within `reach` at positions of
    /// coordinate magnitude `magnitude` is a candidate (module doc), or `None`
    /// when there is no set or `reach` is beyond it.
    fn allowance(&self, reach: f64, magnitude: f64) -> Option<f64> {
        if self.reference.is_empty() {
            return None;
        }
        let a = (self.reach + self.skin - reach) * (1.0 - SLACK.1)
            - SLACK.0 * self.magnitude.max(magnitude);
        (a > 0.0).then_some(a)
    }

    /// The least [`allowance`](Self::allowance) over the positions `ends`.
    fn allowance_at(&self, ends: &[&[DVec3]], reach: f64) -> Option<f64> {
        ends.iter()
            .map(|x| self.allowance(reach, magnitude(x)))
            .try_fold(f64::INFINITY, |a, b| b.map(|b| a.min(b)))
    }

    /// Distance at the reference beyond which a candidate of spread `s`
    /// cannot be within `reach` (with slack); monotone in `s`.
    fn limit(&self, motion: &Motion, reach: f64, s: f64) -> f64 {
        let bound = reach + s;
        bound + SLACK.1 * bound + SLACK.0 * motion.magnitude.max(self.magnitude)
    }

    /// The candidates of spread below `allowance` that may be within `reach`
    /// (distance at the reference at most [`limit`](Self::limit)), as a test
    /// of candidate k, and the places it needs to run on: the first tier's
    /// vertex-triangle and edge-edge pairs, and the prefix of the skin's that
    /// is near enough (no pair spreads more than the whole mesh).
    fn covered<'a>(
        &'a self,
        motion: &'a Motion,
        reach: f64,
        allowance: f64,
    ) -> (
        [std::ops::Range<usize>; 3],
        impl Fn(usize) -> Option<Visited> + Sync + 'a,
    ) {
        let widest = self.limit(motion, reach, motion.whole_spread().min(allowance));
        let far = self.distance[self.within..].partition_point(|&d| d <= widest);
        let places = [
            0..self.vertex_triangles,
            self.vertex_triangles..self.within,
            self.within..self.within + far,
        ];
        // Node boxes are fitted only when the whole mesh spreads more.
        let whole = motion.whole_spread();
        let test = move |k: usize| {
            if !(self.distance[k] <= widest) {
                return None; // (implied by the test below; cheaper)
            }
            let tris = self.tris[k];
            let s = if whole < allowance {
                whole
            } else {
                motion.node_spread(tris[0], tris[1])
            };
            (s < allowance && self.distance[k] <= self.limit(motion, reach, s))
                .then_some((self.pairs[k], tris))
        };
        (places, test)
    }
}

/// Largest `|u - w|` over `u` in box `a` and `w` in box `b`, bounded through
/// its per-axis maxima `max(a.max - b.min, b.max - a.min)` (both cannot be
/// negative). Monotone: growing either box never lowers it, also in floating
/// point.
#[inline]
fn spread(a: &Aabb, b: &Aabb) -> f64 {
    (a.max - b.min).max(b.max - a.min).max(DVec3::ZERO).length()
}

/// Displacements since the reference at each end of the query (one, or two
/// for a motion) and, per node and end, their box over the node's vertices.
/// Spreads are taken at each end separately and the larger kept: the
/// displacement difference of two vertices at any time of a linear motion is
/// a convex combination of the ends' (a box over both ends would hold the
/// whole step's motion).
#[derive(Debug, Clone, Default)]
struct Motion {
    /// Ends in use (1 or 2).
    ends: usize,
    /// `e_k[i]` at `k * n_vertices + i`.
    vertex: Vec<DVec3>,
    /// Box of end `k` of node `n` at `k * nodes + n`.
    node: Vec<Aabb>,
    /// Number of nodes (of the boxes last fitted).
    nodes: usize,
    /// Box of end `k` over all vertices.
    whole: Vec<Aabb>,
    /// Largest coordinate magnitude of the query's positions.
    magnitude: f64,
}

impl Motion {
    /// Fits the displacements of `ends` (one or two position arrays) from
    /// `reference`, and their node boxes.
    fn fit(
        &mut self,
        bvh: &Bvh,
        mesh: &Mesh,
        reference: &[DVec3],
        ends: &[&[DVec3]],
        allowance: f64,
    ) {
        let (nv, nn) = (reference.len(), bvh.n_nodes());
        self.ends = ends.len();
        self.vertex.resize(nv * ends.len(), DVec3::ZERO);
        self.whole.clear();
        for (k, x) in ends.iter().enumerate() {
            let e = &mut self.vertex[k * nv..(k + 1) * nv];
            let sub = |(i, d): (usize, &mut DVec3)| *d = x[i] - reference[i];
            if nv >= PAR_MIN {
                e.par_iter_mut().enumerate().for_each(sub);
            } else {
                e.iter_mut().enumerate().for_each(sub);
            }
            self.whole.push(Aabb::from_points(e));
        }
        self.magnitude = ends.iter().map(|x| magnitude(x)).fold(0.0, f64::max);
        if self.whole_spread() < allowance {
            return; // every pair is covered: no traversal, no node boxes
        }
        self.nodes = nn;
        self.node.resize(nn * ends.len(), Aabb::EMPTY);
        for k in 0..ends.len() {
            let e = &self.vertex[k * nv..(k + 1) * nv];
            bvh.fit_nodes(
                &mut self.node[k * nn..(k + 1) * nn],
                |t| Aabb::from_points(&mesh.triangles()[t].map(|i| e[i as usize])),
                Aabb::union,
            );
        }
    }

    /// The spread of all vertices: at least any pair's or node's.
    fn whole_spread(&self) -> f64 {
        self.whole.iter().map(|b| spread(b, b)).fold(0.0, f64::max)
    }

    /// The spread of nodes `a` and `b` (the same node for a self-test): the
    /// larger of the ends'.
    #[inline]
    fn node_spread(&self, a: u32, b: u32) -> f64 {
        let nn = self.nodes;
        (0..self.ends)
            .map(|k| {
                spread(
                    &self.node[k * nn + a as usize],
                    &self.node[k * nn + b as usize],
                )
            })
            .fold(0.0, f64::max)
    }
}

/// The traversal cull of part (b): a node or node pair whose displacement
/// boxes spread less than `allowance` holds only covered pairs; with
/// `start`, a continuous query's node pair that a separating axis keeps
/// apart over the step holds no impact either.
struct MotionCull<'a> {
    motion: &'a Motion,
    allowance: f64,
    start: Option<StartBoxes<'a>>,
}

/// What a continuous query's node pair test reads: the nodes' boxes at the
/// start of the step `x0 -> x1` (the motion's reference: its one end's
/// displacement boxes then hold `x1 - x0`) and the thickness.
#[derive(Clone, Copy)]
struct StartBoxes<'a> {
    boxes: &'a [Aabb],
    thickness: f64,
}

impl StartBoxes<'_> {
    /// Node `n`'s box at the start and that box moved by its displacement
    /// box in `motion` (end 0): boxes holding the node at both ends.
    #[inline]
    fn moved(&self, motion: &Motion, n: u32) -> [Aabb; 2] {
        let (s, d) = (&self.boxes[n as usize], &motion.node[n as usize]);
        [
            *s,
            Aabb {
                min: s.min + d.min,
                max: s.max + d.max,
            },
        ]
    }
}

impl MotionCull<'_> {
    /// Do nodes `a` and `b` stay apart over the step ([`boxes_stay_apart`]
    /// of their start boxes and those moved by their displacement boxes)?
    #[inline]
    fn apart(&self, a: u32, b: u32) -> bool {
        let Some(start) = self.start else {
            return false;
        };
        let m = self.motion;
        boxes_stay_apart(start.moved(m, a), start.moved(m, b), start.thickness)
    }
}

/// The traversal cull of a repeated continuous query: nodes that hold no
/// touched triangle (`holds`, per node), and, with `start`, node pairs that
/// a coordinate axis keeps apart over the step
/// ([`boxes_stay_apart_on_axes`]: cheap enough for every node pair).
struct RepeatCull<'a> {
    holds: &'a [bool],
    motion: &'a Motion,
    start: Option<StartBoxes<'a>>,
}

impl Cull for RepeatCull<'_> {
    type Scratch = ();
    #[inline]
    fn self_culled(&self, n: u32, _: &mut (), c: &mut Counters) -> bool {
        let culled = !self.holds[n as usize];
        c.self_culls += culled as u64;
        culled
    }
    #[inline]
    fn pair_culled(&self, a: u32, b: u32, _: &mut (), c: &mut Counters) -> bool {
        let culled = !(self.holds[a as usize] || self.holds[b as usize])
            || self.start.is_some_and(|s| {
                let m = self.motion;
                boxes_stay_apart_on_axes(s.moved(m, a), s.moved(m, b), s.thickness)
            });
        c.pair_culls += culled as u64;
        culled
    }
}

impl Cull for MotionCull<'_> {
    type Scratch = ();
    #[inline]
    fn self_culled(&self, n: u32, _: &mut (), c: &mut Counters) -> bool {
        let culled = self.motion.node_spread(n, n) < self.allowance;
        c.self_culls += culled as u64;
        culled
    }
    #[inline]
    fn pair_culled(&self, a: u32, b: u32, _: &mut (), c: &mut Counters) -> bool {
        let culled = self.motion.node_spread(a, b) < self.allowance || self.apart(a, b);
        c.pair_culls += culled as u64;
        culled
    }
}

/// Narrow phase of part (b) and of a repeated continuous query: the fresh
/// query's `test` on the owned element pairs of a leaf pair, unless `skip`
/// (part (b): the two triangles are covered; a repeat: neither is touched)
/// or `apart` (the fresh query's triangle-pair test) decides that none of
/// them is to be found.
struct LeafTests<'a, S, F, A> {
    mesh: &'a Mesh,
    skip: S,
    test: F,
    apart: A,
}

impl<T, S, F, A> LeafVisitor for LeafTests<'_, S, F, A>
where
    T: Send,
    S: Fn(u32, u32) -> bool + Sync,
    F: Fn(ElementPair) -> Option<T> + Sync,
    A: Fn([u32; 2]) -> bool + Sync,
{
    type Item = T;
    const SKIP_ADJACENT: bool = false;

    fn visit(&self, a: u32, b: u32, adjacent: bool, out: &mut Vec<T>) {
        self.visit_counted(a, b, adjacent, out, &mut Counters::default());
    }

    /// Counts the pairs `apart` decides in `filter_decisions`.
    fn visit_counted(&self, a: u32, b: u32, _: bool, out: &mut Vec<T>, c: &mut Counters) {
        if (self.skip)(a, b) {
            return;
        }
        if (self.apart)([a, b]) {
            c.filter_decisions += 1;
            return;
        }
        for_each_owned_pair(self.mesh, a, b, |p| out.extend((self.test)(p.canonical())));
    }
}

/// `inner` on the leaf pairs with a `touched` triangle (and, for a visitor
/// that skips them, sharing no vertex: [`descend_each`] does not ask).
struct Touching<'a, V> {
    inner: &'a V,
    touched: &'a [bool],
    mesh: &'a Mesh,
}

impl<V: LeafVisitor> LeafVisitor for Touching<'_, V> {
    type Item = V::Item;
    const SKIP_ADJACENT: bool = V::SKIP_ADJACENT;

    fn visit(&self, a: u32, b: u32, adjacent: bool, out: &mut Vec<V::Item>) {
        self.visit_counted(a, b, adjacent, out, &mut Counters::default());
    }

    fn visit_counted(&self, a: u32, b: u32, adj: bool, out: &mut Vec<V::Item>, c: &mut Counters) {
        let touched = self.touched[a as usize] || self.touched[b as usize];
        if !touched || (V::SKIP_ADJACENT && self.mesh.share_vertex(a as usize, b as usize)) {
            return;
        }
        self.inner.visit_counted(a, b, adj, out, c);
    }
}

/// Narrow phase of a candidate build: owned element pairs closer than `reach`.
struct Gather<'a> {
    mesh: &'a Mesh,
    x: &'a [DVec3],
    hulls: HullCull,
    max: usize,
    found: AtomicUsize,
}

impl LeafVisitor for Gather<'_> {
    type Item = (f64, ElementPair);
    const SKIP_ADJACENT: bool = false;

    fn visit(&self, a: u32, b: u32, _adjacent: bool, out: &mut Vec<(f64, ElementPair)>) {
        if self.found.load(Ordering::Relaxed) > self.max {
            return; // the output guard: the build fails afterwards
        }
        let before = out.len();
        for_each_owned_near(self.mesh, self.x, &self.hulls, a, b, |p, kind, c: &_| {
            out.extend(self.hulls.closest_within(kind, c).map(|(d, _)| (d, p)))
        });
        guard_add(&self.found, before, out.len());
    }
}

/// Maps `f` over `range` in order, in parallel when it is long.
fn filter_map_ordered<U: Send>(
    range: std::ops::Range<usize>,
    f: impl Fn(usize) -> Option<U> + Sync + Send,
) -> Vec<U> {
    if range.len() >= PAR_MIN {
        range.into_par_iter().filter_map(f).collect()
    } else {
        range.filter_map(f).collect()
    }
}

/// The last continuous query and its answer. A query repeated from the same
/// start with the same thickness (the continuous stage's rounds, after
/// impulses changed a few velocities) re-tests only the triangle pairs that
/// touch a vertex whose end position changed (see [`SelfQueries::continuous`]).
#[derive(Debug, Clone, Default)]
struct Sweep {
    x0: Vec<DVec3>,
    x1: Vec<DVec3>,
    thickness: f64,
    found: Vec<Impact>,
}

/// A repeated continuous query re-tests the changed vertices' triangles only
/// while at most this fraction of the vertices changed; past it a whole query
/// costs about as much.
const REPEAT_SHARE: f64 = 0.25;

/// From this share (one in so many) of the triangles touched, a repeated
/// continuous query traverses the hierarchy once for all of them (with the
/// axis cull); below, each descends from the root alone, which costs less
/// than the traversal's passes over every node. Measured on the centre
/// scene (BENCHMARKS.md, thirtieth landing): at 80k triangles, repeats of
/// up to 24k touched triangles took 1,064 ms by descents and 654 by the
/// traversal over 30 steps, while at 20k the traversal for every repeat
/// cost 0.5-1 ms a step more than the descents.
const REPEAT_TRAVERSE_SHARE: usize = 16;

/// Below this many touched triangles a repeated query's descents run on
/// one thread.
const REPEAT_PAR_MIN: usize = 64;

/// Bitwise equality of two positions (`==` would take -0.0 for 0.0).
#[inline]
pub(crate) fn same_bits(a: DVec3, b: DVec3) -> bool {
    a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits)
}

/// One flag per triangle of `mesh`: whether it holds one of `vertices`.
fn triangles_at(mesh: &Mesh, vertices: &[u32]) -> Vec<bool> {
    let mut at = vec![false; mesh.n_triangles()];
    for &v in vertices {
        for &t in mesh.topology().vertex_tris.row(v as usize) {
            at[t as usize] = true;
        }
    }
    at
}

impl Sweep {
    /// The vertices whose end position differs from the last query's, when
    /// the query repeats it (same start, same thickness) and few moved.
    fn changed(&self, x0: &[DVec3], x1: &[DVec3], thickness: f64) -> Option<Vec<u32>> {
        if self.x0.len() != x0.len() || self.thickness.to_bits() != thickness.to_bits() {
            return None;
        }
        if !self.x0.iter().zip(x0).all(|(a, b)| same_bits(*a, *b)) {
            return None;
        }
        let limit = (REPEAT_SHARE * x1.len() as f64) as usize;
        let mut changed = Vec::new();
        for (i, (a, b)) in self.x1.iter().zip(x1).enumerate() {
            if !same_bits(*a, *b) {
                if changed.len() == limit {
                    return None;
                }
                changed.push(i as u32);
            }
        }
        Some(changed)
    }

    /// Keeps `found` as the answer of the query `x0 -> x1` within `thickness`.
    fn record(&mut self, x0: &[DVec3], x1: &[DVec3], thickness: f64, found: &Impacts) {
        self.x0.clear();
        self.x0.extend_from_slice(x0);
        self.x1.clear();
        self.x1.extend_from_slice(x1);
        self.thickness = thickness;
        self.found.clear();
        self.found
            .extend(found.vertex_triangle.iter().chain(&found.edge_edge));
    }
}

/// The leaves whose boxes are within `gap` of leaf `a`'s, by a descent of
/// the hierarchy from the root: exactly the leaves the self-traversal pairs
/// with `a` (it reaches every leaf pair whose boxes are within `gap`, since
/// a node's box holds its leaves').
fn leaves_near(bvh: &Bvh, a: u32, gap: f64, mut f: impl FnMut(u32)) {
    let query = bvh.boxes[a as usize];
    let mut stack = vec![bvh.root()];
    while let Some(n) = stack.pop() {
        if !bvh.boxes[n as usize].within(&query, gap) {
            continue;
        }
        if bvh.is_leaf(n) {
            if n != a {
                f(n);
            }
        } else {
            stack.extend(bvh.children_of(n));
        }
    }
}

/// The leaf pairs of the touched triangles `tris` with the leaves near
/// them ([`leaves_near`]), each pair once, through `visitor`: what a
/// repeated query's traversal visits, by one descent per triangle.
fn descend_each<V: LeafVisitor>(
    bvh: &Bvh,
    tris: &[u32],
    touched: &[bool],
    gap: f64,
    visitor: &V,
) -> (Vec<V::Item>, Counters) {
    let retest = |&a: &u32| {
        let (mut out, mut c) = (Vec::new(), Counters::default());
        leaves_near(bvh, a, gap, |b| {
            if touched[b as usize] && b < a {
                return; // visited from b
            }
            c.primitive_tests += 1;
            visitor.visit_counted(a.min(b), a.max(b), false, &mut out, &mut c);
        });
        (out, c)
    };
    let parts: Vec<(Vec<V::Item>, Counters)> = if tris.len() >= REPEAT_PAR_MIN {
        tris.par_iter().map(retest).collect()
    } else {
        tris.iter().map(retest).collect()
    };
    let mut counters = Counters::default();
    let mut items = Vec::new();
    for (out, c) in parts {
        items.extend(out);
        counters.primitive_tests += c.primitive_tests;
        counters.filter_decisions += c.filter_decisions;
    }
    (items, counters)
}

/// The self queries of one mesh over a sequence of frames: one hierarchy and
/// one candidate set (see the module doc).
pub struct SelfQueries {
    mesh: Arc<Mesh>,
    bvh: Bvh,
    fit: Fit,
    candidates: Candidates,
    /// The last proximity query's answer, as a set without skin: what a
    /// continuous query from the same positions reads (module doc).
    near: Candidates,
    motion: Motion,
    /// Leaf pairs the last reuse query of each kind tested in part (b)
    /// since the set was built.
    uncovered_tests: Vec<(Kind, u64)>,
    /// The last continuous query, for repeats.
    sweep: Sweep,
    /// The node boxes at the last continuous query's start, when the
    /// hierarchy was fitted there (a buffer swapped with the hierarchy's).
    start_boxes: Vec<Aabb>,
    /// Whether `start_boxes` hold the last fresh continuous query's start
    /// (what a repeat of it reads).
    start_valid: bool,
    skin: f64,
    max_contacts: usize,
    rebuilds: Rebuilds,
}

/// Default skin of the candidate set, in mean rest edge lengths: a pair's
/// candidacy stays valid while the displacements of its vertices differ by
/// less than this. Measured on the centre scene at 3,200 triangles over 60
/// steps (instructions, against 0.25 at the same rebuild share): 0.15 +0.6%,
/// 0.2 +5%, 0.3 +4%, 0.4 +14%.
pub const DEFAULT_SKIN: f64 = 0.25;

/// A candidate set that served fewer queries than this before a proximity
/// query needed a new one died young (module doc). On the 20k centre cloth
/// sets served 3-4 queries, and a rebuild cost about three one-shot
/// queries while a query from the set saved a tenth of one
/// (BENCHMARKS.md, twenty-ninth landing).
pub const REUSE_MIN: u32 = 8;
/// One-shot proximity answers after the first set that died young, before
/// a set is tried again; doubled after each further one, up to [`SKIP_MOST`].
const SKIP_FIRST: u32 = 4;
/// The longest streak of one-shot proximity answers between two sets.
pub const SKIP_MOST: u32 = 64;

/// When a proximity query that needs a new candidate set builds it and
/// when it answers one-shot instead (module doc, "Sets that die young").
#[derive(Debug, Clone, Copy, Default)]
struct Rebuilds {
    /// Queries answered from the current set since it was built (None
    /// before the first set).
    served: Option<u32>,
    /// One-shot answers in the current streak.
    skipped: u32,
    /// The current streak's length (0: none).
    streak: u32,
}

impl Rebuilds {
    /// Should a proximity query that needs a new set answer one-shot?
    fn skip(&mut self) -> bool {
        if self.served.is_none_or(|n| n >= REUSE_MIN) {
            (self.skipped, self.streak) = (0, 0);
            return false;
        }
        if self.streak == 0 {
            self.streak = SKIP_FIRST;
        } else if self.skipped >= self.streak {
            // A new set is tried; the next streak, if it dies young too, is longer.
            (self.skipped, self.streak) = (0, (2 * self.streak).min(SKIP_MOST));
            return false;
        }
        self.skipped += 1;
        true
    }

    /// A set was built.
    fn built(&mut self) {
        self.served = Some(0);
    }

    /// A query was answered from the set.
    fn served(&mut self) {
        self.served = self.served.map(|n| n.saturating_add(1));
    }
}

impl SelfQueries {
    /// The default skin for `mesh`: [`DEFAULT_SKIN`] mean rest edge lengths.
    pub fn default_skin(mesh: &Mesh) -> f64 {
        DEFAULT_SKIN * mesh.mean_edge_length()
    }

    /// Builds the hierarchy of `mesh`; candidate sets are built with `skin`
    /// (> 0, finite) beyond the distance asked for.
    pub fn new(mesh: Arc<Mesh>, skin: f64) -> Result<SelfQueries> {
        if !(skin > 0.0 && skin.is_finite()) {
            return Err(Error::InvalidParameter(format!(
                "skin must be positive and finite, got {skin}"
            )));
        }
        let bvh = build(&mesh);
        Ok(SelfQueries {
            mesh,
            bvh,
            fit: Fit::default(),
            candidates: Candidates::default(),
            near: Candidates::default(),
            motion: Motion::default(),
            uncovered_tests: Vec::new(),
            sweep: Sweep::default(),
            start_boxes: Vec::new(),
            start_valid: false,
            skin,
            max_contacts: DEFAULT_MAX_CONTACTS,
            rebuilds: Rebuilds::default(),
        })
    }

    /// The mesh.
    pub fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    /// The hierarchy.
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Sets the limit on proximity contacts and candidates (default [`DEFAULT_MAX_CONTACTS`]).
    pub fn set_max_contacts(&mut self, max: usize) {
        self.max_contacts = max;
    }

    /// Fits boxes and cones to `x` unless they already are; adds the time to `s`.
    fn fit_static(&mut self, x: &[DVec3], s: &mut FrameStats) {
        if self.fit.fitted && self.fit.at.as_slice() == x {
            return;
        }
        let t0 = Instant::now();
        self.bvh.refit(&self.mesh, x);
        self.fit.at.clear();
        self.fit.at.extend_from_slice(x);
        self.fit.fitted = true;
        s.refit_time += t0.elapsed().as_secs_f64();
    }

    /// Rebuilds the candidate set at `x` for pairs within `reach`, with the skin.
    fn rebuild(&mut self, x: &[DVec3], reach: f64, s: &mut FrameStats) -> Result<()> {
        self.fit_static(x, s);
        let t0 = Instant::now();
        let gap = reach + self.skin;
        let mesh = &*self.mesh;
        let magnitude = magnitude(x);
        let gather = Gather {
            mesh,
            x,
            hulls: HullCull::at_magnitude(gap, magnitude, x),
            max: self.max_contacts,
            found: AtomicUsize::new(0),
        };
        let opts = TraverseOptions {
            cones: false,
            contour: false,
            gap,
        };
        let (pairs, c) = self_traverse(&self.bvh, mesh, x, opts, &gather);
        if pairs.len() > self.max_contacts {
            return Err(Error::TooManyContacts {
                limit: self.max_contacts,
                thickness: gap,
            });
        }
        // The pairs within `reach` in the answers' order: vertex-triangle
        // pairs, then edge-edge, each by ids (counting sorts); then the skin's
        // by distance (a distance is >= 0, so its bits order like it), ties by
        // pair. Keys are unique, so the order does not depend on the input's.
        let (within, mut skin): (Vec<_>, Vec<_>) =
            pairs.into_par_iter().partition(|&(d, _)| d <= reach);
        let (vt, ee): (Vec<_>, Vec<_>) = within
            .into_par_iter()
            .partition(|(_, p)| matches!(p, ElementPair::VertexTriangle(..)));
        let ids = |(_, p): &(f64, ElementPair)| match *p {
            ElementPair::VertexTriangle(a, b) | ElementPair::EdgeEdge(a, b) => (a, b),
        };
        let ((vt, ee), ()) = rayon::join(
            || rayon::join(|| sorted_by_key(vt, ids), || sorted_by_key(ee, ids)),
            || skin.par_sort_unstable_by_key(|&(d, p)| (d.to_bits(), p)),
        );
        let (vertex_triangles, within) = (vt.len(), vt.len() + ee.len());
        let pairs = [vt, ee, skin].concat();
        self.candidates = Candidates {
            reference: x.to_vec(),
            reach,
            skin: self.skin,
            vertex_triangles,
            within,
            distance: pairs.iter().map(|p| p.0).collect(),
            tris: pairs.iter().map(|p| p.1.visiting_triangles(mesh)).collect(),
            pairs: pairs.into_iter().map(|p| p.1).collect(),
            magnitude,
            build_tests: c.primitive_tests,
        };
        self.uncovered_tests.clear();
        self.rebuilds.built();
        s.candidate_builds += 1;
        s.node_pairs += c.node_pairs;
        s.proximity_tests += c.primitive_tests;
        s.traverse_time += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// The candidate set's allowance for a query within `reach` at `ends`,
    /// or None when the query needs a new set: the set does not reach that
    /// far, or is stale for the query's kind.
    fn reusable(&self, ends: &[&[DVec3]], reach: f64) -> Option<f64> {
        let stale = self.stale_for(Kind::new(reach, ends.len()));
        (!stale).then(|| self.candidates.allowance_at(ends, reach))?
    }

    /// True when the last query of `kind` since the set was built tested
    /// more than [`STALE_SHARE`] of a rebuild in part (b).
    fn stale_for(&self, kind: Kind) -> bool {
        let limit = STALE_SHARE * self.candidates.build_tests as f64;
        self.uncovered_tests
            .iter()
            .any(|&(k, tests)| k == kind && tests as f64 > limit)
    }

    /// Records what part (b) of the query of `kind` just tested.
    fn record_uncovered(&mut self, kind: Kind, tests: u64) {
        match self.uncovered_tests.iter_mut().find(|(k, _)| *k == kind) {
            Some(entry) => entry.1 = tests,
            None => self.uncovered_tests.push((kind, tests)),
        }
    }

    /// The allowance of the candidate set for a query within `reach` at
    /// `ends`, after rebuilding the set at `ends[0]` when it is stale for the
    /// query's kind or does not reach that far, and the kind (for
    /// [`uncovered`](Self::uncovered) to record); fits the displacement boxes.
    fn prepare(
        &mut self,
        ends: &[&[DVec3]],
        reach: f64,
        s: &mut FrameStats,
    ) -> Result<(f64, Kind)> {
        let reusable = self.reusable(ends, reach);
        self.prepare_from(ends, reach, reusable, s)
    }

    /// [`prepare`](Self::prepare) with the set's [`reusable`](Self::reusable)
    /// allowance already decided.
    fn prepare_from(
        &mut self,
        ends: &[&[DVec3]],
        reach: f64,
        reusable: Option<f64>,
        s: &mut FrameStats,
    ) -> Result<(f64, Kind)> {
        let kind = Kind::new(reach, ends.len());
        let allowance = match reusable {
            Some(a) => {
                s.candidate_reuses += 1;
                self.rebuilds.served();
                a
            }
            None => {
                let reach = reach.max(self.candidates.reach);
                self.rebuild(ends[0], reach, s)?;
                self.candidates.allowance_at(ends, reach).ok_or_else(|| {
                    Error::InvalidParameter(format!("distance {reach} too large to query"))
                })?
            }
        };
        let t0 = Instant::now();
        let c = &self.candidates;
        self.motion
            .fit(&self.bvh, &self.mesh, &c.reference, ends, allowance);
        s.refit_time += t0.elapsed().as_secs_f64();
        Ok((allowance, kind))
    }

    /// True when the whole mesh spreads less than `allowance`: part (b) is
    /// empty, and neither the hierarchy nor the node displacements need fitting.
    fn all_covered(&self, allowance: f64) -> bool {
        self.motion.whole_spread() < allowance
    }

    /// Part (b) of a query (module doc): the traversal of the hierarchy as
    /// fitted now, boxes within `gap`, culled by motion, running `test` on
    /// the pairs not covered. Records its cost for the query's `kind`
    /// ([`prepare`](Self::prepare)'s) when it read the candidate set.
    fn uncovered<T: Send>(
        &mut self,
        gap: f64,
        (allowance, kind): (f64, Option<Kind>),
        test: impl Fn(ElementPair) -> Option<T> + Sync,
        apart: impl Fn([u32; 2]) -> bool + Sync,
        start: Option<StartBoxes>,
        s: &mut FrameStats,
    ) -> Vec<T> {
        if self.all_covered(allowance) {
            if let Some(kind) = kind {
                self.record_uncovered(kind, 0);
            }
            return Vec::new();
        }
        let mesh = &*self.mesh;
        let cull = MotionCull {
            motion: &self.motion,
            allowance,
            start,
        };
        let motion = &self.motion;
        let visitor = LeafTests {
            mesh,
            // Every pair of the two triangles is covered.
            skip: |a, b| motion.node_spread(a, b) < allowance,
            test,
            apart,
        };
        let (found, c) = traverse(&self.bvh, mesh, gap, &cull, &visitor);
        s.node_pairs += c.node_pairs;
        s.filter_decisions += c.filter_decisions;
        s.proximity_tests += c.primitive_tests;
        s.self_culls += c.self_culls;
        s.pair_culls += c.pair_culls;
        if let Some(kind) = kind {
            self.record_uncovered(kind, c.primitive_tests);
        }
        found
    }

    /// Every vertex-triangle and edge-edge pair closer than `thickness` (> 0)
    /// at `x`: equal to [`BvhDetector`](super::hierarchy::BvhDetector)'s
    /// proximity. From the candidate set and the traversal of what it does not
    /// cover (module doc); rebuilds the set at `x` first when it is stale for
    /// this distance (module doc). Adds its
    /// work to `s`.
    pub fn proximity(
        &mut self,
        x: &[DVec3],
        thickness: f64,
        s: &mut FrameStats,
    ) -> Result<ProximityContacts> {
        self.mesh.check_positions(x)?;
        check_thickness(thickness)?;
        self.near.clear();
        let reusable = self.reusable(&[x], thickness);
        if reusable.is_none() && self.rebuilds.skip() {
            return self.proximity_one_shot(x, thickness, s);
        }
        let (allowance, kind) = self.prepare_from(&[x], thickness, reusable, s)?;
        if !self.all_covered(allowance) {
            self.fit_static(x, s);
        }
        let t0 = Instant::now();
        let mesh = self.mesh.clone();
        let near = Proximity::new(&mesh, x, thickness, self.max_contacts);
        let test = |p: ElementPair| near.test(p);
        let never = |_: [u32; 2]| false;
        let mut fresh = self.uncovered(thickness, (allowance, Some(kind)), test, never, None, s);
        let c = &self.candidates;
        let ([vt, ee, skin], covered) = c.covered(&self.motion, thickness, allowance);
        s.candidates += (vt.len() + ee.len() + skin.len()) as u64;
        // The hierarchy's leaf boxes when it is fitted to `x`: the same boxes.
        let leaves = (!self.all_covered(allowance)).then_some(&self.bvh.boxes);
        let boxes = |t: u32| match leaves {
            Some(b) => b[t as usize],
            None => Aabb::from_points(&mesh.corners(x, t as usize)),
        };
        let test_covered = |k: usize| {
            let (p, [a, b]) = covered(k)?;
            // The fresh query's box test, so that the answers are the same to the bit.
            if a == b || !boxes(a).within(&boxes(b), thickness) {
                return None;
            }
            test(p)
        };
        // The first tier's pairs come out in the answer's order, each kind
        // apart; the skin's join the traversal's to be sorted.
        fresh.extend(filter_map_ordered(skin, test_covered));
        let from_set = ProximityContacts {
            vertex_triangle: filter_map_ordered(vt, |k| match test_covered(k)? {
                Near::Vt(x) => Some(x),
                Near::Ee(_) => None,
            }),
            edge_edge: filter_map_ordered(ee, |k| match test_covered(k)? {
                Near::Ee(x) => Some(x),
                Near::Vt(_) => None,
            }),
        };
        if fresh.len() + from_set.len() > self.max_contacts {
            return Err(Error::TooManyContacts {
                limit: self.max_contacts,
                thickness,
            });
        }
        let out = collect_proximity(fresh).merge(from_set);
        s.proximity_contacts = (out.vertex_triangle.len() + out.edge_edge.len()) as u64;
        self.near.set_answer(&mesh, x, thickness, &out);
        s.traverse_time += t0.elapsed().as_secs_f64();
        Ok(out)
    }

    /// [`proximity`](Self::proximity) answered one-shot, without the
    /// candidate set (module doc, "Sets that die young"); the answer is
    /// recorded for the continuous queries all the same, and the hierarchy
    /// fitted at `x` as a set-based answer leaves it: a continuous query
    /// from `x` culls by the boxes there (without them the 80k centre
    /// cloth's continuous stage took 50% longer).
    fn proximity_one_shot(
        &mut self,
        x: &[DVec3],
        thickness: f64,
        s: &mut FrameStats,
    ) -> Result<ProximityContacts> {
        self.fit_static(x, s);
        let t0 = Instant::now();
        let (out, mut c) = super::proximity_contacts(&self.mesh, x, thickness, self.max_contacts)?;
        s.proximity_tests += c.primitive_tests;
        c.primitive_tests = 0;
        c.add_to(s);
        s.proximity_one_shots += 1;
        s.proximity_contacts = (out.vertex_triangle.len() + out.edge_edge.len()) as u64;
        let mesh = self.mesh.clone();
        self.near.set_answer(&mesh, x, thickness, &out);
        s.traverse_time += t0.elapsed().as_secs_f64();
        Ok(out)
    }

    /// Every element pair that may come within `thickness` (>= 0) while the
    /// mesh moves linearly from `x0` to `x1`: equal to
    /// [`BvhDetector::continuous`](super::hierarchy::BvhDetector::continuous)
    /// for a positive thickness; at thickness 0 that query also skips patches
    /// its swept certificate proves free of contact, so this answer holds
    /// its pairs and at most some of the additive CCD's false positives.
    /// A query repeating the last one (same `x0` and `thickness`) with few end
    /// positions changed re-tests only the triangle pairs touching them
    /// (`repeat_continuous`); otherwise the answer
    /// comes from the candidate set and the swept traversal of what it does
    /// not cover (module doc), rebuilding the set at `x0` when it is stale for
    /// this thickness or does not reach it. Adds its work to `s`.
    pub fn continuous(
        &mut self,
        x0: &[DVec3],
        x1: &[DVec3],
        thickness: f64,
        s: &mut FrameStats,
    ) -> Result<Impacts> {
        check_args(&self.mesh, x0, x1, thickness)?;
        let found = match self.sweep.changed(x0, x1, thickness) {
            Some(changed) => self.repeat_continuous(x0, x1, thickness, &changed, s),
            None => self.fresh_continuous(x0, x1, thickness, s)?,
        };
        self.sweep.record(x0, x1, thickness, &found);
        Ok(found)
    }

    /// The continuous query from a set and the swept traversal of what it
    /// does not cover: the last proximity answer where it was taken at `x0`
    /// ([`near_allowance`](Self::near_allowance)), else the candidate set.
    fn fresh_continuous(
        &mut self,
        x0: &[DVec3],
        x1: &[DVec3],
        thickness: f64,
        s: &mut FrameStats,
    ) -> Result<Impacts> {
        let mesh = self.mesh.clone();
        let (allowance, kind) = match self.near_allowance(x0, x1, thickness) {
            Some(a) => {
                let t0 = Instant::now();
                let c = &self.near;
                self.motion.fit(&self.bvh, &mesh, &c.reference, &[x1], a);
                s.refit_time += t0.elapsed().as_secs_f64();
                s.continuous_from_proximity += 1;
                (a, None)
            }
            None => {
                let (a, kind) = self.prepare(&[x0, x1], thickness, s)?;
                (a, Some(kind))
            }
        };
        let t0 = Instant::now();
        // From the proximity answer the motion's reference is `x0`: the
        // node pair test reads the boxes there, if the hierarchy holds them.
        // They move aside (no copy: 19 MB at 200k triangles) and the swept
        // boxes are fitted into the buffer the last query left.
        let mut start_boxes = std::mem::take(&mut self.start_boxes);
        let mut at_start = false;
        if !self.all_covered(allowance) {
            if kind.is_none() && self.fit.fitted && self.fit.at.as_slice() == x0 {
                start_boxes.resize(self.bvh.boxes.len(), Aabb::EMPTY);
                std::mem::swap(&mut start_boxes, &mut self.bvh.boxes);
                at_start = true;
            }
            self.bvh.refit_swept(&mesh, x0, x1);
            self.fit.fitted = false;
        }
        let t1 = Instant::now();
        s.refit_time += (t1 - t0).as_secs_f64();
        let test = |p: ElementPair| {
            element_toi(&mesh, x0, x1, p, thickness).map(|toi| Impact { pair: p, toi })
        };
        let apart = |pair| stay_apart(&mesh, x0, x1, pair, thickness);
        let start = at_start.then_some(StartBoxes {
            boxes: &start_boxes,
            thickness,
        });
        let mut found = self.uncovered(thickness, (allowance, kind), test, apart, start, s);
        self.start_boxes = start_boxes;
        self.start_valid = at_start;
        let c = if kind.is_none() {
            &self.near
        } else {
            &self.candidates
        };
        let (places, covered) = c.covered(&self.motion, thickness, allowance);
        // The hierarchy's leaf boxes when it is fitted to the sweep: the same boxes.
        let leaves = (!self.all_covered(allowance)).then_some(self.bvh.boxes.as_slice());
        for range in places {
            s.candidates += range.len() as u64;
            found.extend(filter_map_ordered(range, |k| {
                let (pair, tris) = covered(k)?;
                candidate_toi(&mesh, x0, x1, pair, tris, leaves, thickness)
            }));
        }
        s.traverse_time += t1.elapsed().as_secs_f64();
        Ok(Impacts::from_items(found))
    }

    /// The allowance of the last proximity answer for a continuous query
    /// `x0 -> x1` within `thickness`, when that answer was taken at `x0`
    /// (to the bit) within a larger distance (module doc).
    fn near_allowance(&self, x0: &[DVec3], x1: &[DVec3], thickness: f64) -> Option<f64> {
        let c = &self.near;
        let same = c.reference.len() == x0.len()
            && c.reference.iter().zip(x0).all(|(a, b)| same_bits(*a, *b));
        same.then(|| c.allowance(thickness, magnitude(x1)))
            .flatten()
    }

    /// The last continuous query repeated with the end positions of the
    /// `changed` vertices moved. The answer for an element pair reads only
    /// the positions of its two visiting triangles (the swept box test of
    /// those triangles, then the time of impact of the pair's stencil, whose
    /// vertices lie on them), so the last answer's pairs whose visiting
    /// triangles touch no changed vertex stay as they were, and the triangle
    /// pairs that do touch one are tested as the swept traversal tests them
    /// ([`LeafTests`]), on the hierarchy fitted to the new sweep: from one
    /// in [`REPEAT_TRAVERSE_SHARE`] triangles touched, by a traversal that
    /// skips the nodes without a touched triangle ([`RepeatCull`]), else by
    /// a descent per touched triangle ([`descend_each`]). Where the start's
    /// node boxes are at hand (the fresh query took them), the traversal
    /// also culls node pairs that a coordinate axis keeps apart over the
    /// step: on a falling sheet every swept box overlaps its neighbours',
    /// which the relative motion keeps apart (BENCHMARKS.md, thirtieth
    /// landing). Such a pair holds no impact, so the answer is unchanged.
    fn repeat_continuous(
        &mut self,
        x0: &[DVec3],
        x1: &[DVec3],
        thickness: f64,
        changed: &[u32],
        s: &mut FrameStats,
    ) -> Impacts {
        let t0 = Instant::now();
        let mesh = self.mesh.clone();
        let touched = triangles_at(&mesh, changed);
        self.bvh.refit_swept(&mesh, x0, x1);
        self.fit.fitted = false;
        let t1 = Instant::now();
        s.refit_time += (t1 - t0).as_secs_f64();
        let visitor = LeafTests {
            mesh: &mesh,
            // (`retest_touched` visits only the pairs with a touched triangle.)
            skip: |_: u32, _: u32| false,
            test: |p: ElementPair| {
                element_toi(&mesh, x0, x1, p, thickness).map(|toi| Impact { pair: p, toi })
            },
            apart: |pair| stay_apart(&mesh, x0, x1, pair, thickness),
        };
        let sweep = self.start_valid.then_some((x0, x1));
        let (retested, c) = self.retest_touched(&touched, thickness, &visitor, sweep);
        let mut found: Vec<Impact> = self
            .sweep
            .found
            .iter()
            .filter(|i| {
                let [a, b] = i.pair.visiting_triangles(&mesh);
                !touched[a as usize] && !touched[b as usize]
            })
            .copied()
            .collect();
        found.extend(retested);
        s.node_pairs += c.node_pairs;
        s.filter_decisions += c.filter_decisions;
        s.proximity_tests += c.primitive_tests;
        s.continuous_repeats += 1;
        s.traverse_time += t1.elapsed().as_secs_f64();
        Impacts::from_items(found)
    }

    /// The leaf pairs with a `touched` triangle (one flag per triangle)
    /// whose boxes, as the hierarchy is fitted, are within `gap`, through
    /// `visitor` (those its traversal would visit: [`Touching`]): from one in
    /// [`REPEAT_TRAVERSE_SHARE`] triangles touched, by a traversal that
    /// skips the nodes without a touched triangle ([`RepeatCull`]) and,
    /// with `sweep` (a continuous query's step `x0 -> x1`, the start's node
    /// boxes at hand), the node pairs a coordinate axis keeps apart over it;
    /// else by a descent per touched triangle ([`descend_each`]).
    fn retest_touched<V: LeafVisitor>(
        &mut self,
        touched: &[bool],
        gap: f64,
        visitor: &V,
        sweep: Option<(&[DVec3], &[DVec3])>,
    ) -> (Vec<V::Item>, Counters) {
        let visitor = &Touching {
            inner: visitor,
            touched,
            mesh: &self.mesh,
        };
        let tris: Vec<u32> = (0..touched.len() as u32)
            .filter(|&t| touched[t as usize])
            .collect();
        if tris.len() * REPEAT_TRAVERSE_SHARE < touched.len() {
            return descend_each(&self.bvh, &tris, touched, gap, visitor);
        }
        let mut holds = vec![false; self.bvh.n_nodes()];
        let join = |a: &bool, b: &bool| *a || *b;
        self.bvh.fit_nodes(&mut holds, |t| touched[t], join);
        if let Some((x0, x1)) = sweep {
            // (Allowance 0: the displacement boxes of every node.)
            let mesh = self.mesh.clone();
            self.motion.fit(&self.bvh, &mesh, x0, &[x1], 0.0);
        }
        let cull = RepeatCull {
            holds: &holds,
            motion: &self.motion,
            start: sweep.map(|_| StartBoxes {
                boxes: &self.start_boxes,
                thickness: gap,
            }),
        };
        traverse(&self.bvh, &self.mesh, gap, &cull, visitor)
    }

    /// [`intersections`](Self::intersections) at `x`, given `last`, that
    /// query's answer at positions that differ from `x` only at the
    /// vertices `moved`: the pairs of `last` without a triangle at a moved
    /// vertex (their corners are the same, so is their test), and the pairs
    /// with one, tested again on the hierarchy fitted at `x` (as a repeated
    /// continuous query tests its touched triangles: one traversal skipping
    /// the nodes without one, or a descent per triangle when they are few).
    /// The same pairs as a fresh query. The
    /// simulator's end-of-step checks after impact zones moved a few
    /// vertices rigidly: a fresh one-shot at 80k triangles costs tens of
    /// milliseconds. Errors: bad positions, a vertex or triangle id out of
    /// range.
    pub fn intersections_after_moving(
        &mut self,
        x: &[DVec3],
        moved: &[u32],
        last: &[[u32; 2]],
        s: &mut FrameStats,
    ) -> Result<Vec<[u32; 2]>> {
        self.mesh.check_positions(x)?;
        let mesh = self.mesh.clone();
        let (nv, nt) = (mesh.n_vertices(), mesh.n_triangles());
        if let Some(v) = moved.iter().find(|&&v| v as usize >= nv) {
            return Err(Error::InvalidParameter(format!(
                "moved vertex {v} out of range (the mesh has {nv} vertices)"
            )));
        }
        if let Some(p) = last.iter().find(|p| p.iter().any(|&t| t as usize >= nt)) {
            return Err(Error::InvalidParameter(format!(
                "triangle pair {p:?} out of range (the mesh has {nt} triangles)"
            )));
        }
        let touched = triangles_at(&mesh, moved);
        self.fit_static(x, s);
        let t0 = Instant::now();
        let visitor = Intersect {
            mesh: &mesh,
            positions: x,
        };
        let (found, c) = self.retest_touched(&touched, 0.0, &visitor, None);
        let kept = last
            .iter()
            .filter(|p| !(touched[p[0] as usize] || touched[p[1] as usize]));
        let mut pairs: Vec<[u32; 2]> = kept.copied().chain(found).collect();
        pairs.sort_unstable();
        c.add_to(s);
        s.contacts = pairs.len() as u64;
        s.traverse_time += t0.elapsed().as_secs_f64();
        Ok(pairs)
    }

    /// Intersecting non-adjacent triangle pairs at `x`, sorted. With
    /// `cones`, the one-shot query ([`crate::bvh::topdown::self_intersections`]:
    /// its top-down hierarchy, split only where the cone and contour
    /// certificates fail), which on the centre cloth took a third of the time
    /// of the kept hierarchy's refit and traversal at 80k triangles and
    /// under half at 20k (BENCHMARKS.md, twenty-ninth landing); without,
    /// the kept hierarchy culling by boxes only. The same pairs either way.
    /// Adds its work to `s`.
    pub fn intersections(
        &mut self,
        x: &[DVec3],
        cones: bool,
        s: &mut FrameStats,
    ) -> Result<Vec<[u32; 2]>> {
        self.mesh.check_positions(x)?;
        if cones {
            let t0 = Instant::now();
            let (pairs, c) = crate::bvh::topdown::self_intersections(&self.mesh, x);
            c.add_to(s);
            s.contacts = pairs.len() as u64;
            s.traverse_time += t0.elapsed().as_secs_f64();
            return Ok(pairs);
        }
        self.fit_static(x, s);
        let t0 = Instant::now();
        let mesh = &*self.mesh;
        let opts = TraverseOptions {
            cones: false,
            contour: false,
            gap: 0.0,
        };
        let (mut pairs, c): (Vec<[u32; 2]>, Counters) =
            self_traverse(&self.bvh, mesh, x, opts, &Intersect { mesh, positions: x });
        pairs.sort_unstable();
        c.add_to(s);
        s.contacts = pairs.len() as u64;
        s.traverse_time += t0.elapsed().as_secs_f64();
        Ok(pairs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Proximity queries that need a new set after sets that die young
    /// answer one-shot in streaks of 4, 8, 16, ... up to `SKIP_MOST`, a set
    /// tried between streaks; a set that served `REUSE_MIN` queries ends it.
    #[test]
    fn one_shot_streaks_double_while_sets_die_young() {
        let mut r = Rebuilds::default();
        assert!(!r.skip(), "the first query builds a set");
        r.built();
        let mut streaks = Vec::new();
        for _ in 0..7 {
            r.served();
            let mut streak = 0;
            while r.skip() {
                streak += 1;
            }
            streaks.push(streak);
            r.built();
        }
        assert_eq!(streaks, [4, 8, 16, 32, 64, 64, 64]);
        for _ in 0..REUSE_MIN {
            r.served();
        }
        assert!(!r.skip(), "a set that served enough is rebuilt");
        r.built();
        r.served();
        let mut streak = 0;
        while r.skip() {
            streak += 1;
        }
        assert_eq!(streak, SKIP_FIRST, "and the streaks start over");
    }
}
