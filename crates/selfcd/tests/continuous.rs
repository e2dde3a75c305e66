//! Continuous queries: the BVH query against the element-pair loop, and no
//! false negatives against intersections found by dense discrete sampling.

use glam::DVec3;
use selfcd::detect::continuous::{continuous_impacts, element_toi, Impacts};
use selfcd::detect::hierarchy::BvhDetector;
use selfcd::detect::narrow::ElementPair;
use selfcd::geom::distance::HullCull;
use selfcd::scene::{grid, Deformation};
use selfcd::{self_intersections, Mesh, Method};
use std::f64::consts::PI;
use std::sync::Arc;

fn mesh(n: usize) -> Arc<Mesh> {
    let (v, f) = grid(n, 1.0);
    Arc::new(Mesh::new(v, f).unwrap())
}

/// Steps (start shape, end shape) that pass through or near themselves.
fn steps() -> Vec<(&'static str, Deformation, Deformation)> {
    use Deformation::*;
    vec![
        (
            "fold-through",
            Fold {
                angle: 0.9 * PI,
                radius: 0.02,
            },
            Fold {
                angle: 1.15 * PI,
                radius: 0.02,
            },
        ),
        // Ends 0.01 apart: within a separation of 0.02, never touching.
        (
            "fold-close",
            Fold {
                angle: 0.8 * PI,
                radius: 0.005,
            },
            Fold {
                angle: PI,
                radius: 0.005,
            },
        ),
        (
            "crumple-grow",
            Crumple {
                amplitude: 0.05,
                wavelength: 0.4,
                seed: 3,
            },
            Crumple {
                amplitude: 0.3,
                wavelength: 0.4,
                seed: 3,
            },
        ),
        (
            "roll",
            Roll {
                turns: 0.5,
                gap: 0.01,
            },
            Roll {
                turns: 2.0,
                gap: 0.0,
            },
        ),
    ]
}

/// Every element pair by the definition: all vertices against all triangles, all edge pairs.
fn naive(mesh: &Mesh, x0: &[DVec3], x1: &[DVec3], xi: f64) -> Vec<(ElementPair, f64)> {
    let mut out = Vec::new();
    for v in 0..mesh.n_vertices() as u32 {
        for t in 0..mesh.n_triangles() as u32 {
            let p = ElementPair::VertexTriangle(v, t);
            if let Some(toi) = element_toi(mesh, x0, x1, p, xi) {
                out.push((p, toi));
            }
        }
    }
    let ne = mesh.topology().edges.len() as u32;
    for a in 0..ne {
        for b in a + 1..ne {
            let p = ElementPair::EdgeEdge(a, b);
            if let Some(toi) = element_toi(mesh, x0, x1, p, xi) {
                out.push((p, toi));
            }
        }
    }
    out
}

fn flat(i: &Impacts) -> Vec<(ElementPair, f64)> {
    i.vertex_triangle
        .iter()
        .chain(&i.edge_edge)
        .map(|x| (x.pair, x.toi))
        .collect()
}

/// A continuous query: on a kept hierarchy, or the one-shot one.
type Query = fn(&Arc<Mesh>, &[DVec3], &[DVec3], f64) -> Impacts;

