//! A hierarchy built top-down, lazily, for one query: the one-shot
//! [`self_intersections`](crate::detect::self_intersections),
//! [`first_intersection`](crate::detect::first::first_intersection),
//! [`proximity_contacts`](crate::detect::proximity_contacts) (boxes within
//! the thickness, no certificate) and
//! [`continuous_impacts`](crate::detect::continuous::continuous_impacts)
//! (swept boxes; at thickness 0 the certificate holds over the whole step:
//! [`Shape::Swept`]).
//!
//! The bottom-up hierarchy ([`super::build`]) fits every node's box, cone and
//! patch up front, which a simulation pays once and amortises over frames. A
//! one-shot query needs a node only where its parent's certificate failed:
//! on a smooth sheet the root's certificate holds and nothing is split (nor
//! are the triangles' boxes fitted). Here a node is a range of a permutation
//! of the triangles, split only when a test needs its children, at the
//! midpoint of its box along the axis whose plane cuts the fewest triangle
//! boxes, so children are ranges too. A contour's membership tests read
//! marks written over the node's range just before (no inverse permutation
//! is kept up to date at every split). A node whose test
//! failed only because it holds several edge-connected pieces (layers of
//! cloth, a garment on a body: Euler characteristic 2 or more) is split
//! into its largest piece and the rest instead, so that each layer can
//! certify on its own (spatial halves would hold every layer again).
//!
//! ```text
//! self(N)    = nothing if N's certificate holds (tried from CERT_MIN
//!              triangles when static, at every node when swept); the
//!              pairs of a leaf (at most LEAF triangles, SWEPT_LEAF when
//!              swept at thickness 0);
//!              else self(left), self(right), pair(left, right)
//! pair(A, B) = nothing if the boxes are apart or the union's certificate
//!              holds (A and B certified and adjacent); the pairs of two leaves;
//!              else pair over the children of the bigger (of both, in
//!              parallel tasks, when both are large)
//! ```
//!
//! **Certificate.** [`super::certify`]'s theorem, for any set S of triangles
//! (a node, or the union of two): every normal strictly within 90 degrees of
//! an axis v, every edge of S in at most two triangles of S and then with
//! opposite directions, Euler characteristic V - E + F = 1 (V counting every
//! vertex of S once), and the contour (directed edges in one triangle of S)
//! projected along v winding once around a point strictly left of every edge,
//! or forming one simple counter-clockwise loop. Then no two non-adjacent
//! triangles of S touch. Vertices where S has several fans need no test of
//! their own: cut each into one vertex per fan; the result S' is an
//! orientable surface (no closed component: its area-weighted normals would
//! sum to zero, against v), every boundary cycle of S' turns around the point
//! a positive number of times, so one turn means one cycle, one component,
//! and Euler(S') <= 1; cutting added as many vertices as it made copies, so
//! Euler(S') = 1 + copies forces no copy: S' = S is a disk.
//!
//! **Proximity.** A proximity query (gap `d` > 0, [`Shape::At`]) certifies
//! too, with two more conditions, so that a flat patch is not descended to
//! its leaves (normal cones alone do not bound distances). Let S pass the
//! certificate along axis v, its normals within angle `h` of v. Then S
//! projects along v one to one onto a disk D (the contour being its
//! boundary), and (a) every triangle's least altitude bound times `cos h`
//! and (b) the projected distance from each end of each contour edge to
//! every contour edge not ending there both exceed the clearance `c`
//! (the reach, `d` plus the element tests' slack, with a margin for the
//! projection's rounding). Claim: no vertex of S is within `c` of a
//! triangle T of S without it, and no two edges of S without a common
//! vertex are within `c` of each other; projection only shortens
//! distances, so it suffices to show this for the projections. A
//! projected triangle's altitudes are at least its own times `cos h` (its
//! area shrinks by the cosine of its normal's angle, no side grows).
//! Vertex p, triangle T: T lies in D outside the fan of p's triangles.
//! The segment from p to T's nearest point either starts into the fan,
//! and leaves it through a side opposite p (at least an altitude of (a)
//! away) or along a side from p (at least that side's length, longer than
//! its altitude); or starts outside D, and must enter D across a contour
//! edge not ending at p (a contour edge through p cannot be crossed from
//! p), at least (b) away. Two edges: their projections do not cross
//! (D is embedded and they share no point), so their distance is that of
//! an end of one to the other edge e, of a triangle T of S; if the end is
//! a corner of T, e is the side opposite it (an altitude), else the
//! vertex case applies. Hence every such pair is farther than `d` and
//! no element test reports it: the query's answer is unchanged. The
//! altitudes fail (refusing the certificate early) where a triangle is
//! thinner than about `d`; there, flat or not, a vertex and the triangle
//! across the opposite side are genuine contacts.

use super::chunks::Chunks;
use crate::bvh::patch::have_common;
use crate::bvh::traverse::LeafVisitor;
use crate::detect::narrow::Intersect;
use crate::geom::distance::{least_altitude, APART_SLACK};
use crate::geom::loop2d::{
    ends_clear_of_edges, simple_ccw_loop, star_about, swept_simple_ccw_loop, swept_star_about,
    LoopScratch, Plane, Seg,
};
use crate::geom::{Aabb, NormalCone};
use crate::mesh::{share_vertex, Adjacency, Mesh};
use crate::stats::Counters;
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};
use std::sync::OnceLock;

/// Nodes of at most this many triangles are tested pair by pair (at most
/// 64: [`Query::test_near`]'s masks; a swept query's leaves are smaller,
/// [`SWEPT_LEAF`]). With the leaf tests free of branches,
/// 32 beat 16 on every input but the folded grid (+2-3%; BENCHMARKS.md,
/// seventeenth landing); 48 cost the folded grid 5-8% more for no further
/// gain elsewhere.
const LEAF: usize = 32;
/// Nodes of fewer triangles split without trying their self-certificate in
/// a query at one position ([`Shape::At`]): below the leaves' parents it
/// saves only two leaf tests and a leaf pair, and costs a pass over the
/// node's contour where it is tried at all (on the garments the cone
/// refuses most small nodes, and layers hold several pieces). Against
/// trying every node (one-shot, best of 10, two runs each; BENCHMARKS.md,
/// twenty-third landing): body 7%, dress 3-6%, multilayer skirt 3-5%,
/// crumpled grid 1-4% faster, folded grid 1-2% slower, the rest level;
/// 96 was no better. A swept query tries every node: its boxes hold the
/// whole step, so a small node's certificate saves more (with this limit
/// the 20k folded grid's continuous one-shot was 15-22% slower).
const CERT_MIN: usize = 2 * LEAF;
/// A swept query's nodes (at thickness 0, where it certifies) of at most
/// this many triangles are tested pair by pair, after their certificate
/// (tried at every size). Where a sheet
/// folds sharply, a leaf holding the crease fails its certificate while
/// those beside it hold theirs, and each pair of triangles sharing a
/// vertex costs a [`fans_stay_apart`](crate::geom::ccd::fans_stay_apart)
/// test: on the folded 200k grid's continuous one-shot (BENCHMARKS.md,
/// thirty-fourth landing), leaves of [`LEAF`] that try no certificate
/// handed the visitor 975k triangle pairs; trying it cut them to 689k
/// and the query's instructions by 13%; leaves of 16 to 564k and 18%
/// (8: 538k and 18.7%, so no smaller).
const SWEPT_LEAF: usize = 16;
/// 0, 1, ..., 63: the places in a leaf.
const IDS: [u8; 64] = {
    let mut ids = [0u8; 64];
    let mut i = 0;
    while i < 64 {
        ids[i] = i as u8;
        i += 1;
    }
    ids
};
/// Nodes of at least this many triangles run their halves as parallel tasks.
const PAR_MIN: usize = 2048;
/// Triangles per parallel task of one node's certificate passes.
const CHUNK: usize = 8192;

