//! Self-traversal (paper 3.4) of one hierarchy, with a cull callback.
//!
//! ```text
//! self(N)    = nothing if N is a leaf or culled(N), else
//!              self(left) + self(right) + pair(left, right)
//! pair(A, B) = nothing if the boxes are apart, or the slabs (when fitted),
//!              or if pair_culled(A, B); the primitive test if both are
//!              leaves; else pair over the children of the node with the
//!              bigger box.
//! ```
//! The traversal knows boxes, slabs ([`crate::geom::Slab`]: bounds along
//! each node's cone axis, a second bounding volume for near-parallel
//! layers) and the [`Cull`] callbacks only (as parry's BVTT traversal); what
//! a cull means lives in [`super::certify`]. The pair of
//! siblings under a node that was not culled is never offered to
//! `pair_culled`: their union is the node, already refused.
//!
//! Where the cull allows ([`Cull::LEAF_BY_LEAF_WHEN_SMALL`]), the self-test of
//! a node of at most [`Bvh::SMALL`] triangles, or the pair test of two, tests
//! their leaf pairs directly, as the descent tests two leaves, without the
//! node pairs in between (most of a proximity query's node pairs lie there).
//!
//! A split prefetches what the next steps read first (each child's box and
//! children, or triangle): node ids are scattered, and that load was the
//! descent's largest single cost (`crate::prefetch`).
//!
//! **Front.** A traversal may record its *front* ([`Front`]): the jobs at
//! which it stopped (self-tests culled or done leaf by leaf; pairs found
//! apart, culled or tested), which together cover every leaf pair the
//! descent from the root reached. The next frame of a sequence may start
//! from them instead of the root ([`Start::Front`]): each job is tested as
//! the descent tests it, and a job that no longer stops is descended from.
//! The jobs still cover every leaf pair, and a conservative cull is valid
//! at any depth, so the answer is the root's (the leaf pairs tested may
//! differ: a job below a node that is culled again now is still run, and
//! pair descents split by this frame's boxes), without redoing the jobs
//! above the front. A cull that is not conservative (`bvh-cones`) may hide
//! other pairs than from the root. The front only deepens, so the caller
//! records a new one from the root when it has grown.
//!
//! **Clearance.** A recorded job also keeps how far apart what it holds was
//! (its *clearance*; 0 where nothing is known): the gap between the boxes
//! (or, with slabs, the slabs) of a pair found apart, or the visitor's bound
//! on the distance between two leaves it found nothing for
//! ([`LeafVisitor::visit_clear`]). Every point of
//! a node moves at most as far as its farthest vertex, so while no vertex
//! has moved more than half of a job's clearance the boxes are still apart
//! (or the leaves still farther apart than the visitor's distance) and the
//! job stops where it did, finding nothing: a traversal from the front skips
//! it ([`Clearances::Skip`], counted in [`Counters::front_skips`]).
//! Clearances are kept against one set of reference positions: the caller
//! passes the largest vertex displacement from them, a job that stops where
//! it did keeps its clearance, and a new job stores its clearance less twice
//! that displacement (its bound for any later frame through the reference).
//! Measuring costs about a fifth of a frame, so the caller measures only
//! where the motion is slow enough for it to pay ([`Clearances`]). Jobs
//! clear enough to be skipped for many frames can be set apart, so that
//! those frames do not even read them ([`Front::set_far`]).
//!
//! Top levels run in parallel with `rayon::join` (a front, by chunks); each
//! task keeps its own results, counters and cull buffers, and the join order
//! is fixed, so the output is the same for any number of threads.

use super::certify::{BoxesOnly, ConeCull, ContourCull, Cull};
use super::chunks::Chunks;
use super::Bvh;
use crate::mesh::Mesh;
use crate::prefetch::prefetch;
use crate::stats::Counters;
use glam::DVec3;
use rayon::prelude::*;

