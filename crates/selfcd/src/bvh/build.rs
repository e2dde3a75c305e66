//! Bottom-up construction (paper 3.2), once, on the rest mesh.
//!
//! Level by level, nodes are paired greedily so that the merged box is
//! smallest, as in the paper (computed in parallel as locally dominant edges,
//! see [`dominant_matching`]); we measure boxes by *surface area*, not volume,
//! because a flat cloth's boxes all have zero volume. Only nodes whose patches
//! share an edge are paired, so every node is a connected patch of surface
//! (the cone and contour tests need that). When no two remaining nodes share
//! an edge (separate components), they are paired in spatial order.

use super::patch::{self, count_common, merge_contours, pack, Patches};
use super::Bvh;
use crate::geom::{Aabb, NormalCone};
use crate::mesh::{Csr, Mesh};
use rayon::prelude::*;

/// Growing per-node patch data while building.
struct PatchBuilder {
    contour: Vec<Vec<u32>>,
    boundary: Vec<Vec<u32>>,
    euler: Vec<i32>,
    eligible: Vec<bool>,
}

impl PatchBuilder {
    fn leaves(mesh: &Mesh) -> PatchBuilder {
        let topo = mesh.topology();
        let bad = mesh.nonmanifold_triangles();
        let n = mesh.n_triangles();
        let mut b = PatchBuilder {
            contour: Vec::with_capacity(2 * n),
            boundary: Vec::with_capacity(2 * n),
            euler: vec![1; n],
            eligible: bad.iter().map(|&x| !x).collect(),
        };
        for (t, tri) in mesh.triangles().iter().enumerate() {
            let e = topo.tri_edges[t];
            let mut c: Vec<u32> = (0..3)
                .map(|k| pack(e[k], tri[k], tri[(k + 1) % 3]))
                .collect();
            c.sort_unstable();
            let mut v = tri.to_vec();
            v.sort_unstable();
            b.contour.push(c);
            b.boundary.push(v);
        }
        b
    }

    /// Appends the patches of the unions of the `pairs` (disjoint nodes), in order.
    fn push_level(&mut self, mesh: &Mesh, pairs: &[(u32, u32)]) {
        let unions: Vec<_> = pairs
            .par_iter()
            .map(|&(l, r)| self.union(mesh, l as usize, r as usize))
            .collect();
        for (c, v, euler, eligible) in unions {
            self.contour.push(c);
            self.boundary.push(v);
            self.euler.push(euler);
            self.eligible.push(eligible);
        }
    }

    /// Contour, boundary vertices, Euler characteristic and eligibility of the
    /// union of disjoint nodes `l` and `r`.
    fn union(&self, mesh: &Mesh, l: usize, r: usize) -> (Vec<u32>, Vec<u32>, i32, bool) {
        let mut c = Vec::new();
        let info = merge_contours(&self.contour[l], &self.contour[r], &mut c);
        let shared_v = count_common(&self.boundary[l], &self.boundary[r]) as i32;
        let mut v: Vec<u32> = c.iter().flat_map(|&e| patch::unpack(mesh, e)).collect();
        v.sort_unstable();
        v.dedup();
        let euler = self.euler[l] + self.euler[r] - shared_v + info.shared_edges as i32;
        let eligible = self.eligible[l] && self.eligible[r] && !info.conflict;
        (c, v, euler, eligible)
    }

    fn finish(self) -> Patches {
        let flat = |rows: Vec<Vec<u32>>| {
            Csr::from_pairs(
                rows.len(),
                rows.iter()
                    .enumerate()
                    .flat_map(|(i, r)| r.iter().map(move |&x| (i as u32, x))),
            )
        };
        Patches {
            contour: flat(self.contour),
            boundary: flat(self.boundary),
            euler: self.euler,
            eligible: self.eligible,
        }
    }
}