/// The triangles a query sees: at one set of positions, or swept linearly
/// from the first to the second (each vertex moving on a line over the step).
#[derive(Clone, Copy)]
pub enum Shape<'a> {
    /// The triangles at these positions.
    At(&'a [DVec3]),
    /// The triangles over the linear motion from `x0` to `x1`.
    Swept(&'a [DVec3], &'a [DVec3]),
}

impl Shape<'_> {
    /// The positions at the start (the only ones of [`Shape::At`]).
    fn start(&self) -> &[DVec3] {
        match *self {
            Shape::At(x) | Shape::Swept(x, _) => x,
        }
    }

    /// Triangle `t`'s box (over the whole motion).
    #[inline]
    fn bbox(&self, mesh: &Mesh, t: usize) -> Aabb {
        match *self {
            Shape::At(x) => Aabb::from_points(&mesh.corners(x, t)),
            Shape::Swept(x0, x1) => mesh.swept_box(x0, x1, t),
        }
    }

    /// How many unit normals of each triangle the certificate reads: its
    /// normal, or the three directions that hold it over the motion
    /// ([`NormalCone::swept_unit_normals`]).
    fn normals_per_triangle(&self) -> usize {
        match self {
            Shape::At(_) => 1,
            Shape::Swept(..) => 3,
        }
    }

    /// Triangle `t`'s unit normals with bounds on their angles to the
    /// exact ones, into `out` ([`normals_per_triangle`](Self::normals_per_triangle)
    /// of them); zero vectors where they are not known.
    #[inline]
    fn unit_normals(&self, mesh: &Mesh, t: usize, out: &mut [(DVec3, f64)]) {
        let known = match *self {
            Shape::At(x) => {
                let c = mesh.corners(x, t);
                NormalCone::unit_normal(c[0], c[1], c[2]).map(|u| out[0] = u)
            }
            Shape::Swept(x0, x1) => {
                NormalCone::swept_unit_normals(mesh.corners(x0, t), mesh.corners(x1, t))
                    .map(|u| out.copy_from_slice(&u))
            }
        };
        if known.is_none() {
            out.fill((DVec3::ZERO, 0.0));
        }
    }
}

/// All intersecting pairs of non-adjacent triangles of `mesh` at `positions`
/// (`[i, j]`, i < j, sorted), with what the query did.
pub fn self_intersections(mesh: &Mesh, positions: &[DVec3]) -> (Vec<[u32; 2]>, Counters) {
    let visitor = Intersect { mesh, positions };
    let (mut pairs, counters) = query(mesh, Shape::At(positions), 0.0, &visitor);
    pairs.sort_unstable();
    (pairs, counters)
}

/// Some intersecting pair of non-adjacent triangles (`[i, j]`, i < j), or
/// None: the query of [`self_intersections`] stopping at its first pair.
/// Its tests run in one order, so the pair is the same on every run.
pub fn first_intersection(mesh: &Mesh, positions: &[DVec3]) -> Option<[u32; 2]> {
    let visitor = Intersect { mesh, positions };
    let found = run(mesh, Shape::At(positions), 0.0, &visitor, true);
    found.items.into_vec().first().copied()
}

/// What `visitor` reports on the triangle pairs of `shape` whose boxes are
/// within `gap` of each other (`[lo, hi]` order, lo < hi; pairs sharing a
/// vertex only where the visitor asks for them), in no set order, with what
/// the query did. At gap 0 a node, or the union of two, whose certificate
/// holds (over the whole motion for [`Shape::Swept`]) is not descended: no
/// two elements of it that share no vertex touch, so `visitor` must report
/// only such touching pairs there. Above 0 a [`Shape::At`] query certifies
/// with the proximity conditions (module doc): `visitor` must then report
/// only element pairs that share no vertex and are within the gap (plus
/// the element tests' slack). A swept query above 0 culls by boxes alone.
pub fn query<V: LeafVisitor>(
    mesh: &Mesh,
    shape: Shape,
    gap: f64,
    visitor: &V,
) -> (Vec<V::Item>, Counters) {
    let found = run(mesh, shape, gap, visitor, false);
    (found.items.into_vec(), found.counters)
}

/// [`query`]'s items as the tasks left them: lists in an order fixed by the
/// query (not by the threads), none much longer than 32,768 items, for a
/// caller that reads them once (a proximity query may find millions;
/// joining the lists would copy each item again).
pub fn query_parts<V: LeafVisitor>(
    mesh: &Mesh,
    shape: Shape,
    gap: f64,
    visitor: &V,
) -> (Vec<Vec<V::Item>>, Counters) {
    let found = run(mesh, shape, gap, visitor, false);
    (found.items.into_chunks(), found.counters)
}

/// The query from the root, all pairs or (`first`) until one is found.
fn run<V: LeafVisitor>(
    mesh: &Mesh,
    shape: Shape,
    gap: f64,
    visitor: &V,
    first: bool,
) -> Found<V::Item> {
    let n = mesh.n_triangles();
    if n < 2 {
        return Found::default();
    }
    let (q, fit) = Query::new(mesh, shape, gap, visitor, first);
    let mut root = Node::new(0..n as u32, fit);
    let mut found = Found::default();
    q.self_test(&mut root, &mut found);
    found
}

/// What a query shares between its tasks. `order` is the permutation whose
/// ranges are the nodes; a task writes only the entries of the nodes it
/// owns, so the relaxed atomics never race on a value.
struct Query<'a, V> {
    mesh: &'a Mesh,
    shape: Shape<'a>,
    /// Boxes within this gap are tested; certificates only at 0.
    gap: f64,
    visitor: &'a V,
    /// Stop at the first pair found, testing in one order (no parallel tasks).
    first: bool,
    /// Each triangle's box, fitted when the root is first split (a root
    /// that holds its certificate needs none), or with the root's fit where
    /// nothing is certified.
    boxes: OnceLock<Vec<Aabb>>,
    /// The unit normals of each triangle (`k` =
    /// [`Shape::normals_per_triangle`] of them, at `k t..k t + k`), each with
    /// a bound on its angle to the exact one; zero where none is known (the
    /// cone test then fails). Empty when nothing is certified.
    normals: Vec<(DVec3, f64)>,
    /// Where a triangle has several unit normals (a swept query), their sum
    /// and largest bound, or zero where one is not known: what a node's fit
    /// reads ([`Query::node`]; a third of the bytes). Empty otherwise.
    normal_sums: Vec<(DVec3, f64)>,
    /// A proximity query's lower bound on each triangle's least altitude
    /// ([`least_altitude`]), for the clearance of its certificates (module
    /// doc, "Proximity"). Empty at gap 0.
    altitudes: Vec<f64>,
    /// The triangle across each edge of each triangle, and their flags
    /// ([`Adjacency`]; kept by the mesh). Empty when nothing is certified.
    across: &'a [[u32; 3]],
    edge_flags: &'a [u8],
    order: Vec<AtomicU32>,
    /// `id << 32 | position` of each triangle of the nodes marked `id`
    /// ([`mark`](Query::mark)) for a membership test: written only for the
    /// nodes whose contour is computed, not at every split as an inverse
    /// permutation would be. Empty when nothing is certified.
    marks: Vec<AtomicU64>,
    /// The next mark's id (unique within the query, so a stale mark never
    /// names a node being tested).
    next_mark: AtomicU32,
}

