//! BVH detectors: `bvh`, `bvh-cones` and `bvh-cones-contour`.

use super::narrow::{collect_proximity_parts, Intersect, Proximity, DEFAULT_MAX_CONTACTS};
use super::{Detection, Detector, Method};
use crate::bvh::certify::ContourCull;
use crate::bvh::kept::{fold_moves, KeptCertificates, Reuse};
use crate::bvh::refit::ConeFit;
use crate::bvh::traverse::{
    self_traverse_from, self_traverse_parts, traverse_from, Clearances, Front, Start,
    TraverseOptions,
};
use crate::bvh::{build::build, Bvh};
use crate::error::Result;
use crate::mesh::Mesh;
use crate::stats::{Counters, FrameStats};
use glam::DVec3;
use std::sync::Arc;
use std::time::Instant;

/// A BVH built once for the mesh, refitted and traversed each frame.
/// The hierarchy is renumbered depth-first after its build
/// ([`Bvh::depth_first`]): it runs on the mesh with its triangles in that
/// order, and every answer is mapped back to the caller's triangle ids.
/// From the second [`Detector::detect`] call on (a single call, as a
/// one-shot query makes, pays nothing for them) the detector keeps, from
/// frame to frame, the intersection traversal's front
/// ([`crate::bvh::traverse::Front`]) and, for `bvh-cones-contour`, its
/// contour certificates ([`crate::bvh::kept`]).
pub struct BvhDetector {
    /// The caller's mesh.
    mesh: Arc<Mesh>,
    /// The mesh in the hierarchy's triangle order (`mesh` itself when kept
    /// in its own order); vertex and edge ids are the caller's.
    inner: Arc<Mesh>,
    /// The caller's id of each triangle of `inner`, None when the same.
    triangle_of: Option<Vec<u32>>,
    bvh: Bvh,
    method: Method,
    thickness: f64,
    max_contacts: usize,
    kept: Option<KeptCertificates>,
    frames: u64,
    slabs: SlabPolicy,
    front: Option<KeptFront>,
}

/// The intersection traversal's front, its length and the mean edge length
/// of the positions when last recorded from the root, the reference
/// positions its clearances are kept against ([`crate::bvh::traverse`],
/// "Clearance"), and whether they were measured.
#[derive(Debug)]
struct KeptFront {
    front: Front,
    from_root: usize,
    edge: f64,
    reference: Vec<DVec3>,
    measured: bool,
}

/// The front is recorded again from the root once it has grown past this
/// many times its length when last recorded there: it only deepens (a job
/// below a node that is culled again is still run), and a deeper front costs
/// more than the jobs above it.
const FRONT_GROWTH: f64 = 1.25;

/// Clearances pay while no vertex has moved more than this many mean edge
/// lengths from the front's reference positions: beyond, few jobs are clear
/// enough to be skipped, and the clearances of the jobs run shrink by twice
/// the move.
const FRONT_MOVE: f64 = 0.25;

/// Clearances are measured (about a fifth of a frame on the dress) only
/// after a frame that moved no vertex more than this many mean edge lengths:
/// a sequence moving that slowly stays under [`FRONT_MOVE`] for the frames
/// that pay it back. (Measured on the dress, one thread, `PROF_WAVE=drift`:
/// at 0.15 mean edges of wave a frame, measuring every third frame cost 6%
/// more than never; at 0.05, measuring once paid 2-8%; the 4-frame cycle of
/// the peer benchmark moves about 0.06 a frame.)
const MEASURE_MOVE: f64 = 0.08;

/// Front jobs clearer than twice this many mean edge lengths are set apart
/// when clearances are measured (`Front::set_far`): frames skipping by
/// clearances read them only once a vertex has moved this far from the
/// reference. A sequence slow enough to measure moved at most
/// [`MEASURE_MOVE`] in its last frame.
const FAR_MOVE: f64 = MEASURE_MOVE;

