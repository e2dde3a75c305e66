//! The particle sensor of the paper (section 2): a few particles moving on the
//! surface that sense folds and gate the BVH traversal.
//!
//! - [`particle`]: a particle is a surface point (triangle + barycentric).
//! - [`tangent`]: tangent vectors of a triangle, in rest and current shape.
//! - [`walk`]: moving a particle along the surface, across triangles.
//! - [`geodesic`]: geodesic distance fields on the rest mesh (fast marching).
//! - [`odl`]: original distance and path direction: chord on flat rest
//!   shapes, geodesic fields on curved ones, infinite between components.
//! - [`forces`]: the paper's attraction and repulsion.
//! - [`parts`]: convex parts from the hierarchy's normal cones (the particle count).
//! - [`place`]: deterministic initial placement, shared among components.
//! - [`relax`]: per-frame relaxation (N_min, N_max) and the trigger.
//! - [`units`]: the sensor's scale-free, snapped frame.
//! - [`params`]: every constant, with its default.
//!
//! All lengths the sensor reasons in are in units of the mesh's mean rest edge
//! length, in a snapped frame ([`units`]), so its behaviour does not depend on
//! the mesh's scale.

// Guards are written `!(x > limit)` on purpose: they are true for NaN too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod forces;
pub mod geodesic;
pub mod odl;
pub mod params;
pub mod particle;
pub mod parts;
pub mod place;
pub mod relax;
pub mod tangent;
pub mod units;
pub mod walk;

pub use params::SensorParams;
pub use particle::SurfacePoint;
pub use relax::{ClosestPair, Relaxation, Sensor};

#[cfg(test)]
pub(crate) mod testing {
    use crate::mesh::Mesh;
    use crate::scene::{grid, Deformation};

    /// An n x n unit grid and, apart from it, one right triangle with its
    /// right angle at (x, 0, 0) and legs of `size`: two components, the
    /// triangle's vertices last.
    pub fn grid_and_triangle(n: usize, x: f64, size: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let (mut v, mut f) = grid(n, 1.0);
        let k = v.len() as u32;
        v.extend([[x, 0.0, 0.0], [x + size, 0.0, 0.0], [x, size, 0.0]]);
        f.push([k, k + 1, k + 2]);
        (v, f)
    }

    /// An n x n sheet crumpled into its rest shape: curved everywhere.
    pub fn crumpled_rest(n: usize) -> Mesh {
        let (v, f) = grid(n, 1.0);
        let flat = Mesh::new(v, f.clone()).unwrap();
        let rest = Deformation::Crumple {
            amplitude: 0.2,
            wavelength: 0.5,
            seed: 7,
        }
        .apply(flat.rest());
        Mesh::new(rest.iter().map(|p| p.to_array()).collect(), f).unwrap()
    }
}