/// Slabs are compared only for cone axes closer than this cosine (about 45
/// degrees either way): beyond, a slab carried to the other axis is about as
/// wide as the node's box and never culls.
const SLAB_AXES_COS: f64 = 0.7;

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

    /// [`visit_counted`](Self::visit_counted) of triangles `a` and `b`
    /// (not adjacent), returning, when it found nothing, a lower bound on
    /// their distance: while no vertex moves more than half of it, a visit
    /// still finds nothing (module doc, "Clearance"); else 0. The default
    /// knows no bound (0).
    #[inline]
    fn visit_clear(&self, a: u32, b: u32, out: &mut Vec<Self::Item>, c: &mut Counters) -> f64 {
        self.visit_counted(a, b, false, out, c);
        0.0
    }
}

/// Where a traversal starts, and whether it records its front.
#[derive(Debug, Clone, Copy)]
pub enum Start<'a> {
    /// At the root, recording nothing (a single query).
    Root,
    /// At the root, recording the front.
    RootRecording,
    /// At the jobs of a front an earlier traversal of the same hierarchy
    /// recorded, recording the new front, with its clearances as said.
    Front(&'a Front, Clearances),
}

/// What a traversal from a front does with clearances (module doc,
/// "Clearance"). A front recorded from the root has none (all 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Clearances {
    /// No vertex is farther than this from the front's reference positions:
    /// the jobs clearer than twice that are skipped.
    Skip(f64),
    /// These positions become the reference: every job runs and its
    /// clearance is measured.
    Measure,
    /// Every job runs, and the new front has no clearances.
    Drop,
}

impl Start<'_> {
    /// What the traversal does with clearances (a traversal from the root
    /// records none).
    pub fn clearances(&self) -> Clearances {
        match self {
            Start::Front(_, c) => *c,
            _ => Clearances::Drop,
        }
    }
}

impl Clearances {
    /// Twice the vertices' largest move from the reference, rounded up:
    /// what a kept clearance must exceed to be skipped, and what a new one
    /// is stored less (None unless skipping).
    fn twice_moved(self) -> Option<f64> {
        match self {
            Clearances::Skip(moved) => Some(2.0 * moved * (1.0 + 1e-12)),
            _ => None,
        }
    }
}

/// The jobs at which a traversal stopped, in its order (see the module doc),
/// in chunks: one parallel task each, whose jobs' own front is the next
/// front's chunk (no copy into one list). Valid for the hierarchy that
/// recorded it only: it holds node ids.
///
/// The jobs clearer than a limit may be set apart ([`set_far`](Front::set_far)).
/// A traversal skipping by clearances that would skip every one of them
/// (twice its largest move within the limit) does not read them, and the
/// front it records takes them over ([`carry_far`](Front::carry_far)); any
/// other runs them after the others, and its front has none set apart.
#[derive(Debug, Clone, Default)]
pub struct Front {
    chunks: Vec<Vec<Stop>>,
    far: Vec<Vec<Stop>>,
    /// Every job in `far` is clearer than this, in the clearances' unit.
    far_limit: f64,
}

/// A job at which a traversal stopped, with its clearance at the front's
/// reference positions (module doc) in units of [`clear_unit`], rounded
/// down to `f32` (half the bytes of a `f64`, and the jobs are streamed every
/// frame).
#[derive(Debug, Clone, Copy)]
struct Stop {
    job: Job,
    clear: f32,
}

impl Stop {
    /// `job` with clearance `clear` (rounded down; 0 unless positive) in
    /// units of `unit`.
    #[inline]
    fn new(job: Job, clear: f64, unit: f64) -> Stop {
        // A relative 1e-6 below `clear` is below the f32 nearest it (normal
        // f32 only: subnormal ones round by more, so they are dropped).
        let clear = (clear / unit * (1.0 - 1e-6)).min(f32::MAX as f64);
        Stop {
            job,
            clear: if clear >= 1e-30 { clear as f32 } else { 0.0 },
        }
    }
}

/// The unit of a front's clearances: the power of two nearest the mesh's
/// mean rest edge length (so that `f32` holds them at any scale; dividing
/// by it is exact), or 1 where that is not finite and positive.
fn clear_unit(mesh: &Mesh) -> f64 {
    let e = mesh.mean_edge_length();
    let unit = e.log2().round().exp2();
    if unit.is_normal() {
        unit
    } else {
        1.0
    }
}

