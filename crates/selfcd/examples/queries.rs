//! Proximity and continuous queries, fresh and coherent, best of REPS.
//!
//! ```text
//! cargo run --release -p selfcd --example queries -- SIZE STATE [REPS] [D] [SKIN]
//! cargo run --release -p selfcd --example queries -- FILE.obj [REPS] [D] [SKIN]
//! ```
//! A benchmark grid deformed to STATE, or a mesh file at its own positions.
//! D: proximity thickness and SKIN: the coherent candidate set's skin, both
//! in median edge lengths (defaults 0.6 and 0.25, as scripts/bench_peers.py:
//! d = 0.6 median edges, a continuous step of a 0.5-edge wave of wavelength
//! 16 edges, per-frame motion 0.05 edges).
//!
//! Rows: proximity fresh (refit + boxes-only traversal), one-shot
//! (`proximity_contacts`, its hierarchy built top-down), coherent first call
//! (candidate build) and coherent on a frame moved by the per-frame motion;
//! continuous fresh (kept hierarchy), one-shot (`continuous_impacts`) and
//! coherent on the wave step and on a step that does not move. Each
//! coherent row says whether it reused the candidate set. With
//! `QUERIES_ONESHOT=1` only the proximity one-shot row runs, with
//! `QUERIES_CONTINUOUS=1` only the continuous one-shot on the wave step
//! (both for profiling).
use selfcd::bvh::traverse::{self_traverse_parts, TraverseOptions};
use selfcd::bvh::{build::build, Bvh};
use selfcd::detect::coherent::SelfQueries;
use selfcd::detect::continuous::continuous_impacts;
use selfcd::detect::hierarchy::BvhDetector;
use selfcd::detect::narrow::{collect_proximity_parts, Proximity, DEFAULT_MAX_CONTACTS};
use selfcd::detect::proximity_contacts;
use selfcd::{DVec3, FrameStats, Mesh, Method};
use std::time::Instant;

#[path = "common/allocator.rs"]
mod allocator;
#[path = "common/input.rs"]
mod input;
#[path = "common/obj.rs"]
mod obj;
use input::frame;

/// Median edge length at positions `x`.
fn median_edge(mesh: &Mesh, x: &[DVec3]) -> f64 {
    let mut l: Vec<f64> = mesh
        .topology()
        .edges
        .iter()
        .map(|&[a, b]| (x[a as usize] - x[b as usize]).length())
        .collect();
    l.sort_by(f64::total_cmp);
    l[l.len() / 2]
}

/// scripts/bench_peers.py's `wave`: each coordinate a sine of the next one.
fn wave(x: &[DVec3], amplitude: f64, wavelength: f64, phase: f64) -> Vec<DVec3> {
    let k = 2.0 * std::f64::consts::PI / wavelength;
    x.iter()
        .map(|p| {
            *p + amplitude
                * DVec3::new(
                    (k * p.y + phase).sin(),
                    (k * p.z + phase + 1.0).sin(),
                    (k * p.x + phase + 2.0).sin(),
                )
        })
        .collect()
}

/// Best wall time (ms) of `reps` runs of `f`, and its last result.
fn best<T>(reps: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut t = f64::INFINITY;
    let mut out = None;
    for _ in 0..reps.max(1) {
        let t0 = Instant::now();
        out = Some(f());
        t = t.min(t0.elapsed().as_secs_f64() * 1e3);
    }
    (t, out.unwrap())
}

