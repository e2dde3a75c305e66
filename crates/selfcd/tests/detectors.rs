//! Every detector against the brute-force exact reference, on many meshes and
//! deformations. `bvh` and `bvh-cones-contour` must match exactly; the paper's
//! `bvh-cones` (no contour test) may miss contacts: its misses are counted and
//! printed, and it must never report a contact that is not there.

use glam::{DQuat, DVec3};
use selfcd::detect::compare::diff_sorted;
use selfcd::detect::proximity_contacts;
use selfcd::scene::{grid, rigid, scale, Deformation, SplitMix};
use selfcd::{new_detector, Detection, DetectorOptions, Mesh, Method};
use std::f64::consts::PI;
use std::sync::Arc;

/// A jittered grid with randomly chosen diagonals: an irregular flat mesh.
fn irregular(n: usize, seed: u64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut rng = SplitMix::new(seed);
    let h = 1.0 / (n - 1) as f64;
    let mut v = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let interior = i > 0 && j > 0 && i < n - 1 && j < n - 1;
            let (dx, dy) = if interior {
                (0.6 * h * (rng.unit() - 0.5), 0.6 * h * (rng.unit() - 0.5))
            } else {
                (0.0, 0.0)
            };
            v.push([i as f64 * h + dx, j as f64 * h + dy, 0.0]);
        }
    }
    let id = |i: usize, j: usize| (j * n + i) as u32;
    let mut f = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if rng.unit() < 0.5 {
                f.extend([[a, b, c], [a, c, d]]);
            } else {
                f.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    (v, f)
}

fn shapes() -> Vec<(&'static str, Deformation)> {
    use Deformation::*;
    vec![
        ("flat", Flat),
        (
            "fold-apart",
            Fold {
                angle: PI,
                radius: 0.03,
            },
        ),
        (
            "fold-through",
            Fold {
                angle: 1.08 * PI,
                radius: 0.03,
            },
        ),
        (
            "fold-half-way",
            Fold {
                angle: 0.6 * PI,
                radius: 0.05,
            },
        ),
        (
            "zfold",
            ZFold {
                layers: 4,
                gap: 0.02,
            },
        ),
        (
            "crumple-gentle",
            Crumple {
                amplitude: 0.03,
                wavelength: 0.5,
                seed: 1,
            },
        ),
        (
            "crumple-strong",
            Crumple {
                amplitude: 0.3,
                wavelength: 0.4,
                seed: 2,
            },
        ),
        (
            "crumple-wild",
            Crumple {
                amplitude: 0.6,
                wavelength: 0.3,
                seed: 3,
            },
        ),
        ("twist", Twist { turns: 1.5 }),
        (
            "roll",
            Roll {
                turns: 2.0,
                gap: 0.01,
            },
        ),
        (
            "roll-tight",
            Roll {
                turns: 3.0,
                gap: 0.0,
            },
        ),
        (
            "noise",
            Noise {
                amplitude: 0.05,
                seed: 4,
            },
        ),
    ]
}

fn detect(mesh: &Arc<Mesh>, method: Method, p: &[DVec3], thickness: f64) -> Detection {
    let mut d = new_detector(
        mesh.clone(),
        method,
        &DetectorOptions {
            thickness,
            ..Default::default()
        },
    )
    .unwrap();
    d.detect(p).unwrap()
}

/// Checks every method on one configuration; returns (reference contacts, bvh-cones misses).
fn check(name: &str, mesh: &Arc<Mesh>, p: &[DVec3]) -> (usize, u64) {
    let want = detect(mesh, Method::Brute, p, 0.0).pairs;
    for m in [Method::Bvh, Method::BvhConesContour] {
        let got = detect(mesh, m, p, 0.0);
        assert_eq!(got.pairs, want, "{m} differs from brute on {name}");
        assert_eq!(got.stats.contacts as usize, want.len());
    }
    let one_shot = selfcd::self_intersections(mesh, p).unwrap();
    assert_eq!(
        one_shot, want,
        "the one-shot query differs from brute on {name}"
    );
    let paper = detect(mesh, Method::BvhCones, p, 0.0).pairs;
    let (missed, spurious) = diff_sorted(&want, &paper);
    assert_eq!(
        spurious, 0,
        "bvh-cones reported a contact that is not there on {name}"
    );
    (want.len(), missed)
}

