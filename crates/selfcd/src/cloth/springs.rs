//! Springs of a mass-spring cloth: which vertex pairs are linked, how stiff
//! each link is, and the force and positive semi-definite Jacobian of one spring.
//!
//! Spring set of a triangle mesh (built once from the topology):
//! - every mesh edge is a spring; an interior edge that is the longest edge of
//!   both of its triangles is a quad's *diagonal* and is a `Shear` spring, every
//!   other edge is a `Stretch` spring;
//! - across every interior edge, the two vertices opposite it are linked: across
//!   a diagonal this is the quad's other diagonal (`Shear`), across any other
//!   edge it is a `Bend` spring that resists folding about that edge.
//!
//! On the paper's grid this is Provot's cloth: structural springs along the
//! grid lines, both diagonals of every cell as shear springs, and bend springs
//! across every grid line.
//!
//! Stiffness from material moduli (N/m, force per unit width per unit strain):
//! `k = modulus * A / L^2`, where `L` is the rest length and `A` a third of the
//! rest area of the triangles on the spring's edge. Then a uniform strain e
//! stores about `modulus * e^2 / 2` per unit area, whatever the resolution.
//! Damping is stiffness-proportional: `kd = damping * k` (damping in seconds).

use crate::mesh::Mesh;
use glam::{DMat3, DVec3};

/// What a spring resists.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SpringKind {
    /// In-plane stretch along a mesh edge.
    Stretch,
    /// In-plane shear: the diagonals of a quad.
    Shear,
    /// Bending about an edge: the two vertices opposite it.
    Bend,
}

/// Material moduli the spring stiffnesses are derived from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moduli {
    /// Stretch modulus (N/m).
    pub stretch: f64,
    /// Shear modulus (N/m).
    pub shear: f64,
    /// Bend modulus (N/m), applied to the bend springs' length change.
    pub bend: f64,
    /// Stiffness-proportional damping time (s): `kd = damping * k`.
    pub damping: f64,
}

/// All springs of a cloth as flat arrays (one entry per spring).
#[derive(Debug, Clone, Default)]
pub struct Springs {
    /// The two vertices of each spring.
    pub ends: Vec<[u32; 2]>,
    /// Rest length L (m).
    pub rest: Vec<f64>,
    /// Stiffness k (N/m).
    pub stiffness: Vec<f64>,
    /// Damping coefficient kd (N s/m) along the spring.
    pub damping: Vec<f64>,
    /// What each spring resists.
    pub kind: Vec<SpringKind>,
}

impl Springs {
    /// Builds the spring set of `mesh` (see the module doc) with stiffnesses from `moduli`.
    pub fn new(mesh: &Mesh, moduli: &Moduli) -> Springs {
        let rest = mesh.rest();
        let topo = mesh.topology();
        let tris = mesh.triangles();
        let area = |t: u32| {
            let [a, b, c] = mesh.corners(rest, t as usize);
            0.5 * (b - a).cross(c - a).length()
        };
        let len = |e: [u32; 2]| (rest[e[0] as usize] - rest[e[1] as usize]).length();
        let mut s = Springs::default();
        for (e, &ends) in topo.edges.iter().enumerate() {
            let owners = topo.edge_tris.row(e);
            let share = owners.iter().map(|&t| area(t)).sum::<f64>() / 3.0;
            let diagonal =
                owners.len() == 2 && owners.iter().all(|&t| is_longest(mesh, t, e as u32));
            let kind = if diagonal {
                SpringKind::Shear
            } else {
                SpringKind::Stretch
            };
            s.push(ends, len(ends), share, kind, moduli);
            if owners.len() == 2 {
                let (p, q) = (
                    opposite(tris[owners[0] as usize], ends),
                    opposite(tris[owners[1] as usize], ends),
                );
                if p != q {
                    let cross = [p.min(q), p.max(q)];
                    let kind = if diagonal {
                        SpringKind::Shear
                    } else {
                        SpringKind::Bend
                    };
                    s.push(cross, len(cross), share, kind, moduli);
                }
            }
        }
        s
    }

    fn push(&mut self, ends: [u32; 2], rest: f64, area: f64, kind: SpringKind, m: &Moduli) {
        let modulus = match kind {
            SpringKind::Stretch => m.stretch,
            SpringKind::Shear => m.shear,
            SpringKind::Bend => m.bend,
        };
        let k = modulus * area / (rest * rest);
        self.ends.push(ends);
        self.rest.push(rest);
        self.stiffness.push(k);
        self.damping.push(m.damping * k);
        self.kind.push(kind);
    }

    /// Number of springs.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    /// True when there are no springs.
    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// Elastic energy of spring `s` at positions `x`: `k (l - L)^2 / 2`.
    pub fn energy(&self, s: usize, x: &[DVec3]) -> f64 {
        let [i, j] = self.ends[s];
        let stretch = (x[j as usize] - x[i as usize]).length() - self.rest[s];
        0.5 * self.stiffness[s] * stretch * stretch
    }

