//! Times the cloth's response stages alone on one real contact set: the
//! contacts' gathering (`response::gather`) and the impulse stage
//! (`response::impulses`, the Gauss-Seidel sweeps over them).
//!
//! ```text
//! cargo run --release -p selfcd --example cloth_response -- [scene] [n] [warmup] [repeat]
//! ```
//! Steps `scene` (default center) at `n x n` vertices (default 101) for
//! `warmup` steps (default 150), gathers the contacts of that state as the
//! step does (the proximity query within the detection distance), and runs
//! each stage `repeat` times (default 10), the impulses from the state's
//! velocities plus one step of gravity, each time from the same input.
//! Prints the contacts, what the impulses did, the minimum times, and a
//! checksum of the resulting velocities' bits (equal for any number of
//! threads and across changes that keep the arithmetic).

use selfcd::cloth::response::{self, ContactParams};
use selfcd::cloth::{Material, PaperScene, SimOptions, Simulation};
use selfcd::detect::{proximity_contacts, Method};
use std::process::ExitCode;
use std::time::Instant;

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
    let scene: PaperScene = arg(&args, 0, PaperScene::Center)?;
    let n: usize = arg(&args, 1, 101)?;
    let warmup: usize = arg(&args, 2, 150)?;
    let repeat: usize = arg(&args, 3, 10)?;
    let cloth = scene
        .cloth(n, Material::default())
        .map_err(|e| e.to_string())?;
    let opts = SimOptions::for_cloth(&cloth);
    let mut sim =
        Simulation::new(cloth, Method::BvhConesContour, opts).map_err(|e| e.to_string())?;
    for _ in 0..warmup {
        sim.step().map_err(|e| e.to_string())?;
    }
    let (mesh, x) = (sim.cloth().mesh().clone(), sim.positions().to_vec());
    let p: ContactParams = opts.contact;
    let (near, _) = proximity_contacts(&mesh, &x, p.detection_distance(), usize::MAX)
        .map_err(|e| e.to_string())?;
    let (mut gather, mut contacts) = (f64::INFINITY, Vec::new());
    for _ in 0..repeat.max(1) {
        drop(contacts);
        let t0 = Instant::now();
        contacts = response::gather(&mesh, &x, &near);
        gather = gather.min(t0.elapsed().as_secs_f64());
    }
    let inv_mass = sim.cloth().inverse_masses();
    let h = opts.dt;
    let g = sim.cloth().gravity();
    let v0: Vec<_> = (sim.velocities().iter().zip(&inv_mass))
        .map(|(v, &w)| if w > 0.0 { *v + g * h } else { *v })
        .collect();
    // The simulator's: a contact with an obstacle's vertex (none here) has its own.
    let n = x.len();
    let mu = |c: &response::Contact| {
        if c.verts.iter().any(|&k| k as usize >= n) {
            p.obstacle_friction
        } else {
            p.friction
        }
    };
    let (mut best, mut v, mut stats) = (f64::INFINITY, v0.clone(), None);
    for _ in 0..repeat.max(1) {
        v.copy_from_slice(&v0);
        let t0 = Instant::now();
        stats = Some(response::impulses(&contacts, &inv_mass, &mut v, &p, h, mu));
        best = best.min(t0.elapsed().as_secs_f64());
    }
    let bits = v.iter().flat_map(|p| p.to_array()).map(f64::to_bits);
    println!(
        "scene {scene} n {n} after {warmup} steps, threads {}: {} contacts; best of {repeat}: gather {:.3} ms, impulses {:.3} ms ({:?}); velocities checksum {:016x}",
        rayon::current_num_threads(),
        contacts.len(),
        gather * 1e3,
        best * 1e3,
        stats.unwrap_or_default(),
        checksum::fnv(checksum::START, bits)
    );
    Ok(())
}