fn meshes() -> Vec<(String, Arc<Mesh>)> {
    let mut out = Vec::new();
    for n in [11, 21] {
        let (v, f) = grid(n, 1.0);
        out.push((format!("grid{n}"), Arc::new(Mesh::new(v, f).unwrap())));
    }
    for seed in [7, 8] {
        let (v, f) = irregular(17, seed);
        out.push((
            format!("irregular{seed}"),
            Arc::new(Mesh::new(v, f).unwrap()),
        ));
    }
    // Triangles in no spatial order (the hierarchies renumber them; every
    // answer must come back in these ids).
    let (v, mut f) = irregular(17, 9);
    SplitMix::new(9).shuffle(&mut f);
    out.push(("shuffled9".into(), Arc::new(Mesh::new(v, f).unwrap())));
    out
}

/// A unit grid of `side` x `side` vertices and one crumple of it.
fn crumpled_grid(
    side: usize,
    amplitude: f64,
    wavelength: f64,
    seed: u64,
) -> (Arc<Mesh>, Vec<DVec3>) {
    let (v, f) = grid(side, 1.0);
    let mesh = Arc::new(Mesh::new(v, f).unwrap());
    let p = Deformation::Crumple {
        amplitude,
        wavelength,
        seed,
    }
    .apply(mesh.rest());
    (mesh, p)
}

#[test]
fn all_detectors_match_brute_on_varied_deformations() {
    let mut total_missed = 0;
    let mut total_contacts = 0;
    let mut intersecting_cases = 0;
    for (mname, mesh) in meshes() {
        for (sname, shape) in shapes() {
            let p = shape.apply(mesh.rest());
            let (n, missed) = check(&format!("{mname}/{sname}"), &mesh, &p);
            intersecting_cases += (n > 0) as usize;
            total_contacts += n;
            total_missed += missed;
            if missed > 0 {
                println!("bvh-cones missed {missed} of {n} contacts on {mname}/{sname}");
            }
        }
    }
    println!("bvh-cones missed {total_missed} of {total_contacts} contacts over all cases");
    assert!(
        intersecting_cases >= 10,
        "the deformations should produce intersections ({intersecting_cases})"
    );
}

#[test]
fn rigid_motions_and_scales_do_not_change_the_answer() {
    let (mesh, base) = crumpled_grid(15, 0.35, 0.4, 11);
    let want = detect(&mesh, Method::Brute, &base, 0.0).pairs;
    assert!(!want.is_empty());
    let mut rng = SplitMix::new(5);
    for k in 0..4 {
        let rot = DQuat::from_axis_angle(rng.direction(), 2.0 * PI * rng.unit());
        let moved = rigid(&base, rot, rng.direction() * 10.0);
        check(&format!("rigid{k}"), &mesh, &moved);
    }
    for s in [1e-3, 1e3] {
        let scaled_mesh = scaled_mesh(&mesh, s);
        let p = scale(&base, s);
        check(&format!("scale{s}"), &scaled_mesh, &p);
        // Scaling by a power of two is exact, so the contacts are the same ones.
        let p2 = scale(&base, if s < 1.0 { 1.0 / 1024.0 } else { 1024.0 });
        assert_eq!(
            detect(&scaled_mesh, Method::BvhConesContour, &p2, 0.0).pairs,
            want
        );
    }
}

