//! Contour certificates kept from frame to frame (the seed paper's first
//! future-work item: positional relationships change slowly, so cache them).
//!
//! A certificate of [`super::certify::ContourCull`] says that a node, or the
//! union of two adjacent nodes, is a height field along an axis `v`: its
//! normals lie strictly within 90 degrees of `v` and its contour, projected
//! along `v`, is a star about a point or a simple counter-clockwise loop (for
//! two nodes touching only at vertices: two such loops meeting only there).
//! When it is made, the loop tests also say how far (its *slack* `s`) every
//! contour vertex may move, any common translation removed, with the
//! projected loops keeping that property in exact arithmetic
//! ([`star_slack`](crate::geom::loop2d::star_slack),
//! [`simple_ccw_loop_slack`](crate::geom::loop2d::simple_ccw_loop_slack),
//! [`loops_meet_only_where_shared_slack`](crate::geom::loop2d::loops_meet_only_where_shared_slack)).
//!
//! **Bounding the move.** Displacements `e_i = x_i - r_i` are taken from one
//! reference `r`, and every node gets the box of its vertices'
//! displacements, fitted bottom-up each frame. Between the frame `t` a
//! certificate was made and the current one, vertex `i` moved by
//! `e_i - e_i(t)`. Only the part of that move across the certificate's axis
//! moves the projected contour, and both displacements lie in boxes whose
//! points are within `h` and `h(t)` of the line along the axis through the
//! box centre (`half_diagonal_across`), so the projected move is a common
//! translation plus at most `h + h(t)`. The certificate stores `s - h(t)`
//! and holds while `h <= s - h(t)`. The normals are checked on this frame's
//! cones: each must lie strictly within 90 degrees of the stored axis
//! ([`NormalCone::within_90_of`](crate::geom::NormalCone::within_90_of)).
//! The topology (a disk, or two glued along edges) does not change. So a kept
//! certificate is exactly as sound as a fresh one; reusing it costs O(1)
//! instead of a walk along the contour.
//!
//! **One bound for all.** Every node's displacement box lies in the whole
//! mesh's. When that one box is within the slack of every kept certificate
//! (there are some: a flat sheet's single one, a garment's few), they all
//! hold, the frame takes it for every node, and the nodes' boxes are not
//! fitted: one pass over the vertices instead of a second box per triangle
//! and per node. The frame takes it too when the certificates it leaves to a
//! re-check or a fresh test are few enough to cost far less than that fit
//! (a skirt held by four certificates). Certificates made in such a frame
//! store their slack less the whole mesh's spread, which is larger than
//! their own, so they hold for less.
//!
//! **Re-check.** A slack bounds independent moves of every contour vertex,
//! so it is small (about a fiftieth of an edge on a crumpled sheet), and a
//! smooth motion of a tenth of an edge exceeds it while the projected loop
//! stays simple (99-99.8% of the refused certificates on the peer
//! benchmark's wave, BENCHMARKS.md). So a certificate also keeps the plane
//! it was projected on and its contour's edge pairs that a move below the
//! cap could make meet, each with its own slack
//! ([`close_pairs`](crate::geom::loop2d::close_pairs): pairs closer than
//! twice the cap whose slack is below it), and how far the vertices may
//! move with the other conditions of the test holding (the signed areas
//! stay positive; with two loops touching at vertices, a vertex of each
//! outside the other stays outside). While the spread (this frame's plus
//! the one at certification) stays under that reach, the certificate holds
//! exactly when the pairs whose slack the spread reaches are clear now
//! ([`still_clear`](crate::geom::loop2d::still_clear)): the theorem's
//! conditions, at the cost of projecting and comparing those pairs only,
//! without a fresh test's cycle walk and sweep or even the projection of
//! the whole contour.
//!
//! The reference is reset (and every certificate dropped) when the whole
//! mesh's displacement spread exceeds [`RESET`] times the loop test's cap on
//! its slacks: past it few certificates can still hold. When that happens two frames running (the
//! mesh moves too much per frame for any certificate to last), the frame
//! runs the plain tests and records nothing, and until the mesh settles
//! each frame checks the whole mesh's spread in one pass over the vertices
//! instead of fitting the nodes' boxes: fast motion pays that pass only.