/// A range of the permutation, its box, its children once split, and what
/// the union test needs of it once its own certificate held.
struct Node {
    range: Range<u32>,
    bbox: Aabb,
    /// Sum of the unit normals and their largest error bound (see [`Fit`]).
    normals: Option<(DVec3, f64)>,
    kids: Option<Box<[Node; 2]>>,
    cert: Option<Cert>,
    /// Below a node whose certificate held: never self-tested (only pair
    /// tests descend here, and a union certificate needs both nodes'
    /// own), so its fit sums no normals.
    below_cert: bool,
    /// A leaf's triangles as its pair tests read them, gathered once on first
    /// use ([`Query::leaf_tris`]; a leaf meets a dozen others, and each gather
    /// from the mesh's arrays is a cache miss per triangle). Empty until then.
    tris: Box<[LeafTri]>,
}

/// What a node's self-certificate test found.
enum SelfCert {
    Held,
    /// Refused, with several pieces (edge-connected components) in the node.
    Pieces,
    Refused,
}

/// A node whose self-certificate held: its cone and the sorted vertices of
/// its contour (the union test's adjacency check).
struct Cert {
    cone: NormalCone,
    boundary: Vec<u32>,
    /// The least altitude bound of its triangles (a proximity query's).
    altitude: f64,
}

impl Node {
    fn new(range: Range<u32>, fit: Fit) -> Node {
        Node {
            range,
            bbox: fit.bbox,
            normals: fit.normals,
            kids: None,
            cert: None,
            below_cert: false,
            tris: Box::default(),
        }
    }

    fn len(&self) -> usize {
        self.range.len()
    }
}

/// A box and the sum of unit normals with their largest error bound
/// (`None` once a triangle without a normal is in), fitted in one pass.
#[derive(Clone, Copy)]
struct Fit {
    bbox: Aabb,
    normals: Option<(DVec3, f64)>,
}

impl Fit {
    const EMPTY: Fit = Fit {
        bbox: Aabb::EMPTY,
        normals: Some((DVec3::ZERO, 0.0)),
    };

    /// Adds a triangle's box and its unit normals (none when nothing is
    /// certified: then the fit has no normals either).
    #[inline]
    fn add(self, bbox: &Aabb, normals: &[(DVec3, f64)]) -> Fit {
        let normals = match normals {
            [] => None,
            _ => self.normals.and_then(|start| {
                normals.iter().try_fold(start, |(sum, err), &(n, e)| {
                    (n != DVec3::ZERO).then(|| (sum + n, err.max(e)))
                })
            }),
        };
        Fit {
            bbox: self.bbox.union(bbox),
            normals,
        }
    }

    fn join(self, o: Fit) -> Fit {
        Fit {
            bbox: self.bbox.union(&o.bbox),
            normals: self
                .normals
                .zip(o.normals)
                .map(|((s, e), (t, f))| (s + t, e.max(f))),
        }
    }
}

/// A task's findings: its items (its own, then the joined tasks', as
/// chunks: no item is copied once per level of joins or per doubling of one
/// long list), counters and certificate buffers.
struct Found<T> {
    items: Chunks<T>,
    counters: Counters,
    scratch: Scratch,
}

impl<T> Default for Found<T> {
    fn default() -> Self {
        Found {
            items: Chunks::default(),
            counters: Counters::default(),
            scratch: Scratch::default(),
        }
    }
}

impl<T> Found<T> {
    /// Takes in a joined task's findings, after this task's.
    fn absorb(&mut self, o: Found<T>) {
        self.items.join(o.items);
        self.counters.add(&o.counters);
    }
}

/// Buffers of one task's certificates.
#[derive(Default)]
struct Scratch {
    contour: Vec<[u32; 2]>,
    segs: Vec<Seg>,
    /// The contour at the end of a motion.
    segs_end: Vec<Seg>,
    loops: LoopScratch,
    /// A partition's output, grown as needed and never cleared (every entry
    /// used is written first).
    split: Vec<u32>,
}

impl<'a, V: LeafVisitor> Query<'a, V> {
    /// The query's shared state, and the fit of every triangle (summed in
    /// order, so it does not depend on the thread count). What only the
    /// certificates read is computed only at gap 0.
    fn new(
        mesh: &'a Mesh,
        shape: Shape<'a>,
        gap: f64,
        visitor: &'a V,
        first: bool,
    ) -> (Query<'a, V>, Fit) {
        let n = mesh.n_triangles();
        let k = normals_read(shape, gap);
        // What the certificates read (nothing when none is tried).
        let m = if k > 0 { n } else { 0 };
        let mut normals = vec![(DVec3::ZERO, 0.0); k * m];
        let (across, edge_flags): (&[[u32; 3]], &[u8]) = match k {
            0 => (&[], &[]),
            _ => {
                let adjacency = mesh.adjacency();
                (&adjacency.across, &adjacency.flags)
            }
        };
        let boxes = OnceLock::new();
        let fits: Vec<Fit> = if k > 0 {
            normals
                .par_chunks_mut(k * CHUNK)
                .enumerate()
                .map(|(c, normals)| {
                    let mut fit = Fit::EMPTY;
                    for (units, t) in normals.chunks_mut(k).zip(c * CHUNK..) {
                        shape.unit_normals(mesh, t, units);
                        fit = fit.add(&shape.bbox(mesh, t), &[summed(units)]);
                    }
                    fit
                })
                .collect()
        } else {
            // Nothing is certified, so the root splits: its triangles' boxes
            // are kept from this pass instead of fitted again.
            let mut all = vec![Aabb::EMPTY; n];
            let fits = all
                .par_chunks_mut(CHUNK)
                .enumerate()
                .map(|(c, chunk)| {
                    let mut fit = Fit::EMPTY;
                    for (b, t) in chunk.iter_mut().zip(c * CHUNK..) {
                        *b = shape.bbox(mesh, t);
                        fit = fit.add(b, &[]);
                    }
                    fit
                })
                .collect();
            let _ = boxes.set(all);
            fits
        };
        let normal_sums = match k {
            0 | 1 => Vec::new(),
            _ => normals.par_chunks(k).map(summed).collect(),
        };
        let altitudes = match shape {
            Shape::At(x) if k > 0 && gap > 0.0 => (0..m)
                .into_par_iter()
                .map(|t| least_altitude(&mesh.corners(x, t)))
                .collect(),
            _ => Vec::new(),
        };
        let q = Query {
            mesh,
            shape,
            gap,
            visitor,
            first,
            boxes,
            normals,
            normal_sums,
            altitudes,
            across,
            edge_flags,
            order: (0..n as u32).map(AtomicU32::new).collect(),
            marks: (0..m).map(|_| AtomicU64::new(u64::MAX)).collect(),
            next_mark: AtomicU32::new(0),
        };
        (q, fits.into_iter().fold(Fit::EMPTY, Fit::join))
    }