#[test]
fn exact_touching_on_integer_coordinates() {
    // Spacing 1, integer coordinates: a flap folded flat with zero radius lies
    // exactly on the other half (coplanar overlap, touching edges and vertices).
    let (v, f) = grid(9, 8.0);
    let mesh = Arc::new(Mesh::new(v, f).unwrap());
    let folded: Vec<DVec3> = mesh
        .rest()
        .iter()
        .map(|r| {
            if r.x > 4.0 {
                DVec3::new(8.0 - r.x, r.y, 0.0)
            } else {
                *r
            }
        })
        .collect();
    let (n, _) = check("flat-fold", &mesh, &folded);
    assert!(n > 0);
    // Lift the flap by one unit, then pull one vertex down to touch the lower half at a point.
    let mut lifted: Vec<DVec3> = folded
        .iter()
        .zip(mesh.rest())
        .map(|(p, r)| if r.x > 4.0 { *p + DVec3::Z } else { *p })
        .collect();
    assert_eq!(check("lifted", &mesh, &lifted).0, 0);
    let tip = mesh
        .rest()
        .iter()
        .position(|r| r.x == 6.0 && r.y == 4.0)
        .unwrap();
    lifted[tip].z = 0.0; // lands at (2, 4, 0): a vertex of the lower half
    let (n, _) = check("vertex-touch", &mesh, &lifted);
    assert!(n > 0, "touching at a vertex counts");
}

/// Proximity keys by the definition: every vertex against every triangle not
/// containing it, every edge against every edge sharing no vertex.
fn naive_proximity(mesh: &Mesh, p: &[DVec3], d: f64) -> (Vec<(u32, u32)>, Vec<[u32; 2]>) {
    use selfcd::geom::distance::{point_triangle_distance2, segment_segment_distance2};
    let mut vt = Vec::new();
    for v in 0..mesh.n_vertices() as u32 {
        for (t, tri) in mesh.triangles().iter().enumerate() {
            let [a, b, c] = mesh.corners(p, t);
            if !tri.contains(&v) && point_triangle_distance2(p[v as usize], a, b, c).0 < d * d {
                vt.push((v, t as u32));
            }
        }
    }
    let edges = &mesh.topology().edges;
    let mut ee = Vec::new();
    for i in 0..edges.len() {
        for j in i + 1..edges.len() {
            let ([a, b], [c, e]) = (edges[i], edges[j]);
            let disjoint = ![c, e].contains(&a) && ![c, e].contains(&b);
            let q = |k: u32| p[k as usize];
            if disjoint && segment_segment_distance2(q(a), q(b), q(c), q(e)).0 < d * d {
                ee.push([i as u32, j as u32]);
            }
        }
    }
    (vt, ee)
}

#[test]
fn proximity_matches_brute() {
    for (mname, mesh) in meshes().into_iter().take(3) {
        for (sname, shape) in shapes() {
            let p = shape.apply(mesh.rest());
            let d = 0.6 * mesh.mean_edge_length();
            let want = detect(&mesh, Method::Brute, &p, d).proximity;
            let got = detect(&mesh, Method::BvhConesContour, &p, d).proximity;
            let keys = |c: &selfcd::detect::ProximityContacts| {
                (
                    c.vertex_triangle
                        .iter()
                        .map(|x| (x.vertex, x.triangle))
                        .collect::<Vec<_>>(),
                    c.edge_edge.iter().map(|x| x.edges).collect::<Vec<_>>(),
                )
            };
            let (kw, kg) = (keys(&want), keys(&got));
            assert!(
                kw == naive_proximity(&mesh, &p, d),
                "brute proximity differs from the element-pair loop on {mname}/{sname}"
            );
            assert!(
                kw == kg,
                "proximity differs on {mname}/{sname}: brute {} vt {} ee, bvh {} vt {} ee",
                kw.0.len(),
                kw.1.len(),
                kg.0.len(),
                kg.1.len()
            );
            assert!(got == want, "proximity distances differ on {mname}/{sname}");
            let (one_shot, _) = proximity_contacts(&mesh, &p, d, usize::MAX).unwrap();
            assert!(
                one_shot == want,
                "one-shot proximity differs on {mname}/{sname}"
            );
        }
    }
}