use super::refit::ConeFit;
use super::Bvh;
use crate::geom::loop2d::{round_down, ClosePair, Reach};
use crate::geom::Aabb;
use crate::mesh::Mesh;
use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::sync::Mutex;

/// The reference is reset when the mesh's displacement spread exceeds this
/// many times the loop test's cap.
pub const RESET: f64 = 4.0;

/// The close-pair store is compacted only past this many stale entries.
const COMPACT_MIN: usize = 1 << 12;

/// Close pairs are found for a fresh certificate only where this frame's
/// spread is at most this share of the cap: past it the mesh moves fast from
/// the reference and a re-check would seldom be reached, while finding the
/// pairs is a second sweep of the contour. (Measured, one thread,
/// `PROF_WAVE=drift` at 0.15 mean edges a frame: with every fresh test
/// finding them the crumpled grid ran 34% slower; BENCHMARKS.md.)
const RECHECK_SPREAD: f64 = 0.5;

/// `merge` of `of(x - r)` over every vertex's move from reference position
/// `r` to `x` (`empty` for none), on the pool past [`PAR_MIN`] vertices:
/// the one pass over the vertices of the kept certificates' whole spread and
/// of the kept front's largest move. `merge` must be associative and
/// commutative (a box union, a maximum), so the result is the same for any
/// split.
pub(crate) fn fold_moves<T: Copy + Send + Sync>(
    reference: &[DVec3],
    positions: &[DVec3],
    empty: T,
    of: impl Fn(DVec3) -> T + Sync,
    merge: impl Fn(T, T) -> T + Sync,
) -> T {
    let add = |acc: T, (x, r): (&DVec3, &DVec3)| merge(acc, of(*x - *r));
    if positions.len() < PAR_MIN {
        return positions.iter().zip(reference).fold(empty, add);
    }
    let moves = positions.par_iter().zip(reference);
    moves.fold(|| empty, add).reduce(|| empty, &merge)
}

/// What a re-check costs, in fits of one node's displacement box: a rough
/// estimate from one-thread runs (BENCHMARKS.md, eighteenth landing: the fit
/// of every node's box about 27-31 ns a node on skirt_32k; a re-check under
/// 1 us and a fresh test a few us on the garments), used with a margin
/// ([`KeptCertificates::whole_pays`]).
const RECHECK: f64 = 37.0;
/// What a fresh contour test costs, in fits of one node's displacement box
/// (as [`RECHECK`]).
const FRESH: f64 = 110.0;

/// Below this many vertices the displacement pass runs on one thread.
const PAR_MIN: usize = 1 << 14;

/// A kept certificate: the projection axis and how far the vertices may
/// still move from the reference (see the module doc), and what re-checks
/// it exactly once they moved farther ([`Recheck`]).
#[derive(Debug, Clone, Copy)]
pub struct Kept {
    /// Unit axis the patch is a height field along.
    pub axis: DVec3,
    /// The slack left once the displacement spread at certification is taken off.
    pub slack: f64,
    /// The exact re-check, where one was found ([`Recheck`]).
    pub recheck: Option<Recheck>,
}

/// What re-checks a certificate whose slack the spread exceeds (module doc,
/// "Re-check"): the origin of its projection plane, its contour's edge
/// pairs that a move below the cap could make meet, each with its slack
/// less the spread at certification ([`close_pairs`](crate::geom::loop2d::close_pairs)),
/// and the spreads below which they decide and the signed areas hold (the
/// [`Reach`] less the spread at certification).
#[derive(Debug, Clone, Copy)]
pub struct Recheck {
    /// Origin of the projection plane (its axis is the certificate's).
    pub origin: DVec3,
    /// The close pairs: `pairs[start..start + len]` of the store.
    pub start: u32,
    /// Number of close pairs.
    pub len: u32,
    /// The spread up to which the close pairs decide.
    pub within: f64,
    /// The spread up to which the signed areas stay positive (beyond it
    /// they are measured).
    pub area_within: f64,
    /// The margin of the pairs' tests ([`Reach::eps`]).
    pub eps: f64,
}

