//! Geometry: boxes, normal cones, exact predicates and the primitive tests.

pub mod aabb;
pub mod ccd;
pub mod cone;
pub mod distance;
pub mod exact_int;
pub mod loop2d;
pub mod predicates;
pub mod slab;
pub mod tri_tri;

pub use aabb::Aabb;
pub use cone::NormalCone;
pub use slab::Slab;
