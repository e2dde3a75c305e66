//! An aggregation multigrid preconditioner for the cloth's link matrices.
//!
//! Levels. Each level groups the vertices of the finer one into aggregates
//! (pairwise matching along the strongest links, done twice, so aggregates of
//! up to four) and the coarse matrix is the Galerkin product `A_c = P^T A P`
//! with the piecewise-constant prolongation `P` (`(P y)_i = y_{agg(i)}`, a 3x3
//! identity per vertex). For a link matrix `A = diag(D) - sum_s B_s (e_i e_j^T +
//! e_j e_i^T)` this is again a link matrix:
//!
//! ```text
//! D_c[I] = sum_{i in I} D_i - 2 sum_{s = (i, j), i, j in I} B_s,
//! B_c[(I, J)] = sum_{s = (i, j), i in I, j in J} B_s,
//! ```
//!
//! so one coarse step is a few block sums. The aggregation depends only on the
//! matrix given to [`Multigrid::new`]; [`Multigrid::update`] refreshes the
//! values for a new matrix with the same links.
//!
//! Cycle. One application is a V-cycle: one damped block-Jacobi sweep
//! (`z += w D^-1 (r - A z)`, `w = 2/3`) before and after the coarse correction,
//! and a dense Cholesky solve on the coarsest level. Pre- and post-smoothing
//! are the same symmetric sweep, so the cycle is a symmetric linear operator;
//! it is positive definite because `A <= 2 blockdiag(D)` when every `B_s` is
//! positive semi-definite (a spring's `[B -B; -B B]` is at most `2 [B 0; 0 B]`),
//! so the damped sweep contracts in the energy norm. That makes it a valid
//! conjugate-gradient preconditioner, with or without the constraint filter.
//!
//! Precision. The cycle runs in single precision on a copy of each level whose
//! rows' blocks lie contiguously (`Compact`, refreshed by [`Multigrid::update`]): it reads
//! 60% of the bytes of the double-precision link form, in order, and uses
//! SIMD 3x3 products. A preconditioner only has to be close to `A^-1`; the conjugate
//! gradients around it stay in double precision. Rounding makes the cycle
//! symmetric to about 1e-7 relative, far below the solve's tolerance.
//!
//! Additive form. [`Multigrid::coarse_correct`] gives the coarse part of
//! the additive two-level preconditioner `B = D^-1 + P C P^T`
//! ([`super::solver::Preconditioner::TwoLevel`]), `C` one V-cycle of the
//! coarser levels: no work on the finest level but a restriction and a
//! prolongation, which the conjugate gradients fuse into their own passes
//! (`D^-1` is their block Jacobi). Both terms are symmetric positive
//! (semi-)definite, so `B` is a valid preconditioner. Against the V-cycle
//! it gives up the finest level's smoothing, about two matrix products an
//! iteration; on the crumpling centre scene at 101 x 101 it needed about
//! as many iterations (BENCHMARKS.md, thirtieth landing).
//!
//! Every kernel is per row over fixed chunks ([`for_chunks`]), and the
//! aggregation is sequential, so the result has the same bits for any number
//! of threads.
//!
//! Measured on the centre scene (BENCHMARKS.md, "solve-5: preconditioner"):
//! 63 -> 22 iterations at 41 x 41 vertices, 103 -> 23 at 101 x 101. The
//! piecewise-constant coarse spaces bound it: a W-cycle, or three smoothing
//! sweeps, still needs about 21 at 101 x 101.

use super::matrix::{dot, for_chunks, LinkMatrix, Sym3};
use crate::mesh::Csr;
use glam::{DMat3, DVec3, Mat3A, Vec3, Vec3A};

/// Jacobi damping: contracting for any `D^-1 A` with spectrum in (0, 2).
const OMEGA: f64 = 2.0 / 3.0;
/// A link is matched only when at least this fraction of the row's strongest link.
const STRONG: f64 = 0.25;
/// Stop coarsening at this many vertices (the dense solve is `(3n)^3 / 3` flops).
const COARSEST: usize = 48;
/// Stop coarsening when a level keeps more than this fraction of its vertices.
const MIN_REDUCTION: f64 = 0.8;
/// The coarsest level is solved densely only up to this size; beyond, by smoothing.
const DENSE_MAX: usize = 96;
/// Jacobi sweeps of the coarsest level when it is too big for the dense solve.
const COARSE_SWEEPS: usize = 8;

