//! `Simulation`: a cloth, its state, and a detector, stepped in time.
//!
//! One step of length h:
//! 1. proximity contacts within `d + margin` at the current positions (from the
//!    end of the previous step's detection, or a fresh one on the first step);
//! 2. assemble and solve the backward Euler system with the filter: pins fixed,
//!    vertex-triangle contacts inside `d` constrained along their normal;
//! 3. `v += dv`, contact impulses, `x += h v`;
//! 4. correction: no intersecting triangle pair is left at the end of the step.
//!
//! The detector owns its BVH (and any other state between frames); the
//! simulation owns positions and velocities and only hands the detector
//! positions. When the chosen detection method is not conservative, a second,
//! conservative detector (`bvh-cones-contour`) runs the end-of-step check.

use super::model::{Cloth, Energy};
use super::response::{self, ContactKind, ContactParams, StepStart};
use super::solver::{Filter, Pcg, PcgOptions, System};
use crate::detect::hierarchy::BvhDetector;
use crate::detect::{new_detector, Detection, Detector, DetectorOptions, Method};
use crate::error::{Error, Result};
use crate::stats::FrameStats;
use glam::DVec3;
use std::time::Instant;

/// Time step, solver and contact settings of a simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimOptions {
    /// Time step h (s).
    pub dt: f64,
    /// Conjugate-gradient stopping rule.
    pub pcg: PcgOptions,
    /// Contact thickness and handling.
    pub contact: ContactParams,
    /// Detect and respond to self-contact (off: the cloth passes through itself).
    pub self_collision: bool,
}

impl SimOptions {
    /// Defaults for `cloth`: h = 1/60 s, PCG to 1e-3 or 200 iterations, contact
    /// thickness scaled to the mesh ([`ContactParams::for_mesh`]), self-collision on.
    pub fn for_cloth(cloth: &Cloth) -> SimOptions {
        SimOptions {
            dt: 1.0 / 60.0,
            pcg: PcgOptions::default(),
            contact: ContactParams::for_mesh(cloth.mesh()),
            self_collision: true,
        }
    }

    /// Checks ranges: dt > 0, tolerance > 0, contact parameters.
    pub fn validate(&self) -> Result<()> {
        if !(self.dt > 0.0 && self.dt.is_finite()) {
            return Err(Error::InvalidParameter(format!(
                "time step must be positive and finite, got {}",
                self.dt
            )));
        }
        if !(self.pcg.tolerance > 0.0 && self.pcg.tolerance.is_finite()) {
            return Err(Error::InvalidParameter(format!(
                "solver tolerance must be positive, got {}",
                self.pcg.tolerance
            )));
        }
        self.contact.validate()
    }
}

/// Pairs closer than this fraction of the thickness count as meeting in the continuous stage.
const CONTINUOUS_SEPARATION: f64 = 0.5;
/// Most continuous queries per step.
const CONTINUOUS_ROUNDS: u32 = 4;

/// What one step did and cost. Times are wall-clock seconds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepStats {
    /// Conjugate-gradient iterations.
    pub iterations: u32,
    /// Final relative residual of the solve.
    pub residual: f64,
    /// Stats of the method's last detection call this step (at the end-of-step positions).
    pub detection: FrameStats,
    /// Proximity contacts responded to this step (vertex-triangle + edge-edge).
    pub contacts: usize,
    /// Of which vertex-triangle.
    pub vertex_triangle: usize,
    /// Contact constraints put in the solve's filter.
    pub constrained: usize,
    /// Contact impulses applied.
    pub impulses: u64,
    /// Continuous queries run by the continuous stage.
    pub ccd_rounds: u32,
    /// Element pairs the continuous stage found meeting during the step (all rounds).
    pub ccd_impacts: u64,
    /// Vertices whose end-of-step motion the correction stage replaced by the
    /// rigid motion of their impact zone (or froze at the start of the step).
    pub reverted: usize,
    /// Impact zones formed by the correction stage.
    pub zones: usize,
    /// Detections run by the correction stage.
    pub correction_rounds: u32,
    /// Intersecting triangle pairs left at the end of the step (0 unless it started with some).
    pub intersections: usize,
    /// Assembly and solve time.
    pub solve_time: f64,
    /// Detection time (every detector call this step).
    pub detect_time: f64,
    /// Contact response time, without detection.
    pub response_time: f64,
    /// The whole step.
    pub step_time: f64,
}

