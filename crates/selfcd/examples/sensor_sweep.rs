//! Runs the particle sensor gate over analytic animations and reports, per
//! animation, what it triggered on and what it missed against the exact
//! reference; with `--sweep`, repeats that over a grid of sensor parameters
//! (this is how the defaults in `sensor/params.rs` were chosen).
//!
//! With `--table`, prints the per-mesh table of issue 12 (BENCHMARKS.md,
//! "Particle sensor on any surface"): flat cloth, tube, sphere and the meshes
//! of /work/shared/data under fold, roll, twist, bend and crumple, the sphere
//! squeezed until it folds and the three simulated paper scenes. Per row: frames
//! triggered, contacts missed against the exact reference (`diff_sorted`
//! against `bvh-cones-contour` on the same frame), quiet-frame cost against the
//! exact method (both run on the same frame, back to back), particle counts.
//!
//! ```text
//! cargo run --release -p selfcd --example sensor_sweep [-- [--big] [--count K] | --sweep [--fine]]
//! cargo run --release -p selfcd --example sensor_sweep -- --table [--frames F] [--settle N] [--data DIR] [--only NAME,=EXACT,...]
//! cargo run --release -p selfcd --example sensor_sweep -- --sweep-gate
//! RAYON_NUM_THREADS=1 valgrind --tool=callgrind target/release/examples/sensor_sweep --cost MESH ANIM [--frames F] [--settle N]
//! ```
//!
//! `--cost` measures the quiet-frame cost in instructions rather than seconds
//! (the wall clock of a shared machine is noise at these sizes): a first pass
//! finds the frames the gate does not trigger on; a second pass, with fresh
//! detectors (the gate is deterministic, so the same frames are quiet), runs
//! those frames through `exact_quiet_frame` and `gated_quiet_frame`, whose
//! inclusive instruction counts (`callgrind_annotate --inclusive=yes`) give
//! the ratio. MESH is a grid side (`101`) or a name in `--data`; ANIM a name of
//! the table's animations (`rest`, `fold`, `roll`, `twist`, `bend`, `crumple`).

#[path = "common/obj.rs"]
mod obj;

use glam::DQuat;
use selfcd::detect::compare::{compare_methods, reference_pairs, MethodRun};
use selfcd::scene::{grid, Deformation};
use selfcd::sensor::{Sensor, SensorParams};
use selfcd::{DVec3, DetectorOptions, Mesh, Method};
use std::f64::consts::PI;
use std::sync::Arc;

/// A named animation: frame count and the shape at time s in [0, 1].
struct Anim {
    name: &'static str,
    shape: fn(f64, &[DVec3]) -> Vec<DVec3>,
}

fn anims() -> Vec<Anim> {
    vec![
        Anim {
            name: "flat",
            shape: |_, r| r.to_vec(),
        },
        Anim {
            name: "wave",
            shape: wave,
        },
        Anim {
            name: "twist",
            shape: |s, r| Deformation::Twist { turns: 1.0 * s }.apply(r),
        },
        Anim {
            name: "fold",
            shape: |s, r| fold(1.25 * PI * s, 0.05, 0.0, r),
        },
        Anim {
            name: "fold-y",
            shape: |s, r| fold(1.25 * PI * s, 0.05, 0.5 * PI, r),
        },
        Anim {
            name: "fold-diag",
            shape: |s, r| fold(1.25 * PI * s, 0.05, 0.25 * PI, r),
        },
        Anim {
            name: "fold-tight",
            shape: |s, r| fold(1.25 * PI * s, 0.02, 0.0, r),
        },
        Anim {
            name: "roll",
            shape: |s, r| {
                Deformation::Roll {
                    turns: 2.0 * s,
                    gap: 0.02,
                }
                .apply(r)
            },
        },
        Anim {
            name: "crumple",
            shape: |s, r| {
                Deformation::Crumple {
                    amplitude: 0.3 * s,
                    wavelength: 0.4,
                    seed: 1,
                }
                .apply(r)
            },
        },
    ]
}