/// How one level's vertices and links map to the next coarser level.
#[derive(Debug, Clone)]
struct Coarsening {
    /// Aggregate of each fine vertex.
    of: Vec<u32>,
    /// Fine vertices of each aggregate.
    members: Csr,
    /// Fine links between two vertices of each aggregate.
    internal: Csr,
    /// Fine links summed into each coarse link.
    sources: Csr,
}

impl Coarsening {
    /// The coarsening of `fine` by the aggregates `of` (`0..count`) and the
    /// coarse matrix's links (values zero).
    fn new(fine: &LinkMatrix, of: Vec<u32>, count: usize) -> (Coarsening, LinkMatrix) {
        let members = Csr::from_pairs(count, of.iter().enumerate().map(|(i, &a)| (a, i as u32)));
        let ends = fine.ends();
        let internal = Csr::from_pairs(
            count,
            ends.iter()
                .enumerate()
                .filter(|(_, e)| of[e[0] as usize] == of[e[1] as usize])
                .map(|(s, e)| (of[e[0] as usize], s as u32)),
        );
        let mut cross: Vec<(u32, u32, u32)> = ends
            .iter()
            .enumerate()
            .filter_map(|(s, e)| {
                let (a, b) = (of[e[0] as usize], of[e[1] as usize]);
                (a != b).then(|| (a.min(b), a.max(b), s as u32))
            })
            .collect();
        cross.sort_unstable();
        let mut coarse_ends: Vec<[u32; 2]> = Vec::new();
        let mut link_of = Vec::with_capacity(cross.len());
        for &(a, b, s) in &cross {
            if coarse_ends.last() != Some(&[a, b]) {
                coarse_ends.push([a, b]);
            }
            link_of.push(((coarse_ends.len() - 1) as u32, s));
        }
        let sources = Csr::from_pairs(coarse_ends.len(), link_of.iter().copied());
        let coarse = LinkMatrix::new(count, &coarse_ends);
        let c = Coarsening {
            of,
            members,
            internal,
            sources,
        };
        (c, coarse)
    }

    /// `coarse = P^T fine P` (see the module doc).
    fn galerkin(&self, fine: &LinkMatrix, coarse: &mut LinkMatrix) {
        for_chunks(&mut coarse.link, |start, out| {
            for (k, b) in out.iter_mut().enumerate() {
                let sum = self.sources.row(start + k).iter();
                *b = Sym3::upper(
                    &sum.fold(DMat3::ZERO, |acc, &s| acc + fine.link[s as usize].mat()),
                );
            }
            0.0
        });
        for_chunks(&mut coarse.diag, |start, out| {
            for (k, d) in out.iter_mut().enumerate() {
                let a = start + k;
                let own = self.members.row(a).iter();
                let sum = own.fold(DMat3::ZERO, |acc, &i| acc + fine.diag[i as usize]);
                let inner = self.internal.row(a).iter();
                *d = inner.fold(sum, |acc, &s| acc - fine.link[s as usize].mat() * 2.0);
            }
            0.0
        });
    }

    /// `coarse = P^T fine`: each aggregate's sum.
    fn restrict(&self, fine: &[Vec3A], coarse: &mut [Vec3A]) {
        for_chunks(coarse, |start, out| {
            for (k, c) in out.iter_mut().enumerate() {
                let own = self.members.row(start + k).iter();
                *c = own.fold(Vec3A::ZERO, |acc, &i| acc + fine[i as usize]);
            }
            0.0
        });
    }

    /// `fine += P coarse`.
    fn prolong_add(&self, coarse: &[Vec3A], fine: &mut [Vec3A]) {
        for_chunks(fine, |start, out| {
            for (k, f) in out.iter_mut().enumerate() {
                *f += coarse[self.of[start + k] as usize];
            }
            0.0
        });
    }
}

/// Strength of link `s`: the trace of its block (every block is PSD, so the
/// trace bounds its norm).
fn strength(a: &LinkMatrix, s: u32) -> f64 {
    a.link[s as usize].trace()
}

