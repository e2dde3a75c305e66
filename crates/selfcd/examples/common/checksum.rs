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