impl Front {
    /// Number of jobs.
    pub fn len(&self) -> usize {
        self.chunks.iter().chain(&self.far).map(Vec::len).sum()
    }

    /// True when the traversal stopped nowhere below the root (a leaf root).
    pub fn is_empty(&self) -> bool {
        self.chunks.iter().chain(&self.far).all(Vec::is_empty)
    }

    /// Sets apart the jobs clearer than `clearance` (a length), of a
    /// traversal of the hierarchy built for `mesh` (type doc), keeping their
    /// order.
    pub fn set_far(&mut self, mesh: &Mesh, clearance: f64) {
        let limit = clearance / clear_unit(mesh);
        let (mut near, mut far) = (Vec::new(), Vec::new());
        let chunks = std::mem::take(&mut self.chunks).into_iter();
        for chunk in chunks.chain(std::mem::take(&mut self.far)) {
            let (f, n): (Vec<Stop>, Vec<Stop>) =
                chunk.into_iter().partition(|s| s.clear as f64 > limit);
            near.extend((!n.is_empty()).then_some(n));
            far.extend((!f.is_empty()).then_some(f));
        }
        (self.chunks, self.far, self.far_limit) = (near, far, limit);
    }

    /// Takes over the jobs `from` set apart, where the traversal from `from`
    /// with `clearances` (whose front this is) skipped them. False when it
    /// read them instead (then this front has none set apart).
    pub fn carry_far(&mut self, from: &mut Front, clearances: Clearances, mesh: &Mesh) -> bool {
        if from.far.is_empty() {
            return true;
        }
        let skipped = from.skips_far(clearances, clear_unit(mesh));
        if skipped {
            self.far = std::mem::take(&mut from.far);
            self.far_limit = from.far_limit;
        }
        skipped
    }

    /// Number of jobs set apart, and the limit they are clearer than (in
    /// the clearances' unit).
    pub fn far(&self) -> (usize, f64) {
        (self.far.iter().map(Vec::len).sum(), self.far_limit)
    }

    /// Would a traversal with `clearances` skip every job set apart
    /// (clearances in units of `unit`)?
    fn skips_far(&self, clearances: Clearances, unit: f64) -> bool {
        clearances
            .twice_moved()
            .is_some_and(|m| m / unit <= self.far_limit)
    }
}

/// Front jobs per chunk when recorded from the root.
const FRONT_CHUNK: usize = 2048;
/// How many front jobs ahead the boxes are prefetched.
const FRONT_AHEAD: usize = 8;

/// Runs the self-traversal of `bvh` (refitted to `positions`) with the
/// culling `opts` ask for, and returns what the visitor reported, in a fixed
/// order, with the work counters.
pub fn self_traverse<V: LeafVisitor>(
    bvh: &Bvh,
    mesh: &Mesh,
    positions: &[DVec3],
    opts: TraverseOptions,
    visitor: &V,
) -> (Vec<V::Item>, Counters) {
    let (items, counters, _) = self_traverse_from(bvh, mesh, positions, opts, visitor, Start::Root);
    (items, counters)
}

/// [`self_traverse`] from `start`; also returns the front when it records one.
pub fn self_traverse_from<V: LeafVisitor>(
    bvh: &Bvh,
    mesh: &Mesh,
    positions: &[DVec3],
    opts: TraverseOptions,
    visitor: &V,
    start: Start,
) -> (Vec<V::Item>, Counters, Option<Front>) {
    let (items, counters, front) = self_run(bvh, mesh, positions, opts, visitor, start);
    (items.into_vec(), counters, front)
}

/// [`self_traverse`]'s items as the tasks left them: lists in a fixed
/// order, none much longer than 32,768 items, for a caller that reads them
/// once (a proximity query may find millions; joining the lists would copy
/// each item again).
pub fn self_traverse_parts<V: LeafVisitor>(
    bvh: &Bvh,
    mesh: &Mesh,
    positions: &[DVec3],
    opts: TraverseOptions,
    visitor: &V,
) -> (Vec<Vec<V::Item>>, Counters) {
    let (items, counters, _) = self_run(bvh, mesh, positions, opts, visitor, Start::Root);
    (items.into_chunks(), counters)
}