/// A frame that moved a vertex past the limit of the jobs set apart sets
/// them apart again at this many times its move (`Front::set_far`): a
/// waving mesh then stays within its swing, a drifting one sets apart again
/// a few times before its reference resets. Measured on the dress, one
/// thread, mean frame (`PROF_WAVE=1`, then `drift`): 1.1 7.93-8.51 ms,
/// 10.59-10.99; 1.25 7.81-8.10, 10.54-10.95; 1.5 7.98-8.34, 10.89-10.96;
/// 9.27-9.30 and 11.96-11.97 with nothing set apart.
const FAR_GROWTH: f64 = 1.25;

impl KeptFront {
    /// Where this frame's traversal starts: the kept front while it has not
    /// grown too much, else the root (recording). From the front, with
    /// measured clearances while no vertex is farther than [`FRONT_MOVE`]
    /// from the reference ([`Clearances::Skip`]); else the positions become
    /// the reference, and clearances are measured when the mesh moved less
    /// than [`MEASURE_MOVE`] since the last frame (then they will pay), else
    /// dropped (faster motion pays for no measuring). Lengths in mean edges
    /// of the positions the front was recorded at (clearances scale with
    /// the shape, which may be stretched from the rest).
    fn start<'a>(kept: Option<&'a KeptFront>, positions: &[DVec3]) -> Start<'a> {
        match kept {
            Some(k) if k.front.len() as f64 <= FRONT_GROWTH * k.from_root as f64 => {
                let (moved, edge) = (largest_move(&k.reference, positions), k.edge);
                let c = if k.measured && moved <= FRONT_MOVE * edge {
                    Clearances::Skip(moved)
                } else if !k.measured && moved <= MEASURE_MOVE * edge {
                    // (The reference is the last frame's positions.)
                    Clearances::Measure
                } else {
                    Clearances::Drop
                };
                Start::Front(&k.front, c)
            }
            _ => Start::RootRecording,
        }
    }
}

/// The largest distance of a vertex from its reference position, rounded
/// up (the rounding of each difference and norm is far below 1e-12 of it).
/// Where the largest squared distance leaves the normal range (underflow),
/// sqrt(3) times the largest coordinate difference (exact there) bounds it.
fn largest_move(reference: &[DVec3], positions: &[DVec3]) -> f64 {
    let far = |d: DVec3| (d.length_squared(), d.abs().max_element());
    let max = |a: (f64, f64), b: (f64, f64)| (a.0.max(b.0), a.1.max(b.1));
    let (d2, di) = fold_moves(reference, positions, (0.0, 0.0), far, max);
    let d = if d2 >= 1e-300 {
        d2.sqrt()
    } else {
        3f64.sqrt() * di
    };
    d * (1.0 + 1e-12)
}

/// Each pair's triangles mapped through `map`, smaller id first.
fn map_pairs(pairs: &mut [[u32; 2]], map: &[u32]) {
    for p in pairs {
        let [a, b] = p.map(|t| map[t as usize]);
        *p = [a.min(b), a.max(b)];
    }
}

/// When a detector fits slabs ([`Bvh::fit_slabs`]). They cull node pairs
/// whose boxes overlap but which lie apart along their normals (layers of
/// cloth closer than their triangles are wide), and fitting them costs
/// about as much as the refit. So they are fitted for a frame when the last
/// frame flooded the narrow phase (more than [`FLOOD`] triangle tests per
/// triangle), and kept while they cull at least one in [`KEEP`] of the node
/// pairs tested; or always, or never, when forced. A proximity flood does
/// not count: at a thickness near the edge length the layers lie within it
/// (slabs culled 6% of the dress's proximity node pairs, for no time gained).
#[derive(Debug, Clone, Copy, Default)]
struct SlabPolicy {
    on: bool,
    forced: Option<bool>,
}

/// Triangle tests per triangle that turn slabs on.
const FLOOD: u64 = 2;
/// Slabs stay on while they cull one node pair in this many.
const KEEP: u64 = 8;

impl SlabPolicy {
    fn fit(&self) -> bool {
        self.forced.unwrap_or(self.on)
    }

    fn update(&mut self, s: &FrameStats, triangles: usize) {
        self.on = if self.on {
            s.slab_culls * KEEP >= s.node_pairs
        } else {
            s.primitive_tests > FLOOD * triangles as u64
        };
    }
}

/// Kept certificates hold for moves up to this many mean edge lengths.
const KEPT_CAP: f64 = 0.25;