#[test]
fn same_contacts_for_any_thread_count() {
    // Large enough (5000 triangles) that the traversal runs in parallel tasks.
    let (mesh, p) = crumpled_grid(51, 0.4, 0.3, 9);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut d = Vec::new();
            for m in [Method::Bvh, Method::BvhCones, Method::BvhConesContour] {
                let det = detect(&mesh, m, &p, 0.004);
                d.push((
                    det.pairs,
                    det.proximity,
                    det.stats.primitive_tests,
                    det.stats.node_pairs,
                ));
            }
            let (near, c) = proximity_contacts(&mesh, &p, 0.004, usize::MAX).unwrap();
            (d, near, c.primitive_tests, c.node_pairs)
        })
    };
    let one = run(1);
    assert!(!one.0[0].0.is_empty() && !one.1.is_empty());
    // Two threads, and three (the work split unevenly among them).
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
    assert_eq!(one.0[0].0, detect(&mesh, Method::Brute, &p, 0.0).pairs);
    assert_eq!(one.1, one.0[0].1, "one-shot proximity against bvh's");
}

#[test]
fn cones_cull_a_flat_cloth_completely() {
    let (v, f) = grid(41, 1.0);
    let mesh = Arc::new(Mesh::new(v, f).unwrap());
    let flat = mesh.rest().to_vec();
    let s = detect(&mesh, Method::BvhConesContour, &flat, 0.0).stats;
    assert_eq!(
        (s.primitive_tests, s.self_culls, s.node_pairs),
        (0, 1, 0),
        "{s:?}"
    );
    let boxes_only = detect(&mesh, Method::Bvh, &flat, 0.0).stats;
    assert!(boxes_only.adjacent_skips > 3000, "{boxes_only:?}");
}

#[test]
fn bad_positions_are_errors_not_panics() {
    let (v, f) = grid(5, 1.0);
    let mesh = Arc::new(Mesh::new(v, f).unwrap());
    for m in Method::ALL {
        let mut d = new_detector(mesh.clone(), m, &DetectorOptions::default()).unwrap();
        assert!(d.detect(&mesh.rest()[..3]).is_err());
        let mut p = mesh.rest().to_vec();
        p[4].y = f64::INFINITY;
        assert!(d.detect(&p).is_err());
    }
    let (x, mut bad) = (mesh.rest(), mesh.rest().to_vec());
    bad[4].y = f64::INFINITY;
    assert!(proximity_contacts(&mesh, &x[..3], 0.1, 100).is_err());
    assert!(proximity_contacts(&mesh, &bad, 0.1, 100).is_err());
    for d in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(
            proximity_contacts(&mesh, x, d, 100).is_err(),
            "thickness {d}"
        );
    }
    // A thickness larger than the mesh: every non-incident pair is a contact.
    assert!(matches!(
        proximity_contacts(&mesh, x, 10.0, 100),
        Err(selfcd::Error::TooManyContacts { limit: 100, .. })
    ));
    assert!(new_detector(
        mesh,
        Method::Bvh,
        &DetectorOptions {
            thickness: f64::NAN,
            ..Default::default()
        }
    )
    .is_err());
}

/// `mesh` with its rest shape scaled by `s`.
fn scaled_mesh(mesh: &Mesh, s: f64) -> Arc<Mesh> {
    let rest = scale(mesh.rest(), s).iter().map(|p| p.to_array()).collect();
    Arc::new(Mesh::new(rest, mesh.triangles().to_vec()).unwrap())
}

