//! The tree's quality: the SAH cost of Eq. 1 and shape statistics.

use crate::Bvh;
use crate::tree::node::{FREE, NodeKind, NodeRef};

/// Shape of the tree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TreeStats {
    /// Live triangles.
    pub triangles: u32,
    /// Live inner nodes (global and instanced subtrees).
    pub inner_nodes: u32,
    /// Live instance nodes.
    pub instances: u32,
    /// Longest root-to-leaf path in the global tree, instance subtrees included.
    pub max_depth: u32,
    /// SAH cost (Eq. 1) with the configured constants.
    pub sah_cost: f32,
}

impl Bvh {
    /// SAH cost by Eq. 1 with the configured c_T and c_I: [c_T Σ_inner S(N) + c_I Σ_leaves S(N) t_N] / S(root).
    /// An instance counts as an inner node in world space; its object-space subtree's areas are scaled by
    /// the ratio of its world and object root areas.
    pub fn sah_cost(&self) -> f32 {
        self.sah_cost_with(self.config.c_t, self.config.c_i)
    }

    /// SAH cost with explicit constants.
    pub fn sah_cost_with(&self, c_t: f32, c_i: f32) -> f32 {
        if !self.has_live_instances() {
            // Without kept-whole groups every live node is in the tree, unscaled: a linear pass over
            // the flat arrays gives the same sum as a traversal, several times faster (no pointer
            // chasing), which matters to callers that publish the cost of a million-node tree.
            self.cost_over_root(|| {
                let inner: f64 = self
                    .inner
                    .iter()
                    .filter(|n| n.parent != FREE)
                    .map(|n| n.aabb.area() as f64)
                    .sum();
                let leaves: f64 = self
                    .tri
                    .boxes
                    .iter()
                    .zip(&self.tri.parent)
                    .filter(|(_, p)| **p != FREE)
                    .map(|(b, _)| b.area() as f64)
                    .sum();
                c_t as f64 * inner + c_i as f64 * leaves
            })
        } else {
            self.sah_cost_traversed(c_t, c_i)
        }
    }

    /// SAH cost by a traversal from the root (what [`Bvh::sah_cost_with`] computes by other means
    /// when it can; kept public so tests can compare the two).
    pub fn sah_cost_traversed(&self, c_t: f32, c_i: f32) -> f32 {
        let mut shared = std::collections::HashMap::new();
        self.cost_over_root(|| self.subtree_cost(self.root, c_t as f64, c_i as f64, &mut shared))
    }

    fn cost_over_root(&self, total: impl FnOnce() -> f64) -> f32 {
        if self.root.is_none() {
            return 0.0;
        }
        let s_root = self.aabb(self.root).area() as f64;
        if s_root <= 0.0 {
            return 0.0;
        }
        (total() / s_root) as f32
    }

    /// `shared` keeps each object-space subtree's sum once computed: instances that share triangles
    /// share a subtree, which is summed once however many place it.
    fn subtree_cost(
        &self,
        root: NodeRef,
        c_t: f64,
        c_i: f64,
        shared: &mut std::collections::HashMap<u32, f64>,
    ) -> f64 {
        let mut sum = 0.0f64;
        let mut stack = vec![root];
        while let Some(n) = stack.pop() {
            match n.kind() {
                NodeKind::Inner => {
                    let node = &self.inner[n.index() as usize];
                    sum += c_t * node.aabb.area() as f64;
                    stack.extend_from_slice(&node.children);
                }
                NodeKind::Leaf => sum += c_i * self.tri.boxes[n.index() as usize].area() as f64,
                NodeKind::Instance => {
                    let inst = &self.instances[n.index() as usize];
                    let world = inst.aabb.area() as f64;
                    let object = self.aabb(inst.root).area() as f64;
                    sum += c_t * world;
                    if object > 0.0 {
                        let below = match shared.get(&inst.root.0) {
                            Some(&v) => v,
                            None => {
                                let v = self.subtree_cost(inst.root, c_t, c_i, shared);
                                shared.insert(inst.root.0, v);
                                v
                            }
                        };
                        sum += below * world / object;
                    }
                }
                NodeKind::None => {}
            }
        }
        sum
    }

    /// Counts and depth.
    pub fn stats(&self) -> TreeStats {
        let mut max_depth = 0;
        let mut stack: Vec<(NodeRef, u32)> = Vec::new();
        if !self.root.is_none() {
            stack.push((self.root, 1));
        }
        while let Some((n, d)) = stack.pop() {
            max_depth = max_depth.max(d);
            match n.kind() {
                NodeKind::Inner => {
                    for c in self.inner[n.index() as usize].children {
                        stack.push((c, d + 1));
                    }
                }
                NodeKind::Instance => stack.push((self.instances[n.index() as usize].root, d + 1)),
                _ => {}
            }
        }
        TreeStats {
            triangles: self.tri.live,
            inner_nodes: self.inner_count(),
            instances: (self.instances.len() - self.inst_free.len()) as u32,
            max_depth,
            sah_cost: self.sah_cost(),
        }
    }
}
