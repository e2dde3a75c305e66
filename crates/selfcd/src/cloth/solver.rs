//! Backward Euler linearised once per step (Baraff & Witkin 1998), solved by
//! preconditioned conjugate gradients with a constraint filter.
//!
//! With forces `f(x, v)`, masses `M` and step `h`, one step solves
//!
//! ```text
//! (M - h df/dv - h^2 df/dx) dv = h (f0 + h (df/dx) v0),   v1 = v0 + dv,   x1 = x0 + h v1
//! ```
//!
//! where `-df/dx` uses each spring's positive semi-definite approximation
//! ([`super::springs::evaluate`]), so the matrix is symmetric positive definite.
//! Air drag `-c m v` adds `h c m` to the diagonal.
//!
//! Constraints are not forces: a filter `S_i` projects each vertex's velocity
//! change onto its free directions, and `z_i` prescribes the constrained part,
//! so that `dv_i = S_i dv_i + z_i`. A pinned vertex has `S_i = 0`, `z_i = 0`; a
//! vertex in contact with normal n has `S_i = I - n n^T` and `z_i` along n.
//! The modified PCG of Baraff & Witkin solves within that affine space.

use super::matrix::{dot, for_chunks, LinkMatrix, Sym3, CHUNK, PAR_MIN};
use super::model::Cloth;
use super::multigrid::Multigrid;
use super::springs::evaluate;
use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// One vertex's constraint: up to two orthonormal constrained directions, or fully fixed.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Row {
    dirs: [DVec3; 2],
    /// Number of constrained directions; 3 means fully fixed.
    count: u8,
}

/// The constraint filter: per vertex, the directions its velocity change is
/// prescribed along, and the prescribed part `z_i`.
#[derive(Debug, Clone, Default)]
pub struct Filter {
    rows: Vec<Row>,
    z: Vec<DVec3>,
}

/// New directions closer than this (sine of the angle) to the span of a
/// vertex's existing ones are dropped: the constraints would fight.
const MIN_INDEPENDENCE: f64 = 0.3;

impl Filter {
    /// A filter that fixes the velocity of every pinned vertex (`dv = 0`).
    pub fn new(pinned: &[bool]) -> Filter {
        let rows = pinned
            .iter()
            .map(|&p| Row {
                count: if p { 3 } else { 0 },
                ..Row::default()
            })
            .collect();
        Filter {
            rows,
            z: vec![DVec3::ZERO; pinned.len()],
        }
    }

    /// Prescribes `dv_i . n = target` for a unit `n`. Returns false (and changes
    /// nothing) when vertex `i` is fixed or `n` is nearly in the span of its
    /// existing directions.
    pub fn constrain(&mut self, i: usize, n: DVec3, target: f64) -> bool {
        let row = &mut self.rows[i];
        if row.count >= 3 {
            return false;
        }
        let mut m = n;
        for e in &row.dirs[..row.count as usize] {
            m -= *e * m.dot(*e);
        }
        let len = m.length();
        if len.is_nan() || len <= MIN_INDEPENDENCE {
            return false;
        }
        // z' = z + e (target - z.n) / |m| keeps z.e_k and makes z'.n = target.
        let e = m / len;
        let z = self.z[i];
        self.z[i] = z + e * ((target - z.dot(n)) / len);
        if row.count < 2 {
            row.dirs[row.count as usize] = e;
        }
        row.count += 1;
        true
    }

    /// `S_i v`: the part of `v` in vertex i's free directions.
    #[inline]
    pub fn apply(&self, i: usize, v: DVec3) -> DVec3 {
        let row = &self.rows[i];
        match row.count {
            0 => v,
            3 => DVec3::ZERO,
            c => row.dirs[..c as usize]
                .iter()
                .fold(v, |v, e| v - *e * v.dot(*e)),
        }
    }

    /// The prescribed part `z_i` of vertex i's velocity change.
    #[inline]
    pub fn prescribed(&self, i: usize) -> DVec3 {
        self.z[i]
    }

    /// Number of vertices the filter covers.
    #[allow(clippy::len_without_is_empty)]
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Number of vertices with at least one constrained direction (pins included).
    pub fn constrained(&self) -> usize {
        self.rows.iter().filter(|r| r.count > 0).count()
    }
}

/// The linear system of one step: `A dv = b`, in link form.
#[derive(Debug, Clone)]
pub struct System {
    /// `A = M (1 + h c) + sum over springs of (h Kv + h^2 Kx)` in the link pattern.
    pub a: LinkMatrix,
    /// `b = h (f0 + h (df/dx) v0)`.
    pub b: Vec<DVec3>,
    /// Per spring: `f_s + h Kx (v1 - v0)`, what the spring adds to `b / h` at its first end.
    spring_rhs: Vec<DVec3>,
}

