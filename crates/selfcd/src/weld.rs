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

/// False only when every position of `positions` is distinct (then no two
/// vertices weld); true when some may repeat, so that the caller runs the
/// exact grouping ([`position_groups`]). Equal positions have equal keys and
/// so equal hashes, so a repeat is never missed; distinct positions are
/// reported only when two of their 64-bit hashes are equal (odds about
/// n^2 / 2^65 for n vertices, or an adversarial input), which costs the caller
/// the exact grouping and changes no answer.
///
/// One pass into an open-addressing table of hashes at most half full
/// (linear probing), about a sixth of the memory and far fewer instructions
/// than sorting the keys.
pub fn may_repeat_positions(positions: &[DVec3]) -> bool {
    let slots = (2 * positions.len()).next_power_of_two().max(2);
    let shift = 64 - slots.trailing_zeros();
    // 0 marks an empty slot; a hash of 0 is stored as 1 (a merged
    // collision, which only ever reports `true`).
    let mut table = vec![0u64; slots];
    for &p in positions {
        let h = hash(key(p)).max(1);
        let mut s = (h >> shift) as usize;
        loop {
            match table[s] {
                0 => {
                    table[s] = h;
                    break;
                }
                x if x == h => return true,
                _ => s = (s + 1) & (slots - 1),
            }
        }
    }
    false
}

/// A 64-bit hash of a position key: each word multiplied by its own odd
/// constant and rotated apart, then finalized (splitmix64's mixer) so that
/// the top bits, which pick the slot, depend on every input bit.
#[inline]
fn hash(k: [u64; 3]) -> u64 {
    const M: [u64; 3] = [
        0x9E37_79B9_7F4A_7C15,
        0xC2B2_AE3D_27D4_EB4F,
        0x1656_67B1_9E37_79F9,
    ];
    let mut x = k[0].wrapping_mul(M[0])
        ^ k[1].wrapping_mul(M[1]).rotate_left(21)
        ^ k[2].wrapping_mul(M[2]).rotate_left(42);
    x ^= x >> 30;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_screen_finds_every_repeat_and_passes_distinct_positions() {
        // Grid coordinates (many equal words across vertices), signed zeros,
        // subnormals and huge values.
        let mut p: Vec<DVec3> = (0..40_000)
            .map(|i| {
                let (a, b) = ((i % 200) as f64, (i / 200) as f64);
                DVec3::new(a * 0.01, b * 1e-310, (a - b) * 1e300)
            })
            .collect();
        assert!(!may_repeat_positions(&p));
        assert!(!may_repeat_positions(&p[..1]) && !may_repeat_positions(&[]));
        for (i, j) in [(0, 39_999), (123, 124), (39_998, 7)] {
            let mut q = p.clone();
            q[i] = q[j];
            assert!(may_repeat_positions(&q), "{i} = {j}");
            assert_ne!(position_groups(&q).first.len(), q.len());
        }
        // -0.0 and 0.0 are one position (vertex 0 is at the origin).
        p[5] = DVec3::new(-0.0, 0.0, -0.0);
        assert!(may_repeat_positions(&p));
    }

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