/// Both continuous queries, by name.
fn queries() -> [(&'static str, Query); 2] {
    fn kept(m: &Arc<Mesh>, x0: &[DVec3], x1: &[DVec3], xi: f64) -> Impacts {
        let mut det = BvhDetector::new(m.clone(), Method::Bvh, 0.0);
        det.continuous(x0, x1, xi).unwrap()
    }
    fn one_shot(m: &Arc<Mesh>, x0: &[DVec3], x1: &[DVec3], xi: f64) -> Impacts {
        continuous_impacts(m, x0, x1, xi).unwrap().0
    }
    [("kept", kept), ("one-shot", one_shot)]
}

/// With a thickness nothing is certified: both queries give exactly the
/// element-pair loop (at thickness 0, see `swept_certificate_keeps_every_contact`).
#[test]
fn bvh_query_matches_the_element_pair_loop() {
    let m = mesh(9);
    for (name, a, b) in steps() {
        let (x0, x1) = (a.apply(m.rest()), b.apply(m.rest()));
        for xi in [0.0, 0.02] {
            let mut want = naive(&m, &x0, &x1, xi);
            want.sort_by_key(|(p, _)| *p);
            let touches = name != "fold-close" || xi > 0.0;
            assert_eq!(!want.is_empty(), touches, "{name}: something within {xi}?");
            for (query, run) in queries() {
                if xi == 0.0 && query == "one-shot" {
                    continue;
                }
                let mut have = flat(&run(&m, &x0, &x1, xi));
                have.sort_by_key(|(p, _)| *p);
                assert_eq!(have, want, "{query}: {name}, xi {xi}");
            }
        }
    }
}

/// Smallest distance of `pair` over the step, sampled at `n + 1` times.
fn sampled_min_distance(
    mesh: &Mesh,
    x0: &[DVec3],
    x1: &[DVec3],
    pair: ElementPair,
    n: usize,
) -> f64 {
    (0..=n)
        .map(|k| {
            let t = k as f64 / n as f64;
            let x: Vec<DVec3> = x0.iter().zip(x1).map(|(a, b)| *a + (*b - *a) * t).collect();
            pair.distance_within(mesh, &x, &HullCull::new(f64::INFINITY, &x))
                .unwrap_or(f64::INFINITY)
        })
        .fold(f64::INFINITY, f64::min)
}

/// At thickness 0 the swept certificate skips patches that stay free of
/// contact: the answer is the element-pair loop's, less only pairs that the
/// additive CCD reported within its resolution but that never touch (their
/// sampled distance stays well above zero). Steps that bend, twist, move
/// rigidly, stand still, and fold, roll or crumple through themselves.
#[test]
fn swept_certificate_keeps_every_contact() {
    use Deformation::*;
    let m = mesh(12);
    let mut all = steps();
    all.extend([
        (
            "bend",
            Flat,
            Crumple {
                amplitude: 0.05,
                wavelength: 0.5,
                seed: 1,
            },
        ),
        ("twist", Twist { turns: 0.1 }, Twist { turns: 0.4 }),
        (
            "still",
            Fold {
                angle: 0.5 * PI,
                radius: 0.05,
            },
            Fold {
                angle: 0.5 * PI,
                radius: 0.05,
            },
        ),
        (
            "noise",
            Flat,
            Noise {
                amplitude: 0.004,
                seed: 5,
            },
        ),
    ]);
    for (name, a, b) in all {
        let (x0, mut x1) = (a.apply(m.rest()), b.apply(m.rest()));
        if name == "twist" {
            // And a rigid motion on top: a turn about z and a shift.
            let (c, s) = (0.3f64.cos(), 0.3f64.sin());
            x1.iter_mut().for_each(|p| {
                *p = DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z) + DVec3::splat(0.7)
            });
        }
        let touches = name != "fold-close" && !["bend", "twist", "still", "noise"].contains(&name);
        assert_keeps_every_contact(&m, &x0, &x1, name, touches);
    }
}

/// Both queries at thickness 0 give the element-pair loop's answer, less
/// only pairs that never come within 1e-4 (sampled); something is found
/// exactly when `touches`.
fn assert_keeps_every_contact(
    m: &Arc<Mesh>,
    x0: &[DVec3],
    x1: &[DVec3],
    name: &str,
    touches: bool,
) {
    let want = naive(m, x0, x1, 0.0);
    for (query, run) in queries() {
        let got = flat(&run(m, x0, x1, 0.0));
        for g in &got {
            assert!(
                want.contains(g),
                "{query}, {name}: {g:?} not in the element-pair loop"
            );
        }
        for w in want.iter().filter(|w| !got.contains(w)) {
            let d = sampled_min_distance(m, x0, x1, w.0, 2000);
            assert!(
                d > 1e-4,
                "{query}, {name}: {w:?} dropped but comes within {d}"
            );
        }
        assert_eq!(!got.is_empty(), touches, "{query}, {name}: contact found?");
    }
}