/// Pairwise matching: in vertex order, each unmatched vertex is paired with
/// its strongest unmatched neighbour, if that link is strong (at least
/// [`STRONG`] of the row's strongest); otherwise it stays alone. Returns the
/// aggregate of each vertex and the number of aggregates.
fn match_pairs(a: &LinkMatrix) -> (Vec<u32>, usize) {
    const FREE: u32 = u32::MAX;
    let mut of = vec![FREE; a.rows()];
    let mut count = 0u32;
    for i in 0..a.rows() {
        if of[i] != FREE {
            continue;
        }
        let row = a.row(i);
        let top = row.iter().map(|&(s, _)| strength(a, s)).fold(0.0, f64::max);
        let best = row
            .iter()
            .filter(|&&(s, j)| of[j as usize] == FREE && strength(a, s) >= STRONG * top)
            .fold(None, |best: Option<(f64, u32)>, &(s, j)| {
                let w = strength(a, s);
                match best {
                    Some((bw, _)) if bw >= w => best,
                    _ => Some((w, j)),
                }
            });
        of[i] = count;
        if let Some((_, j)) = best.filter(|&(w, _)| w > 0.0) {
            of[j as usize] = count;
        }
        count += 1;
    }
    (of, count as usize)
}

/// `m` rounded to single precision (SIMD columns).
fn single(m: DMat3) -> Mat3A {
    m.as_mat3().into()
}

/// One level's matrix in single precision with each row's blocks stored
/// contiguously: the cycle reads 48 bytes per entry, in row order, where the
/// double-precision link form reads 80 in link order.
#[derive(Debug, Clone, Default)]
struct Compact {
    diag: Vec<Mat3A>,
    /// `D^-1`, scaled by the Jacobi damping.
    smoother: Vec<Mat3A>,
    start: Vec<u32>,
    cols: Vec<u32>,
    /// The link of each off-diagonal entry (its block is minus the link's).
    links: Vec<u32>,
    blocks: Vec<Mat3A>,
}

impl Compact {
    /// The row layout of `a` (values zero until [`Compact::fill`]).
    fn new(a: &LinkMatrix) -> Compact {
        let mut start = vec![0u32];
        let (mut cols, mut links) = (Vec::new(), Vec::new());
        for i in 0..a.rows() {
            for &(s, j) in a.row(i) {
                links.push(s);
                cols.push(j);
            }
            start.push(cols.len() as u32);
        }
        Compact {
            diag: vec![Mat3A::ZERO; a.rows()],
            smoother: vec![Mat3A::ZERO; a.rows()],
            start,
            blocks: vec![Mat3A::ZERO; cols.len()],
            cols,
            links,
        }
    }

    /// Copies `a / scale`'s values, and computes the damped inverse diagonal.
    fn fill(&mut self, a: &LinkMatrix, scale: f64) {
        let links = &self.links;
        for_chunks(&mut self.blocks, |start, out| {
            for (k, b) in out.iter_mut().enumerate() {
                *b = single(-a.link[links[start + k] as usize].mat() / scale);
            }
            0.0
        });
        for_chunks(&mut self.diag, |start, out| {
            for (k, d) in out.iter_mut().enumerate() {
                *d = single(a.diag[start + k] / scale);
            }
            0.0
        });
        for_chunks(&mut self.smoother, |start, out| {
            for (k, d) in out.iter_mut().enumerate() {
                *d = single(a.diag[start + k].inverse() * (scale * OMEGA));
            }
            0.0
        });
    }

    /// Row `i` of `A x`.
    #[inline]
    fn row_mul(&self, i: usize, x: &[Vec3A]) -> Vec3A {
        let (lo, hi) = (self.start[i] as usize, self.start[i + 1] as usize);
        let off = self.cols[lo..hi].iter().zip(&self.blocks[lo..hi]);
        off.fold(self.diag[i] * x[i], |y, (&j, b)| y + *b * x[j as usize])
    }

    /// `z = w D^-1 r`: one Jacobi sweep from zero.
    fn pre_smooth(&self, r: &[Vec3A], z: &mut [Vec3A]) {
        for_chunks(z, |start, out| {
            for (k, zi) in out.iter_mut().enumerate() {
                *zi = self.smoother[start + k] * r[start + k];
            }
            0.0
        });
    }