/// Fold through `angle` around a crease at angle `dir` (radians, about z) through the centre.
fn fold(angle: f64, radius: f64, dir: f64, rest: &[DVec3]) -> Vec<DVec3> {
    let c = rest.iter().copied().sum::<DVec3>() / rest.len() as f64;
    let rot = DQuat::from_rotation_z(dir);
    let turned: Vec<DVec3> = rest.iter().map(|&p| rot * (p - c) + c).collect();
    let folded = Deformation::Fold { angle, radius }.apply(&turned);
    folded
        .iter()
        .map(|&p| rot.inverse() * (p - c) + c)
        .collect()
}

/// A travelling wave of amplitude 5% of the width.
fn wave(s: f64, rest: &[DVec3]) -> Vec<DVec3> {
    rest.iter()
        .map(|p| *p + DVec3::Z * (0.05 * (2.0 * PI * (p.x + 0.5 * p.y - 2.0 * s)).sin()))
        .collect()
}

/// Per-animation summary of a sensor-gated run against bvh-cones-contour.
struct Summary {
    contact_frames: usize,
    first_contact: Option<usize>,
    first_trigger: Option<usize>,
    triggered: usize,
    triggered_quiet: usize,
    late: usize,
    missed: u64,
    steps: f64,
}

fn summarise(bvh: &MethodRun, gated: &MethodRun) -> Summary {
    let contact = |f: usize| bvh.frames[f].stats.contacts > 0;
    let trig = |f: usize| gated.frames[f].stats.triggered == Some(true);
    let n = gated.frames.len();
    Summary {
        contact_frames: (0..n).filter(|&f| contact(f)).count(),
        first_contact: (0..n).find(|&f| contact(f)),
        first_trigger: (0..n).find(|&f| trig(f)),
        triggered: (0..n).filter(|&f| trig(f)).count(),
        triggered_quiet: (0..n).filter(|&f| trig(f) && !contact(f)).count(),
        late: (0..n).filter(|&f| contact(f) && !trig(f)).count(),
        missed: gated.frames.iter().map(|r| r.missed).sum(),
        steps: gated
            .frames
            .iter()
            .map(|r| r.stats.relax_steps as f64)
            .sum::<f64>()
            / n as f64,
    }
}

fn run(mesh: &Arc<Mesh>, anim: &Anim, frames: usize, params: &SensorParams) -> Summary {
    let shapes: Vec<Vec<DVec3>> = (0..frames)
        .map(|f| (anim.shape)(f as f64 / (frames - 1) as f64, mesh.rest()))
        .collect();
    let opts = DetectorOptions {
        sensor: params.clone(),
        ..Default::default()
    };
    let runs = compare_methods(
        mesh,
        &shapes,
        &[Method::BvhConesContour, Method::SensorGated],
        &opts,
        |_| {},
    )
    .unwrap();
    summarise(&runs[0], &runs[1])
}

fn opt(v: Option<usize>) -> String {
    v.map_or("-".into(), |x| x.to_string())
}

fn report(
    mesh: &Arc<Mesh>,
    frames: usize,
    params: &SensorParams,
    label: &str,
) -> (usize, usize, u64) {
    let (mut late, mut quiet, mut missed) = (0, 0, 0);
    for a in anims() {
        let s = run(mesh, &a, frames, params);
        println!(
            "{label:<28} {:<6} contact_frames {:>3} first_contact {:>3} first_trigger {:>3} triggered {:>3} triggered_quiet {:>3} late {:>3} missed {:>6} steps/frame {:.2}",
            a.name,
            s.contact_frames,
            opt(s.first_contact),
            opt(s.first_trigger),
            s.triggered,
            s.triggered_quiet,
            s.late,
            s.missed,
            s.steps
        );
        late += s.late;
        quiet += s.triggered_quiet;
        missed += s.missed;
    }
    (late, quiet, missed)
}