#[test]
fn extreme_scales_give_the_same_pairs() {
    // Powers of two are exact, so every scale must give the unit answer; the
    // predicates would overflow at 2^360 and 2^1000 and underflow at 2^-900
    // without the filter's bounds and the exact path's power-of-two scaling,
    // and the proximity distances without the stencils' (`ccd::rescale`).
    let (mesh, base) = crumpled_grid(13, 0.35, 0.4, 3);
    let want = detect(&mesh, Method::Brute, &base, 0.0).pairs;
    assert!(want.len() > 10, "the crumple should self-intersect");
    let d = 0.6 * mesh.mean_edge_length();
    let keys = |c: &selfcd::detect::ProximityContacts| {
        let vt = c.vertex_triangle.iter().map(|x| [x.vertex, x.triangle]);
        vt.chain(c.edge_edge.iter().map(|x| x.edges))
            .collect::<Vec<_>>()
    };
    let near = keys(&proximity_contacts(&mesh, &base, d, usize::MAX).unwrap().0);
    assert!(near.len() > 100);
    for e in [-1000, -900, -360, 360, 1000] {
        let s = 2f64.powi(e);
        let scaled_mesh = scaled_mesh(&mesh, s);
        let p = scale(&base, s);
        for m in [Method::Brute, Method::Bvh, Method::BvhConesContour] {
            assert_eq!(detect(&scaled_mesh, m, &p, 0.0).pairs, want, "{m} at 2^{e}");
        }
        let one_shot = selfcd::self_intersections(&scaled_mesh, &p).unwrap();
        assert_eq!(one_shot, want, "the one-shot query at 2^{e}");
        // Proximity: the distances multiply four coordinates, which over- and
        // underflowed here before the stencils were rescaled (every contact
        // lost at 2^+-1000, a third at 2^+-360).
        let one_shot = proximity_contacts(&scaled_mesh, &p, d * s, usize::MAX)
            .unwrap()
            .0;
        assert_eq!(keys(&one_shot), near, "one-shot proximity at 2^{e}");
        for m in [Method::Brute, Method::Bvh, Method::BvhConesContour] {
            let got = detect(&scaled_mesh, m, &p, d * s).proximity;
            assert_eq!(keys(&got), near, "{m} proximity at 2^{e}");
        }
    }
}

/// Frames animating `mesh` from its rest shape to `target`: a few large
/// steps, so contact appears part way, then a wobble there in small ones.
fn animation(mesh: &Mesh, target: &[DVec3], steps: usize, wobble: usize) -> Vec<Vec<DVec3>> {
    let edge = mesh.mean_edge_length();
    (0..=steps + wobble)
        .map(|k| {
            let t = (k as f64 / steps as f64).min(1.0);
            let phase = 0.7 * k as f64;
            mesh.rest()
                .iter()
                .zip(target)
                .map(|(a, b)| {
                    let w = DVec3::new(b.y, b.z, b.x) * (2.0 * PI / (8.0 * edge));
                    let wave = DVec3::new(w.x.sin(), (w.y + 1.0).sin(), (w.z + 2.0).sin());
                    a.lerp(*b, t) + 0.03 * edge * (k > steps) as u8 as f64 * (wave * phase.cos())
                })
                .collect()
        })
        .collect()
}