impl BvhDetector {
    /// Builds the hierarchy of `mesh` for `method` (not `brute`), renumbered
    /// depth-first (the type's doc).
    pub fn new(mesh: Arc<Mesh>, method: Method, thickness: f64) -> Self {
        let (bvh, inner, order) = build(&mesh).depth_first(&mesh);
        let inner = Arc::new(inner);
        Self::with_hierarchy(mesh, inner, Some(order), bvh, method, thickness)
    }

    /// [`new`](Self::new) with the hierarchy's leaves in the mesh's own
    /// triangle order, for callers that read the hierarchy
    /// ([`bvh`](Self::bvh)) with the mesh's triangle ids.
    pub fn in_mesh_order(mesh: Arc<Mesh>, method: Method, thickness: f64) -> Self {
        let bvh = build(&mesh);
        Self::with_hierarchy(mesh.clone(), mesh, None, bvh, method, thickness)
    }

    fn with_hierarchy(
        mesh: Arc<Mesh>,
        inner: Arc<Mesh>,
        triangle_of: Option<Vec<u32>>,
        bvh: Bvh,
        method: Method,
        thickness: f64,
    ) -> Self {
        BvhDetector {
            mesh,
            inner,
            triangle_of,
            bvh,
            method,
            thickness,
            max_contacts: DEFAULT_MAX_CONTACTS,
            kept: None,
            frames: 0,
            slabs: SlabPolicy::default(),
            front: None,
        }
    }

    /// Fits slabs every frame (`Some(true)`), never (`Some(false)`), or when
    /// the last frame says they pay (`None`, the default: after a frame with
    /// more than two triangle tests per triangle, for as long as they cull
    /// one node pair in eight). Answers are the same either way.
    pub fn force_slabs(&mut self, on: Option<bool>) {
        self.slabs.forced = on;
    }

    /// The hierarchy, as refitted by the last call. Its leaf `i` holds
    /// triangle `i` of [`hierarchy_mesh`](Self::hierarchy_mesh); its
    /// [`cones_fit`](Bvh::cones_fit) is [`ConeFit::Leaves`] after the frames
    /// of a sequence that start from a kept front (the contour cull then
    /// computes the few internal cones it asks for from the leaves).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// The mesh with its triangles in the hierarchy's order (the caller's
    /// vertex and edge ids).
    pub fn hierarchy_mesh(&self) -> &Arc<Mesh> {
        &self.inner
    }

    /// The caller's id of each triangle of [`hierarchy_mesh`](Self::hierarchy_mesh),
    /// None when they are the same.
    pub fn triangle_order(&self) -> Option<&[u32]> {
        self.triangle_of.as_deref()
    }

    /// Refits the boxes to the triangles swept from `x0` to `x1` (continuous queries).
    pub(crate) fn refit_swept(&mut self, x0: &[DVec3], x1: &[DVec3]) {
        self.bvh.refit_swept(&self.inner, x0, x1);
    }

    /// Fits boxes and cones to the swept triangles ([`Bvh::refit_swept_cones`]).
    pub(crate) fn refit_swept_cones(&mut self, x0: &[DVec3], x1: &[DVec3]) {
        self.bvh.refit_swept_cones(&self.inner, x0, x1);
    }

    /// Refits boxes and cones to `positions` (already checked).
    pub fn refit(&mut self, positions: &[DVec3]) {
        self.bvh.refit(&self.inner, positions);
    }

    /// Traverses the refitted hierarchy: intersections, and proximity when
    /// thickness > 0 (a second, boxes-only traversal: cones say nothing about
    /// distance). Fills every field but the refit and sensor times.
    /// Errors: more proximity contacts than `max_contacts` ([`crate::Error::TooManyContacts`]).
    pub fn traverse(&self, positions: &[DVec3]) -> Result<Detection> {
        self.traverse_with(positions, None, Start::Root)
            .map(|(det, _)| det)
    }

