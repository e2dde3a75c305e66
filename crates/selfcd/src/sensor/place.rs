//! Deterministic initial placement.
//!
//! Candidates are four points per triangle: its centroid and the three points
//! halfway from the centroid to each corner, so even a one-triangle mesh has
//! room for several particles. The particles are shared among the mesh's
//! components ([`crate::Mesh::triangle_components`]) by area: component c gets
//! ceil(count * area_c / area_total) (at least one, at most its candidates),
//! so every component carries a particle and the total is at most
//! count + components - 1. Within a component they are spread by
//! farthest-point sampling of its candidates in rest space: the first goes to
//! the candidate farthest from the component's vertex centroid, each next one to
//! the candidate farthest from those already placed (ties: lowest candidate).
//! On the paper's square this puts four particles near the four corners,
//! already spread, so the relaxation starts near its quiet state.

use super::particle::SurfacePoint;
use crate::mesh::Mesh;
use glam::DVec3;

/// Barycentric weights of the four candidates of a triangle.
const CANDIDATES: [[f64; 3]; 4] = [
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
    [2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0],
    [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0],
    [1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0],
];

/// Particles per component: ceil(count * area share) (less 1e-9, so exact shares
/// do not round up), clamped to [1, 4 * triangles].
pub fn share(mesh: &Mesh, component: &[u32], count: usize) -> Vec<usize> {
    let n = component.iter().max().map_or(0, |&c| c as usize + 1);
    let (mut area, mut tris) = (vec![0.0; n], vec![0usize; n]);
    for (t, &c) in component.iter().enumerate() {
        let [a, b, d] = mesh.corners(mesh.rest(), t);
        area[c as usize] += 0.5 * (b - a).cross(d - a).length();
        tris[c as usize] += 1;
    }
    let total: f64 = area.iter().sum();
    area.iter()
        .zip(&tris)
        .map(|(&a, &t)| {
            let want = if total > 0.0 {
                (count as f64 * a / total - 1e-9).ceil() as usize
            } else {
                1
            };
            want.clamp(1, CANDIDATES.len() * t)
        })
        .collect()
}

/// Particles spread over every component of `mesh` (ids per triangle in `component`), `share` per component.
pub fn place(mesh: &Mesh, component: &[u32], share: &[usize]) -> Vec<SurfacePoint> {
    let mut out = Vec::new();
    for (c, &k) in share.iter().enumerate() {
        let candidates: Vec<SurfacePoint> = component
            .iter()
            .enumerate()
            .filter(|&(_, &tc)| tc as usize == c)
            .flat_map(|(t, _)| {
                CANDIDATES.map(|bary| SurfacePoint {
                    tri: t as u32,
                    bary,
                })
            })
            .collect();
        out.extend(farthest_points(mesh, &candidates, k));
    }
    out
}

/// `count` of `candidates` (non-empty, count <= len) by farthest-point sampling in rest space.
pub fn farthest_points(
    mesh: &Mesh,
    candidates: &[SurfacePoint],
    count: usize,
) -> Vec<SurfacePoint> {
    let at: Vec<DVec3> = candidates.iter().map(|p| p.rest_position(mesh)).collect();
    let middle = at.iter().copied().sum::<DVec3>() / at.len().max(1) as f64;
    let mut dist: Vec<f64> = at.iter().map(|c| c.distance_squared(middle)).collect();
    let mut out = Vec::with_capacity(count);
    for _ in 0..count.min(candidates.len()) {
        let best = argmax(&dist);
        out.push(candidates[best]);
        let chosen = at[best];
        if out.len() == 1 {
            dist.iter_mut().for_each(|d| *d = f64::INFINITY);
        }
        for (d, c) in dist.iter_mut().zip(&at) {
            *d = d.min(c.distance_squared(chosen));
        }
    }
    out
}

/// Index of the first value within a relative 1e-9 of the largest: ties broken
/// the same way whatever the mesh's scale (rounding differs between scales).
fn argmax(v: &[f64]) -> usize {
    let top = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    v.iter()
        .position(|&x| x >= top - 1e-9 * top.abs())
        .unwrap_or(0)
}
