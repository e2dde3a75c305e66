//! Exactness at every scale and every spread of finite coordinates.
//!
//! 1. `triangles_intersect` against an independent exact reference (big
//!    rationals, Caratheodory on the Minkowski difference) on pairs whose
//!    coordinates are drawn from the whole double range in one pair: zero,
//!    the smallest subnormal, 2^-1022, 1e-300, units, 1e300, 2^1000 and the
//!    largest finite value, with both signs, and with shared corners, shared
//!    coordinates and coplanar layouts so that touching cases abound.
//! 2. A power-of-two scaling of each axis (x by 2^-1074, y by 2^1021, ...) is
//!    an exact linear bijection, so it keeps every answer: small integer
//!    triangles (collapsed, touching, coplanar) must give the same answer
//!    after any such scaling, and the pair set of a mesh must not change.
//! 3. Brute force, `bvh` and `bvh-cones-contour` on triangle soups with
//!    coordinates over the whole range equal the reference pair for pair.
//! 4. Infinite and NaN coordinates are refused with `Error::NonFinite`.

use glam::DVec3;
use num_bigint::{BigInt, Sign};
use num_rational::BigRational;
use selfcd::geom::predicates::Expansion;
use selfcd::geom::tri_tri::{triangles_intersect, triangles_intersect_filtered};
use selfcd::scene::{grid, Deformation, SplitMix};
use selfcd::{new_detector, DetectorOptions, Error, Mesh, Method};
use std::sync::Arc;

// ---------------------------------------------------------------------------
// The reference: exact integers from big rationals, Caratheodory.

type P = [BigInt; 3];

fn sub(a: &P, b: &P) -> P {
    [&a[0] - &b[0], &a[1] - &b[1], &a[2] - &b[2]]
}

fn cross(a: &P, b: &P) -> P {
    [
        &a[1] * &b[2] - &a[2] * &b[1],
        &a[2] * &b[0] - &a[0] * &b[2],
        &a[0] * &b[1] - &a[1] * &b[0],
    ]
}

fn dot(a: &P, b: &P) -> BigInt {
    &a[0] * &b[0] + &a[1] * &b[1] + &a[2] * &b[2]
}

fn sign(x: &BigInt) -> i32 {
    match x.sign() {
        Sign::Plus => 1,
        Sign::Minus => -1,
        Sign::NoSign => 0,
    }
}

fn is_zero(p: &P) -> bool {
    p.iter().all(|x| sign(x) == 0)
}

/// Sign of det[b - a, c - a, d - a].
fn orient(a: &P, b: &P, c: &P, d: &P) -> i32 {
    sign(&dot(&cross(&sub(b, a), &sub(c, a)), &sub(d, a)))
}

/// The origin lies in closed segment [a, b] (a == b allowed).
fn origin_in_segment(a: &P, b: &P) -> bool {
    let o = origin();
    let ab = sub(b, a);
    is_zero(&cross(&ab, &sub(&o, a)))
        && sign(&dot(&sub(&o, a), &ab)) >= 0
        && sign(&dot(&sub(&o, b), &sub(a, b))) >= 0
        && (!is_zero(&ab) || is_zero(a))
}

/// The origin lies in closed non-degenerate triangle (a, b, c).
fn origin_in_triangle(a: &P, b: &P, c: &P) -> bool {
    let o = origin();
    let n = cross(&sub(b, a), &sub(c, a));
    if is_zero(&n) || orient(a, b, c, &o) != 0 {
        return false;
    }
    let side = |p: &P, q: &P| sign(&dot(&cross(&sub(q, p), &sub(&o, p)), &n));
    let s = [side(a, b), side(b, c), side(c, a)];
    s.iter().all(|&x| x >= 0) || s.iter().all(|&x| x <= 0)
}

/// The origin lies in closed non-flat tetrahedron (a, b, c, d).
fn origin_in_tetrahedron(a: &P, b: &P, c: &P, d: &P) -> bool {
    let o = origin();
    let v = orient(a, b, c, d);
    v != 0
        && [
            orient(&o, b, c, d),
            orient(a, &o, c, d),
            orient(a, b, &o, d),
            orient(a, b, c, &o),
        ]
        .iter()
        .all(|&s| s * v >= 0)
}

fn origin() -> P {
    [0, 0, 0].map(BigInt::from)
}

