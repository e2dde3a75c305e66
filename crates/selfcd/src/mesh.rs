//! `Mesh`: rest positions, triangles and the topology built once from them.
//!
//! Topology never changes while the mesh deforms, so everything derived from
//! connectivity (edges, vertex -> triangles, edge -> triangles) is computed here
//! once and shared by the BVH, the sensor and the cloth.

use crate::error::{Error, Result};
use crate::geom::predicates::{exponent, mul_pow2};
use crate::geom::Aabb;
use crate::union_find;
use glam::DVec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::OnceLock;

/// Compressed sparse rows: `items[offsets[i]..offsets[i+1]]` belong to `i`.
#[derive(Debug, Clone, Default)]
pub struct Csr {
    /// Start of each row; one more entry than rows.
    pub offsets: Vec<u32>,
    /// Row contents, concatenated.
    pub items: Vec<u32>,
}

impl Csr {
    /// Builds rows from `(row, item)` pairs; items keep their input order within a row.
    pub fn from_pairs(rows: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> Csr {
        let mut offsets = vec![0u32; rows + 1];
        for (r, _) in pairs.clone() {
            offsets[r as usize + 1] += 1;
        }
        for i in 0..rows {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut items = vec![0u32; offsets[rows] as usize];
        for (r, it) in pairs {
            items[fill[r as usize] as usize] = it;
            fill[r as usize] += 1;
        }
        Csr { offsets, items }
    }

    /// The inverse of a map from items to three rows each: row `r` lists
    /// every `t` with `r` in `triples[t]`, in increasing order (once per
    /// occurrence). Equal to [`from_pairs`](Self::from_pairs) over the pairs
    /// `(triples[t][k], t)` in order, in two tight passes (a counting sort).
    /// Kept apart from `from_pairs` for speed: fed those pairs by an iterator
    /// chain, `Mesh::new` at 200k took 17.2 ms instead of 12.4 (one thread).
    pub fn from_triples(rows: usize, triples: &[[u32; 3]]) -> Csr {
        Csr::from_triples_first(rows, triples).0
    }

    /// [`from_triples`](Self::from_triples), and for each triple which of
    /// its entries are the first item of their row (bit k for entry k), found
    /// by the counting pass for free.
    fn from_triples_first(rows: usize, triples: &[[u32; 3]]) -> (Csr, Vec<u8>) {
        let mut counts = vec![0u32; rows + 1];
        let first = (triples.iter())
            .map(|x| {
                let mut bits = 0;
                for (k, &r) in x.iter().enumerate() {
                    let c = &mut counts[r as usize];
                    bits |= ((*c == 0) as u8) << k;
                    *c += 1;
                }
                bits
            })
            .collect();
        (Csr::fill(counts, triples), first)
    }

    /// Rows of `counts[r]` items (`counts` has one spare entry at the end),
    /// row `r` listing every `t` with `r` in `triples[t]`, increasing. The
    /// counts become each row's end, and a backward fill moves every end to
    /// its row's start: no cursor array.
    fn fill(mut counts: Vec<u32>, triples: &[[u32; 3]]) -> Csr {
        let mut sum = 0;
        for c in &mut counts {
            sum += *c;
            *c = sum;
        }
        let mut items = vec![0u32; sum as usize];
        for (t, x) in triples.iter().enumerate().rev() {
            for &r in x.iter().rev() {
                let end = &mut counts[r as usize];
                *end -= 1;
                items[*end as usize] = t as u32;
            }
        }
        Csr {
            offsets: counts,
            items,
        }
    }

    /// The items of row `i`.
    #[inline]
    pub fn row(&self, i: usize) -> &[u32] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.offsets.len() - 1
    }
}

/// Connectivity of a triangle mesh, built once.
#[derive(Debug, Clone)]
pub struct Topology {
    /// Unique undirected edges, each stored with its smaller vertex first.
    pub edges: Vec<[u32; 2]>,
    /// For each triangle, the ids of its edges (v0v1, v1v2, v2v0).
    pub tri_edges: Vec<[u32; 3]>,
    /// For each edge, the triangles that contain it.
    pub edge_tris: Csr,
    /// For each vertex, the triangles that contain it.
    pub vertex_tris: Csr,
    /// For each triangle, which of its elements it *owns* (is the first
    /// triangle of, in `vertex_tris` / `edge_tris`): bit k for vertex k, bit
    /// 3 + k for edge k. Each vertex and edge has exactly one owner.
    pub owned: Vec<u8>,
}

impl Topology {
    /// Builds the topology of `tris` over `n_vertices` vertices (indices must be valid).
    ///
    /// Edges are numbered in order of first appearance (triangle `t`, side `k`
    /// in order `3 t + k`); every row of `edge_tris` and `vertex_tris` lists its
    /// triangles in increasing order. O(n): half-edges are bucketed by their
    /// smaller vertex (a counting sort), so no hashing and no global sort.
    pub fn new(n_vertices: usize, tris: &[[u32; 3]]) -> Topology {
        let (edge, (vertex_tris, vertex_owned)) = rayon::join(
            || unique_edges(n_vertices, tris),
            || Csr::from_triples_first(n_vertices, tris),
        );
        let mut owned = edge.owned;
        for (o, v) in owned.iter_mut().zip(vertex_owned) {
            *o |= v;
        }
        Topology {
            edges: edge.edges,
            tri_edges: edge.tri_edges,
            edge_tris: edge.edge_tris,
            vertex_tris,
            owned,
        }
    }