/// Kept detectors over animations: each frame's pairs equal brute force's,
/// though from the third frame on the traversal starts from the front kept
/// from the last frame (rebased while the mesh deforms, its clear jobs
/// skipped in the wobble), and in the wobble many `bvh-cones-contour` culls
/// reuse contour certificates kept from earlier frames, by their slack or
/// re-checked on their close pairs (all counted, so the kept paths are run).
#[test]
fn kept_detectors_give_the_brute_force_pairs_over_sequences() {
    use selfcd::bvh::refit::ConeFit;
    use selfcd::detect::hierarchy::BvhDetector;
    use selfcd::Detector;
    let (mut reused, mut fresh, mut skipped, mut rechecked) = (0, 0, 0, 0);
    let (mut from_leaves, mut in_order) = (0, 0);
    for (mname, mesh) in meshes().into_iter().skip(1).take(2) {
        for (sname, shape) in shapes() {
            let frames = animation(&mesh, &shape.apply(mesh.rest()), 6, 10);
            for m in [Method::BvhConesContour, Method::Bvh] {
                let mut d = new_detector(mesh.clone(), m, &Default::default()).unwrap();
                let mut front_jobs = 0;
                for (k, p) in frames.iter().enumerate() {
                    let got = d.detect(p).unwrap();
                    let want = detect(&mesh, Method::Brute, p, 0.0).pairs;
                    assert_eq!(got.pairs, want, "{m} {mname}/{sname} frame {k}");
                    front_jobs += got.stats.front_jobs;
                    skipped += got.stats.front_skips;
                    if k > 6 && m == Method::BvhConesContour {
                        reused += got.stats.certificates_reused;
                        rechecked += got.stats.certificates_rechecked;
                        fresh += got.stats.contour_tests;
                    }
                }
                assert!(
                    front_jobs > 0,
                    "{m} {mname}/{sname}: no frame started from a front"
                );
            }
            // Cones from the leaves (most frames here) or merged in the
            // mesh's own order, frame by frame the same pairs.
            let mut lazy = BvhDetector::new(mesh.clone(), Method::BvhConesContour, 0.0);
            let mut merged = BvhDetector::in_mesh_order(mesh.clone(), Method::BvhConesContour, 0.0);
            for (k, p) in frames.iter().enumerate() {
                let got = lazy.detect(p).unwrap().pairs;
                assert_eq!(
                    got,
                    merged.detect(p).unwrap().pairs,
                    "{mname}/{sname} frame {k}"
                );
                from_leaves += (lazy.bvh().cones_fit == ConeFit::Leaves) as u32;
                in_order += (merged.bvh().cones_fit == ConeFit::Leaves) as u32;
            }
            // A plain traversal of the last refit (internal cones stale when
            // it fitted the leaves' only) computes them from the leaves.
            let last = frames.last().unwrap();
            let want = detect(&mesh, Method::Brute, last, 0.0).pairs;
            assert_eq!(lazy.traverse(last).unwrap().pairs, want, "{mname}/{sname}");
            // With slabs fitted every frame (their gaps are clearances too).
            let mut d = BvhDetector::new(mesh.clone(), Method::BvhConesContour, 0.0);
            d.force_slabs(Some(true));
            for (k, p) in frames.iter().enumerate() {
                let got = d.detect(p).unwrap().pairs;
                let want = detect(&mesh, Method::Brute, p, 0.0).pairs;
                assert_eq!(got, want, "slabs on, {mname}/{sname} frame {k}");
            }
        }
    }
    println!(
        "certificates reused {reused}, rechecked {rechecked}, fresh contour tests {fresh}, front jobs skipped {skipped}, frames with cones from the leaves {from_leaves}"
    );
    assert!(skipped > 1000, "front jobs skipped {skipped}");
    assert!(
        from_leaves > 50,
        "{from_leaves} frames fitted the leaves' cones only"
    );
    assert_eq!(in_order, 0, "leaves not depth-first: every cone fitted");
    assert!(rechecked > 100, "certificates rechecked {rechecked}");
    // 22,327 reused against 38,050 fresh tests when written, 33,705 against
    // 26,672 with the twelfth landing's slacks, 37,809 against 11,472 with
    // normals checked from the leaves (deterministic: the kept certificates
    // depend on the frames only, not on threads).
    assert!(reused > 10_000, "reused {reused}, fresh {fresh}");
}

/// Kept detectors over the animations scaled by powers of two (exact) give
/// the unit-scale pairs on every frame: the front's clearances and the
/// vertices' displacement bound hold at every scale (at 2^-1000 nothing is
/// clear enough to skip, and nothing may be skipped wrongly).
#[test]
fn kept_sequences_at_extreme_scales_give_the_unit_pairs() {
    let (_, mesh) = meshes().into_iter().nth(1).unwrap();
    for (sname, shape) in shapes().into_iter().skip(1).take(3) {
        let frames = animation(&mesh, &shape.apply(mesh.rest()), 6, 10);
        let want: Vec<_> = (frames.iter())
            .map(|p| detect(&mesh, Method::Brute, p, 0.0).pairs)
            .collect();
        for e in [-1000, -300, 300, 1000] {
            let s = 2f64.powi(e);
            let mut d = new_detector(
                scaled_mesh(&mesh, s),
                Method::BvhConesContour,
                &Default::default(),
            )
            .unwrap();
            let mut skipped = 0;
            for (k, p) in frames.iter().enumerate() {
                let got = d.detect(&scale(p, s)).unwrap();
                assert_eq!(got.pairs, want[k], "{sname} at 2^{e}, frame {k}");
                skipped += got.stats.front_skips;
            }
            if e.abs() == 300 {
                assert!(skipped > 0, "{sname} at 2^{e}: nothing skipped");
            }
        }
    }
}

