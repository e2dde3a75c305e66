//! A flat sparse symmetric 3x3-block matrix over vertices, stored per link,
//! and the deterministic parallel vector kernels the solver needs.
//!
//! `A = diag(D_i) - sum over links s = (i, j) of B_s (e_i e_j^T + e_j e_i^T)`:
//! each link (spring) owns one symmetric block `B_s`, used in rows i and j, so
//! `(A x)_i = D_i x_i - sum_{s = (i, j)} B_s x_j`. Rows are independent, so the
//! product runs in parallel over fixed chunks of rows and gives the same bits
//! for any number of threads; reductions sum fixed-size chunk partials in chunk
//! order, so they do too.
//!
//! Link blocks are stored as upper triangles ([`Sym3`]): the product is bound
//! by reading them, and 48 bytes a block instead of 72 made it about 10% faster.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// Vectors shorter than this are processed on the calling thread.
pub const PAR_MIN: usize = 2048;
/// Rows per parallel task (fixed, so reductions do not depend on the thread count).
pub const CHUNK: usize = 512;

/// Symmetric 3x3-block matrix in link form (see the module doc).
#[derive(Debug, Clone)]
pub struct LinkMatrix {
    /// Diagonal block of each row.
    pub diag: Vec<DMat3>,
    /// Off-diagonal block of each link, entering rows i and j with a minus sign.
    pub link: Vec<Sym3>,
    /// `row_links[row_start[i]..row_start[i+1]]`: (link, other vertex) of row i,
    /// in link order.
    row_start: Vec<u32>,
    row_links: Vec<(u32, u32)>,
    /// The two rows of each link.
    ends: Vec<[u32; 2]>,
}

impl LinkMatrix {
    /// A zero matrix over `n` rows with one link per entry of `ends`.
    pub fn new(n: usize, ends: &[[u32; 2]]) -> LinkMatrix {
        let mut row_start = vec![0u32; n + 1];
        for e in ends {
            row_start[e[0] as usize + 1] += 1;
            row_start[e[1] as usize + 1] += 1;
        }
        for i in 0..n {
            row_start[i + 1] += row_start[i];
        }
        let mut fill = row_start.clone();
        let mut row_links = vec![(0u32, 0u32); row_start[n] as usize];
        for (s, e) in ends.iter().enumerate() {
            for (a, b) in [(e[0], e[1]), (e[1], e[0])] {
                row_links[fill[a as usize] as usize] = (s as u32, b);
                fill[a as usize] += 1;
            }
        }
        LinkMatrix {
            diag: vec![DMat3::ZERO; n],
            link: vec![Sym3::default(); ends.len()],
            row_start,
            row_links,
            ends: ends.to_vec(),
        }
    }

    /// Number of block rows.
    pub fn rows(&self) -> usize {
        self.diag.len()
    }

    /// The two rows of each link.
    pub fn ends(&self) -> &[[u32; 2]] {
        &self.ends
    }

    /// The (link, other vertex) pairs of row `i`.
    #[inline]
    pub fn row(&self, i: usize) -> &[(u32, u32)] {
        &self.row_links[self.row_start[i] as usize..self.row_start[i + 1] as usize]
    }

    /// Row `i` of `A x`.
    #[inline]
    pub fn row_mul(&self, i: usize, x: &[DVec3]) -> DVec3 {
        let mut y = self.diag[i] * x[i];
        for &(s, j) in self.row(i) {
            y -= self.link[s as usize].mul(x[j as usize]);
        }
        y
    }

    /// `y = A x`.
    pub fn mul(&self, x: &[DVec3], y: &mut [DVec3]) {
        for_chunks(y, |start, out| {
            for (k, yi) in out.iter_mut().enumerate() {
                *yi = self.row_mul(start + k, x);
            }
            0.0
        });
    }
}

/// A symmetric 3x3 block by its upper triangle: xx, xy, xz, yy, yz, zz.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Sym3([f64; 6]);

impl Sym3 {
    /// The upper triangle of `m` (symmetric).
    #[inline]
    pub fn upper(m: &DMat3) -> Sym3 {
        debug_assert!(*m == m.transpose(), "link blocks are symmetric");
        let (c1, c2) = (m.y_axis, m.z_axis);
        Sym3([m.x_axis.x, c1.x, c2.x, c1.y, c2.y, c2.z])
    }

    /// The full block.
    #[inline]
    pub fn mat(&self) -> DMat3 {
        let [xx, xy, xz, yy, yz, zz] = self.0;
        DMat3::from_cols(
            DVec3::new(xx, xy, xz),
            DVec3::new(xy, yy, yz),
            DVec3::new(xz, yz, zz),
        )
    }

    /// The trace.
    #[inline]
    pub fn trace(&self) -> f64 {
        self.0[0] + self.0[3] + self.0[5]
    }

    /// `B v`, with the same roundings as `DMat3 * v` for the full block.
    #[inline]
    pub fn mul(&self, v: DVec3) -> DVec3 {
        let [xx, xy, xz, yy, yz, zz] = self.0;
        DVec3::new(
            xx * v.x + xy * v.y + xz * v.z,
            xy * v.x + yy * v.y + yz * v.z,
            xz * v.x + yz * v.y + zz * v.z,
        )
    }
}