    /// This topology with the triangles renumbered: triangle `i` of the
    /// result is triangle `order[i]` here (`tris` the renumbered triangles).
    /// Edge and vertex ids are kept; the triangles of each edge and vertex,
    /// and their owners, come from the renumbered triples as in
    /// [`new`](Self::new).
    fn reordered(&self, order: &[u32], tris: &[[u32; 3]]) -> Topology {
        let tri_edges: Vec<[u32; 3]> = order.iter().map(|&t| self.tri_edges[t as usize]).collect();
        let ((edge_tris, edge_owned), (vertex_tris, mut owned)) = rayon::join(
            || Csr::from_triples_first(self.edges.len(), &tri_edges),
            || Csr::from_triples_first(self.vertex_tris.rows(), tris),
        );
        for (o, e) in owned.iter_mut().zip(edge_owned) {
            *o |= e << 3;
        }
        Topology {
            edges: self.edges.clone(),
            tri_edges,
            edge_tris,
            vertex_tris,
            owned,
        }
    }

    /// True when edge `e` has exactly two triangles (an interior edge of a manifold).
    #[inline]
    pub fn is_manifold_interior(&self, e: u32) -> bool {
        self.edge_tris.row(e as usize).len() == 2
    }

    /// The first pair `(first, second)` of triangles with the same vertex set,
    /// smallest `second` first (ties: smallest `first`), or None.
    /// A `second` shares all three edges with its `first`, an earlier
    /// triangle, so it owns none of them: only such triangles (none on a
    /// strip-ordered sheet) are looked at, each by comparing the third
    /// corners of the earlier triangles on its first edge.
    fn first_duplicate(&self, tris: &[[u32; 3]]) -> Option<(usize, usize)> {
        let third = |t: u32, a: u32, b: u32| {
            let v = tris[t as usize];
            v[0] as u64 + v[1] as u64 + v[2] as u64 - a as u64 - b as u64
        };
        (self.owned.iter().enumerate())
            .filter(|(_, &o)| o & 0o70 == 0)
            .find_map(|(t, _)| {
                let [a, b, _] = tris[t];
                let row = self.edge_tris.row(self.tri_edges[t][0] as usize);
                (row.iter().take_while(|&&s| (s as usize) < t))
                    .find(|&&s| third(s, a, b) == third(t as u32, a, b))
                    .map(|&s| (s as usize, t))
            })
    }
}

/// Triangles per parallel task of the validity check in [`Mesh::screened`].
const CHECK_CHUNK: usize = 4096;

/// The edge half of a [`Topology`]: its `edges`, `tri_edges` and
/// `edge_tris`, and the edge bits (3 + k) of `owned`.
struct EdgeTopology {
    edges: Vec<[u32; 2]>,
    tri_edges: Vec<[u32; 3]>,
    edge_tris: Csr,
    owned: Vec<u8>,
}

/// Unique undirected edges (smaller vertex first), numbered in order of first
/// appearance, each triangle's edge ids, each edge's triangles and owner.
fn unique_edges(n_vertices: usize, tris: &[[u32; 3]]) -> EdgeTopology {
    /// The ends of side k of triangle `v`, smaller first.
    #[inline]
    fn side(v: &[u32; 3], k: usize) -> (u32, u32) {
        let (a, b) = (v[k], v[if k == 2 { 0 } else { k + 1 }]);
        (a.min(b), a.max(b))
    }
    // Counting sort of the half-edges by their smaller vertex, each stored
    // as `larger vertex << 32 | half-edge index` (half-edge 3 t + k is side
    // k of triangle t), so each bucket is in increasing half-edge order.
    let mut start = vec![0u32; n_vertices + 1];
    for v in tris {
        for k in 0..3 {
            start[side(v, k).0 as usize + 1] += 1;
        }
    }
    for v in 0..n_vertices {
        start[v + 1] += start[v];
    }
    let mut cursor = start[..n_vertices].to_vec();
    let mut keys = vec![0u64; 3 * tris.len()];
    for (t, v) in tris.iter().enumerate() {
        for k in 0..3 {
            let (lo, hi) = side(v, k);
            let c = &mut cursor[lo as usize];
            keys[*c as usize] = (hi as u64) << 32 | (3 * t + k) as u64;
            *c += 1;
        }
    }
    drop(cursor);
    // `first[h]` is the first half-edge of h's edge: the first in its bucket
    // with the same larger vertex (then, in place, h's edge id). `seen[hi]`
    // holds `lo << 32 | first` for the last bucket `lo` that met `hi` (no
    // sort; no bucket is u32::MAX, the smaller vertex of nothing).
    let mut tri_edges = vec![[0u32; 3]; tris.len()];
    let first = tri_edges.as_flattened_mut();
    let mut seen = vec![u64::MAX; n_vertices];
    for lo in 0..n_vertices {
        for &key in &keys[start[lo] as usize..start[lo + 1] as usize] {
            let (hi, h) = ((key >> 32) as usize, key as u32);
            let s = seen[hi];
            let lead = if s >> 32 == lo as u64 { s as u32 } else { h };
            seen[hi] = (lo as u64) << 32 | lead as u64;
            first[h as usize] = lead;
        }
    }
    drop((keys, seen, start));
    // Number edges at their first half-edge, whose triangle owns the edge
    // (rows of `edge_tris` are increasing); later half-edges copy the id
    // (`first[h] < h` is already renumbered when h is reached).
    let mut edges = Vec::with_capacity(first.len() / 2 + 1);
    let mut counts = Vec::with_capacity(first.len() / 2 + 2);
    let mut owned = vec![0u8; tris.len()];
    for (t, v) in tris.iter().enumerate() {
        for k in 0..3 {
            let h = 3 * t + k;
            let f = first[h] as usize;
            first[h] = if f == h {
                let (lo, hi) = side(v, k);
                edges.push([lo, hi]);
                counts.push(1);
                owned[t] |= 8 << k;
                (edges.len() - 1) as u32
            } else {
                let e = first[f];
                counts[e as usize] += 1;
                e
            };
        }
    }
    counts.push(0);
    EdgeTopology {
        edge_tris: Csr::fill(counts, &tri_edges),
        edges,
        tri_edges,
        owned,
    }
}

/// True when triangles (vertex ids) `a` and `b` share at least one vertex.
#[inline]
pub fn share_vertex(a: &[u32; 3], b: &[u32; 3]) -> bool {
    // All nine comparisons, no early exit: in the traversals' leaf tests the
    // answer is a coin flip for the branch predictor.
    a.iter()
        .fold(false, |m, v| m | (*v == b[0]) | (*v == b[1]) | (*v == b[2]))
}

/// A triangle mesh with validated rest positions and its topology.
#[derive(Debug, Clone)]
pub struct Mesh {
    rest: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
    topo: Topology,
    /// Computed on first use: the one-shot query never asks (a square root
    /// per edge, 1.1 ms of `Mesh::new`'s 11 at 200k).
    mean_edge: OnceLock<f64>,
    /// Computed on first use, by the first query that tries a certificate.
    adjacency: OnceLock<Adjacency>,
}

/// Which triangle lies across each edge of each triangle, and how the two
/// meet there: what the one-shot queries' certificates read to walk a
/// patch's pieces and contour ([`Mesh::adjacency`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Adjacency {
    /// The triangle across edge k (corners k, k + 1) of each triangle:
    /// itself on a border, or on an edge in more than two triangles.
    pub across: Vec<[u32; 3]>,
    /// Per triangle: [`Adjacency::TANGLED`] when one of its edges is in
    /// more than two triangles, [`Adjacency::FLIPPED`] `<< k` when the
    /// triangle across edge k runs it in the same direction (inconsistent
    /// winding).
    pub flags: Vec<u8>,
}

