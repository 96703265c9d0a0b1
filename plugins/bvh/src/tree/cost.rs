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
        self.sah_cost_unless(c_t, c_i, || false).unwrap_or(0.0)
    }

    /// [`Bvh::sah_cost_with`], given up (`None`) as soon as `stop` says so: it is asked every
    /// 65,536 nodes, so a caller with something more pressing to do (an edit waiting for the
    /// tree) never waits for a pass over millions of nodes.
    pub fn sah_cost_unless(&self, c_t: f32, c_i: f32, stop: impl Fn() -> bool) -> Option<f32> {
        const SLICE: usize = 1 << 16;
        // Every live node is in the tree, or in one object-space subtree that instances place: a
        // linear pass over the flat arrays sums them all, several times faster than a traversal
        // (no pointer chasing), which matters to callers that publish the cost of a tree of
        // millions. Each placed subtree's own sum (a traversal of it alone: the groups kept whole,
        // usually few) then comes out of that and back in once per instance, scaled by its area
        // in the world.
        let (c_t, c_i) = (c_t as f64, c_i as f64);
        let mut inner = 0.0f64;
        for slice in self.inner.chunks(SLICE) {
            if stop() {
                return None;
            }
            inner += slice
                .iter()
                .filter(|n| n.parent != FREE)
                .map(|n| n.aabb.area() as f64)
                .sum::<f64>();
        }
        let mut leaves = 0.0f64;
        for (k, parents) in self.tri.parent.chunks(SLICE).enumerate() {
            if stop() {
                return None;
            }
            let first = (k * SLICE) as u32;
            leaves += (first..)
                .zip(parents)
                .filter(|(_, p)| **p != FREE)
                .map(|(t, _)| self.tri(t).aabb().area() as f64)
                .sum::<f64>();
        }
        Some(self.cost_over_root(|| {
            let mut total = c_t * inner + c_i * leaves;
            let mut placed: std::collections::HashMap<u32, f64> = std::collections::HashMap::new();
            for inst in self.instances.iter().filter(|i| i.group != FREE) {
                let below = *placed.entry(inst.root.0).or_insert_with(|| {
                    let v = self.subtree_cost(inst.root, c_t, c_i, &mut Default::default());
                    total -= v;
                    v
                });
                let world = inst.aabb.area() as f64;
                let object = self.aabb(inst.root).area() as f64;
                total += c_t * world;
                if object > 0.0 {
                    total += below * world / object;
                }
            }
            total
        }))
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
                NodeKind::Leaf => sum += c_i * self.tri(n.index()).aabb().area() as f64,
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