impl System {
    /// An empty system for `cloth`'s vertices and springs.
    pub fn new(cloth: &Cloth) -> System {
        let n = cloth.mesh().n_vertices();
        let s = cloth.springs();
        System {
            a: LinkMatrix::new(n, &s.ends),
            b: vec![DVec3::ZERO; n],
            spring_rhs: vec![DVec3::ZERO; s.len()],
        }
    }

    /// Fills `A` and `b` for one step of length `h` from the state (`x`, `v`).
    pub fn assemble(&mut self, cloth: &Cloth, x: &[DVec3], v: &[DVec3], h: f64) {
        let s = cloth.springs();
        let link_block = |k: usize| {
            let [i, j] = s.ends[k];
            let (i, j) = (i as usize, j as usize);
            let e = evaluate(
                x[j] - x[i],
                v[j] - v[i],
                s.rest[k],
                s.stiffness[k],
                s.damping[k],
            );
            (
                e.kv * h + e.kx * (h * h),
                e.force + e.kx * (v[j] - v[i]) * h,
            )
        };
        for_chunks2(
            &mut self.a.link,
            &mut self.spring_rhs,
            |start, blocks, rhs| {
                for (k, (blk, r)) in blocks.iter_mut().zip(rhs.iter_mut()).enumerate() {
                    let (block, rhs) = link_block(start + k);
                    (*blk, *r) = (Sym3::upper(&block), rhs);
                }
            },
        );
        let (mass, g, drag) = (cloth.masses(), cloth.gravity(), cloth.material().air_drag);
        let mut diag = std::mem::take(&mut self.a.diag);
        let (a, spring_rhs) = (&self.a, &self.spring_rhs);
        for_chunks2(&mut diag, &mut self.b, |start, d, b| {
            for (k, (d, b)) in d.iter_mut().zip(b.iter_mut()).enumerate() {
                let i = start + k;
                let mut block = DMat3::from_diagonal(DVec3::splat(mass[i] * (1.0 + h * drag)));
                let mut f = (g - v[i] * drag) * mass[i];
                for &(l, _) in a.row(i) {
                    let l = l as usize;
                    block += a.link[l].mat();
                    // The spring's first end gets +rhs, its second end -rhs.
                    f += if s.ends[l][0] as usize == i {
                        spring_rhs[l]
                    } else {
                        -spring_rhs[l]
                    };
                }
                *d = block;
                *b = f * h;
            }
        });
        self.a.diag = diag;
    }
}

/// Runs `f(start, a_chunk, b_chunk)` over matching fixed chunks of two slices,
/// in parallel when they are long.
pub fn for_chunks2<A: Send, B: Send>(
    a: &mut [A],
    b: &mut [B],
    f: impl Fn(usize, &mut [A], &mut [B]) + Sync,
) {
    if a.len() < PAR_MIN {
        a.chunks_mut(CHUNK)
            .zip(b.chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(k, (x, y))| f(k * CHUNK, x, y));
    } else {
        a.par_chunks_mut(CHUNK)
            .zip(b.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(k, (x, y))| f(k * CHUNK, x, y));
    }
}

/// `s = P^-1 r` for preconditioner `p` (`mg` its hierarchy where it has
/// one, `pinv` the inverse diagonal blocks); returns `r . s`.
fn precondition(
    p: Preconditioner,
    mg: Option<&mut Multigrid>,
    pinv: &[DMat3],
    r: &[DVec3],
    s: &mut [DVec3],
) -> f64 {
    match (p, mg) {
        (Preconditioner::Multigrid, Some(m)) => {
            m.apply(r, s);
            dot(r, s)
        }
        (_, mg) => {
            for_chunks(s, |start, out| {
                for (k, si) in out.iter_mut().enumerate() {
                    *si = pinv[start + k] * r[start + k];
                }
                0.0
            });
            let jacobi = dot(r, s);
            match mg {
                Some(m) => {
                    let coarse = m.coarse_correct(r);
                    if let Some((of, e)) = m.correction() {
                        for (si, &a) in s.iter_mut().zip(of) {
                            *si += e[a as usize];
                        }
                    }
                    jacobi + coarse
                }
                None => jacobi,
            }
        }
    }
}

