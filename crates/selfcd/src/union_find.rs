//! Disjoint sets over `0..n` stored as a parent array (`parent[i] == i` at a
//! root), shared by the mesh's fan count and the sensor's components.

/// Root of `v`, halving the path on the way.
pub fn find(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        let up = parent[parent[v as usize] as usize];
        parent[v as usize] = up;
        v = up;
    }
    v
}

/// Joins the sets of `a` and `b`; true when they were apart. The smaller
/// root becomes the parent, so the result does not depend on the call order
/// within a set.
pub fn union(parent: &mut [u32], a: u32, b: u32) -> bool {
    let (ra, rb) = (find(parent, a), find(parent, b));
    let (lo, hi) = (ra.min(rb), ra.max(rb));
    parent[hi as usize] = lo;
    lo != hi
}
