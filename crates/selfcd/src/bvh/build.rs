//! Bottom-up construction (paper 3.2), once, on the rest mesh.
//!
//! Level by level, nodes are paired greedily so that the merged box is
//! smallest, as in the paper (computed in parallel as locally dominant edges,
//! see `Level::matching`); we measure boxes by *surface area*, not volume,
//! because a flat cloth's boxes all have zero volume. Only nodes whose patches
//! share an edge are paired, so every node is a connected patch of surface
//! (the cone and contour tests need that). When no two remaining nodes share
//! an edge (separate components), they are paired in spatial order.
//!
//! Everything is parallel within a level and O(n) over the whole build: the
//! nodes' adjacency is coarsened row by row (no global sort), and each
//! parent's patch comes from its children's sorted lists by linear merges
//! (see `union`); boxes and cones are fitted as the parents are made, so no
//! refit follows. The result does not depend on the number of threads.

use super::patch::{
    leaf_boundary, leaf_contour, merge_contours_with, sort_up_to_three, unpack, Patches, Row,
    INELIGIBLE, SEVERAL,
};
use super::Bvh;
use crate::geom::{Aabb, NormalCone};
use crate::mesh::{Csr, Mesh};
use rayon::prelude::*;

/// Builds the hierarchy of `mesh` on its rest shape, with boxes and cones fitted to it.
pub fn build(mesh: &Mesh) -> Bvh {
    let n = mesh.n_triangles();
    let rest = mesh.rest();
    // Room for every node from the start: growing past the leaves would
    // copy them into freshly faulted memory.
    let nodes = (2 * n).saturating_sub(1);
    let (mut boxes, mut cones) = (Vec::with_capacity(nodes), Vec::with_capacity(nodes));
    (0..n)
        .into_par_iter()
        .map(|t| {
            let c = mesh.corners(rest, t);
            (
                Aabb::from_points(&c),
                NormalCone::of_triangle(c[0], c[1], c[2]),
            )
        })
        .unzip_into_vecs(&mut boxes, &mut cones);
    // The leaves' component tags (a serial union-find) alongside the leaves' patches.
    let ((mut patches, mut level), leaf_tags) = rayon::join(
        || rayon::join(|| PatchBuilder::leaves(mesh), || Level::leaves(mesh)),
        || leaf_component_tags(mesh),
    );
    let mut children: Vec<[u32; 2]> = Vec::with_capacity(n.saturating_sub(1));
    let mut levels = Vec::new();
    while level.nodes.len() > 1 {
        let mate = level.matching(&boxes);
        let mut pairs = level.pairs(&mate);
        let mate = if pairs.is_empty() {
            let mate = spatial_mates(&level.nodes, &boxes);
            pairs = level.pairs(&mate);
            mate
        } else {
            mate
        };
        let first = (n + children.len()) as u32;
        fit_parents(&mut boxes, &mut cones, &pairs);
        patches.push_level(mesh, &pairs);
        children.extend(pairs.iter().map(|&(a, b)| [a, b]));
        levels.push(first..first + pairs.len() as u32);
        level = level.coarsen(&mate, first);
    }
    let component = component_tags(leaf_tags, &children);
    Bvh {
        n_leaves: n,
        children,
        levels,
        boxes,
        cones,
        slabs: Vec::new(),
        patches: patches.finish(component),
        spans: Vec::new(),
        cones_fit: super::refit::ConeFit::All,
    }
}

/// Appends the box and cone of every parent of `pairs` (children already
/// fitted), written in place into the room reserved for every node (no
/// temporary list, no copy).
fn fit_parents(boxes: &mut Vec<Aabb>, cones: &mut Vec<NormalCone>, pairs: &[(u32, u32)]) {
    let first = boxes.len();
    boxes.resize(first + pairs.len(), Aabb::EMPTY);
    cones.resize(first + pairs.len(), NormalCone::FULL);
    let (children, parents) = boxes.split_at_mut(first);
    let (child_cones, parent_cones) = cones.split_at_mut(first);
    (parents.par_iter_mut().zip(parent_cones))
        .zip(pairs)
        .for_each(|((b, c), &(l, r))| {
            let (l, r) = (l as usize, r as usize);
            *b = children[l].union(&children[r]);
            *c = child_cones[l].merge(&child_cones[r]);
        });
}

