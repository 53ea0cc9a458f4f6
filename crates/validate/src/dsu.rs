//! Union-find with path halving. Roots are linked smaller index over larger, so the structure
//! (and everything derived from it) is deterministic; one `u32` per element keeps it in cache.

pub(crate) struct Dsu {
    parent: Vec<u32>,
}

impl Dsu {
    pub(crate) fn new(n: usize) -> Self {
        Self { parent: (0..n as u32).collect() }
    }

    /// Makes it `n` singletons again, keeping the allocation.
    pub(crate) fn reset(&mut self, n: usize) {
        self.parent.clear();
        self.parent.extend(0..n as u32);
    }

    pub(crate) fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] as usize != x {
            let p = self.parent[x] as usize;
            self.parent[x] = self.parent[p];
            x = self.parent[x] as usize;
        }
        x
    }

    /// Joins `x`'s set to the set whose root is `root`, and returns the joined set's root.
    pub(crate) fn union_root(&mut self, root: usize, x: usize) -> usize {
        let rx = self.find(x);
        if rx == root {
            return root;
        }
        let (lo, hi) = (root.min(rx), root.max(rx));
        self.parent[hi] = lo as u32;
        lo
    }

    pub(crate) fn union(&mut self, a: usize, b: usize) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            let (lo, hi) = (a.min(b), a.max(b));
            self.parent[hi] = lo as u32;
        }
    }
}
