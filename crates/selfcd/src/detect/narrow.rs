//! Narrow phase: what is tested on each candidate triangle pair.
//!
//! - [`Intersect`]: exact closed triangle-triangle test behind a floating-point
//!   filter, any finite scale, non-adjacent pairs only.
//! - [`Proximity`]: vertex-triangle and edge-edge pairs closer than a thickness
//!   `d`, skipping elements that share a vertex.

use crate::bvh::traverse::LeafVisitor;
use crate::error::{Error, Result};
use crate::geom::ccd::StencilKind;
use crate::geom::distance::HullCull;
use crate::geom::tri_tri::{plane_clearance, triangles_intersect_filtered, Decision};
use crate::geom::Aabb;
use crate::mesh::Mesh;
use crate::stats::Counters;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Exact intersection test of two triangles of one mesh.
pub struct Intersect<'a> {
    /// The mesh (triangles).
    pub mesh: &'a Mesh,
    /// Current vertex positions.
    pub positions: &'a [DVec3],
}

impl LeafVisitor for Intersect<'_> {
    type Item = [u32; 2];
    const SKIP_ADJACENT: bool = true;

    #[inline]
    fn visit(&self, a: u32, b: u32, adjacent: bool, out: &mut Vec<[u32; 2]>) {
        self.visit_counted(a, b, adjacent, out, &mut Counters::default());
    }

    #[inline]
    fn visit_counted(&self, a: u32, b: u32, _adj: bool, out: &mut Vec<[u32; 2]>, c: &mut Counters) {
        let ta = self.mesh.corners(self.positions, a as usize);
        let tb = self.mesh.corners(self.positions, b as usize);
        self.decide(a, b, (&ta, &tb), out, c);
    }

    /// The visit, then how far one triangle lies on one side of the other's
    /// plane ([`plane_clearance`]) when they do not meet.
    #[inline]
    fn visit_clear(&self, a: u32, b: u32, out: &mut Vec<[u32; 2]>, c: &mut Counters) -> f64 {
        let ta = self.mesh.corners(self.positions, a as usize);
        let tb = self.mesh.corners(self.positions, b as usize);
        if self.decide(a, b, (&ta, &tb), out, c) {
            0.0
        } else {
            plane_clearance(&ta, &tb)
        }
    }
}

impl Intersect<'_> {
    /// The filtered exact test of triangles `a` and `b` at corners `t`,
    /// counted; true (and the pair added to `out`) when they meet.
    #[inline]
    fn decide(
        &self,
        a: u32,
        b: u32,
        t: (&[DVec3; 3], &[DVec3; 3]),
        out: &mut Vec<[u32; 2]>,
        c: &mut Counters,
    ) -> bool {
        match triangles_intersect_filtered(t.0, t.1) {
            Decision::FilterApart => {
                c.filter_decisions += 1;
                false
            }
            d if d.intersect() => {
                out.push([a, b]);
                true
            }
            _ => false,
        }
    }
}

/// A vertex closer than the thickness to a triangle it is not part of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexTriangle {
    /// The vertex.
    pub vertex: u32,
    /// The triangle.
    pub triangle: u32,
    /// Distance from the vertex to the triangle.
    pub distance: f64,
    /// Barycentric weights of the closest point on the triangle.
    pub bary: [f64; 3],
}

/// Two edges (sharing no vertex) closer than the thickness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeEdge {
    /// Edge ids into the mesh topology, smaller first.
    pub edges: [u32; 2],
    /// Distance between the edges.
    pub distance: f64,
    /// Parameters of the closest points along each edge (from its smaller vertex).
    pub params: [f64; 2],
}

/// Proximity contacts of one frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ProximityContacts {
    /// Vertex-triangle pairs, sorted by (vertex, triangle).
    pub vertex_triangle: Vec<VertexTriangle>,
    /// Edge-edge pairs, sorted by edge ids.
    pub edge_edge: Vec<EdgeEdge>,
}

/// The order of vertex-triangle contacts.
fn vt_key(x: &VertexTriangle) -> (u32, u32) {
    (x.vertex, x.triangle)
}

/// The order of edge-edge contacts.
fn ee_key(x: &EdgeEdge) -> (u32, u32) {
    (x.edges[0], x.edges[1])
}

