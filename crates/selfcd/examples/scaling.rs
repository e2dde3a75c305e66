//! Scaling benchmark: grid cloths of 200, 20k and 200k triangles, flat /
//! crumpled / folded, every BVH method (and brute force up to 20k).
//! Arguments ending in `.obj` are real meshes instead: for each, the build,
//! the one-shot query (build + detect) and, per BVH method, one frame
//! (refit + query) with its counters, medians over repetitions.
//!
//! With `oneshot` first, the one-shot query as a mesh checker calls it
//! (validation and topology, hierarchy, query; what `selfcd.self_intersections`
//! runs) on each input: grids of the given sizes (default 200k) in every
//! state, and `.obj` files; best of the repetitions, each phase timed apart.
//!
//! `cargo run --release -p selfcd --example scaling [-- SIZES... | FILES.obj...]`
//! `cargo run --release -p selfcd --example scaling -- oneshot [SIZES...] [FILES.obj...]`

use selfcd::bench::{markdown, scaling};
use selfcd::bvh::build::build;
use selfcd::scene::{grid, grid_side_for, BenchState};
use selfcd::{new_detector, DetectorOptions, Mesh, Method};
use std::sync::Arc;
use std::time::Instant;

#[path = "common/allocator.rs"]
mod allocator;
#[path = "common/obj.rs"]
mod obj;
use obj::read_obj;

fn main() -> selfcd::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("oneshot") {
        return one_shots(&args[1..]);
    }
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
    let mut bytes = 0.0;
    let build_ms = median(
        (0..reps)
            .map(|_| {
                let t0 = Instant::now();
                let (b, ..) = build(&mesh).depth_first(&mesh);
                let t = t0.elapsed().as_secs_f64();
                bytes = b.memory_bytes() as f64 / mesh.n_triangles() as f64;
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

/// The one-shot rows: every grid size in every state, then every file.
fn one_shots(args: &[String]) -> selfcd::Result<()> {
    let mut sizes: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    let files: Vec<&String> = args.iter().filter(|a| a.ends_with(".obj")).collect();
    if sizes.is_empty() && files.is_empty() {
        sizes.push(200_000);
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("load average at start: {}", load.trim());
    println!("| input | triangles | Mesh::new ms | build ms | one-shot ms | pairs |\n|---|---:|---:|---:|---:|---:|");
    for &size in &sizes {
        let side = grid_side_for(size);
        let (v, f) = grid(side, 1.0);
        for state in BenchState::ALL {
            let rest: Vec<selfcd::DVec3> =
                v.iter().map(|p| selfcd::DVec3::from_array(*p)).collect();
            let p = state.deformation(side).apply(&rest);
            let v: Vec<[f64; 3]> = p.iter().map(|x| x.to_array()).collect();
            one_shot(&format!("grid {}", state.name()), &v, &f)?;
        }
    }
    for path in files {
        let (v, f) = read_obj(path);
        let name = std::path::Path::new(path).file_stem().unwrap_or_default();
        one_shot(&name.to_string_lossy(), &v, &f)?;
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("load average at end: {}", load.trim());
    Ok(())
}

/// Best of 7: `Mesh::new`, `build` alone, and the whole one-shot (`Mesh::new`
/// + `self_intersections` at the mesh's own vertices).
fn one_shot(name: &str, v: &[[f64; 3]], f: &[[u32; 3]]) -> selfcd::Result<()> {
    let best = |mut run: Box<dyn FnMut() -> selfcd::Result<f64> + '_>| -> selfcd::Result<f64> {
        (0..7).try_fold(f64::INFINITY, |b, _| Ok(b.min(run()?)))
    };
    let timed = |t0: Instant| t0.elapsed().as_secs_f64() * 1e3;
    let new_ms = best(Box::new(|| {
        let (v, f) = (v.to_vec(), f.to_vec());
        let t0 = Instant::now();
        let m = Mesh::new(v, f)?;
        let t = timed(t0);
        drop(m);
        Ok(t)
    }))?;
    let mesh = Arc::new(Mesh::new(v.to_vec(), f.to_vec())?);
    let build_ms = best(Box::new(|| {
        let t0 = Instant::now();
        let b = build(&mesh);
        let t = timed(t0);
        drop(b);
        Ok(t)
    }))?;
    let mut pairs = 0;
    let total_ms = best(Box::new(|| {
        let (v, f) = (v.to_vec(), f.to_vec());
        let t0 = Instant::now();
        let m = Arc::new(Mesh::new(v, f)?);
        pairs = selfcd::self_intersections(&m, m.rest())?.len();
        let t = timed(t0);
        drop(m);
        Ok(t)
    }))?;
    println!(
        "| {name} | {} | {new_ms:.1} | {build_ms:.1} | {total_ms:.1} | {pairs} |",
        mesh.n_triangles()
    );
    Ok(())
}
