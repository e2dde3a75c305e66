//! Moving a particle on the surface (paper 2.3, made precise).
//!
//! A step is a tangent vector d at the particle in the current shape. It is
//! carried to rest space through the deformation of the particle's triangle
//! (see [`super::tangent`]) and followed there as a straight line: inside a
//! triangle the barycentric weights change linearly, b(s) = b + s db; when a
//! weight reaches 0 the path leaves through the opposite edge, and the rest of
//! the step is unfolded into the neighbour across that edge (rotated about the
//! shared edge so that it keeps its angle with the edge: a straight line on the
//! unfolded surface, the identity on a flat rest shape). At a mesh-boundary or
//! non-manifold edge the particle stops going outwards and slides along the
//! edge with the along-edge part of what is left. Weights stay >= 0 and sum to
//! 1 after every move, so the particle never leaves the surface.

use super::particle::SurfacePoint;
use super::tangent::{self, TriMap};
use crate::mesh::Mesh;
use glam::DVec3;

/// Most edge crossings (and slides) of one step; a step that needs more stops there, still on the surface.
pub const MAX_CROSSINGS: usize = 256;

/// Moves `p` by the current-space tangent vector `d`, carried to rest space by
/// `map` (the deformation of p's triangle). A degenerate current triangle has
/// no tangent plane: the particle stays.
pub fn step(mesh: &Mesh, map: &TriMap, p: SurfacePoint, d: DVec3) -> SurfacePoint {
    match map.increments(d) {
        Some(inc) => walk_increments(mesh, p, inc),
        None => p,
    }
}

/// Follows the rest-space vector `r` (in the plane of p's triangle) from `p` as a
/// straight line on the unfolded rest surface, sliding along boundary edges.
pub fn walk(mesh: &Mesh, p: SurfacePoint, r: DVec3) -> SurfacePoint {
    let (e1, e2) = tangent::edges(mesh, mesh.rest(), p.tri as usize);
    match tangent::to_bary(e1, e2, r) {
        Some(inc) => walk_increments(mesh, p, inc),
        None => p,
    }
}

/// [`walk`] with the step given as barycentric increments (d1, d2) in p's triangle.
pub fn walk_increments(mesh: &Mesh, mut p: SurfacePoint, mut inc: [f64; 2]) -> SurfacePoint {
    let rest = mesh.rest();
    let stop = mesh.mean_edge_length() * 1e-12;
    // Local index of the vertex opposite the edge the point lies on and must not leave through.
    let mut entry: Option<usize> = None;
    for _ in 0..MAX_CROSSINGS {
        let d = [-(inc[0] + inc[1]), inc[0], inc[1]];
        let Some((k, s)) = exit(&p.bary, &d, entry) else {
            advance(&mut p, &d, 1.0);
            break;
        };
        advance(&mut p, &d, s);
        p.bary[k] = 0.0;
        p.normalise();
        let (e1, e2) = tangent::edges(mesh, rest, p.tri as usize);
        let r = tangent::from_bary(e1, e2, inc) * (1.0 - s);
        let r = match cross(mesh, &p, k) {
            Some((next, opposite)) => {
                let r = unfold(r, mesh, p.tri, k, next.tri, opposite);
                (p, entry) = (next, Some(opposite));
                r
            }
            None => {
                entry = Some(k);
                slide(r, rest, mesh.triangles()[p.tri as usize], k)
            }
        };
        if !(r.length() > stop) {
            break;
        }
        let (f1, f2) = tangent::edges(mesh, rest, p.tri as usize);
        let Some(next_inc) = tangent::to_bary(f1, f2, r) else {
            break;
        };
        inc = next_inc;
    }
    p
}

/// First weight to reach zero along b + s d for s in [0, 1): (its index, s).
/// The weight of `entry` is ignored (the point sits on that edge, coming from across it).
#[inline]
fn exit(b: &[f64; 3], d: &[f64; 3], entry: Option<usize>) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for k in 0..3 {
        if Some(k) == entry || !(d[k] < 0.0) {
            continue;
        }
        let s = (b[k] / -d[k]).max(0.0);
        if s < best.map_or(1.0, |(_, bs)| bs) {
            best = Some((k, s));
        }
    }
    best
}

/// b += s d, then back to a convex combination.
#[inline]
fn advance(p: &mut SurfacePoint, d: &[f64; 3], s: f64) {
    for (b, dm) in p.bary.iter_mut().zip(d) {
        *b += s * dm;
    }
    p.normalise();
}

/// The same point (on the edge opposite local vertex `k` of p's triangle) in the
/// triangle across that edge, and the local index of that triangle's vertex
/// off the edge. None at a boundary or non-manifold edge.
fn cross(mesh: &Mesh, p: &SurfacePoint, k: usize) -> Option<(SurfacePoint, usize)> {
    let t = p.tri as usize;
    let edge = mesh.topology().tri_edges[t][(k + 1) % 3];
    let [t0, t1] = <[u32; 2]>::try_from(mesh.topology().edge_tris.row(edge as usize)).ok()?;
    let next = if t0 as usize == t { t1 } else { t0 };
    let (old, new) = (mesh.triangles()[t], mesh.triangles()[next as usize]);
    let mut bary = [0.0; 3];
    let mut off = 3;
    for (m, v) in new.iter().enumerate() {
        match old.iter().position(|u| u == v) {
            Some(o) => bary[m] = p.bary[o],
            None => off = m,
        }
    }
    (off < 3).then_some((SurfacePoint { tri: next, bary }, off))
}

/// Carries rest vector `r` across the edge shared by triangle `from` (off-edge
/// local vertex `k`) and triangle `to` (off-edge local vertex `opposite`): with
/// e the unit edge and n_from, n_to the unit in-plane normals of the edge
/// pointing into each triangle, r' = (r.e) e - (r.n_from) n_to.
fn unfold(r: DVec3, mesh: &Mesh, from: u32, k: usize, to: u32, opposite: usize) -> DVec3 {
    let rest = mesh.rest();
    let (tf, tt) = (
        mesh.triangles()[from as usize],
        mesh.triangles()[to as usize],
    );
    let a = rest[tf[(k + 1) % 3] as usize];
    let e = (rest[tf[(k + 2) % 3] as usize] - a).normalize_or_zero();
    let inward = |c: DVec3| {
        let v = c - a;
        (v - e * v.dot(e)).normalize_or_zero()
    };
    let (n_from, n_to) = (
        inward(rest[tf[k] as usize]),
        inward(rest[tt[opposite] as usize]),
    );
    e * r.dot(e) - n_to * r.dot(n_from)
}

/// The along-edge part of `r` for the boundary edge opposite local vertex `k` of triangle `tri`.
fn slide(r: DVec3, rest: &[DVec3], tri: [u32; 3], k: usize) -> DVec3 {
    let (a, b) = (
        rest[tri[(k + 1) % 3] as usize],
        rest[tri[(k + 2) % 3] as usize],
    );
    let e = (b - a).normalize_or_zero();
    e * r.dot(e)
}
