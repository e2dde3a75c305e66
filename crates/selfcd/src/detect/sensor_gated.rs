//! The paper's method, `sensor-gated`: relax the particle sensor, and refit
//! and traverse the BVH only on frames where the sensor triggers (or refit
//! every frame, with `SensorParams::refit_every_frame`). Not conservative: on
//! frames the sensor does not trigger, contacts are not looked for.
//! [`super::compare::compare_methods`] counts what it misses.
//!
//! The particle count follows the convex parts of the current shape
//! ([`crate::sensor::parts`]): every [`RECOUNT`] frames, and on every
//! triggered frame (whose refit is paid anyway), the parts are counted from the
//! refitted cones; when the count (clamped to [`count`, [`max_particles`]])
//! differs from the particles', [`Sensor::follow_parts`] adds particles where
//! parts appeared and merges them where parts vanished. Otherwise the
//! particles persist as they are.

use super::hierarchy::BvhDetector;
use super::{Detection, Detector, Method};
use crate::error::Result;
use crate::mesh::Mesh;
use crate::sensor::parts::{convex_parts, Parts};
use crate::sensor::{Relaxation, Sensor, SensorParams};
use crate::stats::FrameStats;
use glam::DVec3;
use std::sync::Arc;
use std::time::Instant;

/// Frames between two part counts on quiet frames. A count refits the BVH
/// (the exact method's cost on a quiet frame is at least its refit), so a
/// count every 16 frames costs at most 1/16 = 6.25% of the exact method,
/// which leaves the relaxation the rest of the 10% quiet-frame budget.
pub const RECOUNT: u64 = 16;

/// Most particles on a mesh of `triangles` triangles: sqrt(triangles / 4).
/// One relaxation update costs k^2 pair terms and a quiet frame of the exact
/// method at least a refit of its 2 n - 1 nodes, so k^2 <= n / 4 keeps one
/// update to a fraction of the exact method at any size (measured in
/// BENCHMARKS.md); the count is still clamped to [`count`, `max_count`].
pub fn max_particles(triangles: usize) -> usize {
    ((triangles as f64 / 4.0).sqrt()) as usize
}

/// Particle sensor in front of a BVH detector (`params.inner`).
pub struct SensorGatedDetector {
    bvh: BvhDetector,
    sensor: Sensor,
    particles: Vec<DVec3>,
    refit_every_frame: bool,
    /// Particle count bounds: [`SensorParams::count`], [`SensorParams::max_count`].
    bounds: (usize, usize),
    /// Frames detected so far.
    frame: u64,
}

impl SensorGatedDetector {
    /// Builds the BVH and places the particles; any mesh (curved rest shape,
    /// several components, one triangle). Errors: invalid parameters.
    /// The particle count is the rest shape's number of convex parts
    /// ([`crate::sensor::parts`]), clamped to [`count`, [`max_particles`]]
    /// (itself within [`count`, `max_count`]).
    pub fn new(mesh: Arc<Mesh>, thickness: f64, params: &SensorParams) -> Result<Self> {
        params.validate()?;
        let bvh = BvhDetector::new(mesh.clone(), params.inner, thickness);
        let parts = convex_parts(bvh.bvh());
        let bounds = (
            params.count,
            max_particles(mesh.n_triangles()).clamp(params.count, params.max_count),
        );
        let params = SensorParams {
            count: parts.clamp(bounds.0, bounds.1),
            max_count: bounds.1,
            ..params.clone()
        };
        let mut sensor = Sensor::new(mesh.clone(), params.clone())?;
        sensor.set_margin(thickness);
        let particles = sensor.positions(mesh.rest());
        Ok(SensorGatedDetector {
            bvh,
            sensor,
            particles,
            refit_every_frame: params.refit_every_frame,
            bounds,
            frame: 0,
        })
    }

    /// The sensor, as left by the last frame.
    pub fn sensor(&self) -> &Sensor {
        &self.sensor
    }

    /// Reads the parts of the shape the BVH was just refitted to and follows
    /// them. Counting the parts visits only the nodes above them; the O(n)
    /// labelling runs only when the count asks for particles to be added or merged.
    fn follow_parts(&mut self, positions: &[DVec3]) {
        let target = convex_parts(self.bvh.bvh()).clamp(self.bounds.0, self.bounds.1);
        if target == self.sensor.points().len() {
            return;
        }
        let parts = Parts::new(self.bvh.bvh(), self.bvh.mesh(), positions);
        self.sensor.follow_parts(&parts, target);
    }
}

/// Copies one frame's relaxation into the stats.
fn write_sensor(s: &mut FrameStats, r: &Relaxation, seconds: f64) {
    s.sensor_time = seconds;
    s.triggered = Some(r.triggered);
    s.relax_steps = r.steps;
    s.moving_particles = r.moving;
    s.closest_sl = r.closest.sl;
    s.closest_odl = r.closest.odl;
}

impl Detector for SensorGatedDetector {
    fn method(&self) -> Method {
        Method::SensorGated
    }

    fn mesh(&self) -> &Arc<Mesh> {
        self.bvh.mesh()
    }

    fn detect(&mut self, positions: &[DVec3]) -> Result<Detection> {
        self.bvh.mesh().check_positions(positions)?;
        let timed_refit = |bvh: &mut BvhDetector| {
            let t0 = Instant::now();
            bvh.refit(positions);
            t0.elapsed().as_secs_f64()
        };
        let recount = self.frame.is_multiple_of(RECOUNT);
        self.frame += 1;
        let refitted = self.refit_every_frame || recount;
        let mut refit = if refitted {
            timed_refit(&mut self.bvh)
        } else {
            0.0
        };
        let t0 = Instant::now();
        if recount {
            self.follow_parts(positions);
        }
        let relax = self.sensor.relax_checked(positions);
        let mut sensor_time = t0.elapsed().as_secs_f64();
        let mut det = if relax.triggered {
            if !refitted {
                refit = timed_refit(&mut self.bvh);
            }
            let det = self.bvh.traverse(positions)?;
            if !recount {
                // The refit is paid: follow the parts of this shape for the next frame.
                let t0 = Instant::now();
                self.follow_parts(positions);
                sensor_time += t0.elapsed().as_secs_f64();
            }
            det
        } else {
            Detection::default()
        };
        self.particles = self.sensor.positions(positions);
        det.stats.refit_time = refit;
        write_sensor(&mut det.stats, &relax, sensor_time);
        Ok(det)
    }

    fn set_max_contacts(&mut self, max: usize) {
        self.bvh.set_max_contacts(max);
    }

    fn particles(&self) -> Vec<DVec3> {
        self.particles.clone()
    }
}
