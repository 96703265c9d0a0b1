//! Treelet restructuring (Karras and Aila 2013): take a node and the few largest nodes below it as
//! a treelet of up to `MAX_TREELET` subtrees, find the topology over those subtrees with the least
//! total inner area by dynamic programming over subsets, and rebuild the treelet that way if it is
//! cheaper. The subtrees below are not touched, so the move is local and exact.

use crate::Bvh;
use crate::tree::bvh::AreaSum;
use crate::tree::node::NodeRef;
use crate::tree::scratch::{MAX_TREELET, TreeletScratch};

impl TreeletScratch {
    /// The part holding the lowest bit of the best split of `mask`: the first partition whose sum
    /// is the least one the dynamic programme kept. The same sum of the same two floats, so the
    /// comparison is exact.
    fn split_of(&self, mask: usize) -> usize {
        let low = mask & mask.wrapping_neg();
        let others = mask ^ low;
        let mut sub = (others - 1) & others;
        loop {
            let p = sub | low;
            if self.cost[p] + self.cost[mask ^ p] == self.best_sum[mask] || sub == 0 {
                return p;
            }
            sub = (sub - 1) & others;
        }
    }
}

impl Bvh {
    /// Restructures the treelet of up to `size` subtrees rooted at inner node `r` optimally.
    /// Returns whether the tree changed.
    pub(crate) fn optimize_treelet(&mut self, r: u32, size: usize, s: &mut TreeletScratch) -> bool {
        let size = size.clamp(3, MAX_TREELET);
        // Gather: start from r's children, repeatedly open the largest inner subtree.
        let mut n = 2;
        s.leaves[0] = self.inner[r as usize].children[0];
        s.leaves[1] = self.inner[r as usize].children[1];
        s.internal[0] = r;
        let mut m = 1;
        let mut old_cost = self.inner[r as usize].aabb.area();
        while n < size {
            let mut pick = usize::MAX;
            let mut pick_area = -1.0f32;
            for k in 0..n {
                if s.leaves[k].is_inner() {
                    let a = self.inner[s.leaves[k].index() as usize].aabb.area();
                    if a > pick_area {
                        pick_area = a;
                        pick = k;
                    }
                }
            }
            if pick == usize::MAX {
                break;
            }
            let node = s.leaves[pick].index();
            let [a, b] = self.inner[node as usize].children;
            s.internal[m] = node;
            m += 1;
            old_cost += pick_area;
            s.leaves[pick] = a;
            s.leaves[n] = b;
            n += 1;
        }
        if n < 3 {
            return false;
        }
        for k in 0..n {
            s.leaf_box[k] = self.aabb(s.leaves[k]);
        }
        let full = (1usize << n) - 1;
        for mask in 1..=full {
            let low = mask.trailing_zeros() as usize;
            let rest = mask & (mask - 1);
            s.bounds[mask] = if rest == 0 {
                s.leaf_box[low]
            } else {
                s.bounds[rest].union(&s.leaf_box[low])
            };
            s.area[mask] = s.bounds[mask].area();
        }
        for mask in 1..=full {
            if mask & (mask - 1) == 0 {
                s.cost[mask] = 0.0;
                continue;
            }
            // Partitions (p, mask ^ p) with p holding the lowest bit, each pair once; `sub`
            // starts below `others` so that p never is the whole mask. Only the least sum is
            // kept: the few splits the rebuild uses are found again from it, which keeps this
            // loop (3^n / 2 steps) free of the argmin's branches.
            let low = mask & mask.wrapping_neg();
            let others = mask ^ low;
            // Two running minima, because one was bound by the latency of its compare.
            let mut best = [f32::INFINITY; 2];
            let mut sub = (others - 1) & others;
            'parts: loop {
                for b in &mut best {
                    let p = sub | low;
                    let c = s.cost[p] + s.cost[mask ^ p];
                    *b = if c < *b { c } else { *b };
                    if sub == 0 {
                        break 'parts;
                    }
                    sub = (sub - 1) & others;
                }
            }
            let best = best[0].min(best[1]);
            s.best_sum[mask] = best;
            s.cost[mask] = best + s.area[mask];
        }
        // Rounding in the sums must not trigger an endless sequence of equal-cost rebuilds.
        if s.cost[full] >= old_cost * (1.0 - 1e-6) {
            return false;
        }
        // Rebuild top-down, reusing the treelet's inner nodes (r stays at the top).
        let mut next_internal = 1;
        let mut sp = 0;
        s.stack[sp] = (full as u16, r);
        sp += 1;
        while sp > 0 {
            sp -= 1;
            let (mask, node) = s.stack[sp];
            let left = s.split_of(mask as usize);
            let right = mask as usize ^ left;
            let mut kids = [NodeRef::NONE; 2];
            for (slot, part) in [left, right].into_iter().enumerate() {
                kids[slot] = if part & (part - 1) == 0 {
                    s.leaves[part.trailing_zeros() as usize]
                } else {
                    let id = s.internal[next_internal];
                    next_internal += 1;
                    s.stack[sp] = (part as u16, id);
                    sp += 1;
                    NodeRef::inner(id)
                };
            }
            let aabb = s.bounds[mask as usize];
            self.write_inner(node, AreaSum::Change, |n| {
                n.aabb = aabb;
                n.children = kids;
            });
            self.set_parent(kids[0], node);
            self.set_parent(kids[1], node);
        }
        debug_assert_eq!(next_internal, m);
        true
    }

    /// Restructures the treelet at every inner node of the global tree, children before parents
    /// (a parent's treelet then gathers subtrees that are already good). Returns how many changed.
    pub(crate) fn treelet_pass(&mut self, size: usize) -> u32 {
        self.treelet_walk(size, f32::NEG_INFINITY)
    }

    /// [`Bvh::treelet_pass`] restricted to the inner nodes of the global tree whose box has at
    /// least `min_area` times the root's area. A treelet can gain at most its inner nodes' area,
    /// so the few large nodes near the top hold most of what restructuring gains, and there
    /// large treelets pay; the many small ones below are left to cheaper moves. Returns how many
    /// treelets changed.
    pub(crate) fn treelet_pass_above(&mut self, size: usize, min_area: f32) -> u32 {
        if !self.root.is_inner() {
            return 0;
        }
        let floor = min_area * self.inner[self.root.index() as usize].aabb.area();
        if self.has_live_instances() {
            return self.treelet_walk(size, floor);
        }
        // Without instances every live slot with a parent, and the root, is in the global tree:
        // a scan of the flat array, with no list of nodes to build. A restructured treelet keeps
        // its slots, so the scan's order only decides which treelet goes first.
        let root = self.root.index();
        self.with_treelet_scratch(|bvh, s| {
            let mut changed = 0;
            for i in 0..bvh.inner.len() as u32 {
                let n = &bvh.inner[i as usize];
                if (n.has_parent() || i == root) && n.aabb.area() >= floor {
                    changed += bvh.optimize_treelet(i, size, s) as u32;
                }
            }
            changed
        })
    }

    /// Runs `f` with the treelet tables, made on the first call and kept for the next ones (they
    /// are taken out of the tree while `f` has it mutably).
    pub(crate) fn with_treelet_scratch<R>(
        &mut self,
        f: impl FnOnce(&mut Self, &mut TreeletScratch) -> R,
    ) -> R {
        let mut s = self.scratch.treelet.take().unwrap_or_default();
        let r = f(self, &mut s);
        self.scratch.treelet = Some(s);
        r
    }

    /// Treelets at the inner nodes of the global tree whose box area is at least `floor`, found
    /// by a walk from the root (which stops at instances), children before parents.
    fn treelet_walk(&mut self, size: usize, floor: f32) -> u32 {
        let mut order = Vec::new();
        if self.root.is_inner() {
            self.collect_inner(self.root, &mut order);
        }
        self.with_treelet_scratch(|bvh, s| {
            let mut changed = 0;
            // collect_inner lists parents before children: reversed, children come first.
            for &i in order.iter().rev() {
                if bvh.inner[i as usize].aabb.area() >= floor {
                    changed += bvh.optimize_treelet(i, size, s) as u32;
                }
            }
            changed
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Aabb;
    use crate::{BvhConfig, Triangle};
    use glam::Vec3;

    /// A binary tree over leaf indices, for enumerating every topology by brute force.
    #[derive(Clone)]
    enum T {
        Leaf(usize),
        Pair(Box<T>, Box<T>),
    }

    /// Every full binary tree over leaves 0..n: leaf k joins as the sibling of each node of every
    /// tree over 0..k, which makes each of the (2n-3)!! topologies exactly once.
    fn all_trees(n: usize) -> Vec<T> {
        fn with_sibling(t: &T, k: usize, out: &mut Vec<T>) {
            out.push(T::Pair(Box::new(t.clone()), Box::new(T::Leaf(k))));
            if let T::Pair(a, b) = t {
                let mut sub = Vec::new();
                with_sibling(a, k, &mut sub);
                for x in sub.drain(..) {
                    out.push(T::Pair(Box::new(x), b.clone()));
                }
                with_sibling(b, k, &mut sub);
                for x in sub {
                    out.push(T::Pair(a.clone(), Box::new(x)));
                }
            }
        }
        let mut trees = vec![T::Leaf(0)];
        for k in 1..n {
            let mut next = Vec::new();
            for t in &trees {
                with_sibling(t, k, &mut next);
            }
            trees = next;
        }
        trees
    }

    /// Sum of the inner boxes' areas, and the box.
    fn cost(t: &T, boxes: &[Aabb]) -> (f32, Aabb) {
        match t {
            T::Leaf(k) => (0.0, boxes[*k]),
            T::Pair(a, b) => {
                let (ca, ba) = cost(a, boxes);
                let (cb, bb) = cost(b, boxes);
                let u = ba.union(&bb);
                (ca + cb + u.area(), u)
            }
        }
    }

    fn inner_area(bvh: &Bvh) -> f32 {
        (0..bvh.inner_capacity())
            .filter_map(|i| bvh.inner_node(i))
            .map(|n| n.aabb.area())
            .sum()
    }

    #[test]
    fn a_treelet_over_the_whole_tree_is_the_best_of_every_topology() {
        let mut rnd = crate::test_random(0x9e3779b97f4a7c15u64);
        assert_eq!(all_trees(5).len(), 105);
        for n in [3usize, 4, 5, 6, 7] {
            for _ in 0..4 {
                let tris: Vec<Triangle> = (0..n)
                    .map(|_| {
                        let c = Vec3::new(rnd(), rnd(), rnd()) * 10.0;
                        let s = 0.2 + rnd() * 3.0;
                        Triangle::new(
                            c,
                            c + Vec3::new(s, rnd(), 0.0),
                            c + Vec3::new(0.0, s, rnd()),
                        )
                    })
                    .collect();
                let boxes: Vec<Aabb> = tris.iter().map(|t| t.aabb()).collect();
                let best = all_trees(n)
                    .iter()
                    .map(|t| cost(t, &boxes).0)
                    .fold(f32::INFINITY, f32::min);
                let mut bvh = Bvh::new(BvhConfig::incr());
                bvh.insert_triangles(&tris).unwrap();
                let before = inner_area(&bvh);
                let acc_before = bvh.area_acc;
                let root = bvh.root().index();
                let mut s = Box::<TreeletScratch>::default();
                bvh.optimize_treelet(root, n, &mut s);
                bvh.validate().unwrap();
                let after = inner_area(&bvh);
                assert!(after <= before * (1.0 + 1e-5), "{before} -> {after}");
                assert!(
                    (after - best).abs() <= 1e-4 * best,
                    "{n} leaves: treelet gives {after}, the best topology {best}"
                );
                // Moves judge themselves by the running sum: it must follow the restructuring.
                let acc_delta = (bvh.area_acc - acc_before) as f32;
                assert!(
                    (acc_delta - (after - before)).abs() <= 1e-3 * before,
                    "the running area sum moved by {acc_delta}, the tree by {}",
                    after - before
                );
            }
        }
    }

    /// An IncrU tree over `n` scattered triangles of mixed sizes.
    fn soup_tree(n: usize, seed: u64) -> (Bvh, Vec<Triangle>) {
        let mut rnd = crate::test_random(seed);
        let tris: Vec<Triangle> = (0..n)
            .map(|_| {
                let c = Vec3::new(rnd(), rnd(), rnd()) * 40.0;
                let s = 0.1 + rnd() * rnd() * 6.0;
                Triangle::new(
                    c,
                    c + Vec3::new(s, rnd(), 0.0),
                    c + Vec3::new(0.0, s, rnd()),
                )
            })
            .collect();
        let mut bvh = Bvh::new(BvhConfig::incr_u());
        bvh.insert_triangles(&tris).unwrap();
        (bvh, tris)
    }

    #[test]
    fn sweeps_over_large_nodes_gain_and_leave_the_rest_to_other_moves() {
        let (bvh, _) = soup_tree(2000, 0x2545_f491_4f6c_dd1d);
        let cost = bvh.sah_cost();
        // Above the root's own area nothing qualifies.
        let mut none = bvh.clone();
        assert_eq!(none.treelet_pass_above(8, 1.01), 0);
        assert_eq!(none.gpu_nodes(), bvh.gpu_nodes());
        // At the root's area only the root's treelet may change.
        let mut top = bvh.clone();
        assert!(top.treelet_pass_above(8, 1.0) <= 1);
        let mut large = bvh.clone();
        let mut every = bvh.clone();
        let (n_large, n_every) = (
            large.treelet_pass_above(6, 0.01),
            every.treelet_pass_above(6, 0.0),
        );
        for (name, t) in [("top", &top), ("large", &large), ("every", &every)] {
            t.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(t.sah_cost() <= cost * (1.0 + 1e-6), "{name}");
        }
        assert!(0 < n_large && n_large < n_every, "{n_large} of {n_every}");
        assert!(large.sah_cost() < cost && every.sah_cost() < large.sah_cost());
        // Moves judge themselves by the running sum: it must follow the sweep.
        let acc = (large.area_acc - bvh.area_acc) as f32;
        let real = inner_area(&large) - inner_area(&bvh);
        assert!(
            (acc - real).abs() <= 1e-3 * inner_area(&bvh),
            "{acc} against {real}"
        );
    }

    #[test]
    fn sweeps_leave_kept_whole_groups_as_they_are() {
        use glam::Affine3A;
        let (mut bvh, tris) = soup_tree(600, 0x9e37_79b9_7f4a_7c15);
        // A group as large as the scene, so its instance's box passes any area floor.
        let group: Vec<Triangle> = tris.iter().step_by(3).copied().collect();
        bvh.insert_group(&group, Affine3A::from_translation(Vec3::X), true)
            .unwrap();
        let inst = (0..bvh.instances.len() as u32)
            .find(|i| !bvh.inst_free.contains(i))
            .unwrap();
        let mut inside = Vec::new();
        bvh.collect_inner(bvh.instances[inst as usize].root, &mut inside);
        assert!(inside.len() > 100);
        let snapshot: Vec<_> = inside.iter().map(|&i| bvh.inner[i as usize]).collect();
        let cost = bvh.sah_cost();
        assert!(bvh.treelet_pass_above(6, 0.0) > 0);
        bvh.validate().unwrap();
        assert!(bvh.sah_cost() <= cost * (1.0 + 1e-6));
        for (&i, before) in inside.iter().zip(&snapshot) {
            let after = &bvh.inner[i as usize];
            assert_eq!(after.children, before.children, "node {i} of the group");
            assert_eq!(after.aabb, before.aabb, "node {i} of the group");
        }
    }
}
