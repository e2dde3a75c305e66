//! Times the cloth's implicit solve alone, block-Jacobi against the multigrid
//! V-cycle and the two-level form, on
//! the same system in one process.
//!
//! ```text
//! cargo run --release -p selfcd --example cloth_solve -- [scene] [n] [warmup] [repeat] [which]
//! ```
//! which: block-jacobi | multigrid | two-level | all (default): the preconditioners
//! timed. One alone, with the repeat at 1 and 3, gives the instructions of
//! one solve under callgrind as the difference over 2.
//! Steps `scene` (default center) at `n x n` vertices (default 101) for
//! `warmup` steps (default 30), assembles that state's system (pins in the
//! filter, no contacts), and solves it `repeat` times (default 10) with each
//! preconditioner, warm-started from the last step's velocity change as the
//! simulation does. Prints iterations, the minimum time per solve, and the
//! multigrid's build and per-step update times. Solves run on rayon's pool, as
//! in the simulator's step. Each solve's error is given in
//! the energy norm, `|dv - dv*|_A / |dv*|_A`, against a multigrid solve to
//! 1e-10; `TOL=...` sets the tolerance of the timed solves (default 1e-3).
//!
//! `DUMP=FILE` also writes the system for outside study
//! (`scripts/solve_amg.py` reads it), as little-endian f64s: the rows n and
//! links m; each row's diagonal block (9, row-major); each link's two rows
//! and block (2 + 9); b, the warm start and the positions (3 per row); and
//! 1 for each pinned row, else 0.

use glam::DVec3;
use selfcd::cloth::multigrid::Multigrid;
use selfcd::cloth::solver::{Filter, Pcg, System};
use selfcd::cloth::{PaperScene, PcgOptions, Preconditioner};
use selfcd::detect::Method;
use std::process::ExitCode;
use std::time::Instant;

#[path = "common/allocator.rs"]
mod allocator;
#[path = "common/args.rs"]
mod args;
use args::{arg, exit_status};
fn main() -> ExitCode {
    exit_status(run())
}

/// Minimum wall-clock seconds of `f` over `repeat` runs, and its last result.
fn min_time<T>(repeat: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeat.max(1) {
        let t0 = Instant::now();
        out = Some(f());
        best = best.min(t0.elapsed().as_secs_f64());
    }
    (best, out.expect("at least one run"))
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene: PaperScene = args
        .first()
        .map(|s| s.parse())
        .transpose()
        .map_err(|e| format!("{e}"))?
        .unwrap_or(PaperScene::Center);
    let n: usize = arg(&args, 1, 101)?;
    let warmup: usize = arg(&args, 2, 30)?;
    let repeat: usize = arg(&args, 3, 10)?;
    let which: String = arg(&args, 4, "all".to_string())?;
    let kinds = match which.as_str() {
        "block-jacobi" => vec![Preconditioner::BlockJacobi],
        "multigrid" => vec![Preconditioner::Multigrid],
        "two-level" => vec![Preconditioner::TwoLevel],
        "all" => vec![
            Preconditioner::BlockJacobi,
            Preconditioner::Multigrid,
            Preconditioner::TwoLevel,
        ],
        other => return Err(format!("unknown preconditioner {other:?}")),
    };
    let mut sim = scene
        .simulation(n, Method::BvhConesContour)
        .map_err(|e| e.to_string())?;
    let mut v_prev = sim.velocities().to_vec();
    for _ in 0..warmup {
        v_prev = sim.velocities().to_vec();
        sim.step().map_err(|e| e.to_string())?;
    }
    let cloth = sim.cloth();
    let h = sim.options().dt;
    let mut system = System::new(cloth);
    let (assemble, ()) = min_time(repeat, || {
        system.assemble(cloth, sim.positions(), sim.velocities(), h)
    });
    let filter = Filter::new(cloth.pinned());
    let start: Vec<DVec3> = sim
        .velocities()
        .iter()
        .zip(&v_prev)
        .map(|(v, p)| *v - *p)
        .collect();
    println!(
        "scene {scene} n {n} ({} triangles) after {warmup} steps, threads {}, repeat {repeat}: assembly {:.3} ms",
        cloth.mesh().n_triangles(),
        rayon::current_num_threads(),
        assemble * 1e3
    );
    // Reference: the multigrid PCG run to 1e-10.
    let mut exact = start.clone();
    let tight = PcgOptions {
        tolerance: 1e-10,
        max_iterations: 2000,
        ..PcgOptions::default()
    };
    Pcg::default().solve(&system.a, &system.b, &filter, &mut exact, tight);
    let energy = |e: &[DVec3]| {
        let mut ae = vec![DVec3::ZERO; e.len()];
        system.a.mul(e, &mut ae);
        e.iter().zip(&ae).map(|(x, y)| x.dot(*y)).sum::<f64>()
    };
    let norm = energy(&exact).sqrt();
    if let Ok(path) = std::env::var("DUMP") {
        dump(&path, &system, &start, sim.positions(), cloth.pinned())?;
    }
    let tolerance: f64 = std::env::var("TOL")
        .ok()
        .and_then(|x| x.parse().ok())
        .unwrap_or(1e-3);
    for &p in &kinds {
        let opts = PcgOptions {
            preconditioner: p,
            tolerance,
            ..PcgOptions::default()
        };
        let mut pcg = Pcg::default();
        let mut dv = start.clone();
        // The first solve builds the hierarchy; time the steady state.
        pcg.solve(&system.a, &system.b, &filter, &mut dv, opts);
        // On rayon's pool, as the simulator's step runs it.
        let (t, stats) = min_time(repeat, || {
            dv.copy_from_slice(&start);
            rayon::scope(|_| pcg.solve(&system.a, &system.b, &filter, &mut dv, opts))
        });
        let error: Vec<DVec3> = dv.iter().zip(&exact).map(|(a, b)| *a - *b).collect();
        println!(
            "{p:?}: {} iterations, residual {:.1e}, relative energy-norm error {:.1e}, solve {:.3} ms ({:.3} ms per iteration)",
            stats.iterations,
            stats.residual,
            energy(&error).sqrt() / norm,
            t * 1e3,
            t * 1e3 / stats.iterations.max(1) as f64
        );
    }
    if kinds.len() < 2 {
        return Ok(());
    }
    let (build, mut mg) = min_time(repeat, || Multigrid::new(&system.a, true));
    let (update, ()) = min_time(repeat, || mg.update(&system.a));
    println!(
        "multigrid: {} levels {:?}, build {:.3} ms, update per step {:.3} ms",
        mg.depth(),
        mg.sizes(),
        build * 1e3,
        update * 1e3
    );
    Ok(())
}

/// Writes the system to `path` in the module doc's layout.
fn dump(
    path: &str,
    system: &System,
    start: &[DVec3],
    x: &[DVec3],
    pinned: &[bool],
) -> Result<(), String> {
    let a = &system.a;
    let mut out = vec![a.rows() as f64, a.ends().len() as f64];
    for d in &a.diag {
        out.extend(d.transpose().to_cols_array());
    }
    for (e, l) in a.ends().iter().zip(&a.link) {
        out.extend([f64::from(e[0]), f64::from(e[1])]);
        out.extend(l.mat().transpose().to_cols_array());
    }
    for v in system.b.iter().chain(start).chain(x) {
        out.extend(v.to_array());
    }
    out.extend(pinned.iter().map(|&p| f64::from(u8::from(p))));
    let bytes: Vec<u8> = out.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(path, bytes).map_err(|e| format!("cannot write {path}: {e}"))
}
