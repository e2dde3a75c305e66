//! The paper's method, `sensor-gated`: relax the particle sensor, and refit
//! and traverse the BVH only on frames where the sensor triggers (or refit
//! every frame, with `SensorParams::refit_every_frame`). Not conservative: on
//! frames the sensor does not trigger, contacts are not looked for.
//! [`super::compare::compare_methods`] counts what it misses.
//!
//! The particle count follows the convex parts of the current shape
//! ([`crate::sensor::parts`]): on every triggered frame, on a frame where the
//! shape moved since the last count (a distance between the particles'
//! surface points of that count shrank by more than the trigger tolerance,
//! or their normals turned by about 30 degrees), and every [`RECOUNT`]
//! frames, the parts are counted from sampled cones ([`PartTree`]: no refit;
//! [`crate::sensor::parts::SAMPLES`] triangles read per coarse leaf); when the
//! count (clamped to [`count`, [`max_particles`]]) differs from the
//! particles', [`Sensor::follow_parts`] adds particles where parts appeared
//! and merges them where parts vanished. Otherwise the particles persist as
//! they are. A frame's relaxation spends at most triangles / [`PAIR_BUDGET`]
//! pair terms (at least [`MIN_PAIR_BUDGET`]; [`Sensor::set_pair_budget`]), so
//! many particles make fewer updates per frame.

use super::hierarchy::BvhDetector;
use super::{Detection, Detector, Method};
use crate::error::Result;
use crate::mesh::Mesh;
use crate::sensor::parts::PartTree;
use crate::sensor::{Relaxation, Sensor, SensorParams, SurfacePoint};
use crate::stats::FrameStats;
use glam::DVec3;
use std::sync::Arc;
use std::time::Instant;

/// Most frames between two part counts. A moving shape is recounted when it
/// moved (see the module documentation), so the period only bounds how long a
/// change that the probes cannot see (within a part, between particles) goes
/// uncounted.
pub const RECOUNT: u64 = 64;

/// The shape seen at the last part count: the particles' surface points then,
/// and, for chain pairs of them (each point with the next and with the one half
/// the list away), their distance and the cosine between their triangles'
/// normals. A rigid motion changes neither; a fold, roll or crumple that
/// changes the parts bends the surface between some pair (the cosine moves) or
/// brings it closer (the distance shrinks). O(particles) per frame.
#[derive(Debug, Clone, Default)]
struct Probes {
    points: Vec<SurfacePoint>,
    /// (distance, cosine) of every chain pair at the last count.
    then: Vec<(f64, f64)>,
}

/// A probe pair's normals turned by more than this (cosine change: about 30
/// degrees from parallel) since the last count: the parts may have changed.
const TURN: f64 = 0.134;

impl Probes {
    /// Probes at the particles `points` in the shape `positions`.
    fn new(mesh: &Mesh, points: &[SurfacePoint], positions: &[DVec3]) -> Probes {
        let mut probes = Probes {
            points: points.to_vec(),
            then: Vec::new(),
        };
        probes.then = probes.pairs(mesh, positions).collect();
        probes
    }

    /// (distance, normal cosine) of the chain pairs in the shape `positions`.
    fn pairs<'a>(
        &'a self,
        mesh: &'a Mesh,
        positions: &'a [DVec3],
    ) -> impl Iterator<Item = (f64, f64)> + 'a {
        let k = self.points.len();
        let at = move |i: usize| {
            let p = &self.points[i % k];
            let [a, b, c] = mesh.corners(positions, p.tri as usize);
            (
                p.position(mesh, positions),
                (b - a).cross(c - a).normalize_or_zero(),
            )
        };
        (0..k).flat_map(move |i| {
            let (p, n) = at(i);
            [i + 1, i + k / 2].map(|j| {
                let (q, m) = at(j);
                (p.distance(q), n.dot(m))
            })
        })
    }

    /// True when a chain pair came closer by more than `limit`, or its
    /// normals turned by more than [`TURN`], since the probes were made. A
    /// pair that only parted is not counted: the parts follow the normals,
    /// and a stretch that does not turn them (a twist's pull on the sheet's
    /// edges) leaves them; a fold or roll brings pairs closer or turns them.
    fn moved(&self, mesh: &Mesh, positions: &[DVec3], limit: f64) -> bool {
        self.pairs(mesh, positions)
            .zip(&self.then)
            .any(|((d, c), &(d0, c0))| !(d0 - d <= limit && (c - c0).abs() <= TURN))
    }
}