/// A cloth in motion: state, solver and detectors.
pub struct Simulation {
    cloth: Cloth,
    opts: SimOptions,
    x: Vec<DVec3>,
    v: Vec<DVec3>,
    dv: Vec<DVec3>,
    inv_mass: Vec<f64>,
    detector: Box<dyn Detector>,
    guard: Option<Box<dyn Detector>>,
    /// Hierarchy for the continuous stage (swept boxes), when self-collision is on.
    continuous: Option<BvhDetector>,
    pending: Option<Detection>,
    system: System,
    pcg: Pcg,
    time: f64,
    steps: u64,
}

impl Simulation {
    /// A simulation of `cloth` at rest in its rest shape, detecting self-contact
    /// with `method`.
    pub fn new(cloth: Cloth, method: Method, opts: SimOptions) -> Result<Simulation> {
        opts.validate()?;
        let mesh = cloth.mesh().clone();
        let detector = new_detector(
            mesh.clone(),
            method,
            &DetectorOptions {
                thickness: opts.contact.detection_distance(),
                ..Default::default()
            },
        )?;
        let guard = if method.is_conservative() {
            None
        } else {
            Some(new_detector(
                mesh.clone(),
                Method::BvhConesContour,
                &DetectorOptions::default(),
            )?)
        };
        let continuous = opts.self_collision.then(|| BvhDetector::new(mesh.clone(), Method::Bvh, 0.0));
        let n = mesh.n_vertices();
        Ok(Simulation {
            x: mesh.rest().to_vec(),
            v: vec![DVec3::ZERO; n],
            dv: vec![DVec3::ZERO; n],
            inv_mass: cloth.inverse_masses(),
            system: System::new(&cloth),
            pcg: Pcg::default(),
            cloth,
            opts,
            detector,
            guard,
            continuous,
            pending: None,
            time: 0.0,
            steps: 0,
        })
    }

    /// Replaces the state. Pinned vertices keep the given positions with zero velocity.
    pub fn set_state(&mut self, x: Vec<DVec3>, mut v: Vec<DVec3>) -> Result<()> {
        let mesh = self.cloth.mesh();
        mesh.check_positions(&x)?;
        mesh.check_positions(&v)?;
        for (vi, &p) in v.iter_mut().zip(self.cloth.pinned()) {
            if p {
                *vi = DVec3::ZERO;
            }
        }
        (self.x, self.v) = (x, v);
        self.dv.iter_mut().for_each(|d| *d = DVec3::ZERO);
        self.pending = None;
        Ok(())
    }

    /// Current positions (m).
    pub fn positions(&self) -> &[DVec3] {
        &self.x
    }

    /// Current velocities (m/s).
    pub fn velocities(&self) -> &[DVec3] {
        &self.v
    }

    /// The cloth.
    pub fn cloth(&self) -> &Cloth {
        &self.cloth
    }

    /// The options.
    pub fn options(&self) -> &SimOptions {
        &self.opts
    }