/// Sensor-only replay of one animation against precomputed reference contact
/// counts (what the gated detector would find is exactly the reference on
/// triggered frames, because the inner method is conservative).
fn replay(
    mesh: &Arc<Mesh>,
    shapes: &[Vec<DVec3>],
    contacts: &[usize],
    params: &SensorParams,
) -> (usize, usize, usize, u64, f64) {
    let mut sensor = Sensor::new(mesh.clone(), params.clone()).unwrap();
    let (mut late, mut quiet, mut trig, mut missed, mut steps) = (0, 0, 0, 0u64, 0u64);
    for (shape, &c) in shapes.iter().zip(contacts) {
        let r = sensor.relax(shape).unwrap();
        steps += r.steps as u64;
        trig += r.triggered as usize;
        quiet += (r.triggered && c == 0) as usize;
        if !r.triggered && c > 0 {
            late += 1;
            missed += c as u64;
        }
    }
    (
        late,
        quiet,
        trig,
        missed,
        steps as f64 / shapes.len() as f64,
    )
}

fn sweep(mesh: &Arc<Mesh>, frames: usize) {
    let data: Vec<(Vec<Vec<DVec3>>, Vec<usize>)> = anims()
        .iter()
        .map(|a| {
            let shapes: Vec<Vec<DVec3>> = (0..frames)
                .map(|f| (a.shape)(f as f64 / (frames - 1) as f64, mesh.rest()))
                .collect();
            let contacts = reference_pairs(mesh, &shapes)
                .unwrap()
                .iter()
                .map(|p| p.len())
                .collect();
            (shapes, contacts)
        })
        .collect();
    if std::env::args().any(|a| a == "--fine") {
        for epsilon in [1e-3, 1e-2, 5e-2] {
            for n_min in [1, 2] {
                for (tolerance, step_gain, n_max) in [
                    (3.0, 16.0, 8),
                    (3.0, 16.0, 16),
                    (3.0, 4.0, 16),
                    (3.0, 64.0, 8),
                ] {
                    let p = SensorParams {
                        epsilon,
                        n_min,
                        tolerance,
                        step_gain,
                        n_max,
                        ..Default::default()
                    };
                    print!("eps {epsilon} nmin {n_min} ");
                    sweep_line(mesh, &data, &p);
                }
            }
        }
        return;
    }
    for count in [4, 8, 16] {
        for tolerance in [2.0, 3.0, 4.0] {
            for step_gain in [1.0, 4.0, 16.0, 64.0] {
                for max_step in [0.5, 1.0] {
                    for n_max in [4, 8, 16] {
                        let p = SensorParams {
                            count,
                            tolerance,
                            n_max,
                            max_step,
                            step_gain,
                            ..Default::default()
                        };
                        sweep_line(mesh, &data, &p);
                    }
                }
            }
        }
    }
}

