//! Per-frame refit: leaves from the triangles, then each build level from its
//! children. O(n), parallel within a level; the structure never changes.

use super::Bvh;
use crate::geom::slab::carry_error;
use crate::geom::{Aabb, NormalCone, Slab};
use crate::mesh::Mesh;
use glam::DVec3;
use rayon::prelude::*;

/// Below this many nodes a level is refitted on one thread.
const PAR_MIN: usize = 4096;
/// How many parents ahead [`Bvh::fit_up`] prefetches children: their ids
/// are scattered on meshes whose triangle order is not a grid's.
const AHEAD: usize = 8;

impl Bvh {
    /// Refits every box and cone to `positions` (same vertex count as the
    /// mesh, checked by the caller) and, when `slabs`, every node's slab
    /// along its cone's axis ([`Slab`]), in the same passes; otherwise (or
    /// where coordinates exceed 1e300) no slabs are kept, and none bound
    /// anything. The slabs hold until the next refit.
    pub fn refit(&mut self, mesh: &Mesh, positions: &[DVec3], slabs: bool) {
        self.refit_also(
            mesh,
            positions,
            slabs,
            &mut none(self.n_nodes()),
            |_, _| (),
            |_, _| (),
        );
    }

    /// [`refit`](Self::refit), also filling `values` (one per node) in the
    /// same passes: `leaf(t, corners)` for leaf `t`, the `merge` of the
    /// children for every internal node. One walk over the triangles instead
    /// of two (the kept certificates' displacement boxes).
    pub fn refit_also<T: Copy + Send + Sync>(
        &mut self,
        mesh: &Mesh,
        positions: &[DVec3],
        slabs: bool,
        values: &mut [T],
        leaf: impl Fn(usize, &[DVec3; 3]) -> T + Sync,
        merge: impl Fn(&T, &T) -> T + Sync,
    ) {
        // The carries' rounding margin, from the largest coordinate (which
        // bounds the root box's, not fitted yet).
        let largest = |m: f64, p: &DVec3| m.max(p.abs().max_element());
        let err = slabs
            .then(|| carry_error(positions.iter().fold(0.0, largest)))
            .flatten();
        let mut fitted = std::mem::take(&mut self.slabs);
        fitted.clear();
        if let Some(err) = err {
            fitted.resize(self.n_nodes(), Slab::ALL);
            self.refit_triangles(mesh, positions, (&mut fitted, err), values, leaf, merge);
        } else {
            let no_slabs = (&mut none(self.n_nodes())[..], 0.0);
            self.refit_triangles(mesh, positions, no_slabs, values, leaf, merge);
        }
        self.slabs = fitted;
    }

    /// [`refit_also`](Self::refit_also) with node slabs of type `S` (none
    /// for `()`), their carries widened by `err`.
    fn refit_triangles<T: Copy + Send + Sync, S: NodeSlab>(
        &mut self,
        mesh: &Mesh,
        positions: &[DVec3],
        slabs: (&mut [S], f64),
        values: &mut [T],
        leaf: impl Fn(usize, &[DVec3; 3]) -> T + Sync,
        merge: impl Fn(&T, &T) -> T + Sync,
    ) {
        let fit = |t| {
            let c = mesh.corners(positions, t);
            let cone = NormalCone::of_triangle(c[0], c[1], c[2]);
            let slab = S::leaf(cone.axis, &c);
            (Aabb::from_points(&c), cone, leaf(t, &c), slab)
        };
        self.refit_with(values, slabs, fit, merge);
    }

    /// Refits the boxes to the triangles swept linearly from `x0` to `x1` (for
    /// continuous queries with a thickness); cones become full, so no cone
    /// culling applies. [`refit_swept_cones`](Self::refit_swept_cones) fits
    /// the cones too, for the swept certificate at thickness 0.
    pub fn refit_swept(&mut self, mesh: &Mesh, x0: &[DVec3], x1: &[DVec3]) {
        let fit = |t| (mesh.swept_box(x0, x1, t), NormalCone::FULL, (), ());
        self.slabs.clear();
        let n = self.n_nodes();
        self.refit_with(&mut none(n), (&mut none(n), 0.0), fit, |_, _| ());
    }

    /// Refits the boxes to the swept triangles, as [`refit_swept`](Self::refit_swept),
    /// and the cones to their normals over the whole motion
    /// ([`NormalCone::of_swept_triangle`]), for the swept certificate.
    pub fn refit_swept_cones(&mut self, mesh: &Mesh, x0: &[DVec3], x1: &[DVec3]) {
        let fit = |t| {
            let (c0, c1) = (mesh.corners(x0, t), mesh.corners(x1, t));
            let b = Aabb::from_points(&c0).union(&Aabb::from_points(&c1));
            (b, NormalCone::of_swept_triangle(c0, c1), (), ())
        };
        self.slabs.clear();
        let n = self.n_nodes();
        self.refit_with(&mut none(n), (&mut none(n), 0.0), fit, |_, _| ());
    }

