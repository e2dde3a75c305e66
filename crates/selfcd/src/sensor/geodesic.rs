//! Geodesic distance on the rest mesh from one surface point to every vertex,
//! by fast marching (Kimmel and Sethian's triangle update run in Dijkstra
//! order).
//!
//! Vertices are accepted in order of distance, as in Dijkstra's algorithm on
//! the edge graph. A vertex w of a triangle (v, u, w) whose other two corners
//! are accepted also gets the planar update: unfold the triangle into the plane,
//! put the virtual source s at distances d(v), d(u) from v and u on the far side
//! of edge vu, and take |s - w| when the straight line from s to w crosses edge
//! vu (the front passes through the triangle). Otherwise only the edge paths
//! d(v) + |vw| count. Exact on a flat mesh for sources at vertices when every
//! update is a crossing one; in general the error is first order in the edge
//! length and much smaller than the edge graph's (measured in BENCHMARKS.md).
//! The march stops once the front passes `cut`: vertices beyond it (and those
//! of other components, never reached) keep distance infinity.
//! A zero-area triangle gets no planar update (only its edges carry paths).

use super::particle::SurfacePoint;
use crate::mesh::Mesh;
use glam::DVec3;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Reusable buffers of [`Marcher::distance_field`].
#[derive(Debug, Clone, Default)]
pub struct Marcher {
    accepted: Vec<bool>,
    heap: BinaryHeap<Reverse<(u64, u32)>>,
}

impl Marcher {
    /// Writes into `dist` the geodesic distance on the surface with `mesh`'s
    /// triangles and vertex positions `rest` (in `rest`'s units) from `source`
    /// to every vertex up to `cut`; infinity beyond it and on other components.
    /// Returns the number of vertices accepted (the cost).
    pub fn distance_field(
        &mut self,
        mesh: &Mesh,
        rest: &[DVec3],
        source: &SurfacePoint,
        cut: f64,
        dist: &mut Vec<f64>,
    ) -> usize {
        let n = mesh.n_vertices();
        dist.clear();
        dist.resize(n, f64::INFINITY);
        self.accepted.clear();
        self.accepted.resize(n, false);
        self.heap.clear();
        let s = source.position(mesh, rest);
        for &c in &mesh.triangles()[source.tri as usize] {
            self.relax_to(dist, c, rest[c as usize].distance(s));
        }
        let mut reached = 0;
        while let Some(Reverse((_, v))) = self.heap.pop() {
            if std::mem::replace(&mut self.accepted[v as usize], true) {
                continue;
            }
            reached += 1;
            if dist[v as usize] > cut {
                // Beyond the cut: forget this and every later (farther) tentative value.
                dist[v as usize] = f64::INFINITY;
                for Reverse((_, w)) in self.heap.drain() {
                    if !self.accepted[w as usize] {
                        dist[w as usize] = f64::INFINITY;
                    }
                }
                break;
            }
            for &t in mesh.topology().vertex_tris.row(v as usize) {
                self.update_triangle(rest, dist, v, mesh.triangles()[t as usize]);
            }
        }
        reached
    }

    /// Updates the two other corners of triangle `tri` from its newly accepted corner `v`.
    fn update_triangle(&mut self, rest: &[DVec3], dist: &mut [f64], v: u32, tri: [u32; 3]) {
        let k = tri.iter().position(|&x| x == v).unwrap_or(0);
        for (w, u) in [
            (tri[(k + 1) % 3], tri[(k + 2) % 3]),
            (tri[(k + 2) % 3], tri[(k + 1) % 3]),
        ] {
            if self.accepted[w as usize] {
                continue;
            }
            let (pv, pw) = (rest[v as usize], rest[w as usize]);
            let mut best = dist[v as usize] + pv.distance(pw);
            if self.accepted[u as usize] {
                let pu = rest[u as usize];
                if let Some(d) = planar_update(pv, dist[v as usize], pu, dist[u as usize], pw) {
                    best = best.min(d);
                }
            }
            self.relax_to(dist, w, best);
        }
    }

    /// Lowers `dist[w]` to `d` if smaller and queues w.
    fn relax_to(&mut self, dist: &mut [f64], w: u32, d: f64) {
        if d < dist[w as usize] {
            dist[w as usize] = d;
            // Non-negative f64s order like their bit patterns.
            self.heap.push(Reverse((d.to_bits(), w)));
        }
    }
}

/// Distance to `w` from the virtual source at distances `dv` from `v` and `du`
/// from `u` on the far side of edge vu, when the straight path crosses the edge.
fn planar_update(v: DVec3, dv: f64, u: DVec3, du: f64, w: DVec3) -> Option<f64> {
    let e = u - v;
    let l = e.length();
    let x_axis = e / l;
    let rw = w - v;
    let wx = rw.dot(x_axis);
    let wy = (rw - x_axis * wx).length();
    if !(l > 0.0 && wy > 1e-12 * l) {
        return None;
    }
    let sx = (dv * dv - du * du + l * l) / (2.0 * l);
    let sy2 = dv * dv - sx * sx;
    if !(sy2 >= 0.0) {
        return None;
    }
    let sy = -sy2.sqrt();
    let cross_x = sx + (wx - sx) * (-sy / (wy - sy));
    (0.0..=l)
        .contains(&cross_x)
        .then(|| ((wx - sx).powi(2) + (wy - sy).powi(2)).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::testing::grid_and_triangle;

    #[test]
    fn flat_grid_is_close_to_euclidean_and_other_components_are_unreached() {
        let (v, f) = grid_and_triangle(21, 5.0, 1.0);
        let n = v.len() as u32 - 3;
        let mesh = Mesh::new(v, f).unwrap();
        let src = SurfacePoint::centroid(0);
        let mut dist = Vec::new();
        Marcher::default().distance_field(&mesh, mesh.rest(), &src, f64::INFINITY, &mut dist);
        let s = src.rest_position(&mesh);
        let worst = (0..n as usize)
            .map(|i| (dist[i] - mesh.rest()[i].distance(s)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.02, "worst error {worst} on a unit square");
        assert!(dist[n as usize..].iter().all(|d| d.is_infinite()));
    }

    /// The march never puts a vertex closer to the source than the straight
    /// line: what lets a path skip a field beyond its reach by the chord alone
    /// ([`super::super::odl`]).
    #[test]
    fn the_march_is_never_shorter_than_the_straight_line() {
        use crate::scene::tube;
        use crate::sensor::testing::crumpled_rest;
        let (v, f) = tube(24, 25, 0.2, 1.0);
        for mesh in [crumpled_rest(41), Mesh::new(v, f).unwrap()] {
            let cut = 12.0 * mesh.mean_edge_length();
            let mut dist = Vec::new();
            for tri in (0..mesh.n_triangles() as u32).step_by(97) {
                let src = SurfacePoint::centroid(tri);
                Marcher::default().distance_field(&mesh, mesh.rest(), &src, cut, &mut dist);
                let s = src.rest_position(&mesh);
                for (d, p) in dist.iter().zip(mesh.rest()).filter(|(d, _)| d.is_finite()) {
                    assert!(
                        *d >= p.distance(s) * (1.0 - 1e-12),
                        "{d} < {}",
                        p.distance(s)
                    );
                }
            }
        }
    }
}