/// Component tag of every leaf (see [`Patches::component`]), from the mesh's
/// vertex-connected components.
fn leaf_component_tags(mesh: &Mesh) -> Vec<u8> {
    mesh.triangle_components()
        .into_iter()
        .map(|c| (c % SEVERAL as u32) as u8)
        .collect()
}

/// Component tag of every node, from the leaves' `tags`: each parent's from
/// its children (children have smaller ids, so one pass in id order).
fn component_tags(mut tags: Vec<u8>, children: &[[u32; 2]]) -> Vec<u8> {
    tags.reserve_exact(children.len());
    for &[l, r] in children {
        let (a, b) = (tags[l as usize], tags[r as usize]);
        tags.push(if a == b { a } else { SEVERAL });
    }
    tags
}

/// Marks a node without a partner.
const NONE: u32 = u32::MAX;

/// The nodes still to be paired and which of them share an edge.
struct Level {
    /// Node ids, increasing.
    nodes: Vec<u32>,
    /// Row i: the places in `nodes` of the nodes sharing an edge with `nodes[i]`.
    adjacency: Csr,
}

impl Level {
    /// The leaves, adjacent when their triangles share an edge.
    fn leaves(mesh: &Mesh) -> Level {
        let topo = mesh.topology();
        let adjacency = par_rows(mesh.n_triangles(), |t, row| {
            for &e in &topo.tri_edges[t] {
                let others = topo.edge_tris.row(e as usize).iter();
                row.extend(others.filter(|&&u| u as usize != t));
            }
            // Two triangles share at most one edge (else they would be
            // duplicates, which `Mesh::new` refuses), so no neighbour repeats;
            // a row longer than three (a non-manifold edge) is deduplicated
            // all the same. Most rows have three entries or fewer: three
            // compare-exchanges sort them.
            match row.len() {
                0..=3 => sort_up_to_three(row),
                _ => {
                    row.sort_unstable();
                    row.dedup();
                }
            }
        });
        Level {
            nodes: (0..mesh.n_triangles() as u32).collect(),
            adjacency,
        }
    }

