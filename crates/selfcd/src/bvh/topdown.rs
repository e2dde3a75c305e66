//! A hierarchy built top-down, lazily, for one query: the one-shot
//! [`self_intersections`](crate::detect::self_intersections).
//!
//! The bottom-up hierarchy ([`super::build`]) fits every node's box, cone and
//! patch up front, which a simulation pays once and amortises over frames. A
//! one-shot query needs a node only where its parent's certificate failed:
//! on a smooth sheet the root's certificate holds and nothing is split. Here
//! a node is a range of a permutation of the triangles, split (only when a
//! test needs its children) by the midpoint of its box's longest side, so
//! children are ranges too and a triangle's membership in a node is a range
//! test on its position in the permutation.
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

use crate::bvh::patch::{have_common, pack, project_contour, unpack};
use crate::bvh::traverse::LeafVisitor;
use crate::detect::narrow::Intersect;
use crate::geom::loop2d::{simple_ccw_loop, star_about, LoopScratch, Plane, Seg};
use crate::geom::{Aabb, NormalCone};
use crate::mesh::Mesh;
use crate::stats::Counters;
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

/// Nodes of at most this many triangles are tested pair by pair.
const LEAF: usize = 8;
/// Nodes of at least this many triangles run their halves as parallel tasks.
const PAR_MIN: usize = 2048;

/// All intersecting pairs of non-adjacent triangles of `mesh` at `positions`
/// (`[i, j]`, i < j, sorted), with what the query did.
pub fn self_intersections(mesh: &Mesh, positions: &[DVec3]) -> (Vec<[u32; 2]>, Counters) {
    let n = mesh.n_triangles();
    if n < 2 {
        return (Vec::new(), Counters::default());
    }
    let q = Query::new(mesh, positions);
    let mut root = q.node(0..n as u32);
    let mut out = q.self_test(&mut root);
    out.pairs.sort_unstable();
    (out.pairs, out.counters)
}

/// What a query shares between its tasks. `order` is the permutation whose
/// ranges are the nodes, `pos` its inverse; a task writes only the entries
/// of the nodes it owns, so the relaxed atomics never race on a value.
struct Query<'a> {
    mesh: &'a Mesh,
    x: &'a [DVec3],
    boxes: Vec<Aabb>,
    /// Unit normal of each triangle and a bound on its angle to the exact
    /// one; a zero normal where none is known (the cone test then fails).
    normals: Vec<(DVec3, f64)>,
    order: Vec<AtomicU32>,
    pos: Vec<AtomicU32>,
}

/// A range of the permutation, its box, its children once split, and its
/// patch once a test needed it.
struct Node {
    range: Range<u32>,
    bbox: Aabb,
    kids: Option<Box<[Node; 2]>>,
    patch: Option<Patch>,
}

/// What the certificates need of a node: its cone when under 90 degrees,
/// and then whether it is a disk (module doc), its packed contour and the
/// sorted vertices of that contour.
#[derive(Default)]
struct Patch {
    cone: Option<NormalCone>,
    disk: bool,
    /// The self-certificate held (set by [`Query::self_certified`]).
    certified: bool,
    contour: Vec<u32>,
    boundary: Vec<u32>,
}

impl Node {
    fn len(&self) -> usize {
        self.range.len()
    }
}

/// A task's findings.
#[derive(Default)]
struct Found {
    pairs: Vec<[u32; 2]>,
    counters: Counters,
    scratch: Scratch,
}

impl Found {
    fn absorb(&mut self, mut o: Found) {
        self.pairs.append(&mut o.pairs);
        self.counters.add(&o.counters);
    }
}

/// Buffers of one task's certificates.
#[derive(Default)]
struct Scratch {
    normals: Vec<DVec3>,
    contour: Vec<u32>,
    segs: Vec<Seg>,
    loops: LoopScratch,
}

