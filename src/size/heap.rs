//! A binary min-heap of node indices with back pointers, so that a node's key can be decreased
//! in place (the seed's "min-heap with back pointers", Algorithm 4-2).

const NONE: u32 = u32::MAX;

/// Min-heap of `(key, node)` with `pos[node]` giving the node's slot.
pub(crate) struct IndexedHeap {
    slots: Vec<(f64, u32)>,
    pos: Vec<u32>,
}

impl IndexedHeap {
    /// An empty heap for nodes `0..n`.
    pub fn new(n: usize) -> Self {
        assert!(n < NONE as usize, "too many nodes for the heap");
        IndexedHeap { slots: Vec::new(), pos: vec![NONE; n] }
    }

    /// A heap holding every node `i` with `keys[i] < below` (O(n) heapify).
    pub fn from_keys(keys: &[f64], below: f64) -> Self {
        let mut h = IndexedHeap::new(keys.len());
        h.slots = keys.iter().enumerate().filter(|(_, k)| **k < below).map(|(i, &k)| (k, i as u32)).collect();
        for (s, &(_, i)) in h.slots.iter().enumerate() {
            h.pos[i as usize] = s as u32;
        }
        for s in (0..h.slots.len() / 2).rev() {
            h.down(s);
        }
        h
    }

    /// Inserts `node` with `key`, or lowers its key if already present and larger.
    pub fn push_or_decrease(&mut self, node: usize, key: f64) {
        let p = self.pos[node];
        if p == NONE {
            self.slots.push((key, node as u32));
            let s = self.slots.len() - 1;
            self.pos[node] = s as u32;
            self.up(s);
        } else if key < self.slots[p as usize].0 {
            self.slots[p as usize].0 = key;
            self.up(p as usize);
        }
    }

    /// Removes and returns the node with the smallest key.
    pub fn pop(&mut self) -> Option<(usize, f64)> {
        let last = self.slots.len().checked_sub(1)?;
        self.slots.swap(0, last);
        let (k, i) = self.slots.pop().unwrap();
        self.pos[i as usize] = NONE;
        if !self.slots.is_empty() {
            self.pos[self.slots[0].1 as usize] = 0;
            self.down(0);
        }
        Some((i as usize, k))
    }

    fn up(&mut self, mut s: usize) {
        let item = self.slots[s];
        while s > 0 {
            let parent = (s - 1) / 2;
            let pi = self.slots[parent];
            if pi.0 <= item.0 {
                break;
            }
            self.slots[s] = pi;
            self.pos[pi.1 as usize] = s as u32;
            s = parent;
        }
        self.slots[s] = item;
        self.pos[item.1 as usize] = s as u32;
    }

    fn down(&mut self, mut s: usize) {
        let n = self.slots.len();
        let item = self.slots[s];
        loop {
            let mut c = 2 * s + 1;
            if c >= n {
                break;
            }
            if c + 1 < n && self.slots[c + 1].0 < self.slots[c].0 {
                c += 1;
            }
            let ci = self.slots[c];
            if ci.0 >= item.0 {
                break;
            }
            self.slots[s] = ci;
            self.pos[ci.1 as usize] = s as u32;
            s = c;
        }
        self.slots[s] = item;
        self.pos[item.1 as usize] = s as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_heap_sorts_with_decrease_key() {
        let keys = [5.0, 3.0, f64::INFINITY, 8.0, 1.0, 7.0];
        let mut h = IndexedHeap::from_keys(&keys, f64::INFINITY);
        h.push_or_decrease(3, 2.0);
        h.push_or_decrease(2, 4.0);
        h.push_or_decrease(5, 9.0); // not a decrease: ignored
        let mut out = vec![];
        while let Some((i, k)) = h.pop() {
            out.push((i, k));
        }
        assert_eq!(out, vec![(4, 1.0), (3, 2.0), (1, 3.0), (2, 4.0), (0, 5.0), (5, 7.0)]);
    }
}
