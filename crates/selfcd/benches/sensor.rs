//! Particle sensor cost and what the gate saves and misses (issue 3).
//!
//! 1. Quiet frames (nothing collides: flat, waving, half-twisted cloth) at 200
//!    and 20k triangles, particles settled: criterion times of one frame of
//!    `bvh-cones-contour`, of the sensor's public relax (which also checks the
//!    positions, O(n)), and of
//!    `sensor-gated` (refit only when triggered, the default, and refit every frame).
//! 2. Analytic animations (fold in half, roll, twist, crumple; 60 frames) at
//!    200 and 20k triangles: frames triggered, primitive tests, time per frame
//!    and contacts missed by the gate, via `detect::compare::compare_methods`.
//!
//! ```text
//! cargo bench -p selfcd --bench sensor
//! ```

use criterion::{BenchmarkId, Criterion};
use selfcd::detect::compare::{compare_methods, MethodRun};
use selfcd::scene::{grid, Deformation};
use selfcd::sensor::{Sensor, SensorParams};
use selfcd::{new_detector, DVec3, Detector, DetectorOptions, FrameStats, Mesh, Method};
use std::f64::consts::PI;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Grid sides giving 200 and 20 000 triangles.
const SIDES: [usize; 2] = [11, 101];

fn square(side: usize) -> Arc<Mesh> {
    let (v, f) = grid(side, 1.0);
    Arc::new(Mesh::new(v, f).unwrap())
}

/// Quiet shapes: nothing collides.
fn quiet_shapes(mesh: &Mesh) -> Vec<(&'static str, Vec<DVec3>)> {
    let wave = mesh
        .rest()
        .iter()
        .map(|p| *p + DVec3::Z * (0.05 * (2.0 * PI * (p.x + 0.5 * p.y)).sin()))
        .collect();
    vec![
        ("flat", mesh.rest().to_vec()),
        ("wave", wave),
        (
            "twist",
            Deformation::Twist { turns: 0.5 }.apply(mesh.rest()),
        ),
    ]
}

/// A detector that has seen `pos` for 300 frames, so its particles have settled.
fn settled(
    mesh: &Arc<Mesh>,
    method: Method,
    sensor: SensorParams,
    pos: &[DVec3],
) -> Box<dyn Detector> {
    let opts = DetectorOptions {
        sensor,
        ..Default::default()
    };
    let mut d = new_detector(mesh.clone(), method, &opts).unwrap();
    for _ in 0..300 {
        d.detect(pos).unwrap();
    }
    d
}

fn eager() -> SensorParams {
    SensorParams {
        refit_every_frame: true,
        ..Default::default()
    }
}

/// Median seconds of `f` over `reps` runs.
fn median_time(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[reps / 2]
}

fn quiet_criterion(c: &mut Criterion) {
    let mut g = c.benchmark_group("sensor_quiet");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(20);
    for side in SIDES {
        let mesh = square(side);
        let n = mesh.n_triangles();
        for (name, pos) in quiet_shapes(&mesh) {
            let id = |m: &str| BenchmarkId::new(m, format!("{name}/{n}"));
            let mut bvh = settled(
                &mesh,
                Method::BvhConesContour,
                SensorParams::default(),
                &pos,
            );
            g.bench_function(id("bvh-cones-contour"), |b| {
                b.iter(|| bvh.detect(&pos).unwrap())
            });
            let mut sensor = Sensor::new(mesh.clone(), SensorParams::default()).unwrap();
            for _ in 0..300 {
                sensor.relax(&pos).unwrap();
            }
            // The public relax checks every position (O(n)); the detector's does not repeat that check.
            g.bench_function(id("sensor-relax-with-position-check"), |b| {
                b.iter(|| sensor.relax(&pos).unwrap())
            });
            let mut gated = settled(&mesh, Method::SensorGated, SensorParams::default(), &pos);
            g.bench_function(id("sensor-gated"), |b| {
                b.iter(|| gated.detect(&pos).unwrap())
            });
            let mut gated_eager = settled(&mesh, Method::SensorGated, eager(), &pos);
            g.bench_function(id("sensor-gated-refit-every-frame"), |b| {
                b.iter(|| gated_eager.detect(&pos).unwrap())
            });
        }
    }
    g.finish();
}

/// Median of `stat` over 201 frames of `det` at `pos`, and the last frame's stats.
fn median_stat(
    det: &mut dyn Detector,
    pos: &[DVec3],
    stat: impl Fn(&FrameStats) -> f64,
) -> (f64, FrameStats) {
    let mut v = Vec::with_capacity(201);
    let mut last = FrameStats::default();
    for _ in 0..201 {
        last = det.detect(pos).unwrap().stats;
        v.push(stat(&last));
    }
    v.sort_by(f64::total_cmp);
    (v[100], last)
}

