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
//! the tolerance; the relaxation also stops as soon as it triggers.

use super::forces::{forces, Local};
use super::odl::{Located, OriginalDistance};
use super::params::SensorParams;
use super::particle::SurfacePoint;
use super::parts::Parts;
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
    /// Pair terms one frame's relaxation may spend, if bounded (see [`Sensor::set_pair_budget`]).
    pair_budget: Option<usize>,
    locals: Vec<Local>,
    /// The particles' rest points ([`OriginalDistance::locate`]), per update.
    located: Vec<Located>,
    forces: Vec<DVec3>,
    /// Per particle step control (see [`Sensor::update`]); persistent across frames.
    damping: Vec<Damping>,
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

/// Least step scale of a particle (see [`Sensor::update`]): 1/64 of the step.
pub const MIN_SCALE: f64 = 1.0 / 64.0;

/// A step within 30 degrees of the last one is steady (cos 30 degrees).
pub const STEADY_COS: f64 = 0.866;

/// Step control of one particle: its step is the clamped force step times
/// `scale`. After each update the scale doubles (up to 1) when the step was
/// steady (within 30 degrees of the last) and the particle went at least half
/// as far as asked: it follows a pull, a fold or the spreading of a bunch.
/// Otherwise it halves (down to [`MIN_SCALE`]): the particle overshot an
/// equilibrium, circles (on curved rest shapes the field-gradient directions
/// jump between triangles), or is pushed against a boundary it slides along.
/// So particles come to rest on a quiet shape, and a quiet frame makes one
/// update and no geodesic field.
#[derive(Debug, Clone, Copy)]
struct Damping {
    /// The last unclamped step (current space, mean-edge units).
    last: DVec3,
    /// Step scale in [`MIN_SCALE`, 1].
    scale: f64,
    /// Length of the last step asked for (mean-edge units).
    asked: f64,
    /// Whether the last step was steady.
    steady: bool,
}

impl Default for Damping {
    fn default() -> Self {
        Damping {
            last: DVec3::ZERO,
            scale: 1.0,
            asked: 0.0,
            steady: false,
        }
    }
}

