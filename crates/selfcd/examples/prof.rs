//! Profiling helper: repeated detections of one benchmark frame, best time.
//! `cargo run --release -p selfcd --example prof -- SIZE STATE METHOD [REPS] [THICKNESS in mean edges]`
use selfcd::scene::{grid, grid_side_for, BenchState};
use selfcd::{new_detector, DetectorOptions, Mesh, Method};
use std::sync::Arc;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let n: usize = a[1].parse().unwrap();
    let state: BenchState = a[2].parse().unwrap();
    let method: Method = a[3].parse().unwrap();
    let reps: usize = a.get(4).map(|x| x.parse().unwrap()).unwrap_or(5);
    let thickness: f64 = a.get(5).map(|x| x.parse().unwrap()).unwrap_or(0.0);
    let side = grid_side_for(n);
    let (v, f) = grid(side, 1.0);
    let mesh = Arc::new(Mesh::new(v, f).unwrap());
    let p = state.deformation(side).apply(mesh.rest());
    let opts = DetectorOptions {
        thickness: thickness * mesh.mean_edge_length(),
        ..Default::default()
    };
    let mut d = new_detector(mesh, method, &opts).unwrap();
    let (mut refit, mut trav, mut last) = (f64::MAX, f64::MAX, None);
    for _ in 0..reps {
        let s = d.detect(&p).unwrap().stats;
        refit = refit.min(s.refit_time);
        trav = trav.min(s.traverse_time);
        last = Some(s);
    }
    let s = last.unwrap();
    println!(
        "best refit {:.3} ms, best traverse {:.3} ms; node pairs {}, contour tests {}, primitive tests {}, contacts {}, proximity tests {}, proximity contacts {}",
        refit * 1e3, trav * 1e3, s.node_pairs, s.contour_tests, s.primitive_tests, s.contacts, s.proximity_tests, s.proximity_contacts
    );
}