    /// [`traverse`](Self::traverse) from `start` (returning the front when
    /// it records one), the contour cull reusing kept certificates through
    /// `reuse` when given.
    fn traverse_with(
        &self,
        positions: &[DVec3],
        reuse: Option<&Reuse>,
        start: Start,
    ) -> Result<(Detection, Option<Front>)> {
        let t0 = Instant::now();
        let mesh = &*self.inner;
        let opts = TraverseOptions {
            cones: self.method != Method::Bvh,
            contour: self.method == Method::BvhConesContour,
            gap: 0.0,
        };
        let visitor = Intersect { mesh, positions };
        let (mut pairs, counters, front) = match reuse {
            Some(r) => {
                let cull = ContourCull::with_reuse(&self.bvh, mesh, positions, r);
                traverse_from(&self.bvh, mesh, 0.0, &cull, &visitor, start)
            }
            None => self_traverse_from(&self.bvh, mesh, positions, opts, &visitor, start),
        };
        if let Some(map) = &self.triangle_of {
            map_pairs(&mut pairs, map);
        }
        pairs.sort_unstable();
        let mut det = Detection {
            pairs,
            ..Default::default()
        };
        let mut proximity = Counters::default();
        if self.thickness > 0.0 {
            let near = Proximity::new(mesh, positions, self.thickness, self.max_contacts);
            let opts = TraverseOptions {
                cones: false,
                contour: false,
                gap: self.thickness,
            };
            let (parts, c) = self_traverse_parts(&self.bvh, mesh, positions, opts, &near);
            near.check_output(parts.iter().map(Vec::len).sum())?;
            det.proximity = collect_proximity_parts(parts);
            if let Some(map) = &self.triangle_of {
                det.proximity.map_triangles(map);
            }
            proximity = c;
        }
        let s = &mut det.stats;
        counters.write_to(s);
        s.node_pairs += proximity.node_pairs;
        s.slab_culls += proximity.slab_culls;
        s.proximity_tests = proximity.primitive_tests;
        s.traverse_time = t0.elapsed().as_secs_f64();
        det.count_contacts();
        Ok((det, front))
    }

    /// Sets the limit on proximity contacts (default [`DEFAULT_MAX_CONTACTS`]).
    pub fn set_max_contacts(&mut self, max: usize) {
        self.max_contacts = max;
    }

    /// One frame of [`Detector::detect`]: where the traversal starts and
    /// the refit (with the kept certificates' displacement boxes and the
    /// slabs when on), timed together as the refit, then the traversal.
    fn detect_frame(&mut self, positions: &[DVec3]) -> Result<Detection> {
        self.mesh.check_positions(positions)?;
        // The refit's time includes choosing the start (a pass over the
        // vertices for their largest move).
        let t0 = Instant::now();
        self.frames += 1;
        // From the second frame on (a sequence, not a single query) the
        // traversal keeps its front and the contour cull its certificates;
        // their displacement boxes are fitted with the refit, and timed with it.
        let sequence = self.frames >= 2;
        let start = if sequence {
            KeptFront::start(self.front.as_ref(), positions)
        } else {
            Start::Root
        };
        let keeps = self.method == Method::BvhConesContour && sequence;
        // From a kept front the contour cull asks few internal cones (its
        // kept certificates check their normals from the leaves): the refit
        // fits the leaves' cones only (`ConeFit`; slabs then lie along the
        // internal nodes' axes as last fitted).
        let from_front = matches!(start, Start::Front(..));
        let cones = if keeps && from_front && !self.bvh.spans.is_empty() {
            ConeFit::Leaves
        } else {
            ConeFit::All
        };
        let cap = KEPT_CAP * self.mesh.mean_edge_length();
        let mut kept = keeps.then(|| {
            self.kept
                .take()
                .unwrap_or_else(|| KeptCertificates::new(cap))
        });
        let reuse = match kept.as_mut() {
            Some(k) => k.refit(&mut self.bvh, &self.inner, positions, cones),
            None => {
                self.bvh.refit(&self.inner, positions);
                None
            }
        };
        if self.slabs.fit() {
            self.bvh.fit_slabs(&self.inner, positions);
        }
        let refit_time = t0.elapsed().as_secs_f64();
        let clearances = start.clearances();
        let det = self.traverse_with(positions, reuse.as_ref(), start);
        let fresh = reuse.map(Reuse::into_fresh);
        if let Some(mut k) = kept {
            k.keep(fresh.unwrap_or_default());
            self.kept = Some(k);
        }
        let (mut det, front) = det?;
        if let Some(mut front) = front {
            let (from_root, edge, mut reference) = match self.front.take() {
                Some(mut k) if from_front => {
                    let carried = front.carry_far(&mut k.front, clearances, &self.inner);
                    if let (false, Clearances::Skip(moved)) = (carried, clearances) {
                        // A vertex moved past the limit: set apart again,
                        // farther (a waving mesh stays within its swing).
                        let limit = (FAR_MOVE * k.edge).max(FAR_GROWTH * moved);
                        front.set_far(&self.inner, 2.0 * limit);
                    }
                    (k.from_root, k.edge, k.reference)
                }
                k => {
                    let edge = self.mesh.mean_edge_length_at(positions);
                    (
                        front.len(),
                        edge,
                        k.map(|k| k.reference).unwrap_or_default(),
                    )
                }
            };
            if !matches!(clearances, Clearances::Skip(_)) {
                reference.clear();
                reference.extend_from_slice(positions);
            }
            if clearances == Clearances::Measure {
                front.set_far(&self.inner, 2.0 * FAR_MOVE * edge);
            }
            self.front = Some(KeptFront {
                front,
                from_root,
                edge,
                reference,
                measured: clearances != Clearances::Drop,
            });
        }
        det.stats.refit_time = refit_time;
        Ok(det)
    }
}