/// One parameter setting over every animation: one line.
fn sweep_line(mesh: &Arc<Mesh>, data: &[(Vec<Vec<DVec3>>, Vec<usize>)], p: &SensorParams) {
    let mut line = format!(
        "k {} tol {} gain {} step {} nmax {}:",
        p.count, p.tolerance, p.step_gain, p.max_step, p.n_max
    );
    let mut tot = (0, 0, 0u64, 0.0);
    for (a, (shapes, contacts)) in anims().iter().zip(data) {
        let (late, quiet, trig, missed, steps) = replay(mesh, shapes, contacts, p);
        line += &format!(
            " {}[trig {trig} quiet {quiet} late {late} missed {missed} steps {steps:.1}]",
            a.name
        );
        tot = (tot.0 + late, tot.1 + quiet, tot.2 + missed, tot.3 + steps);
    }
    println!(
        "{line} TOTAL late {} quiet {} missed {} steps {:.1}",
        tot.0,
        tot.1,
        tot.2,
        tot.3 / data.len() as f64
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.iter().any(|a| a == "--table") {
        table(&args);
        return;
    }
    if args.iter().any(|a| a == "--crumple") {
        crumple(&args);
        return;
    }
    if args.iter().any(|a| a == "--cost") {
        // Inside the pool, so that the detectors' parallel work runs on the
        // calling thread's stack (callgrind's inclusive counts follow it).
        let pool = rayon::ThreadPoolBuilder::new().build().unwrap();
        pool.install(|| cost(&args));
        return;
    }
    if args.iter().any(|a| a == "--sweep-gate") {
        sweep_gate();
        return;
    }
    let sides: &[usize] = if args.iter().any(|a| a == "--big") {
        &[11, 101]
    } else {
        &[11]
    };
    let frames = 60;
    for &side in sides {
        let (v, f) = grid(side, 1.0);
        let mesh = Arc::new(Mesh::new(v, f).unwrap());
        println!(
            "# grid {side}x{side}: {} triangles, {frames} frames per animation",
            mesh.n_triangles()
        );
        if args.iter().any(|a| a == "--sweep") {
            sweep(&mesh, frames);
        } else {
            let count = args
                .iter()
                .position(|a| a == "--count")
                .and_then(|i| args.get(i + 1)?.parse().ok());
            let p = SensorParams {
                count: count.unwrap_or(4),
                ..Default::default()
            };
            report(&mesh, frames, &p, &format!("defaults, k {}", p.count));
        }
    }
}

// ---- The table of issue 12 (`--table`) ----

/// One row of the table: what the gate did over one animation.
#[derive(Default)]
struct Row {
    frames: usize,
    contact_frames: usize,
    triggered: usize,
    contacts: u64,
    missed: u64,
    triggered_quiet: usize,
    /// (gated seconds, exact seconds) of every frame the gate did not trigger on.
    quiet: Vec<(f64, f64)>,
    /// (sensor seconds, exact seconds) summed over every frame.
    sensor: (f64, f64),
    steps: u64,
    particles: Vec<usize>,
}

impl Row {
    /// sum(gated) / sum(exact) over the untriggered frames (the quiet-frame cost).
    fn quiet_cost(&self) -> Option<f64> {
        let (g, e) = self
            .quiet
            .iter()
            .fold((0.0, 0.0), |(g, e), &(a, b)| (g + a, e + b));
        (!self.quiet.is_empty()).then(|| g / e)
    }
}

/// Runs `bvh-cones-contour` (the reference) and `sensor-gated` on every frame,
/// back to back, and counts what the gate missed.
fn gate_row(mesh: &Arc<Mesh>, frames: impl Iterator<Item = Vec<DVec3>>) -> Row {
    gate_row_with(mesh, frames, &SensorParams::default())
}

/// [`gate_row`] with the given sensor parameters.
fn gate_row_with(
    mesh: &Arc<Mesh>,
    frames: impl Iterator<Item = Vec<DVec3>>,
    params: &SensorParams,
) -> Row {
    use selfcd::detect::compare::diff_sorted;
    use std::time::Instant;
    let opts = DetectorOptions {
        sensor: params.clone(),
        ..Default::default()
    };
    let mut exact = selfcd::new_detector(mesh.clone(), Method::BvhConesContour, &opts).unwrap();
    let mut gated = selfcd::new_detector(mesh.clone(), Method::SensorGated, &opts).unwrap();
    let mut row = Row::default();
    let mut frames = frames.peekable();
    // `--settle N`: N frames of the first shape first, not counted (particles settled).
    if let Some(first) = frames.peek() {
        for _ in 0..settle_frames() {
            exact.detect(first).unwrap();
            gated.detect(first).unwrap();
        }
    }
    for shape in frames {
        let t0 = Instant::now();
        let want = exact.detect(&shape).unwrap();
        let te = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let got = gated.detect(&shape).unwrap();
        let tg = t0.elapsed().as_secs_f64();
        let (missed, spurious) = diff_sorted(&want.pairs, &got.pairs);
        assert_eq!(
            spurious, 0,
            "the gate reported a pair the exact method did not"
        );
        let trig = got.stats.triggered == Some(true);
        row.frames += 1;
        row.contact_frames += !want.pairs.is_empty() as usize;
        row.triggered += trig as usize;
        row.triggered_quiet += (trig && want.pairs.is_empty()) as usize;
        row.contacts += want.pairs.len() as u64;
        row.missed += missed;
        if !trig {
            row.quiet.push((tg, te));
        }
        row.sensor.0 += got.stats.sensor_time;
        row.sensor.1 += te;
        row.steps += got.stats.relax_steps as u64;
        row.particles.push(gated.particles().len());
    }
    row
}

/// "first -> min..max -> last" of the particle counts.
fn counts(p: &[usize]) -> String {
    let (lo, hi) = (p.iter().min().unwrap(), p.iter().max().unwrap());
    format!("{} -> {lo}..{hi} -> {}", p[0], p[p.len() - 1])
}

fn print_row(mesh: &str, tris: usize, anim: &str, r: &Row) {
    let cost = r.quiet_cost().map_or("- (no quiet frame)".into(), |c| {
        format!("{:.1}%", 100.0 * c)
    });
    println!(
        "| {mesh} | {tris} | {anim} | {} | {} | {} | {} | {} | {cost} | {:.1}% | {:.1} | {} |",
        r.frames,
        r.contact_frames,
        r.triggered,
        r.contacts,
        r.missed,
        100.0 * r.sensor.0 / r.sensor.1,
        r.steps as f64 / r.frames as f64,
        counts(&r.particles)
    );
}

/// A shape of a rest mesh at time s in [0, 1].
type ShapeAt = fn(f64, &[DVec3]) -> Vec<DVec3>;

/// The animations of the table, at time s in [0, 1].
fn table_anims() -> Vec<(&'static str, ShapeAt)> {
    vec![
        ("rest (static)", |_, r| r.to_vec()),
        ("fold", |s, r| fold(1.25 * PI * s, 0.05, 0.0, r)),
        ("roll", |s, r| {
            Deformation::Roll {
                turns: 1.5 * s,
                gap: 0.05,
            }
            .apply(r)
        }),
        ("twist", |s, r| {
            Deformation::Twist { turns: 1.5 * s }.apply(r)
        }),
        ("bend", |s, r| fold(1.9 * PI * s, 0.12, 0.0, r)),
        ("crumple", |s, r| {
            Deformation::Crumple {
                amplitude: 0.3 * s,
                wavelength: 0.4,
                seed: 1,
            }
            .apply(r)
        }),
    ]
}

/// The `--settle N` argument (0 without it).
fn settle_frames() -> usize {
    let args: Vec<String> = std::env::args().collect();
    arg_value(&args, "--settle").map_or(0, |s| s.parse().unwrap())
}

fn arg_value<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    let i = args.iter().position(|a| a == name)?;
    args.get(i + 1).map(|s| s.as_str())
}