/// Exact integer images of the doubles of a pair: each coordinate as a big
/// rational (exact), all multiplied by the largest denominator (a power of two).
fn to_integers(a: &[DVec3; 3], b: &[DVec3; 3]) -> ([P; 3], [P; 3]) {
    let q = |x: f64| BigRational::from_float(x).expect("finite");
    let all: Vec<BigRational> = a
        .iter()
        .chain(b)
        .flat_map(|p| p.to_array().map(q))
        .collect();
    let den = all
        .iter()
        .map(|r| r.denom().clone())
        .max()
        .expect("six points");
    let int = |x: f64| {
        let r = q(x) * BigRational::from_integer(den.clone());
        assert!(r.is_integer());
        r.to_integer()
    };
    let p = |t: &[DVec3; 3]| t.map(|v| v.to_array().map(int));
    (p(a), p(b))
}

/// A and B meet iff the origin is in conv(A - B); by Caratheodory, iff it is
/// in a point, segment, triangle or tetrahedron of the nine differences.
fn reference(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    // Disjoint boxes (exact comparisons of the doubles) settle most pairs.
    let ((la, ha), (lb, hb)) = (bounds(a), bounds(b));
    if (0..3).any(|k| ha[k] < lb[k] || hb[k] < la[k]) {
        return false;
    }
    let (ia, ib) = to_integers(a, b);
    let d: Vec<P> = ia
        .iter()
        .flat_map(|p| ib.iter().map(move |q| sub(p, q)))
        .collect();
    let n = d.len();
    for i in 0..n {
        if is_zero(&d[i]) {
            return true;
        }
        for j in i + 1..n {
            if origin_in_segment(&d[i], &d[j]) {
                return true;
            }
            for k in j + 1..n {
                if origin_in_triangle(&d[i], &d[j], &d[k]) {
                    return true;
                }
                for l in k + 1..n {
                    if origin_in_tetrahedron(&d[i], &d[j], &d[k], &d[l]) {
                        return true;
                    }
                }
            }
        }
    }
    false
}

