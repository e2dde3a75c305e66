//! The particle sensor and the `sensor-gated` detector on analytic animations.

use selfcd::detect::compare::{compare_methods, MethodRun};
use selfcd::geom::distance::point_triangle_distance2;
use selfcd::scene::{grid, pinch, scale, sphere, tube, Deformation, SplitMix};
use selfcd::sensor::odl::{OriginalDistance, CUT};
use selfcd::sensor::parts::Parts;
use selfcd::sensor::tangent;
use selfcd::sensor::{Sensor, SensorParams, SurfacePoint};
use selfcd::{new_detector, DVec3, DetectorOptions, Error, Mesh, Method};
use std::f64::consts::PI;
use std::sync::Arc;

fn square(n: usize, size: f64) -> Arc<Mesh> {
    let (v, f) = grid(n, size);
    Arc::new(Mesh::new(v, f).unwrap())
}

/// Fold the half x > mid over through `max_angle * s` at frame s in [0, 1].
fn fold_frames(mesh: &Mesh, frames: usize, max_angle: f64) -> Vec<Vec<DVec3>> {
    (0..frames)
        .map(|f| {
            let s = f as f64 / (frames - 1) as f64;
            Deformation::Fold {
                angle: max_angle * s,
                radius: 0.05,
            }
            .apply(mesh.rest())
        })
        .collect()
}

/// A travelling wave of amplitude `amp * width`.
fn wave(rest: &[DVec3], width: f64, amp: f64, s: f64) -> Vec<DVec3> {
    rest.iter()
        .map(|p| {
            *p + DVec3::Z * (amp * width * (2.0 * PI * ((p.x + 0.5 * p.y) / width - 2.0 * s)).sin())
        })
        .collect()
}

/// Sensor points near the centre of an n x n grid, `gap` rest units apart (a square of four).
fn cluster(mesh: &Mesh, gap: f64) -> Vec<SurfacePoint> {
    let c = DVec3::new(0.5, 0.5, 0.0) * (mesh.rest()[mesh.n_vertices() - 1].x);
    let targets = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
        .map(|(x, y)| c + DVec3::new(x, y, 0.0) * gap * 0.5);
    targets
        .iter()
        .map(|&t| {
            let tri = (0..mesh.n_triangles())
                .min_by(|&a, &b| {
                    let d = |k: usize| {
                        mesh.corners(mesh.rest(), k)
                            .iter()
                            .sum::<DVec3>()
                            .distance(t * 3.0)
                    };
                    d(a).total_cmp(&d(b))
                })
                .unwrap();
            SurfacePoint::centroid(tri as u32)
        })
        .collect()
}

/// Frame `frame` of a long random sequence: a crumple, noise and a twist in
/// turn, each with random amplitude.
fn random_shape(frame: usize, rng: &mut SplitMix) -> Deformation {
    match frame % 3 {
        0 => Deformation::Crumple {
            amplitude: 0.4 * rng.unit(),
            wavelength: 0.2 + 0.5 * rng.unit(),
            seed: rng.next_u64(),
        },
        1 => Deformation::Noise {
            amplitude: 0.05 * rng.unit(),
            seed: rng.next_u64(),
        },
        _ => Deformation::Twist {
            turns: 2.0 * rng.unit() - 1.0,
        },
    }
}

fn min_pair_distance(p: &[DVec3]) -> f64 {
    let mut m = f64::INFINITY;
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            m = m.min(p[i].distance(p[j]));
        }
    }
    m
}

