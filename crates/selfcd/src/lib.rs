//! selfcd: self-collision detection for deforming triangle meshes.
//!
//! A bottom-up BVH with normal-cone ("positive vector") culling and a
//! conservative contour test, exact triangle-triangle predicates, proximity
//! queries, and (see the crate README) the paper's particle sensor and cloth
//! simulator. Start with [`Mesh::new`] and [`detect::new_detector`].

pub mod bench;
pub mod bvh;
pub mod cloth;
pub mod detect;
pub mod error;
pub mod geom;
pub mod mesh;
pub mod scene;
pub mod sensor;
pub mod stats;

pub use detect::{new_detector, self_intersections, Detection, Detector, DetectorOptions, Method};
pub use error::{Error, Result};
pub use glam::DVec3;
pub use mesh::Mesh;
pub use stats::FrameStats;