    /// The detection method driving the response.
    pub fn method(&self) -> Method {
        self.detector.method()
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Energy of the current state.
    pub fn energy(&self) -> Energy {
        self.cloth.energy(&self.x, &self.v)
    }

    /// Advances the simulation by one time step.
    pub fn step(&mut self) -> Result<StepStats> {
        let t_step = Instant::now();
        let h = self.opts.dt;
        let mut st = StepStats::default();
        let contacts = if self.opts.self_collision {
            let det = match self.pending.take() {
                Some(d) => d,
                None => self.timed_detect(&mut st)?,
            };
            let t0 = Instant::now();
            let c = response::gather(self.cloth.mesh(), &self.x, &det.proximity);
            st.response_time += t0.elapsed().as_secs_f64();
            c
        } else {
            Vec::new()
        };
        st.contacts = contacts.len();
        st.vertex_triangle = contacts
            .iter()
            .filter(|c| c.kind == ContactKind::VertexTriangle)
            .count();

        let t0 = Instant::now();
        let mut filter = Filter::new(self.cloth.pinned());
        st.constrained = response::constrain(
            &contacts,
            &self.v,
            &self.dv,
            &self.opts.contact,
            h,
            &mut filter,
        );
        let t1 = Instant::now();
        self.system.assemble(&self.cloth, &self.x, &self.v, h);
        let pcg = self.pcg.solve(
            &self.system.a,
            &self.system.b,
            &filter,
            &mut self.dv,
            self.opts.pcg,
        );
        (st.iterations, st.residual) = (pcg.iterations, pcg.residual);
        let t2 = Instant::now();
        st.solve_time = (t2 - t1).as_secs_f64();

        let x0 = self.x.clone();
        for (v, dv) in self.v.iter_mut().zip(&self.dv) {
            *v += *dv;
        }
        st.impulses = response::impulses(
            &contacts,
            &self.inv_mass,
            &mut self.v,
            &self.opts.contact,
            h,
        )
        .impulses;
        if let Some(query) = self.continuous.as_mut() {
            let separation = CONTINUOUS_SEPARATION * self.opts.contact.thickness;
            let c = response::continuous_impulses(query, &x0, &self.inv_mass, &mut self.v, h, separation, CONTINUOUS_ROUNDS)?;
            (st.ccd_rounds, st.ccd_impacts) = (c.rounds, c.impacts);
            st.impulses += c.impulses;
            st.detect_time += c.detect_time;
            st.response_time -= c.detect_time;
        }
        for (x, v) in self.x.iter_mut().zip(&self.v) {
            *x += *v * h;
        }
        st.response_time += (t1 - t0).as_secs_f64() + t2.elapsed().as_secs_f64();

        if self.opts.self_collision {
            self.correct(&x0, &mut st)?;
        }
        self.time += h;
        self.steps += 1;
        st.step_time = t_step.elapsed().as_secs_f64();
        Ok(st)
    }

    /// Runs the detector at the current positions, adding its time to `st`.
    fn timed_detect(&mut self, st: &mut StepStats) -> Result<Detection> {
        let t0 = Instant::now();
        let det = self.detector.detect(&self.x)?;
        st.detect_time += t0.elapsed().as_secs_f64();
        st.detection = det.stats.clone();
        Ok(det)
    }

    /// The correction stage; leaves the method's detection at the final positions pending.
    fn correct(&mut self, x0: &[DVec3], st: &mut StepStats) -> Result<()> {
        let t0 = Instant::now();
        let checker: &mut dyn Detector = match self.guard.as_mut() {
            Some(g) => g.as_mut(),
            None => self.detector.as_mut(),
        };
        let start = StepStart { x0, mass: self.cloth.masses(), pinned: self.cloth.pinned(), h: self.opts.dt };
        let c = response::correct(checker, &start, &mut self.x, &mut self.v)?;
        st.response_time += t0.elapsed().as_secs_f64() - c.detect_time;
        st.detect_time += c.detect_time;
        (st.reverted, st.zones) = (c.zone_vertices, c.zones);
        (st.correction_rounds, st.intersections) = (c.rounds, c.remaining);
        let det = if self.guard.is_some() {
            self.timed_detect(st)?
        } else {
            c.detection
        };
        st.detection = det.stats.clone();
        self.pending = Some(det);
        Ok(())
    }
}
