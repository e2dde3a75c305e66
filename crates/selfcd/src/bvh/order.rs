//! The hierarchy renumbered depth-first, for memory locality.
//!
//! A refit reads each node's children, and a traversal goes from a node to
//! its children and on to their leaves. Leaves are numbered as the mesh
//! numbers its triangles, and parents in the order the build made them, so
//! where the input's triangle order is not coherent in space (a garment
//! exported with its panels' triangles interleaved, layers stacked by
//! another tool), those reads land anywhere in the arrays. Renumbered with
//! the leaves in the tree's depth-first order and each level's parents in
//! the order of their first leaf, every subtree's leaves lie side by side
//! and so do the parents of neighbouring subtrees.
//!
//! The tree is the same, so every query gives the same answers once the
//! triangle ids are mapped back: the mesh is renumbered with its leaves
//! ([`Mesh::reordered`](crate::mesh::Mesh::reordered)), keeping its vertex
//! and edge ids, so the patches' contours (packed edge ids) and boundaries
//! (vertex ids) hold as they are.

use super::patch::Patches;
use super::Bvh;
use crate::mesh::Csr;

impl Bvh {
    /// This hierarchy renumbered depth-first (module doc), and the order of
    /// its leaves: leaf `i` of the result is leaf `order[i]` of this one, so
    /// it holds triangle `order[i]` of this hierarchy's mesh, triangle `i` of
    /// `mesh.reordered(&order)`. Within each build level the parents are
    /// sorted by their first leaf, so children still have smaller ids than
    /// their parents and a level is still one range.
    pub fn depth_first(&self) -> (Bvh, Vec<u32>) {
        let n = self.n_leaves;
        let nodes = self.n_nodes();
        // Leaves in depth-first order (left child first), and each internal
        // node's first leaf in that order, its sort key within its level.
        let mut order = Vec::with_capacity(n);
        let mut first_leaf = vec![0u32; nodes - n];
        let mut stack = vec![self.root()];
        while let Some(v) = stack.pop() {
            if self.is_leaf(v) {
                order.push(v);
                continue;
            }
            first_leaf[v as usize - n] = order.len() as u32;
            let [l, r] = self.children_of(v);
            stack.extend([r, l]);
        }
        let mut new_id = vec![0u32; nodes];
        for (i, &t) in order.iter().enumerate() {
            new_id[t as usize] = i as u32;
        }
        let mut old_of: Vec<u32> = order.clone();
        old_of.extend(n as u32..nodes as u32);
        for level in &self.levels {
            let ids = &mut old_of[level.start as usize..level.end as usize];
            ids.sort_unstable_by_key(|&v| first_leaf[v as usize - n]);
            for (k, &v) in ids.iter().enumerate() {
                new_id[v as usize] = level.start + k as u32;
            }
        }
        let children: Vec<[u32; 2]> = old_of[n..]
            .iter()
            .map(|&v| self.children_of(v).map(|c| new_id[c as usize]))
            .collect();
        // Each node's leaves: its left child's range, then its right's.
        let mut spans: Vec<[u32; 2]> = (0..n as u32).map(|i| [i, i + 1]).collect();
        for &[l, r] in &children {
            let ([lo, mid], [start, hi]) = (spans[l as usize], spans[r as usize]);
            debug_assert_eq!(mid, start, "depth-first leaves");
            spans.push([lo, hi]);
        }
        let p = &self.patches;
        let bvh = Bvh {
            n_leaves: n,
            children,
            levels: self.levels.clone(),
            boxes: pick(&self.boxes, &old_of),
            cones: pick(&self.cones, &old_of),
            cones_fit: self.cones_fit,
            slabs: if self.has_slabs() {
                pick(&self.slabs, &old_of)
            } else {
                Vec::new()
            },
            patches: Patches {
                contour: rows_in_order(&p.contour, &old_of),
                boundary: rows_in_order(&p.boundary, &old_of),
                euler: pick(&p.euler, &old_of),
                component: pick(&p.component, &old_of),
            },
            spans,
        };
        (bvh, order)
    }
}

