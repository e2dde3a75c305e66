//! Zero-area triangles: each counts as the segment or point it is.
//!
//! 1. `triangles_intersect` against an independent exact reference on small
//!    integer coordinates (collapsed, touching and coplanar cases abound there).
//! 2. Meshes holding zero-area triangles through every method of the public
//!    API: the BVH methods equal brute force, brute force equals the
//!    reference, the non-conservative methods report nothing that is not there,
//!    proximity equals brute force, and nothing panics.

use glam::DVec3;
use selfcd::geom::tri_tri::triangles_intersect;
use selfcd::scene::{grid, Deformation, SplitMix};
use selfcd::sensor::SensorParams;
use selfcd::{new_detector, Detection, DetectorOptions, Mesh, Method};
use std::sync::Arc;

type P = [i64; 3];

fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: P, b: P) -> P {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: P, b: P) -> i64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Sign of det[b - a, c - a, d - a], exact in integers.
fn orient(a: P, b: P, c: P, d: P) -> i64 {
    dot(cross(sub(b, a), sub(c, a)), sub(d, a)).signum()
}

const O: P = [0, 0, 0];

/// The origin lies in closed segment [a, b] (a == b allowed).
fn origin_in_segment(a: P, b: P) -> bool {
    let ab = sub(b, a);
    cross(ab, sub(O, a)) == [0; 3]
        && dot(sub(O, a), ab) >= 0
        && dot(sub(O, b), sub(a, b)) >= 0
        && (ab != [0; 3] || a == O)
}

/// The origin lies in closed non-degenerate triangle (a, b, c): in its plane
/// and on the inner side of each edge, seen along the normal.
fn origin_in_triangle(a: P, b: P, c: P) -> bool {
    let n = cross(sub(b, a), sub(c, a));
    if n == [0; 3] || orient(a, b, c, O) != 0 {
        return false;
    }
    let side = |p: P, q: P| dot(cross(sub(q, p), sub(O, p)), n).signum();
    let s = [side(a, b), side(b, c), side(c, a)];
    s.iter().all(|&x| x >= 0) || s.iter().all(|&x| x <= 0)
}

/// The origin lies in closed non-flat tetrahedron (a, b, c, d).
fn origin_in_tetrahedron(a: P, b: P, c: P, d: P) -> bool {
    let v = orient(a, b, c, d);
    if v == 0 {
        return false;
    }
    [
        orient(O, b, c, d),
        orient(a, O, c, d),
        orient(a, b, O, d),
        orient(a, b, c, O),
    ]
    .iter()
    .all(|&s| s * v >= 0)
}

/// A and B meet iff the origin is in conv(A - B); by Caratheodory, iff it is
/// in a point, segment, triangle or tetrahedron of the nine differences.
fn reference(a: &[P; 3], b: &[P; 3]) -> bool {
    let d: Vec<P> = a
        .iter()
        .flat_map(|&p| b.iter().map(move |&q| sub(p, q)))
        .collect();
    let n = d.len();
    for i in 0..n {
        if d[i] == O {
            return true;
        }
        for j in i + 1..n {
            if origin_in_segment(d[i], d[j]) {
                return true;
            }
            for k in j + 1..n {
                if origin_in_triangle(d[i], d[j], d[k]) {
                    return true;
                }
                for l in k + 1..n {
                    if origin_in_tetrahedron(d[i], d[j], d[k], d[l]) {
                        return true;
                    }
                }
            }
        }
    }
    false
}

/// A random triangle on the integer grid [-2, 2]^3, collapsed to a segment or
/// point half of the time.
fn random_triangle(rng: &mut SplitMix) -> [P; 3] {
    let mut pt = || [0; 3].map(|_: i64| (rng.next_u64() % 5) as i64 - 2);
    let (a, b, mut c) = (pt(), pt(), pt());
    let kind = rng.next_u64() % 6;
    match kind {
        0 => c = a, // segment with a repeated corner
        1 => c = [2 * b[0] - a[0], 2 * b[1] - a[1], 2 * b[2] - a[2]].map(|x| x.clamp(-4, 4)), // collinear
        2 => return [a; 3], // point
        _ => {}
    }
    if kind == 1 && cross(sub(b, a), sub(c, a)) != [0; 3] {
        c = a; // the clamp broke collinearity: fall back to a repeated corner
    }
    [a, b, c]
}

fn to_f(t: &[P; 3]) -> [DVec3; 3] {
    t.map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
}

#[test]
fn triangle_test_matches_an_independent_reference() {
    let mut rng = SplitMix::new(42);
    let (mut hits, mut degenerate_hits) = (0, 0);
    for i in 0..40_000 {
        let a = random_triangle(&mut rng);
        let b = random_triangle(&mut rng);
        let want = reference(&a, &b);
        let (fa, fb) = (to_f(&a), to_f(&b));
        assert_eq!(triangles_intersect(&fa, &fb), want, "case {i}: {a:?} {b:?}");
        assert_eq!(
            triangles_intersect(&fb, &fa),
            want,
            "case {i} swapped: {a:?} {b:?}"
        );
        hits += want as usize;
        let flat = |t: &[P; 3]| cross(sub(t[1], t[0]), sub(t[2], t[0])) == [0; 3];
        degenerate_hits += (want && (flat(&a) || flat(&b))) as usize;
    }
    // Both answers are frequent, so neither a constant nor a one-sided bug passes.
    assert!(
        hits > 4_000 && hits < 36_000 && degenerate_hits > 2_000,
        "{hits} {degenerate_hits}"
    );
}

