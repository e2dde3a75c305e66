//! Node contours and the star contour test (Volino & Magnenat-Thalmann's
//! condition (B), made conservative).
//!
//! A node's patch is the set of triangles under it. Its *contour* is every
//! directed edge of the patch not shared by two of its triangles: mesh boundary
//! edges and the edges the BVH cut. Contours are stored once, as sorted lists
//! of packed directed edges `edge_id << 1 | reversed`, with the sorted list of
//! the patch's boundary vertices and its Euler characteristic.
//!
//! **Theorem used.** Let a patch be connected with Euler characteristic 1, be
//! an orientable manifold (every edge in at most two triangles, every vertex
//! star one fan), have every triangle normal strictly within 90 degrees of v,
//! and let c be a point such that, projected along v, c lies strictly left of
//! every directed contour edge with the edges turning around c once in total.
//! Then the patch has no two non-adjacent triangles that touch. (Each cycle of
//! contour edges turns around c a positive whole number of times, so one turn
//! means one simple star-shaped loop; the projection is then a local,
//! orientation-preserving map of a disk whose boundary goes once around a
//! simple curve, so its degree is 1 and it is one-to-one.)

use crate::mesh::{Csr, Mesh};
use glam::DVec3;
use std::f64::consts::TAU;

/// Per-node patch topology, fixed at build time.
#[derive(Debug, Clone, Default)]
pub struct Patches {
    /// Sorted packed directed contour edges of each node.
    pub contour: Csr,
    /// Sorted boundary vertices of each node (the vertices of its contour).
    pub boundary: Csr,
    /// Euler characteristic V - E + F of each node's patch.
    pub euler: Vec<i32>,
    /// False when the patch holds a non-manifold element or inconsistent
    /// winding: the contour test never passes for it.
    pub eligible: Vec<bool>,
}

/// Packs directed edge `a -> b` (edge id `e`) as `e << 1 | (a > b)`.
#[inline]
pub fn pack(e: u32, a: u32, b: u32) -> u32 {
    (e << 1) | (a > b) as u32
}

/// The directed vertex pair of a packed contour edge.
#[inline]
pub fn unpack(mesh: &Mesh, packed: u32) -> [u32; 2] {
    let [lo, hi] = mesh.topology().edges[(packed >> 1) as usize];
    if packed & 1 == 0 {
        [lo, hi]
    } else {
        [hi, lo]
    }
}

/// What merging two contours found.
#[derive(Debug, Clone, Copy, Default)]
pub struct MergeInfo {
    /// Edges present in both contours (they become interior to the union).
    pub shared_edges: u32,
    /// A shared edge had the same direction on both sides: inconsistent winding.
    pub conflict: bool,
}

/// Contour of the union of two disjoint patches: the symmetric difference of
/// their sorted contours, written to `out`.
pub fn merge_contours(a: &[u32], b: &[u32], out: &mut Vec<u32>) -> MergeInfo {
    out.clear();
    let mut info = MergeInfo::default();
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let (ea, eb) = (a[i] >> 1, b[j] >> 1);
        if ea < eb {
            out.push(a[i]);
            i += 1;
        } else if eb < ea {
            out.push(b[j]);
            j += 1;
        } else {
            info.shared_edges += 1;
            info.conflict |= a[i] == b[j];
            i += 1;
            j += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    info
}

/// Number of common items of two sorted lists.
pub fn count_common(a: &[u32], b: &[u32]) -> u32 {
    let (mut i, mut j, mut n) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                n += 1;
                i += 1;
                j += 1;
            }
        }
    }
    n
}

/// True when two sorted lists share an item.
pub fn have_common(a: &[u32], b: &[u32]) -> bool {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => return true,
        }
    }
    false
}

/// The star test: projected along `axis`, does the centroid of the contour's
/// start points lie strictly left of every directed contour edge, with the
/// contour turning around it exactly once? Conservative: `false` means "cannot
/// tell", and the caller descends.
pub fn star_contour(mesh: &Mesh, positions: &[DVec3], contour: &[u32], axis: DVec3) -> bool {
    if contour.len() < 3 {
        return false;
    }
    let u = axis.any_orthonormal_vector();
    let w = axis.cross(u); // (u, w, axis) right-handed: counter-clockwise seen from +axis
    let proj = |v: u32| {
        let p = positions[v as usize];
        [p.dot(u), p.dot(w)]
    };
    let mut c = [0.0; 2];
    for &e in contour {
        let p = proj(unpack(mesh, e)[0]);
        c[0] += p[0];
        c[1] += p[1];
    }
    let inv = 1.0 / contour.len() as f64;
    let c = [c[0] * inv, c[1] * inv];
    let mut turn = 0.0;
    for &e in contour {
        let [a, b] = unpack(mesh, e);
        let (pa, pb) = (proj(a), proj(b));
        let (ax, ay, bx, by) = (pa[0] - c[0], pa[1] - c[1], pb[0] - c[0], pb[1] - c[1]);
        let cross = ax * by - ay * bx;
        let scale = (ax * ax + ay * ay).max(bx * bx + by * by);
        // Strictly left, with a relative margin far above the rounding of the projection.
        if !(cross > 1e-9 * scale) {
            return false;
        }
        turn += cross.atan2(ax * bx + ay * by);
    }
    (turn - TAU).abs() < 0.5
}

impl Patches {
    /// Contour of `node`.
    #[inline]
    pub fn contour_of(&self, node: u32) -> &[u32] {
        self.contour.row(node as usize)
    }

    /// Boundary vertices of `node`.
    #[inline]
    pub fn boundary_of(&self, node: u32) -> &[u32] {
        self.boundary.row(node as usize)
    }
}

/// Flags, per triangle, whether it touches a non-manifold edge (more than two
/// triangles) or a non-manifold vertex (its triangles form several fans).
pub fn nonmanifold_triangles(mesh: &Mesh) -> Vec<bool> {
    let topo = mesh.topology();
    let tris = mesh.triangles();
    let mut bad = vec![false; tris.len()];
    for e in 0..topo.edges.len() {
        let row = topo.edge_tris.row(e);
        if row.len() > 2 {
            row.iter().for_each(|&t| bad[t as usize] = true);
        }
    }
    // A vertex is manifold when its triangles are connected through edges at it.
    let mut parent: Vec<u32> = Vec::new();
    for v in 0..mesh.n_vertices() {
        let fan = topo.vertex_tris.row(v);
        if fan.len() < 2 {
            continue;
        }
        parent.clear();
        parent.extend(0..fan.len() as u32);
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        for i in 0..fan.len() {
            for j in i + 1..fan.len() {
                let (ti, tj) = (fan[i] as usize, fan[j] as usize);
                let shares_edge_at_v = topo.tri_edges[ti].iter().any(|e| {
                    topo.tri_edges[tj].contains(e) && topo.edges[*e as usize].contains(&(v as u32))
                });
                if shares_edge_at_v {
                    let (ri, rj) = (find(&mut parent, i as u32), find(&mut parent, j as u32));
                    parent[ri as usize] = rj;
                }
            }
        }
        let roots = (0..fan.len() as u32).filter(|&i| find(&mut parent, i) == i).count();
        if roots > 1 {
            fan.iter().for_each(|&t| bad[t as usize] = true);
        }
    }
    bad
}
