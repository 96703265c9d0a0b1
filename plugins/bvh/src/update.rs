//! Global updates: remove an inefficient node and re-insert its two children at better places,
//! driven by the node update cache (paper section 4.3), plus the optional post-pass.

use crate::node::{NONE, NodeKind, NodeRef};
use crate::{Bvh, Inefficiency};

impl Bvh {
    /// Inefficiency of inner node `i` by the configured measure.
    pub fn inefficiency(&self, i: u32) -> f32 {
        let n = &self.inner[i as usize];
        let a = n.aabb.area();
        let l = self.aabb(n.children[0]).area();
        let r = self.aabb(n.children[1]).area();
        let m_sum = || a / (0.5 * (l + r)).max(f32::MIN_POSITIVE);
        let m_min = || a / l.min(r).max(f32::MIN_POSITIVE);
        match self.config.inefficiency {
            Inefficiency::Area => a,
            Inefficiency::Sum => m_sum(),
            Inefficiency::Min => m_min(),
            Inefficiency::Comb => m_sum() * m_min() * a,
        }
    }

    /// Runs a batch of updates if the node update cache holds N_u nodes.
    pub(crate) fn maybe_update(&mut self) {
        if self.config.global_updates && self.cache.len() >= self.config.update_cache_size as usize {
            self.run_update_batch();
        }
    }

    /// Updates the k_u fraction of the cached nodes with the highest inefficiency, then empties the cache.
    pub fn run_update_batch(&mut self) {
        let mut candidates: Vec<(f32, u32)> = std::mem::take(&mut self.cache)
            .into_iter()
            .filter_map(|i| {
                self.in_cache[i as usize] = false;
                self.updatable(i).then(|| (self.inefficiency(i), i))
            })
            .collect();
        let k = ((self.config.update_fraction * candidates.len() as f32).ceil() as usize).min(candidates.len());
        self.update_top(&mut candidates, k);
    }

    /// Re-inserts the children of the `k` most inefficient of `candidates`.
    fn update_top(&mut self, candidates: &mut [(f32, u32)], k: usize) {
        if k == 0 {
            return;
        }
        if k < candidates.len() {
            candidates.select_nth_unstable_by(k - 1, |a, b| b.0.total_cmp(&a.0));
        }
        let recording = std::mem::replace(&mut self.recording, false);
        for &(_, i) in &candidates[..k] {
            // An earlier update in this batch may have moved this node to the root.
            if self.updatable(i) {
                self.reinsert_children(i);
            }
        }
        self.recording = recording;
    }

    /// Whether inner node `i` may be updated: live, in the global tree, not the root.
    fn updatable(&self, i: u32) -> bool {
        let n = &self.inner[i as usize];
        n.parent != NONE && n.parent != crate::node::FREE && self.in_global_tree(i)
    }

    /// Removes inner node `n` and its parent, then inserts `n`'s two children separately with the
    /// search, reusing the two freed inner nodes for them.
    pub(crate) fn reinsert_children(&mut self, n: u32) {
        let [a, b] = self.inner[n as usize].children;
        let p = self.unlink(NodeRef::inner(n));
        debug_assert_ne!(p, NONE);
        self.set_parent(a, NONE);
        self.set_parent(b, NONE);
        // The larger child first: it constrains the best position of the smaller one.
        let (first, second) = if self.aabb(a).area() >= self.aabb(b).area() { (a, b) } else { (b, a) };
        self.insert_node_with(first, n);
        self.insert_node_with(second, p);
        self.update_ops += 1;
    }

    /// The post-pass ("BVH postprocessing", [9]): `rounds` rounds, each re-inserting the children of
    /// the `fraction` of all inner nodes with the highest inefficiency. Returns the updates done.
    pub fn optimize(&mut self, rounds: u32, fraction: f32) -> u64 {
        let before = self.update_ops;
        let mut nodes = Vec::new();
        for _ in 0..rounds {
            nodes.clear();
            if self.root.kind() == NodeKind::Inner {
                self.collect_inner(self.root, &mut nodes);
            }
            let mut candidates: Vec<(f32, u32)> = nodes
                .iter()
                .filter(|&&i| self.inner[i as usize].parent != NONE)
                .map(|&i| (self.inefficiency(i), i))
                .collect();
            let k = ((fraction * candidates.len() as f32).ceil() as usize).min(candidates.len());
            self.update_top(&mut candidates, k);
        }
        self.update_ops - before
    }
}
