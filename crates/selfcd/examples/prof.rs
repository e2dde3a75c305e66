//! Profiling helper: repeated detections of one frame, best times.
//!
//! `cargo run --release -p selfcd --example prof -- SIZE STATE METHOD [REPS] [THICKNESS in mean edges]`
//! (a benchmark grid, deformed), or
//! `cargo run --release -p selfcd --example prof -- FILE.obj METHOD [REPS] [THICKNESS in mean edges]`
//! (a mesh file at its own positions).
//!
//! `REPS = 0` only builds the detector (for profiling the build alone);
//! `PROF_BUILDS=k` builds it k times and reports the best build time;
//! `PROF_MAIN_THREAD=1` runs everything on the main thread (for callgrind);
//! `PROF_EACH=1` prints every detection's times and contour work;
//! `PROF_SLABS=1` (or `0`) fits slabs every frame (or never) instead of
//! when the detector's policy says so (`BvhDetector::force_slabs`);
//! `PROF_WAVE=1` detects on a sequence of four frames cycled (the frame
//! plus a wave of 0.05 mean edges, wavelength 16 mean edges, phase 0.7 k:
//! the per-frame sequence of `scripts/bench_peers.py`) instead of one;
//! `PROF_AMPLITUDE=a` sets the wave's amplitude to `a` mean edges (0.05);
//! `PROF_WAVE=drift` on one frame per repetition, the wave's phase moving
//! as before and its wavelength growing 2% a frame (no frame repeats). The
//! first detection (refit + traverse) is reported apart from the best.
//! `PROF_GAP_MS=g` sleeps `g` ms before each cycle of the frames (the idle
//! gaps a caller's other work leaves, as between the peer script's runs).
//! The last line is a checksum of what was found (every frame's pairs and
//! proximity contacts): the same for any number of threads.
//! `PROF_ONESHOT=1` runs the one-shot query instead (`self_intersections`'s
//! top-down hierarchy, REPS times, on the mesh as built): best time and
//! what it did; METHOD is ignored.
use selfcd::detect::hierarchy::BvhDetector;
use selfcd::{new_detector, Detector, DetectorOptions, Method};
use std::time::Instant;

#[path = "common/allocator.rs"]
mod allocator;
#[path = "common/checksum.rs"]
mod checksum;
#[path = "common/input.rs"]
mod input;
#[path = "common/obj.rs"]
mod obj;
use input::frame;

