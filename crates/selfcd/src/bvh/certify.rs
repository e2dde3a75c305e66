//! Culling certificates for the self-traversal: the paper's normal-cone test
//! ([`ConeCull`], not conservative on its own) and the cone plus contour test
//! ([`ContourCull`], Volino & Magnenat-Thalmann's condition (B), made conservative).
//! The traversal ([`super::traverse`]) only sees the [`Cull`] callbacks.
//!
//! **Theorem used.** Let a patch be connected with Euler characteristic 1, be
//! an orientable manifold (every edge in at most two triangles, every vertex
//! star one fan), have every triangle normal strictly within 90 degrees of v,
//! and let c be a point such that, projected along v, c lies strictly left of
//! every directed contour edge with the edges turning around c once in total.
//! Then the patch has no two non-adjacent triangles that touch. (Each cycle of
//! contour edges turns around c a positive whole number of times, so one turn
//! means one simple star-shaped loop; the projection is then a local,
//! orientation-preserving map of a disk whose boundary goes once around a
//! simple curve, so its degree is 1 and it is one-to-one.) The same holds when
//! the projected contour is any simple counter-clockwise loop.
//!
//! The loop is checked in O(contour) by the star test about the patch's box
//! centre; when that fails, by the exact condition (one simple
//! counter-clockwise loop, [`simple_ccw_loop`], O(contour) expected). For the
//! union of two adjacent disks A and B glued along edges the union's contour
//! gets the same test; pinched at vertices only, A and B are each checked as
//! above and their loops must meet only along the vertices they share, neither
//! inside the other: the projection is then one-to-one on each and their
//! images meet only where the patches themselves meet.
//!
//! Every decision is made from this frame's boxes, cones and positions, or,
//! when the caller keeps certificates across frames ([`super::kept`]), from
//! a certificate of an earlier frame that this frame's cones and
//! displacement bounds show still holds.

use super::kept::{LoopPairs, Reuse};
use super::patch::{count_common, have_common, merge_contours, project_contour, unpack, Patches};
use super::refit::ConeFit;
use super::Bvh;
use crate::geom::loop2d::{
    close_pairs, is_ccw, loops_meet_only_where_shared, loops_meet_only_where_shared_slack,
    simple_ccw_loop, simple_ccw_loop_slack, star_about, star_slack, still_clear,
    swept_simple_ccw_loop, swept_star_about, LoopScratch, Plane, Seg,
};
use crate::geom::NormalCone;
use crate::mesh::Mesh;
use crate::stats::Counters;
use glam::DVec3;

/// What the traversal asks before descending. Answers may only be `true` when
/// no two non-adjacent triangles of the node (or of the pair's union) touch.
pub trait Cull: Sync {
    /// Per-task buffers (one per parallel task, reused across calls).
    type Scratch: Default + Send;
    /// May the self-test of internal node `n` be skipped?
    fn self_culled(&self, n: u32, s: &mut Self::Scratch, c: &mut Counters) -> bool;
    /// May the pair test of disjoint nodes `a` and `b` (boxes overlapping,
    /// not siblings, not both leaves) be skipped?
    fn pair_culled(&self, a: u32, b: u32, s: &mut Self::Scratch, c: &mut Counters) -> bool;
    /// When true, the traversal tests a small node (at most
    /// [`SMALL`](super::Bvh::SMALL) triangles), or a pair of them, leaf pair
    /// by leaf pair, without asking about the nodes in between: for culls
    /// that would cull none of them (boxes only). (The coherent queries'
    /// motion cull keeps the descent: leaf by leaf, the pairs it would have
    /// culled counted as fresh work and the candidate set was rebuilt more
    /// often.)
    const LEAF_BY_LEAF_WHEN_SMALL: bool = false;
}

/// No culling: every overlapping box pair is descended (`bvh`, proximity).
pub struct BoxesOnly;