impl<'a> Query<'a> {
    fn new(mesh: &'a Mesh, x: &'a [DVec3]) -> Query<'a> {
        let n = mesh.n_triangles();
        let (boxes, normals) = (0..n)
            .into_par_iter()
            .map(|t| {
                let c = mesh.corners(x, t);
                let normal =
                    NormalCone::unit_normal(c[0], c[1], c[2]).unwrap_or((DVec3::ZERO, 0.0));
                (Aabb::from_points(&c), normal)
            })
            .unzip();
        let ids = || (0..n as u32).map(AtomicU32::new).collect();
        Query {
            mesh,
            x,
            boxes,
            normals,
            order: ids(),
            pos: ids(),
        }
    }

    #[inline]
    fn tri(&self, i: u32) -> u32 {
        self.order[i as usize].load(Relaxed)
    }

    fn node(&self, range: Range<u32>) -> Node {
        let bbox = range.clone().fold(Aabb::EMPTY, |b, i| {
            b.union(&self.boxes[self.tri(i) as usize])
        });
        Node {
            range,
            bbox,
            kids: None,
            patch: None,
        }
    }

    /// Every intersecting pair within `node`.
    fn self_test(&self, node: &mut Node) -> Found {
        let mut f = Found::default();
        if node.len() <= LEAF {
            self.leaf_self(node, &mut f);
            return f;
        }
        if self.self_certified(node, &mut f) {
            f.counters.self_culls += 1;
            return f;
        }
        let parallel = node.len() >= PAR_MIN;
        let [a, b] = self.kids(node);
        if parallel {
            let (fa, fb) = rayon::join(|| self.self_test(a), || self.self_test(b));
            f.absorb(fa);
            f.absorb(fb);
        } else {
            f.absorb(self.self_test(a));
            f.absorb(self.self_test(b));
        }
        self.pair_test(a, b, &mut f);
        f
    }

    /// Every intersecting pair with one triangle in `a`, one in `b`.
    fn pair_test(&self, a: &mut Node, b: &mut Node, f: &mut Found) {
        if !a.bbox.overlaps(&b.bbox) {
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
        let (big, small) = if a.len() >= b.len() { (a, b) } else { (b, a) };
        let [p, q] = self.kids(big);
        self.pair_test(p, small, f);
        self.pair_test(q, small, f);
    }

    /// The children of `node`, split now if they are not yet.
    fn kids<'n>(&self, node: &'n mut Node) -> &'n mut [Node; 2] {
        if node.kids.is_none() {
            let mid = self.partition(node);
            node.kids = Some(Box::new([
                self.node(node.range.start..mid),
                self.node(mid..node.range.end),
            ]));
        }
        node.kids.as_mut().unwrap()
    }

    /// Partitions `node`'s range at the midpoint of its box along the axis
    /// whose halves' boxes overlap least (by the overlap's surface area;
    /// ties to the longest side): stacked layers are split apart rather than
    /// cut across, which would leave every part with all the layers. The
    /// middle of the range is taken instead when the midpoint leaves a side
    /// with under 1/16 of it, so the depth stays logarithmic. Returns where
    /// the second part starts.
    fn partition(&self, node: &Node) -> u32 {
        let Range { start, end } = node.range.clone();
        let twice_mid = node.bbox.min + node.bbox.max;
        let mut cut = [0u32; 3];
        for i in start..end {
            let b = &self.boxes[self.tri(i) as usize];
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
            let b = &self.boxes[t as usize];
            b.min[axis] + b.max[axis] < twice_mid[axis]
        };
        let (mut i, mut j) = (start, end);
        while i < j {
            let t = self.tri(i);
            if below(t) {
                i += 1;
            } else {
                j -= 1;
                let u = self.tri(j);
                self.place(i, u);
                self.place(j, t);
            }
        }
        let len = end - start;
        if (i - start).min(end - i) >= (len / 16).max(1) {
            return i;
        }
        self.split_at_median(start..end, axis)
    }

    /// Orders `range` so its first half holds the triangles whose box
    /// centres are lowest along `axis` (ties by id); returns the middle.
    fn split_at_median(&self, range: Range<u32>, axis: usize) -> u32 {
        let mut tris: Vec<u32> = range.clone().map(|i| self.tri(i)).collect();
        let key = |t: &u32| {
            let b = &self.boxes[*t as usize];
            (b.min[axis] + b.max[axis], *t)
        };
        let half = tris.len() / 2;
        tris.select_nth_unstable_by(half, |p, q| key(p).partial_cmp(&key(q)).unwrap());
        for (i, t) in range.clone().zip(tris) {
            self.place(i, t);
        }
        range.start + half as u32
    }

    #[inline]
    fn place(&self, i: u32, t: u32) {
        self.order[i as usize].store(t, Relaxed);
        self.pos[t as usize].store(i, Relaxed);
    }

    /// The patch of `node`, found now if it is not yet.
    fn patch<'n>(&self, node: &'n mut Node, f: &mut Found) -> &'n Patch {
        if node.patch.is_none() {
            let ranges = [node.range.clone()];
            let mut p = Patch {
                cone: self.cone(&ranges, &mut f.scratch.normals),
                ..Patch::default()
            };
            if p.cone.is_some() {
                p.disk = self.disk_contour(&ranges, &mut p.contour);
                p.boundary = vertices(self.mesh, &p.contour);
            }
            node.patch = Some(p);
        }
        node.patch.as_ref().unwrap()
    }

    /// The self-certificate of `node` (module doc); counted in `f`.
    fn self_certified(&self, node: &mut Node, f: &mut Found) -> bool {
        let bbox = node.bbox;
        let p = self.patch(node, f);
        let Some(cone) = p.cone else {
            return false;
        };
        let ok = p.disk && self.height_field(cone.axis, &bbox, &p.contour, f);
        f.counters.contour_fails += !ok as u64;
        node.patch.as_mut().unwrap().certified = ok;
        ok
    }

    /// The certificate of the union of `a` and `b`, tried only when their
    /// merged cone is under 90 degrees and their contours share a vertex
    /// (patches apart have two loops, which the test refuses).
    fn union_certified(&self, a: &mut Node, b: &mut Node, f: &mut Found) -> bool {
        let (Some(pa), Some(pb)) = (&a.patch, &b.patch) else {
            return false;
        };
        if !(pa.certified && pb.certified) {
            return false;
        }
        let (Some(ca), Some(cb)) = (pa.cone, pb.cone) else {
            return false;
        };
        let (box_a, box_b) = (a.bbox, b.bbox);
        if !ca.merge_is_positive(&cb) || !have_common(&pa.boundary, &pb.boundary) {
            return false;
        }
        let ranges = [a.range.clone(), b.range.clone()];
        let mut contour = std::mem::take(&mut f.scratch.contour);
        let ok = self.disk_contour(&ranges, &mut contour)
            && self.height_field(ca.merge(&cb).axis, &box_a.union(&box_b), &contour, f);
        f.scratch.contour = contour;
        f.counters.contour_fails += !ok as u64;
        ok
    }

    /// Is packed `contour` projected along unit `axis` one loop around the
    /// centre of `bbox` (star test) or one simple counter-clockwise loop?
    fn height_field(&self, axis: DVec3, bbox: &Aabb, contour: &[u32], f: &mut Found) -> bool {
        f.counters.contour_tests += 1;
        let s = &mut f.scratch;
        let plane = Plane::new(axis, bbox.center());
        project_contour(self.mesh, self.x, contour, &plane, &mut s.segs);
        star_about(&s.segs, [0.0; 2]) || simple_ccw_loop(&s.segs, &mut s.loops)
    }

    /// The normal cone of the triangles in `ranges` about their mean
    /// normal, when it is under 90 degrees.
    fn cone(&self, ranges: &[Range<u32>], normals: &mut Vec<DVec3>) -> Option<NormalCone> {
        normals.clear();
        let (mut sum, mut err) = (DVec3::ZERO, 0.0f64);
        for i in ranges.iter().flat_map(|r| r.clone()) {
            let (n, e) = self.normals[self.tri(i) as usize];
            if n == DVec3::ZERO {
                return None;
            }
            normals.push(n);
            sum += n;
            err = err.max(e);
        }
        let cone = NormalCone::around(sum.normalize_or_zero(), normals, err);
        cone.is_positive().then_some(cone)
    }

    /// Writes the packed contour of the union of `ranges` into `contour`;
    /// true when every edge of the union is in at most two of its triangles,
    /// with opposite directions, and its Euler characteristic is 1.
    fn disk_contour(&self, ranges: &[Range<u32>], contour: &mut Vec<u32>) -> bool {
        contour.clear();
        let topo = self.mesh.topology();
        let tris = self.mesh.triangles();
        let member = |t: u32| {
            let p = self.pos[t as usize].load(Relaxed);
            ranges.iter().any(|r| r.contains(&p))
        };
        let (mut v, mut f) = (0i64, 0i64);
        for i in ranges.iter().flat_map(|r| r.clone()) {
            let t = self.tri(i);
            let (tri, edges, owned) = (
                tris[t as usize],
                topo.tri_edges[t as usize],
                topo.owned[t as usize],
            );
            f += 1;
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                match *topo.edge_tris.row(edges[k] as usize) {
                    [_] => contour.push(pack(edges[k], a, b)),
                    [s, u] => {
                        let o = s ^ u ^ t;
                        if !member(o) {
                            contour.push(pack(edges[k], a, b));
                        } else if !has_directed_edge(tris[o as usize], b, a) {
                            return false;
                        }
                    }
                    _ => return false,
                }
                // Each vertex is counted by the first of its triangles in the set.
                let first = owned & (1 << k) != 0
                    || topo
                        .vertex_tris
                        .row(tri[k] as usize)
                        .iter()
                        .find(|&&s| member(s))
                        == Some(&t);
                v += first as i64;
            }
        }
        let e = (3 * f + contour.len() as i64) / 2;
        v - e + f == 1
    }

    fn leaf_self(&self, node: &Node, f: &mut Found) {
        let r = node.range.clone();
        for i in r.clone() {
            for j in i + 1..r.end {
                self.test(self.tri(i), self.tri(j), f);
            }
        }
    }

    fn leaf_pair(&self, a: &Node, b: &Node, f: &mut Found) {
        for i in a.range.clone() {
            for j in b.range.clone() {
                self.test(self.tri(i), self.tri(j), f);
            }
        }
    }

    #[inline]
    fn test(&self, s: u32, t: u32, f: &mut Found) {
        if !self.boxes[s as usize].overlaps(&self.boxes[t as usize]) {
            return;
        }
        if self.mesh.share_vertex(s as usize, t as usize) {
            f.counters.adjacent_skips += 1;
            return;
        }
        f.counters.primitive_tests += 1;
        let visitor = Intersect {
            mesh: self.mesh,
            positions: self.x,
        };
        let (lo, hi) = (s.min(t), s.max(t));
        visitor.visit_counted(lo, hi, false, &mut f.pairs, &mut f.counters);
    }
}

/// The sorted distinct vertices of packed contour edges.
fn vertices(mesh: &Mesh, contour: &[u32]) -> Vec<u32> {
    let mut v: Vec<u32> = contour.iter().flat_map(|&e| unpack(mesh, e)).collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// Does triangle `tri` hold the directed edge `a -> b`?
#[inline]
fn has_directed_edge(tri: [u32; 3], a: u32, b: u32) -> bool {
    (0..3).any(|k| tri[k] == a && tri[(k + 1) % 3] == b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::grid;

    /// `disk_contour` of all the triangles of a mesh.
    fn whole_is_disk(v: &[[f64; 3]], f: &[[u32; 3]]) -> bool {
        let mesh = Mesh::new(v.to_vec(), f.to_vec()).unwrap();
        let q = Query::new(&mesh, mesh.rest());
        q.disk_contour(&[0..f.len() as u32], &mut Vec::new())
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
}
