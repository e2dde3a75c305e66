//! Built-in meshes and analytic deformations: the square cloth of the paper at
//! any resolution, and the shapes the tests and benchmarks put it in (flat,
//! folded, Z-folded, crumpled, twisted, rolled, noisy), all as pure functions
//! of the rest positions so they are reproducible.

use crate::error::{try_vec, Error, Result};
use glam::{DQuat, DVec3};
use std::f64::consts::PI;

/// A square grid cloth in the xy plane: `n x n` vertices over `[0, size]^2`,
/// `2 (n-1)^2` triangles, counter-clockwise seen from +z, diagonals alternating
/// in a checkerboard so the mesh has no preferred direction.
pub fn grid(n: usize, size: f64) -> MeshArrays {
    grid_rect(n, n, size, size)
}

/// Vertices and triangles of a generated mesh.
pub type MeshArrays = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// [`grid`] for a side taken from user input: an error, not an abort or a
/// wrapped index, when the side is below 2, the vertices overflow 32-bit
/// indices, or the arrays cannot be allocated ([`Error::OutOfMemory`]).
pub fn try_grid(n: usize, size: f64) -> Result<MeshArrays> {
    let vertices = n
        .checked_mul(n)
        .filter(|&v| n >= 2 && v <= 1usize << 32)
        .ok_or_else(|| {
            Error::InvalidParameter(format!(
                "a grid of {n} x {n} vertices is not possible: the side must be at least 2 and the \
                 vertices must fit 32-bit indices"
            ))
        })?;
    let mut v = try_vec(vertices, "grid vertices")?;
    let mut f = try_vec(2 * (n - 1) * (n - 1), "grid triangles")?;
    fill_grid(n, n, size, size, &mut v, &mut f);
    Ok((v, f))
}

/// A rectangular grid cloth: `nx x ny` vertices over `[0, sx] x [0, sy]`.
pub fn grid_rect(nx: usize, ny: usize, sx: f64, sy: f64) -> MeshArrays {
    let (mut v, mut f) = (Vec::new(), Vec::new());
    fill_grid(nx, ny, sx, sy, &mut v, &mut f);
    (v, f)
}

/// Appends the vertices and triangles of [`grid_rect`] to `v` and `f`.
fn fill_grid(nx: usize, ny: usize, sx: f64, sy: f64, v: &mut Vec<[f64; 3]>, f: &mut Vec<[u32; 3]>) {
    v.reserve(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            v.push([
                sx * i as f64 / (nx - 1) as f64,
                sy * j as f64 / (ny - 1) as f64,
                0.0,
            ]);
        }
    }
    let id = |i: usize, j: usize| (j * nx + i) as u32;
    f.reserve(2 * (nx - 1) * (ny - 1));
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                f.push([a, b, c]);
                f.push([a, c, d]);
            } else {
                f.push([a, b, d]);
                f.push([b, c, d]);
            }
        }
    }
}

/// A closed UV sphere of radius `r` about the origin, poles on the z axis:
/// `rings >= 2` bands of latitude, `segments >= 3` of longitude, outward
/// counter-clockwise triangles. The obstacle of the cloth tests and benchmarks.
pub fn sphere(rings: usize, segments: usize, r: f64) -> MeshArrays {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut v = vec![[0.0, 0.0, r]];
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            v.push([
                r * theta.sin() * phi.cos(),
                r * theta.sin() * phi.sin(),
                r * theta.cos(),
            ]);
        }
    }
    v.push([0.0, 0.0, -r]);
    let south = (v.len() - 1) as u32;
    let at = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
    let mut f = Vec::with_capacity(2 * segments * (rings - 1));
    for j in 0..segments {
        f.push([0, at(1, j), at(1, j + 1)]);
        f.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
        for i in 1..rings - 1 {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            f.push([a, b, c]);
            f.push([a, c, d]);
        }
    }
    (v, f)
}