/// A sheet folded into layers half an edge apart (the benchmark's folded
/// grid, smaller), moved by a wave of one and a half gaps: the layers
/// pass into each other in places. Away from the creases the one-shot
/// query's small swept leaves hold their own certificates
/// (`bvh::topdown`'s `SWEPT_LEAF`); the answer must not lose a contact.
#[test]
fn folded_layers_keep_every_contact() {
    let n = 25;
    let m = mesh(n);
    let e = 1.0 / (n - 1) as f64;
    // Sheared along x so that the layers' vertices are not stacked exactly
    // (a vertex passing a rounding error beside another is no test).
    let x0: Vec<DVec3> = Deformation::ZFold {
        layers: 4,
        gap: 0.5 * e,
    }
    .apply(m.rest())
    .iter()
    .map(|p| *p + DVec3::X * (0.3 * p.z))
    .collect();
    assert!(self_intersections(&m, &x0).unwrap().is_empty());
    // Layers j gap apart move by +-0.4 e sin(k x) cos(k y) in turn (cos of
    // pi z / gap): neighbours close by up to 0.8 e, so meet in places.
    let k = 2.0 * PI / (8.0 * e);
    let x1: Vec<DVec3> = x0
        .iter()
        .map(|p| {
            let bump = 0.4 * e * (k * p.x).sin() * (k * p.y).cos() * (PI * p.z / (0.5 * e)).cos();
            *p + DVec3::new(0.0, 0.0, bump)
        })
        .collect();
    assert_keeps_every_contact(&m, &x0, &x1, "folded", true);
    // (Before leaves tried their certificates, none held here: 0 culls.)
    let (_, c) = continuous_impacts(&m, &x0, &x1, 0.0).unwrap();
    assert!(c.self_culls > 0, "no certified leaf: {c:?}");
}

#[test]
fn no_intersection_is_reached_before_the_reported_time() {
    let m = mesh(11);
    for (name, a, b) in steps() {
        let (x0, x1) = (a.apply(m.rest()), b.apply(m.rest()));
        assert!(
            self_intersections(&m, &x0).unwrap().is_empty(),
            "{name} must start clean"
        );
        let impacts: Vec<_> = queries()
            .iter()
            .map(|(_, run)| flat(&run(&m, &x0, &x1, 0.0)))
            .collect();
        let mut checked = 0;
        for k in 1..=64 {
            let s = k as f64 / 64.0;
            let xs: Vec<DVec3> = x0.iter().zip(&x1).map(|(p, q)| p.lerp(*q, s)).collect();
            for [ta, tb] in self_intersections(&m, &xs).unwrap() {
                checked += 1;
                let (fa, fb) = (m.triangles()[ta as usize], m.triangles()[tb as usize]);
                let ea = m.topology().tri_edges[ta as usize];
                let eb = m.topology().tri_edges[tb as usize];
                let covers = |p: &ElementPair| match *p {
                    ElementPair::VertexTriangle(v, t) => {
                        (fa.contains(&v) && t == tb) || (fb.contains(&v) && t == ta)
                    }
                    ElementPair::EdgeEdge(e0, e1) => {
                        (ea.contains(&e0) && eb.contains(&e1))
                            || (ea.contains(&e1) && eb.contains(&e0))
                    }
                };
                for found in &impacts {
                    let first = found
                        .iter()
                        .filter(|(p, _)| covers(p))
                        .map(|(_, t)| *t)
                        .fold(f64::INFINITY, f64::min);
                    assert!(first <= s, "{name}: triangles {ta},{tb} intersect at t = {s}, first impact reported {first}");
                }
            }
        }
        assert!(
            checked > 0 || name == "fold-close",
            "{name}: the step should intersect somewhere"
        );
    }
}

