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

use glam::DVec3;
use rayon::prelude::*;

/// The largest coordinate magnitude of `points` (0 when empty): the scale the
/// rounding slacks are taken against. In parallel when there are many.
pub fn magnitude(points: &[DVec3]) -> f64 {
    let size = |p: &DVec3| p.abs().max_element();
    if points.len() >= 1 << 14 {
        points.par_iter().map(size).reduce(|| 0.0, f64::max)
    } else {
        points.iter().map(size).fold(0.0, f64::max)
    }
}