    /// Sets every leaf's box, cone, value and slab from `leaf(triangle)`,
    /// then merges upwards (values of a zero-sized type, as [`none`], are
    /// not merged: there is nothing to fill).
    fn refit_with<T: Copy + Send + Sync, S: NodeSlab>(
        &mut self,
        values: &mut [T],
        (slabs, err): (&mut [S], f64),
        leaf: impl Fn(usize) -> (Aabb, NormalCone, T, S) + Sync,
        merge: impl Fn(&T, &T) -> T + Sync,
    ) {
        let n = self.n_leaves;
        assert_eq!(values.len(), self.n_nodes(), "one value per node");
        assert_eq!(slabs.len(), self.n_nodes(), "one slab per node");
        let (boxes, cones) = (&mut self.boxes[..n], &mut self.cones[..n]);
        let set = |t: usize, (b, c, v, s): Out<T, S>| {
            (*b, *c, *v, *s) = leaf(t);
        };
        let leaves = (boxes, cones, &mut values[..n], &mut slabs[..n]);
        if n >= PAR_MIN {
            leaves
                .into_par_iter()
                .enumerate()
                .for_each(|(t, x)| set(t, x));
        } else {
            let (boxes, cones, vals, slabs) = leaves;
            (boxes.iter_mut().zip(cones).zip(vals).zip(slabs))
                .enumerate()
                .for_each(|(t, (((b, c), v), s))| set(t, (b, c, v, s)));
        }
        let mut boxes = std::mem::take(&mut self.boxes);
        let mut cones = std::mem::take(&mut self.cones);
        self.merge_up_all((&mut boxes, &mut cones), values, merge, (slabs, err));
        (self.boxes, self.cones) = (boxes, cones);
    }

    /// Sets every internal node's box, cone, value and slab from its
    /// children's, level by level (leaves already set): one pass that reads
    /// each node's children once for all four.
    fn merge_up_all<T: Copy + Send + Sync, S: NodeSlab>(
        &self,
        (boxes, cones): (&mut [Aabb], &mut [NormalCone]),
        values: &mut [T],
        merge: impl Fn(&T, &T) -> T + Sync,
        (slabs, err): (&mut [S], f64),
    ) {
        let n = self.n_leaves;
        for level in &self.levels {
            let (lo, hi) = (level.start as usize, level.end as usize);
            // Children of this level all have ids below `lo`.
            let (b_done, b_rest) = boxes.split_at_mut(lo);
            let (c_done, c_rest) = cones.split_at_mut(lo);
            let (v_done, v_rest) = values.split_at_mut(lo);
            let (s_done, s_rest) = slabs.split_at_mut(lo);
            let kids = &self.children[lo - n..hi - n];
            let set = |i: usize, (b, c, v, s): Out<T, S>| {
                if let Some(&[l, r]) = kids.get(i + AHEAD) {
                    for k in [l, r].map(|k| k as usize) {
                        crate::prefetch::prefetch(&b_done[k]);
                        crate::prefetch::prefetch(&c_done[k]);
                    }
                }
                let [l, r] = kids[i].map(|k| k as usize);
                *b = b_done[l].union(&b_done[r]);
                *c = c_done[l].merge(&c_done[r]);
                if std::mem::size_of::<T>() > 0 {
                    *v = merge(&v_done[l], &v_done[r]);
                }
                let kid = |k: usize| (&s_done[k], c_done[k].axis, &b_done[k]);
                *s = S::parent([kid(l), kid(r)], c.axis, b, err);
            };
            let m = hi - lo;
            let out = (
                &mut b_rest[..m],
                &mut c_rest[..m],
                &mut v_rest[..m],
                &mut s_rest[..m],
            );
            if m >= PAR_MIN {
                out.into_par_iter().enumerate().for_each(|(i, x)| set(i, x));
            } else {
                let (b, c, v, s) = out;
                (b.iter_mut().zip(c).zip(v).zip(s))
                    .enumerate()
                    .for_each(|(i, (((b, c), v), s))| set(i, (b, c, v, s)));
            }
        }
    }

    /// True when the last refit fitted the slabs ([`refit`](Self::refit)).
    pub fn has_slabs(&self) -> bool {
        self.slabs.len() == self.boxes.len()
    }