    /// Each triangle's box.
    #[inline]
    fn boxes(&self) -> &[Aabb] {
        self.boxes.get_or_init(|| {
            (0..self.mesh.n_triangles())
                .into_par_iter()
                .map(|t| self.shape.bbox(self.mesh, t))
                .collect()
        })
    }

    /// `op` on every piece of at most [`CHUNK`] positions of `ranges`, in
    /// order; in parallel when there are several.
    fn pieces<T: Send>(
        &self,
        ranges: &[Range<u32>],
        op: impl Fn(Range<u32>) -> T + Sync,
    ) -> Vec<T> {
        let len: usize = ranges.iter().map(|r| r.len()).sum();
        if len <= 2 * CHUNK {
            return ranges.iter().map(|r| op(r.clone())).collect();
        }
        let pieces: Vec<Range<u32>> = ranges
            .iter()
            .flat_map(|r| {
                r.clone()
                    .step_by(CHUNK)
                    .map(move |i| i..(i + CHUNK as u32).min(r.end))
            })
            .collect();
        pieces.into_par_iter().map(&op).collect()
    }

    /// The triangle at position `i` of the permutation.
    #[inline]
    fn tri(&self, i: u32) -> u32 {
        self.order[i as usize].load(Relaxed)
    }

    /// `node`'s two children, split at position `mid` and fitted; below a
    /// node whose certificate held, [`below_cert`](Node::below_cert).
    fn split_at(&self, node: &Node, mid: u32) -> Box<[Node; 2]> {
        let below = node.cert.is_some() || node.below_cert;
        Box::new([
            self.node_fit(node.range.start..mid, below),
            self.node_fit(mid..node.range.end, below),
        ])
    }

    /// The node of the triangles at positions `range`, fitted;
    /// [`below_cert`](Node::below_cert) when `below_cert`, and then its fit
    /// sums no normals (its certificate would be refused, and none is tried).
    fn node_fit(&self, range: Range<u32>, below_cert: bool) -> Node {
        let boxes = self.boxes();
        // Each triangle's normals as one: the sum of its own, or itself.
        let sums = match self.normals_per_triangle() {
            _ if below_cert => &[][..],
            0 => &[][..],
            1 => &self.normals[..],
            _ => &self.normal_sums[..],
        };
        let fit = range.clone().fold(Fit::EMPTY, |fit, i| {
            let t = self.tri(i) as usize;
            // (No normals where nothing is certified.)
            fit.add(&boxes[t], sums.get(t..t + 1).unwrap_or_default())
        });
        Node {
            below_cert,
            ..Node::new(range, fit)
        }
    }