impl Cull for BoxesOnly {
    type Scratch = ();
    const LEAF_BY_LEAF_WHEN_SMALL: bool = true;
    #[inline]
    fn self_culled(&self, _: u32, _: &mut (), _: &mut Counters) -> bool {
        false
    }
    #[inline]
    fn pair_culled(&self, _: u32, _: u32, _: &mut (), _: &mut Counters) -> bool {
        false
    }
}

/// The paper's cull: a node, or an adjacent pair, whose normal cone is under
/// 90 degrees. Not conservative (a positive cone allows a patch that winds
/// over itself); `bvh-cones`.
pub struct ConeCull<'a> {
    cones: Cones<'a>,
}

impl<'a> ConeCull<'a> {
    /// The cull of `bvh`, built for `mesh`, whose every cone the last refit
    /// fitted.
    pub fn new(bvh: &'a Bvh, mesh: &'a Mesh) -> Self {
        assert_eq!(
            bvh.cones_fit,
            ConeFit::All,
            "the cone cull reads every cone"
        );
        ConeCull {
            cones: Cones {
                bvh,
                mesh,
                from_leaves: false,
            },
        }
    }

    /// The cones of nodes `a` and `b` when they are adjacent with a positive
    /// merged cone ([`Cones::adjacent_positive`]). Most overlapping pairs in
    /// layered cloth lie in different mesh components (one byte per node
    /// says so): that first.
    #[inline]
    fn adjacent_positive(&self, a: u32, b: u32) -> Option<(NormalCone, NormalCone)> {
        if !self.cones.bvh.patches.may_touch(a, b) {
            return None;
        }
        self.cones.adjacent_positive(a, b)
    }
}

/// The cones the contour cull reads: the fitted ones, or, after a refit of
/// the leaves' cones only ([`ConeFit::Leaves`]),
/// each internal node's computed from its leaves when asked (a kept front's
/// frame asks for few).
#[derive(Clone, Copy)]
struct Cones<'a> {
    bvh: &'a Bvh,
    /// The mesh `bvh` was built for (its leaves' patches).
    mesh: &'a Mesh,
    from_leaves: bool,
}

impl Cones<'_> {
    /// The cone of node `n`.
    #[inline]
    fn of(&self, n: u32) -> NormalCone {
        if self.from_leaves {
            self.bvh.cone_from_leaves(n)
        } else {
            self.bvh.cones[n as usize]
        }
    }

    /// Every normal under node `n` strictly within 90 degrees of unit `v`?
    #[inline]
    fn within_90_of(&self, n: u32, v: DVec3) -> bool {
        if self.from_leaves {
            self.bvh.leaves_within_90_of(n, v)
        } else {
            self.bvh.cones[n as usize].within_90_of(v)
        }
    }

    /// The cones of adjacent nodes `a` and `b` (sharing a boundary vertex)
    /// when both and their merge are positive. Cheapest first: fitted
    /// cones can only merge positive if both are, and only adjacent patches
    /// are worth merging; cones from the leaves are computed for adjacent
    /// nodes only.
    #[inline]
    fn adjacent_positive(&self, a: u32, b: u32) -> Option<(NormalCone, NormalCone)> {
        let p = &self.bvh.patches;
        let m = self.mesh;
        let adjacent = || have_common(&p.boundary_of(m, a), &p.boundary_of(m, b));
        if self.from_leaves && !adjacent() {
            return None;
        }
        let (ca, cb) = (self.of(a), self.of(b));
        let ok = ca.is_positive()
            && cb.is_positive()
            && (self.from_leaves || adjacent())
            && ca.merge_is_positive(&cb);
        ok.then_some((ca, cb))
    }
}

impl Cull for ConeCull<'_> {
    type Scratch = ();
    #[inline]
    fn self_culled(&self, n: u32, _: &mut (), c: &mut Counters) -> bool {
        let culled = self.cones.of(n).is_positive();
        c.self_culls += culled as u64;
        culled
    }
    #[inline]
    fn pair_culled(&self, a: u32, b: u32, _: &mut (), c: &mut Counters) -> bool {
        let culled = self.adjacent_positive(a, b).is_some();
        c.pair_culls += culled as u64;
        culled
    }
}