#[test]
fn bad_inputs_are_errors() {
    let m = mesh(5);
    let mut det = BvhDetector::new(m.clone(), Method::Bvh, 0.0);
    let x = m.rest().to_vec();
    assert!(det.continuous(&x, &x[..3], 0.0).is_err());
    assert!(det.continuous(&x, &x, -1.0).is_err());
    let mut nan = x.clone();
    nan[0].x = f64::NAN;
    assert!(det.continuous(&x, &nan, 0.0).is_err());
    assert_eq!(det.continuous(&x, &x, 0.0).unwrap(), Impacts::default());
    assert!(continuous_impacts(&m, &x, &x[..3], 0.0).is_err());
    assert!(continuous_impacts(&m, &x, &x, f64::INFINITY).is_err());
    assert!(continuous_impacts(&m, &x, &nan, 0.0).is_err());
    assert_eq!(
        continuous_impacts(&m, &x, &x, 0.0).unwrap().0,
        Impacts::default()
    );
}

/// Coherent queries (one hierarchy, candidate set reused across frames) give
/// exactly what fresh queries give, frame after frame of a simulated
/// sequence that folds onto itself: through the rebuild path, the reuse path
/// with most pairs covered (default skin) and with most pairs left to the
/// motion-culled traversal (a skin of a hundredth of an edge).
#[test]
fn coherent_queries_equal_fresh_ones_on_a_simulated_sequence() {
    use selfcd::cloth::PaperScene;
    use selfcd::detect::coherent::SelfQueries;
    use selfcd::detect::Detector;
    use selfcd::FrameStats;

    let mut sim = PaperScene::Center
        .simulation(31, Method::BvhConesContour)
        .unwrap();
    let mesh = sim.cloth().mesh().clone();
    let e = mesh.mean_edge_length();
    let reach = sim.options().contact.detection_distance();
    let mut coherent = SelfQueries::new(mesh.clone(), 0.25 * e).unwrap();
    let mut thin = SelfQueries::new(mesh.clone(), 0.01 * e).unwrap();
    // Proximity alone, thin skin: its sets die young, so it answers one-shot
    // in streaks between them (module doc of `coherent`).
    let mut alone = SelfQueries::new(mesh.clone(), 0.01 * e).unwrap();
    let mut fresh = BvhDetector::new(mesh.clone(), Method::Bvh, reach);
    let (mut stats, mut thin_stats) = (FrameStats::default(), FrameStats::default());
    let mut alone_stats = FrameStats::default();
    let (mut contacts, mut impacts) = (0, 0);
    let mut x0 = sim.positions().to_vec();
    for frame in 0..240 {
        sim.step().unwrap();
        let x1 = sim.positions().to_vec();
        let want = fresh.detect(&x0).unwrap().proximity;
        let near = coherent.proximity(&x0, reach, &mut stats).unwrap();
        assert_eq!(near, want, "frame {frame}");
        let near = thin.proximity(&x0, reach, &mut thin_stats).unwrap();
        assert_eq!(near, want, "frame {frame}, thin skin");
        let near = alone.proximity(&x0, reach, &mut alone_stats).unwrap();
        assert_eq!(near, want, "frame {frame}, proximity alone");
        contacts += near.vertex_triangle.len() + near.edge_edge.len();
        // Every tenth frame also a step five times as long, which the
        // proximity answer at x0 covers less of (the step's motion culls less).
        let long: Vec<_> = x0
            .iter()
            .zip(&x1)
            .map(|(a, b)| *a + 5.0 * (*b - *a))
            .collect();
        let ends: &[&[_]] = if frame % 10 == 0 {
            &[&x1, &long]
        } else {
            &[&x1]
        };
        for (separation, x1) in [0.05 * e, reach, 1.5 * reach]
            .into_iter()
            .flat_map(|s| ends.iter().map(move |x1| (s, *x1)))
        {
            let want = fresh.continuous(&x0, x1, separation).unwrap();
            let got = coherent
                .continuous(&x0, x1, separation, &mut stats)
                .unwrap();
            assert_eq!(got, want, "frame {frame}, separation {separation}");
            let got = thin
                .continuous(&x0, x1, separation, &mut thin_stats)
                .unwrap();
            assert_eq!(
                got, want,
                "frame {frame}, separation {separation}, thin skin"
            );
            impacts += got.vertex_triangle.len() + got.edge_edge.len();
        }
        let pairs = coherent.intersections(&x1, true, &mut stats).unwrap();
        assert_eq!(pairs, fresh.detect(&x1).unwrap().pairs, "frame {frame}");
        x0 = x1;
    }
    for (name, s) in [("default", &stats), ("thin", &thin_stats)] {
        eprintln!(
            "coherent, {name} skin: {contacts} contacts, {impacts} impacts, {} builds, {} reuses, {} one-shot proximity answers, {} leaf tests",
            s.candidate_builds, s.candidate_reuses, s.proximity_one_shots, s.proximity_tests
        );
        assert!(s.candidate_builds > 1 && s.candidate_reuses > s.candidate_builds);
        // Each frame's thinnest query starts where the proximity was taken
        // (for the five-times-longer step too), the wider ones do not fit in
        // its reach.
        assert_eq!(s.continuous_from_proximity, 240 + 24, "{name}");
    }
    let s = &alone_stats;
    eprintln!(
        "proximity alone, thin skin: {} builds, {} reuses, {} one-shot answers",
        s.candidate_builds, s.candidate_reuses, s.proximity_one_shots
    );
    assert!(s.proximity_one_shots > 0 && s.candidate_builds > 1 && s.candidate_reuses > 0);
    assert!(
        contacts > 0 && impacts > 0,
        "nothing came near: nothing tested"
    );
    assert!(
        thin_stats.self_culls > 0 && thin_stats.pair_culls > 0,
        "the motion cull never decided"
    );
}

