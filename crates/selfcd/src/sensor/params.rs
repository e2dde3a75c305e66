//! `SensorParams`: every constant of the particle sensor, with its default.
//!
//! Lengths (step sizes, epsilon, tolerance) are in units of the mesh's mean
//! rest edge length L ([`crate::Mesh::mean_edge_length`]), and the force
//! constants a and b act on lengths in those units, so the sensor behaves the
//! same on a mesh scaled by any factor.
//!
//! How the defaults were chosen: `a = 20`, `b = 10` and `count = 4` are the
//! paper's. The others come from the sweep
//! `cargo run --release -p selfcd --example sensor_sweep -- --big --sweep [--fine]`,
//! which replays the sensor over nine analytic animations (flat, wave, twist,
//! four folds, roll, crumple; 60 frames each) at 200 and 20k triangles and
//! counts frames triggered without contacts, frames with contacts the gate
//! skipped, and updates per frame, against the exact reference. Over
//! tolerance {2,3,4} x gain {1,4,16,64} x max_step {0.5,1} x N_max {4,8,16}
//! the defaults sit in the middle of a block of settings that never skipped a
//! contact frame on the fold, roll, twist and wave animations at either size
//! (gain 1 is too slow to follow a fold at 20k; max_step 2 overshoots at
//! 200; N_min = 2 lets the one particle that tracks a fold stop early), with
//! one update per quiet frame once the particles have settled. No setting
//! with 4 particles catches the crumple animation, whose first contacts are
//! local (see BENCHMARKS.md, "Particle sensor (issue 3)").

use crate::detect::Method;
use crate::error::{Error, Result};

/// Most particles: each update costs count^2 force terms (the paper uses 4).
pub const MAX_COUNT: usize = 1024;

/// Most particle updates per frame (`n_max`): bounds the time of one detection.
pub const MAX_UPDATES: u32 = 10_000;

/// Parameters of the particle sensor and the sensor-gated detector.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorParams {
    /// Least number of particles k (the paper's 4 for its square cloth). `sensor-gated`
    /// follows the number of convex parts of the current shape ([`super::parts`])
    /// clamped to [`count`, [`crate::detect::sensor_gated::max_particles`]] (itself
    /// clamped to [`count`, `max_count`]); [`super::Sensor::new`] uses `count` as given.
    pub count: usize,
    /// Most particles `sensor-gated` ever places (each costs O(k) per update).
    pub max_count: usize,
    /// Attraction constant a in fa(r) = a / r^2 (paper: 20).
    pub a: f64,
    /// Repulsion constant b in fr(r) = -b / r^2 (paper: 10).
    pub b: f64,
    /// N_min: relaxation stops once fewer than this many particles moved more than `epsilon`.
    pub n_min: u32,
    /// N_max: the most particle updates per frame.
    pub n_max: u32,
    /// A particle "moved" in an update when it went further than this (mean-edge units).
    pub epsilon: f64,
    /// Step per unit force: an update moves a particle by `step_gain * F_tangent` (mean-edge units).
    pub step_gain: f64,
    /// The longest step of one update (mean-edge units): the clamp on `step_gain * |F|`.
    pub max_step: f64,
    /// Trigger: the traversal runs when the closest pair's straight-line distance is below this (mean-edge units).
    pub tolerance: f64,
    /// The BVH method run on triggered frames: `bvh-cones-contour` (default) or `bvh-cones` (the paper's).
    pub inner: Method,
    /// Refit the BVH on every frame (true) or only on triggered frames (false, default).
    /// Refit recomputes every box and cone from the positions, so the contacts are
    /// the same either way (tested); on a quiet frame the refit is most of the BVH's
    /// cost (a flat cloth is culled at the root), so skipping it is the saving.
    pub refit_every_frame: bool,
}

impl Default for SensorParams {
    fn default() -> Self {
        SensorParams {
            count: 4,
            max_count: 256,
            a: 20.0,
            b: 10.0,
            n_min: 1,
            n_max: 8,
            epsilon: 0.05,
            step_gain: 16.0,
            max_step: 0.5,
            tolerance: 3.0,
            inner: Method::BvhConesContour,
            refit_every_frame: false,
        }
    }
}

impl SensorParams {
    /// Checks every field's range; the error names the field.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: String| Err(Error::InvalidParameter(what));
        if self.count < 2 {
            return bad(format!(
                "sensor count must be at least 2 (a pair), got {}",
                self.count
            ));
        }
        if self.count > MAX_COUNT {
            return bad(format!(
                "sensor count must be at most {MAX_COUNT}, got {}",
                self.count
            ));
        }
        if self.max_count < self.count {
            return bad(format!(
                "sensor max_count ({}) must be at least count ({})",
                self.max_count, self.count
            ));
        }
        for (name, v) in [("a", self.a), ("b", self.b), ("step_gain", self.step_gain)] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("sensor {name} must be finite and >= 0, got {v}"));
            }
        }
        for (name, v) in [
            ("epsilon", self.epsilon),
            ("max_step", self.max_step),
            ("tolerance", self.tolerance),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("sensor {name} must be finite and > 0, got {v}"));
            }
        }
        if !(1..=MAX_UPDATES).contains(&self.n_max) {
            return bad(format!(
                "sensor n_max must be in 1..={MAX_UPDATES}, got {}",
                self.n_max
            ));
        }
        if self.n_min > self.n_max {
            return bad(format!(
                "sensor n_min ({}) must not exceed n_max ({})",
                self.n_min, self.n_max
            ));
        }
        if !matches!(
            self.inner,
            Method::BvhCones | Method::BvhConesContour | Method::Bvh
        ) {
            return bad(format!(
                "sensor inner method must be bvh, bvh-cones or bvh-cones-contour, got {}",
                self.inner
            ));
        }
        Ok(())
    }
}