    /// The rounding margin of a carry between this hierarchy's slabs
    /// ([`carry_error`] of the root box's largest coordinate), or None.
    pub fn slab_error(&self) -> Option<f64> {
        let root = self.boxes.last()?;
        carry_error(root.min.abs().max(root.max.abs()).max_element())
    }

    /// Fills `values` (one per node) bottom-up: `leaf(t)` for leaf `t`, the
    /// `merge` of the children for every internal node; parallel within a
    /// build level. For per-node bounds of other per-vertex data (the
    /// displacement boxes of the coherent queries).
    pub fn fit_nodes<T: Copy + Send + Sync>(
        &self,
        values: &mut [T],
        leaf: impl Fn(usize) -> T + Sync,
        merge: impl Fn(&T, &T) -> T + Sync,
    ) {
        let leaves = &mut values[..self.n_leaves];
        if leaves.len() >= PAR_MIN {
            leaves
                .par_iter_mut()
                .enumerate()
                .for_each(|(t, v)| *v = leaf(t));
        } else {
            leaves
                .iter_mut()
                .enumerate()
                .for_each(|(t, v)| *v = leaf(t));
        }
        self.merge_up(values, merge);
    }

    /// Sets every internal node of `values` to the `merge` of its children,
    /// level by level (leaves already set).
    fn merge_up<T: Copy + Send + Sync>(
        &self,
        values: &mut [T],
        merge: impl Fn(&T, &T) -> T + Sync,
    ) {
        self.fit_up(values, |_, [l, r], done| {
            merge(&done[l as usize], &done[r as usize])
        });
    }

    /// Sets every internal node `p` of `values` to `fit(p, children of p,
    /// done)`, level by level, where `done` holds the values of every node
    /// below the level (leaves already set); parallel within a level.
    fn fit_up<T: Copy + Send + Sync>(
        &self,
        values: &mut [T],
        fit: impl Fn(usize, [u32; 2], &[T]) -> T + Sync,
    ) {
        let n = self.n_leaves;
        for level in &self.levels {
            let (lo, hi) = (level.start as usize, level.end as usize);
            // Children of this level all have ids below `lo`.
            let (done, rest) = values.split_at_mut(lo);
            let kids = &self.children[lo - n..hi - n];
            let set = |(i, v): (usize, &mut T)| {
                if let Some(&[a, b]) = kids.get(i + AHEAD) {
                    crate::prefetch::prefetch(&done[a as usize]);
                    crate::prefetch::prefetch(&done[b as usize]);
                }
                *v = fit(lo + i, kids[i], done)
            };
            let out = &mut rest[..hi - lo];
            if hi - lo >= PAR_MIN {
                out.par_iter_mut().enumerate().for_each(set);
            } else {
                out.iter_mut().enumerate().for_each(set);
            }
        }
    }
}

/// No values: one `()` per node, for the refits that fill only boxes and
/// cones (a zero-sized type: no memory, nothing merged).
fn none(nodes: usize) -> Vec<()> {
    vec![(); nodes]
}

/// One node's box, cone, value and slab, as a refit pass writes them.
type Out<'a, T, S> = (&'a mut Aabb, &'a mut NormalCone, &'a mut T, &'a mut S);

/// A node's slab as the refit fits it: a [`Slab`] along the node's cone
/// axis, or nothing (`()`) when the refit keeps none.
trait NodeSlab: Copy + Send + Sync {
    /// A leaf's, along its cone axis `axis`, from its corners.
    fn leaf(axis: DVec3, corners: &[DVec3; 3]) -> Self;
    /// A parent's along its axis `v`: the children's (slab, axis, box)
    /// carried to `v`, within the parent's box `b`, widened by `err`.
    fn parent(kids: [(&Self, DVec3, &Aabb); 2], v: DVec3, b: &Aabb, err: f64) -> Self;
}

impl NodeSlab for () {
    #[inline]
    fn leaf(_: DVec3, _: &[DVec3; 3]) {}
    #[inline]
    fn parent(_: [(&(), DVec3, &Aabb); 2], _: DVec3, _: &Aabb, _: f64) {}
}

impl NodeSlab for Slab {
    #[inline]
    fn leaf(axis: DVec3, corners: &[DVec3; 3]) -> Slab {
        Slab::of_corners(axis, corners)
    }

    #[inline]
    fn parent(kids: [(&Slab, DVec3, &Aabb); 2], v: DVec3, b: &Aabb, err: f64) -> Slab {
        let [x, y] = kids.map(|(s, u, kb)| s.carry(u, kb, v));
        x.union(&y).intersect(&Slab::of_box(v, b)).widen(err)
    }
}
