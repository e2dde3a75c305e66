//! Profiling helper on a mesh file: build time, then repeated detections.
//! `cargo run --release -p selfcd --example objprof -- FILE.obj METHOD [REPS]`
use selfcd::detect::hierarchy::BvhDetector;
use selfcd::{Detector, Mesh, Method};
use std::sync::Arc;
use std::time::Instant;

fn read_obj(path: &str) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let text = std::fs::read_to_string(path).expect("readable OBJ");
    let (mut v, mut f) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f64> = it.take(3).map(|x| x.parse().unwrap()).collect();
                v.push([c[0], c[1], c[2]]);
            }
            Some("f") => {
                let c: Vec<u32> = it
                    .map(|x| x.split('/').next().unwrap().parse::<u32>().unwrap() - 1)
                    .collect();
                for k in 1..c.len() - 1 {
                    f.push([c[0], c[k], c[k + 1]]);
                }
            }
            _ => {}
        }
    }
    (v, f)
}

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
