//! Deterministic initial placement: farthest-point sampling of triangle
//! centroids on the rest mesh. The first particle goes to the centroid farthest
//! from the rest vertex centroid; each next one to the centroid whose rest
//! distance to the particles already placed is largest (ties: lowest triangle
//! id). On the paper's square this puts four particles near the four corners,
//! already spread, so the relaxation starts near its quiet state.

use super::particle::SurfacePoint;
use crate::mesh::Mesh;
use glam::DVec3;

/// `count` particles spread over `mesh` by farthest-point sampling (count <= triangles, checked by the caller).
pub fn farthest_points(mesh: &Mesh, count: usize) -> Vec<SurfacePoint> {
    let rest = mesh.rest();
    let centroids: Vec<DVec3> = (0..mesh.n_triangles())
        .map(|t| mesh.corners(rest, t).iter().sum::<DVec3>() / 3.0)
        .collect();
    let middle = rest.iter().copied().sum::<DVec3>() / rest.len() as f64;
    let mut dist: Vec<f64> = centroids
        .iter()
        .map(|c| c.distance_squared(middle))
        .collect();
    let mut out = Vec::with_capacity(count);
    for _ in 0..count {
        let best = argmax(&dist);
        out.push(SurfacePoint::centroid(best as u32));
        let chosen = centroids[best];
        if out.len() == 1 {
            dist.iter_mut().for_each(|d| *d = f64::INFINITY);
        }
        for (d, c) in dist.iter_mut().zip(&centroids) {
            *d = d.min(c.distance_squared(chosen));
        }
    }
    out
}

/// Index of the largest value; the first one on ties.
fn argmax(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in v.iter().enumerate() {
        if x > v[best] {
            best = i;
        }
    }
    best
}
