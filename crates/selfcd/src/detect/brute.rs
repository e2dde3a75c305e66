//! The exact reference: every pair of triangles, exact test. O(n^2).

use super::narrow::{collect_proximity, Intersect, Proximity, DEFAULT_MAX_CONTACTS};
use super::{Detection, Detector, Method};
use crate::bvh::traverse::LeafVisitor;
use crate::error::Result;
use crate::geom::Aabb;
use crate::mesh::Mesh;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// Tests every pair of triangles. A box check (exact: boxes are not rounded)
/// precedes each exact test; it is counted as part of that primitive test.
pub struct BruteDetector {
    mesh: Arc<Mesh>,
    thickness: f64,
    max_contacts: usize,
}

impl BruteDetector {
    /// A brute-force detector for `mesh`.
    pub fn new(mesh: Arc<Mesh>, thickness: f64) -> Self {
        BruteDetector {
            mesh,
            thickness,
            max_contacts: DEFAULT_MAX_CONTACTS,
        }
    }
}

/// Runs `visitor` on every pair i < j whose boxes are within `gap`, skipping
/// pairs sharing a vertex when the visitor says so. Returns items in (i, j) order
/// and the number of pairs considered.
fn all_pairs<V: LeafVisitor>(
    mesh: &Mesh,
    positions: &[DVec3],
    gap: f64,
    visitor: &V,
) -> (Vec<V::Item>, u64, u64) {
    let n = mesh.n_triangles();
    let boxes: Vec<Aabb> = (0..n)
        .map(|t| Aabb::from_points(&mesh.corners(positions, t)))
        .collect();
    let per_row: Vec<(Vec<V::Item>, u64, u64)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (mut out, mut tests, mut adjacent) = (Vec::new(), 0u64, 0u64);
            for j in i + 1..n {
                let adj = mesh.share_vertex(i, j);
                if adj {
                    adjacent += 1;
                    if V::SKIP_ADJACENT {
                        continue;
                    }
                }
                tests += 1;
                if boxes[i].within(&boxes[j], gap) {
                    visitor.visit(i as u32, j as u32, adj, &mut out);
                }
            }
            (out, tests, adjacent)
        })
        .collect();
    let (mut items, mut tests, mut adjacent) = (Vec::new(), 0, 0);
    for (o, t, a) in per_row {
        items.extend(o);
        tests += t;
        adjacent += a;
    }
    (items, tests, adjacent)
}

impl Detector for BruteDetector {
    fn method(&self) -> Method {
        Method::Brute
    }

    fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    fn set_max_contacts(&mut self, max: usize) {
        self.max_contacts = max;
    }

    fn detect(&mut self, positions: &[DVec3]) -> Result<Detection> {
        let mesh = &*self.mesh;
        mesh.check_positions(positions)?;
        let t0 = Instant::now();
        let (pairs, tests, adjacent) =
            all_pairs(mesh, positions, 0.0, &Intersect { mesh, positions });
        let mut det = Detection {
            pairs,
            ..Default::default()
        };
        if self.thickness > 0.0 {
            let near = Proximity::new(mesh, positions, self.thickness, self.max_contacts);
            let (items, tested, _) = all_pairs(mesh, positions, self.thickness, &near);
            near.check_output(items.len())?;
            det.proximity = collect_proximity(items);
            det.stats.proximity_tests = tested;
        }
        let s = &mut det.stats;
        s.traverse_time = t0.elapsed().as_secs_f64();
        s.primitive_tests = tests;
        s.adjacent_skips = adjacent;
        det.count_contacts();
        Ok(det)
    }
}