impl ProximityContacts {
    /// The vertex-triangle contacts' triangles mapped through `map` (a
    /// renumbering), sorted again; edge-edge contacts are unchanged.
    pub fn map_triangles(&mut self, map: &[u32]) {
        for x in &mut self.vertex_triangle {
            x.triangle = map[x.triangle as usize];
        }
        self.vertex_triangle.sort_unstable_by_key(vt_key);
    }

    /// Number of contacts of both kinds.
    pub fn len(&self) -> usize {
        self.vertex_triangle.len() + self.edge_edge.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The contacts of `self` and `other`, two sorted sets of different
    /// element pairs, as one sorted set (a linear merge per kind).
    pub fn merge(self, other: ProximityContacts) -> ProximityContacts {
        ProximityContacts {
            vertex_triangle: merge_sorted(self.vertex_triangle, other.vertex_triangle, vt_key),
            edge_edge: merge_sorted(self.edge_edge, other.edge_edge, ee_key),
        }
    }
}

/// Two lists sorted by `key` merged into one.
fn merge_sorted<T: Copy>(a: Vec<T>, b: Vec<T>, key: impl Fn(&T) -> (u32, u32)) -> Vec<T> {
    if a.is_empty() {
        return b;
    }
    if b.is_empty() {
        return a;
    }
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if key(&a[i]) < key(&b[j]) {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

/// One proximity contact found on a triangle pair (deduplicated afterwards).
#[derive(Debug, Clone, Copy)]
pub enum Near {
    /// Vertex near a triangle.
    Vt(VertexTriangle),
    /// Edge near an edge.
    Ee(EdgeEdge),
}

/// Default limit on the proximity contacts of one query (about 64 bytes each):
/// a thickness larger than the mesh makes the output grow as vertices x
/// triangles, and the query must fail clearly before memory runs out.
pub const DEFAULT_MAX_CONTACTS: usize = 20_000_000;

/// Err([`Error::InvalidParameter`]) unless `thickness` is a proximity
/// query's: positive and finite.
pub(crate) fn check_thickness(thickness: f64) -> Result<()> {
    if !(thickness > 0.0 && thickness.is_finite()) {
        return Err(Error::InvalidParameter(format!(
            "thickness must be positive and finite, got {thickness}"
        )));
    }
    Ok(())
}

/// Proximity test with thickness `d` between two triangles of one mesh.
pub struct Proximity<'a> {
    /// The mesh (triangles, edges).
    pub mesh: &'a Mesh,
    /// Current vertex positions.
    pub positions: &'a [DVec3],
    /// Thickness: report element pairs strictly closer than this.
    pub thickness: f64,
    /// The element-level cull for this thickness and these positions.
    hulls: HullCull,
    /// Most contacts collected; past it, visits stop and [`Proximity::check_output`] fails.
    pub max_contacts: usize,
    /// Contacts collected so far over all threads, counted in whole blocks
    /// of 256 as each task's output crosses them: at most the true count
    /// (the final check counts the output itself).
    pub found: AtomicUsize,
}

/// Contacts a task adds to a query's shared output guard at a time. Adding
/// at every triangle pair that found one made the two cores pass the
/// counter's cache line back and forth (BENCHMARKS.md, thirty-third
/// landing); in blocks the guard stays a lower bound of the true count,
/// short of it by under a block per output part, and the query's final
/// check counts the output itself.
pub(crate) const GUARD_BLOCK: usize = 256;

/// Adds to `found` the whole [`GUARD_BLOCK`]s that a visit's output
/// crossed, growing from `before` to `after` items.
#[inline]
pub(crate) fn guard_add(found: &AtomicUsize, before: usize, after: usize) {
    let blocks = after / GUARD_BLOCK - before / GUARD_BLOCK;
    if blocks > 0 {
        found.fetch_add(blocks * GUARD_BLOCK, Ordering::Relaxed);
    }
}

impl<'a> Proximity<'a> {
    /// The test with thickness `thickness`, collecting at most `max_contacts` contacts.
    pub fn new(
        mesh: &'a Mesh,
        positions: &'a [DVec3],
        thickness: f64,
        max_contacts: usize,
    ) -> Self {
        Proximity {
            mesh,
            positions,
            thickness,
            hulls: HullCull::new(thickness, positions),
            max_contacts,
            found: AtomicUsize::new(0),
        }
    }

    /// Err([`Error::TooManyContacts`]) when the query's output, `found`
    /// contacts in all, is over its limit (the visits then stopped early
    /// and it is incomplete).
    pub fn check_output(&self, found: usize) -> Result<()> {
        if found > self.max_contacts {
            return Err(Error::TooManyContacts {
                limit: self.max_contacts,
                thickness: self.thickness,
            });
        }
        Ok(())
    }

    /// The contact of `pair` when it is closer than the thickness (incident
    /// pairs never are). Every query path runs this same arithmetic (the
    /// hull cull, then `near_vt` or `near_ee`; [`for_each_owned_near`] culls
    /// as `hulls.apart` does), so cached and fresh queries give bit-identical
    /// contacts.
    pub(crate) fn test(&self, pair: ElementPair) -> Option<Near> {
        match pair {
            ElementPair::VertexTriangle(v, t) => self.vertex_triangle(v, t),
            ElementPair::EdgeEdge(ea, eb) => self.edge_edge(ea, eb),
        }
    }

    fn vertex_triangle(&self, v: u32, t: u32) -> Option<Near> {
        let tri = self.mesh.triangles()[t as usize];
        if tri.contains(&v) {
            return None;
        }
        let [a, b, c] = self.mesh.corners(self.positions, t as usize);
        let p = self.positions[v as usize];
        if self.hulls.apart(&[p], &[a, b, c]) {
            return None;
        }
        self.near_vt(v, t, &[p, a, b, c])
    }

    fn edge_edge(&self, e0: u32, e1: u32) -> Option<Near> {
        // Fixed argument order, so the same pair always gives the same numbers.
        let (e0, e1) = (e0.min(e1), e0.max(e1));
        let edges = &self.mesh.topology().edges;
        let ([a, b], [c, d]) = (edges[e0 as usize], edges[e1 as usize]);
        if a == c || a == d || b == c || b == d {
            return None;
        }
        let p = |i: u32| self.positions[i as usize];
        if self.hulls.apart(&[p(a), p(b)], &[p(c), p(d)]) {
            return None;
        }
        self.near_ee(e0, e1, &[p(a), p(b), p(c), p(d)])
    }

    /// The contact of vertex `v` and triangle `t` (stencil corners `c`: the
    /// vertex, then the triangle's) when closer than the thickness.
    #[inline]
    fn near_vt(&self, vertex: u32, triangle: u32, c: &[DVec3; 4]) -> Option<Near> {
        let within = self.hulls.closest_within(StencilKind::VertexTriangle, c);
        within.map(|(distance, bary)| {
            Near::Vt(VertexTriangle {
                vertex,
                triangle,
                distance,
                bary,
            })
        })
    }

    /// The contact of edges `e0 < e1` (stencil corners `c`, each edge's
    /// smaller vertex first) when closer than the thickness.
    #[inline]
    fn near_ee(&self, e0: u32, e1: u32, c: &[DVec3; 4]) -> Option<Near> {
        let within = self.hulls.closest_within(StencilKind::EdgeEdge, c);
        within.map(|(distance, [s, t, _])| {
            Near::Ee(EdgeEdge {
                edges: [e0, e1],
                distance,
                params: [s, t],
            })
        })
    }
}

impl LeafVisitor for Proximity<'_> {
    type Item = Near;
    const SKIP_ADJACENT: bool = false;

    fn visit(&self, a: u32, b: u32, _adjacent: bool, out: &mut Vec<Near>) {
        if self.found.load(Ordering::Relaxed) > self.max_contacts {
            return; // the output guard: the query fails in check_output
        }
        let before = out.len();
        let sink = Collect { near: self, out };
        for_each_owned_near(self.mesh, self.positions, &self.hulls, a, b, sink);
        guard_add(&self.found, before, out.len());
    }
}

/// [`Proximity`]'s sink: each element pair's contact, when closer than the
/// thickness, onto `out`.
struct Collect<'p, 'a> {
    near: &'p Proximity<'a>,
    out: &'p mut Vec<Near>,
}

impl NearSink for Collect<'_, '_> {
    #[inline(always)]
    fn vertex_triangle(&mut self, v: u32, t: u32, c: &[DVec3; 4]) {
        if let Some(near) = self.near.near_vt(v, t, c) {
            self.out.push(near);
        }
    }

