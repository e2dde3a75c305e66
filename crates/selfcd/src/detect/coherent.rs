//! Coherent self queries: one hierarchy per mesh serves the intersection,
//! proximity and continuous queries of a sequence of frames, and a candidate
//! set of element pairs is reused from frame to frame while nothing moved far
//! enough to change the answers (a Verlet list).
//!
//! **Candidate set.** At reference positions `r` it holds every owned element
//! pair (vertex-triangle, edge-edge; see [`for_each_owned_pair`]) closer than
//! `reach + skin`. Let positions `x` satisfy `|x_i - r_i - c| < skin / 2` for
//! every vertex i and one common translation `c`. Each side of an element pair
//! is a convex combination of its vertices, so (translation aside) it moved by
//! less than `skin / 2`, and the pair's distance changed by less than `skin`:
//! every pair closer than `reach` at `x` is a candidate. For a linear motion
//! `x0 -> x1` the same holds at every time of the step when it holds at both
//! ends (with `c` interpolated: the deviation is a convex combination of the
//! ends'). The answers are then computed on the candidates with exactly the
//! arithmetic (and box tests) of a fresh query, so they are equal to it, not
//! approximations; `tests/continuous.rs` checks that on simulated sequences.
//!
//! A flat sheet that does not move costs one O(n) motion check per query.

use super::continuous::{candidate_toi, check_args, swept_query, Impacts};
use super::narrow::{
    collect_proximity, for_each_owned_pair, ElementPair, Intersect, Proximity, ProximityContacts,
    DEFAULT_MAX_CONTACTS,
};
use crate::bvh::traverse::{self_traverse, LeafVisitor, TraverseOptions};
use crate::bvh::{build::build, Bvh};
use crate::error::{Error, Result};
use crate::geom::Aabb;
use crate::mesh::Mesh;
use crate::stats::{Counters, FrameStats};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Below this many items a loop runs on one thread.
const PAR_MIN: usize = 4096;

/// What the hierarchy's boxes are fitted to: static boxes at `at` when
/// `fitted`, else nothing yet or a swept motion. `at` keeps its buffer
/// across frames (no allocation per refit).
#[derive(Debug, Clone, Default, PartialEq)]
struct Fit {
    fitted: bool,
    at: Vec<DVec3>,
}

/// Element pairs closer than `reach + skin` at `reference`, sorted by their
/// distance there (then by pair).
#[derive(Debug, Clone, Default)]
struct Candidates {
    reference: Vec<DVec3>,
    reach: f64,
    skin: f64,
    pairs: Vec<ElementPair>,
    /// Distance of each pair at `reference`, increasing.
    distance: Vec<f64>,
    /// Largest coordinate magnitude at `reference` (for the rounding slack).
    magnitude: f64,
}

/// Relative slack on the distance bounds below: covers rounding (1e-9 of the
/// coordinates) and the time-of-impact resolution (1e-6 of the distances).
const SLACK: (f64, f64) = (1e-9, 1e-5);

impl Candidates {
    /// The deviation of `x` from the reference (see [`deviation`]) when every
    /// pair within `reach` at `x` is a candidate, `None` otherwise.
    fn cover(&self, x: &[DVec3], reach: f64) -> Option<f64> {
        if reach > self.reach || self.reference.len() != x.len() {
            return None;
        }
        let dev = deviation(&self.reference, x);
        (dev < 0.5 * self.skin).then_some(dev)
    }

    /// The candidates that may be within `reach` at positions deviating by at
    /// most `dev` from the reference: a pair's distance changed by at most
    /// `2 dev`, so only a prefix of the distance-sorted list can qualify.
    fn within(&self, reach: f64, dev: f64) -> &[ElementPair] {
        let bound = reach + 2.0 * dev;
        let limit = bound + SLACK.1 * bound + SLACK.0 * self.magnitude;
        &self.pairs[..self.distance.partition_point(|&d| d <= limit)]
    }
}

