//! Steps one of the paper's cloth scenes and reports step time, broken down.
//!
//! ```text
//! cargo run --release -p selfcd --example cloth -- [scene] [n] [steps] [method] [warmup]
//! ```
//! scene: two-corners | corner | center (default center); n: vertices per side
//! (default 11); steps: timed steps (default 600); method: detection method
//! (default bvh-cones-contour); warmup: steps run before timing (default 0).
//! `CLOTH_PRECONDITIONER=block-jacobi|multigrid|two-level` overrides the preconditioner
//! the simulator picks by size (`Preconditioner::for_vertices`).
//! `CLOTH_TRACE=1` prints one line a step: its stages' times and what the
//! queries did (where a scene's time goes as it falls, folds and settles).
//! The last
//! line is a checksum of the final positions' bits: the same for any number
//! of threads.

use selfcd::cloth::{Material, PaperScene, Preconditioner, SimOptions, Simulation};
use selfcd::detect::Method;
use std::process::ExitCode;

#[path = "common/allocator.rs"]
mod allocator;
#[path = "common/args.rs"]
mod args;
use args::{arg, exit_status};
#[path = "common/checksum.rs"]
#[allow(dead_code)]
mod checksum;
fn main() -> ExitCode {
    exit_status(run())
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene: PaperScene = args
        .first()
        .map(|s| s.parse())
        .transpose()
        .map_err(|e| format!("{e}"))?
        .unwrap_or(PaperScene::Center);
    let n: usize = arg(&args, 1, 11)?;
    let steps: usize = arg(&args, 2, 600)?;
    let method: Method = args
        .get(3)
        .map(|s| s.parse())
        .transpose()
        .map_err(|e| format!("{e}"))?
        .unwrap_or(Method::BvhConesContour);
    let warmup: usize = arg(&args, 4, 0)?;
    let cloth = scene
        .cloth(n, Material::default())
        .map_err(|e| e.to_string())?;
    let mut opts = SimOptions::for_cloth(&cloth);
    opts.pcg.preconditioner = match std::env::var("CLOTH_PRECONDITIONER").as_deref() {
        Ok("block-jacobi") => Preconditioner::BlockJacobi,
        Ok("multigrid") => Preconditioner::Multigrid,
        Ok("two-level") => Preconditioner::TwoLevel,
        Err(_) => opts.pcg.preconditioner,
        Ok(other) => return Err(format!("unknown preconditioner {other:?}")),
    };
    let mut sim = Simulation::new(cloth, method, opts).map_err(|e| e.to_string())?;
    let tris = sim.cloth().mesh().n_triangles();
    for _ in 0..warmup {
        sim.step().map_err(|e| e.to_string())?;
    }
    let (mut step, mut solve, mut detect, mut response) = (0.0, 0.0, 0.0, 0.0);
    let (mut proximity, mut continuous, mut ccd_rounds) = (0.0, 0.0, 0u64);
    let (mut iters, mut contacts, mut in_zones, mut rounds, mut worst) =
        (0u64, 0usize, 0usize, 0u32, 0.0f64);
    let mut intersections = 0;
    let (mut builds, mut reuses, mut one_shots) = (0u64, 0u64, 0u64);
    let (mut node_pairs, mut leaf_tests) = (0u64, 0u64);
    let (mut repeats, mut proved, mut from_proximity) = (0u64, 0u64, 0u64);
    let (mut fit_time, mut query_time, mut candidates) = (0.0, 0.0, 0u64);
    let trace = std::env::var_os("CLOTH_TRACE").is_some_and(|x| x == "1");
    for k in 0..steps {
        let st = sim.step().map_err(|e| e.to_string())?;
        step += st.step_time;
        solve += st.solve_time;
        detect += st.detect_time;
        proximity += st.proximity_time;
        continuous += st.continuous_time;
        ccd_rounds += st.ccd_rounds as u64;
        response += st.response_time;
        iters += st.iterations as u64;
        contacts += st.contacts;
        in_zones += st.reverted;
        rounds += st.correction_rounds;
        intersections += st.intersections;
        builds += st.detection.candidate_builds;
        reuses += st.detection.candidate_reuses;
        one_shots += st.detection.proximity_one_shots;
        repeats += st.detection.continuous_repeats;
        from_proximity += st.detection.continuous_from_proximity;
        proved += st.proved_clear as u64;
        node_pairs += st.detection.node_pairs;
        leaf_tests += st.detection.proximity_tests;
        fit_time += st.detection.refit_time;
        query_time += st.detection.traverse_time;
        candidates += st.detection.candidates;
        worst = worst.max(st.step_time);
        if trace {
            let d = &st.detection;
            println!(
                "step {k} ms: proximity {:.2} continuous {:.2} ({} rounds) solve {:.2} ({} iterations) response {:.2}; contacts {}, one-shot answers {}, set queries {}, set builds {}, node pairs {}, leaf pairs {}",
                st.proximity_time * 1e3,
                st.continuous_time * 1e3,
                st.ccd_rounds,
                st.solve_time * 1e3,
                st.iterations,
                st.response_time * 1e3,
                st.contacts,
                d.proximity_one_shots,
                d.candidate_reuses,
                d.candidate_builds,
                d.node_pairs,
                d.proximity_tests
            );
        }
        if std::env::var_os("CLOTH_VERBOSE").is_some() && k % 30 == 0 {
            let e = sim.energy();
            println!(
                "step {k:5} t {:6.2}s it {:3} res {:.1e} contacts {:5} constrained {:4} impulses {:5} zone vertices {:4} rounds {} step {:.2} ms E {:.4} (kin {:.4} grav {:.4} elastic {:.4}) zmin {:.3}",
                sim.time(), st.iterations, st.residual, st.contacts, st.constrained, st.impulses, st.reverted, st.correction_rounds, st.step_time * 1e3, e.total(), e.kinetic, e.gravity, e.elastic, sim.positions().iter().map(|p| p.z).fold(f64::INFINITY, f64::min)
            );
        }
    }
    let s = steps.max(1) as f64;
    let ms = |x: f64| x / s * 1e3;
    println!(
        "scene {scene} n {n} ({tris} triangles) method {method} threads {} steps {steps} (after {warmup} warm-up) preconditioner {:?}",
        rayon::current_num_threads(),
        opts.pcg.preconditioner
    );
    println!(
        "mean step {:.3} ms ({:.1} steps/s): solve {:.3} ms, detection {:.3} ms, response {:.3} ms; worst step {:.3} ms",
        ms(step),
        s / step,
        ms(solve),
        ms(detect),
        ms(response),
        worst * 1e3
    );
    println!(
        "detection: proximity {:.3} ms, continuous {:.3} ms ({:.2} rounds/step), intersection checks {:.3} ms",
        ms(proximity),
        ms(continuous),
        ccd_rounds as f64 / s,
        ms((detect - proximity - continuous).max(0.0))
    );
    println!(
        "mean CG iterations {:.1}, contacts/step {:.1}, vertices in impact zones {in_zones}, correction detections/step {:.2} (steps proved clear by the continuous stage {proved}), intersections left {intersections}",
        iters as f64 / s,
        contacts as f64 / s,
        rounds as f64 / s
    );
    println!(
        "candidate sets built {builds}, queries answered from a cached set {reuses}, proximity queries answered one-shot {one_shots}, continuous repeats re-tested around changed vertices {repeats}, continuous queries from the proximity answer {from_proximity}; per step: node pairs {:.0}, leaf pairs tested by proximity and continuous queries {:.0}",
        node_pairs as f64 / s,
        leaf_tests as f64 / s
    );
    println!(
        "self queries per step: fitting (hierarchy, displacement boxes) {:.3} ms, traversals and tests {:.3} ms, candidates examined {:.0}",
        ms(fit_time),
        ms(query_time),
        candidates as f64 / s
    );
    let bits = sim.positions().iter().flat_map(|p| p.to_array());
    let sum = checksum::fnv(checksum::START, bits.map(f64::to_bits));
    println!("final positions checksum {sum:016x}");
    Ok(())
}
