//! A flat sparse symmetric 3x3-block matrix over vertices, stored per link,
//! and the deterministic parallel vector kernels the solver needs.
//!
//! `A = diag(D_i) - sum over links s = (i, j) of B_s (e_i e_j^T + e_j e_i^T)`:
//! each link (spring) owns one symmetric block `B_s`, used in rows i and j, so
//! `(A x)_i = D_i x_i - sum_{s = (i, j)} B_s x_j`. Rows are independent, so the
//! product runs in parallel over fixed chunks of rows and gives the same bits
//! for any number of threads; reductions sum fixed-size chunk partials in chunk
//! order, so they do too.

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
    pub link: Vec<DMat3>,
    /// `row_links[row_start[i]..row_start[i+1]]`: (link, other vertex) of row i,
    /// in link order.
    row_start: Vec<u32>,
    row_links: Vec<(u32, u32)>,
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
            link: vec![DMat3::ZERO; ends.len()],
            row_start,
            row_links,
        }
    }

    /// Number of block rows.
    pub fn rows(&self) -> usize {
        self.diag.len()
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
            y -= self.link[s as usize] * x[j as usize];
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
        a.link[0] = DMat3::from_diagonal(DVec3::new(1.0, 2.0, 3.0));
        a.link[1] = DMat3::from_cols(
            DVec3::new(1.0, 0.5, 0.0),
            DVec3::new(0.5, 1.0, 0.0),
            DVec3::Z,
        );
        let x = [
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(-1.0, 0.0, 1.0),
            DVec3::new(0.5, 0.5, 0.5),
        ];
        let mut y = [DVec3::ZERO; 3];
        a.mul(&x, &mut y);
        let y1 = a.diag[1] * x[1] - a.link[0] * x[0] - a.link[1] * x[2];
        assert_eq!(y[1], y1);
        assert_eq!(y[0], a.diag[0] * x[0] - a.link[0] * x[1]);
        assert_eq!(dot(&x, &x), 14.0 + 2.0 + 0.75);
    }
}