fn table(args: &[String]) {
    use selfcd::cloth::scenes::PaperScene;
    use selfcd::scene::{pinch, sphere, tube};
    let frames: usize = arg_value(args, "--frames").map_or(40, |s| s.parse().unwrap());
    let data = arg_value(args, "--data").unwrap_or("/work/shared/data");
    let only = arg_value(args, "--only");
    // `--only a,b`: rows whose mesh name contains a or b; `=a`: named exactly a.
    let keep = |name: &str| {
        only.is_none_or(|o| {
            o.split(',').any(|w| match w.strip_prefix('=') {
                Some(exact) => name == exact,
                None => name.contains(w),
            })
        })
    };
    let mut meshes: Vec<(String, Arc<Mesh>)> = vec![
        ("flat cloth 21x21".into(), grid(21, 1.0)),
        ("flat cloth 101x101".into(), grid(101, 1.0)),
        ("tube 24x25".into(), tube(24, 25, 0.12, 1.0)),
        ("sphere 13x20".into(), sphere(13, 20, 0.5)),
    ]
    .into_iter()
    .map(|(n, (v, f))| (n, Arc::new(Mesh::new(v, f).unwrap())))
    .collect();
    for name in [
        "body",
        "dress_on_body",
        "multilayer_skirt_on_body",
        "skirt_32k",
    ] {
        if keep(name) {
            let (v, f) = obj::read_obj(&format!("{data}/{name}.obj"));
            meshes.push((name.into(), Arc::new(Mesh::new(v, f).unwrap())));
        }
    }
    println!("| mesh | triangles | animation | frames | frames with contacts | frames triggered | contacts (exact) | contacts missed | quiet-frame cost / exact | sensor / exact, all frames | updates per frame | particles (first -> min..max -> last) |");
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    for (name, mesh) in meshes.iter().filter(|(n, _)| keep(n)) {
        let n = mesh.n_triangles();
        for (anim, shape) in table_anims() {
            let shapes = (0..frames).map(|f| shape(f as f64 / (frames - 1) as f64, mesh.rest()));
            print_row(name, n, anim, &gate_row(mesh, shapes));
        }
        if name.starts_with("sphere") {
            let shapes =
                (0..frames).map(|f| pinch(mesh.rest(), 1.6 * f as f64 / (frames - 1) as f64));
            print_row(name, n, "squeeze until it folds", &gate_row(mesh, shapes));
        }
    }
    if keep("paper") {
        for scene in PaperScene::ALL {
            let mut sim = scene.simulation(21, Method::BvhConesContour).unwrap();
            let mut shapes = Vec::with_capacity(300);
            for _ in 0..300 {
                sim.step().unwrap();
                shapes.push(sim.positions().to_vec());
            }
            let mesh = sim.cloth().mesh().clone();
            let row = gate_row(&mesh, shapes.into_iter());
            print_row(
                &format!("paper {scene}"),
                mesh.n_triangles(),
                "simulated, 300 steps",
                &row,
            );
        }
    }
}