    #[inline(always)]
    fn edge_edge(&mut self, e0: u32, e1: u32, c: &[DVec3; 4]) {
        if let Some(near) = self.near.near_ee(e0, e1, c) {
            self.out.push(near);
        }
    }
}

/// A pair of mesh elements that may touch: (vertex, triangle) or (edge, edge).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ElementPair {
    /// A vertex and a triangle.
    VertexTriangle(u32, u32),
    /// Two edges.
    EdgeEdge(u32, u32),
}

/// Calls `f` for the element pairs that
/// the triangle pair (a, b) owns, so that over all triangle pairs each element
/// pair comes up exactly once: a vertex is tested only from its first triangle,
/// an edge only from its first triangle (its *owner*). Complete for any query
/// whose leaf boxes contain the elements (proximity, swept boxes): a vertex near
/// triangle t lies in its owner's box, so the traversal visits (owner, t);
/// likewise for two edges. Incident pairs are passed on; the callee skips them.
pub fn for_each_owned_pair(mesh: &Mesh, a: u32, b: u32, mut f: impl FnMut(ElementPair)) {
    let topo = mesh.topology();
    let tris = mesh.triangles();
    let (a, b) = (a as usize, b as usize);
    let (oa, ob) = (topo.owned[a], topo.owned[b]);
    for (x, y, owned) in [(a, b, oa), (b, a, ob)] {
        for k in bits(owned) {
            f(ElementPair::VertexTriangle(tris[x][k], y as u32));
        }
    }
    for ka in bits(oa >> 3) {
        for kb in bits(ob >> 3) {
            f(ElementPair::EdgeEdge(
                topo.tri_edges[a][ka],
                topo.tri_edges[b][kb],
            ));
        }
    }
}