/// A rigid translation keeps the candidate set (distances do not change), and
/// the answers still equal a fresh query's at the translated positions; a
/// motion wider than the skin is answered by the motion-culled traversal and
/// makes the next query of the same distance rebuild the set.
#[test]
fn translation_reuses_the_candidate_set() {
    use selfcd::detect::coherent::SelfQueries;
    use selfcd::detect::Detector;
    use selfcd::FrameStats;

    let m = mesh(24);
    let x = Deformation::Fold {
        angle: 0.95 * PI,
        radius: 0.03,
    }
    .apply(m.rest());
    let e = m.mean_edge_length();
    let d = 0.6 * e;
    let mut q = SelfQueries::new(m.clone(), 0.25 * e).unwrap();
    let mut fresh = BvhDetector::new(m.clone(), Method::Bvh, d);
    let mut s = FrameStats::default();
    let first = q.proximity(&x, d, &mut s).unwrap();
    assert_eq!(first, fresh.detect(&x).unwrap().proximity);
    assert!(
        !first.vertex_triangle.is_empty(),
        "the fold must come near itself"
    );
    let moved: Vec<DVec3> = x.iter().map(|p| *p + DVec3::new(3.0, -2.0, 7.0)).collect();
    let again = q.proximity(&moved, d, &mut s).unwrap();
    assert_eq!(again, fresh.detect(&moved).unwrap().proximity);
    assert_eq!((s.candidate_builds, s.candidate_reuses), (1, 1));
    // Folding further moves one half against the other: covered far from the
    // hinge, traversed near it.
    let bent = Deformation::Fold {
        angle: 0.7 * PI,
        radius: 0.03,
    }
    .apply(m.rest());
    let other = q.proximity(&bent, d, &mut s).unwrap();
    assert_eq!(other, fresh.detect(&bent).unwrap().proximity);
    assert_eq!((s.candidate_builds, s.candidate_reuses), (1, 2));
    // Every vertex jittered by about an edge from the translated state:
    // nothing is covered, the traversal answers, and the next query rebuilds.
    let mut q = SelfQueries::new(m.clone(), 0.25 * e).unwrap();
    let mut s = FrameStats::default();
    q.proximity(&x, d, &mut s).unwrap();
    let jitter: Vec<DVec3> = x
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let a = i as f64 * 2.399;
            *p + 0.4 * e * DVec3::new(a.cos(), a.sin(), (3.0 * a).cos())
        })
        .collect();
    let shaken = q.proximity(&jitter, d, &mut s).unwrap();
    assert_eq!(shaken, fresh.detect(&jitter).unwrap().proximity);
    assert_eq!((s.candidate_builds, s.candidate_reuses), (1, 1));
    // Staleness is per kind of query: one at another distance keeps the set
    // (and answers right from it and its traversal) ...
    let near = q.proximity(&jitter, 0.5 * d, &mut s).unwrap();
    let mut thin = BvhDetector::new(m.clone(), Method::Bvh, 0.5 * d);
    assert_eq!(near, thin.detect(&jitter).unwrap().proximity);
    assert_eq!((s.candidate_builds, s.candidate_reuses), (1, 2));
    // ... and the next query at `d` needs a new set. The set served only
    // two queries, so that query and the next three are answered one-shot
    // (the same contacts), then a new set is built, and used again.
    let counts = |s: &FrameStats| {
        (
            s.candidate_builds,
            s.candidate_reuses,
            s.proximity_one_shots,
        )
    };
    let again = q.proximity(&jitter, d, &mut s).unwrap();
    assert_eq!(again, shaken);
    assert_eq!(counts(&s), (1, 2, 1));
    for _ in 0..3 {
        assert_eq!(q.proximity(&jitter, d, &mut s).unwrap(), shaken);
    }
    assert_eq!(counts(&s), (1, 2, 4));
    assert_eq!(q.proximity(&jitter, d, &mut s).unwrap(), shaken);
    assert_eq!(counts(&s), (2, 2, 4));
    assert_eq!(q.proximity(&jitter, d, &mut s).unwrap(), shaken);
    assert_eq!(counts(&s), (2, 3, 4));
    // A continuous query from a one-shot answer's positions reads it.
    let mut q = SelfQueries::new(m.clone(), 0.25 * e).unwrap();
    let mut s = FrameStats::default();
    q.proximity(&x, d, &mut s).unwrap();
    for _ in 0..2 {
        q.proximity(&jitter, d, &mut s).unwrap();
    }
    assert_eq!(counts(&s), (1, 1, 1));
    let step: Vec<DVec3> = jitter
        .iter()
        .map(|p| *p + DVec3::new(0.0, 0.0, 0.1 * e))
        .collect();
    let got = q.continuous(&jitter, &step, 0.2 * d, &mut s).unwrap();
    assert_eq!(got, fresh.continuous(&jitter, &step, 0.2 * d).unwrap());
    assert_eq!(s.continuous_from_proximity, 1);
}

