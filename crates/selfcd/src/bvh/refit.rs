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

/// Which cones a refit fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConeFit {
    /// Every node's, the leaves' and their merges up the levels.
    All,
    /// The leaves' only: the internal nodes' cones are left stale
    /// ([`Bvh::cones_fit`] says so), and a reader that needs one computes it
    /// from its leaves ([`Bvh::cone_from_leaves`],
    /// [`Bvh::leaves_within_90_of`]); the hierarchy's leaves must be
    /// numbered depth-first ([`Bvh::depth_first`]). For frames that read few
    /// internal cones: the merges are most of a refit's arithmetic, and not
    /// writing the cones saves a pass over their memory.
    Leaves,
}

impl Bvh {
    /// Refits every box and cone to `positions` (same vertex count as the mesh,
    /// checked by the caller).
    pub fn refit(&mut self, mesh: &Mesh, positions: &[DVec3]) {
        self.refit_cones(mesh, positions, ConeFit::All);
    }

    /// [`refit`](Self::refit), fitting the cones `cones` says.
    pub fn refit_cones(&mut self, mesh: &Mesh, positions: &[DVec3], cones: ConeFit) {
        self.refit_also(
            mesh,
            positions,
            cones,
            &mut none(self.n_nodes()),
            |_, _| (),
            |_, _| (),
        );
    }

    /// [`refit_cones`](Self::refit_cones), also filling `values` (one per
    /// node) in the same passes: `leaf(t, corners)` for leaf `t`, the `merge`
    /// of the children for every internal node. One walk over the triangles
    /// instead of two (the kept certificates' displacement boxes).
    pub fn refit_also<T: Copy + Send + Sync>(
        &mut self,
        mesh: &Mesh,
        positions: &[DVec3],
        cones: ConeFit,
        values: &mut [T],
        leaf: impl Fn(usize, &[DVec3; 3]) -> T + Sync,
        merge: impl Fn(&T, &T) -> T + Sync,
    ) {
        let fit = |t| {
            let c = mesh.corners(positions, t);
            let cone = NormalCone::of_triangle(c[0], c[1], c[2]);
            (Aabb::from_points(&c), cone, leaf(t, &c))
        };
        self.refit_with(cones, values, fit, merge);
    }

    /// Refits the boxes to the triangles swept linearly from `x0` to `x1` (for
    /// continuous queries with a thickness); cones become full, so no cone
    /// culling applies. [`refit_swept_cones`](Self::refit_swept_cones) fits
    /// the cones too, for the swept certificate at thickness 0.
    pub fn refit_swept(&mut self, mesh: &Mesh, x0: &[DVec3], x1: &[DVec3]) {
        let fit = |t| (mesh.swept_box(x0, x1, t), NormalCone::FULL, ());
        self.refit_with(ConeFit::All, &mut none(self.n_nodes()), fit, |_, _| ());
    }

    /// Refits the boxes to the swept triangles, as [`refit_swept`](Self::refit_swept),
    /// and the cones to their normals over the whole motion
    /// ([`NormalCone::of_swept_triangle`]), for the swept certificate.
    pub fn refit_swept_cones(&mut self, mesh: &Mesh, x0: &[DVec3], x1: &[DVec3]) {
        let fit = |t| {
            let (c0, c1) = (mesh.corners(x0, t), mesh.corners(x1, t));
            let b = Aabb::from_points(&c0).union(&Aabb::from_points(&c1));
            (b, NormalCone::of_swept_triangle(c0, c1), ())
        };
        self.refit_with(ConeFit::All, &mut none(self.n_nodes()), fit, |_, _| ());
    }

    /// Sets every leaf's box, cone and value from `leaf(triangle)`, then
    /// merges upwards (values of a zero-sized type, as [`none`], are not
    /// merged: there is nothing to fill; cones as `cones` says).
    fn refit_with<T: Copy + Send + Sync>(
        &mut self,
        fit: ConeFit,
        values: &mut [T],
        leaf: impl Fn(usize) -> (Aabb, NormalCone, T) + Sync,
        merge: impl Fn(&T, &T) -> T + Sync,
    ) {
        let n = self.n_leaves;
        assert_eq!(values.len(), self.n_nodes(), "one value per node");
        assert!(
            fit == ConeFit::All || self.spans.len() == self.n_nodes() - n,
            "cones from the leaves need depth-first leaves"
        );
        self.cones_fit = fit;
        self.slabs.clear(); // stale now; `fit_slabs` refits them
        let (boxes, cones) = (&mut self.boxes[..n], &mut self.cones[..n]);
        let set = |t: usize, (b, c, v): (&mut Aabb, &mut NormalCone, &mut T)| {
            (*b, *c, *v) = leaf(t);
        };
        let leaves = (boxes, cones, &mut values[..n]);
        if n >= PAR_MIN {
            leaves
                .into_par_iter()
                .enumerate()
                .for_each(|(t, x)| set(t, x));
        } else {
            let (boxes, cones, vals) = leaves;
            (boxes.iter_mut().zip(cones).zip(vals))
                .enumerate()
                .for_each(|(t, ((b, c), v))| set(t, (b, c, v)));
        }
        let mut boxes = std::mem::take(&mut self.boxes);
        let mut cones = std::mem::take(&mut self.cones);
        self.merge_up_all(fit, &mut boxes, &mut cones, values, merge);
        (self.boxes, self.cones) = (boxes, cones);
    }