    /// Greedy matching of adjacent nodes in order of merged box surface area
    /// (ties by ids), computed as locally dominant edges: an edge that is the
    /// best of both its endpoints is in the greedy matching, so matching those,
    /// dropping their endpoints and repeating gives the greedy result with no
    /// global sort. A node's best only changes when its best partner is taken,
    /// so later rounds revisit only those. Rounds stop after [`ROUNDS`] (a long
    /// chain of ever larger merges would otherwise take one round per edge);
    /// nodes left unmatched wait for the next level.
    /// Returns each place's partner place, or [`NONE`].
    fn matching(&self, boxes: &[Aabb]) -> Vec<u32> {
        let m = self.nodes.len();
        let mut mate = vec![NONE; m];
        let mut best: Vec<u32> = (0..m)
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|i| self.best_partner(i, &mate, boxes))
            .collect();
        // Unmatched places that still have a candidate.
        let mut open: Vec<u32> = Vec::with_capacity(m);
        open.extend((0..m as u32).filter(|&i| best[i as usize] != NONE));
        for round in 0..ROUNDS {
            if round > 0 {
                let fresh: Vec<u32> = open
                    .par_iter()
                    .with_min_len(CHUNK)
                    .map(|&i| match best[i as usize] {
                        b if mate[b as usize] == NONE => b,
                        _ => self.best_partner(i as usize, &mate, boxes),
                    })
                    .collect();
                for (&i, b) in open.iter().zip(fresh) {
                    best[i as usize] = b;
                }
                open.retain(|&i| best[i as usize] != NONE);
            }
            let mut matched = false;
            for &i in &open {
                let b = best[i as usize];
                if best[b as usize] == i {
                    mate[i as usize] = b;
                    matched = true;
                }
            }
            if !matched {
                break;
            }
            open.retain(|&i| mate[i as usize] == NONE);
        }
        mate
    }

    /// The unmatched neighbour of place `i` whose merged box is smallest.
    fn best_partner(&self, i: usize, mate: &[u32], boxes: &[Aabb]) -> u32 {
        let own = &boxes[self.nodes[i] as usize];
        let mut best = (f64::INFINITY, NONE);
        for &j in self.adjacency.row(i) {
            if mate[j as usize] != NONE {
                continue;
            }
            // The union with the smaller id first, so that it is the same
            // number from either side (min and max may differ on signed zeros).
            let other = &boxes[self.nodes[j as usize] as usize];
            let merged = if (j as usize) < i {
                other.union(own)
            } else {
                own.union(other)
            };
            let area = merged.surface_area();
            // With `i` common to both candidates, the ids' pair orders as `j`.
            if best.1 == NONE || area.total_cmp(&best.0).then(j.cmp(&best.1)).is_lt() {
                best = (area, j);
            }
        }
        best.1
    }

    /// The matched node pairs `(a, b)`, a < b, in increasing order of `a`.
    fn pairs(&self, mate: &[u32]) -> Vec<(u32, u32)> {
        (0..mate.len())
            .filter(|&i| (i as u32) < mate[i] && mate[i] != NONE)
            .map(|i| (self.nodes[i], self.nodes[mate[i] as usize]))
            .collect()
    }

    /// The next level: unmatched nodes (kept, in order), then the parents of
    /// the pairs (ids from `first`, in the order of [`pairs`](Self::pairs)),
    /// adjacent when any of their children were.
    fn coarsen(&self, mate: &[u32], first: u32) -> Level {
        let m = self.nodes.len();
        let kept = mate.iter().filter(|&&x| x == NONE).count() as u32;
        // New place of every old place; `members[q]` lists the old places of q.
        let mut place = vec![0u32; m];
        let mut members = vec![[NONE; 2]; m - (m - kept as usize) / 2];
        let (mut k, mut p) = (0u32, kept);
        for i in 0..m {
            if mate[i] == NONE {
                place[i] = k;
                members[k as usize] = [i as u32, NONE];
                k += 1;
            } else if (i as u32) < mate[i] {
                place[i] = p;
                place[mate[i] as usize] = p;
                members[p as usize] = [i as u32, mate[i]];
                p += 1;
            }
        }
        let nodes = members
            .iter()
            .enumerate()
            .map(|(q, &[i, _])| {
                if (q as u32) < kept {
                    self.nodes[i as usize]
                } else {
                    first + q as u32 - kept
                }
            })
            .collect();
        let adjacency = par_rows(members.len(), |q, row| {
            for &i in members[q].iter().filter(|&&i| i != NONE) {
                let near = self.adjacency.row(i as usize).iter();
                row.extend(near.map(|&j| place[j as usize]).filter(|&x| x != q as u32));
            }
            row.sort_unstable();
            row.dedup();
        });
        Level { nodes, adjacency }
    }
}

/// Rounds of locally dominant matching per level.
const ROUNDS: usize = 8;

/// Partners for nodes with no shared edges (separate components): in order
/// along the longest axis of their joint box, consecutive ones; an odd one out
/// waits for the next level.
fn spatial_mates(nodes: &[u32], boxes: &[Aabb]) -> Vec<u32> {
    let all = nodes
        .iter()
        .fold(Aabb::EMPTY, |b, &a| b.union(&boxes[a as usize]));
    let ext = all.max - all.min;
    let k = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mut order: Vec<u32> = (0..nodes.len() as u32).collect();
    order.sort_by(|&a, &b| {
        let c = |i: u32| boxes[nodes[i as usize] as usize].center()[k];
        c(a).total_cmp(&c(b)).then(a.cmp(&b))
    });
    let mut mate = vec![NONE; nodes.len()];
    for p in order.chunks_exact(2) {
        mate[p[0] as usize] = p[1];
        mate[p[1] as usize] = p[0];
    }
    mate
}