/// A fresh certificate's re-check data before it is stored.
#[derive(Debug, Clone)]
struct FreshRecheck {
    origin: DVec3,
    pairs: Vec<ClosePair>,
    within: f64,
    area_within: f64,
    eps: f64,
}

/// What a fresh certificate offers a re-check: the origin of its plane, its
/// contour's [`close_pairs`](crate::geom::loop2d::close_pairs) within the
/// cap, and how far they decide ([`Reach`]).
#[derive(Debug, Clone)]
pub struct LoopPairs {
    /// Origin of the projection plane.
    pub origin: DVec3,
    /// The close pairs, their edges as packed contour edges
    /// ([`crate::bvh::patch::pack`]), sorted by slack.
    pub pairs: Vec<ClosePair>,
    /// The move below which they decide.
    pub reach: Reach,
}

impl Kept {
    /// How far the spread may grow with the certificate still deciding
    /// ([`reach`]).
    fn reach(&self) -> f64 {
        reach(self.slack, self.recheck.map(|r| r.within))
    }
}

/// How far the spread may grow with a certificate of slack `slack` and,
/// where it has one, a re-check deciding up to `within`, still deciding.
fn reach(slack: f64, within: Option<f64>) -> f64 {
    within.map_or(slack, |w| slack.max(w))
}

/// The certificates of one hierarchy, with the reference they are kept against.
#[derive(Debug, Default)]
pub struct KeptCertificates {
    reference: Vec<DVec3>,
    /// The slot in `kept` of each certificate, by key: `a << 32 | b` for the
    /// union of nodes a < b, `n << 32 | n` for node n. (Fx hashing: the
    /// traversal looks up every culled job every frame, and the keys are
    /// node ids, not input an attacker chooses.)
    slots: FxHashMap<u64, u32>,
    /// The certificates, in the order they were first made: about the
    /// order in which a traversal (from the same front) asks for them, so
    /// that its reads stream, where a map holding them is read at random
    /// (and a map of slots is small enough to stay in cache).
    kept: Vec<Kept>,
    /// The close pairs of every kept re-check ([`Recheck`]); those of
    /// replaced certificates stay until the store is compacted ([`keep`](Self::keep)).
    pairs: Vec<ClosePair>,
    /// How many of `pairs` kept certificates refer to.
    live_pairs: usize,
    /// Displacement box of every node this frame, or of the whole mesh only
    /// (one entry) when that is within every kept slack.
    spread: Vec<Aabb>,
    /// The smallest slack kept since the reference was reset.
    least_slack: f64,
    cap: f64,
    /// The last frame reset the reference.
    reset_last: bool,
}

/// The map key of node `a`'s certificate (`a == b`) or of the union of `a` and `b`.
#[inline]
fn key(a: u32, b: u32) -> u64 {
    let (a, b) = (a.min(b) as u64, a.max(b) as u64);
    a << 32 | b
}

/// Half the diagonal of a box of displacements: the farthest any of its
/// points is from its centre, with its rounding ([`with_rounding`]).
#[inline]
fn half_diagonal(b: &Aabb) -> f64 {
    with_rounding(0.5 * (b.max - b.min).length(), b)
}

/// Distance `r` computed from displacement box `b`, padded by the rounding
/// of the displacements (each coordinate within 2^-53 of its own size) and
/// of this sum.
#[inline]
fn with_rounding(r: f64, b: &Aabb) -> f64 {
    let size = b.magnitude();
    (r + 1e-15 * size) * (1.0 + 1e-12)
}