    /// Leaf `node`'s triangles, gathered on first use.
    fn leaf_tris<'n>(&self, node: &'n mut Node) -> &'n [LeafTri] {
        if node.tris.is_empty() {
            let (boxes, tris) = (self.boxes(), self.mesh.triangles());
            node.tris = node
                .range
                .clone()
                .map(|i| {
                    let t = self.tri(i);
                    LeafTri {
                        t,
                        bbox: boxes[t as usize],
                        v: tris[t as usize],
                    }
                })
                .collect();
        }
        &node.tris
    }

    /// Every intersecting pair within `node`, into `f`.
    fn self_test(&self, node: &mut Node, f: &mut Found<V::Item>) {
        let swept = matches!(self.shape, Shape::Swept(..));
        // (A static leaf's certificate would save too little; a swept
        // query above thickness 0 reads no normals: it certifies nothing.)
        let certified_leaves = swept && self.normals_per_triangle() > 0;
        if node.len() <= if certified_leaves { SWEPT_LEAF } else { LEAF } {
            if certified_leaves && matches!(self.self_certified(node, f), SelfCert::Held) {
                f.counters.self_culls += 1;
                return;
            }
            return self.leaf_self(node, f);
        }
        let tried = swept || node.len() >= CERT_MIN;
        let cert = if tried {
            self.self_certified(node, f)
        } else {
            SelfCert::Refused
        };
        match cert {
            SelfCert::Held => {
                f.counters.self_culls += 1;
                return;
            }
            SelfCert::Pieces => {
                if let Some(mid) = self.split_off_piece(node) {
                    node.kids = Some(self.split_at(node, mid));
                }
            }
            SelfCert::Refused => {}
        }
        let parallel = !self.first && node.len() >= PAR_MIN;
        let [a, b] = self.kids(node, &mut f.scratch.split);
        if parallel {
            let ((), other) = rayon::join(
                || self.self_test(a, f),
                || {
                    let mut other = Found::default();
                    self.self_test(b, &mut other);
                    other
                },
            );
            f.absorb(other);
        } else {
            self.self_test(a, f);
            if !self.done(f) {
                self.self_test(b, f);
            }
        }
        self.pair_test(a, b, f);
    }

    /// Has a first-pair query found its pair?
    #[inline]
    fn done(&self, f: &Found<V::Item>) -> bool {
        self.first && !f.items.is_empty()
    }

    /// [`normals_read`] of this query.
    #[inline]
    fn normals_per_triangle(&self) -> usize {
        normals_read(self.shape, self.gap)
    }

    /// Every intersecting pair with one triangle in `a`, one in `b`.
    fn pair_test(&self, a: &mut Node, b: &mut Node, f: &mut Found<V::Item>) {
        if self.done(f) || !a.bbox.within(&b.bbox, self.gap) {
            return;
        }
        f.counters.node_pairs += 1;
        if a.len() <= LEAF && b.len() <= LEAF {
            self.leaf_pair(a, b, f);
            return;
        }
        if self.union_certified(a, b, f) {
            f.counters.pair_culls += 1;
            return;
        }
        if !self.first && a.len().min(b.len()) >= PAR_MIN {
            return self.pair_test_parallel(a, b, f);
        }
        let (big, small) = if a.len() >= b.len() { (a, b) } else { (b, a) };
        let [p, q] = self.kids(big, &mut f.scratch.split);
        self.pair_test(p, small, f);
        self.pair_test(q, small, f);
    }

    /// [`pair_test`](Self::pair_test) of two large nodes by their four
    /// child pairs, two disjoint ones at a time in parallel tasks.
    fn pair_test_parallel(&self, a: &mut Node, b: &mut Node, f: &mut Found<V::Item>) {
        let [a0, a1] = self.kids(a, &mut f.scratch.split);
        let [b0, b1] = self.kids(b, &mut f.scratch.split);
        self.pair_tests_apart(a0, b0, a1, b1, f);
        self.pair_tests_apart(a0, b1, a1, b0, f);
    }

    /// The pair tests of `p` with `q` and of `r` with `s` (four distinct
    /// nodes) as two parallel tasks.
    fn pair_tests_apart(
        &self,
        p: &mut Node,
        q: &mut Node,
        r: &mut Node,
        s: &mut Node,
        f: &mut Found<V::Item>,
    ) {
        let ((), other) = rayon::join(
            || self.pair_test(p, q, f),
            || {
                let mut other = Found::default();
                self.pair_test(r, s, &mut other);
                other
            },
        );
        f.absorb(other);
    }

    /// The children of `node`, split now if they are not yet.
    fn kids<'n>(&self, node: &'n mut Node, buf: &mut Vec<u32>) -> &'n mut [Node; 2] {
        if node.kids.is_none() {
            let mid = self.partition(node, buf);
            node.kids = Some(self.split_at(node, mid));
        }
        node.kids.as_mut().unwrap()
    }

    /// Partitions `node`'s range at the midpoint of its box along the axis
    /// whose plane there cuts the fewest triangle boxes (ties to the longest
    /// side): stacked layers are split apart rather than cut across, which
    /// would leave every part with all the layers (and the pair of parts
    /// with a seam through every layer). The middle of the range is taken
    /// instead when the midpoint leaves a side with under 1/16 of it, so the
    /// depth stays logarithmic. Returns where the second part starts.
    fn partition(&self, node: &Node, buf: &mut Vec<u32>) -> u32 {
        let Range { start, end } = node.range.clone();
        let boxes = self.boxes();
        let twice_mid = node.bbox.min + node.bbox.max;
        let mut cut = [0u32; 3];
        for i in start..end {
            let b = &boxes[self.tri(i) as usize];
            let straddles = (2.0 * b.min).cmplt(twice_mid) & twice_mid.cmplt(2.0 * b.max);
            for (axis, c) in cut.iter_mut().enumerate() {
                *c += straddles.test(axis) as u32;
            }
        }
        let ext = node.bbox.max - node.bbox.min;
        let cost = |axis: usize| (cut[axis], -ext[axis]);
        let axis = (0..3)
            .min_by(|&a, &b| {
                cost(a)
                    .partial_cmp(&cost(b))
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
            .unwrap_or(0);
        let below = |t: u32| {
            let b = &boxes[t as usize];
            b.min[axis] + b.max[axis] < twice_mid[axis]
        };
        // Branchless: each triangle is written at both free ends of `buf`,
        // and the end it belongs to advances (the side is a coin flip for
        // the branch predictor).
        let n = (end - start) as usize;
        if buf.len() < n {
            buf.resize(n, 0);
        }
        let buf = &mut buf[..n];
        let (mut a, mut b) = (0usize, n);
        for k in start..end {
            let t = self.tri(k);
            let low = below(t);
            buf[a] = t;
            buf[b - 1] = t;
            a += low as usize;
            b -= !low as usize;
        }
        for (k, &t) in (start..end).zip(buf.iter()) {
            self.place(k, t);
        }
        let i = start + a as u32;
        let len = end - start;
        if (i - start).min(end - i) >= (len / 16).max(1) {
            return i;
        }
        self.split_at_median(start..end, axis)
    }

    /// Orders `range` so its first half holds the triangles whose box
    /// centres are lowest along `axis` (ties by id); returns the middle.
    fn split_at_median(&self, range: Range<u32>, axis: usize) -> u32 {
        let boxes = self.boxes();
        // The keys read once each (the selection compares each element a
        // few times, and each read of a box through the permutation misses).
        let mut keyed: Vec<(f64, u32)> = range
            .clone()
            .map(|i| {
                let t = self.tri(i);
                let b = &boxes[t as usize];
                (b.min[axis] + b.max[axis], t)
            })
            .collect();
        let half = keyed.len() / 2;
        keyed.select_nth_unstable_by(half, |p, q| p.partial_cmp(q).unwrap());
        for (i, (_, t)) in range.clone().zip(keyed) {
            self.place(i, t);
        }
        range.start + half as u32
    }

    /// Puts triangle `t` at position `i`.
    #[inline]
    fn place(&self, i: u32, t: u32) {
        self.order[i as usize].store(t, Relaxed);
    }

    /// The self-certificate of `node` (module doc), kept in the node when
    /// it holds; counted in `f`.
    fn self_certified(&self, node: &mut Node, f: &mut Found<V::Item>) -> SelfCert {
        let Some((cone, altitude)) = node.normals.and_then(|n| self.cone(node, n)) else {
            return SelfCert::Refused;
        };
        if !self.spaced(altitude, &cone, &node.bbox) {
            return SelfCert::Refused;
        }
        f.counters.contour_tests += 1;
        let mut contour = std::mem::take(&mut f.scratch.contour);
        let range = std::slice::from_ref(&node.range);
        let euler = self.contour_euler(range, &mut contour);
        let ok = euler == Some(1) && self.height_field(cone.axis, &node.bbox, &contour, f);
        if ok {
            let boundary = starts(&contour);
            node.cert = Some(Cert {
                cone,
                boundary,
                altitude,
            });
        }
        f.scratch.contour = contour;
        f.counters.contour_fails += !ok as u64;
        match euler {
            _ if ok => SelfCert::Held,
            Some(e) if e >= 2 => SelfCert::Pieces,
            _ => SelfCert::Refused,
        }
    }

    /// Splits `node` into its largest edge-connected piece and the rest
    /// (reordering its range: the piece first) when each side holds at
    /// least 1/16 of it, so the depth stays logarithmic. Returns where the
    /// rest starts, or `None` (range untouched).
    ///
    /// Why: a node whose cone is under 90 degrees but which holds several
    /// pieces (layers of cloth lying on each other, a garment on a body)
    /// fails the disk test, and so do its spatial halves, which hold the
    /// same layers, down to the leaves. Split by pieces, each layer can
    /// certify on its own, and only the pair of layers is descended.
    fn split_off_piece(&self, node: &Node) -> Option<u32> {
        let Range { start, end } = node.range.clone();
        let len = (end - start) as usize;
        const NONE: u32 = u32::MAX;
        let mut label = vec![NONE; len];
        let id = self.mark(std::slice::from_ref(&node.range));
        let (mut stack, mut largest, mut pieces) = (Vec::new(), (0usize, 0u32), 0u32);
        for first in 0..len {
            if label[first] != NONE {
                continue;
            }
            label[first] = pieces;
            stack.push(first);
            let mut size = 0;
            while let Some(k) = stack.pop() {
                size += 1;
                let t = self.tri(start + k as u32);
                for o in self.across[t as usize] {
                    let Some(p) = self.marked(id, o).filter(|_| o != t) else {
                        continue;
                    };
                    let p = (p - start) as usize;
                    if label[p] == NONE {
                        label[p] = pieces;
                        stack.push(p);
                    }
                }
            }
            if size > largest.0 {
                largest = (size, pieces);
            }
            pieces += 1;
        }
        let min = (len / 16).max(1);
        if pieces < 2 || largest.0 < min || len - largest.0 < min {
            return None;
        }
        let tris: Vec<u32> = (start..end).map(|i| self.tri(i)).collect();
        let (piece, rest): (Vec<_>, Vec<_>) =
            tris.iter().zip(&label).partition(|(_, &l)| l == largest.1);
        for (i, (&t, _)) in (start..).zip(piece.into_iter().chain(rest)) {
            self.place(i, t);
        }
        Some(start + largest.0 as u32)
    }

    /// The certificate of the union of `a` and `b`, tried only when their
    /// merged cone is under 90 degrees and their contours share a vertex
    /// (patches apart have two loops, which the test refuses).
    fn union_certified(&self, a: &Node, b: &Node, f: &mut Found<V::Item>) -> bool {
        let (Some(pa), Some(pb)) = (&a.cert, &b.cert) else {
            return false;
        };
        let (ca, cb) = (pa.cone, pb.cone);
        let both = a.bbox.union(&b.bbox);
        if !ca.merge_is_positive(&cb) || !have_common(&pa.boundary, &pb.boundary) {
            return false;
        }
        let cone = ca.merge(&cb);
        if !self.spaced(pa.altitude.min(pb.altitude), &cone, &both) {
            return false;
        }
        f.counters.contour_tests += 1;
        let ranges = [a.range.clone(), b.range.clone()];
        let mut contour = std::mem::take(&mut f.scratch.contour);
        let ok = self.disk_contour(&ranges, &mut contour)
            && self.height_field(cone.axis, &both, &contour, f);
        f.scratch.contour = contour;
        f.counters.contour_fails += !ok as u64;
        ok
    }

    /// Is `contour` projected along unit `axis` one loop around the
    /// centre of `bbox` (star test) or one simple counter-clockwise loop,
    /// for the whole motion of a [`Shape::Swept`] (the swept tests of
    /// [`crate::geom::loop2d`] on its projections at both ends)?
    fn height_field(
        &self,
        axis: DVec3,
        bbox: &Aabb,
        contour: &[[u32; 2]],
        f: &mut Found<V::Item>,
    ) -> bool {
        let s = &mut f.scratch;
        let plane = Plane::new(axis, bbox.center());
        let project = |x: &[DVec3], segs: &mut Vec<Seg>| {
            segs.clear();
            segs.extend(contour.iter().map(|&v| Seg {
                p: v.map(|v| plane.project(x[v as usize])),
                v,
            }));
        };
        project(self.shape.start(), &mut s.segs);
        match self.shape {
            Shape::At(_) if self.gap > 0.0 => {
                (star_about(&s.segs, [0.0; 2]) || simple_ccw_loop(&s.segs, &mut s.loops))
                    && ends_clear_of_edges(&s.segs, self.clearance(bbox), &mut s.loops)
            }
            Shape::At(_) => star_about(&s.segs, [0.0; 2]) || simple_ccw_loop(&s.segs, &mut s.loops),
            Shape::Swept(_, x1) => {
                project(x1, &mut s.segs_end);
                swept_star_about(&s.segs, &s.segs_end, [0.0; 2])
                    || swept_simple_ccw_loop(&s.segs, &s.segs_end, &mut s.loops)
            }
        }
    }

    /// The normal cone of `node`'s triangles (unit normals summing to `sum`,
    /// erring by at most `err`) about their mean normal, when it is under 90
    /// degrees: the normal farthest from the axis, the scan stopping at one
    /// past 90 degrees.
    ///
    /// With the cone, the least of the triangles' altitude bounds (a
    /// proximity query's; infinite otherwise).
    fn cone(&self, node: &Node, (sum, err): (DVec3, f64)) -> Option<(NormalCone, f64)> {
        let axis = sum.normalize_or_zero();
        let k = self.normals_per_triangle();
        let none = (f64::INFINITY, DVec3::ZERO, f64::INFINITY);
        // No altitude at or below the clearance passes `spaced`.
        let floor = self.clearance(&node.bbox);
        let least = self.pieces(std::slice::from_ref(&node.range), |r| {
            let mut least = none;
            for i in r {
                let t = self.tri(i) as usize;
                for &(n, _) in &self.normals[k * t..k * t + k] {
                    let dot = axis.dot(n);
                    if dot < 0.0 {
                        return None;
                    }
                    if dot < least.0 {
                        least = (dot, n, least.2);
                    }
                }
                if let Some(&h) = self.altitudes.get(t) {
                    if !(h > floor) {
                        return None; // too low for any cone: refused early
                    }
                    least.2 = least.2.min(h);
                }
            }
            Some(least)
        });
        let (_, least, altitude) = least.into_iter().try_fold(none, |a, b| {
            b.map(|b| {
                let h = a.2.min(b.2);
                if b.0 < a.0 {
                    (b.0, b.1, h)
                } else {
                    (a.0, a.1, h)
                }
            })
        })?;
        let cone =
            NormalCone::within_90_around(axis, least, err).filter(NormalCone::is_positive)?;
        Some((cone, altitude))
    }

    /// The clearance a proximity certificate of triangles within `bbox`
    /// asks of its projected contour and altitudes: the gap plus the slack
    /// the element culls keep above the distance functions' rounding, at
    /// the box's coordinate magnitude (as
    /// [`crate::geom::distance::hulls_apart`] takes it for a pair inside
    /// the box), with margins far above the rounding of the projection and
    /// of the contour's distances (a few ulps of the box's extent).
    fn clearance(&self, bbox: &Aabb) -> f64 {
        let reach = self.gap + APART_SLACK * bbox.magnitude();
        reach * (1.0 + 1e-9) + 1e-9 * (bbox.max - bbox.min).element_sum()
    }

    /// True at gap 0; for a proximity query, when triangles whose least
    /// altitude bound is `altitude` and whose normals lie in `cone` have
    /// projected altitudes above the clearance (module doc, "Proximity").
    fn spaced(&self, altitude: f64, cone: &NormalCone, bbox: &Aabb) -> bool {
        self.gap == 0.0 || altitude * cone.cos_half() * (1.0 - 1e-9) > self.clearance(bbox)
    }

    /// Writes the contour of the union of `ranges` into `contour`; true
    /// when every edge of the union is in at most two of its triangles, with
    /// opposite directions, and its Euler characteristic is 1.
    ///
    /// Vertices are counted by their owners ([`crate::mesh::Topology::owned`])
    /// in the union, plus the contour's vertices whose owner is outside it.
    /// That is every vertex once where the mesh is manifold, and never more
    /// than every vertex: the count is low only at a vertex with several
    /// fans, and a low count can only refuse a certificate (the module
    /// doc's S' has Euler characteristic at most 1, so S has at most 1, and a
    /// lower count than S's is then below 1).
    fn disk_contour(&self, ranges: &[Range<u32>], contour: &mut Vec<[u32; 2]>) -> bool {
        self.contour_euler(ranges, contour) == Some(1)
    }

    /// The contour of the union of `ranges` and its Euler characteristic as
    /// [`disk_contour`](Self::disk_contour) counts it (never above the
    /// union's own, so 2 or more means several components), or `None` at an
    /// edge that refuses the union (in more than two triangles of the mesh,
    /// or in two of the union with the same direction).
    fn contour_euler(&self, ranges: &[Range<u32>], contour: &mut Vec<[u32; 2]>) -> Option<i64> {
        contour.clear();
        let (mut owned, mut f) = (0i64, 0i64);
        let id = self.mark(ranges);
        for piece in self.pieces(ranges, |r| self.contour_piece(id, r)) {
            let (o, n, edges) = piece?;
            (owned, f) = (owned + o, f + n);
            contour.extend(edges);
        }
        let member = |t: u32| self.marked(id, t).is_some();
        let vertex_tris = &self.mesh.topology().vertex_tris;
        let outside_owned = starts(contour)
            .into_iter()
            .filter(|&v| !member(vertex_tris.row(v as usize)[0]))
            .count() as i64;
        let e = (3 * f + contour.len() as i64) / 2;
        Some(owned + outside_owned - e + f)
    }

    /// Marks the triangles at positions `ranges` with a new id (in
    /// parallel pieces for a large union) and returns it.
    fn mark(&self, ranges: &[Range<u32>]) -> u32 {
        let id = self.next_mark.fetch_add(1, Relaxed);
        self.pieces(ranges, |r| {
            for i in r {
                let t = self.tri(i) as usize;
                self.marks[t].store(u64::from(id) << 32 | u64::from(i), Relaxed);
            }
        });
        id
    }

    /// The position of triangle `t` when it is in the nodes marked `id`.
    #[inline]
    fn marked(&self, id: u32, t: u32) -> Option<u32> {
        let m = self.marks[t as usize].load(Relaxed);
        (m >> 32 == u64::from(id)).then_some(m as u32)
    }

    /// The contour edges of the triangles at positions `r` of the nodes
    /// marked `id`, with how many triangles and owned vertices they hold;
    /// `None` at an edge in more than two triangles of the mesh or in two of
    /// the union with the same direction.
    fn contour_piece(&self, id: u32, r: Range<u32>) -> Option<(i64, i64, Vec<[u32; 2]>)> {
        let (tris, owned) = (self.mesh.triangles(), &self.mesh.topology().owned);
        let (mut v, mut contour) = (0i64, Vec::new());
        let f = r.len() as i64;
        for i in r {
            let t = self.tri(i);
            let (tri, across, flags) = (
                tris[t as usize],
                self.across[t as usize],
                self.edge_flags[t as usize],
            );
            if flags & Adjacency::TANGLED != 0 {
                return None;
            }
            v += (owned[t as usize] & 7).count_ones() as i64;
            for k in 0..3 {
                let o = across[k];
                if o == t || self.marked(id, o).is_none() {
                    contour.push([tri[k], tri[(k + 1) % 3]]);
                } else if flags & (Adjacency::FLIPPED << k) != 0 {
                    return None;
                }
            }
        }
        Some((v, f, contour))
    }

    /// Every intersecting pair within leaf `node`.
    fn leaf_self(&self, node: &mut Node, f: &mut Found<V::Item>) {
        let leaf = self.leaf_tris(node);
        for (i, p) in leaf.iter().enumerate() {
            self.test_near(p, leaf, &IDS[i + 1..leaf.len()], f);
        }
    }

    /// Every intersecting pair of a triangle of leaf `a` and one of leaf `b`.
    fn leaf_pair(&self, a: &mut Node, b: &mut Node, f: &mut Found<V::Item>) {
        let (box_a, box_b) = (a.bbox, b.bbox);
        let mut near_b = [0u8; LEAF];
        let tb = self.leaf_tris(b);
        let lb = self.near(tb, &box_a, &mut near_b);
        if lb.is_empty() {
            return;
        }
        let mut near_a = [0u8; LEAF];
        let ta = self.leaf_tris(a);
        for &i in self.near(ta, &box_b, &mut near_a) {
            self.test_near(&ta[i as usize], tb, lb, f);
        }
    }

    /// [`test`](Self::test) of `p` with each of `qs[k]`, k in `ids` (at most
    /// 64), whose box is within the gap of `p`'s: the boxes are compared
    /// first, all of them without a branch (a box test is a coin flip for
    /// the branch predictor), and only the pairs they keep are tested.
    #[inline]
    fn test_near(&self, p: &LeafTri, qs: &[LeafTri], ids: &[u8], f: &mut Found<V::Item>) {
        debug_assert!(ids.len() <= 64);
        // Bit k: q_ids[k]'s box is within the gap; of those, sharing a vertex.
        let (mut near, mut adjacent) = (0u64, 0u64);
        for (k, &i) in ids.iter().enumerate() {
            let q = &qs[i as usize];
            let within = p.bbox.within(&q.bbox, self.gap);
            near |= (within as u64) << k;
            adjacent |= ((within & share_vertex(&p.v, &q.v)) as u64) << k;
        }
        if V::SKIP_ADJACENT {
            f.counters.adjacent_skips += adjacent.count_ones() as u64;
            near &= !adjacent;
        }
        for k in crate::bits::set_bits(near) {
            let q = &qs[ids[k] as usize];
            self.test(p, q, adjacent >> k & 1 != 0, f);
        }
    }

    /// The places in a leaf of its triangles whose boxes are within the gap
    /// of `other` (the other leaf's box): only they can meet one of its
    /// triangles.
    fn near<'b>(&self, tris: &[LeafTri], other: &Aabb, buf: &'b mut [u8; LEAF]) -> &'b [u8] {
        // Written always, kept when near: no branch on the box test.
        let mut n = 0;
        for (i, p) in tris.iter().enumerate() {
            buf[n] = i as u8;
            n += p.bbox.within(other, self.gap) as usize;
        }
        &buf[..n]
    }

    /// The visitor's test of two leaf triangles whose boxes are within the
    /// gap (`adjacent`: they share a vertex; never for a visitor that skips
    /// those).
    #[inline]
    fn test(&self, p: &LeafTri, q: &LeafTri, adjacent: bool, f: &mut Found<V::Item>) {
        f.counters.primitive_tests += 1;
        let (lo, hi) = (p.t.min(q.t), p.t.max(q.t));
        self.visitor
            .visit_counted(lo, hi, adjacent, &mut f.items.last, &mut f.counters);
        f.items.set_aside_when_full();
    }
}