fn fresh_proximity(bvh: &mut Bvh, mesh: &Mesh, x: &[DVec3], d: f64) -> usize {
    bvh.refit(mesh, x);
    let near = Proximity::new(mesh, x, d, DEFAULT_MAX_CONTACTS);
    let opts = TraverseOptions {
        cones: false,
        contour: false,
        gap: d,
    };
    let (parts, _) = self_traverse_parts(bvh, mesh, x, opts, &near);
    let c = collect_proximity_parts(parts);
    c.vertex_triangle.len() + c.edge_edge.len()
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let (mesh, x, rest) = frame(&a);
    let reps: usize = rest.first().map_or(5, |s| s.parse().unwrap());
    let d_edges: f64 = rest.get(1).map_or(0.6, |s| s.parse().unwrap());
    let skin_edges: f64 = rest.get(2).map_or(0.25, |s| s.parse().unwrap());
    let e = median_edge(&mesh, &x);
    let d = d_edges * e;
    let moved = wave(&x, 0.05 * e, 16.0 * e, 0.7);
    let step = wave(&x, 0.5 * e, 16.0 * e, 0.3);
    println!(
        "{} triangles, median edge {e:.4e}, d {d_edges} edges, skin {skin_edges} edges, threads {}, best of {reps}",
        mesh.n_triangles(),
        rayon::current_num_threads()
    );

    if std::env::var_os("QUERIES_CONTINUOUS").is_some() {
        let (ms, (n, c)) = best(reps, || {
            let (i, c) = continuous_impacts(&mesh, &x, &step, 0.0).unwrap();
            (i.vertex_triangle.len() + i.edge_edge.len(), c)
        });
        println!(
            "continuous one-shot, wave step   {ms:9.3} ms  {n} pairs ({} certificates tried, {} failed, {} node pairs, {} triangle pairs, {} decided by the filters)",
            c.contour_tests, c.contour_fails, c.node_pairs, c.primitive_tests, c.filter_decisions
        );
        return;
    }
    let only_one_shot = std::env::var_os("QUERIES_ONESHOT").is_some();
    let mut bvh = build(&mesh);
    if !only_one_shot {
        let (ms, n) = best(reps, || fresh_proximity(&mut bvh, &mesh, &x, d));
        println!("proximity fresh                 {ms:9.3} ms  {n} pairs");
    }
    let (ms, (n, c)) = best(reps, || {
        let (p, c) = proximity_contacts(&mesh, &x, d, DEFAULT_MAX_CONTACTS).unwrap();
        (p.vertex_triangle.len() + p.edge_edge.len(), c)
    });
    println!(
        "proximity one-shot              {ms:9.3} ms  {n} pairs ({} node pairs, {} triangle pairs)",
        c.node_pairs, c.primitive_tests
    );
    if only_one_shot {
        return;
    }
    let coherent = || SelfQueries::new(mesh.clone(), skin_edges * e).unwrap();
    let count = |c: &selfcd::detect::ProximityContacts| c.vertex_triangle.len() + c.edge_edge.len();
    let (ms, (n, s)) = best(reps, || {
        let mut q = coherent();
        let mut s = FrameStats::default();
        let c = q.proximity(&x, d, &mut s).unwrap();
        (count(&c), s)
    });
    println!(
        "proximity coherent, first call {ms:9.3} ms  {n} pairs (incl. hierarchy build; {} candidates)",
        s.candidates
    );
    let mut q = coherent();
    q.proximity(&x, d, &mut FrameStats::default()).unwrap();
    let (ms, (n, s)) = best(reps, || {
        let mut s = FrameStats::default();
        let c = q.proximity(&moved, d, &mut s).unwrap();
        (count(&c), s)
    });
    println!(
        "proximity coherent, next frame {ms:9.3} ms  {n} pairs (reused {}, built {})",
        s.candidate_reuses, s.candidate_builds
    );

    let mut det = BvhDetector::new(mesh.clone(), Method::Bvh, 0.0);
    for (name, x1) in [("wave step", &step), ("no motion", &x)] {
        let (ms, n) = best(reps, || {
            let i = det.continuous(&x, x1, 0.0).unwrap();
            i.vertex_triangle.len() + i.edge_edge.len()
        });
        println!("continuous fresh, {name:9}      {ms:9.3} ms  {n} pairs");
        let (ms, (n, c)) = best(reps, || {
            let (i, c) = continuous_impacts(&mesh, &x, x1, 0.0).unwrap();
            (i.vertex_triangle.len() + i.edge_edge.len(), c)
        });
        println!(
            "continuous one-shot, {name:9}   {ms:9.3} ms  {n} pairs ({} certificates tried, {} failed, {} node pairs, {} triangle pairs)",
            c.contour_tests, c.contour_fails, c.node_pairs, c.primitive_tests
        );
        let (ms, (n, s)) = best(reps, || {
            let mut s = FrameStats::default();
            let i = q.continuous(&x, x1, 0.0, &mut s).unwrap();
            (i.vertex_triangle.len() + i.edge_edge.len(), s)
        });
        println!(
            "continuous coherent, {name:9}   {ms:9.3} ms  {n} pairs (reused {}, built {})",
            s.candidate_reuses, s.candidate_builds
        );
    }
}
