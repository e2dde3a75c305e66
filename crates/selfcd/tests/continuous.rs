//! Continuous queries: the BVH query against the element-pair loop, and no
//! false negatives against intersections found by dense discrete sampling.

use glam::DVec3;
use selfcd::detect::continuous::{element_toi, Impacts};
use selfcd::detect::hierarchy::BvhDetector;
use selfcd::detect::narrow::ElementPair;
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

#[test]
fn bvh_query_matches_the_element_pair_loop() {
    let m = mesh(9);
    for (name, a, b) in steps() {
        let (x0, x1) = (a.apply(m.rest()), b.apply(m.rest()));
        for xi in [0.0, 0.02] {
            let mut det = BvhDetector::new(m.clone(), Method::Bvh, 0.0);
            let got = det.continuous(&x0, &x1, xi).unwrap();
            let mut want = naive(&m, &x0, &x1, xi);
            want.sort_by_key(|(p, _)| *p);
            let mut have = flat(&got);
            have.sort_by_key(|(p, _)| *p);
            let touches = name != "fold-close" || xi > 0.0;
            assert_eq!(!want.is_empty(), touches, "{name}: something within {xi}?");
            assert_eq!(have, want, "{name}, xi {xi}");
        }
    }
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
        let mut det = BvhDetector::new(m.clone(), Method::Bvh, 0.0);
        let impacts = flat(&det.continuous(&x0, &x1, 0.0).unwrap());
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
                let first = impacts
                    .iter()
                    .filter(|(p, _)| covers(p))
                    .map(|(_, t)| *t)
                    .fold(f64::INFINITY, f64::min);
                assert!(first <= s, "{name}: triangles {ta},{tb} intersect at t = {s}, first impact reported {first}");
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
}