    /// `t = r - A z`.
    fn residual(&self, r: &[Vec3A], z: &[Vec3A], t: &mut [Vec3A]) {
        for_chunks(t, |start, out| {
            for (k, ti) in out.iter_mut().enumerate() {
                *ti = r[start + k] - self.row_mul(start + k, z);
            }
            0.0
        });
    }

    /// `z += w D^-1 (r - A z)`, through `tmp`.
    fn sweep(&self, r: &[Vec3A], z: &mut [Vec3A], tmp: &mut [Vec3A]) {
        let zr: &[Vec3A] = z;
        for_chunks(tmp, |start, out| {
            for (k, ti) in out.iter_mut().enumerate() {
                let i = start + k;
                *ti = zr[i] + self.smoother[i] * (r[i] - self.row_mul(i, zr));
            }
            0.0
        });
        z.copy_from_slice(tmp);
    }
}

/// A level's right-hand side, solution and work vector.
#[derive(Debug, Clone, Default)]
struct Work {
    rhs: Vec<Vec3A>,
    sol: Vec<Vec3A>,
    tmp: Vec<Vec3A>,
}

impl Work {
    fn new(n: usize) -> Work {
        Work {
            rhs: vec![Vec3A::ZERO; n],
            sol: vec![Vec3A::ZERO; n],
            tmp: vec![Vec3A::ZERO; n],
        }
    }
}

/// One coarse level: its coarsening from the finer level, its matrix (in
/// link form, for the next Galerkin product, and compact, for the cycle).
#[derive(Debug, Clone)]
struct Level {
    coarsening: Coarsening,
    a: LinkMatrix,
    compact: Compact,
    work: Work,
}

/// The aggregation multigrid hierarchy over a fixed link pattern (module doc).
#[derive(Debug, Clone)]
pub struct Multigrid {
    links: usize,
    /// The levels hold `A / scale` (a power of two near `A`'s largest
    /// diagonal entry), so single precision holds them at any mesh scale.
    scale: f64,
    /// The finest level's matrix (filled only for the V-cycle,
    /// [`Multigrid::apply`]) and vectors.
    fine: Option<Compact>,
    work: Work,
    /// The coarse part of the additive form: `P^T r`, then `C P^T r`, in
    /// double precision and `A`'s units ([`Multigrid::coarse_correct`]).
    restricted: Vec<DVec3>,
    correction: Vec<DVec3>,
    levels: Vec<Level>,
    /// Lower Cholesky factor (row-major, dense) of the coarsest matrix, when it is small and SPD.
    dense: Option<Vec<f64>>,
}

impl Multigrid {
    /// Builds the levels for `a`'s link pattern, aggregating by `a`'s values,
    /// and fills them from `a`. With `fine` false the finest level's
    /// single-precision copy is not kept: the hierarchy then serves only
    /// [`Multigrid::coarse_correct`].
    pub fn new(a: &LinkMatrix, fine: bool) -> Multigrid {
        let mut levels: Vec<Level> = Vec::new();
        loop {
            let fine = levels.last().map_or(a, |l| &l.a);
            let n = fine.rows();
            if n <= COARSEST {
                break;
            }
            // Two rounds of pairwise matching make one level.
            let (first, m) = match_pairs(fine);
            let (once, mut mid) = Coarsening::new(fine, first, m);
            once.galerkin(fine, &mut mid);
            let (second, count) = match_pairs(&mid);
            if count as f64 > MIN_REDUCTION * n as f64 {
                break;
            }
            let of: Vec<u32> = once.of.iter().map(|&p| second[p as usize]).collect();
            let (coarsening, mut coarse) = Coarsening::new(fine, of, count);
            coarsening.galerkin(fine, &mut coarse);
            levels.push(Level {
                coarsening,
                compact: Compact::new(&coarse),
                a: coarse,
                work: Work::new(count),
            });
        }
        let coarse = levels.first().map_or(0, |l| l.a.rows());
        let mut mg = Multigrid {
            links: a.link.len(),
            scale: 1.0,
            fine: fine.then(|| Compact::new(a)),
            work: Work::new(a.rows()),
            levels,
            dense: None,
            restricted: vec![DVec3::ZERO; coarse],
            correction: vec![DVec3::ZERO; coarse],
        };
        mg.update(a);
        mg
    }

