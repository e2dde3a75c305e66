//! Profiling helper: repeated detections of one frame, best times.
//!
//! `cargo run --release -p selfcd --example prof -- SIZE STATE METHOD [REPS] [THICKNESS in mean edges]`
//! (a benchmark grid, deformed), or
//! `cargo run --release -p selfcd --example prof -- FILE.obj METHOD [REPS] [THICKNESS in mean edges]`
//! (a mesh file at its own positions).
use selfcd::{new_detector, DetectorOptions, Method};
use std::time::Instant;

#[path = "common/input.rs"]
mod input;
#[path = "common/obj.rs"]
mod obj;
use input::frame;

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
