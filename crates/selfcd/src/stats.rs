//! Per-frame counters: what each detector spent and found.

/// What one detection call cost and found. Times are wall-clock seconds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameStats {
    /// Time to refit boxes and cones (s).
    pub refit_time: f64,
    /// Time spent in the self-traversal and narrow phase (s).
    pub traverse_time: f64,
    /// Time spent relaxing the particle sensor (s); zero for other methods.
    pub sensor_time: f64,
    /// Node pairs whose boxes were compared.
    pub node_pairs: u64,
    /// Nodes whose self-test was skipped by the cone (and contour) test.
    pub self_culls: u64,
    /// Adjacent node pairs skipped by the merged cone (and contour) test.
    pub pair_culls: u64,
    /// Contour tests run (self and pair).
    pub contour_tests: u64,
    /// Contour tests that failed, so the node or pair was descended into.
    pub contour_fails: u64,
    /// Culls decided by a contour certificate kept from an earlier frame
    /// (reused work; not in `contour_tests`, which counts fresh tests).
    pub certificates_reused: u64,
    /// Culls decided by a kept certificate whose slack the motion exceeded,
    /// re-checked exactly on its contour's close edge pairs (cheaper than a
    /// fresh test; not in `contour_tests`).
    pub certificates_rechecked: u64,
    /// Node pairs with overlapping boxes found apart along a node's cone
    /// axis ([`crate::geom::Slab`]; only when the detector fits slabs).
    pub slab_culls: u64,
    /// Leaf pairs skipped because the triangles share a vertex.
    pub adjacent_skips: u64,
    /// Traversal jobs started from the front kept from an earlier frame
    /// (reused work: the descent from the root down to them was skipped;
    /// [`crate::bvh::traverse::Front`]); 0 when the traversal began at the root.
    pub front_jobs: u64,
    /// Of those, the jobs skipped: what they hold was far enough apart for
    /// the vertices' displacement since ([`crate::bvh::traverse::Front`],
    /// "Clearance"), so they stop where they did and find nothing (reused work).
    pub front_skips: u64,
    /// Triangle-triangle tests run: the paper's polygon-polygon checks.
    pub primitive_tests: u64,
    /// Of those, the pairs the floating-point filter proved apart without the
    /// exact predicates (the rest ran the exact test); in continuous
    /// queries, the triangle pairs a separating axis (or, for two with one
    /// common vertex, a plane through it) kept apart over the step without
    /// element tests.
    pub filter_decisions: u64,
    /// Leaf pairs given the proximity test (thickness > 0; its node pairs are in `node_pairs`).
    pub proximity_tests: u64,
    /// Intersecting triangle pairs found.
    pub contacts: u64,
    /// Proximity contacts (vertex-triangle + edge-edge) found, when thickness > 0.
    pub proximity_contacts: u64,
    /// Coherent queries: candidate sets built by a traversal (fresh work).
    pub candidate_builds: u64,
    /// Coherent queries: queries answered from a cached candidate set (reused work).
    pub candidate_reuses: u64,
    /// Coherent queries: proximity queries answered one-shot, without the
    /// candidate set, after sets went stale young (fresh work;
    /// [`crate::detect::coherent`], "Sets that die young").
    pub proximity_one_shots: u64,
    /// Coherent queries: cached candidate element pairs examined (those near
    /// enough to come within the query's distance, and every pair within the
    /// set's own reach).
    pub candidates: u64,
    /// Coherent queries: continuous queries that repeated the last one with a
    /// few end positions changed, answered by re-testing only the triangles
    /// touching those (reused work).
    pub continuous_repeats: u64,
    /// Coherent queries: continuous queries answered from the last
    /// proximity query's answer, taken at their start, and the traversal of
    /// the pairs the step's motion may have brought in (reused work).
    pub continuous_from_proximity: u64,
    /// Sensor-gated only: did the sensor trigger the traversal this frame.
    pub triggered: Option<bool>,
    /// Sensor-gated only: particle updates made while relaxing.
    pub relax_steps: u32,
    /// Sensor-gated only: particles that moved more than epsilon in the last update.
    pub moving_particles: u32,
    /// Sensor-gated only: straight-line distance of the closest particle pair (mean-edge units).
    pub closest_sl: f64,
    /// Sensor-gated only: original (surface) distance of that pair (mean-edge units).
    pub closest_odl: f64,
}