/// `max_i |x_i - r_i - c|` with `c` the centre of the displacements' box:
/// the motion left once a common translation is taken out.
fn deviation(r: &[DVec3], x: &[DVec3]) -> f64 {
    let d = |i: usize| x[i] - r[i];
    let (lo, hi) = if x.len() >= PAR_MIN {
        (0..x.len()).into_par_iter().map(|i| (d(i), d(i))).reduce(
            || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        )
    } else {
        (0..x.len()).fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |a, i| (a.0.min(d(i)), a.1.max(d(i))),
        )
    };
    let c = (lo + hi) * 0.5;
    let max2 = if x.len() >= PAR_MIN {
        (0..x.len())
            .into_par_iter()
            .map(|i| (d(i) - c).length_squared())
            .reduce(|| 0.0, f64::max)
    } else {
        (0..x.len())
            .map(|i| (d(i) - c).length_squared())
            .fold(0.0, f64::max)
    };
    max2.sqrt()
}

/// Narrow phase of a candidate build: owned element pairs closer than `reach`.
struct Gather<'a> {
    mesh: &'a Mesh,
    x: &'a [DVec3],
    reach: f64,
    max: usize,
    found: AtomicUsize,
}

impl LeafVisitor for Gather<'_> {
    type Item = (f64, ElementPair);
    const SKIP_ADJACENT: bool = false;

    fn visit(&self, a: u32, b: u32, _adjacent: bool, out: &mut Vec<(f64, ElementPair)>) {
        if self.found.load(Ordering::Relaxed) > self.max {
            return; // the output guard: the build fails afterwards
        }
        let before = out.len();
        for_each_owned_pair(self.mesh, a, b, |p| {
            let p = p.canonical();
            if let Some(d) = p.distance_within(self.mesh, self.x, self.reach) {
                out.push((d, p));
            }
        });
        if out.len() > before {
            self.found.fetch_add(out.len() - before, Ordering::Relaxed);
        }
    }
}

/// Maps `f` over `items` in order, in parallel when there are many.
fn filter_map_ordered<T: Sync, U: Send>(
    items: &[T],
    f: impl Fn(&T) -> Option<U> + Sync + Send,
) -> Vec<U> {
    if items.len() >= PAR_MIN {
        items.par_iter().filter_map(f).collect()
    } else {
        items.iter().filter_map(f).collect()
    }
}

/// The self queries of one mesh over a sequence of frames: one hierarchy and
/// one candidate set (see the module doc).
pub struct SelfQueries {
    mesh: Arc<Mesh>,
    bvh: Bvh,
    fit: Fit,
    candidates: Candidates,
    skin: f64,
    max_skin: f64,
    max_contacts: usize,
}

/// A continuous query whose motion its candidate set does not cover rebuilds
/// the set with a skin this much wider than the motion's deviation.
const SKIN_OVER_MOTION: f64 = 2.2;
/// Default largest skin, in units of the base skin; wider motions take the
/// swept traversal. A sheet has in-plane neighbours within any skin, so wide
/// skins cost more than they save (measured: 8 was slower than 1 or 2 on the
/// falling centre scene).
const MAX_SKIN: f64 = 2.0;

impl SelfQueries {
    /// Builds the hierarchy of `mesh`; candidate sets are built with `skin`
    /// (> 0, finite) beyond the distance asked for.
    pub fn new(mesh: Arc<Mesh>, skin: f64) -> Result<SelfQueries> {
        if !(skin > 0.0 && skin.is_finite()) {
            return Err(Error::InvalidParameter(format!(
                "skin must be positive and finite, got {skin}"
            )));
        }
        let bvh = build(&mesh);
        Ok(SelfQueries {
            mesh,
            bvh,
            fit: Fit::default(),
            candidates: Candidates::default(),
            skin,
            max_skin: MAX_SKIN * skin,
            max_contacts: DEFAULT_MAX_CONTACTS,
        })
    }