impl Detector for BvhDetector {
    fn method(&self) -> Method {
        self.method
    }

    fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    fn set_max_contacts(&mut self, max: usize) {
        BvhDetector::set_max_contacts(self, max);
    }

    fn detect(&mut self, positions: &[DVec3]) -> Result<Detection> {
        let det = self.detect_frame(positions)?;
        self.slabs.update(&det.stats, self.mesh.n_triangles());
        Ok(det)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::brute::BruteDetector;
    use crate::scene::{grid, Deformation};

    /// A crumpled sheet waving with a growing swing: clearances measured on
    /// the second frame set the clearest jobs apart, the small swings skip
    /// them without reading them, a larger one reads them and sets them
    /// apart again farther; every frame's pairs are brute force's.
    #[test]
    fn front_jobs_set_apart_are_skipped_read_and_set_apart_again() {
        let (v, f) = grid(30, 1.0);
        let mesh = Arc::new(Mesh::new(v, f).unwrap());
        let base = Deformation::Crumple {
            amplitude: 0.35,
            wavelength: 0.4,
            seed: 3,
        }
        .apply(mesh.rest());
        let edge = mesh.mean_edge_length();
        let frame = |k: usize, swing: f64| -> Vec<DVec3> {
            let phase = 0.9 * k as f64;
            base.iter()
                .map(|p| {
                    let w = (p.x + 2.0 * p.y) * 7.0 + phase;
                    *p + DVec3::new(w.sin(), w.cos(), (w + 1.0).sin())
                        * (swing * edge / 3f64.sqrt())
                })
                .collect()
        };
        let mut d = BvhDetector::new(mesh.clone(), Method::BvhConesContour, 0.0);
        let mut brute = BruteDetector::new(mesh.clone(), 0.0);
        let (mut carried, mut limits, mut pairs) = (0, Vec::new(), 0);
        for k in 0..40 {
            // Slow first (a measure, then skipping), then past FAR_MOVE.
            let swing = if k < 20 {
                0.02
            } else {
                0.02 + 0.02 * (k - 20) as f64
            };
            let x = if k == 0 {
                base.clone()
            } else {
                frame(k, swing)
            };
            let got = d.detect(&x).unwrap().pairs;
            let want = brute.detect(&x).unwrap().pairs;
            assert_eq!(got, want, "frame {k}");
            pairs += got.len();
            let (far, limit) = d.front.as_ref().map_or((0, 0.0), |k| k.front.far());
            if far > 0 {
                carried += 1;
                if limits.last() != Some(&limit) {
                    limits.push(limit);
                }
            }
        }
        assert!(pairs > 0, "nothing intersects: nothing tested");
        assert!(carried > 10, "jobs set apart on {carried} frames");
        assert!(limits.len() >= 2, "set apart again: limits {limits:?}");
        assert!(limits.windows(2).all(|w| w[0] < w[1]), "{limits:?}");
    }
}