/// [`self_traverse_from`] with its items as chunks.
fn self_run<V: LeafVisitor>(
    bvh: &Bvh,
    mesh: &Mesh,
    positions: &[DVec3],
    opts: TraverseOptions,
    visitor: &V,
    start: Start,
) -> (Chunks<V::Item>, Counters, Option<Front>) {
    let gap = opts.gap;
    match (opts.cones, opts.contour) {
        (false, _) => run_from(bvh, mesh, gap, &BoxesOnly, visitor, start),
        (true, false) => {
            let cull = ConeCull::new(bvh, mesh);
            run_from(bvh, mesh, gap, &cull, visitor, start)
        }
        (true, true) => {
            let cull = ContourCull::new(bvh, mesh, positions);
            run_from(bvh, mesh, gap, &cull, visitor, start)
        }
    }
}

/// Runs the self-traversal of `bvh` with boxes closer than `gap` counting as
/// overlapping and `cull` deciding what to skip; returns what the visitor
/// reported, in a fixed order, with the work counters.
pub fn traverse<C: Cull, V: LeafVisitor>(
    bvh: &Bvh,
    mesh: &Mesh,
    gap: f64,
    cull: &C,
    visitor: &V,
) -> (Vec<V::Item>, Counters) {
    let (items, counters, _) = traverse_from(bvh, mesh, gap, cull, visitor, Start::Root);
    (items, counters)
}

/// [`traverse`] from `start`; also returns the front when it records one
/// (from [`Start::RootRecording`] and [`Start::Front`]). Starting from a
/// front counts its jobs in [`Counters::front_jobs`].
pub fn traverse_from<C: Cull, V: LeafVisitor>(
    bvh: &Bvh,
    mesh: &Mesh,
    gap: f64,
    cull: &C,
    visitor: &V,
    start: Start,
) -> (Vec<V::Item>, Counters, Option<Front>) {
    let (items, counters, front) = run_from(bvh, mesh, gap, cull, visitor, start);
    (items.into_vec(), counters, front)
}

/// [`traverse_from`] with its items as chunks.
fn run_from<C: Cull, V: LeafVisitor>(
    bvh: &Bvh,
    mesh: &Mesh,
    gap: f64,
    cull: &C,
    visitor: &V,
    start: Start,
) -> (Chunks<V::Item>, Counters, Option<Front>) {
    let ctx = Ctx {
        bvh,
        mesh,
        gap,
        small_end: if C::LEAF_BY_LEAF_WHEN_SMALL {
            bvh.small_end()
        } else {
            0
        },
        slab_gap: bvh
            .has_slabs()
            .then(|| bvh.slab_error().map(|e| gap + e))
            .flatten(),
        cull,
        visitor,
        record: !matches!(start, Start::Root),
        clearances: start.clearances(),
        unit: clear_unit(mesh),
    };
    let acc = match start {
        Start::Front(front, c) => {
            let skips_far = front.skips_far(c, ctx.unit);
            let mut chunks: Vec<&Vec<Stop>> = front.chunks.iter().collect();
            if !skips_far {
                chunks.extend(&front.far);
            }
            let mut acc = ctx.front_task(&chunks);
            if skips_far {
                acc.counters.front_skips += front.far.iter().map(Vec::len).sum::<usize>() as u64;
            }
            acc
        }
        Start::Root | Start::RootRecording => {
            // Spawn parallel tasks only where there is enough work to share.
            let par_depth = if bvh.n_leaves >= 4096 { 10 } else { 0 };
            ctx.self_task(bvh.root(), par_depth)
        }
    };
    let Acc {
        items,
        front,
        mut counters,
        ..
    } = acc;
    let front = match start {
        Start::Root => None,
        Start::RootRecording => {
            let jobs = front.into_vec();
            Some(Front {
                chunks: jobs.chunks(FRONT_CHUNK).map(<[Stop]>::to_vec).collect(),
                ..Front::default()
            })
        }
        Start::Front(kept, _) => {
            counters.front_jobs = kept.len() as u64;
            // Each chunk's task gave one chunk of the new front.
            Some(Front {
                chunks: front.into_chunks(),
                ..Front::default()
            })
        }
    };
    (items, counters, front)
}

