//! Best-first branch-and-bound search for the sibling that minimises the SAH cost increase
//! (Bittner et al. 2013, as summarised in the paper's section 4.2).

use crate::aabb::LaneBox;
use crate::node::{NONE, NodeKind, NodeRef};
use crate::{Aabb, Bvh};

/// Reusable priority queue, so a search allocates nothing once warmed up.
#[derive(Clone, Default)]
pub struct SearchScratch {
    heap: Vec<(f32, NodeRef)>,
}

impl SearchScratch {
    /// Smallest key in the queue, or infinity when it is empty.
    #[inline]
    fn min_key(&self) -> f32 {
        self.heap.first().map_or(f32::INFINITY, |e| e.0)
    }

    /// Sifts with a hole instead of swaps: one write per level instead of two.
    #[inline]
    fn push(&mut self, cost: f32, node: NodeRef) {
        let mut i = self.heap.len();
        self.heap.push((cost, node));
        while i > 0 {
            let p = (i - 1) / 2;
            if self.heap[p].0 <= cost {
                break;
            }
            self.heap[i] = self.heap[p];
            i = p;
        }
        self.heap[i] = (cost, node);
    }

    #[inline]
    fn pop(&mut self) -> Option<(f32, NodeRef)> {
        let last = self.heap.pop()?;
        if self.heap.is_empty() {
            return Some(last);
        }
        Some(self.replace_top(last))
    }

    /// Takes the head out and puts `e` in, in one sift down: `e` must not be smaller than the
    /// head, and the queue must not be empty.
    #[inline]
    fn replace_top(&mut self, e: (f32, NodeRef)) -> (f32, NodeRef) {
        let n = self.heap.len();
        let top = self.heap[0];
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
            if e.0 <= self.heap[c].0 {
                break;
            }
            self.heap[i] = self.heap[c];
            i = c;
        }
        self.heap[i] = e;
        top
    }
}

impl Bvh {
    /// The node whose becoming the sibling of a node with box `l` increases the tree's total inner
    /// surface area the least. Exact with respect to the current tree. The tree must not be empty.
    pub fn find_best_sibling(&self, l: &Aabb, scratch: &mut SearchScratch) -> NodeRef {
        // The root is a candidate like any other, and the one every search may fall back on.
        self.find_best_sibling_from(l, self.root, scratch)
    }

