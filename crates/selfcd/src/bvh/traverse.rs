//! Self-traversal (paper 3.4) with cone and contour culling.
//!
//! ```text
//! self(N)    = nothing if N is a leaf or culled(N), else
//!              self(left) + self(right) + pair(left, right)
//! pair(A, B) = nothing if the boxes are apart, or if A and B are adjacent and
//!              their union is culled; the primitive test if both are leaves;
//!              else pair over the children of the node with the bigger box.
//! ```
//! Top levels run in parallel with `rayon::join`; each task keeps its own
//! results and counters, and the join order is fixed, so the output is the
//! same for any number of threads.

use super::patch::{count_common, have_common, merge_contours, project_contour};
use super::Bvh;
use crate::geom::loop2d::{loops_meet_only_where_shared, simple_ccw_loop, star_about, Plane, Seg};
use crate::mesh::Mesh;
use crate::stats::Counters;
use glam::DVec3;

/// Which culling tests the traversal runs, and how far apart boxes may be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraverseOptions {
    /// Skip nodes and adjacent pairs whose normal cone is under 90 degrees.
    pub cones: bool,
    /// Require the star contour test as well before a cone cull (conservative).
    pub contour: bool,
    /// Boxes count as overlapping when their gap is at most this (proximity thickness).
    pub gap: f64,
}

/// The narrow phase run on each leaf pair whose boxes overlap.
pub trait LeafVisitor: Sync {
    /// What a visit reports.
    type Item: Send;
    /// True when leaf pairs sharing a vertex are skipped without a visit.
    const SKIP_ADJACENT: bool;
    /// Tests triangles `a` and `b` (a != b) and appends what it finds to `out`.
    fn visit(&self, a: u32, b: u32, adjacent: bool, out: &mut Vec<Self::Item>);

    /// [`visit`](Self::visit), also counting what the test did in `counters`
    /// (e.g. filter decisions); the default counts nothing.
    #[inline]
    fn visit_counted(
        &self,
        a: u32,
        b: u32,
        adjacent: bool,
        out: &mut Vec<Self::Item>,
        _counters: &mut Counters,
    ) {
        self.visit(a, b, adjacent, out)
    }
}

/// Runs the self-traversal of `bvh` (refitted to `positions`) and returns what
/// the visitor reported, in a fixed order, with the work counters.
pub fn self_traverse<V: LeafVisitor>(
    bvh: &Bvh,
    mesh: &Mesh,
    positions: &[DVec3],
    opts: TraverseOptions,
    visitor: &V,
) -> (Vec<V::Item>, Counters) {
    let ctx = Ctx {
        bvh,
        mesh,
        positions,
        opts,
        visitor,
    };
    // Spawn parallel tasks only where there is enough work to share.
    let par_depth = if bvh.n_leaves >= 4096 { 10 } else { 0 };
    let acc = ctx.self_task(bvh.root(), par_depth);
    (acc.items, acc.counters)
}

struct Ctx<'a, V> {
    bvh: &'a Bvh,
    mesh: &'a Mesh,
    positions: &'a [DVec3],
    opts: TraverseOptions,
    visitor: &'a V,
}

struct Acc<T> {
    items: Vec<T>,
    counters: Counters,
    scratch: Vec<u32>,
    segs: Vec<Seg>,
    segs_b: Vec<Seg>,
}

impl<T> Acc<T> {
    fn new() -> Self {
        Acc {
            items: Vec::new(),
            counters: Counters::default(),
            scratch: Vec::new(),
            segs: Vec::new(),
            segs_b: Vec::new(),
        }
    }

    fn join(mut self, o: Acc<T>) -> Self {
        self.items.extend(o.items);
        self.counters.add(&o.counters);
        self
    }
}

/// Marks a stack entry as a self-test rather than a pair.
const SELF: u32 = u32::MAX;