#[test]
fn two_distinct_points_do_not_meet() {
    let p = |x: f64| [DVec3::new(x, 0.0, 0.0); 3];
    assert!(!triangles_intersect(&p(0.0), &p(1.0)));
    assert!(triangles_intersect(&p(1.0), &p(1.0)));
}

/// A grid with zero-area triangles: every third interior diagonal gets a
/// vertex at its midpoint and a sliver (the collapsed triangle between the
/// two halves), plus a needle (a segment triangle) standing through the
/// cloth (when `needle`: it makes the rest shape curved, which the sensor
/// refuses) and a point triangle lying on it. Every coordinate is a binary
/// fraction, so the reference can work on exact integers.
fn grid_with_slivers(n: usize, needle: bool) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let (mut v, f) = grid(n, 1.0);
    let mut out = Vec::new();
    let mut k = 0;
    let mut i = 0;
    while i < f.len() {
        let (t, u) = (f[i], f[i + 1]); // the two triangles of one grid square share a diagonal
        i += 2;
        k += 1;
        let shared: Vec<u32> = t.iter().copied().filter(|x| u.contains(x)).collect();
        if k % 3 != 0 || shared.len() != 2 {
            out.extend([t, u]);
            continue;
        }
        // Directed edge a -> b of t is the diagonal; t = (a, b, c), u has b -> a.
        let pos = (0..3)
            .find(|&j| shared.contains(&t[j]) && shared.contains(&t[(j + 1) % 3]))
            .unwrap();
        let (a, b, c) = (t[pos], t[(pos + 1) % 3], t[(pos + 2) % 3]);
        let (pa, pb) = (v[a as usize], v[b as usize]);
        let m = v.len() as u32;
        v.push([0, 1, 2].map(|j| 0.5 * (pa[j] + pb[j])));
        // (a, m, c) and (m, b, c) replace t; the sliver (b, m, a) closes the gap against u.
        out.extend([[a, m, c], [m, b, c], [b, m, a], u]);
    }
    let base = v.len() as u32;
    v.extend([[0.703125, 0.296875, 0.0]; 3]); // a point on the cloth
    out.push([base, base + 1, base + 2]);
    if needle {
        let x = [0.40625, 0.421875];
        v.extend([[x[0], x[1], -0.5], [x[0], x[1], 0.0], [x[0], x[1], 0.5]]); // through the cloth
        out.push([base + 3, base + 4, base + 5]);
    }
    (v, out)
}

fn run(mesh: &Arc<Mesh>, method: Method, frames: &[Vec<DVec3>], thickness: f64) -> Vec<Detection> {
    let opts = DetectorOptions {
        thickness,
        sensor: SensorParams::default(),
    };
    let mut d = new_detector(mesh.clone(), method, &opts).unwrap();
    frames.iter().map(|p| d.detect(p).unwrap()).collect()
}

fn reference_pairs(mesh: &Mesh, p: &[DVec3]) -> Vec<[u32; 2]> {
    // Corners are binary fractions (multiples of 1/64), so scaling by 4096 gives exact integers.
    let mut out = Vec::new();
    for i in 0..mesh.n_triangles() {
        for j in i + 1..mesh.n_triangles() {
            if mesh.share_vertex(i, j) {
                continue;
            }
            let int = |t: [DVec3; 3]| {
                t.map(|q| {
                    q.to_array().map(|x| {
                        assert!(
                            (x * 4096.0).fract() == 0.0 && x.abs() < 16.0,
                            "{x} is not a small binary fraction"
                        );
                        (x * 4096.0) as i64
                    })
                })
            };
            let (ia, ib) = (int(mesh.corners(p, i)), int(mesh.corners(p, j)));
            if reference(&ia, &ib) {
                out.push([i as u32, j as u32]);
            }
        }
    }
    out
}

#[test]
fn every_method_handles_zero_area_triangles() {
    for needle in [true, false] {
        let (v, f) = grid_with_slivers(9, needle);
        check_zero_area_mesh(&Arc::new(Mesh::new(v, f).unwrap()));
    }
}