fn bounds(t: &[DVec3; 3]) -> (DVec3, DVec3) {
    (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
}

// ---------------------------------------------------------------------------
// Generators.

/// Magnitudes over the whole finite range.
const PALETTE: [f64; 10] = [
    0.0,
    5e-324,                  // smallest subnormal
    2.2250738585072014e-308, // smallest normal
    1e-300,
    0.75,
    1.0,
    3.0,
    1e300,
    1.0715086071862673e301, // 2^1000
    f64::MAX,
];

fn pick(rng: &mut SplitMix) -> f64 {
    let x = PALETTE[(rng.next_u64() % PALETTE.len() as u64) as usize];
    if rng.next_u64().is_multiple_of(2) {
        x
    } else {
        -x
    }
}

fn point(rng: &mut SplitMix) -> DVec3 {
    DVec3::new(pick(rng), pick(rng), pick(rng))
}

/// A pair over the whole range, laid out so that contact is frequent: b
/// reuses corners of a, moves one coordinate of a corner, or both lie in one
/// plane z = c; a triangle collapses to a segment or point now and then.
fn wide_pair(rng: &mut SplitMix) -> ([DVec3; 3], [DVec3; 3]) {
    let mut a = [point(rng), point(rng), point(rng)];
    let mut b = [point(rng), point(rng), point(rng)];
    for q in b.iter_mut() {
        let src = a[(rng.next_u64() % 3) as usize];
        match rng.next_u64() % 4 {
            0 => *q = src,
            1 => q[(rng.next_u64() % 3) as usize] = src[(rng.next_u64() % 3) as usize],
            2 => *q = DVec3::new(src.x, src.y, q.z),
            _ => {}
        }
    }
    if rng.next_u64().is_multiple_of(4) {
        let z = pick(rng);
        a.iter_mut().chain(b.iter_mut()).for_each(|p| p.z = z);
    }
    match rng.next_u64() % 8 {
        0 => a[2] = a[0],
        1 => b[1] = b[2],
        _ => {}
    }
    (a, b)
}

/// A triangle on the integer grid [-2, 2]^3, collapsed to a segment or point
/// a third of the time.
fn small_triangle(rng: &mut SplitMix) -> [DVec3; 3] {
    let mut c = || (rng.next_u64() % 5) as f64 - 2.0;
    let mut t = [(); 3].map(|_| DVec3::new(c(), c(), c()));
    match rng.next_u64() % 6 {
        0 => t[2] = t[0],
        1 => t[2] = t[1] * 2.0 - t[0],
        2 => t = [t[0]; 3],
        _ => {}
    }
    t
}

/// Exponents for a per-axis scaling 2^e: each keeps [-4, 4] * 2^e exact.
const EXPONENTS: [i32; 9] = [-1074, -1073, -1050, -1000, -600, 0, 600, 1000, 1021];

fn pow2(e: i32) -> f64 {
    // 2^e for -1074 <= e <= 1023, exactly (powi would underflow through 1/2^1074).
    if e >= -1022 {
        f64::from_bits(((1023 + e) as u64) << 52)
    } else {
        f64::from_bits(1u64 << (e + 1074))
    }
}

fn random_axis_scale(rng: &mut SplitMix) -> DVec3 {
    let mut e = || EXPONENTS[(rng.next_u64() % EXPONENTS.len() as u64) as usize];
    DVec3::new(pow2(e()), pow2(e()), pow2(e()))
}

// ---------------------------------------------------------------------------
// Pair tests.

#[test]
fn pairs_over_the_whole_range_match_the_reference() {
    let mut rng = SplitMix::new(7);
    let (mut hits, mut big, mut n) = (0, 0, 0);
    for i in 0..3000 {
        let (a, b) = wide_pair(&mut rng);
        let want = reference(&a, &b);
        assert_eq!(triangles_intersect(&a, &b), want, "case {i}: {a:?} {b:?}");
        assert_eq!(triangles_intersect(&b, &a), want, "case {i} swapped");
        assert_eq!(
            triangles_intersect_filtered(&a, &b).intersect(),
            want,
            "case {i} filtered"
        );
        hits += want as usize;
        big += Expansion::new([a[0], a[1], a[2], b[0], b[1], b[2]]).is_none() as usize;
        n += 1;
    }
    // Both answers frequent, and most pairs need the big-integer path.
    assert!(hits > n / 10 && hits < n * 9 / 10, "{hits} of {n}");
    assert!(big > n / 2, "{big} of {n} on big integers");
}

#[test]
fn largest_values_and_subnormals_touch_exactly() {
    let (m, t) = (f64::MAX, f64::from_bits(1));
    let v = DVec3::new;
    // A huge triangle in z = 0 and a needle from -m to +m through a point
    // one subnormal off its edge: differences overflow f64, the answer must not.
    let a = [v(-m, -m, 0.0), v(m, -m, 0.0), v(0.0, m, 0.0)];
    let through = [v(0.0, 0.0, -m), v(0.0, 0.0, m), v(0.0, 0.0, m)];
    assert!(triangles_intersect(&a, &through));
    let edge = [v(-m, -m, -m), v(-m, -m, m), v(-m, -m, 0.0)];
    assert!(triangles_intersect(&a, &edge), "touches the corner");
    let beside = edge.map(|p| p - v(0.0, t, 0.0)); // -m - t rounds back to -m
    assert!(triangles_intersect(&a, &beside));
    // One ulp up from the corner along y: outside (the triangle is one point wide at x = -m).
    let up = f64::from_bits(m.to_bits() - 1);
    let nudged = edge.map(|p| v(p.x, -up, p.z));
    assert!(!triangles_intersect(&a, &nudged));
    assert!(!reference(&a, &nudged));
    // Coplanar at the subnormal scale: a triangle of side 3 ulps and one
    // touching its hypotenuse, then one moved a single ulp away.
    let s = [v(0.0, 0.0, 0.0), v(3.0 * t, 0.0, 0.0), v(0.0, 3.0 * t, 0.0)];
    let touch = [
        v(2.0 * t, t, 0.0),
        v(4.0 * t, 4.0 * t, 0.0),
        v(2.0 * t, 5.0 * t, 0.0),
    ];
    assert!(triangles_intersect(&s, &touch));
    let apart = touch.map(|p| p + v(t, 0.0, 0.0));
    assert!(!triangles_intersect(&s, &apart));
    for (x, y) in [(&s, &touch), (&s, &apart), (&a, &through), (&a, &edge)] {
        assert_eq!(triangles_intersect(x, y), reference(x, y));
    }
    // One corner near 1e300, the others near 1e-300: a long sliver whose far
    // end crosses a unit triangle in z = 0, and then lifted by 1e-300.
    let sliver = [
        v(1e-300, 1e-300, -1e-300),
        v(2e-300, 1e-300, 1e-300),
        v(1e300, 1e300, 1e300),
    ];
    let unit = [v(-1.0, -1.0, 0.0), v(1.0, -1.0, 0.0), v(0.0, 1.0, 0.0)];
    assert_eq!(
        triangles_intersect(&sliver, &unit),
        reference(&sliver, &unit)
    );
    assert!(triangles_intersect(&sliver, &unit));
    let lifted = sliver.map(|p| p + v(0.0, 0.0, 2e-300));
    assert_eq!(
        triangles_intersect(&lifted, &unit),
        reference(&lifted, &unit)
    );
}

#[test]
fn per_axis_powers_of_two_keep_every_answer() {
    let mut rng = SplitMix::new(11);
    let mut hits = 0;
    for i in 0..20_000 {
        let (a, b) = (small_triangle(&mut rng), small_triangle(&mut rng));
        let want = triangles_intersect(&a, &b);
        let s = random_axis_scale(&mut rng);
        let (sa, sb) = (a.map(|p| p * s), b.map(|p| p * s));
        assert!(
            sa.iter().zip(&a).all(|(q, p)| *q / s == *p),
            "scaling must be exact"
        );
        assert_eq!(
            triangles_intersect(&sa, &sb),
            want,
            "case {i} scaled by {s:?}: {a:?} {b:?}"
        );
        assert_eq!(
            triangles_intersect_filtered(&sb, &sa).intersect(),
            want,
            "case {i} filtered"
        );
        hits += want as usize;
        if i % 50 == 0 {
            assert_eq!(reference(&sa, &sb), want, "reference, case {i}");
        }
    }
    assert!(hits > 3000 && hits < 17_000, "{hits}");
}

// ---------------------------------------------------------------------------
// Mesh tests.

fn pairs(mesh: &Arc<Mesh>, method: Method, p: &[DVec3]) -> Vec<[u32; 2]> {
    let mut d = new_detector(mesh.clone(), method, &DetectorOptions::default()).unwrap();
    d.detect(p).unwrap().pairs
}

/// A soup of `n` triangles (no shared vertices), every pair a candidate.
fn soup(tris: &[[DVec3; 3]]) -> Arc<Mesh> {
    let v: Vec<[f64; 3]> = tris.iter().flatten().map(|p| p.to_array()).collect();
    let f: Vec<[u32; 3]> = (0..tris.len() as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    Arc::new(Mesh::new(v, f).unwrap())
}

fn reference_pairs(tris: &[[DVec3; 3]]) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    for i in 0..tris.len() {
        for j in i + 1..tris.len() {
            if reference(&tris[i], &tris[j]) {
                out.push([i as u32, j as u32]);
            }
        }
    }
    out
}

const EXACT: [Method; 3] = [Method::Brute, Method::Bvh, Method::BvhConesContour];

#[test]
fn soups_over_the_whole_range_match_the_reference() {
    let mut rng = SplitMix::new(3);
    for round in 0..6 {
        // Pairs from the wide generator, so that contacts abound inside the soup.
        let tris: Vec<[DVec3; 3]> = (0..12)
            .flat_map(|_| {
                let (a, b) = wide_pair(&mut rng);
                [a, b]
            })
            .collect();
        let mesh = soup(&tris);
        let want = reference_pairs(&tris);
        assert!(!want.is_empty(), "round {round}");
        for m in EXACT {
            assert_eq!(pairs(&mesh, m, mesh.rest()), want, "{m}, round {round}");
        }
        let one_shot = selfcd::self_intersections(&mesh, mesh.rest()).unwrap();
        assert_eq!(one_shot, want, "one-shot, round {round}");
    }
}

#[test]
fn per_axis_powers_of_two_keep_the_pairs_of_meshes() {
    // A crumpled grid and a soup of small integer triangles.
    let (v, f) = grid(9, 1.0);
    let grid_mesh = Arc::new(Mesh::new(v, f).unwrap());
    let crumpled = Deformation::Crumple {
        amplitude: 0.35,
        wavelength: 0.4,
        seed: 3,
    }
    .apply(grid_mesh.rest());
    let mut rng = SplitMix::new(5);
    let tris: Vec<[DVec3; 3]> = (0..40).map(|_| small_triangle(&mut rng)).collect();
    let soup_mesh = soup(&tris);
    let cases = [
        (grid_mesh, crumpled),
        (soup_mesh.clone(), soup_mesh.rest().to_vec()),
    ];
    for (k, (mesh, p)) in cases.iter().enumerate() {
        let want = pairs(mesh, Method::Brute, p);
        assert!(want.len() > 5, "case {k}: {}", want.len());
        for s in [
            DVec3::new(pow2(-900), pow2(900), 1.0),
            DVec3::new(pow2(1000), pow2(-1000), pow2(-500)),
            DVec3::splat(pow2(-1000)),
            DVec3::splat(pow2(1000)),
            DVec3::new(1.0, 1.0, pow2(-960)),
        ] {
            let q: Vec<DVec3> = p.iter().map(|x| *x * s).collect();
            if q.iter().zip(p).any(|(y, x)| *y / s != *x) {
                continue; // not exact at this scale (a coordinate went subnormal)
            }
            let scaled = Arc::new(
                Mesh::new(
                    mesh.rest().iter().map(|x| (*x * s).to_array()).collect(),
                    mesh.triangles().to_vec(),
                )
                .unwrap(),
            );
            for m in EXACT {
                assert_eq!(pairs(&scaled, m, &q), want, "case {k}, {m}, scale {s:?}");
            }
            let one_shot = selfcd::self_intersections(&scaled, &q).unwrap();
            assert_eq!(one_shot, want, "case {k}, one-shot, scale {s:?}");
        }
    }
    // The integer soup at the subnormal scale is exact too.
    let q: Vec<DVec3> = tris.iter().flatten().map(|x| *x * pow2(-1074)).collect();
    let tiny = soup(&q.chunks(3).map(|c| [c[0], c[1], c[2]]).collect::<Vec<_>>());
    for m in EXACT {
        assert_eq!(
            pairs(&tiny, m, &q),
            pairs(&soup_mesh, Method::Brute, soup_mesh.rest()),
            "{m} at 2^-1074"
        );
    }
    assert_eq!(
        selfcd::self_intersections(&tiny, &q).unwrap(),
        pairs(&soup_mesh, Method::Brute, soup_mesh.rest()),
        "one-shot at 2^-1074"
    );
}

#[test]
fn non_finite_coordinates_are_refused() {
    let tris = [
        [DVec3::ZERO, DVec3::X, DVec3::Y],
        [DVec3::Z, DVec3::X + DVec3::Z, DVec3::Y],
    ];
    let mesh = soup(&tris);
    for bad in [f64::INFINITY, f64::NEG_INFINITY, f64::NAN] {
        let mut v: Vec<[f64; 3]> = mesh.rest().iter().map(|p| p.to_array()).collect();
        v[4][1] = bad;
        let err = Mesh::new(v, mesh.triangles().to_vec()).unwrap_err();
        assert!(matches!(err, Error::NonFinite { vertex: 4, .. }), "{err}");
        let mut p = mesh.rest().to_vec();
        p[2].z = bad;
        for m in EXACT {
            let mut d = new_detector(mesh.clone(), m, &DetectorOptions::default()).unwrap();
            let err = d.detect(&p).unwrap_err();
            assert!(
                matches!(err, Error::NonFinite { vertex: 2, .. }),
                "{m}: {err}"
            );
        }
    }
}

#[test]
fn rest_shapes_at_extreme_scales_are_accepted() {
    // Edges of 2^-900 used to have length 0 (the squares underflowed), and the
    // sensor refused such a rest shape for having no length unit.
    let (v, f) = grid(6, 1.0);
    let unit = Mesh::new(v.clone(), f.clone()).unwrap().mean_edge_length();
    for e in [-1000, -900, 900, 1000] {
        let s = pow2(e);
        let scaled: Vec<[f64; 3]> = v.iter().map(|p| p.map(|x| x * s)).collect();
        let mesh = Arc::new(Mesh::new(scaled, f.clone()).unwrap());
        assert_eq!(mesh.mean_edge_length(), unit * s, "2^{e}");
        let opts = DetectorOptions::default();
        let mut d = new_detector(mesh.clone(), Method::SensorGated, &opts)
            .unwrap_or_else(|err| panic!("2^{e}: {err}"));
        let got = d.detect(mesh.rest()).unwrap().pairs;
        assert!(
            got.is_empty(),
            "a flat grid has no self-intersection, 2^{e}"
        );
    }
}