    /// [`Bvh::find_best_sibling`] seeded with a candidate: `hint` (a node of the tree) is returned
    /// unless some node is strictly better. A re-insertion passes the position it came from, so
    /// the search only expands subtrees that could beat it instead of every subtree that could
    /// beat the root, and a node with nowhere better to go stays where it was.
    pub(crate) fn find_best_sibling_from(
        &self,
        l: &Aabb,
        hint: NodeRef,
        scratch: &mut SearchScratch,
    ) -> NodeRef {
        let q = LaneBox::new(l);
        let mut best = hint;
        let mut c_best = self.aabb(hint).union_area(l);
        let mut a = self.parent(hint);
        while a != NONE {
            let n = &self.inner[a as usize];
            let (u, s) = q.union_area_and_area(&n.aabb);
            c_best += u - s;
            a = n.parent;
        }
        let s_l = l.area();
        let root = self.root;
        if !root.is_inner() {
            return best;
        }
        let root_box = self.inner[root.index() as usize].aabb;
        scratch.heap.clear();
        // The queue holds inner nodes whose own cost is already counted, keyed by the cost they
        // induce on their children. Children are costed when their parent is expanded, not when
        // they are popped: a leaf never enters the queue, a good child lowers `c_best` before its
        // siblings are considered, and each box is read once.
        let c_root = root_box.union_area(l) - root_box.area();
        let mut next = (c_root + s_l < c_best).then_some((c_root, root));
        while let Some((c_i, x)) = next {
            if c_i + s_l >= c_best {
                break;
            }
            // The cheaper child worth expanding, held back from the queue: a child's key is at
            // least its parent's, so the search mostly walks down, and a child no dearer than
            // the queue's head is expanded next without a round trip through the heap.
            let mut held: Option<(f32, NodeRef)> = None;
            // Written out for each child: a loop over the two cost as much as a box test.
            macro_rules! visit {
                ($child:expr) => {
                    let child: NodeRef = $child;
                    if child.kind() != NodeKind::Inner {
                        let c = c_i + q.union_area(&self.aabb(child));
                        if c < c_best {
                            best = child;
                            c_best = c;
                        }
                    } else {
                        let (u, a) =
                            q.union_area_and_area(&self.inner[child.index() as usize].aabb);
                        let c = c_i + u;
                        if c < c_best {
                            best = child;
                            c_best = c;
                        }
                        let c_child = c - a;
                        if c_child + s_l < c_best {
                            match held {
                                Some(h) if h.0 <= c_child => scratch.push(c_child, child),
                                Some(h) => {
                                    scratch.push(h.0, h.1);
                                    held = Some((c_child, child));
                                }
                                None => held = Some((c_child, child)),
                            }
                        }
                    }
                };
            }
            let [left, right] = self.inner[x.index() as usize].children;
            visit!(left);
            visit!(right);
            next = match held {
                Some(h) if h.0 <= scratch.min_key() => Some(h),
                Some(h) => Some(scratch.replace_top(h)),
                None => scratch.pop(),
            };
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

    /// The induced cost of `x` becoming the sibling of a node with box `l`, summed in f64 from `x`
    /// up: the reference the searches are checked against.
    fn induced_cost(bvh: &Bvh, x: NodeRef, l: &Aabb) -> f64 {
        let mut c = bvh.aabb(x).union_area(l) as f64;
        let mut a = bvh.parent(x);
        while a != NONE {
            let b = bvh.inner[a as usize].aabb;
            c += b.union_area(l) as f64 - b.area() as f64;
            a = bvh.inner[a as usize].parent;
        }
        c
    }

    #[test]
    fn searches_find_the_cheapest_sibling_of_all_nodes() {
        use crate::{BvhConfig, Triangle};
        use glam::Vec3;
        let mut rnd = crate::test_random(0x5851_f42d_4c95_7f2d);
        let mut v = || Vec3::new(rnd(), rnd(), rnd());
        let tris: Vec<Triangle> = (0..400)
            .map(|_| {
                let c = v() * 30.0;
                Triangle::new(c, c + v() * 2.0, c + v() * 2.0)
            })
            .collect();
        let mut bvh = Bvh::new(BvhConfig::incr_u());
        bvh.insert_triangles(&tris).unwrap();
        let mut inner = Vec::new();
        bvh.collect_inner(bvh.root, &mut inner);
        let mut nodes: Vec<NodeRef> = inner.iter().map(|&i| NodeRef::inner(i)).collect();
        nodes.extend((0..tris.len() as u32).map(NodeRef::leaf));
        let mut scratch = SearchScratch::default();
        for q in 0..300 {
            // Boxes from a triangle's size to a tenth of the scene, anywhere in it.
            let lo = v() * 32.0;
            let l = Aabb::new(lo, lo + v() * (0.5 + (q % 4) as f32 * 1.5));
            let best = nodes
                .iter()
                .map(|&x| induced_cost(&bvh, x, &l))
                .fold(f64::INFINITY, f64::min);
            let tolerance = 1e-5 * best.max(1.0);
            let found = bvh.find_best_sibling(&l, &mut scratch);
            assert!(
                induced_cost(&bvh, found, &l) <= best + tolerance,
                "query {q}"
            );
            let hint = nodes[(v().x * nodes.len() as f32) as usize % nodes.len()];
            let seeded = bvh.find_best_sibling_from(&l, hint, &mut scratch);
            assert!(
                induced_cost(&bvh, seeded, &l) <= best + tolerance,
                "seeded query {q}"
            );
        }
        // Seeded with the cheapest node, the search keeps it.
        let l = tris[7].aabb();
        let cheapest = *nodes
            .iter()
            .min_by(|a, b| induced_cost(&bvh, **a, &l).total_cmp(&induced_cost(&bvh, **b, &l)))
            .unwrap();
        let c = induced_cost(&bvh, cheapest, &l);
        let seeded = bvh.find_best_sibling_from(&l, cheapest, &mut scratch);
        assert!(induced_cost(&bvh, seeded, &l) <= c + 1e-5 * c);
    }

    #[test]
    fn interleaved_pushes_pops_and_replacements_keep_the_order() {
        let mut rnd = crate::test_random(0x9e37_79b9_7f4a_7c15);
        let mut s = SearchScratch::default();
        let mut model: Vec<f32> = Vec::new();
        for step in 0..5000u32 {
            let c = (rnd() * 100.0).floor();
            match step % 3 {
                0 | 1 => {
                    s.push(c, NodeRef::inner(step));
                    model.push(c);
                }
                _ if !model.is_empty() && c >= s.min_key() => {
                    let (got, _) = s.replace_top((c, NodeRef::inner(step)));
                    let k = model.iter().copied().fold(f32::INFINITY, f32::min);
                    assert_eq!(got, k);
                    let at = model.iter().position(|&m| m == k).unwrap();
                    model[at] = c;
                }
                _ => {
                    let got = s.pop().map(|e| e.0);
                    let k = model.iter().copied().reduce(f32::min);
                    assert_eq!(got, k);
                    if let Some(k) = k {
                        let at = model.iter().position(|&m| m == k).unwrap();
                        model.swap_remove(at);
                    }
                }
            }
            assert_eq!(
                s.min_key(),
                model.iter().copied().fold(f32::INFINITY, f32::min)
            );
        }
    }
}