/// Pair terms one frame's relaxation may spend: triangles / this
/// ([`Sensor::set_pair_budget`]). The same share as [`max_particles`]: at the
/// most particles a frame makes one update, with fewer it makes more (up to N_max).
pub const PAIR_BUDGET: usize = 4;

/// Least pair budget of a frame: 8 updates (N_max) of 11 particles. On a
/// small mesh (under 4,096 triangles) the relaxation is cheap in absolute
/// terms, and its particles, few for the mesh, need their updates to follow a
/// fold (the sphere's crumple misses 209 contacts at n / 4).
pub const MIN_PAIR_BUDGET: usize = 1024;

/// Most particles on a mesh of `triangles` triangles: sqrt(triangles / 4).
/// One relaxation update costs k^2 pair terms and a quiet frame of the exact
/// method at least a refit of its 2 n - 1 nodes, so k^2 <= n / 4 keeps one
/// update to a fraction of the exact method at any size (measured in
/// BENCHMARKS.md); the count is still clamped to [`count`, `max_count`].
pub fn max_particles(triangles: usize) -> usize {
    ((triangles as f64 / 4.0).sqrt()) as usize
}

/// Coarse leaves of the part count per particle at most: the count resolves
/// parts of about triangles / (this x [`max_particles`]) triangles, finer
/// than the most particles it can ask for.
pub const LEAVES_PER_PARTICLE: usize = 8;

/// Triangles per coarse leaf of the part count on a mesh of `triangles`
/// triangles with at most `most` particles (see [`LEAVES_PER_PARTICLE`]).
pub fn part_leaf_size(triangles: usize, most: usize) -> usize {
    (triangles / (LEAVES_PER_PARTICLE * most.max(1))).max(1)
}

/// Particle sensor in front of a BVH detector (`params.inner`).
pub struct SensorGatedDetector {
    bvh: BvhDetector,
    sensor: Sensor,
    /// The sampled cones that count the parts.
    parts: PartTree,
    particles: Vec<DVec3>,
    refit_every_frame: bool,
    /// Particle count bounds: [`SensorParams::count`], [`SensorParams::max_count`].
    bounds: (usize, usize),
    /// Frames detected so far.
    frame: u64,
    /// Frame of the last part count.
    counted: u64,
    /// The shape at the last part count.
    probes: Probes,
}

impl SensorGatedDetector {
    /// Builds the BVH and places the particles; any mesh (curved rest shape,
    /// several components, one triangle). Errors: invalid parameters.
    /// The particle count is the rest shape's number of convex parts
    /// ([`crate::sensor::parts`]), clamped to [`count`, [`max_particles`]]
    /// (itself within [`count`, `max_count`]).
    pub fn new(mesh: Arc<Mesh>, thickness: f64, params: &SensorParams) -> Result<Self> {
        params.validate()?;
        // In the mesh's order: the parts below are read off its hierarchy
        // with the mesh's triangle ids.
        let bvh = BvhDetector::in_mesh_order(mesh.clone(), params.inner, thickness);
        let bounds = (
            params.count,
            max_particles(mesh.n_triangles()).clamp(params.count, params.max_count),
        );
        let mut parts = PartTree::new(bvh.bvh(), part_leaf_size(mesh.n_triangles(), bounds.1));
        let params = SensorParams {
            count: parts
                .fit(&mesh, mesh.rest())
                .len()
                .clamp(bounds.0, bounds.1),
            max_count: bounds.1,
            ..params.clone()
        };
        let mut sensor = Sensor::new(mesh.clone(), params.clone())?;
        sensor.set_margin(thickness);
        sensor.set_pair_budget((mesh.n_triangles() / PAIR_BUDGET).max(MIN_PAIR_BUDGET));
        let particles = sensor.positions(mesh.rest());
        Ok(SensorGatedDetector {
            bvh,
            sensor,
            parts,
            particles,
            refit_every_frame: params.refit_every_frame,
            bounds,
            frame: 0,
            counted: 0,
            probes: Probes::default(),
        })
    }

    /// The sensor, as left by the last frame.
    pub fn sensor(&self) -> &Sensor {
        &self.sensor
    }