impl Adjacency {
    /// Flag: one of the triangle's edges is in more than two triangles.
    pub const TANGLED: u8 = 1;
    /// Flag, shifted by the edge's index: the triangle across that edge
    /// runs it in the same direction.
    pub const FLIPPED: u8 = 2;

    /// The adjacency of `mesh`'s triangles (in parallel; each triangle's
    /// entries are its own, so the result does not depend on the threads).
    fn of(mesh: &Mesh) -> Adjacency {
        let mut adj = Adjacency::default();
        (0..mesh.n_triangles() as u32)
            .into_par_iter()
            .map(|t| Adjacency::around(mesh, t))
            .unzip_into_vecs(&mut adj.across, &mut adj.flags);
        adj
    }

    /// The triangles across the edges of triangle `t` and its flags.
    fn around(mesh: &Mesh, t: u32) -> ([u32; 3], u8) {
        let (topo, tris) = (mesh.topology(), mesh.triangles());
        let tri = tris[t as usize];
        let (mut across, mut flags) = ([t; 3], 0);
        for (k, &e) in topo.tri_edges[t as usize].iter().enumerate() {
            match *topo.edge_tris.row(e as usize) {
                [_] => {}
                [s, u] => {
                    let o = s ^ u ^ t;
                    across[k] = o;
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    let other = tris[o as usize];
                    if (0..3).any(|j| other[j] == a && other[(j + 1) % 3] == b) {
                        flags |= Adjacency::FLIPPED << k;
                    }
                }
                _ => flags |= Adjacency::TANGLED,
            }
        }
        (across, flags)
    }
}

impl Mesh {
    /// Validates `vertices` (rest shape) and `triangles` and builds the topology.
    ///
    /// Errors: empty mesh, non-finite coordinate, index out of range, a triangle
    /// repeating a vertex index, two triangles with the same vertex set.
    ///
    /// Accepted: zero-area triangles (collinear or coincident corners, in the
    /// rest shape or any frame). Every query treats one as the segment or point
    /// it is: it intersects what that segment or point touches; its normal cone
    /// is the full cone, so no node holding it is culled.
    ///
    /// Refused, by policy: a repeated vertex *index* (`[a, b, b]`) names an edge
    /// from a vertex to itself, which the edge topology cannot hold; a collapsed
    /// corner needs its own vertex at the same position (`weld` in the Python
    /// API keeps one so). Two triangles with the same three vertices are
    /// refused too: they are adjacent, so their contact is never a
    /// self-intersection, and one of them is a duplicate to remove.
    pub fn new(vertices: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Result<Mesh> {
        Mesh::screened(vertices, triangles, false).map(|(mesh, _)| mesh)
    }

    /// [`new`](Self::new), and whether some vertices may share a position:
    /// with `screen`, [`may_repeat_positions`](crate::weld::may_repeat_positions)
    /// of the vertices, run beside the topology (true without `screen`).
    pub fn screened(
        vertices: Vec<[f64; 3]>,
        triangles: Vec<[u32; 3]>,
        screen: bool,
    ) -> Result<(Mesh, bool)> {
        if vertices.is_empty() {
            return Err(Error::EmptyMesh("no vertices"));
        }
        if triangles.is_empty() {
            return Err(Error::EmptyMesh("no triangles"));
        }
        // In place: `[f64; 3]` and `DVec3` have one layout, so no new buffer.
        let rest: Vec<DVec3> = vertices.into_iter().map(DVec3::from_array).collect();
        let n = rest.len();
        let invalid = |t: &[u32; 3]| {
            t.iter().any(|&v| v as usize >= n) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2]
        };
        // The first invalid triangle: the first chunk holding one, scanned by
        // a plain loop (a parallel search per triangle costs more than the test).
        let first_bad =
            (triangles.par_chunks(CHECK_CHUNK).enumerate()).find_map_first(|(c, chunk)| {
                chunk.iter().position(invalid).map(|k| c * CHECK_CHUNK + k)
            });
        // The positions' checks beside the topology (which needs valid
        // triangles only); errors in the order the checks are documented.
        let (repeats, topo) = rayon::join(
            || check_finite(&rest).map(|()| !screen || crate::weld::may_repeat_positions(&rest)),
            || match first_bad {
                Some(i) => Err(first_invalid(&triangles[..=i], n)),
                None => Ok(Topology::new(n, &triangles)),
            },
        );
        let (repeats, topo) = (repeats?, topo?);
        if let Some((first, second)) = topo.first_duplicate(&triangles) {
            return Err(Error::DuplicateTriangle { first, second });
        }
        let mesh = Mesh {
            rest,
            tris: triangles,
            topo,
            mean_edge: OnceLock::new(),
            adjacency: OnceLock::new(),
        };
        Ok((mesh, repeats))
    }