/// Runs `f(start, chunk)` over fixed chunks of `out` (in parallel when long)
/// and returns the sum of the returned partials, added in chunk order.
pub fn for_chunks<T: Send>(out: &mut [T], f: impl Fn(usize, &mut [T]) -> f64 + Sync) -> f64 {
    if out.len() < PAR_MIN {
        return out
            .chunks_mut(CHUNK)
            .enumerate()
            .map(|(k, c)| f(k * CHUNK, c))
            .sum();
    }
    let partials: Vec<f64> = out
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(k, c)| f(k * CHUNK, c))
        .collect();
    partials.into_iter().sum()
}

/// `a . b`, summed in fixed chunks (same bits for any thread count).
pub fn dot(a: &[DVec3], b: &[DVec3]) -> f64 {
    let part = |k: usize| {
        let end = ((k + 1) * CHUNK).min(a.len());
        a[k * CHUNK..end]
            .iter()
            .zip(&b[k * CHUNK..end])
            .map(|(x, y)| x.dot(*y))
            .sum::<f64>()
    };
    let chunks = a.len().div_ceil(CHUNK);
    if a.len() < PAR_MIN {
        return (0..chunks).map(part).sum();
    }
    let partials: Vec<f64> = (0..chunks).into_par_iter().map(part).collect();
    partials.into_iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_matches_dense() {
        // Path 0 - 1 - 2 with distinct blocks.
        let mut a = LinkMatrix::new(3, &[[0, 1], [1, 2]]);
        for i in 0..3 {
            a.diag[i] = DMat3::from_diagonal(DVec3::splat(4.0 + i as f64));
        }
        let b0 = DMat3::from_diagonal(DVec3::new(1.0, 2.0, 3.0));
        let b1 = DMat3::from_cols(
            DVec3::new(1.0, 0.5, 0.0),
            DVec3::new(0.5, 1.0, 0.0),
            DVec3::Z,
        );
        a.link = vec![Sym3::upper(&b0), Sym3::upper(&b1)];
        let x = [
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(-1.0, 0.0, 1.0),
            DVec3::new(0.5, 0.5, 0.5),
        ];
        let mut y = [DVec3::ZERO; 3];
        a.mul(&x, &mut y);
        let y1 = a.diag[1] * x[1] - b0 * x[0] - b1 * x[2];
        assert_eq!(y[1], y1);
        assert_eq!(y[0], a.diag[0] * x[0] - b0 * x[1]);
        assert_eq!(dot(&x, &x), 14.0 + 2.0 + 0.75);
    }
}

/// Test matrices shaped like the cloth's.
#[cfg(test)]
pub(crate) mod testing {
    use super::{LinkMatrix, Sym3};
    use crate::cloth::springs::outer;
    use glam::{DMat3, DVec3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// An `n x n` grid of vertices linked along rows, columns and both
    /// diagonals, each link a positive semi-definite block `k u u^T + c I`
    /// with `u` near the link's direction (a random tilt out of the plane) and
    /// random `k`, `c`; `D_i = m I + sum of its links`: a mass matrix plus
    /// springs, so symmetric positive definite like the cloth's.
    pub fn spring_grid(n: usize, seed: u64) -> LinkMatrix {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let id = |x: usize, y: usize| (y * n + x) as u32;
        let mut ends = Vec::new();
        for y in 0..n {
            for x in 0..n {
                if x + 1 < n {
                    ends.push([id(x, y), id(x + 1, y)]);
                }
                if y + 1 < n {
                    ends.push([id(x, y), id(x, y + 1)]);
                }
                if x + 1 < n && y + 1 < n {
                    ends.push([id(x, y), id(x + 1, y + 1)]);
                    ends.push([id(x + 1, y), id(x, y + 1)]);
                }
            }
        }
        let mut a = LinkMatrix::new(n * n, &ends);
        let at = |v: u32| DVec3::new((v as usize % n) as f64, (v as usize / n) as f64, 0.0);
        for (b, e) in a.link.iter_mut().zip(&ends) {
            let tilt = DVec3::new(0.0, 0.0, rng.gen_range(-0.3..0.3));
            let u = (at(e[1]) - at(e[0]) + tilt).normalize();
            *b = Sym3::upper(
                &(outer(u) * rng.gen_range(50.0..100.0)
                    + DMat3::from_diagonal(DVec3::splat(rng.gen_range(0.0..1.0)))),
            );
        }
        for i in 0..n * n {
            let springs = a.row(i).iter().map(|&(s, _)| a.link[s as usize].mat());
            a.diag[i] = springs.fold(DMat3::from_diagonal(DVec3::splat(0.01)), |d, b| d + b);
        }
        a
    }

    /// A random vector of `n` entries in [-1, 1]^3.
    pub fn random_vector(n: usize, seed: u64) -> Vec<DVec3> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                DVec3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                )
            })
            .collect()
    }
}
