//! selfcd: self-collision detection for deforming triangle meshes.
//!
//! A bottom-up BVH with normal-cone ("positive vector") culling and a
//! conservative contour test, exact triangle-triangle predicates, proximity
//! and continuous queries, the paper's particle sensor ([`sensor`]) and a
//! mass-spring cloth simulator ([`cloth`]); the repository's README.md covers
//! the command line and the Python API. Start with [`Mesh::new`] and
//! [`detect::new_detector`].
//!
//! Nothing panics on bad input: every error is an [`Error`].

// `!(x > y)` is the NaN-safe comparison used on purpose throughout (NaN fails the test).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bench;
pub(crate) mod bits;
pub mod bvh;
pub mod cloth;
pub mod detect;
pub mod error;
pub mod geom;
pub mod mesh;
pub(crate) mod prefetch;
pub mod scene;
pub mod sensor;
pub mod stats;
pub(crate) mod union_find;
pub mod weld;

pub use detect::{new_detector, self_intersections, Detection, Detector, DetectorOptions, Method};
pub use error::{Error, Result};
pub use glam::DVec3;
pub use mesh::Mesh;
pub use stats::FrameStats;
