//! Vertices at exactly equal positions: the grouping behind welding a
//! triangle soup (the Python API's `weld=True` and its unwelded-mesh warning).
//!
//! Equal means bitwise-equal coordinates once -0.0 is read as 0.0: no
//! tolerance, so nothing apart in the input is merged.

use glam::DVec3;
use rayon::prelude::*;

/// Groups of vertices at equal positions, numbered in first-occurrence order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PositionGroups {
    /// Group id of every vertex.
    pub group: Vec<u32>,
    /// First vertex of every group (increasing).
    pub first: Vec<u32>,
}

/// The bit pattern of `x` with -0.0 read as 0.0 (`+ 0.0` does that).
#[inline]
fn key(p: DVec3) -> [u64; 3] {
    (p + DVec3::ZERO).to_array().map(f64::to_bits)
}

/// Groups `positions` by exact equality. O(n log n), parallel sort; the
/// result does not depend on the thread count.
pub fn position_groups(positions: &[DVec3]) -> PositionGroups {
    let n = positions.len();
    // Equal positions end up adjacent, each run in increasing vertex order.
    let mut keyed: Vec<([u64; 3], u32)> = (positions.par_iter().enumerate())
        .map(|(i, &p)| (key(p), i as u32))
        .collect();
    keyed.par_sort_unstable();
    let mut rep = vec![0u32; n];
    for run in keyed.chunk_by(|a, b| a.0 == b.0) {
        for &(_, i) in run {
            rep[i as usize] = run[0].1;
        }
    }
    let mut group = vec![0u32; n];
    let mut first = Vec::new();
    for i in 0..n {
        let r = rep[i] as usize;
        group[i] = if r == i {
            first.push(i as u32);
            (first.len() - 1) as u32
        } else {
            group[r]
        };
    }
    PositionGroups { group, first }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_equal_positions_in_first_occurrence_order() {
        let p = [
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(-0.0, 0.0, -0.0),
            DVec3::new(1.0, 2.0, 3.0 + f64::EPSILON * 4.0),
        ];
        let g = position_groups(&p);
        assert_eq!(g.group, vec![0, 1, 0, 1, 2]);
        assert_eq!(g.first, vec![0, 1, 4]);
        assert_eq!(position_groups(&[]).first, Vec::<u32>::new());
    }
}