/// Runs `f(start, a, b, c)` over matching fixed chunks of three slices and
/// returns the sum of its partials, added in chunk order (parallel when long).
fn for_chunks3(
    a: &mut [DVec3],
    b: &mut [DVec3],
    c: &mut [DVec3],
    f: impl Fn(usize, &mut [DVec3], &mut [DVec3], &mut [DVec3]) -> f64 + Sync,
) -> f64 {
    if a.len() < PAR_MIN {
        let it = a
            .chunks_mut(CHUNK)
            .zip(b.chunks_mut(CHUNK))
            .zip(c.chunks_mut(CHUNK));
        return it
            .enumerate()
            .map(|(k, ((x, y), z))| f(k * CHUNK, x, y, z))
            .sum();
    }
    let it = a
        .par_chunks_mut(CHUNK)
        .zip(b.par_chunks_mut(CHUNK))
        .zip(c.par_chunks_mut(CHUNK));
    let partials: Vec<f64> = it
        .enumerate()
        .map(|(k, ((x, y), z))| f(k * CHUNK, x, y, z))
        .collect();
    partials.into_iter().sum()
}

/// The preconditioner `P` of the conjugate gradients (applied as `c = S P^-1 r`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Preconditioner {
    /// `P = blockdiag(A)`: cheap, but the iterations grow with the resolution.
    #[default]
    BlockJacobi,
    /// One V-cycle of aggregation multigrid on the unfiltered `A`
    /// ([`super::multigrid`]): about three matrix products per iteration, and
    /// far fewer iterations on fine meshes; yet slower than
    /// [`Preconditioner::TwoLevel`] on every scene measured, so no longer
    /// picked by [`Preconditioner::for_vertices`].
    Multigrid,
    /// Block Jacobi plus a coarse-grid correction, added:
    /// `P^-1 = blockdiag(A)^-1 + P C P^T` with the aggregation and the
    /// V-cycle `C` of [`super::multigrid`] on the coarser levels
    /// ([`Multigrid::coarse_correct`]). No matrix product on the finest
    /// level beyond the conjugate gradients' own, and about as many
    /// iterations as the V-cycle where contacts constrain much of the cloth.
    TwoLevel,
}

/// From this many vertices up, [`Preconditioner::for_vertices`] picks the
/// two-level form. Measured on the centre scene over 200 steps, 2 threads
/// (BENCHMARKS.md, thirtieth landing): it needs about half of block Jacobi's
/// iterations from 31 x 31 vertices up, but pays the coarse levels' update
/// every step, so the solves level at 961 vertices (1.72 against 1.74 ms)
/// and block Jacobi wins below (0.54 against 0.95 ms at 441). The V-cycle
/// ([`Preconditioner::Multigrid`]) needed a few iterations fewer than the
/// two-level form but took longer at every size measured (its two
/// finest-level products an iteration).
pub const TWO_LEVEL_MIN_VERTICES: usize = 1_000;

impl Preconditioner {
    /// The faster preconditioner for a cloth of `n` vertices on measured runs:
    /// two-level from [`TWO_LEVEL_MIN_VERTICES`] up, block Jacobi below.
    pub fn for_vertices(n: usize) -> Preconditioner {
        if n >= TWO_LEVEL_MIN_VERTICES {
            Preconditioner::TwoLevel
        } else {
            Preconditioner::BlockJacobi
        }
    }
}

/// Stopping rule, iteration cap and preconditioner of the conjugate gradients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcgOptions {
    /// Stop when the preconditioned residual norm has dropped by this factor.
    pub tolerance: f64,
    /// Stop after this many iterations whatever the residual.
    pub max_iterations: u32,
    /// The preconditioner.
    pub preconditioner: Preconditioner,
}

impl Default for PcgOptions {
    fn default() -> Self {
        PcgOptions {
            tolerance: 1e-3,
            max_iterations: 200,
            preconditioner: Preconditioner::default(),
        }
    }
}

/// What one solve did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PcgStats {
    /// Iterations run.
    pub iterations: u32,
    /// Final relative residual `sqrt(r.P^-1 r / b.P^-1 b)` (filtered).
    pub residual: f64,
}

/// Work vectors of the filtered PCG and the multigrid hierarchy (of either
/// multigrid preconditioner), kept between steps.
#[derive(Debug, Clone, Default)]
pub struct Pcg {
    r: Vec<DVec3>,
    c: Vec<DVec3>,
    q: Vec<DVec3>,
    s: Vec<DVec3>,
    pinv: Vec<DMat3>,
    /// Built on the first solve that needs it; its aggregates follow that matrix.
    multigrid: Option<Multigrid>,
}

