//! Connected components of a mesh: triangles are connected when they share a
//! vertex (a surface path can pass through a shared vertex). Between components
//! there is no surface path, so the original distance there is infinite.

use crate::mesh::Mesh;
use crate::union_find::{find, union};

/// Component id of every triangle, numbered 0.. in order of each component's first triangle.
pub fn triangle_components(mesh: &Mesh) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..mesh.n_vertices() as u32).collect();
    for t in mesh.triangles() {
        union(&mut parent, t[0], t[1]);
        union(&mut parent, t[0], t[2]);
    }
    let mut label = vec![u32::MAX; parent.len()];
    let mut next = 0;
    mesh.triangles()
        .iter()
        .map(|t| {
            let root = find(&mut parent, t[0]) as usize;
            if label[root] == u32::MAX {
                label[root] = next;
                next += 1;
            }
            label[root]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_quads_and_a_bow_tie() {
        let v = vec![
            [0., 0., 0.],
            [1., 0., 0.],
            [1., 1., 0.],
            [0., 1., 0.],
            [5., 0., 0.],
            [6., 0., 0.],
            [5., 1., 0.],
            [7., 1., 0.],
            [7., 0., 0.],
        ];
        // Quad (0,1); lone triangle (2) and a triangle touching it at vertex 6 (3).
        let f = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [6, 7, 8]];
        let m = Mesh::new(v, f).unwrap();
        assert_eq!(triangle_components(&m), vec![0, 0, 1, 1]);
    }
}