/// Rows filled in parallel by `fill(row, out)` (which appends to `out`),
/// gathered into one [`Csr`]. Rows are filled in fixed chunks, so the result
/// does not depend on the number of threads.
fn par_rows(rows: usize, fill: impl Fn(usize, &mut Vec<u32>) + Sync) -> Csr {
    let parts: Vec<(Vec<u32>, Vec<u32>)> = (0..rows.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            // Room for rows of up to 8 on average (leaves have 3, coarser
            // nodes rarely more), so that a chunk seldom regrows.
            let (mut items, mut ends) = (Vec::with_capacity(8 * CHUNK), Vec::with_capacity(CHUNK));
            let mut row = Vec::new();
            for r in c * CHUNK..((c + 1) * CHUNK).min(rows) {
                row.clear();
                fill(r, &mut row);
                items.extend_from_slice(&row);
                ends.push(items.len() as u32);
            }
            (items, ends)
        })
        .collect();
    let mut csr = Csr {
        offsets: Vec::with_capacity(rows + 1),
        items: Vec::with_capacity(parts.iter().map(|p| p.0.len()).sum()),
    };
    csr.offsets.push(0);
    for (items, ends) in parts {
        let base = csr.items.len() as u32;
        csr.offsets.extend(ends.iter().map(|&e| base + e));
        csr.items.extend_from_slice(&items);
    }
    csr
}

/// Rows per parallel task.
const CHUNK: usize = 1024;

/// Growing per-node patch data while building: [`Patches`] plus, for every
/// boundary vertex, its number of contour edges (what makes a union's
/// boundary a linear merge). Leaves' lists are computed, not stored (see
/// [`Patches`]); `contour`, `boundary` and `degree` hold the internal nodes'.
struct PatchBuilder {
    n_leaves: usize,
    contour: Csr,
    boundary: Csr,
    /// Contour edges at each boundary vertex, aligned with `boundary.items`.
    degree: Vec<u32>,
    euler: Vec<i32>,
    eligible: Vec<bool>,
    /// The parallel tasks' outputs, kept from level to level so that each
    /// level writes into memory the previous one already touched.
    parts: Vec<PatchOut>,
}

/// One chunk of nodes' patches, as computed in a parallel task.
#[derive(Default)]
struct PatchOut {
    contour: Vec<u32>,
    contour_ends: Vec<u32>,
    boundary: Vec<u32>,
    degree: Vec<u32>,
    boundary_ends: Vec<u32>,
    euler: Vec<i32>,
    eligible: Vec<bool>,
}

impl PatchOut {
    /// Empties every list, with room for `nodes` nodes holding at most
    /// `contour` contour edges and `boundary` boundary vertices in all.
    fn clear_for(&mut self, nodes: usize, contour: usize, boundary: usize) {
        room(&mut self.contour, contour);
        room(&mut self.contour_ends, nodes);
        room(&mut self.boundary, boundary);
        room(&mut self.degree, boundary);
        room(&mut self.boundary_ends, nodes);
        room(&mut self.euler, nodes);
        room(&mut self.eligible, nodes);
    }
}

/// Empties `v` with room for `n` items: its memory when large enough, else
/// a new buffer (growing it would copy the stale items first).
fn room<T>(v: &mut Vec<T>, n: usize) {
    v.clear();
    if v.capacity() < n {
        *v = Vec::with_capacity(n);
    }
}

impl PatchBuilder {
    /// The leaves: each triangle's three directed edges and three corners
    /// (two contour edges at each, [`LEAF_DEGREE`]), Euler characteristic 1.
    fn leaves(mesh: &Mesh) -> PatchBuilder {
        let n = mesh.n_triangles();
        // Room for every internal node from the start: about three times
        // the leaves' lists in all for patches that grow like disks (1.6 M
        // entries at the 200k grid), so that the levels append without
        // reallocating and nothing is copied into a larger buffer.
        let empty = || {
            let mut offsets = Vec::with_capacity(n + 1);
            offsets.push(0);
            Csr {
                offsets,
                items: Vec::with_capacity(3 * 3 * n),
            }
        };
        let mut euler = Vec::with_capacity(2 * n);
        euler.resize(n, 1);
        let mut eligible = Vec::with_capacity(2 * n);
        eligible.extend(mesh.nonmanifold_triangles().iter().map(|&x| !x));
        PatchBuilder {
            n_leaves: n,
            contour: empty(),
            boundary: empty(),
            degree: Vec::with_capacity(3 * 3 * n),
            euler,
            eligible,
            parts: Vec::new(),
        }
    }