/// Cone and contour certificate (see the module doc): exact; `bvh-cones-contour`.
pub struct ContourCull<'a> {
    bvh: &'a Bvh,
    mesh: &'a Mesh,
    positions: &'a [DVec3],
    cones: Cones<'a>,
    reuse: Option<&'a Reuse<'a>>,
}

/// How a kept certificate decided.
#[derive(Debug, Clone, Copy)]
enum Reused {
    /// The spread is within its slack.
    Slack,
    /// Its contour's close pairs are still clear.
    Rechecked,
}

impl Reused {
    fn count(self, c: &mut Counters) {
        match self {
            Reused::Slack => c.certificates_reused += 1,
            Reused::Rechecked => c.certificates_rechecked += 1,
        }
    }
}

/// Buffers of one task's contour tests.
#[derive(Default)]
pub struct ContourScratch {
    merged: Vec<u32>,
    segs: Vec<Seg>,
    segs_b: Vec<Seg>,
    loops: LoopScratch,
}

impl<'a> ContourCull<'a> {
    /// Certificates for `bvh` refitted to `positions` (its internal cones
    /// computed from the leaves where the refit fitted the leaves' only,
    /// [`Bvh::cones_fit`]).
    pub fn new(bvh: &'a Bvh, mesh: &'a Mesh, positions: &'a [DVec3]) -> Self {
        ContourCull {
            bvh,
            mesh,
            positions,
            cones: Cones {
                bvh,
                mesh,
                from_leaves: bvh.cones_fit == ConeFit::Leaves,
            },
            reuse: None,
        }
    }

    /// [`new`](Self::new), reusing the certificates of earlier frames that
    /// still hold and recording the ones made now ([`super::kept`]).
    pub fn with_reuse(
        bvh: &'a Bvh,
        mesh: &'a Mesh,
        positions: &'a [DVec3],
        reuse: &'a Reuse<'a>,
    ) -> Self {
        ContourCull {
            reuse: Some(reuse),
            ..Self::new(bvh, mesh, positions)
        }
    }

    /// The projected contour of a disk-like patch is one simple counter-clockwise
    /// loop: the star test about `center` first, the exact loop test if that
    /// fails. The projection is left in `segs`.
    fn disk_is_height_field(
        &self,
        contour: &[u32],
        plane: &Plane,
        center: [f64; 2],
        segs: &mut Vec<Seg>,
        loops: &mut LoopScratch,
    ) -> bool {
        project_contour(self.mesh, self.positions, contour, plane, segs);
        star_about(segs, center) || simple_ccw_loop(segs, loops)
    }

    /// [`disk_is_height_field`](Self::disk_is_height_field) with the slack
    /// of its answer (how far the vertices may move), or None. The loop
    /// test's slack is at most `cap` (it compares the edge pairs up to `2 cap`
    /// apart); the star test's is not capped (it costs the same at any size).
    fn disk_slack(
        &self,
        contour: &[u32],
        (plane, center): (&Plane, [f64; 2]),
        cap: f64,
        segs: &mut Vec<Seg>,
        loops: &mut LoopScratch,
    ) -> Option<f64> {
        project_contour(self.mesh, self.positions, contour, plane, segs);
        star_slack(segs, center).or_else(|| simple_ccw_loop_slack(segs, loops, cap))
    }