/// The continuous stage's rounds: a query repeated from the same start with
/// the end positions of a few vertices changed (as impulses change their
/// velocities) re-tests only the triangles touching them, and must still
/// answer exactly what a fresh query gives; so must a repeat where nothing
/// changed and one where most vertices changed (a whole query). Every
/// fourth frame starts with a proximity query at `x0`, as the simulator's
/// step does, and adds a fast common slide to the step: its continuous
/// queries then read that answer, and their repeats cull by the start's
/// node boxes (the axis cull of `RepeatCull`).
#[test]
fn repeated_continuous_queries_equal_fresh_ones() {
    use selfcd::cloth::PaperScene;
    use selfcd::detect::coherent::SelfQueries;
    use selfcd::FrameStats;

    let mut sim = PaperScene::Center
        .simulation(31, Method::BvhConesContour)
        .unwrap();
    let mesh = sim.cloth().mesh().clone();
    let e = mesh.mean_edge_length();
    let contact = sim.options().contact;
    let mut q = SelfQueries::new(mesh.clone(), 0.25 * e).unwrap();
    let mut fresh = BvhDetector::new(mesh.clone(), Method::Bvh, 0.0);
    let mut s = FrameStats::default();
    let (mut repeated_impacts, mut rounds, mut repeats_after_proximity) = (0, 0, 0);
    let mut x0 = sim.positions().to_vec();
    for frame in 0..120 {
        sim.step().unwrap();
        let mut x1 = sim.positions().to_vec();
        // The simulator's continuous thickness, and a wider one that finds more.
        let thickness = if frame % 2 == 0 {
            0.05 * e
        } else {
            contact.detection_distance()
        };
        let after_proximity = frame % 4 == 0;
        if after_proximity {
            q.proximity(&x0, contact.detection_distance(), &mut s)
                .unwrap();
            // A fast common slide along the sheet on top: every swept box
            // then overlaps its neighbours', which the relative motion
            // keeps apart.
            x1.iter_mut().for_each(|p| p.x += 4.0 * e);
        }
        let repeats_before = s.continuous_repeats;
        for round in 0..4 {
            let got = q.continuous(&x0, &x1, thickness, &mut s).unwrap();
            let want = fresh.continuous(&x0, &x1, thickness).unwrap();
            assert_eq!(got, want, "frame {frame}, round {round}");
            if round > 0 {
                repeated_impacts += got.vertex_triangle.len() + got.edge_edge.len();
            }
            rounds += 1;
            // Slow down the vertices of what was found (an impulse), or, in
            // the last round of some frames, most of the mesh.
            let mut slow = |v: u32| {
                let i = v as usize;
                x1[i] = x0[i] + 0.5 * (x1[i] - x0[i]);
            };
            if round == 2 && frame % 5 == 0 {
                (0..mesh.n_vertices() as u32)
                    .filter(|v| v % 3 != 0)
                    .for_each(&mut slow);
                continue;
            }
            let topo = mesh.topology();
            for i in got.vertex_triangle.iter().chain(&got.edge_edge) {
                match i.pair {
                    ElementPair::VertexTriangle(v, t) => {
                        slow(v);
                        mesh.triangles()[t as usize].into_iter().for_each(&mut slow);
                    }
                    ElementPair::EdgeEdge(a, b) => {
                        topo.edges[a as usize].into_iter().for_each(&mut slow);
                        topo.edges[b as usize].into_iter().for_each(&mut slow);
                    }
                }
            }
        }
        if after_proximity {
            repeats_after_proximity += s.continuous_repeats - repeats_before;
        }
        x0 = sim.positions().to_vec();
    }
    eprintln!(
        "{rounds} queries: {} repeats ({repeats_after_proximity} after a proximity query), {} builds, {} reuses, {} from the proximity answer, {repeated_impacts} impacts in repeats",
        s.continuous_repeats, s.candidate_builds, s.candidate_reuses, s.continuous_from_proximity
    );
    assert!(s.continuous_from_proximity > 0 && repeats_after_proximity > 0);
    // Rounds 1-3 of every frame may repeat round 0's query; most of them
    // should (round 2 of every fifth frame changes too many vertices).
    let repeatable = rounds * 3 / 4;
    assert!(
        s.continuous_repeats > repeatable / 2,
        "the repeat path was not taken"
    );
    assert!(s.candidate_reuses > 0 && s.candidate_builds > 0);
    assert!(
        repeated_impacts > 0,
        "no repeat found anything: nothing tested"
    );
}