/// `--sweep-gate`: the gated detector (particles following the parts) over
/// flat cloth at 200 and 800 triangles, the tube and the sphere under every
/// animation of the table, for force scale {1/4, 1, 4} x a/b {1, 2, 4} x
/// tolerance {2, 3, 4} (mean edges). One line per setting: frames triggered
/// without contacts, contacts missed, mean updates per frame.
fn sweep_gate() {
    use selfcd::scene::{sphere, tube};
    let meshes: Vec<Arc<Mesh>> = [
        grid(11, 1.0),
        grid(21, 1.0),
        tube(24, 25, 0.12, 1.0),
        sphere(13, 20, 0.5),
    ]
    .into_iter()
    .map(|(v, f)| Arc::new(Mesh::new(v, f).unwrap()))
    .collect();
    let frames = 40;
    for scale in [0.25, 1.0, 4.0] {
        for ratio in [1.0, 2.0, 4.0] {
            for tolerance in [2.0, 3.0, 4.0] {
                let p = SensorParams {
                    a: 10.0 * ratio * scale,
                    b: 10.0 * scale,
                    tolerance,
                    ..Default::default()
                };
                let (mut quiet_trig, mut missed, mut steps, mut n) = (0, 0, 0u64, 0);
                for mesh in &meshes {
                    for (_, shape) in table_anims() {
                        let shapes =
                            (0..frames).map(|f| shape(f as f64 / (frames - 1) as f64, mesh.rest()));
                        let r = gate_row_with(mesh, shapes, &p);
                        quiet_trig += r.triggered_quiet;
                        missed += r.missed;
                        steps += r.steps;
                        n += r.frames;
                    }
                }
                println!(
                    "a {:>5} b {:>5} tol {tolerance}: triggered without contacts {quiet_trig:>4} missed {missed:>6} updates/frame {:.2}",
                    p.a, p.b, steps as f64 / n as f64
                );
            }
        }
    }
}

