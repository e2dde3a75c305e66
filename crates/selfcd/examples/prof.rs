//! Profiling helper: repeated detections of one frame, best times.
//!
//! `cargo run --release -p selfcd --example prof -- SIZE STATE METHOD [REPS] [THICKNESS in mean edges]`
//! (a benchmark grid, deformed), or
//! `cargo run --release -p selfcd --example prof -- FILE.obj METHOD [REPS] [THICKNESS in mean edges]`
//! (a mesh file at its own positions).
use selfcd::scene::{grid, grid_side_for, BenchState};
use selfcd::{new_detector, DVec3, DetectorOptions, Mesh, Method};
use std::sync::Arc;
use std::time::Instant;

#[path = "common/obj.rs"]
mod obj;

/// The mesh, the frame to detect on, and the remaining arguments.
fn frame(a: &[String]) -> (Arc<Mesh>, Vec<DVec3>, &[String]) {
    if a[1].ends_with(".obj") {
        let (v, f) = obj::read_obj(&a[1]);
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

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let (mesh, p, rest) = frame(&a);
    let method: Method = rest[0].parse().unwrap();
    let reps: usize = rest.get(1).map(|x| x.parse().unwrap()).unwrap_or(5);
    let thickness: f64 = rest.get(2).map(|x| x.parse().unwrap()).unwrap_or(0.0);
    let opts = DetectorOptions {
        thickness: thickness * mesh.mean_edge_length(),
        ..Default::default()
    };
    let n = mesh.n_triangles();
    let t0 = Instant::now();
    let mut d = new_detector(mesh, method, &opts).unwrap();
    let build = t0.elapsed().as_secs_f64();
    let (mut refit, mut trav, mut last) = (f64::MAX, f64::MAX, None);
    for _ in 0..reps {
        let s = d.detect(&p).unwrap().stats;
        refit = refit.min(s.refit_time);
        trav = trav.min(s.traverse_time);
        last = Some(s);
    }
    let s = last.unwrap();
    println!(
        "{n} triangles: build {:.1} ms, best refit {:.3} ms, best traverse {:.3} ms; node pairs {}, contour tests {} (failed {}), primitive tests {}, contacts {}, proximity tests {}, proximity contacts {}",
        build * 1e3, refit * 1e3, trav * 1e3, s.node_pairs, s.contour_tests, s.contour_fails, s.primitive_tests, s.contacts, s.proximity_tests, s.proximity_contacts
    );
}