    /// Node `n`'s lists, computed for a leaf of `mesh`.
    fn side<'a>(&'a self, mesh: &Mesh, n: usize) -> Side<'a> {
        let Some(i) = n.checked_sub(self.n_leaves) else {
            return Side {
                contour: Row::Leaf(leaf_contour(mesh, n as u32)),
                boundary: Row::Leaf(leaf_boundary(mesh, n as u32)),
                degree: &LEAF_DEGREE,
            };
        };
        let (lo, hi) = (self.boundary.offsets[i], self.boundary.offsets[i + 1]);
        Side {
            contour: Row::Stored(self.contour.row(i)),
            boundary: Row::Stored(self.boundary.row(i)),
            degree: &self.degree[lo as usize..hi as usize],
        }
    }

    /// Lengths of node `n`'s contour and boundary.
    fn lens(&self, n: usize) -> (usize, usize) {
        let Some(i) = n.checked_sub(self.n_leaves) else {
            return (3, 3);
        };
        let len = |c: &Csr| (c.offsets[i + 1] - c.offsets[i]) as usize;
        (len(&self.contour), len(&self.boundary))
    }

    /// Appends the patches of the unions of `pairs` (disjoint nodes), in order.
    fn push_level(&mut self, mesh: &Mesh, pairs: &[(u32, u32)]) {
        let mut parts = std::mem::take(&mut self.parts);
        let chunks = pairs.len().div_ceil(CHUNK);
        if parts.len() < chunks {
            parts.resize_with(chunks, PatchOut::default);
        }
        let this = &*self;
        (parts[..chunks].par_iter_mut())
            .zip(pairs.par_chunks(CHUNK))
            .for_each(|(out, chunk)| {
                let (mut nc, mut nb) = (0, 0);
                for &(l, r) in chunk {
                    let ((cl, bl), (cr, br)) = (this.lens(l as usize), this.lens(r as usize));
                    nc += cl + cr;
                    nb += bl + br;
                }
                out.clear_for(chunk.len(), nc, nb);
                let mut shared = Vec::new();
                for &(l, r) in chunk {
                    this.union(mesh, l as usize, r as usize, out, &mut shared);
                }
            });
        for p in &parts[..chunks] {
            let base = self.contour.items.len() as u32;
            let ends = p.contour_ends.iter().map(|&e| base + e);
            self.contour.offsets.extend(ends);
            self.contour.items.extend_from_slice(&p.contour);
            let base = self.boundary.items.len() as u32;
            let ends = p.boundary_ends.iter().map(|&e| base + e);
            self.boundary.offsets.extend(ends);
            self.boundary.items.extend_from_slice(&p.boundary);
            self.degree.extend_from_slice(&p.degree);
            self.euler.extend_from_slice(&p.euler);
            self.eligible.extend_from_slice(&p.eligible);
        }
        self.parts = parts;
    }

    /// Appends the patch of the union of disjoint nodes `l` and `r` to `out`;
    /// see [`union`].
    fn union(&self, mesh: &Mesh, l: usize, r: usize, out: &mut PatchOut, shared: &mut Vec<u32>) {
        let (a, b) = (self.side(mesh, l), self.side(mesh, r));
        let u = union(mesh, &a, &b, out, shared);
        out.contour_ends.push(out.contour.len() as u32);
        out.boundary_ends.push(out.boundary.len() as u32);
        out.euler
            .push(self.euler[l] + self.euler[r] - u.vertices as i32 + u.edges as i32);
        out.eligible
            .push(self.eligible[l] && self.eligible[r] && !u.conflict);
    }

    /// The finished patches, ineligible nodes marked in `euler`, with the
    /// nodes' component tags.
    fn finish(mut self, component: Vec<u8>) -> Patches {
        for c in [&mut self.contour, &mut self.boundary] {
            c.offsets.shrink_to_fit();
            c.items.shrink_to_fit();
        }
        for (e, &ok) in self.euler.iter_mut().zip(&self.eligible) {
            if !ok {
                *e = INELIGIBLE;
            }
        }
        Patches {
            n_leaves: self.n_leaves,
            contour: self.contour,
            boundary: self.boundary,
            rows: Vec::new(),
            euler: self.euler,
            component,
        }
    }
}

