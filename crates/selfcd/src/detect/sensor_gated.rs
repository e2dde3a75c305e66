//! The paper's method, `sensor-gated`: relax the particle sensor, and refit
//! and traverse the BVH only on frames where the sensor triggers (or refit
//! every frame, with `SensorParams::refit_every_frame`). Not conservative: on frames the sensor does not trigger, contacts
//! are not looked for. [`super::compare::compare_methods`] counts what it misses.

use super::hierarchy::BvhDetector;
use super::{Detection, Detector, Method};
use crate::error::Result;
use crate::mesh::Mesh;
use crate::sensor::parts::convex_parts;
use crate::sensor::{Relaxation, Sensor, SensorParams};
use crate::stats::FrameStats;
use glam::DVec3;
use std::sync::Arc;
use std::time::Instant;

/// Particle sensor in front of a BVH detector (`params.inner`).
pub struct SensorGatedDetector {
    bvh: BvhDetector,
    sensor: Sensor,
    particles: Vec<DVec3>,
    refit_every_frame: bool,
}

impl SensorGatedDetector {
    /// Builds the BVH and places the particles; any mesh (curved rest shape,
    /// several components, one triangle). Errors: invalid parameters.
    /// The particle count is the rest shape's number of convex parts
    /// ([`crate::sensor::parts`]), clamped to [`count`, `max_count`].
    pub fn new(mesh: Arc<Mesh>, thickness: f64, params: &SensorParams) -> Result<Self> {
        params.validate()?;
        let bvh = BvhDetector::new(mesh.clone(), params.inner, thickness);
        let parts = convex_parts(bvh.bvh());
        let params = SensorParams {
            count: parts.clamp(params.count, params.max_count),
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
        })
    }

    /// The sensor, as left by the last frame.
    pub fn sensor(&self) -> &Sensor {
        &self.sensor
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
        let mut refit = if self.refit_every_frame {
            timed_refit(&mut self.bvh)
        } else {
            0.0
        };
        let t0 = Instant::now();
        let relax = self.sensor.relax_checked(positions);
        let sensor_time = t0.elapsed().as_secs_f64();
        self.particles = self.sensor.positions(positions);
        let mut det = if relax.triggered {
            if !self.refit_every_frame {
                refit = timed_refit(&mut self.bvh);
            }
            self.bvh.traverse(positions)?
        } else {
            Detection::default()
        };
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
