//! Detectors: one trait, several methods, each reusable frame after frame.
//!
//! | method              | broad phase                         | conservative |
//! |---------------------|-------------------------------------|--------------|
//! | `brute`             | every pair (exact reference)        | yes          |
//! | `bvh`               | BVH boxes                           | yes          |
//! | `bvh-cones`         | BVH + normal cones (the paper)      | no: misses counted in tests |
//! | `bvh-cones-contour` | BVH + cones + star contour test     | yes (default) |
//! | `sensor-gated`      | particle sensor, then a BVH method  | no: misses counted by `compare` |
//!
//! Proximity (thickness > 0) and continuous queries ([`continuous`]) use the
//! same hierarchy with boxes only. [`coherent`] serves a sequence of frames
//! (the simulator): one hierarchy for all three queries, and a candidate set
//! reused while nothing moved far enough to change the answers.

pub mod brute;
pub mod coherent;
pub mod compare;
pub mod continuous;
pub mod first;
pub mod hierarchy;
pub mod narrow;
pub mod obstacle;
pub mod sensor_gated;

use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::sensor::SensorParams;
use crate::stats::{Counters, FrameStats};
use glam::DVec3;
pub use narrow::{EdgeEdge, ProximityContacts, VertexTriangle};
use std::str::FromStr;
use std::sync::Arc;

/// The detection methods, by their command-line names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// All pairs, exact: the reference.
    Brute,
    /// BVH with boxes only.
    Bvh,
    /// BVH with normal-cone culling, no contour test (the paper's hierarchy).
    BvhCones,
    /// BVH with normal cones and the star contour test (conservative).
    BvhConesContour,
    /// The particle sensor gating a BVH method (the paper's full method).
    SensorGated,
}

impl Method {
    /// Every method, in report order.
    pub const ALL: [Method; 5] = [
        Method::Brute,
        Method::Bvh,
        Method::BvhCones,
        Method::BvhConesContour,
        Method::SensorGated,
    ];

    /// The method's name, as used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Brute => "brute",
            Method::Bvh => "bvh",
            Method::BvhCones => "bvh-cones",
            Method::BvhConesContour => "bvh-cones-contour",
            Method::SensorGated => "sensor-gated",
        }
    }

    /// True when the method never misses a contact (false for the methods
    /// that can miss contacts by design: `bvh-cones`, `sensor-gated`).
    pub fn is_conservative(self) -> bool {
        !matches!(self, Method::BvhCones | Method::SensorGated)
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = Error;
    fn from_str(s: &str) -> Result<Method> {
        crate::error::parse_name(s, &Method::ALL, Method::name, "method")
    }
}

/// Options shared by all detectors.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectorOptions {
    /// Proximity thickness d (metres): when > 0, vertex-triangle and edge-edge
    /// pairs closer than d are reported too.
    pub thickness: f64,
    /// Particle sensor parameters (used by `sensor-gated`).
    pub sensor: SensorParams,
}

impl Default for DetectorOptions {
    fn default() -> Self {
        DetectorOptions {
            thickness: 0.0,
            sensor: SensorParams::default(),
        }
    }
}

impl DetectorOptions {
    /// Checks the options' ranges.
    pub fn validate(&self) -> Result<()> {
        if !(self.thickness >= 0.0 && self.thickness.is_finite()) {
            return Err(Error::InvalidParameter(format!(
                "thickness must be finite and >= 0, got {}",
                self.thickness
            )));
        }
        self.sensor.validate()
    }
}

/// What one detection call found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Detection {
    /// Intersecting pairs of non-adjacent triangles (i < j), sorted.
    pub pairs: Vec<[u32; 2]>,
    /// Proximity contacts (empty unless thickness > 0).
    pub proximity: ProximityContacts,
    /// What the call cost.
    pub stats: FrameStats,
}

impl Detection {
    /// Sets the stats' contact counts from what was found.
    pub fn count_contacts(&mut self) {
        self.stats.contacts = self.pairs.len() as u64;
        self.stats.proximity_contacts =
            (self.proximity.vertex_triangle.len() + self.proximity.edge_edge.len()) as u64;
    }
}

