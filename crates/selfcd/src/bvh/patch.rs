//! Node patches: contours, boundary vertices and Euler characteristics.
//! The theorem the contour test rests on is in [`super::certify`]; the 2-D
//! loop geometry of the test lives in [`crate::geom::loop2d`].
//!
//! A node's patch is the set of triangles under it. Its *contour* is every
//! directed edge of the patch not shared by two of its triangles: mesh boundary
//! edges and the edges the BVH cut. Contours are stored once, as sorted lists
//! of packed directed edges `edge_id << 1 | reversed`, with the sorted list of
//! the patch's boundary vertices and its Euler characteristic.

use crate::geom::loop2d::{Plane, Seg};
use crate::mesh::{Csr, Mesh};
use glam::DVec3;

/// Per-node patch topology, fixed at build time.
///
/// A leaf's lists are its triangle's three directed edges and three
/// corners ([`leaf_contour`], [`leaf_boundary`]); they are not stored, so
/// `contour` and `boundary` hold the internal nodes' rows only (the leaves'
/// rows and offsets were 32 of the hierarchy's 313 bytes a triangle on the
/// garments).
#[derive(Debug, Clone, Default)]
pub struct Patches {
    /// Number of leaves (the internal nodes' ids start here).
    pub n_leaves: usize,
    /// Sorted packed directed contour edges of each internal node (its row:
    /// [`row`](Self::row)).
    pub contour: Csr,
    /// Sorted boundary vertices of each internal node (the vertices of its
    /// contour).
    pub boundary: Csr,
    /// The row of `contour` and `boundary` of internal node `n_leaves + i`
    /// (entry `i`) where the nodes were renumbered after the build
    /// ([`super::Bvh::depth_first`]: the rows stay where the build wrote
    /// them); empty when internal node `n_leaves + i`'s row is `i`.
    pub rows: Vec<u32>,
    /// Euler characteristic V - E + F of each node's patch, or [`INELIGIBLE`]
    /// when the patch holds a non-manifold element or inconsistent winding
    /// (the contour test never passes for it).
    pub euler: Vec<i32>,
    /// A tag of the vertex-connected mesh component of each node's triangles:
    /// the component id modulo 255, or [`SEVERAL`] when they lie in several
    /// components. Nodes with different tags, neither [`SEVERAL`], lie in
    /// different components, so they share no vertex.
    pub component: Vec<u8>,
}

/// A node's contour or boundary: an internal node's stored row, or a
/// leaf's three entries, computed from the mesh.
#[derive(Debug, Clone, Copy)]
pub enum Row<'a> {
    /// An internal node's row.
    Stored(&'a [u32]),
    /// A leaf's entries.
    Leaf([u32; 3]),
}

impl std::ops::Deref for Row<'_> {
    type Target = [u32];
    #[inline]
    fn deref(&self) -> &[u32] {
        match self {
            Row::Stored(s) => s,
            Row::Leaf(a) => a,
        }
    }
}

/// Sorts a list of at most three items by compare-exchanges.
#[inline]
pub(super) fn sort_up_to_three(row: &mut [u32]) {
    let n = row.len();
    for (i, j) in [(0, 1), (1, 2), (0, 1)] {
        if j < n && row[j] < row[i] {
            row.swap(i, j);
        }
    }
}

/// The sorted packed directed edges of triangle `t`: its patch's contour.
#[inline]
pub fn leaf_contour(mesh: &Mesh, t: u32) -> [u32; 3] {
    let tri = mesh.triangles()[t as usize];
    let e = mesh.topology().tri_edges[t as usize];
    let mut c = [0, 1, 2].map(|k| pack(e[k], tri[k], tri[(k + 1) % 3]));
    sort_up_to_three(&mut c);
    c
}

/// The sorted corners of triangle `t`: its patch's boundary.
#[inline]
pub fn leaf_boundary(mesh: &Mesh, t: u32) -> [u32; 3] {
    let mut v = mesh.triangles()[t as usize];
    sort_up_to_three(&mut v);
    v
}

/// The Euler characteristic stored for a patch the contour test refuses.
pub const INELIGIBLE: i32 = i32::MIN / 4;

/// The component tag of a node spanning several components.
pub const SEVERAL: u8 = u8::MAX;

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
    merge_contours_with(a, b, out, |_| {})
}

