//! Early exit: one intersecting pair, or none, without finding them all:
//! the one-shot query's top-down hierarchy ([`crate::bvh::topdown`]),
//! stopping at its first pair. Its certificates are exact, so it never misses
//! a pair; its tests run in one order, so the pair found is the same on
//! every run.

use crate::error::Result;
use crate::mesh::Mesh;
use glam::DVec3;

/// Some non-adjacent pair `[a, b]` (a < b) of `mesh`'s triangles that intersect
/// at `positions`, or None when there is none.
///
/// Errors: positions of the wrong length or not finite (as every query).
pub fn first_intersection(mesh: &Mesh, positions: &[DVec3]) -> Result<Option<[u32; 2]>> {
    mesh.check_positions(positions)?;
    Ok(crate::bvh::topdown::first_intersection(mesh, positions))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::brute::BruteDetector;
    use crate::detect::Detector;
    use crate::scene::{grid, Deformation};
    use std::sync::Arc;

    fn grid_mesh(n: usize) -> Arc<Mesh> {
        let (v, t) = grid(n, 1.0);
        Arc::new(Mesh::new(v, t).unwrap())
    }

    fn all_pairs(mesh: &Arc<Mesh>, p: &[DVec3]) -> Vec<[u32; 2]> {
        BruteDetector::new(mesh.clone(), 0.0)
            .detect(p)
            .unwrap()
            .pairs
    }

    #[test]
    fn finds_a_pair_exactly_when_there_is_one() {
        let mesh = grid_mesh(13);
        let (mut found, mut clean) = (0, 0);
        for (k, seed) in (0..12u64).enumerate() {
            let amplitude = 0.05 * k as f64;
            let p = Deformation::Crumple {
                amplitude,
                wavelength: 0.4,
                seed,
            }
            .apply(mesh.rest());
            let all = all_pairs(&mesh, &p);
            match first_intersection(&mesh, &p).unwrap() {
                Some(pair) => {
                    assert!(all.contains(&pair), "{pair:?} is not an intersecting pair");
                    found += 1;
                }
                None => {
                    assert!(all.is_empty(), "missed {} pairs", all.len());
                    clean += 1;
                }
            }
        }
        assert!(
            found >= 3 && clean >= 3,
            "{found} meshes with pairs, {clean} without"
        );
    }

    #[test]
    fn flat_and_touching_neighbours_are_not_pairs() {
        let mesh = grid_mesh(9);
        assert_eq!(first_intersection(&mesh, mesh.rest()).unwrap(), None);
    }

    #[test]
    fn crossing_triangles_are_found_and_bad_positions_refused() {
        let v = vec![
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.5, 0.5, -1.0],
            [0.5, 0.5, 1.0],
            [1.5, 0.5, 1.0],
        ];
        let mesh = Mesh::new(v, vec![[0, 1, 2], [3, 4, 5]]).unwrap();
        assert_eq!(
            first_intersection(&mesh, mesh.rest()).unwrap(),
            Some([0, 1])
        );
        assert!(first_intersection(&mesh, &mesh.rest()[..3]).is_err());
        let mut nan = mesh.rest().to_vec();
        nan[4].z = f64::NAN;
        assert!(first_intersection(&mesh, &nan).is_err());
    }
}