/// Where [`for_each_owned_near`] hands its element pairs, one method per
/// kind, each with its stencil's corners (in [`ElementPair::stencil`]'s
/// order). A closure of `(pair, kind, corners)` is one; a visitor on the
/// hot path implements it with methods inlined at each call site.
pub trait NearSink {
    /// Vertex `v` and triangle `t` (corners: the vertex, then the triangle's).
    fn vertex_triangle(&mut self, v: u32, t: u32, c: &[DVec3; 4]);
    /// Edges `e0 <= e1` (corners: each edge's smaller vertex first).
    fn edge_edge(&mut self, e0: u32, e1: u32, c: &[DVec3; 4]);
}

impl<F: FnMut(ElementPair, StencilKind, &[DVec3; 4])> NearSink for F {
    #[inline(always)]
    fn vertex_triangle(&mut self, v: u32, t: u32, c: &[DVec3; 4]) {
        self(
            ElementPair::VertexTriangle(v, t),
            StencilKind::VertexTriangle,
            c,
        )
    }

    #[inline(always)]
    fn edge_edge(&mut self, e0: u32, e1: u32, c: &[DVec3; 4]) {
        self(ElementPair::EdgeEdge(e0, e1), StencilKind::EdgeEdge, c)
    }
}

/// The owned element pairs of triangles `a` and `b` that share no vertex and
/// whose hulls at `x` the cull keeps, canonical, handed to `f` by kind with
/// their stencils' corners (in [`ElementPair::stencil`]'s order): exactly what
/// [`for_each_owned_pair`] followed by `canonical`, `stencil` and
/// [`HullCull::apart`] gives, in the same order, with each corner read and
/// each box fitted once per triangle pair instead of once per element pair.
pub fn for_each_owned_near(
    mesh: &Mesh,
    x: &[DVec3],
    hulls: &HullCull,
    a: u32,
    b: u32,
    mut f: impl NearSink,
) {
    let topo = mesh.topology();
    let (oa, ob) = (topo.owned[a as usize], topo.owned[b as usize]);
    if (oa | ob) == 0 {
        return;
    }
    let tris = mesh.triangles();
    let (ta, tb) = (&tris[a as usize], &tris[b as usize]);
    // Built in place ([`Mesh::corners`]): `array::map` builds a temporary
    // and copies it in 16-byte moves across the 24-byte corners, whose
    // reads then stall on store forwarding (5% of the one-shot on a
    // crumpled cloth; BENCHMARKS.md).
    let (pa, pb) = (mesh.corners(x, a as usize), mesh.corners(x, b as usize));
    owned_vertices_near(hulls, (ta, &pa, oa), (tb, &pb, b), &mut f);
    owned_vertices_near(hulls, (tb, &pb, ob), (ta, &pa, a), &mut f);
    if oa & 0o70 == 0 || ob & 0o70 == 0 {
        return;
    }
    let (ea, eb) = (&topo.tri_edges[a as usize], &topo.tri_edges[b as usize]);
    for ka in bits(oa >> 3) {
        let (va, xa) = edge_of(ta, &pa, ka);
        let hull = Aabb::from_points(&xa);
        for kb in bits(ob >> 3) {
            let (vb, xb) = edge_of(tb, &pb, kb);
            let shared = va[0] == vb[0] || va[0] == vb[1] || va[1] == vb[0] || va[1] == vb[1];
            if shared || hulls.boxes_apart(&hull, &Aabb::from_points(&xb)) {
                continue;
            }
            let (e0, e1) = (ea[ka], eb[kb]);
            if e0 <= e1 {
                f.edge_edge(e0, e1, &[xa[0], xa[1], xb[0], xb[1]]);
            } else {
                f.edge_edge(e1, e0, &[xb[0], xb[1], xa[0], xa[1]]);
            }
        }
    }
}