/// Number of vertices per side of a square grid with about `triangles` triangles.
pub fn grid_side_for(triangles: usize) -> usize {
    ((triangles as f64 / 2.0).sqrt().round() as usize + 1).max(2)
}

/// A small deterministic generator (splitmix64) so scenes need no RNG crate.
#[derive(Debug, Clone)]
pub struct SplitMix(u64);

impl SplitMix {
    /// Generator from a seed.
    pub fn new(seed: u64) -> Self {
        SplitMix(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Shuffles `v` (Fisher-Yates; the modulo's bias is far below what a
    /// test mesh notices).
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            v.swap(i, (self.next_u64() % (i as u64 + 1)) as usize);
        }
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform direction on the unit sphere.
    pub fn direction(&mut self) -> DVec3 {
        let z = 2.0 * self.unit() - 1.0;
        let a = 2.0 * PI * self.unit();
        let r = (1.0 - z * z).sqrt();
        DVec3::new(r * a.cos(), r * a.sin(), z)
    }
}

/// A shape to put a flat rest mesh in. Lengths are relative to the rest
/// mesh's extent along x (`width`), so a shape means the same at any scale.
#[derive(Debug, Clone, PartialEq)]
pub enum Deformation {
    /// Unchanged.
    Flat,
    /// Fold the half x > mid over a cylinder of radius `radius * width`,
    /// through `angle` radians (PI folds it flat on top; more pushes it through).
    Fold { angle: f64, radius: f64 },
    /// Accordion fold into `layers` (>= 1) flat layers stacked `gap * width` apart.
    ZFold { layers: usize, gap: f64 },
    /// A smooth random displacement of size `amplitude * width` and wavelength
    /// `wavelength * width`; large amplitudes fold the sheet through itself.
    Crumple {
        amplitude: f64,
        wavelength: f64,
        seed: u64,
    },
    /// Twist about the x axis through the centre by `turns` full turns end to end.
    Twist { turns: f64 },
    /// Roll from the x = max end onto a spiral of `turns` turns, layers `gap * width` apart.
    Roll { turns: f64, gap: f64 },
    /// Independent random offsets of each vertex, up to `amplitude * width`.
    Noise { amplitude: f64, seed: u64 },
}

/// The benchmark's states of a square cloth: flat; crumpled so that distant
/// parts pass through each other; Z-folded into 8 layers half an edge apart
/// that do not touch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BenchState {
    /// Unchanged, flat.
    Flat,
    /// Strong smooth random displacement: many self-intersections.
    Crumpled,
    /// Accordion layers 0.5 edge lengths apart, not touching.
    Folded,
}

impl BenchState {
    /// Every state, in report order.
    pub const ALL: [BenchState; 3] = [BenchState::Flat, BenchState::Crumpled, BenchState::Folded];

    /// The state's name.
    pub fn name(self) -> &'static str {
        match self {
            BenchState::Flat => "flat",
            BenchState::Crumpled => "crumpled",
            BenchState::Folded => "folded",
        }
    }

    /// The state's shape for a square grid with `side` vertices per side.
    pub fn deformation(self, side: usize) -> Deformation {
        match self {
            BenchState::Flat => Deformation::Flat,
            BenchState::Crumpled => Deformation::Crumple {
                amplitude: 0.3,
                wavelength: 0.4,
                seed: 1,
            },
            BenchState::Folded => Deformation::ZFold {
                layers: 8,
                gap: 0.5 / (side - 1) as f64,
            },
        }
    }
}

impl std::str::FromStr for BenchState {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<BenchState> {
        crate::error::parse_name(s, &BenchState::ALL, BenchState::name, "state")
    }
}

/// Extent of the rest shape: (min corner, max corner, width along x; never 0).
fn frame(rest: &[DVec3]) -> (DVec3, DVec3, f64) {
    let lo = rest.iter().fold(DVec3::INFINITY, |a, &b| a.min(b));
    let hi = rest.iter().fold(DVec3::NEG_INFINITY, |a, &b| a.max(b));
    (lo, hi, (hi.x - lo.x).max(f64::MIN_POSITIVE))
}

