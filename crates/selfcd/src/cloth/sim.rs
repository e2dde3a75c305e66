//! `Simulation`: a cloth, its state, obstacles and collision queries, stepped in time.
//!
//! Data flows one way through a step of length h, and the step alone runs
//! (and times) the queries, all on one self-collision hierarchy
//! ([`SelfQueries`]: static boxes for proximity and intersections, swept
//! boxes for continuous queries, and a candidate set of element pairs reused
//! across steps wherever the cloth's motion is coherent: elements whose
//! vertices moved alike keep their candidates however far they travelled):
//! 1. proximity at the current positions: self within `d + margin` and
//!    cloth-obstacle (the obstacles at the start of the step);
//! 2. assemble and solve the backward Euler system with the filter: pins fixed,
//!    vertex-triangle contacts inside `d` constrained along their normal;
//! 3. `v += dv`, contact impulses with friction;
//! 4. continuous stage: continuous queries (self, and cloth against the
//!    obstacles moving over the step) and inelastic impulses, repeated (a
//!    repeated self query re-tests only the triangles of the vertices the
//!    impulses moved);
//! 5. `x += h v`;
//! 6. correction: a conservative intersection check (self, and cloth against
//!    the obstacles at the end of the step) and impact zones, repeated until
//!    no intersecting triangle pair is left; the first self check is skipped
//!    when the last continuous query proved the step clear
//!    ([`StepStats::proved_clear`]). Self-intersections the state
//!    already had at the start of the step (an input may come with some) are
//!    left alone and still counted in [`StepStats::intersections`]; a state
//!    free of them stays free.
//!
//! The queries own the hierarchies; the simulation owns positions and
//! velocities and hands the queries positions. The detection method decides
//! the culling of the intersection checks: boxes only for `bvh`, the
//! conservative cones and contours of `bvh-cones-contour` otherwise (the
//! correction needs a conservative check, so the paper's `bvh-cones` and the
//! sensor gate are not used for it).

use super::model::{Cloth, Energy};
use super::obstacle::{Collider, Obstacles};
use super::response::{self, Contact, ContactParams, StepStart, Zones};
use super::solver::{Filter, Pcg, PcgOptions, Preconditioner, System};
use crate::bvh::{build::build, Bvh};
use crate::detect::coherent::SelfQueries;
use crate::detect::Method;
use crate::error::{Error, Result};
use crate::geom::ccd::StencilKind;
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
            pcg: PcgOptions {
                preconditioner: Preconditioner::for_vertices(cloth.mesh().n_vertices()),
                ..PcgOptions::default()
            },
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
const CONTINUOUS_THICKNESS: f64 = 0.5;
/// Most continuous queries per step.
const CONTINUOUS_ROUNDS: u32 = 4;
/// Most correction rounds per step.
const CORRECTION_ROUNDS: u32 = 64;

/// What one step did and cost. Times are wall-clock seconds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepStats {
    /// Conjugate-gradient iterations.
    pub iterations: u32,
    /// Final relative residual of the solve.
    pub residual: f64,
    /// Work of the step's self queries (proximity, continuous, intersections), summed.
    pub detection: FrameStats,
    /// Proximity contacts responded to this step (vertex-triangle + edge-edge, self and obstacle).
    pub contacts: usize,
    /// Of which vertex-triangle.
    pub vertex_triangle: usize,
    /// Of which cloth-obstacle.
    pub obstacle_contacts: usize,
    /// Contact constraints put in the solve's filter.
    pub constrained: usize,
    /// Contact impulses applied.
    pub impulses: u64,
    /// Continuous queries run by the continuous stage.
    pub ccd_rounds: u32,
    /// Element pairs the continuous stage found meeting during the step (all rounds).
    pub ccd_impacts: u64,
    /// Vertices whose end-of-step motion the correction stage replaced by the
    /// rigid motion of their impact zone, froze, or bound to an obstacle.
    pub reverted: usize,
    /// Impact zones formed by the correction stage.
    pub zones: usize,
    /// Intersection checks run by the correction stage.
    pub correction_rounds: u32,
    /// The step started free of self-intersections and the continuous stage's
    /// last self query, at the final velocities, found no element pair coming
    /// within its thickness: then the step creates no self-intersection, and
    /// the correction's first self check is skipped. Why: two triangles
    /// sharing no vertex are disjoint at the start; while they stay
    /// disjoint, their distance is the least of their vertex-triangle and
    /// edge-edge distances (none of which share a vertex), and it changes
    /// continuously, so before they could meet one of those pairs would come
    /// within the thickness, which the query (conservative: no false
    /// negatives) would have reported. The end positions are exactly that
    /// query's `x0 + h v`.
    pub proved_clear: bool,
    /// Intersecting triangle pairs left at the end of the step, self and
    /// cloth-obstacle (0 unless it started with some).
    pub intersections: usize,
    /// Of which cloth-obstacle.
    pub obstacle_intersections: usize,
    /// Assembly and solve time.
    pub solve_time: f64,
    /// Self-collision query time (proximity, continuous and intersection checks).
    pub detect_time: f64,
    /// Of which the proximity query.
    pub proximity_time: f64,
    /// Of which the continuous queries.
    pub continuous_time: f64,
    /// Cloth-obstacle query time (the same three).
    pub obstacle_time: f64,
    /// Contact response time (everything else the step does).
    pub response_time: f64,
    /// The whole step.
    pub step_time: f64,
}

