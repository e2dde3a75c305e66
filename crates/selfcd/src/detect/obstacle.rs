//! Queries between two meshes: a cloth and an obstacle, each with its own BVH.
//!
//! Positions live in one *combined* index space: cloth vertices `0..n`, then the
//! obstacle's vertices at `n + i`. Every element pair comes out as a four-point
//! stencil in that space, so the cloth's response treats self- and obstacle
//! contacts alike (obstacle vertices get zero inverse mass).
//!
//! Broad phase: the two hierarchies traversed against each other, boxes only
//! (cones say nothing about distance or motion), two boxes kept when their gap
//! is at most `gap`. Narrow phase, per leaf pair (cloth triangle a, obstacle
//! triangle b): a's vertices against b, b's vertices against a, and a's edges
//! against b's edges, with the engine's distance functions ([`proximity`]),
//! continuous queries ([`continuous`]) or exact triangle tests
//! ([`intersections`]). The obstacle's own pairs are never tested.

use crate::bvh::Bvh;
use crate::geom::ccd::{closest_within, time_of_impact, StencilKind};
use crate::geom::tri_tri::triangles_intersect;
use crate::mesh::Mesh;
use glam::DVec3;

/// An element pair across the two meshes, in cloth / obstacle ids.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum CrossPair {
    /// A cloth vertex and an obstacle triangle.
    ClothVertex(u32, u32),
    /// An obstacle vertex and a cloth triangle.
    ObstacleVertex(u32, u32),
    /// A cloth edge and an obstacle edge.
    Edges(u32, u32),
}

/// The cloth, the obstacle, and where the obstacle's vertices start in the combined index space.
#[derive(Clone, Copy)]
pub struct Meshes<'a> {
    /// The cloth mesh (vertices `0..offset`).
    pub cloth: &'a Mesh,
    /// The obstacle mesh (vertex `i` at `offset + i`).
    pub obstacle: &'a Mesh,
}

impl Meshes<'_> {
    fn offset(&self) -> u32 {
        self.cloth.n_vertices() as u32
    }

    /// The pair's four points in the combined index space, and its kind:
    /// point first for a vertex-triangle pair, the cloth side first always.
    pub fn stencil(&self, pair: CrossPair) -> (StencilKind, [u32; 4]) {
        let o = self.offset();
        match pair {
            CrossPair::ClothVertex(v, t) => {
                let [a, b, c] = self.obstacle.triangles()[t as usize];
                (StencilKind::VertexTriangle, [v, a + o, b + o, c + o])
            }
            CrossPair::ObstacleVertex(v, t) => {
                let [a, b, c] = self.cloth.triangles()[t as usize];
                (StencilKind::VertexTriangle, [v + o, a, b, c])
            }
            CrossPair::Edges(e, f) => {
                let [a, b] = self.cloth.topology().edges[e as usize];
                let [c, d] = self.obstacle.topology().edges[f as usize];
                (StencilKind::EdgeEdge, [a, b, c + o, d + o])
            }
        }
    }
}

/// Leaf pairs (cloth triangle, obstacle triangle) whose boxes are at most
/// `gap` apart, sorted. Both hierarchies must be refitted by the caller.
pub fn leaf_pairs(cloth: &Bvh, obstacle: &Bvh, gap: f64) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    let mut stack = vec![(cloth.root(), obstacle.root())];
    while let Some((a, b)) = stack.pop() {
        let (ba, bb) = (&cloth.boxes[a as usize], &obstacle.boxes[b as usize]);
        if !ba.within(bb, gap) {
            continue;
        }
        match (cloth.is_leaf(a), obstacle.is_leaf(b)) {
            (true, true) => out.push([a, b]),
            // Descend the node with the bigger box (or the only internal one).
            (false, leaf_b) if leaf_b || ba.surface_area() >= bb.surface_area() => {
                let [l, r] = cloth.children_of(a);
                stack.extend([(l, b), (r, b)]);
            }
            _ => {
                let [l, r] = obstacle.children_of(b);
                stack.extend([(a, l), (a, r)]);
            }
        }
    }
    out.sort_unstable();
    out
}