    /// The same mesh with its triangles renumbered: triangle `i` of the
    /// result is triangle `order[i]` of this one (`order` a permutation of
    /// the triangle ids). Vertices, edges and their ids are unchanged, so a
    /// query on the result answers a query on this mesh once its triangle
    /// ids are mapped back through `order` (a hierarchy's depth-first order:
    /// [`crate::bvh::Bvh::depth_first`]).
    pub fn reordered(&self, order: &[u32]) -> Mesh {
        assert_eq!(order.len(), self.tris.len(), "one entry per triangle");
        let tris: Vec<[u32; 3]> = order.iter().map(|&t| self.tris[t as usize]).collect();
        let (topo, rest) = rayon::join(|| self.topo.reordered(order, &tris), || self.rest.clone());
        Mesh {
            rest,
            tris,
            topo,
            mean_edge: self.mean_edge.clone(),
            // (Triangle ids changed.)
            adjacency: OnceLock::new(),
        }
    }

    /// Rest positions.
    pub fn rest(&self) -> &[DVec3] {
        &self.rest
    }

    /// Triangles as vertex index triples.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.tris
    }

    /// Connectivity built at construction.
    pub fn topology(&self) -> &Topology {
        &self.topo
    }

    /// The triangles' adjacency, computed on first use and kept: it depends
    /// on the triangles only, so every query on this mesh shares it.
    pub fn adjacency(&self) -> &Adjacency {
        if let Some(adjacency) = self.adjacency.get() {
            return adjacency;
        }
        // Computed outside the cell: the parallel pass lets this thread run
        // other tasks meanwhile, and one of them may be another query on
        // this mesh (an initializer that re-entered the cell would
        // deadlock). Queries that race compute the same value; one is kept.
        let _ = self.adjacency.set(Adjacency::of(self));
        self.adjacency.get().expect("set above")
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.rest.len()
    }

    /// Number of triangles.
    pub fn n_triangles(&self) -> usize {
        self.tris.len()
    }

    /// Mean rest edge length: the length unit of the sensor.
    pub fn mean_edge_length(&self) -> f64 {
        let edges = self.topo.edges.iter();
        *(self.mean_edge).get_or_init(|| mean_length(edges.map(|e| edge_length(&self.rest, *e))))
    }

    /// Mean edge length at `positions` (one pass over the edges; the rest's
    /// is [`mean_edge_length`](Self::mean_edge_length), computed once).
    pub fn mean_edge_length_at(&self, positions: &[DVec3]) -> f64 {
        mean_length(self.topo.edges.iter().map(|e| edge_length(positions, *e)))
    }

    /// True when `positions` are the rest shape: the rest slice itself (known
    /// without reading it) or an equal one.
    pub fn is_rest(&self, positions: &[DVec3]) -> bool {
        std::ptr::eq(positions, self.rest.as_slice()) || positions == self.rest
    }

    /// Checks that `positions` fit this mesh: right length, all finite (the
    /// rest slice itself was checked at construction).
    pub fn check_positions(&self, positions: &[DVec3]) -> Result<()> {
        if std::ptr::eq(positions, self.rest.as_slice()) {
            return Ok(());
        }
        if positions.len() != self.rest.len() {
            return Err(Error::PositionsLength {
                expected: self.rest.len(),
                got: positions.len(),
            });
        }
        check_finite(positions)
    }

    /// The three corners of triangle `t` in `positions`.
    #[inline]
    pub fn corners(&self, positions: &[DVec3], t: usize) -> [DVec3; 3] {
        let [a, b, c] = self.tris[t];
        [
            positions[a as usize],
            positions[b as usize],
            positions[c as usize],
        ]
    }

    /// The box of triangle `t` over the linear motion from `x0` to `x1`: its
    /// corners' boxes at both ends (each point of the swept triangle is a
    /// convex combination of them).
    #[inline]
    pub fn swept_box(&self, x0: &[DVec3], x1: &[DVec3], t: usize) -> Aabb {
        Aabb::from_points(&self.corners(x0, t)).union(&Aabb::from_points(&self.corners(x1, t)))
    }

    /// True when triangles `a` and `b` share at least one vertex.
    #[inline]
    pub fn share_vertex(&self, a: usize, b: usize) -> bool {
        share_vertex(&self.tris[a], &self.tris[b])
    }

    /// Component id of every triangle, numbered 0.. in order of each
    /// component's first triangle. Triangles are connected when they share a
    /// vertex: a surface path passes through a shared vertex, and triangles of
    /// different components share none.
    pub fn triangle_components(&self) -> Vec<u32> {
        let mut parent: Vec<u32> = (0..self.n_vertices() as u32).collect();
        for t in self.triangles() {
            union_find::union(&mut parent, t[0], t[1]);
            union_find::union(&mut parent, t[0], t[2]);
        }
        let mut label = vec![u32::MAX; parent.len()];
        let mut next = 0;
        self.triangles()
            .iter()
            .map(|t| {
                let root = union_find::find(&mut parent, t[0]) as usize;
                if label[root] == u32::MAX {
                    label[root] = next;
                    next += 1;
                }
                label[root]
            })
            .collect()
    }

    /// Flags, per triangle, whether it touches a non-manifold edge (more than two
    /// triangles) or a non-manifold vertex (its triangles form several fans).
    pub fn nonmanifold_triangles(&self) -> Vec<bool> {
        let topo = &self.topo;
        let several_fans: Vec<bool> = (0..self.n_vertices() as u32)
            .into_par_iter()
            .map(|v| !self.one_fan_at(v))
            .collect();
        self.tris
            .par_iter()
            .zip(&topo.tri_edges)
            .map(|(t, e)| {
                e.iter().any(|&e| topo.edge_tris.row(e as usize).len() > 2)
                    || t.iter().any(|&v| several_fans[v as usize])
            })
            .collect()
    }

    /// True when the triangles at vertex `v` form one fan: connected through
    /// edges at `v`. Where every edge at `v` has at most two triangles, the
    /// fans are paths and cycles, so a walk around `v` from one triangle (both
    /// ways when it stops at a border) meets all of them only if there is one;
    /// at a non-manifold edge, a union-find over the vertex's triangles decides.
    fn one_fan_at(&self, v: u32) -> bool {
        let fan = self.topo.vertex_tris.row(v as usize);
        let Some(&first) = fan.first() else {
            return true;
        };
        let mut seen = 1;
        for leave in self.edges_at(first, v) {
            let (mut t, mut e) = (first, leave);
            loop {
                t = match *self.topo.edge_tris.row(e as usize) {
                    [x, y] => x ^ y ^ t,
                    [_] => break,
                    _ => return self.fans_at(v, &mut Vec::new()) == 1,
                };
                if t == first {
                    return seen == fan.len();
                }
                seen += 1;
                let [a, b] = self.edges_at(t, v);
                e = if a == e { b } else { a };
            }
        }
        seen == fan.len()
    }

    /// The two edges of triangle `t` at its corner `v`.
    #[inline]
    fn edges_at(&self, t: u32, v: u32) -> [u32; 2] {
        let tri = self.tris[t as usize];
        let k = if tri[0] == v {
            0
        } else if tri[1] == v {
            1
        } else {
            2
        };
        let e = self.topo.tri_edges[t as usize];
        [e[k], e[(k + 2) % 3]]
    }

    /// Number of fans at vertex `v`: classes of its triangles connected
    /// through edges at `v` (union-find over the vertex's triangles, whose
    /// row is sorted, so a neighbour's place is a binary search).
    fn fans_at(&self, v: u32, parent: &mut Vec<u32>) -> usize {
        let topo = &self.topo;
        let fan = topo.vertex_tris.row(v as usize);
        parent.clear();
        parent.extend(0..fan.len() as u32);
        let mut fans = fan.len();
        for (i, &t) in fan.iter().enumerate() {
            let k = self.tris[t as usize]
                .iter()
                .position(|&c| c == v)
                .unwrap_or(0);
            // The two sides of t at corner k: k (from v) and k + 2 (into v).
            for side in [k, (k + 2) % 3] {
                let e = topo.tri_edges[t as usize][side] as usize;
                for &u in topo.edge_tris.row(e) {
                    let Ok(j) = fan.binary_search(&u) else {
                        continue;
                    };
                    if union_find::union(parent, i as u32, j as u32) {
                        fans -= 1;
                    }
                }
            }
        }
        fans
    }
}

