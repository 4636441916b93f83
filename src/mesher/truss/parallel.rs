//! Deterministic parallel sums and marks cleared in O(1), for the force loops' hot paths.

use rayon::prelude::*;

/// Chunk size of the deterministic parallel loops: the same partial sums for any thread count.
pub(crate) const CHUNK: usize = 4096;

/// Deterministic parallel sum of pairs: fixed chunks of [`CHUNK`], partial sums added in order
/// (the same result bit for bit for any thread count).
pub(crate) fn det_sum(n: usize, f: impl Fn(usize) -> (f64, f64) + Sync) -> (f64, f64) {
    let parts: Vec<(f64, f64)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut s = (0.0, 0.0);
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let (a, b) = f(i);
                s.0 += a;
                s.1 += b;
            }
            s
        })
        .collect();
    parts.iter().fold((0.0, 0.0), |acc, s| (acc.0 + s.0, acc.1 + s.1))
}

/// Membership marks over `0..n` that are cleared in O(1): a generation counter.
#[derive(Default)]
pub(crate) struct Marks {
    stamp: Vec<u32>,
    now: u32,
}

impl Marks {
    /// Forgets every mark; makes room for `n` items.
    pub(crate) fn reset(&mut self, n: usize) {
        if self.stamp.len() != n || self.now == u32::MAX {
            self.stamp = vec![0; n];
            self.now = 0;
        }
        self.now += 1;
    }
    /// Marks i; true when it was not marked yet.
    pub(crate) fn mark(&mut self, i: u32) -> bool {
        let s = &mut self.stamp[i as usize];
        let fresh = *s != self.now;
        *s = self.now;
        fresh
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn det_sum_adds_every_term() {
        let (a, b) = det_sum(3 * CHUNK + 7, |i| (i as f64, 1.0));
        let n = (3 * CHUNK + 7) as f64;
        assert_eq!(b, n);
        assert_eq!(a, n * (n - 1.0) / 2.0);
    }

    #[test]
    fn marks_clear_between_generations() {
        let mut m = Marks::default();
        m.reset(4);
        assert!(m.mark(2));
        assert!(!m.mark(2));
        m.reset(4);
        assert!(m.mark(2));
    }
}