/// `v` in the order `ids` (entry `i` of the result is `v[ids[i]]`).
fn pick<T: Copy>(v: &[T], ids: &[u32]) -> Vec<T> {
    ids.iter().map(|&i| v[i as usize]).collect()
}

/// The rows of `c` in the order `rows` (row `i` of the result is row
/// `rows[i]` of `c`), contents unchanged.
fn rows_in_order(c: &Csr, rows: &[u32]) -> Csr {
    let mut offsets = Vec::with_capacity(rows.len() + 1);
    let mut items = Vec::with_capacity(c.items.len());
    offsets.push(0);
    for &r in rows {
        items.extend_from_slice(c.row(r as usize));
        offsets.push(items.len() as u32);
    }
    Csr { offsets, items }
}

#[cfg(test)]
mod tests {
    use crate::bvh::build::build;
    use crate::bvh::traverse::{self_traverse, TraverseOptions};
    use crate::detect::narrow::Intersect;
    use crate::mesh::Mesh;
    use crate::scene::{grid, Deformation, SplitMix};

    /// A mesh whose triangles come in a random order, renumbered
    /// depth-first: the leaves of every subtree are one range, children
    /// have smaller ids than their parents, and the contour cull finds the
    /// same pairs (mapped back) as the hierarchy in the input's order.
    #[test]
    fn depth_first_keeps_the_tree_and_its_answers() {
        let (v, mut f) = grid(24, 1.0);
        let mut rng = SplitMix::new(5);
        for i in (1..f.len()).rev() {
            f.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
        }
        let mesh = Mesh::new(v, f).unwrap();
        let x = Deformation::Crumple {
            amplitude: 0.3,
            wavelength: 0.2,
            seed: 4,
        }
        .apply(mesh.rest());
        let mut bvh = build(&mesh);
        let (mut df, order) = bvh.depth_first();
        let inner = mesh.reordered(&order);
        // Leaves of each subtree: one range.
        let mut span = vec![(u32::MAX, 0u32, 0u32); df.n_nodes()];
        for l in 0..df.n_leaves as u32 {
            span[l as usize] = (l, l, 1);
        }
        for p in df.n_leaves as u32..df.n_nodes() as u32 {
            let [a, b] = df.children_of(p);
            assert!(a < p && b < p);
            let (x, y) = (span[a as usize], span[b as usize]);
            assert_eq!(
                x.1 + 1,
                y.0,
                "left subtree's leaves just before the right's"
            );
            span[p as usize] = (x.0, y.1, x.2 + y.2);
            assert_eq!(df.spans[p as usize], [x.0, y.1 + 1]);
        }
        assert_eq!(
            span[df.root() as usize],
            (0, df.n_leaves as u32 - 1, df.n_leaves as u32)
        );
        bvh.refit(&mesh, &x);
        df.refit(&inner, &x);
        let opts = TraverseOptions {
            cones: true,
            contour: true,
            gap: 0.0,
        };
        let find = |bvh, mesh, map: &dyn Fn(u32) -> u32| {
            let visitor = Intersect {
                mesh,
                positions: &x,
            };
            let (pairs, c) = self_traverse(bvh, mesh, &x, opts, &visitor);
            let mut pairs: Vec<[u32; 2]> = pairs
                .into_iter()
                .map(|[a, b]| [map(a).min(map(b)), map(a).max(map(b))])
                .collect();
            pairs.sort_unstable();
            (pairs, c.self_culls + c.pair_culls)
        };
        let (want, culls) = find(&bvh, &mesh, &|t| t);
        let (got, df_culls) = find(&df, &inner, &|t| order[t as usize]);
        assert!(!want.is_empty());
        assert_eq!(got, want);
        assert_eq!(df_culls, culls, "the same certificates");
    }
}
