//! Bounding volume hierarchy over the triangles of one mesh (paper 3.1-3.4).
//!
//! Built once, bottom-up, on the rest mesh ([`build`]); every frame only the
//! boxes and normal cones are refitted ([`refit`]). All data lives in flat
//! arrays indexed by node id: nodes `0..n` are the leaves (leaf `i` holds
//! triangle `i`), internal nodes follow in creation order, so every child has a
//! smaller id than its parent and the root is the last node. A kept detector
//! renumbers its hierarchy depth-first ([`order`]: every subtree's leaves one
//! id range, for memory locality, and for cones computed from the leaves)
//! and runs it on the mesh with its triangles in that order.
//!
//! A one-shot query (no later frames to amortise a build over) uses its own
//! hierarchy instead, built top-down only where its certificates fail
//! ([`topdown`]).

pub mod build;
pub mod certify;
mod chunks;
pub mod kept;
pub mod order;
pub mod patch;
pub mod refit;
pub mod topdown;
pub mod traverse;

use crate::geom::{Aabb, NormalCone, Slab};
use crate::mesh::Csr;

/// A flat, bottom-up BVH with per-node boxes, normal cones and contours.
#[derive(Debug, Clone)]
pub struct Bvh {
    /// Number of leaves (= triangles).
    pub n_leaves: usize,
    /// Children of internal node `n_leaves + i`.
    pub children: Vec<[u32; 2]>,
    /// Internal node id ranges, one per build level; nodes of a level only have
    /// children from earlier levels, so a level can be refitted in parallel.
    pub levels: Vec<std::ops::Range<u32>>,
    /// Box of every node, refitted each frame.
    pub boxes: Vec<Aabb>,
    /// Normal cone of every node, refitted each frame (the internal nodes'
    /// only when [`cones_fit`](Self::cones_fit) is [`refit::ConeFit::All`]).
    pub cones: Vec<NormalCone>,
    /// Which cones the last refit (or the build) fitted.
    pub cones_fit: refit::ConeFit,
    /// Slab of every node along its cone's axis ([`Slab`]) when fitted
    /// ([`Bvh::fit_slabs`], after a refit); empty otherwise.
    pub slabs: Vec<Slab>,
    /// Contour and patch topology of every node, fixed at build time.
    pub patches: patch::Patches,
    /// The leaves under internal node `n_leaves + i` as one id range
    /// `[start, end)` (entry `i`), when the leaves are numbered depth-first
    /// ([`Bvh::depth_first`]); empty otherwise. A node's cone can then be
    /// computed from its leaves' ([`cone_from_leaves`](Self::cone_from_leaves)).
    pub spans: Vec<[u32; 2]>,
}

impl Bvh {
    /// Most triangles under a node of the first two levels (leaves included).
    pub const SMALL: usize = 4;

    /// Nodes below this id hold at most [`SMALL`](Self::SMALL) triangles: the
    /// leaves and the first two levels' parents (each pairs two nodes of the
    /// level below or carries one up).
    pub fn small_end(&self) -> u32 {
        self.levels.get(1).map_or(self.n_nodes() as u32, |l| l.end)
    }

    /// The triangles under small node `n` (id below [`small_end`](Self::small_end)),
    /// in `out`; returns how many.
    #[inline]
    pub fn small_leaves(&self, n: u32, out: &mut [u32; Self::SMALL]) -> usize {
        if self.is_leaf(n) {
            out[0] = n;
            return 1;
        }
        let mut k = 0;
        for c in self.children_of(n) {
            if self.is_leaf(c) {
                out[k] = c;
                k += 1;
            } else {
                for g in self.children_of(c) {
                    out[k] = g;
                    k += 1;
                }
            }
        }
        k
    }

    /// The cone of node `n` computed from its leaves' cones
    /// ([`NormalCone::around_leaves`]), for a refit that fitted the leaves'
    /// cones only ([`refit::ConeFit::Leaves`]): O(leaves under `n`). The
    /// fitted cone where the leaves are not numbered depth-first.
    pub fn cone_from_leaves(&self, n: u32) -> NormalCone {
        match self.leaves_of(n) {
            Some(leaves) if !self.is_leaf(n) => NormalCone::around_leaves(&self.cones[leaves]),
            _ => self.cones[n as usize],
        }
    }

    /// The leaves under node `n` as one id range: a leaf itself, an
    /// internal node's when the leaves are numbered depth-first ([`spans`](Self::spans)).
    #[inline]
    fn leaves_of(&self, n: u32) -> Option<std::ops::Range<usize>> {
        if self.is_leaf(n) {
            return Some(n as usize..n as usize + 1);
        }
        let &[lo, hi] = self.spans.get(n as usize - self.n_leaves)?;
        Some(lo as usize..hi as usize)
    }

    /// True when every normal under node `n` lies strictly within 90
    /// degrees of unit `v`, from its leaves' cones
    /// ([`NormalCone::leaves_within_90_of`]; O(leaves under `n`)), or from
    /// its fitted cone where the leaves are not numbered depth-first.
    pub fn leaves_within_90_of(&self, n: u32, v: glam::DVec3) -> bool {
        match self.leaves_of(n) {
            Some(leaves) => NormalCone::leaves_within_90_of(&self.cones[leaves], v),
            None => self.cones[n as usize].within_90_of(v),
        }
    }

    /// Total number of nodes (2 n - 1).
    pub fn n_nodes(&self) -> usize {
        self.boxes.len()
    }

    /// The root node id.
    pub fn root(&self) -> u32 {
        (self.n_nodes() - 1) as u32
    }

    /// True for leaf nodes.
    #[inline]
    pub fn is_leaf(&self, node: u32) -> bool {
        (node as usize) < self.n_leaves
    }

    /// Children of an internal node.
    #[inline]
    pub fn children_of(&self, node: u32) -> [u32; 2] {
        self.children[node as usize - self.n_leaves]
    }

    /// Bytes held by the hierarchy's arrays (not counting the mesh).
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        let csr = |c: &Csr| (c.offsets.capacity() + c.items.capacity()) * 4;
        self.children.capacity() * size_of::<[u32; 2]>()
            + self.boxes.capacity() * size_of::<Aabb>()
            + self.cones.capacity() * size_of::<NormalCone>()
            + self.slabs.capacity() * size_of::<Slab>()
            + csr(&self.patches.contour)
            + csr(&self.patches.boundary)
            + self.patches.euler.capacity() * 4
            + self.patches.component.capacity()
            + self.patches.rows.capacity() * 4
            + self.spans.capacity() * size_of::<[u32; 2]>()
    }
}