/// A power-of-two scale is exact, so both queries must give the same impact
/// pairs at any scale (before the CCD normalised its stencils, a sheet at
/// 2^300 or 2^-300 lost every impact and one at 2^600 gained thousands);
/// at thickness 0 the one-shot query's certificate must not be fooled by
/// overflowing or underflowing normals either.
#[test]
fn extreme_scales_give_the_same_impact_pairs() {
    let m = mesh(9);
    let keys = |i: &Impacts| flat(i).into_iter().map(|(p, _)| p).collect::<Vec<_>>();
    let mut checked = 0;
    for (name, a, b) in steps() {
        let (x0, x1) = (a.apply(m.rest()), b.apply(m.rest()));
        let unit: Vec<_> = queries()
            .iter()
            .map(|(_, run)| keys(&run(&m, &x0, &x1, 0.0)))
            .collect();
        for k in [-1000, -600, -300, 300, 600, 1000] {
            let s = 2f64.powi(k);
            let scaled = |x: &[DVec3]| x.iter().map(|p| *p * s).collect::<Vec<_>>();
            let (y0, y1) = (scaled(&x0), scaled(&x1));
            let rest: Vec<[f64; 3]> = scaled(m.rest()).iter().map(|p| p.to_array()).collect();
            let ms = Arc::new(Mesh::new(rest, m.triangles().to_vec()).unwrap());
            for ((query, run), want) in queries().iter().zip(&unit) {
                let got = keys(&run(&ms, &y0, &y1, 0.0));
                assert_eq!(&got, want, "{query}, {name}, scale 2^{k}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 4 * 6 * 2);
}

/// The end-of-step checks' repeated query: after some vertices moved, the
/// intersections from the last answer and the triangles at the moved
/// vertices equal a fresh query's, over rounds that move a few vertices
/// (the per-triangle descents) or a sixth of them (the traversal), on a
/// crumpled sheet that passes through itself; bad ids are errors.
#[test]
fn intersections_after_moving_equal_fresh_ones() {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use selfcd::detect::coherent::SelfQueries;
    use selfcd::FrameStats;

    let mesh = mesh(31);
    let e = mesh.mean_edge_length();
    let crumple = Deformation::Crumple {
        amplitude: 0.3,
        wavelength: 0.3,
        seed: 7,
    };
    let mut x = crumple.apply(mesh.rest());
    let mut q = SelfQueries::new(mesh.clone(), 0.25 * e).unwrap();
    let mut s = FrameStats::default();
    let mut last = q.intersections(&x, true, &mut s).unwrap();
    assert!(
        last.len() > 20,
        "the sheet must pass through itself: {}",
        last.len()
    );
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let n = mesh.n_vertices() as u32;
    let (mut descents, mut traversals) = (0, 0);
    for round in 0..24 {
        let count = if round % 3 == 2 {
            n as usize / 6
        } else {
            1 + round % 5
        };
        let mut moved: Vec<u32> = (0..count).map(|_| rng.gen_range(0..n)).collect();
        moved.sort_unstable();
        moved.dedup();
        for &v in &moved {
            let d = DVec3::new(rng.gen(), rng.gen(), rng.gen()) - DVec3::splat(0.5);
            x[v as usize] += 4.0 * e * d;
        }
        let node_pairs = s.node_pairs;
        let got = q
            .intersections_after_moving(&x, &moved, &last, &mut s)
            .unwrap();
        let (want, _) = selfcd::bvh::topdown::self_intersections(&mesh, &x);
        assert_eq!(got, want, "round {round}");
        if s.node_pairs > node_pairs {
            traversals += 1;
        } else {
            descents += 1;
        }
        last = got;
    }
    assert!(descents > 0 && traversals > 0, "{descents} {traversals}");
    assert!(q
        .intersections_after_moving(&x, &[n], &last, &mut s)
        .is_err());
    let bad = [[0, mesh.n_triangles() as u32]];
    assert!(q
        .intersections_after_moving(&x, &[0], &bad, &mut s)
        .is_err());
}
