//! Per-frame refit: leaves from the triangles, then each build level from its
//! children. O(n), parallel within a level; the structure never changes.

use super::Bvh;
use crate::geom::{Aabb, NormalCone};
use crate::mesh::Mesh;
use glam::DVec3;
use rayon::prelude::*;

/// Below this many nodes a level is refitted on one thread.
const PAR_MIN: usize = 4096;

impl Bvh {
    /// Refits every box and cone to `positions` (same vertex count as the mesh,
    /// checked by the caller).
    pub fn refit(&mut self, mesh: &Mesh, positions: &[DVec3]) {
        self.refit_with(|t| {
            let c = mesh.corners(positions, t);
            (
                Aabb::from_points(&c),
                NormalCone::of_triangle(c[0], c[1], c[2]),
            )
        });
    }

    /// Refits the boxes to the triangles swept linearly from `x0` to `x1` (for
    /// continuous queries); cones become full, so no cone culling applies.
    pub fn refit_swept(&mut self, mesh: &Mesh, x0: &[DVec3], x1: &[DVec3]) {
        self.refit_with(|t| {
            let b = Aabb::from_points(&mesh.corners(x0, t))
                .union(&Aabb::from_points(&mesh.corners(x1, t)));
            (b, NormalCone::FULL)
        });
    }

    /// Sets every leaf's box and cone from `leaf(triangle)`, then merges upwards.
    fn refit_with(&mut self, leaf: impl Fn(usize) -> (Aabb, NormalCone) + Sync) {
        let n = self.n_leaves;
        let (boxes, cones) = (&mut self.boxes[..n], &mut self.cones[..n]);
        if n >= PAR_MIN {
            boxes
                .par_iter_mut()
                .zip(cones.par_iter_mut())
                .enumerate()
                .for_each(|(t, (b, c))| (*b, *c) = leaf(t));
        } else {
            boxes
                .iter_mut()
                .zip(cones.iter_mut())
                .enumerate()
                .for_each(|(t, (b, c))| (*b, *c) = leaf(t));
        }
        for level in &self.levels {
            let (lo, hi) = (level.start as usize, level.end as usize);
            // Children of this level all have ids below `lo`.
            let (done_b, rest_b) = self.boxes.split_at_mut(lo);
            let (done_c, rest_c) = self.cones.split_at_mut(lo);
            let kids = &self.children[lo - n..hi - n];
            let fit = |(i, (b, c)): (usize, (&mut Aabb, &mut NormalCone))| {
                let [l, r] = kids[i];
                let (l, r) = (l as usize, r as usize);
                *b = done_b[l].union(&done_b[r]);
                *c = done_c[l].merge(&done_c[r]);
            };
            let (rb, rc) = (&mut rest_b[..hi - lo], &mut rest_c[..hi - lo]);
            if hi - lo >= PAR_MIN {
                rb.par_iter_mut()
                    .zip(rc.par_iter_mut())
                    .enumerate()
                    .for_each(fit);
            } else {
                rb.iter_mut().zip(rc.iter_mut()).enumerate().for_each(fit);
            }
        }
    }
}