/// The vertex-triangle part of [`for_each_owned_near`]: the vertices of
/// triangle `tv` (corners `pv`) that it owns, against triangle `t`.
#[inline(always)]
fn owned_vertices_near(
    hulls: &HullCull,
    (tv, pv, owned): (&[u32; 3], &[DVec3; 3], u8),
    (tt, pt, t): (&[u32; 3], &[DVec3; 3], u32),
    f: &mut impl NearSink,
) {
    if owned & 7 == 0 {
        return;
    }
    let hull = Aabb::from_points(pt);
    for k in bits(owned) {
        if !tt.contains(&tv[k]) && !hulls.boxes_apart(&Aabb::from_points(&[pv[k]]), &hull) {
            f.vertex_triangle(tv[k], t, &[pv[k], pt[0], pt[1], pt[2]]);
        }
    }
}

/// The indices k < 3 of the set bits of `mask & 7` (a triangle's owned
/// vertices, or its edges after a shift by 3), in increasing order.
#[inline(always)]
fn bits(mask: u8) -> impl Iterator<Item = usize> {
    crate::bits::set_bits(u64::from(mask & 7))
}

/// Edge `k` (corners k, k + 1) of a triangle with corners `p`, as the
/// topology stores it: smaller vertex first.
#[inline(always)]
fn edge_of(t: &[u32; 3], p: &[DVec3; 3], k: usize) -> ([u32; 2], [DVec3; 2]) {
    let (i, j) = (k, (k + 1) % 3);
    if t[i] < t[j] {
        ([t[i], t[j]], [p[i], p[j]])
    } else {
        ([t[j], t[i]], [p[j], p[i]])
    }
}

impl ElementPair {
    /// The pair with its edges in increasing order (vertex-triangle pairs unchanged):
    /// the one spelling every query reports.
    #[inline]
    pub fn canonical(self) -> ElementPair {
        match self {
            ElementPair::EdgeEdge(a, b) => ElementPair::EdgeEdge(a.min(b), a.max(b)),
            vt => vt,
        }
    }

    /// The triangle pair whose visit reports this element pair (see
    /// [`for_each_owned_pair`]): the vertex's or each edge's owner triangle,
    /// and for a vertex the triangle itself.
    #[inline]
    pub fn visiting_triangles(self, mesh: &Mesh) -> [u32; 2] {
        let topo = mesh.topology();
        match self {
            ElementPair::VertexTriangle(v, t) => [topo.vertex_tris.row(v as usize)[0], t],
            ElementPair::EdgeEdge(a, b) => [
                topo.edge_tris.row(a as usize)[0],
                topo.edge_tris.row(b as usize)[0],
            ],
        }
    }

