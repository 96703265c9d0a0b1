//! The shape a baked group's triangles have inside the global tree, as a tree of their own: what a
//! group kept whole gets back when it leaves the baked tree, instead of a build from scratch.

use crate::top_down::BuiltTree;
use crate::tree::node::{InnerNode, NONE, NodeKind, NodeRef};
use crate::{Aabb, Bvh};

impl Bvh {
    /// The tree the global tree induces on `triangles` (live leaves of the global tree): each inner
    /// node with some of them under both children becomes a node, any other is passed through. Leaf
    /// `k` of the result is `triangles[k]`; boxes are left empty for the caller to refit. O(n + depth),
    /// no sorting, and as good as the tree it comes from, which updates kept close to the SAH.
    pub(crate) fn induced_tree(&mut self, triangles: &[u32]) -> BuiltTree {
        let mut local = std::mem::take(&mut self.scratch.induced_local);
        let mut marked = std::mem::take(&mut self.scratch.induced_marked);
        local.resize(self.tri.parent.len(), NONE);
        marked.resize(self.inner.len(), false);
        for (k, &t) in triangles.iter().enumerate() {
            local[t as usize] = k as u32;
        }
        // Every inner node above one of the triangles.
        for &t in triangles {
            let mut p = self.tri.parent[t as usize];
            while p != NONE && !marked[p as usize] {
                marked[p as usize] = true;
                p = self.inner[p as usize].parent;
            }
        }
        let tree = self.induced_from(triangles, &local, &marked);
        // Back to all NONE and false, touching only what was written.
        for &t in triangles {
            local[t as usize] = NONE;
            let mut p = self.tri.parent[t as usize];
            while p != NONE && marked[p as usize] {
                marked[p as usize] = false;
                p = self.inner[p as usize].parent;
            }
        }
        self.scratch.induced_local = local;
        self.scratch.induced_marked = marked;
        tree
    }

    /// The induced tree, given each triangle's place in `triangles` (`local`) and the inner nodes
    /// above them (`marked`).
    fn induced_from(&self, triangles: &[u32], local: &[u32], marked: &[bool]) -> BuiltTree {
        let mut nodes: Vec<InnerNode> = Vec::with_capacity(triangles.len().saturating_sub(1));
        // Post-order over the marked nodes: (node, children done); results on their own stack.
        let mut stack: Vec<(NodeRef, bool)> = vec![(self.root, false)];
        let mut results: Vec<NodeRef> = Vec::new();
        while let Some((n, done)) = stack.pop() {
            match n.kind() {
                NodeKind::Inner if !marked[n.index() as usize] => results.push(NodeRef::NONE),
                NodeKind::Inner if !done => {
                    stack.push((n, true));
                    let [a, b] = self.inner[n.index() as usize].children;
                    stack.push((b, false));
                    stack.push((a, false));
                }
                NodeKind::Inner => {
                    let b = results.pop().unwrap_or(NodeRef::NONE);
                    let a = results.pop().unwrap_or(NodeRef::NONE);
                    results.push(match (a.is_none(), b.is_none()) {
                        (false, false) => {
                            let i = nodes.len() as u32;
                            for c in [a, b] {
                                if c.kind() == NodeKind::Inner {
                                    nodes[c.index() as usize].parent = i;
                                }
                            }
                            nodes.push(InnerNode {
                                aabb: Aabb::EMPTY,
                                children: [a, b],
                                parent: NONE,
                            });
                            NodeRef::inner(i)
                        }
                        (false, true) => a,
                        (true, false) => b,
                        (true, true) => NodeRef::NONE,
                    });
                }
                NodeKind::Leaf => {
                    let k = local[n.index() as usize];
                    results.push(if k == NONE {
                        NodeRef::NONE
                    } else {
                        NodeRef::leaf(k)
                    });
                }
                // Instances hold no baked triangle.
                _ => results.push(NodeRef::NONE),
            }
        }
        BuiltTree {
            nodes,
            root: results.pop().unwrap_or(NodeRef::NONE),
        }
    }
}