impl Deformation {
    /// Checks the parameters: every number finite; `layers` >= 1; radius >= 0;
    /// wavelength and roll turns > 0 (a negative gap is allowed: the layers
    /// then pass through each other). [`Deformation::apply`] with
    /// other values does not panic, but its positions mean nothing.
    pub fn validate(&self) -> Result<()> {
        use Deformation::*;
        let (named, positive): (Vec<(&str, f64)>, &[&str]) = match *self {
            Flat => (vec![], &[]),
            Fold { angle, radius } => (vec![("angle", angle), ("radius", radius)], &[]),
            ZFold { layers, gap } => {
                if layers == 0 {
                    return Err(Error::InvalidParameter(
                        "zfold layers must be at least 1".into(),
                    ));
                }
                (vec![("gap", gap)], &[])
            }
            Crumple {
                amplitude,
                wavelength,
                ..
            } => (
                vec![("amplitude", amplitude), ("wavelength", wavelength)],
                &["wavelength"],
            ),
            Twist { turns } => (vec![("turns", turns)], &[]),
            Roll { turns, gap } => (vec![("turns", turns), ("gap", gap)], &["turns"]),
            Noise { amplitude, .. } => (vec![("amplitude", amplitude)], &[]),
        };
        for (name, v) in named {
            let must_be_positive = positive.contains(&name);
            let non_negative = name == "radius";
            let ok = v.is_finite() && (!must_be_positive || v > 0.0) && (!non_negative || v >= 0.0);
            if !ok {
                let range = if must_be_positive {
                    "finite and > 0"
                } else if non_negative {
                    "finite and >= 0"
                } else {
                    "finite"
                };
                return Err(Error::InvalidParameter(format!(
                    "shape parameter {name} must be {range}, got {v}"
                )));
            }
        }
        Ok(())
    }

    /// Positions of `rest` (a flat mesh in the xy plane) in this shape
    /// (parameters as [`Deformation::validate`] accepts).
    pub fn apply(&self, rest: &[DVec3]) -> Vec<DVec3> {
        let (lo, hi, w) = frame(rest);
        match *self {
            Deformation::Flat => rest.to_vec(),
            Deformation::Fold { angle, radius } => {
                let mid = 0.5 * (lo.x + hi.x);
                let r = radius * w;
                rest.iter().map(|p| fold_point(*p, mid, r, angle)).collect()
            }
            Deformation::ZFold { layers, gap } => {
                let layers = layers.max(1); // 0 is refused by validate; never underflow
                let panel = w / layers as f64;
                rest.iter()
                    .map(|p| {
                        let u = (p.x - lo.x) / panel;
                        let k = (u.floor() as usize).min(layers - 1);
                        let local = (u - k as f64) * panel;
                        let on_fold = k > 0 && (u - k as f64).abs() < 1e-12;
                        let x = if k.is_multiple_of(2) {
                            local
                        } else {
                            panel - local
                        };
                        let z = if on_fold {
                            (k as f64 - 0.5) * gap * w
                        } else {
                            k as f64 * gap * w
                        };
                        DVec3::new(lo.x + x, p.y, p.z + z)
                    })
                    .collect()
            }
            Deformation::Crumple {
                amplitude,
                wavelength,
                seed,
            } => {
                let mut rng = SplitMix::new(seed);
                let waves: Vec<(DVec3, DVec3, f64)> = (0..8)
                    .map(|_| {
                        (
                            rng.direction() * (2.0 * PI / (wavelength * w)),
                            rng.direction(),
                            2.0 * PI * rng.unit(),
                        )
                    })
                    .collect();
                rest.iter()
                    .map(|&p| {
                        let q = p - lo;
                        p + waves
                            .iter()
                            .map(|(k, d, ph)| *d * (k.dot(q) + ph).sin())
                            .sum::<DVec3>()
                            * (amplitude * w / 8f64.sqrt())
                    })
                    .collect()
            }
            Deformation::Twist { turns } => {
                let yc = 0.5 * (lo.y + hi.y);
                rest.iter()
                    .map(|p| {
                        let a = 2.0 * PI * turns * (p.x - lo.x) / w;
                        let (y, z) = (p.y - yc, p.z);
                        DVec3::new(
                            p.x,
                            yc + y * a.cos() - z * a.sin(),
                            y * a.sin() + z * a.cos(),
                        )
                    })
                    .collect()
            }
            Deformation::Roll { turns, gap } => roll(rest, lo, w, turns, gap * w),
            Deformation::Noise { amplitude, seed } => {
                let mut rng = SplitMix::new(seed);
                rest.iter()
                    .map(|&p| p + rng.direction() * (amplitude * w * rng.unit()))
                    .collect()
            }
        }
    }
}