/// Length of edge `e` for any finite corners: the difference is moved by a
/// power of two to [1, 2) before squaring, so no square overflows or
/// underflows (edges of 2^-900 are not zero); the result is bit for bit the
/// naive one wherever that does not overflow or underflow (so the naive one
/// is used there, the cheaper). Saturated at
/// `f64::MAX` when the length exceeds it.
fn edge_length(x: &[DVec3], e: [u32; 2]) -> f64 {
    let (a, b) = (x[e[0] as usize], x[e[1] as usize]);
    let (d, twice) = match a - b {
        d if d.is_finite() => (d, false),
        _ => (0.5 * a - 0.5 * b, true), // the difference overflowed: halve first
    };
    let m = d.abs().max_element();
    if (1e-150..1e150).contains(&m) {
        return d.length(); // the common case: no square can overflow or underflow
    }
    if m == 0.0 {
        return 0.0;
    }
    let k = exponent(m);
    let len = mul_pow2(mul_pow2(d, -k).length(), k);
    (if twice { 2.0 * len } else { len }).min(f64::MAX)
}

/// Mean of finite non-negative `lengths` (0 for none), summed at the scale of
/// the largest so that the sum cannot overflow (bit for bit the naive mean
/// where that does not overflow or underflow). The common case takes one
/// pass: the naive sum is kept alongside the largest length and used when
/// that is below 1e150 (then the sum, at most 3 * 2^32 such terms, is finite).
fn mean_length(lengths: impl Iterator<Item = f64> + Clone) -> f64 {
    let (n, top, sum) = lengths
        .clone()
        .fold((0usize, 0.0f64, 0.0f64), |(n, m, s), x| {
            (n + 1, m.max(x), s + x)
        });
    if top == 0.0 {
        return 0.0;
    }
    if top < 1e150 {
        return sum / n as f64; // the common case: no overflow
    }
    let k = exponent(top);
    mul_pow2(lengths.map(|x| mul_pow2(x, -k)).sum::<f64>() / n as f64, k)
}

/// The first error of `triangles` in order (index out of range, repeated
/// vertex, or a duplicate of an earlier triangle); the slow path, run only
/// when the fast checks found an invalid triangle (the last one given).
fn first_invalid(triangles: &[[u32; 3]], n: usize) -> Error {
    let mut seen: HashMap<[u32; 3], usize> = HashMap::with_capacity(triangles.len());
    for (i, t) in triangles.iter().enumerate() {
        if let Some(&bad) = t.iter().find(|&&v| v as usize >= n) {
            return Error::IndexOutOfRange {
                triangle: i,
                index: bad as u64,
                vertex_count: n,
            };
        }
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return Error::RepeatedVertex {
                triangle: i,
                indices: *t,
            };
        }
        let mut key = *t;
        key.sort_unstable();
        if let Some(&first) = seen.get(&key) {
            return Error::DuplicateTriangle { first, second: i };
        }
        seen.insert(key, i);
    }
    unreachable!("the last triangle given is invalid")
}

