//! Criterion benchmarks of the engine (issue 2): mesh validation and topology,
//! BVH build, refit, one detection (refit + traversal + narrow phase) per
//! size, state and method, and the one-shot query (issue 10: `Mesh::new` +
//! `self_intersections`, what a mesh checker calls).
//!
//! The contour test's loop checks alone (`loop2d`, issue 10 item 2) on
//! wavy rings of 12 to 400 edges listed in a scrambled order, as patch
//! contours are (sorted by edge id, not along the loop).
//!
//! `cargo bench -p selfcd --bench detect` (filter with e.g. `-- 200000`).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use selfcd::bvh::build::build;
use selfcd::geom::loop2d::{simple_ccw_loop, simple_ccw_loop_slack, LoopScratch, Seg};
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

/// A ring of `m` edges with a 5-fold wave (simple, not convex), its edges
/// listed in a scrambled order, and the length of its edges.
fn wavy_ring(m: usize) -> (Vec<Seg>, f64) {
    let at = |k: usize| {
        let a = std::f64::consts::TAU * k as f64 / m as f64;
        let r = 1.0 + 0.2 * (5.0 * a).sin();
        [r * a.cos(), r * a.sin()]
    };
    let mut segs: Vec<Seg> = (0..m)
        .map(|k| Seg {
            p: [at(k), at((k + 1) % m)],
            v: [k as u32, ((k + 1) % m) as u32],
        })
        .collect();
    for k in (1..m).rev() {
        segs.swap(k, (k * 7919 + 13) % (k + 1));
    }
    (segs, std::f64::consts::TAU / m as f64)
}

/// The loop tests; the slack's cap at a quarter and at one edge length (the
/// cap is a quarter of the mean 3-D edge, and projected contours of tilted
/// patches have shorter edges: there the cap reaches farther).
fn bench_loops(c: &mut Criterion) {
    let mut g = c.benchmark_group("loop2d");
    g.measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300));
    let mut scratch = LoopScratch::default();
    for m in [12, 40, 120, 400] {
        let (segs, edge) = wavy_ring(m);
        g.bench_with_input(BenchmarkId::new("simple_ccw_loop", m), &segs, |b, s| {
            b.iter(|| simple_ccw_loop(s, &mut scratch))
        });
        for (name, cap) in [
            ("slack_cap_quarter_edge", 0.25 * edge),
            ("slack_cap_one_edge", edge),
        ] {
            assert!(simple_ccw_loop_slack(&segs, &mut scratch, cap).is_some());
            g.bench_with_input(BenchmarkId::new(name, m), &segs, |b, s| {
                b.iter(|| simple_ccw_loop_slack(s, &mut scratch, cap))
            });
        }
    }
    g.finish();
}

criterion_group!(
    benches,
    bench_build_refit,
    bench_detect,
    bench_one_shot,
    bench_loops
);
criterion_main!(benches);