struct Ctx<'a, C, V> {
    bvh: &'a Bvh,
    mesh: &'a Mesh,
    gap: f64,
    /// Nodes below this id are tested leaf pair by leaf pair (0: none).
    small_end: u32,
    /// The gap slabs must exceed: `gap` plus the carry's rounding, or None
    /// where slabs bound nothing.
    slab_gap: Option<f64>,
    cull: &'a C,
    visitor: &'a V,
    /// Keep the jobs at which the traversal stops ([`Front`]).
    record: bool,
    /// What the traversal does with clearances.
    clearances: Clearances,
    /// The unit of the front's clearances ([`clear_unit`]).
    unit: f64,
}

/// What one task found: its items and front jobs in order, its counters,
/// the cull's scratch and the descent's stack.
struct Acc<T, S> {
    items: Chunks<T>,
    front: Chunks<Stop>,
    counters: Counters,
    scratch: S,
    stack: Vec<Job>,
}

impl<T, S: Default> Acc<T, S> {
    fn new() -> Self {
        Acc {
            items: Chunks::default(),
            front: Chunks::default(),
            counters: Counters::default(),
            scratch: S::default(),
            stack: Vec::new(),
        }
    }

    /// This task's items and front, then `o`'s.
    fn join(mut self, o: Acc<T, S>) -> Self {
        self.items.join(o.items);
        self.front.join(o.front);
        self.counters.add(&o.counters);
        self
    }
}

/// A stack entry: a self-test, a pair of siblings, or any other pair.
#[derive(Debug, Clone, Copy)]
enum Job {
    Node(u32),
    Pair(u32, u32, bool),
}