#[test]
fn particles_stay_on_the_surface_through_long_random_deformations() {
    let mesh = square(21, 1.0);
    // Aggressive motion to stress the walk: long steps, many particles.
    let params = SensorParams {
        count: 12,
        step_gain: 64.0,
        max_step: 3.0,
        n_max: 4,
        ..Default::default()
    };
    let mut sensor = Sensor::new(mesh.clone(), params).unwrap();
    let mut rng = SplitMix::new(7);
    for frame in 0..300 {
        let shape = random_shape(frame, &mut rng);
        let pos = shape.apply(mesh.rest());
        sensor.relax(&pos).unwrap();
        let extent = 2.0; // bounds every shape above
        for (p, x) in sensor.points().iter().zip(sensor.positions(&pos)) {
            p.check(&mesh).unwrap();
            assert!((p.bary.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let [a, b, c] = mesh.corners(&pos, p.tri as usize);
            let (d2, _) = point_triangle_distance2(x, a, b, c);
            assert!(
                d2.sqrt() <= 1e-9 * extent,
                "frame {frame}: particle {x} is {} off its triangle",
                d2.sqrt()
            );
            let r = p.rest_position(&mesh);
            assert!(
                r.x >= -1e-12
                    && r.x <= 1.0 + 1e-12
                    && r.y >= -1e-12
                    && r.y <= 1.0 + 1e-12
                    && r.z == 0.0,
                "left the sheet: {r}"
            );
        }
    }
}

#[test]
fn flat_and_waving_cloth_spread_the_particles_and_never_trigger() {
    for n in [11, 41] {
        let mesh = square(n, 1.0);
        let unit = mesh.mean_edge_length();
        // Start bunched up: a square of side 0.4 (4 edges on the 11 x 11 grid), above the trigger distance.
        let mut sensor =
            Sensor::with_points(mesh.clone(), SensorParams::default(), cluster(&mesh, 0.4))
                .unwrap();
        let start = min_pair_distance(&sensor.positions(mesh.rest()));
        assert!(start / unit > sensor.trigger_distance(), "start {start}");
        for f in 0..400 {
            let pos = if f < 200 {
                mesh.rest().to_vec()
            } else {
                wave(mesh.rest(), 1.0, 0.05, f as f64 / 200.0)
            };
            let r = sensor.relax(&pos).unwrap();
            assert!(
                !r.triggered,
                "n {n} frame {f}: triggered at SL {} (ODL {})",
                r.closest.sl, r.closest.odl
            );
        }
        // Spread: every pair at least 0.9 of the width apart in rest space (the corners of the square).
        let rest: Vec<DVec3> = sensor
            .points()
            .iter()
            .map(|p| p.rest_position(&mesh))
            .collect();
        assert!(
            min_pair_distance(&rest) > 0.9,
            "n {n}: not spread: {rest:?}"
        );
    }
}

/// Frames (first with contacts per the reference, first triggered) of a run of `[reference-ish, gated]`.
fn onsets(bvh: &MethodRun, gated: &MethodRun) -> (Option<usize>, Option<usize>) {
    let first_contact = bvh.frames.iter().position(|r| r.stats.contacts > 0);
    let first_trigger = gated
        .frames
        .iter()
        .position(|r| r.stats.triggered == Some(true));
    (first_contact, first_trigger)
}

#[test]
fn fold_over_the_closest_pair_is_across_the_fold_and_the_gate_fires_in_time() {
    for n in [11, 41] {
        let mesh = square(n, 1.0);
        let frames = fold_frames(&mesh, 60, 1.25 * PI);
        let opts = DetectorOptions::default();
        let runs = compare_methods(
            &mesh,
            &frames,
            &[Method::BvhConesContour, Method::SensorGated],
            &opts,
            |_| {},
        )
        .unwrap();
        let (contact, trigger) = onsets(&runs[0], &runs[1]);
        let (contact, trigger) = (
            contact.expect("the fold must self-intersect"),
            trigger.expect("the gate must fire"),
        );
        eprintln!("fold {n}x{n}: first contact frame {contact}, first trigger frame {trigger}: {} frames early", contact as i64 - trigger as i64);
        assert!(
            trigger <= contact,
            "n {n}: triggered at {trigger}, contacts from {contact}"
        );
        let missed: u64 = runs[1].frames.iter().map(|r| r.missed).sum();
        assert_eq!(missed, 0, "n {n}: the gate skipped frames with contacts");
        assert!(runs[1].frames.iter().all(|r| r.spurious == 0));

        // Replay the sensor alone to see which pair it picked.
        let mut sensor = Sensor::new(mesh.clone(), SensorParams::default()).unwrap();
        for (f, pos) in frames.iter().enumerate() {
            let r = sensor.relax(pos).unwrap();
            if f >= trigger {
                let ri = sensor.points()[r.closest.i].rest_position(&mesh);
                let rj = sensor.points()[r.closest.j].rest_position(&mesh);
                assert!(
                    (ri.x - 0.5) * (rj.x - 0.5) < 0.0,
                    "n {n} frame {f}: pair not across the fold: {ri} {rj}"
                );
                // Close in space, far along the surface: t = (ro - rs) / ro > 0, and > 1/2 once in contact.
                let t = (r.closest.odl - r.closest.sl) / r.closest.odl;
                assert!(
                    t > if f >= contact { 0.5 } else { 0.0 },
                    "n {n} frame {f}: {:?}",
                    r.closest
                );
            }
        }
    }
}

#[test]
fn scaling_the_mesh_by_1e3_gives_the_same_trajectories() {
    let small = square(21, 1.0);
    let big = square(21, 1000.0);
    let mut a = Sensor::new(small.clone(), SensorParams::default()).unwrap();
    let mut b = Sensor::new(big.clone(), SensorParams::default()).unwrap();
    let frames = fold_frames(&small, 40, 1.25 * PI);
    for (f, pos) in frames.iter().enumerate() {
        let ra = a.relax(pos).unwrap();
        let rb = b.relax(&scale(pos, 1000.0)).unwrap();
        assert_eq!(
            (ra.steps, ra.moving, ra.triggered),
            (rb.steps, rb.moving, rb.triggered),
            "frame {f}"
        );
        assert!(
            (ra.closest.sl - rb.closest.sl).abs() < 1e-9
                && (ra.closest.odl - rb.closest.odl).abs() < 1e-9
        );
        let (pa, pb) = (a.positions(pos), b.positions(&scale(pos, 1000.0)));
        for (x, y) in pa.iter().zip(&pb) {
            assert!(
                (*x / a.unit() - *y / b.unit()).length() < 1e-9,
                "frame {f}: {x} vs {y}"
            );
        }
    }
}

#[test]
fn relaxation_stops_by_n_max_or_n_min() {
    let mesh = square(21, 1.0);
    let far_from_rest = cluster(&mesh, 0.3);
    let run = |n_min: u32, n_max: u32| {
        let p = SensorParams {
            n_min,
            n_max,
            ..Default::default()
        };
        let mut s = Sensor::with_points(mesh.clone(), p, far_from_rest.clone()).unwrap();
        s.relax(mesh.rest()).unwrap()
    };
    // N_max: bunched particles all move, so only the update cap stops them.
    let r = run(1, 3);
    assert_eq!(r.steps, 3);
    assert!(r.moving >= 1);
    // N_min: given room, they settle in the corners and fewer than N_min = 1 move.
    let r = run(1, 10_000);
    assert!(r.steps < 10_000, "{r:?}");
    assert_eq!(r.moving, 0);
    // N_min above the particle count: always fewer than N_min moved, so one update.
    assert_eq!(run(5, 100).steps, 1);
    // N_min = 0: never fewer than 0 moved, so always N_max.
    let r = run(0, 7);
    assert_eq!((r.steps, r.moving), (7, r.moving));
    assert_eq!(run(0, 7).steps, 7);
}

/// A pair budget caps a frame's updates at budget / k^2 (at least one, at most N_max).
#[test]
fn the_pair_budget_caps_the_updates_of_a_frame() {
    let mesh = square(21, 1.0);
    let points = cluster(&mesh, 0.3);
    let k = points.len();
    let p = SensorParams {
        n_min: 0,
        n_max: 7,
        ..Default::default()
    };
    let mut s = Sensor::with_points(mesh.clone(), p, points).unwrap();
    assert_eq!(s.max_updates(), 7);
    for (budget, most) in [(3 * k * k + 1, 3), (k * k - 1, 1), (0, 1), (100 * k * k, 7)] {
        s.set_pair_budget(budget);
        assert_eq!(s.max_updates(), most, "budget {budget}");
        assert_eq!(s.relax(mesh.rest()).unwrap().steps, most, "budget {budget}");
    }
}

#[test]
fn sensor_gated_against_brute_counts_what_the_gate_missed() {
    let mesh = square(11, 1.0);
    type Shape = Box<dyn Fn(f64) -> Deformation>;
    let anims: [(&str, Shape); 4] = [
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
    ];
    for (name, shape) in &anims {
        let frames: Vec<Vec<DVec3>> = (0..40)
            .map(|f| shape(f as f64 / 39.0).apply(mesh.rest()))
            .collect();
        let runs = compare_methods(
            &mesh,
            &frames,
            &[Method::Brute, Method::SensorGated],
            &DetectorOptions::default(),
            |_| {},
        )
        .unwrap();
        let (brute, gated) = (&runs[0], &runs[1]);
        let mut missed_expected = 0;
        for (f, (b, g)) in brute.frames.iter().zip(&gated.frames).enumerate() {
            assert_eq!(
                (b.missed, b.spurious),
                (0, 0),
                "brute disagrees with the reference"
            );
            assert_eq!(
                g.spurious, 0,
                "{name} frame {f}: the gate reported a false contact"
            );
            match g.stats.triggered {
                Some(true) => assert_eq!(
                    (g.missed, g.stats.contacts),
                    (0, b.stats.contacts),
                    "{name} frame {f}"
                ),
                Some(false) => {
                    assert_eq!((g.stats.contacts, g.stats.primitive_tests), (0, 0));
                    missed_expected += b.stats.contacts;
                }
                None => panic!("sensor-gated must say whether it triggered"),
            }
        }
        let missed: u64 = gated.frames.iter().map(|r| r.missed).sum();
        let triggered = gated
            .frames
            .iter()
            .filter(|r| r.stats.triggered == Some(true))
            .count();
        eprintln!("{name}: triggered {triggered}/40 frames, contacts missed by the gate {missed}");
        assert_eq!(
            missed, missed_expected,
            "{name}: misses are the contacts on untriggered frames"
        );
        // The crumple too: particles added where convex parts appear, and
        // parts recounted as soon as the surface bends under the particles,
        // catch its local folds (all 1,605 missed with 4 fixed particles, 1
        // with a recount every 16 frames).
        let contacts: u64 = brute.frames.iter().map(|r| r.stats.contacts).sum();
        assert_eq!(
            missed, 0,
            "{name}: the gate skipped {missed} of {contacts} contacts"
        );
    }
}

#[test]
fn detector_api_errors_and_particles() {
    assert_eq!(
        "sensor-gated".parse::<Method>().unwrap(),
        Method::SensorGated
    );
    assert!(!Method::SensorGated.is_conservative());
    let mesh = square(11, 1.0);
    let mut det = new_detector(
        mesh.clone(),
        Method::SensorGated,
        &DetectorOptions::default(),
    )
    .unwrap();
    let d = det.detect(mesh.rest()).unwrap();
    assert_eq!(d.stats.triggered, Some(false));
    assert!(d.stats.relax_steps >= 1 && d.stats.closest_sl > 0.0 && d.stats.closest_odl > 0.0);
    assert_eq!(det.particles().len(), 4);
    assert!(
        new_detector(mesh.clone(), Method::Bvh, &DetectorOptions::default())
            .unwrap()
            .particles()
            .is_empty()
    );
    assert!(det.detect(&mesh.rest()[1..]).is_err());

    // A tilted flat sheet is fine; a curved one is refused with a typed error.
    let tilted: Vec<[f64; 3]> = mesh
        .rest()
        .iter()
        .map(|p| [p.x, p.y * 0.6, p.y * 0.8])
        .collect();
    let flat = Arc::new(Mesh::new(tilted, mesh.triangles().to_vec()).unwrap());
    assert!(new_detector(flat, Method::SensorGated, &DetectorOptions::default()).is_ok());
    let bent = Deformation::Fold {
        angle: PI / 2.0,
        radius: 0.1,
    }
    .apply(mesh.rest());
    let bent: Vec<[f64; 3]> = bent.iter().map(|p| p.to_array()).collect();
    let curved = Arc::new(Mesh::new(bent, mesh.triangles().to_vec()).unwrap());
    assert!(!Sensor::new(curved.clone(), SensorParams::default())
        .unwrap()
        .original_distance()
        .is_flat());
    assert!(new_detector(curved, Method::SensorGated, &DetectorOptions::default()).is_ok());

    for bad in [
        SensorParams {
            count: 1,
            ..Default::default()
        },
        SensorParams {
            n_max: 0,
            ..Default::default()
        },
        SensorParams {
            tolerance: f64::NAN,
            ..Default::default()
        },
        SensorParams {
            max_step: 0.0,
            ..Default::default()
        },
        SensorParams {
            a: -1.0,
            ..Default::default()
        },
        SensorParams {
            inner: Method::Brute,
            ..Default::default()
        },
    ] {
        let opts = DetectorOptions {
            sensor: bad.clone(),
            ..Default::default()
        };
        let err = new_detector(mesh.clone(), Method::SensorGated, &opts).err();
        assert!(
            matches!(err, Some(Error::InvalidParameter(_))),
            "{bad:?}: {err:?}"
        );
    }
    let off = vec![
        SurfacePoint {
            tri: 0,
            bary: [0.5, 0.6, -0.1],
        },
        SurfacePoint::centroid(1),
    ];
    assert!(Sensor::with_points(mesh, SensorParams::default(), off).is_err());
}

#[test]
fn deterministic_and_lazy_refit_gives_the_same_contacts() {
    let mesh = square(21, 1.0);
    let frames = fold_frames(&mesh, 30, 1.25 * PI);
    let run = |refit_every_frame: bool| {
        let opts = DetectorOptions {
            sensor: SensorParams {
                refit_every_frame,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut det = new_detector(mesh.clone(), Method::SensorGated, &opts).unwrap();
        frames
            .iter()
            .map(|f| {
                let d = det.detect(f).unwrap();
                (
                    d.pairs,
                    d.stats.triggered,
                    d.stats.relax_steps,
                    d.stats.closest_sl,
                    det.particles(),
                )
            })
            .collect::<Vec<_>>()
    };
    let (a, b, c) = (run(true), run(true), run(false));
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert!(
        a.iter().any(|r| !r.0.is_empty()),
        "the fold must produce contacts"
    );
}

#[test]
fn thickness_widens_the_trigger() {
    let mesh = square(11, 1.0);
    let frames = fold_frames(&mesh, 60, 1.25 * PI);
    let first = |thickness: f64| {
        let opts = DetectorOptions {
            thickness,
            ..Default::default()
        };
        let mut det = new_detector(mesh.clone(), Method::SensorGated, &opts).unwrap();
        frames
            .iter()
            .position(|f| det.detect(f).unwrap().stats.triggered == Some(true))
            .unwrap()
    };
    assert!(first(0.2) < first(0.0));
}

// ---- Any surface: curved rest shapes, several components, one triangle ----
/// Brute force and the gate on the same frames: (exact contacts, contacts the
/// gate missed, the gate's run).
fn gate_against_brute(mesh: &Arc<Mesh>, frames: &[Vec<DVec3>]) -> (u64, u64, MethodRun) {
    let mut runs = compare_methods(
        mesh,
        frames,
        &[Method::Brute, Method::SensorGated],
        &DetectorOptions::default(),
        |_| {},
    )
    .unwrap();
    let gated = runs.pop().unwrap();
    let contacts = runs[0].frames.iter().map(|r| r.stats.contacts).sum();
    let missed = gated.frames.iter().map(|r| r.missed).sum();
    (contacts, missed, gated)
}

fn mesh_of((v, f): (Vec<[f64; 3]>, Vec<[u32; 3]>)) -> Arc<Mesh> {
    Arc::new(Mesh::new(v, f).unwrap())
}

/// The n x n unit grid rolled into a half cylinder of circumference 2 (so the
/// unrolled sheet is the flat grid itself: geodesics there are flat segments).
fn half_cylinder(n: usize) -> (Arc<Mesh>, Arc<Mesh>) {
    let (v, f) = grid(n, 1.0);
    let r = 1.0 / PI;
    let curved: Vec<[f64; 3]> = v
        .iter()
        .map(|p| [r * (p[0] * PI).cos(), p[1], r * (p[0] * PI).sin()])
        .collect();
    (mesh_of((curved, f.clone())), mesh_of((v, f)))
}

/// Two n x n sheets, the second `gap` above the first (two components).
fn two_sheets(n: usize, gap: f64) -> Arc<Mesh> {
    let (mut v, mut f) = grid(n, 1.0);
    let m = v.len() as u32;
    let (v2, f2) = grid(n, 1.0);
    v.extend(v2.iter().map(|p| [p[0] + 0.13, p[1] + 0.07, gap]));
    f.extend(f2.iter().map(|t| t.map(|i| i + m)));
    mesh_of((v, f))
}

#[test]
fn geodesic_original_distance_matches_the_unrolled_cylinder() {
    let (curved, flat) = half_cylinder(41);
    let mut rng = SplitMix::new(3);
    let points: Vec<SurfacePoint> = (0..24)
        .map(|_| {
            let (a, b) = (rng.unit(), rng.unit());
            let (a, b) = if a + b > 1.0 {
                (1.0 - a, 1.0 - b)
            } else {
                (a, b)
            };
            SurfacePoint {
                tri: (rng.next_u64() % curved.n_triangles() as u64) as u32,
                bary: [1.0 - a - b, a, b],
            }
        })
        .collect();
    let mut odl = OriginalDistance::new(curved.clone());
    assert!(!odl.is_flat());
    odl.refresh(&points);
    let (mut worst_len, mut worst_angle) = (0.0f64, 0.0f64);
    for i in 0..points.len() {
        for j in 0..points.len() {
            if i == j {
                continue;
            }
            let path = odl.path(&points, i, j);
            let exact = (points[j].rest_position(&flat) - points[i].rest_position(&flat))
                / flat.mean_edge_length();
            let len = path.length * curved.mean_edge_length() / flat.mean_edge_length();
            if exact.length() > CUT - 2.0 {
                // At or beyond the field's reach: a lower bound of the true
                // distance, and not below the reach less a triangle's edge.
                assert!(
                    len <= exact.length() * 1.03 + 0.5
                        && len >= (exact.length() * 0.97 - 0.5).min(CUT - 2.0),
                    "{i}->{j}: {len} vs {}",
                    exact.length()
                );
                continue;
            }
            assert!(
                len <= exact.length() * 1.03 + 0.5 && len >= exact.length() * 0.97 - 0.5,
                "{i}->{j}: {len} vs {}",
                exact.length()
            );
            if exact.length() > 4.0 {
                worst_len = worst_len.max((len / exact.length() - 1.0).abs());
                // The direction, carried to the unrolled sheet through barycentric increments.
                let t = points[i].tri as usize;
                let (c1, c2) = tangent::edges(&curved, curved.rest(), t);
                let (f1, f2) = tangent::edges(&flat, flat.rest(), t);
                let d =
                    tangent::from_bary(f1, f2, tangent::to_bary(c1, c2, path.direction).unwrap());
                worst_angle = worst_angle.max(d.angle_between(exact));
            }
        }
    }
    eprintln!("half cylinder 41x41: worst relative length error {worst_len:.4}, worst direction error {:.2} deg", worst_angle.to_degrees());
    assert!(worst_len < 0.02, "{worst_len}");
    assert!(
        worst_angle.to_degrees() < 8.0,
        "{}",
        worst_angle.to_degrees()
    );
}

#[test]
fn several_components_carry_particles_and_are_infinitely_apart() {
    let mesh = two_sheets(11, 0.5);
    let sensor = Sensor::new(mesh.clone(), SensorParams::default()).unwrap();
    let odl = sensor.original_distance();
    let comps = odl.components();
    let on = |c: u32| {
        sensor
            .points()
            .iter()
            .filter(|p| comps[p.tri as usize] == c)
            .count()
    };
    assert_eq!((on(0), on(1)), (2, 2), "four particles shared by area");
    let p = sensor.points();
    let across = (0..p.len())
        .flat_map(|i| (0..p.len()).map(move |j| (i, j)))
        .filter(|&(i, j)| comps[p[i].tri as usize] != comps[p[j].tri as usize]);
    for (i, j) in across {
        assert!(odl.path(p, i, j).length.is_infinite());
    }
    // The top sheet comes down through the bottom one: every contact is caught.
    let frames: Vec<Vec<DVec3>> = (0..40)
        .map(|f| {
            let dz = -0.8 * f as f64 / 39.0;
            mesh.rest()
                .iter()
                .enumerate()
                .map(|(v, x)| {
                    if v >= 121 {
                        *x + DVec3::new(0.0, 0.0, dz + 0.1 * (x.x * 7.0).sin())
                    } else {
                        *x
                    }
                })
                .collect()
        })
        .collect();
    let (contacts, missed, _) = gate_against_brute(&mesh, &frames);
    eprintln!("two sheets: {contacts} contacts, {missed} missed");
    assert!(contacts > 0);
    assert_eq!(missed, 0);
}

#[test]
fn a_one_triangle_mesh_is_accepted() {
    let mesh = mesh_of((
        vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]],
        vec![[0, 1, 2]],
    ));
    let mut det = new_detector(
        mesh.clone(),
        Method::SensorGated,
        &DetectorOptions::default(),
    )
    .unwrap();
    for f in 0..5 {
        let pos: Vec<DVec3> = mesh
            .rest()
            .iter()
            .map(|p| *p * (1.0 + 0.1 * f as f64))
            .collect();
        let d = det.detect(&pos).unwrap();
        assert!(d.pairs.is_empty());
    }
    let parts = det.particles();
    assert_eq!(parts.len(), 4);
    assert!(
        min_pair_distance(&parts) > 0.0,
        "particles on distinct points"
    );
}

/// A tube and a sphere beside it (two curved components) through random motions.
#[test]
fn particles_stay_on_curved_surfaces_through_long_random_deformations() {
    let (mut v, mut f) = tube(16, 21, 0.2, 1.0);
    let m = v.len() as u32;
    let (sv, sf) = sphere(11, 16, 0.3);
    v.extend(sv.iter().map(|p| [p[0] + 0.5, p[1] + 0.6, p[2]]));
    f.extend(sf.iter().map(|t| t.map(|i| i + m)));
    let mesh = mesh_of((v, f));
    let params = SensorParams {
        count: 12,
        step_gain: 64.0,
        max_step: 3.0,
        n_max: 4,
        ..Default::default()
    };
    let mut sensor = Sensor::new(mesh.clone(), params).unwrap();
    let comps = sensor.original_distance().components().clone();
    let start: Vec<u32> = sensor
        .points()
        .iter()
        .map(|p| comps[p.tri as usize])
        .collect();
    let mut rng = SplitMix::new(11);
    for frame in 0..200 {
        let shape = random_shape(frame, &mut rng);
        let pos = shape.apply(mesh.rest());
        sensor.relax(&pos).unwrap();
        let extent = 4.0;
        for (k, (p, x)) in sensor
            .points()
            .iter()
            .zip(sensor.positions(&pos))
            .enumerate()
        {
            p.check(&mesh).unwrap();
            let [a, b, c] = mesh.corners(&pos, p.tri as usize);
            let (d2, _) = point_triangle_distance2(x, a, b, c);
            assert!(
                d2.sqrt() <= 1e-9 * extent,
                "frame {frame}: particle {x} is {} off its triangle",
                d2.sqrt()
            );
            assert_eq!(
                comps[p.tri as usize], start[k],
                "a particle changed component"
            );
        }
    }
}

/// A shape of a rest mesh at time s in [0, 1].
type Shape = fn(f64, &[DVec3]) -> Vec<DVec3>;

/// Shapes of a curved rest mesh at time s in [0, 1].
fn curved_anims() -> Vec<(&'static str, Shape)> {
    vec![
        ("fold", |s, r| {
            Deformation::Fold {
                angle: 1.25 * PI * s,
                radius: 0.05,
            }
            .apply(r)
        }),
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
        ("bend", |s, r| {
            Deformation::Fold {
                angle: 1.9 * PI * s,
                radius: 0.12,
            }
            .apply(r)
        }),
    ]
}

#[test]
fn curved_meshes_fold_roll_twist_bend_without_misses() {
    let (cyl, _) = half_cylinder(15);
    let meshes = [
        ("half-cylinder", cyl),
        ("tube", mesh_of(tube(24, 25, 0.12, 1.0))),
        ("sphere", mesh_of(sphere(11, 16, 0.5))),
    ];
    let mut total_missed = 0;
    for (mname, mesh) in &meshes {
        for (aname, shape) in curved_anims() {
            let frames: Vec<Vec<DVec3>> = (0..40)
                .map(|f| shape(f as f64 / 39.0, mesh.rest()))
                .collect();
            let (contacts, missed, gated) = gate_against_brute(mesh, &frames);
            let triggered = gated
                .frames
                .iter()
                .filter(|r| r.stats.triggered == Some(true))
                .count();
            eprintln!(
                "{mname} {aname}: {contacts} contacts, triggered {triggered}/40, missed {missed}"
            );
            total_missed += missed;
            assert!(gated.frames.iter().all(|r| r.spurious == 0));
        }
    }
    assert_eq!(total_missed, 0, "contacts missed on curved meshes");
    // The sphere squeezed until its sides pass through each other.
    let mesh = mesh_of(sphere(13, 20, 0.5));
    let frames: Vec<Vec<DVec3>> = (0..40)
        .map(|f| pinch(mesh.rest(), 1.6 * f as f64 / 39.0))
        .collect();
    let (contacts, missed, _) = gate_against_brute(&mesh, &frames);
    eprintln!("sphere squeeze: {contacts} contacts, missed {missed}");
    assert!(contacts > 0);
    assert_eq!(missed, 0);
}

#[test]
fn curved_trajectories_are_the_same_at_1e_minus_3_and_1e3() {
    let base = mesh_of(tube(24, 25, 0.12, 1.0));
    let scaled = |s: f64| {
        mesh_of((
            base.rest().iter().map(|p| (*p * s).to_array()).collect(),
            base.triangles().to_vec(),
        ))
    };
    let (small, big) = (scaled(1e-3), scaled(1e3));
    let mut a = Sensor::new(small.clone(), SensorParams::default()).unwrap();
    let mut b = Sensor::new(big.clone(), SensorParams::default()).unwrap();
    assert_eq!(a.points(), b.points(), "placement");
    for f in 0..40 {
        let shape = Deformation::Fold {
            angle: 1.25 * PI * f as f64 / 39.0,
            radius: 0.05,
        }
        .apply(base.rest());
        let (pa, pb) = (scale(&shape, 1e-3), scale(&shape, 1e3));
        let (ra, rb) = (a.relax(&pa).unwrap(), b.relax(&pb).unwrap());
        assert_eq!(
            (ra.steps, ra.moving, ra.triggered),
            (rb.steps, rb.moving, rb.triggered),
            "frame {f}"
        );
        assert!(
            (ra.closest.sl - rb.closest.sl).abs() < 1e-6 * ra.closest.sl.max(1.0),
            "frame {f}"
        );
        for (x, y) in a.positions(&pa).iter().zip(&b.positions(&pb)) {
            assert!(
                (*x / a.unit() - *y / b.unit()).length() < 1e-6,
                "frame {f}: {x} vs {y}"
            );
        }
    }
}

/// `follow_parts`: adds a particle at the anchor of each part without one
/// (largest first), merges particles sharing a part (never the last of a
/// component), and leaves every other particle where it was.
#[test]
fn follow_parts_adds_merges_and_keeps_the_rest() {
    let mesh = two_sheets(5, 0.5); // 32 triangles per sheet, two components
    let at = |t: u32| SurfacePoint::centroid(t);
    let start = vec![at(0), at(1), at(2), at(40)];
    let mut sensor =
        Sensor::with_points(mesh.clone(), SensorParams::default(), start.clone()).unwrap();
    // Parts: triangles 0..16 part 0, 16..32 part 1, the second sheet part 2.
    let three = |points: &[SurfacePoint]| Parts {
        of_point: points
            .iter()
            .map(|p| match p.tri {
                0..16 => 0,
                16..32 => 1,
                _ => 2,
            })
            .collect(),
        size: vec![16, 16, 32],
        anchor: vec![5, 20, 50],
    };
    // Target 3: one merge is enough (particle 1 shares part 0 with particle 0).
    assert_eq!(sensor.follow_parts(&three(sensor.points()), 3), (0, 1));
    assert_eq!(sensor.points(), &[at(0), at(2), at(40)]);
    // Target 4: part 1 holds none, a particle goes to its anchor; the others stay.
    assert_eq!(sensor.follow_parts(&three(sensor.points()), 4), (1, 0));
    assert_eq!(sensor.points(), &[at(0), at(2), at(40), at(20)]);
    assert_eq!(sensor.follow_parts(&three(sensor.points()), 4), (0, 0));
    // One part, target 1: the second sheet's particle is the last of its component and stays.
    let one_part = Parts {
        of_point: vec![0; sensor.points().len()],
        size: vec![64],
        anchor: vec![0],
    };
    assert_eq!(sensor.follow_parts(&one_part, 1), (0, 2));
    assert_eq!(sensor.points(), &[at(0), at(40)]);
    // The sensor still relaxes with its new particles.
    sensor.relax(mesh.rest()).unwrap();
}

/// The gated detector's particle count follows the parts of the current
/// shape: up on a crumple, back to the least count once the sheet is flat again.
#[test]
fn particle_count_follows_the_convex_parts_over_time() {
    let mesh = square(21, 1.0);
    let opts = DetectorOptions::default();
    let mut det = new_detector(mesh.clone(), Method::SensorGated, &opts).unwrap();
    // Strong enough that normals turn past 90 degrees (small bumps stay one part).
    let crumpled = Deformation::Crumple {
        amplitude: 0.2,
        wavelength: 0.4,
        seed: 1,
    }
    .apply(mesh.rest());
    let mut counts = Vec::new();
    for f in 0..96 {
        let shape = if (32..64).contains(&f) {
            &crumpled
        } else {
            mesh.rest()
        };
        det.detect(shape).unwrap();
        counts.push(det.particles().len());
    }
    let least = SensorParams::default().count;
    assert_eq!(counts[31], least, "flat sheet: one part, the least count");
    assert!(
        counts[63] > least,
        "crumpled: more parts, more particles: {counts:?}"
    );
    assert_eq!(counts[95], least, "flat again: merged back: {counts:?}");
}