    /// True when this hierarchy was built for `a`'s pattern (same rows and
    /// links), with the finest level's copy when `fine`.
    pub fn fits(&self, a: &LinkMatrix, fine: bool) -> bool {
        self.work.rhs.len() == a.rows() && self.links == a.link.len() && self.fine.is_some() == fine
    }

    /// Number of levels, the finest included.
    pub fn depth(&self) -> usize {
        self.levels.len() + 1
    }

    /// Vertices per level, finest first.
    pub fn sizes(&self) -> Vec<usize> {
        std::iter::once(self.work.rhs.len())
            .chain(self.levels.iter().map(|l| l.a.rows()))
            .collect()
    }

    /// Recomputes every level's matrix and the dense factor from `a` (same links).
    pub fn update(&mut self, a: &LinkMatrix) {
        let largest = a
            .diag
            .iter()
            .map(|d| d.x_axis.x.max(d.y_axis.y).max(d.z_axis.z));
        self.scale = power_of_two(largest.fold(0.0, f64::max));
        let scale = self.scale;
        if let Some(fine) = self.fine.as_mut() {
            fine.fill(a, scale);
        }
        for k in 0..self.levels.len() {
            let (done, rest) = self.levels.split_at_mut(k);
            let fine = done.last().map_or(a, |l| &l.a);
            let level = &mut rest[0];
            level.coarsening.galerkin(fine, &mut level.a);
            level.compact.fill(&level.a, scale);
        }
        let coarsest = self.levels.last().map_or(a, |l| &l.a);
        self.dense = (coarsest.rows() <= DENSE_MAX)
            .then(|| cholesky(coarsest, scale))
            .flatten();
    }

    /// `z = B r`: one V-cycle, in single precision.
    /// The cycle is linear, so it runs on `r / rho` (rho a power of two near
    /// `r`'s largest entry) and the result is scaled back.
    ///
    /// # Panics
    /// If the hierarchy was built without its finest level (`new(a, false)`).
    pub fn apply(&mut self, r: &[DVec3], z: &mut [DVec3]) {
        let rho = power_of_two(largest_entry(r));
        let w = &mut self.work;
        for (f, d) in w.rhs.iter_mut().zip(r) {
            *f = (*d / rho).as_vec3().into();
        }
        let m = self
            .fine
            .as_ref()
            .expect("a V-cycle needs the finest level");
        cycle(Grid { m, w }, &mut self.levels, self.dense.as_deref());
        let back = rho / self.scale;
        for (d, f) in z.iter_mut().zip(&self.work.sol) {
            *d = Vec3::from(*f).as_dvec3() * back;
        }
    }

    /// The coarse part of the additive two-level preconditioner (module
    /// doc): computes `e = P C P^T r`, read per vertex through
    /// [`Multigrid::correction`], and returns `r . e`. `C` runs in single
    /// precision on `P^T r / rho` (rho a power of two near its largest
    /// entry); `P^T r`, `C`'s result scaled back and the product are in
    /// double precision. Zero when there is no coarser level.
    pub fn coarse_correct(&mut self, r: &[DVec3]) -> f64 {
        let Some((first, rest)) = self.levels.split_first_mut() else {
            return 0.0;
        };
        let members = &first.coarsening.members;
        for_chunks(&mut self.restricted, |start, out| {
            for (k, c) in out.iter_mut().enumerate() {
                let own = members.row(start + k).iter();
                *c = own.fold(DVec3::ZERO, |acc, &i| acc + r[i as usize]);
            }
            0.0
        });
        let rho = power_of_two(largest_entry(&self.restricted));
        for (f, d) in first.work.rhs.iter_mut().zip(&self.restricted) {
            *f = (*d / rho).as_vec3().into();
        }
        let m = &first.compact;
        cycle(
            Grid {
                m,
                w: &mut first.work,
            },
            rest,
            self.dense.as_deref(),
        );
        let back = rho / self.scale;
        let sol = &first.work.sol;
        for_chunks(&mut self.correction, |start, out| {
            for (k, e) in out.iter_mut().enumerate() {
                *e = Vec3::from(sol[start + k]).as_dvec3() * back;
            }
            0.0
        });
        dot(&self.restricted, &self.correction)
    }