/// [`half_diagonal`] across unit `axis`: the farthest any point of the box
/// is from the line through its centre along `axis`, which bounds how far
/// displacements in the box move a projection along `axis` (the contour
/// test's) apart from a common translation. A convex function of the point,
/// so a corner's: `|c x axis|` for the half-extents `c` with each sign of y
/// and z (no cancellation when `c` is near `axis`). Never above
/// [`half_diagonal`]; much below it for motion along the axis (cloth moving
/// along its normals).
#[inline]
fn half_diagonal_across(b: &Aabb, axis: DVec3) -> f64 {
    let h = 0.5 * (b.max - b.min);
    let far = [1.0, -1.0]
        .iter()
        .flat_map(|&y| [1.0, -1.0].map(|z| (y, z)));
    let r2 = far.fold(0.0, |r2: f64, (y, z)| {
        r2.max(
            DVec3::new(h.x, y * h.y, z * h.z)
                .cross(axis)
                .length_squared(),
        )
    });
    with_rounding(r2.sqrt(), b)
}

impl KeptCertificates {
    /// An empty store; the loop test's certificates are made to hold for
    /// moves up to `cap` (a length, e.g. a fraction of the mean edge).
    pub fn new(cap: f64) -> Self {
        KeptCertificates {
            cap,
            least_slack: f64::INFINITY,
            ..Default::default()
        }
    }

