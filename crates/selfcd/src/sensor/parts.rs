//! Convex parts (paper 2.1: "the number of particles equals the number of
//! convex parts of the object"), read from the hierarchy's normal cones: the
//! fewest hierarchy nodes whose normal cones have a half-angle under 90
//! degrees (all normals in one open half-space: the traversal's own cone
//! criterion, [`crate::geom::NormalCone::is_positive`]) and that together cover the mesh.
//! A node's cone holds its children's, so the top-most qualifying nodes are
//! that fewest set; a leaf's cone (one triangle) always qualifies. A flat
//! sheet is one part, a tube or a sphere a few, a crumpled sheet many.
//!
//! [`Parts`] labels every triangle with its part, so that the sensor can see
//! which parts carry no particle (where a part appeared) and which carry
//! several (where parts merged); see [`super::Sensor::follow_parts`].
//! Only the public `Bvh` accessors (root, children, boxes, cones) are used here.

use crate::bvh::Bvh;
use crate::mesh::Mesh;
use glam::DVec3;

/// Number of convex parts of the shape `bvh` was last fitted to.
pub fn convex_parts(bvh: &Bvh) -> usize {
    part_nodes(bvh).len()
}

/// The part nodes of the shape `bvh` was last fitted to, in depth-first order
/// (first child first), so the list is deterministic.
pub fn part_nodes(bvh: &Bvh) -> Vec<u32> {
    let mut stack = vec![bvh.root()];
    let mut parts = Vec::new();
    while let Some(node) = stack.pop() {
        if bvh.is_leaf(node) || bvh.cones[node as usize].is_positive() {
            parts.push(node);
        } else {
            let [a, b] = bvh.children_of(node);
            stack.extend([b, a]);
        }
    }
    parts
}

/// The convex parts of one shape: every triangle's part, and per part its
/// size (triangles) and an anchor triangle (the one whose centroid is
/// closest to the part's box centre: where a new particle goes).
#[derive(Debug, Clone, Default)]
pub struct Parts {
    /// Part id of every triangle.
    pub of_triangle: Vec<u32>,
    /// Triangles per part.
    pub size: Vec<u32>,
    /// Anchor triangle per part.
    pub anchor: Vec<u32>,
}

impl Parts {
    /// The parts of `positions`, which `bvh` (built on `mesh`) was last fitted to.
    pub fn new(bvh: &Bvh, mesh: &Mesh, positions: &[DVec3]) -> Parts {
        let nodes = part_nodes(bvh);
        let mut parts = Parts {
            of_triangle: vec![0; mesh.n_triangles()],
            size: vec![0; nodes.len()],
            anchor: vec![0; nodes.len()],
        };
        let mut stack = Vec::new();
        for (p, &node) in nodes.iter().enumerate() {
            let centre = bvh.boxes[node as usize].center();
            let mut best = f64::INFINITY;
            stack.push(node);
            while let Some(n) = stack.pop() {
                if !bvh.is_leaf(n) {
                    stack.extend(bvh.children_of(n));
                    continue;
                }
                parts.of_triangle[n as usize] = p as u32;
                parts.size[p] += 1;
                let [a, b, c] = mesh.corners(positions, n as usize);
                let d = ((a + b + c) / 3.0).distance_squared(centre);
                // Ties: the lowest triangle, whatever the traversal order.
                if d < best || (d == best && n < parts.anchor[p]) {
                    best = d;
                    parts.anchor[p] = n;
                }
            }
        }
        parts
    }

    /// Number of parts.
    pub fn len(&self) -> usize {
        self.size.len()
    }

    /// True when there is no part (a mesh always has one).
    pub fn is_empty(&self) -> bool {
        self.size.is_empty()
    }
}
