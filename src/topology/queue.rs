//! A worst-first quality priority queue with lazy deletion by generation counters.

use slotmap::{Key, SecondaryMap};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

#[derive(Clone, Copy, Debug)]
struct Entry<K> {
    quality: f64,
    key: K,
    generation: u32,
}

impl<K> PartialEq for Entry<K> {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl<K> Eq for Entry<K> {}
impl<K> PartialOrd for Entry<K> {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl<K> Ord for Entry<K> {
    /// Reversed, so that the max-heap pops the lowest quality first; ties by generation keep
    /// the order deterministic.
    fn cmp(&self, other: &Self) -> Ordering {
        other.quality.total_cmp(&self.quality).then(other.generation.cmp(&self.generation))
    }
}

/// Worst-first queue of elements keyed by slotmap keys. `push` on a key already queued
/// supersedes the old entry; `remove` forgets a key. Stale entries are skipped on `pop`, so the
/// queue stays correct as elements change or die, without searching the heap.
#[derive(Clone, Debug)]
pub struct QualityQueue<K: Key> {
    heap: BinaryHeap<Entry<K>>,
    generation: SecondaryMap<K, u32>,
    counter: u32,
}

impl<K: Key> Default for QualityQueue<K> {
    fn default() -> Self {
        Self::new()
    }
}

impl<K: Key> QualityQueue<K> {
    /// An empty queue.
    pub fn new() -> Self {
        QualityQueue { heap: BinaryHeap::new(), generation: SecondaryMap::new(), counter: 0 }
    }

    /// Queues (or re-queues) `key` with `quality`.
    pub fn push(&mut self, key: K, quality: f64) {
        self.counter = self.counter.wrapping_add(1);
        self.generation.insert(key, self.counter);
        self.heap.push(Entry { quality, key, generation: self.counter });
    }

    /// Forgets `key` (its entries become stale).
    pub fn remove(&mut self, key: K) {
        self.generation.remove(key);
    }

    /// The worst live entry, removed from the queue.
    pub fn pop(&mut self) -> Option<(K, f64)> {
        while let Some(e) = self.heap.pop() {
            if self.generation.get(e.key) == Some(&e.generation) {
                self.generation.remove(e.key);
                return Some((e.key, e.quality));
            }
        }
        None
    }

    /// The worst live entry without removing it.
    pub fn peek(&mut self) -> Option<(K, f64)> {
        while let Some(e) = self.heap.peek() {
            if self.generation.get(e.key) == Some(&e.generation) {
                return Some((e.key, e.quality));
            }
            self.heap.pop();
        }
        None
    }

    /// Number of live keys.
    pub fn len(&self) -> usize {
        self.generation.len()
    }

    /// True when no live key is queued.
    pub fn is_empty(&self) -> bool {
        self.generation.is_empty()
    }
}

impl<P: super::MeshPoint> super::TriMesh<P> {
    /// A queue holding every face with its quality q.
    pub fn quality_queue(&self) -> QualityQueue<super::FaceId> {
        let mut q = QualityQueue::new();
        for f in self.face_ids() {
            q.push(f, self.face_quality(f));
        }
        q
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    slotmap::new_key_type! { struct K; }

    #[test]
    fn worst_first_with_updates_and_removals() {
        let mut sm: slotmap::SlotMap<K, ()> = slotmap::SlotMap::with_key();
        let keys: Vec<K> = (0..5).map(|_| sm.insert(())).collect();
        let mut q = QualityQueue::new();
        for (i, &k) in keys.iter().enumerate() {
            q.push(k, i as f64 / 10.0);
        }
        q.push(keys[4], 0.01); // now the worst
        q.remove(keys[0]);
        assert_eq!(q.len(), 4);
        assert_eq!(q.pop(), Some((keys[4], 0.01)));
        assert_eq!(q.pop(), Some((keys[1], 0.1)));
        assert_eq!(q.peek(), Some((keys[2], 0.2)));
        assert_eq!(q.pop(), Some((keys[2], 0.2)));
        assert_eq!(q.pop(), Some((keys[3], 0.3)));
        assert_eq!(q.pop(), None);
        assert!(q.is_empty());
    }
}