    /// Refits `bvh` to `positions` (its cones as `cones` says) and, in the
    /// same passes, the displacement boxes of its nodes; resets the
    /// reference when they spread beyond the cap. Returns this frame's view
    /// for the traversal, or None when the plain tests should run (the
    /// reference was reset this frame and the last). After a reset every
    /// cone is fitted whatever `cones` says: with no certificate kept, every
    /// culled job of the front is tested afresh, and computing its cones from
    /// the leaves cost more than the merges (dress, a drifting wave of one
    /// mean edge, one thread: 31.3-31.9 ms a frame against 29.4-30.1).
    pub fn refit<'a>(
        &'a mut self,
        bvh: &mut Bvh,
        mesh: &Mesh,
        positions: &[DVec3],
        cones: ConeFit,
    ) -> Option<Reuse<'a>> {
        let cones = if self.reset_last { ConeFit::All } else { cones };
        // The whole mesh's displacement box, where it can decide: after a
        // reset (has the mesh settled?) or with certificates to hold.
        let same = self.reference.len() == positions.len();
        let whole = (same && (self.reset_last || !self.kept.is_empty()))
            .then(|| self.whole_spread(positions));
        let settled = |b: &Aabb| half_diagonal(b) <= RESET * self.cap;
        let mut reset = !same || (self.reset_last && !whole.as_ref().is_some_and(settled));
        if reset {
            bvh.refit(mesh, positions);
        } else if let Some(b) = whole.filter(|b| self.whole_pays(half_diagonal(b), bvh.n_nodes())) {
            bvh.refit_cones(mesh, positions, cones);
            self.spread.clear();
            self.spread.push(b);
            reset = !settled(&b);
        } else {
            let (tris, r) = (mesh.triangles(), &self.reference);
            self.spread.resize(bvh.n_nodes(), Aabb::EMPTY);
            bvh.refit_also(
                mesh,
                positions,
                cones,
                &mut self.spread,
                |t, x| {
                    let [a, b, c] = tris[t].map(|v| r[v as usize]);
                    Aabb::from_points(&[x[0] - a, x[1] - b, x[2] - c])
                },
                Aabb::union,
            );
            reset = !settled(&self.spread[bvh.root() as usize]);
        }
        let reset_last = self.reset_last;
        self.reset_last = reset;
        if reset {
            self.reset(positions);
            if reset_last {
                return None;
            }
            // Displacements from the new reference are exactly zero.
            let zero = Aabb {
                min: DVec3::ZERO,
                max: DVec3::ZERO,
            };
            self.spread.clear();
            self.spread.resize(bvh.n_nodes(), zero);
        }
        Some(Reuse {
            slots: &self.slots,
            kept: &self.kept,
            pairs: &self.pairs,
            spread: &self.spread,
            cap: self.cap,
            fresh: Mutex::new(Vec::new()),
        })
    }

    /// Adds the certificates made in a frame (`Reuse::into_fresh`). Where a
    /// node (or union) already has one, the one holding for more is kept:
    /// a certificate that did not hold this frame still holds in any later
    /// frame whose spread is within its slack, and one remade under a large
    /// spread keeps little (its slack less that spread).
    /// The close pairs are stored once a certificate is kept, and the store
    /// is compacted when more than half of it belongs to replaced ones (a
    /// sequence that never resets its reference, as a cycling motion, would
    /// otherwise grow it every frame).
    pub fn keep(&mut self, fresh: Fresh) {
        for (key, mut k, recheck) in fresh.0 {
            let reach = reach(k.slack, recheck.as_ref().map(|r| r.within));
            let slot = self.slots.get(&key).map(|&s| s as usize);
            if slot.is_some_and(|s| reach <= self.kept[s].reach()) {
                continue;
            }
            k.recheck = recheck.and_then(|r| {
                let start = u32::try_from(self.pairs.len()).ok()?;
                let len = u32::try_from(r.pairs.len()).ok()?;
                self.pairs.extend_from_slice(&r.pairs);
                Some(Recheck {
                    origin: r.origin,
                    start,
                    len,
                    within: r.within,
                    area_within: r.area_within,
                    eps: r.eps,
                })
            });
            self.live_pairs += k.recheck.map_or(0, |r| r.len as usize);
            match slot {
                Some(s) => {
                    let old = std::mem::replace(&mut self.kept[s], k);
                    self.live_pairs -= old.recheck.map_or(0, |r| r.len as usize);
                }
                None => {
                    self.slots.insert(key, self.kept.len() as u32);
                    self.kept.push(k);
                }
            }
            if k.slack > 0.0 {
                self.least_slack = self.least_slack.min(k.slack);
            }
        }
        if self.pairs.len() > 2 * self.live_pairs + COMPACT_MIN {
            self.compact();
        }
    }

    /// Moves the close pairs of the kept certificates to the front of the
    /// store (in one pass over them) and drops the rest.
    fn compact(&mut self) {
        let mut pairs = Vec::with_capacity(self.live_pairs);
        for k in &mut self.kept {
            if let Some(r) = k.recheck.as_mut() {
                let (start, len) = (r.start as usize, r.len as usize);
                r.start = pairs.len() as u32;
                pairs.extend_from_slice(&self.pairs[start..start + len]);
            }
        }
        self.pairs = pairs;
    }

    /// Is the whole mesh's displacement spread `h` worth taking for every
    /// node, instead of fitting the nodes' own boxes (a second refit of
    /// `nodes` nodes)? Yes when it is within the least slack (every
    /// certificate holds), or when the certificates it leaves to a re-check
    /// ([`RECHECK`]) or a fresh test ([`FRESH`]) cost far less than the fit.
    fn whole_pays(&self, h: f64, nodes: usize) -> bool {
        if self.kept.is_empty() {
            return false;
        }
        if h <= self.least_slack {
            return true;
        }
        let cost: f64 = self
            .kept
            .iter()
            .map(|k| {
                if h <= k.slack {
                    0.0
                } else if h <= k.reach() {
                    RECHECK
                } else {
                    FRESH
                }
            })
            .sum();
        // (A margin of 4 for the estimate: a whole-mesh spread also leaves
        // re-checks more pairs, and remade certificates less slack.)
        4.0 * cost < nodes as f64
    }

    /// The box of every vertex's displacement from the reference, in one
    /// pass over the vertices (it holds the root's displacement box, and more
    /// where vertices lie on no triangle).
    fn whole_spread(&self, positions: &[DVec3]) -> Aabb {
        let one = |d: DVec3| Aabb::from_points(&[d]);
        fold_moves(&self.reference, positions, Aabb::EMPTY, one, |a, b| {
            a.union(&b)
        })
    }

    fn reset(&mut self, positions: &[DVec3]) {
        self.reference.clear();
        self.reference.extend_from_slice(positions);
        self.slots.clear();
        self.kept.clear();
        self.pairs.clear();
        self.live_pairs = 0;
        self.least_slack = f64::INFINITY;
    }
}

