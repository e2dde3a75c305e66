//! The input of the per-frame examples (prof, queries): a benchmark grid
//! deformed to a state, or a mesh file at its own positions.

use super::obj::read_obj;
use selfcd::scene::{grid, grid_side_for, BenchState};
use selfcd::{DVec3, Mesh};
use std::sync::Arc;

/// The mesh, the frame to detect on, and the remaining arguments.
pub fn frame(a: &[String]) -> (Arc<Mesh>, Vec<DVec3>, &[String]) {
    if a[1].ends_with(".obj") {
        let (v, f) = read_obj(&a[1]);
        let mesh = Arc::new(Mesh::new(v, f).unwrap());
        let p = mesh.rest().to_vec();
        return (mesh, p, &a[2..]);
    }
    let n: usize = a[1].parse().unwrap();
    let state: BenchState = a[2].parse().unwrap();
    let side = grid_side_for(n);
    let (v, f) = grid(side, 1.0);
    let mesh = Arc::new(Mesh::new(v, f).unwrap());
    let p = state.deformation(side).apply(mesh.rest());
    (mesh, p, &a[3..])
}