    /// Relative length change `(l - L) / L` of spring `s` at positions `x`.
    pub fn strain(&self, s: usize, x: &[DVec3]) -> f64 {
        let [i, j] = self.ends[s];
        (x[j as usize] - x[i as usize]).length() / self.rest[s] - 1.0
    }
}

/// True when edge `e` is strictly the longest edge of triangle `t` in the rest shape.
fn is_longest(mesh: &Mesh, t: u32, e: u32) -> bool {
    let topo = mesh.topology();
    let rest = mesh.rest();
    let l = |e: u32| {
        let [a, b] = topo.edges[e as usize];
        (rest[a as usize] - rest[b as usize]).length_squared()
    };
    let le = l(e);
    topo.tri_edges[t as usize]
        .iter()
        .filter(|&&o| o != e)
        .all(|&o| le > l(o) * (1.0 + 1e-9))
}

/// The vertex of triangle `t` that is not on edge `e`.
fn opposite(t: [u32; 3], e: [u32; 2]) -> u32 {
    t.into_iter().find(|v| !e.contains(v)).unwrap_or(t[0])
}

/// Force, and Jacobian blocks, of one spring, seen from its first end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringEval {
    /// Force on the first end: `f = k (l - L) u + kd ((v1 - v0) . u) u`, `u = (x1 - x0) / l`;
    /// the second end gets `-f`.
    pub force: DVec3,
    /// `Kx = k (u u^T + max(0, 1 - L/l) (I - u u^T))`: minus the force's position
    /// derivative `-df0/dx0`, with the compressive (indefinite) part dropped so it
    /// is positive semi-definite (Baraff & Witkin 1998; Choi & Ko 2002).
    pub kx: DMat3,
    /// `Kv = kd u u^T = -df0/dv0`.
    pub kv: DMat3,
}

/// Evaluates a spring with rest length `rest`, stiffness `k` and damping `kd`,
/// from `d = x1 - x0` and `w = v1 - v0`. A zero-length spring has no direction:
/// its force is zero and `Kx = k I`, which keeps the system positive definite.
#[inline]
pub fn evaluate(d: DVec3, w: DVec3, rest: f64, k: f64, kd: f64) -> SpringEval {
    let l = d.length();
    if l.is_nan() || l <= 1e-12 * rest {
        return SpringEval {
            force: DVec3::ZERO,
            kx: DMat3::from_diagonal(DVec3::splat(k)),
            kv: DMat3::ZERO,
        };
    }
    let u = d / l;
    let uu = outer(u);
    let force = u * (k * (l - rest) + kd * w.dot(u));
    let lateral = (1.0 - rest / l).max(0.0);
    let kx = uu * (k * (1.0 - lateral)) + DMat3::from_diagonal(DVec3::splat(k * lateral));
    SpringEval {
        force,
        kx,
        kv: uu * kd,
    }
}

/// The outer product `u u^T`.
#[inline]
pub fn outer(u: DVec3) -> DMat3 {
    DMat3::from_cols(u * u.x, u * u.y, u * u.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::grid;

    #[test]
    fn grid_gets_provot_springs() {
        let (v, f) = grid(3, 1.0);
        let mesh = Mesh::new(v, f).unwrap();
        let m = Moduli {
            stretch: 1.0,
            shear: 1.0,
            bend: 1.0,
            damping: 0.0,
        };
        let s = Springs::new(&mesh, &m);
        let count = |k: SpringKind| s.kind.iter().filter(|&&x| x == k).count();
        // 12 grid-line edges, 4 cells x 2 diagonals, 4 interior grid-line edges.
        assert_eq!(
            (
                count(SpringKind::Stretch),
                count(SpringKind::Shear),
                count(SpringKind::Bend)
            ),
            (12, 8, 4)
        );
    }

    #[test]
    fn jacobian_matches_finite_differences_when_stretched() {
        let (d, w) = (DVec3::new(1.2, 0.3, -0.1), DVec3::ZERO);
        let e = evaluate(d, w, 1.0, 7.0, 0.0);
        let h = 1e-6;
        for c in 0..3 {
            let mut dp = d;
            dp[c] -= h; // moving x0 by +h changes d by -h
            let f1 = evaluate(dp, w, 1.0, 7.0, 0.0).force;
            let col = -(f1 - e.force) / h;
            assert!(
                (col - e.kx.col(c)).length() < 1e-4,
                "column {c}: {col} vs {}",
                e.kx.col(c)
            );
        }
    }

    #[test]
    fn compressed_jacobian_is_positive_semidefinite() {
        let e = evaluate(DVec3::new(0.5, 0.0, 0.0), DVec3::ZERO, 1.0, 3.0, 0.0);
        for v in [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE] {
            assert!(v.dot(e.kx * v) >= 0.0);
        }
        assert!(
            e.force.x < 0.0,
            "a compressed spring pushes its first end away"
        );
    }
}