/// Every method on `mesh` (flat or curved rest shape).
fn check_zero_area_mesh(mesh: &Arc<Mesh>) {
    let rest = mesh.rest().to_vec();
    // Integer-friendly frames for the reference: rest, a flat fold onto itself.
    let folded: Vec<DVec3> = rest
        .iter()
        .map(|r| {
            if r.x > 0.5 && r.z == 0.0 {
                DVec3::new(1.0 - r.x, r.y, 0.0)
            } else {
                *r
            }
        })
        .collect();
    let exact_frames = vec![rest.clone(), folded];
    for (k, p) in exact_frames.iter().enumerate() {
        let brute = run(mesh, Method::Brute, std::slice::from_ref(p), 0.0);
        assert_eq!(
            brute[0].pairs,
            reference_pairs(mesh, p),
            "brute vs reference, frame {k}"
        );
        assert!(
            !brute[0].pairs.is_empty(),
            "the point (and the needle) touch the cloth"
        );
    }
    let mut frames = exact_frames;
    for d in [
        Deformation::Fold {
            angle: 1.08 * std::f64::consts::PI,
            radius: 0.03,
        },
        Deformation::Crumple {
            amplitude: 0.3,
            wavelength: 0.4,
            seed: 2,
        },
        Deformation::Twist { turns: 1.5 },
        Deformation::ZFold {
            layers: 3,
            gap: 0.0,
        },
    ] {
        frames.push(d.apply(&rest));
    }
    let want = run(mesh, Method::Brute, &frames, 0.0);
    for m in [Method::Bvh, Method::BvhConesContour] {
        for (k, got) in run(mesh, m, &frames, 0.0).iter().enumerate() {
            assert_eq!(got.pairs, want[k].pairs, "{m}, frame {k}");
        }
    }
    for (k, p) in frames.iter().enumerate() {
        let one_shot = selfcd::self_intersections(mesh, p).unwrap();
        assert_eq!(one_shot, want[k].pairs, "one-shot, frame {k}");
    }
    // The sensor accepts curved rest shapes too (issue 12): a subset of the truth either way.
    for m in [Method::BvhCones, Method::SensorGated] {
        for (k, got) in run(mesh, m, &frames, 0.0).iter().enumerate() {
            let extra: Vec<_> = got
                .pairs
                .iter()
                .filter(|p| !want[k].pairs.contains(p))
                .collect();
            assert!(
                extra.is_empty(),
                "{m} reported pairs that do not touch, frame {k}: {extra:?}"
            );
        }
    }
    // A slow wobble of the folded frame: from the third frame the kept
    // detector fits the leaves' cones only, zero-area ones (full cones)
    // among them.
    {
        use selfcd::bvh::refit::ConeFit;
        use selfcd::detect::hierarchy::BvhDetector;
        use selfcd::Detector;
        let edge = mesh.mean_edge_length();
        let mut det = BvhDetector::new(mesh.clone(), Method::BvhConesContour, 0.0);
        let mut from_leaves = 0;
        for k in 0..12 {
            let phase = 0.7 * k as f64;
            let p: Vec<DVec3> = frames[1]
                .iter()
                .map(|q| {
                    q + 0.02
                        * edge
                        * DVec3::new(
                            (9.0 * q.y + phase).sin(),
                            (9.0 * q.x).cos(),
                            (5.0 * q.x + phase).sin(),
                        )
                })
                .collect();
            let want = run(mesh, Method::Brute, std::slice::from_ref(&p), 0.0);
            assert_eq!(
                det.detect(&p).unwrap().pairs,
                want[0].pairs,
                "wobble frame {k}"
            );
            from_leaves += (det.bvh().cones_fit == ConeFit::Leaves) as u32;
        }
        assert!(from_leaves > 0, "no frame fitted the leaves' cones only");
    }
    let d = 0.3 * mesh.mean_edge_length();
    let near = run(mesh, Method::Brute, &frames, d);
    for m in [Method::Bvh, Method::BvhConesContour, Method::SensorGated] {
        for (k, got) in run(mesh, m, &frames, d).iter().enumerate() {
            if m != Method::SensorGated {
                assert_eq!(got.proximity, near[k].proximity, "{m} proximity, frame {k}");
            }
            assert!(got
                .proximity
                .vertex_triangle
                .iter()
                .all(|c| c.distance.is_finite()));
            assert!(got
                .proximity
                .edge_edge
                .iter()
                .all(|c| c.distance.is_finite()));
        }
    }
}

#[test]
fn a_mesh_of_points_only_is_valid() {
    let mesh = Arc::new(
        Mesh::new(
            vec![[1.0, 2.0, 3.0]; 12],
            (0..4).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect(),
        )
        .unwrap(),
    );
    let p = mesh.rest().to_vec();
    let all = vec![[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];
    for m in [
        Method::Brute,
        Method::Bvh,
        Method::BvhCones,
        Method::BvhConesContour,
    ] {
        let mut d = new_detector(mesh.clone(), m, &DetectorOptions::default()).unwrap();
        assert_eq!(d.detect(&p).unwrap().pairs, all, "{m}");
    }
    // Every edge has zero length: the sensor has no length unit.
    let opts = DetectorOptions {
        thickness: 0.0,
        sensor: SensorParams {
            count: 2,
            ..Default::default()
        },
    };
    let sensor = new_detector(mesh.clone(), Method::SensorGated, &opts);
    let err = sensor.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(err.contains("edge length"), "{err}");
}
