//! The one union–find of the workspace (mesh welding, topology, the builder's components).

/// Disjoint sets over `0..n` with path halving. The root of a set is always its **smallest**
/// element, so roots, and the labels of [`UnionFind::labels_into`], do not depend on the order
/// of the unions: the builder's octrees stay identical whatever order its edges come in.
///
/// ```
/// use sdfmo_mesh::UnionFind;
/// let mut uf = UnionFind::new(5);
/// assert!(uf.union(3, 1));
/// assert!(uf.union(4, 3));
/// assert!(!uf.union(1, 4));
/// assert_eq!(uf.find(4), 1);
/// let mut labels = Vec::new();
/// assert_eq!(uf.labels_into(&mut labels), 3);
/// assert_eq!(labels, [0, 1, 2, 1, 1]);
/// ```
#[derive(Clone, Debug, Default)]
pub struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    /// `n` singletons.
    pub fn new(n: usize) -> UnionFind {
        let mut uf = UnionFind::default();
        uf.reset(n);
        uf
    }

    /// Back to `n` singletons, keeping the allocation (for scratch use in a loop).
    pub fn reset(&mut self, n: usize) {
        self.parent.clear();
        self.parent.extend(0..n as u32);
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.parent.len()
    }

    /// True when there are no elements.
    pub fn is_empty(&self) -> bool {
        self.parent.is_empty()
    }

    /// The root (smallest element) of `x`'s set.
    #[inline]
    pub fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let grandparent = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = grandparent;
            x = grandparent;
        }
        x
    }

    /// Joins the sets of `a` and `b`; false when they were one set already.
    #[inline]
    pub fn union(&mut self, a: u32, b: u32) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        let (root, other) = if ra < rb { (ra, rb) } else { (rb, ra) };
        self.parent[other as usize] = root;
        true
    }

    /// Labels every element with its set's number, sets numbered `0, 1, …` in order of their
    /// smallest element, into `labels` (cleared first); returns the number of sets.
    pub fn labels_into(&mut self, labels: &mut Vec<u32>) -> usize {
        let n = self.len();
        labels.clear();
        labels.resize(n, u32::MAX);
        let mut count = 0u32;
        for x in 0..n as u32 {
            // The root is the smallest element, so it was labelled before any other member.
            let r = self.find(x) as usize;
            if labels[r] == u32::MAX {
                labels[r] = count;
                count += 1;
            }
            labels[x as usize] = labels[r];
        }
        count as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_do_not_depend_on_the_union_order() {
        let pairs = [(5u32, 2u32), (2, 7), (0, 9), (9, 3), (7, 1)];
        let mut reference = Vec::new();
        let mut uf = UnionFind::new(10);
        for &(a, b) in &pairs {
            uf.union(a, b);
        }
        let count = uf.labels_into(&mut reference);
        assert_eq!(count, 5);
        assert_eq!(reference, [0, 1, 1, 0, 2, 1, 3, 1, 4, 0]);
        // Every rotation and reversal of the same unions gives the same labels and roots.
        for shift in 0..pairs.len() {
            for reverse in [false, true] {
                let mut order: Vec<_> =
                    pairs.iter().cycle().skip(shift).take(pairs.len()).collect();
                if reverse {
                    order.reverse();
                }
                uf.reset(10);
                for &&(a, b) in &order {
                    uf.union(b, a);
                }
                let mut labels = Vec::new();
                assert_eq!(uf.labels_into(&mut labels), count);
                assert_eq!(labels, reference);
                assert_eq!(uf.find(7), 1, "the smallest element is the root");
            }
        }
    }
}