    /// Sets every internal node's box, cone and value to the merge of its
    /// children's, level by level (leaves already set): one pass that reads
    /// each node's children once for all three (three passes read the child
    /// ids and walk the levels three times).
    fn merge_up_all<T: Copy + Send + Sync>(
        &self,
        fit: ConeFit,
        boxes: &mut [Aabb],
        cones: &mut [NormalCone],
        values: &mut [T],
        merge: impl Fn(&T, &T) -> T + Sync,
    ) {
        let n = self.n_leaves;
        for level in &self.levels {
            let (lo, hi) = (level.start as usize, level.end as usize);
            // Children of this level all have ids below `lo`.
            let (b_done, b_rest) = boxes.split_at_mut(lo);
            let (c_done, c_rest) = cones.split_at_mut(lo);
            let (v_done, v_rest) = values.split_at_mut(lo);
            let kids = &self.children[lo - n..hi - n];
            let set = |(i, (b, (c, v))): (usize, (&mut Aabb, (&mut NormalCone, &mut T)))| {
                if let Some(&[l, r]) = kids.get(i + AHEAD) {
                    for k in [l, r].map(|k| k as usize) {
                        crate::prefetch::prefetch(&b_done[k]);
                        if fit == ConeFit::All {
                            crate::prefetch::prefetch(&c_done[k]);
                        }
                        if std::mem::size_of::<T>() > 0 {
                            crate::prefetch::prefetch(&v_done[k]);
                        }
                    }
                }
                let [l, r] = kids[i].map(|k| k as usize);
                *b = b_done[l].union(&b_done[r]);
                if fit == ConeFit::All {
                    *c = c_done[l].merge(&c_done[r]);
                }
                if std::mem::size_of::<T>() > 0 {
                    *v = merge(&v_done[l], &v_done[r]);
                }
            };
            let out = (
                &mut b_rest[..hi - lo],
                &mut c_rest[..hi - lo],
                &mut v_rest[..hi - lo],
            );
            if hi - lo >= PAR_MIN {
                let (b, c, v) = out;
                b.par_iter_mut()
                    .zip(c.par_iter_mut().zip(v.par_iter_mut()))
                    .enumerate()
                    .for_each(set);
            } else {
                let (b, c, v) = out;
                b.iter_mut()
                    .zip(c.iter_mut().zip(v))
                    .enumerate()
                    .for_each(set);
            }
        }
    }

    /// Fits every node's slab along its cone's axis ([`Slab`]) to
    /// `positions`, the positions of the last refit. The slabs hold until
    /// the next refit; none are fitted (and none bound anything) where
    /// coordinates exceed 1e300. A slab bounds its node along any unit
    /// axis, so after a refit of the leaves' cones only
    /// ([`ConeFit::Leaves`]) the internal nodes' axes are those of the last
    /// refit that fitted them: as sound, and near this frame's while the
    /// normals turn slowly.
    pub fn fit_slabs(&mut self, mesh: &Mesh, positions: &[DVec3]) {
        let Some(err) = self.slab_error() else {
            self.slabs.clear();
            return;
        };
        let n = self.n_leaves;
        let cones = &self.cones;
        self.slabs.resize(self.boxes.len(), Slab::ALL);
        self.slabs[..n]
            .par_iter_mut()
            .with_min_len(PAR_MIN)
            .enumerate()
            .for_each(|(t, s)| *s = Slab::of_corners(cones[t].axis, &mesh.corners(positions, t)));
        let mut slabs = std::mem::take(&mut self.slabs);
        let (boxes, cones) = (&self.boxes, &self.cones);
        // The children's axes and boxes are read at random too: fetched ahead.
        let ahead = |k: u32| {
            crate::prefetch::prefetch(&cones[k as usize]);
            crate::prefetch::prefetch(&boxes[k as usize]);
        };
        self.fit_up(&mut slabs, ahead, |p, kids, done| {
            let v = cones[p].axis;
            let carried = kids.map(|k| {
                let k = k as usize;
                done[k].carry(cones[k].axis, &boxes[k], v)
            });
            let own = Slab::of_box(v, &boxes[p]);
            carried[0].union(&carried[1]).intersect(&own).widen(err)
        });
        self.slabs = slabs;
    }

    /// True when [`fit_slabs`](Self::fit_slabs) fitted the slabs to the
    /// last refit.
    pub fn has_slabs(&self) -> bool {
        self.slabs.len() == self.boxes.len()
    }

    /// The rounding margin of a carry between this hierarchy's slabs
    /// ([`carry_error`] of the root box's largest coordinate), or None.
    pub fn slab_error(&self) -> Option<f64> {
        let root = self.boxes.last()?;
        carry_error(root.magnitude())
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
        self.fit_up(
            values,
            |_| (),
            |_, [l, r], done| merge(&done[l as usize], &done[r as usize]),
        );
    }

    /// Sets every internal node `p` of `values` to `fit(p, children of p,
    /// done)`, level by level, where `done` holds the values of every node
    /// below the level (leaves already set); parallel within a level. The
    /// children's values are prefetched a few parents ahead, and `ahead(k)`
    /// is called there for each child `k` (to prefetch what else `fit` reads).
    fn fit_up<T: Copy + Send + Sync>(
        &self,
        values: &mut [T],
        ahead: impl Fn(u32) + Sync,
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
                    ahead(a);
                    ahead(b);
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
