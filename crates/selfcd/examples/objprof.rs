//! Profiling helper on a mesh file: build time, then repeated detections.
//! `cargo run --release -p selfcd --example objprof -- FILE.obj METHOD [REPS]`
use selfcd::detect::hierarchy::BvhDetector;
use selfcd::{Detector, Mesh, Method};
use std::sync::Arc;
use std::time::Instant;

#[path = "common/obj.rs"]
mod obj;
use obj::read_obj;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let (v, f) = read_obj(&a[1]);
    let method: Method = a[2].parse().unwrap();
    let reps: usize = a.get(3).map(|x| x.parse().unwrap()).unwrap_or(20);
    let mesh = Arc::new(Mesh::new(v, f).unwrap());
    let p = mesh.rest().to_vec();
    let mut build = f64::MAX;
    for _ in 0..3 {
        let t = Instant::now();
        let d = BvhDetector::new(mesh.clone(), method, 0.0);
        build = build.min(t.elapsed().as_secs_f64());
        drop(d);
    }
    let mut d = BvhDetector::new(mesh.clone(), method, 0.0);
    let (mut refit, mut trav, mut last) = (f64::MAX, f64::MAX, None);
    for _ in 0..reps {
        let s = d.detect(&p).unwrap().stats;
        refit = refit.min(s.refit_time);
        trav = trav.min(s.traverse_time);
        last = Some(s);
    }
    let s = last.unwrap();
    println!(
        "{} tris: build {:.1} ms, refit {:.2} ms, traverse {:.2} ms; node pairs {}, contour tests {} (fail {}), primitive {}, contacts {}",
        mesh.n_triangles(), build * 1e3, refit * 1e3, trav * 1e3, s.node_pairs, s.contour_tests, s.contour_fails, s.primitive_tests, s.contacts
    );
}