    /// A kept certificate of node `a` (`a == b`) or of the union of `a` and
    /// `b` that still holds: both cones within 90 degrees of its axis, and
    /// this frame's spread within its slack, or within its re-check's reach
    /// with the close pairs that spread reaches still clear ([`still_clear`]:
    /// only those pairs' edges are projected).
    fn reused(&self, r: &Reuse, a: u32, b: u32, s: &mut ContourScratch) -> Option<Reused> {
        let (k, spread) = r.get(a, b)?;
        // The O(1) test of the spread before the normals' (O(leaves) from
        // the leaves' cones).
        let check = k.recheck.filter(|c| spread <= c.within);
        if spread > k.slack && check.is_none() {
            return None;
        }
        let c = self.cones;
        if !(c.within_90_of(a, k.axis) && (a == b || c.within_90_of(b, k.axis))) {
            return None;
        }
        if spread <= k.slack {
            return Some(Reused::Slack);
        }
        let check = check?;
        let plane = Plane::new(k.axis, check.origin);
        let (mesh, x) = (self.mesh, self.positions);
        let seg = |packed: u32| {
            let v = unpack(mesh, packed);
            let p = v.map(|v| x.get(v as usize).map(|&q| plane.project(q)));
            Some(Seg {
                p: [p[0]?, p[1]?],
                v,
            })
        };
        let ok = still_clear(r.pairs(&check), spread, check.eps, seg)
            && (spread <= check.area_within || self.loops_ccw(a, b, &plane, s));
        ok.then_some(Reused::Rechecked)
    }

    /// Are the contour loops of node `a` (`a == b`) or of the union of `a`
    /// and `b` (one loop when glued along edges, else each patch's)
    /// counter-clockwise, projected on `plane`?
    fn loops_ccw(&self, a: u32, b: u32, plane: &Plane, s: &mut ContourScratch) -> bool {
        let (p, mesh, x) = (&self.bvh.patches, self.mesh, self.positions);
        let ccw = |contour: &[u32], segs: &mut Vec<Seg>| {
            project_contour(mesh, x, contour, plane, segs);
            is_ccw(segs)
        };
        if a == b {
            return ccw(&p.contour_of(mesh, a), &mut s.segs);
        }
        let mut merged = std::mem::take(&mut s.merged);
        let ok = match union_disk(p, mesh, a, b, &mut merged) {
            Some(true) => ccw(&merged, &mut s.segs),
            Some(false) => {
                ccw(&p.contour_of(mesh, a), &mut s.segs) && ccw(&p.contour_of(mesh, b), &mut s.segs)
            }
            None => false,
        };
        s.merged = merged;
        ok
    }

    /// What re-checks the certificate just made from the projection in
    /// `segs` (on `plane`) of `contour`, or, for two loops, of contour `a`
    /// in `segs` and `b` in `segs_b`: their close pairs, as packed contour
    /// edges, and their reach.
    fn loop_pairs(
        &self,
        r: &Reuse,
        plane: &Plane,
        (a, b): (&[u32], &[u32]),
        s: &mut ContourScratch,
    ) -> Option<LoopPairs> {
        if !b.is_empty() {
            s.segs.extend_from_slice(&s.segs_b);
        }
        let mut pairs = Vec::new();
        let reach = close_pairs(&s.segs, a.len(), r.cap(), &mut s.loops, &mut pairs)?;
        let packed = |i: u32| {
            let i = i as usize;
            a.get(i).or_else(|| b.get(i - a.len())).copied()
        };
        for c in &mut pairs {
            c.edges = [packed(c.edges[0])?, packed(c.edges[1])?];
        }
        Some(LoopPairs {
            origin: plane.origin(),
            pairs,
            reach,
        })
    }

    /// The fresh certificate of `contour` (a disk) projected on `plane`
    /// (normal to `axis`), recorded for later frames.
    fn certify_disk(
        &self,
        r: &Reuse,
        (a, b): (u32, u32),
        contour: &[u32],
        (axis, plane): (DVec3, &Plane),
        s: &mut ContourScratch,
    ) -> bool {
        let slack = self.disk_slack(
            contour,
            (plane, [0.0; 2]),
            r.cap(),
            &mut s.segs,
            &mut s.loops,
        );
        // (The close pairs are found only where they may pay: `record`.)
        r.record((a, b), axis, slack, || {
            self.loop_pairs(r, plane, (contour, &[]), s)
        })
    }