impl<C: Cull, V: LeafVisitor> Ctx<'_, C, V> {
    fn self_task(&self, n: u32, depth: u32) -> Acc<V::Item, C::Scratch> {
        let mut acc = Acc::new();
        if depth == 0 {
            self.run(Job::Node(n), None, &mut acc);
            return acc;
        }
        if self.bvh.is_leaf(n) {
            return acc;
        }
        if self.self_culled(n, &mut acc) {
            self.stop(Job::Node(n), Clear::None, None, &mut acc);
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
            || self.pair_task(l, r, true, depth - 1),
        );
        acc.join(x).join(y).join(z)
    }

    fn pair_task(&self, a: u32, b: u32, siblings: bool, depth: u32) -> Acc<V::Item, C::Scratch> {
        let mut acc = Acc::new();
        if depth == 0 {
            self.run(Job::Pair(a, b, siblings), None, &mut acc);
            return acc;
        }
        match self.pair_step(a, b, siblings, true, &mut acc) {
            Step::Done(clear) => {
                self.stop(Job::Pair(a, b, siblings), clear, None, &mut acc);
                acc
            }
            Step::Split(keep, [x, y]) => {
                let (p, q) = rayon::join(
                    || self.pair_task(keep, x, false, depth - 1),
                    || self.pair_task(keep, y, false, depth - 1),
                );
                acc.join(p).join(q)
            }
        }
    }

    /// The jobs of a front, a chunk per parallel task, each job run as the
    /// descent runs it; the tasks' fronts are the new front's chunks (a
    /// chunk's task joins nothing, so its whole front is one).
    fn front_task(&self, chunks: &[&Vec<Stop>]) -> Acc<V::Item, C::Scratch> {
        // Jobs clearer than this (in the clearances' unit) stop where they
        // did, finding nothing (none when these positions become the
        // reference). Dividing by a power of two is exact, or overflows to
        // infinity (nothing skipped), or underflows far below any kept
        // clearance (at least 1e-30 units).
        let skip = (self.clearances.twice_moved()).map_or(f64::INFINITY, |m| m / self.unit);
        let chunk = |jobs: &Vec<Stop>| {
            let mut acc = Acc::new();
            acc.front.last.reserve(jobs.len() + jobs.len() / 8);
            for (i, &stop) in jobs.iter().enumerate() {
                if stop.clear as f64 > skip {
                    acc.counters.front_skips += 1;
                    acc.front.last.push(stop);
                    continue;
                }
                if let Some(&Stop {
                    job: Job::Pair(a, b, _),
                    clear,
                }) = jobs.get(i + FRONT_AHEAD)
                {
                    if clear as f64 <= skip {
                        // Boxes only: most front jobs stop at their boxes, and
                        // `prefetch_node`'s children too made the crumpled grid
                        // 9% slower.
                        prefetch(&self.bvh.boxes[a as usize]);
                        prefetch(&self.bvh.boxes[b as usize]);
                    }
                }
                // A job that stops where it did keeps its clearance (a bound
                // at the reference positions, which have not changed).
                let kept = match self.clearances {
                    Clearances::Skip(_) => Some(stop.clear),
                    _ => None,
                };
                self.run(stop.job, kept, &mut acc);
            }
            acc
        };
        let accs: Vec<_> = chunks.par_iter().map(|&c| chunk(c)).collect();
        accs.into_iter().fold(Acc::new(), Acc::join)
    }

    /// Sequential traversal from one job with the task's stack.
    /// `kept`: the clearance `job` keeps if it stops where it is.
    fn run(&self, job: Job, mut kept: Option<f32>, acc: &mut Acc<V::Item, C::Scratch>) {
        let mut stack = std::mem::take(&mut acc.stack);
        stack.push(job);
        while let Some(job) = stack.pop() {
            let kept = kept.take();
            match job {
                Job::Node(n) => {
                    if self.bvh.is_leaf(n) {
                        continue;
                    }
                    if self.self_culled(n, acc) {
                        self.stop(job, Clear::None, kept, acc);
                    } else if n < self.small_end {
                        self.small_self(n, acc);
                        self.stop(job, Clear::None, kept, acc);
                    } else {
                        let [l, r] = self.bvh.children_of(n);
                        stack.extend([Job::Pair(l, r, true), Job::Node(r), Job::Node(l)]);
                    }
                }
                Job::Pair(a, b, siblings) => {
                    match self.pair_step(a, b, siblings, kept.is_none(), acc) {
                        Step::Split(keep, [x, y]) => {
                            self.prefetch_node(y);
                            self.prefetch_node(x);
                            stack.extend([Job::Pair(keep, y, false), Job::Pair(keep, x, false)]);
                        }
                        Step::Done(clear) => self.stop(job, clear, kept, acc),
                    }
                }
            }
        }
        acc.stack = stack;
    }

    /// The traversal stopped at `job`: a front job, when recording, with
    /// its `kept` clearance, or the one measured from `clear` at these
    /// positions less twice their displacement from the front's reference.
    #[inline]
    fn stop(&self, job: Job, clear: Clear, kept: Option<f32>, acc: &mut Acc<V::Item, C::Scratch>) {
        if !self.record {
            return;
        }
        let stop = match (kept, self.clearances) {
            (Some(clear), _) => Stop { job, clear },
            (None, Clearances::Drop) => Stop { job, clear: 0.0 },
            (None, c) => {
                let clear = self.clearance(clear) - c.twice_moved().unwrap_or(0.0);
                Stop::new(job, clear, self.unit)
            }
        };
        acc.front.last.push(stop);
    }

    /// The clearance at these positions of what a stopped job holds.
    fn clearance(&self, clear: Clear) -> f64 {
        match clear {
            Clear::None => 0.0,
            Clear::Boxes(a, b) => {
                let (x, y) = (&self.bvh.boxes[a as usize], &self.bvh.boxes[b as usize]);
                // The gap along the axis that separates them most, beyond the traversal's.
                let boxes = (x.min - y.max).max(y.min - x.max).max_element() - self.gap;
                boxes.max(self.slab_clearance(a, b).unwrap_or(0.0))
            }
            Clear::Leaves(c) => c,
        }
    }

    /// Prefetches what a pair step on `n` reads first: its box, and its
    /// children (internal) or triangle (leaf).
    #[inline(always)]
    fn prefetch_node(&self, n: u32) {
        let bvh = self.bvh;
        prefetch(&bvh.boxes[n as usize]);
        if bvh.is_leaf(n) {
            prefetch(&self.mesh.triangles()[n as usize]);
        } else {
            prefetch(&bvh.children[n as usize - bvh.n_leaves]);
        }
    }

    #[inline]
    fn self_culled(&self, n: u32, acc: &mut Acc<V::Item, C::Scratch>) -> bool {
        self.cull
            .self_culled(n, &mut acc.scratch, &mut acc.counters)
    }

    /// The primitive test of two leaves (kept out of the descent's hot
    /// loop); returns their clearance when `measure` and recording with
    /// clearances.
    #[inline(never)]
    fn leaf_pair(
        &self,
        a: u32,
        b: u32,
        measure: bool,
        acc: &mut Acc<V::Item, C::Scratch>,
    ) -> Clear {
        let adjacent = self.mesh.share_vertex(a as usize, b as usize);
        if adjacent {
            acc.counters.adjacent_skips += 1;
            if V::SKIP_ADJACENT {
                return Clear::None;
            }
        }
        acc.counters.primitive_tests += 1;
        let (lo, hi) = (a.min(b), a.max(b));
        let (items, c) = (&mut acc.items.last, &mut acc.counters);
        if !(measure && self.record) || self.clearances == Clearances::Drop || adjacent {
            self.visitor.visit_counted(lo, hi, adjacent, items, c);
            acc.items.set_aside_when_full();
            return Clear::None;
        }
        let clear = self.visitor.visit_clear(lo, hi, items, c);
        acc.items.set_aside_when_full();
        Clear::Leaves(clear)
    }

    /// The leaf pairs of small node `n`, each tested as the descent tests
    /// two leaves ([`leaf_row`](Self::leaf_row)).
    fn small_self(&self, n: u32, acc: &mut Acc<V::Item, C::Scratch>) {
        let mut leaves = [0; Bvh::SMALL];
        let k = self.bvh.small_leaves(n, &mut leaves);
        for (i, &x) in leaves[..k].iter().enumerate() {
            self.leaf_row(x, &leaves[i + 1..k], acc);
        }
    }

    /// The leaf pairs of small nodes `a` and `b`, each tested as the descent
    /// tests two leaves.
    fn small_pair(&self, a: u32, b: u32, acc: &mut Acc<V::Item, C::Scratch>) {
        let (mut la, mut lb) = ([0; Bvh::SMALL], [0; Bvh::SMALL]);
        let (ka, kb) = (
            self.bvh.small_leaves(a, &mut la),
            self.bvh.small_leaves(b, &mut lb),
        );
        for &x in &la[..ka] {
            self.leaf_row(x, &lb[..kb], acc);
        }
    }

    /// Leaf `x` with each of `ys` as the descent tests two leaves (boxes
    /// within the gap, counted as node pairs; then slabs, then the leaf
    /// test): the box tests first, all of them without a branch (each is a
    /// coin flip for the branch predictor), then the pairs they keep.
    #[inline]
    fn leaf_row(&self, x: u32, ys: &[u32], acc: &mut Acc<V::Item, C::Scratch>) {
        let boxes = &self.bvh.boxes;
        let bx = &boxes[x as usize];
        let near = ys.iter().enumerate().fold(0u32, |m, (k, &y)| {
            m | (bx.within(&boxes[y as usize], self.gap) as u32) << k
        });
        acc.counters.node_pairs += ys.len() as u64;
        for k in crate::bits::set_bits(u64::from(near)) {
            let y = ys[k];
            if self.slabs_apart(x, y) {
                acc.counters.slab_culls += 1;
            } else {
                self.leaf_pair(x, y, false, acc);
            }
        }
    }

    /// The first tests of every node pair, counted: do the boxes meet within
    /// the gap and the slabs not rule the pair out?
    #[inline]
    fn may_meet(&self, a: u32, b: u32, acc: &mut Acc<V::Item, C::Scratch>) -> bool {
        acc.counters.node_pairs += 1;
        let boxes = &self.bvh.boxes;
        if !boxes[a as usize].within(&boxes[b as usize], self.gap) {
            return false;
        }
        if self.slabs_apart(a, b) {
            acc.counters.slab_culls += 1;
            return false;
        }
        true
    }

    /// Are the nodes apart along `a`'s cone axis ([`crate::geom::Slab`]:
    /// `a`'s slab against `b`'s carried to it)? Only tried for axes within
    /// [`SLAB_AXES_COS`]. (Trying `b`'s axis too cost more than it culled.)
    #[inline]
    fn slabs_apart(&self, a: u32, b: u32) -> bool {
        self.slab_clearance(a, b).is_some_and(|c| c > 0.0)
    }

    /// How much the nodes' slabs along `a`'s cone axis are farther apart
    /// than the slab gap ([`slabs_apart`](Self::slabs_apart) when
    /// positive), or None where slabs are not compared. The axis is a unit
    /// vector up to rounding, so the gap bounds the distance between the
    /// nodes (a projection moves no point farther than it is from another).
    #[inline]
    fn slab_clearance(&self, a: u32, b: u32) -> Option<f64> {
        let gap = self.slab_gap?;
        let (bvh, (a, b)) = (self.bvh, (a as usize, b as usize));
        let (ua, ub) = (bvh.cones[a].axis, bvh.cones[b].axis);
        if ua.dot(ub).abs() < SLAB_AXES_COS {
            return None;
        }
        let (sa, sb) = (&bvh.slabs[a], bvh.slabs[b].carry(ub, &bvh.boxes[b], ua));
        Some((sb.lo - sa.hi).max(sa.lo - sb.hi) - gap)
    }

    /// One step of pair(a, b): tests and culls, and returns the pairs to
    /// descend into, or that the pair is done with its clearance (two
    /// leaves' measured only when `measure`: a front job that stops where it
    /// did keeps its own).
    #[inline]
    fn pair_step(
        &self,
        a: u32,
        b: u32,
        siblings: bool,
        measure: bool,
        acc: &mut Acc<V::Item, C::Scratch>,
    ) -> Step {
        let bvh = self.bvh;
        if !self.may_meet(a, b, acc) {
            return Step::Done(Clear::Boxes(a, b));
        }
        let (ba, bb) = (&bvh.boxes[a as usize], &bvh.boxes[b as usize]);
        let (la, lb) = (bvh.is_leaf(a), bvh.is_leaf(b));
        if la && lb {
            return Step::Done(self.leaf_pair(a, b, measure, acc));
        }
        if !siblings
            && self
                .cull
                .pair_culled(a, b, &mut acc.scratch, &mut acc.counters)
        {
            return Step::Done(Clear::None);
        }
        if a < self.small_end && b < self.small_end {
            self.small_pair(a, b, acc);
            return Step::Done(Clear::None);
        }
        let split_b = la || (!lb && bb.surface_area() > ba.surface_area());
        if split_b {
            Step::Split(a, bvh.children_of(b))
        } else {
            Step::Split(b, bvh.children_of(a))
        }
    }
}

/// What one step of pair(a, b) decided.
enum Step {
    /// Descend into the pairs of the node kept with each child of the other.
    Split(u32, [u32; 2]),
    /// Done, with what its clearance would be measured from ([`Stop`]).
    Done(Clear),
}

/// What a stopped job's clearance is measured from, when it is needed
/// (recording, and no clearance kept for the job).
#[derive(Clone, Copy)]
enum Clear {
    /// Nothing known: 0.
    None,
    /// Boxes (or slabs) found apart.
    Boxes(u32, u32),
    /// Leaves whose visit found nothing, and their clearance (measured
    /// only where the traversal measures).
    Leaves(f64),
}