impl FrameStats {
    /// Total detection time of the frame (s).
    pub fn total_time(&self) -> f64 {
        self.refit_time + self.traverse_time + self.sensor_time
    }
}

/// Traversal counters, summed over parallel tasks (sums do not depend on scheduling).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// See [`FrameStats::node_pairs`].
    pub node_pairs: u64,
    /// See [`FrameStats::self_culls`].
    pub self_culls: u64,
    /// See [`FrameStats::pair_culls`].
    pub pair_culls: u64,
    /// See [`FrameStats::contour_tests`].
    pub contour_tests: u64,
    /// See [`FrameStats::contour_fails`].
    pub contour_fails: u64,
    /// See [`FrameStats::certificates_reused`].
    pub certificates_reused: u64,
    /// See [`FrameStats::certificates_rechecked`].
    pub certificates_rechecked: u64,
    /// See [`FrameStats::slab_culls`].
    pub slab_culls: u64,
    /// See [`FrameStats::adjacent_skips`].
    pub adjacent_skips: u64,
    /// See [`FrameStats::front_jobs`].
    pub front_jobs: u64,
    /// See [`FrameStats::front_skips`].
    pub front_skips: u64,
    /// See [`FrameStats::primitive_tests`].
    pub primitive_tests: u64,
    /// See [`FrameStats::filter_decisions`].
    pub filter_decisions: u64,
}

impl Counters {
    /// Adds another task's counters.
    pub fn add(&mut self, o: &Counters) {
        self.node_pairs += o.node_pairs;
        self.self_culls += o.self_culls;
        self.pair_culls += o.pair_culls;
        self.contour_tests += o.contour_tests;
        self.contour_fails += o.contour_fails;
        self.certificates_reused += o.certificates_reused;
        self.certificates_rechecked += o.certificates_rechecked;
        self.slab_culls += o.slab_culls;
        self.adjacent_skips += o.adjacent_skips;
        self.front_jobs += o.front_jobs;
        self.front_skips += o.front_skips;
        self.primitive_tests += o.primitive_tests;
        self.filter_decisions += o.filter_decisions;
    }

    /// Adds the counters to a frame's stats (several traversals in one frame).
    pub fn add_to(&self, s: &mut FrameStats) {
        s.node_pairs += self.node_pairs;
        s.self_culls += self.self_culls;
        s.pair_culls += self.pair_culls;
        s.contour_tests += self.contour_tests;
        s.contour_fails += self.contour_fails;
        s.certificates_reused += self.certificates_reused;
        s.certificates_rechecked += self.certificates_rechecked;
        s.slab_culls += self.slab_culls;
        s.adjacent_skips += self.adjacent_skips;
        s.front_jobs += self.front_jobs;
        s.front_skips += self.front_skips;
        s.primitive_tests += self.primitive_tests;
        s.filter_decisions += self.filter_decisions;
    }

    /// Copies the counters into a frame's stats.
    pub fn write_to(&self, s: &mut FrameStats) {
        s.node_pairs = self.node_pairs;
        s.self_culls = self.self_culls;
        s.pair_culls = self.pair_culls;
        s.contour_tests = self.contour_tests;
        s.contour_fails = self.contour_fails;
        s.certificates_reused = self.certificates_reused;
        s.certificates_rechecked = self.certificates_rechecked;
        s.slab_culls = self.slab_culls;
        s.adjacent_skips = self.adjacent_skips;
        s.front_jobs = self.front_jobs;
        s.front_skips = self.front_skips;
        s.primitive_tests = self.primitive_tests;
        s.filter_decisions = self.filter_decisions;
    }
}