/// A front that grew past a quarter over its length when recorded from the
/// root is recorded again from there: a flat sheet's front is its root
/// (culled); crumpled, the descent from that root deepens it, so the next
/// frame starts at the root again, and the one after from the new front.
#[test]
fn a_grown_front_is_recorded_again_from_the_root() {
    let (mesh, crumpled) = crumpled_grid(21, 0.35, 0.4, 3);
    let flat = mesh.rest().to_vec();
    let mut d = new_detector(mesh.clone(), Method::BvhConesContour, &Default::default()).unwrap();
    let jobs: Vec<u64> = [&flat, &flat, &flat, &crumpled, &crumpled, &crumpled]
        .iter()
        .map(|p| {
            let got = d.detect(p).unwrap();
            assert_eq!(got.pairs, detect(&mesh, Method::Brute, p, 0.0).pairs);
            got.stats.front_jobs
        })
        .collect();
    // Frame 1 records nothing, frame 2 records from the root (one job: the
    // root, culled), frames 3 and 4 start there, frame 5 is recorded from
    // the root again and frame 6 starts from that.
    assert_eq!(jobs[..5], [0, 0, 1, 1, 0], "{jobs:?}");
    assert!(jobs[5] > 100, "{jobs:?}");
}

/// `bvh-cones` is not conservative: from a kept front it still reports only
/// intersecting pairs, but not always the ones a traversal from the root
/// reports (pair descents split the node with the larger box this frame, so
/// a front job may stand where today's descent from the root would not pass,
/// and a cone cull there hides other pairs).
#[test]
fn a_kept_front_reports_only_intersections_with_cones() {
    use selfcd::detect::hierarchy::BvhDetector;
    use selfcd::Detector;
    let (mut differ, mut frames, mut front_jobs) = (0, 0, 0);
    for (mname, mesh) in meshes().into_iter().skip(1).take(2) {
        for (sname, shape) in shapes() {
            let mut d = BvhDetector::new(mesh.clone(), Method::BvhCones, 0.0);
            for (k, p) in animation(&mesh, &shape.apply(mesh.rest()), 6, 10)
                .iter()
                .enumerate()
            {
                let got = d.detect(p).unwrap();
                let exact = detect(&mesh, Method::Brute, p, 0.0).pairs;
                assert!(
                    got.pairs.iter().all(|x| exact.contains(x)),
                    "{mname}/{sname} frame {k}"
                );
                differ += (got.pairs != d.traverse(p).unwrap().pairs) as u32;
                frames += 1;
                front_jobs += got.stats.front_jobs;
            }
        }
    }
    println!("frames whose pairs differ from the root's: {differ} of {frames}");
    assert!(front_jobs > 0);
}

