//! Convex parts (paper 2.1: "the number of particles equals the number of
//! convex parts of the object"), read from the hierarchy's normal cones: the
//! fewest hierarchy nodes whose normal cones have a half-angle under 90
//! degrees (all normals in one open half-space: the traversal's own cone
//! criterion, [`crate::geom::NormalCone::is_positive`]) and that together cover the mesh.
//! A node's cone holds its children's, so the top-most qualifying nodes are
//! that fewest set; a leaf's cone (one triangle) always qualifies. A flat
//! sheet is one part, a tube or a sphere a few.
//!
//! Only the public `Bvh` accessors (root, children, cones) are used here.

use crate::bvh::Bvh;

/// Number of convex parts of the shape `bvh` was last fitted to.
pub fn convex_parts(bvh: &Bvh) -> usize {
    let mut stack = vec![bvh.root()];
    let mut parts = 0;
    while let Some(node) = stack.pop() {
        if bvh.is_leaf(node) || bvh.cones[node as usize].is_positive() {
            parts += 1;
        } else {
            stack.extend(bvh.children_of(node));
        }
    }
    parts
}