/// Bends x beyond `mid` around a cylinder of radius `r` (axis along y at height r) by `angle`.
fn fold_point(p: DVec3, mid: f64, r: f64, angle: f64) -> DVec3 {
    let s = p.x - mid;
    if s <= 0.0 {
        return p;
    }
    let arc = angle * r;
    if s <= arc {
        let phi = s / r;
        return DVec3::new(mid + r * phi.sin(), p.y, p.z + r - r * phi.cos());
    }
    let (sin_a, cos_a) = angle.sin_cos();
    let end = DVec3::new(mid + r * sin_a, p.y, p.z + r - r * cos_a);
    end + DVec3::new(cos_a, 0.0, sin_a) * (s - arc)
}

/// Wraps the sheet, from its x = max end, around an Archimedean spiral.
fn roll(rest: &[DVec3], lo: DVec3, w: f64, turns: f64, gap: f64) -> Vec<DVec3> {
    // Spiral r(phi) = r0 + gap * phi / (2 pi), phi in [0, 2 pi turns], rolled
    // inwards: arc length measured from the outer end, which stays on the plane.
    let phi_max = 2.0 * PI * turns;
    let r_outer = {
        // Choose r0 so the spiral's length equals the rolled length w / 2 when turns > 0.
        let rolled = 0.5 * w;
        let mean_r = if phi_max > 0.0 { rolled / phi_max } else { 0.0 };
        mean_r + 0.5 * gap * turns
    };
    let rolled = 0.5 * w;
    rest.iter()
        .map(|p| {
            let s = p.x - lo.x - 0.5 * w; // > 0: on the rolled half
            if s <= 0.0 || phi_max <= 0.0 {
                return *p;
            }
            // Approximate the spiral arc length by mean radius: phi = s / rolled * phi_max.
            let phi = (s / rolled) * phi_max;
            let r = (r_outer - gap * phi / (2.0 * PI)).max(1e-9 * w);
            let x0 = lo.x + 0.5 * w;
            DVec3::new(x0 + r * phi.sin(), p.y, p.z + r_outer - r * phi.cos())
        })
        .collect()
}

/// Applies a rigid motion (rotation then translation) to positions.
pub fn rigid(positions: &[DVec3], rotation: DQuat, translation: DVec3) -> Vec<DVec3> {
    positions
        .iter()
        .map(|&p| rotation * p + translation)
        .collect()
}

/// Scales positions about the origin.
pub fn scale(positions: &[DVec3], s: f64) -> Vec<DVec3> {
    positions.iter().map(|&p| p * s).collect()
}