/// One child's patch lists.
struct Side<'a> {
    contour: Row<'a>,
    boundary: Row<'a>,
    degree: &'a [u32],
}

/// A leaf's boundary degrees: two contour edges at each corner.
const LEAF_DEGREE: [u32; 3] = [2; 3];

/// What a union shares between its two sides.
struct Shared {
    edges: u32,
    vertices: u32,
    conflict: bool,
}

/// Appends the contour, boundary and boundary degrees of the union of two
/// disjoint patches to `out`, and says what they share.
///
/// The contour is the symmetric difference of the sorted contours. A vertex
/// on the union's boundary is one with a contour edge left: its degree is
/// `deg_a + deg_b - 2 s`, where `s` counts the shared edges at it (a shared
/// edge leaves both contours). So the boundary is one merge of the sorted
/// boundaries against the sorted ends of the (few) shared edges.
fn union(mesh: &Mesh, a: &Side, b: &Side, out: &mut PatchOut, ends: &mut Vec<u32>) -> Shared {
    ends.clear();
    let info = merge_contours_with(&a.contour, &b.contour, &mut out.contour, |e| {
        ends.extend(unpack(mesh, e))
    });
    ends.sort_unstable();
    let (mut i, mut j, mut s, mut common) = (0, 0, 0, 0);
    // Stored degrees are positive, so a vertex on one side only stays.
    while i < a.boundary.len() && j < b.boundary.len() {
        let (va, vb) = (a.boundary[i], b.boundary[j]);
        if va < vb {
            out.boundary.push(va);
            out.degree.push(a.degree[i]);
            i += 1;
        } else if vb < va {
            out.boundary.push(vb);
            out.degree.push(b.degree[j]);
            j += 1;
        } else {
            common += 1;
            let mut d = a.degree[i] + b.degree[j];
            while s < ends.len() && ends[s] < va {
                s += 1;
            }
            while s < ends.len() && ends[s] == va {
                d -= 2;
                s += 1;
            }
            if d > 0 {
                out.boundary.push(va);
                out.degree.push(d);
            }
            i += 1;
            j += 1;
        }
    }
    for (side, k) in [(a, i), (b, j)] {
        out.boundary.extend_from_slice(&side.boundary[k..]);
        out.degree.extend_from_slice(&side.degree[k..]);
    }
    Shared {
        edges: info.shared_edges,
        vertices: common,
        conflict: info.conflict,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::patch::pack;
    use crate::scene::{grid, Deformation, SplitMix};
    use std::collections::BTreeMap;

    /// A grid with holes, flipped triangles (winding conflicts), a fin and a
    /// separate strip, so that every case of the patch merge is met.
    fn mesh(seed: u64) -> Mesh {
        let (mut v, mut f) = grid(12, 1.0);
        let mut rng = SplitMix::new(seed);
        let mut next = || rng.next_u64() % 10;
        f = f
            .into_iter()
            .filter_map(|[a, b, c]| match next() {
                0 => None,
                1 => Some([a, c, b]),
                _ => Some([a, b, c]),
            })
            .collect();
        let [a, b, _] = f[3];
        for z in [1.0, -1.0] {
            v.push([0.5, 0.5, z]);
            f.push([a, b, v.len() as u32 - 1]);
        }
        let s = v.len() as u32;
        v.extend([
            [0.0, 0.0, 5.0],
            [1.0, 0.0, 5.0],
            [0.0, 1.0, 5.0],
            [1.0, 1.0, 5.0],
        ]);
        f.extend([[s, s + 1, s + 2], [s + 1, s + 3, s + 2]]);
        Mesh::new(v, f).unwrap()
    }

    fn leaves_of(bvh: &Bvh, n: u32, out: &mut Vec<u32>) {
        if bvh.is_leaf(n) {
            out.push(n);
        } else {
            bvh.children_of(n)
                .iter()
                .for_each(|&c| leaves_of(bvh, c, out));
        }
    }

    #[test]
    fn patches_match_their_definition() {
        for seed in 0..6 {
            let m = mesh(seed);
            let (topo, bad) = (m.topology(), m.nonmanifold_triangles());
            let components = m.triangle_components();
            let bvh = build(&m);
            let p = &bvh.patches;
            for n in 0..bvh.n_nodes() as u32 {
                let mut tris = Vec::new();
                leaves_of(&bvh, n, &mut tris);
                // Directed edges of the patch by edge id.
                let mut edges: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
                let mut verts: Vec<u32> = Vec::new();
                for &t in &tris {
                    let tri = m.triangles()[t as usize];
                    for k in 0..3 {
                        let e = topo.tri_edges[t as usize][k];
                        edges
                            .entry(e)
                            .or_default()
                            .push(pack(e, tri[k], tri[(k + 1) % 3]));
                    }
                    verts.extend(tri);
                }
                verts.sort_unstable();
                verts.dedup();
                let contour = &*p.contour_of(&m, n);
                let odd: Vec<u32> = edges
                    .iter()
                    .filter(|(_, d)| d.len() % 2 == 1)
                    .map(|(&e, _)| e)
                    .collect();
                assert_eq!(contour.iter().map(|&e| e >> 1).collect::<Vec<_>>(), odd);
                for &c in contour {
                    let d = &edges[&(c >> 1)];
                    assert!(d.len() > 1 || d[0] == c, "node {n}: direction of {c}");
                }
                let mut boundary: Vec<u32> = contour.iter().flat_map(|&e| unpack(&m, e)).collect();
                boundary.sort_unstable();
                boundary.dedup();
                assert_eq!(&*p.boundary_of(&m, n), &boundary[..], "node {n}");
                let conflict = edges.values().any(|d| d.len() == 2 && d[0] == d[1]);
                let eligible = !conflict && tris.iter().all(|&t| !bad[t as usize]);
                assert_eq!(p.euler_of(n).is_some(), eligible, "node {n}");
                if eligible {
                    let euler = verts.len() as i32 - edges.len() as i32 + tris.len() as i32;
                    assert_eq!(p.euler_of(n), Some(euler), "node {n}");
                }
                let mut tags: Vec<u8> = tris
                    .iter()
                    .map(|&t| (components[t as usize] % 255) as u8)
                    .collect();
                tags.sort_unstable();
                tags.dedup();
                let tag = if tags.len() == 1 { tags[0] } else { SEVERAL };
                assert_eq!(p.component[n as usize], tag, "node {n}");
            }
        }
    }

    #[test]
    fn three_compare_exchanges_sort_up_to_three() {
        // Rows of three: every order, below.
        for row in [vec![], vec![5], vec![7, 2], vec![2, 7]] {
            let mut want = row.clone();
            want.sort_unstable();
            let mut got = row;
            sort_up_to_three(&mut got);
            assert_eq!(got, want);
        }
        for p in [
            [1, 2, 3],
            [1, 3, 2],
            [2, 1, 3],
            [2, 3, 1],
            [3, 1, 2],
            [3, 2, 1],
        ] {
            let mut got = p;
            sort_up_to_three(&mut got);
            assert_eq!(got, [1, 2, 3], "{p:?}");
        }
    }

    #[test]
    fn small_nodes_list_their_leaves() {
        for seed in 0..4 {
            let bvh = build(&mesh(seed));
            let end = bvh.small_end();
            assert!(end as usize > bvh.n_leaves && (end as usize) < bvh.n_nodes());
            for n in 0..bvh.n_nodes() as u32 {
                let mut want = Vec::new();
                leaves_of(&bvh, n, &mut want);
                if n < end {
                    let mut got = [0; Bvh::SMALL];
                    let k = bvh.small_leaves(n, &mut got);
                    assert_eq!(got[..k], want[..], "node {n}");
                } else {
                    assert!(!bvh.is_leaf(n));
                }
            }
        }
    }

    #[test]
    fn built_boxes_and_cones_are_a_refit_at_rest() {
        let m = mesh(1);
        let bvh = build(&m);
        let mut refitted = bvh.clone();
        let p = Deformation::Crumple {
            amplitude: 0.3,
            wavelength: 0.5,
            seed: 3,
        }
        .apply(m.rest());
        refitted.refit(&m, &p);
        refitted.refit(&m, m.rest());
        assert_eq!(bvh.boxes, refitted.boxes);
        assert_eq!(bvh.cones, refitted.cones);
    }
}
