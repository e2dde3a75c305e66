//! A list built by parallel tasks in a fixed order, as lists of lists.

/// Items a task appends to [`Chunks::last`] before the list is set aside
/// ([`Chunks::set_aside_when_full`]) and a new one started: a proximity
/// query may find millions, and one list would be copied at each doubling.
pub const PART: usize = 1 << 15;

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

    /// Sets `last` aside once it holds [`PART`] items, starting a new one
    /// with room for a part and a few items beyond it.
    #[inline]
    pub fn set_aside_when_full(&mut self) {
        if self.last.len() >= PART {
            let full = std::mem::replace(&mut self.last, Vec::with_capacity(PART + 64));
            self.done.push(full);
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
