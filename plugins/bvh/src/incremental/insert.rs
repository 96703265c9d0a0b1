//! Sequential incremental construction: Incr and IncrU (section 4 of the paper).

use crate::tree::bvh::AreaSum;
use crate::tree::node::{InnerNode, NONE, NodeRef};
use crate::tree::triangle::validate_triangles;
use crate::{Aabb, Bvh, BvhError, Triangle};

/// R_coh(x, y) = S(x ∪ y) / (S(x) + S(y)): below R_max two primitives are worth inserting as a pair.
#[inline]
pub fn coherence(a: &Aabb, b: &Aabb) -> f32 {
    let sum = a.area() + b.area();
    if sum <= 0.0 {
        // Two degenerate (zero-area) boxes: coherent only if they coincide.
        return if a.union_area(b) <= 0.0 {
            0.0
        } else {
            f32::INFINITY
        };
    }
    a.union_area(b) / sum
}

impl Bvh {
    /// Inserts world-space triangles one by one (Incr, or IncrU when global updates are enabled),
    /// pairing coherent consecutive triangles when clustering is on. Returns the new triangle ids, in
    /// input order (`0..n` for a fresh tree).
    /// Rejects the whole batch, inserting nothing, if any vertex is NaN, infinite or absurdly large.
    pub fn insert_triangles(&mut self, tris: &[Triangle]) -> Result<Vec<u32>, BvhError> {
        validate_triangles(tris)?;
        self.check_room(tris.len())?;
        self.reserve(tris.len());
        let ids = self.alloc_triangles(tris);
        for item in self.cluster_items(&ids) {
            self.insert_item(item);
        }
        Ok(ids)
    }

    /// A detached inner node over two detached nodes.
    pub(crate) fn make_pair(&mut self, a: NodeRef, b: NodeRef) -> NodeRef {
        let n = self.alloc_inner();
        self.set_pair(n, a, b);
        NodeRef::inner(n)
    }

    /// Makes inner node `n` the detached parent of `a` and `b`.
    pub(crate) fn set_pair(&mut self, n: u32, a: NodeRef, b: NodeRef) {
        let node = InnerNode {
            aabb: self.aabb(a).union(&self.aabb(b)),
            children: [a, b],
            parent: NONE,
        };
        self.write_inner(n, AreaSum::Outside, |slot| *slot = node);
        self.set_parent(a, n);
        self.set_parent(b, n);
    }

    /// Inserts one detached item and runs a batch of global updates when the cache is full.
    pub(crate) fn insert_item(&mut self, item: NodeRef) {
        self.insert_item_near(item, NodeRef::NONE);
    }

    /// [`Bvh::insert_item`] with the search seeded by `hint` (ignored unless a node of the global
    /// tree).
    pub(crate) fn insert_item_near(&mut self, item: NodeRef, hint: NodeRef) {
        if item.is_inner() {
            self.record(item.index());
        }
        let seeded = !self.root.is_none()
            && !hint.is_none()
            && (!hint.is_inner() || self.in_global_tree(hint.index()));
        if seeded {
            let p = self.alloc_inner();
            self.insert_node_from(item, p, hint);
        } else {
            self.insert_node(item);
        }
        self.maybe_update();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coherence_of_neighbours_and_strangers() {
        let a = Aabb::new(glam::Vec3::ZERO, glam::Vec3::ONE);
        let b = Aabb::new(
            glam::Vec3::new(1.0, 0.0, 0.0),
            glam::Vec3::new(2.0, 1.0, 1.0),
        );
        let far = Aabb::new(glam::Vec3::splat(10.0), glam::Vec3::splat(11.0));
        assert!(coherence(&a, &b) < 1.5);
        assert!(coherence(&a, &far) > 1.5);
    }
}