    /// The mesh.
    pub fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    /// The hierarchy.
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Sets the widest skin a continuous query may rebuild its candidate set
    /// with (default 2 times the base skin); motions that need more take the
    /// swept traversal instead.
    pub fn set_max_skin(&mut self, max_skin: f64) {
        self.max_skin = max_skin;
    }

    /// Sets the limit on proximity contacts and candidates (default [`DEFAULT_MAX_CONTACTS`]).
    pub fn set_max_contacts(&mut self, max: usize) {
        self.max_contacts = max;
    }

    /// Fits boxes and cones to `x` unless they already are; adds the time to `s`.
    fn fit_static(&mut self, x: &[DVec3], s: &mut FrameStats) {
        if self.fit.fitted && self.fit.at.as_slice() == x {
            return;
        }
        let t0 = Instant::now();
        self.bvh.refit(&self.mesh, x);
        self.fit.at.clear();
        self.fit.at.extend_from_slice(x);
        self.fit.fitted = true;
        s.refit_time += t0.elapsed().as_secs_f64();
    }

    /// Rebuilds the candidate set at `x` for pairs within `reach` with `skin`.
    fn rebuild(&mut self, x: &[DVec3], reach: f64, skin: f64, s: &mut FrameStats) -> Result<()> {
        self.fit_static(x, s);
        let t0 = Instant::now();
        let gap = reach + skin;
        let mesh = &*self.mesh;
        let gather = Gather {
            mesh,
            x,
            reach: gap,
            max: self.max_contacts,
            found: AtomicUsize::new(0),
        };
        let opts = TraverseOptions {
            cones: false,
            contour: false,
            gap,
        };
        let (mut pairs, c) = self_traverse(&self.bvh, mesh, x, opts, &gather);
        if pairs.len() > self.max_contacts {
            return Err(Error::TooManyContacts {
                limit: self.max_contacts,
                thickness: gap,
            });
        }
        pairs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let magnitude = x.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max);
        self.candidates = Candidates {
            reference: x.to_vec(),
            reach,
            skin,
            distance: pairs.iter().map(|p| p.0).collect(),
            pairs: pairs.into_iter().map(|p| p.1).collect(),
            magnitude,
        };
        s.candidate_builds += 1;
        s.node_pairs += c.node_pairs;
        s.proximity_tests += c.primitive_tests;
        s.traverse_time += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// Every vertex-triangle and edge-edge pair closer than `thickness` (> 0)
    /// at `x`: equal to [`BvhDetector`](super::hierarchy::BvhDetector)'s
    /// proximity. Reuses the candidate set when it covers `x`, else rebuilds it
    /// at `x`. Adds its work to `s`.
    pub fn proximity(
        &mut self,
        x: &[DVec3],
        thickness: f64,
        s: &mut FrameStats,
    ) -> Result<ProximityContacts> {
        self.mesh.check_positions(x)?;
        if !(thickness > 0.0 && thickness.is_finite()) {
            return Err(Error::InvalidParameter(format!(
                "thickness must be positive and finite, got {thickness}"
            )));
        }
        let dev = match self.candidates.cover(x, thickness) {
            Some(dev) => {
                s.candidate_reuses += 1;
                dev
            }
            None => {
                self.rebuild(x, thickness, self.skin, s)?;
                0.0
            }
        };
        let t0 = Instant::now();
        let mesh = &*self.mesh;
        let near = Proximity::new(mesh, x, thickness, self.max_contacts);
        let boxes = |t: u32| Aabb::from_points(&mesh.corners(x, t as usize));
        let pairs = self.candidates.within(thickness, dev);
        let found = filter_map_ordered(pairs, |&p| {
            // The fresh query's box test, so that the answers are the same to the bit.
            let [a, b] = p.visiting_triangles(mesh);
            if a == b || !boxes(a).within(&boxes(b), thickness) {
                return None;
            }
            let mut out = Vec::new();
            near.test(p, &mut out);
            out.pop()
        });
        s.candidates += pairs.len() as u64;
        if found.len() > self.max_contacts {
            return Err(Error::TooManyContacts {
                limit: self.max_contacts,
                thickness,
            });
        }
        let out = collect_proximity(found);
        s.proximity_contacts = (out.vertex_triangle.len() + out.edge_edge.len()) as u64;
        s.traverse_time += t0.elapsed().as_secs_f64();
        Ok(out)
    }