/// Builds the hierarchy of `mesh` on its rest shape, with boxes and cones fitted to it.
pub fn build(mesh: &Mesh) -> Bvh {
    let n = mesh.n_triangles();
    let rest = mesh.rest();
    let mut boxes: Vec<Aabb> = (0..n)
        .into_par_iter()
        .map(|t| Aabb::from_points(&mesh.corners(rest, t)))
        .collect();
    let mut patches = PatchBuilder::leaves(mesh);
    let mut children: Vec<[u32; 2]> = Vec::with_capacity(n.saturating_sub(1));
    let mut levels = Vec::new();

    let mut active: Vec<u32> = (0..n as u32).collect();
    let mut graph = leaf_graph(mesh);
    let mut rep: Vec<u32> = (0..(2 * n) as u32).collect();
    while active.len() > 1 {
        let level_start = (n + children.len()) as u32;
        let mut matched = dominant_matching(&graph, &boxes);
        if matched.is_empty() {
            matched = spatial_pairs(&active, &boxes);
        }
        // Number parents in the order of their children, so that refitting a
        // level reads the previous levels almost sequentially (cache locality).
        for m in matched.iter_mut() {
            *m = (m.0.min(m.1), m.0.max(m.1));
        }
        matched.par_sort_unstable();
        patches.push_level(mesh, &matched);
        for &(a, b) in &matched {
            let p = (n + children.len()) as u32;
            children.push([a, b]);
            boxes.push(boxes[a as usize].union(&boxes[b as usize]));
            rep[a as usize] = p;
            rep[b as usize] = p;
        }
        levels.push(level_start..(n + children.len()) as u32);
        active = active.iter().map(|&a| rep[a as usize]).collect();
        active.sort_unstable();
        active.dedup();
        graph = graph
            .par_iter()
            .map(|&(a, b)| {
                let (x, y) = (rep[a as usize], rep[b as usize]);
                (x.min(y), x.max(y))
            })
            .filter(|&(x, y)| x != y)
            .collect();
        graph.par_sort_unstable();
        graph.dedup();
    }
    let cones = vec![NormalCone::FULL; boxes.len()];
    let mut bvh = Bvh {
        n_leaves: n,
        children,
        levels,
        boxes,
        cones,
        patches: patches.finish(),
    };
    bvh.refit(mesh, rest);
    bvh
}

/// Pairs of triangles sharing an edge, (a, b) with a < b, sorted.
fn leaf_graph(mesh: &Mesh) -> Vec<(u32, u32)> {
    let topo = mesh.topology();
    let mut g = Vec::with_capacity(topo.edges.len());
    for e in 0..topo.edges.len() {
        let row = topo.edge_tris.row(e);
        for i in 0..row.len() {
            for j in i + 1..row.len() {
                g.push((row[i].min(row[j]), row[i].max(row[j])));
            }
        }
    }
    g.par_sort_unstable();
    g.dedup();
    g
}

/// Rounds of locally dominant matching per level.
const ROUNDS: usize = 8;

/// Key ordering candidate merges: merged box surface area, ties by ids.
type Key = (f64, u32, u32);

fn key_less(x: &Key, y: &Key) -> bool {
    x.0.total_cmp(&y.0)
        .then(x.1.cmp(&y.1))
        .then(x.2.cmp(&y.2))
        .is_lt()
}

/// The greedy matching of graph edges in order of merged box surface area
/// (ties by ids), computed as locally dominant edges: an edge that is the
/// best of both its endpoints is in the greedy matching, so matching those,
/// dropping their endpoints and repeating gives the greedy result with O(E)
/// work per round and no global sort. Rounds stop after [`ROUNDS`] (a long
/// chain of ever larger merges would otherwise take one round per edge); nodes
/// left unmatched wait for the next level.
fn dominant_matching(graph: &[(u32, u32)], boxes: &[Aabb]) -> Vec<(u32, u32)> {
    let mut cand: Vec<Key> = graph
        .par_iter()
        .map(|&(a, b)| {
            (
                boxes[a as usize].union(&boxes[b as usize]).surface_area(),
                a,
                b,
            )
        })
        .collect();
    const NONE: Key = (f64::INFINITY, u32::MAX, u32::MAX);
    let mut best = vec![NONE; boxes.len()];
    let mut used = vec![false; boxes.len()];
    let mut out = Vec::new();
    for _ in 0..ROUNDS {
        if cand.is_empty() {
            break;
        }
        for c in &cand {
            for v in [c.1, c.2] {
                if key_less(c, &best[v as usize]) {
                    best[v as usize] = *c;
                }
            }
        }
        for c in &cand {
            if best[c.1 as usize] == *c && best[c.2 as usize] == *c {
                used[c.1 as usize] = true;
                used[c.2 as usize] = true;
                out.push((c.1, c.2));
            }
        }
        for c in &cand {
            best[c.1 as usize] = NONE;
            best[c.2 as usize] = NONE;
        }
        cand.retain(|c| !used[c.1 as usize] && !used[c.2 as usize]);
    }
    out
}

/// Pairs nodes with no shared edges (separate components) in order along the
/// longest axis of their joint box; an odd one out waits for the next level.
fn spatial_pairs(active: &[u32], boxes: &[Aabb]) -> Vec<(u32, u32)> {
    let all = active
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
    let mut order = active.to_vec();
    order.sort_by(|&a, &b| {
        boxes[a as usize].center()[k]
            .total_cmp(&boxes[b as usize].center()[k])
            .then(a.cmp(&b))
    });
    order.chunks_exact(2).map(|p| (p[0], p[1])).collect()
}