    /// The pair as a stencil: its kind and four vertex ids, (v, t0, t1, t2)
    /// or (a, b, c, d) for edges a-b and c-d in the pair's order; `None` when
    /// the elements share a vertex (incident pairs are never contacts).
    #[inline]
    pub fn stencil(self, mesh: &Mesh) -> Option<(StencilKind, [u32; 4])> {
        match self {
            ElementPair::VertexTriangle(v, t) => {
                let tri = mesh.triangles()[t as usize];
                (!tri.contains(&v))
                    .then_some((StencilKind::VertexTriangle, [v, tri[0], tri[1], tri[2]]))
            }
            ElementPair::EdgeEdge(e0, e1) => {
                let edges = &mesh.topology().edges;
                let ([a, b], [c, d]) = (edges[e0 as usize], edges[e1 as usize]);
                (a != c && a != d && b != c && b != d)
                    .then_some((StencilKind::EdgeEdge, [a, b, c, d]))
            }
        }
    }

    /// The distance of the two elements at `x` when they share no vertex and
    /// are closer than `hulls.gap` (a cull made for `x`), else `None`.
    pub fn distance_within(self, mesh: &Mesh, x: &[DVec3], hulls: &HullCull) -> Option<f64> {
        let (kind, ids) = self.stencil(mesh)?;
        let corners = ids.map(|i| x[i as usize]);
        let (first, second) = corners.split_at(kind.split());
        if hulls.apart(first, second) {
            return None;
        }
        hulls.closest_within(kind, &corners).map(|(d, _)| d)
    }
}

/// Sorts raw proximity contacts (each element pair is reported once, by its
/// owners, so the keys are unique and the order does not depend on the threads).
pub fn collect_proximity(items: Vec<Near>) -> ProximityContacts {
    collect_proximity_parts(vec![items])
}

/// [`collect_proximity`] of the contacts in `parts`, each part read once
/// and freed as soon as it is.
pub fn collect_proximity_parts(parts: Vec<Vec<Near>>) -> ProximityContacts {
    let count = |p: &Vec<Near>| p.iter().filter(|x| matches!(x, Near::Vt(_))).count();
    let n_vt: usize = parts.par_iter().map(count).sum();
    let n: usize = parts.iter().map(Vec::len).sum();
    let (mut vt, mut ee) = (Vec::with_capacity(n_vt), Vec::with_capacity(n - n_vt));
    for part in parts {
        for it in part {
            match it {
                Near::Vt(x) => vt.push(x),
                Near::Ee(x) => ee.push(x),
            }
        }
    }
    let (vertex_triangle, edge_edge) =
        rayon::join(|| sorted_by_key(vt, vt_key), || sorted_by_key(ee, ee_key));
    ProximityContacts {
        vertex_triangle,
        edge_edge,
    }
}