/// The sum of a triangle's unit normals and their largest bound, or zero
/// when one of them is not known (zero) or they cancel exactly: what
/// [`Fit::add`] would sum one by one (its zero refuses the cone either
/// way), in one read for a node's fit.
fn summed(units: &[(DVec3, f64)]) -> (DVec3, f64) {
    let known = units.iter().all(|&(n, _)| n != DVec3::ZERO);
    let sum = units
        .iter()
        .fold((DVec3::ZERO, 0.0f64), |(s, e), &(n, f)| (s + n, e.max(f)));
    if known {
        sum
    } else {
        (DVec3::ZERO, 0.0)
    }
}

/// How many unit normals of each triangle a query of `shape` within `gap`
/// reads: none unless it certifies (gap 0, or a proximity query at one
/// position).
fn normals_read(shape: Shape, gap: f64) -> usize {
    match shape {
        _ if gap == 0.0 => shape.normals_per_triangle(),
        Shape::At(_) => 1,
        Shape::Swept(..) => 0,
    }
}

/// A leaf's triangle as its pair tests read it.
#[derive(Clone, Copy)]
struct LeafTri {
    t: u32,
    bbox: Aabb,
    v: [u32; 3],
}

/// The sorted distinct start vertices of `contour` (every vertex of a
/// contour of consistently wound triangles starts one of its edges).
fn starts(contour: &[[u32; 2]]) -> Vec<u32> {
    let mut v: Vec<u32> = contour.iter().map(|e| e[0]).collect();
    v.sort_unstable();
    v.dedup();
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{grid, Deformation};

    /// `disk_contour` of all the triangles of a mesh.
    fn whole_is_disk(v: &[[f64; 3]], f: &[[u32; 3]]) -> bool {
        let mesh = Mesh::new(v.to_vec(), f.to_vec()).unwrap();
        let visitor = Intersect {
            mesh: &mesh,
            positions: mesh.rest(),
        };
        let (q, _) = Query::new(&mesh, Shape::At(mesh.rest()), 0.0, &visitor, false);
        let all = 0..f.len() as u32;
        q.disk_contour(std::slice::from_ref(&all), &mut Vec::new())
    }

    #[test]
    fn only_consistently_wound_disks_pass_the_topology_test() {
        let square = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        assert!(whole_is_disk(&square, &[[0, 1, 2], [0, 2, 3]]));
        // The shared edge 0-2 in the same direction in both: inconsistent winding.
        assert!(!whole_is_disk(&square, &[[0, 1, 2], [0, 3, 2]]));
        // Two triangles apart: Euler characteristic 2.
        let mut apart = square.to_vec();
        apart.extend([[5.0, 0.0, 0.0], [6.0, 0.0, 0.0], [5.0, 1.0, 0.0]]);
        assert!(!whole_is_disk(&apart, &[[0, 1, 2], [4, 5, 6]]));
        // A ring of quads around a hole: Euler characteristic 0.
        let ring: Vec<[f64; 3]> = (0..8)
            .map(|k| {
                let a = std::f64::consts::FRAC_PI_2 * (k % 4) as f64;
                let r = if k < 4 { 1.0 } else { 2.0 };
                [r * a.cos(), r * a.sin(), 0.0]
            })
            .collect();
        let quads: Vec<[u32; 3]> = (0..4u32)
            .flat_map(|k| {
                let (i0, i1, o0, o1) = (k, (k + 1) % 4, k + 4, (k + 1) % 4 + 4);
                [[i0, o0, o1], [i0, o1, i1]]
            })
            .collect();
        assert!(!whole_is_disk(&ring, &quads));
        // Filling the hole makes it a disk.
        let mut filled = quads.clone();
        filled.extend([[0, 1, 2], [0, 2, 3]]);
        assert!(whole_is_disk(&ring, &filled));
    }

    #[test]
    fn a_flat_sheet_costs_one_certificate() {
        let (v, f) = grid(40, 1.0);
        let mesh = Mesh::new(v, f).unwrap();
        let (pairs, c) = self_intersections(&mesh, mesh.rest());
        assert!(pairs.is_empty());
        assert_eq!((c.self_culls, c.contour_tests, c.node_pairs), (1, 1, 0));
    }

    #[test]
    fn the_same_work_and_answers_for_any_thread_count() {
        // Big enough for parallel halves, pair tests and certificate pieces.
        let (v, f) = grid(121, 1.0);
        let mesh = Mesh::new(v, f).unwrap();
        let p = Deformation::Crumple {
            amplitude: 0.3,
            wavelength: 0.4,
            seed: 4,
        }
        .apply(mesh.rest());
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| self_intersections(&mesh, &p))
        };
        let (pairs, counters) = run(1);
        assert!(pairs.len() > 100, "{}", pairs.len());
        assert!(
            counters.pair_culls > 0 && counters.self_culls > 0,
            "{counters:?}"
        );
        let (pairs3, counters3) = run(3);
        assert_eq!(pairs, pairs3);
        assert_eq!(counters, counters3);
    }

    /// Every deformation of `v, f` against brute force (all pairs tested).
    fn check_against_brute(v: &[[f64; 3]], f: &[[u32; 3]]) -> usize {
        use crate::detect::brute::BruteDetector;
        use crate::detect::Detector;
        let mesh = std::sync::Arc::new(Mesh::new(v.to_vec(), f.to_vec()).unwrap());
        let shapes = [
            Deformation::Flat,
            Deformation::Fold {
                angle: 1.1 * std::f64::consts::PI,
                radius: 0.02,
            },
            Deformation::Crumple {
                amplitude: 0.3,
                wavelength: 0.35,
                seed: 3,
            },
            Deformation::Twist { turns: 1.2 },
            Deformation::ZFold {
                layers: 3,
                gap: 0.0,
            },
        ];
        let mut found = 0;
        for d in shapes {
            let p = d.apply(mesh.rest());
            let want = BruteDetector::new(mesh.clone(), 0.0)
                .detect(&p)
                .unwrap()
                .pairs;
            assert_eq!(self_intersections(&mesh, &p).0, want, "{d:?}");
            assert_eq!(
                first_intersection(&mesh, &p).is_some(),
                !want.is_empty(),
                "{d:?}"
            );
            found += want.len();
        }
        found
    }

    /// Two wavy sheets lying on each other, `gap` apart (one mesh, two
    /// components); the upper one's vertex `lift` (if any) shifted by `dz`,
    /// so that it may pierce the lower one.
    fn layered_sheets(gap: f64, lift: Option<usize>, dz: f64) -> (Mesh, Vec<DVec3>) {
        let (v, f) = grid(40, 1.0);
        let n = v.len() as u32;
        let wave = |p: [f64; 3]| 0.06 * (2.0 * std::f64::consts::PI * p[0]).sin();
        let mut all: Vec<[f64; 3]> = v.iter().map(|&p| [p[0], p[1], wave(p)]).collect();
        all.extend(v.iter().map(|&p| [p[0], p[1], wave(p) + gap]));
        if let Some(k) = lift {
            all[v.len() + k][2] += dz;
        }
        let mut tris = f.clone();
        tris.extend(f.iter().map(|t| t.map(|i| i + n)));
        let mesh = Mesh::new(all, tris).unwrap();
        let x = mesh.rest().to_vec();
        (mesh, x)
    }

    #[test]
    fn layers_certify_each_on_its_own() {
        // Under 90 degrees together, but two pieces: the disk test fails at
        // the root, which is split into the sheets; each certifies, and only
        // their pair is descended (no leaf of one sheet tested against itself
        // or a neighbour: no adjacent pair is ever looked at).
        let (mesh, x) = layered_sheets(0.03, None, 0.0);
        let (pairs, c) = self_intersections(&mesh, &x);
        assert!(pairs.is_empty());
        assert!(c.self_culls >= 2, "{c:?}");
        assert_eq!(c.adjacent_skips, 0, "{c:?}");
        assert!(c.node_pairs > 0, "{c:?}");
        // A vertex of the upper sheet pushed through the lower one: the
        // same pairs as the brute-force reference.
        use crate::detect::{brute::BruteDetector, Detector};
        let (mesh, x) = layered_sheets(0.03, Some(40 * 20 + 13), -0.1);
        let mesh = std::sync::Arc::new(mesh);
        let want = BruteDetector::new(mesh.clone(), 0.0)
            .detect(&x)
            .unwrap()
            .pairs;
        let (mut got, _) = self_intersections(&mesh, &x);
        got.sort_unstable();
        assert!(!want.is_empty());
        assert_eq!(got, want);
    }

    #[test]
    fn flipped_fins_and_pinches_match_brute_force() {
        let (v, f) = grid(24, 1.0);
        // Every seventh triangle wound the other way (its edges run with their neighbours').
        let flipped: Vec<[u32; 3]> = f
            .iter()
            .enumerate()
            .map(|(k, t)| if k % 7 == 0 { [t[0], t[2], t[1]] } else { *t })
            .collect();
        // A fin: a third triangle on each edge of a row (edges in three triangles).
        let mut fin_v = v.clone();
        let mut fin_f = f.clone();
        for k in 0..20u32 {
            let (a, b) = (24 * 10 + k, 24 * 10 + k + 1);
            let [x, y, _] = v[a as usize];
            fin_v.push([x + 0.01, y, 0.05]);
            fin_f.push([a, b, fin_v.len() as u32 - 1]);
        }
        // Two sheets pinched at one vertex (a vertex with two fans).
        let (w, g) = grid(16, 1.0);
        let corner = (16 * 16 - 1) as u32;
        let mut pinch_v = w.clone();
        let offset = pinch_v.len() as u32 - 1;
        pinch_v.extend(w.iter().skip(1).map(|p| [p[0] + 1.0, p[1] + 1.0, p[2]]));
        let mut pinch_f = g.clone();
        pinch_f.extend(
            g.iter()
                .map(|t| t.map(|i| if i == 0 { corner } else { i + offset })),
        );
        let mut total = 0;
        for (v, f) in [(&v, &flipped), (&fin_v, &fin_f), (&pinch_v, &pinch_f)] {
            total += check_against_brute(v, f);
        }
        assert!(total > 50, "the deformations should intersect ({total})");
    }
}
