//! Relaxation and trigger (paper 2.4).
//!
//! Each frame the particles are updated, all at once from the same snapshot
//! (Jacobi style, so the order of particles does not matter), until fewer than
//! N_min particles moved more than epsilon in an update, or N_max updates were
//! made. One update: F_i from [`super::forces`], projected on the tangent
//! plane of i's triangle (F - (F.n) n), scaled by the step gain, clamped to
//! the maximum step, and walked along the surface ([`super::walk`]). Then the
//! closest pair by straight-line distance is found, and the sensor triggers
//! when that distance is below the tolerance.

use super::forces::{forces, Local};
use super::odl::{check_flat, original_distance};
use super::params::SensorParams;
use super::particle::SurfacePoint;
use super::place::farthest_points;
use super::walk;
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use glam::DVec3;
use std::sync::Arc;

/// The particle sensor of one mesh: its particles persist from frame to frame.
#[derive(Debug, Clone)]
pub struct Sensor {
    mesh: Arc<Mesh>,
    params: SensorParams,
    points: Vec<SurfacePoint>,
    unit: f64,
    margin: f64,
    locals: Vec<Local>,
    forces: Vec<DVec3>,
}

/// The closest particle pair by straight-line distance; distances in mean-edge units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosestPair {
    /// First particle (i < j).
    pub i: usize,
    /// Second particle.
    pub j: usize,
    /// Straight-line distance rs (SL).
    pub sl: f64,
    /// Original distance ro (ODL).
    pub odl: f64,
}

/// What one frame's relaxation did and decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relaxation {
    /// Particle updates made (1..=N_max).
    pub steps: u32,
    /// Particles that moved more than epsilon in the last update.
    pub moving: u32,
    /// The closest pair after relaxing.
    pub closest: ClosestPair,
    /// True when the closest pair's SL is below the trigger distance.
    pub triggered: bool,
}

impl Sensor {
    /// A sensor on `mesh` with particles placed by farthest-point sampling.
    /// Errors: invalid parameters, more particles than triangles, a curved rest
    /// shape, or a mean edge length of zero.
    pub fn new(mesh: Arc<Mesh>, params: SensorParams) -> Result<Sensor> {
        if params.count > mesh.n_triangles() {
            return Err(Error::InvalidParameter(format!(
                "sensor count {} exceeds the mesh's {} triangles",
                params.count,
                mesh.n_triangles()
            )));
        }
        let points = farthest_points(&mesh, params.count);
        Sensor::with_points(mesh, params, points)
    }

    /// A sensor with the given particles (their number overrides `params.count`).
    pub fn with_points(
        mesh: Arc<Mesh>,
        mut params: SensorParams,
        points: Vec<SurfacePoint>,
    ) -> Result<Sensor> {
        params.count = points.len();
        params.validate()?;
        check_flat(&mesh)?;
        points.iter().try_for_each(|p| p.check(&mesh))?;
        let unit = mesh.mean_edge_length();
        if !(unit > 0.0) {
            // A mesh of zero-area triangles all at one point: no length unit.
            return Err(Error::InvalidParameter(
                "the particle sensor needs a mesh with a positive mean edge length".into(),
            ));
        }
        Ok(Sensor {
            mesh,
            params,
            points,
            unit,
            margin: 0.0,
            locals: Vec::new(),
            forces: Vec::new(),
        })
    }

    /// Adds `length` (metres, >= 0) to the trigger distance: the detector's proximity thickness.
    pub fn set_margin(&mut self, length: f64) {
        self.margin = length.max(0.0) / self.unit;
    }

    /// The trigger distance: tolerance + margin (mean-edge units).
    pub fn trigger_distance(&self) -> f64 {
        self.params.tolerance + self.margin
    }

    /// The particles.
    pub fn points(&self) -> &[SurfacePoint] {
        &self.points
    }

    /// The parameters in use.
    pub fn params(&self) -> &SensorParams {
        &self.params
    }

    /// The length unit L (mean rest edge length, metres).
    pub fn unit(&self) -> f64 {
        self.unit
    }

    /// Particle positions in shape `positions`.
    pub fn positions(&self, positions: &[DVec3]) -> Vec<DVec3> {
        self.points
            .iter()
            .map(|p| p.position(&self.mesh, positions))
            .collect()
    }

    /// Relaxes at `positions` (checked against the mesh) and decides the trigger.
    pub fn relax(&mut self, positions: &[DVec3]) -> Result<Relaxation> {
        self.mesh.check_positions(positions)?;
        Ok(self.relax_checked(positions))
    }

    /// [`Sensor::relax`] for positions already checked by the caller.
    pub(crate) fn relax_checked(&mut self, positions: &[DVec3]) -> Relaxation {
        let (mut steps, mut moving) = (0, 0);
        while steps < self.params.n_max {
            moving = self.update(positions);
            steps += 1;
            if moving < self.params.n_min {
                break;
            }
        }
        let closest = self.closest(positions);
        Relaxation {
            steps,
            moving,
            closest,
            triggered: closest.sl < self.trigger_distance(),
        }
    }

    /// One update of every particle from the same snapshot; returns how many moved more than epsilon.
    pub fn update(&mut self, positions: &[DVec3]) -> u32 {
        let mesh = &*self.mesh;
        self.locals.clear();
        self.locals.extend(
            self.points
                .iter()
                .map(|p| Local::new(mesh, positions, p, self.unit)),
        );
        forces(&self.locals, self.params.a, self.params.b, &mut self.forces);
        let mut moving = 0;
        for ((p, l), f) in self.points.iter_mut().zip(&self.locals).zip(&self.forces) {
            let d = displacement(&self.params, l, *f) * self.unit;
            *p = walk::step(mesh, &l.map, *p, d);
            if p.position(mesh, positions).distance(l.current * self.unit)
                > self.params.epsilon * self.unit
            {
                moving += 1;
            }
        }
        moving
    }

    /// The pair with the smallest straight-line distance (first such pair on ties).
    pub fn closest(&self, positions: &[DVec3]) -> ClosestPair {
        let cur = self.positions(positions);
        let mut best = ClosestPair {
            i: 0,
            j: 1,
            sl: f64::INFINITY,
            odl: f64::INFINITY,
        };
        for i in 0..cur.len() {
            for j in i + 1..cur.len() {
                let sl = cur[i].distance(cur[j]) / self.unit;
                if sl < best.sl {
                    best = ClosestPair { i, j, sl, odl: 0.0 };
                }
            }
        }
        let (ri, rj) = (
            self.points[best.i].rest_position(&self.mesh),
            self.points[best.j].rest_position(&self.mesh),
        );
        best.odl = original_distance(ri, rj) / self.unit;
        best
    }
}

/// The step of a particle under force `f` in mean-edge units: the tangent part
/// F - (F.n) n, times the gain, clamped to the maximum step. Zero on a degenerate triangle.
#[inline]
fn displacement(params: &SensorParams, l: &Local, f: DVec3) -> DVec3 {
    let Some(n) = l.map.normal else {
        return DVec3::ZERO;
    };
    let step = (f - n * f.dot(n)) * params.step_gain;
    let len = step.length();
    if !len.is_finite() {
        return DVec3::ZERO;
    }
    if len > params.max_step {
        step * (params.max_step / len)
    } else {
        step
    }
}
