//! A list built by parallel tasks in a fixed order, as lists of lists.

/// Most items a task appends to one list ([`Chunks::last`]) before it is
/// set aside ([`Chunks::set_aside_when_full`]) and a new one started: a
/// proximity query may find millions, and one list would be copied at each
/// doubling.
pub const PART: usize = 1 << 15;

/// A task's first list, once it holds items, has room for this many (and
/// [`ROOM`]); each list set aside after it starts one twice as long, up to
/// [`PART`]. So lists grow like a doubling vector without copying their
/// items: a copy costs memory bandwidth, the scarce resource of a query that
/// writes millions of contacts (BENCHMARKS.md, thirty-fifth landing).
pub const FIRST: usize = 256;

/// Spare room a list keeps for one visit's items: a list is set aside once
/// no more than this many places are left. A visit that adds more only makes
/// the vector grow (and copy) as any vector does.
pub const ROOM: usize = 64;

/// A list built by parallel tasks in a fixed order: `done`'s chunks, then
/// `last`. Joining moves chunks, not elements, so each element is copied
/// at most once, into the final vector, or never when the caller reads
/// the chunks ([`into_chunks`](Self::into_chunks)).
#[derive(Debug)]
pub struct Chunks<T> {
    /// The list a task appends to.
    pub last: Vec<T>,
    done: Vec<Vec<T>>,
}

impl<T> Default for Chunks<T> {
    fn default() -> Self {
        Chunks {
            last: Vec::new(),
            done: Vec::new(),
        }
    }
}

impl<T> Chunks<T> {
    /// This list, then `o`'s.
    pub fn join(&mut self, o: Chunks<T>) {
        self.flush();
        self.done.extend(o.done);
        if !o.last.is_empty() {
            self.done.push(o.last);
        }
    }

    fn flush(&mut self) {
        if !self.last.is_empty() {
            self.done.push(std::mem::take(&mut self.last));
        }
    }

    /// Makes room in `last` for one more visit's items ([`ROOM`]) without
    /// copying many: a first list with items gets room for [`FIRST`] (its
    /// few items copied once); a fuller list is set aside and a new one
    /// started, twice as long (at most [`PART`]). Call it after each visit.
    #[inline]
    pub fn set_aside_when_full(&mut self) {
        let len = self.last.len();
        if len != 0 && len + ROOM >= self.last.capacity() {
            self.make_room(len);
        }
    }

    /// [`set_aside_when_full`](Self::set_aside_when_full)'s rare part, out
    /// of line so that its every-visit test inlines.
    #[cold]
    #[inline(never)]
    fn make_room(&mut self, len: usize) {
        if len < FIRST {
            self.last.reserve_exact(FIRST + ROOM - len);
        } else {
            let next = Vec::with_capacity((2 * len).min(PART) + ROOM);
            self.done.push(std::mem::replace(&mut self.last, next));
        }
    }

    /// True when the list has no item.
    pub fn is_empty(&self) -> bool {
        self.last.is_empty() && self.done.is_empty()
    }

    /// The chunks, in order (none empty).
    pub fn into_chunks(mut self) -> Vec<Vec<T>> {
        self.flush();
        self.done
    }

    /// Every element, in order, in one vector.
    pub fn into_vec(mut self) -> Vec<T> {
        self.flush();
        if self.done.len() == 1 {
            return self.done.pop().unwrap_or_default();
        }
        let mut out = Vec::with_capacity(self.done.iter().map(Vec::len).sum());
        self.done
            .into_iter()
            .for_each(|mut chunk| out.append(&mut chunk));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tasks appending past several parts and joined in a fixed order give
    /// the items in that order, as one list or as chunks.
    #[test]
    fn set_aside_and_joined_lists_keep_their_order() {
        let task = |from: usize, n: usize| {
            let mut c = Chunks::default();
            for i in from..from + n {
                c.last.push(i);
                c.set_aside_when_full();
            }
            c
        };
        let mut all = task(0, 2 * PART + 5);
        all.join(task(2 * PART + 5, 0));
        all.join(task(2 * PART + 5, PART));
        all.last.push(3 * PART + 5);
        let want: Vec<usize> = (0..3 * PART + 6).collect();
        assert!(!all.is_empty() && Chunks::<usize>::default().is_empty());
        let chunks = all.into_chunks();
        assert!(chunks.len() >= 4 && chunks.iter().all(|c| !c.is_empty() && c.len() <= PART));
        // Lists double from FIRST to PART, each with room for a visit's items.
        let first = task(0, 3 * PART).into_chunks();
        let lens: Vec<usize> = first.iter().map(Vec::len).collect();
        assert_eq!(lens[0], FIRST);
        assert!(lens
            .windows(2)
            .all(|w| w[1] == (2 * w[0]).min(PART) || w[1] < w[0]));
        // Each list set aside was full to its room: no room wasted, none copied.
        let set_aside = &first[..first.len() - 1];
        assert!(set_aside.iter().all(|c| c.capacity() <= c.len() + ROOM));
        let mut again = Chunks::default();
        for c in &chunks {
            again.join(Chunks {
                last: c.clone(),
                done: Vec::new(),
            });
        }
        assert_eq!(chunks.concat(), want);
        assert_eq!(again.into_vec(), want);
    }
}