    /// Every element pair that may come within `thickness` (>= 0) while the
    /// mesh moves linearly from `x0` to `x1`: equal to
    /// [`BvhDetector::continuous`](super::hierarchy::BvhDetector::continuous).
    /// From the candidate set when it covers both ends; else, when the motion's
    /// deviation (common translation aside) is narrow enough, from a candidate
    /// set rebuilt at `x0` with a skin covering it (and the proximity reach
    /// of the previous set, so the next proximity query may reuse it); else by
    /// a swept traversal. Adds its work to `s`.
    pub fn continuous(
        &mut self,
        x0: &[DVec3],
        x1: &[DVec3],
        thickness: f64,
        s: &mut FrameStats,
    ) -> Result<Impacts> {
        let mesh = self.mesh.clone();
        check_args(&mesh, x0, x1, thickness)?;
        let cover = |c: &Candidates, x| c.cover(x, thickness);
        let mut ends = (cover(&self.candidates, x0), cover(&self.candidates, x1));
        if ends.0.is_none() || ends.1.is_none() {
            let dev = deviation(x0, x1);
            let skin = self.skin.max(SKIN_OVER_MOTION * dev);
            if skin <= self.max_skin {
                let reach = thickness.max(self.candidates.reach);
                self.rebuild(x0, reach, skin, s)?;
                ends = (Some(0.0), Some(dev));
            }
        }
        let t0 = Instant::now();
        if let (Some(d0), Some(d1)) = ends {
            s.candidate_reuses += 1;
            // The deviation at any time of the step is at most the ends' (module doc).
            let pairs = self.candidates.within(thickness, d0.max(d1));
            let found = filter_map_ordered(pairs, |&p| candidate_toi(&mesh, x0, x1, p, thickness));
            s.candidates += pairs.len() as u64;
            s.traverse_time += t0.elapsed().as_secs_f64();
            return Ok(Impacts::from_items(found));
        }
        self.bvh.refit_swept(&mesh, x0, x1);
        self.fit.fitted = false;
        let t1 = Instant::now();
        s.refit_time += (t1 - t0).as_secs_f64();
        let (found, c) = swept_query(&self.bvh, &mesh, x0, x1, thickness);
        s.swept_queries += 1;
        s.node_pairs += c.node_pairs;
        s.traverse_time += t1.elapsed().as_secs_f64();
        Ok(found)
    }

    /// Intersecting non-adjacent triangle pairs at `x`, sorted, with the
    /// conservative culling of `bvh-cones-contour` (or boxes only when
    /// `cones` is false). Adds its work to `s`.
    pub fn intersections(
        &mut self,
        x: &[DVec3],
        cones: bool,
        s: &mut FrameStats,
    ) -> Result<Vec<[u32; 2]>> {
        self.mesh.check_positions(x)?;
        self.fit_static(x, s);
        let t0 = Instant::now();
        let mesh = &*self.mesh;
        let opts = TraverseOptions {
            cones,
            contour: cones,
            gap: 0.0,
        };
        let (mut pairs, c): (Vec<[u32; 2]>, Counters) =
            self_traverse(&self.bvh, mesh, x, opts, &Intersect { mesh, positions: x });
        pairs.sort_unstable();
        c.add_to(s);
        s.contacts = pairs.len() as u64;
        s.traverse_time += t0.elapsed().as_secs_f64();
        Ok(pairs)
    }
}