impl Damping {
    /// Updates the scale after a step that moved the particle by `moved` (mean-edge units).
    fn settle(&mut self, moved: f64) {
        self.scale = if self.steady && moved >= 0.5 * self.asked {
            (self.scale * 2.0).min(1.0)
        } else {
            (self.scale * 0.5).max(MIN_SCALE)
        };
    }
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
        let mut odl = odl;
        odl.set_reach(2.0 * params.tolerance / (1.0 - FOLD_T));
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
            pair_budget: None,
            locals: Vec::new(),
            located: Vec::new(),
            forces: Vec::new(),
            damping: Vec::new(),
        })
    }

    /// Follows the convex parts `parts` of the current shape (paper 2.1; seen
    /// by these particles, in their order) with persistent particles, towards
    /// `target` particles:
    ///
    /// - merge: while there are more particles than `target`, a particle whose
    ///   part already holds an earlier particle is removed (merged into that
    ///   one), never the last particle of its component;
    /// - add: while there are fewer, a particle is placed at the anchor
    ///   triangle of the largest part that holds none (ties: the lower part).
    ///
    /// Every other particle keeps its place and its geodesic field. Returns
    /// (added, removed).
    pub fn follow_parts(&mut self, parts: &Parts, target: usize) -> (usize, usize) {
        let comp = self.odl.components().clone();
        // Particles per component, over the particles' components only (O(k), not O(n)).
        let n_comp = self
            .points
            .iter()
            .map(|p| comp[p.tri as usize] as usize + 1)
            .max();
        let mut per_comp = vec![0usize; n_comp.unwrap_or(0)];
        for p in &self.points {
            per_comp[comp[p.tri as usize] as usize] += 1;
        }
        let excess = self.points.len().saturating_sub(target);
        let mut held = vec![false; parts.len()];
        let (mut keep, mut removed) = (Vec::with_capacity(self.points.len()), 0);
        for (p, &part) in self.points.iter().zip(&parts.of_point) {
            let (part, c) = (part as usize, comp[p.tri as usize] as usize);
            let merge = held[part] && removed < excess && per_comp[c] > 1;
            removed += merge as usize;
            per_comp[c] -= merge as usize;
            held[part] = true;
            keep.push(!merge);
        }
        if removed > 0 {
            let mut k = keep.iter();
            self.points.retain(|_| *k.next().unwrap_or(&true));
            self.odl.retain(&keep);
            let mut k = keep.iter();
            self.damping.retain(|_| *k.next().unwrap_or(&true));
        }
        let mut empty: Vec<usize> = (0..parts.len()).filter(|&p| !held[p]).collect();
        empty.sort_by_key(|&p| (std::cmp::Reverse(parts.size[p]), p));
        let room = target.saturating_sub(self.points.len());
        let added = empty.len().min(room);
        self.points.extend(
            empty[..added]
                .iter()
                .map(|&p| SurfacePoint::centroid(parts.anchor[p])),
        );
        (added, removed)
    }

    /// Adds `length` (metres, >= 0) to the trigger distance: the detector's proximity thickness.
    /// The geodesic fields reach at least 2 / (1 - [`FOLD_T`]) trigger
    /// distances, so that every pair close enough to trigger is judged folded
    /// or not from its field, not from the cut ([`OriginalDistance::set_reach`]).
    pub fn set_margin(&mut self, length: f64) {
        self.margin = length.max(0.0) / self.unit;
        self.odl
            .set_reach(2.0 * self.trigger_distance() / (1.0 - FOLD_T));
    }

    /// Bounds the updates of one frame to `pairs` pair terms: with k
    /// particles, an update costs k^2 of them (forces and the closest pair),
    /// so a frame makes at most pairs / k^2 updates (at least one, at most
    /// N_max). The gated detector sets this to a share of the mesh's size, so
    /// that many particles (a shape of many parts) cost a bounded share of the
    /// exact method; without it, a frame makes up to N_max updates.
    pub fn set_pair_budget(&mut self, pairs: usize) {
        self.pair_budget = Some(pairs);
    }

    /// The most updates of one frame: N_max, or fewer under the pair budget.
    pub fn max_updates(&self) -> u32 {
        let k = self.points.len().max(1);
        let n_max = self.params.n_max;
        self.pair_budget
            .map_or(n_max, |b| (b / (k * k)).clamp(1, n_max as usize) as u32)
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
    ///
    /// Besides N_min and N_max, the relaxation stops as soon as the sensor
    /// triggers: a triggered frame runs the exact traversal, so further
    /// updates cannot change what the frame finds, and the particles go on
    /// from where they are on the next frame. On a shape with contacts at rest
    /// (a garment on a body) every frame triggers and makes one update.
    pub(crate) fn relax_checked(&mut self, positions: &[DVec3]) -> Relaxation {
        let (mut steps, most) = (0, self.max_updates());
        loop {
            let moving = self.step(positions);
            steps += 1;
            let closest = self.closest_in_frame();
            let triggered = closest.folded && closest.sl < self.trigger_distance();
            if triggered || moving < self.params.n_min || steps >= most {
                return Relaxation {
                    steps,
                    moving,
                    closest,
                    triggered,
                };
            }
        }
    }

    /// Writes the corners of every particle's triangle, in the sensor's frame
    /// ([`super::units`]), into the buffer: all the sensor reads of a shape, so
    /// a frame costs O(particles), not O(vertices). Other entries are stale.
    fn load_corners(&mut self, positions: &[DVec3]) {
        let (origin, unit) = (self.origin, self.unit);
        self.scaled.resize(positions.len(), DVec3::ZERO);
        for p in &self.points {
            for &c in &self.norm.triangles()[p.tri as usize] {
                self.scaled[c as usize] = to_frame(positions[c as usize], origin, unit);
            }
        }
    }

    /// One update of every particle from the same snapshot; returns how many
    /// moved more than epsilon. Each particle's step is scaled by its own
    /// factor, halved when the step points against its last one (it overshot an
    /// equilibrium: on curved rest shapes the field-gradient directions jump
    /// between triangles, and undamped particles circle for ever) and doubled,
    /// up to 1, otherwise; so particles settle where the forces balance, and
    /// still follow a fold at full speed two or three updates after it pulls.
    pub fn update(&mut self, positions: &[DVec3]) -> u32 {
        self.step(positions)
    }

    /// [`Sensor::update`] (positions already checked).
    fn step(&mut self, raw: &[DVec3]) -> u32 {
        self.load_corners(raw);
        self.odl.renew(&self.points);
        self.locate();
        let (mesh, positions) = (&*self.norm, &self.scaled);
        let unit = mesh.mean_edge_length();
        self.locals.clear();
        self.locals.extend(
            self.points
                .iter()
                .map(|p| Local::new(mesh, positions, p, unit)),
        );
        forces(
            &self.locals,
            (&self.points, &self.located),
            &self.odl,
            self.params.a,
            self.params.b,
            &mut self.forces,
        );
        self.damping.resize(self.points.len(), Damping::default());
        for (((p, l), f), dmp) in self
            .points
            .iter_mut()
            .zip(&self.locals)
            .zip(&self.forces)
            .zip(&mut self.damping)
        {
            let d = displacement(&self.params, l, *f);
            dmp.steady = d.dot(dmp.last) > STEADY_COS * d.length() * dmp.last.length();
            dmp.last = d;
            let step = clamped(&self.params, d) * dmp.scale;
            dmp.asked = step.length();
            *p = walk::step(mesh, &l.map, *p, step * unit);
        }
        self.load_corners(raw);
        self.locate();
        let mesh = &*self.norm;
        let mut moving = 0;
        for ((p, l), dmp) in self.points.iter().zip(&self.locals).zip(&mut self.damping) {
            let moved = p.position(mesh, &self.scaled).distance(l.current * unit) / unit;
            moving += (moved > self.params.epsilon) as u32;
            dmp.settle(moved);
        }
        moving
    }

    /// The pair that decides the trigger: the smallest straight-line distance
    /// among folded pairs (t = (ro - rs) / ro >= [`FOLD_T`]: close in space, far
    /// along the surface, or on different components), else among all pairs
    /// (then it does not trigger). First such pair on ties.
    pub fn closest(&mut self, positions: &[DVec3]) -> ClosestPair {
        self.load_corners(positions);
        self.locate();
        self.closest_in_frame()
    }

    /// Locates the particles in the rest copy and marches the geodesic fields
    /// that paths between them read ([`OriginalDistance::prepare`]).
    fn locate(&mut self) {
        self.odl.locate(&self.points, &mut self.located);
        self.odl.prepare(&self.points, &self.located);
    }

    /// [`Sensor::closest`] at the positions in the buffer, with the particles
    /// located ([`OriginalDistance::locate`]) where they are.
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
                let path = self.odl.path_between(
                    (&self.points[i], &self.located[i]),
                    (&self.points[j], &self.located[j]),
                    j,
                );
                let odl = path.length;
                let folded = !(sl > (1.0 - FOLD_T) * path.lower);
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

/// The step of a particle under force `f` in mean-edge units before the
/// clamp: the tangent part F - (F.n) n, times the gain. Zero on a degenerate
/// triangle or a non-finite force.
#[inline]
fn displacement(params: &SensorParams, l: &Local, f: DVec3) -> DVec3 {
    let Some(n) = l.map.normal else {
        return DVec3::ZERO;
    };
    let step = (f - n * f.dot(n)) * params.step_gain;
    if step.is_finite() {
        step
    } else {
        DVec3::ZERO
    }
}

/// `step` clamped to the maximum step.
#[inline]
fn clamped(params: &SensorParams, step: DVec3) -> DVec3 {
    let len = step.length();
    if len > params.max_step {
        step * (params.max_step / len)
    } else {
        step
    }
}
