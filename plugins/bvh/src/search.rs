//! Best-first branch-and-bound search for the sibling that minimises the SAH cost increase
//! (Bittner et al. 2013, as summarised in the paper's section 4.2).

use crate::node::{NodeKind, NodeRef};
use crate::{Aabb, Bvh};

/// Reusable priority queue, so a search allocates nothing once warmed up.
#[derive(Clone, Default)]
pub struct SearchScratch {
    heap: Vec<(f32, NodeRef)>,
}

impl SearchScratch {
    #[inline]
    fn push(&mut self, cost: f32, node: NodeRef) {
        self.heap.push((cost, node));
        let mut i = self.heap.len() - 1;
        while i > 0 {
            let p = (i - 1) / 2;
            if self.heap[p].0 <= self.heap[i].0 {
                break;
            }
            self.heap.swap(p, i);
            i = p;
        }
    }

    #[inline]
    fn pop(&mut self) -> Option<(f32, NodeRef)> {
        let last = self.heap.pop()?;
        if self.heap.is_empty() {
            return Some(last);
        }
        let top = std::mem::replace(&mut self.heap[0], last);
        let n = self.heap.len();
        let mut i = 0;
        loop {
            let l = 2 * i + 1;
            if l >= n {
                break;
            }
            let r = l + 1;
            let c = if r < n && self.heap[r].0 < self.heap[l].0 {
                r
            } else {
                l
            };
            if self.heap[i].0 <= self.heap[c].0 {
                break;
            }
            self.heap.swap(i, c);
            i = c;
        }
        Some(top)
    }
}

impl Bvh {
    /// The node whose becoming the sibling of a node with box `l` increases the tree's total inner
    /// surface area the least. Exact with respect to the current tree. The tree must not be empty.
    pub fn find_best_sibling(&self, l: &Aabb, scratch: &mut SearchScratch) -> NodeRef {
        let s_l = l.area();
        let root = self.root;
        let root_box = self.aabb(root);
        let mut best = root;
        let mut c_best = root_box.union_area(l);
        if !root.is_inner() {
            return best;
        }
        scratch.heap.clear();
        // The queue holds inner nodes whose own cost is already counted, keyed by the cost they
        // induce on their children. Children are costed when their parent is expanded, not when
        // they are popped: a leaf never enters the queue, a good child lowers `c_best` before its
        // siblings are considered, and each box is read once.
        let c_root = c_best - root_box.area();
        if c_root + s_l < c_best {
            scratch.push(c_root, root);
        }
        while let Some((c_i, x)) = scratch.pop() {
            if c_i + s_l >= c_best {
                break;
            }
            for child in self.inner[x.index() as usize].children {
                let (b, inner) = match child.kind() {
                    NodeKind::Inner => (self.inner[child.index() as usize].aabb, true),
                    _ => (self.aabb(child), false),
                };
                let c = c_i + b.union_area(l);
                if c < c_best {
                    best = child;
                    c_best = c;
                }
                if inner {
                    let c_child = c - b.area();
                    if c_child + s_l < c_best {
                        scratch.push(c_child, child);
                    }
                }
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heap_pops_in_order() {
        let mut s = SearchScratch::default();
        for (i, c) in [5.0, 1.0, 3.0, 0.5, 9.0, 2.0].into_iter().enumerate() {
            s.push(c, NodeRef::inner(i as u32));
        }
        let mut out = vec![];
        while let Some((c, _)) = s.pop() {
            out.push(c);
        }
        assert_eq!(out, vec![0.5, 1.0, 2.0, 3.0, 5.0, 9.0]);
    }
}
