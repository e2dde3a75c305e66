//! Scaling benchmark: grid cloths of 200, 20k and 200k triangles, flat /
//! crumpled / folded, every BVH method (and brute force up to 20k).
//! Arguments ending in `.obj` are real meshes instead: for each, the build,
//! the one-shot query (build + detect) and, per BVH method, one frame
//! (refit + query) with its counters, medians over repetitions.
//!
//! `cargo run --release -p selfcd --example scaling [-- SIZES... | FILES.obj...]`

use selfcd::bench::{markdown, scaling};
use selfcd::bvh::build::build;
use selfcd::scene::BenchState;
use selfcd::{new_detector, DetectorOptions, Mesh, Method};
use std::sync::Arc;
use std::time::Instant;

#[path = "common/obj.rs"]
mod obj;
use obj::read_obj;

fn main() -> selfcd::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let objs: Vec<&String> = args.iter().filter(|a| a.ends_with(".obj")).collect();
    if !objs.is_empty() {
        for path in objs {
            real_mesh(path)?;
        }
        return Ok(());
    }
    let args: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    let sizes = if args.is_empty() {
        vec![200, 20_000, 200_000]
    } else {
        args
    };
    let mut rows = Vec::new();
    for &size in &sizes {
        let methods: Vec<Method> = Method::ALL
            .into_iter()
            .filter(|&m| m != Method::Brute || size <= 20_000)
            .collect();
        let reps = if size >= 100_000 { 5 } else { 11 };
        rows.extend(scaling(&[size], &BenchState::ALL, &methods, reps, |r| {
            eprintln!(
                "{} {} {}: {:.3} ms",
                r.triangles,
                r.state.name(),
                r.method,
                (r.refit_time + r.traverse_time) * 1e3
            )
        })?);
    }
    println!("{}", markdown(&rows));
    Ok(())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// One real mesh at its rest shape: build, one-shot, and per-frame rows.
fn real_mesh(path: &str) -> selfcd::Result<()> {
    let (v, f) = read_obj(path);
    let mesh = Arc::new(Mesh::new(v, f)?);
    let p = mesh.rest().to_vec();
    let reps = 7;
    let build_ms = median(
        (0..reps)
            .map(|_| {
                let t0 = Instant::now();
                let b = build(&mesh);
                let t = t0.elapsed().as_secs_f64();
                drop(b);
                t * 1e3
            })
            .collect(),
    );
    let oneshot_ms = median(
        (0..reps)
            .map(|_| {
                let t0 = Instant::now();
                let n = selfcd::self_intersections(&mesh, &p).unwrap().len();
                std::hint::black_box(n);
                t0.elapsed().as_secs_f64() * 1e3
            })
            .collect(),
    );
    let bytes = build(&mesh).memory_bytes() as f64 / mesh.n_triangles() as f64;
    println!(
        "{path}: {} triangles, build {build_ms:.2} ms, one-shot {oneshot_ms:.2} ms, {bytes:.0} B/tri",
        mesh.n_triangles()
    );
    for method in [Method::Bvh, Method::BvhCones, Method::BvhConesContour] {
        let mut det = new_detector(mesh.clone(), method, &DetectorOptions::default())?;
        let mut last = det.detect(&p)?.stats;
        let mut t = Vec::new();
        for _ in 0..reps {
            let t0 = Instant::now();
            last = det.detect(&p)?.stats;
            t.push(t0.elapsed().as_secs_f64() * 1e3);
        }
        println!(
            "  {method}: frame {:.2} ms; node pairs {}, culls {}, contour tests {}, primitive tests {} ({} by the filter), contacts {}",
            median(t),
            last.node_pairs,
            last.self_culls + last.pair_culls,
            last.contour_tests,
            last.primitive_tests,
            last.filter_decisions,
            last.contacts
        );
    }
    Ok(())
}
