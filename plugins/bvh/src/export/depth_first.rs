//! The binary GPU records renumbered depth first, with each node's two children in adjacent records:
//! a ray descending the tree reads records that lie together, which caches reward. The tree's own
//! arrays keep their allocation order; this is the order a relayout would give them.

use crate::tree::node::{NONE, NodeRef};
use crate::{Bvh, GpuLayout, GpuNode};

/// The binary records in depth-first order.
pub type DepthFirstLayout = GpuLayout<GpuNode>;

impl Bvh {
    /// Renumbers the live node records depth first from the root, then from each instance's root;
    /// both children of a node get adjacent records.
    pub fn gpu_depth_first_layout(&self) -> DepthFirstLayout {
        let mut slot_of = vec![NONE; self.inner.len()];
        let mut order: Vec<u32> = Vec::new();
        let mut stack: Vec<u32> = Vec::new();
        let place = |r: NodeRef, slot_of: &mut Vec<u32>, order: &mut Vec<u32>| -> bool {
            if !r.is_inner() || slot_of[r.index() as usize] != NONE {
                return false;
            }
            slot_of[r.index() as usize] = order.len() as u32;
            order.push(r.index());
            true
        };
        let roots: Vec<NodeRef> = std::iter::once(self.root)
            .chain(
                (0..self.instances.len() as u32).filter_map(|i| self.instance(i).map(|x| x.root)),
            )
            .collect();
        for root in roots {
            if place(root, &mut slot_of, &mut order) {
                stack.push(root.index());
            }
            while let Some(n) = stack.pop() {
                let [a, b] = self.inner[n as usize].children;
                // Both children placed together, then the left one's subtree first.
                let (pa, pb) = (
                    place(a, &mut slot_of, &mut order),
                    place(b, &mut slot_of, &mut order),
                );
                if pb {
                    stack.push(b.index());
                }
                if pa {
                    stack.push(a.index());
                }
            }
        }
        let rename = |r: u32| {
            let r = NodeRef(r);
            if r.is_inner() {
                NodeRef::inner(slot_of[r.index() as usize]).0
            } else {
                r.0
            }
        };
        let nodes = order
            .iter()
            .map(|&old| {
                let mut rec = self.gpu_node(old);
                rec.a_ref = rename(rec.a_ref);
                rec.b_ref = rename(rec.b_ref);
                rec
            })
            .collect();
        let instances = self.gpu_instances_renamed(|r| rename(r.0));
        GpuLayout {
            nodes,
            root: rename(self.root.0),
            instances,
        }
    }
}
