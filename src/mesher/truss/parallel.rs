//! Deterministic parallel sums and membership flags, for the force loops' hot paths.

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

/// Membership flags over `0..n`, read back in index order ([`Flags::set_indices`]): a set
/// of nodes in an order that does not depend on how it was gathered.
#[derive(Default)]
pub(crate) struct Flags(Vec<bool>);

impl Flags {
    /// Makes room for `n` items, all clear (a new size clears; otherwise they must be clear).
    pub(crate) fn fit(&mut self, n: usize) {
        if self.0.len() != n {
            self.0 = vec![false; n];
        }
    }
    pub(crate) fn set(&mut self, i: u32) {
        self.0[i as usize] = true;
    }
    pub(crate) fn get(&self, i: u32) -> bool {
        self.0[i as usize]
    }
    /// The set items, in increasing order (eight flags at a time: most are clear).
    pub(crate) fn set_indices(&self) -> Vec<u32> {
        let mut out = Vec::new();
        for (c, w) in self.0.chunks(8).enumerate() {
            if w.iter().any(|&f| f) {
                out.extend(w.iter().enumerate().filter(|x| *x.1).map(|(k, _)| (8 * c + k) as u32));
            }
        }
        out
    }
    /// Clears the items `set` (all that are set).
    pub(crate) fn clear(&mut self, set: &[u32]) {
        for &i in set {
            self.0[i as usize] = false;
        }
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
    fn flags_read_back_in_order_and_clear() {
        let mut f = Flags::default();
        f.fit(3 * CHUNK);
        for i in (0..3 * CHUNK as u32).rev().filter(|i| i % 7 == 3) {
            f.set(i);
        }
        let set = f.set_indices();
        assert_eq!(set, (0..3 * CHUNK as u32).filter(|i| i % 7 == 3).collect::<Vec<_>>());
        f.clear(&set);
        assert!(f.set_indices().is_empty());
    }
}