/// One frame's view of the kept certificates, for [`super::certify::ContourCull`].
pub struct Reuse<'a> {
    slots: &'a FxHashMap<u64, u32>,
    kept: &'a [Kept],
    pairs: &'a [ClosePair],
    spread: &'a [Aabb],
    cap: f64,
    fresh: Mutex<Vec<(u64, Kept, Option<FreshRecheck>)>>,
}

/// The certificates a frame made, for [`KeptCertificates::keep`].
#[derive(Debug, Default)]
pub struct Fresh(Vec<(u64, Kept, Option<FreshRecheck>)>);

impl Reuse<'_> {
    /// The cap on the loop test's slacks (see `ContourCull`).
    pub fn cap(&self) -> f64 {
        self.cap
    }

    /// The displacement spread of node `a`, or of the union of `a` and `b`
    /// (the whole mesh's when only that was fitted), across `axis`.
    #[inline]
    fn spread(&self, a: u32, b: u32, axis: DVec3) -> f64 {
        match self.spread {
            [whole] => half_diagonal_across(whole, axis),
            all => half_diagonal_across(&all[a as usize].union(&all[b as usize]), axis),
        }
    }

    /// The kept certificate of node `a` (`a == b`) or of the union of `a`
    /// and `b`, with this frame's spread across its axis (the spread is only
    /// taken where there is a certificate).
    #[inline]
    pub fn get(&self, a: u32, b: u32) -> Option<(Kept, f64)> {
        let k = &self.kept[*self.slots.get(&key(a, b))? as usize];
        Some((*k, self.spread(a, b, k.axis)))
    }

    /// The close pairs of a kept re-check.
    pub fn pairs(&self, r: &Recheck) -> &[ClosePair] {
        let start = r.start as usize;
        &self.pairs[start..start + r.len as usize]
    }

    /// Records the certificate of node `a` (`a == b`) or of the union of
    /// `a` and `b` made this frame along `axis` with slack `slack` (None: no
    /// certificate) and, where its contour was one loop and the spread
    /// leaves room for it (`RECHECK_SPREAD`), what re-checks it: the pairs
    /// `close` finds within the cap. Returns whether there is a certificate.
    pub fn record(
        &self,
        (a, b): (u32, u32),
        axis: DVec3,
        slack: Option<f64>,
        close: impl FnOnce() -> Option<LoopPairs>,
    ) -> bool {
        let Some(slack) = slack else {
            return false;
        };
        let spread = self.spread(a, b, axis);
        let left = slack - spread;
        let recheck = (spread <= RECHECK_SPREAD * self.cap).then(close).flatten();
        // The pairs' slacks and the reach bound the move since now; less the
        // spread now, they bound the spread of a later frame (module doc).
        let recheck = recheck.map(|mut r| {
            for c in &mut r.pairs {
                c.slack = round_down(c.slack as f64 - spread);
            }
            FreshRecheck {
                origin: r.origin,
                pairs: r.pairs,
                within: r.reach.moved - spread,
                area_within: r.reach.area - spread,
                eps: r.reach.eps,
            }
        });
        let within = recheck.as_ref().map_or(f64::NEG_INFINITY, |r| r.within);
        if left > 0.0 || within > 0.0 {
            let kept = Kept {
                axis,
                slack: left,
                recheck: None,
            };
            self.fresh.lock().unwrap_or_else(|e| e.into_inner()).push((
                key(a, b),
                kept,
                recheck.filter(|r| r.within > 0.0),
            ));
        }
        true
    }

    /// The certificates made this frame.
    pub fn into_fresh(self) -> Fresh {
        Fresh(self.fresh.into_inner().unwrap_or_else(|e| e.into_inner()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SplitMix;

    /// Remade certificates do not grow the close-pair store without bound:
    /// it is compacted, and every kept re-check still reads its own pairs.
    #[test]
    fn the_close_pair_store_is_compacted() {
        let mut store = KeptCertificates::new(1.0);
        let fresh = |round: u32| {
            let pairs: Vec<ClosePair> = (0..10)
                .map(|i| ClosePair {
                    edges: [round, i],
                    slack: 0.0,
                })
                .collect();
            let certificate = |key: u64| {
                let kept = Kept {
                    axis: DVec3::Z,
                    slack: 0.0,
                    recheck: None,
                };
                let recheck = FreshRecheck {
                    origin: DVec3::ZERO,
                    pairs: pairs.clone(),
                    within: 0.5 + round as f64, // each remade one holds for more
                    area_within: 0.0,
                    eps: 0.0,
                };
                (key, kept, Some(recheck))
            };
            Fresh(vec![certificate(1), certificate(2 << 32 | 2)])
        };
        for round in 0..2000 {
            store.keep(fresh(round));
            assert!(
                store.pairs.len() <= 2 * 20 + COMPACT_MIN + 20,
                "round {round}"
            );
        }
        assert_eq!(store.live_pairs, 20);
        for k in &store.kept {
            let r = k.recheck.unwrap();
            let pairs = &store.pairs[r.start as usize..(r.start + r.len) as usize];
            let edges: Vec<[u32; 2]> = pairs.iter().map(|c| c.edges).collect();
            assert_eq!(edges, (0..10).map(|i| [1999, i]).collect::<Vec<_>>());
        }
    }

    /// Every point of a box is within [`half_diagonal_across`] of the line
    /// along the axis through the box centre; a corner is almost that far
    /// (the bound is tight); never more than [`half_diagonal`]; and motion
    /// along the axis only counts for its rounding.
    #[test]
    fn across_bounds_the_distance_from_the_axis_line() {
        let mut rng = SplitMix::new(17);
        let mut r = || 2.0 * rng.unit() - 1.0;
        for _ in 0..500 {
            let (a, b) = (DVec3::new(r(), r(), r()), DVec3::new(r(), r(), r()));
            let bx = Aabb {
                min: a.min(b),
                max: a.max(b),
            };
            let axis = DVec3::new(r(), r(), r()).normalize();
            let across = half_diagonal_across(&bx, axis);
            assert!(across <= half_diagonal(&bx));
            let c = bx.center();
            let off_line = |p: DVec3| (p - c).reject_from_normalized(axis).length();
            let mut farthest: f64 = 0.0;
            for k in 0..64 {
                let t = DVec3::new(r(), r(), r()) * 0.5 + 0.5;
                let corner = DVec3::new((k & 1) as f64, (k >> 1 & 1) as f64, (k >> 2 & 1) as f64);
                for p in [
                    bx.min + (bx.max - bx.min) * t,
                    bx.min + (bx.max - bx.min) * corner,
                ] {
                    farthest = farthest.max(off_line(p));
                }
            }
            assert!(farthest <= across && across <= farthest * (1.0 + 1e-9) + 1e-14);
        }
        let along = Aabb {
            min: DVec3::new(0.0, 0.0, -1.0),
            max: DVec3::new(0.0, 0.0, 1.0),
        };
        assert!(half_diagonal_across(&along, DVec3::Z) <= 2e-15);
        assert!(half_diagonal_across(&along, DVec3::X) >= 1.0);
    }
}