impl Pcg {
    /// Solves `A dv = b` within the filter's affine space, starting from `dv`
    /// (filtered, plus the prescribed part); returns with the solution in `dv`.
    /// A is symmetric positive definite, and so is `P` (either kind).
    pub fn solve(
        &mut self,
        a: &LinkMatrix,
        b: &[DVec3],
        filter: &Filter,
        dv: &mut [DVec3],
        opts: PcgOptions,
    ) -> PcgStats {
        let n = a.rows();
        for w in [&mut self.r, &mut self.c, &mut self.q, &mut self.s] {
            w.resize(n, DVec3::ZERO);
        }
        self.pinv.resize(n, DMat3::ZERO);
        for_chunks2(&mut self.pinv, dv, |start, p, x| {
            for (k, (p, x)) in p.iter_mut().zip(x.iter_mut()).enumerate() {
                let i = start + k;
                *p = a.diag[i].inverse();
                *x = filter.apply(i, *x) + filter.prescribed(i);
            }
        });
        let kind = opts.preconditioner;
        let fine = kind == Preconditioner::Multigrid;
        let mut mg = match kind {
            Preconditioner::BlockJacobi => None,
            Preconditioner::Multigrid | Preconditioner::TwoLevel => {
                Some(match self.multigrid.take() {
                    Some(mut m) if m.fits(a, fine) => {
                        m.update(a);
                        m
                    }
                    _ => Multigrid::new(a, fine),
                })
            }
        };
        let pinv = &self.pinv;
        let dv_ro: &[DVec3] = dv;
        // r = S (b - A dv), and the reference (S b).P^-1 (S b), with S b in q.
        for_chunks2(&mut self.r, &mut self.q, |start, r, sb| {
            for k in 0..r.len() {
                let i = start + k;
                r[k] = filter.apply(i, b[i] - a.row_mul(i, dv_ro));
                sb[k] = filter.apply(i, b[i]);
            }
        });
        let delta_b = precondition(kind, mg.as_mut(), pinv, &self.q, &mut self.c);
        let delta = precondition(kind, mg.as_mut(), pinv, &self.r, &mut self.s);
        let s = &self.s;
        for_chunks(&mut self.c, |start, c| {
            for (k, ci) in c.iter_mut().enumerate() {
                *ci = filter.apply(start + k, s[start + k]);
            }
            0.0
        });
        let reference = if delta_b > 0.0 { delta_b } else { delta };
        let mut delta = delta;
        let tol2 = opts.tolerance * opts.tolerance;
        let mut it = 0;
        while it < opts.max_iterations && reference > 0.0 && delta > tol2 * reference {
            let c = &self.c;
            let cq = for_chunks(&mut self.q, |start, q| {
                let mut part = 0.0;
                for (k, qi) in q.iter_mut().enumerate() {
                    let i = start + k;
                    *qi = filter.apply(i, a.row_mul(i, c));
                    part += c[i].dot(*qi);
                }
                part
            });
            if cq.is_nan() || cq <= 0.0 {
                break;
            }
            let alpha = delta / cq;
            let (c, q, jacobi) = (&self.c, &self.q, !fine);
            // With block Jacobi (alone or two-level), s = blockdiag(A)^-1 r
            // and r.s in the same pass.
            let mut next = for_chunks3(dv, &mut self.r, &mut self.s, |start, x, r, s| {
                let mut part = 0.0;
                for k in 0..x.len() {
                    let i = start + k;
                    x[k] += c[i] * alpha;
                    r[k] -= q[i] * alpha;
                    if jacobi {
                        s[k] = pinv[i] * r[k];
                        part += r[k].dot(s[k]);
                    }
                }
                part
            });
            match mg.as_mut() {
                Some(m) if fine => next = precondition(kind, Some(m), pinv, &self.r, &mut self.s),
                Some(m) => next += m.coarse_correct(&self.r),
                None => {}
            }
            let beta = next / delta;
            delta = next;
            let s = &self.s;
            // The two-level coarse correction joins s here (P e, per vertex).
            let coarse = mg.as_ref().filter(|_| !fine).and_then(|m| m.correction());
            for_chunks(&mut self.c, |start, c| {
                for (k, ci) in c.iter_mut().enumerate() {
                    let i = start + k;
                    let si = match coarse {
                        Some((of, e)) => s[i] + e[of[i] as usize],
                        None => s[i],
                    };
                    *ci = filter.apply(i, si + *ci * beta);
                }
                0.0
            });
            it += 1;
        }
        self.multigrid = mg.or(self.multigrid.take());
        let residual = if reference > 0.0 {
            (delta / reference).max(0.0).sqrt()
        } else {
            0.0
        };
        PcgStats {
            iterations: it,
            residual,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::matrix::testing::{random_vector, spring_grid};

    /// A filter on an `n`-vertex system: a few pins and contact-like constraints.
    fn some_filter(n: usize) -> Filter {
        let pinned: Vec<bool> = (0..n).map(|i| i % 97 == 5).collect();
        let mut f = Filter::new(&pinned);
        for i in (0..n).step_by(13) {
            let normal = DVec3::new(0.3, -0.2, 1.0).normalize();
            f.constrain(i, normal, 0.01 * (i % 7) as f64);
            if i % 3 == 0 {
                f.constrain(i, DVec3::X, -0.02);
            }
        }
        f
    }

    fn solve(
        a: &LinkMatrix,
        b: &[DVec3],
        f: &Filter,
        p: Preconditioner,
        tol: f64,
    ) -> (Vec<DVec3>, PcgStats) {
        let opts = PcgOptions {
            tolerance: tol,
            max_iterations: 5000,
            preconditioner: p,
        };
        let mut dv = vec![DVec3::ZERO; a.rows()];
        let stats = Pcg::default().solve(a, b, f, &mut dv, opts);
        (dv, stats)
    }

    #[test]
    fn preconditioners_agree_and_keep_the_prescribed_part() {
        let a = spring_grid(45, 11);
        let b = random_vector(a.rows(), 12);
        let f = some_filter(a.rows());
        let (exact, _) = solve(&a, &b, &f, Preconditioner::BlockJacobi, 1e-12);
        for p in [
            Preconditioner::BlockJacobi,
            Preconditioner::Multigrid,
            Preconditioner::TwoLevel,
        ] {
            let (dv, stats) = solve(&a, &b, &f, p, 1e-6);
            assert!(stats.residual <= 1e-6, "{p:?}: {stats:?}");
            let err = dv
                .iter()
                .zip(&exact)
                .map(|(x, y)| (*x - *y).length())
                .fold(0.0, f64::max);
            let size = exact.iter().map(|x| x.length()).fold(0.0, f64::max);
            assert!(err <= 1e-3 * size, "{p:?}: error {err} of {size}");
            for (i, x) in dv.iter().enumerate() {
                // The constrained part is exactly the prescribed one.
                let constrained = *x - f.apply(i, *x);
                let z = f.prescribed(i);
                assert!(
                    (constrained - z).length() <= 1e-12 * (1.0 + z.length()),
                    "vertex {i}"
                );
            }
        }
    }

    #[test]
    fn multigrid_and_two_level_need_fewer_iterations() {
        // Like the centre scene: one pin in the middle and one patch in contact.
        let n = 60;
        let a = spring_grid(n, 13);
        let b = random_vector(a.rows(), 14);
        let mut pinned = vec![false; a.rows()];
        pinned[(n / 2) * n + n / 2] = true;
        let mut f = Filter::new(&pinned);
        for y in 5..15 {
            for x in 40..50 {
                f.constrain(y * n + x, DVec3::Z, 0.01);
            }
        }
        let (_, jacobi) = solve(&a, &b, &f, Preconditioner::BlockJacobi, 1e-3);
        let (_, multigrid) = solve(&a, &b, &f, Preconditioner::Multigrid, 1e-3);
        let (_, two_level) = solve(&a, &b, &f, Preconditioner::TwoLevel, 1e-3);
        assert!(
            multigrid.iterations * 3 < jacobi.iterations,
            "{multigrid:?} vs {jacobi:?}"
        );
        assert!(
            two_level.iterations * 2 < jacobi.iterations,
            "{two_level:?} vs {jacobi:?}"
        );
    }

    #[test]
    fn filter_prescribes_and_projects() {
        let mut f = Filter::new(&[false, true]);
        assert!(
            !f.constrain(1, DVec3::Z, 1.0),
            "a pinned vertex takes no more constraints"
        );
        assert!(f.constrain(0, DVec3::Z, 2.0));
        assert!(
            !f.constrain(0, DVec3::new(0.0, 0.1, 1.0).normalize(), 1.0),
            "nearly parallel"
        );
        let n = DVec3::new(1.0, 0.0, 1.0).normalize();
        assert!(f.constrain(0, n, 3.0));
        let z = f.prescribed(0);
        assert!((z.z - 2.0).abs() < 1e-12 && (z.dot(n) - 3.0).abs() < 1e-12);
        assert_eq!(f.apply(0, DVec3::new(1.0, 1.0, 1.0)), DVec3::Y);
        assert_eq!(f.apply(1, DVec3::ONE), DVec3::ZERO);
    }
}