    /// Is the union of adjacent disjoint patches a and b a height field along
    /// `axis`? When they share edges the union is a disk (Euler characteristic
    /// 1, no conflicting edge) and its contour gets the node test; when they
    /// touch only at vertices each patch's loop must be simple and the two
    /// loops meet only where the patches do. With kept certificates, the
    /// answer is recorded with its slack and the close pairs of both loops.
    fn union_is_height_field(&self, a: u32, b: u32, axis: DVec3, s: &mut ContourScratch) -> bool {
        let (bvh, p) = (self.bvh, &self.bvh.patches);
        let Some(glued) = union_disk(p, self.mesh, a, b, &mut s.merged) else {
            return false;
        };
        let (box_a, box_b) = (&bvh.boxes[a as usize], &bvh.boxes[b as usize]);
        let plane = Plane::new(axis, box_a.union(box_b).center());
        if glued {
            // Patches glued along edges: the union is one disk, tested as a node is.
            let merged = std::mem::take(&mut s.merged);
            let ok = match self.reuse {
                Some(r) => self.certify_disk(r, (a, b), &merged, (axis, &plane), s),
                None => {
                    self.disk_is_height_field(&merged, &plane, [0.0; 2], &mut s.segs, &mut s.loops)
                }
            };
            s.merged = merged;
            return ok;
        }
        let (ca, cb) = (plane.project(box_a.center()), plane.project(box_b.center()));
        let ContourScratch {
            segs,
            segs_b,
            loops,
            ..
        } = s;
        let (ka, kb) = (p.contour_of(self.mesh, a), p.contour_of(self.mesh, b));
        let (ka, kb) = (&*ka, &*kb);
        let Some(r) = self.reuse else {
            return self.disk_is_height_field(ka, &plane, ca, segs, loops)
                && self.disk_is_height_field(kb, &plane, cb, segs_b, loops)
                && loops_meet_only_where_shared(segs, segs_b, loops);
        };
        let cap = r.cap();
        let slack = self
            .disk_slack(ka, (&plane, ca), cap, segs, loops)
            .and_then(|sa| {
                let sb = self.disk_slack(kb, (&plane, cb), cap, segs_b, loops)?;
                let sab = loops_meet_only_where_shared_slack(segs, segs_b, loops, cap)?;
                Some(sa.min(sb).min(sab))
            });
        r.record((a, b), axis, slack, || {
            self.loop_pairs(r, &plane, (ka, kb), s)
        })
    }
}

/// The topology of the union of adjacent disjoint patches `a` and `b`, its
/// contour written to `merged`: `Some(true)` when they are glued along edges
/// into one disk (Euler characteristic 1, consistent winding), `Some(false)`
/// when they are two disks touching only at vertices, `None` otherwise (no
/// certificate).
fn union_disk(p: &Patches, mesh: &Mesh, a: u32, b: u32, merged: &mut Vec<u32>) -> Option<bool> {
    let (ea, eb) = (p.euler_of(a)?, p.euler_of(b)?);
    let (ka, kb) = (p.contour_of(mesh, a), p.contour_of(mesh, b));
    merged.reserve(ka.len() + kb.len());
    let info = merge_contours(&ka, &kb, merged);
    let shared_v = count_common(&p.boundary_of(mesh, a), &p.boundary_of(mesh, b)) as i32;
    let euler = ea + eb - shared_v + info.shared_edges as i32;
    (!info.conflict && euler == 1).then_some(info.shared_edges > 0)
}

/// The self-certificate of node `n` (module doc): a positive cone, a disk
/// (Euler characteristic 1), and `loop_test` passing on its contour projected
/// along the cone's axis about its box centre; counted in `c`.
fn disk_certified(
    (bvh, mesh): (&Bvh, &Mesh),
    (n, cone): (u32, &NormalCone),
    c: &mut Counters,
    loop_test: impl FnOnce(&[u32], &Plane) -> bool,
) -> bool {
    if !cone.is_positive() {
        return false;
    }
    c.contour_tests += 1;
    let p = &bvh.patches;
    let ok = p.euler_of(n) == Some(1) && {
        let plane = Plane::new(cone.axis, bvh.boxes[n as usize].center());
        loop_test(&p.contour_of(mesh, n), &plane)
    };
    c.contour_fails += !ok as u64;
    c.self_culls += ok as u64;
    ok
}

