//! Relaxation and trigger (paper 2.4).
//!
//! Each frame the particles are updated, all at once from the same snapshot
//! (Jacobi style, so the order of particles does not matter), until fewer than
//! N_min particles moved more than epsilon in an update, or N_max updates were
//! made. One update: F_i from [`super::forces`], projected on the tangent
//! plane of i's triangle (F - (F.n) n), scaled by the step gain, clamped to
//! the maximum step, and walked along the surface ([`super::walk`]). Then the
//! closest folded pair by straight-line distance is found (see
//! [`Sensor::closest`]), and the sensor triggers when that distance is below
//! the tolerance.

use super::forces::{forces, Local};
use super::odl::OriginalDistance;
use super::params::SensorParams;
use super::particle::SurfacePoint;
use super::place::{place, share};
use super::units::{normalised, to_frame};
use super::walk;
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use glam::DVec3;
use std::sync::Arc;

/// The particle sensor of one mesh: its particles persist from frame to frame.
#[derive(Debug, Clone)]
pub struct Sensor {
    mesh: Arc<Mesh>,
    /// The mesh in mean-edge units, snapped ([`normalised`]): what the sensor computes on.
    norm: Arc<Mesh>,
    /// Origin of `norm` in the mesh's units.
    origin: DVec3,
    /// The current positions in `norm`'s frame (one frame's buffer).
    scaled: Vec<DVec3>,
    params: SensorParams,
    points: Vec<SurfacePoint>,
    odl: OriginalDistance,
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
    /// Original distance ro (ODL); infinite between components.
    pub odl: f64,
    /// True when t = (ro - rs) / ro >= [`FOLD_T`].
    pub folded: bool,
}

/// Least t = (ro - rs) / ro of a pair that can trigger: a pair as close in
/// space as along the surface (t near 0) only says the particles are
/// neighbours, not that the surface folded between them. A fold that brings
/// two points together has t -> 1; 1/4 leaves margin for the geodesic's error
/// and for curved rest shapes, where the chord is shorter than the geodesic.
pub const FOLD_T: f64 = 0.25;

/// What one frame's relaxation did and decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relaxation {
    /// Particle updates made (1..=N_max).
    pub steps: u32,
    /// Particles that moved more than epsilon in the last update.
    pub moving: u32,
    /// The closest pair after relaxing.
    pub closest: ClosestPair,
    /// True when the closest pair is folded and its SL is below the trigger distance.
    pub triggered: bool,
}

impl Sensor {
    /// A sensor on `mesh` with `params.count` particles shared among its
    /// components and spread over each ([`super::place`]). Any mesh is accepted:
    /// flat or curved rest shape, any number of components, one triangle.
    /// Errors: invalid parameters, or a mean edge length of zero.
    pub fn new(mesh: Arc<Mesh>, params: SensorParams) -> Result<Sensor> {
        params.validate()?;
        let (norm, origin) = normalised(&mesh);
        let odl = OriginalDistance::new(norm.clone());
        let points = place(
            &norm,
            odl.components(),
            &share(&norm, odl.components(), params.count),
        );
        Sensor::build(mesh, (norm, origin), params, points, odl)
    }

    /// A sensor with the given particles (their number overrides `params.count`).
    pub fn with_points(
        mesh: Arc<Mesh>,
        params: SensorParams,
        points: Vec<SurfacePoint>,
    ) -> Result<Sensor> {
        let (norm, origin) = normalised(&mesh);
        let odl = OriginalDistance::new(norm.clone());
        Sensor::build(mesh, (norm, origin), params, points, odl)
    }

    fn build(
        mesh: Arc<Mesh>,
        (norm, origin): (Arc<Mesh>, DVec3),
        mut params: SensorParams,
        points: Vec<SurfacePoint>,
        odl: OriginalDistance,
    ) -> Result<Sensor> {
        // One particle per component at least: that may exceed max_count (a triangle soup).
        params.count = points.len();
        params.max_count = params.max_count.max(params.count);
        params.validate()?;
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
            norm,
            origin,
            scaled: Vec::new(),
            params,
            points,
            odl,
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

    /// The original distance in use (flat or geodesic, components, fields computed).
    pub fn original_distance(&self) -> &OriginalDistance {
        &self.odl
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
        self.load_frame(positions);
        let (mut steps, mut moving) = (0, 0);
        while steps < self.params.n_max {
            moving = self.step();
            steps += 1;
            if moving < self.params.n_min {
                break;
            }
        }
        let closest = self.closest_in_frame();
        Relaxation {
            steps,
            moving,
            closest,
            triggered: closest.folded && closest.sl < self.trigger_distance(),
        }
    }

    /// Writes `positions` in the sensor's frame ([`super::units`]) into the buffer.
    fn load_frame(&mut self, positions: &[DVec3]) {
        let (origin, unit) = (self.origin, self.unit);
        self.scaled.clear();
        self.scaled
            .extend(positions.iter().map(|&p| to_frame(p, origin, unit)));
    }

    /// One update of every particle from the same snapshot; returns how many moved more than epsilon.
    pub fn update(&mut self, positions: &[DVec3]) -> u32 {
        self.load_frame(positions);
        self.step()
    }

    /// [`Sensor::update`] at the positions in the buffer.
    fn step(&mut self) -> u32 {
        let (mesh, positions) = (&*self.norm, &self.scaled);
        let unit = mesh.mean_edge_length();
        self.locals.clear();
        self.locals.extend(
            self.points
                .iter()
                .map(|p| Local::new(mesh, positions, p, unit)),
        );
        self.odl.refresh(&self.points);
        forces(
            &self.locals,
            &self.points,
            &self.odl,
            self.params.a,
            self.params.b,
            &mut self.forces,
        );
        let mut moving = 0;
        for ((p, l), f) in self.points.iter_mut().zip(&self.locals).zip(&self.forces) {
            let d = displacement(&self.params, l, *f) * unit;
            *p = walk::step(mesh, &l.map, *p, d);
            if p.position(mesh, positions).distance(l.current * unit) > self.params.epsilon * unit {
                moving += 1;
            }
        }
        moving
    }

    /// The pair that decides the trigger: the smallest straight-line distance
    /// among folded pairs (t = (ro - rs) / ro >= [`FOLD_T`]: close in space, far
    /// along the surface, or on different components), else among all pairs
    /// (then it does not trigger). First such pair on ties.
    pub fn closest(&mut self, positions: &[DVec3]) -> ClosestPair {
        self.load_frame(positions);
        self.closest_in_frame()
    }

    /// [`Sensor::closest`] at the positions in the buffer.
    fn closest_in_frame(&self) -> ClosestPair {
        let unit = self.norm.mean_edge_length();
        let cur: Vec<DVec3> = self
            .points
            .iter()
            .map(|p| p.position(&self.norm, &self.scaled))
            .collect();
        let mut best = ClosestPair {
            i: 0,
            j: 1,
            sl: f64::INFINITY,
            odl: f64::INFINITY,
            folded: false,
        };
        for i in 0..cur.len() {
            for j in i + 1..cur.len() {
                let sl = cur[i].distance(cur[j]) / unit;
                let odl = self.odl.path(&self.points, i, j).length;
                let folded = !(sl > (1.0 - FOLD_T) * odl);
                if (folded, -sl) > (best.folded, -best.sl) {
                    best = ClosestPair {
                        i,
                        j,
                        sl,
                        odl,
                        folded,
                    };
                }
            }
        }
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
