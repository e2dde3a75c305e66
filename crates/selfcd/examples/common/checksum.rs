//! A checksum of an output's bits (FNV-1a over 64-bit words), so that runs
//! can be compared by one line: the same output gives the same checksum for
//! any number of threads.

/// FNV-1a of `words`, continuing from `h` (start from [`START`]).
pub fn fnv(h: u64, words: impl IntoIterator<Item = u64>) -> u64 {
    words
        .into_iter()
        .fold(h, |h, w| (h ^ w).wrapping_mul(0x0100_0000_01b3))
}

/// The FNV-1a offset basis.
pub const START: u64 = 0xcbf2_9ce4_8422_2325;

/// The checksum of sorted triangle pairs.
pub fn pairs(h: u64, pairs: &[[u32; 2]]) -> u64 {
    fnv(h, pairs.iter().map(|p| (p[0] as u64) << 32 | p[1] as u64))
}

/// The checksum of proximity contacts: ids and distance bits of each.
pub fn proximity(h: u64, near: &selfcd::detect::ProximityContacts) -> u64 {
    let vt = near.vertex_triangle.iter();
    let ee = near.edge_edge.iter();
    let h = fnv(
        h,
        vt.flat_map(|c| {
            [
                (c.vertex as u64) << 32 | c.triangle as u64,
                c.distance.to_bits(),
            ]
        }),
    );
    fnv(
        h,
        ee.flat_map(|c| {
            [
                (c.edges[0] as u64) << 32 | c.edges[1] as u64,
                c.distance.to_bits(),
            ]
        }),
    )
}
