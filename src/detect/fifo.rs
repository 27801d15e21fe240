//! A first-in, first-out queue of at most `N` items in a fixed array, for the stages
//! whose items wait a while before they are handled in order (onsets waiting to be
//! placed, onsets waiting for a second look). An item pushed onto a full queue is
//! counted, not stored. Allocates nothing; runs on the thread of the stage that owns it.

#[derive(Debug, Clone)]
pub(super) struct Fifo<T: Copy + Default, const N: usize> {
    items: [T; N],
    first: usize,
    len: usize,
    /// Items pushed while the queue was full.
    dropped: u64,
}

impl<T: Copy + Default, const N: usize> Fifo<T, N> {
    pub(super) fn new() -> Self {
        Self {
            items: [T::default(); N],
            first: 0,
            len: 0,
            dropped: 0,
        }
    }

    /// Adds `item` at the back, or counts it as dropped when the queue is full.
    pub(super) fn push(&mut self, item: T) {
        if self.len == N {
            self.dropped += 1;
            return;
        }
        self.items[(self.first + self.len) % N] = item;
        self.len += 1;
    }

    /// The oldest item, left in the queue.
    pub(super) fn front(&self) -> Option<T> {
        (self.len > 0).then(|| self.items[self.first])
    }

    /// Takes the oldest item out.
    pub(super) fn pop(&mut self) -> Option<T> {
        let item = self.front()?;
        self.first = (self.first + 1) % N;
        self.len -= 1;
        Some(item)
    }

    /// The items, oldest first, left in the queue.
    pub(super) fn iter(&self) -> impl Iterator<Item = &T> + '_ {
        (0..self.len).map(move |i| &self.items[(self.first + i) % N])
    }

    /// Items that found the queue full.
    pub(super) fn dropped(&self) -> u64 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn items_come_out_in_order_across_the_wrap_and_a_full_queue_counts_what_it_drops() {
        let mut q: Fifo<u64, 3> = Fifo::new();
        assert_eq!(q.front(), None);
        for k in 0..3 {
            q.push(k);
        }
        q.push(99);
        assert_eq!(q.dropped(), 1);
        assert_eq!(q.pop(), Some(0));
        q.push(3);
        assert_eq!(q.front(), Some(1));
        assert_eq!(q.iter().copied().collect::<Vec<_>>(), [1, 2, 3]);
        assert_eq!(
            [q.pop(), q.pop(), q.pop(), q.pop()],
            [Some(1), Some(2), Some(3), None]
        );
        assert_eq!(q.dropped(), 1);
    }
}