/// Err([`Error::NonFinite`]) naming the first vertex with an infinite or NaN
/// coordinate. The common case, all finite, is one branch-free pass: `0 x` is
/// 0 (of either sign) for a finite x and NaN otherwise, and a sum of zeros is
/// 0 where one NaN makes it NaN (about half the instructions of testing each
/// coordinate, which every detector pays on every frame); only a failure
/// looks for the vertex.
fn check_finite(p: &[DVec3]) -> Result<()> {
    if p.iter().fold(DVec3::ZERO, |sum, &v| sum + v * 0.0) == DVec3::ZERO {
        return Ok(());
    }
    for (i, v) in p.iter().enumerate() {
        if let Some(&value) = v.as_ref().iter().find(|x| !x.is_finite()) {
            return Err(Error::NonFinite { vertex: i, value });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh with its triangles renumbered has the topology of a mesh
    /// built from them afresh, with the same vertex and edge ids: each
    /// triangle's edges are the same vertex pairs, every edge and vertex has
    /// the same triangles and the same owner.
    #[test]
    fn reordered_topology_is_the_fresh_one_in_the_old_edge_ids() {
        let (v, f) = crate::scene::grid(13, 1.0);
        let mesh = Mesh::new(v.clone(), f).unwrap();
        let mut order: Vec<u32> = (0..mesh.n_triangles() as u32).collect();
        crate::scene::SplitMix::new(3).shuffle(&mut order);
        let got = mesh.reordered(&order);
        let fresh = Mesh::new(v, got.triangles().to_vec()).unwrap();
        let (g, f) = (got.topology(), fresh.topology());
        assert_eq!(g.edges, mesh.topology().edges);
        assert_eq!(g.vertex_tris.offsets, f.vertex_tris.offsets);
        assert_eq!(g.vertex_tris.items, f.vertex_tris.items);
        assert_eq!(g.owned, f.owned);
        for (ge, fe) in g.tri_edges.iter().zip(&f.tri_edges) {
            for (&a, &b) in ge.iter().zip(fe) {
                assert_eq!(g.edges[a as usize], f.edges[b as usize]);
                assert_eq!(g.edge_tris.row(a as usize), f.edge_tris.row(b as usize));
            }
        }
    }

    /// `from_triples` is `from_pairs` over every (row, triple index) pair.
    #[test]
    fn from_triples_is_from_pairs() {
        let mut rng = crate::scene::SplitMix::new(9);
        let triples: Vec<[u32; 3]> = (0..500)
            .map(|_| [(); 3].map(|_| (rng.unit() * 60.0) as u32))
            .collect();
        let pairs = triples.iter().enumerate();
        let want = Csr::from_pairs(60, pairs.flat_map(|(t, x)| x.map(|r| (r, t as u32))));
        let got = Csr::from_triples(60, &triples);
        assert_eq!((got.offsets, got.items), (want.offsets, want.items));
    }

    fn quad() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        (
            vec![[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn topology_of_a_quad() {
        let (v, f) = quad();
        let m = Mesh::new(v, f).unwrap();
        let t = m.topology();
        assert_eq!(t.edges.len(), 5);
        let diag = t.tri_edges[0][2];
        assert_eq!(t.edge_tris.row(diag as usize), &[0, 1]);
        assert_eq!(t.vertex_tris.row(0), &[0, 1]);
        assert!(m.share_vertex(0, 1));
    }

    /// Varied connectivity from a grid: a random subset of its triangles (so
    /// some vertices become bow-ties), shuffled, some flipped, plus two fins on
    /// one edge (three or four triangles there) and two closed fans sharing one vertex.
    fn tangled(seed: u64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        use rand::{seq::SliceRandom, Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (mut v, tris) = crate::scene::grid(9, 1.0);
        let mut f: Vec<[u32; 3]> = tris
            .into_iter()
            .filter_map(|[a, b, c]| match rng.gen_range(0..10) {
                0 | 1 => None,
                2 | 3 => Some([a, c, b]),
                _ => Some([a, b, c]),
            })
            .collect();
        let [a, b, _] = f[0];
        for z in [1.0, -1.0] {
            v.push([0.3, 0.3, z]);
            f.push([a, b, v.len() as u32 - 1]);
        }
        // Two closed fans (double cone) at a new apex.
        let apex = v.len() as u32;
        v.push([5.0, 5.0, 0.0]);
        for side in [-1.0, 1.0] {
            let ring = v.len() as u32;
            for k in 0..4 {
                let t = k as f64 * std::f64::consts::FRAC_PI_2;
                v.push([5.0 + t.cos(), 5.0 + t.sin(), side]);
            }
            f.extend((0..4).map(|k| [apex, ring + k, ring + (k + 1) % 4]));
        }
        f.shuffle(&mut rng);
        (v, f)
    }

    #[test]
    fn topology_matches_a_hash_map_reference() {
        for seed in 0..8 {
            let (v, f) = tangled(seed);
            let topo = Topology::new(v.len(), &f);
            let mut ids: HashMap<[u32; 2], u32> = HashMap::new();
            let mut edges = Vec::new();
            for (t, tri) in f.iter().enumerate() {
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    let key = [a.min(b), a.max(b)];
                    let id = *ids.entry(key).or_insert_with(|| {
                        edges.push(key);
                        edges.len() as u32 - 1
                    });
                    assert_eq!(topo.tri_edges[t][k], id);
                    assert!(topo.edge_tris.row(id as usize).contains(&(t as u32)));
                    assert!(topo.vertex_tris.row(a as usize).contains(&(t as u32)));
                }
            }
            assert_eq!(topo.edges, edges);
            for (t, tri) in f.iter().enumerate() {
                let first = |c: &Csr, r: u32| c.row(r as usize)[0] as usize == t;
                let want = (0..3)
                    .map(|k| {
                        (first(&topo.vertex_tris, tri[k]) as u8) << k
                            | (first(&topo.edge_tris, topo.tri_edges[t][k]) as u8) << (3 + k)
                    })
                    .sum::<u8>();
                assert_eq!(topo.owned[t], want, "triangle {t}");
            }
            for c in [&topo.edge_tris, &topo.vertex_tris] {
                assert!((0..c.rows()).all(|r| c.row(r).windows(2).all(|w| w[0] < w[1])));
            }
            assert_eq!(topo.edge_tris.items.len(), 3 * f.len());
            assert_eq!(topo.vertex_tris.items.len(), 3 * f.len());
        }
    }

    #[test]
    fn two_quads_and_a_bow_tie() {
        let v = vec![
            [0., 0., 0.],
            [1., 0., 0.],
            [1., 1., 0.],
            [0., 1., 0.],
            [5., 0., 0.],
            [6., 0., 0.],
            [5., 1., 0.],
            [7., 1., 0.],
            [7., 0., 0.],
        ];
        // Quad (0,1); lone triangle (2) and a triangle touching it at vertex 6 (3).
        let f = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [6, 7, 8]];
        let m = Mesh::new(v, f).unwrap();
        assert_eq!(m.triangle_components(), vec![0, 0, 1, 1]);
    }

    /// The adjacency against a search of every triangle for each edge, on
    /// meshes with borders, fins (edges in three or four triangles) and
    /// flipped triangles; a reordered mesh gets its own.
    #[test]
    fn adjacency_matches_a_search() {
        let (mut flipped, mut tangled_seen) = (0, 0);
        for seed in 0..6 {
            let (v, f) = tangled(seed);
            let m = Mesh::new(v, f.clone()).unwrap();
            let adj = m.adjacency();
            for (t, tri) in f.iter().enumerate() {
                let mut flags = 0;
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    let others: Vec<usize> = (0..f.len())
                        .filter(|&o| o != t && f[o].contains(&a) && f[o].contains(&b))
                        .collect();
                    let across = match others[..] {
                        [o] => {
                            let same = (0..3).any(|j| f[o][j] == a && f[o][(j + 1) % 3] == b);
                            flags |= (same as u8 * Adjacency::FLIPPED) << k;
                            o as u32
                        }
                        [] => t as u32,
                        _ => {
                            flags |= Adjacency::TANGLED;
                            t as u32
                        }
                    };
                    assert_eq!(
                        adj.across[t][k], across,
                        "seed {seed}, triangle {t}, edge {k}"
                    );
                }
                assert_eq!(adj.flags[t], flags, "seed {seed}, triangle {t}");
                flipped += (flags & !Adjacency::TANGLED != 0) as usize;
                tangled_seen += (flags & Adjacency::TANGLED != 0) as usize;
            }
            let order: Vec<u32> = (0..f.len() as u32).rev().collect();
            let r = m.reordered(&order);
            let back = |t: u32| order[t as usize];
            for (i, &t) in order.iter().enumerate() {
                let mapped = r.adjacency().across[i].map(back);
                assert_eq!(mapped, adj.across[t as usize]);
            }
        }
        assert!(flipped > 10 && tangled_seen > 5, "{flipped} {tangled_seen}");
    }

    /// Queries on one new mesh run as tasks of one pool, racing to compute
    /// its adjacency: every query gets the same answer, and the adjacency
    /// kept is the one computed alone. (The deadlock `Mesh::adjacency`
    /// avoids needs a thread to steal a query while it waits inside the
    /// computation; this test does not force that timing.)
    #[test]
    fn concurrent_queries_share_the_adjacency() {
        use rayon::prelude::*;
        let (v, f) = crate::scene::grid(160, 1.0);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        for _ in 0..4 {
            let mesh = Mesh::new(v.clone(), f.clone()).unwrap();
            let answers: Vec<_> = pool.install(|| {
                (0..8)
                    .into_par_iter()
                    .map(|_| crate::bvh::topdown::self_intersections(&mesh, mesh.rest()).0)
                    .collect()
            });
            assert!(answers.iter().all(|a| a.is_empty()));
            assert_eq!(mesh.adjacency(), &Adjacency::of(&mesh));
        }
    }

    #[test]
    fn fan_walk_agrees_with_union_find() {
        let (mut bowties, mut several) = (0, 0);
        for seed in 0..8 {
            let (v, f) = tangled(seed);
            let m = Mesh::new(v, f).unwrap();
            let bad = m.nonmanifold_triangles();
            for v in 0..m.n_vertices() as u32 {
                let fans = m.fans_at(v, &mut Vec::new());
                assert_eq!(m.one_fan_at(v), fans <= 1, "vertex {v}, seed {seed}");
                several += (fans > 1) as usize;
                for &t in m.topology().vertex_tris.row(v as usize) {
                    assert!(fans <= 1 || bad[t as usize]);
                }
            }
            let fin = m
                .topology()
                .edge_tris
                .offsets
                .windows(2)
                .any(|w| w[1] - w[0] > 2);
            bowties += fin as usize;
        }
        assert!(
            several > 8 && bowties == 8,
            "{several} several-fan vertices, {bowties} fins"
        );
    }

    #[test]
    fn the_first_bad_triangle_is_named() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for _ in 0..40 {
            let (v, mut f) = tangled(rng.gen());
            let n = v.len() as u32;
            for _ in 0..rng.gen_range(1..4) {
                let i = rng.gen_range(0..f.len());
                let j = rng.gen_range(0..f.len());
                f[j] = match rng.gen_range(0..3) {
                    0 => [f[i][1], f[i][2], f[i][0]],
                    1 => [f[i][0], n + 3, f[i][2]],
                    _ => [f[i][0], f[i][0], f[i][2]],
                };
            }
            let got = Mesh::new(v.clone(), f.clone()).err().map(|e| e.to_string());
            let want = first_error_reference(&f, v.len()).map(|e| e.to_string());
            assert_eq!(got, want);
        }
    }

    /// A duplicate whose earlier copy owns none of its edges (each edge has
    /// an earlier fin) is still found.
    #[test]
    fn a_duplicate_behind_fins_is_named() {
        let v = vec![[0.0; 3]; 6];
        let f = vec![
            [0, 1, 3],
            [1, 2, 4],
            [2, 0, 5],
            [0, 1, 2],
            [3, 4, 5],
            [1, 2, 0],
        ];
        let got = Mesh::new(v.clone(), f.clone()).err().map(|e| e.to_string());
        let want = first_error_reference(&f, v.len()).map(|e| e.to_string());
        assert_eq!(got, want);
        assert!(got.is_some_and(|e| e.contains('3') && e.contains('5')));
    }

    /// The first bad triangle in order, by the definition.
    fn first_error_reference(f: &[[u32; 3]], n: usize) -> Option<Error> {
        (0..f.len()).find_map(|i| {
            let t = f[i];
            let mut key = t;
            key.sort_unstable();
            if let Some(&bad) = t.iter().find(|&&v| v as usize >= n) {
                Some(Error::IndexOutOfRange {
                    triangle: i,
                    index: bad as u64,
                    vertex_count: n,
                })
            } else if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                Some(Error::RepeatedVertex {
                    triangle: i,
                    indices: t,
                })
            } else {
                (0..i)
                    .find(|&j| {
                        let mut k = f[j];
                        k.sort_unstable();
                        k == key
                    })
                    .map(|first| Error::DuplicateTriangle { first, second: i })
            }
        })
    }

    #[test]
    fn bad_inputs_are_named() {
        let (v, _) = quad();
        assert!(matches!(
            Mesh::new(vec![], vec![[0, 1, 2]]),
            Err(Error::EmptyMesh(_))
        ));
        assert!(matches!(
            Mesh::new(v.clone(), vec![]),
            Err(Error::EmptyMesh(_))
        ));
        assert!(matches!(
            Mesh::new(v.clone(), vec![[0, 1, 9]]),
            Err(Error::IndexOutOfRange { index: 9, .. })
        ));
        assert!(matches!(
            Mesh::new(v.clone(), vec![[0, 1, 1]]),
            Err(Error::RepeatedVertex { .. })
        ));
        assert!(matches!(
            Mesh::new(v.clone(), vec![[0, 1, 2], [2, 0, 1]]),
            Err(Error::DuplicateTriangle {
                first: 0,
                second: 1
            })
        ));
        let mut nan = v.clone();
        nan[2][1] = f64::NAN;
        assert!(matches!(
            Mesh::new(nan, vec![[0, 1, 2]]),
            Err(Error::NonFinite { vertex: 2, .. })
        ));
        // Zero-area triangles are valid: a segment, a point.
        let line = vec![[0., 0., 0.], [1., 1., 1.], [2., 2., 2.]];
        assert!(Mesh::new(line, vec![[0, 1, 2]]).is_ok());
        assert!(Mesh::new(vec![[1., 2., 3.]; 3], vec![[0, 1, 2]]).is_ok());
        let m = Mesh::new(v, vec![[0, 1, 2]]).unwrap();
        assert!(matches!(
            m.check_positions(&[DVec3::ZERO]),
            Err(Error::PositionsLength { .. })
        ));
    }

    /// `screened` gives `new`'s mesh and errors, and the weld screen's answer.
    #[test]
    fn screened_is_new_with_the_screen() {
        let (v, f) = tangled(3);
        let (m, repeats) = Mesh::screened(v.clone(), f.clone(), true).unwrap();
        let rest: Vec<DVec3> = v.iter().map(|&p| DVec3::from_array(p)).collect();
        assert_eq!(repeats, crate::weld::may_repeat_positions(&rest));
        assert!(!repeats && Mesh::screened(v.clone(), f.clone(), false).unwrap().1);
        assert_eq!(
            m.topology().edges,
            Mesh::new(v.clone(), f.clone()).unwrap().topology().edges
        );
        let mut twin = v.clone();
        twin[1] = twin[0];
        assert!(Mesh::screened(twin, f.clone(), true).unwrap().1);
        // A non-finite vertex is named before a bad triangle, as `new` does.
        let (mut nan, mut bad) = (v, f);
        nan[4][2] = f64::INFINITY;
        bad[7] = [0, 0, 1];
        let err = Mesh::screened(nan, bad, true).err().map(|e| e.to_string());
        assert_eq!(
            err,
            Some(
                Error::NonFinite {
                    vertex: 4,
                    value: f64::INFINITY
                }
                .to_string()
            )
        );
    }

    #[test]
    fn mean_edge_length_at_any_scale() {
        let (v, f) = quad();
        let unit = Mesh::new(v.clone(), f.clone()).unwrap().mean_edge_length();
        assert_eq!(unit, (4.0 + 2f64.sqrt()) / 5.0);
        for e in [-1000, -900, 600, 1000, 1022] {
            let s = 2f64.powi(e.max(-1000)) * 2f64.powi(e - e.max(-1000));
            let scaled = v.iter().map(|p| p.map(|x| x * s)).collect();
            let got = Mesh::new(scaled, f.clone()).unwrap().mean_edge_length();
            assert_eq!(got, unit * s, "2^{e}: bit for bit the unit mean, scaled");
        }
        // Corners at -MAX and +MAX: the edge exceeds f64, the mean saturates.
        let far = vec![[-f64::MAX, 0., 0.], [f64::MAX, 0., 0.], [0., 1., 0.]];
        let m = Mesh::new(far, vec![[0, 1, 2]]).unwrap().mean_edge_length();
        assert!(m.is_finite() && m > 0.6 * f64::MAX, "{m:e}");
    }
}