    /// The fine vertices' aggregates and, per aggregate, the coarse
    /// correction of the last [`Multigrid::coarse_correct`]: vertex `i`'s
    /// part of `e` is `correction[of[i]]`. `None` without a coarser level.
    pub fn correction(&self) -> Option<(&[u32], &[DVec3])> {
        let first = self.levels.first()?;
        Some((&first.coarsening.of, &self.correction))
    }
}

/// The largest absolute coordinate of `v`.
fn largest_entry(v: &[DVec3]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs().max_element()))
}

/// One level's operands in a cycle.
struct Grid<'a> {
    m: &'a Compact,
    w: &'a mut Work,
}

/// `w.sol = B w.rhs` on a level whose coarser levels are `coarser`:
/// pre-smooth, coarse correction, post-smooth. The coarsest level is solved
/// densely, or smoothed when too big.
fn cycle(g: Grid, coarser: &mut [Level], dense: Option<&[f64]>) {
    let Grid { m, w } = g;
    let Some((next, rest)) = coarser.split_first_mut() else {
        match dense {
            Some(f) => dense_solve(f, &w.rhs, &mut w.sol),
            None => {
                m.pre_smooth(&w.rhs, &mut w.sol);
                for _ in 1..COARSE_SWEEPS {
                    m.sweep(&w.rhs, &mut w.sol, &mut w.tmp);
                }
            }
        }
        return;
    };
    m.pre_smooth(&w.rhs, &mut w.sol);
    m.residual(&w.rhs, &w.sol, &mut w.tmp);
    next.coarsening.restrict(&w.tmp, &mut next.work.rhs);
    let coarse = Grid {
        m: &next.compact,
        w: &mut next.work,
    };
    cycle(coarse, rest, dense);
    next.coarsening.prolong_add(&next.work.sol, &mut w.sol);
    m.sweep(&w.rhs, &mut w.sol, &mut w.tmp);
}

/// The power of two nearest `x` (in log scale); 1 for zero or non-finite `x`.
fn power_of_two(x: f64) -> f64 {
    let p = x.log2().round().exp2();
    if p.is_normal() {
        p
    } else {
        1.0
    }
}

/// Dense lower Cholesky factor of `a / scale` (row-major, `3n x 3n`), or
/// `None` when it is not numerically positive definite.
fn cholesky(a: &LinkMatrix, scale: f64) -> Option<Vec<f64>> {
    let n = 3 * a.rows();
    let mut m = vec![0.0; n * n];
    for i in 0..a.rows() {
        let mut put = |j: usize, b: &DMat3, sign: f64| {
            for c in 0..3 {
                for r in 0..3 {
                    m[(3 * i + r) * n + 3 * j + c] += sign * b.col(c)[r];
                }
            }
        };
        put(i, &a.diag[i], 1.0 / scale);
        for &(s, j) in a.row(i) {
            put(j as usize, &a.link[s as usize].mat(), -1.0 / scale);
        }
    }
    for j in 0..n {
        let d = m[j * n + j] - (0..j).map(|k| m[j * n + k] * m[j * n + k]).sum::<f64>();
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        let d = d.sqrt();
        m[j * n + j] = d;
        for i in j + 1..n {
            let s = (0..j).map(|k| m[i * n + k] * m[j * n + k]).sum::<f64>();
            m[i * n + j] = (m[i * n + j] - s) / d;
        }
    }
    Some(m)
}

