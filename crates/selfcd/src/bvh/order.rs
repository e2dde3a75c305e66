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

use super::Bvh;
use crate::mesh::Mesh;

impl Bvh {
    /// This hierarchy, built for `mesh`, renumbered depth-first (module
    /// doc), with `mesh` renumbered alike and the order of the leaves: leaf
    /// `i` of the result is leaf `order[i]` of this one, so it holds
    /// triangle `order[i]` of `mesh`, triangle `i` of the returned mesh
    /// (`mesh.reordered(&order)`). Within each build level the parents are
    /// sorted by their first leaf, so children still have smaller ids than
    /// their parents and a level is still one range. Fresh memory and
    /// scattered moves are the expensive part here: the boxes and cones are
    /// refitted to the rest shape in place rather than moved, the patches'
    /// rows stay where the build wrote them (`Patches::rows` maps the new
    /// ids to them), and only the small per-node arrays are rewritten.
    pub fn depth_first(mut self, mesh: &Mesh) -> (Bvh, Mesh, Vec<u32>) {
        let n = self.n_leaves;
        let nodes = self.n_nodes();
        // Each internal node's level, and the next free id in each level.
        let mut level_of = vec![0u32; nodes - n];
        let mut next: Vec<u32> = self.levels.iter().map(|l| l.start).collect();
        for (k, l) in self.levels.iter().enumerate() {
            level_of[l.start as usize - n..l.end as usize - n].fill(k as u32);
        }
        // Depth-first (left child first): leaves in order, and each internal
        // node the next id of its level, which sorts a level's nodes by
        // their first leaf (disjoint subtrees are visited one after the other).
        let mut order = Vec::with_capacity(n);
        let mut new_id = vec![0u32; nodes];
        let mut stack = vec![self.root()];
        while let Some(v) = stack.pop() {
            if self.is_leaf(v) {
                new_id[v as usize] = order.len() as u32;
                order.push(v);
                continue;
            }
            let slot = &mut next[level_of[v as usize - n] as usize];
            new_id[v as usize] = *slot;
            *slot += 1;
            let [l, r] = self.children_of(v);
            stack.extend([r, l]);
        }
        let mut old_of = vec![0u32; nodes];
        for (v, &i) in new_id.iter().enumerate() {
            old_of[i as usize] = v as u32;
        }
        let children: Vec<[u32; 2]> = old_of[n..]
            .iter()
            .map(|&v| self.children_of(v).map(|c| new_id[c as usize]))
            .collect();
        // Each internal node's leaves: its left child's range, then its right's.
        let mut spans: Vec<[u32; 2]> = Vec::with_capacity(children.len());
        for &[l, r] in &children {
            let span = |c: u32| match c.checked_sub(n as u32) {
                Some(i) => spans[i as usize],
                None => [c, c + 1],
            };
            let ([lo, mid], [start, hi]) = (span(l), span(r));
            debug_assert_eq!(mid, start, "depth-first leaves");
            spans.push([lo, hi]);
        }
        let p = &mut self.patches;
        p.euler = pick(&p.euler, &old_of);
        p.component = pick(&p.component, &old_of);
        p.rows = old_of[n..]
            .iter()
            .map(|&v| p.row(v as usize) as u32)
            .collect();
        self.children = children;
        self.spans = spans;
        let mesh = mesh.reordered(&order);
        self.refit(&mesh, mesh.rest());
        (self, mesh, order)
    }
}

/// `v` in the order `ids` (entry `i` of the result is `v[ids[i]]`).
fn pick<T: Copy>(v: &[T], ids: &[u32]) -> Vec<T> {
    ids.iter().map(|&i| v[i as usize]).collect()
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
        SplitMix::new(5).shuffle(&mut f);
        let mesh = Mesh::new(v, f).unwrap();
        let x = Deformation::Crumple {
            amplitude: 0.3,
            wavelength: 0.2,
            seed: 4,
        }
        .apply(mesh.rest());
        let mut bvh = build(&mesh);
        let (mut df, inner, order) = bvh.clone().depth_first(&mesh);
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
            assert_eq!(df.spans[p as usize - df.n_leaves], [x.0, y.1 + 1]);
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