/// Runs `f`, adding its wall-clock time to `*acc`.
fn timed<T>(acc: &mut f64, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let out = f();
    *acc += t0.elapsed().as_secs_f64();
    out
}

/// A cloth in motion: state, obstacles, solver and collision queries.
pub struct Simulation {
    cloth: Cloth,
    opts: SimOptions,
    x: Vec<DVec3>,
    v: Vec<DVec3>,
    dv: Vec<DVec3>,
    inv_mass: Vec<f64>,
    /// The detection method (culling of the intersection checks).
    method: Method,
    /// Self queries: one hierarchy, one candidate set.
    queries: SelfQueries,
    /// Self-intersecting pairs of the current state (sorted): the correction
    /// leaves these alone (an input may start with some), and removes any other.
    tolerated: Vec<[u32; 2]>,
    /// Obstacles, with the cloth hierarchy their queries traverse.
    obstacles: Option<(Obstacles, Bvh)>,
    system: System,
    pcg: Pcg,
    time: f64,
    steps: u64,
}

impl Simulation {
    /// A simulation of `cloth` at rest in its rest shape, detecting self-contact
    /// with `method`, without obstacles.
    pub fn new(cloth: Cloth, method: Method, opts: SimOptions) -> Result<Simulation> {
        opts.validate()?;
        let mesh = cloth.mesh().clone();
        let mut queries = SelfQueries::new(mesh.clone(), SelfQueries::default_skin(&mesh))?;
        let tolerated = queries.intersections(
            mesh.rest(),
            method != Method::Bvh,
            &mut FrameStats::default(),
        )?;
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
            method,
            queries,
            tolerated,
            obstacles: None,
            time: 0.0,
            steps: 0,
        })
    }

    /// Sets the obstacles the cloth collides with (`None`: no obstacle). They
    /// are played from the simulation's current time onwards, from their time 0.
    pub fn set_obstacles(&mut self, obstacles: Option<Obstacles>) {
        self.obstacles = obstacles.map(|o| (o, build(self.cloth.mesh())));
    }

    /// The obstacles, if any.
    pub fn obstacles(&self) -> Option<&Obstacles> {
        self.obstacles.as_ref().map(|(o, _)| o)
    }

    /// Obstacle positions (merged mesh) at the current time, empty without obstacles.
    pub fn obstacle_positions(&self) -> Vec<DVec3> {
        self.obstacles()
            .map_or_else(Vec::new, |o| o.positions_at(self.time))
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
        self.tolerated =
            self.queries
                .intersections(&x, self.cones(), &mut FrameStats::default())?;
        (self.x, self.v) = (x, v);
        self.dv.iter_mut().for_each(|d| *d = DVec3::ZERO);
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
        self.method
    }

    /// Whether the intersection checks cull with cones and contours.
    fn cones(&self) -> bool {
        self.method != Method::Bvh
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

    /// Advances the simulation by one time step (see the module doc).
    ///
    /// The step runs on a thread of rayon's pool. Called from outside it,
    /// every parallel loop is handed to the pool while the caller sleeps until
    /// it is done, and a step runs hundreds of short loops (three per
    /// conjugate-gradient iteration): on the 20k centre scene that cost a
    /// third of the solve. Results do not depend on it (fixed partitions).
    pub fn step(&mut self) -> Result<StepStats> {
        rayon::scope(|_| self.step_in_pool())
    }

    fn step_in_pool(&mut self) -> Result<StepStats> {
        let t_step = Instant::now();
        let (h, n) = (self.opts.dt, self.x.len());
        let contact = self.opts.contact;
        let mut st = StepStats::default();
        // Combined state: the cloth's vertices, then the obstacles' (inverse mass 0).
        let (o0, o1) = match &self.obstacles {
            Some((o, _)) => (o.positions_at(self.time), o.positions_at(self.time + h)),
            None => (Vec::new(), Vec::new()),
        };
        let x0: Vec<DVec3> = self.x.iter().chain(&o0).copied().collect();
        let obstacle_v: Vec<DVec3> = o0.iter().zip(&o1).map(|(a, b)| (*b - *a) / h).collect();
        let inv_mass: Vec<f64> = self
            .inv_mass
            .iter()
            .copied()
            .chain(o0.iter().map(|_| 0.0))
            .collect();

        // 1. One detection pass at the start positions.
        let mut contacts = Vec::new();
        let mut det = FrameStats::default();
        if self.opts.self_collision {
            let reach = contact.detection_distance();
            let near = timed(&mut st.proximity_time, || {
                self.queries.proximity(&self.x, reach, &mut det)
            })?;
            contacts = response::gather(self.cloth.mesh(), &self.x, &near);
        }
        if let Some((obs, bvh)) = self.obstacles.as_mut() {
            let mut c = Collider::new(self.cloth.mesh(), bvh, obs);
            let near = timed(&mut st.obstacle_time, || {
                c.proximity(&x0, contact.detection_distance())
            });
            let found = response::cross_contacts(c.meshes, &x0, &near);
            st.obstacle_contacts = found.len();
            contacts.extend(found);
        }
        st.contacts = contacts.len();
        st.vertex_triangle = contacts
            .iter()
            .filter(|c| c.kind == StencilKind::VertexTriangle)
            .count();

        // 2. Solve, with vertex-triangle contacts in the filter.
        let mut v: Vec<DVec3> = self.v.iter().chain(&obstacle_v).copied().collect();
        let mut filter = Filter::new(self.cloth.pinned());
        let dv_prev: Vec<DVec3> = self
            .dv
            .iter()
            .copied()
            .chain(o0.iter().map(|_| DVec3::ZERO))
            .collect();
        st.constrained = response::constrain(&contacts, &v, &dv_prev, &contact, h, &mut filter);
        let pcg = timed(&mut st.solve_time, || {
            self.system.assemble(&self.cloth, &self.x, &self.v, h);
            self.pcg.solve(
                &self.system.a,
                &self.system.b,
                &filter,
                &mut self.dv,
                self.opts.pcg,
            )
        });
        (st.iterations, st.residual) = (pcg.iterations, pcg.residual);

        // 3. Velocities and contact impulses.
        for (v, dv) in v.iter_mut().zip(&self.dv) {
            *v += *dv;
        }
        let mu = |c: &Contact| {
            if c.verts.iter().any(|&k| k as usize >= n) {
                contact.obstacle_friction
            } else {
                contact.friction
            }
        };
        st.impulses = response::impulses(&contacts, &inv_mass, &mut v, &contact, h, mu).impulses;

        // 4. Continuous stage.
        let thickness = CONTINUOUS_THICKNESS * contact.thickness;
        let mut x1 = x0.clone();
        // The last self query found nothing at the final velocities (see `correct`).
        let mut clear = false;
        while st.ccd_rounds < CONTINUOUS_ROUNDS {
            for ((e, a), b) in x1.iter_mut().zip(&x0).zip(&v) {
                *e = *a + *b * h;
            }
            st.ccd_rounds += 1;
            let mut hits = Vec::new();
            if self.opts.self_collision {
                let (c0, c1) = (&x0[..n], &x1[..n]);
                let found = timed(&mut st.continuous_time, || {
                    self.queries.continuous(c0, c1, thickness, &mut det)
                })?;
                hits = response::impact_contacts(self.cloth.mesh(), c0, c1, &found);
                clear = hits.is_empty();
            }
            if let Some((obs, bvh)) = self.obstacles.as_mut() {
                let mut c = Collider::new(self.cloth.mesh(), bvh, obs);
                let found = timed(&mut st.obstacle_time, || c.continuous(&x0, &x1, thickness));
                hits.extend(response::cross_impact_contacts(c.meshes, &x0, &x1, &found));
            }
            st.ccd_impacts += hits.len() as u64;
            let applied = response::impact_impulses(&hits, &inv_mass, &mut v, mu).impulses;
            st.impulses += applied;
            if applied == 0 {
                break;
            }
            clear = false;
        }

        // 5. Positions.
        v.truncate(n);
        self.v = v;
        for (x, v) in self.x.iter_mut().zip(&self.v) {
            *x += *v * h;
        }

        // 6. Correction.
        st.detect_time = st.proximity_time + st.continuous_time;
        st.proved_clear = clear && self.tolerated.is_empty();
        self.correct(&x0[..n], &o0, &o1, &mut st, &mut det)?;
        st.detection = det;
        self.time += h;
        self.steps += 1;
        st.step_time = t_step.elapsed().as_secs_f64();
        st.response_time = st.step_time - st.solve_time - st.detect_time - st.obstacle_time;
        Ok(st)
    }

    /// The correction stage: intersection checks at the end positions
    /// (obstacles at `o1`) and impact zones from the start positions `x0`.
    fn correct(
        &mut self,
        x0: &[DVec3],
        o0: &[DVec3],
        o1: &[DVec3],
        st: &mut StepStats,
        det: &mut FrameStats,
    ) -> Result<()> {
        let n = x0.len();
        let start = StepStart {
            x0,
            mass: self.cloth.masses(),
            pinned: self.cloth.pinned(),
            h: self.opts.dt,
        };
        let mut zones = Zones::new(self.cloth.pinned());
        let v_in = self.v.clone();
        let mut combined: Vec<DVec3> = self.x.iter().chain(o1).copied().collect();
        // The last check's answer and the vertices the zones moved since:
        // a later check tests again only the triangles at those vertices.
        let (mut last, mut moved): (Option<Vec<[u32; 2]>>, Vec<u32>) = (None, Vec::new());
        loop {
            st.correction_rounds += 1;
            let cones = self.cones();
            // A proved-clear step skips its first self check (see `proved_clear`).
            let proved = st.proved_clear && st.correction_rounds == 1;
            let all = if self.opts.self_collision && !proved {
                timed(&mut st.detect_time, || match &last {
                    Some(last) => self
                        .queries
                        .intersections_after_moving(&self.x, &moved, last, det),
                    None => self.queries.intersections(&self.x, cones, det),
                })?
            } else {
                Vec::new()
            };
            let pairs: Vec<[u32; 2]> = all
                .iter()
                .copied()
                .filter(|p| self.tolerated.binary_search(p).is_err())
                .collect();
            let mut hits = Vec::new();
            if let Some((obs, bvh)) = self.obstacles.as_mut() {
                combined[..n].copy_from_slice(&self.x);
                let mut c = Collider::new(self.cloth.mesh(), bvh, obs);
                hits = timed(&mut st.obstacle_time, || c.intersections(&combined));
            }
            let mesh = self.cloth.mesh();
            // A cloth vertex meeting an obstacle follows the obstacle triangle's mean motion.
            let motion = |t: u32| {
                let tri = obstacle_triangle(self.obstacles.as_ref(), t);
                tri.iter()
                    .map(|&i| o1[i as usize] - o0[i as usize])
                    .sum::<DVec3>()
                    / 3.0
            };
            let mut changed = zones.bind(mesh, hits.iter().map(|h| h[0]), |i| {
                hits.iter()
                    .find(|h| mesh.triangles()[h[0] as usize].contains(&(i as u32)))
                    .map_or(DVec3::ZERO, |h| motion(h[1]))
            });
            changed |= !pairs.is_empty() && zones.absorb(mesh, &pairs);
            if !changed || st.correction_rounds >= CORRECTION_ROUNDS {
                (st.intersections, st.obstacle_intersections) =
                    (all.len() + hits.len(), hits.len());
                (st.reverted, st.zones) = (zones.members(), zones.count());
                self.tolerated = all;
                return Ok(());
            }
            moved = zones.move_rigidly(&start, &v_in, &mut self.x, &mut self.v);
            // (Only a check that ran: a proved-clear step's first is skipped.)
            last = (!proved).then_some(all);
        }
    }
}

/// Corners of triangle `t` of the merged obstacle mesh.
fn obstacle_triangle(obstacles: Option<&(Obstacles, Bvh)>, t: u32) -> [u32; 3] {
    obstacles.map_or([0; 3], |(o, _)| o.mesh().triangles()[t as usize])
}
