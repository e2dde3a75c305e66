//! The set bits of a mask as indices: the one loop the traversals' branch-free
//! box tests (a mask of the pairs they keep) and the narrow phase's ownership
//! masks are read with.

/// The indices of the set bits of `mask`, in increasing order.
#[inline(always)]
pub fn set_bits(mask: u64) -> impl Iterator<Item = usize> {
    let mut m = mask;
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            k
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_bits_are_the_ones_in_order() {
        assert_eq!(set_bits(0).count(), 0);
        assert_eq!(set_bits(0b1011_0010).collect::<Vec<_>>(), [1, 4, 5, 7]);
        assert_eq!(set_bits(1 << 63).collect::<Vec<_>>(), [63]);
        for m in 0..512u64 {
            let want: Vec<usize> = (0..9).filter(|k| m >> k & 1 != 0).collect();
            assert_eq!(set_bits(m).collect::<Vec<_>>(), want);
        }
    }
}