    /// Counts the parts of `positions` and follows them. The labelling (over
    /// the samples) runs only when the count asks for particles to be added or merged.
    fn follow_parts(&mut self, positions: &[DVec3]) {
        self.counted = self.frame;
        let mesh = self.bvh.mesh();
        let nodes = self.parts.fit(mesh, positions);
        let target = nodes.len().clamp(self.bounds.0, self.bounds.1);
        if target != self.sensor.points().len() {
            let parts = self
                .parts
                .parts(&nodes, mesh, positions, self.sensor.points());
            self.sensor.follow_parts(&parts, target);
        }
        self.probes = Probes::new(self.bvh.mesh(), self.sensor.points(), positions);
    }

    /// True when the parts are due for a count before this frame's relaxation:
    /// the first frame, [`RECOUNT`] frames after the last count, or the shape
    /// moved by more than the trigger tolerance since then.
    fn recount_due(&self, positions: &[DVec3]) -> bool {
        self.frame == 0
            || self.frame - self.counted >= RECOUNT
            || self.probes.moved(
                self.bvh.mesh(),
                positions,
                self.sensor.params().tolerance * self.sensor.unit(),
            )
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
        let recount = self.recount_due(positions);
        let refitted = self.refit_every_frame;
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
                // Follow the parts of this shape for the next frame.
                let t0 = Instant::now();
                self.follow_parts(positions);
                sensor_time += t0.elapsed().as_secs_f64();
            }
            det
        } else {
            Detection::default()
        };
        self.particles = self.sensor.positions(positions);
        self.frame += 1;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{grid, Deformation};
    use glam::DQuat;

    /// The gate refuses what `Mesh::check_positions` refuses, with its error:
    /// an infinite or NaN coordinate anywhere, or a wrong vertex count.
    #[test]
    fn the_gate_refuses_non_finite_positions() {
        let (v, f) = grid(11, 1.0);
        let mesh = Arc::new(Mesh::new(v, f).unwrap());
        let mut gate =
            SensorGatedDetector::new(mesh.clone(), 0.01, &SensorParams::default()).unwrap();
        assert!(gate.detect(mesh.rest()).is_ok());
        for bad in [f64::INFINITY, f64::NEG_INFINITY, f64::NAN, f64::MAX * 2.0] {
            for (vertex, axis) in [(0, 0), (57, 1), (120, 2)] {
                let mut p = mesh.rest().to_vec();
                p[vertex][axis] = bad;
                let err = gate.detect(&p).unwrap_err();
                assert!(
                    matches!(err, crate::error::Error::NonFinite { vertex: v, .. } if v == vertex),
                    "{err}"
                );
            }
        }
        let short = &mesh.rest()[1..];
        assert!(gate.detect(short).is_err());
    }

    #[test]
    fn probes_ignore_rigid_motion_and_see_a_fold() {
        let (v, f) = grid(21, 1.0);
        let mesh = Mesh::new(v, f).unwrap();
        let points: Vec<SurfacePoint> = [0, 77, 400, 799]
            .into_iter()
            .map(SurfacePoint::centroid)
            .collect();
        let probes = Probes::new(&mesh, &points, mesh.rest());
        let limit = 3.0 * mesh.mean_edge_length();
        let turn = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 1.0);
        let rigid: Vec<DVec3> = mesh
            .rest()
            .iter()
            .map(|&p| turn * p + DVec3::new(5.0, -2.0, 7.0))
            .collect();
        assert!(!probes.moved(&mesh, mesh.rest(), limit));
        assert!(!probes.moved(&mesh, &rigid, limit));
        // An in-plane stretch parts every pair and turns no normal; a shrink
        // brings them closer.
        for (scale, moved) in [(1.5, false), (0.5, true)] {
            let scaled: Vec<DVec3> = mesh.rest().iter().map(|&p| p * scale).collect();
            assert_eq!(probes.moved(&mesh, &scaled, limit), moved, "scale {scale}");
        }
        for (angle, moved) in [(0.1, false), (2.0, true)] {
            let folded = Deformation::Fold {
                angle,
                radius: 0.05,
            }
            .apply(mesh.rest());
            assert_eq!(probes.moved(&mesh, &folded, limit), moved, "fold {angle}");
        }
    }
}