impl Cull for ContourCull<'_> {
    type Scratch = ContourScratch;

    fn self_culled(&self, n: u32, s: &mut ContourScratch, c: &mut Counters) -> bool {
        let Some(r) = self.reuse else {
            let cone = self.cones.of(n);
            return disk_certified((self.bvh, self.mesh), (n, &cone), c, |contour, plane| {
                self.disk_is_height_field(contour, plane, [0.0; 2], &mut s.segs, &mut s.loops)
            });
        };
        // (A kept certificate's check puts every normal within 90 degrees
        // of its axis: the cone is positive.)
        if let Some(how) = self.reused(r, n, n, s) {
            how.count(c);
            c.self_culls += 1;
            return true;
        }
        let cone = self.cones.of(n);
        disk_certified((self.bvh, self.mesh), (n, &cone), c, |contour, plane| {
            self.certify_disk(r, (n, n), contour, (cone.axis, plane), s)
        })
    }

    fn pair_culled(&self, a: u32, b: u32, s: &mut ContourScratch, c: &mut Counters) -> bool {
        if !self.bvh.patches.may_touch(a, b) {
            return false;
        }
        // A kept certificate first: only adjacent nodes have one (the
        // topology is fixed), and its check puts both cones within 90
        // degrees of one axis, which `adjacent_positive` would ask again.
        if let Some(how) = self.reuse.and_then(|r| self.reused(r, a, b, s)) {
            how.count(c);
            c.pair_culls += 1;
            return true;
        }
        let Some((ca, cb)) = self.cones.adjacent_positive(a, b) else {
            return false;
        };
        c.contour_tests += 1;
        let ok = self.union_is_height_field(a, b, ca.merge(&cb).axis, s);
        c.contour_fails += !ok as u64;
        c.pair_culls += ok as u64;
        ok
    }
}

/// The certificate over a linear motion `x0 -> x1` (continuous queries with
/// thickness 0): with the hierarchy fitted by [`Bvh::refit_swept_cones`],
/// a node's cone holds its normals at every time of the step. If it is
/// positive, the patch is a disk and its contour stays star-shaped about one
/// fixed centre along the cone's axis for the whole step
/// ([`swept_star_about`]), the theorem of the module doc holds at every
/// time: no two elements of the patch that share no vertex ever touch during
/// the step, so no vertex-triangle or edge-edge pair of it has a contact.
/// Adjacent pairs get the same test on their union when they are glued along
/// edges (pairs touching only at vertices are not certified).
pub struct SweptContourCull<'a> {
    bvh: &'a Bvh,
    mesh: &'a Mesh,
    x0: &'a [DVec3],
    x1: &'a [DVec3],
    cones: ConeCull<'a>,
}

impl<'a> SweptContourCull<'a> {
    /// Certificates for `bvh` fitted by [`Bvh::refit_swept_cones`] to `x0 -> x1`.
    pub fn new(bvh: &'a Bvh, mesh: &'a Mesh, x0: &'a [DVec3], x1: &'a [DVec3]) -> Self {
        SweptContourCull {
            bvh,
            mesh,
            x0,
            x1,
            cones: ConeCull::new(bvh, mesh),
        }
    }

    /// Does the disk with `contour` stay a height field along `plane`'s
    /// normal for the whole step (its cone already positive)?
    fn disk_stays_height_field(
        &self,
        contour: &[u32],
        plane: &Plane,
        s: &mut ContourScratch,
    ) -> bool {
        project_contour(self.mesh, self.x0, contour, plane, &mut s.segs);
        project_contour(self.mesh, self.x1, contour, plane, &mut s.segs_b);
        swept_star_about(&s.segs, &s.segs_b, [0.0; 2])
            || swept_simple_ccw_loop(&s.segs, &s.segs_b, &mut s.loops)
    }
}