#[test]
fn slabs_give_the_brute_force_answers() {
    use selfcd::detect::hierarchy::BvhDetector;
    use selfcd::Detector;
    let mut culls = 0;
    for (mname, mesh) in meshes() {
        for (sname, shape) in shapes() {
            let target = shape.apply(mesh.rest());
            let d = 0.6 * mesh.mean_edge_length();
            // Half-way, fully deformed, and a layer stacked a tenth of an edge above.
            let half: Vec<DVec3> = mesh
                .rest()
                .iter()
                .zip(&target)
                .map(|(a, b)| a.lerp(*b, 0.5))
                .collect();
            for p in [half, target] {
                let want = detect(&mesh, Method::Brute, &p, d);
                for m in [Method::Bvh, Method::BvhCones, Method::BvhConesContour] {
                    let mut det = BvhDetector::new(mesh.clone(), m, d);
                    det.force_slabs(Some(true));
                    let got = det.detect(&p).unwrap();
                    culls += got.stats.slab_culls;
                    if m != Method::BvhCones {
                        assert_eq!(got.pairs, want.pairs, "{m} with slabs on {mname}/{sname}");
                    }
                    assert!(
                        got.proximity == want.proximity,
                        "{m} proximity with slabs on {mname}/{sname}"
                    );
                }
            }
        }
    }
    // Two sheets a tenth of an edge apart: boxes overlap, slabs do not.
    let (v, f) = grid(21, 1.0);
    let mut v2 = v.clone();
    v2.extend(v.iter().map(|p| [p[0], p[1], p[2] + 0.005]));
    let mut f2 = f.clone();
    f2.extend(f.iter().map(|t| t.map(|i| i + v.len() as u32)));
    let mesh = Arc::new(Mesh::new(v2, f2).unwrap());
    let p = Deformation::Twist { turns: 0.1 }.apply(mesh.rest());
    let mut det = BvhDetector::new(mesh.clone(), Method::BvhConesContour, 0.0);
    det.force_slabs(Some(true));
    let got = det.detect(&p).unwrap();
    assert_eq!(got.pairs, detect(&mesh, Method::Brute, &p, 0.0).pairs);
    culls += got.stats.slab_culls;
    assert!(
        got.stats.slab_culls > 100,
        "stacked sheets: {:?}",
        got.stats
    );
    println!("slab culls {culls}");
}

/// A flat annular sector (radii 10 to 14, one unit apart; about one unit
/// along each ring) whose two ends are `gap` apart at the inner ring: one
/// disk, a height field, every triangle's altitude above 0.6, so only the
/// proximity certificate's contour clearance can see the ends come close.
fn open_ring(gap: f64) -> Arc<Mesh> {
    let (rings, steps) = (5usize, 60usize);
    let sweep = 2.0 * PI - gap / 10.0;
    let mut v = Vec::new();
    for i in 0..rings {
        for j in 0..=steps {
            let (r, a) = (10.0 + i as f64, sweep * j as f64 / steps as f64);
            v.push([r * a.cos(), r * a.sin(), 0.0]);
        }
    }
    let id = |i: usize, j: usize| (i * (steps + 1) + j) as u32;
    let mut f = Vec::new();
    for i in 0..rings - 1 {
        for j in 0..steps {
            f.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
        }
    }
    Arc::new(Mesh::new(v, f).unwrap())
}

#[test]
fn proximity_certificates_cull_flat_patches_and_keep_close_ends() {
    // A flat sheet at 0.6 edges: its root certifies, nothing is tested.
    let (v, f) = grid(41, 1.0);
    let mesh = Arc::new(Mesh::new(v, f).unwrap());
    let d = 0.6 * mesh.mean_edge_length();
    let (near, c) = proximity_contacts(&mesh, mesh.rest(), d, usize::MAX).unwrap();
    assert!(near.is_empty());
    assert_eq!((c.self_culls, c.primitive_tests), (1, 0), "{c:?}");
    // The open ring: its ends 2 apart, nothing near, and certified whole; 0.2
    // apart, the ends' vertices and edges are contacts, which the contour's
    // clearance (not the altitudes) keeps from being certified away.
    let d = 0.5;
    for (gap, certified) in [(2.0, true), (0.2, false)] {
        let mesh = open_ring(gap);
        let x = mesh.rest();
        let (near, c) = proximity_contacts(&mesh, x, d, usize::MAX).unwrap();
        let want = detect(&mesh, Method::Brute, x, d).proximity;
        assert_eq!(near, want, "gap {gap}");
        assert_eq!(near.is_empty(), certified, "gap {gap}: {near:?}");
        assert_eq!(c.primitive_tests == 0, certified, "gap {gap}: {c:?}");
    }
}
