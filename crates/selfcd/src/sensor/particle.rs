//! A particle is a point of the surface: a triangle and barycentric
//! coordinates in it. Its position in any shape of the mesh is
//! `p = b0 P[v0] + b1 P[v1] + b2 P[v2]`, so it moves with the material and can
//! never be off the surface.

use crate::error::{Error, Result};
use crate::mesh::Mesh;
use glam::DVec3;

/// A point on the surface: triangle `tri` and barycentric weights `bary` (each >= 0, sum 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// The triangle holding the point.
    pub tri: u32,
    /// Barycentric weights of the triangle's corners, in the triangle's vertex order.
    pub bary: [f64; 3],
}

impl SurfacePoint {
    /// The centroid of triangle `tri`.
    pub fn centroid(tri: u32) -> SurfacePoint {
        SurfacePoint {
            tri,
            bary: [1.0 / 3.0; 3],
        }
    }

    /// Checks that the point is on `mesh`: valid triangle, finite weights >= 0 summing to 1 (within 1e-9).
    pub fn check(&self, mesh: &Mesh) -> Result<()> {
        let ok_tri = (self.tri as usize) < mesh.n_triangles();
        let ok_bary = self.bary.iter().all(|b| b.is_finite() && *b >= 0.0)
            && (self.bary.iter().sum::<f64>() - 1.0).abs() <= 1e-9;
        if ok_tri && ok_bary {
            return Ok(());
        }
        Err(Error::InvalidParameter(format!(
            "surface point {:?} is not on the mesh ({} triangles; weights must be >= 0 and sum to 1)",
            self,
            mesh.n_triangles()
        )))
    }

    /// Position of the point in `positions` (a shape of `mesh`).
    #[inline]
    pub fn position(&self, mesh: &Mesh, positions: &[DVec3]) -> DVec3 {
        let c = mesh.corners(positions, self.tri as usize);
        c[0] * self.bary[0] + c[1] * self.bary[1] + c[2] * self.bary[2]
    }

    /// Position of the point in the rest shape.
    #[inline]
    pub fn rest_position(&self, mesh: &Mesh) -> DVec3 {
        self.position(mesh, mesh.rest())
    }

    /// Makes the weights exactly a convex combination: negatives (rounding) to 0, then sum to 1.
    pub fn normalise(&mut self) {
        for b in &mut self.bary {
            *b = b.max(0.0);
        }
        let s: f64 = self.bary.iter().sum();
        if s > 0.0 {
            for b in &mut self.bary {
                *b /= s;
            }
        } else {
            self.bary = [1.0 / 3.0; 3];
        }
    }
}