/// Solves `L L^T z = r` with the factor of [`cholesky`].
fn dense_solve(l: &[f64], r: &[Vec3A], z: &mut [Vec3A]) {
    let n = 3 * r.len();
    let mut y: Vec<f64> = r
        .iter()
        .flat_map(|v| Vec3::from(*v).as_dvec3().to_array())
        .collect();
    for i in 0..n {
        let s = (0..i).map(|k| l[i * n + k] * y[k]).sum::<f64>();
        y[i] = (y[i] - s) / l[i * n + i];
    }
    for i in (0..n).rev() {
        let s = (i + 1..n).map(|k| l[k * n + i] * y[k]).sum::<f64>();
        y[i] = (y[i] - s) / l[i * n + i];
    }
    for (k, zi) in z.iter_mut().enumerate() {
        *zi = DVec3::new(y[3 * k], y[3 * k + 1], y[3 * k + 2])
            .as_vec3()
            .into();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::matrix::dot;
    use crate::cloth::matrix::testing::{random_vector, spring_grid};

    fn apply(mg: &mut Multigrid, r: &[DVec3]) -> Vec<DVec3> {
        let mut z = vec![DVec3::ZERO; r.len()];
        mg.apply(r, &mut z);
        z
    }

    #[test]
    fn coarsens_to_a_dense_coarsest_level() {
        let a = spring_grid(40, 1);
        let mg = Multigrid::new(&a, true);
        let sizes = mg.sizes();
        assert!(sizes.len() >= 3, "{sizes:?}");
        assert!(sizes.windows(2).all(|w| w[1] < w[0]), "{sizes:?}");
        assert!(sizes[1] * 3 <= sizes[0], "{sizes:?}");
        assert!(*sizes.last().unwrap() <= DENSE_MAX && mg.dense.is_some());
    }

    #[test]
    fn galerkin_product_matches_p_transpose_a_p() {
        // (P^T A P) y = P^T (A (P y)) for the first coarsening.
        let a = spring_grid(12, 2);
        let mg = Multigrid::new(&a, true);
        let level = &mg.levels[0];
        let y = random_vector(level.a.rows(), 3);
        let py: Vec<DVec3> = level.coarsening.of.iter().map(|&c| y[c as usize]).collect();
        let mut apy = vec![DVec3::ZERO; a.rows()];
        a.mul(&py, &mut apy);
        let mut direct = vec![DVec3::ZERO; y.len()];
        level.a.mul(&y, &mut direct);
        for (c, d) in direct.iter().enumerate() {
            let members = level.coarsening.members.row(c);
            let sum: DVec3 = members.iter().map(|&i| apy[i as usize]).sum();
            assert!(
                (sum - *d).length() <= 1e-9 * (1.0 + d.length()),
                "{sum} vs {d}"
            );
        }
    }

    /// Checks that `b` (a preconditioner applied to a vector of `n` rows)
    /// is symmetric to single precision's rounding and positive definite,
    /// on four pairs of random vectors from `seed` on.
    fn assert_symmetric_positive(n: usize, seed: u64, mut b: impl FnMut(&[DVec3]) -> Vec<DVec3>) {
        for k in 0..4 {
            let (u, v) = (random_vector(n, seed + k), random_vector(n, seed + 10 + k));
            let (bu, bv) = (b(&u), b(&v));
            let (ubv, vbu) = (dot(&u, &bv), dot(&v, &bu));
            // Single precision inside the cycle: symmetric to rounding.
            let scale = (dot(&u, &bu) * dot(&v, &bv)).sqrt();
            assert!((ubv - vbu).abs() <= 1e-5 * scale, "{ubv} vs {vbu}");
            assert!(dot(&u, &bu) > 0.0 && dot(&v, &bv) > 0.0);
        }
    }

    #[test]
    fn cycle_is_symmetric_and_positive_definite() {
        let a = spring_grid(30, 4);
        let mut mg = Multigrid::new(&a, true);
        assert_symmetric_positive(a.rows(), 10, |r| apply(&mut mg, r));
    }

    /// `B r` of the additive two-level form: `blockdiag(A)^-1 r + P C P^T r`.
    fn two_level(mg: &mut Multigrid, a: &LinkMatrix, r: &[DVec3]) -> (Vec<DVec3>, f64) {
        let coarse = mg.coarse_correct(r);
        let (of, e) = mg.correction().expect("a coarser level");
        let z = (0..r.len())
            .map(|i| a.diag[i].inverse() * r[i] + e[of[i] as usize])
            .collect();
        (z, coarse)
    }

    #[test]
    fn two_level_is_symmetric_and_positive_definite() {
        let a = spring_grid(30, 7);
        let mut mg = Multigrid::new(&a, false);
        assert_symmetric_positive(a.rows(), 30, |r| two_level(&mut mg, &a, r).0);
        for seed in 0..4 {
            let u = random_vector(a.rows(), 50 + seed);
            let (bu, coarse) = two_level(&mut mg, &a, &u);
            assert!(coarse > 0.0);
            // The returned product is r . (P C P^T r), the coarse part of u . B u.
            let jacobi: f64 = (0..u.len())
                .map(|i| u[i].dot(a.diag[i].inverse() * u[i]))
                .sum();
            let whole = dot(&u, &bu);
            assert!((jacobi + coarse - whole).abs() <= 1e-9 * whole);
        }
    }

    #[test]
    fn two_level_correction_needs_no_finest_copy() {
        let a = spring_grid(20, 8);
        let mut coarse_only = Multigrid::new(&a, false);
        let mut full = Multigrid::new(&a, true);
        assert!(coarse_only.fits(&a, false) && !coarse_only.fits(&a, true));
        let r = random_vector(a.rows(), 9);
        // The same coarse levels: the same correction either way.
        assert_eq!(
            two_level(&mut coarse_only, &a, &r),
            two_level(&mut full, &a, &r)
        );
    }

    #[test]
    fn cycle_reduces_the_energy_norm_error() {
        // One cycle as a stationary iteration: e' = (I - B A) e contracts in the A-norm.
        let a = spring_grid(30, 5);
        let mut mg = Multigrid::new(&a, true);
        let e = random_vector(a.rows(), 6);
        let mut ae = vec![DVec3::ZERO; a.rows()];
        a.mul(&e, &mut ae);
        let bae = apply(&mut mg, &ae);
        let next: Vec<DVec3> = e.iter().zip(&bae).map(|(x, y)| *x - *y).collect();
        let mut an = vec![DVec3::ZERO; a.rows()];
        a.mul(&next, &mut an);
        let ratio = (dot(&next, &an) / dot(&e, &ae)).sqrt();
        assert!(ratio < 0.9, "energy-norm contraction {ratio}");
    }

    #[test]
    fn works_at_any_scale() {
        // Scaling A by 2^k and r by 2^j scales B r by 2^(j - k), bit for bit,
        // far outside single precision's range (the V-cycle and the
        // two-level correction alike).
        let a = spring_grid(20, 9);
        let r = random_vector(a.rows(), 10);
        let reference = apply(&mut Multigrid::new(&a, true), &r);
        let mut coarse = Multigrid::new(&a, false);
        let dot_ref = coarse.coarse_correct(&r);
        let e_ref = coarse.correction().unwrap().1.to_vec();
        for (ka, kr) in [(-200, 300), (150, -250), (0, -140)] {
            let (sa, sr) = (2f64.powi(ka), 2f64.powi(kr));
            let mut b = a.clone();
            b.diag.iter_mut().for_each(|d| *d *= sa);
            b.link
                .iter_mut()
                .for_each(|l| *l = Sym3::upper(&(l.mat() * sa)));
            let rs: Vec<DVec3> = r.iter().map(|v| *v * sr).collect();
            let z = apply(&mut Multigrid::new(&b, true), &rs);
            for (x, y) in z.iter().zip(&reference) {
                assert_eq!(*x, *y * (sr / sa), "scale 2^{ka}, rhs 2^{kr}");
            }
            // The two-level correction too, and its product with r.
            let mut coarse = Multigrid::new(&b, false);
            assert_eq!(coarse.coarse_correct(&rs), dot_ref * (sr * sr / sa));
            for (x, y) in coarse.correction().unwrap().1.iter().zip(&e_ref) {
                assert_eq!(*x, *y * (sr / sa), "scale 2^{ka}, rhs 2^{kr}");
            }
        }
    }

    #[test]
    fn update_follows_new_values() {
        let a = spring_grid(20, 7);
        let mut b = a.clone();
        for d in b.diag.iter_mut() {
            *d += DMat3::from_diagonal(DVec3::splat(5.0));
        }
        let (mut updated, mut fresh) = (Multigrid::new(&a, true), Multigrid::new(&b, true));
        assert!(updated.fits(&b, true));
        updated.update(&b);
        let r = random_vector(a.rows(), 8);
        assert_eq!(apply(&mut updated, &r), apply(&mut fresh, &r));
    }
}