/// The element pairs of the leaf pairs, each once, in the leaf pairs' order.
///
/// Each element is taken only from its *owner*, the first triangle that holds
/// it (as in the self queries, [`super::narrow::for_each_owned_pair`]): a
/// vertex or edge close to (or sweeping near) a triangle lies in its owner's
/// box, so the traversal reaches that pair through the owner, and no pair comes twice.
pub fn element_pairs(m: Meshes, leaves: &[[u32; 2]]) -> Vec<CrossPair> {
    let (ct, ot) = (m.cloth.topology(), m.obstacle.topology());
    let owns_vertex =
        |topo: &crate::mesh::Topology, t: u32, v: u32| topo.vertex_tris.row(v as usize)[0] == t;
    let owns_edge =
        |topo: &crate::mesh::Topology, t: u32, e: u32| topo.edge_tris.row(e as usize)[0] == t;
    let mut out = Vec::with_capacity(leaves.len() * 4);
    for &[a, b] in leaves {
        let (ta, tb) = (
            m.cloth.triangles()[a as usize],
            m.obstacle.triangles()[b as usize],
        );
        let vs_a = ta.into_iter().filter(|&v| owns_vertex(ct, a, v));
        out.extend(vs_a.map(|v| CrossPair::ClothVertex(v, b)));
        let vs_b = tb.into_iter().filter(|&v| owns_vertex(ot, b, v));
        out.extend(vs_b.map(|v| CrossPair::ObstacleVertex(v, a)));
        for e in ct.tri_edges[a as usize]
            .into_iter()
            .filter(|&e| owns_edge(ct, a, e))
        {
            let fs = ot.tri_edges[b as usize]
                .into_iter()
                .filter(|&f| owns_edge(ot, b, f));
            out.extend(fs.map(|f| CrossPair::Edges(e, f)));
        }
    }
    out
}

/// An element pair closer than the query distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Near {
    /// The elements.
    pub pair: CrossPair,
    /// Their distance.
    pub distance: f64,
    /// Closest point: barycentrics on the triangle, or the two edge parameters (third 0).
    pub params: [f64; 3],
}

/// The pairs of `pairs` strictly closer than `d` at combined positions `x`.
pub fn proximity(m: Meshes, x: &[DVec3], pairs: &[CrossPair], d: f64) -> Vec<Near> {
    pairs
        .iter()
        .filter_map(|&pair| {
            let (kind, ids) = m.stencil(pair);
            let c = ids.map(|i| x[i as usize]);
            closest_within(kind, &c, d, true).map(|(distance, params)| Near {
                pair,
                distance,
                params,
            })
        })
        .collect()
}

/// An element pair that may come within the thickness during the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// The elements.
    pub pair: CrossPair,
    /// Conservative time of impact in [0, 1].
    pub toi: f64,
}

/// The pairs of `pairs` that come within `thickness` while every combined position
/// moves linearly from `x0` to `x1`, with conservative times of impact (the
/// engine's continuous query, [`time_of_impact`]).
pub fn continuous(
    m: Meshes,
    x0: &[DVec3],
    x1: &[DVec3],
    pairs: &[CrossPair],
    thickness: f64,
) -> Vec<Impact> {
    pairs
        .iter()
        .filter_map(|&pair| {
            let (kind, ids) = m.stencil(pair);
            let at = |x: &[DVec3]| ids.map(|i| x[i as usize]);
            time_of_impact(kind, at(x0), at(x1), thickness).map(|toi| Impact { pair, toi })
        })
        .collect()
}

