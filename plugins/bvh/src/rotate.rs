//! Tree rotations (Kensler 2008): swap a node's child with a grandchild on the other side when that
//! shrinks the one box the swap changes. Cheap local updates applied along an insertion's path.

use crate::Bvh;
use crate::node::NONE;

impl Bvh {
    /// Tries the best rotation at every inner node from `i` up to the root. Every box on that path
    /// may just have grown (an insertion), so every node on it is a candidate, not only the ones
    /// whose box changed.
    pub(crate) fn rotate_upwards(&mut self, mut i: u32) {
        while i != NONE {
            self.rotate_at(i);
            i = self.inner[i as usize].parent;
        }
    }

    /// Applies the rotation at inner node `a` that lowers the total area the most, if any does.
    /// `a`'s own box never changes: only the child that receives a grandchild gets a new box.
    fn rotate_at(&mut self, a: u32) {
        let [b, c] = self.inner[a as usize].children;
        // (gain, side that keeps its box, grandchild slot to swap)
        let mut best = (0.0f32, 0usize, 0usize);
        for (side, (stay, other)) in [(b, c), (c, b)].into_iter().enumerate() {
            // Swap `stay` with one of `other`'s children.
            if !other.is_inner() {
                continue;
            }
            let on = &self.inner[other.index() as usize];
            let s_other = on.aabb.area();
            let bs = self.aabb(stay);
            for slot in 0..2 {
                let keep = on.children[1 - slot];
                let gain = s_other - bs.union_area(&self.aabb(keep));
                if gain > best.0 {
                    best = (gain, side, slot);
                }
            }
        }
        let (gain, side, slot) = best;
        if gain <= 0.0 {
            return;
        }
        let stay = [b, c][side];
        let other = [b, c][1 - side];
        let o = other.index();
        let moved = self.inner[o as usize].children[slot];
        // `moved` goes up to `a` in `stay`'s place; `stay` goes down into `other`.
        self.inner[a as usize].children[side] = moved;
        self.set_parent(moved, a);
        self.inner[o as usize].children[slot] = stay;
        self.set_parent(stay, o);
        let [x, y] = self.inner[o as usize].children;
        let aabb = self.aabb(x).union(&self.aabb(y));
        self.area_acc += aabb.area() as f64 - self.inner[o as usize].aabb.area() as f64;
        self.inner[o as usize].aabb = aabb;
        self.changes.mark_inner(a);
        self.changes.mark_inner(o);
    }
}
