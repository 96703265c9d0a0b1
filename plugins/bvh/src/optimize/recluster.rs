//! Post-pass restarts: re-clustering the top of the tree over its small subtrees, and a snapshot of
//! the topology so that a restart which does not pay off can be taken back.
//!
//! Re-insertion and treelet moves stop in a local minimum whose top levels were shaped by the order
//! the triangles arrived in. Rebuilding only the levels above subtrees of a few triangles (binned SAH
//! over their boxes) puts the insertion-built clusters into a different arrangement, from which the
//! same moves often reach a lower minimum.

use crate::top_down::build_binned_parallel;
use crate::tree::bvh::AreaSum;
use crate::tree::node::{FREE, InnerNode, NONE, NodeKind, NodeRef};
use crate::{Aabb, Bvh};

/// Everything a topology change touches: node links and boxes, not triangles or groups.
pub(crate) struct TopologySnapshot {
    inner: Vec<InnerNode>,
    inner_free: Vec<u32>,
    tri_parent: Vec<u32>,
    instance_parent: Vec<u32>,
    root: NodeRef,
    area_acc: f64,
}

impl Bvh {
    pub(crate) fn topology_snapshot(&self) -> TopologySnapshot {
        TopologySnapshot {
            inner: self.inner.clone(),
            inner_free: self.inner_free.clone(),
            tri_parent: self.tri.parent.clone(),
            instance_parent: self.instances.iter().map(|i| i.parent).collect(),
            root: self.root,
            area_acc: self.area_acc,
        }
    }

    /// Puts the topology back as it was, marking every inner node that differs as changed.
    pub(crate) fn restore_topology(&mut self, s: TopologySnapshot) {
        // Moves reuse freed slots, so the arrays only ever grow between a snapshot and its restore;
        // slots added since become free again.
        for i in s.inner.len()..self.inner.len() {
            self.write_inner(i as u32, AreaSum::Outside, |n| {
                n.parent = FREE;
                n.children = [NodeRef::NONE; 2];
            });
        }
        let mut free = s.inner_free;
        free.extend(s.inner.len() as u32..self.inner.len() as u32);
        for (i, node) in s.inner.into_iter().enumerate() {
            let cur = &self.inner[i];
            if cur.children != node.children || cur.parent != node.parent || cur.aabb != node.aabb {
                self.write_inner(i as u32, AreaSum::Outside, |slot| *slot = node);
            }
        }
        self.inner_free = free;
        self.tri.parent = s.tri_parent;
        for (inst, p) in self.instances.iter_mut().zip(s.instance_parent) {
            inst.parent = p;
        }
        if self.root != s.root {
            self.changes.root_changed = true;
        }
        self.root = s.root;
        self.area_acc = s.area_acc;
    }

    /// Rebuilds the global tree above the subtrees of at most `cut` triangles (instances count as
    /// one) with binned SAH over their boxes, reusing the inner nodes it replaces. Returns the
    /// number of subtrees re-clustered.
    pub(crate) fn recluster_top(&mut self, cut: u32) -> usize {
        if !self.root.is_inner() {
            return 0;
        }
        let mut order = Vec::new();
        self.collect_inner(self.root, &mut order);
        // Triangles under each inner node, children before parents.
        let mut size = vec![0u32; self.inner.len()];
        let count = |size: &[u32], r: NodeRef| match r.kind() {
            NodeKind::Inner => size[r.index() as usize],
            _ => 1,
        };
        for &i in order.iter().rev() {
            let [a, b] = self.inner[i as usize].children;
            size[i as usize] = count(&size, a) + count(&size, b);
        }
        let mut cuts = Vec::new();
        let mut top = Vec::new();
        let mut stack = vec![self.root];
        while let Some(r) = stack.pop() {
            if r.is_inner() && size[r.index() as usize] > cut {
                top.push(r.index());
                stack.extend_from_slice(&self.inner[r.index() as usize].children);
            } else {
                cuts.push(r);
            }
        }
        let boxes: Vec<Aabb> = cuts.iter().map(|&c| self.aabb(c)).collect();
        let built = build_binned_parallel(&boxes);
        // A binary tree over the cut has one inner node fewer than the cut: exactly `top`.
        debug_assert_eq!(built.nodes.len(), top.len());
        let map = |r: NodeRef| match r.kind() {
            NodeKind::Inner => NodeRef::inner(top[r.index() as usize]),
            _ => cuts[r.index() as usize],
        };
        for (k, n) in built.nodes.iter().enumerate() {
            let me = top[k];
            let children = n.children.map(map);
            let parent = if n.parent == NONE {
                NONE
            } else {
                top[n.parent as usize]
            };
            let node = InnerNode {
                aabb: n.aabb,
                children,
                parent,
            };
            self.write_inner(me, AreaSum::Change, |slot| *slot = node);
            for c in children {
                self.set_parent(c, me);
            }
        }
        let root = map(built.root);
        if root != self.root {
            self.root = root;
            self.changes.root_changed = true;
        }
        cuts.len()
    }
}

#[cfg(test)]
mod tests {
    use crate::{Bvh, BvhConfig, Triangle};
    use glam::Vec3;

    fn scatter(n: usize) -> Vec<Triangle> {
        let mut rnd = crate::test_random(0x2545_f491_4f6c_dd1du64);
        (0..n)
            .map(|_| {
                let c = Vec3::new(rnd(), rnd(), rnd()) * 20.0;
                Triangle::new(
                    c,
                    c + Vec3::new(rnd(), 0.3, 0.0),
                    c + Vec3::new(0.0, rnd(), 0.5),
                )
            })
            .collect()
    }

    #[test]
    fn a_restored_snapshot_is_the_tree_it_was_taken_of() {
        let mut bvh = Bvh::new(BvhConfig::incr_u());
        bvh.insert_triangles(&scatter(2000)).unwrap();
        bvh.take_changes();
        let cost = bvh.sah_cost();
        let nodes: Vec<_> = (0..bvh.inner_capacity()).map(|i| bvh.gpu_node(i)).collect();
        let root = bvh.root();
        let snapshot = bvh.topology_snapshot();
        let subtrees = bvh.recluster_top(16);
        assert!(subtrees > 100, "{subtrees} subtrees re-clustered");
        bvh.validate().unwrap();
        assert_ne!(bvh.sah_cost(), cost, "re-clustering changed nothing");
        bvh.restore_topology(snapshot);
        bvh.validate().unwrap();
        assert_eq!(bvh.root(), root);
        assert_eq!(bvh.sah_cost(), cost);
        for (i, n) in nodes.iter().enumerate() {
            assert_eq!(*n, bvh.gpu_node(i as u32), "node {i}");
        }
        // What the restore rewrote is in the change log, so an uploaded copy follows it.
        assert!(bvh.take_changes().inner_count() > 0);
    }
}
