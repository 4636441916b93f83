//! Disjoint sets over 0..n (union-find with path halving; the smaller root wins a union, so
//! the result does not depend on anything but the order of the unions).

/// Disjoint sets over 0..n.
#[derive(Clone, Debug)]
pub struct DisjointSets {
    up: Vec<usize>,
}

impl DisjointSets {
    /// n singletons.
    pub fn new(n: usize) -> Self {
        DisjointSets { up: (0..n).collect() }
    }

    /// The representative of `i`'s set (the smallest member ever made root).
    pub fn root(&mut self, mut i: usize) -> usize {
        while self.up[i] != i {
            self.up[i] = self.up[self.up[i]];
            i = self.up[i];
        }
        i
    }

    /// Joins the sets of `a` and `b`; returns whether they were apart.
    pub fn join(&mut self, a: usize, b: usize) -> bool {
        let (x, y) = (self.root(a), self.root(b));
        if x == y {
            return false;
        }
        self.up[x.max(y)] = x.min(y);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joins_and_roots() {
        let mut s = DisjointSets::new(6);
        assert!(s.join(4, 2));
        assert!(s.join(2, 5));
        assert!(!s.join(5, 4));
        assert!(s.join(0, 1));
        assert_eq!(s.root(5), 2);
        assert_eq!(s.root(1), 0);
        assert_ne!(s.root(3), s.root(2));
        assert_eq!((0..6).filter(|&i| s.root(i) == i).count(), 3);
    }
}
