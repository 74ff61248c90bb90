//! Union-find over triangle indices that also keeps, per triangle, a parity bit to its root: the
//! surface components join with parity ignored, the sheets with the relative winding of two
//! triangles. The smaller root wins every join, so roots (and parities) depend only on the order
//! of the joins, never on the thread count.

/// Union-find with a parity bit per node (to its parent; to the root once found).
#[derive(Debug)]
pub(super) struct ParityForest {
    parent: Vec<u32>,
    odd: Vec<bool>,
}

impl ParityForest {
    /// `n` singletons, each its own root with parity 0.
    pub(super) fn new(n: usize) -> ParityForest {
        ParityForest { parent: (0..n as u32).collect(), odd: vec![false; n] }
    }

    /// Root of `x` and the parity of `x` to it; points the path at the root.
    pub(super) fn find(&mut self, x: u32) -> (u32, bool) {
        let (mut r, mut odd) = (x, false);
        while self.parent[r as usize] != r {
            odd ^= self.odd[r as usize];
            r = self.parent[r as usize];
        }
        // Again from `x`: each node's parity to the root is its parity to its old parent and on.
        let (mut v, mut to_root) = (x, odd);
        while self.parent[v as usize] != v {
            let next = self.parent[v as usize];
            let next_to_root = to_root ^ self.odd[v as usize];
            self.parent[v as usize] = r;
            self.odd[v as usize] = to_root;
            (v, to_root) = (next, next_to_root);
        }
        (r, odd)
    }

    /// Join the sets of `a` and `b`, recording that their parities differ (`against`) or agree,
    /// unless they are joined already (then the relation found first stands). The smaller root
    /// becomes the root.
    pub(super) fn join(&mut self, a: u32, b: u32, against: bool) {
        let ((ra, pa), (rb, pb)) = (self.find(a), self.find(b));
        if ra == rb {
            return;
        }
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        self.parent[hi as usize] = lo;
        self.odd[hi as usize] = pa ^ pb ^ against;
    }
}