/// `items` in increasing order of their unique `key` (first, second): a
/// counting sort on `first` (a vertex or edge id, so the buckets number at
/// most the mesh's elements) of `second` and the item's place packed in one
/// integer, each bucket (a few items) sorted, then the items gathered in that
/// order (each copied once). O(items + largest first id), against a
/// comparison sort's log factor.
pub(crate) fn sorted_by_key<T: Copy + Send + Sync>(
    items: Vec<T>,
    key: impl Fn(&T) -> (u32, u32) + Sync,
) -> Vec<T> {
    let Some(max) = items.iter().map(|x| key(x).0).max() else {
        return items;
    };
    let mut start = vec![0u32; max as usize + 2];
    for x in &items {
        start[key(x).0 as usize + 1] += 1;
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut fill = start.clone();
    let mut order = vec![0u64; items.len()];
    for (i, x) in items.iter().enumerate() {
        let (first, second) = key(x);
        let slot = &mut fill[first as usize];
        order[*slot as usize] = (second as u64) << 32 | i as u64;
        *slot += 1;
    }
    for w in start.windows(2) {
        order[w[0] as usize..w[1] as usize].sort_unstable();
    }
    order
        .par_iter()
        .map(|&o| items[o as u32 as usize])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{seq::SliceRandom, Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The per-triangle-pair kernel gives exactly the pairs, in the order,
    /// and with the corners of the per-element path, incident and culled
    /// pairs included, on a crumpled sheet at several gaps (every triangle
    /// pair, so pairs far apart and sharing vertices are both covered).
    #[test]
    fn owned_near_is_owned_pairs_stencils_and_hull_cull() {
        let mesh = crate::sensor::testing::crumpled_rest(9);
        let x = mesh.rest().to_vec();
        let n = mesh.n_triangles() as u32;
        for gap in [0.0, 0.02, 0.1, 0.5, f64::INFINITY] {
            let hulls = HullCull::new(gap, &x);
            let (mut kept, mut culled) = (0, 0);
            for a in 0..n {
                for b in (a + 1)..n {
                    let mut slow = Vec::new();
                    for_each_owned_pair(&mesh, a, b, |p| {
                        let p = p.canonical();
                        let Some((kind, ids)) = p.stencil(&mesh) else {
                            return;
                        };
                        let c = ids.map(|i| x[i as usize]);
                        let (first, second) = c.split_at(kind.split());
                        if hulls.apart(first, second) {
                            culled += 1;
                        } else {
                            slow.push((p, kind, c));
                        }
                    });
                    let mut fast = Vec::new();
                    for_each_owned_near(&mesh, &x, &hulls, a, b, |p, kind, c: &_| {
                        fast.push((p, kind, *c))
                    });
                    kept += slow.len();
                    assert_eq!(fast, slow, "triangles {a} and {b}, gap {gap}");
                }
            }
            assert!(kept > 0 && (gap.is_infinite() || culled > 0), "gap {gap}");
        }
    }

    fn vt(vertex: u32, triangle: u32) -> Near {
        Near::Vt(VertexTriangle {
            vertex,
            triangle,
            distance: 0.5,
            bary: [1.0, 0.0, 0.0],
        })
    }

    fn ee(a: u32, b: u32) -> Near {
        Near::Ee(EdgeEdge {
            edges: [a, b],
            distance: 0.25,
            params: [0.5, 0.5],
        })
    }

    /// Unique random contacts of both kinds, in random order.
    fn contacts(n: usize, seed: u64) -> Vec<Near> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut keys: Vec<(bool, u32, u32)> = (0..n)
            .map(|_| (rng.gen(), rng.gen_range(0..50), rng.gen_range(0..50)))
            .collect();
        keys.sort_unstable();
        keys.dedup();
        keys.shuffle(&mut rng);
        keys.into_iter()
            .map(|(kind, a, b)| if kind { vt(a, b) } else { ee(a, b) })
            .collect()
    }

    /// The contacts' keys, vertex-triangle ones first (tagged 0) then edge-edge.
    fn keys(c: &ProximityContacts) -> Vec<(u8, u32, u32)> {
        let vt = c.vertex_triangle.iter().map(vt_key).map(|(a, b)| (0, a, b));
        vt.chain(c.edge_edge.iter().map(ee_key).map(|(a, b)| (1, a, b)))
            .collect()
    }

    #[test]
    fn collected_contacts_are_sorted_by_kind_and_ids() {
        let items = contacts(2000, 1);
        let n = items.len();
        let c = collect_proximity(items);
        assert_eq!(c.len(), n);
        assert!(keys(&c).windows(2).all(|w| w[0] < w[1]));
        assert!(collect_proximity(Vec::new()).is_empty());
    }

    #[test]
    fn merging_two_sorted_sets_sorts_their_union() {
        for seed in 0..4 {
            let mut items = contacts(1500, 10 + seed);
            let all = collect_proximity(items.clone());
            let cut = items.len() / (2 + seed as usize);
            let rest = items.split_off(cut);
            let merged = collect_proximity(items).merge(collect_proximity(rest));
            assert_eq!(keys(&merged), keys(&all), "seed {seed}");
        }
        let one = collect_proximity(contacts(100, 7));
        assert_eq!(
            keys(&one.clone().merge(ProximityContacts::default())),
            keys(&one)
        );
        assert_eq!(
            keys(&ProximityContacts::default().merge(one.clone())),
            keys(&one)
        );
    }
}