/// Leaf pairs whose triangles intersect at combined positions `x` (exact test).
pub fn intersections(m: Meshes, x: &[DVec3], leaves: &[[u32; 2]]) -> Vec<[u32; 2]> {
    let o = m.offset() as usize;
    leaves
        .iter()
        .copied()
        .filter(|&[a, b]| {
            let ta = m.cloth.triangles()[a as usize].map(|i| x[i as usize]);
            let tb = m.obstacle.triangles()[b as usize].map(|i| x[o + i as usize]);
            triangles_intersect(&ta, &tb)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build::build;
    use crate::scene::grid;

    fn two_grids(lift: f64) -> (Mesh, Mesh, Vec<DVec3>) {
        let (v, f) = grid(6, 1.0);
        let cloth = Mesh::new(v.clone(), f.clone()).unwrap();
        let shifted: Vec<[f64; 3]> = v
            .iter()
            .map(|p| [p[0] + 0.05, p[1] + 0.03, p[2] + lift])
            .collect();
        let obstacle = Mesh::new(shifted, f).unwrap();
        let x = cloth
            .rest()
            .iter()
            .chain(obstacle.rest())
            .copied()
            .collect();
        (cloth, obstacle, x)
    }

    /// Every element pair closer than d, by looping over all of them.
    fn brute_near(m: Meshes, x: &[DVec3], d: f64) -> Vec<CrossPair> {
        let (nc, no) = (m.cloth.n_vertices() as u32, m.obstacle.n_vertices() as u32);
        let (tc, to) = (
            m.cloth.n_triangles() as u32,
            m.obstacle.n_triangles() as u32,
        );
        let (ec, eo) = (
            m.cloth.topology().edges.len() as u32,
            m.obstacle.topology().edges.len() as u32,
        );
        let all: Vec<CrossPair> = (0..nc)
            .flat_map(|v| (0..to).map(move |t| CrossPair::ClothVertex(v, t)))
            .chain((0..no).flat_map(|v| (0..tc).map(move |t| CrossPair::ObstacleVertex(v, t))))
            .chain((0..ec).flat_map(|e| (0..eo).map(move |f| CrossPair::Edges(e, f))))
            .collect();
        proximity(m, x, &all, d).iter().map(|n| n.pair).collect()
    }

    #[test]
    fn traversal_finds_every_near_pair() {
        for lift in [0.0, 0.02, 0.1, 0.5] {
            let (cloth, obstacle, x) = two_grids(lift);
            let m = Meshes {
                cloth: &cloth,
                obstacle: &obstacle,
            };
            let d = 0.12;
            let (mut bc, mut bo) = (build(&cloth), build(&obstacle));
            bc.refit(&cloth, cloth.rest());
            bo.refit(&obstacle, obstacle.rest());
            let pairs = element_pairs(m, &leaf_pairs(&bc, &bo, d));
            let mut got: Vec<_> = proximity(m, &x, &pairs, d).iter().map(|n| n.pair).collect();
            got.sort_unstable();
            assert!(
                got == brute_near(m, &x, d),
                "lift {lift}: {} pairs, brute force {}",
                got.len(),
                brute_near(m, &x, d).len()
            );
            assert_eq!(got.is_empty(), lift > d);
        }
    }

    #[test]
    fn coplanar_overlap_intersects_and_lifted_does_not() {
        for (lift, want) in [(0.0, true), (0.01, false)] {
            let (cloth, obstacle, x) = two_grids(lift);
            let m = Meshes {
                cloth: &cloth,
                obstacle: &obstacle,
            };
            let (mut bc, mut bo) = (build(&cloth), build(&obstacle));
            bc.refit(&cloth, cloth.rest());
            bo.refit(&obstacle, obstacle.rest());
            let hits = intersections(m, &x, &leaf_pairs(&bc, &bo, 0.0));
            assert_eq!(!hits.is_empty(), want);
        }
    }

    #[test]
    fn continuous_finds_a_cloth_falling_through() {
        let (cloth, obstacle, x0) = two_grids(0.2);
        let m = Meshes {
            cloth: &cloth,
            obstacle: &obstacle,
        };
        let n = cloth.n_vertices();
        // The cloth moves up by 0.4: it passes the obstacle half way.
        let x1: Vec<DVec3> = x0
            .iter()
            .enumerate()
            .map(|(i, p)| if i < n { *p + DVec3::Z * 0.4 } else { *p })
            .collect();
        let (mut bc, mut bo) = (build(&cloth), build(&obstacle));
        bc.refit_swept(&cloth, &x0[..n], &x1[..n]);
        bo.refit(&obstacle, obstacle.rest());
        let hits = continuous(
            m,
            &x0,
            &x1,
            &element_pairs(m, &leaf_pairs(&bc, &bo, 0.0)),
            0.0,
        );
        assert!(!hits.is_empty());
        assert!(hits.iter().all(|h| h.toi <= 0.5 + 1e-9));
        let earliest = hits.iter().map(|h| h.toi).fold(1.0, f64::min);
        assert!(earliest > 0.45, "{earliest}");
    }
}