/// A closed tube (no caps) along x: `n_around x n_along` vertices, radius
/// `radius`, length `length`, starting at x = 0. A curved rest shape for the
/// particle sensor's tests and benchmarks.
pub fn tube(
    n_around: usize,
    n_along: usize,
    radius: f64,
    length: f64,
) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut v = Vec::with_capacity(n_around * n_along);
    for j in 0..n_along {
        for i in 0..n_around {
            let a = 2.0 * PI * i as f64 / n_around as f64;
            let x = length * j as f64 / (n_along - 1) as f64;
            v.push([x, radius * a.cos(), radius * a.sin()]);
        }
    }
    let id = |i: usize, j: usize| (j * n_around + i % n_around) as u32;
    let mut f = Vec::with_capacity(2 * n_around * (n_along - 1));
    for j in 0..n_along - 1 {
        for i in 0..n_around {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            f.push([a, b, c]);
            f.push([a, c, d]);
        }
    }
    (v, f)
}

/// Pinches `rest` (any shape) towards the plane x = c (c the x-midpoint of its
/// bounds) near the plane z = zc: x' = c + (x - c) (1 - depth g(z)), with g a
/// Gaussian of width a quarter of the z extent. Past depth 1 the two sides pass
/// through each other: a sphere squeezed until it folds.
pub fn pinch(rest: &[DVec3], depth: f64) -> Vec<DVec3> {
    let (lo, hi, _) = frame(rest);
    let (c, zc) = (0.5 * (lo.x + hi.x), 0.5 * (lo.z + hi.z));
    let width = (0.25 * (hi.z - lo.z)).max(f64::MIN_POSITIVE);
    rest.iter()
        .map(|p| {
            let g = (-((p.z - zc) / width).powi(2)).exp();
            DVec3::new(c + (p.x - c) * (1.0 - depth * g), p.y, p.z)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_shapes_and_sizes_are_errors_not_panics() {
        let (v, _) = grid(5, 1.0);
        let rest: Vec<DVec3> = v.iter().map(|p| DVec3::from_array(*p)).collect();
        let zero = Deformation::ZFold {
            layers: 0,
            gap: 0.1,
        };
        assert!(zero.validate().is_err());
        assert_eq!(zero.apply(&rest).len(), rest.len()); // no underflow even unchecked
        for bad in [
            Deformation::Fold {
                angle: f64::NAN,
                radius: 0.1,
            },
            Deformation::Fold {
                angle: 1.0,
                radius: -0.1,
            },
            Deformation::Crumple {
                amplitude: 0.1,
                wavelength: 0.0,
                seed: 1,
            },
            Deformation::Roll {
                turns: 0.0,
                gap: 0.1,
            },
            Deformation::Twist {
                turns: f64::INFINITY,
            },
            Deformation::Noise {
                amplitude: f64::NAN,
                seed: 1,
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
        assert!(Deformation::ZFold {
            layers: 3,
            gap: 0.0
        }
        .validate()
        .is_ok());
        assert!(matches!(try_grid(1, 1.0), Err(Error::InvalidParameter(_))));
        assert!(matches!(
            try_grid(1 << 16 | 1, 1.0),
            Err(Error::InvalidParameter(_))
        ));
        assert!(matches!(
            try_grid(usize::MAX, 1.0),
            Err(Error::InvalidParameter(_))
        ));
        assert_eq!(try_grid(4, 2.0).unwrap(), grid(4, 2.0));
    }

    #[test]
    fn paper_grid_has_200_triangles() {
        let (v, f) = grid(11, 1.0);
        assert_eq!((v.len(), f.len()), (121, 200));
        assert_eq!(grid_side_for(200), 11);
    }

    #[test]
    fn fold_preserves_lengths_along_x() {
        let rest: Vec<DVec3> = (0..=100)
            .map(|i| DVec3::new(i as f64 / 100.0, 0.0, 0.0))
            .collect();
        let p = Deformation::Fold {
            angle: PI,
            radius: 0.05,
        }
        .apply(&rest);
        let len: f64 = p.windows(2).map(|w| (w[1] - w[0]).length()).sum();
        assert!((len - 1.0).abs() < 1e-3, "length {len}");
        assert!((p[100].z - 0.1).abs() < 1e-9 && p[100].x < 0.6);
    }
}