impl<V: LeafVisitor> Ctx<'_, V> {
    fn self_task(&self, n: u32, depth: u32) -> Acc<V::Item> {
        let mut acc = Acc::new();
        if depth == 0 {
            self.run(n, SELF, &mut acc);
            return acc;
        }
        if self.bvh.is_leaf(n) || self.self_culled(n, &mut acc) {
            return acc;
        }
        let [l, r] = self.bvh.children_of(n);
        let ((x, y), z) = rayon::join(
            || {
                rayon::join(
                    || self.self_task(l, depth - 1),
                    || self.self_task(r, depth - 1),
                )
            },
            || self.pair_task(l, r, depth - 1),
        );
        acc.join(x).join(y).join(z)
    }

    fn pair_task(&self, a: u32, b: u32, depth: u32) -> Acc<V::Item> {
        let mut acc = Acc::new();
        if depth == 0 {
            self.run(a, b, &mut acc);
            return acc;
        }
        match self.pair_step(a, b, &mut acc) {
            None => acc,
            Some((keep, [x, y])) => {
                let (p, q) = rayon::join(
                    || self.pair_task(keep, x, depth - 1),
                    || self.pair_task(keep, y, depth - 1),
                );
                acc.join(p).join(q)
            }
        }
    }

    /// Sequential traversal from one task with an explicit stack.
    fn run(&self, a: u32, b: u32, acc: &mut Acc<V::Item>) {
        let mut stack = vec![(a, b)];
        while let Some((a, b)) = stack.pop() {
            if b == SELF {
                if !self.bvh.is_leaf(a) && !self.self_culled(a, acc) {
                    let [l, r] = self.bvh.children_of(a);
                    stack.extend([(l, r), (r, SELF), (l, SELF)]);
                }
            } else if let Some((keep, [x, y])) = self.pair_step(a, b, acc) {
                stack.extend([(keep, y), (keep, x)]);
            }
        }
    }

    /// One step of pair(a, b): tests and culls, and returns the pairs to descend
    /// into as (node kept, children of the node split), or None when done.
    fn pair_step(&self, a: u32, b: u32, acc: &mut Acc<V::Item>) -> Option<(u32, [u32; 2])> {
        let bvh = self.bvh;
        acc.counters.node_pairs += 1;
        let (ba, bb) = (&bvh.boxes[a as usize], &bvh.boxes[b as usize]);
        if !ba.within(bb, self.opts.gap) {
            return None;
        }
        let (la, lb) = (bvh.is_leaf(a), bvh.is_leaf(b));
        if la && lb {
            let adjacent = self.mesh.share_vertex(a as usize, b as usize);
            if adjacent {
                acc.counters.adjacent_skips += 1;
                if V::SKIP_ADJACENT {
                    return None;
                }
            }
            acc.counters.primitive_tests += 1;
            self.visitor.visit_counted(
                a.min(b),
                a.max(b),
                adjacent,
                &mut acc.items,
                &mut acc.counters,
            );
            return None;
        }
        if self.pair_culled(a, b, acc) {
            return None;
        }
        let split_b = la || (!lb && bb.surface_area() > ba.surface_area());
        Some(if split_b {
            (a, bvh.children_of(b))
        } else {
            (b, bvh.children_of(a))
        })
    }

    fn self_culled(&self, n: u32, acc: &mut Acc<V::Item>) -> bool {
        let bvh = self.bvh;
        let cone = &bvh.cones[n as usize];
        if !self.opts.cones || !cone.is_positive() {
            return false;
        }
        if self.opts.contour {
            acc.counters.contour_tests += 1;
            let p = &bvh.patches;
            let ok = p.eligible[n as usize] && p.euler[n as usize] == 1 && {
                let plane = Plane::new(cone.axis, bvh.boxes[n as usize].center());
                self.disk_is_height_field(p.contour_of(n), &plane, [0.0; 2], &mut acc.segs)
            };
            if !ok {
                acc.counters.contour_fails += 1;
                return false;
            }
        }
        acc.counters.self_culls += 1;
        true
    }

    /// The projected contour of a disk-like patch is one simple counter-clockwise
    /// loop: the star test about `center` first, the exact loop test if that fails.
    fn disk_is_height_field(
        &self,
        contour: &[u32],
        plane: &Plane,
        center: [f64; 2],
        segs: &mut Vec<Seg>,
    ) -> bool {
        project_contour(self.mesh, self.positions, contour, plane, segs);
        star_about(segs, center) || simple_ccw_loop(segs)
    }

    fn pair_culled(&self, a: u32, b: u32, acc: &mut Acc<V::Item>) -> bool {
        if !self.opts.cones {
            return false;
        }
        let bvh = self.bvh;
        let (ca, cb) = (&bvh.cones[a as usize], &bvh.cones[b as usize]);
        let p = &bvh.patches;
        // Cheapest first: the merged cone can only be positive if both are, and
        // it is only worth merging for adjacent patches (most overlapping pairs
        // in layered cloth are not adjacent).
        if !ca.is_positive()
            || !cb.is_positive()
            || !have_common(p.boundary_of(a), p.boundary_of(b))
        {
            return false;
        }
        let merged = ca.merge(cb);
        if !merged.is_positive() {
            return false;
        }
        if self.opts.contour {
            acc.counters.contour_tests += 1;
            if !(p.eligible[a as usize]
                && p.eligible[b as usize]
                && self.union_is_height_field(a, b, merged.axis, acc))
            {
                acc.counters.contour_fails += 1;
                return false;
            }
        }
        acc.counters.pair_culls += 1;
        true
    }

    /// Is the union of adjacent disjoint patches a and b a height field along
    /// `axis`? When they share edges the union is a disk (Euler characteristic
    /// 1, no conflicting edge) and its contour gets the node test; when they
    /// touch only at vertices each patch's loop must be simple and the two
    /// loops meet only where the patches do.
    fn union_is_height_field(&self, a: u32, b: u32, axis: DVec3, acc: &mut Acc<V::Item>) -> bool {
        let (bvh, p) = (self.bvh, &self.bvh.patches);
        let info = merge_contours(p.contour_of(a), p.contour_of(b), &mut acc.scratch);
        let shared_v = count_common(p.boundary_of(a), p.boundary_of(b)) as i32;
        let euler = p.euler[a as usize] + p.euler[b as usize] - shared_v + info.shared_edges as i32;
        if info.conflict || euler != 1 {
            return false;
        }
        let (box_a, box_b) = (&bvh.boxes[a as usize], &bvh.boxes[b as usize]);
        let plane = Plane::new(axis, box_a.union(box_b).center());
        if info.shared_edges > 0 {
            // Patches glued along edges: the union is one disk, tested as a node is.
            return self.disk_is_height_field(&acc.scratch, &plane, [0.0; 2], &mut acc.segs);
        }
        let (ca, cb) = (plane.project(box_a.center()), plane.project(box_b.center()));
        self.disk_is_height_field(p.contour_of(a), &plane, ca, &mut acc.segs)
            && self.disk_is_height_field(p.contour_of(b), &plane, cb, &mut acc.segs_b)
            && loops_meet_only_where_shared(&acc.segs, &acc.segs_b)
    }
}