/// One table row per quiet shape: median times and the sensor's share.
fn quiet_table() {
    println!("\n## quiet frames (medians of 201 frames, particles settled)");
    println!("| triangles | shape | bvh-cones-contour (refit + traverse) | sensor (relax + trigger) | sensor / bvh | sensor-gated | sensor-gated, refit every frame | updates/frame | triggered |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for side in SIDES {
        let mesh = square(side);
        for (name, pos) in quiet_shapes(&mesh) {
            let mut bvh = settled(
                &mesh,
                Method::BvhConesContour,
                SensorParams::default(),
                &pos,
            );
            let t_bvh = median_time(201, || drop(bvh.detect(&pos).unwrap()));
            let mut gated = settled(&mesh, Method::SensorGated, SensorParams::default(), &pos);
            let (t_sensor, stats) = median_stat(&mut *gated, &pos, |s| s.sensor_time);
            let t_gated = median_time(201, || drop(gated.detect(&pos).unwrap()));
            let mut eager = settled(&mesh, Method::SensorGated, eager(), &pos);
            let t_eager = median_time(201, || drop(eager.detect(&pos).unwrap()));
            println!(
                "| {} | {name} | {:.2} us | {:.2} us | {:.1}% | {:.2} us | {:.2} us | {} | {:?} |",
                mesh.n_triangles(),
                t_bvh * 1e6,
                t_sensor * 1e6,
                100.0 * t_sensor / t_bvh,
                t_gated * 1e6,
                t_eager * 1e6,
                stats.relax_steps,
                stats.triggered.unwrap_or(true)
            );
        }
    }
}

/// A named animation: its shape at time s in [0, 1].
type Animation = (&'static str, Box<dyn Fn(f64) -> Deformation>);

/// The analytic animations: name and shape at time s in [0, 1].
fn animations() -> Vec<Animation> {
    vec![
        (
            "fold",
            Box::new(|s| Deformation::Fold {
                angle: 1.25 * PI * s,
                radius: 0.05,
            }),
        ),
        (
            "roll",
            Box::new(|s| Deformation::Roll {
                turns: 2.0 * s,
                gap: 0.02,
            }),
        ),
        ("twist", Box::new(|s| Deformation::Twist { turns: s })),
        (
            "crumple",
            Box::new(|s| Deformation::Crumple {
                amplitude: 0.3 * s,
                wavelength: 0.4,
                seed: 1,
            }),
        ),
    ]
}

fn mean(run: &MethodRun, f: impl Fn(&selfcd::detect::compare::FrameRecord) -> f64) -> f64 {
    run.frames.iter().map(f).sum::<f64>() / run.frames.len() as f64
}

fn animation_table() {
    println!("\n## analytic animations (60 frames each)");
    println!("| triangles | animation | frames with contacts | first contact | triggered (quiet) | first trigger | primitive tests bvh / gated | mean time bvh / gated | median quiet-frame time bvh / gated | contacts | missed by gate |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for side in SIDES {
        let mesh = square(side);
        for (name, shape) in animations() {
            let frames: Vec<Vec<DVec3>> = (0..60)
                .map(|f| shape(f as f64 / 59.0).apply(mesh.rest()))
                .collect();
            let methods = [Method::BvhConesContour, Method::SensorGated];
            let runs = compare_methods(
                &mesh,
                &frames,
                &methods,
                &DetectorOptions::default(),
                |_| {},
            )
            .unwrap();
            let (b, g) = (&runs[0], &runs[1]);
            let contact: Vec<bool> = b.frames.iter().map(|r| r.stats.contacts > 0).collect();
            let trig: Vec<bool> = g
                .frames
                .iter()
                .map(|r| r.stats.triggered == Some(true))
                .collect();
            let quiet_median = |r: &MethodRun| {
                let mut q: Vec<f64> = r
                    .frames
                    .iter()
                    .zip(&contact)
                    .filter(|(_, &c)| !c)
                    .map(|(f, _)| f.stats.total_time())
                    .collect();
                q.sort_by(f64::total_cmp);
                q.get(q.len() / 2).copied().unwrap_or(0.0)
            };
            let first = |v: &[bool]| {
                v.iter()
                    .position(|&x| x)
                    .map_or("-".to_string(), |f| f.to_string())
            };
            println!(
                "| {} | {name} | {} | {} | {} ({}) | {} | {:.0} / {:.0} | {:.1} / {:.1} us | {:.1} / {:.1} us | {} | {} |",
                mesh.n_triangles(),
                contact.iter().filter(|&&c| c).count(),
                first(&contact),
                trig.iter().filter(|&&t| t).count(),
                trig.iter().zip(&contact).filter(|(&t, &c)| t && !c).count(),
                first(&trig),
                mean(b, |r| r.stats.primitive_tests as f64),
                mean(g, |r| r.stats.primitive_tests as f64),
                mean(b, |r| r.stats.total_time()) * 1e6,
                mean(g, |r| r.stats.total_time()) * 1e6,
                quiet_median(b) * 1e6,
                quiet_median(g) * 1e6,
                b.frames.iter().map(|r| r.stats.contacts).sum::<u64>(),
                g.frames.iter().map(|r| r.missed).sum::<u64>(),
            );
        }
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    quiet_criterion(&mut c);
    quiet_table();
    animation_table();
    c.final_summary();
}