/// [`merge_contours`] appending to `out` (not clearing it), and calling
/// `on_shared` with each shared edge (as packed in `a`).
#[inline]
pub fn merge_contours_with(
    a: &[u32],
    b: &[u32],
    out: &mut Vec<u32>,
    mut on_shared: impl FnMut(u32),
) -> MergeInfo {
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
            on_shared(a[i]);
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

/// True when two sorted lists share an item. Lists whose ranges do not
/// overlap are apart at once; a short list against a long one (a small node
/// against a big one, the common case in a descent) is searched item by item
/// in the long one, O(short log long); otherwise the lists are merged.
pub fn have_common(a: &[u32], b: &[u32]) -> bool {
    let (short, long) = if a.len() <= b.len() { (a, b) } else { (b, a) };
    let (Some(&s0), Some(&s1), Some(&l0), Some(&l1)) =
        (short.first(), short.last(), long.first(), long.last())
    else {
        return false;
    };
    if s1 < l0 || l1 < s0 {
        return false;
    }
    if 8 * short.len() < long.len() {
        let mut rest = long;
        for x in short {
            match rest.binary_search(x) {
                Ok(_) => return true,
                Err(k) => rest = &rest[k..],
            }
        }
        return false;
    }
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

impl Patches {
    /// The row of `contour` and `boundary` that holds internal node `node`'s
    /// lists.
    #[inline]
    pub fn row(&self, node: usize) -> usize {
        let i = node - self.n_leaves;
        self.rows.get(i).map_or(i, |&r| r as usize)
    }

    /// Contour of `node`, of the hierarchy built for `mesh` (whose triangle
    /// `t` is leaf `t`).
    #[inline]
    pub fn contour_of(&self, mesh: &Mesh, node: u32) -> Row<'_> {
        if (node as usize) < self.n_leaves {
            return Row::Leaf(leaf_contour(mesh, node));
        }
        Row::Stored(self.contour.row(self.row(node as usize)))
    }

    /// Boundary vertices of `node`, of the hierarchy built for `mesh`.
    #[inline]
    pub fn boundary_of(&self, mesh: &Mesh, node: u32) -> Row<'_> {
        if (node as usize) < self.n_leaves {
            return Row::Leaf(leaf_boundary(mesh, node));
        }
        Row::Stored(self.boundary.row(self.row(node as usize)))
    }

    /// Euler characteristic of an eligible node (manifold, consistent winding),
    /// None for the others.
    #[inline]
    pub fn euler_of(&self, node: u32) -> Option<i32> {
        Some(self.euler[node as usize]).filter(|&e| e != INELIGIBLE)
    }

    /// False when nodes `a` and `b` certainly share no vertex (their triangles
    /// lie in different mesh components); O(1).
    #[inline]
    pub fn may_touch(&self, a: u32, b: u32) -> bool {
        let (x, y) = (self.component[a as usize], self.component[b as usize]);
        x == y || x == SEVERAL || y == SEVERAL
    }
}

/// Projects directed contour edges along `axis` (relative to `origin`) into `out`.
/// The basis (u, w, axis) is right-handed, so counter-clockwise seen from +axis
/// stays counter-clockwise.
pub fn project_contour(
    mesh: &Mesh,
    positions: &[DVec3],
    contour: &[u32],
    plane: &Plane,
    out: &mut Vec<Seg>,
) {
    out.clear();
    out.extend(contour.iter().map(|&e| {
        let v = unpack(mesh, e);
        Seg {
            p: [
                plane.project(positions[v[0] as usize]),
                plane.project(positions[v[1] as usize]),
            ],
            v,
        }
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `have_common` agrees with `count_common > 0` on sorted lists of every
    /// length ratio (merge, item-by-item search, disjoint ranges, empty).
    #[test]
    fn have_common_matches_the_count() {
        let mut rng = crate::scene::SplitMix::new(7);
        let mut next = move |m: u64| (rng.next_u64() % m) as u32;
        let list = |len: u32, range: u64, next: &mut dyn FnMut(u64) -> u32| {
            let mut v: Vec<u32> = (0..len).map(|_| next(range)).collect();
            v.sort_unstable();
            v.dedup();
            v
        };
        let (mut both, mut neither) = (0, 0);
        for _ in 0..4000 {
            let (la, lb) = (next(4), next(200));
            let a = list(la, 400, &mut next);
            let b = list(lb, 400, &mut next);
            let want = count_common(&a, &b) > 0;
            assert_eq!(have_common(&a, &b), want, "{a:?} {b:?}");
            assert_eq!(have_common(&b, &a), want, "{b:?} {a:?}");
            if want {
                both += 1;
            } else {
                neither += 1;
            }
        }
        assert!(both > 100 && neither > 100, "{both} {neither}");
    }
}
