//! Criterion benchmarks of the engine (issue 2): mesh validation and topology,
//! BVH build, refit, one detection (refit + traversal + narrow phase) per
//! size, state and method, and the one-shot query (issue 10: `Mesh::new` +
//! `self_intersections`, what a mesh checker calls).
//!
//! `cargo bench -p selfcd --bench detect` (filter with e.g. `-- 200000`).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use selfcd::bvh::build::build;
use selfcd::scene::{grid, grid_side_for, BenchState};
use selfcd::{new_detector, DetectorOptions, Mesh, Method};
use std::sync::Arc;
use std::time::Duration;

const SIZES: [usize; 3] = [200, 20_000, 200_000];

fn mesh(size: usize) -> (Arc<Mesh>, usize) {
    let side = grid_side_for(size);
    let (v, f) = grid(side, 1.0);
    (Arc::new(Mesh::new(v, f).unwrap()), side)
}

fn bench_build_refit(c: &mut Criterion) {
    let mut g = c.benchmark_group("bvh");
    g.sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    for size in SIZES {
        let (m, side) = mesh(size);
        let (v, f) = grid(side, 1.0);
        g.bench_function(BenchmarkId::new("mesh_new", size), |b| {
            b.iter(|| Mesh::new(v.clone(), f.clone()).unwrap())
        });
        g.bench_with_input(BenchmarkId::new("build", size), &m, |b, m| {
            b.iter(|| build(m))
        });
        let mut bvh = build(&m);
        let p = BenchState::Crumpled.deformation(side).apply(m.rest());
        g.bench_with_input(BenchmarkId::new("refit", size), &p, |b, p| {
            b.iter(|| bvh.refit(&m, p))
        });
    }
    g.finish();
}

fn bench_detect(c: &mut Criterion) {
    let mut g = c.benchmark_group("detect");
    g.sample_size(10)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500));
    for size in SIZES {
        let (m, side) = mesh(size);
        for state in BenchState::ALL {
            let p = state.deformation(side).apply(m.rest());
            for method in [Method::Bvh, Method::BvhCones, Method::BvhConesContour] {
                let mut det = new_detector(m.clone(), method, &DetectorOptions::default()).unwrap();
                let id = BenchmarkId::new(format!("{}/{}", state.name(), method), size);
                g.bench_function(id, |b| b.iter(|| det.detect(&p).unwrap()));
            }
        }
    }
    g.finish();
}

fn bench_one_shot(c: &mut Criterion) {
    let mut g = c.benchmark_group("one_shot");
    g.sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    for size in SIZES {
        let side = grid_side_for(size);
        let (v, f) = grid(side, 1.0);
        let rest: Vec<_> = v.iter().map(|p| selfcd::DVec3::from_array(*p)).collect();
        for state in BenchState::ALL {
            let at: Vec<[f64; 3]> = state
                .deformation(side)
                .apply(&rest)
                .iter()
                .map(|p| p.to_array())
                .collect();
            let id = BenchmarkId::new(state.name(), size);
            g.bench_function(id, |b| {
                b.iter(|| {
                    let m = Arc::new(Mesh::new(at.clone(), f.clone()).unwrap());
                    selfcd::self_intersections(&m, m.rest()).unwrap()
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench_build_refit, bench_detect, bench_one_shot);
criterion_main!(benches);
