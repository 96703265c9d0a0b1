//! Tree quality (the SAH cost of Eq. 1), structural validation and statistics.

use crate::node::{FREE, NONE, NodeKind, NodeRef};
use crate::{Aabb, Bvh};

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
                    .tri_box
                    .iter()
                    .zip(&self.tri_parent)
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
        self.cost_over_root(|| self.subtree_cost(self.root, c_t as f64, c_i as f64))
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

    fn subtree_cost(&self, root: NodeRef, c_t: f64, c_i: f64) -> f64 {
        let mut sum = 0.0f64;
        let mut stack = vec![root];
        while let Some(n) = stack.pop() {
            match n.kind() {
                NodeKind::Inner => {
                    let node = &self.inner[n.index() as usize];
                    sum += c_t * node.aabb.area() as f64;
                    stack.extend_from_slice(&node.children);
                }
                NodeKind::Leaf => sum += c_i * self.tri_box[n.index() as usize].area() as f64,
                NodeKind::Instance => {
                    let inst = &self.instances[n.index() as usize];
                    let world = inst.aabb.area() as f64;
                    let object = self.aabb(inst.root).area() as f64;
                    sum += c_t * world;
                    if object > 0.0 {
                        sum += self.subtree_cost(inst.root, c_t, c_i) * world / object;
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
            triangles: self.live_tris,
            inner_nodes: self.inner_count(),
            instances: (self.instances.len() - self.inst_free.len()) as u32,
            max_depth,
            sah_cost: self.sah_cost(),
        }
    }

    /// Checks every invariant: each live triangle in exactly one leaf and no dead one in any; parent and
    /// child links agree; every box contains its children (and a leaf's box is its triangle's); no
    /// NaN; no live node unreachable; groups and instances consistent. Returns the first violation.
    pub fn validate(&self) -> Result<(), String> {
        let mut seen_tri = vec![0u8; self.tris.len()];
        let mut seen_inner = vec![false; self.inner.len()];
        let mut seen_inst = vec![false; self.instances.len()];
        if !self.root.is_none() {
            if self.parent(self.root) != NONE {
                return Err(format!("root {:?} has a parent", self.root));
            }
            self.validate_subtree(
                self.root,
                &mut seen_tri,
                &mut seen_inner,
                &mut seen_inst,
                false,
            )?;
        }
        for (t, &count) in seen_tri.iter().enumerate() {
            let live = self.tri_parent[t] != FREE;
            match (live, count) {
                (true, 1) | (false, 0) => {}
                (true, c) => return Err(format!("live triangle {t} is in {c} leaves")),
                (false, c) => return Err(format!("freed triangle {t} is in {c} leaves")),
            }
        }
        for (i, n) in self.inner.iter().enumerate() {
            if (n.parent != FREE) != seen_inner[i] {
                return Err(format!(
                    "inner node {i} is live={} but reachable={}",
                    n.parent != FREE,
                    seen_inner[i]
                ));
            }
        }
        for (i, inst) in self.instances.iter().enumerate() {
            if (inst.group != FREE) != seen_inst[i] {
                return Err(format!(
                    "instance {i} is live={} but reachable={}",
                    inst.group != FREE,
                    seen_inst[i]
                ));
            }
        }
        if self.live_tris as usize != seen_tri.iter().filter(|&&c| c == 1).count() {
            return Err("live triangle count is off".into());
        }
        for (gi, g) in self.groups.iter().enumerate().filter(|(_, g)| g.is_alive()) {
            for &t in g.triangle_ids() {
                if self.tri_group[t as usize] != gi as u32 {
                    return Err(format!("triangle {t} of group {gi} names another group"));
                }
            }
        }
        Ok(())
    }

    fn validate_subtree(
        &self,
        root: NodeRef,
        seen_tri: &mut [u8],
        seen_inner: &mut [bool],
        seen_inst: &mut [bool],
        in_instance: bool,
    ) -> Result<(), String> {
        let mut stack = vec![root];
        while let Some(n) = stack.pop() {
            let i = n.index() as usize;
            match n.kind() {
                NodeKind::Inner => {
                    let node = self
                        .inner
                        .get(i)
                        .ok_or(format!("inner node {i} out of range"))?;
                    if node.parent == FREE {
                        return Err(format!("freed inner node {i} is in the tree"));
                    }
                    if std::mem::replace(&mut seen_inner[i], true) {
                        return Err(format!("inner node {i} is reached twice"));
                    }
                    check_box(&node.aabb, &format!("inner node {i}"))?;
                    for c in node.children {
                        if c.is_none() {
                            return Err(format!("inner node {i} lacks a child"));
                        }
                        if self.parent(c) != i as u32 {
                            return Err(format!(
                                "child {c:?} of {i} names parent {}",
                                self.parent(c)
                            ));
                        }
                        if !node.aabb.contains_box(&self.aabb(c), 1e-6) {
                            return Err(format!("inner node {i} does not contain child {c:?}"));
                        }
                        stack.push(c);
                    }
                }
                NodeKind::Leaf => {
                    if i >= self.tris.len() || self.tri_parent[i] == FREE {
                        return Err(format!("leaf of dead triangle {i}"));
                    }
                    seen_tri[i] = seen_tri[i].saturating_add(1);
                    check_box(&self.tri_box[i], &format!("triangle {i}"))?;
                    if self.tri_box[i] != self.tris[i].aabb() {
                        return Err(format!("leaf box of triangle {i} is stale"));
                    }
                }
                NodeKind::Instance => {
                    if in_instance {
                        return Err("instance inside an instance".into());
                    }
                    let inst = self
                        .instances
                        .get(i)
                        .ok_or(format!("instance {i} out of range"))?;
                    if inst.group == FREE {
                        return Err(format!("freed instance {i} is in the tree"));
                    }
                    if std::mem::replace(&mut seen_inst[i], true) {
                        return Err(format!("instance {i} is reached twice"));
                    }
                    check_box(&inst.aabb, &format!("instance {i}"))?;
                    if self.parent(inst.root) != NONE {
                        return Err(format!("object root of instance {i} has a parent"));
                    }
                    let world = self.aabb(inst.root).transformed(&inst.transform);
                    if !inst.aabb.contains_box(&world, 1e-5) {
                        return Err(format!("instance {i} box does not contain its subtree"));
                    }
                    self.validate_subtree(inst.root, seen_tri, seen_inner, seen_inst, true)?;
                }
                NodeKind::None => return Err("null reference in the tree".into()),
            }
        }
        Ok(())
    }
}

fn check_box(b: &Aabb, what: &str) -> Result<(), String> {
    if !b.is_finite() || b.is_empty() {
        return Err(format!("{what} has a bad box {b:?}"));
    }
    Ok(())
}