/// A self-collision detector for one mesh, keeping its state between frames.
pub trait Detector: Send {
    /// The method this detector runs.
    fn method(&self) -> Method;
    /// The mesh it was built for.
    fn mesh(&self) -> &Arc<Mesh>;
    /// Finds self-intersections (and proximity contacts) at `positions`.
    fn detect(&mut self, positions: &[DVec3]) -> Result<Detection>;
    /// Sets the most proximity contacts one call may collect (default
    /// [`narrow::DEFAULT_MAX_CONTACTS`]); past it `detect` fails with
    /// [`Error::TooManyContacts`] instead of exhausting memory.
    fn set_max_contacts(&mut self, max: usize);
    /// Current particle positions, for drawing (empty for methods without a sensor).
    fn particles(&self) -> Vec<DVec3> {
        Vec::new()
    }
}

/// Builds a detector running `method` on `mesh`.
pub fn new_detector(
    mesh: Arc<Mesh>,
    method: Method,
    opts: &DetectorOptions,
) -> Result<Box<dyn Detector>> {
    opts.validate()?;
    Ok(match method {
        Method::Brute => Box::new(brute::BruteDetector::new(mesh, opts.thickness)),
        Method::SensorGated => Box::new(sensor_gated::SensorGatedDetector::new(
            mesh,
            opts.thickness,
            &opts.sensor,
        )?),
        _ => Box::new(hierarchy::BvhDetector::new(mesh, method, opts.thickness)),
    })
}

/// One-shot exact query: all intersecting non-adjacent triangle pairs of a
/// mesh at `positions`, `[i, j]` with i < j, sorted.
///
/// Runs on a hierarchy built top-down for this query alone
/// ([`crate::bvh::topdown`]): nodes are split only where a certificate
/// fails, so a smooth sheet costs one certificate. A simulation, which asks
/// every frame, keeps a [`Detector`] instead.
pub fn self_intersections(mesh: &Arc<Mesh>, positions: &[DVec3]) -> Result<Vec<[u32; 2]>> {
    mesh.check_positions(positions)?;
    Ok(crate::bvh::topdown::self_intersections(mesh, positions).0)
}

/// [`self_intersections`] as a [`Detection`], for callers that report what
/// a detector reports: its pairs, its counters, and the whole query's time
/// (hierarchy included) as `traverse_time`.
pub fn one_shot_detection(mesh: &Mesh, positions: &[DVec3]) -> Result<Detection> {
    mesh.check_positions(positions)?;
    let t0 = std::time::Instant::now();
    let (pairs, counters) = crate::bvh::topdown::self_intersections(mesh, positions);
    let mut det = Detection {
        pairs,
        ..Default::default()
    };
    counters.write_to(&mut det.stats);
    det.stats.traverse_time = t0.elapsed().as_secs_f64();
    det.count_contacts();
    Ok(det)
}

/// One-shot proximity query: every vertex-triangle and edge-edge pair (not
/// sharing a vertex) closer than `thickness` (> 0, finite) at `positions`,
/// sorted as a [`Detector`]'s proximity contacts and equal to them to the bit
/// (the same box test within `thickness`, the same element arithmetic), with
/// what the query did. At most `max_contacts` contacts are collected; past it
/// the query fails with [`Error::TooManyContacts`].
///
/// Runs on the one-shot's top-down hierarchy ([`crate::bvh::topdown`]), split
/// wherever two boxes come within `thickness`, except in patches whose
/// certificate holds with room to spare: under 90 degrees of normals, a
/// disk seen along the cone's axis, every triangle's altitude and the
/// contour's own clearance above `thickness` (the module doc's
/// "Proximity"; a flat sheet is not descended at all). A simulation, which
/// asks every step, keeps [`coherent::SelfQueries`] instead.
pub fn proximity_contacts(
    mesh: &Mesh,
    positions: &[DVec3],
    thickness: f64,
    max_contacts: usize,
) -> Result<(ProximityContacts, Counters)> {
    mesh.check_positions(positions)?;
    narrow::check_thickness(thickness)?;
    let near = narrow::Proximity::new(mesh, positions, thickness, max_contacts);
    let shape = crate::bvh::topdown::Shape::At(positions);
    let (parts, counters) = crate::bvh::topdown::query_parts(mesh, shape, thickness, &near);
    near.check_output(parts.iter().map(Vec::len).sum())?;
    Ok((narrow::collect_proximity_parts(parts), counters))
}