/// `--crumple [--sides 11,101,708]`: the crumple on square grids (200, 20k and
/// 1M triangles by default), one table row each.
fn crumple(args: &[String]) {
    let sides: Vec<usize> = arg_value(args, "--sides")
        .unwrap_or("11,101,708")
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let frames: usize = arg_value(args, "--frames").map_or(40, |s| s.parse().unwrap());
    let (_, shape) = table_anims().pop().unwrap();
    for side in sides {
        let (v, f) = grid(side, 1.0);
        let mesh = Arc::new(Mesh::new(v, f).unwrap());
        let shapes = (0..frames).map(|f| shape(f as f64 / (frames - 1) as f64, mesh.rest()));
        print_row(
            &format!("flat {side}x{side}"),
            mesh.n_triangles(),
            "crumple",
            &gate_row(&mesh, shapes),
        );
    }
}

/// One quiet frame of the exact method (a separate function, so that callgrind
/// attributes its instructions; see `--cost`).
#[inline(never)]
fn exact_quiet_frame(det: &mut dyn selfcd::Detector, shape: &[DVec3]) -> usize {
    det.detect(shape).unwrap().pairs.len()
}

/// One quiet frame of the gate (see [`exact_quiet_frame`]).
#[inline(never)]
fn gated_quiet_frame(det: &mut dyn selfcd::Detector, shape: &[DVec3]) -> usize {
    det.detect(shape).unwrap().pairs.len()
}

/// Any other frame, either method.
#[inline(never)]
fn other_frame(det: &mut dyn selfcd::Detector, shape: &[DVec3]) -> usize {
    det.detect(shape).unwrap().pairs.len()
}

/// `--cost MESH ANIM [--frames F] [--settle N] [--data DIR]`: see the module documentation.
fn cost(args: &[String]) {
    let i = args.iter().position(|a| a == "--cost").unwrap();
    let (name, anim) = (&args[i + 1], &args[i + 2]);
    let frames: usize = arg_value(args, "--frames").map_or(40, |s| s.parse().unwrap());
    let data = arg_value(args, "--data").unwrap_or("/work/shared/data");
    let (v, f) = match name.parse::<usize>() {
        Ok(side) => grid(side, 1.0),
        Err(_) => obj::read_obj(&format!("{data}/{name}.obj")),
    };
    let mesh = Arc::new(Mesh::new(v, f).unwrap());
    let (_, shape) = table_anims()
        .into_iter()
        .find(|(a, _)| a.starts_with(anim.as_str()))
        .expect("an animation of the table");
    let shapes: Vec<Vec<DVec3>> = (0..frames)
        .map(|f| shape(f as f64 / (frames - 1) as f64, mesh.rest()))
        .collect();
    let opts = DetectorOptions::default();
    let fresh = || {
        let mut exact = selfcd::new_detector(mesh.clone(), Method::BvhConesContour, &opts).unwrap();
        let mut gated = selfcd::new_detector(mesh.clone(), Method::SensorGated, &opts).unwrap();
        for _ in 0..settle_frames() {
            other_frame(&mut *exact, &shapes[0]);
            other_frame(&mut *gated, &shapes[0]);
        }
        (exact, gated)
    };
    let (mut exact, mut gated) = fresh();
    let quiet: Vec<bool> = shapes
        .iter()
        .map(|s| {
            exact.detect(s).unwrap();
            gated.detect(s).unwrap().stats.triggered != Some(true)
        })
        .collect();
    let (mut exact, mut gated) = fresh();
    for (s, &q) in shapes.iter().zip(&quiet) {
        if q {
            exact_quiet_frame(&mut *exact, s);
            let got = gated_quiet_frame(&mut *gated, s);
            assert_eq!(got, 0, "a quiet frame of the second pass triggered");
        } else {
            other_frame(&mut *exact, s);
            other_frame(&mut *gated, s);
        }
    }
    println!(
        "{name} {anim}: {} frames, {} quiet (gated_quiet_frame / exact_quiet_frame in callgrind)",
        frames,
        quiet.iter().filter(|&&q| q).count()
    );
}