impl Cull for SweptContourCull<'_> {
    type Scratch = ContourScratch;

    fn self_culled(&self, n: u32, s: &mut ContourScratch, c: &mut Counters) -> bool {
        let cone = self.cones.cones.of(n);
        disk_certified((self.bvh, self.mesh), (n, &cone), c, |contour, plane| {
            self.disk_stays_height_field(contour, plane, s)
        })
    }

    fn pair_culled(&self, a: u32, b: u32, s: &mut ContourScratch, c: &mut Counters) -> bool {
        let Some((ca, cb)) = self.cones.adjacent_positive(a, b) else {
            return false;
        };
        c.contour_tests += 1;
        let bvh = self.bvh;
        let ok = union_disk(&bvh.patches, self.mesh, a, b, &mut s.merged) == Some(true) && {
            let axis = ca.merge(&cb).axis;
            let center = bvh.boxes[a as usize].union(&bvh.boxes[b as usize]).center();
            let merged = std::mem::take(&mut s.merged);
            let ok = self.disk_stays_height_field(&merged, &Plane::new(axis, center), s);
            s.merged = merged;
            ok
        };
        c.contour_fails += !ok as u64;
        c.pair_culls += ok as u64;
        ok
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build::build;
    use crate::bvh::traverse::traverse;
    use crate::detect::narrow::Intersect;

    /// A strip of `n` quads winding `turns` times around the z axis while
    /// rising slowly (a spiral ramp): every normal within a few degrees of +z,
    /// no two triangles touching, but its projection along z overlaps itself
    /// once `turns` > 1.
    fn ramp(n: usize, turns: f64) -> Mesh {
        let mut v = Vec::new();
        for i in 0..=n {
            let t = std::f64::consts::TAU * turns * i as f64 / n as f64;
            for r in [1.0, 2.0] {
                v.push([r * t.cos(), r * t.sin(), 0.05 * t]);
            }
        }
        let q = |i: usize, k: usize| (2 * i + k) as u32;
        let f = (0..n)
            .flat_map(|i| {
                [
                    [q(i, 0), q(i, 1), q(i + 1, 1)],
                    [q(i, 0), q(i + 1, 1), q(i + 1, 0)],
                ]
            })
            .collect();
        Mesh::new(v, f).unwrap()
    }

    fn root_culled(mesh: &Mesh) -> (bool, bool) {
        let mut bvh = build(mesh);
        bvh.refit(mesh, mesh.rest());
        let root = bvh.root();
        let cones = ConeCull::new(&bvh, mesh);
        let contour = ContourCull::new(&bvh, mesh, mesh.rest());
        let mut c = Counters::default();
        (
            cones.self_culled(root, &mut (), &mut c),
            contour.self_culled(root, &mut ContourScratch::default(), &mut c),
        )
    }

    #[test]
    fn contour_refuses_a_ramp_that_overlaps_in_projection() {
        // Half a turn: a height field, culled by both; 1.2 turns: the cone
        // alone still culls, the contour test refuses.
        assert_eq!(root_culled(&ramp(64, 0.5)), (true, true));
        assert_eq!(root_culled(&ramp(64, 1.2)), (true, false));
    }

    #[test]
    fn culls_do_not_change_the_pairs() {
        // The ramp's turns made to cross (height 0.2 sin(1.3 t) at angle t):
        // every cull gives the boxes-only pairs.
        let (n, turns) = (200, 1.6);
        let mesh = ramp(n, turns);
        let p: Vec<DVec3> = (0..mesh.rest().len())
            .map(|k| {
                let t = std::f64::consts::TAU * turns * (k / 2) as f64 / n as f64;
                let x = mesh.rest()[k];
                DVec3::new(x.x, x.y, 0.2 * (1.3 * t).sin())
            })
            .collect();
        let mut bvh = build(&mesh);
        bvh.refit(&mesh, &p);
        let visitor = Intersect {
            mesh: &mesh,
            positions: &p,
        };
        let mut want = traverse(&bvh, &mesh, 0.0, &BoxesOnly, &visitor).0;
        want.sort_unstable();
        assert!(!want.is_empty());
        let mut got = traverse(
            &bvh,
            &mesh,
            0.0,
            &ContourCull::new(&bvh, &mesh, &p),
            &visitor,
        )
        .0;
        got.sort_unstable();
        assert_eq!(got, want);
    }
}
