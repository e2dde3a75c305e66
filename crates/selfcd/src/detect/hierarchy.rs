//! BVH detectors: `bvh`, `bvh-cones` and `bvh-cones-contour`.

use super::narrow::{collect_proximity, Intersect, Proximity};
use super::{Detection, Detector, Method};
use crate::bvh::traverse::{self_traverse, TraverseOptions};
use crate::bvh::{build::build, Bvh};
use crate::error::Result;
use crate::mesh::Mesh;
use crate::stats::Counters;
use glam::DVec3;
use std::sync::Arc;
use std::time::Instant;

/// A BVH built once for the mesh, refitted and traversed each frame.
pub struct BvhDetector {
    mesh: Arc<Mesh>,
    bvh: Bvh,
    method: Method,
    thickness: f64,
}

impl BvhDetector {
    /// Builds the hierarchy of `mesh` for `method` (not `brute`).
    pub fn new(mesh: Arc<Mesh>, method: Method, thickness: f64) -> Self {
        let bvh = build(&mesh);
        BvhDetector {
            mesh,
            bvh,
            method,
            thickness,
        }
    }

    /// The hierarchy, as refitted by the last call.
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Refits the boxes to the triangles swept from `x0` to `x1` (continuous queries).
    pub(crate) fn refit_swept(&mut self, x0: &[DVec3], x1: &[DVec3]) {
        self.bvh.refit_swept(&self.mesh, x0, x1);
    }

    /// Refits boxes and cones to `positions` (already checked).
    pub fn refit(&mut self, positions: &[DVec3]) {
        self.bvh.refit(&self.mesh, positions);
    }

    /// Traverses the refitted hierarchy: intersections, and proximity when
    /// thickness > 0 (a second, boxes-only traversal: cones say nothing about
    /// distance). Fills every field but the refit and sensor times.
    pub fn traverse(&self, positions: &[DVec3]) -> Detection {
        let t0 = Instant::now();
        let mesh = &*self.mesh;
        let opts = TraverseOptions {
            cones: self.method != Method::Bvh,
            contour: self.method == Method::BvhConesContour,
            gap: 0.0,
        };
        let (mut pairs, counters) = self_traverse(
            &self.bvh,
            mesh,
            positions,
            opts,
            &Intersect { mesh, positions },
        );
        pairs.sort_unstable();
        let mut det = Detection {
            pairs,
            ..Default::default()
        };
        let mut proximity = Counters::default();
        if self.thickness > 0.0 {
            let near = Proximity {
                mesh,
                positions,
                thickness: self.thickness,
            };
            let opts = TraverseOptions {
                cones: false,
                contour: false,
                gap: self.thickness,
            };
            let (items, c) = self_traverse(&self.bvh, mesh, positions, opts, &near);
            det.proximity = collect_proximity(items);
            proximity = c;
        }
        let s = &mut det.stats;
        counters.write_to(s);
        s.node_pairs += proximity.node_pairs;
        s.proximity_tests = proximity.primitive_tests;
        s.traverse_time = t0.elapsed().as_secs_f64();
        det.count_contacts();
        det
    }
}

impl Detector for BvhDetector {
    fn method(&self) -> Method {
        self.method
    }

    fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    fn detect(&mut self, positions: &[DVec3]) -> Result<Detection> {
        self.mesh.check_positions(positions)?;
        let t0 = Instant::now();
        self.refit(positions);
        let refit_time = t0.elapsed().as_secs_f64();
        let mut det = self.traverse(positions);
        det.stats.refit_time = refit_time;
        Ok(det)
    }
}