fn main() {
    if std::env::var("PROF_MAIN_THREAD").is_ok_and(|x| x == "1") {
        // All work on the main thread, so that a profiler's inclusive costs
        // per function add up across parallel calls.
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .use_current_thread()
            .build_global()
            .unwrap();
    }
    let a: Vec<String> = std::env::args().collect();
    let (mesh, p, rest) = frame(&a);
    let method: Method = rest[0].parse().unwrap();
    let reps: usize = rest.get(1).map(|x| x.parse().unwrap()).unwrap_or(5);
    if std::env::var("PROF_ONESHOT").is_ok_and(|x| x == "1") {
        return one_shot(&mesh, &p, reps);
    }
    let thickness: f64 = rest.get(2).map(|x| x.parse().unwrap()).unwrap_or(0.0);
    let builds: usize = std::env::var("PROF_BUILDS")
        .ok()
        .map(|x| x.parse().unwrap())
        .unwrap_or(1);
    let opts = DetectorOptions {
        thickness: thickness * mesh.mean_edge_length(),
        ..Default::default()
    };
    let slabs = std::env::var("PROF_SLABS").ok().map(|x| x == "1");
    let n = mesh.n_triangles();
    let mut build = f64::MAX;
    let mut d = None;
    for _ in 0..builds.max(1) {
        drop(d.take());
        let t0 = Instant::now();
        d = Some(match slabs {
            Some(on) => {
                let mut b = BvhDetector::new(mesh.clone(), method, opts.thickness);
                b.force_slabs(Some(on));
                Box::new(b) as Box<dyn Detector>
            }
            None => new_detector(mesh.clone(), method, &opts).unwrap(),
        });
        build = build.min(t0.elapsed().as_secs_f64());
    }
    let mut d = d.unwrap();
    if reps == 0 {
        println!("{n} triangles: best build {:.2} ms", build * 1e3);
        return;
    }
    let wave = std::env::var("PROF_WAVE").unwrap_or_default();
    let frames = if wave == "1" || wave == "drift" {
        let e = mesh.mean_edge_length();
        let drift = wave == "drift";
        let amplitude: f64 = std::env::var("PROF_AMPLITUDE")
            .ok()
            .map_or(0.05, |a| a.parse().unwrap());
        (0..if drift { reps } else { 4 })
            .map(|f| {
                let ph = 0.7 * f as f64;
                // Drifting: the wavelength grows 2% a frame, so no frame repeats.
                let k = std::f64::consts::TAU
                    / (16.0 * e * if drift { 1.0 + 0.02 * f as f64 } else { 1.0 });
                p.iter()
                    .map(|x| {
                        let s = |a: f64, o: f64| (k * a + ph + o).sin();
                        let wave = selfcd::DVec3::new(s(x.y, 0.0), s(x.z, 1.0), s(x.x, 2.0));
                        *x + amplitude * e * wave
                    })
                    .collect()
            })
            .collect()
    } else {
        vec![p]
    };
    let each = std::env::var("PROF_EACH").is_ok_and(|x| x == "1");
    let (mut refit, mut trav, mut last) = (f64::MAX, f64::MAX, None);
    let mut sum = checksum::START;
    let mut first = 0.0;
    let gap: u64 = std::env::var("PROF_GAP_MS")
        .ok()
        .map_or(0, |g| g.parse().unwrap());
    for r in 0..reps {
        if gap > 0 && r % frames.len() == 0 {
            std::thread::sleep(std::time::Duration::from_millis(gap));
        }
        let det = d.detect(&frames[r % frames.len()]).unwrap();
        sum = checksum::pairs(sum, &det.pairs);
        sum = checksum::proximity(sum, &det.proximity);
        let s = det.stats;
        if r == 0 {
            first = s.refit_time + s.traverse_time;
        }
        if each {
            println!(
                "frame {r}: refit {:.3} ms, traverse {:.3} ms, contour tests {}, reused {}, rechecked {}, primitive tests {}, filter decisions {}, slab culls {}, node pairs {}, self culls {}, pair culls {}, adjacent skips {}, front jobs {} (skipped {})",
                s.refit_time * 1e3,
                s.traverse_time * 1e3,
                s.contour_tests,
                s.certificates_reused,
                s.certificates_rechecked,
                s.primitive_tests,
                s.filter_decisions,
                s.slab_culls,
                s.node_pairs,
                s.self_culls,
                s.pair_culls,
                s.adjacent_skips,
                s.front_jobs,
                s.front_skips
            );
        }
        refit = refit.min(s.refit_time);
        trav = trav.min(s.traverse_time);
        last = Some(s);
    }
    let s = last.unwrap();
    println!(
        "{n} triangles: build {:.1} ms, first detect {:.1} ms, best refit {:.3} ms, best traverse {:.3} ms; node pairs {}, contour tests {} (failed {}, certificates reused {}), primitive tests {}, contacts {}, proximity tests {}, proximity contacts {}",
        build * 1e3, first * 1e3, refit * 1e3, trav * 1e3, s.node_pairs, s.contour_tests, s.contour_fails, s.certificates_reused, s.primitive_tests, s.contacts, s.proximity_tests, s.proximity_contacts
    );
    println!("pairs checksum {sum:016x} (every frame's pairs and proximity contacts)");
}

/// `PROF_ONESHOT=1`: the one-shot query `reps` times; best time and counters.
fn one_shot(mesh: &selfcd::Mesh, p: &[selfcd::DVec3], reps: usize) {
    let mut best = f64::MAX;
    let mut last = None;
    for _ in 0..reps.max(1) {
        let t0 = Instant::now();
        let (pairs, c) = selfcd::bvh::topdown::self_intersections(mesh, p);
        best = best.min(t0.elapsed().as_secs_f64() * 1e3);
        last = Some((pairs, c));
    }
    let (pairs, c) = last.unwrap();
    let sum = checksum::pairs(checksum::START, &pairs);
    println!("one-shot best {best:.2} ms, {} pairs; {c:?}", pairs.len());
    println!("pairs checksum {sum:016x}");
}
